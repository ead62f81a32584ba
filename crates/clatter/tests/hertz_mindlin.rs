//! The Hertz-Mindlin tangential law: a sphere resting on a floor under gravity, its contact
//! point kicked sideways, sticks (high friction) and rocks on the tangential spring. The
//! contact point's slip `u` (centre velocity less `R w`) is then a damped oscillator with
//! effective mass `m_t = 2/7 m` (the sphere's translation and spin both answer the force),
//! Mindlin's stiffness `k_t = 8 G* sqrt(R d)` at the static overlap `d` of Hertz's law, and
//! the Hertz-Mindlin damping `g_t = 2 sqrt(5/6) beta sqrt(m k_t)`,
//! `beta = -ln e / sqrt(pi^2 + ln^2 e)` (LIGGGHTS' `hertz` with `tangential history`): its
//! period and the decay of its velocity peaks from one period to the next follow in closed
//! form.

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};
use step_backend::step_n;

const R: f64 = 0.01;
const DENSITY: f64 = 2500.0;
const YOUNG: f64 = 5.0e7;
const POISSON: f64 = 0.3;
const G: f64 = 9.81;
const E: f64 = 0.8;
const V0: f64 = 2.0e-4;

#[test]
fn tangential_oscillation_follows_hertz_mindlin() {
    let shape = ShapeKind::Sphere { radius: R }.prepare().unwrap();
    let m = DENSITY * shape.volume as f64;
    // Sphere and floor of one material: 1/E* = 2 (1 - v^2) / E, 1/G* = 4 (2 - v)(1 + v) / E.
    let e_star = 1.0 / (2.0 * (1.0 - POISSON * POISSON) / YOUNG);
    let g_star = 1.0 / (2.0 * 2.0 * (2.0 - POISSON) * (1.0 + POISSON) / YOUNG);
    // Static overlap: 4/3 E* sqrt(R) d^1.5 = m g.
    let d = (3.0 * m * G / (4.0 * e_star * R.sqrt())).powf(2.0 / 3.0);
    let k_t = 8.0 * g_star * (R * d).sqrt();
    let ln_e = E.ln();
    let beta = -ln_e / (std::f64::consts::PI.powi(2) + ln_e * ln_e).sqrt();
    let g_t = 2.0 * (5.0f64 / 6.0).sqrt() * beta * (m * k_t).sqrt();
    let m_t = 2.0 / 7.0 * m;
    let w_n = (k_t / m_t).sqrt();
    let zeta = g_t / (2.0 * (k_t * m_t).sqrt());
    let w_d = w_n * (1.0 - zeta * zeta).sqrt();
    let period = 2.0 * std::f64::consts::PI / w_d;
    let decay = (-zeta * w_n * period).exp();

    let material = Material::new(
        "m",
        DENSITY as f32,
        ContactLaw::Hertz {
            youngs_modulus: YOUNG as f32,
            poisson_ratio: POISSON as f32,
        },
        E as f32,
        10.0,
    );
    let mut w = World::new(WorldDesc {
        shapes: vec![shape],
        materials: vec![material],
        walls: vec![Wall {
            plane: Plane {
                normal: Vec3::Z,
                offset: 0.0,
            },
            material: 0,
        }],
        bodies: vec![BodyInit {
            shape: 0,
            material: 0,
            position: Vec3::new(0.0, 0.0, (R - d) as f32).as_dvec3(),
            orientation: Quat::IDENTITY,
            velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
        }],
        gravity: Vec3::new(0.0, 0.0, -G as f32),
        dt: None,
        skin: None,
        periodic: None,
    });
    // Let the normal contact settle (its own damping), then kick the centre sideways.
    let settle = (0.05 / w.dt as f64) as u64;
    step_n(&mut w, settle).unwrap();
    w.state.velocity[0].x = V0 as f32;
    // Slip velocity of the contact point, sampled every step for three periods.
    let steps = (3.0 * period / w.dt as f64).ceil() as usize;
    assert!(
        steps > 60,
        "{steps} steps per three periods: too coarse a test"
    );
    let mut slip = Vec::with_capacity(steps);
    for _ in 0..steps {
        step_n(&mut w, 1).unwrap();
        slip.push(w.state.velocity[0].x as f64 - R * w.state.omega[0].y as f64);
    }
    // Positive peaks (local maxima above zero), refined by a parabola through three samples.
    let dt = w.dt as f64;
    let peaks: Vec<(f64, f64)> = (1..slip.len() - 1)
        .filter(|&k| slip[k] > 0.0 && slip[k] >= slip[k - 1] && slip[k] > slip[k + 1])
        .map(|k| {
            let (a, b, c) = (slip[k - 1], slip[k], slip[k + 1]);
            let shift = 0.5 * (a - c) / (a - 2.0 * b + c);
            ((k as f64 + shift) * dt, b - 0.25 * (a - c) * shift)
        })
        .collect();
    assert!(peaks.len() >= 2, "peaks {peaks:?}");
    let measured_period = peaks[1].0 - peaks[0].0;
    let measured_decay = peaks[1].1 / peaks[0].1;
    eprintln!(
        "k_t {k_t:.4e} N/m, zeta {zeta:.4}: period {period:.4e} s measured {measured_period:.4e}; decay per period {decay:.4} measured {measured_decay:.4} ({:.0} steps per period)",
        period / dt
    );
    assert!(
        (measured_period / period - 1.0).abs() < 0.01,
        "period {period} measured {measured_period}"
    );
    // The damping rate (log decrement) within 3%.
    assert!(
        (measured_decay.ln() / decay.ln() - 1.0).abs() < 0.03,
        "decay per period {decay} measured {measured_decay}"
    );
}
