//! Chung & Ooi tests 4-8 at the published conditions, against the paper's curves.
//!
//! Conditions as LIGGGHTS-PFM (`examples/LIGGGHTS/PFM/tests/contact_models/chung/test04..08`)
//! and Kratos (`DEMApplication/python_scripts/Chung_Ooi_class.py`) run them (Yade's Test4.py
//! agrees for test 4); the published curves as Kratos ships them digitised ([`super::data`]).
//! Test 7 has no curve but a closed form: surfaces that roll together exchange no tangential
//! force, so each sphere keeps its spin and gains no tangential velocity.
//!
//! Quantities in the paper's normalisations, with `v_ct` the slip velocity of the contact
//! point (sphere b against a, or the plane), `v_n` the normal approach speed, primes after
//! the impact: test 4 `v_t'/v_t`, the spin, `atan(v_ct'/v_n')`; test 5 `v_ct'/(mu v_n')` and
//! `R w'/(mu v_n)` against `v_t/(mu v_n)`; tests 6 and 8 `beta = -v_ct'/v_ct` against
//! `3.5 mu (1 + e) v_n / v_ct`, and `v_ct'/v_n'` against `v_ct/v_n`.
//!
//! Rows: one per published point (a subset with `--quick`), an absolute error in the
//! figure's units against a tolerance stated with each figure (docs/validation.md says why).

use glam::DVec3;

use super::data::{Curve, Table, table};
use super::{
    AL_ALLOY, ALUMINA, COPPER, Case, NYLON, POLYETHYLENE, RIGID, Run, STEEL, Solid, TOL, denser,
    law, mass, material, run_cases, run_cases_with,
};
use crate::plot::{Panel, Series, chart};
use crate::validate::reference::{self, Ball, Law};
use crate::validate::{Ctx, Outcome, Row};

/// One figure of the paper: its table, what it plots, and how clatter's point is made.
struct Figure<'a> {
    table: Table,
    /// The row's quantity.
    quantity: &'static str,
    x_label: &'static str,
    y_label: &'static str,
    /// The largest absolute error against the paper that passes, in the figure's units.
    tol: f64,
    /// Which points have a row against the paper (docs/validation.md says why).
    paper: Paper,
    /// Series drawn for reference only (experiment, FEM, another test).
    extra: &'static [(&'static str, &'static str)],
    /// The impact at abscissa `x`, for a sphere of this solid.
    case: &'a dyn Fn(&Solid, f64) -> Case,
    /// The figure's ordinate from the case and the bodies after it.
    measure: &'a dyn Fn(&Case, &(Ball, Ball)) -> f64,
}

/// How a figure's points are compared with the paper (every point is also compared with
/// the f64 integration of clatter's own law).
#[derive(Clone, Copy, PartialEq)]
enum Paper {
    /// Every point must agree.
    All,
    /// Every point is compared; where clatter's law slides throughout the contact (gross
    /// sliding, where at `e = 1` its law and the paper's agree) it must agree, elsewhere a
    /// difference is the documented one of its tangential law ([`STICK`]).
    Sliding,
    /// Every point is compared; a difference is the documented one ([`STICK_AND_CAP`]).
    Known,
}

/// Why clatter differs from the paper at small slip (docs/validation.md, "Known differences").
const STICK: &str = "tangential spring on the total displacement, the paper's incremental";

/// Why clatter differs from the paper in tests 6 and 8 (docs/validation.md, "Known
/// differences").
const STICK_AND_CAP: &str = "tangential spring on the total displacement, the paper's incremental; friction capped by the unclamped normal force";

/// One test: its name, its spheres (each with the name of its series in the tables), and
/// how a batch of cases of one solid runs.
struct Test<'a> {
    ctx: &'a Ctx,
    name: &'static str,
    title: &'static str,
    solids: &'a [(Solid, &'static str)],
    run: &'a dyn Fn(&Solid, &[Case]) -> anyhow::Result<Run>,
    /// The f64 law of a sphere of this solid against its partner.
    law: &'a dyn Fn(&Solid) -> Law,
    /// The scale of the slip rows' error: `3.5 mu (1 + e) v_n`, the change of the contact
    /// slip in gross sliding.
    slip_scale: f64,
}

/// The f64 integration of `law` for `c` at t_c/20000 ([`reference::impact`]): the bodies
/// after, and whether it slid throughout.
fn ode(law: &Law, c: &Case) -> ((Ball, Ball), bool) {
    let (m_eff, r_eff) = if c.a.m.is_infinite() {
        (c.b.m, c.b.r)
    } else {
        (
            c.a.m * c.b.m / (c.a.m + c.b.m),
            c.a.r * c.b.r / (c.a.r + c.b.r),
        )
    };
    let (_, _, tc) = reference::hertz_impact(m_eff, r_eff, law.stiffness, -normal(&c.a, &c.b));
    let mut b = c.b;
    b.x.z += 1e-6 * b.r;
    let o = reference::impact(law, c.a, b, tc / 20000.0);
    ((o.a, o.b), o.sliding_throughout)
}

/// Owned plot lines: `(legend, x, y, published)`.
type Lines = Vec<(String, Vec<f64>, Vec<f64>, bool)>;

/// How a plot line is drawn: clatter's points as markers, the f64 integration of its law as
/// a solid line, the published curves dashed.
fn series_of<'a>(name: &'a str, x: &'a [f64], y: &'a [f64], published: bool) -> Series<'a> {
    if published {
        Series::dashed(name, x, y)
    } else if name.ends_with("f64") {
        Series::line(name, x, y)
    } else {
        Series::points(name, x, y)
    }
}

/// The published points a run checks: all of them, or three with `--quick`.
fn picked(c: &Curve, quick: bool) -> Vec<usize> {
    let n = c.x.len();
    if quick && n > 3 {
        vec![1, n / 2, n - 2]
    } else {
        (0..n).collect()
    }
}

/// Runs the cases of one figure for every solid: its rows and its plot lines.
fn figure(t: &Test, fig: &Figure, rows: &mut Vec<Row>) -> anyhow::Result<Lines> {
    let mut lines = Lines::new();
    for (solid, series) in t.solids {
        let curve = fig.table.series(series)?;
        let pick = picked(&curve, t.ctx.quick);
        let cases: Vec<Case> = pick
            .iter()
            .map(|&k| (fig.case)(solid, curve.x[k]))
            .collect();
        t.ctx.progress(&format!(
            "{}: {}, {}, {} impacts",
            t.name,
            fig.quantity,
            solid.name,
            cases.len()
        ));
        let run = (t.run)(solid, &cases)?;
        let law = (t.law)(solid);
        let (mut ys, mut odes) = (Vec::new(), Vec::new());
        for (j, &k) in pick.iter().enumerate() {
            let measured = (fig.measure)(&cases[j], &run.after[j]);
            let (truth, sliding) = ode(&law, &cases[j]);
            let case = format!("{} x={:.3}", solid.name, curve.x[k]);
            rows.push(Row::normalised(
                t.name,
                &case,
                "slip after v_ct' (m/s)",
                slip_x(&truth.0, &truth.1),
                slip_x(&run.after[j].0, &run.after[j].1),
                t.slip_scale,
                TOL,
                "f64 ODE, same law",
                run.dt,
            ));
            let ode = (fig.measure)(&cases[j], &truth);
            let paper = Row::range(
                t.name,
                &case,
                fig.quantity,
                curve.y[k] - fig.tol,
                curve.y[k] + fig.tol,
                measured,
                &format!("paper, {series} ({}, Kratos' digitisation)", fig.table.file),
                run.dt,
            );
            rows.push(match fig.paper {
                Paper::All => paper,
                Paper::Sliding if sliding => paper,
                Paper::Sliding => paper.known(STICK),
                Paper::Known => paper.known(STICK_AND_CAP),
            });
            ys.push(measured);
            odes.push(ode);
        }
        let xs: Vec<f64> = pick.iter().map(|&k| curve.x[k]).collect();
        lines.push((format!("{} clatter", solid.name), xs.clone(), ys, false));
        lines.push((
            format!("{} clatter's law, f64", solid.name),
            xs,
            odes,
            false,
        ));
        lines.push((format!("{} paper", solid.name), curve.x, curve.y, true));
    }
    for (series, legend) in fig.extra {
        let c = fig.table.series(series)?;
        lines.push((legend.to_string(), c.x, c.y, true));
    }
    Ok(lines)
}

/// Runs every figure of a test and draws them, one panel each.
fn run_test(t: &Test, figures: &[Figure]) -> anyhow::Result<Outcome> {
    let mut rows = Vec::new();
    let mut all = Vec::new();
    for f in figures {
        all.push(figure(t, f, &mut rows)?);
    }
    let panels: Vec<Panel> = figures
        .iter()
        .zip(&all)
        .map(|(f, lines)| Panel {
            y_label: f.y_label,
            x_label: f.x_label,
            series: lines
                .iter()
                .map(|(n, x, y, published)| series_of(n, x, y, *published))
                .collect(),
            log: false,
        })
        .collect();
    Ok(Outcome {
        rows,
        plots: vec![(format!("{}.svg", t.name), chart(t.title, &panels))],
    })
}

/// Slip velocity (x) of b's contact point against a's (a below b, contact normal +z).
fn slip_x(a: &Ball, b: &Ball) -> f64 {
    let va = if a.m.is_infinite() {
        0.0
    } else {
        a.v.x + a.r * a.w.y
    };
    b.v.x - b.r * b.w.y - va
}

/// Normal speed of b away from a (positive after the impact).
fn normal(a: &Ball, b: &Ball) -> f64 {
    let va = if a.m.is_infinite() { 0.0 } else { a.v.z };
    b.v.z - va
}

/// A sphere of `s` (radius `r`) just above the rigid plane.
fn on_plane(s: &Solid, r: f64, v: DVec3, w: DVec3) -> Case {
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

/// Runs spheres of `s` on the rigid plane, restitution `e` and friction `mu` for both.
fn on_rigid(ctx: &Ctx, s: &Solid, cases: &[Case], e: f64, mu: f64) -> anyhow::Result<Run> {
    run_cases(
        ctx,
        cases,
        &material(s, e, mu),
        Some(&material(&RIGID, e, mu)),
        None,
        false,
    )
}

/// Test 4: Al oxide and Al alloy spheres (R = 2.5 mm) on a rigid plane at 3.9 m/s, incident
/// angles 5-85 deg, e = 0.98, mu = 0.092.
pub fn test4(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let (r, v, e, mu) = (0.0025, 3.9, 0.98, 0.092);
    let case = |s: &Solid, deg: f64| {
        let t = deg.to_radians();
        on_plane(
            s,
            r,
            DVec3::new(v * t.sin(), 0.0, -v * t.cos()),
            DVec3::ZERO,
        )
    };
    let run = |s: &Solid, c: &[Case]| on_rigid(ctx, s, c, e, mu);
    let t = Test {
        ctx,
        name: "chung-ooi-4",
        title: "Chung & Ooi test 4: oblique impacts on a rigid plane at 3.9 m/s (e = 0.98, mu = 0.092)",
        solids: &[(ALUMINA, "oxide"), (AL_ALLOY, "alloy")],
        run: &run,
        law: &|s| law(s, &RIGID, e, mu),
        slip_scale: 3.5 * mu * (1.0 + e) * v * (5.0f64).to_radians().cos(),
    };
    let angle = "incident angle from the normal (deg)";
    let kharaz = &[("kharaz", "experiment (Kharaz et al. 2001)")];
    run_test(
        &t,
        &[
            Figure {
                table: table!("test4_tangential_restitution.csv")?,
                quantity: "v_t'/v_t",
                x_label: angle,
                y_label: "tangential restitution v_t'/v_t",
                tol: 0.02,
                paper: Paper::All,
                extra: kharaz,
                case: &case,
                measure: &|c, (_, b)| b.v.x / c.b.v.x,
            },
            Figure {
                table: table!("test4_angular_velocity.csv")?,
                quantity: "rebound spin (rad/s)",
                x_label: angle,
                y_label: "rebound angular velocity (rad/s)",
                tol: 15.0,
                paper: Paper::All,
                extra: kharaz,
                case: &case,
                measure: &|_, (_, b)| -b.w.y,
            },
            Figure {
                table: table!("test4_rebound_angle.csv")?,
                quantity: "contact rebound angle (deg)",
                x_label: angle,
                y_label: "rebound angle of the contact point (deg)",
                tol: 1.5,
                paper: Paper::All,
                extra: kharaz,
                case: &case,
                measure: &|_, (a, b)| (slip_x(a, b) / normal(a, b)).atan().to_degrees(),
            },
        ],
    )
}

/// Test 5: steel and polyethylene spheres (R = 10 um) on a rigid plane, normal speed 5 m/s,
/// tangential speed `x mu v_n`, e = 1, mu = 0.3.
pub fn test5(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let (r, vn, e, mu) = (1.0e-5, 5.0, 1.0, 0.3);
    let case = |s: &Solid, x: f64| on_plane(s, r, DVec3::new(x * mu * vn, 0.0, -vn), DVec3::ZERO);
    let run = |s: &Solid, c: &[Case]| on_rigid(ctx, s, c, e, mu);
    let t = Test {
        ctx,
        name: "chung-ooi-5",
        title: "Chung & Ooi test 5: normal speed 5 m/s, varied tangential speed (R = 10 um, e = 1, mu = 0.3)",
        solids: &[(STEEL, "steel"), (POLYETHYLENE, "polyethylene")],
        run: &run,
        law: &|s| law(s, &RIGID, e, mu),
        slip_scale: 3.5 * mu * (1.0 + e) * vn,
    };
    let x = "normalised incident angle v_t/(mu v_n)";
    let fem = &[("fem", "FEM (paper)")];
    run_test(
        &t,
        &[
            Figure {
                table: table!("test5_rebound_angle.csv")?,
                quantity: "v_ct'/(mu v_n')",
                x_label: x,
                y_label: "normalised rebound angle v_ct'/(mu v_n')",
                tol: 0.14,
                paper: Paper::Sliding,
                extra: fem,
                case: &case,
                measure: &|_, (a, b)| slip_x(a, b) / (mu * normal(a, b)),
            },
            Figure {
                table: table!("test5_angular_velocity.csv")?,
                quantity: "R w'/(mu v_n)",
                x_label: x,
                y_label: "normalised rebound spin R w'/(mu v_n)",
                tol: 0.1,
                paper: Paper::Sliding,
                extra: fem,
                case: &case,
                measure: &|c, (_, b)| -b.r * b.w.y / (mu * -c.b.v.z),
            },
        ],
    )
}

/// The beta and recoil figures of tests 6 and 8 (normal speed 0.2 m/s, e = 0.5, mu = 0.4),
/// `case(s, v_ct)` the impact with contact slip `v_ct`.
fn spin_figures<'a>(
    beta: &'static str,
    recoil: &'static str,
    extra: &'static [(&'static str, &'static str)],
    by_beta: &'a dyn Fn(&Solid, f64) -> Case,
    by_tan: &'a dyn Fn(&Solid, f64) -> Case,
) -> anyhow::Result<[Figure<'a>; 2]> {
    Ok([
        Figure {
            table: Table::parse(beta, data_text(beta)?)?,
            quantity: "beta = -v_ct'/v_ct",
            x_label: "3.5 mu (1 + e) v_n / v_ct",
            y_label: "tangential restitution of the contact point, beta",
            tol: 0.02,
            paper: Paper::Known,
            extra,
            case: by_beta,
            measure: &|c, (a, b)| -slip_x(a, b) / slip_x(&c.a, &c.b),
        },
        Figure {
            table: Table::parse(recoil, data_text(recoil)?)?,
            quantity: "v_ct'/v_n'",
            x_label: "tangent of the incident angle, v_ct/v_n",
            y_label: "tangent of the recoil angle, v_ct'/v_n'",
            tol: 0.084,
            paper: Paper::Known,
            extra,
            case: by_tan,
            measure: &|_, (a, b)| slip_x(a, b) / normal(a, b),
        },
    ])
}

/// The text of the spin tests' tables.
fn data_text(file: &str) -> anyhow::Result<&'static str> {
    Ok(match file {
        "test6_beta.csv" => include_str!("data/test6_beta.csv"),
        "test6_recoil.csv" => include_str!("data/test6_recoil.csv"),
        "test8_beta.csv" => include_str!("data/test8_beta.csv"),
        "test8_recoil.csv" => include_str!("data/test8_recoil.csv"),
        _ => anyhow::bail!("no table {file}"),
    })
}

/// Speeds of tests 6-8: normal 0.2 m/s, e = 0.5, mu = 0.4; `3.5 mu (1 + e) v_n`.
const VN: f64 = 0.2;
const E_SPIN: f64 = 0.5;
const MU_SPIN: f64 = 0.4;
const SLIP_SCALE: f64 = 3.5 * MU_SPIN * (1.0 + E_SPIN) * VN;

/// Test 6: Al alloy and nylon spheres (R = 0.1 m) spinning onto a rigid plane at 0.2 m/s,
/// no tangential velocity of the centre, e = 0.5, mu = 0.4.
pub fn test6(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let r = 0.1;
    let case = |s: &Solid, v_ct: f64| {
        on_plane(
            s,
            r,
            DVec3::new(0.0, 0.0, -VN),
            DVec3::new(0.0, -v_ct / r, 0.0),
        )
    };
    let by_beta = |s: &Solid, x: f64| case(s, SLIP_SCALE / x);
    let by_tan = |s: &Solid, x: f64| case(s, x * VN);
    let run = |s: &Solid, c: &[Case]| on_rigid(ctx, s, c, E_SPIN, MU_SPIN);
    let t = Test {
        ctx,
        name: "chung-ooi-6",
        title: "Chung & Ooi test 6: spinning sphere on a rigid plane (R = 0.1 m, 0.2 m/s, e = 0.5, mu = 0.4)",
        solids: &[(AL_ALLOY, "alloy"), (NYLON, "nylon")],
        run: &run,
        law: &|s| law(s, &RIGID, E_SPIN, MU_SPIN),
        slip_scale: SLIP_SCALE,
    };
    let figs = spin_figures("test6_beta.csv", "test6_recoil.csv", &[], &by_beta, &by_tan)?;
    run_test(&t, &figs)
}

/// Test 8: an Al alloy or nylon sphere (R = 0.1 m) spinning onto a stationary sphere of the
/// same material, R = 0.5 m and 1000 times the density, at 0.2 m/s, e = 0.5, mu = 0.4.
pub fn test8(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let (r, big) = (0.1, 0.5);
    let case = |s: &Solid, v_ct: f64| Case {
        a: Ball {
            m: mass(&denser(*s, 1000.0), big),
            r: big,
            x: DVec3::new(0.0, 0.0, -big),
            v: DVec3::ZERO,
            w: DVec3::ZERO,
        },
        b: Ball {
            m: mass(s, r),
            r,
            x: DVec3::new(0.0, 0.0, r),
            v: DVec3::new(0.0, 0.0, -VN),
            w: DVec3::new(0.0, -v_ct / r, 0.0),
        },
    };
    let by_beta = |s: &Solid, x: f64| case(s, SLIP_SCALE / x);
    let by_tan = |s: &Solid, x: f64| case(s, x * VN);
    let run = |s: &Solid, c: &[Case]| {
        run_cases_with(
            ctx,
            c,
            &material(s, E_SPIN, MU_SPIN),
            Some(&material(&denser(*s, 1000.0), E_SPIN, MU_SPIN)),
            None,
            None,
            false,
        )
    };
    let t = Test {
        ctx,
        name: "chung-ooi-8",
        title: "Chung & Ooi test 8: spinning sphere (R = 0.1 m) on a large, dense sphere (R = 0.5 m), 0.2 m/s, e = 0.5, mu = 0.4",
        solids: &[(AL_ALLOY, "alloy"), (NYLON, "nylon")],
        run: &run,
        law: &|s| law(s, s, E_SPIN, MU_SPIN),
        slip_scale: SLIP_SCALE,
    };
    let extra = &[("test6", "sphere on a rigid plane, test 6 (paper)")];
    let figs = spin_figures(
        "test8_beta.csv",
        "test8_recoil.csv",
        extra,
        &by_beta,
        &by_tan,
    )?;
    run_test(&t, &figs)
}

/// Test 7: two identical spheres (Al alloy, copper; R = 0.1 m) each at 0.2 m/s toward the
/// other, spinning in opposite senses at `w` so that their surfaces move together (no initial
/// slip), e = 0.5, mu = 0.4. Truth: no tangential force, so each keeps its spin and gains no
/// tangential velocity.
pub fn test7(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = "chung-ooi-7";
    let r = 0.1;
    // LIGGGHTS-PFM chung/test07's angular velocities (rad/s).
    let ws: &[f64] = if ctx.quick {
        &[0.175, 2.0, 21.0]
    } else {
        &[
            0.175, 0.30, 0.42, 0.60, 0.80, 1.0, 1.2, 1.5, 2.0, 2.4, 2.8, 3.0, 3.5, 4.0, 6.0, 8.0,
            10.0, 12.0, 14.0, 21.0,
        ]
    };
    let mut rows = Vec::new();
    let mut lines: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
    for s in [AL_ALLOY, COPPER] {
        ctx.progress(&format!("{name}: {}, {} impacts", s.name, ws.len()));
        let m = mass(&s, r);
        let cases: Vec<Case> = ws
            .iter()
            .map(|&w| Case {
                a: Ball {
                    m,
                    r,
                    x: DVec3::new(0.0, 0.0, -r),
                    v: DVec3::new(0.0, 0.0, VN),
                    w: DVec3::new(0.0, -w, 0.0),
                },
                b: Ball {
                    m,
                    r,
                    x: DVec3::new(0.0, 0.0, r),
                    v: DVec3::new(0.0, 0.0, -VN),
                    w: DVec3::new(0.0, w, 0.0),
                },
            })
            .collect();
        let run = run_cases(
            ctx,
            &cases,
            &material(&s, E_SPIN, MU_SPIN),
            None,
            None,
            false,
        )?;
        let (mut spin, mut vt) = (Vec::new(), Vec::new());
        for (k, &w) in ws.iter().enumerate() {
            let b = &run.after[k].1;
            let case = format!("{} w={w}", s.name);
            let truth = "rolling contact: spin and tangential velocity unchanged";
            rows.push(Row::relative(
                name,
                &case,
                "rebound spin (rad/s)",
                w,
                b.w.y,
                TOL,
                truth,
                run.dt,
            ));
            rows.push(Row::normalised(
                name,
                &case,
                "rebound v_t (m/s)",
                0.0,
                b.v.x,
                r * w,
                TOL,
                truth,
                run.dt,
            ));
            spin.push(b.w.y);
            vt.push(b.v.x);
        }
        lines.push((format!("{} spin", s.name), ws.to_vec(), spin));
        lines.push((format!("{} v_t", s.name), ws.to_vec(), vt));
    }
    let zeros = vec![0.0; ws.len()];
    let svg = chart(
        "Chung & Ooi test 7: two spheres spinning in opposite senses (no slip), 0.2 m/s each, e = 0.5, mu = 0.4",
        &[
            Panel {
                y_label: "rebound angular velocity (rad/s)",
                x_label: "initial angular velocity (rad/s)",
                series: vec![
                    Series::points(&lines[0].0, &lines[0].1, &lines[0].2),
                    Series::points(&lines[2].0, &lines[2].1, &lines[2].2),
                    Series::dashed("closed form (= initial)", ws, ws),
                ],
                log: false,
            },
            Panel {
                y_label: "rebound tangential velocity (m/s)",
                x_label: "initial angular velocity (rad/s)",
                series: vec![
                    Series::points(&lines[1].0, &lines[1].1, &lines[1].2),
                    Series::points(&lines[3].0, &lines[3].1, &lines[3].2),
                    Series::dashed("closed form (0)", ws, &zeros),
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
