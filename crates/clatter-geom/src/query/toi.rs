//! Time of impact of two shapes moving with constant linear and angular velocity, by
//! conservative advancement (Mirtich) with a directional bound.
//!
//! Each body's centre of mass moves as `x(t) = x0 + v t` and its orientation as
//! `q(t) = exp(ω t) q0` (ω in the world frame, about the centre of mass). At the current time
//! GJK gives the distance `d` and the unit normal `n` from `a` to `b`. Along the fixed world
//! axis `n` the gap can close no faster than
//! `μ = (v_a - v_b)·n + |n × ω_a| r_a + |n × ω_b| r_b` (with `r` the largest distance of a
//! polyhedron vertex from its centre of mass; a sphere contributes no rotational term), so
//! the bodies cannot touch before `t + d / μ`; if `μ <= 0` they never touch at all. Time is
//! advanced by `(d - tol/2) / μ`, which never overshoots, until `d <= tol`.
//!
//! Guarantees, with `tol = TOI_REL_TOL x (sum of bounding radii)`:
//! * the returned time is never later than the first contact (up to GJK's accuracy), and the
//!   shapes are at most `tol` apart at that time;
//! * `None` means a separating bound proved that no contact happens in `[0, horizon]`;
//! * shapes overlapping at `t = 0` return time 0 with the penetration normal and points.
//!
//! Two spheres are solved in closed form (exact contact time, distance 0).
//! When [`TOI_MAX_ITERATIONS`] steps are taken without convergence (grazing motions with fast
//! spin), the current time is returned with `converged = false`: the shapes are still apart
//! then, and no contact happened before it.

use glam::{DQuat, DVec3, Vec3};

use super::support::DPose;
use super::{Pair, contact, to_world};
use crate::{Pose, Shape};

/// Iteration cap of conservative advancement.
///
/// A fast spin that grazes the other shape advances by about `gap / (ω r)` a step: a cube
/// of size 1 spinning at 100 rad/s 0.01 from a wall needs ~10,000 steps to cover 1 s. At
/// 1,000 the cap was reached on such motions; each step is one GJK distance (about a
/// microsecond), so the cap bounds a query at about 0.1 s.
pub const TOI_MAX_ITERATIONS: usize = 100_000;
/// Distance tolerance at impact, relative to the sum of the two bounding radii.
pub const TOI_REL_TOL: f64 = 1e-6;

/// Constant velocities of a body: `linear` of the centre of mass, `angular` (rad/s, world
/// frame) about the centre of mass.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    pub linear: Vec3,
    pub angular: Vec3,
}

/// First contact found by [`time_of_impact`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Toi {
    /// Time of first contact (0 when overlapping at the start).
    pub time: f32,
    /// Witness points on `a` and `b` at that time (world frame), at most the tolerance apart
    /// (the contact's witness points when overlapping at the start).
    pub points: [Vec3; 2],
    /// Unit contact normal from `a` to `b` at that time.
    pub normal: Vec3,
    /// False when the iteration cap was hit: `time` is then a conservative (early) estimate.
    pub converged: bool,
}

#[inline]
fn pose_at(q0: DQuat, x0: DVec3, v: DVec3, w: DVec3, t: f64) -> DPose {
    DPose::new(DQuat::from_scaled_axis(w * t) * q0, x0 + v * t)
}

/// First time in `[0, horizon]` at which `a` (starting at `pose_a`, moving with `motion_a`)
/// and `b` touch, with the points and normal there; `None` if they do not.
pub fn time_of_impact(
    a: &Shape,
    pose_a: &Pose,
    motion_a: &Motion,
    b: &Shape,
    pose_b: &Pose,
    motion_b: &Motion,
    horizon: f32,
) -> Option<Toi> {
    let horizon = horizon as f64;
    if horizon.is_nan() || horizon < 0.0 {
        return None;
    }
    let (qa, xa) = (pose_a.rotation.as_dquat(), pose_a.position.as_dvec3());
    let (qb, xb) = (pose_b.rotation.as_dquat(), pose_b.position.as_dvec3());
    let (va, wa) = (motion_a.linear.as_dvec3(), motion_a.angular.as_dvec3());
    let (vb, wb) = (motion_b.linear.as_dvec3(), motion_b.angular.as_dvec3());
    if let (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) = (a, b) {
        return spheres(xa, va, *ra as f64, xb, vb, *rb as f64, horizon);
    }
    let core_radius = |s: &Shape| match s {
        Shape::Sphere { .. } => 0.0,
        Shape::Polyhedron(p) => p.radius as f64,
        Shape::Composite(c) => c.radius as f64,
    };
    let (ra, rb) = (core_radius(a), core_radius(b));
    let size = (a.bounding_radius() + b.bounding_radius()) as f64;
    let tol = TOI_REL_TOL * size;
    let mut t = 0.0f64;
    let mut last = None;
    for _ in 0..TOI_MAX_ITERATIONS {
        let pa = pose_at(qa, xa, va, wa, t);
        let pb = pose_at(qb, xb, vb, wb, t);
        let (raw, frame, swapped) = Pair::new(a, &pa, b, &pb).distance_raw();
        if raw.overlap {
            // Only at t = 0 in exact arithmetic; report the penetration there.
            let pa32 = Pose::new(
                pa.pos.as_vec3(),
                (DQuat::from_scaled_axis(wa * t) * qa).as_quat(),
            );
            let pb32 = Pose::new(
                pb.pos.as_vec3(),
                (DQuat::from_scaled_axis(wb * t) * qb).as_quat(),
            );
            let c = contact(a, &pa32, b, &pb32);
            return Some(Toi {
                time: t as f32,
                points: c.points,
                normal: c.normal,
                converged: true,
            });
        }
        let (points, normal) = to_world(&frame, swapped, &raw);
        if raw.sep <= tol {
            return Some(Toi {
                time: t as f32,
                points,
                normal,
                converged: true,
            });
        }
        let n = {
            let n = frame.vector(raw.normal);
            if swapped { -n } else { n }
        };
        let mu = (va - vb).dot(n) + n.cross(wa).length() * ra + n.cross(wb).length() * rb;
        if mu.is_nan() || mu <= 0.0 {
            return None;
        }
        t += (raw.sep - 0.5 * tol) / mu;
        if t > horizon {
            return None;
        }
        last = Some(Toi {
            time: t as f32,
            points,
            normal,
            converged: false,
        });
    }
    last
}

/// Closed-form first contact of two spheres in linear motion.
fn spheres(xa: DVec3, va: DVec3, ra: f64, xb: DVec3, vb: DVec3, rb: f64, h: f64) -> Option<Toi> {
    let p = xb - xa;
    let u = vb - va;
    let r = ra + rb;
    let c = p.length_squared() - r * r;
    let t = if c <= 0.0 {
        0.0
    } else {
        let b = p.dot(u);
        let a = u.length_squared();
        if b >= 0.0 || a == 0.0 {
            return None;
        }
        let disc = b * b - a * c;
        if disc < 0.0 {
            return None;
        }
        // Smaller root of a t² + 2 b t + c = 0, in the cancellation-free form.
        c / (-b + disc.sqrt())
    };
    if t > h {
        return None;
    }
    let ca = xa + va * t;
    let cb = xb + vb * t;
    let d = cb - ca;
    let len = d.length();
    let n = if len > 0.0 { d / len } else { DVec3::X };
    Some(Toi {
        time: t as f32,
        points: [(ca + n * ra).as_vec3(), (cb - n * rb).as_vec3()],
        normal: n.as_vec3(),
        converged: true,
    })
}
