//! The Hertz-Mindlin tangential law (`hertz-mindlin`): a sphere resting on a floor under
//! gravity is kicked sideways and, held by friction (`mu = 10`), rocks on its tangential
//! spring. The contact point's slip `u` (centre velocity less `R w`) is a damped oscillator
//! with mass `m_t = 2/7 m` (translation and spin both answer the force), Mindlin's stiffness
//! `k_t = 8 G* sqrt(R d)` at Hertz's static overlap `d`, and the Hertz-Mindlin damping
//! `g_t = 2 sqrt(5/6) beta sqrt(m k_t)`, `beta = -ln e / sqrt(pi^2 + ln^2 e)` (LIGGGHTS'
//! `hertz` with `tangential history`).
//!
//! Truth: the closed form of that oscillator, `u'(t) = v0 e^(-z w t) (cos w_d t - z w / w_d
//! sin w_d t)`: its period `2 pi / w_d` and its decay from one velocity peak to the next,
//! `exp(-z w 2 pi / w_d)`. Tolerances: 1% on the period, 3% on the logarithmic decrement
//! (the tangential spring is stepped explicitly, first order in dt; measured 0.4-0.9% at the
//! default step).

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};

use super::{Ctx, Outcome, Row};
use crate::plot::{Panel, Series, chart};

/// The check's name.
pub const NAME: &str = "hertz-mindlin";

const R: f64 = 0.01;
const DENSITY: f64 = 2500.0;
const YOUNG: f64 = 5.0e7;
const POISSON: f64 = 0.3;
const G: f64 = 9.81;
const V0: f64 = 2.0e-4;

/// One case's plot data: e, times (ms), measured and closed-form slip velocities.
type Curve = (f64, Vec<f64>, Vec<f64>, Vec<f64>);

/// The closed form's `(zeta, w_n, w_d)` for restitution `e`, and the static overlap.
fn oscillator(e: f64, mass: f64) -> (f64, f64, f64, f64) {
    let e_star = YOUNG / (2.0 * (1.0 - POISSON * POISSON));
    let g_star = YOUNG / (4.0 * (2.0 - POISSON) * (1.0 + POISSON));
    let d = (3.0 * mass * G / (4.0 * e_star * R.sqrt())).powf(2.0 / 3.0);
    let k_t = 8.0 * g_star * (R * d).sqrt();
    let ln_e = e.ln();
    let beta = -ln_e / (std::f64::consts::PI.powi(2) + ln_e * ln_e).sqrt();
    let g_t = 2.0 * (5.0f64 / 6.0).sqrt() * beta * (mass * k_t).sqrt();
    let m_t = 2.0 / 7.0 * mass;
    let w_n = (k_t / m_t).sqrt();
    let zeta = g_t / (2.0 * (k_t * m_t).sqrt());
    (zeta, w_n, w_n * (1.0 - zeta * zeta).sqrt(), d)
}

/// The check: e = 0.8 (and 0.65 in the full suite).
pub fn check(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let es: &[f64] = if ctx.quick { &[0.8] } else { &[0.8, 0.65] };
    let mut rows = Vec::new();
    let mut curves: Vec<Curve> = Vec::new();
    for &e in es {
        ctx.progress(&format!("{NAME}: e = {e}"));
        let shape = ShapeKind::Sphere { radius: R }.prepare().expect("sphere");
        let mass = DENSITY * shape.volume as f64;
        let (zeta, w_n, w_d, d) = oscillator(e, mass);
        let period = 2.0 * std::f64::consts::PI / w_d;
        let decay = (-zeta * w_n * period).exp();
        let material = Material::new(
            "m",
            DENSITY as f32,
            ContactLaw::Hertz {
                youngs_modulus: YOUNG as f32,
                poisson_ratio: POISSON as f32,
            },
            e as f32,
            10.0,
        );
        let world = World::new(WorldDesc {
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
        let dt = world.dt as f64;
        let mut sim = ctx.sim(world)?;
        sim.run_for(0.05)?;
        sim.restart_with(|w| w.state.velocity[0].x = V0 as f32)?;
        let steps = (2.5 * period / dt).ceil() as usize;
        let mut slip = Vec::with_capacity(steps);
        for _ in 0..steps {
            sim.step(1)?;
            let s = &sim.world.state;
            slip.push(s.velocity[0].x as f64 - R * s.omega[0].y as f64);
        }
        // Positive velocity peaks, refined by a parabola through three samples.
        let peaks: Vec<(f64, f64)> = (1..slip.len().saturating_sub(1))
            .filter(|&k| slip[k] > 0.0 && slip[k] >= slip[k - 1] && slip[k] > slip[k + 1])
            .map(|k| {
                let (a, b, c) = (slip[k - 1], slip[k], slip[k + 1]);
                let shift = 0.5 * (a - c) / (a - 2.0 * b + c);
                ((k as f64 + shift) * dt, b - 0.25 * (a - c) * shift)
            })
            .collect();
        let case = format!("e={e} R=10mm E=50MPa");
        let truth = "damped oscillator, m_t = 2/7 m";
        let (measured_period, measured_decrement) = match peaks.as_slice() {
            [p0, p1, ..] => (p1.0 - p0.0, -(p1.1 / p0.1).ln()),
            _ => (f64::NAN, f64::NAN),
        };
        rows.push(Row::relative(
            NAME,
            &case,
            "period (s)",
            period,
            measured_period,
            0.01,
            truth,
            dt,
        ));
        rows.push(Row::relative(
            NAME,
            &case,
            "log decrement per period",
            -decay.ln(),
            measured_decrement,
            0.03,
            truth,
            dt,
        ));
        let ts: Vec<f64> = (1..=slip.len()).map(|k| k as f64 * dt * 1e3).collect();
        let analytic: Vec<f64> = ts
            .iter()
            .map(|&t_ms| {
                let t = t_ms * 1e-3;
                V0 * (-zeta * w_n * t).exp()
                    * ((w_d * t).cos() - zeta * w_n / w_d * (w_d * t).sin())
            })
            .collect();
        curves.push((e, ts, slip, analytic));
    }
    let labels: Vec<(String, String)> = curves
        .iter()
        .map(|(e, ..)| (format!("clatter e={e}"), format!("closed form e={e}")))
        .collect();
    let mut series = Vec::new();
    for ((_, ts, slip, analytic), (measured, closed)) in curves.iter().zip(&labels) {
        series.push(Series::points(measured, ts, slip));
        series.push(Series::line(closed, ts, analytic));
    }
    let svg = chart(
        "Hertz-Mindlin: slip velocity of a sphere rocking on its tangential spring",
        &[Panel {
            y_label: "slip velocity (m/s)",
            x_label: "time (ms)",
            series,
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{NAME}.svg"), svg)],
    })
}
