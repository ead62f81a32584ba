//! The WGSL contact law (`shaders/contacts/law.wgsl`) against its Rust twin (`clatter::law`) on
//! thousands of random contact states: linear and Hertz, one to four points, sphere and
//! polyhedron shares, springs inside and beyond the Coulomb cap, spinning patches, adhesion,
//! and every material coefficient that is off by default (rolling and spinning friction, and
//! any added to `clatter::material_coefficients!`) on for half the materials.
//! Forces, torques and the new springs must agree to rounding (the GPU may fuse
//! multiply-adds, and damping may nearly cancel a spring): within 1e-4 of the contact's
//! force and torque scales.

use clatter::PairParams;
use clatter::contract::PairContext;
use clatter::law::{self, BodyMotion};
use clatter::material::{COEFFICIENTS, Cohesion, ContactLaw, Material};
use clatter_geom::narrow::{ContactPoint, Manifold};
use clatter_gpu::law::{LawQuery, law_batch};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn vec(rng: &mut ChaCha8Rng, scale: f32) -> Vec3 {
    if scale <= 0.0 {
        return Vec3::ZERO;
    }
    Vec3::new(
        rng.random_range(-scale..scale),
        rng.random_range(-scale..scale),
        rng.random_range(-scale..scale),
    )
}

fn unit(rng: &mut ChaCha8Rng) -> Vec3 {
    loop {
        let v = vec(rng, 1.0);
        if v.length_squared() > 1e-3 {
            return v.normalize();
        }
    }
}

fn params(rng: &mut ChaCha8Rng) -> PairParams {
    let material = |rng: &mut ChaCha8Rng| {
        let law = if rng.random_bool(0.5) {
            ContactLaw::Linear {
                stiffness: 10f32.powf(rng.random_range(2.0..6.0)),
            }
        } else {
            ContactLaw::Hertz {
                youngs_modulus: 10f32.powf(rng.random_range(6.0..10.0)),
                poisson_ratio: rng.random_range(0.0..0.45),
            }
        };
        let restitution = rng.random_range(0.05..1.0);
        let friction = rng.random_range(0.0..1.0);
        let mut m = Material::new("m", 1000.0, law, restitution, friction);
        // Every coefficient that is off by default (rolling and spinning friction, and any
        // term added to the table since): on for half the materials.
        for c in COEFFICIENTS.iter().filter(|c| c.default == 0.0) {
            if let Some(v) = m.coefficient_mut(c.name) {
                *v = if rng.random_bool(0.5) {
                    rng.random_range(0.0..0.5)
                } else {
                    0.0
                };
            }
        }
        m.cohesion = rng.random_bool(0.5).then(|| Cohesion::Dmt {
            surface_energy: 10f32.powf(rng.random_range(-3.0..1.0)),
        });
        m
    };
    let a = material(rng);
    let mut b = material(rng);
    b.law = match (a.law, b.law) {
        (ContactLaw::Linear { .. }, l @ ContactLaw::Linear { .. }) => l,
        (ContactLaw::Hertz { .. }, l @ ContactLaw::Hertz { .. }) => l,
        (l, _) => l,
    };
    PairParams::combine(&a, &b)
}

fn query(rng: &mut ChaCha8Rng) -> LawQuery {
    let size = 10f32.powf(rng.random_range(-3.0..0.0));
    let count = rng.random_range(1..=4usize);
    let normal = unit(rng);
    let centre = vec(rng, size);
    let mut points = [ContactPoint::default(); 4];
    for p in points.iter_mut().take(count) {
        let offset = vec(rng, 0.3 * size);
        *p = ContactPoint {
            point: centre + offset - normal * offset.dot(normal),
            depth: rng.random_range(0.0..0.02) * size,
        };
    }
    let speed = rng.random_range(0.0..3.0);
    let motion = |rng: &mut ChaCha8Rng, at: Vec3| BodyMotion {
        position: at,
        velocity: vec(rng, speed),
        omega: vec(rng, speed / size),
    };
    let a = if rng.random_bool(0.2) {
        BodyMotion::default()
    } else {
        motion(rng, centre - normal * size)
    };
    let b = motion(rng, centre + normal * size);
    let mass = 10f32.powf(rng.random_range(-6.0..1.0));
    // Springs: zero (a new contact), small, or far beyond the Coulomb cap.
    let reach = [0.0, 1e-4, 1.0][rng.random_range(0..3usize)] * size;
    let share = if rng.random_bool(0.5) { 1.0 } else { 0.25 };
    let dt = 10f32.powf(rng.random_range(-6.0..-4.0));
    let mut twist = rng.random_range(-1.0..1.0) * reach / size;
    if share == 1.0 && count == 1 {
        // A sphere contact, resolved within the step: its first or last step (an overlap
        // within a step's travel) half the time, and a coverage of a new, a released or a
        // continuing contact.
        if rng.random_bool(0.5) {
            points[0].depth = rng.random_range(0.0..1.0) * speed * dt;
        }
        twist = match rng.random_range(0..3u32) {
            0 => 0.0,
            1 => -1.0,
            _ => points[0].depth * rng.random_range(0.5..1.5),
        };
    }
    LawQuery {
        context: PairContext {
            params: params(rng),
            m_eff: mass,
            r_eff: size,
            share,
            dt,
        },
        manifold: Manifold {
            normal,
            points,
            count,
        },
        a,
        b,
        history: vec(rng, reach),
        twist,
    }
}

#[test]
fn wgsl_law_matches_the_rust_law() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let queries: Vec<LawQuery> = (0..20_000).map(|_| query(&mut rng)).collect();
    let gpu = law_batch(&ctx, &queries).expect("law batch runs");
    assert_eq!(gpu.len(), queries.len());
    let (mut capped, mut patches, mut optional_or_sticky, mut worst) = (0, 0, 0, 0.0f32);
    for (k, (q, (g, g_hist))) in queries.iter().zip(&gpu).enumerate() {
        let (mut hist, mut twist) = (q.history, q.twist);
        let qc = &q.context;
        let c = law::contact_force(qc, &q.manifold, &q.a, &q.b, &mut hist, &mut twist);
        // Scales: the force, and the torque it makes over the contact's lever arms.
        let lever = (q.manifold.points[0].point - q.b.position).length()
            + (q.manifold.points[0].point - q.a.position).length();
        // (The spring forces too: the damping can nearly cancel them.)
        let springs: f32 = q
            .manifold
            .points()
            .iter()
            .map(|p| law::spring(&qc.params, qc.r_eff, p.depth, qc.share).0.abs())
            .sum();
        let f_scale = c
            .force_b
            .length()
            .max(c.normal_force.abs())
            .max(springs + law::adhesion(&qc.params, qc.r_eff))
            .max(1e-30);
        let rolling = law::rolling_torque(qc, q.manifold.normal, &q.a, &q.b, f_scale);
        let spinning = law::spinning_torque(qc, q.manifold.normal, &q.a, &q.b, f_scale);
        let t_scale = f_scale * lever
            + c.torque_a.length()
            + c.torque_b.length()
            + rolling.length()
            + spinning.length();
        // Spring scales: what one step of the relative motion adds to a spring (a new
        // spring is that alone, where rounding in the tangential projection shows), and the
        // overlap for a sphere contact's coverage.
        let travel = (q.a.velocity.length()
            + q.b.velocity.length()
            + (q.a.omega.length() + q.b.omega.length()) * lever)
            * qc.dt;
        let h_scale = hist.length().max(q.history.length()).max(travel).max(1e-30);
        let twist_scale = twist
            .abs()
            .max(q.twist.abs())
            .max((q.a.omega.length() + q.b.omega.length()) * qc.dt)
            .max(q.manifold.points[0].depth)
            .max(1e-30);
        let errs = [
            (g.force_b - c.force_b).length() / f_scale,
            (g.normal_force - c.normal_force).abs() / f_scale,
            (g.torque_a - c.torque_a).length() / t_scale,
            (g.torque_b - c.torque_b).length() / t_scale,
            (Vec3::new(g_hist[0], g_hist[1], g_hist[2]) - hist).length() / h_scale,
            (g_hist[3] - twist).abs() / twist_scale,
        ];
        let err = errs.iter().copied().fold(0.0, f32::max);
        assert!(
            err < 1e-4,
            "contact {k}: GPU and CPU laws disagree by {err:.2e} ({errs:?})\n  query {q:?}\n  cpu {c:?} spring {hist} twist {twist}\n  gpu {g:?} spring {g_hist:?}"
        );
        worst = worst.max(err);
        let cap = qc.params.friction * c.normal_force.max(0.0);
        if q.history.length() > 0.0 && (hist.length() * 1.0001 < q.history.length() || cap == 0.0) {
            capped += 1;
        }
        if q.manifold.count > 1 {
            patches += 1;
        }
        let optional_on = COEFFICIENTS
            .iter()
            .filter(|c| c.default == 0.0)
            .any(|c| qc.params.coefficient(c.name).is_some_and(|v| v > 0.0));
        if optional_on || qc.params.cohesion_model != 0 {
            optional_or_sticky += 1;
        }
    }
    eprintln!(
        "law twins: {} contacts, {patches} patches, {capped} at the Coulomb cap, {optional_or_sticky} with an optional coefficient (rolling or spinning friction, ...) or adhesion, worst relative difference {worst:.2e}",
        queries.len()
    );
    assert!(
        patches > 10_000 && capped > 1_000 && optional_or_sticky > 5_000,
        "the random states cover the law's branches"
    );
}
