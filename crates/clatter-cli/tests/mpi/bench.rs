//! `mpirun -np N clatter bench` and `clatter validate --only pile` on ranks: the same rows as
//! one process.

use super::*;

/// `clatter bench --json` rows without what depends on the clock and the rank count.
#[cfg(feature = "mpi")]
fn bench_rows(o: &Output, what: &str) -> Vec<serde_json::Value> {
    assert_ok(o, what);
    let rows: Vec<serde_json::Value> =
        serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{what}: {e}:\n{}", text(o)));
    rows.into_iter()
        .map(|mut r| {
            let m = r.as_object_mut().expect("a row is an object");
            for k in [
                "steps_per_s",
                "body_steps_per_s",
                "ms_per_step",
                "ranks",
                "backend",
            ] {
                assert!(m.remove(k).is_some(), "{what}: no {k} in the row");
            }
            r
        })
        .collect()
}

/// `mpirun -np N clatter bench`: a poured pile (settled and cached by one process, then
/// taken from the cache and split between the ranks with its contact list) and a lattice
/// (distributed at its first rebuild), timed on 2 and 3 ranks: the same rows as one process
/// (contacts and pairs per body, rebuilds, the pile's kinetic energy after the timed steps,
/// bitwise), `--emit-lammps` writing one process's files, one table printed; and the refusals (the GPU backend, --render), one message each.
#[cfg(feature = "mpi")]
#[test]
fn bench_on_2_and_3_ranks_times_the_steps_one_process_times() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("bench");
    let cache = dir.join("piles").display().to_string();
    let cases: [&[&str]; 2] = [
        &["--bodies", "256,300", "--settle", "200", "--steps", "300"],
        &[
            "--pile", "lattice", "--shape", "mixed", "--bodies", "200", "--settle", "300",
            "--steps", "200",
        ],
    ];
    for case in cases {
        let mut args = vec!["bench", "--json", "--threads", "1", "--pile-cache", &cache];
        args.extend(case);
        let a: Vec<&dyn AsRef<std::ffi::OsStr>> = args
            .iter()
            .map(|s| s as &dyn AsRef<std::ffi::OsStr>)
            .collect();
        let one = bench_rows(&clatter(&a), "bench on one process");
        assert_eq!(one.len(), case[1].split(',').count(), "{case:?}");
        for ranks in [2, 3] {
            // 3 ranks with the exchange overlapped, 2 with the default blocking one.
            let env: &[(&str, &str)] = if ranks == 3 {
                &[("CLATTER_MPI_OVERLAP", "1")]
            } else {
                &[]
            };
            let got = bench_rows(
                &mpirun_with(ranks, env, &args),
                &format!("bench on {ranks} ranks"),
            );
            assert_eq!(got, one, "{case:?} on {ranks} ranks");
        }
    }
    // --emit-lammps: rank 0 writes the gathered pile, one process's bytes.
    let emitted = |d: &Path| {
        ["pile.data", "in.pile"].map(|f| std::fs::read(d.join(f)).expect("an emitted file"))
    };
    let (e1, e2) = (dir.join("emit1"), dir.join("emit2"));
    let emit = |d: &Path| {
        let d = d.display().to_string();
        let args = [
            "bench",
            "--bodies",
            "256",
            "--settle",
            "50",
            "--steps",
            "10",
            "--pile-cache",
            &cache,
            "--emit-lammps",
            &d,
        ];
        args.map(String::from)
    };
    let a = emit(&e1);
    let a: Vec<&dyn AsRef<std::ffi::OsStr>> =
        a.iter().map(|s| s as &dyn AsRef<std::ffi::OsStr>).collect();
    assert_ok(&clatter(&a), "--emit-lammps on one process");
    let a = emit(&e2);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    assert_ok(&mpirun(2, &a), "--emit-lammps on 2 ranks");
    assert!(
        emitted(&e1) == emitted(&e2),
        "--emit-lammps on 2 ranks differs"
    );
    // The table: printed once, by rank 0.
    let o = mpirun_with(
        2,
        &[("CLATTER_MPI_OVERLAP", "1")],
        &[
            "bench", "--pile", "lattice", "--bodies", "300", "--settle", "10", "--steps", "10",
        ],
    );
    assert_ok(&o, "the table on 2 ranks");
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.matches("# clatter bench").count(), 1, "{}", text(&o));
    assert!(out.contains("2 MPI ranks x"), "{}", text(&o));
    assert!(out.contains("cpu on 2 MPI ranks"), "{}", text(&o));
    // Each rank's time split: one line, one number per rank in each list; the work and the
    // collectives add up to the rank's own steps.
    let err = String::from_utf8_lossy(&o.stderr);
    let split: Vec<&str> = err
        .lines()
        .filter_map(|l| l.strip_prefix("# per rank, ms per timed step: "))
        .collect();
    assert_eq!(split.len(), 1, "{}", text(&o));
    // A line's lists of numbers, one list per "; "-separated part.
    let numbers = |line: &str| -> Vec<Vec<f64>> {
        let numbers = |part: &str| {
            part.split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect()
        };
        line.split("; ").map(numbers).collect()
    };
    let lists = numbers(split[0]);
    assert_eq!(lists.len(), 6, "{}", split[0]);
    assert!(lists.iter().all(|l| l.len() == 2), "{}", split[0]);
    for r in 0..2 {
        let own = lists[0][r];
        assert!(own > 0.0, "{}", split[0]);
        let parts: f64 = lists[1..5].iter().map(|l| l[r]).sum();
        assert!((parts - own).abs() <= 0.005, "rank {r}: {}", split[0]);
        assert!(lists[1..].iter().all(|l| l[r] >= -0.0005), "{}", split[0]);
        // The work overlapped with the ghost states is part of the work.
        assert!(lists[5][r] <= lists[1][r] + 0.0005, "{}", split[0]);
    }
    // The overlap ran (`CLATTER_MPI_OVERLAP=1`): most steps overlapped on each rank, some pairs
    // computed while the states travelled.
    let overlap: Vec<&str> = err
        .lines()
        .filter_map(|l| l.strip_prefix("# per rank, overlap of the ghost states (on): "))
        .collect();
    assert_eq!(overlap.len(), 1, "{}", text(&o));
    let counts = numbers(overlap[0]);
    assert_eq!(counts.len(), 4, "{}", overlap[0]);
    assert!(counts[0].iter().all(|&s| s > 0.0), "{}", overlap[0]);
    assert!(
        counts[3].iter().all(|&p| (0.0..=100.0).contains(&p)),
        "{}",
        overlap[0]
    );
    for (extra, message) in [
        ("--backend=gpu", "times the CPU pipeline"),
        ("--render", "run `clatter bench` without mpirun"),
    ] {
        let o = mpirun(2, &["bench", "--bodies", "300", "--pile", "lattice", extra]);
        assert!(!o.status.success(), "{extra} should fail:\n{}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(message),
            "{extra}: want {message:?}:\n{}",
            text(&o)
        );
        assert_eq!(
            err.matches("error:").count(),
            1,
            "{extra}: one message:\n{}",
            text(&o)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `validation.json` without what names the rank count (`backend`, `ranks`).
#[cfg(feature = "mpi")]
fn validation_rows(dir: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&read(&dir.join("validation.json"))).expect("validation.json");
    let o = v.as_object_mut().expect("an object");
    o.remove("backend");
    o.remove("ranks");
    v
}

/// `mpirun -np N clatter validate --only pile` (the poured pile, its 490 spheres falling
/// through the rank boundaries) on 1, 2 and 3 ranks: the same table row, `validation.json`
/// (the measured packing fraction to the bit) and kinetic-energy plot as one process, the
/// table printed once; the checks too small to split are refused with one error.
#[cfg(feature = "mpi")]
#[test]
fn validate_only_pile_on_1_2_3_ranks_is_one_process_validation() {
    if !have_mpirun() {
        return;
    }
    let dir = test_dir("validate");
    let one = dir.join("one");
    let one_s = one.display().to_string();
    let args = ["validate", "--only", "pile", "--quick", "--quiet", "--out"];
    let mut a: Vec<&str> = args.to_vec();
    a.extend([one_s.as_str(), "--backend", "cpu"]);
    let a: Vec<&dyn AsRef<std::ffi::OsStr>> = a.iter().map(|s| s as _).collect();
    let o = clatter(&a);
    assert_ok(&o, "validate --only pile without MPI");
    let row = |o: &Output| -> String {
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        let rows: Vec<&str> = out
            .lines()
            .filter(|l| l.starts_with("poured-pile"))
            .collect();
        assert_eq!(rows.len(), 1, "one table row:\n{}", text(o));
        rows[0].to_string()
    };
    let want_row = row(&o);
    assert!(want_row.ends_with("pass"), "{want_row}");
    let want = validation_rows(&one);
    assert_eq!(want["rows_total"], 1);
    for ranks in 1..=3 {
        let out = dir.join(format!("ranks{ranks}"));
        let out_s = out.display().to_string();
        let mut a: Vec<&str> = args.to_vec();
        a.push(&out_s);
        let o = mpirun(ranks, &a);
        assert_ok(&o, &format!("validate --only pile on {ranks} ranks"));
        assert_eq!(row(&o), want_row, "the row on {ranks} ranks");
        assert_eq!(
            String::from_utf8_lossy(&o.stdout)
                .matches("validation passed")
                .count(),
            1,
            "one verdict:\n{}",
            text(&o)
        );
        assert_eq!(
            validation_rows(&out),
            want,
            "validation.json on {ranks} ranks"
        );
        let json: serde_json::Value =
            serde_json::from_str(&read(&out.join("validation.json"))).expect("json");
        assert_eq!(json["ranks"], ranks);
        assert!(
            std::fs::read(out.join("poured-pile.svg")).ok()
                == std::fs::read(one.join("poured-pile.svg")).ok(),
            "the kinetic energy plot on {ranks} ranks differs from one process's"
        );
    }
    for (extra, message) in [
        (vec!["--quick"], "runs only poured-pile (`--only pile`)"),
        (
            vec!["--only", "pile,chung-ooi-1"],
            "chung-ooi-1 has one to a few dozen bodies",
        ),
        (
            vec!["--only", "pile", "--backend", "gpu"],
            "uses the CPU pipeline",
        ),
    ] {
        let mut a = vec!["validate"];
        a.extend(&extra);
        let o = mpirun(2, &a);
        assert!(!o.status.success(), "{extra:?} should fail:\n{}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(message),
            "{extra:?}: want {message:?}:\n{}",
            text(&o)
        );
        assert_eq!(
            err.matches("error:").count(),
            1,
            "{extra:?}: one message:\n{}",
            text(&o)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
