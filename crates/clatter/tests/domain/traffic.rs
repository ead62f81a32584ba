//! What the ranks send: messages over the limit in rounds, the bytes a check step receives,
//! rebuilds that keep their boxes going point to point.

use super::*;

/// Messages longer than a transport's limit go in rounds (`Rounds`, as over MPI, whose
/// counts are `int`): on threads whose messages may not pass 40 or 256 bytes a round (every
/// round checked), an all-to-all of random lengths (empty ones, and ones of many rounds)
/// delivers every message whole, and a sphere pile stepped on 3 ranks ends bitwise as one
/// process's (its ghost states, rebuilds and gathers all cut into pieces).
#[test]
fn messages_over_the_limit_go_in_rounds_bitwise() {
    let mut u = uniform(41);
    let lens: Vec<Vec<usize>> = (0..4)
        .map(|_| {
            (0..4)
                .map(|_| match (u() * 4.0) as u32 {
                    0 => 0,
                    1 => 1 + (u() * 9.0) as usize,
                    _ => (u() * 900.0) as usize,
                })
                .collect()
        })
        .collect();
    let message = |from: usize, to: usize| -> Vec<u8> {
        (0..lens[from][to])
            .map(|k| (k * 31 + from * 7 + to * 3) as u8)
            .collect()
    };
    std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group_limited(4, 40)
            .into_iter()
            .map(|comm| {
                let message = &message;
                scope.spawn(move || {
                    let me = comm.rank();
                    let got = comm.all_to_all((0..4).map(|to| message(me, to)).collect());
                    for (from, m) in got.iter().enumerate() {
                        assert_eq!(*m, message(from, me), "{from} to {me}");
                    }
                    let all = comm.all_gather(&message(me, (me + 1) % 4));
                    for (from, m) in all.iter().enumerate() {
                        assert_eq!(*m, message(from, (from + 1) % 4), "gathered from {from}");
                    }
                })
            })
            .collect();
        for h in handles {
            h.join().expect("rank thread");
        }
    });
    let mut desc = pile(PileShape::Sphere, 200, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
    }
    let world = World::new(desc);
    let steps = 200;
    let want = one_process(world.clone(), steps);
    let ends: Vec<End> = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group_limited(3, 256)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    for _ in 0..steps {
                        d.step(&comm).expect("ranks step");
                    }
                    let contacts = d.contact_count(&comm);
                    let g = d.gather(&comm);
                    End {
                        state: snapshot(&g),
                        checkpoint: g.checkpoint_bytes("test", "", &[]),
                        contacts,
                        rebuilds: g.rebuilds,
                        step: g.step_count,
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    for e in &ends {
        assert_eq!(*e, want, "3 ranks under a 256-byte limit");
    }
}

/// [`ThreadComm`] with the bytes this rank receives counted. Every collective goes through
/// `all_to_all` here (the reductions as all-gathers of their operands), so a reduction is
/// counted as `ranks` times its operand, as a naive transport receives it.
struct Counted {
    inner: ThreadComm,
    received: std::cell::Cell<u64>,
}

impl Counted {
    fn new(inner: ThreadComm) -> Counted {
        Counted {
            inner,
            received: std::cell::Cell::new(0),
        }
    }

    /// Bytes received since the last call.
    fn take(&self) -> u64 {
        self.received.replace(0)
    }

    fn gathered_u64s(&self, x: u64) -> impl Iterator<Item = u64> {
        self.all_gather(&x.to_le_bytes())
            .into_iter()
            .map(|b| u64::from_le_bytes(b[..8].try_into().expect("8 bytes")))
    }
}

impl Comm for Counted {
    fn rank(&self) -> usize {
        self.inner.rank()
    }
    fn size(&self) -> usize {
        self.inner.size()
    }
    fn all_to_all(&self, send: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        let got = self.inner.all_to_all(send);
        let n: usize = got.iter().map(Vec::len).sum();
        self.received.set(self.received.get() + n as u64);
        got
    }
    fn all_gather(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.all_to_all(vec![mine.to_vec(); self.size()])
    }
    fn max_f32(&self, x: f32) -> f32 {
        self.all_gather(&x.to_le_bytes())
            .iter()
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .fold(f32::NEG_INFINITY, f32::max)
    }
    fn sum_u64(&self, x: u64) -> u64 {
        self.gathered_u64s(x).sum()
    }
    fn min_u64(&self, x: u64) -> u64 {
        self.gathered_u64s(x).min().unwrap_or(x)
    }
}

/// Bytes received by each rank of 3, after `steps` steps, for what a check step and an
/// energy sample cost now and before: (a full check, the gather of the whole world the
/// check step did before, the totals of an energy sample, the gather of every body's state
/// the sample did before).
fn check_bytes(world: &World, steps: usize) -> Vec<[u64; 4]> {
    let health = clatter::Health::new(world);
    std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(3)
            .into_iter()
            .map(|comm| {
                let (w, health) = (world.clone(), health.clone());
                scope.spawn(move || {
                    let comm = Counted::new(comm);
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    for _ in 0..steps {
                        d.step(&comm).expect("ranks step");
                    }
                    // The ghost states an overlapped step leaves owed are the next step's
                    // exchange, which a check brings forward: not the check's own bytes.
                    d.sync_ghosts(&comm);
                    comm.take();
                    d.check(&health, &comm, true).expect("healthy");
                    let check = comm.take();
                    let _ = d.gather(&comm);
                    let gather = comm.take();
                    let _ = d.totals(&comm);
                    let totals = comm.take();
                    let _ = d.gather_bodies(&comm);
                    [check, gather, totals, comm.take()]
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    })
}

/// A check step and an energy sample receive a fixed number of bytes per rank, whatever
/// the number of bodies (exact sums and a few minima and maxima), where the gathers they
/// replaced received every body (and contact) on every rank: counted through the transport
/// on piles of 2,000 and 8,000 spheres on 3 ranks.
#[test]
fn a_check_step_receives_bytes_independent_of_the_world() {
    let mut sizes = Vec::new();
    for n in [2000, 8000] {
        let world = World::new(pile(PileShape::Sphere, n, &PileParams::default()));
        let bytes = check_bytes(&world, 20);
        eprintln!(
            "{n} spheres on 3 ranks, bytes received per rank [check, gather, totals, gather_bodies]: {bytes:?}"
        );
        for &[check, gather, totals, bodies] in &bytes {
            assert!(
                check < 8 * 1024,
                "{n} bodies: a check receives {check} bytes"
            );
            assert!(
                totals < 16 * 1024,
                "{n} bodies: a sample receives {totals} bytes"
            );
            assert!(
                gather > 100 * n as u64 && bodies > 90 * n as u64,
                "{n} bodies: a gather receives every body ({gather}, {bodies} bytes)"
            );
        }
        sizes.push(bytes);
    }
    let fixed = |b: &Vec<[u64; 4]>| b.iter().map(|b| [b[0], b[2]]).collect::<Vec<_>>();
    assert_eq!(
        fixed(&sizes[0]),
        fixed(&sizes[1]),
        "a check's and a sample's bytes do not grow with the bodies"
    );
}

/// The numbers of BENCHMARKS.md's "Blow-up checks on ranks": bytes per rank of a check step
/// and of a gather on the default scene (after 2000 steps, with its contacts) on 2 and 3
/// ranks. Run by hand: `cargo test --release -p clatter --test domain -- --ignored bytes`.
#[test]
#[ignore]
fn bytes_of_a_check_step_on_the_default_scene() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/default.toml");
    let world = Scene::load(&path).expect("default scene").world();
    eprintln!("default scene, 3 ranks: {:?}", check_bytes(&world, 2000));
}

/// Rebuilds that keep their boxes move bodies and springs point to point between ranks
/// whose boxes are near (`Comm::exchange_with`), and only they: on the shaken sphere pile
/// on 3 and 4 ranks every rebuild but those that cut boxes goes point to point (the guard
/// that falls back to an all-to-all never fires), with the result bitwise one process's
/// (the tests above). And the peers found from the distance between boxes hold every body:
/// no box is farther from another than any of its bodies was at the last rebuild (brute
/// force over the bodies, at every step).
#[test]
fn rebuilds_with_kept_boxes_go_point_to_point() {
    let mut desc = pile(PileShape::Sphere, 400, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
    }
    let world = World::new(desc);
    let reference = one_process(world.clone(), 600);
    for ranks in [3, 4] {
        let got: Vec<(u64, u64, u64, End)> = std::thread::scope(|scope| {
            let handles: Vec<_> = ThreadComm::group(ranks)
                .into_iter()
                .map(|comm| {
                    let w = world.clone();
                    scope.spawn(move || {
                        let mut d = Domain::new(w, comm.rank(), comm.size());
                        for _ in 0..600 {
                            d.step(&comm).expect("ranks step");
                            let boxes = d.boxes().cloned().expect("cut at the first step");
                            let local = d.local();
                            for i in (0..local.len()).filter(|&i| !local.is_ghost(i)) {
                                let x = local.rebuild_position()[i];
                                for s in 0..comm.size() {
                                    assert!(
                                        boxes.box_distance(comm.rank(), s)
                                            <= boxes.distance(x, s) + 1e-6,
                                        "a box nearer than its body"
                                    );
                                }
                            }
                        }
                        let g = d.gather(&comm);
                        let end = End {
                            state: snapshot(&g),
                            checkpoint: g.checkpoint_bytes("test", "", &[]),
                            contacts: d.contact_count(&comm),
                            rebuilds: g.rebuilds,
                            step: g.step_count,
                        };
                        (d.sparse_migrations(), d.recuts(), g.rebuilds, end)
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("rank thread"))
                .collect()
        });
        let (sparse, recuts, rebuilds, end) = &got[0];
        eprintln!(
            "{ranks} ranks: {rebuilds} rebuilds, {recuts} cut boxes, {sparse} point to point"
        );
        assert!(
            *sparse > 10,
            "{ranks} ranks: {sparse} point-to-point rebuilds"
        );
        assert_eq!(
            sparse + recuts,
            *rebuilds,
            "{ranks} ranks: every kept-box rebuild sparse"
        );
        assert!(end == &reference, "{ranks} ranks: bitwise one process");
    }
}

/// A rank thread that panics makes the others panic at their next collective instead of
/// leaving them waiting for it forever: a failing test fails, it does not hang.
#[test]
fn a_panicking_rank_stops_the_others() {
    let (tx, rx) = std::sync::mpsc::channel();
    for comm in ThreadComm::group(3) {
        let tx = tx.clone();
        std::thread::spawn(move || {
            let me = comm.rank();
            // The closure owns the handle: it is dropped while unwinding, as a failing
            // test's rank thread drops it.
            let ended = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
                if me == 1 {
                    panic!("rank 1 fails on purpose");
                }
                comm.all_gather(&[me as u8]);
                comm.all_gather(&[me as u8]);
            }));
            tx.send((me, ended.is_err())).expect("the test waits");
        });
    }
    drop(tx);
    let mut failed = Vec::new();
    for _ in 0..3 {
        let (rank, panicked) = rx
            .recv_timeout(std::time::Duration::from_secs(60))
            .expect("every rank ends within a minute (none hangs)");
        failed.push((rank, panicked));
    }
    failed.sort_unstable();
    assert_eq!(failed, vec![(0, true), (1, true), (2, true)]);
}
