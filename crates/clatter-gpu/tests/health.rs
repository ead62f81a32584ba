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
        // clatter_backend::GPU_OVERLAP_MARGIN, what `clatter run` arms the alarm with.
        overlap_limit: 0.99 * clatter::health::OVERLAP_LIMIT,
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

/// How deep the host's cheap check thinks `world`'s deepest contact may be: the largest
/// `law::depth_at_force` over `OVERLAP_LIMIT` times the smaller body's size, over the touching
/// contacts above the force floor (the contacts `Health::check` measures when it is above 1),
/// from the law functions and the scene's shapes, not from the GPU.
fn host_depth_ratio(world: &World, floor: f32) -> f32 {
    use clatter::Partner;
    use clatter::health::OVERLAP_LIMIT;
    use clatter::law;
    let c = &world.consts;
    let size = |i: usize| {
        let v = world.shapes[c.shape[i] as usize].volume;
        (3.0 * v / (4.0 * std::f32::consts::PI)).cbrt().max(1e-12)
    };
    let springs = world.contacts.springs();
    let mut worst = 0.0f32;
    for k in 0..springs.touching.len() {
        let f = springs.forces[k].normal_force;
        // Not `<= floor`: a NaN force fails the host's `> floor` too.
        if !springs.touching[k] || f.abs().partial_cmp(&floor) != Some(std::cmp::Ordering::Greater)
        {
            continue;
        }
        let (i, other) = world.contacts.partners(k);
        let i = i as usize;
        let (p, r_eff, share, s) = match other {
            Partner::Body(j) => {
                let j = j as usize;
                let (ri, rj) = (c.equivalent_radius[i], c.equivalent_radius[j]);
                (
                    *world.pair_params(c.material[i], c.material[j]),
                    ri * rj / (ri + rj),
                    law::point_share(c.is_sphere[i], c.is_sphere[j]),
                    size(i).min(size(j)),
                )
            }
            Partner::Wall(w) => (
                *world.pair_params(world.walls[w as usize].material, c.material[i]),
                c.equivalent_radius[i],
                law::point_share(c.is_sphere[i], c.is_sphere[i]),
                size(i),
            ),
            Partner::Boundary(_) => continue,
        };
        worst = worst.max(law::depth_at_force(&p, r_eff, f, share) / (OVERLAP_LIMIT * s));
    }
    worst
}

/// The GPU's deep-overlap alarm fires at every check step where the host's cheap check would
/// measure a contact (its force, all on one point, means an overlap beyond the limit), and
/// not where every such estimate is below 0.98 of the limit (the margin is 0.99, for the
/// f32 rounding on either side): soft spheres and a cube land on
/// the floor one after the other, so each contact's estimate rises through the limit and
/// falls back.
#[test]
fn the_overlap_alarm_fires_where_the_host_would_look() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut text = String::from(
        "[simulation]\nsteps = 400\ndt = 1.0e-4\ngravity = [0.0, 0.0, 0.0]\n\n[[material]]\nname = \"m\"\ndensity = 1000.0\nstiffness = 300.0\nrestitution = 0.5\n\n[[shape]]\nname = \"ball\"\nsphere = { radius = 0.01 }\n\n[[shape]]\nname = \"cube\"\nbox = { half_extents = [0.008, 0.008, 0.008] }\n\n[container]\nmin = [0.0, 0.0, 0.0]\nmax = [0.2, 0.2, 0.3]\nmaterial = \"m\"\n",
    );
    // (shape, half height, speed, landing time): one contact at a time.
    let drops = [
        ("ball", 0.01, 1.0, 0.005),
        ("cube", 0.008, 0.6, 0.04),
        ("ball", 0.01, 2.5, 0.075),
    ];
    for (k, (shape, half, v, t)) in drops.iter().enumerate() {
        let x = 0.04 + 0.05 * k as f64;
        text.push_str(&format!(
            "\n[[body]]\nshape = \"{shape}\"\nmaterial = \"m\"\nposition = [{x}, 0.1, {}]\nvelocity = [0.0, 0.0, {}]\n",
            half + v * t,
            -v
        ));
    }
    let start = world(&text);
    let h = Health::new(&start);
    let mut gpu = GpuWorld::new(ctx, &start).expect("fits");
    gpu.set_health(&start, setup(&start, 0));
    let mut w = start.clone();
    let (mut must, mut calm) = (0, 0);
    for _ in 0..110 {
        let report = gpu.step_into(10, &mut w).expect("steps");
        assert!(report.bad_body.is_none());
        w.set_contact_state(gpu.contact_state().expect("reads"));
        assert_eq!(w.step_count % 10, 0, "stopped at a check step");
        let ratio = host_depth_ratio(&w, h.force_floor());
        if ratio > 1.0 {
            must += 1;
            assert!(
                report.alarm,
                "step {}: the host would measure a contact (depth estimate {ratio} of the limit) but the GPU raised no alarm",
                w.step_count
            );
        } else if ratio > 0.0 && ratio < 0.98 {
            // A contact above the force floor that the host would not measure.
            calm += 1;
            assert!(
                !report.alarm,
                "step {}: an alarm with every depth estimate below the margin ({ratio} of the limit)",
                w.step_count
            );
        }
        if report.alarm {
            gpu.clear_alarm().expect("clears");
        }
    }
    assert!(
        must > 0 && calm > 0,
        "the estimates crossed the limit ({must} check steps) and stayed above the force floor but below the limit ({calm})"
    );
}
