//! `--backend gpu|cpu|auto` on `clatter run` and `clatter bench`: the GPU gives the CPU's
//! answers through the same outputs, auto says what it chose and why, bad values are refused.

mod common;

use common::{assert_ok, clatter, test_dir, text};

/// Rows of final.csv as numbers.
fn final_rows(dir: &std::path::Path) -> Vec<Vec<f64>> {
    let s = std::fs::read_to_string(dir.join("final.csv")).expect("final.csv written");
    s.lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().expect("a number")).collect())
        .collect()
}

/// Asserts that two runs' `final.csv` list the same bodies at positions within `tol` (m) of
/// each other; returns the number of bodies.
fn same_final_positions(cpu: &std::path::Path, gpu: &std::path::Path, tol: f64) -> usize {
    let (a, b) = (final_rows(cpu), final_rows(gpu));
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.iter().zip(&b) {
        assert_eq!(ra[0], rb[0], "same body ids");
        for k in 1..4 {
            assert!(
                (ra[k] - rb[k]).abs() < tol,
                "body {}: position {:?} vs {:?}",
                ra[0],
                &ra[1..4],
                &rb[1..4]
            );
        }
    }
    a.len()
}

fn gpu_available() -> bool {
    clatter_gpu::test_context().is_some()
}

/// The run's `summary.json` in `out`, parsed.
fn summary(out: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("valid JSON")
}

#[test]
fn gpu_run_matches_cpu_run_through_the_same_outputs() {
    if !gpu_available() {
        return;
    }
    let dir = test_dir("backend", "dice");
    let (cpu, gpu) = (dir.join("cpu"), dir.join("gpu"));
    for (backend, out) in [("cpu", &cpu), ("gpu", &gpu)] {
        let o = clatter(&[
            &"run",
            &"../../scenes/dice-box.toml",
            &"--steps",
            &"600",
            &"--backend",
            &backend,
            &"--out",
            out,
            &"--format",
            &"csv,vtk",
            &"--output-every",
            &"200",
        ]);
        assert_ok(&o, backend);
    }
    let bodies = same_final_positions(&cpu, &gpu, 1e-5);
    assert!(bodies > 1, "the scene has bodies");
    let gpu_summary = summary(&gpu);
    assert!(
        gpu_summary["backend"]
            .as_str()
            .unwrap_or("")
            .starts_with("gpu"),
        "{gpu_summary}"
    );
    // The GPU's broad-phase rebuilds reach the summary (they read 0 before): the CPU's
    // count, give or take one that f32 rounding may move.
    let cpu_summary = summary(&cpu);
    let rebuilds = |s: &serde_json::Value| s["broad_phase_rebuilds"].as_u64().expect("rebuilds");
    let (r_cpu, r_gpu) = (rebuilds(&cpu_summary), rebuilds(&gpu_summary));
    assert!(
        r_cpu > 0 && r_gpu + 1 >= r_cpu && r_gpu <= r_cpu + 1,
        "rebuilds: cpu {r_cpu}, gpu {r_gpu}"
    );
    for f in ["trace.csv", "bodies.pvd", "bodies_000600.vtu", "energy.csv"] {
        assert!(gpu.join(f).exists(), "{f} written by the GPU run");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn auto_says_which_backend_and_why() {
    let o = clatter(&[
        &"run",
        &"../../scenes/bouncing-ball.toml",
        &"--steps",
        &"50",
        &"--backend",
        &"auto",
    ]);
    assert_ok(&o, "auto run");
    let err = String::from_utf8_lossy(&o.stderr);
    let line = err
        .lines()
        .find(|l| l.starts_with("backend: "))
        .unwrap_or_else(|| panic!("no backend line:\n{}", text(&o)));
    assert!(
        line.starts_with("backend: gpu (auto: found") || line.starts_with("backend: cpu (auto: "),
        "{line}"
    );
}

/// Looking for an adapter on a machine without a display (a server, a container, CI) prints
/// the choice and nothing that reads like a failure: Mesa's Vulkan device-selection layer
/// used to make libwayland print `error: XDG_RUNTIME_DIR is invalid or not set in the
/// environment.` twice before the run started. The default scene's results go to
/// `clatter-out/default/` under the working directory: a scratch directory here, never the
/// source tree.
#[test]
fn auto_probe_without_a_display_prints_no_errors() {
    let dir = test_dir("backend", "no-display");
    let source_out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("clatter-out");
    let source_out_before = source_out.exists();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_clatter"))
        .args(["run", "--steps", "5"])
        .current_dir(&dir)
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("DISPLAY")
        // The layer's own switches, which would hide what this test looks for.
        .env_remove("NODEVICE_SELECT")
        .env_remove("MESA_VK_DEVICE_SELECT")
        .env_remove("DRI_PRIME")
        .output()
        .expect("run clatter");
    assert_ok(&o, "auto run without a display");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.lines().any(|l| l.starts_with("backend: ")),
        "no backend line:\n{}",
        text(&o)
    );
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert!(errors.is_empty(), "{errors:?}\n{}", text(&o));
    assert!(dir.join("clatter-out/default/final.csv").is_file());
    assert!(
        source_out_before || !source_out.exists(),
        "the run wrote into the source tree: {}",
        source_out.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_backend_is_refused() {
    let o = clatter(&[&"run", &"--backend", &"quantum"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("quantum") && err.contains("gpu"), "{err}");
}

/// `clatter bench --backend gpu --json` with `extra` arguments: the first row.
fn gpu_bench_row(extra: &[&str]) -> serde_json::Value {
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
        vec![&"bench", &"--backend", &"gpu", &"--pile", &"lattice"];
    args.extend(extra.iter().map(|a| a as &dyn AsRef<std::ffi::OsStr>));
    args.push(&"--json");
    let o = clatter(&args);
    assert_ok(&o, "gpu bench");
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON rows");
    rows[0].clone()
}

#[test]
fn gpu_bench_prints_the_same_table() {
    if !gpu_available() {
        return;
    }
    let row = gpu_bench_row(&["--bodies", "300", "--steps", "20", "--settle", "20"]);
    assert_eq!(row["bodies"], 300);
    assert!(row["steps_per_s"].as_f64().unwrap_or(0.0) > 0.0, "{row}");
    assert!(
        row["backend"].as_str().unwrap_or("").starts_with("gpu"),
        "{row}"
    );
}

#[test]
fn gpu_bench_profile_times_every_kernel() {
    if !gpu_available() {
        return;
    }
    // Cubes: the two-pass contact stage of polyhedron scenes.
    let row = gpu_bench_row(&[
        "--shape",
        "cube",
        "--bodies",
        "200",
        "--steps",
        "5",
        "--settle",
        "5",
        "--profile",
        "--profile-steps",
        "4",
    ]);
    let kernels = row["kernels"].as_array().expect("kernel times");
    let names: Vec<&str> = kernels.iter().filter_map(|k| k[0].as_str()).collect();
    for stage in [
        "prepare",
        "bin",
        "scan",
        "count_pairs",
        "contacts_sat",
        "contacts_full_spheres",
        "contacts_full_poly",
        "integrate",
    ] {
        assert!(names.contains(&stage), "{stage} not timed: {names:?}");
    }
    let times: Vec<f64> = kernels.iter().filter_map(|k| k[1].as_f64()).collect();
    assert_eq!(times.len(), names.len());
    assert!(times.iter().all(|&t| t >= 0.0), "{times:?}");
    assert!(times.iter().sum::<f64>() > 0.0, "{times:?}");
    // 200 cubes on a lattice: each has its upper and side neighbours as candidates.
    let pairs = row["pairs"].as_u64().expect("pair count");
    assert!((200..=200 * 13).contains(&pairs), "{pairs} pairs");
    assert!(
        row["copy_bandwidth_gb_s"].as_f64().unwrap_or(0.0) > 0.0,
        "{row}"
    );
    // What the full phase ran: no sphere bodies here, and at most every candidate pair.
    let full = &row["full_phase"];
    let count = |k: &str| full[k].as_u64().unwrap_or_else(|| panic!("{k} in {row}"));
    assert_eq!(count("with_sphere"), 0, "{row}");
    let poly = count("full_tests") + count("remembered_faces") + count("remembered_edges");
    assert!(poly <= pairs, "{poly} of {pairs} pairs in the full phase");
}

#[test]
fn profile_needs_the_gpu_backend() {
    let o = clatter(&[
        &"bench",
        &"--backend",
        &"cpu",
        &"--profile",
        &"--bodies",
        &"64",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--backend gpu"), "{err}");
}

#[test]
fn bench_times_a_scene_file_or_the_default_scene() {
    // The dice box: as many bodies as `clatter run` writes rows for.
    let dir = test_dir("backend", "bench-scene");
    let o = clatter(&[
        &"run",
        &"../../scenes/dice-box.toml",
        &"--steps",
        &"1",
        &"--quiet",
        &"--out",
        &dir,
    ]);
    assert_ok(&o, "run dice-box");
    let bodies = final_rows(&dir).len();
    for (scene, expect) in [("../../scenes/dice-box.toml", bodies), ("default", 2500)] {
        let o = clatter(&[
            &"bench",
            &"--scene",
            &scene,
            &"--steps",
            &"2",
            &"--settle",
            &"1",
            &"--json",
        ]);
        assert_ok(&o, "bench --scene");
        let rows: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON rows");
        assert_eq!(rows.as_array().map(|r| r.len()), Some(1), "{rows}");
        assert_eq!(rows[0]["bodies"], expect, "{scene}");
        assert_eq!(rows[0]["shape"], "scene");
        assert!(rows[0]["steps_per_s"].as_f64().unwrap_or(0.0) > 0.0);
    }
    let o = clatter(&[&"bench", &"--scene", &"no/such/scene.toml"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no/such/scene.toml"), "{err}");
}

/// `--pile poured` (the default) rains the bodies into the box and settles them once: the
/// second call reuses the cached pile (the file is not written again), and the rows say which
/// pile they timed, with contacts and candidate pairs per body.
#[test]
fn poured_pile_is_settled_once_and_cached() {
    let dir = test_dir("backend", "pile-cache");
    let _ = std::fs::remove_dir_all(&dir);
    let cache = dir.join("piles");
    let args: [&dyn AsRef<std::ffi::OsStr>; 14] = [
        &"bench",
        &"--pile-cache",
        &cache,
        &"--bodies",
        &"64",
        &"--shape",
        &"mixed",
        &"--steps",
        &"5",
        &"--settle",
        &"0",
        &"--backend",
        &"cpu",
        &"--json",
    ];
    let first = clatter(&args);
    assert_ok(&first, "bench poured (settle)");
    let err = String::from_utf8_lossy(&first.stderr);
    assert!(
        err.contains("poured pile: settling 64 mixed bodies"),
        "{err}"
    );
    assert!(err.contains("cached in"), "{err}");
    let files: Vec<_> = std::fs::read_dir(&cache)
        .expect("the cache directory")
        .map(|e| e.expect("entry").path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let name = files[0].file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with("mixed-n64-seed") && name.ends_with(".ckpt"),
        "{name}"
    );
    let written = std::fs::metadata(&files[0]).unwrap().modified().unwrap();
    let second = clatter(&args);
    assert_ok(&second, "bench poured (cached)");
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(err.contains("poured pile: reusing"), "{err}");
    assert!(!err.contains("settling"), "{err}");
    assert_eq!(
        std::fs::metadata(&files[0]).unwrap().modified().unwrap(),
        written,
        "the cached pile is not written again"
    );
    // The same timings from the same settled pile, and a pile in contact.
    let rows = |o: &std::process::Output| -> serde_json::Value {
        serde_json::from_slice(&o.stdout).expect("JSON rows")
    };
    let (a, b) = (rows(&first), rows(&second));
    assert_eq!(a[0]["pile"], "poured");
    assert_eq!(a[0]["contacts_per_body"], b[0]["contacts_per_body"]);
    assert!(a[0]["contacts_per_body"].as_f64().unwrap() > 1.0, "{a}");
    assert!(a[0]["pairs_per_body"].as_f64().unwrap() > 1.0, "{a}");
    // `--tiles 3`: the cached pile three times side by side, timed as one row of 192 bodies
    // in contact across the tiles' seams too (no new pile is settled or cached).
    let mut tiled_args: Vec<&dyn AsRef<std::ffi::OsStr>> = args.to_vec();
    tiled_args.extend([&"--tiles" as &dyn AsRef<std::ffi::OsStr>, &"3"]);
    let tiled = clatter(&tiled_args);
    assert_ok(&tiled, "bench poured --tiles 3");
    let t = rows(&tiled);
    assert_eq!(t[0]["bodies"], 192, "{t}");
    assert_eq!(t[0]["pile"], "poured");
    assert!(t[0]["contacts_per_body"].as_f64().unwrap() > 1.0, "{t}");
    assert_eq!(std::fs::read_dir(&cache).expect("cache").count(), 1);
    // Tiles copy a poured pile only.
    let o = clatter(&[
        &"bench",
        &"--pile",
        &"lattice",
        &"--tiles",
        &"2",
        &"--bodies",
        &"27",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--tiles"));
    // The lattice pile needs no cache.
    let o = clatter(&[
        &"bench",
        &"--pile",
        &"lattice",
        &"--bodies",
        &"27",
        &"--steps",
        &"2",
        &"--settle",
        &"0",
        &"--json",
    ]);
    assert_ok(&o, "bench lattice");
    assert_eq!(rows(&o)[0]["pile"], "lattice");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn gpu_runs_the_clumps_scene_as_the_cpu_does() {
    // Composite bodies (multi-sphere clumps, a sphere-and-cube hammer, decomposed meshes) on
    // `--backend gpu`: the same final state as the CPU's, and its checkpoint resumes on the
    // CPU.
    if !gpu_available() {
        return;
    }
    let dir = test_dir("backend", "clumps");
    let (cpu, gpu) = (dir.join("cpu"), dir.join("gpu"));
    for (backend, out) in [("cpu", &cpu), ("gpu", &gpu)] {
        let o = clatter(&[
            &"run",
            &"../../scenes/clumps.toml",
            &"--steps",
            &"400",
            &"--backend",
            &backend,
            &"--out",
            out,
            &"--checkpoint-every",
            &"0.001",
        ]);
        assert_ok(&o, backend);
    }
    let bodies = same_final_positions(&cpu, &gpu, 1e-5);
    assert!(bodies > 100, "the scene has its clumps");
    let resumed = dir.join("resumed");
    let o = clatter(&[
        &"resume",
        &gpu.join("checkpoint.ckpt"),
        &"--steps",
        &"450",
        &"--backend",
        &"cpu",
        &"--out",
        &resumed,
    ]);
    assert_ok(&o, "resume on the CPU");
    assert_eq!(final_rows(&resumed).len(), bodies);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A checkpoint written on the GPU while a ball rolls on a mesh floor resumes where the
/// uninterrupted GPU run goes, and the run's summary counts that mesh contact: the run
/// loop's read-back brought the contact list back but not the mesh contact slots, so the
/// checkpoint lost the contact's friction spring and `summary.json` said 0 contacts.
#[test]
fn a_gpu_checkpoint_keeps_its_mesh_contacts() {
    if !gpu_available() {
        return;
    }
    let dir = test_dir("backend", "gpu-mesh-ckpt");
    std::fs::write(
        dir.join("floor.obj"),
        "v -0.2 -0.2 0\nv 0.2 -0.2 0\nv 0.2 0.2 0\nv -0.2 0.2 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let scene = dir.join("drop.toml");
    std::fs::write(
        &scene,
        r#"[simulation]
steps = 60
dt = 5.0e-5
[[material]]
name = "m"
density = 1000.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.5
[[shape]]
name = "ball"
sphere = { radius = 0.005 }
[[boundary]]
mesh = { file = "floor.obj" }
material = "m"
[[body]]
shape = "ball"
material = "m"
position = [0.07, 0.01, 0.0053]
velocity = [0.3, 0.0, -0.6]
"#,
    )
    .unwrap();
    let (straight, half, resumed) = (dir.join("straight"), dir.join("half"), dir.join("resumed"));
    let gpu = ["--backend", "gpu", "--quiet"];
    let o = clatter(&[
        &"run", &scene, &"--out", &straight, &gpu[0], &gpu[1], &gpu[2],
    ]);
    assert_ok(&o, "the straight GPU run");
    let o = clatter(&[
        &"run",
        &scene,
        &"--steps",
        &"20",
        &"--checkpoint-every",
        &"1",
        &"--out",
        &half,
        &gpu[0],
        &gpu[1],
        &gpu[2],
    ]);
    assert_ok(&o, "the first 20 steps");
    let half_summary = summary(&half);
    assert_eq!(
        half_summary["contacts"].as_u64(),
        Some(1),
        "the ball on the mesh: {half_summary}"
    );
    let o = clatter(&[
        &"resume",
        &half.join("checkpoint.ckpt"),
        &"--steps",
        &"40",
        &"--out",
        &resumed,
        &gpu[0],
        &gpu[1],
        &gpu[2],
    ]);
    assert_ok(&o, "resume on the GPU");
    assert_eq!(
        std::fs::read(straight.join("final.csv")).unwrap(),
        std::fs::read(resumed.join("final.csv")).unwrap(),
        "the resumed GPU run ends where the straight one does"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A first pair list larger than the GPU's initial pair buffers (48 spheres within a 5 cm
/// skin: ~1,100 candidate pairs) grows them and runs the stopped rebuild again: that is one
/// rebuild, as on the CPU (the run again counted a second one).
#[test]
fn a_growing_gpu_pair_list_counts_one_rebuild() {
    if !gpu_available() {
        return;
    }
    let dir = test_dir("backend", "gpu-grow");
    let scene = dir.join("skin.toml");
    std::fs::write(
        &scene,
        r#"[simulation]
steps = 3
dt = 1e-5
gravity = [0, 0, 0]
skin = 0.05
[[material]]
name = "m"
density = 1000.0
stiffness = 1e4
[[shape]]
name = "b"
sphere = { radius = 0.004 }
[[group]]
shape = "b"
material = "m"
lattice = { min = [0, 0, 0], max = [0.0255, 0.0255, 0.017], spacing = 0.0085 }
"#,
    )
    .unwrap();
    let mut rebuilds = Vec::new();
    for backend in ["cpu", "gpu"] {
        let out = dir.join(backend);
        let o = clatter(&[
            &"run",
            &scene,
            &"--backend",
            &backend,
            &"--out",
            &out,
            &"--quiet",
        ]);
        assert_ok(&o, backend);
        rebuilds.push(summary(&out)["broad_phase_rebuilds"].as_u64());
    }
    assert_eq!(rebuilds, [Some(1), Some(1)], "cpu, gpu");
    let _ = std::fs::remove_dir_all(&dir);
}
