//! The boxes: recut past the imbalance threshold, cut 2 by 2 on a wide pile, histogram cuts
//! against random piles, the cut tree's ranks within reach and every partner held as a ghost.

use super::*;

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
