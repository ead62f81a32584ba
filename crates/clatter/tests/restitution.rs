//! Normal impacts against closed forms: the linear spring-dashpot's coefficient of restitution
//! `e` and contact duration `t_c = pi / sqrt(k/m - (eta/2m)^2)` (sphere on a wall and
//! sphere on sphere, head-on, no friction, no gravity), and the Hertz law's restitution against
//! an independent high-accuracy integration of the same ODE.

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, PairParams, Wall, World, WorldDesc};
use glam::{Quat, Vec3};
use step_backend::step;

const R: f64 = 0.01;
const DENSITY: f32 = 2500.0;
const K: f32 = 2.0e4;
const V0: f32 = 0.5;

fn material(law: ContactLaw, e: f32) -> Material {
    Material::new("m", DENSITY, law, e, 0.0)
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

/// A sphere just above the floor `z = 0`, moving down at `V0`; no gravity.
fn wall_world(law: ContactLaw, e: f32, dt_fraction: f64) -> (World, f64) {
    wall_world_phase(law, e, dt_fraction, 0.0)
}

/// `phase` in [0, 1) shifts the start by that fraction of a step's travel.
fn wall_world_phase(law: ContactLaw, e: f32, dt_fraction: f64, phase: f64) -> (World, f64) {
    let m = material(law, e);
    let shape = ShapeKind::Sphere { radius: R }.prepare().unwrap();
    let mass = DENSITY as f64 * shape.volume as f64;
    let params = PairParams::combine(&m, &m);
    let t_c = params.contact_duration(mass, R, V0 as f64);
    let gap = (2.0e-4 + V0 as f64 * t_c / dt_fraction * phase) as f32;
    let desc = WorldDesc {
        shapes: vec![shape],
        materials: vec![m],
        walls: vec![Wall {
            plane: Plane {
                normal: Vec3::Z,
                offset: 0.0,
            },
            material: 0,
        }],
        bodies: vec![body(
            0,
            Vec3::new(0.0, 0.0, R as f32 + gap),
            Vec3::new(0.0, 0.0, -V0),
        )],
        gravity: Vec3::ZERO,
        dt: Some((t_c / dt_fraction) as f32),
        skin: None,
        periodic: None,
    };
    (World::new(desc), t_c)
}

/// Two spheres of radii `ra`, `rb` on the x axis, approaching head-on at relative speed `2 V0`.
fn pair_world(law: ContactLaw, e: f32, ra: f64, rb: f64, dt_fraction: f64) -> (World, f64) {
    let m = material(law, e);
    let sa = ShapeKind::Sphere { radius: ra }.prepare().unwrap();
    let sb = ShapeKind::Sphere { radius: rb }.prepare().unwrap();
    let (ma, mb) = (
        DENSITY as f64 * sa.volume as f64,
        DENSITY as f64 * sb.volume as f64,
    );
    let m_eff = ma * mb / (ma + mb);
    let params = PairParams::combine(&m, &m);
    let t_c = params.contact_duration(m_eff, ra * rb / (ra + rb), 2.0 * V0 as f64);
    let gap = 2.0e-4f32;
    let desc = WorldDesc {
        shapes: vec![sa, sb],
        materials: vec![m],
        walls: vec![],
        bodies: vec![
            body(
                0,
                Vec3::new(-(ra as f32) - gap / 2.0, 0.0, 0.0),
                Vec3::new(V0, 0.0, 0.0),
            ),
            body(
                1,
                Vec3::new(rb as f32 + gap / 2.0, 0.0, 0.0),
                Vec3::new(-V0, 0.0, 0.0),
            ),
        ],
        gravity: Vec3::ZERO,
        dt: Some((t_c / dt_fraction) as f32),
        skin: None,
        periodic: None,
    };
    (World::new(desc), t_c)
}

/// Steps until the single contact has come and gone; returns the time in contact (steps whose
/// narrow phase found an overlap, times dt). The velocities are then the outgoing ones.
fn run_impact(w: &mut World) -> f64 {
    let mut contact_steps = 0u64;
    let mut was_in_contact = false;
    for _ in 0..1_000_000 {
        let s = step(w).unwrap();
        if s.contacts > 0 {
            contact_steps += 1;
            was_in_contact = true;
        } else if was_in_contact {
            // One more force-free step: the velocity is final.
            let s = step(w).unwrap();
            assert_eq!(s.contacts, 0, "bodies touched again");
            return contact_steps as f64 * w.dt as f64;
        }
    }
    panic!("the impact never ended");
}

/// Steps per contact duration for the 1% assertions. The error in `e` is first order in dt:
/// at `t_c / 200` it reaches 3.3% for e = 0.1 and 1.0% for e = 0.3 in the worst case over the
/// phase at which the contact starts (see `restitution_error_is_first_order_in_dt`), so the
/// 1% requirement needs about `t_c / 700` for e = 0.1.
const FINE: f64 = 1000.0;

const RESTITUTIONS: [f32; 6] = [0.1, 0.3, 0.5, 0.7, 0.9, 1.0];

#[test]
fn linear_sphere_wall_restitution_and_duration() {
    for &e in &RESTITUTIONS {
        let (mut w, t_c) = wall_world(ContactLaw::Linear { stiffness: K }, e, FINE);
        let v_in = w.state.velocity[0].z as f64;
        let measured_tc = run_impact(&mut w);
        let v_out = w.state.velocity[0].z as f64;
        let e_meas = -v_out / v_in;
        eprintln!(
            "wall e={e}: measured e={e_meas:.5} (rel err {:.2e}), t_c={t_c:.4e} measured {measured_tc:.4e} (rel err {:.2e})",
            e_meas / e as f64 - 1.0,
            measured_tc / t_c - 1.0
        );
        assert!(
            (e_meas / e as f64 - 1.0).abs() < 0.01,
            "e = {e}: measured {e_meas}"
        );
        assert!(
            (measured_tc / t_c - 1.0).abs() < 0.02,
            "e = {e}: t_c {t_c} measured {measured_tc}"
        );
        // Head-on and frictionless: nothing sideways, no spin.
        assert_eq!(w.state.velocity[0].x, 0.0);
        assert_eq!(w.state.velocity[0].y, 0.0);
        assert_eq!(w.state.omega[0], Vec3::ZERO);
    }
}

#[test]
fn linear_sphere_sphere_restitution_and_duration() {
    for &e in &RESTITUTIONS {
        let (mut w, t_c) = pair_world(ContactLaw::Linear { stiffness: K }, e, R, R, FINE);
        let v_in = (w.state.velocity[1].x - w.state.velocity[0].x) as f64;
        let p0 = w.momentum();
        let measured_tc = run_impact(&mut w);
        let v_out = (w.state.velocity[1].x - w.state.velocity[0].x) as f64;
        let e_meas = -v_out / v_in;
        eprintln!(
            "pair e={e}: measured e={e_meas:.5} (rel err {:.2e}), t_c={t_c:.4e} measured {measured_tc:.4e} (rel err {:.2e})",
            e_meas / e as f64 - 1.0,
            measured_tc / t_c - 1.0
        );
        assert!(
            (e_meas / e as f64 - 1.0).abs() < 0.01,
            "e = {e}: measured {e_meas}"
        );
        assert!(
            (measured_tc / t_c - 1.0).abs() < 0.02,
            "e = {e}: t_c {t_c} measured {measured_tc}"
        );
        // Equal masses: symmetric outcome, momentum (zero) kept.
        let p1 = w.momentum();
        let scale = w.consts.mass[0] as f64 * V0 as f64;
        assert!(
            (p1[0] - p0[0]).abs() < 1e-6 * scale,
            "momentum {p0:?} -> {p1:?}"
        );
        assert_eq!(w.state.velocity[0].y, 0.0);
        assert_eq!(w.state.velocity[0].z, 0.0);
    }
}

/// The Hertz-Mindlin normal law with Tsuji's damping, integrated independently (RK4 in f64,
/// 200 000 steps per contact): `m x'' = -(4/3 E* sqrt(R x) x + c sqrt(2 E* sqrt(R x) m) x')`.
/// Returns (restitution, contact duration).
fn hertz_reference(e_star: f64, damping_factor: f64, m: f64, r: f64, v0: f64) -> (f64, f64) {
    let acc = |x: f64, v: f64| {
        if x <= 0.0 {
            return 0.0;
        }
        let a = (r * x).sqrt();
        let f = 4.0 / 3.0 * e_star * a * x + damping_factor * (2.0 * e_star * a * m).sqrt() * v;
        -f / m
    };
    let t_est = 2.87 * (m * m / (r * e_star * e_star * v0)).powf(0.2);
    let h = t_est / 200_000.0;
    let (mut x, mut v, mut t) = (0.0f64, v0, 0.0f64);
    loop {
        let (k1x, k1v) = (v, acc(x, v));
        let (k2x, k2v) = (v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
        let (k3x, k3v) = (v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
        let (k4x, k4v) = (v + h * k3v, acc(x + h * k3x, v + h * k3v));
        let xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if t > 0.0 && xn <= 0.0 {
            // Linear interpolation of the exit.
            let frac = x / (x - xn);
            return (-(v + frac * (vn - v)) / v0, t + frac * h);
        }
        x = xn;
        v = vn;
        t += h;
    }
}

#[test]
fn hertz_sphere_wall_restitution() {
    let (youngs, poisson) = (5.0e7f32, 0.3f32);
    let law = ContactLaw::Hertz {
        youngs_modulus: youngs,
        poisson_ratio: poisson,
    };
    for &e in &RESTITUTIONS {
        let m = material(law, e);
        let params = PairParams::combine(&m, &m);
        let (mut w, t_c) = wall_world(law, e, FINE);
        let mass = w.consts.mass[0] as f64;
        let (e_ref, tc_ref) = hertz_reference(
            params.stiffness as f64,
            params.damping_factor as f64,
            mass,
            R,
            V0 as f64,
        );
        let v_in = w.state.velocity[0].z as f64;
        let measured_tc = run_impact(&mut w);
        let e_meas = -w.state.velocity[0].z as f64 / v_in;
        eprintln!(
            "hertz e={e}: measured e={e_meas:.5} reference ODE e={e_ref:.5} (requested rel err {:.2e}, vs ODE {:.2e}); t_c est {t_c:.4e} ODE {tc_ref:.4e} measured {measured_tc:.4e}",
            e_meas / e as f64 - 1.0,
            e_meas / e_ref - 1.0
        );
        // The simulation integrates the law it claims to (tight).
        assert!(
            (e_meas / e_ref - 1.0).abs() < 0.01,
            "e = {e}: measured {e_meas}, ODE {e_ref}"
        );
        assert!(
            (measured_tc / tc_ref - 1.0).abs() < 0.02,
            "e = {e}: t_c ODE {tc_ref} measured {measured_tc}"
        );
        // Undamped estimate of the duration (2.87 (m^2 / (R E*^2 v))^(1/5)) holds for e = 1.
        if e == 1.0 {
            assert!(
                (measured_tc / t_c - 1.0).abs() < 0.02,
                "t_c {t_c} measured {measured_tc}"
            );
        }
        // Tsuji's damping `2 sqrt(5/6) beta sqrt(S_n m)` with the linear model's e -> beta map
        // is often said to give e only approximately; the independent ODE integration above
        // finds it exact to 1e-7 for every e here (the restitution of this dashpot depends on
        // beta alone, and the sqrt(5/6) makes the map match). So the requested e must be met
        // as tightly as in the linear model: 1% at t_c / 1000.
        assert!(
            (e_ref / e as f64 - 1.0).abs() < 1e-4,
            "e = {e}: ODE gives {e_ref}"
        );
        assert!(
            (e_meas / e as f64 - 1.0).abs() < 0.01,
            "e = {e}: measured {e_meas}"
        );
    }
}

/// Relative error of the measured restitution, `e_measured / e - 1`, for a sphere hitting
/// the floor (`pair = false`) or a second sphere of radius `R * size_ratio` head-on, the
/// contact starting at `phase` (a fraction of a step's travel), at `t_c / dt_fraction`, or at
/// the default step when `dt_fraction` is `None`.
fn restitution_error(
    law: ContactLaw,
    e: f32,
    pair: Option<f64>,
    dt_fraction: Option<f64>,
    phase: f64,
) -> f64 {
    let (mut w, _) = match pair {
        None => wall_world_phase(law, e, dt_fraction.unwrap_or(50.0), phase),
        Some(ratio) => pair_world(law, e, R, R * ratio, dt_fraction.unwrap_or(50.0)),
    };
    if dt_fraction.is_none() {
        w.dt = w.auto_dt();
    }
    if pair.is_some() {
        // Shift sphere 1 by the phase's fraction of a step's travel.
        w.state.position[1].x += 2.0 * V0 as f64 * w.dt as f64 * phase;
        w.rebuild_contacts();
    }
    let rel = |w: &World| match pair {
        None => w.state.velocity[0].z as f64,
        Some(_) => (w.state.velocity[1].x - w.state.velocity[0].x) as f64,
    };
    let v_in = rel(&w);
    run_impact(&mut w);
    -rel(&w) / v_in / e as f64 - 1.0
}

/// The worst error over phases at which the contact starts within a step.
fn worst_restitution_error(
    law: ContactLaw,
    e: f32,
    pair: Option<f64>,
    dt_fraction: Option<f64>,
) -> f64 {
    (0..11)
        .map(|k| restitution_error(law, e, pair, dt_fraction, k as f64 / 11.0).abs())
        .fold(0.0, f64::max)
}

const HERTZ: ContactLaw = ContactLaw::Hertz {
    youngs_modulus: 5.0e7,
    poisson_ratio: 0.3,
};

/// The requested restitution is met within 0.5% at the default time step (`t_c / 50`, as
/// `World` picks it), for any e in [0.05, 1], whatever the phase at which the contact starts
/// and ends within a step: linear and Hertz, sphere on wall and head-on sphere pairs of
/// equal and unequal sizes. (An explicit dashpot at the same step is off by up to 18% at
/// e = 0.05: the table in docs/validation.md.) The normal force is the law's impulse over
/// each step, resolved at onset and release (`law::resolved_normal_force`).
#[test]
fn restitution_within_half_a_percent_at_the_default_step() {
    for (name, law) in [
        ("linear", ContactLaw::Linear { stiffness: K }),
        ("hertz", HERTZ),
    ] {
        for &e in &[0.05f32, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0] {
            for (case, pair) in [("wall", None), ("pair", Some(1.0)), ("unequal", Some(2.5))] {
                let err = worst_restitution_error(law, e, pair, None);
                eprintln!("{name} {case} e={e}: worst rel err {err:.2e} at the default step");
                assert!(err < 0.005, "{name} {case} e = {e}: error {err}");
            }
        }
    }
}

/// Resolving the contact inside the step leaves an error of second order: from the default
/// step to a step 2.5 times coarser (t_c / 20) it stays within 3%, and it shrinks as the
/// step does.
#[test]
fn restitution_error_shrinks_with_the_step() {
    for &e in &[0.1f32, 0.5, 0.9] {
        let law = ContactLaw::Linear { stiffness: K };
        let errs: Vec<f64> = [20.0, 50.0, 200.0]
            .iter()
            .map(|&f| worst_restitution_error(law, e, None, Some(f)))
            .collect();
        eprintln!("e={e}: worst rel err at t_c/20, t_c/50, t_c/200: {errs:?}");
        assert!(errs[0] < 0.03, "e = {e}: {errs:?}");
        assert!(errs[1] < 0.005, "e = {e}: {errs:?}");
        assert!(errs[2] < 0.002, "e = {e}: {errs:?}");
    }
}
