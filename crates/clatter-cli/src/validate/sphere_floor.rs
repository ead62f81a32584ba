//! A 0.2 m sphere of density 2600 kg/m^3 on a floor with a stiff linear spring (k = 10^6 N/m),
//! g = 9.81 m/s^2, at the default time step (t_c/50): four closed-form checks that used to be
//! presented as the MFIX cases DEM01-DEM04 (they are not the published set-ups; those are in
//! `mfix.rs`), kept under names that say what they are.
//!
//! - `free-fall-kn1e6`, free fall and first contact: the time of first contact
//!   `sqrt(2 (h0 - r) / g)`, the impact speed `sqrt(2 g (h0 - r))` (closed forms, 2%).
//! - `bounce-heights-kn1e6`, bouncing: apex heights `h_k = (h0 - r) e^(2k) + r` (e = 0.9). The
//!   apex of each flight is taken from the state just after the contact (`z + v^2 / 2g`, exact
//!   for the ballistic flight). Tolerance `1% * k` on `h_k - r`: `e` is promised within 0.5%
//!   and the height compounds it `2k` times.
//! - `two-sphere-stack-kn1e6`, two stacked spheres (r = 0.1 and 0.05 m) settled on the floor:
//!   the equilibrium overlaps `(m1 + m2) g / k` (floor) and `m2 g / k` (between them), 2%.
//! - `slip-to-roll-kn1e6`, slip to roll: a sphere launched at `u0 = 3 m/s` on a floor with
//!   `mu = 0.3` slides until `t = 2 u0 / (7 mu g)` and then rolls at `5/7 u0` (2%); the rolling
//!   time is where a straight line fitted to the slip speed during sliding reaches zero.

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};

use super::{Ctx, Outcome, Row};
use crate::plot::{Panel, Series, chart};

/// The check of free fall and first contact.
pub const FREE_FALL: &str = "free-fall-kn1e6";
/// The check of bounce heights.
pub const BOUNCE_HEIGHTS: &str = "bounce-heights-kn1e6";
/// The check of two stacked spheres settled.
pub const TWO_SPHERE_STACK: &str = "two-sphere-stack-kn1e6";
/// The check of slip to roll.
pub const SLIP_TO_ROLL: &str = "slip-to-roll-kn1e6";

const G: f64 = 9.81;
const K: f32 = 1.0e6;
const DENSITY: f32 = 2600.0;
const R: f64 = 0.1;

fn world(radii: &[f64], z: &[f64], v: Vec3, e: f64, mu: f64) -> World {
    let material = Material::new(
        "sphere-floor",
        DENSITY,
        ContactLaw::Linear { stiffness: K },
        e as f32,
        mu as f32,
    );
    World::new(WorldDesc {
        shapes: radii
            .iter()
            .map(|r| ShapeKind::Sphere { radius: *r }.prepare().expect("sphere"))
            .collect(),
        materials: vec![material],
        walls: vec![Wall {
            plane: Plane {
                normal: Vec3::Z,
                offset: 0.0,
            },
            material: 0,
        }],
        bodies: z
            .iter()
            .enumerate()
            .map(|(i, z)| BodyInit {
                shape: i as u32,
                material: 0,
                position: Vec3::new(0.0, 0.0, *z as f32).as_dvec3(),
                orientation: Quat::IDENTITY,
                velocity: if i == 0 { v } else { Vec3::ZERO },
                angular_velocity: Vec3::ZERO,
            })
            .collect(),
        gravity: Vec3::new(0.0, 0.0, -G as f32),
        dt: None,
        skin: None,
        periodic: None,
    })
}

fn mass(r: f64) -> f64 {
    DENSITY as f64 * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)
}

/// `(t, z, v_z)` of the sphere.
type Sample = (f64, f64, f64);

/// The bouncing sphere from `h0`: samples `(t, z, v_z)` every `every` steps for `seconds`.
fn bounce(
    ctx: &Ctx,
    h0: f64,
    e: f64,
    seconds: f64,
    every: u64,
) -> anyhow::Result<(Vec<Sample>, f64)> {
    let w = world(&[R], &[h0], Vec3::ZERO, e, 0.0);
    let dt = w.dt as f64;
    let mut sim = ctx.sim(w)?;
    let mut samples = vec![(0.0, h0, 0.0)];
    let n = (seconds / dt / every as f64).ceil() as u64;
    for _ in 0..n {
        sim.step(every)?;
        let w = &sim.world;
        samples.push((w.time, w.state.position[0].z, w.state.velocity[0].z as f64));
    }
    Ok((samples, dt))
}

/// Free fall and the first contact.
pub fn free_fall(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = FREE_FALL;
    let h0 = 0.5;
    let e = 0.9;
    let t_hit = (2.0 * (h0 - R) / G).sqrt();
    ctx.progress(&format!("{name}: free fall from {h0} m"));
    let (s, dt) = bounce(ctx, h0, e, 1.2 * t_hit, 1)?;
    // First contact: interpolate the centre crossing z = r.
    let k = s.iter().position(|p| p.1 < R).unwrap_or(s.len() - 1);
    let (a, b) = (s[k.saturating_sub(1)], s[k]);
    let t_meas = a.0 + (b.0 - a.0) * (a.1 - R) / (a.1 - b.1);
    let v_meas = -a.2;
    let v_true = (2.0 * G * (h0 - R)).sqrt();
    let rows = vec![
        Row::relative(
            name,
            "h0=0.5 m",
            "time of first contact (s)",
            t_hit,
            t_meas,
            0.02,
            "free fall closed form",
            dt,
        ),
        Row::relative(
            name,
            "h0=0.5 m",
            "impact speed (m/s)",
            v_true,
            v_meas,
            0.02,
            "free fall closed form",
            dt,
        ),
    ];
    let t: Vec<f64> = s.iter().map(|p| p.0).collect();
    let z: Vec<f64> = s.iter().map(|p| p.1).collect();
    let za: Vec<f64> = t
        .iter()
        .map(|t| {
            if *t < t_hit {
                h0 - 0.5 * G * t * t
            } else {
                f64::NAN
            }
        })
        .collect();
    let svg = chart(
        "Free fall onto a floor, k = 1e6 N/m",
        &[Panel {
            y_label: "centre height (m)",
            x_label: "time (s)",
            series: vec![
                Series::line("clatter", &t, &z),
                Series::dashed("h0 - g t^2/2", &t, &za),
            ],
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// The sequence of bounce heights.
pub fn bounce_heights(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = BOUNCE_HEIGHTS;
    let (h0, e): (f64, f64) = (0.5, 0.9);
    let bounces: i32 = if ctx.quick { 3 } else { 5 };
    // Flight times shrink by e each bounce: sum of 2 sqrt(2 (h_k - r)/g).
    let mut seconds = (2.0 * (h0 - R) / G).sqrt();
    for k in 1..=bounces {
        seconds += 2.0 * (2.0 * (h0 - R) * e.powi(2 * k) / G).sqrt();
    }
    ctx.progress(&format!("{name}: {bounces} bounces, {seconds:.2} s"));
    let (s, dt) = bounce(ctx, h0, e, seconds * 1.02, 5)?;
    let mut apex = Vec::new();
    let mut touching = false;
    for p in &s {
        if p.1 < R {
            touching = true;
        } else if touching && p.2 > 0.0 {
            apex.push(p.1 + p.2 * p.2 / (2.0 * G));
            touching = false;
        }
    }
    let mut rows = Vec::new();
    let (mut ks, mut hm, mut ht) = (Vec::new(), Vec::new(), Vec::new());
    for k in 1..=bounces {
        let expected = (h0 - R) * e.powi(2 * k);
        let measured = apex.get(k as usize - 1).map_or(f64::NAN, |h| h - R);
        rows.push(Row::relative(
            name,
            &format!("k={k}"),
            "apex height h_k - r (m)",
            expected,
            measured,
            0.01 * k as f64,
            "(h0 - r) e^2k",
            dt,
        ));
        ks.push(k as f64);
        hm.push(measured);
        ht.push(expected);
    }
    let t: Vec<f64> = s.iter().map(|p| p.0).collect();
    let z: Vec<f64> = s.iter().map(|p| p.1 - R).collect();
    let svg = chart(
        "Bouncing sphere, k = 1e6 N/m, e = 0.9",
        &[
            Panel {
                y_label: "centre height - r (m)",
                x_label: "time (s)",
                series: vec![Series::line("clatter", &t, &z)],
                log: false,
            },
            Panel {
                y_label: "apex height h_k - r (m)",
                x_label: "bounce k",
                series: vec![
                    Series::points("clatter", &ks, &hm),
                    Series::dashed("(h0 - r) e^2k", &ks, &ht),
                ],
                log: false,
            },
        ],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// Two stacked spheres at rest on the floor.
pub fn two_sphere_stack(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = TWO_SPHERE_STACK;
    let (r1, r2) = (R, 0.05);
    let (m1, m2) = (mass(r1), mass(r2));
    let k = K as f64;
    let w = world(&[r1, r2], &[r1, 2.0 * r1 + r2], Vec3::ZERO, 0.3, 0.0);
    let dt = w.dt as f64;
    let tc = std::f64::consts::PI * (m2 / k).sqrt();
    ctx.progress(&format!("{name}: settling for 200 contact times"));
    let mut sim = ctx.sim(w)?;
    let mut t = Vec::new();
    let mut d1 = Vec::new();
    let mut d2 = Vec::new();
    for _ in 0..100 {
        sim.run_for(2.0 * tc)?;
        let p = &sim.world.state.position;
        t.push(sim.world.time);
        d1.push(r1 - p[0].z);
        d2.push(r1 + r2 - (p[1].z - p[0].z));
    }
    let e1 = (m1 + m2) * G / k;
    let e2 = m2 * G / k;
    let rows = vec![
        Row::relative(
            name,
            "r=0.1,0.05 m",
            "floor overlap (m)",
            e1,
            *d1.last().expect("samples"),
            0.02,
            "(m1 + m2) g / k",
            dt,
        ),
        Row::relative(
            name,
            "r=0.1,0.05 m",
            "sphere-sphere overlap (m)",
            e2,
            *d2.last().expect("samples"),
            0.02,
            "m2 g / k",
            dt,
        ),
    ];
    let c1 = vec![e1; t.len()];
    let c2 = vec![e2; t.len()];
    let svg = chart(
        "Two stacked spheres settling on a floor, k = 1e6 N/m",
        &[Panel {
            y_label: "overlap (m)",
            x_label: "time (s)",
            series: vec![
                Series::line("floor", &t, &d1),
                Series::dashed("(m1+m2) g/k", &t, &c1),
                Series::line("between", &t, &d2),
                Series::dashed("m2 g/k", &t, &c2),
            ],
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// A sliding sphere ends rolling.
pub fn slip_to_roll(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = SLIP_TO_ROLL;
    let (u0, mu) = (3.0, 0.3);
    let m = mass(R);
    let z0 = R - m * G / K as f64;
    let w = world(&[R], &[z0], Vec3::new(u0 as f32, 0.0, 0.0), 0.9, mu);
    let dt = w.dt as f64;
    let t_roll = 2.0 * u0 / (7.0 * mu * G);
    ctx.progress(&format!("{name}: sliding for {t_roll:.3} s"));
    let mut sim = ctx.sim(w)?;
    let (mut t, mut v, mut rw, mut slip) = (vec![0.0], vec![u0], vec![0.0], vec![u0]);
    while sim.world.time < 2.0 * t_roll {
        sim.step(5)?;
        let s = &sim.world.state;
        let (vx, wy) = (s.velocity[0].x as f64, s.omega[0].y as f64);
        t.push(sim.world.time);
        v.push(vx);
        rw.push(R * wy);
        slip.push(vx - R * wy);
    }
    // Straight line through the slip speed while clearly sliding (between 80% and 20% of u0).
    let pts: Vec<(f64, f64)> = t
        .iter()
        .zip(&slip)
        .filter(|(_, s)| **s < 0.8 * u0 && **s > 0.2 * u0)
        .map(|(t, s)| (*t, *s))
        .collect();
    let n = pts.len() as f64;
    let (mt, ms) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let slope = pts.iter().map(|p| (p.0 - mt) * (p.1 - ms)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mt).powi(2)).sum::<f64>();
    let t_meas = mt - ms / slope;
    let v_end = *v.last().expect("samples");
    let rw_end = *rw.last().expect("samples");
    let rows = vec![
        Row::relative(
            name,
            "u0=3 mu=0.3",
            "time to rolling (s)",
            t_roll,
            t_meas,
            0.02,
            "2 u0 / (7 mu g)",
            dt,
        ),
        Row::relative(
            name,
            "u0=3 mu=0.3",
            "final velocity (m/s)",
            5.0 / 7.0 * u0,
            v_end,
            0.02,
            "5/7 u0",
            dt,
        ),
        Row::relative(
            name,
            "u0=3 mu=0.3",
            "final R w (m/s)",
            5.0 / 7.0 * u0,
            rw_end,
            0.02,
            "5/7 u0",
            dt,
        ),
    ];
    let va: Vec<f64> = t
        .iter()
        .map(|t| {
            if *t < t_roll {
                u0 - mu * G * t
            } else {
                5.0 / 7.0 * u0
            }
        })
        .collect();
    let rwa: Vec<f64> = t.iter().map(|t| 2.5 * mu * G * t.min(t_roll)).collect();
    let svg = chart(
        "Slip to roll on a rough floor, k = 1e6 N/m",
        &[Panel {
            y_label: "velocity, R w (m/s)",
            x_label: "time (s)",
            series: vec![
                Series::line("v clatter", &t, &v),
                Series::dashed("v analytic", &t, &va),
                Series::line("R w clatter", &t, &rw),
                Series::dashed("R w analytic", &t, &rwa),
            ],
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}
