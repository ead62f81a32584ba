//! Chung & Ooi tests 1-3: head-on impacts. Tests 1-2 (elastic) against Hertz theory's closed
//! forms for the maximum overlap, the peak force and the contact duration
//! (`2 * 1.4716 d_max / v`); test 3 (damped) against the requested coefficient of
//! restitution, at a fine step (t_c/1000) so that what is checked is the damping law.

use glam::DVec3;

use super::{
    AL_ALLOY_2, ALUMINA, CAST_IRON, Case, GLASS, LIMESTONE, MG_ALLOY, RIGID, Solid, TOL, law, mass,
    material, peaks, run_cases,
};
use crate::plot::{Panel, Series, chart};
use crate::validate::reference::{self, Ball};
use crate::validate::{Ctx, Outcome, Row};

/// Elastic head-on impacts (sphere pairs, or spheres on a `wall` plane) against Hertz theory.
pub fn head_on(
    ctx: &Ctx,
    name: &str,
    title: &str,
    set: &[(Solid, f64, f64)],
    wall: Option<&Solid>,
) -> anyhow::Result<Outcome> {
    let mut rows = Vec::new();
    // Per material: name, then (time, force) and (overlap, force), all normalised.
    type Curves = (String, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);
    let mut curves: Vec<Curves> = Vec::new();
    let mut theory: Vec<Curves> = Vec::new();
    for (solid, r, v) in set {
        ctx.progress(&format!("{name}: {}", solid.name));
        let m = mass(solid, *r);
        let b = Ball {
            m,
            r: *r,
            x: DVec3::new(0.0, 0.0, *r),
            v: DVec3::new(0.0, 0.0, -v),
            w: DVec3::ZERO,
        };
        let (case, other, m_eff, r_eff, speed) = match wall {
            Some(ws) => (Case { a: Ball::wall(), b }, *ws, m, *r, *v),
            None => {
                let a = Ball {
                    x: DVec3::new(0.0, 0.0, -r),
                    v: DVec3::new(0.0, 0.0, *v),
                    ..b
                };
                (Case { a, b }, *solid, m / 2.0, r / 2.0, 2.0 * v)
            }
        };
        let law = law(solid, &other, 1.0, 0.0);
        let (d, f, tc) = reference::hertz_impact(m_eff, r_eff, law.stiffness, speed);
        let sphere = material(solid, 1.0, 0.0);
        let wall_mat = wall.map(|ws| material(ws, 1.0, 0.0));
        let run = run_cases(ctx, &[case], &sphere, wall_mat.as_ref(), None, true)?;
        let (dm, fm, tm, t0) = peaks(&run.history[0]);
        let truth = "Hertz closed form";
        let case_name = format!("{} R={} v={}", solid.name, r, v);
        rows.push(Row::relative(
            name,
            &case_name,
            "max overlap (m)",
            d,
            dm,
            TOL,
            truth,
            run.dt,
        ));
        rows.push(Row::relative(
            name,
            &case_name,
            "peak force (N)",
            f,
            fm,
            TOL,
            truth,
            run.dt,
        ));
        rows.push(Row::relative(
            name,
            &case_name,
            "contact duration (s)",
            tc,
            tm,
            TOL,
            truth,
            run.dt,
        ));
        let h = &run.history[0];
        let inside: Vec<&(f64, f64, f64)> = h.iter().filter(|s| s.1 > -0.05 * d).collect();
        curves.push((
            solid.name.to_string(),
            inside.iter().map(|s| (s.0 - t0) / tc).collect(),
            inside.iter().map(|s| s.2 / f).collect(),
            inside.iter().map(|s| s.1 / d).collect(),
            inside.iter().map(|s| s.2 / f).collect(),
        ));
        // Theory: the elastic Hertz ODE (f64) for force(t), the closed form for force(overlap).
        let ode = reference::impact(
            &law,
            if wall.is_some() { Ball::wall() } else { case.a },
            Ball {
                x: b.x + DVec3::Z * 1e-12,
                ..b
            },
            tc / 2000.0,
        );
        let pick: Vec<&(f64, f64, f64)> = ode.history.iter().step_by(10).collect();
        let xs: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
        theory.push((
            solid.name.to_string(),
            pick.iter().map(|s| s.0 / tc).collect(),
            pick.iter().map(|s| s.2 / f).collect(),
            xs.clone(),
            xs.iter().map(|x| x.powf(1.5)).collect(),
        ));
    }
    let names: Vec<(String, String)> = curves
        .iter()
        .map(|c| (format!("{} clatter", c.0), format!("{} Hertz", c.0)))
        .collect();
    let mut p1 = Vec::new();
    let mut p2 = Vec::new();
    for ((c, t), n) in curves.iter().zip(&theory).zip(&names) {
        p1.push(Series::points(&n.0, &c.1, &c.2));
        p1.push(Series::dashed(&n.1, &t.1, &t.2));
        p2.push(Series::points(&n.0, &c.3, &c.4));
        p2.push(Series::dashed(&n.1, &t.3, &t.4));
    }
    let svg = chart(
        title,
        &[
            Panel {
                y_label: "normal force / Hertz peak",
                x_label: "time / Hertz contact duration",
                series: p1,
                log: false,
            },
            Panel {
                y_label: "normal force / Hertz peak",
                x_label: "overlap / Hertz max overlap",
                series: p2,
                log: false,
            },
        ],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// Test 1: elastic normal impact of two identical spheres: glass and limestone, R = 0.010 m,
/// each at 10 m/s toward the other (LIGGGHTS-PFM chung/test01, Yade Test1.py, Kratos
/// Benchmark1).
pub fn test1(ctx: &Ctx) -> anyhow::Result<Outcome> {
    head_on(
        ctx,
        "chung-ooi-1",
        "Chung & Ooi test 1: two identical spheres, elastic, head-on",
        &[(GLASS, 0.010, 10.0), (LIMESTONE, 0.010, 10.0)],
        None,
    )
}

/// Test 2: elastic normal impact of a sphere with a rigid plane: Al alloy and Mg alloy,
/// R = 0.10 m, 0.2 m/s (LIGGGHTS-PFM chung/test02, Yade Test2.py).
pub fn test2(ctx: &Ctx) -> anyhow::Result<Outcome> {
    head_on(
        ctx,
        "chung-ooi-2",
        "Chung & Ooi test 2: sphere on a rigid plane, elastic, normal",
        &[(AL_ALLOY_2, 0.10, 0.2), (MG_ALLOY, 0.10, 0.2)],
        Some(&RIGID),
    )
}

/// The earlier test 2 (alumina and cast iron, R = 0.10 m, 0.2 m/s on a rigid plane): Hertz
/// theory on two stiffer, denser solids.
pub fn hertz_plane_alumina_iron(ctx: &Ctx) -> anyhow::Result<Outcome> {
    head_on(
        ctx,
        "hertz-plane-alumina-iron",
        "Hertz sphere on a rigid plane: alumina and cast iron, R = 0.1 m, 0.2 m/s",
        &[(ALUMINA, 0.10, 0.2), (CAST_IRON, 0.10, 0.2)],
        Some(&RIGID),
    )
}

/// Test 3: normal sphere-plane impacts with damping: Al oxide and cast iron, R = 2.5 mm,
/// 3.9 m/s, requested e 0.1-1 (LIGGGHTS-PFM chung/test03, Yade Test3.py).
pub fn test3(ctx: &Ctx) -> anyhow::Result<Outcome> {
    restitution_sweep(
        ctx,
        "chung-ooi-3",
        "Chung & Ooi test 3: restitution, Al oxide and cast iron (R = 2.5 mm, 3.9 m/s) on a rigid plane, dt = t_c/1000",
        &[ALUMINA, CAST_IRON],
        0.0025,
        3.9,
    )
}

/// The earlier test 3: a glass sphere, R = 10 mm, at 3.9 m/s on a rigid plane.
pub fn restitution_glass_10mm(ctx: &Ctx) -> anyhow::Result<Outcome> {
    restitution_sweep(
        ctx,
        "restitution-glass-10mm",
        "Restitution, Hertz glass sphere (R = 10 mm, 3.9 m/s) on a rigid plane, dt = t_c/1000",
        &[GLASS],
        0.010,
        3.9,
    )
}

/// Measured against requested restitution of spheres of each solid (radius `r`, speed `v`)
/// on a rigid plane, at t_c/1000.
fn restitution_sweep(
    ctx: &Ctx,
    name: &str,
    title: &str,
    solids: &[Solid],
    r: f64,
    v: f64,
) -> anyhow::Result<Outcome> {
    let es: &[f64] = if ctx.quick {
        &[0.2, 0.5, 0.8]
    } else {
        &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]
    };
    let mut rows = Vec::new();
    let mut curves: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
    for solid in solids {
        let m = mass(solid, r);
        let l = law(solid, &RIGID, 1.0, 0.0);
        let (_, _, tc) = reference::hertz_impact(m, r, l.stiffness, v);
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for &e in es {
            ctx.progress(&format!("{name}: {}, e = {e}", solid.name));
            let b = Ball {
                m,
                r,
                x: DVec3::new(0.0, 0.0, r),
                v: DVec3::new(0.0, 0.0, -v),
                w: DVec3::ZERO,
            };
            let run = run_cases(
                ctx,
                &[Case { a: Ball::wall(), b }],
                &material(solid, e, 0.0),
                Some(&material(&RIGID, e, 0.0)),
                Some(tc / 1000.0),
                false,
            )?;
            let measured = run.after[0].1.v.z / v;
            let case = if solids.len() > 1 {
                format!("{} e={e}", solid.name)
            } else {
                format!("e={e}")
            };
            rows.push(Row::relative(
                name,
                &case,
                "restitution",
                e,
                measured,
                TOL,
                "requested e",
                run.dt,
            ));
            xs.push(e);
            ys.push(measured);
        }
        curves.push((solid.name.to_string(), xs, ys));
    }
    let mut series: Vec<Series> = curves
        .iter()
        .map(|(n, xs, ys)| Series::points(n, xs, ys))
        .collect();
    series.push(Series::dashed("requested", es, es));
    let svg = chart(
        title,
        &[Panel {
            y_label: "measured restitution",
            x_label: "requested restitution",
            series,
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}
