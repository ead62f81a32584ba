//! `mpirun -np N clatter run` and `resume` (docs/parallel.md): final.csv, energy.csv and
//! discharge.csv byte for byte the one-process run's on 1, 2 and 3 ranks, for the default
//! scene, a sphere pile, a scene with a sink, a periodic scene and a mesh boundary; a
//! checkpoint written on 3 ranks byte for byte one process's, resumed on 2 ranks and on one
//! process; every output file (frames, VTK, contacts) one process's; blow-ups stopped as one
//! process stops them; `clatter bench` on 2 and 3 ranks timing the same steps as one process
//! (the same rows but for the timings); `clatter validate --only pile` on 1, 2 and 3 ranks
//! with one process's row, validation.json and plot; bad rank counts and a build without
//! MPI give errors, not hangs.
//!
//! The runs under mpirun need the binary built with the feature:
//! `cargo test --release -p clatter-cli --features mpi --test mpi`. Without it they are
//! skipped, loudly; the decomposition itself is tested without MPI by
//! `crates/clatter/tests/domain.rs`.

#[cfg(feature = "mpi")]
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

#[cfg(feature = "mpi")]
mod bench;
#[path = "../common/mod.rs"]
mod common;
use common::text;
#[cfg(feature = "mpi")]
use common::{assert_ok, clatter};

#[cfg(feature = "mpi")]
fn test_dir(name: &str) -> PathBuf {
    common::test_dir("mpi", name)
}

/// A command's output, killed after `limit` (a hang is a failure, not a stuck test).
fn output_within(mut cmd: Command, limit: Duration) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the command");
    let started = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("collect the output");
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let o = child.wait_with_output().expect("collect the output");
            panic!("still running after {limit:?} (a hang?):\n{}", text(&o));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Started as if by `mpirun -np 3` (Open MPI's variable), a build without the feature stops
/// at once with an error instead of running the scene (or the benchmark) three times.
#[cfg(not(feature = "mpi"))]
#[test]
fn several_ranks_without_the_feature_is_an_error() {
    let cases: [&[&str]; 3] = [
        &["run", "--steps", "1", "--quiet"],
        &[
            "bench", "--pile", "lattice", "--bodies", "64", "--steps", "1",
        ],
        &["validate", "--only", "pile", "--quick"],
    ];
    for args in cases {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_clatter"));
        cmd.args(args).env("OMPI_COMM_WORLD_SIZE", "3");
        let o = output_within(cmd, Duration::from_secs(60));
        assert!(!o.status.success(), "{args:?}: {}", text(&o));
        assert!(
            String::from_utf8_lossy(&o.stderr).contains("built without MPI"),
            "{args:?}: {}",
            text(&o)
        );
    }
}

/// Listed as ignored, with the reason, in every `cargo test` without the feature.
#[cfg(not(feature = "mpi"))]
#[test]
#[ignore = "SKIPPED: the runs under mpirun (1, 2, 3 ranks bitwise equal to one process) need `cargo test --release -p clatter-cli --features mpi --test mpi`"]
fn runs_under_mpirun_need_the_mpi_feature() {}

/// 300 spheres poured into a narrow box with a push sideways: they cross the rank
/// boundaries (the first cut is across the box's long axis, x) many times.
#[cfg(feature = "mpi")]
const SPHERE_PILE: &str = r#"[simulation]
steps = 6000
dt = 2.0e-5
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "m"
density = 1000.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.5

[container]
min = [0.0, 0.0, 0.0]
max = [0.3, 0.05, 0.2]
material = "m"

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[group]]
shape = "ball"
material = "m"
random = { min = [0.01, 0.01, 0.01], max = [0.29, 0.04, 0.19], count = 300, seed = 7 }
velocity = [1.5, 0.0, -0.5]
"#;

/// `mpirun` with what it needs here: `--oversubscribe` (2 cores), and leave to run as root
/// (containers).
#[cfg(feature = "mpi")]
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    mpirun_with(ranks, &[], args)
}

/// [`mpirun`] with environment variables set on every rank (`-x NAME=VALUE`, Open MPI's).
///
/// Each launch gets a session directory of its own (`orte_tmpdir_base`, removed after):
/// Open MPI's default, `/tmp/ompi.<host>.<uid>`, is shared by every job of the user, and a
/// job ending while another starts can remove it from under the other
/// (open-mpi/ompi#8510), which then exits non-zero; this suite runs its tests, and so its
/// launches, in parallel (and other suites may run beside it).
#[cfg(feature = "mpi")]
fn mpirun_with(ranks: usize, env: &[(&str, &str)], args: &[&str]) -> Output {
    static LAUNCHES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = LAUNCHES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let session = std::env::temp_dir().join(format!("ompi-t{}-{n}", std::process::id()));
    std::fs::create_dir_all(&session).expect("create the session directory");
    let mut cmd = Command::new("mpirun");
    cmd.arg("--mca").arg("orte_tmpdir_base").arg(&session);
    for (name, value) in env {
        cmd.arg("-x").arg(format!("{name}={value}"));
    }
    cmd.args(["--oversubscribe", "-np", &ranks.to_string()])
        .arg(env!("CARGO_BIN_EXE_clatter"))
        .args(args)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1");
    let out = output_within(cmd, Duration::from_secs(600));
    let _ = std::fs::remove_dir_all(&session);
    out
}

/// Whether mpirun is on the PATH: a build with the feature is meant to be tested under it,
/// so its absence fails the test.
#[cfg(feature = "mpi")]
fn have_mpirun() -> bool {
    let ok = Command::new("mpirun")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "built with --features mpi but mpirun is not on the PATH (apt-get install openmpi-bin)"
    );
    ok
}

#[cfg(feature = "mpi")]
fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()))
}

/// The example scene `name` of the repository's `scenes/`.
#[cfg(feature = "mpi")]
fn scene_file(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

/// `scene` (None: the default scene) for `steps` steps on one process, then on 1, 2 and 3
/// ranks: final.csv, energy.csv (and discharge.csv) byte for byte the same, and the
/// summary's contacts, rebuilds and energies.
#[cfg(feature = "mpi")]
fn bitwise_on_ranks(name: &str, scene: Option<&Path>, steps: &str) {
    let dir = test_dir(name);
    let reference = dir.join("one");
    let mut args: Vec<String> = Vec::new();
    if let Some(s) = scene {
        args.push(s.display().to_string());
    }
    args.extend(["--steps", steps, "--quiet"].map(String::from));
    let mut one: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"run", &"--backend", &"cpu"];
    one.extend(args.iter().map(|a| a as &dyn AsRef<std::ffi::OsStr>));
    one.extend([&"--out" as &dyn AsRef<std::ffi::OsStr>, &reference]);
    assert_ok(&clatter(&one), "the run without MPI");
    let want = read(&reference.join("final.csv"));
    let want_summary: serde_json::Value =
        serde_json::from_str(&read(&reference.join("summary.json"))).expect("summary");
    for ranks in 1..=3 {
        let out = dir.join(format!("ranks{ranks}"));
        let mut a: Vec<&str> = vec!["run"];
        a.extend(args.iter().map(String::as_str));
        let out_s = out.display().to_string();
        a.extend(["--out", &out_s]);
        // 3 ranks with the ghost states' exchange overlapped (`CLATTER_MPI_OVERLAP=1`), 1
        // and 2 with the default, blocking exchange: both bitwise one process.
        let env: &[(&str, &str)] = if ranks == 3 {
            &[("CLATTER_MPI_OVERLAP", "1")]
        } else {
            &[]
        };
        let o = mpirun_with(ranks, env, &a);
        assert_ok(&o, &format!("{name} on {ranks} ranks"));
        for file in ["energy.csv", "discharge.csv"] {
            let one = reference.join(file);
            if one.exists() {
                assert!(
                    read(&out.join(file)) == read(&one),
                    "{name} on {ranks} ranks: {file} differs from one process's"
                );
            }
        }
        let got = read(&out.join("final.csv"));
        if got != want {
            let line = got
                .lines()
                .zip(want.lines())
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            panic!(
                "{name} on {ranks} ranks: final.csv differs from one process, first at line {}:\n  mpi: {}\n  one: {}",
                line + 1,
                got.lines().nth(line).unwrap_or(""),
                want.lines().nth(line).unwrap_or("")
            );
        }
        let summary: serde_json::Value =
            serde_json::from_str(&read(&out.join("summary.json"))).expect("summary");
        for key in [
            "step",
            "contacts",
            "max_contacts",
            "broad_phase_rebuilds",
            "kinetic_energy",
            "potential_energy",
            "momentum",
        ] {
            assert_eq!(
                summary[key], want_summary[key],
                "{name} on {ranks} ranks: summary {key}"
            );
        }
        assert_eq!(summary["ranks"], ranks, "{name}: ranks in the summary");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(feature = "mpi")]
#[test]
fn default_scene_on_1_2_3_ranks_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks("default", None, "200");
    }
}

#[cfg(feature = "mpi")]
#[test]
fn sphere_pile_on_1_2_3_ranks_is_bitwise_one_process() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("pile-scene");
    let scene = dir.join("pile.toml");
    std::fs::write(&scene, SPHERE_PILE).expect("write the scene");
    bitwise_on_ranks("pile", Some(&scene), "6000");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Messages over the transport's limit go in pieces (MPI counts are `int`: a message of 2
/// GiB or more is split): with the limit lowered to 4 KiB (`CLATTER_MPI_MESSAGE_LIMIT`), the
/// sphere pile on 3 ranks, whose first distribution, ghost exchanges and gathers then all
/// take several pieces or rounds, still ends bitwise as one process's (final.csv,
/// energy.csv), and so does a checkpoint broadcast in pieces and resumed on 2 ranks.
#[cfg(feature = "mpi")]
#[test]
fn messages_over_the_limit_are_split_bitwise() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("limit");
    let scene = dir.join("pile.toml");
    std::fs::write(&scene, SPHERE_PILE).expect("write the scene");
    let s = scene.display().to_string();
    let one = dir.join("one");
    let one_s = one.display().to_string();
    let o = clatter(&[
        &"run",
        &s,
        &"--steps",
        &"1500",
        &"--quiet",
        &"--backend",
        &"cpu",
        &"--out",
        &one_s,
    ]);
    assert_ok(&o, "the run without MPI");
    let limited = [("CLATTER_MPI_MESSAGE_LIMIT", "4096")];
    let out = dir.join("ranks3");
    let out_s = out.display().to_string();
    let a = [
        "run",
        &s,
        "--steps",
        "1500",
        "--quiet",
        "--out",
        &out_s,
        "--checkpoint-every",
        "0.01",
    ];
    let o = mpirun_with(3, &limited, &a);
    assert_ok(&o, "3 ranks under a 4 KiB limit");
    for file in ["final.csv", "energy.csv"] {
        assert!(
            read(&out.join(file)) == read(&one.join(file)),
            "{file} under a 4 KiB limit differs from one process's"
        );
    }
    let ckpt = out.join("checkpoint.ckpt");
    let resumed = dir.join("resumed");
    let resumed_s = resumed.display().to_string();
    let ckpt_s = ckpt.display().to_string();
    let o = mpirun_with(
        2,
        &limited,
        &[
            "resume", &ckpt_s, "--steps", "300", "--quiet", "--out", &resumed_s,
        ],
    );
    assert_ok(&o, "resumed on 2 ranks under a 4 KiB limit");
    let o = clatter(&[
        &"run",
        &s,
        &"--steps",
        &"1800",
        &"--quiet",
        &"--backend",
        &"cpu",
        &"--out",
        &one_s,
    ]);
    assert_ok(&o, "the longer run without MPI");
    assert!(
        read(&resumed.join("final.csv")) == read(&one.join("final.csv")),
        "resumed under a 4 KiB limit: final.csv differs from one process's"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Sinks: discharge.csv as well (`scenes/sink-floor.toml`, 30 of 50 spheres removed).
#[cfg(feature = "mpi")]
#[test]
fn sink_scene_on_1_2_3_ranks_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks("sink", Some(&scene_file("sink-floor.toml")), "4000");
    }
}

/// Periodic boundaries in x and y (`scenes/periodic-floor.toml`): ghosts across the seam.
#[cfg(feature = "mpi")]
#[test]
fn periodic_scene_on_1_2_3_ranks_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks(
            "periodic",
            Some(&scene_file("periodic-floor.toml")),
            "20000",
        );
    }
}

/// A mesh boundary (`scenes/mesh-floor.toml`): mesh contact slots moved with the bodies.
#[cfg(feature = "mpi")]
#[test]
fn mesh_scene_on_1_2_3_ranks_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks("mesh", Some(&scene_file("mesh-floor.toml")), "3000");
    }
}

/// Composites (`scenes/clumps.toml`: clumps of spheres and convex pieces, 210 bodies): each
/// piece pair's contact and spring moved with its bodies between ranks.
#[cfg(feature = "mpi")]
#[test]
fn composite_scene_on_1_2_3_ranks_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks("clumps", Some(&scene_file("clumps.toml")), "1500");
    }
}

/// A moving mesh boundary (`scenes/drum.toml`: 2,352 beads poured into a drum that starts
/// turning at step 8,000): the mesh's pose stepped alike on every rank, its contact slots
/// moved with the bodies.
#[cfg(feature = "mpi")]
#[test]
fn moving_mesh_scene_on_1_2_3_ranks_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks("drum", Some(&scene_file("drum.toml")), "9000");
    }
}

/// More ranks than bodies (`scenes/cube-on-floor.toml`, 2 bodies, and
/// `scenes/bouncing-ball.toml`, 1): the ranks beyond the bodies own empty boxes and the run
/// is one process's, bitwise.
#[cfg(feature = "mpi")]
#[test]
fn more_ranks_than_bodies_is_bitwise_one_process() {
    if have_mpirun() {
        bitwise_on_ranks("few-cube", Some(&scene_file("cube-on-floor.toml")), "3000");
        bitwise_on_ranks("few-ball", Some(&scene_file("bouncing-ball.toml")), "3000");
    }
}

/// Every file of a run with every output (trace.csv, VTK bodies, shapes, boundaries and
/// contacts frames, energy.csv, checkpoint.ckpt, final.csv) is one process's, byte for byte,
/// on 3 ranks (`scenes/mesh-floor.toml`: mesh contacts in the contact frames too).
#[cfg(feature = "mpi")]
#[test]
fn every_output_file_on_3_ranks_is_one_process_file() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("outputs");
    let scene = scene_file("mesh-floor.toml");
    let (one, three) = (dir.join("one"), dir.join("three"));
    let s = scene.display().to_string();
    let outputs = [
        "--steps",
        "2000",
        "--format",
        "csv,vtk",
        "--output-every",
        "500",
        "--contacts",
        "--checkpoint-every",
        "0.02",
        "--quiet",
    ];
    let mut a: Vec<&dyn AsRef<std::ffi::OsStr>> =
        vec![&"run", &scene, &"--backend", &"cpu", &"--out", &one];
    a.extend(outputs.iter().map(|x| x as &dyn AsRef<std::ffi::OsStr>));
    assert_ok(&clatter(&a), "one process");
    let t = three.display().to_string();
    let mut m = vec!["run", &s, "--out", &t];
    m.extend(outputs);
    assert_ok(&mpirun(3, &m), "3 ranks");
    let names = common::names(&one);
    assert_eq!(names, common::names(&three), "the same files");
    assert!(
        names.iter().any(|n| n.starts_with("contacts_")),
        "{names:?}"
    );
    for name in names.iter().filter(|n| *n != "summary.json") {
        assert!(
            std::fs::read(one.join(name)).expect("one process's file")
                == std::fs::read(three.join(name)).expect("3 ranks' file"),
            "{name} differs"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A checkpoint written on 3 ranks is byte for byte one process's; resumed on 2 ranks and
/// on one process (no MPI), it ends as the uninterrupted one-process run.
#[cfg(feature = "mpi")]
#[test]
fn checkpoint_on_3_ranks_resumes_on_2_and_on_one_process_bitwise() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("checkpoint");
    let scene = dir.join("pile.toml");
    std::fs::write(&scene, SPHERE_PILE).expect("write the scene");
    let (one, three, whole, two, alone) = (
        dir.join("one"),
        dir.join("three"),
        dir.join("whole"),
        dir.join("two"),
        dir.join("alone"),
    );
    let every = ["--checkpoint-every", "0.01", "--quiet"];
    let mut a: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![
        &"run",
        &scene,
        &"--backend",
        &"cpu",
        &"--steps",
        &"2900",
        &"--out",
        &one,
    ];
    a.extend(every.iter().map(|s| s as &dyn AsRef<std::ffi::OsStr>));
    assert_ok(&clatter(&a), "one process to step 2900");
    let s = scene.display().to_string();
    let t = three.display().to_string();
    let mut m = vec!["run", &s, "--steps", "2900", "--out", &t];
    m.extend(every);
    assert_ok(&mpirun(3, &m), "3 ranks to step 2900");
    assert!(
        std::fs::read(one.join("checkpoint.ckpt")).expect("one process's checkpoint")
            == std::fs::read(three.join("checkpoint.ckpt")).expect("3 ranks' checkpoint"),
        "the checkpoint written on 3 ranks differs from one process's"
    );
    let a: [&dyn AsRef<std::ffi::OsStr>; 9] = [
        &"run",
        &scene,
        &"--backend",
        &"cpu",
        &"--steps",
        &"4500",
        &"--quiet",
        &"--out",
        &whole,
    ];
    assert_ok(&clatter(&a), "one process to step 4500");
    let ckpt = three.join("checkpoint.ckpt").display().to_string();
    let t2 = two.display().to_string();
    let o = mpirun(
        2,
        &["resume", &ckpt, "--steps", "1600", "--quiet", "--out", &t2],
    );
    assert_ok(&o, "resumed on 2 ranks");
    let a: [&dyn AsRef<std::ffi::OsStr>; 9] = [
        &"resume",
        &ckpt,
        &"--backend",
        &"cpu",
        &"--steps",
        &"1600",
        &"--quiet",
        &"--out",
        &alone,
    ];
    assert_ok(&clatter(&a), "resumed on one process");
    let want = read(&whole.join("final.csv"));
    assert!(
        read(&two.join("final.csv")) == want,
        "resumed on 2 ranks: final.csv differs"
    );
    assert!(
        read(&alone.join("final.csv")) == want,
        "resumed on one process: final.csv differs"
    );
    let summary = |d: &Path| -> serde_json::Value {
        serde_json::from_str(&read(&d.join("summary.json"))).expect("summary")
    };
    assert_eq!(
        summary(&two)["max_contacts"],
        summary(&alone)["max_contacts"],
        "resumed on 2 ranks: max_contacts"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Blow-ups: a time step far above the stability bound (the energy check, on the gathered
/// world) and an absurd one (a non-finite state, named by its lowest scene id): on 2 ranks,
/// the same message, exit status 3, last_good.ckpt and energy.csv as one process.
#[cfg(feature = "mpi")]
#[test]
fn blow_ups_stop_every_rank_as_one_process_stops() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("blow-up");
    for (name, dt) in [("energy", "1.5e-3"), ("nan", "1.0e30")] {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(
            &scene,
            SPHERE_PILE.replace("dt = 2.0e-5", &format!("dt = {dt}")),
        )
        .expect("write the scene");
        let (one, two) = (
            dir.join(format!("{name}-one")),
            dir.join(format!("{name}-two")),
        );
        let a: [&dyn AsRef<std::ffi::OsStr>; 7] = [
            &"run",
            &scene,
            &"--backend",
            &"cpu",
            &"--quiet",
            &"--out",
            &one,
        ];
        let o1 = clatter(&a);
        let (s, t) = (scene.display().to_string(), two.display().to_string());
        let o2 = mpirun(2, &["run", &s, "--quiet", "--out", &t]);
        assert_eq!(
            o1.status.code(),
            Some(3),
            "{name}: one process\n{}",
            text(&o1)
        );
        assert_eq!(o2.status.code(), Some(3), "{name}: 2 ranks\n{}", text(&o2));
        let error = |o: &Output| {
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .find(|l| l.starts_with("error:"))
                .map(String::from)
        };
        assert!(error(&o1).is_some(), "{name}: {}", text(&o1));
        assert_eq!(error(&o1), error(&o2), "{name}: the same message");
        for file in ["last_good.ckpt", "energy.csv"] {
            assert!(
                std::fs::read(one.join(file)).expect("one process's file")
                    == std::fs::read(two.join(file)).expect("2 ranks' file"),
                "{name}: {file} differs"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A blow-up found by a rank other than 0: a sphere shot at the +x wall from the far end of
/// a pile (x = 0.25 m, where the pile ends at 0.2 m; on 3 ranks the first cut is at the 2/3
/// quantile of x, so rank 2 owns it) overlaps the wall by most of its radius about 280
/// steps in, past two full checks (so the last good state is the ranks' kept shares, not
/// the start). On 3 ranks: one process's message (naming that body and wall, with the cause
/// found from its state on its rank), exit status 3, last_good.ckpt and energy.csv.
#[cfg(feature = "mpi")]
#[test]
fn blow_up_on_a_body_of_rank_2_is_one_process_blow_up() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("blow-up-rank-2");
    let scene = dir.join("shot.toml");
    let shot = SPHERE_PILE.replace("max = [0.29, 0.04, 0.19]", "max = [0.2, 0.04, 0.19]")
        + "\n[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.25, 0.025, 0.15]\nvelocity = [8.0, 0.0, 0.0]\n";
    std::fs::write(&scene, shot).expect("write the scene");
    let (one, three) = (dir.join("one"), dir.join("three"));
    let s = scene.display().to_string();
    let (o, t) = (one.display().to_string(), three.display().to_string());
    let o1 = clatter(&[&"run", &s, &"--backend", &"cpu", &"--quiet", &"--out", &o]);
    let o3 = mpirun(3, &["run", &s, "--quiet", "--out", &t]);
    assert_eq!(o1.status.code(), Some(3), "one process\n{}", text(&o1));
    assert_eq!(o3.status.code(), Some(3), "3 ranks\n{}", text(&o3));
    let error = |o: &Output| {
        String::from_utf8_lossy(&o.stderr)
            .lines()
            .find(|l| l.starts_with("error:"))
            .map(String::from)
    };
    let message = error(&o1).unwrap_or_default();
    assert!(
        message.contains("body 0 and wall 1 overlap"),
        "the shot sphere (body 0: `[[body]]`s come before groups) on the +x wall: {message}"
    );
    assert_eq!(error(&o1), error(&o3), "the same message");
    let stderr = String::from_utf8_lossy(&o3.stderr);
    assert!(
        stderr.contains("the last good state (step 300,"),
        "kept at the full check of step 300: {stderr}"
    );
    for file in ["last_good.ckpt", "energy.csv"] {
        assert!(
            std::fs::read(one.join(file)).expect("one process's file")
                == std::fs::read(three.join(file)).expect("3 ranks' file"),
            "{file} differs"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// More ranks than bodies, a missing scene file and options not carried yet: one clear
/// error (from rank 0), every rank stopped, no hang.
#[cfg(feature = "mpi")]
#[test]
fn bad_rank_counts_and_arguments_are_errors() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("errors");
    let scene = dir.join("two.toml");
    std::fs::write(
        &scene,
        "[simulation]\nsteps = 10\n\
         [[material]]\nname = \"m\"\ndensity = 1000.0\nstiffness = 2.0e3\nrestitution = 0.5\nfriction = 0.5\n\
         [[shape]]\nname = \"b\"\nsphere = { radius = 0.01 }\n\
         [[body]]\nshape = \"b\"\nmaterial = \"m\"\nposition = [0.0, 0.0, 0.0]\n\
         [[body]]\nshape = \"b\"\nmaterial = \"m\"\nposition = [0.1, 0.0, 0.0]\n",
    )
    .expect("write the scene");
    let s = scene.display().to_string();
    let cases: [(Vec<&str>, &str); 2] = [
        (vec!["run", "no-such-scene.toml"], "no-such-scene.toml"),
        (
            vec!["run", &s, "--backend", "gpu"],
            "runs on several MPI ranks use the CPU pipeline",
        ),
    ];
    for (args, message) in cases {
        let o = mpirun(3, &args);
        assert!(!o.status.success(), "{args:?} should fail:\n{}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(message),
            "{args:?}: want {message:?}:\n{}",
            text(&o)
        );
        assert_eq!(
            err.matches("error:").count(),
            1,
            "{args:?}: one message, from rank 0:\n{}",
            text(&o)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
