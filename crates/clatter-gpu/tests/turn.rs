//! A turning mesh boundary's pose in WGSL (`shaders/common/turn.wgsl`) against its Rust twin
//! (`clatter::turn`), bitwise: the angle `rate u mod 2 pi` from the double-single elapsed
//! time, the quaternion and the translation, for rates from 1e-3 to 1e3 rad/s over times
//! from the first step to hours, random axes and centres, and the sine and cosine over
//! every octant. The two must give the same bits: the drum's wall is where the bodies
//! meet it on both executors.

use clatter::turn::{sin_cos, turn_angle, turn_pose};
use clatter_gpu::turn::{TurnQuery, turn_batch};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `x` split into an unevaluated sum of two f32 (as `Boundary::elapsed_ds`).
fn split(x: f64) -> (f32, f32) {
    let hi = x as f32;
    (hi, (x - hi as f64) as f32)
}

fn queries() -> Vec<TurnQuery> {
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    let mut out = Vec::new();
    for k in 0..20_000 {
        let axis = loop {
            let v = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if v.length_squared() > 1e-2 {
                break if k % 5 == 0 { Vec3::Y } else { v.normalize() };
            }
        };
        let rate = 10f32.powf(rng.random_range(-3.0..3.0));
        let centre = Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
        );
        // Elapsed times as the executors keep them (n dt, exact in 48 bits) from one step
        // to about 10^4 s.
        let dt = rng.random_range(1e-6f32..1e-3) as f64;
        let n = 10f64.powf(rng.random_range(0.0..7.0)).floor();
        let u = split(n * dt);
        let x = rng.random_range(0.0f32..3.99);
        out.push(TurnQuery {
            axis,
            rate,
            centre,
            u,
            x,
        });
    }
    // The octant edges of the sine and cosine, where the reduction switches.
    for j in 0..6 {
        let e = (j as f64 * std::f64::consts::FRAC_PI_4) as f32;
        for d in -8i32..=8 {
            let x = f32::from_bits((e.to_bits() as i64 + d as i64).max(0) as u32);
            if x < 4.0 {
                let mut q = out[0];
                q.x = x;
                out.push(q);
            }
        }
    }
    out
}

#[test]
fn turning_poses_are_bitwise_the_cpus() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let queries = queries();
    let answers = turn_batch(&ctx, &queries).unwrap();
    assert_eq!(answers.len(), queries.len());
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (q, a) in queries.iter().zip(&answers) {
        let angle = turn_angle(q.rate, q.u);
        assert_eq!(a.angle.to_bits(), angle.to_bits(), "angle of {q:?}");
        let (rotation, translation) = turn_pose(q.axis, q.centre, angle);
        assert_eq!(
            bits(&a.rotation.to_array()),
            bits(&rotation.to_array()),
            "rotation of {q:?}: GPU {} CPU {rotation}",
            a.rotation
        );
        assert_eq!(
            bits(&a.translation.to_array()),
            bits(&translation.to_array()),
            "translation of {q:?}: GPU {} CPU {translation}",
            a.translation
        );
        let (s, c) = sin_cos(q.x);
        assert_eq!(
            (a.sin_cos.0.to_bits(), a.sin_cos.1.to_bits()),
            (s.to_bits(), c.to_bits()),
            "sin_cos({})",
            q.x
        );
    }
}
