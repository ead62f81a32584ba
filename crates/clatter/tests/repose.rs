//! The angle of repose of a sphere pile grows with rolling friction: a column of 400
//! frictional spheres collapses on a rough floor, and the slope of the deposit is measured
//! for `mu_r` = 0, 0.15 and 0.4. Without rolling resistance spheres roll away and the pile
//! flattens (spheres flow almost like a liquid); with it they stop on a slope.

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const R: f32 = 0.003;

fn column(mu_r: f32) -> World {
    let mut grain = Material::new(
        "grain",
        2500.0,
        ContactLaw::Linear { stiffness: 5.0e3 },
        0.3,
        0.5,
    );
    grain.rolling_friction = mu_r;
    let mut floor = grain.clone();
    floor.friction = 0.8;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let spacing = 2.1 * R;
    let mut bodies = Vec::new();
    for k in 0..400 {
        let (x, y, z) = (k % 5, (k / 5) % 5, k / 25);
        let jitter = Vec3::new(
            rng.random_range(-0.02..0.02),
            rng.random_range(-0.02..0.02),
            0.0,
        );
        bodies.push(BodyInit {
            shape: 0,
            material: 0,
            position: ((Vec3::new(x as f32 - 2.0, y as f32 - 2.0, z as f32 + 0.5) + jitter)
                * spacing
                + Vec3::new(0.0, 0.0, R))
            .as_dvec3(),
            orientation: Quat::IDENTITY,
            velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
        });
    }
    World::new(WorldDesc {
        shapes: vec![ShapeKind::Sphere { radius: R as f64 }.prepare().unwrap()],
        materials: vec![grain, floor],
        walls: vec![Wall {
            plane: Plane {
                normal: Vec3::Z,
                offset: 0.0,
            },
            material: 1,
        }],
        bodies,
        gravity: Vec3::new(0.0, 0.0, -9.81),
        dt: None,
        skin: None,
        periodic: None,
    })
}

/// The slope of the pile, in degrees: the highest sphere top per ring of radial distance
/// from the pile's axis, fitted by a line over the rings between the summit and the foot.
fn repose_angle(w: &World) -> f64 {
    let n = w.len();
    let centre = w
        .state
        .position
        .iter()
        .fold(Vec3::ZERO, |a, &p| a + p.as_vec3())
        / n as f32;
    let ring = 2.0 * R;
    let mut top = vec![0.0f32; 64];
    for p in w.state.position.iter().map(|p| p.as_vec3()) {
        let rho = ((p.x - centre.x).powi(2) + (p.y - centre.y).powi(2)).sqrt();
        let k = ((rho / ring) as usize).min(top.len() - 1);
        top[k] = top[k].max(p.z + R);
    }
    // Rings from the summit out to the last one with a sphere above the first layer.
    let last = top.iter().rposition(|&h| h > 2.5 * R).unwrap_or(1).max(1);
    let pts: Vec<(f64, f64)> = (0..=last)
        .filter(|&k| top[k] > 0.0)
        .map(|k| (((k as f32 + 0.5) * ring) as f64, top[k] as f64))
        .collect();
    let m = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let (sxx, sxy) = pts.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx).powi(2), a.1 + (p.0 - mx) * (p.1 - my))
    });
    let slope = if sxx > 0.0 { -sxy / sxx } else { 0.0 };
    slope.max(0.0).atan().to_degrees()
}

#[test]
fn angle_of_repose_grows_with_rolling_friction() {
    let mut angles = Vec::new();
    for mu_r in [0.0f32, 0.15, 0.4] {
        let mut w = column(mu_r);
        let steps = (0.8 / w.dt as f64) as u64;
        for _ in 0..steps {
            w.step().expect("the pile settles");
        }
        let angle = repose_angle(&w);
        eprintln!(
            "rolling friction {mu_r}: angle of repose {angle:.1} deg after {:.2} s, kinetic energy {:.2e} J",
            w.time,
            w.kinetic_energy()
        );
        angles.push(angle);
    }
    assert!(
        angles[1] > angles[0] + 2.0 && angles[2] > angles[1] + 2.0,
        "angles {angles:?} do not grow with rolling friction"
    );
}
