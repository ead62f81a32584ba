//! Progress lines for batch jobs (`--log-every`, docs/outputs.md "Logs for batch jobs"): with
//! stderr piped (as here, `Command::output`), `run`, `resume`, `render` and `validate` print
//! a header once and fixed-width lines at the asked steps and at the end; `--quiet` prints
//! none; the lines change nothing in the results.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{assert_ok, clatter, text};

const DT: f64 = 1.0e-4;

/// Four spheres falling onto a floor, two already resting on it: 23 steps.
const SCENE: &str = r#"[simulation]
steps = 23
dt = 1.0e-4

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e3

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"

[[group]]
shape = "ball"
material = "m"
lattice = { min = [0.0, 0.0, 0.0099], max = [0.03, 0.0, 0.0099], spacing = 0.03 }

[[group]]
shape = "ball"
material = "m"
lattice = { min = [0.0, 0.0, 0.1], max = [0.03, 0.03, 0.1], spacing = 0.03 }
"#;

/// A fresh directory under cargo's scratch directory for integration tests (target/tmp).
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("batch-log-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the test directory");
    dir
}

fn write_scene(dir: &Path) -> PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, SCENE).expect("write the scene");
    p
}

/// One progress line: step, total, simulated time, steps/s, kinetic energy, contacts.
#[derive(Debug)]
struct Line {
    step: u64,
    total: u64,
    time: f64,
    rate: f64,
    kinetic: f64,
    contacts: u64,
}

/// The header count and the progress lines of a run's stderr.
fn progress(o: &Output) -> (usize, Vec<Line>) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    let headers = stderr
        .lines()
        .filter(|l| l.trim_start().starts_with("step/total"))
        .count();
    let lines = stderr
        .lines()
        .filter_map(|l| {
            let (step, rest) = l.split_once('/')?;
            let step = step.trim().parse().ok()?;
            let f: Vec<&str> = rest.split_whitespace().collect();
            let num = |k: usize| -> f64 {
                f[k].parse()
                    .unwrap_or_else(|e| panic!("column {k} of {l:?}: {e}"))
            };
            assert_eq!(
                f.len(),
                9,
                "{l:?}: 5 numbers, then elapsed and ETA with units"
            );
            Some(Line {
                step,
                total: num(0) as u64,
                time: num(1),
                rate: num(2),
                kinetic: num(3),
                contacts: num(4) as u64,
            })
        })
        .collect();
    (headers, lines)
}

/// Checks the lines against the steps they should be at and the run's total.
fn check_lines(o: &Output, steps: &[u64], total: u64) {
    let (headers, lines) = progress(o);
    assert_eq!(headers, 1, "one header line:\n{}", text(o));
    let got: Vec<u64> = lines.iter().map(|l| l.step).collect();
    assert_eq!(got, steps, "{}", text(o));
    for l in &lines {
        assert_eq!(l.total, total, "{l:?}");
        let t = l.step as f64 * DT;
        assert!(
            (l.time - t).abs() <= 1e-4 * t,
            "time {} at step {}",
            l.time,
            l.step
        );
        assert!(l.rate > 0.0 && l.kinetic > 0.0, "{l:?}");
    }
}

#[test]
fn run_prints_a_line_every_n_steps_and_at_the_end() {
    let dir = scratch("run");
    let scene = write_scene(&dir);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = clatter(&[
        &"run",
        &scene,
        &"--backend",
        &"cpu",
        &"--log-every",
        &"5",
        &"--out",
        &a,
    ]);
    assert_ok(&o, "run --log-every 5");
    check_lines(&o, &[5, 10, 15, 20, 23], 23);
    let (_, lines) = progress(&o);
    assert!(lines.iter().all(|l| l.contacts >= 2), "{lines:?}");
    // The lines read the state only: the results are those of a run without them.
    let o = clatter(&[
        &"run",
        &scene,
        &"--backend",
        &"cpu",
        &"--quiet",
        &"--out",
        &b,
    ]);
    assert_ok(&o, "run --quiet");
    assert!(o.stderr.is_empty(), "--quiet prints nothing:\n{}", text(&o));
    for f in ["final.csv", "energy.csv"] {
        assert_eq!(
            std::fs::read(a.join(f)).expect("read"),
            std::fs::read(b.join(f)).expect("read"),
            "{f} differs with the progress lines"
        );
    }
    // --quiet wins over --log-every.
    let o = clatter(&[&"run", &scene, &"--quiet", &"--log-every", &"5"]);
    assert_ok(&o, "run --quiet --log-every 5");
    assert!(o.stderr.is_empty(), "--quiet prints nothing:\n{}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// On the GPU the run stops at the lines' steps and reads the state back there: the same
/// lines, and the results of a run without them.
#[test]
fn gpu_run_logs_without_changing_its_results() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let dir = scratch("gpu");
    let scene = write_scene(&dir);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = clatter(&[
        &"run",
        &scene,
        &"--backend",
        &"gpu",
        &"--log-every",
        &"5",
        &"--out",
        &a,
    ]);
    assert_ok(&o, "run --backend gpu --log-every 5");
    check_lines(&o, &[5, 10, 15, 20, 23], 23);
    let o = clatter(&[
        &"run",
        &scene,
        &"--backend",
        &"gpu",
        &"--quiet",
        &"--out",
        &b,
    ]);
    assert_ok(&o, "run --backend gpu --quiet");
    for f in ["final.csv", "energy.csv"] {
        assert_eq!(
            std::fs::read(a.join(f)).expect("read"),
            std::fs::read(b.join(f)).expect("read"),
            "{f} differs with the progress lines"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_piped_run_logs_by_wall_time_by_default() {
    let dir = scratch("default");
    let scene = write_scene(&dir);
    // Far shorter than the 10 s default: the header and the last line only.
    let o = clatter(&[&"run", &scene, &"--backend", &"cpu"]);
    assert_ok(&o, "run");
    check_lines(&o, &[23], 23);
    // An explicit wall time, long enough for one line at most besides the last.
    let o = clatter(&[&"run", &scene, &"--backend", &"cpu", &"--log-every", &"1h"]);
    assert_ok(&o, "run --log-every 1h");
    check_lines(&o, &[23], 23);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn resume_counts_from_the_checkpoint() {
    let dir = scratch("resume");
    let scene = write_scene(&dir);
    let out = dir.join("out");
    let o = clatter(&[
        &"run",
        &scene,
        &"--backend",
        &"cpu",
        &"--steps",
        &"20",
        &"--checkpoint-every",
        &"1.0",
        &"--out",
        &out,
        &"--quiet",
    ]);
    assert_ok(&o, "run --steps 20");
    let o = clatter(&[
        &"resume",
        &out.join("checkpoint.ckpt"),
        &"--backend",
        &"cpu",
        &"--steps",
        &"12",
        &"--log-every",
        &"5",
    ]);
    assert_ok(&o, "resume --log-every 5");
    check_lines(&o, &[25, 30, 32], 32);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_logs_between_frames() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let dir = scratch("render");
    let scene = write_scene(&dir);
    let out = dir.join("frames");
    let o = clatter(&[
        &"render",
        &scene,
        &"--backend",
        &"cpu",
        &"--out",
        &out,
        &"--every",
        &"8",
        &"--steps",
        &"12",
        &"--size",
        &"32x24",
        &"--log-every",
        &"5",
    ]);
    assert_ok(&o, "render --log-every 5");
    check_lines(&o, &[5, 10, 12], 12);
    // The frames are those of steps 0, 8 and 12, as without the lines.
    let pngs = common::names(&out)
        .into_iter()
        .filter(|n| n.ends_with(".png"))
        .count();
    assert_eq!(pngs, 3, "{}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn validate_logs_a_line_per_check() {
    let o = clatter(&[
        &"validate",
        &"--backend",
        &"cpu",
        &"--quick",
        &"--only",
        &"mfix-dem01,mfix-dem02",
        &"--log-every",
        &"10s",
    ]);
    assert_ok(&o, "validate --log-every 10s");
    let stderr = String::from_utf8_lossy(&o.stderr);
    let header = stderr
        .lines()
        .filter(|l| l.starts_with("check ") && l.contains("elapsed"))
        .count();
    assert_eq!(header, 1, "{}", text(&o));
    let done: Vec<(&str, &str)> = stderr
        .lines()
        .filter(|l| l.contains(" done ") && !l.starts_with("check "))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f[0], f[1])
        })
        .collect();
    assert_eq!(
        done,
        [("mfix-dem01", "1/2"), ("mfix-dem02", "2/2")],
        "{}",
        text(&o)
    );
    let o = clatter(&[
        &"validate",
        &"--backend",
        &"cpu",
        &"--quick",
        &"--only",
        &"mfix-dem01",
        &"--quiet",
    ]);
    assert_ok(&o, "validate --quiet");
    assert!(o.stderr.is_empty(), "--quiet prints nothing:\n{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("validation passed"));
}

#[test]
fn bad_intervals_are_usage_errors() {
    for bad in ["0", "10x", "-5s", "s", "1.5"] {
        let arg = format!("--log-every={bad}");
        let o = clatter(&[&"run", &"--steps", &"1", &arg]);
        assert_eq!(o.status.code(), Some(2), "--log-every {bad}:\n{}", text(&o));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            stderr.contains("--log-every") && stderr.contains("10s"),
            "--log-every {bad}:\n{stderr}"
        );
    }
}
