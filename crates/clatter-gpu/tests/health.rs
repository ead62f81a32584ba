//! The GPU's blow-up checks, energy samples and last good state (health.wgsl,
//! `GpuWorld::set_health`) against the host's: the samples equal `World::kinetic_energy`
//! and `potential_energy` within f32 rounding, the snapshot is bitwise the state of a plain
//! run at that step, the checks stop the pipeline when the host's would fire and not on a
//! calm pile.

use clatter::World;
use clatter::health::{ENERGY_FACTOR, Health};
use clatter_gpu::{GpuWorld, HealthSetup};

const PILE: &str = r#"
[simulation]
steps = 200
dt = 2.0e-5

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
restitution = 0.5

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[[shape]]
name = "cube"
box = { half_extents = [0.01, 0.01, 0.01] }

[container]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.3]
material = "m"

[[group]]
shape = "cube"
material = "m"
lattice = { min = [0.03, 0.03, 0.03], max = [0.17, 0.17, 0.1], spacing = 0.035 }
velocity = [0.3, -0.2, -0.5]

[[group]]
shape = "ball"
material = "m"
lattice = { min = [0.05, 0.05, 0.15], max = [0.15, 0.15, 0.25], spacing = 0.03 }
"#;

fn world(text: &str) -> World {
    clatter::scene::Scene::parse(text, "pile.toml")
        .expect("the scene parses")
        .world()
}

fn setup(world: &World, energy_every: u64) -> HealthSetup {
    let h = Health::new(world);
    HealthSetup {
        check_every: 10,
        energy_every,
        snapshot_every: 100,
        budget: h.baseline(),
        alarm_factor: 0.5 * ENERGY_FACTOR,
        force_floor: h.force_floor(),
    }
}

#[test]
fn energy_samples_equal_the_host_sums() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut w = world(PILE);
    let mut gpu = GpuWorld::new(ctx, &w).expect("fits");
    gpu.set_health(&w, setup(&w, 7));
    let report = gpu.step_into(63, &mut w).expect("steps");
    assert!(!report.alarm, "a calm pile raises no alarm");
    let samples = gpu.take_samples();
    assert_eq!(
        samples.iter().map(|s| s.step).collect::<Vec<_>>(),
        (1..=9).map(|k| 7 * k).collect::<Vec<_>>()
    );
    let last = samples.last().expect("a sample at step 63");
    assert_eq!(w.step_count, 63);
    assert_eq!(last.time, w.time);
    let close = |a: f64, b: f64, what: &str| {
        assert!(
            (a - b).abs() <= 1e-5 * b.abs().max(1e-9),
            "{what}: GPU {a}, host {b}"
        );
    };
    close(last.kinetic, w.kinetic_energy(), "kinetic energy");
    close(last.potential, w.potential_energy(), "potential energy");
    let m = w.momentum();
    let scale = m.iter().map(|x| x.abs()).fold(1e-9, f64::max);
    for (k, (gpu, host)) in last.momentum.iter().zip(m).enumerate() {
        assert!(
            (gpu - host).abs() <= 1e-5 * scale,
            "momentum {k}: GPU {gpu}, host {host}"
        );
    }
}

#[test]
fn the_last_good_state_is_bitwise_the_state_at_its_step() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let start = world(PILE);
    let mut gpu = GpuWorld::new(ctx.clone(), &start).expect("fits");
    let mut snap = start.clone();
    assert!(
        !gpu.read_last_good(&mut snap).expect("reads"),
        "no snapshot before the first batch"
    );
    gpu.set_health(&start, setup(&start, 0));
    gpu.step(250).expect("steps");
    assert!(gpu.read_last_good(&mut snap).expect("reads"));
    assert_eq!(snap.step_count, 200);
    // A plain run (no checks) of 200 steps.
    let mut plain = start.clone();
    let mut other = GpuWorld::new(ctx, &start).expect("fits");
    other.step(200).expect("steps");
    other.read_into(&mut plain).expect("reads");
    assert_eq!(snap.time, plain.time);
    assert_eq!(snap.state.position, plain.state.position);
    assert_eq!(snap.state.velocity, plain.state.velocity);
    assert_eq!(snap.state.orientation, plain.state.orientation);
    assert_eq!(snap.state.angular_momentum, plain.state.angular_momentum);
    let (a, b) = (snap.contact_state(), plain.contact_state());
    assert_eq!(a.pairs, b.pairs);
    assert_eq!(a.history, b.history);
    assert_eq!(a.touching, b.touching);
    assert_eq!(a.wall_touching, b.wall_touching);
    assert_eq!(a.forces, b.forces);
}

#[test]
fn the_checks_do_not_change_the_trajectory() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let start = world(PILE);
    let (mut a, mut b) = (start.clone(), start.clone());
    let mut checked = GpuWorld::new(ctx.clone(), &start).expect("fits");
    checked.set_health(&start, setup(&start, 3));
    checked.step(150).expect("steps");
    checked.read_into(&mut a).expect("reads");
    let mut plain = GpuWorld::new(ctx, &start).expect("fits");
    plain.step(150).expect("steps");
    plain.read_into(&mut b).expect("reads");
    assert_eq!(a.state.position, b.state.position);
    assert_eq!(a.state.velocity, b.state.velocity);
}

#[test]
fn an_escaping_body_stops_the_pipeline_at_the_check_step() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    // 500 m/s with dt = 1e-4: five radii per step, through the wall at x = 0.2.
    let text = PILE.replace("dt = 2.0e-5", "dt = 1.0e-4").replace(
        "[[group]]\nshape = \"ball\"",
        "[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.1, 0.1, 0.28]\nvelocity = [500.0, 0.0, 0.0]\n\n[[group]]\nshape = \"ball\"",
    );
    let mut w = world(&text);
    let mut gpu = GpuWorld::new(ctx, &w).expect("fits");
    let s = setup(&w, 0);
    gpu.set_health(&w, s);
    let report = gpu.step_into(95, &mut w).expect("steps");
    assert!(report.alarm, "the escape raises the alarm");
    assert_eq!(w.step_count, 10, "at the first check step");
    gpu.read_into(&mut w).expect("reads");
    let h = Health::new(&world(&text));
    let err = h.check(&w, false).expect_err("the host finds the escape");
    assert!(err.to_string().contains("escaped through wall 1"), "{err}");
}
