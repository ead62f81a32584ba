//! Rolling resistance (constant directional torque `mu_r R Fn`) and DMT adhesion against
//! their closed forms.
//!
//! - A solid sphere rolling without slipping on a floor at `u0` decelerates at
//!   `5/7 mu_r g` (the torque `mu_r R m g` slows the spin, friction at the contact keeps it
//!   rolling), so it stops after `u0^2 / (2 * 5/7 mu_r g)`.
//! - A sphere hanging under a ceiling with DMT adhesion stays when its weight is below the
//!   pull-off force `2 pi gamma R` and falls when it is above.

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, Cohesion, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};
use step_backend::step_n;

const R: f32 = 0.01;
const DENSITY: f32 = 2500.0;
const K: f32 = 2.0e4;
const G: f32 = 9.81;

fn sphere_world(
    material: Material,
    wall_normal: Vec3,
    position: Vec3,
    velocity: Vec3,
    omega: Vec3,
) -> World {
    let shape = ShapeKind::Sphere { radius: R as f64 }.prepare().unwrap();
    World::new(WorldDesc {
        shapes: vec![shape],
        materials: vec![material],
        walls: vec![Wall {
            plane: Plane {
                normal: wall_normal,
                offset: 0.0,
            },
            material: 0,
        }],
        bodies: vec![BodyInit {
            shape: 0,
            material: 0,
            position: position.as_dvec3(),
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

fn mass() -> f32 {
    DENSITY * 4.0 / 3.0 * std::f32::consts::PI * R * R * R
}

#[test]
fn rolling_sphere_stops_over_the_analytic_distance() {
    for (mu_r, u0) in [(0.05f32, 0.2f32), (0.2, 0.5)] {
        let mut material =
            Material::new("m", DENSITY, ContactLaw::Linear { stiffness: K }, 0.5, 0.8);
        material.rolling_friction = mu_r;
        let v = Vec3::new(u0, 0.0, 0.0);
        // Rolling without slipping: omega = (z x v) / R.
        let omega = Vec3::Z.cross(v) / R;
        let z0 = R - mass() * G / K;
        let mut w = sphere_world(material, Vec3::Z, Vec3::new(0.0, 0.0, z0), v, omega);
        let a = 5.0 / 7.0 * mu_r as f64 * G as f64;
        let t_stop = u0 as f64 / a;
        let expected = (u0 as f64).powi(2) / (2.0 * a);
        let steps = ((1.3 * t_stop) / w.dt as f64).ceil() as u64;
        step_n(&mut w, steps).unwrap();
        let travelled = w.state.position[0].x;
        let speed = w.state.velocity[0].length();
        assert!(
            speed < 1e-3 * u0,
            "mu_r = {mu_r}: still moving at {speed} m/s after {:.3} s (stops at {t_stop:.3} s)",
            w.time
        );
        let err = (travelled - expected).abs() / expected;
        eprintln!(
            "mu_r = {mu_r}, u0 = {u0}: stopped after {travelled:.5} m, analytic {expected:.5} m ({:.2}%)",
            100.0 * err
        );
        assert!(err < 0.02, "mu_r = {mu_r}: {travelled} m vs {expected} m");
    }
}

#[test]
fn without_rolling_friction_a_rolling_sphere_keeps_rolling() {
    let material = Material::new("m", DENSITY, ContactLaw::Linear { stiffness: K }, 0.5, 0.8);
    let v = Vec3::new(0.2, 0.0, 0.0);
    let z0 = R - mass() * G / K;
    let mut w = sphere_world(
        material,
        Vec3::Z,
        Vec3::new(0.0, 0.0, z0),
        v,
        Vec3::Z.cross(v) / R,
    );
    let steps = (0.3 / w.dt as f64).ceil() as u64;
    step_n(&mut w, steps).unwrap();
    let speed = w.state.velocity[0].x;
    assert!((speed - 0.2).abs() < 2e-3, "speed {speed}");
}

/// Whether a sphere of weight `weight_ratio * 2 pi gamma R` hanging under a ceiling is still
/// attached after 0.1 s.
fn stays_attached(weight_ratio: f32) -> bool {
    let gamma = weight_ratio.recip() * mass() * G / (2.0 * std::f32::consts::PI * R);
    let mut material = Material::new("m", DENSITY, ContactLaw::Linear { stiffness: K }, 0.3, 0.5);
    material.cohesion = Some(Cohesion::Dmt {
        surface_energy: gamma,
    });
    // The ceiling is z = 0 (solid above). The sphere starts at rest where the spring would
    // balance adhesion minus weight (a hair's overlap when the weight wins): it stays there
    // if the pull-off force is the analytic one, and leaves if it is weaker.
    let pull = 2.0 * std::f32::consts::PI * gamma * R;
    let depth = (pull * (1.0 - weight_ratio)).max(1e-5 * pull) / K;
    let mut w = sphere_world(
        material,
        -Vec3::Z,
        Vec3::new(0.0, 0.0, -(R - depth)),
        Vec3::ZERO,
        Vec3::ZERO,
    );
    let steps = (0.1 / w.dt as f64).ceil() as u64;
    step_n(&mut w, steps).unwrap();
    let gap = -w.state.position_f32(0).z - R;
    gap < 0.01 * R
}

#[test]
fn dmt_pull_off_force_is_two_pi_gamma_r() {
    assert!(
        stays_attached(0.9),
        "a sphere of 0.9x the pull-off weight falls"
    );
    assert!(
        stays_attached(0.98),
        "a sphere of 0.98x the pull-off weight falls"
    );
    assert!(
        !stays_attached(1.02),
        "a sphere of 1.02x the pull-off weight stays"
    );
    assert!(
        !stays_attached(1.2),
        "a sphere of 1.2x the pull-off weight stays"
    );
}

#[test]
fn spinning_sphere_stops_in_the_analytic_time() {
    // The torque mu_s R m g about the vertical slows a sphere spinning on the floor at a
    // constant rate: it stops after I w0 / (mu_s R m g) = 0.4 w0 R / (mu_s g).
    let (mu_s, w0) = (0.1f32, 50.0f32);
    let mut material = Material::new("m", DENSITY, ContactLaw::Linear { stiffness: K }, 0.5, 0.8);
    material.spinning_friction = mu_s;
    let z0 = R - mass() * G / K;
    let mut w = sphere_world(
        material,
        Vec3::Z,
        Vec3::new(0.0, 0.0, z0),
        Vec3::ZERO,
        Vec3::Z * w0,
    );
    let t_stop = 0.4 * w0 as f64 * R as f64 / (mu_s as f64 * G as f64);
    // Half way, the spin is half.
    let half = (0.5 * t_stop / w.dt as f64).round() as u64;
    step_n(&mut w, half).unwrap();
    let spin = w.state.omega[0].z as f64;
    let expected = w0 as f64 * (1.0 - w.time / t_stop);
    assert!(
        (spin - expected).abs() < 0.02 * w0 as f64,
        "spin {spin} rad/s at {:.4} s, analytic {expected}",
        w.time
    );
    step_n(&mut w, half).unwrap();
    step_n(&mut w, half / 5).unwrap();
    assert!(
        w.state.omega[0].length() < 1e-3 * w0,
        "still spinning at {} rad/s after {:.4} s (stops at {t_stop:.4} s)",
        w.state.omega[0].length(),
        w.time
    );
}
