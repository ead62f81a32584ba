//! A sphere launched on a rough floor slides, then rolls: the closed forms of the sliding
//! phase (Coulomb friction `mu m g` decelerating the centre and spinning the sphere up) and of
//! the final rolling state (angular momentum about the contact point is conserved:
//! `m v R + I w = const`, `I = 2/5 m R^2`).
//!
//! Sign convention: the floor is `z = 0`, the sphere moves along a horizontal `u`; rolling
//! without slipping means `omega = (z x v) / R` (for `u = x`, `omega_y = v_x / R`). Backspin of
//! magnitude `w0` is `omega = -w0 (z x u)`. Then `v_final = (5 v0 - 2 R w0) / 7` along `u`.

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};
use step_backend::{step, step_n};

const R: f32 = 0.01;
const DENSITY: f32 = 2500.0;
const K: f32 = 2.0e4;
const MU: f32 = 0.3;
const G: f32 = 9.81;

/// A sphere resting at its static overlap on the floor, launched with `velocity` and `omega`.
fn world(velocity: Vec3, omega: Vec3) -> World {
    let shape = ShapeKind::Sphere { radius: R as f64 }.prepare().unwrap();
    let mass = DENSITY * shape.volume;
    let material = Material::new("m", DENSITY, ContactLaw::Linear { stiffness: K }, 0.5, MU);
    World::new(WorldDesc {
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
            position: Vec3::new(0.0, 0.0, R - mass * G / K).as_dvec3(),
            orientation: Quat::IDENTITY,
            velocity,
            angular_velocity: omega,
        }],
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: None,
        skin: None,
        periodic: None,
    })
}

fn run_for(w: &mut World, seconds: f64) {
    let steps = (seconds / w.dt as f64).ceil() as u64;
    step_n(w, steps).unwrap();
}

/// Slip velocity of the contact point (bottom of the sphere).
fn slip(w: &World) -> Vec3 {
    w.state.velocity[0] + w.state.omega[0].cross(Vec3::new(0.0, 0.0, -R))
}

#[test]
fn sliding_sphere_ends_rolling_at_five_sevenths() {
    let v0 = 1.0f32;
    for angle in [0.0f32, 0.7, 2.5] {
        let u = Vec3::new(angle.cos(), angle.sin(), 0.0);
        let mut w = world(u * v0, Vec3::ZERO);
        // Sliding phase: constant deceleration mu g, spin-up 5 mu g / (2 R).
        let t_roll = 2.0 * v0 as f64 / (7.0 * (MU * G) as f64);
        let t_half = 0.5 * t_roll;
        run_for(&mut w, t_half);
        let t = w.time;
        let v_expected = v0 as f64 - (MU * G) as f64 * t;
        let w_expected = 2.5 * (MU * G) as f64 * t / R as f64;
        let v = w.state.velocity[0].dot(u) as f64;
        let spin = w.state.omega[0].dot(Vec3::Z.cross(u)) as f64;
        eprintln!(
            "angle {angle}: at t={t:.4}: v={v:.5} (expected {v_expected:.5}), omega={spin:.3} (expected {w_expected:.3})"
        );
        assert!(
            (v / v_expected - 1.0).abs() < 0.01,
            "sliding v {v}, expected {v_expected}"
        );
        assert!(
            (spin / w_expected - 1.0).abs() < 0.02,
            "sliding omega {spin}, expected {w_expected}"
        );

        // Slip stops at t_roll.
        let mut t_stop = None;
        while w.time < 2.0 * t_roll {
            step(&mut w).unwrap();
            if t_stop.is_none() && slip(&w).length() < 0.01 * v0 {
                t_stop = Some(w.time);
            }
        }
        let t_stop = t_stop.expect("the sphere never stopped slipping");
        eprintln!("angle {angle}: slip stops at {t_stop:.5} s, expected {t_roll:.5} s");
        assert!(
            (t_stop / t_roll - 1.0).abs() < 0.03,
            "slip stopped at {t_stop}, expected {t_roll}"
        );

        run_for(&mut w, 0.3);
        let v = w.state.velocity[0];
        let vr = (w.state.omega[0].cross(Vec3::Z) * R).dot(u);
        eprintln!(
            "angle {angle}: final v={v:?}, omega={:?}, v.u={}, omega R={vr}",
            w.state.omega[0],
            v.dot(u)
        );
        assert!(
            (v.dot(u) / (5.0 / 7.0 * v0) - 1.0).abs() < 0.01,
            "final speed {v}, expected {}",
            5.0 / 7.0 * v0
        );
        assert!(
            (vr / v.dot(u) - 1.0).abs() < 0.01,
            "v = {v}, omega R = {vr}: not rolling"
        );
        // Straight on: nothing across the launch direction, no spin about z or u.
        assert!(v.dot(Vec3::Z.cross(u)).abs() < 1e-4 * v0);
        assert!(
            w.state.omega[0].dot(u).abs() * R < 1e-4 * v0
                && w.state.omega[0].z.abs() * R < 1e-4 * v0
        );

        // Rolling goes on without losing speed (the model has no rolling resistance).
        let before = v.dot(u);
        run_for(&mut w, 0.3);
        let after = w.state.velocity[0].dot(u);
        assert!(
            (after / before - 1.0).abs() < 0.005,
            "rolling speed {before} -> {after}"
        );
        // Still on the floor at its static overlap.
        let sink = (R - w.state.position_f32(0).z) as f64;
        let static_overlap = (w.consts.mass[0] * G / K) as f64;
        assert!(
            (sink - static_overlap).abs() < 0.05 * static_overlap,
            "overlap {sink} vs {static_overlap}"
        );
    }
}

#[test]
fn spinning_sphere_final_velocity() {
    let v0 = 1.0f32;
    let u = Vec3::X;
    // R w0: backspin (positive), strong backspin that reverses, topspin (negative).
    for r_w0 in [1.0f32, 5.0, -2.0, 3.5] {
        let w0 = r_w0 / R;
        let omega = -w0 * Vec3::Z.cross(u);
        let mut w = world(u * v0, omega);
        let expected = (5.0 * v0 - 2.0 * r_w0) / 7.0;
        let slip0 = (v0 + r_w0).abs();
        let t_roll = 2.0 * slip0 as f64 / (7.0 * (MU * G) as f64);
        run_for(&mut w, t_roll + 0.2);
        let v = w.state.velocity[0].dot(u);
        let vr = w.state.omega[0].dot(Vec3::Z.cross(u)) * R;
        eprintln!("R w0 = {r_w0}: v = {v:.5}, omega R = {vr:.5}, expected {expected:.5}");
        assert!(
            (v - expected).abs() < 0.01 * expected.abs(),
            "R w0 = {r_w0}: v = {v}, expected {expected}"
        );
        assert!(
            (vr - v).abs() < 0.01 * v.abs(),
            "R w0 = {r_w0}: v = {v}, omega R = {vr}: not rolling"
        );
        // Angular momentum about the contact point is conserved.
        let m = w.consts.mass[0];
        let l0 = m * v0 * R + 0.4 * m * R * R * (-w0);
        let l1 = m * v * R + 0.4 * m * R * R * (vr / R);
        assert!(
            (l1 - l0).abs() < 0.01 * m * v0 * R,
            "L about contact {l0} -> {l1}"
        );
    }
}
