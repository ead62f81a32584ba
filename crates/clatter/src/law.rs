//! The DEM contact law, applied to one contact manifold. Its GPU twin is
//! `clatter-gpu/shaders/law.wgsl`: the same functions under the same names, checked against
//! each other on random contacts by `clatter-gpu/tests/law.rs`. Its parameters are one
//! [`PairParams`] row per material pair (`contract.rs`).
//!
//! - **Normal**: a spring-dashpot per manifold point. Contacts with a sphere (one point) use
//!   the material's law as is; polyhedron contacts give each of up to four points a fixed
//!   quarter ([`POLYHEDRON_POINT_SHARE`]), so stiffness grows with contact area and, the
//!   share never depending on the current point count, the spring has a potential
//!   ([`elastic_energy`]). Damping is shared in proportion to stiffness, its total set by
//!   the restitution. The force is not clamped at zero (the closed forms of restitution and
//!   duration assume the unclamped law).
//! - **Tangential**: one Cundall-Strack spring per pair at the manifold's centroid, carried
//!   across steps, rotated into the current tangent plane, capped by Coulomb (`mu Fn`).
//! - **Twisting**: patches of two or more points resist spin about the normal with the
//!   tangential law times the patch radius squared, capped at `mu Fn r_patch`.
//! - **Rolling resistance** ([`rolling_torque`]): a constant directional torque
//!   `mu_r R* Fn` against the relative rolling velocity.
//! - **Spinning resistance** ([`spinning_torque`]): `mu_s R* Fn` against relative spin about
//!   the normal.
//! - **Cohesion** ([`adhesion`]): DMT, a constant pull `2 pi gamma R*` while touching.
//!   Friction and rolling resistance are capped by the spring-dashpot force alone.

use glam::Vec3;

use crate::contract::{
    COHESION_DMT, COHESION_NONE, LINEAR_TANGENTIAL_RATIO, MODEL_HERTZ, POLYHEDRON_POINT_SHARE,
    TANGENTIAL_DAMPING_RATIO,
};
pub use crate::contract::{ContactForce, PairParams};
use clatter_geom::narrow::Manifold;

/// Rigid motion of one side of a contact (a wall has zero velocities).
#[derive(Debug, Clone, Copy, Default)]
pub struct BodyMotion {
    /// Centre of mass.
    pub position: Vec3,
    /// Linear velocity.
    pub velocity: Vec3,
    /// Angular velocity (rad/s, world frame).
    pub omega: Vec3,
}

impl BodyMotion {
    #[inline]
    fn point_velocity(&self, p: Vec3) -> Vec3 {
        self.velocity + self.omega.cross(p - self.position)
    }
}

/// Spring force and stiffness of one point at overlap `depth` carrying `share` of the law
/// (linear: `share k d`; Hertz: `share 4/3 E* sqrt(r_eff d) d`).
#[inline(always)]
pub fn spring(p: &PairParams, r_eff: f32, depth: f32, share: f32) -> (f32, f32) {
    if p.model == MODEL_HERTZ {
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
    if p.model == MODEL_HERTZ {
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
    a: &BodyMotion,
    b: &BodyMotion,
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
    let mut out = ContactForce::new(
        f,
        f.cross(point - a.position),
        (point - b.position).cross(f),
        fn_,
    );
    adhesion_and_rolling(p, m_eff, r_eff, n, point, a, b, fn_, dt, &mut out);
    out
}

/// The adhesive pull of a touching pair (DMT: `2 pi gamma R*`, N), 0 without cohesion.
#[inline(always)]
pub fn adhesion(p: &PairParams, r_eff: f32) -> f32 {
    if p.cohesion_model == COHESION_DMT {
        2.0 * std::f32::consts::PI * p.surface_energy * r_eff
    } else {
        0.0
    }
}

/// Rolling resistance, the torque on side b (side a gets its negative): the constant
/// directional torque `-mu_r R* Fn w_r / |w_r|` against the relative rolling velocity `w_r`
/// (the relative angular velocity less its part about the normal). Below the angular speed
/// one step of the full torque would take away from a body of inertia `2/5 m* R*^2`, the
/// torque shrinks in proportion, so a rolling body comes to rest instead of rocking.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn rolling_torque(
    p: &PairParams,
    m_eff: f32,
    r_eff: f32,
    n: Vec3,
    a: &BodyMotion,
    b: &BodyMotion,
    normal_force: f32,
    dt: f32,
) -> Vec3 {
    let w = b.omega - a.omega;
    let w_roll = w - n * w.dot(n);
    let limit = p.rolling_friction * r_eff * normal_force.max(0.0);
    match resisting_scale(limit, w_roll.length(), m_eff, r_eff, dt) {
        Some(scale) => -w_roll * scale,
        None => Vec3::ZERO,
    }
}

/// Torque per unit of relative angular velocity of a resisting torque of magnitude `limit`
/// at angular speed `speed`: `limit / speed`, or less near rest, where one step of the full
/// torque would take more than `speed` away from a body of inertia `2/5 m* R*^2`. `None`
/// when there is nothing to resist.
#[inline(always)]
fn resisting_scale(limit: f32, speed: f32, m_eff: f32, r_eff: f32, dt: f32) -> Option<f32> {
    let step_change = limit * dt / (0.4 * m_eff * r_eff * r_eff);
    (limit > 0.0 && speed > 0.0).then(|| limit / speed.max(step_change))
}

/// Spinning resistance, the torque on side b (side a gets its negative): the constant torque
/// `-mu_s R* Fn sign(w_n) n` against the relative spin `w_n` about the normal, shrinking in
/// proportion near rest as [`rolling_torque`] does.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn spinning_torque(
    p: &PairParams,
    m_eff: f32,
    r_eff: f32,
    n: Vec3,
    a: &BodyMotion,
    b: &BodyMotion,
    normal_force: f32,
    dt: f32,
) -> Vec3 {
    let w_n = (b.omega - a.omega).dot(n);
    let limit = p.spinning_friction * r_eff * normal_force.max(0.0);
    match resisting_scale(limit, w_n.abs(), m_eff, r_eff, dt) {
        Some(scale) => n * (-w_n * scale),
        None => Vec3::ZERO,
    }
}

/// Adds adhesion (acting at `at`, along the normal) and rolling resistance to a contact's
/// force; `normal_force` is the contact's spring-dashpot normal force (without adhesion).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn adhesion_and_rolling(
    p: &PairParams,
    m_eff: f32,
    r_eff: f32,
    n: Vec3,
    at: Vec3,
    a: &BodyMotion,
    b: &BodyMotion,
    normal_force: f32,
    dt: f32,
    out: &mut ContactForce,
) {
    if p.cohesion_model != COHESION_NONE {
        let pull = adhesion(p, r_eff);
        let f = n * -pull;
        out.force_b += f;
        out.normal_force -= pull;
        out.torque_b += (at - b.position).cross(f);
        out.torque_a += f.cross(at - a.position);
    }
    if p.rolling_friction > 0.0 {
        let tau = rolling_torque(p, m_eff, r_eff, n, a, b, normal_force, dt);
        out.torque_b += tau;
        out.torque_a -= tau;
    }
    if p.spinning_friction > 0.0 {
        let tau = spinning_torque(p, m_eff, r_eff, n, a, b, normal_force, dt);
        out.torque_b += tau;
        out.torque_a -= tau;
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
    a: &BodyMotion,
    b: &BodyMotion,
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
    let normal_force = out.normal_force;
    adhesion_and_rolling(
        p,
        m_eff,
        r_eff,
        n,
        centroid,
        a,
        b,
        normal_force,
        dt,
        &mut out,
    );
    out
}

/// The overlap at which one point carrying `share` of the law has spring force `force`:
/// the inverse of [`spring`] (the largest overlap a contact with that total normal force can
/// have, when all of it sits on one point).
pub fn depth_at_force(p: &PairParams, r_eff: f32, force: f32, share: f32) -> f32 {
    let (f1, _) = spring(p, r_eff, 1.0, share);
    if p.model == MODEL_HERTZ {
        // spring(d) = spring(1) d^1.5 (r_eff d)^0.5 / r_eff^0.5 = f1 d^1.5.
        (force.abs() / f1).powf(2.0 / 3.0)
    } else {
        force.abs() / f1
    }
}

/// The elastic energy of one point carrying `share` of the law at overlap `depth`: the
/// integral of [`spring`] from 0 to `depth` (linear: `f d / 2`; Hertz: `2/5 f d`), J.
pub fn elastic_energy(p: &PairParams, r_eff: f32, depth: f32, share: f32) -> f64 {
    let d = depth.max(0.0);
    let (f, _) = spring(p, r_eff, d, share);
    let exponent = if p.model == MODEL_HERTZ { 2.5 } else { 2.0 };
    f as f64 * d as f64 / exponent
}

/// The share of the law each manifold point carries: 1 in contacts with a sphere (always one
/// point), [`POLYHEDRON_POINT_SHARE`] between polyhedra and walls.
#[inline]
pub fn point_share(a_is_sphere: bool, b_is_sphere: bool) -> f32 {
    if a_is_sphere || b_is_sphere {
        crate::contract::SPHERE_POINT_SHARE
    } else {
        POLYHEDRON_POINT_SHARE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{ContactLaw, Material};

    fn params(law: ContactLaw) -> PairParams {
        let m = Material {
            name: "m".into(),
            density: 1000.0,
            law,
            restitution: 0.5,
            friction: 0.3,
            rolling_friction: 0.0,
            spinning_friction: 0.0,
            cohesion: None,
        };
        PairParams::combine(&m, &m)
    }

    #[test]
    fn energy_and_depth_follow_the_spring() {
        for law in [
            ContactLaw::Linear { stiffness: 2.0e4 },
            ContactLaw::Hertz {
                youngs_modulus: 1.0e7,
                poisson_ratio: 0.3,
            },
        ] {
            let p = params(law);
            let (r, share, depth) = (0.01f32, POLYHEDRON_POINT_SHARE, 1.0e-4f32);
            // The energy is the integral of the force (midpoint rule, 10,000 slices).
            let slices = 10_000;
            let h = depth as f64 / slices as f64;
            let integral: f64 = (0..slices)
                .map(|k| spring(&p, r, ((k as f64 + 0.5) * h) as f32, share).0 as f64 * h)
                .sum();
            let e = elastic_energy(&p, r, depth, share);
            assert!(
                (e - integral).abs() < 1e-5 * integral,
                "{law:?}: {e} vs {integral}"
            );
            // The depth at the spring's force is the depth.
            let (f, _) = spring(&p, r, depth, share);
            let d = depth_at_force(&p, r, f, share);
            assert!((d - depth).abs() < 1e-5 * depth, "{law:?}: {d} vs {depth}");
        }
    }
}
