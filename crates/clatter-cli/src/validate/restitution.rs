//! The coefficient of restitution at the default time step (`World` picks `t_c / 50` when
//! `WorldDesc.dt` is `None`): head-on sphere-wall and sphere-sphere impacts, linear and Hertz,
//! `e` in {0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0}, no gravity, no friction. One world per case,
//! so that each runs at its own default step.
//!
//! Truth: the requested `e` (the material's restitution; both sides of a pair, wall
//! included, have it, so the combined `sqrt(e_a e_b)` is `e`). Tolerance 0.5% relative: what
//! the contact law promises at the default step (issue 14). The measured `e` is the ratio of
//! the outgoing to the incoming normal relative velocity.

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, PairParams, Wall, World, WorldDesc};
use glam::{Quat, Vec3};

use super::{Ctx, Outcome, Row};
use crate::plot::{Panel, Series, chart};

/// The check's name (its rows may fail until the law meets `e` at the default step).
pub const NAME: &str = "restitution-default-dt";

const TOL: f64 = 0.005;
const R: f64 = 0.01;
const DENSITY: f32 = 2500.0;
const V0: f32 = 0.5;

fn material(hertz: bool, e: f64) -> Material {
    let law = if hertz {
        ContactLaw::Hertz {
            youngs_modulus: 5.0e9,
            poisson_ratio: 0.3,
        }
    } else {
        ContactLaw::Linear { stiffness: 2.0e4 }
    };
    Material::new("m", DENSITY, law, e as f32, 0.0)
}

fn body(shape: u32, position: Vec3, velocity: Vec3) -> BodyInit {
    BodyInit {
        shape,
        material: 0,
        position: position.as_dvec3(),
        orientation: Quat::IDENTITY,
        velocity,
        angular_velocity: Vec3::ZERO,
    }
}

/// One head-on impact at the default step; returns (measured e, dt).
fn impact(ctx: &Ctx, hertz: bool, wall: bool, e: f64) -> anyhow::Result<(f64, f64)> {
    let m = material(hertz, e);
    let shape = ShapeKind::Sphere { radius: R }.prepare().expect("sphere");
    let mass = DENSITY as f64 * shape.volume as f64;
    let build = |gap: f32| -> World {
        let (bodies, walls) = if wall {
            (
                vec![body(
                    0,
                    Vec3::new(0.0, 0.0, R as f32 + gap),
                    Vec3::new(0.0, 0.0, -V0),
                )],
                vec![Wall {
                    plane: Plane {
                        normal: Vec3::Z,
                        offset: 0.0,
                    },
                    material: 0,
                }],
            )
        } else {
            (
                vec![
                    body(
                        0,
                        Vec3::new(0.0, 0.0, -(R as f32) - gap / 2.0),
                        Vec3::new(0.0, 0.0, V0),
                    ),
                    body(
                        0,
                        Vec3::new(0.0, 0.0, R as f32 + gap / 2.0),
                        Vec3::new(0.0, 0.0, -V0),
                    ),
                ],
                vec![],
            )
        };
        World::new(WorldDesc {
            shapes: vec![shape.clone()],
            materials: vec![m.clone()],
            walls,
            bodies,
            gravity: Vec3::ZERO,
            dt: None,
            skin: None,
            periodic: None,
        })
    };
    let dt = build(0.0).dt as f64;
    let speed = if wall { V0 } else { 2.0 * V0 } as f64;
    let gap = 1.5 * speed * dt;
    let world = build(gap as f32);
    let params = PairParams::combine(&m, &m);
    let (m_eff, r_eff) = if wall {
        (mass, R)
    } else {
        (mass / 2.0, R / 2.0)
    };
    let tc = params.contact_duration(m_eff, r_eff, speed);
    let steps = ((gap / speed + 3.0 * tc) / dt).ceil() as u64 + 5;
    let mut sim = ctx.sim(world)?;
    sim.step(steps)?;
    let v = &sim.world.state.velocity;
    let out = if wall {
        v[0].z as f64
    } else {
        (v[1].z - v[0].z) as f64
    };
    Ok((out / speed, dt))
}

/// The check.
pub fn check(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let es = [0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0];
    let mut rows = Vec::new();
    let mut curves: Vec<(String, Vec<f64>)> = Vec::new();
    for hertz in [false, true] {
        for wall in [true, false] {
            let label = format!(
                "{} {}",
                if hertz { "hertz" } else { "linear" },
                if wall { "sphere-wall" } else { "sphere-sphere" }
            );
            ctx.progress(&format!("{NAME}: {label}"));
            let mut ys = Vec::new();
            for &e in &es {
                let (measured, dt) = impact(ctx, hertz, wall, e)?;
                rows.push(Row::relative(
                    NAME,
                    &format!("{label} e={e}"),
                    "restitution",
                    e,
                    measured,
                    TOL,
                    "requested e",
                    dt,
                ));
                ys.push(measured / e);
            }
            curves.push((label, ys));
        }
    }
    let xs: Vec<f64> = es.to_vec();
    let ones = vec![1.0; es.len()];
    let lo = vec![1.0 - TOL; es.len()];
    let hi = vec![1.0 + TOL; es.len()];
    let mut series: Vec<Series> = curves
        .iter()
        .map(|(l, ys)| Series::points(l, &xs, ys))
        .collect();
    series.push(Series::line("requested", &xs, &ones));
    series.push(Series::dashed("-0.5%", &xs, &lo));
    series.push(Series::dashed("+0.5%", &xs, &hi));
    let svg = chart(
        "Restitution at the default time step (t_c/50)",
        &[Panel {
            y_label: "measured e / requested e",
            x_label: "requested e",
            series,
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{NAME}.svg"), svg)],
    })
}
