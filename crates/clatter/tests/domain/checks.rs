//! The blow-up checks and the totals on ranks against one process's.

use super::*;

/// The pile of `mpi.rs`'s rank-2 blow-up: 300 spheres in x < 0.2 m and one (body 0, the
/// scene's `[[body]]` before its group) at x = 0.25 m shot at the +x wall, which it
/// overlaps by more than half its radius about 300 steps in.
const SHOT: &str = r#"[simulation]
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

[[body]]
shape = "ball"
material = "m"
position = [0.25, 0.025, 0.15]
velocity = [8.0, 0.0, 0.0]

[[group]]
shape = "ball"
material = "m"
random = { min = [0.01, 0.01, 0.01], max = [0.2, 0.04, 0.19], count = 300, seed = 7 }
velocity = [1.5, 0.0, -0.5]
"#;

/// The steps of `clatter run`'s checks: the cheap check every 10 steps, the full one every
/// 100 (which keeps the last good state).
const CHECK_EVERY: u64 = 10;
const FULL_CHECK_EVERY: u64 = 100;

/// A blow-up on a body owned by rank 2 of 3 (a deep overlap with a wall, found by that rank
/// alone): every rank reports one process's blow-up (kind, body, numbers, the cause found
/// from the body's state), and the last good state gathered from the shares the ranks kept
/// at the last full check is one process's, checkpoint byte for byte.
#[test]
fn a_blow_up_on_rank_2_is_one_process_blow_up() {
    let world = Scene::parse(SHOT, "shot.toml").expect("parses").world();
    let health = clatter::Health::new(&world);
    let (want, want_good) = {
        let mut w = world.clone();
        let mut good = w.clone();
        loop {
            w.step().expect("finite");
            let s = w.step_count;
            let full = s.is_multiple_of(FULL_CHECK_EVERY);
            if full || s.is_multiple_of(CHECK_EVERY) {
                match health.check(&w, full) {
                    Ok(()) if full => good = w.clone(),
                    Ok(()) => {}
                    Err(b) => break (b, good.checkpoint_bytes("test", "", &[])),
                }
            }
            assert!(s < 2000, "the shot should blow up");
        }
    };
    assert!(
        want.to_string().contains("body 0 and wall 1 overlap") && want.step > FULL_CHECK_EVERY,
        "{want}"
    );
    let got: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(3)
            .into_iter()
            .map(|comm| {
                let (w, health) = (world.clone(), health.clone());
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    let mut kept = None;
                    loop {
                        d.step(&comm).expect("finite");
                        let s = d.local().step_count;
                        let full = s.is_multiple_of(FULL_CHECK_EVERY);
                        if full || s.is_multiple_of(CHECK_EVERY) {
                            match d.check(&health, &comm, full) {
                                Ok(()) if full => kept = Some(d.share()),
                                Ok(()) => {}
                                Err(b) => {
                                    let kept = kept.expect("a full check passed");
                                    let good = d.gather_kept(&kept, &comm);
                                    let owns = d.ids().iter().enumerate().any(|(i, &g)| {
                                        g as usize == b.body && !d.local().is_ghost(i)
                                    });
                                    let ckpt = good.map(|g| g.checkpoint_bytes("test", "", &[]));
                                    break (b, ckpt, owns);
                                }
                            }
                        }
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    for (rank, (b, ckpt, owns)) in got.iter().enumerate() {
        assert_eq!(b, &want, "rank {rank}: one process's blow-up");
        assert_eq!(*owns, rank == 2, "rank {rank}: body 0 is rank 2's");
        assert_eq!(
            ckpt.is_some(),
            rank == 0,
            "the last good state on rank 0 only"
        );
    }
    assert!(
        got[0].1.as_ref() == Some(&want_good),
        "the last good state gathered from the shares is one process's"
    );
}

/// The totals of `energy.csv` and `discharge.csv` reduced over ranks (`Domain::totals`,
/// exact sums of each rank's bodies) are bitwise one process's (`World::kinetic_energy`,
/// `potential_energy`, `momentum`, `discharged`), on the sink scene (bodies removed) on 2
/// and 3 ranks.
#[test]
fn totals_on_ranks_are_one_process_totals() {
    let world = scene_world("sink-floor.toml");
    let steps = 3000;
    let mut w = world.clone();
    for _ in 0..steps {
        w.step().expect("one process steps");
    }
    let d = w.discharged();
    assert!(d.count > 0, "bodies should be removed by then");
    let want = [
        w.kinetic_energy(),
        w.potential_energy(),
        w.momentum()[0],
        w.momentum()[1],
        w.momentum()[2],
        d.mass,
    ]
    .map(f64::to_bits);
    for ranks in [2, 3] {
        let got: Vec<clatter::domain::Totals> = std::thread::scope(|scope| {
            let handles: Vec<_> = ThreadComm::group(ranks)
                .into_iter()
                .map(|comm| {
                    let w = world.clone();
                    scope.spawn(move || {
                        let mut d = Domain::new(w, comm.rank(), comm.size());
                        for _ in 0..steps {
                            d.step(&comm).expect("ranks step");
                        }
                        d.totals(&comm)
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("rank thread"))
                .collect()
        });
        for t in &got {
            let bits = [
                t.kinetic,
                t.potential,
                t.momentum[0],
                t.momentum[1],
                t.momentum[2],
                t.removed_mass,
            ]
            .map(f64::to_bits);
            assert_eq!(bits, want, "{ranks} ranks: the totals");
            assert_eq!(t.removed, d.count, "{ranks} ranks: removed bodies");
            assert_eq!(t.step, w.step_count);
        }
    }
}
