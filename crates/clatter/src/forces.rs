//! Stage 5, **forces**: the DEM contact law applied to one contact manifold.
//!
//! Normal: a spring per manifold point. Contacts that always have one point (anything with a
//! sphere) use the material's law as it is; polyhedron-polyhedron and polyhedron-wall
//! contacts give each of their up to four points a fixed quarter of it, so a full face
//! contact has the material's stiffness, an edge half and a vertex a quarter (contact
//! stiffness grows with contact area, as in real solids). The share per point never depends
//! on how many points there are right now, so the normal force derives from a potential and
//! an elastic (e = 1, no friction) polyhedron keeps its energy. Damping is spread over the
//! points in proportion to their stiffness, with the total set from the restitution for the
//! contact's current total stiffness. The force is not clamped at zero: that is the linear
//! spring-dashpot whose restitution and duration have the closed forms used for the damping
//! (a clamp would change both).
//! Tangential: one Cundall-Strack spring per pair, at the centroid of the manifold, carried
//! across steps, rotated into the current tangent plane, capped by Coulomb (`mu * Fn`).
//! Twisting: for patches of two or more points, a torsional spring-dashpot about the normal
//! (stiffness and damping of the tangential law times the patch radius squared), capped at
//! `mu * Fn * r_patch`, so a body spinning on a face comes to rest.

use glam::Vec3;

use crate::material::{LINEAR_TANGENTIAL_RATIO, PairParams, TANGENTIAL_DAMPING_RATIO};
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

/// Spring force and stiffness of one point at overlap `depth` carrying `share` of the law.
#[inline(always)]
fn spring(p: &PairParams, r_eff: f32, depth: f32, share: f32) -> (f32, f32) {
    if p.hertz {
        let contact = (r_eff * depth.max(0.0)).sqrt();
        (
            share * 4.0 / 3.0 * p.stiffness * contact * depth,
            share * 2.0 * p.stiffness * contact,
        )
    } else {
        (share * p.stiffness * depth, share * p.stiffness)
    }
}

/// Total normal damping coefficient for total normal stiffness `k` (linear: the closed form
/// from the restitution; Hertz: Tsuji's form with the current contact stiffness).
#[inline(always)]
fn damping(p: &PairParams, m_eff: f32, k: f32) -> f32 {
    p.damping_factor * (m_eff * k.max(0.0)).sqrt()
}

/// Tangential stiffness of the pair's spring.
#[inline(always)]
fn tangential_stiffness(p: &PairParams, r_eff: f32, depth: f32, share_total: f32) -> f32 {
    if p.hertz {
        share_total * 8.0 * p.shear * (r_eff * depth.max(0.0)).sqrt()
    } else {
        LINEAR_TANGENTIAL_RATIO * p.stiffness
    }
}

/// The Cundall-Strack spring at a point moving with tangential relative velocity from `vrel`:
/// rotates `history` into the tangent plane of `n`, stretches it, caps it by Coulomb, and
/// returns the tangential force on side b.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn tangential_law(
    p: &PairParams,
    kt: f32,
    n: Vec3,
    vrel: Vec3,
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
    share: f32,
    n: Vec3,
    point: Vec3,
    depth: f32,
    a: &Side,
    b: &Side,
    history: &mut Vec3,
    dt: f32,
) -> ContactForce {
    let vrel = b.point_velocity(point) - a.point_velocity(point);
    let (fs, k) = spring(p, r_eff, depth, share);
    let eta = damping(p, m_eff, k);
    let fn_ = fs - eta * vrel.dot(n);
    let kt = tangential_stiffness(p, r_eff, depth, share);
    let ft = tangential_law(p, kt, n, vrel, fn_, eta, history, dt);
    let f = n * fn_ + ft;
    ContactForce {
        force_b: f,
        torque_a: f.cross(point - a.position),
        torque_b: (point - b.position).cross(f),
        normal_force: fn_,
    }
}

/// Computes the contact force of `manifold` between `a` and `b` and updates the tangential
/// spring `history` and the twisting spring `twist` (zero for a new contact). `m_eff` and
/// `r_eff` are the effective mass and radius of the pair; `share` is the fraction of the
/// material's law each point carries (1 for contacts involving a sphere, 1/4 otherwise).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn contact_force(
    p: &PairParams,
    m_eff: f32,
    r_eff: f32,
    share: f32,
    manifold: &Manifold,
    a: &Side,
    b: &Side,
    history: &mut Vec3,
    twist: &mut f32,
    dt: f32,
) -> ContactForce {
    let n = manifold.normal;
    if manifold.count == 1 {
        *twist = 0.0;
        let cp = manifold.points[0];
        return point_contact_force(
            p, m_eff, r_eff, share, n, cp.point, cp.depth, a, b, history, dt,
        );
    }
    let pts = manifold.points();
    let inv_count = 1.0 / pts.len() as f32;
    // Springs and total stiffness first: damping is shared in proportion to stiffness.
    let mut springs = [(0.0f32, 0.0f32); 4];
    let mut k_total = 0.0;
    let mut centroid = Vec3::ZERO;
    let mut mean_depth = 0.0;
    for (s, cp) in springs.iter_mut().zip(pts) {
        *s = spring(p, r_eff, cp.depth, share);
        k_total += s.1;
        centroid += cp.point;
        mean_depth += cp.depth;
    }
    centroid *= inv_count;
    mean_depth *= inv_count;
    let eta_total = damping(p, m_eff, k_total);
    let mut out = ContactForce::default();
    for (&(fs, k), cp) in springs.iter().zip(pts) {
        let vrel = b.point_velocity(cp.point) - a.point_velocity(cp.point);
        let eta = if k_total > 0.0 {
            eta_total * k / k_total
        } else {
            0.0
        };
        let fn_i = fs - eta * vrel.dot(n);
        let f = n * fn_i;
        out.force_b += f;
        out.torque_b += (cp.point - b.position).cross(f);
        out.torque_a += f.cross(cp.point - a.position);
        out.normal_force += fn_i;
    }
    // One tangential spring for the whole patch, at its centroid.
    let share_total = share * pts.len() as f32;
    let kt = tangential_stiffness(p, r_eff, mean_depth, share_total);
    let vrel = b.point_velocity(centroid) - a.point_velocity(centroid);
    let ft = tangential_law(p, kt, n, vrel, out.normal_force, eta_total, history, dt);
    out.force_b += ft;
    out.torque_b += (centroid - b.position).cross(ft);
    out.torque_a += ft.cross(centroid - a.position);
    // Twisting about the normal, resisted over the patch radius.
    let r_patch = pts
        .iter()
        .map(|cp| (cp.point - centroid).reject_from_normalized(n).length())
        .sum::<f32>()
        * inv_count;
    if r_patch > 0.0 {
        let w_n = (b.omega - a.omega).dot(n);
        let r2 = r_patch * r_patch;
        let k_tw = kt * r2;
        let eta_tw = TANGENTIAL_DAMPING_RATIO * eta_total * r2;
        *twist += w_n * dt;
        let mut tau = -k_tw * *twist - eta_tw * w_n;
        let cap = p.friction * out.normal_force.max(0.0) * r_patch;
        if tau.abs() > cap {
            tau = cap.copysign(tau);
            *twist = if k_tw > 0.0 { -tau / k_tw } else { 0.0 };
        }
        out.torque_b += n * tau;
        out.torque_a -= n * tau;
    } else {
        *twist = 0.0;
    }
    out
}
