//! `discharge.csv` end to end: rows at the first step, every energy sample and the last step,
//! cumulative counts that match the removed bodies missing from final.csv and the summary;
//! a resumed run continues the file exactly as an uninterrupted run writes it; the GPU run
//! writes the same file, digit for digit (lavapipe in CI).

mod common;

use common::{assert_ok, clatter, test_dir, text};

/// A lattice of spheres falling onto a floor whose left half is a sink.
const SCENE: &str = include_str!("../../../scenes/sink-floor.toml");

fn run(dir: &std::path::Path, out: &str, extra: &[&str]) -> std::path::PathBuf {
    let scene = dir.join("sink.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join(out);
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
        vec![&"run", &scene, &"--out", &out, &"--energy-every", &"250"];
    for a in extra {
        args.push(a);
    }
    let o = clatter(&args);
    assert_ok(&o, "run");
    out
}

fn rows(out: &std::path::Path) -> Vec<(u64, f64, u64, f64)> {
    let s = std::fs::read_to_string(out.join("discharge.csv")).expect("discharge.csv");
    let mut lines = s.lines();
    assert_eq!(lines.next(), Some("step,time,count,mass"));
    lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (
                c[0].parse().unwrap(),
                c[1].parse().unwrap(),
                c[2].parse().unwrap(),
                c[3].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn discharge_csv_counts_the_removed_bodies() {
    let dir = test_dir("discharge", "cpu");
    let out = run(&dir, "cpu", &["--backend", "cpu"]);
    let r = rows(&out);
    let steps: Vec<u64> = r.iter().map(|x| x.0).collect();
    assert_eq!(steps, (0..=4000).step_by(250).collect::<Vec<_>>());
    assert_eq!((r[0].2, r[0].3), (0, 0.0));
    for w in r.windows(2) {
        assert!(w[1].2 >= w[0].2 && w[1].3 >= w[0].3, "cumulative: {r:?}");
    }
    // Each removed ball has the same mass: mass = count x m.
    let m = 1000.0f32 * (4.0 / 3.0 * std::f32::consts::PI * 0.005f32.powi(3));
    let last = r.last().unwrap();
    assert_eq!(last.2, 30, "{r:?}");
    assert!(
        (last.3 / (30.0 * m as f64) - 1.0).abs() < 1e-6,
        "{} vs 30 x {m}",
        last.3
    );
    // final.csv has the 20 others; the summary agrees.
    let f = std::fs::read_to_string(out.join("final.csv")).unwrap();
    assert_eq!(f.lines().count() - 1, 20);
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["removed"], 30);
    assert_eq!(s["removed_mass"].as_f64(), Some(last.3));

    // Resumed halfway from a checkpoint: the same file.
    let half = run(
        &dir,
        "half",
        &[
            "--backend",
            "cpu",
            "--steps",
            "2000",
            "--checkpoint-every",
            "0.1",
        ],
    );
    let o = clatter(&[
        &"resume",
        &half.join("checkpoint.ckpt"),
        &"--steps",
        &"2000",
        &"--out",
        &half,
    ]);
    assert_ok(&o, "resume");
    assert_eq!(
        std::fs::read_to_string(half.join("discharge.csv")).unwrap(),
        std::fs::read_to_string(out.join("discharge.csv")).unwrap(),
        "{}",
        text(&o)
    );

    // The GPU writes the same file.
    if clatter_gpu::test_context().is_some() {
        let gpu = run(&dir, "gpu", &["--backend", "gpu"]);
        assert_eq!(
            std::fs::read_to_string(gpu.join("discharge.csv")).unwrap(),
            std::fs::read_to_string(out.join("discharge.csv")).unwrap()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
