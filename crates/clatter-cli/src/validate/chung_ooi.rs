//! Chung & Ooi (2011), "Benchmark tests for verifying discrete element modelling codes at
//! particle impact level", Granular Matter 13:643-656: tests 1-8, with the materials and
//! conditions of the paper's Table 1 as far as we know them (docs/validation.md lists them and
//! which ones are our choice).
//!
//! Truths:
//! - tests 1-2 (elastic, head-on): Hertz theory's closed forms for the maximum overlap, the
//!   peak force and the contact duration (`2 * 1.4716 d_max / v`);
//! - test 3 (damped, head-on): the requested coefficient of restitution, at a fine time step
//!   (t_c/1000, so that what is checked is the damping law, not the step);
//! - tests 4-8 (oblique, elastic `e = 1`): where the f64 integration of the same law
//!   ([`reference::impact`]) finds the friction at its Coulomb cap throughout the contact
//!   (gross sliding), the rigid-body Coulomb impulse ratio in closed form
//!   ([`reference::gross_sliding`]); elsewhere that f64 integration itself (at t_c/20000).
//!   Rebound tangential velocity and spin cross zero as the angle varies, so their errors
//!   are normalised by the incident slip speed of the contact point.
//!
//! Tolerance 2% throughout: the time step is the default t_c/50 (1/1000 for test 3), at
//! which the integrator's error in these quantities is about 0.1% (peak sampled within half
//! a step of the true peak: `(pi/50)^2/8`); 2% leaves room for f32 state without hiding a
//! wrong law (a wrong Hertz exponent, a missing factor of the effective radius or mass, or
//! a mis-scaled tangential stiffness all move these quantities by 5% or more).

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{DVec3, Quat, Vec3};

use super::reference::{self, Ball, Law};
use super::{Ctx, Outcome, Row};
use crate::plot::{Panel, Series, chart};

const TOL: f64 = 0.02;

/// An elastic solid as the paper lists it.
#[derive(Clone, Copy)]
pub struct Solid {
    pub name: &'static str,
    pub youngs: f64,
    pub poisson: f64,
    pub density: f64,
}

pub const GLASS: Solid = Solid {
    name: "glass",
    youngs: 4.8e10,
    poisson: 0.20,
    density: 2800.0,
};
pub const LIMESTONE: Solid = Solid {
    name: "limestone",
    youngs: 2.0e10,
    poisson: 0.25,
    density: 2500.0,
};
pub const ALUMINA: Solid = Solid {
    name: "alumina",
    youngs: 3.8e11,
    poisson: 0.23,
    density: 4000.0,
};
pub const CAST_IRON: Solid = Solid {
    name: "cast iron",
    youngs: 1.0e11,
    poisson: 0.25,
    density: 7000.0,
};
pub const AL_ALLOY: Solid = Solid {
    name: "aluminium alloy",
    youngs: 7.0e10,
    poisson: 0.33,
    density: 2699.0,
};
/// A rigid plane: a modulus 10^5 times alumina's, so that it adds 1e-5 to `1/E*` (it is in
/// the truth's `E*` too).
pub const RIGID: Solid = Solid {
    name: "rigid",
    youngs: 1.0e16,
    poisson: 0.25,
    density: 1000.0,
};

fn material(s: &Solid, e: f64, mu: f64) -> Material {
    Material::new(
        s.name,
        s.density as f32,
        ContactLaw::Hertz {
            youngs_modulus: s.youngs as f32,
            poisson_ratio: s.poisson as f32,
        },
        e as f32,
        mu as f32,
    )
}

fn mass(s: &Solid, r: f64) -> f64 {
    s.density * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)
}

/// The f64 law of a pair of solids (both `e` and `mu` as given).
fn law(a: &Solid, b: &Solid, e: f64, mu: f64) -> Law {
    // The values as the f32 material stores them, so that the truth sees the same inputs.
    let f = |x: f64| x as f32 as f64;
    Law {
        hertz: true,
        stiffness: reference::e_star(f(a.youngs), f(a.poisson), f(b.youngs), f(b.poisson)),
        shear: reference::g_star(f(a.youngs), f(a.poisson), f(b.youngs), f(b.poisson)),
        restitution: f(e),
        friction: f(mu),
    }
}

/// One impact: `a` is [`Ball::wall`] or a sphere below `b`; both just touching at the start
/// (the runner moves them apart by a step and a half of approach).
#[derive(Clone, Copy)]
pub struct Case {
    pub a: Ball,
    pub b: Ball,
}

/// The state after an impact run, per case: (a, b) as clatter left them.
pub struct Run {
    pub after: Vec<(Ball, Ball)>,
    pub dt: f64,
    /// Per case, `(t, overlap, normal force on b)` at every step (only when recorded).
    pub history: Vec<Vec<(f64, f64, f64)>>,
}

fn ball_of(w: &World, i: usize, m: f64, r: f64) -> Ball {
    let d = |v: Vec3| v.as_dvec3();
    Ball {
        m,
        r,
        x: d(w.state.position[i]),
        v: d(w.state.velocity[i]),
        w: d(w.state.omega[i]),
    }
}

fn body(shape: u32, material: u32, b: &Ball, offset: DVec3) -> BodyInit {
    BodyInit {
        shape,
        material,
        position: (b.x + offset).as_vec3(),
        orientation: Quat::IDENTITY,
        velocity: b.v.as_vec3(),
        angular_velocity: b.w.as_vec3(),
    }
}

/// Runs `cases` side by side in one world (spheres of `sphere` material; pairs, or spheres on
/// the wall `z = 0` of `wall` material), `dt` the world's default unless given, until every
/// contact is over. With `record`, one step at a time, the overlap and force of each case
/// kept.
pub fn run_cases(
    ctx: &Ctx,
    cases: &[Case],
    sphere: &Material,
    wall: Option<&Material>,
    dt: Option<f64>,
    record: bool,
) -> anyhow::Result<Run> {
    let spacing = cases
        .iter()
        .map(|c| 4.0 * (c.a.r + c.b.r))
        .fold(0.0, f64::max);
    let build = |gap: &[f64]| -> World {
        let mut shapes = Vec::new();
        let mut shape_of = |r: f64| -> u32 {
            shapes.push(ShapeKind::Sphere { radius: r }.prepare().expect("sphere"));
            (shapes.len() - 1) as u32
        };
        let mut bodies = Vec::new();
        for (k, c) in cases.iter().enumerate() {
            let shift = DVec3::new(0.0, k as f64 * spacing, 0.0);
            if c.a.m.is_infinite() {
                let s = shape_of(c.b.r);
                bodies.push(body(s, 0, &c.b, shift + DVec3::Z * gap[k]));
            } else {
                let sa = shape_of(c.a.r);
                bodies.push(body(sa, 0, &c.a, shift - DVec3::Z * (0.5 * gap[k])));
                let sb = shape_of(c.b.r);
                bodies.push(body(sb, 0, &c.b, shift + DVec3::Z * (0.5 * gap[k])));
            }
        }
        let mut materials = vec![sphere.clone()];
        let mut walls = Vec::new();
        if let Some(m) = wall {
            materials.push(m.clone());
            walls.push(Wall {
                plane: Plane {
                    normal: Vec3::Z,
                    offset: 0.0,
                },
                material: 1,
            });
        }
        World::new(WorldDesc {
            shapes,
            materials,
            walls,
            bodies,
            gravity: Vec3::ZERO,
            dt: dt.map(|d| d as f32),
            skin: None,
            periodic: None,
        })
    };
    let approach: Vec<f64> = cases
        .iter()
        .map(|c| (c.a.v.z - c.b.v.z).max(1e-12))
        .collect();
    let probe = build(&vec![0.0; cases.len()]);
    let step = probe.dt as f64;
    let gap: Vec<f64> = approach.iter().map(|v| 1.5 * v * step).collect();
    let world = build(&gap);
    // Long enough for the slowest case: approach, twice the elastic Hertz duration (damped
    // contacts last a little longer), and a few steps apart.
    let sphere_solid_e = match sphere.law {
        ContactLaw::Hertz {
            youngs_modulus,
            poisson_ratio,
        } => (youngs_modulus as f64, poisson_ratio as f64),
        ContactLaw::Linear { .. } => unreachable!("Chung & Ooi cases are Hertzian"),
    };
    let wall_e = wall.map(|m| match m.law {
        ContactLaw::Hertz {
            youngs_modulus,
            poisson_ratio,
        } => (youngs_modulus as f64, poisson_ratio as f64),
        ContactLaw::Linear { .. } => unreachable!(),
    });
    let mut t_end: f64 = 0.0;
    for (c, v) in cases.iter().zip(&approach) {
        let (m_eff, r_eff, other) = if c.a.m.is_infinite() {
            (c.b.m, c.b.r, wall_e.expect("a wall material"))
        } else {
            (
                c.a.m * c.b.m / (c.a.m + c.b.m),
                c.a.r * c.b.r / (c.a.r + c.b.r),
                sphere_solid_e,
            )
        };
        let es = reference::e_star(sphere_solid_e.0, sphere_solid_e.1, other.0, other.1);
        let (_, _, tc) = reference::hertz_impact(m_eff, r_eff, es, *v);
        t_end = t_end.max(1.5 * step + 2.0 * tc);
    }
    let steps = (t_end / step).ceil() as u64 + 5;
    let mut sim = ctx.sim(world)?;
    let mut history = vec![Vec::new(); cases.len()];
    let index = |k: usize| -> (Option<usize>, usize) {
        let mut i = 0;
        for (j, c) in cases.iter().enumerate() {
            let pair = !c.a.m.is_infinite();
            if j == k {
                return if pair { (Some(i), i + 1) } else { (None, i) };
            }
            i += if pair { 2 } else { 1 };
        }
        unreachable!()
    };
    if record {
        // Each sample: the time and overlap before a step, and the force that step applied
        // (computed from that overlap): `m dv / dt` of b along the normal.
        let depth_of = |w: &World, k: usize| -> f64 {
            let (ia, ib) = index(k);
            let xb = w.state.position[ib].as_dvec3();
            match ia {
                None => cases[k].b.r - xb.z,
                Some(ia) => {
                    cases[k].a.r + cases[k].b.r - (xb - w.state.position[ia].as_dvec3()).length()
                }
            }
        };
        for _ in 0..steps {
            let t = sim.world.time;
            let before: Vec<(f64, f64)> = (0..cases.len())
                .map(|k| {
                    (
                        sim.world.state.velocity[index(k).1].z as f64,
                        depth_of(&sim.world, k),
                    )
                })
                .collect();
            sim.step(1)?;
            for (k, c) in cases.iter().enumerate() {
                let v = sim.world.state.velocity[index(k).1].z as f64;
                let force = c.b.m * (v - before[k].0) / step;
                history[k].push((t, before[k].1, force));
            }
        }
    } else {
        sim.step(steps)?;
    }
    let w = &sim.world;
    let after = cases
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let (ia, ib) = index(k);
            let a = match ia {
                None => c.a,
                Some(ia) => ball_of(w, ia, c.a.m, c.a.r),
            };
            (a, ball_of(w, ib, c.b.m, c.b.r))
        })
        .collect();
    Ok(Run {
        after,
        dt: step,
        history,
    })
}

/// Overlap peak, force peak, and contact duration (zero crossings of the overlap,
/// interpolated) of a recorded history.
fn peaks(h: &[(f64, f64, f64)]) -> (f64, f64, f64, f64) {
    let d_max = h.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
    let f_max = h.iter().map(|s| s.2).fold(f64::NEG_INFINITY, f64::max);
    let mut t_in = f64::NAN;
    let mut t_out = f64::NAN;
    for win in h.windows(2) {
        let ((t0, d0, _), (t1, d1, _)) = (win[0], win[1]);
        let cross = t0 + (t1 - t0) * d0 / (d0 - d1);
        if d0 <= 0.0 && d1 > 0.0 && t_in.is_nan() {
            t_in = cross;
        }
        if d0 > 0.0 && d1 <= 0.0 && !t_in.is_nan() && t_out.is_nan() {
            t_out = cross;
        }
    }
    (d_max, f_max, t_out - t_in, t_in)
}

/// Tests 1 and 2: elastic head-on impacts against Hertz theory.
fn head_on(
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

/// Test 1: elastic normal impact of two identical spheres (glass, limestone; R = 0.010 m,
/// each at 10 m/s toward the other).
pub fn test1(ctx: &Ctx) -> anyhow::Result<Outcome> {
    head_on(
        ctx,
        "chung-ooi-1",
        "Chung & Ooi test 1: two identical spheres, elastic, head-on",
        &[(GLASS, 0.010, 10.0), (LIMESTONE, 0.010, 10.0)],
        None,
    )
}

/// Test 2: elastic normal impact of a sphere with a rigid plane (alumina, cast iron;
/// R = 0.10 m, 0.2 m/s).
pub fn test2(ctx: &Ctx) -> anyhow::Result<Outcome> {
    head_on(
        ctx,
        "chung-ooi-2",
        "Chung & Ooi test 2: sphere on a rigid plane, elastic, normal",
        &[(ALUMINA, 0.10, 0.2), (CAST_IRON, 0.10, 0.2)],
        Some(&RIGID),
    )
}

/// Test 3: normal sphere-wall impacts with damping: measured coefficient of restitution vs the
/// requested one (glass sphere R = 0.010 m on a rigid plane at 3.9 m/s), at t_c/1000.
pub fn test3(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = "chung-ooi-3";
    let es: &[f64] = if ctx.quick {
        &[0.2, 0.5, 0.8]
    } else {
        &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]
    };
    let (r, v) = (0.010, 3.9);
    let m = mass(&GLASS, r);
    let l = law(&GLASS, &RIGID, 1.0, 0.0);
    let (_, _, tc) = reference::hertz_impact(m, r, l.stiffness, v);
    let mut rows = Vec::new();
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for &e in es {
        ctx.progress(&format!("{name}: e = {e}"));
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
            &material(&GLASS, e, 0.0),
            Some(&material(&RIGID, e, 0.0)),
            Some(tc / 1000.0),
            false,
        )?;
        let measured = run.after[0].1.v.z / v;
        rows.push(Row::relative(
            name,
            &format!("e={e}"),
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
    let svg = chart(
        "Chung & Ooi test 3: restitution, Hertz sphere on a rigid plane (dt = t_c/1000)",
        &[Panel {
            y_label: "measured restitution",
            x_label: "requested restitution",
            series: vec![
                Series::points("clatter", &xs, &ys),
                Series::dashed("requested", &xs, &xs),
            ],
            log: false,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// The truth of an oblique case: the gross-sliding closed form where the f64 integration of
/// the same law slides throughout, else that integration.
fn oblique_truth(l: &Law, c: &Case) -> ((Ball, Ball), &'static str, (Ball, Ball)) {
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
fn slip(c: &Case) -> f64 {
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

fn wall_case(s: &Solid, r: f64, v: DVec3, w: DVec3) -> Case {
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

/// Test 4: oblique impact of an alumina sphere (R = 2.5 mm) on an aluminium-alloy plane at a
/// constant speed of 3.9 m/s and incident angles (from the normal) 5-85 deg; mu = 0.092.
pub fn test4(ctx: &Ctx) -> anyhow::Result<Outcome> {
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
        "chung-ooi-4",
        "Chung & Ooi test 4: oblique impact on a plane, constant speed 3.9 m/s",
        "incident angle from the normal (deg)",
        &labels,
        &angles,
        &cases,
        &ALUMINA,
        Some(&AL_ALLOY),
        0.092,
        true,
    )
}

/// Test 5: oblique impacts at a constant normal speed (5 m/s) and tangential speeds
/// 0.5-20 m/s (alumina on aluminium alloy, mu = 0.092).
pub fn test5(ctx: &Ctx) -> anyhow::Result<Outcome> {
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
        "chung-ooi-5",
        "Chung & Ooi test 5: constant normal speed 5 m/s, varied tangential speed",
        "incident tangential speed (m/s)",
        &labels,
        &vts,
        &cases,
        &ALUMINA,
        Some(&AL_ALLOY),
        0.092,
        false,
    )
}

/// Test 6: impacts with spin: constant normal speed (1 m/s), no tangential velocity, initial
/// spin R w = 0.1-5 m/s (alumina on aluminium alloy, mu = 0.092).
pub fn test6(ctx: &Ctx) -> anyhow::Result<Outcome> {
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
        "chung-ooi-6",
        "Chung & Ooi test 6: impact with spin on a plane, normal speed 1 m/s",
        "incident R w (m/s)",
        &labels,
        &rws,
        &cases,
        &ALUMINA,
        Some(&AL_ALLOY),
        0.092,
        false,
    )
}

/// Test 7: two identical aluminium-alloy spheres (R = 0.10 m, mu = 0.4), each at 0.2 m/s
/// toward the other, both spinning the same way (R w = 0.02-1 m/s).
pub fn test7(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let rws: Vec<f64> = if ctx.quick {
        vec![0.05, 0.2, 1.0]
    } else {
        vec![0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
    };
    let r = 0.10;
    let m = mass(&AL_ALLOY, r);
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
        "chung-ooi-7",
        "Chung & Ooi test 7: two identical spheres with spin, normal speed 0.2 m/s each",
        "incident R w of each sphere (m/s)",
        &labels,
        &rws,
        &cases,
        &AL_ALLOY,
        None,
        0.4,
        false,
    )
}

/// Test 8: spheres of unequal size (aluminium alloy, R = 0.10 and 0.05 m, mu = 0.4), each
/// at 0.2 m/s toward the other, the small one with tangential speed 0.02-1 m/s.
pub fn test8(ctx: &Ctx) -> anyhow::Result<Outcome> {
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
                m: mass(&AL_ALLOY, ra),
                r: ra,
                x: DVec3::new(0.0, 0.0, -ra),
                v: DVec3::new(0.0, 0.0, 0.2),
                w: DVec3::ZERO,
            },
            b: Ball {
                m: mass(&AL_ALLOY, rb),
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
        "chung-ooi-8",
        "Chung & Ooi test 8: unequal spheres, normal speed 0.2 m/s each, varied tangential speed",
        "incident tangential speed of the small sphere (m/s)",
        &labels,
        &vts,
        &cases,
        &AL_ALLOY,
        None,
        0.4,
        false,
    )
}
