//! Chung & Ooi (2011), "Benchmark tests for verifying discrete element modelling codes at
//! particle impact level", Granular Matter 13:643-656: tests 1-8 at the conditions the public
//! implementations of the benchmark use (LIGGGHTS-PFM's `tests/contact_models/chung/test01..08`,
//! Kratos' `Chung_Ooi_class.py`, Yade's `Test1.py..Test4.py`; docs/validation.md cites each),
//! and, under names of their own, the impacts clatter checked before under these names.
//!
//! - [`normal`]: tests 1-3 (head-on impacts: Hertz closed forms, requested restitution);
//! - [`published`]: tests 4-8 (oblique impacts and spin) against the paper's curves as
//!   Kratos ships them digitised ([`data`]), test 7 against its closed form;
//! - [`legacy`]: the earlier, elastic (`e = 1`) oblique and head-on cases, against the
//!   gross-sliding closed form or the f64 integration of the same law.
//!
//! This file: the solids, and the harness that runs several impacts side by side in one world
//! on the chosen backend.

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{DVec3, Quat, Vec3};

use super::Ctx;
use super::reference::{self, Ball, Law};

pub mod data;
pub mod legacy;
pub mod normal;
pub mod published;

/// The tolerance of the closed-form rows (docs/validation.md: the integrator's own error at
/// `t_c/50` is about 0.1%; 2% still catches a wrong exponent or factor).
pub const TOL: f64 = 0.02;

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
/// Aluminium oxide (alumina): tests 3 and 4.
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
/// Aluminium alloy as test 2 has it (LIGGGHTS-PFM test02: nu 0.30, 2699 kg/m^3).
pub const AL_ALLOY_2: Solid = Solid {
    name: "Al alloy",
    youngs: 7.0e10,
    poisson: 0.30,
    density: 2699.0,
};
pub const MG_ALLOY: Solid = Solid {
    name: "Mg alloy",
    youngs: 4.0e10,
    poisson: 0.35,
    density: 1800.0,
};
/// Aluminium alloy as tests 4 and 6-8 have it (LIGGGHTS-PFM test04/06/07/08, Yade Test4.py:
/// nu 0.33, 2700 kg/m^3).
pub const AL_ALLOY: Solid = Solid {
    name: "Al alloy",
    youngs: 7.0e10,
    poisson: 0.33,
    density: 2700.0,
};
/// The aluminium alloy of the earlier checks ([`legacy`]: 2699 kg/m^3).
pub const AL_ALLOY_OLD: Solid = Solid {
    name: "aluminium alloy",
    youngs: 7.0e10,
    poisson: 0.33,
    density: 2699.0,
};
pub const STEEL: Solid = Solid {
    name: "steel",
    youngs: 2.08e11,
    poisson: 0.30,
    density: 7850.0,
};
pub const POLYETHYLENE: Solid = Solid {
    name: "polyethylene",
    youngs: 1.0e9,
    poisson: 0.40,
    density: 1400.0,
};
pub const NYLON: Solid = Solid {
    name: "nylon",
    youngs: 2.5e9,
    poisson: 0.40,
    density: 1000.0,
};
pub const COPPER: Solid = Solid {
    name: "copper",
    youngs: 1.2e11,
    poisson: 0.35,
    density: 8900.0,
};
/// A rigid plane: a modulus 10^5 times alumina's, so that it adds 1e-5 (relative) to `1/E*`
/// and `1/G*` of the stiffest sphere here (it is in the truth's `E*` too). The public scripts
/// do the same in their own ways: Yade's walls are 1000 times stiffer than the sphere,
/// LIGGGHTS-PFM gives sphere and wall one material of twice the sphere's modulus (the same
/// `E*` and `G*` as a rigid plane).
pub const RIGID: Solid = Solid {
    name: "rigid",
    youngs: 1.0e16,
    poisson: 0.25,
    density: 1000.0,
};

/// `s` with another density (test 8's large sphere: 1000 times the small one's).
pub fn denser(s: Solid, factor: f64) -> Solid {
    Solid {
        density: s.density * factor,
        ..s
    }
}

pub fn material(s: &Solid, e: f64, mu: f64) -> Material {
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

pub fn mass(s: &Solid, r: f64) -> f64 {
    s.density * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)
}

/// The f64 law of a pair of solids (both `e` and `mu` as given).
pub fn law(a: &Solid, b: &Solid, e: f64, mu: f64) -> Law {
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
        x: w.state.position[i],
        v: d(w.state.velocity[i]),
        w: d(w.state.omega[i]),
    }
}

fn body(shape: u32, material: u32, b: &Ball, offset: DVec3) -> BodyInit {
    BodyInit {
        shape,
        material,
        position: b.x + offset,
        orientation: Quat::IDENTITY,
        velocity: b.v.as_vec3(),
        angular_velocity: b.w.as_vec3(),
    }
}

/// The world of [`run_cases_with`]: the cases side by side along y, `gap[k]` between the
/// surfaces of case k.
fn build_world(
    cases: &[Case],
    gap: &[f64],
    sphere: &Material,
    lower: Option<&Material>,
    wall: Option<&Material>,
    dt: Option<f64>,
) -> World {
    let lower_index = 1 + u32::from(wall.is_some());
    let spacing = cases
        .iter()
        .map(|c| 4.0 * (c.a.r + c.b.r))
        .fold(0.0, f64::max);
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
            bodies.push(body(
                sa,
                if lower.is_some() { lower_index } else { 0 },
                &c.a,
                shift - DVec3::Z * (0.5 * gap[k]),
            ));
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
    if let Some(m) = lower {
        materials.push(m.clone());
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
    run_cases_with(ctx, cases, sphere, None, wall, dt, record)
}

/// [`run_cases`], sphere `a` of each pair of material `lower` where given (test 8's large,
/// dense sphere).
pub fn run_cases_with(
    ctx: &Ctx,
    cases: &[Case],
    sphere: &Material,
    lower: Option<&Material>,
    wall: Option<&Material>,
    dt: Option<f64>,
    record: bool,
) -> anyhow::Result<Run> {
    let build = |gap: &[f64]| build_world(cases, gap, sphere, lower, wall, dt);
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
            let xb = w.state.position[ib];
            match ia {
                None => cases[k].b.r - xb.z,
                Some(ia) => cases[k].a.r + cases[k].b.r - (xb - w.state.position[ia]).length(),
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
