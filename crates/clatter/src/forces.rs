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

/// Computes the contact force of `manifold` between `a` and `b` and updates the tangential
/// spring `history` (zero for a new contact). `m_eff` and `r_eff` are the effective mass and
/// radius of the pair.
#[inline]
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
    let count = manifold.count as f32;
    let inv_count = 1.0 / count;
    let mut out = ContactForce::default();
    let mut centroid = Vec3::ZERO;
    let mut mean_depth = 0.0;
    let (kn_lin, eta_lin) = if p.hertz {
        (0.0, 0.0)
    } else {
        (p.stiffness, p.damping_factor * (m_eff * p.stiffness).sqrt())
    };
    let mut eta_n_total = 0.0;
    for cp in manifold.points() {
        let vrel = b.point_velocity(cp.point) - a.point_velocity(cp.point);
        let vn = vrel.dot(n);
        let (fn_i, eta) = if p.hertz {
            let contact = (r_eff * cp.depth).sqrt();
            let sn = 2.0 * p.stiffness * contact;
            let eta = p.damping_factor * (sn * m_eff).sqrt();
            (4.0 / 3.0 * p.stiffness * contact * cp.depth - eta * vn, eta)
        } else {
            (kn_lin * cp.depth - eta_lin * vn, eta_lin)
        };
        let fn_i = fn_i * inv_count;
        eta_n_total += eta * inv_count;
        let f = n * fn_i;
        out.force_b += f;
        out.torque_b += (cp.point - b.position).cross(f);
        out.torque_a -= (cp.point - a.position).cross(f);
        out.normal_force += fn_i;
        centroid += cp.point;
        mean_depth += cp.depth;
    }
    centroid *= inv_count;
    mean_depth *= inv_count;

    // Tangential spring at the centroid.
    let vrel = b.point_velocity(centroid) - a.point_velocity(centroid);
    let vt = vrel - n * vrel.dot(n);
    let old_len2 = history.length_squared();
    let mut xi = *history - n * history.dot(n);
    let new_len2 = xi.length_squared();
    if new_len2 > 0.0 && old_len2 > new_len2 {
        xi *= (old_len2 / new_len2).sqrt();
    }
    xi += vt * dt;
    let kt = if p.hertz {
        8.0 * p.shear * (r_eff * mean_depth).sqrt()
    } else {
        LINEAR_TANGENTIAL_RATIO * kn_lin
    };
    let eta_t = TANGENTIAL_DAMPING_RATIO * eta_n_total;
    let mut ft = -kt * xi - eta_t * vt;
    let cap = p.friction * out.normal_force.max(0.0);
    let ft_len2 = ft.length_squared();
    if ft_len2 > cap * cap {
        ft *= cap / ft_len2.sqrt();
        // Keep the spring at the length that the capped force corresponds to.
        xi = if kt > 0.0 { -ft / kt } else { Vec3::ZERO };
    }
    *history = xi;
    out.force_b += ft;
    out.torque_b += (centroid - b.position).cross(ft);
    out.torque_a -= (centroid - a.position).cross(ft);
    out
}
