//! The domain decomposition (`clatter::domain`) on ranks that are threads of this process
//! (`ThreadComm`): a world stepped on 1, 2, 3 and 4 ranks ends bitwise equal to the same
//! world stepped by `World::step`, with the same contact count and rebuilds. The MPI
//! transport itself is tested by `clatter-cli/tests/mpi.rs` (feature `mpi`).

use std::path::Path;

use clatter::World;
use clatter::domain::{Comm, Domain, ThreadComm};
use clatter::pile::{PileParams, PileShape, pile};
use clatter::scene::Scene;
use glam::Vec3;

/// Every state bit of every body, in order.
fn snapshot(w: &World) -> Vec<u64> {
    let mut out = Vec::with_capacity(w.len() * 20);
    for i in 0..w.len() {
        let s = &w.state;
        out.extend(s.position[i].to_array().map(f64::to_bits));
        let f32s = s.velocity[i]
            .to_array()
            .into_iter()
            .chain(s.orientation[i].to_array())
            .chain(s.orientation_residual[i].to_array())
            .chain(s.angular_momentum[i].to_array())
            .chain(s.omega[i].to_array());
        out.extend(f32s.map(|x| x.to_bits() as u64));
        out.push(s.removed[i] as u64);
    }
    out
}

/// What a run ends with: every state bit, the touching contacts, the rebuilds.
#[derive(Debug, PartialEq)]
struct End {
    state: Vec<u64>,
    /// The world's checkpoint: every state bit, the contact list with its springs, forces,
    /// hints and bounds, the rebuild positions, the clock.
    checkpoint: Vec<u8>,
    contacts: usize,
    rebuilds: u64,
    step: u64,
}

fn one_process(mut w: World, steps: usize) -> End {
    for _ in 0..steps {
        w.step().expect("one process steps");
    }
    End {
        state: snapshot(&w),
        checkpoint: w.checkpoint_bytes("test", "", &[]),
        contacts: w.contact_count(),
        rebuilds: w.rebuilds,
        step: w.step_count,
    }
}

/// `world` stepped on `ranks` threads; every rank's gathered end must agree.
fn on_ranks(world: &World, ranks: usize, steps: usize) -> End {
    on_ranks_counted(world, ranks, steps).0
}

/// [`on_ranks`], with the number of bodies handed from one rank to another at rebuilds.
fn on_ranks_counted(world: &World, ranks: usize, steps: usize) -> (End, u64) {
    let ends: Vec<(End, u64)> = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(ranks)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    for _ in 0..steps {
                        d.step(&comm).expect("ranks step");
                    }
                    let contacts = d.contact_count(&comm);
                    let handovers = comm.sum_u64(d.handed_over());
                    let g = d.gather(&comm);
                    let end = End {
                        state: snapshot(&g),
                        checkpoint: g.checkpoint_bytes("test", "", &[]),
                        contacts,
                        rebuilds: g.rebuilds,
                        step: g.step_count,
                    };
                    (end, handovers)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    for e in &ends[1..] {
        assert_eq!(e, &ends[0], "ranks disagree");
    }
    ends.into_iter().next().expect("one rank at least")
}

fn check(name: &str, world: World, steps: usize) -> u64 {
    let reference = one_process(world.clone(), steps);
    assert!(
        reference.rebuilds > 3,
        "{name}: the run should rebuild ({} rebuilds)",
        reference.rebuilds
    );
    eprintln!(
        "{name}: {} steps, {} rebuilds, {} contacts at the end",
        steps, reference.rebuilds, reference.contacts
    );
    let mut handovers = 0;
    for ranks in 1..=4 {
        let (got, handed) = on_ranks_counted(&world, ranks, steps);
        eprintln!("{name} on {ranks} ranks: {handed} bodies handed over");
        handovers = handovers.max(handed);
        assert_eq!(got.step, reference.step, "{name} on {ranks} ranks: step");
        assert_eq!(
            got.rebuilds, reference.rebuilds,
            "{name} on {ranks} ranks: rebuilds"
        );
        assert_eq!(
            got.contacts, reference.contacts,
            "{name} on {ranks} ranks: contacts"
        );
        let first = got
            .state
            .iter()
            .zip(&reference.state)
            .position(|(a, b)| a != b);
        assert!(
            first.is_none(),
            "{name} on {ranks} ranks: state differs from one process at word {first:?} (body {:?})",
            first.map(|k| k / 20)
        );
        let first = got
            .checkpoint
            .iter()
            .zip(&reference.checkpoint)
            .position(|(a, b)| a != b);
        assert!(
            first.is_none() && got.checkpoint.len() == reference.checkpoint.len(),
            "{name} on {ranks} ranks: the gathered world's checkpoint differs from one process's at byte {first:?} (lengths {} and {})",
            got.checkpoint.len(),
            reference.checkpoint.len()
        );
    }
    handovers
}

/// A lattice of spheres shaken hard: bodies cross the rank boundaries many times.
#[test]
fn sphere_pile_on_1_to_4_ranks_is_bitwise_one_process() {
    let mut desc = pile(PileShape::Sphere, 400, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
    }
    let handovers = check("sphere pile", World::new(desc), 600);
    assert!(
        handovers > 100,
        "bodies should cross rank boundaries many times ({handovers} handovers)"
    );
}

/// The mixed polyhedra of the determinism test (separating-axis hints, face contacts).
#[test]
fn mixed_pile_on_1_to_4_ranks_is_bitwise_one_process() {
    let mut desc = pile(PileShape::Mixed, 300, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 1.5;
        b.angular_velocity = Vec3::new((f * 0.29).cos(), (f * 0.53).sin(), (f * 0.97).cos()) * 30.0;
    }
    check("mixed pile", World::new(desc), 400);
}

/// The CLI's default scene (2500 polyhedra and spheres poured into a box), shortened.
#[test]
fn default_scene_on_1_to_4_ranks_is_bitwise_one_process() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/default.toml");
    let scene = Scene::load(&path).expect("default scene");
    check("default scene", scene.world(), 5000);
}

fn scene_world(name: &str) -> World {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    Scene::load(&path)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .world()
}

/// Sinks: bodies removed on one rank stay removed (the flag travels with the state) and
/// drop out of every pair, as on one process.
#[test]
fn sink_scene_on_1_to_4_ranks_is_bitwise_one_process() {
    let world = scene_world("sink-floor.toml");
    assert!(!world.sinks.is_empty());
    let reference = {
        let mut w = world.clone();
        for _ in 0..4000 {
            w.step().expect("steps");
        }
        w.discharged().count
    };
    assert!(reference > 0, "the sink should remove bodies");
    check("sink floor", world, 4000);
}

/// Composites (clumps): contacts per piece pair, their springs carried by piece code.
#[test]
fn clumps_on_1_to_4_ranks_is_bitwise_one_process() {
    check("clumps", scene_world("clumps.toml"), 10000);
}

/// A run stopped between rebuilds on 3 ranks, its world gathered (what a checkpoint
/// stores) and continued on 2 ranks and on 1, ends bitwise as one process's uninterrupted
/// run; so does one process's world continued on 3 ranks.
#[test]
fn a_world_gathered_on_3_ranks_continues_on_2_and_1_bitwise() {
    let mut desc = pile(PileShape::Mixed, 200, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 1.5;
    }
    let world = World::new(desc);
    let (first, then) = (157, 300);
    let reference = one_process(world.clone(), first + then);
    // 157 steps on 3 ranks, gathered; stopped mid-interval (no rebuild due).
    let gathered: World = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(3)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    for _ in 0..first {
                        d.step(&comm).expect("ranks step");
                    }
                    d.gather(&comm)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .next()
            .expect("rank 0")
    });
    assert!(!gathered.needs_rebuild(), "stop between rebuilds");
    let resumed = |start: &World, ranks: usize| on_ranks(start, ranks, then);
    for ranks in [2, 1] {
        let got = resumed(&gathered, ranks);
        assert!(
            got.checkpoint == reference.checkpoint,
            "gathered on 3 ranks, continued on {ranks}: differs from one process"
        );
    }
    let mut one = world.clone();
    for _ in 0..first {
        one.step().expect("steps");
    }
    let got = resumed(&one, 3);
    assert!(
        got.checkpoint == reference.checkpoint,
        "one process continued on 3 ranks: differs"
    );
}

/// Periodic boundaries (x and y): ghosts across the seam, a rank its own neighbour on one
/// rank, the outer boxes ending at the periodic box.
#[test]
fn periodic_scene_on_1_to_4_ranks_is_bitwise_one_process() {
    let handovers = check("periodic floor", scene_world("periodic-floor.toml"), 6000);
    assert!(handovers > 50, "{handovers} handovers");
}

/// Mesh boundaries: a static mesh floor, and a turning drum (slots carried with the bodies,
/// the rebuild test counting the meshes' motion).
#[test]
fn mesh_scenes_on_1_to_4_ranks_are_bitwise_one_process() {
    check("mesh floor", scene_world("mesh-floor.toml"), 3000);
    check("drum", scene_world("drum.toml"), 3000);
}

/// A world with a current contact list (what a resumed checkpoint or a cached pile is) is
/// split between the ranks at once, with no rebuild: every rank owns its share before the
/// first step, and the run continued on 1 to 4 ranks ends bitwise as one process's, for
/// polyhedra, composites (per-piece contacts, rebuild orientations), periodic boundaries
/// (ghosts across the seam) and mesh boundaries (the candidates found again per rank, the
/// slots carried), static and turning.
#[test]
fn a_current_world_is_split_at_once_and_continues_bitwise() {
    let mut mixed = pile(PileShape::Mixed, 200, &PileParams::default());
    for (i, b) in mixed.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 1.5;
    }
    let cases = [
        ("mixed pile", World::new(mixed), 157, 300),
        ("clumps", scene_world("clumps.toml"), 2000, 1500),
        (
            "periodic floor",
            scene_world("periodic-floor.toml"),
            6000,
            1500,
        ),
        ("mesh floor", scene_world("mesh-floor.toml"), 2500, 1000),
        ("drum", scene_world("drum.toml"), 2500, 1000),
    ];
    for (name, world, first, then) in cases {
        let mut start = world;
        for _ in 0..first {
            start.step().expect("steps");
        }
        // Stop between rebuilds: the list is current.
        while start.needs_rebuild() {
            start.step().expect("steps");
        }
        assert!(
            start.contact_count() > 0,
            "{name}: split with contacts touching"
        );
        let reference = one_process(start.clone(), then);
        for ranks in 1..=4 {
            let owned: Vec<usize> = (0..ranks)
                .map(|r| Domain::new(start.clone(), r, ranks).owned())
                .collect();
            assert_eq!(
                owned.iter().sum::<usize>(),
                start.len(),
                "{name}: {owned:?}"
            );
            assert!(
                owned.iter().all(|&n| n > 0),
                "{name} on {ranks} ranks: every rank owns bodies before the first step: {owned:?}"
            );
            let got = on_ranks(&start, ranks, then);
            assert_eq!(got.rebuilds, reference.rebuilds, "{name} on {ranks} ranks");
            assert!(
                got.checkpoint == reference.checkpoint,
                "{name}: continued on {ranks} ranks, differs from one process"
            );
        }
    }
}

/// The boxes are cut again only when the ranks' shares drift past `REBALANCE_IMBALANCE`
/// (10%): most rebuilds of the default scene keep them (the result is one process's all the
/// same, which `check` holds for every scene here).
#[test]
fn boxes_are_recut_only_past_the_imbalance_threshold() {
    use clatter::domain::Bisection;
    assert_eq!(Bisection::imbalance(&[10, 10, 10]), 0.0);
    assert!((Bisection::imbalance(&[11, 10, 9]) - 0.1).abs() < 1e-12);
    assert!((Bisection::imbalance(&[0, 0, 4]) - 2.0).abs() < 1e-12);
    assert_eq!(Bisection::imbalance(&[0, 0]), 0.0);
    let world = scene_world("default.toml");
    let steps = 3000;
    let (rebuilds, recuts): (u64, Vec<u64>) = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(3)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    for _ in 0..steps {
                        d.step(&comm).expect("ranks step");
                    }
                    (d.local().rebuilds, d.recuts())
                })
            })
            .collect();
        let ends: Vec<(u64, u64)> = handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect();
        (ends[0].0, ends.iter().map(|e| e.1).collect())
    });
    assert!(recuts.iter().all(|&r| r == recuts[0]), "{recuts:?}");
    eprintln!(
        "default scene, 3 ranks, {steps} steps: {rebuilds} rebuilds, {} recuts",
        recuts[0]
    );
    assert!(
        recuts[0] >= 1 && recuts[0] < rebuilds / 2,
        "{} recuts in {rebuilds} rebuilds",
        recuts[0]
    );
}

/// A pile much wider than it is tall, on 4 ranks: the bisection cuts it 2 x 2 (across x
/// and across y, never along z), not into 4 slabs, and the run is still bitwise one
/// process's on 1 to 4 ranks.
#[test]
fn a_wide_flat_pile_is_cut_2_by_2_on_4_ranks_and_stays_bitwise() {
    let text = r#"[simulation]
steps = 1500
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
max = [0.4, 0.4, 0.06]
material = "m"

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[group]]
shape = "ball"
material = "m"
random = { min = [0.01, 0.01, 0.01], max = [0.39, 0.39, 0.05], count = 400, seed = 5 }
velocity = [0.6, -0.4, -0.3]
"#;
    let world = Scene::parse(text, "wide.toml")
        .expect("the wide pile parses")
        .world();
    check("wide flat pile", world.clone(), 1500);
    let boxes: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(4)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    for _ in 0..50 {
                        d.step(&comm).expect("ranks step");
                    }
                    (
                        d.boxes().cloned().expect("cut at the first step"),
                        d.owned(),
                    )
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    let cuts = boxes[0].0.cuts().to_vec();
    assert!(boxes.iter().all(|b| b.0 == boxes[0].0), "ranks disagree");
    eprintln!(
        "wide flat pile on 4 ranks: cuts {cuts:?}, owned {:?}",
        boxes.iter().map(|b| b.1).collect::<Vec<_>>()
    );
    assert_eq!(cuts.len(), 3);
    let (root, first, second) = (cuts[0].0, cuts[1].0, cuts[2].0);
    assert!(
        root < 2 && first < 2 && second < 2,
        "no cut along z: {cuts:?}"
    );
    assert!(
        first != root && second != root,
        "the halves are cut across the other horizontal axis (2 x 2): {cuts:?}"
    );
    assert!(boxes.iter().all(|b| b.1 > 0), "every rank owns bodies");
}

/// A small deterministic generator for the tests below (xorshift64*), uniform in [0, 1).
fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed.max(1);
    move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The cuts found from summed histograms balance the ranks' counts within
/// `REBALANCE_IMBALANCE`, counted by brute force over every body, on random piles: a heap
/// (denser at the bottom, with bodies sharing coordinates), and a tight cluster with a few
/// bodies far away (the first histogram puts the cluster in one bin: the refinement passes
/// must split it). The boxes tile space (each body in exactly its owner's box), and the
/// same cuts come out when each rank holds a share of the bodies and the histograms are
/// summed over ranks (`ThreadComm`) as when one holds them all.
#[test]
fn histogram_cuts_balance_random_piles() {
    use clatter::domain::{Bisection, REBALANCE_IMBALANCE};
    let mut u = uniform(17);
    let mut heap: Vec<Vec3> = (0..6000)
        .map(|_| {
            let (x, y, h) = (u(), u(), u());
            Vec3::new(x * 2.0, y, 0.5 * h * h * (1.0 - (x - 0.5).abs()))
        })
        .collect();
    // Bodies sharing a coordinate (a lattice row).
    heap.extend((0..300).map(|k| Vec3::new(0.7, k as f32 * 0.003, 0.01)));
    let mut cluster: Vec<Vec3> = (0..5000)
        .map(|_| Vec3::new(u(), u(), u()) * 1e-3 + Vec3::new(3.0, 1.0, 0.5))
        .collect();
    cluster.extend((0..5).map(|k| Vec3::new(-1000.0 + k as f32, 400.0, 0.0)));
    for (name, pts) in [("heap", &heap), ("cluster", &cluster)] {
        for ranks in [2, 3, 4, 5, 7, 16] {
            let b = Bisection::balanced(pts, ranks, None, None);
            let mut owned = vec![0u64; ranks];
            for p in pts.iter() {
                let x = p.as_dvec3();
                let r = b.owner(x);
                owned[r] += 1;
                let inside = |r: usize| {
                    let reg = b.region(r);
                    (0..3).all(|a| reg[a][0] <= x[a] && x[a] < reg[a][1])
                };
                assert!(inside(r), "{name}: {p} outside its owner's box");
                assert_eq!((0..ranks).filter(|&s| inside(s)).count(), 1, "{name}: {p}");
                assert_eq!(b.distance(x, r), 0.0);
            }
            let imbalance = Bisection::imbalance(&owned);
            eprintln!("{name} on {ranks} ranks: owned {owned:?}, imbalance {imbalance:.4}");
            assert!(
                imbalance <= REBALANCE_IMBALANCE,
                "{name} on {ranks} ranks: {owned:?} ({imbalance})"
            );
            // The same cuts from shares of the bodies, histograms summed over the ranks.
            let shared: Vec<Bisection> = std::thread::scope(|scope| {
                let handles: Vec<_> = ThreadComm::group(ranks)
                    .into_iter()
                    .map(|comm| {
                        let mine: Vec<Vec3> = pts
                            .iter()
                            .enumerate()
                            .filter(|(i, _)| (i * 7 + i / 3) % ranks == comm.rank())
                            .map(|(_, p)| *p)
                            .collect();
                        scope.spawn(move || {
                            Bisection::balanced(&mine, comm.size(), None, Some(&comm))
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().expect("rank thread"))
                    .collect()
            });
            assert!(
                shared.iter().all(|s| *s == b),
                "{name} on {ranks} ranks: shares give other cuts"
            );
        }
    }
}

/// The ranks a body is a ghost on and a rank's peers, found by walking the cut tree
/// (`Bisection::within`, `Bisection::boxes_within`), are exactly those found by testing
/// every rank's box (brute force), on 1 to 64 ranks, in open space and periodic along x and
/// y, for points inside, between and far outside the boxes and reaches from a hair to
/// everything.
#[test]
fn ranks_within_reach_from_the_cut_tree_are_the_brute_force_ranks() {
    use clatter::Periodic;
    use clatter::domain::Bisection;
    let mut u = uniform(29);
    let pts: Vec<Vec3> = (0..4000)
        .map(|_| {
            let (x, y, h) = (u(), u(), u());
            Vec3::new(x * 2.0, y, 0.5 * h * h)
        })
        .collect();
    let periodic = Periodic {
        min: Vec3::new(0.0, 0.0, -1.0),
        max: Vec3::new(2.0, 1.0, 1.0),
        axes: [true, true, false],
    };
    let mut checked = 0usize;
    for p in [None, Some(&periodic)] {
        for ranks in [1, 2, 3, 4, 5, 7, 8, 16, 33, 64] {
            let b = Bisection::balanced(&pts, ranks, p, None);
            for reach in [1e-4, 0.01, 0.05, 0.2, 1.0, 10.0, f64::INFINITY] {
                for k in 0..200 {
                    // Inside the pile, and (every fourth) far around it.
                    let spread = if k % 4 == 0 { 6.0 } else { 1.0 };
                    let mut c = |lo: f32, w: f32| (lo + (u() - 0.5) * w * spread) as f64;
                    let x = glam::DVec3::new(c(1.0, 2.0), c(0.5, 1.0), c(0.25, 0.5));
                    let brute: Vec<usize> =
                        (0..ranks).filter(|&r| b.distance(x, r) < reach).collect();
                    assert_eq!(
                        b.within(x, reach),
                        brute,
                        "{ranks} ranks, {p:?}, {x}, {reach}"
                    );
                    checked += brute.len();
                }
                for r in 0..ranks {
                    let brute: Vec<usize> = (0..ranks)
                        .filter(|&s| b.box_distance(r, s) < reach)
                        .collect();
                    assert_eq!(
                        b.boxes_within(r, reach),
                        brute,
                        "{ranks} ranks, {p:?}, rank {r}, {reach}"
                    );
                }
            }
        }
    }
    assert!(checked > 10_000, "the points found ranks ({checked})");
}

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

/// Random spheres and cubes, in a closed box or periodic along x and y.
fn random_world(periodic: bool) -> World {
    let bounds = if periodic {
        "periodic = { min = [0.0, 0.0, 0.0], max = [0.2, 0.12, 0.0], axes = \"xy\" }"
    } else {
        ""
    };
    let text = format!(
        r#"[simulation]
steps = 10
gravity = [0.0, 0.0, 0.0]
{bounds}

[[material]]
name = "m"
density = 1000.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.5

[[shape]]
name = "ball"
sphere = {{ radius = 0.004 }}

[[shape]]
name = "cube"
polyhedron = {{ kind = "cube", radius = 0.005 }}

[[group]]
shape = "ball"
material = "m"
random = {{ min = [0.0, 0.0, 0.0], max = [0.2, 0.12, 0.04], count = 700, seed = 3 }}

[[group]]
shape = "cube"
material = "m"
random = {{ min = [0.0, 0.0, 0.0], max = [0.2, 0.12, 0.04], count = 100, seed = 4 }}
"#
    );
    Scene::parse(&text, "random.toml")
        .expect("the random scene parses")
        .world()
}

/// Checks by brute force over every pair that each rank holds every body within `reach`
/// (the nearest image along periodic axes) of the bodies it owns, at the positions `x` the
/// contact list was built at; returns how many such partners are ghosts.
fn partners_on_rank(world: &World, x: &[glam::DVec3], ids: &[u32], ghost: &[bool]) -> usize {
    let reach = 2.0 * world.consts.max_radius() as f64 + world.skin as f64;
    let mut ghosts = 0;
    for (k, &i) in ids.iter().enumerate() {
        if ghost[k] {
            continue;
        }
        for (j, xj) in x.iter().enumerate() {
            let mut d = *xj - x[i as usize];
            if let Some(p) = &world.periodic {
                for a in 0..3 {
                    if p.axes[a] {
                        let len = (p.max[a] - p.min[a]) as f64;
                        d[a] -= len * (d[a] / len).round();
                    }
                }
            }
            if j as u32 != i && d.length() < reach {
                let at = ids.binary_search(&(j as u32));
                assert!(
                    at.is_ok(),
                    "body {j} within reach of owned {i} is not on the rank"
                );
                ghosts += at.is_ok_and(|at| ghost[at]) as usize;
            }
        }
    }
    ghosts
}

/// Every body within reach of an owned body's centre is on the rank (owned or a ghost), on
/// 2 to 8 ranks, checked by brute force over every pair of random positions, in a closed box
/// and periodic along x and y (ghosts across the seams): both when a current world is split
/// at once (`Domain::new`) and when the first step's rebuild distributes a new one from
/// histograms summed over the ranks.
#[test]
fn ghosts_hold_every_partner_within_reach() {
    for periodic in [false, true] {
        let fresh = random_world(periodic);
        let mut current = fresh.clone();
        current.step().expect("one step");
        assert!(!current.needs_rebuild(), "the list is current");
        let n = current.len();
        for ranks in [2, 3, 4, 5, 8] {
            // Split at once.
            let mut ghosts = 0;
            let mut owned = 0;
            for r in 0..ranks {
                let d = Domain::new(current.clone(), r, ranks);
                let local = d.local();
                let ghost: Vec<bool> = (0..local.len()).map(|i| local.is_ghost(i)).collect();
                owned += d.owned();
                ghosts += partners_on_rank(&current, current.rebuild_position(), d.ids(), &ghost);
            }
            assert_eq!(owned, n, "every body owned once");
            eprintln!("periodic {periodic}, {ranks} ranks: {ghosts} partners are ghosts");
            assert!(ghosts > 0, "pairs cross the boxes");
            // Distributed by the first step's rebuild.
            let ghosts: usize = std::thread::scope(|scope| {
                let handles: Vec<_> = ThreadComm::group(ranks)
                    .into_iter()
                    .map(|comm| {
                        let w = fresh.clone();
                        scope.spawn(move || {
                            let mut d = Domain::new(w, comm.rank(), comm.size());
                            d.step(&comm).expect("ranks step");
                            let whole = d.gather(&comm);
                            let local = d.local();
                            let ghost: Vec<bool> =
                                (0..local.len()).map(|i| local.is_ghost(i)).collect();
                            partners_on_rank(&whole, whole.rebuild_position(), d.ids(), &ghost)
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().expect("rank thread"))
                    .sum()
            });
            assert!(ghosts > 0, "pairs cross the boxes");
        }
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
