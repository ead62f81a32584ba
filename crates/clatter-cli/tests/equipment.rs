//! The equipment validations of docs/equipment.md, end to end through `clatter run`: the
//! silo discharge rate against Beverloo's law over several orifice sizes, and the rotating
//! drum's dynamic angle of repose against the rotation speed. They take minutes each, so they
//! are `#[ignore]`d; run them with
//!
//! ```sh
//! cargo test --release -p clatter-cli --test equipment -- --ignored --nocapture --test-threads 1
//! ```
//!
//! The meshes come from `scripts/make_meshes.py` (python3), the measurements from
//! `clatter::analysis`. The example scenes themselves (scenes/hopper.toml, scenes/drum.toml)
//! are run for a few steps by `run_cli`'s example-scene test.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use clatter::analysis::{discharge_rate, drum_bed_angle, drum_surface, fit_beverloo};
use common::{assert_ok, clatter, test_dir};

const G: f64 = 9.81;
/// Bead radius, m, and density, kg/m^3.
const R: f64 = 0.0015;
const RHO: f64 = 2500.0;

fn make_mesh(args: &[&str]) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/make_meshes.py");
    let o = Command::new("python3")
        .arg(script)
        .args(args)
        .output()
        .expect("python3 runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Reads `discharge.csv` as `(time, mass)`.
fn discharge(out: &Path) -> Vec<(f64, f64)> {
    std::fs::read_to_string(out.join("discharge.csv"))
        .expect("discharge.csv")
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (c[1], c[3])
        })
        .collect()
}

/// Rows `(step, id, x, y, z)` of `trace.csv`.
fn trace(out: &Path) -> Vec<(u64, f64, f64, f64)> {
    std::fs::read_to_string(out.join("trace.csv"))
        .expect("trace.csv")
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (c[0] as u64, c[3], c[4], c[5])
        })
        .collect()
}

/// One silo run with a square orifice of side `d_orifice` (m); returns the steady discharge
/// rate (kg/s) and the bulk density of the settled fill (kg/m^3).
fn silo_run(dir: &Path, d_orifice: f64) -> (f64, f64) {
    let width = 0.06;
    let name = format!("silo_{:.0}mm", d_orifice * 1000.0);
    let mesh = dir.join(format!("{name}.stl"));
    let plate = dir.join(format!("{name}_plate.stl"));
    make_mesh(&[
        "silo",
        "--width",
        &width.to_string(),
        "--height",
        "0.2",
        "--orifice",
        &d_orifice.to_string(),
        "--out",
        mesh.to_str().unwrap(),
    ]);
    make_mesh(&[
        "plate",
        "--size",
        &(d_orifice + 0.01).to_string(),
        "--z",
        "-0.001",
        "--out",
        plate.to_str().unwrap(),
    ]);
    let t_open = 0.45;
    let count = 10000;
    let scene = format!(
        r#"
[simulation]
duration = 1.3
dt = 5.0e-5

[[material]]
name = "glass"
density = {RHO}
stiffness = 200.0
restitution = 0.3
friction = 0.5

[[shape]]
name = "bead"
sphere = {{ radius = {R} }}

[[boundary]]
mesh = {{ file = "{}" }}
material = "glass"

[[boundary]]
mesh = {{ file = "{}" }}
material = "glass"
motion = {{ velocity = [1.0, 0.0, 0.0] }}
start = {t_open}
end = {}

[[group]]
shape = "bead"
material = "glass"
random = {{ min = [-0.0275, -0.0275, 0.003], max = [0.0275, 0.0275, 0.19], count = {count} }}
seed = 11

[[sink]]
min = [-0.3, -0.3, -0.5]
max = [0.3, 0.3, -0.02]
"#,
        mesh.display(),
        plate.display(),
        t_open + 0.05,
    );
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    let out = dir.join(&name);
    // The settled fill, just before the plate moves: bulk density from the bed height.
    let o = clatter(&[
        &"run",
        &path,
        &"--out",
        &out,
        &"--energy-every",
        &"200",
        &"--output-every",
        &((t_open / 5.0e-5) as u64).to_string(),
        &"--quiet",
    ]);
    assert_ok(&o, &name);
    let step_open = (t_open / 5.0e-5) as u64;
    let fill: Vec<f64> = trace(&out)
        .iter()
        .filter(|r| r.0 == step_open)
        .map(|r| r.3)
        .collect();
    let mut z = fill.clone();
    z.sort_by(f64::total_cmp);
    // The bed's top: the mean height of its highest 5% of centres, plus a radius.
    let top_n = (z.len() / 20).max(1);
    let top = z[z.len() - top_n..].iter().sum::<f64>() / top_n as f64 + R;
    let m = RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let rho_b = fill.len() as f64 * m / (width * width * top);
    let rows = discharge(&out);
    let total = count as f64 * m;
    // The steady window: from 0.1 s after the plate has gone to when half has run out.
    let t0 = t_open + 0.15;
    let t1 = rows
        .iter()
        .find(|r| r.1 > 0.5 * total)
        .map_or(rows.last().unwrap().0, |r| r.0);
    let w = discharge_rate(&rows, t0, t1).expect("a discharge window");
    println!(
        "D = {:.1} mm (D/d = {:.2}): W = {w:.5e} kg/s over t = {t0:.2}..{t1:.3} s, rho_b = {rho_b:.0} kg/m^3",
        d_orifice * 1000.0,
        d_orifice / (2.0 * R)
    );
    (w, rho_b)
}

#[test]
#[ignore = "minutes: the Beverloo series of docs/equipment.md"]
fn silo_discharge_follows_beverloo() {
    let dir = test_dir("equipment", "beverloo");
    let d = 2.0 * R;
    let mut points = Vec::new();
    let mut rho_b = Vec::new();
    // D/d from 5 to 8: the silo (60 mm) stays at least 2.5 orifices wide.
    for ratio in [5.0, 6.0, 7.0, 8.0] {
        let (w, rb) = silo_run(&dir, ratio * d);
        points.push((ratio * d, w));
        rho_b.push(rb);
    }
    let rb = rho_b.iter().sum::<f64>() / rho_b.len() as f64;
    let fit = fit_beverloo(&points, rb, G, d).expect("a fit");
    // A square orifice of side D has 4/pi the area of a circle of diameter D.
    let c_circle = fit.c / (4.0 / std::f64::consts::PI);
    println!(
        "Beverloo: C = {:.3} (square orifice), {c_circle:.3} per circle-equivalent area; k = {:.2}; rho_b = {rb:.0}",
        fit.c, fit.k
    );
    assert!((0.5..=0.7).contains(&c_circle), "C = {c_circle}");
    assert!((1.2..=2.0).contains(&fit.k), "k = {}", fit.k);
}

/// One speed of the drum series: `scenes/drum.toml` turning at `w` rad/s, `frames` frames
/// 0.1 s apart once the bed has turned through 1.5 rad (at least 1.5 s). Returns the bed
/// angle (`drum_bed_angle`, the flat surface through the bed's centroid) and the surface fit
/// (`drum_surface`, the highest centres across the middle 60%), each as (mean, standard
/// error) in degrees.
fn drum_run(dir: &Path, w: f64, frames: u64) -> ((f64, f64), (f64, f64)) {
    let scene_src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/drum.toml");
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/meshes/drum.stl");
    let text = std::fs::read_to_string(scene_src).unwrap();
    let start = 0.4;
    let dt = 5.0e-5;
    let every = 0.1;
    let settle = (1.5 / w).max(1.5);
    let first = ((start + settle) / dt).round() as u64;
    let duration = first as f64 * dt + every * frames as f64;
    let text = text
        .replace(
            "\"meshes/drum.stl\"",
            &format!("{:?}", mesh.display().to_string()),
        )
        .replace(
            "angular_velocity = [0.0, 1.4, 0.0]",
            &format!("angular_velocity = [0.0, {w}, 0.0]"),
        )
        .replace("duration = 2.0", &format!("duration = {duration}"));
    let path: PathBuf = dir.join(format!("drum_{w:.3}.toml"));
    std::fs::write(&path, text).unwrap();
    let out = dir.join(format!("drum_{w:.3}"));
    let o = clatter(&[
        &"run",
        &path,
        &"--out",
        &out,
        &"--output-every",
        &((every / dt).round() as u64).to_string(),
        &"--quiet",
    ]);
    assert_ok(&o, "drum");
    let rows = trace(&out);
    let (mut bed, mut surface) = (Vec::new(), Vec::new());
    let mut steps: Vec<u64> = rows.iter().map(|r| r.0).filter(|&s| s >= first).collect();
    steps.dedup();
    for s in steps {
        // Cross-section: u = x, v = z (the axis is y).
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.0 == s)
            .map(|r| (r.1, r.3))
            .collect();
        bed.push(drum_bed_angle(&pts).expect("a bed below the axis"));
        surface.push(
            drum_surface(&pts, 0.6 * 0.05, 10)
                .expect("a surface")
                .angle_deg,
        );
    }
    let (b, s) = (block_mean(&bed, 10), block_mean(&surface, 10));
    println!(
        "w = {w:.3} rad/s, Fr = {:.2e}: bed angle {:.2} +- {:.2} deg, surface fit {:.2} +- {:.2} deg ({} frames)",
        w * w * 0.05 / G,
        b.0,
        b.1,
        s.0,
        s.1,
        bed.len()
    );
    (b, s)
}

/// The mean of a correlated series and its standard error from the means of consecutive
/// blocks of `block` values (frames 0.1 s apart within one avalanche are not independent;
/// blocks of 1 s are treated as if they were).
fn block_mean(x: &[f64], block: usize) -> (f64, f64) {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let blocks: Vec<f64> = x
        .chunks_exact(block)
        .map(|c| c.iter().sum::<f64>() / block as f64)
        .collect();
    let n = blocks.len() as f64;
    let var = blocks.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
#[ignore = "minutes: the drum series of docs/equipment.md"]
fn drum_angle_against_speed() {
    let dir = test_dir("equipment", "drum");
    let froude = [1e-4, 3e-4, 1e-3, 2.15e-3, 4.64e-3, 1e-2];
    let runs: Vec<((f64, f64), (f64, f64))> = froude
        .iter()
        .map(|fr| drum_run(&dir, (fr * G / 0.05f64).sqrt(), 150))
        .collect();
    for ((a, se), (sa, sse)) in &runs {
        assert!((20.0..40.0).contains(a), "bed angle {a} deg: {runs:?}");
        assert!((20.0..40.0).contains(sa), "surface fit {sa} deg: {runs:?}");
        assert!(
            *se < 0.5 && *sse < 0.5,
            "standard errors {se}, {sse} deg: {runs:?}"
        );
    }
    // The angle grows with the speed, by both measures (the surface fit of docs/equipment.md
    // and the bed's centroid): the weighted least-squares slope against log10(Fr) is positive
    // by more than three standard errors, and no speed is significantly (2 sigma) below a
    // slower one.
    for (what, measure) in [("surface fit", 1), ("bed angle", 0)] {
        let pts: Vec<(f64, f64, f64)> = froude
            .iter()
            .zip(&runs)
            .map(|(fr, (bed, surface))| {
                let (a, se) = if measure == 0 { bed } else { surface };
                (fr.log10(), *a, *se)
            })
            .collect();
        let (slope, slope_se) = weighted_slope(&pts);
        println!("{what} against log10(Fr): {slope:.2} +- {slope_se:.2} deg per decade");
        assert!(
            slope > 3.0 * slope_se,
            "{what}: slope {slope} +- {slope_se}: {runs:?}"
        );
        for i in 0..pts.len() {
            for j in i + 1..pts.len() {
                let (ai, si) = (pts[i].1, pts[i].2);
                let (aj, sj) = (pts[j].1, pts[j].2);
                assert!(
                    aj > ai - 2.0 * (si * si + sj * sj).sqrt(),
                    "{what}: {runs:?}"
                );
            }
        }
    }
}

/// Weighted least-squares slope of `y` on `x` for points `(x, y, standard error of y)`, and
/// its standard error.
fn weighted_slope(pts: &[(f64, f64, f64)]) -> (f64, f64) {
    let w: Vec<f64> = pts.iter().map(|p| 1.0 / (p.2 * p.2)).collect();
    let sw: f64 = w.iter().sum();
    let xm = pts.iter().zip(&w).map(|(p, w)| w * p.0).sum::<f64>() / sw;
    let ym = pts.iter().zip(&w).map(|(p, w)| w * p.1).sum::<f64>() / sw;
    let sxx: f64 = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.0 - xm).powi(2))
        .sum();
    let sxy: f64 = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.0 - xm) * (p.1 - ym))
        .sum();
    (sxy / sxx, (1.0 / sxx).sqrt())
}
