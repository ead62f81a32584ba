//! `[[boundary]]` meshes through the `clatter` binary: the VTK series gets
//! `boundaries_NNNNNN.vtu` frames (read back with meshio: the triangles where the motion put
//! them at each frame's time), `--backend gpu` runs the scene and writes the CPU's frames
//! (`auto` runs it on the CPU when the only adapter is a software one), and a bad mesh file
//! stops the run with the field and file named.

mod common;

use std::process::{Command, Stdio};

use common::{assert_ok, clatter, names, test_dir, text};

/// A 0.2 m square plate in the plane z = 0 (two triangles), translated at 0.5 m/s along x
/// from t = 0 to t = 0.01 s; a ball resting on it.
const SCENE: &str = r#"[simulation]
steps = 1000
dt = 2.0e-5
[[material]]
name = "steel"
density = 7800.0
stiffness = 1.0e4
friction = 0.3
[[shape]]
name = "ball"
sphere = { radius = 0.01 }
[[body]]
shape = "ball"
material = "steel"
position = [0.0, 0.0, 0.00999]
[[boundary]]
mesh = { file = "plate.obj", scale = 1.0 }
material = "steel"
motion = { velocity = [0.5, 0.0, 0.0] }
end = 0.01
"#;

const PLATE: &str = "v -0.1 -0.1 0\nv 0.1 -0.1 0\nv 0.1 0.1 0\nv -0.1 0.1 0\nf 1 2 3\nf 1 3 4\n";

const READ: &str = r#"
import sys, json, meshio
m = meshio.read(sys.argv[1])
print(json.dumps({"x": [float(p[0]) for p in m.points],
                  "cells": sum(len(c.data) for c in m.cells),
                  "vx": [float(v[0]) for v in m.cell_data["velocity"][0]]}))
"#;

fn meshio_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import meshio, numpy"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        if std::env::var_os("CI").is_some() {
            panic!("python3 with meshio is required in CI (python3 -m pip install meshio)");
        }
        eprintln!("\n*** SKIPPED: python3 with meshio is not available ***\n");
    }
    ok
}

#[test]
fn boundary_frames_follow_the_motion() {
    let dir = test_dir("boundary", "frames");
    std::fs::write(dir.join("plate.obj"), PLATE).unwrap();
    std::fs::write(dir.join("plate.toml"), SCENE).unwrap();
    let out = dir.join("out");
    let o = clatter(&[
        &"run",
        &dir.join("plate.toml"),
        &"--backend",
        &"auto",
        &"--out",
        &out,
        &"--format",
        &"vtk",
        &"--output-every",
        &"250",
    ]);
    assert_ok(&o, "run");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("backend: cpu"),
        "{}",
        text(&o)
    );
    let files = names(&out);
    for f in [
        "boundaries.pvd",
        "boundaries_000000.vtu",
        "boundaries_000250.vtu",
        "boundaries_001000.vtu",
    ] {
        assert!(files.contains(&f.to_string()), "{f} missing: {files:?}");
    }
    let pvd = std::fs::read_to_string(out.join("boundaries.pvd")).unwrap();
    assert!(pvd.contains("boundaries_000500.vtu"), "{pvd}");
    if !meshio_available() {
        return;
    }
    // Frames at t = 0, 0.005 s (moving at 0.5 m/s: shifted 2.5 mm) and 0.02 s (stopped at
    // t = 0.01 s: shifted 5 mm, no velocity).
    for (step, shift, speed) in [(0, 0.0, 0.5), (250, 0.0025, 0.5), (1000, 0.005, 0.0)] {
        let file = out.join(format!("boundaries_{step:06}.vtu"));
        let r = Command::new("python3")
            .args(["-c", READ])
            .arg(&file)
            .output()
            .unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let v: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
        assert_eq!(v["cells"], 2);
        let mut xs: Vec<f64> = v["x"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        xs.sort_by(f64::total_cmp);
        assert!((xs[0] - (-0.1 + shift)).abs() < 1e-6, "step {step}: {xs:?}");
        assert!((xs[3] - (0.1 + shift)).abs() < 1e-6, "step {step}: {xs:?}");
        for vx in v["vx"].as_array().unwrap() {
            assert!(
                (vx.as_f64().unwrap() - speed).abs() < 1e-6,
                "step {step}: {v}"
            );
        }
    }
}

#[test]
fn gpu_backend_runs_boundaries_and_a_bad_mesh_stops_the_run() {
    let dir = test_dir("boundary", "refuse");
    std::fs::write(dir.join("plate.obj"), PLATE).unwrap();
    std::fs::write(dir.join("plate.toml"), SCENE).unwrap();
    if clatter_gpu::test_context().is_some() {
        // The ball on the moving plate: the same final state on both backends (this scene
        // agrees bitwise, see crates/clatter-gpu/tests/boundaries.rs).
        let mut frames = Vec::new();
        for backend in ["gpu", "cpu"] {
            let out = dir.join(format!("out_{backend}"));
            let o = clatter(&[
                &"run",
                &dir.join("plate.toml"),
                &"--backend",
                &backend,
                &"--out",
                &out,
                &"--format",
                &"vtk",
                &"--output-every",
                &"1000",
            ]);
            assert_ok(&o, "run");
            assert!(
                text(&o).contains(&format!("backend          {backend}")),
                "{}",
                text(&o)
            );
            frames.push(std::fs::read(out.join("final.csv")).unwrap());
        }
        assert!(
            frames[0] == frames[1],
            "the GPU's final.csv differs from the CPU's:\n{}\n{}",
            String::from_utf8_lossy(&frames[0]),
            String::from_utf8_lossy(&frames[1])
        );
    }
    std::fs::write(
        dir.join("bad.toml"),
        SCENE.replace("plate.obj", "missing.stl"),
    )
    .unwrap();
    let o = clatter(&[&"run", &dir.join("bad.toml")]);
    assert!(!o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("bad.toml:") && t.contains("boundary[0].mesh.file") && t.contains("missing.stl"),
        "{t}"
    );
    assert!(!t.contains("panicked"), "{t}");
}

/// `--contacts` lists the ball's contact with the mesh like a wall contact: `body_a` is
/// `-1 - (walls + boundary)` (here -1: no walls, boundary 0), `body_b` the ball, the normal
/// up, the normal force the ball's weight.
#[test]
fn mesh_contacts_are_in_the_contact_series() {
    let dir = test_dir("boundary", "contacts");
    std::fs::write(dir.join("plate.obj"), PLATE).unwrap();
    std::fs::write(dir.join("plate.toml"), SCENE).unwrap();
    let out = dir.join("out");
    let o = clatter(&[
        &"run",
        &dir.join("plate.toml"),
        &"--out",
        &out,
        &"--format",
        &"vtk",
        &"--contacts",
        &"--output-every",
        &"1000",
    ]);
    assert_ok(&o, "run");
    if !meshio_available() {
        return;
    }
    let read = r#"
import sys, json, meshio
m = meshio.read(sys.argv[1])
d = m.point_data
print(json.dumps({"a": [int(x) for x in d["body_a"]], "b": [int(x) for x in d["body_b"]],
                  "nz": [float(n[2]) for n in d["normal"]],
                  "f": [float(x) for x in d["normal_force"]]}))
"#;
    let r = Command::new("python3")
        .args(["-c", read])
        .arg(out.join("contacts_001000.vtu"))
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(v["a"], serde_json::json!([-1]), "{v}");
    assert_eq!(v["b"], serde_json::json!([0]), "{v}");
    assert!(v["nz"][0].as_f64().unwrap() > 0.999, "{v}");
    let weight = 7800.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.01f64.powi(3) * 9.81;
    let f = v["f"][0].as_f64().unwrap();
    assert!(
        (f / weight - 1.0).abs() < 0.5,
        "normal force {f} N, weight {weight} N"
    );
}

#[path = "../../clatter/tests/common/awkward.rs"]
mod awkward;
#[path = "../../clatter/tests/common/meshes.rs"]
mod meshes;

/// A closed drum STL as LIGGGHTS users have it (576 triangles, normals towards the grains)
/// runs unchanged: one `note:` line says so, no warning, and the results are the outward
/// twin's byte for byte.
#[test]
fn an_inward_wound_drum_stl_runs_as_it_is() {
    let dir = test_dir("boundary", "inward-drum");
    let (v, t) = awkward::closed_drum(0.05, 0.04, 144);
    let inward: Vec<[u32; 3]> = t.iter().map(|f| [f[0], f[2], f[1]]).collect();
    let mut finals = Vec::new();
    for (name, tris) in [("in", &inward), ("out", &t)] {
        let stl = format!("drum-{name}.stl");
        std::fs::write(
            dir.join(&stl),
            awkward::binary_stl(&v, tris, "solid drum", 576),
        )
        .unwrap();
        let scene = dir.join(format!("drum-{name}.toml"));
        std::fs::write(&scene, awkward::drum_scene(&stl)).unwrap();
        let out = dir.join(format!("out-{name}"));
        let o = clatter(&[
            &"run",
            &scene,
            &"--backend",
            &"cpu",
            &"--out",
            &out,
            &"--steps",
            &"1500",
        ]);
        assert_ok(&o, "run");
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        let notes: Vec<&str> = err.lines().filter(|l| l.starts_with("note:")).collect();
        if name == "in" {
            assert_eq!(notes.len(), 1, "{err}");
            assert!(
                notes[0].contains("wound inwards") && notes[0].contains(&stl),
                "{err}"
            );
        } else {
            assert!(notes.is_empty(), "{err}");
        }
        assert!(!err.contains("warning:"), "{err}");
        finals.push(std::fs::read(out.join("final.csv")).unwrap());
    }
    assert!(
        finals[0] == finals[1],
        "the inward drum's final.csv differs from the outward one's"
    );
}
