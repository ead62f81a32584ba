//! `clatter run` end to end: outputs and their formats, body order, a free fall against the
//! integrator's exact discrete solution, thread-count independence, argument errors, and
//! the example scenes in `scenes/`.

use std::path::{Path, PathBuf};

use clatter::scene::Scene;

const HEADER: &str = "id,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz";

mod common;
use common::{assert_ok, clatter, text};

fn test_dir(name: &str) -> PathBuf {
    common::test_dir("run-cli", name)
}

/// The run's `summary.json` in `out`, parsed.
fn read_summary(out: &Path) -> serde_json::Value {
    let path = out.join("summary.json");
    let text =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Parses a CSV file into its header and rows of numbers.
fn read_csv(path: &Path) -> (String, Vec<Vec<f64>>) {
    let text =
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines.next().expect("a header line").to_string();
    let columns = header.split(',').count();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            let row: Vec<f64> = l
                .split(',')
                .map(|c| c.parse().unwrap_or_else(|e| panic!("{c:?} in {l:?}: {e}")))
                .collect();
            assert_eq!(row.len(), columns, "row {l:?} of {}", path.display());
            row
        })
        .collect();
    (header, rows)
}

/// Two single bodies, a 3 x 2 x 2 lattice and 4 random cubes: 18 bodies.
const SMALL: &str = r#"[simulation]
steps = 23
dt = 1.0e-4

[[material]]
name = "plastic"
density = 1000.0
stiffness = 1.0e3

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.012 }

[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "plastic"

[[group]]
shape = "ball"
material = "plastic"
lattice = { min = [0.0, 0.0, 0.1], max = [0.06, 0.03, 0.13], spacing = 0.03 }

[[group]]
shape = "cube"
material = "plastic"
random = { min = [1.0, 1.0, 1.0], max = [1.2, 1.2, 1.2], count = 4 }

[[body]]
shape = "ball"
material = "plastic"
position = [0.5, 0.5, 0.3]

[[body]]
shape = "cube"
material = "plastic"
position = [0.6, 0.5, 0.3]
velocity = [1.0, 0.0, 0.0]
"#;

#[test]
fn small_scene_outputs() {
    let dir = test_dir("small");
    let scene = dir.join("small.toml");
    std::fs::write(&scene, SMALL).unwrap();
    let out = dir.join("out");
    let output = clatter(&[
        &"run",
        &scene,
        &"--out",
        &out,
        &"--trace-every",
        &"5",
        &"--quiet",
    ]);
    assert_ok(&output, "clatter run small.toml");
    assert!(!String::from_utf8_lossy(&output.stderr).contains("panicked"));

    // Only the outputs (energy.csv and its plot always come with --out), no temporary files.
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "energy.csv",
            "energy.svg",
            "final.csv",
            "summary.json",
            "trace.csv"
        ]
    );

    // Scene order: [[body]] entries first, then groups in file order, lattices x fastest.
    let mut expected: Vec<[f32; 3]> = vec![[0.5, 0.5, 0.3], [0.6, 0.5, 0.3]];
    for z in 0..2 {
        for y in 0..2 {
            for x in 0..3 {
                expected.push([0.03 * x as f32, 0.03 * y as f32, 0.1 + 0.03 * z as f32]);
            }
        }
    }
    let n = expected.len() + 4;
    assert_eq!(n, 18);

    let (header, rows) = read_csv(&out.join("final.csv"));
    assert_eq!(header, HEADER);
    assert_eq!(rows.len(), n);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[0], i as f64, "ids in order");
        let q = (row[4] * row[4] + row[5] * row[5] + row[6] * row[6] + row[7] * row[7]).sqrt();
        assert!((q - 1.0).abs() < 1e-5, "unit quaternion in row {i}");
    }

    // trace.csv: the initial state at step 0, then steps 5, 10, 15, 20 (23 is not a multiple).
    let (header, rows) = read_csv(&out.join("trace.csv"));
    assert_eq!(header, format!("step,time,{HEADER}"));
    let snapshots = [0u64, 5, 10, 15, 20];
    assert_eq!(rows.len(), snapshots.len() * n);
    for (k, &step) in snapshots.iter().enumerate() {
        for i in 0..n {
            let row = &rows[k * n + i];
            assert_eq!(row[0], step as f64);
            assert!(
                (row[1] - step as f64 * 1e-4).abs() < 1e-9,
                "time of step {step}: {}",
                row[1]
            );
            assert_eq!(row[2], i as f64);
        }
    }
    // Initial positions identify the bodies.
    for (i, p) in expected.iter().enumerate() {
        let row = &rows[i];
        for c in 0..3 {
            assert!(
                (row[3 + c] - p[c] as f64).abs() < 1e-6,
                "body {i}: {:?} vs {p:?}",
                &row[3..6]
            );
        }
    }
    for row in &rows[expected.len()..n] {
        assert!(
            row[3..6].iter().all(|&c| (1.0..=1.2).contains(&c)),
            "random cube at {:?}",
            &row[3..6]
        );
    }
    // The moving cube (body 1) starts with its velocity.
    assert_eq!(rows[1][10], 1.0);

    // summary.json
    let summary = read_summary(&out);
    assert_eq!(summary["steps"].as_u64(), Some(23));
    assert_eq!(summary["bodies"].as_u64(), Some(n as u64));
    assert_eq!(summary["walls"].as_u64(), Some(1));
    assert_eq!(
        summary["dt"].as_f64(),
        Some(1e-4),
        "dt as written in the scene"
    );
    let t = summary["simulated_time"].as_f64().expect("simulated_time");
    assert!((t - 23e-4).abs() < 1e-9, "simulated_time {t}");
    assert!(
        summary["contacts"].is_u64(),
        "contacts: {}",
        summary["contacts"]
    );
    let ke = summary["kinetic_energy"].as_f64().expect("kinetic_energy");
    assert!(ke.is_finite() && ke > 0.0);
    for key in [
        "dt",
        "max_contacts",
        "potential_energy",
        "momentum",
        "threads",
        "broad_phase_rebuilds",
    ] {
        assert!(summary.get(key).is_some(), "summary.json lacks {key}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn free_fall_matches_semi_implicit_euler() {
    let dir = test_dir("free-fall");
    let scene = dir.join("fall.toml");
    std::fs::write(
        &scene,
        r#"[simulation]
steps = 500
dt = 1.0e-3
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4

[[shape]]
name = "ball"
sphere = { radius = 0.1 }

[[body]]
shape = "ball"
material = "m"
position = [0.0, 0.0, 10.0]
velocity = [0.5, 0.0, 0.0]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let output = clatter(&[&"run", &scene, &"--out", &out, &"--quiet"]);
    assert_ok(&output, "clatter run fall.toml");
    let (_, rows) = read_csv(&out.join("final.csv"));
    assert_eq!(rows.len(), 1);
    let (x, z, vx, vz) = (rows[0][1], rows[0][3], rows[0][8], rows[0][10]);

    let n = 500.0;
    let dt = 1.0e-3f32 as f64;
    let g = 9.81f32 as f64;
    let t = n * dt;
    // Semi-implicit Euler: v_k = -k g dt, z_n = z0 + dt sum_{k=1..n} v_k = z0 - g dt^2 n (n+1) / 2.
    let z_discrete = 10.0 - g * dt * dt * n * (n + 1.0) / 2.0;
    let z_exact = 10.0 - g * t * t / 2.0;
    assert!(
        (z - z_discrete).abs() < 2e-5 * 10.0,
        "z = {z}, discrete sum {z_discrete}"
    );
    assert!(
        (z - z_exact).abs() < 1e-3 * z_exact,
        "z = {z}, analytic {z_exact}"
    );
    assert!((vz + g * t).abs() < 1e-4, "vz = {vz}");
    assert!((x - 0.5 * t).abs() < 1e-5, "x = {x}");
    assert_eq!(vx, 0.5);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A few hundred bodies falling into a box: enough contacts and bodies for the parallel
/// stages to split work between threads.
const PILE: &str = r#"[simulation]
steps = 3000
dt = 2.0e-5

[[material]]
name = "plastic"
density = 1200.0
stiffness = 1.0e4
restitution = 0.4
friction = 0.5

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.01 }

[[shape]]
name = "ball"
sphere = { radius = 0.008 }

[container]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.5]
material = "plastic"

[[group]]
shape = "cube"
material = "plastic"
random = { min = [0.01, 0.01, 0.01], max = [0.19, 0.19, 0.25], count = 200, seed = 4 }
random_orientation = true
velocity = [0.0, 0.0, -4.0]
angular_velocity = [3.0, 1.0, -2.0]

[[group]]
shape = "ball"
material = "plastic"
random = { min = [0.01, 0.01, 0.01], max = [0.19, 0.19, 0.25], count = 150, seed = 5 }
velocity = [0.0, 0.0, -4.0]
"#;

#[test]
fn thread_count_does_not_change_results() {
    let dir = test_dir("threads");
    let scene = dir.join("pile.toml");
    std::fs::write(&scene, PILE).unwrap();
    let mut finals = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.join(format!("out{threads}"));
        let output = clatter(&[
            &"run",
            &scene,
            &"--out",
            &out,
            &"--threads",
            &threads,
            &"--quiet",
        ]);
        assert_ok(&output, &format!("clatter run --threads {threads}"));
        let summary = read_summary(&out);
        assert_eq!(summary["threads"].as_u64(), Some(threads.parse().unwrap()));
        assert!(
            summary["max_contacts"].as_u64().unwrap() >= 50,
            "too few contacts to test: {summary}"
        );
        finals.push(std::fs::read(out.join("final.csv")).unwrap());
    }
    assert!(
        finals[0] == finals[1],
        "final.csv differs between --threads 1 and --threads 2"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn trace_every_zero_is_an_error() {
    let dir = test_dir("trace-zero");
    let scene = dir.join("small.toml");
    std::fs::write(&scene, SMALL).unwrap();
    let out = dir.join("out");
    let output = clatter(&[&"run", &scene, &"--out", &out, &"--trace-every", &"0"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("--trace-every"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        !out.exists(),
        "--out created although the arguments were rejected"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn trace_every_needs_out() {
    let dir = test_dir("trace-no-out");
    let scene = dir.join("small.toml");
    std::fs::write(&scene, SMALL).unwrap();
    let output = clatter(&[&"run", &scene, &"--trace-every", &"5"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("--trace-every") && stderr.contains("--out"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn missing_scene_file() {
    let dir = test_dir("missing");
    let scene = dir.join("no-such-scene.toml");
    let out = dir.join("out");
    let output = clatter(&[&"run", &scene, &"--out", &out]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains(&scene.display().to_string()),
        "error does not name the path: {stderr}"
    );
    assert!(stderr.contains("cannot read"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--energy-every` writes `energy.csv`, so it needs `--out` like the other series
/// options (it was accepted and silently did nothing).
#[test]
fn energy_every_needs_out() {
    let dir = test_dir("energy-no-out");
    let scene = dir.join("small.toml");
    std::fs::write(&scene, SMALL).unwrap();
    let output = clatter(&[&"run", &scene, &"--energy-every", &"5"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--energy-every") && stderr.contains("--out"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A thread count far beyond the machine's cores is refused before anything is created
/// (`--threads 100000` started that many OS threads and never reached the first step).
#[test]
fn absurd_thread_counts_are_refused() {
    let dir = test_dir("threads");
    let scene = dir.join("small.toml");
    std::fs::write(&scene, SMALL).unwrap();
    let out = dir.join("out");
    let too_many = (clatter::thread_limit() + 1).to_string();
    let output = clatter(&[&"run", &scene, &"--threads", &too_many, &"--out", &out]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--threads") && stderr.contains(&too_many),
        "{stderr}"
    );
    assert!(
        !out.exists(),
        "--out created although the arguments were rejected"
    );
    // The limit itself is allowed.
    let output = clatter(&[&"run", &scene, &"--threads", &"3", &"--steps", &"2"]);
    assert_ok(&output, "3 threads");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A checkpoint resumed into the directory of a run of another scene starts its series
/// afresh, with a warning, instead of splicing its rows onto the other run's; resumed
/// into its own run's directory it continues them. A missing checkpoint's error says its
/// cause once.
#[test]
fn resume_continues_only_its_own_scenes_series() {
    let dir = test_dir("resume-other");
    let small = dir.join("small.toml");
    std::fs::write(&small, SMALL).unwrap();
    let other = dir.join("other.toml");
    std::fs::write(&other, SMALL.replace("steps = 23", "steps = 40")).unwrap();
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = clatter(&[
        &"run",
        &small,
        &"--out",
        &a,
        &"--energy-every",
        &"5",
        &"--checkpoint-every",
        &"1.0e-3",
        &"--quiet",
    ]);
    assert_ok(&o, "the small scene");
    let o = clatter(&[
        &"run",
        &other,
        &"--out",
        &b,
        &"--energy-every",
        &"5",
        &"--quiet",
    ]);
    assert_ok(&o, "the other scene");
    let ckpt = a.join("checkpoint.ckpt");
    let start = clatter::Checkpoint::load(&ckpt).unwrap().step_count();
    assert!(start > 0);
    // Into the other scene's directory: a warning, and energy.csv from the resume step.
    let o = clatter(&[&"resume", &ckpt, &"--out", &b, &"--steps", &"5", &"--quiet"]);
    assert_ok(&o, "resume into the other run's directory");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("another scene"), "{stderr}");
    let (_, rows) = read_csv(&b.join("energy.csv"));
    assert_eq!(
        rows[0][0] as u64, start,
        "the series starts at the resume step"
    );
    // Into its own directory: the rows before the resume step are kept.
    let o = clatter(&[&"resume", &ckpt, &"--out", &a, &"--steps", &"5", &"--quiet"]);
    assert_ok(&o, "resume into its own directory");
    assert!(!String::from_utf8_lossy(&o.stderr).contains("another scene"));
    let (_, rows) = read_csv(&a.join("energy.csv"));
    assert_eq!(rows[0][0], 0.0, "the series goes on from step 0");
    // A missing checkpoint: the cause once, not twice.
    let missing = dir.join("missing.ckpt");
    let o = clatter(&[&"resume", &missing, &"--out", &dir.join("c")]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.matches("No such file").count(), 1, "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mesh scene run by a relative path and resumed from another working directory: the
/// checkpoint names the scene file by its absolute path, so the mesh files (relative to the
/// scene file) are found again, and the resumed run ends where a straight one does.
#[test]
fn a_mesh_scene_resumes_from_another_working_directory() {
    let dir = test_dir("resume-cwd");
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let work = dir.join("work");
    std::fs::create_dir_all(work.join("meshes")).unwrap();
    std::fs::copy(scenes.join("mesh-floor.toml"), work.join("mesh-floor.toml")).unwrap();
    for m in ["bowl.obj", "plate.obj"] {
        std::fs::copy(scenes.join("meshes").join(m), work.join("meshes").join(m)).unwrap();
    }
    let run_in = |cwd: &Path, args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_clatter"))
            .current_dir(cwd)
            .args(args)
            .output()
            .expect("run clatter")
    };
    let common = ["--backend", "cpu", "--quiet"];
    let o = run_in(
        &work,
        &[
            &[
                "run",
                "mesh-floor.toml",
                "--steps",
                "40",
                "--out",
                "straight",
            ],
            &common[..],
        ]
        .concat(),
    );
    assert_ok(&o, "the straight run");
    let o = run_in(
        &work,
        &[
            &[
                "run",
                "mesh-floor.toml",
                "--steps",
                "20",
                "--out",
                "half",
                "--checkpoint-every",
                "1e9",
            ],
            &common[..],
        ]
        .concat(),
    );
    assert_ok(&o, "the first half");
    // From the directory above, where `meshes/bowl.obj` is not.
    let o = run_in(
        &dir,
        &[
            &[
                "resume",
                "work/half/checkpoint.ckpt",
                "--steps",
                "20",
                "--out",
                "resumed",
            ],
            &common[..],
        ]
        .concat(),
    );
    assert_ok(&o, "resume from another directory");
    assert_eq!(
        std::fs::read(work.join("straight/final.csv")).unwrap(),
        std::fs::read(dir.join("resumed/final.csv")).unwrap(),
        "the resumed run ends where the straight one does"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A time step so small that a step's gravity is a few f32 spacings of a 1 m/s velocity is
/// warned about (slow accelerations are rounded: at dt = 1e-7 s gravity reads 9.54 m/s² at
/// 3 m/s); the scene's own 1e-4 s is not.
#[test]
fn a_tiny_time_step_is_warned_about() {
    let dir = test_dir("tiny-dt");
    for (dt, warned) in [("1.0e-4", false), ("1.0e-7", true)] {
        let scene = dir.join(format!("small-{dt}.toml"));
        std::fs::write(&scene, SMALL.replace("dt = 1.0e-4", &format!("dt = {dt}"))).unwrap();
        let o = clatter(&[&"run", &scene, &"--steps", &"2", &"--backend", &"cpu"]);
        assert_ok(&o, dt);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            stderr.contains("Velocities are f32"),
            warned,
            "dt {dt}: {stderr}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn example_scenes() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("read {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenes.sort();
    scenes
}

#[test]
fn every_example_scene_loads() {
    let scenes = example_scenes();
    for name in [
        "default.toml",
        "bouncing-ball.toml",
        "cube-on-floor.toml",
        "hertz-spheres.toml",
        "dice-box.toml",
    ] {
        assert!(
            scenes.iter().any(|p| p.ends_with(name)),
            "scenes/{name} is missing"
        );
    }
    for path in &scenes {
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!scene.desc.bodies.is_empty());
        assert!(
            scene.warnings.is_empty(),
            "{}: warnings {:?}",
            path.display(),
            scene.warnings
        );
        let world = scene.world();
        assert!(
            world.dt > 0.0 && world.dt.is_finite(),
            "{}: dt {}",
            path.display(),
            world.dt
        );
    }
}

#[test]
fn every_example_scene_runs() {
    let dir = test_dir("examples");
    for path in example_scenes() {
        let out = dir.join(path.file_stem().unwrap());
        let output = clatter(&[&"run", &path, &"--steps", &"50", &"--out", &out, &"--quiet"]);
        assert_ok(&output, &format!("clatter run {}", path.display()));
        let bodies = Scene::load(&path).unwrap().desc.bodies.len();
        let (header, rows) = read_csv(&out.join("final.csv"));
        assert_eq!(header, HEADER);
        assert_eq!(rows.len(), bodies, "{}", path.display());
        assert!(
            rows.iter().all(|r| r.iter().all(|c| c.is_finite())),
            "{}",
            path.display()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every example scene but the large benchmark ones (`bench-*`, below and in BENCHMARKS.md)
/// runs to its end as `clatter run SCENE` does, without a blow-up: `rocks.toml` did not (a
/// steel die's corner went 51% of its size into the floor at its first stiffness), and the
/// 50-step runs above cannot see that. About a minute on two cores, most of it the default
/// scene and the drum.
#[test]
fn every_example_scene_runs_to_its_end() {
    let dir = test_dir("examples-end");
    let mut ran = 0;
    for path in example_scenes() {
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        if stem.starts_with("bench-") {
            continue;
        }
        let out = dir.join(&stem);
        let output = clatter(&[&"run", &path, &"--backend", &"cpu", &"--out", &out, &"-q"]);
        assert_ok(&output, &format!("clatter run {}", path.display()));
        let summary = read_summary(&out);
        let scene = Scene::load(&path).unwrap();
        let world = scene.world();
        assert_eq!(
            summary["steps"].as_u64(),
            Some(scene.steps(world.dt)),
            "{}: {summary}",
            path.display()
        );
        ran += 1;
    }
    assert!(ran >= 11, "{ran} scenes");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `scenes/bench-mixed-20k.toml` runs to its end: its six bands of polyhedra and spheres
/// fall onto each other at t = 0.108 s, and at its first stiffness (1e3 N/m) that collapse
/// pressed two bodies 50% of their size into each other, so `clatter run` stopped there as a
/// blow-up. The whole scene takes minutes; one column of it (its lattices cut to 0.075 m
/// square, 432 bodies, every band and the same fall) goes through the same collapse in
/// seconds, and stopped at the same step with the old stiffness.
#[test]
fn the_mixed_bench_scene_collapses_and_runs_to_its_end() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/bench-mixed-20k.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let wide = "max = [0.5, 0.5, ";
    assert_eq!(text.matches(wide).count(), 6, "the scene's six lattices");
    let dir = test_dir("mixed-column");
    std::fs::create_dir_all(&dir).unwrap();
    let column = dir.join("column.toml");
    std::fs::write(&column, text.replace(wide, "max = [0.075, 0.075, ")).unwrap();
    let out = dir.join("out");
    let output = clatter(&[&"run", &column, &"--backend", &"cpu", &"--out", &out, &"-q"]);
    assert_ok(&output, "clatter run (one column of bench-mixed-20k)");
    let (_, rows) = read_csv(&out.join("final.csv"));
    assert_eq!(rows.len(), 432);
    let summary = read_summary(&out);
    // The end of the scene's 0.2 s, well past the collapse.
    assert!(
        summary["simulated_time"].as_f64().unwrap() > 0.199,
        "{summary}"
    );
    assert!(summary["contacts"].as_u64().unwrap() > 400, "{summary}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn docs_full_example_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene-format.md");
    let doc =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    let after = doc
        .split("## Full example")
        .nth(1)
        .expect("a `## Full example` section");
    let block = after
        .split("```toml\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("a toml block");
    let scene = Scene::parse(block, "docs/scene-format.md").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        scene.desc.bodies.len(),
        30,
        "the ids in the example's comments"
    );
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

/// `[simulation]` with `extra` and one ball on an `n`-point lattice along x.
fn lattice_scene(extra: &str, max_x: f64, spacing: f64) -> String {
    format!(
        "[simulation]\n{extra}\n\n[[material]]\nname = \"m\"\ndensity = 1000.0\nstiffness = 1.0e4\n\n\
         [[shape]]\nname = \"ball\"\nsphere = {{ radius = 0.001 }}\n\n\
         [[group]]\nshape = \"ball\"\nmaterial = \"m\"\n\
         lattice = {{ min = [0.0, 0.0, 0.0], max = [{max_x:?}, 0.0, 0.0], spacing = {spacing:?} }}\n"
    )
}

#[test]
fn duration_counts_whole_steps() {
    for (duration, dt, steps) in [
        (0.35, 1e-4, 3500u64),
        (0.1, 1e-3, 100),
        (1.0, 3e-5, 33334),
        (0.01, 0.004, 3),
    ] {
        let text = lattice_scene(&format!("duration = {duration:?}\ndt = {dt:?}"), 0.0, 1.0);
        let scene = Scene::parse(&text, "t.toml").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            scene.steps(scene.world().dt),
            steps,
            "duration {duration}, dt {dt}"
        );
    }
}

#[test]
fn lattice_includes_max() {
    for (max_x, spacing, count) in [
        (0.06, 0.02, 4usize),
        (0.3, 0.1, 4),
        (0.7, 0.1, 8),
        (0.05, 0.02, 3),
        (0.0, 1.0, 1),
    ] {
        let scene = Scene::parse(&lattice_scene("steps = 1", max_x, spacing), "t.toml")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            scene.desc.bodies.len(),
            count,
            "max {max_x}, spacing {spacing}"
        );
    }
}

#[test]
fn periodic_scene_says_positions_are_wrapped_and_keeps_them_in_the_box() {
    let dir = test_dir("periodic");
    let out = dir.join("out");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/periodic-floor.toml");
    let o = clatter(&[
        &"run",
        &scene,
        &"--steps",
        &"3000",
        &"--backend",
        &"cpu",
        &"--out",
        &out,
    ]);
    assert_ok(&o, "periodic run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("periodic: x in [0, 0.08), y in [0, 0.08); output positions are wrapped"),
        "{err}"
    );
    let (_, rows) = read_csv(&out.join("final.csv"));
    assert_eq!(rows.len(), 222);
    for r in &rows {
        assert!(
            (0.0..0.08).contains(&r[1]) && (0.0..0.08).contains(&r[2]),
            "{r:?}"
        );
    }
}

/// The first run of the README (`clatter run`, no scene, no --out) leaves the default scene's
/// results in clatter-out/default/ with a picture of the last step; a scene file run without
/// --out writes nothing and says in one line how to get the files.
#[test]
fn first_run_leaves_results_to_open() {
    let dir = test_dir("first-run");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_clatter"))
        .args(["run", "--steps", "20", "--backend", "cpu"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_ok(&o, "clatter run (default scene)");
    let out = dir.join("clatter-out/default");
    for f in ["final.csv", "summary.json", "energy.csv", "energy.svg"] {
        assert!(out.join(f).is_file(), "{f} missing:\n{}", text(&o));
    }
    let stdout = String::from_utf8_lossy(&o.stdout);
    let png = out.join("final.png");
    if png.exists() {
        assert!(stdout.contains("results in clatter-out/default/: final.csv, summary.json, energy.csv, energy.svg, final.png"), "{}", text(&o));
        let img = image::open(&png).expect("final.png decodes");
        assert_eq!((img.width(), img.height()), (1280, 720));
    } else {
        // Only without any GPU adapter, not even a software one (CI has lavapipe).
        assert!(
            std::env::var_os("CI").is_none(),
            "no final.png:\n{}",
            text(&o)
        );
        assert!(String::from_utf8_lossy(&o.stderr).contains("warning: no picture"));
    }
    let scene = dir.join("ball.toml");
    std::fs::write(&scene, SMALL).unwrap();
    let o = clatter(&[&"run", &scene, &"--steps", &"5"]);
    assert_ok(&o, "clatter run ball.toml");
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("no files written: --out DIR writes final.csv, summary.json and the energy plot energy.svg (--format vtk adds ParaView frames; `clatter render` draws pictures)"),
        "{}",
        text(&o)
    );
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        2,
        "only clatter-out and ball.toml"
    );
}
