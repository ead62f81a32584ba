//! Conservation laws:
//! - `energy-gas`: frictionless, perfectly elastic (`e = 1`) spheres in a closed box of
//!   `e = 1` walls: kinetic plus elastic energy (`k d^2 / 2` per contact) stays within 1% of
//!   its start over the run (semi-implicit Euler's energy error at t_c/50 is bounded, of order
//!   `(omega dt)^2`, and does not accumulate).
//! - `momentum-periodic`: a damped, frictional cloud in a fully periodic box (two thirds
//!   spheres, one third randomly oriented cubes), no gravity: the total momentum changes only
//!   by f32 rounding, `|dP| / sum m|v| <= 1e-5`.
//! - `symmetric-top`: a free box with two equal principal moments (`I1 = I2 != I3`) spinning
//!   about an axis off its symmetry axis: the body-frame angular velocity precesses about the
//!   symmetry axis at `Omega = (I3 - I1) / I1 w3` (Euler's equations, closed form; 2%), the
//!   angular momentum stays constant (1e-5 relative) and so does the rotational energy (1%).

use clatter::geom::narrow::Plane;
use clatter::geom::{RegularKind, ShapeKind};
use clatter::{BodyInit, ContactLaw, Material, Periodic, Wall, World, WorldDesc};
use glam::{DVec3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Ctx, Outcome, Row};
use crate::plot::{Panel, Series, chart};

const R: f32 = 0.01;
const K: f32 = 2.0e4;

fn rand_vec(rng: &mut ChaCha8Rng) -> Vec3 {
    Vec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    )
}

/// `n^3` spheres on a jittered lattice of pitch `pitch` starting at `pitch / 2`, random
/// velocities of up to `speed` per component.
fn lattice(n: usize, pitch: f32, speed: f32, seed: u64) -> Vec<BodyInit> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut bodies = Vec::new();
    for i in 0..n * n * n {
        let c = Vec3::new(
            (i % n) as f32 + 0.5,
            ((i / n) % n) as f32 + 0.5,
            (i / (n * n)) as f32 + 0.5,
        );
        let jitter = rand_vec(&mut rng) * 0.1;
        bodies.push(BodyInit {
            shape: 0,
            material: 0,
            position: ((c + jitter) * pitch).as_dvec3(),
            orientation: Quat::IDENTITY,
            velocity: rand_vec(&mut rng) * speed,
            angular_velocity: Vec3::ZERO,
        });
    }
    bodies
}

/// Kinetic plus elastic energy of the spheres of `w` (linear stiffness `K` everywhere).
fn energy(w: &World) -> f64 {
    let p = &w.state.position;
    let mut e = w.kinetic_energy();
    let k = K as f64;
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = 2.0 * R as f64 - (p[i] - p[j]).length();
            if d > 0.0 {
                e += 0.5 * k * d * d;
            }
        }
        for wall in &w.walls {
            let d = R as f64 - (wall.plane.normal.as_dvec3().dot(p[i]) - wall.plane.offset as f64);
            if d > 0.0 {
                e += 0.5 * k * d * d;
            }
        }
    }
    e
}

/// The elastic gas in a box.
pub fn energy_gas(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = "energy-gas";
    let n = if ctx.quick { 3 } else { 6 };
    let pitch = 4.0 * R;
    let side = n as f32 * pitch;
    let material = Material::new("gas", 2500.0, ContactLaw::Linear { stiffness: K }, 1.0, 0.0);
    let walls = [
        (Vec3::X, 0.0),
        (-Vec3::X, -side),
        (Vec3::Y, 0.0),
        (-Vec3::Y, -side),
        (Vec3::Z, 0.0),
        (-Vec3::Z, -side),
    ]
    .into_iter()
    .map(|(normal, offset)| Wall {
        plane: Plane { normal, offset },
        material: 0,
    })
    .collect();
    let w = World::new(WorldDesc {
        shapes: vec![
            ShapeKind::Sphere { radius: R as f64 }
                .prepare()
                .expect("sphere"),
        ],
        materials: vec![material],
        walls,
        bodies: lattice(n, pitch, 0.5, 11),
        gravity: Vec3::ZERO,
        dt: None,
        skin: None,
        periodic: None,
    });
    let dt = w.dt as f64;
    let seconds = if ctx.quick { 0.3 } else { 2.0 };
    ctx.progress(&format!("{name}: {} spheres for {seconds} s", n * n * n));
    let mut sim = ctx.sim(w)?;
    let e0 = energy(&sim.world);
    let (mut t, mut rel) = (vec![0.0], vec![0.0]);
    while sim.world.time < seconds {
        sim.step(100)?;
        t.push(sim.world.time);
        rel.push(energy(&sim.world) / e0 - 1.0);
    }
    let worst = rel.iter().fold(0.0f64, |a, r| a.max(r.abs()));
    let rows = vec![Row::bound(
        name,
        &format!("{} spheres, {seconds} s", n * n * n),
        "max |E(t)/E0 - 1|",
        worst,
        0.01,
        "energy conserved (e = 1, no friction)",
        dt,
    )];
    let svg = chart(
        "Elastic frictionless spheres in a box: energy",
        &[Panel {
            y_label: "E(t)/E0 - 1",
            x_label: "time (s)",
            series: vec![Series::line("kinetic + elastic", &t, &rel)],
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// Momentum of a colliding cloud in a periodic box.
pub fn momentum_periodic(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = "momentum-periodic";
    let n = if ctx.quick { 4 } else { 8 };
    let pitch = 2.6 * R;
    let side = n as f32 * pitch;
    let material = Material::new(
        "cloud",
        2500.0,
        ContactLaw::Linear { stiffness: K },
        0.5,
        0.5,
    );
    let mut bodies = lattice(n, pitch, 1.0, 7);
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for (i, b) in bodies.iter_mut().enumerate() {
        b.angular_velocity = rand_vec(&mut rng) * 50.0;
        // Every third body a cube (circumradius R), randomly oriented.
        if i % 3 == 2 {
            b.shape = 1;
            b.orientation = clatter::scene::random_rotation(&mut rng);
        }
    }
    let w = World::new(WorldDesc {
        shapes: vec![
            ShapeKind::Sphere { radius: R as f64 }
                .prepare()
                .expect("sphere"),
            ShapeKind::Regular {
                kind: RegularKind::Cube,
                radius: R as f64,
            }
            .prepare()
            .expect("cube"),
        ],
        materials: vec![material],
        walls: vec![],
        bodies,
        gravity: Vec3::ZERO,
        dt: None,
        skin: None,
        periodic: Some(Periodic {
            min: Vec3::ZERO,
            max: Vec3::splat(side),
            axes: [true; 3],
        }),
    });
    let dt = w.dt as f64;
    let seconds = if ctx.quick { 0.1 } else { 0.5 };
    ctx.progress(&format!(
        "{name}: {} spheres and cubes for {seconds} s",
        n * n * n
    ));
    let momentum = |w: &World| DVec3::from(w.momentum());
    let scale = |w: &World| -> f64 {
        w.state
            .velocity
            .iter()
            .zip(&w.consts.mass)
            .map(|(v, m)| (v.length() * m) as f64)
            .sum()
    };
    let mut sim = ctx.sim(w)?;
    let p0 = momentum(&sim.world);
    let s0 = scale(&sim.world);
    let (mut t, mut drift, mut ke) = (vec![0.0], vec![0.0], vec![sim.world.kinetic_energy()]);
    while sim.world.time < seconds {
        sim.step(100)?;
        t.push(sim.world.time);
        drift.push((momentum(&sim.world) - p0).length() / s0);
        ke.push(sim.world.kinetic_energy());
    }
    let worst = drift.iter().fold(0.0f64, |a, d| a.max(*d));
    let rows = vec![Row::bound(
        name,
        &format!("{} spheres+cubes, {seconds} s", n * n * n),
        "max |P(t) - P0| / sum m|v0|",
        worst,
        1e-5,
        "momentum conserved",
        dt,
    )];
    let svg = chart(
        "Colliding cloud in a periodic box: momentum",
        &[
            Panel {
                y_label: "|P(t) - P0| / sum m|v0|",
                x_label: "",
                series: vec![Series::line("drift", &t, &drift)],
                log: false,
            },
            Panel {
                y_label: "kinetic energy (J, log)",
                x_label: "time (s)",
                series: vec![Series::line("kinetic", &t, &ke)],
                log: true,
            },
        ],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// Torque-free precession of a symmetric top.
pub fn symmetric_top(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = "symmetric-top";
    let desc = |omega: Vec3| WorldDesc {
        shapes: vec![
            ShapeKind::Box {
                half_extents: [0.01, 0.01, 0.03],
            }
            .prepare()
            .expect("box"),
        ],
        materials: vec![Material::new(
            "top",
            1000.0,
            ContactLaw::Linear { stiffness: K },
            0.5,
            0.5,
        )],
        walls: vec![],
        bodies: vec![BodyInit {
            shape: 0,
            material: 0,
            position: glam::DVec3::ZERO,
            orientation: Quat::IDENTITY,
            velocity: Vec3::ZERO,
            angular_velocity: omega,
        }],
        gravity: Vec3::ZERO,
        dt: Some(1.0e-4),
        skin: None,
        periodic: None,
    };
    // The principal frame and moments, from a probe world.
    let probe = World::new(desc(Vec3::ZERO));
    let q = probe.state.orientation[0];
    let i = probe.consts.inertia[0].as_dvec3();
    let s = (0..3)
        .find(|&k| {
            let (a, b) = (i[(k + 1) % 3], i[(k + 2) % 3]);
            (a - b).abs() < 1e-6 * a && (i[k] - a).abs() > 1e-3 * a
        })
        .expect("a symmetric box");
    let (i1, i3) = (i[(s + 1) % 3], i[s]);
    let (w1, w3) = (2.0, 10.0);
    let mut wb = DVec3::ZERO;
    wb[(s + 1) % 3] = w1;
    wb[s] = w3;
    let omega = q * wb.as_vec3();
    let w = World::new(desc(omega));
    let dt = w.dt as f64;
    let precession = (i3 - i1) / i1 * w3;
    let seconds = if ctx.quick { 1.0 } else { 4.0 };
    ctx.progress(&format!(
        "{name}: {seconds} s, expected precession {precession:.3} rad/s"
    ));
    let mut sim = ctx.sim(w)?;
    let l0 = sim.world.state.angular_momentum[0].as_dvec3();
    let e0 = sim.world.kinetic_energy();
    let (mut t, mut phase, mut a1, mut a2) = (vec![], vec![], vec![], vec![]);
    let mut l_drift = 0.0f64;
    let mut e_drift = 0.0f64;
    let mut unwrap = 0.0;
    let mut last = f64::NAN;
    loop {
        let st = &sim.world.state;
        let body = (st.orientation[0].inverse() * st.omega[0]).as_dvec3();
        let (x, y) = (body[(s + 1) % 3], body[(s + 2) % 3]);
        let mut ph = y.atan2(x);
        if last.is_finite() {
            while ph + unwrap - last > std::f64::consts::PI {
                unwrap -= 2.0 * std::f64::consts::PI;
            }
            while ph + unwrap - last < -std::f64::consts::PI {
                unwrap += 2.0 * std::f64::consts::PI;
            }
        }
        ph += unwrap;
        last = ph;
        t.push(sim.world.time);
        phase.push(ph);
        a1.push(x);
        a2.push(y);
        l_drift = l_drift.max((st.angular_momentum[0].as_dvec3() - l0).length() / l0.length());
        e_drift = e_drift.max((sim.world.kinetic_energy() / e0 - 1.0).abs());
        if sim.world.time >= seconds {
            break;
        }
        sim.step(50)?;
    }
    let n = t.len() as f64;
    let (mt, mp) = (t.iter().sum::<f64>() / n, phase.iter().sum::<f64>() / n);
    let rate = t
        .iter()
        .zip(&phase)
        .map(|(t, p)| (t - mt) * (p - mp))
        .sum::<f64>()
        / t.iter().map(|t| (t - mt).powi(2)).sum::<f64>();
    let case = "box 1:1:3, w=(2,0,10) body";
    let rows = vec![
        Row::relative(
            name,
            case,
            "body-frame precession rate (rad/s)",
            precession,
            rate,
            0.02,
            "(I3 - I1)/I1 w3",
            dt,
        ),
        Row::bound(
            name,
            case,
            "max |L(t) - L0| / |L0|",
            l_drift,
            1e-5,
            "L conserved",
            dt,
        ),
        Row::bound(
            name,
            case,
            "max |E(t)/E0 - 1|",
            e_drift,
            0.01,
            "rotational energy conserved",
            dt,
        ),
    ];
    let b1: Vec<f64> = t.iter().map(|t| w1 * (precession * t).cos()).collect();
    let b2: Vec<f64> = t.iter().map(|t| w1 * (precession * t).sin()).collect();
    let svg = chart(
        "Torque-free symmetric top: body-frame angular velocity",
        &[Panel {
            y_label: "body-frame w perpendicular to the axis (rad/s)",
            x_label: "time (s)",
            series: vec![
                Series::line("w1 clatter", &t, &a1),
                Series::dashed("w1 analytic", &t, &b1),
                Series::line("w2 clatter", &t, &a2),
                Series::dashed("w2 analytic", &t, &b2),
            ],
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}
