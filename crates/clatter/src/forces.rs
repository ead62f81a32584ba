//! Stage 5, **forces**: the DEM contact law applied to one contact manifold.
//!
//! Normal: a spring-dashpot per manifold point, each point carrying `1/count` of the contact's
//! stiffness and damping, so a face resting on four points is as stiff as a vertex on one and
//! uneven overlap produces the restoring torque. The force is not clamped at zero: that is the
//! linear spring-dashpot whose restitution and duration have the closed forms used for the
//! damping (a clamp would change both).
//! Tangential: one Cundall-Strack spring per pair, at the centroid of the manifold, carried
//! across steps, rotated into the current tangent plane, capped by Coulomb (`mu * Fn`).

use glam::Vec3;

use crate::material::{PairParams, LINEAR_TANGENTIAL_RATIO, TANGENTIAL_DAMPING_RATIO};
use clatter_geom::narrow::Manifold;

/// Rigid motion of one side of a contact (a wall has zero velocities).
#[derive(Debug, Clone, Copy, Default)]
pub struct Side {
    /// Centre of mass.
    pub position: Vec3,
    /// Linear velocity.
    pub velocity: Vec3,
    /// Angular velocity (rad/s, world frame).
    pub omega: Vec3,
}

impl Side {
    #[inline]
    fn point_velocity(&self, p: Vec3) -> Vec3 {
        self.velocity + self.omega.cross(p - self.position)
    }
}

/// What one contact does: the force on `b` (the force on `a` is exactly its negative) and the
/// torques on both sides about their centres of mass.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactForce {
    /// Force on side b (N); side a gets `-force_b`.
    pub force_b: Vec3,
    /// Torque on side a (N m).
    pub torque_a: Vec3,
    /// Torque on side b (N m).
    pub torque_b: Vec3,
    /// Total normal force (N, positive when pushing apart).
    pub normal_force: f32,
}

/// Normal force of one manifold point carrying `1/count` of the contact, and its damping
/// coefficient (already divided by `count`). `vn` is the normal relative velocity (negative
/// when approaching).
#[inline(always)]
fn normal_law(p: &PairParams, m_eff: f32, r_eff: f32, eta_lin: f32, depth: f32, vn: f32, inv_count: f32) -> (f32, f32) {
    let (f, eta) = if p.hertz {
        let contact = (r_eff * depth).sqrt();
        let eta = p.damping_factor * (2.0 * p.stiffness * contact * m_eff).sqrt();
        (4.0 / 3.0 * p.stiffness * contact * depth - eta * vn, eta)
    } else {
        (p.stiffness * depth - eta_lin * vn, eta_lin)
    };
    (f * inv_count, eta * inv_count)
}

/// The Cundall-Strack spring at a point moving with tangential relative velocity from `vrel`:
/// rotates `history` into the tangent plane of `n`, stretches it, caps it by Coulomb, and
/// returns the tangential force on side b.
#[inline(always)]
fn tangential_law(
    p: &PairParams,
    r_eff: f32,
    n: Vec3,
    vrel: Vec3,
    mean_depth: f32,
    normal_force: f32,
    eta_n: f32,
    history: &mut Vec3,
    dt: f32,
) -> Vec3 {
    let vt = vrel - n * vrel.dot(n);
    let mut xi = *history;
    let along = xi.dot(n);
    if along != 0.0 {
        // Rotate the spring into the current tangent plane, keeping its length.
        let old_len2 = xi.length_squared();
        xi -= n * along;
        let new_len2 = xi.length_squared();
        if new_len2 > 0.0 {
            xi *= (old_len2 / new_len2).sqrt();
        }
    }
    xi += vt * dt;
    let kt = if p.hertz {
        8.0 * p.shear * (r_eff * mean_depth).sqrt()
    } else {
        LINEAR_TANGENTIAL_RATIO * p.stiffness
    };
    let mut ft = -kt * xi - (TANGENTIAL_DAMPING_RATIO * eta_n) * vt;
    let cap = p.friction * normal_force.max(0.0);
    let ft_len2 = ft.length_squared();
    if ft_len2 > cap * cap {
        ft *= cap / ft_len2.sqrt();
        // Keep the spring at the length that the capped force corresponds to.
        xi = if kt > 0.0 { -ft / kt } else { Vec3::ZERO };
    }
    *history = xi;
    ft
}

/// The contact force of a one-point contact (spheres, vertex and edge contacts): normal and
/// tangential forces act at `point`, overlap `depth` along the unit normal `n` (from a to b).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn point_contact_force(
    p: &PairParams,
    m_eff: f32,
    r_eff: f32,
    n: Vec3,
    point: Vec3,
    depth: f32,
    a: &Side,
    b: &Side,
    history: &mut Vec3,
    dt: f32,
) -> ContactForce {
    let eta_lin = if p.hertz { 0.0 } else { p.damping_factor * (m_eff * p.stiffness).sqrt() };
    let vrel = b.point_velocity(point) - a.point_velocity(point);
    let (fn_, eta) = normal_law(p, m_eff, r_eff, eta_lin, depth, vrel.dot(n), 1.0);
    let ft = tangential_law(p, r_eff, n, vrel, depth, fn_, eta, history, dt);
    let f = n * fn_ + ft;
    ContactForce {
        force_b: f,
        torque_a: f.cross(point - a.position),
        torque_b: (point - b.position).cross(f),
        normal_force: fn_,
    }
}

/// Computes the contact force of `manifold` between `a` and `b` and updates the tangential
/// spring `history` (zero for a new contact). `m_eff` and `r_eff` are the effective mass and
/// radius of the pair.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn contact_force(
    p: &PairParams,
    m_eff: f32,
    r_eff: f32,
    manifold: &Manifold,
    a: &Side,
    b: &Side,
    history: &mut Vec3,
    dt: f32,
) -> ContactForce {
    let n = manifold.normal;
    let eta_lin = if p.hertz { 0.0 } else { p.damping_factor * (m_eff * p.stiffness).sqrt() };
    if manifold.count == 1 {
        let cp = manifold.points[0];
        return point_contact_force(p, m_eff, r_eff, n, cp.point, cp.depth, a, b, history, dt);
    }
    let inv_count = 1.0 / manifold.count as f32;
    let mut out = ContactForce::default();
    let mut centroid = Vec3::ZERO;
    let mut mean_depth = 0.0;
    let mut eta_n = 0.0;
    for cp in manifold.points() {
        let vrel = b.point_velocity(cp.point) - a.point_velocity(cp.point);
        let (fn_i, eta) = normal_law(p, m_eff, r_eff, eta_lin, cp.depth, vrel.dot(n), inv_count);
        eta_n += eta;
        let f = n * fn_i;
        out.force_b += f;
        out.torque_b += (cp.point - b.position).cross(f);
        out.torque_a += f.cross(cp.point - a.position);
        out.normal_force += fn_i;
        centroid += cp.point;
        mean_depth += cp.depth;
    }
    // One tangential spring for the whole patch, at its centroid.
    centroid *= inv_count;
    mean_depth *= inv_count;
    let vrel = b.point_velocity(centroid) - a.point_velocity(centroid);
    let ft = tangential_law(p, r_eff, n, vrel, mean_depth, out.normal_force, eta_n, history, dt);
    out.force_b += ft;
    out.torque_b += (centroid - b.position).cross(ft);
    out.torque_a += ft.cross(centroid - a.position);
    out
}
