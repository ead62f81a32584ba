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

/// A lattice of spheres shaken hard: bodies cross the slab boundaries many times.
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
/// rank, the slabs ending at the box.
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

/// The slabs are cut again only when the ranks' shares drift past `REBALANCE_IMBALANCE`
/// (10%): most rebuilds of the default scene keep them (the result is one process's all the
/// same, which `check` holds for every scene here).
#[test]
fn slabs_are_recut_only_past_the_imbalance_threshold() {
    use clatter::domain::Slabs;
    assert_eq!(Slabs::imbalance(&[10, 10, 10]), 0.0);
    assert!((Slabs::imbalance(&[11, 10, 9]) - 0.1).abs() < 1e-12);
    assert!((Slabs::imbalance(&[0, 0, 4]) - 2.0).abs() < 1e-12);
    assert_eq!(Slabs::imbalance(&[0, 0]), 0.0);
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
