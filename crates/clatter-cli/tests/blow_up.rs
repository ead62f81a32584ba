//! Blow-ups stop cleanly, end to end through the `clatter` binary: each cause (non-finite
//! state, energy growth, escape, initial and deep overlap, soft contacts sinking) stops the run
//! with a message naming body, step and cause, exit status 3, a loadable `last_good.ckpt`, and
//! no partial, temporary or final files; on the GPU too, where `last_good.ckpt` comes from the
//! device's snapshot and keeps the mesh contact slots.

use std::path::PathBuf;

use clatter::Checkpoint;

mod common;
use common::{check_vtu, clatter, csv_rows, names, read, text};

fn test_dir(name: &str) -> PathBuf {
    common::test_dir("blow-up", name)
}

const BOX: &str = r#"
[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
restitution = 0.5

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[[shape]]
name = "cube"
box = { half_extents = [0.01, 0.01, 0.01] }

[container]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.2]
material = "m"
"#;

/// Runs a scene that must blow up; checks exit status, message, files. Returns stderr.
fn blow_up(
    name: &str,
    simulation: &str,
    bodies: &str,
    needles: &[&str],
    last_good_step: Option<u64>,
) -> String {
    blow_up_on("auto", name, simulation, bodies, needles, last_good_step)
}

/// [`blow_up`] with `--backend backend`.
fn blow_up_on(
    backend: &str,
    name: &str,
    simulation: &str,
    bodies: &str,
    needles: &[&str],
    last_good_step: Option<u64>,
) -> String {
    blow_up_world(backend, name, simulation, bodies, needles, last_good_step).0
}

/// [`blow_up_on`], also returning the world of `last_good.ckpt`.
fn blow_up_world(
    backend: &str,
    name: &str,
    simulation: &str,
    bodies: &str,
    needles: &[&str],
    last_good_step: Option<u64>,
) -> (String, clatter::World) {
    let dir = test_dir(&format!("blowup-{name}"));
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(
        &scene,
        format!("[simulation]\n{simulation}\n{BOX}\n{bodies}"),
    )
    .unwrap();
    let out = dir.join("out");
    let o = clatter(&[
        &"run",
        &scene,
        &"--out",
        &out,
        &"--quiet",
        &"--format",
        &"csv,vtk",
        &"--output-every",
        &"1000",
        &"--backend",
        &backend,
    ]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(
        o.status.code(),
        Some(3),
        "{name}: exit status 3 for a blow-up\n{}",
        text(&o)
    );
    assert!(!err.contains("panicked"), "{name}: {err}");
    for n in needles {
        assert!(err.contains(n), "{name}: expected `{n}` in:\n{err}");
    }
    // No partial or temporary files; no final results; a loadable last good state.
    let files = names(&out);
    assert!(
        files.iter().all(|f| !f.ends_with(".tmp")),
        "{name}: temporary files left: {files:?}"
    );
    for f in ["final.csv", "summary.json", "trace.csv"] {
        assert!(
            !files.contains(&f.to_string()),
            "{name}: {f} written by a blown-up run"
        );
    }
    let ckpt = Checkpoint::load(&out.join("last_good.ckpt"))
        .unwrap_or_else(|e| panic!("{name}: last_good.ckpt: {e}"));
    let (_, world) = ckpt.world().expect("the last good state restores");
    assert!(
        world.state.position.iter().all(|x| x.is_finite())
            && world.state.velocity.iter().all(|v| v.is_finite())
    );
    if let Some(s) = last_good_step {
        assert_eq!(world.step_count, s, "{name}: step of the last good state");
    }
    assert!(
        err.contains(&format!("last good state (step {}", world.step_count)),
        "{name}: {err}"
    );
    assert!(err.contains("last_good.ckpt"), "{name}: {err}");
    for f in &files {
        let path = out.join(f);
        match f.as_str() {
            "energy.csv" => {
                let rows = csv_rows(&path);
                assert!(
                    !rows.is_empty() && rows.iter().all(|r| r.len() == 8),
                    "{name}: energy.csv"
                );
            }
            "energy.svg" => assert!(
                String::from_utf8(read(&path))
                    .unwrap()
                    .trim_end()
                    .ends_with("</svg>")
            ),
            "bodies.pvd" | "shapes.pvd" | "boundaries.pvd" | "last_good.ckpt" => {}
            f if f.starts_with("bodies_")
                || f.starts_with("shapes_")
                || f.starts_with("boundaries_") =>
            {
                check_vtu(&path)
            }
            other => panic!("{name}: unexpected file {other}"),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    (err, world)
}

#[test]
fn blow_up_non_finite() {
    // A time step so large that the first step overflows.
    let err = blow_up(
        "nan",
        "steps = 50\ndt = 1.0e30",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.1]\n",
        &[
            "step 1 ",
            "body 0 has a non-finite position or velocity",
            "above the stability bound",
            "dt = 1.000e30",
        ],
        Some(0),
    );
    // The warning before the start (lines from the system's graphics stack, e.g. Mesa's
    // "XDG_RUNTIME_DIR is invalid" when `auto` probes for a GPU on a headless machine, aside).
    let ours: Vec<&str> = err
        .lines()
        .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
        .collect();
    assert!(
        ours.first()
            .is_some_and(|l| l.starts_with("warning: dt = 1.000e30 s is above the stability bound")),
        "{err}"
    );
}

/// The GPU pipeline stops at the step a body goes non-finite and reports it like the CPU:
/// exit 3, the body and the step, the last good state.
#[test]
fn blow_up_non_finite_on_the_gpu() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    blow_up_on(
        "gpu",
        "nan-gpu",
        "steps = 50\ndt = 1.0e30",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.1]\n",
        &["step 1 ", "body 0 has a non-finite position or velocity"],
        Some(0),
    );
    // Past the first step of a batch (lean steps, see clatter-gpu's world/advance.rs): a ball
    // resting on the floor with a time step ten times the stability bound. The GPU's state
    // comes back for the checks every 10 steps, and at step 10 the energy has grown without
    // bound, as the CPU pipeline reports it (`blow_up_energy_growth`).
    blow_up_on(
        "gpu",
        "energy-gpu",
        "steps = 2000\ndt = 1.0e-2",
        "[[body]]\nshape = \"cube\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.1]\n\n[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.05, 0.05, 0.0099]\n",
        &["step 10 ", "the kinetic energy grows without bound"],
        Some(0),
    );
}

/// The GPU's own checks (health.wgsl) stop the pipeline at the check step where the host's
/// would fire; the report is then the host's, word for word as on the CPU.
#[test]
fn blow_up_escape_and_overlap_on_the_gpu() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    blow_up_on(
        "gpu",
        "escape-gpu",
        "steps = 100\ndt = 1.0e-4",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.1]\nvelocity = [500.0, 0.0, 0.0]\n",
        &[
            "step 10 ",
            "body 0 escaped through wall 1",
            "body 0 moves 5.00 of its size per step",
            "too fast for dt",
        ],
        Some(0),
    );
    blow_up_on(
        "gpu",
        "overlap-gpu",
        "steps = 2000\ndt = 1.0e-4",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.0102]\n[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.035]\nvelocity = [0.0, 0.0, -60.0]\n",
        &[
            "step 10 ",
            "body 1 and wall 4 overlap by",
            "body 1 moves 0.60 of its size per step",
        ],
        Some(0),
    );
}

#[test]
fn blow_up_energy_growth() {
    // A lattice of touching balls on the floor with dt twice the stability bound.
    let err = blow_up(
        "energy",
        "steps = 3000\ndt = 2.0e-3",
        "[[group]]\nshape = \"ball\"\nmaterial = \"m\"\nlattice = { min = [0.05, 0.05, 0.01], max = [0.09, 0.09, 0.05], spacing = 0.02 }\n",
        &[
            "kinetic energy grows without bound",
            "body ",
            "step ",
            "time step dt = 2.000e-3 s is above the stability bound",
        ],
        Some(0),
    );
    assert!(
        err.contains("warning: dt = 2.000e-3 s is above the stability bound"),
        "{err}"
    );
}

#[test]
fn blow_up_escape() {
    // 500 m/s with dt = 1e-4: five radii per step, through the wall at x = 0.2.
    blow_up(
        "escape",
        "steps = 100\ndt = 1.0e-4",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.1]\nvelocity = [500.0, 0.0, 0.0]\n",
        &[
            "step 10 ",
            "body 0 escaped through wall 1",
            "body 0 moves 5.00 of its size per step",
            "too fast for dt",
        ],
        Some(0),
    );
}

#[test]
fn blow_up_initial_overlap() {
    blow_up(
        "overlap0",
        "steps = 100",
        "[[body]]\nshape = \"cube\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.1]\n[[body]]\nshape = \"cube\"\nmaterial = \"m\"\nposition = [0.105, 0.1, 0.1]\n",
        &[
            "start overlapping: body 0 and body 1",
            "at step 0",
            "121%",
            "overlapping initial placement",
        ],
        Some(0),
    );
}

#[test]
fn blow_up_deep_overlap() {
    // A ball hitting one at rest at 60 m/s: 0.6 radii per step, so it sinks deep into it
    // (and through it into the floor: the spring would need 6 cm to stop it).
    blow_up(
        "overlap",
        "steps = 2000\ndt = 1.0e-4",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.0102]\n[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.035]\nvelocity = [0.0, 0.0, -60.0]\n",
        &[
            "step 10 ",
            "body 1 and wall 4 overlap by",
            "body 1 moves 0.60 of its size per step",
        ],
        Some(0),
    );
}

#[test]
fn soft_contacts_sinking_are_reported() {
    // A cube on the floor with a spring far too soft for its weight sinks by its own size.
    let simulation = "steps = 400";
    let bodies = "[[body]]\nshape = \"cube\"\nmaterial = \"soft\"\nposition = [0.1, 0.1, 0.0101]\n";
    let scene_extra =
        "[[material]]\nname = \"soft\"\ndensity = 1000.0\nstiffness = 3.0\nrestitution = 0.5\n";
    blow_up(
        "soft",
        simulation,
        &format!("{scene_extra}{bodies}"),
        &[
            "body 0 and wall 4 overlap",
            "too soft for the load",
            "`soft`",
        ],
        None,
    );
}

/// A GPU blow-up in a scene with a mesh boundary and a composite: the `last_good.ckpt`
/// (from the device's snapshot) holds the clump's mesh slots, one per piece, with their
/// springs, so that resumed on the CPU its mesh contacts go on instead of restarting.
#[test]
fn gpu_blow_up_last_good_keeps_the_mesh_slots() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let mesh_dir = test_dir("mesh-plate");
    let plate = mesh_dir.join("plate.obj");
    // A horizontal plate at z = 0.05 over most of the box.
    std::fs::write(
        &plate,
        "v 0.02 0.02 0.05\nv 0.18 0.02 0.05\nv 0.18 0.18 0.05\nv 0.02 0.18 0.05\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    // A two-ball clump sliding on the plate (sunk by its weight), and a ball thrown at the floor (60 m/s from
    // 0.15 m up, 0.6 mm a step): it reaches the floor after some 200 steps and overlaps it
    // far beyond the checks' bound, after the snapshot of step 200.
    let bodies = format!(
        r#"
[[shape]]
name = "pair"
composite = [ {{ shape = "ball", offset = [-0.008, 0.0, 0.0] }},
              {{ shape = "ball", offset = [0.008, 0.0, 0.0] }} ]

[[boundary]]
mesh = {{ file = "{}" }}
material = "m"

[[body]]
shape = "pair"
material = "m"
position = [0.1, 0.1, 0.059996]
velocity = [0.2, 0.1, 0.0]

[[body]]
shape = "ball"
material = "m"
position = [0.03, 0.03, 0.15]
velocity = [0.0, 0.0, -60.0]
"#,
        plate.display()
    );
    let (err, mut world) = blow_up_world(
        "gpu",
        "mesh-gpu",
        "steps = 2000\ndt = 1.0e-5",
        &bodies,
        &[],
        None,
    );
    assert!(world.step_count >= 100, "step {}: {err}", world.step_count);
    let touching: Vec<_> = world
        .mesh_slots()
        .iter()
        .filter(|s| s.touching)
        .copied()
        .collect();
    let pieces: std::collections::BTreeSet<u32> = touching.iter().map(|s| s.piece).collect();
    assert_eq!(
        pieces,
        [0, 1].into(),
        "{touching:?} step {} pos {:?} {err}",
        world.step_count,
        world.state.position
    );
    assert!(
        touching.iter().all(|s| s.history.length() > 0.0),
        "{touching:?}"
    );
    // Resumed on the CPU, the clump's mesh contacts carry on.
    let before = world.mesh_slots().to_vec();
    world.step().unwrap();
    let after = world.mesh_slots();
    for (a, b) in before.iter().zip(after) {
        if a.touching {
            assert!(b.touching && b.piece == a.piece);
            assert!((b.history - a.history).length() < 0.5 * a.history.length());
        }
    }
    let _ = std::fs::remove_dir_all(&mesh_dir);
}
