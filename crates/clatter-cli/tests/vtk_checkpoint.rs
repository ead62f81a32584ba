//! Outputs people can trust, end to end through the `clatter` binary:
//! - VTK frames read back by an independent reader (Python `meshio`) with the right counts,
//!   positions, orientations and velocities;
//! - `run` of 2N steps equals `run` of N steps + `resume` + N steps, byte for byte in every
//!   output (final.csv, trace.csv, energy.csv, VTK frames, the final checkpoint);
//! - damaged checkpoints are refused with a clear error;
//! - a run killed with SIGKILL while writing leaves only complete files under final names,
//!   and resuming its checkpoint finishes the run exactly as an uninterrupted one.
//!
//! The blow-up stops are in `blow_up.rs`.

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use clatter::Checkpoint;

mod common;
use common::{assert_ok, check_vtu, clatter, csv_rows, names, read, text};

fn test_dir(name: &str) -> PathBuf {
    common::test_dir("vtk-ckpt", name)
}

/// Spheres and cubes settling on a floor in an open box: contacts with walls and between
/// bodies from the first steps.
const PILE: &str = r#"
[simulation]
steps = 40
dt = 2.0e-5

[[material]]
name = "plastic"
density = 1200.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.4

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.006 }

[container]
min = [0.0, 0.0, 0.0]
max = [0.05, 0.05, 0.1]
material = "plastic"
top = false

[[group]]
shape = "ball"
material = "plastic"
lattice = { min = [0.01, 0.01, 0.0049], max = [0.04, 0.04, 0.0049], spacing = 0.0099 }

[[group]]
shape = "cube"
material = "plastic"
random = { min = [0.01, 0.01, 0.02], max = [0.04, 0.04, 0.06], count = 12, seed = 2 }
random_orientation = true
velocity = [0.0, 0.0, -0.5]
angular_velocity = [3.0, -2.0, 5.0]
"#;

/// Parses a CSV file of numbers (after the header) into rows.
const MESHIO_SCRIPT: &str = r#"
import json, sys, re, os
import meshio
d = sys.argv[1]
out = {}
for series in ("bodies", "contacts"):
    pvd = open(os.path.join(d, series + ".pvd")).read()
    frames = []
    for m in re.finditer(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd):
        t, f = float(m.group(1)), m.group(2)
        head = open(os.path.join(d, f)).read(2000)
        n = int(re.search(r'NumberOfPoints="(\d+)"', head).group(1))
        if n == 0:
            # meshio cannot read a grid without points or cells; report it as such.
            frames.append({"file": f, "time": t, "n": 0})
            continue
        mesh = meshio.read(os.path.join(d, f))
        fr = {"file": f, "time": t, "n": int(len(mesh.points)),
              "cells": int(sum(len(c.data) for c in mesh.cells)),
              "points": mesh.points.astype(float).tolist(),
              "field_time": float(mesh.field_data["TimeValue"][0]),
              "field_step": int(mesh.field_data["Step"][0])}
        for k, v in mesh.point_data.items():
            if v.ndim == 2 and v.shape[1] == 1:
                v = v[:, 0]
            fr[k] = v.astype(float).tolist()
        frames.append(fr)
    out[series] = frames
print(json.dumps(out))
"#;

/// Whether `python3 -c "import meshio"` works. In CI (`CI` set) a missing meshio fails the
/// test (`.ci/run` installs it); elsewhere the test is skipped with a loud message.
fn meshio_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import meshio"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        if std::env::var_os("CI").is_some() {
            panic!("python3 with meshio is required in CI (python3 -m pip install meshio)");
        }
        eprintln!(
            "\n*** SKIPPED: python3 with meshio is not available (python3 -m pip install meshio); the VTK read-back test did not run ***\n"
        );
    }
    ok
}

#[test]
fn vtk_output_reads_back_with_meshio() {
    if !meshio_available() {
        return;
    }
    let dir = test_dir("meshio");
    let scene = dir.join("pile.toml");
    std::fs::write(&scene, PILE).unwrap();
    let out = dir.join("out");
    let o = clatter(&[
        &"run",
        &scene,
        &"--out",
        &out,
        &"--format",
        &"csv,vtk",
        &"--output-every",
        &"10",
        &"--contacts",
        &"--quiet",
    ]);
    assert_ok(&o, "clatter run --format csv,vtk");
    let mut expected: Vec<String> = vec![
        "bodies.pvd".into(),
        "contacts.pvd".into(),
        "shapes.pvd".into(),
    ];
    for s in [0, 10, 20, 30, 40] {
        expected.push(format!("bodies_{s:06}.vtu"));
        expected.push(format!("contacts_{s:06}.vtu"));
        expected.push(format!("shapes_{s:06}.vtu"));
    }
    expected.extend(
        [
            "energy.csv",
            "energy.svg",
            "final.csv",
            "summary.json",
            "trace.csv",
        ]
        .map(String::from),
    );
    expected.sort();
    assert_eq!(names(&out), expected);

    let py = Command::new("python3")
        .arg("-c")
        .arg(MESHIO_SCRIPT)
        .arg(&out)
        .output()
        .expect("run python3");
    assert!(
        py.status.success(),
        "meshio read-back failed:\n{}",
        text(&py)
    );
    let json: serde_json::Value = serde_json::from_slice(&py.stdout).expect("JSON from the script");

    // Bodies: every frame against trace.csv, bit for bit (f32 through f64 is exact).
    let trace = csv_rows(&out.join("trace.csv"));
    let n = clatter::scene::Scene::parse(PILE, "pile")
        .unwrap()
        .desc
        .bodies
        .len();
    assert_eq!(n, 16 + 12);
    let frames = json["bodies"].as_array().unwrap();
    assert_eq!(frames.len(), 5);
    let f32_of = |v: &serde_json::Value| v.as_f64().unwrap() as f32;
    for (k, fr) in frames.iter().enumerate() {
        let step = 10 * k;
        assert_eq!(fr["n"].as_u64(), Some(n as u64), "points in {}", fr["file"]);
        assert_eq!(
            fr["cells"].as_u64(),
            Some(n as u64),
            "vertex cells in {}",
            fr["file"]
        );
        assert_eq!(fr["field_step"].as_u64(), Some(step as u64));
        let rows = &trace[k * n..(k + 1) * n];
        let t: f64 = rows[0][1].parse().unwrap();
        assert_eq!(fr["time"].as_f64(), Some(t), "pvd time of step {step}");
        assert_eq!(
            fr["field_time"].as_f64(),
            Some(t),
            "TimeValue of step {step}"
        );
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(row[0], step.to_string());
            assert_eq!(fr["id"][i].as_f64(), Some(i as f64));
            let col = |c: usize| row[c].parse::<f32>().unwrap();
            for c in 0..3 {
                assert_eq!(
                    f32_of(&fr["points"][i][c]),
                    col(3 + c),
                    "position of body {i} at step {step}"
                );
                assert_eq!(
                    f32_of(&fr["velocity"][i][c]),
                    col(10 + c),
                    "velocity of body {i}"
                );
                assert_eq!(
                    f32_of(&fr["angular_velocity"][i][c]),
                    col(13 + c),
                    "angular velocity of body {i}"
                );
            }
            for c in 0..4 {
                assert_eq!(
                    f32_of(&fr["orientation"][i][c]),
                    col(6 + c),
                    "orientation of body {i}"
                );
            }
            // The rotation matrix is the quaternion's.
            let q = glam::Quat::from_xyzw(col(7), col(8), col(9), col(6));
            let m = glam::Mat3::from_quat(q);
            for r in 0..3 {
                for c in 0..3 {
                    let got = f32_of(&fr["rotation"][i][3 * r + c]);
                    assert!(
                        (got - m.col(c)[r]).abs() < 1e-6,
                        "rotation[{r}][{c}] of body {i}"
                    );
                }
            }
            let shape = if i < 16 { 0.0 } else { 1.0 };
            assert_eq!(fr["shape"][i].as_f64(), Some(shape));
            assert_eq!(fr["material"][i].as_f64(), Some(0.0));
        }
    }
    // Contacts: the balls rest on the floor (wall 4) from the start; ids in range, unit
    // normals, and the per-body counts of the bodies file agree.
    let contacts = json["contacts"].as_array().unwrap();
    assert_eq!(contacts.len(), 5);
    let mut seen = 0;
    for (k, fr) in contacts.iter().enumerate().skip(1) {
        let m = fr["n"].as_u64().unwrap() as usize;
        assert!(
            m >= 16,
            "the 16 balls touch the floor at frame {k}: {m} contacts"
        );
        seen += m;
        let mut count = vec![0u32; n];
        let mut floor_force = 0.0;
        for c in 0..m {
            let (a, b) = (
                fr["body_a"][c].as_f64().unwrap() as i64,
                fr["body_b"][c].as_f64().unwrap() as i64,
            );
            assert!((0..n as i64).contains(&b), "body_b {b}");
            assert!(
                a < b && a >= -5,
                "body_a {a} (walls are -1 - index; 5 walls)"
            );
            count[b as usize] += 1;
            if a >= 0 {
                count[a as usize] += 1;
            }
            let nrm: f64 = (0..3)
                .map(|x| fr["normal"][c][x].as_f64().unwrap().powi(2))
                .sum::<f64>()
                .sqrt();
            assert!((nrm - 1.0).abs() < 1e-5, "unit normal: {nrm}");
            assert!(fr["depth"][c].as_f64().unwrap() > 0.0);
            // The force's normal component is the normal force (friction is tangential).
            let fn_: f64 = (0..3)
                .map(|x| fr["force"][c][x].as_f64().unwrap() * fr["normal"][c][x].as_f64().unwrap())
                .sum();
            let want = fr["normal_force"][c].as_f64().unwrap();
            assert!(
                (fn_ - want).abs() <= 1e-4 * want.abs().max(1e-3),
                "normal component {fn_} vs {want}"
            );
            if a == -5 {
                // On the floor the normal is +z.
                assert!(fr["normal"][c][2].as_f64().unwrap() > 0.99);
                floor_force += fr["force"][c][2].as_f64().unwrap();
            }
        }
        if k < 4 {
            // The balls, released from a slight overlap, are pushed up by the floor.
            assert!(
                floor_force > 0.0,
                "net floor force {floor_force} at frame {k}"
            );
        }
        let bodies = &frames[k];
        for (i, &c) in count.iter().enumerate() {
            assert!(
                bodies["contacts"][i].as_f64().unwrap() >= c as f64,
                "contact count of body {i}"
            );
        }
    }
    assert!(seen > 0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mixed shapes tumbling in a closed box (many rebuilds, springs with history).
const TUMBLE: &str = r#"
[simulation]
steps = 600
dt = 2.0e-5

[[material]]
name = "plastic"
density = 1200.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.5

[container]
min = [0.0, 0.0, 0.0]
max = [0.06, 0.06, 0.08]
material = "plastic"

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.006 }

[[shape]]
name = "tetra"
polyhedron = { kind = "tetrahedron", radius = 0.007 }

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

# A cube spinning flat on the floor: a face contact with a twisting spring.
[[body]]
shape = "cube"
material = "plastic"
position = [0.03, 0.03, 0.00345]
angular_velocity = [0.0, 0.0, 40.0]

[[group]]
shape = "cube"
material = "plastic"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 25, seed = 3 }
random_orientation = true
velocity = [0.4, -0.3, -0.5]
angular_velocity = [20.0, 5.0, -10.0]

[[group]]
shape = "tetra"
material = "plastic"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 15, seed = 4 }
random_orientation = true
velocity = [-0.4, 0.3, -0.2]

[[group]]
shape = "ball"
material = "plastic"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 15, seed = 5 }
velocity = [0.1, 0.5, -0.6]
"#;

fn series_args() -> Vec<String> {
    [
        "--format",
        "csv,vtk",
        "--output-every",
        "50",
        "--contacts",
        "--energy-every",
        "10",
        "--checkpoint-every",
        "0.002",
        "--quiet",
    ]
    .map(String::from)
    .to_vec()
}

fn run_with(args: &[&str], extra: &[String]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_clatter"));
    cmd.args(args).args(extra);
    cmd.output().expect("run clatter")
}

#[test]
fn run_and_resume_equal_one_run_bitwise() {
    let dir = test_dir("restart");
    let scene = dir.join("tumble.toml");
    std::fs::write(&scene, TUMBLE).unwrap();
    let s = scene.to_str().unwrap();
    let (a, b, c) = (dir.join("a"), dir.join("b"), dir.join("c"));
    let o = run_with(
        &[
            "run",
            s,
            "--steps",
            "600",
            "--threads",
            "1",
            "--out",
            a.to_str().unwrap(),
        ],
        &series_args(),
    );
    assert_ok(&o, "the uninterrupted run");
    let o = run_with(
        &[
            "run",
            s,
            "--steps",
            "300",
            "--threads",
            "2",
            "--out",
            b.to_str().unwrap(),
        ],
        &series_args(),
    );
    assert_ok(&o, "the first half");
    let ckpt = b.join("checkpoint.ckpt");
    assert_eq!(Checkpoint::load(&ckpt).unwrap().step_count(), 300);
    std::fs::copy(&ckpt, dir.join("half.ckpt")).unwrap();
    // Resume into the same directory (the series continue) and, with the stored options,
    // into a fresh one.
    let o = run_with(
        &[
            "resume",
            ckpt.to_str().unwrap(),
            "--steps",
            "300",
            "--out",
            b.to_str().unwrap(),
            "--threads",
            "2",
            "--quiet",
        ],
        &[],
    );
    assert_ok(&o, "resume into the same directory");
    let half = dir.join("half.ckpt");
    let o = run_with(
        &[
            "resume",
            half.to_str().unwrap(),
            "--steps",
            "300",
            "--out",
            c.to_str().unwrap(),
            "--quiet",
        ],
        &[],
    );
    assert_ok(&o, "resume into a new directory");

    let summary: serde_json::Value =
        serde_json::from_slice(&read(&b.join("summary.json"))).unwrap();
    assert_eq!(summary["step"].as_u64(), Some(600));
    assert_eq!(summary["resumed_from_step"].as_u64(), Some(300));
    assert!(summary["broad_phase_rebuilds"].as_u64().unwrap() > 3);
    assert!(summary["max_contacts"].as_u64().unwrap() > 5);

    // Every file but the summary (wall times) is identical, VTK frames and checkpoint included.
    let all = names(&a);
    assert_eq!(all, names(&b), "the same files");
    assert!(
        all.contains(&"bodies_000600.vtu".to_string())
            && all.contains(&"contacts_000300.vtu".to_string())
    );
    for name in all.iter().filter(|n| *n != "summary.json") {
        assert!(
            read(&a.join(name)) == read(&b.join(name)),
            "{name} differs between the straight and the resumed run"
        );
    }
    // The fresh directory holds the second half only, with the same final state.
    for name in [
        "final.csv",
        "checkpoint.ckpt",
        "bodies_000600.vtu",
        "contacts_000450.vtu",
    ] {
        assert!(
            read(&a.join(name)) == read(&c.join(name)),
            "{name} differs (resumed into a new directory)"
        );
    }
    let c_trace = csv_rows(&c.join("trace.csv"));
    assert_eq!(
        c_trace.first().unwrap()[0],
        "300",
        "the new trace starts at the checkpoint"
    );
    let a_trace = String::from_utf8(read(&a.join("trace.csv"))).unwrap();
    let c_text = String::from_utf8(read(&c.join("trace.csv"))).unwrap();
    assert!(
        a_trace.ends_with(c_text.split_once('\n').unwrap().1),
        "the second half of the trace"
    );

    // Resuming a finished run's checkpoint without --steps runs nothing and changes nothing.
    let d = dir.join("d");
    let o = run_with(
        &[
            "resume",
            a.join("checkpoint.ckpt").to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "--quiet",
        ],
        &[],
    );
    assert_ok(&o, "resume at the end");
    assert!(read(&a.join("final.csv")) == read(&d.join("final.csv")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn damaged_checkpoints_are_refused() {
    let dir = test_dir("damaged");
    let scene = dir.join("tumble.toml");
    std::fs::write(&scene, TUMBLE).unwrap();
    let a = dir.join("a");
    let o = clatter(&[
        &"run",
        &scene,
        &"--steps",
        &"20",
        &"--out",
        &a,
        &"--checkpoint-every",
        &"1",
        &"--quiet",
    ]);
    assert_ok(&o, "run");
    let good = read(&a.join("checkpoint.ckpt"));
    let mut cases: Vec<(String, Vec<u8>, &str)> = Vec::new();
    for k in [0usize, 9, 30, 200, good.len() / 2, good.len() - 1] {
        let mut b = good.clone();
        b[k] ^= 0x40;
        let want = match k {
            0 => "not a clatter checkpoint",
            9 => "not supported",
            _ => "checksum mismatch",
        };
        cases.push((format!("flip{k}"), b, want));
    }
    for cut in [0usize, 5, 16, 100, good.len() / 3, good.len() - 1] {
        let want = if cut == 0 {
            "not a clatter checkpoint"
        } else {
            "truncated checkpoint"
        };
        cases.push((format!("cut{cut}"), good[..cut].to_vec(), want));
    }
    for (name, bytes, want) in cases {
        let path = dir.join(format!("{name}.ckpt"));
        std::fs::write(&path, bytes).unwrap();
        let out = dir.join(format!("out-{name}"));
        let o = clatter(&[&"resume", &path, &"--out", &out]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {}", text(&o));
        assert!(
            err.contains(&format!("cannot resume from {}", path.display())),
            "{name}: {err}"
        );
        assert!(err.contains(want), "{name}: expected `{want}` in {err}");
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(
            !out.exists(),
            "{name}: --out was created for a refused checkpoint"
        );
    }
    let o = clatter(&[&"resume", &dir.join("nope.ckpt")]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope.ckpt"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A pile large enough that writing a frame takes a while: 1500 balls.
const KILL: &str = r#"
[simulation]
steps = 300
dt = 2.0e-5

[[material]]
name = "m"
density = 1200.0
stiffness = 2.0e3
restitution = 0.5

[[shape]]
name = "ball"
sphere = { radius = 0.004 }

[container]
min = [0.0, 0.0, 0.0]
max = [0.12, 0.12, 0.2]
material = "m"

[[group]]
shape = "ball"
material = "m"
lattice = { min = [0.01, 0.01, 0.01], max = [0.11, 0.11, 0.11], spacing = 0.0099 }
velocity = [0.0, 0.0, -0.3]
"#;

#[test]
fn sigkill_leaves_only_complete_files() {
    let dir = test_dir("kill");
    let scene = dir.join("kill.toml");
    std::fs::write(&scene, KILL).unwrap();
    let reference = dir.join("reference");
    let args = [
        "--format",
        "csv,vtk",
        "--output-every",
        "1",
        "--contacts",
        "--checkpoint-every",
        "0.0002",
        "--quiet",
    ];
    let o = run_with(
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            reference.to_str().unwrap(),
            "--format",
            "csv",
            "--quiet",
        ],
        &[],
    );
    assert_ok(&o, "the reference run");
    for (round, delay_ms) in [150u64, 400, 900].into_iter().enumerate() {
        let out = dir.join(format!("killed-{round}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_clatter"))
            .args([
                "run",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn clatter");
        // Wait until it has written two frames (a loaded machine can take a while), then a
        // little more, then SIGKILL.
        let start = Instant::now();
        while !out.join("bodies_000001.vtu").exists() && start.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(delay_ms));
        let finished = child.try_wait().unwrap().is_some();
        child.kill().expect("SIGKILL");
        child.wait().unwrap();
        assert!(
            !finished,
            "round {round}: the run finished before it was killed; make the scene longer"
        );
        let files = names(&out);
        let frames: Vec<&String> = files
            .iter()
            .filter(|f| f.starts_with("bodies_") && f.ends_with(".vtu"))
            .collect();
        assert!(
            frames.len() >= 2,
            "round {round}: too few frames before the kill: {files:?}"
        );
        // Every file under a final name is complete.
        for f in &files {
            let path = out.join(f);
            if f.ends_with(".tmp") {
                continue;
            } else if f.ends_with(".vtu") {
                check_vtu(&path);
            } else if f.ends_with(".pvd") {
                let t = String::from_utf8(read(&path)).unwrap();
                assert!(t.ends_with("</VTKFile>\n"), "{f} incomplete");
                for entry in t.split("file=\"").skip(1) {
                    let name = entry.split('"').next().unwrap();
                    assert!(
                        out.join(name).exists(),
                        "{f} lists {name}, which does not exist"
                    );
                }
            } else if f == "checkpoint.ckpt" {
                Checkpoint::load(&path)
                    .unwrap_or_else(|e| panic!("round {round}: checkpoint.ckpt: {e}"));
            } else {
                panic!(
                    "round {round}: {f} exists under its final name although the run was killed"
                );
            }
        }
        // The checkpoint finishes the run exactly as an uninterrupted one.
        let ckpt = out.join("checkpoint.ckpt");
        if ckpt.exists() {
            let o = run_with(
                &[
                    "resume",
                    ckpt.to_str().unwrap(),
                    "--out",
                    out.to_str().unwrap(),
                    "--quiet",
                ],
                &[],
            );
            assert_ok(&o, "resume after SIGKILL");
            assert!(
                read(&out.join("final.csv")) == read(&reference.join("final.csv")),
                "round {round}: resumed final state differs"
            );
            assert!(names(&out).iter().filter(|f| f.ends_with(".vtu")).count() >= 2 * 301 - 2);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
