//! The impacts clatter checked under the names `chung-ooi-2`..`chung-ooi-8` before those
//! names took the published conditions: useful checks of their own, kept under names that say
//! what they are (docs/validation.md). Oblique cases run perfectly elastic (`e = 1`), which
//! makes the truth independent of how the tangential damping is defined: the rigid-body
//! Coulomb impulse ratio where the f64 integration of the same law
//! ([`reference::impact`]) finds the friction at its cap throughout the contact (gross
//! sliding), else that integration itself (at t_c/20000). Rebound tangential velocity and
//! spin cross zero as the angle varies, so their errors are normalised by the incident slip
//! speed of the contact point. Tolerance 2% ([`TOL`]).

use glam::DVec3;

use super::{AL_ALLOY_OLD, ALUMINA, Case, Solid, TOL, law, mass, material, run_cases};
use crate::plot::{Panel, Series, chart};
use crate::validate::reference::{self, Ball, Law};
use crate::validate::{Ctx, Outcome, Row};

/// The truth of an oblique case: the gross-sliding closed form where the f64 integration of
/// the same law slides throughout, else that integration.
pub fn oblique_truth(l: &Law, c: &Case) -> ((Ball, Ball), &'static str, (Ball, Ball)) {
    let (m_eff, r_eff) = if c.a.m.is_infinite() {
        (c.b.m, c.b.r)
    } else {
        (
            c.a.m * c.b.m / (c.a.m + c.b.m),
            c.a.r * c.b.r / (c.a.r + c.b.r),
        )
    };
    let vn = c.a.v.z - c.b.v.z;
    let (_, _, tc) = reference::hertz_impact(m_eff, r_eff, l.stiffness, vn);
    let start = |mut x: Ball| {
        x.x.z += 1e-12;
        x
    };
    let ode = reference::impact(l, c.a, start(c.b), tc / 20000.0);
    let sliding = reference::gross_sliding(l.friction, l.restitution, c.a, c.b);
    if ode.sliding_throughout {
        (sliding, "gross sliding closed form", sliding)
    } else {
        ((ode.a, ode.b), "f64 ODE, same law", sliding)
    }
}

/// Slip speed of the contact point before the impact (the scale of the oblique errors).
pub fn slip(c: &Case) -> f64 {
    let vb = c.b.v + c.b.w.cross(-DVec3::Z * c.b.r);
    let va = c.a.v + c.a.w.cross(DVec3::Z * c.a.r);
    let s = vb - va;
    (s - DVec3::Z * s.z).length()
}

/// Oblique cases: rows for b's rebound tangential velocity and spin, and a plot against
/// `xs` (the varied parameter).
#[allow(clippy::too_many_arguments)]
fn oblique(
    ctx: &Ctx,
    name: &str,
    title: &str,
    x_label: &str,
    labels: &[String],
    xs: &[f64],
    cases: &[Case],
    sphere: &Solid,
    wall: Option<&Solid>,
    mu: f64,
    angle_plot: bool,
) -> anyhow::Result<Outcome> {
    ctx.progress(&format!("{name}: {} impacts in one world", cases.len()));
    let l = law(sphere, wall.unwrap_or(sphere), 1.0, mu);
    let run = run_cases(
        ctx,
        cases,
        &material(sphere, 1.0, mu),
        wall.map(|w| material(w, 1.0, mu)).as_ref(),
        None,
        false,
    )?;
    ctx.progress(&format!("{name}: f64 reference integrations"));
    let mut rows = Vec::new();
    let mut plot: [Vec<f64>; 6] = Default::default();
    for (k, c) in cases.iter().enumerate() {
        let ((_, tb), truth, (_, sb)) = oblique_truth(&l, c);
        let (_, mb) = run.after[k];
        let scale = slip(c);
        rows.push(Row::normalised(
            name,
            &labels[k],
            "rebound v_t (m/s)",
            tb.v.x,
            mb.v.x,
            scale,
            TOL,
            truth,
            run.dt,
        ));
        rows.push(Row::normalised(
            name,
            &labels[k],
            "rebound R w (m/s)",
            tb.r * tb.w.y,
            mb.r * mb.w.y,
            scale,
            TOL,
            truth,
            run.dt,
        ));
        let value = |b: &Ball| {
            if angle_plot {
                (b.v.x / b.v.z).atan().to_degrees()
            } else {
                b.v.x
            }
        };
        plot[0].push(value(&mb));
        plot[1].push(value(&tb));
        plot[2].push(value(&sb));
        plot[3].push(mb.r * mb.w.y);
        plot[4].push(tb.r * tb.w.y);
        plot[5].push(sb.r * sb.w.y);
    }
    let y1 = if angle_plot {
        "rebound angle of the centre (deg)"
    } else {
        "rebound tangential velocity (m/s)"
    };
    let svg = chart(
        title,
        &[
            Panel {
                y_label: y1,
                x_label,
                series: vec![
                    Series::points("clatter", xs, &plot[0]),
                    Series::dashed("truth", xs, &plot[1]),
                    Series::line("gross sliding", xs, &plot[2]),
                ],
                log: false,
            },
            Panel {
                y_label: "rebound R w (m/s)",
                x_label,
                series: vec![
                    Series::points("clatter", xs, &plot[3]),
                    Series::dashed("truth", xs, &plot[4]),
                    Series::line("gross sliding", xs, &plot[5]),
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

pub fn wall_case(s: &Solid, r: f64, v: DVec3, w: DVec3) -> Case {
    Case {
        a: Ball::wall(),
        b: Ball {
            m: mass(s, r),
            r,
            x: DVec3::new(0.0, 0.0, r),
            v,
            w,
        },
    }
}

/// The earlier test 4: oblique impacts of an alumina sphere (R = 2.5 mm) on an aluminium-alloy plane
/// at 3.9 m/s, incident angles 5-85 deg from the normal, mu = 0.092, elastic.
pub fn oblique_alumina_on_alloy(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let angles: Vec<f64> = if ctx.quick {
        vec![10.0, 30.0, 50.0, 70.0]
    } else {
        (1..=17).map(|k| 5.0 * k as f64).collect()
    };
    let cases: Vec<Case> = angles
        .iter()
        .map(|a| {
            let t = a.to_radians();
            wall_case(
                &ALUMINA,
                0.0025,
                DVec3::new(3.9 * t.sin(), 0.0, -3.9 * t.cos()),
                DVec3::ZERO,
            )
        })
        .collect();
    let labels: Vec<String> = angles.iter().map(|a| format!("theta={a}deg")).collect();
    oblique(
        ctx,
        "oblique-alumina-on-alloy",
        "Oblique impacts, alumina on an Al-alloy plane, 3.9 m/s, elastic",
        "incident angle from the normal (deg)",
        &labels,
        &angles,
        &cases,
        &ALUMINA,
        Some(&AL_ALLOY_OLD),
        0.092,
        true,
    )
}

/// The earlier test 5: alumina on aluminium alloy (R = 2.5 mm, mu = 0.092, elastic) at a
/// normal speed of 5 m/s and tangential speeds 0.5-20 m/s.
pub fn oblique_alumina_vt_sweep(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let vts: Vec<f64> = if ctx.quick {
        vec![1.0, 5.0, 20.0]
    } else {
        vec![0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 10.0, 20.0]
    };
    let cases: Vec<Case> = vts
        .iter()
        .map(|vt| wall_case(&ALUMINA, 0.0025, DVec3::new(*vt, 0.0, -5.0), DVec3::ZERO))
        .collect();
    let labels: Vec<String> = vts.iter().map(|v| format!("vt={v}")).collect();
    oblique(
        ctx,
        "oblique-alumina-vt-sweep",
        "Alumina on Al alloy, normal speed 5 m/s, varied tangential speed, elastic",
        "incident tangential speed (m/s)",
        &labels,
        &vts,
        &cases,
        &ALUMINA,
        Some(&AL_ALLOY_OLD),
        0.092,
        false,
    )
}

/// The earlier test 6: alumina on aluminium alloy (R = 2.5 mm, mu = 0.092, elastic), normal
/// speed 1 m/s, no tangential velocity, initial spin R w = 0.1-5 m/s.
pub fn spin_alumina_on_alloy(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let rws: Vec<f64> = if ctx.quick {
        vec![0.2, 1.0, 5.0]
    } else {
        vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0]
    };
    let r = 0.0025;
    let cases: Vec<Case> = rws
        .iter()
        .map(|rw| {
            wall_case(
                &ALUMINA,
                r,
                DVec3::new(0.0, 0.0, -1.0),
                DVec3::new(0.0, rw / r, 0.0),
            )
        })
        .collect();
    let labels: Vec<String> = rws.iter().map(|v| format!("Rw={v}")).collect();
    oblique(
        ctx,
        "spin-alumina-on-alloy",
        "Spinning alumina sphere on an Al-alloy plane, normal speed 1 m/s, elastic",
        "incident R w (m/s)",
        &labels,
        &rws,
        &cases,
        &ALUMINA,
        Some(&AL_ALLOY_OLD),
        0.092,
        false,
    )
}

/// The earlier test 7: two identical aluminium-alloy spheres (R = 0.10 m, mu = 0.4, elastic),
/// each at 0.2 m/s toward the other, both spinning the same way (R w = 0.02-1 m/s): their
/// surfaces slide against each other (unlike Chung & Ooi test 7, where they roll together).
pub fn spin_pair_sliding(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let rws: Vec<f64> = if ctx.quick {
        vec![0.05, 0.2, 1.0]
    } else {
        vec![0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
    };
    let r = 0.10;
    let m = mass(&AL_ALLOY_OLD, r);
    let cases: Vec<Case> = rws
        .iter()
        .map(|rw| {
            let w = DVec3::new(0.0, rw / r, 0.0);
            Case {
                a: Ball {
                    m,
                    r,
                    x: DVec3::new(0.0, 0.0, -r),
                    v: DVec3::new(0.0, 0.0, 0.2),
                    w,
                },
                b: Ball {
                    m,
                    r,
                    x: DVec3::new(0.0, 0.0, r),
                    v: DVec3::new(0.0, 0.0, -0.2),
                    w,
                },
            }
        })
        .collect();
    let labels: Vec<String> = rws.iter().map(|v| format!("Rw={v}")).collect();
    oblique(
        ctx,
        "spin-pair-sliding",
        "Two identical spheres spinning the same way (sliding), 0.2 m/s each, elastic",
        "incident R w of each sphere (m/s)",
        &labels,
        &rws,
        &cases,
        &AL_ALLOY_OLD,
        None,
        0.4,
        false,
    )
}

/// The earlier test 8: aluminium-alloy spheres of unequal size (R = 0.10 and 0.05 m, mu = 0.4,
/// elastic), each at 0.2 m/s toward the other, the small one with tangential speed 0.02-1 m/s.
pub fn oblique_unequal_spheres(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let vts: Vec<f64> = if ctx.quick {
        vec![0.05, 0.2, 1.0]
    } else {
        vec![0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
    };
    let (ra, rb) = (0.10, 0.05);
    let cases: Vec<Case> = vts
        .iter()
        .map(|vt| Case {
            a: Ball {
                m: mass(&AL_ALLOY_OLD, ra),
                r: ra,
                x: DVec3::new(0.0, 0.0, -ra),
                v: DVec3::new(0.0, 0.0, 0.2),
                w: DVec3::ZERO,
            },
            b: Ball {
                m: mass(&AL_ALLOY_OLD, rb),
                r: rb,
                x: DVec3::new(0.0, 0.0, rb),
                v: DVec3::new(*vt, 0.0, -0.2),
                w: DVec3::ZERO,
            },
        })
        .collect();
    let labels: Vec<String> = vts.iter().map(|v| format!("vt={v}")).collect();
    oblique(
        ctx,
        "oblique-unequal-spheres",
        "Unequal spheres, normal speed 0.2 m/s each, varied tangential speed, elastic",
        "incident tangential speed of the small sphere (m/s)",
        &labels,
        &vts,
        &cases,
        &AL_ALLOY_OLD,
        None,
        0.4,
        false,
    )
}
