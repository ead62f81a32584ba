//! Worlds stepped on 1-4 thread ranks against one process, bitwise: piles, the default
//! scene, sinks, clumps, periodic and mesh scenes, a gathered world continued on fewer ranks.

use super::*;

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
