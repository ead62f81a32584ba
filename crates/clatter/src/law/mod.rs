//! The DEM contact law, applied to one contact manifold. Its GPU twin is
//! `clatter-gpu/shaders/contacts/law.wgsl`: the same functions under the same names, checked against
//! each other on random contacts by `clatter-gpu/tests/law.rs`. Its parameters are one
//! [`PairParams`] row per material pair (`contract.rs`).
//!
//! - **Normal**: a spring-dashpot per manifold point. Contacts with a sphere (one point) use
//!   the material's law as is; polyhedron contacts give each of up to four points a fixed
//!   quarter ([`POLYHEDRON_POINT_SHARE`]), so stiffness grows with contact area and, the
//!   share never depending on the current point count, the spring has a potential
//!   ([`elastic_energy`]). Damping is shared in proportion to stiffness, its total set by
//!   the restitution. The force is not clamped at zero (the closed forms of restitution and
//!   duration assume the unclamped law). Contacts with a sphere resolve the normal force
//!   within the step ([`resolved_normal_force`]: the law's impulse over the step, with the
//!   contact's onset and release located inside it), so the requested restitution holds at
//!   the default step; polyhedron contacts apply the law at the step's start.
//! - **Tangential**: one Cundall-Strack spring per pair at the manifold's centroid, carried
//!   across steps, rotated into the current tangent plane, capped by Coulomb (`mu Fn`).
//!   Linear: stiffness `2/7 k`, damping half the normal's. Hertz: Mindlin's
//!   `k_t = 8 G* sqrt(R* d)` with the Hertz-Mindlin damping `2 sqrt(5/6) beta sqrt(m* k_t)`
//!   (LIGGGHTS' `hertz` with `tangential history`).
//! - **Twisting**: patches of two or more points resist spin about the normal with the
//!   tangential law times the patch radius squared, capped at `mu Fn r_patch`.
//! - **Rolling resistance** ([`rolling_torque`]): a constant directional torque
//!   `mu_r R* Fn` against the relative rolling velocity.
//! - **Spinning resistance** ([`spinning_torque`]): `mu_s R* Fn` against relative spin about
//!   the normal.
//! - **Cohesion** ([`adhesion`]): DMT, a constant pull `2 pi gamma R*` while touching.
//!   Friction and rolling resistance are capped by the spring-dashpot force alone.

use glam::{Vec3, Vec3A};

use crate::contract::{
    COHESION_DMT, COHESION_NONE, LINEAR_TANGENTIAL_RATIO, MODEL_HERTZ, POLYHEDRON_POINT_SHARE,
    SPHERE_POINT_SHARE, TANGENTIAL_DAMPING_RATIO,
};
pub use crate::contract::{ContactForce, PairContext, PairParams};
use clatter_geom::narrow::{ContactPoint, Manifold};

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

/// A [`BodyMotion`] in 16-byte vectors, for the law's inner arithmetic.
///
/// Why: glam's `Vec3A` does each of `Vec3`'s IEEE operations lane by lane (a dot product
/// as `(x x' + y y') + z z'`, a cross product's lanes as `Vec3::cross`'s products and
/// differences), so the law computes the same bits in fewer instructions than with `Vec3`,
/// which the compiler spread over scalar and paired lanes with shuffles and spills between.
#[derive(Clone, Copy)]
struct MotionA {
    position: Vec3A,
    velocity: Vec3A,
    omega: Vec3A,
}

impl MotionA {
    #[inline(always)]
    fn of(m: &BodyMotion) -> Self {
        MotionA {
            position: m.position.into(),
            velocity: m.velocity.into(),
            omega: m.omega.into(),
        }
    }

    /// The velocity of the body's point at `p`: `v + w x (p - x)`.
    #[inline(always)]
    fn point_velocity(&self, p: Vec3A) -> Vec3A {
        self.velocity + self.omega.cross(p - self.position)
    }
}

/// Spring force and stiffness of one point at overlap `depth` carrying `share` of the law
/// (linear: `share k d`; Hertz: `share 4/3 E* sqrt(r_eff d) d`).
#[inline(always)]
pub fn spring(p: &PairParams, r_eff: f32, depth: f32, share: f32) -> (f32, f32) {
    spring_in::<false>(p, r_eff, depth, share)
}

/// Whether pair parameters `p` use the Hertz law; false without a look when the caller
/// knows its pairs are `PLAIN` ([`is_plain`]).
#[inline(always)]
fn hertz<const PLAIN: bool>(p: &PairParams) -> bool {
    !PLAIN && p.model == MODEL_HERTZ
}

/// Whether pair parameters `p` are the plain law: linear, without cohesion, rolling or
/// spinning resistance. A stage whose pairs are all plain may call the `PLAIN = true` forms
/// of the law ([`point_contact_force_in`]), which leave out the tests for the rest: the same
/// operations on the same values, so the same bits as the general forms.
#[inline]
// Not `<= 0.0`: the law's tests are `> 0.0`, which a NaN fails too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn is_plain(p: &PairParams) -> bool {
    p.model != MODEL_HERTZ
        && p.cohesion_model == COHESION_NONE
        && !(p.rolling_friction > 0.0)
        && !(p.spinning_friction > 0.0)
}

/// [`spring`], knowing the law is linear when `PLAIN`.
#[inline(always)]
fn spring_in<const PLAIN: bool>(p: &PairParams, r_eff: f32, depth: f32, share: f32) -> (f32, f32) {
    if hertz::<PLAIN>(p) {
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

/// Tangential damping coefficient for tangential stiffness `kt`: Hertz-Mindlin (as
/// LIGGGHTS' `hertz` with `tangential history`) `2 sqrt(5/6) beta sqrt(m* S_t)` with
/// `S_t = kt = 8 G* sqrt(R* d)`, the normal law's damping form applied to the tangential
/// stiffness; linear: [`TANGENTIAL_DAMPING_RATIO`] times the normal damping `eta_n`.
#[inline(always)]
fn tangential_damping<const PLAIN: bool>(c: &PairContext, kt: f32, eta_n: f32) -> f32 {
    if hertz::<PLAIN>(&c.params) {
        damping(&c.params, c.m_eff, kt)
    } else {
        TANGENTIAL_DAMPING_RATIO * eta_n
    }
}

/// Tangential stiffness of the pair's spring.
#[inline(always)]
fn tangential_stiffness<const PLAIN: bool>(c: &PairContext, depth: f32, share_total: f32) -> f32 {
    let p = &c.params;
    if hertz::<PLAIN>(p) {
        share_total * 8.0 * p.shear * (c.r_eff * depth.max(0.0)).sqrt()
    } else {
        LINEAR_TANGENTIAL_RATIO * p.stiffness
    }
}

/// The Cundall-Strack spring at a point moving with tangential relative velocity from `vrel`:
/// rotates `history` into the tangent plane of `n`, stretches it, caps it by Coulomb, and
/// returns the tangential force on side b.
#[inline(always)]
fn tangential_law(
    c: &PairContext,
    kt: f32,
    n: Vec3A,
    vrel: Vec3A,
    normal_force: f32,
    eta_t: f32,
    history: &mut Vec3,
) -> Vec3A {
    let vt = vrel - n * vrel.dot(n);
    let mut xi = Vec3A::from(*history);
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
    xi += vt * c.dt;
    let cap = c.params.friction * normal_force.max(0.0);
    // The spring slips: it holds at most the Coulomb force. Then the force, spring and
    // dashpot, is capped by Coulomb too. Both are radial projections, so the spring and the
    // force are continuous where a contact passes between sticking and sliding: a contact
    // within rounding of its cap ends the step with the same spring either way (two
    // executors that round differently do not part there). A spring reset to `-ft / kt`
    // after capping the sum jumped by `eta_t vt / kt` at the threshold; one reset to
    // `-(ft + eta_t vt) / kt` (LAMMPS' gran/hooke/history) is continuous but keeps the
    // dashpot's share in the spring while sliding, which moved the Chung & Ooi micro-slip
    // results 5% from their own converged integration at clatter's time step.
    // WGSL twin: law.wgsl `tangential_law`; f64 twin: clatter-cli validate/reference.rs.
    let spring2 = kt * kt * xi.length_squared();
    if spring2 > cap * cap {
        xi *= cap / spring2.sqrt();
    }
    let mut ft = -kt * xi - eta_t * vt;
    let ft_len2 = ft.length_squared();
    if ft_len2 > cap * cap {
        ft *= cap / ft_len2.sqrt();
    }
    *history = xi.into();
    ft
}

/// The contact force of a one-point contact (spheres, vertex and edge contacts): normal and
/// tangential forces act at `cp.point`, overlap `cp.depth` along the unit normal `n` (from a
/// to b).
/// `coverage` is the contact's normal state across steps: for contacts with a sphere
/// (`share` = [`SPHERE_POINT_SHARE`]) the normal force is resolved within the step
/// ([`resolved_normal_force`]) and `coverage` carries the dashpot's primitive at the overlap
/// up to which it has been applied; polyhedron contacts use the explicit law and get 0.
#[inline(always)]
pub fn point_contact_force(
    c: &PairContext,
    n: Vec3,
    cp: ContactPoint,
    a: &BodyMotion,
    b: &BodyMotion,
    history: &mut Vec3,
    coverage: &mut f32,
) -> ContactForce {
    point_contact_force_in::<false>(c, n, cp, a, b, history, coverage)
}

/// [`point_contact_force`] for a caller that knows whether the pair's law is plain
/// ([`is_plain`]): with `PLAIN = true` the tests for the Hertz law, cohesion, rolling and
/// spinning resistance are left out (the same bits as [`point_contact_force`] for plain
/// parameters; other parameters must use `PLAIN = false`).
#[inline(always)]
pub fn point_contact_force_in<const PLAIN: bool>(
    c: &PairContext,
    n: Vec3,
    cp: ContactPoint,
    a: &BodyMotion,
    b: &BodyMotion,
    history: &mut Vec3,
    coverage: &mut f32,
) -> ContactForce {
    point_force_known::<PLAIN>(c, None, n, cp, a, b, history, coverage)
}

/// [`point_contact_force_in`], with the linear law's constants of context `c` taken from
/// `known` when given ([`LinearLaw::of`]`(c)`, the same values: the same bits).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn point_force_known<const PLAIN: bool>(
    c: &PairContext,
    known: Option<&LinearLaw>,
    n: Vec3,
    cp: ContactPoint,
    a: &BodyMotion,
    b: &BodyMotion,
    history: &mut Vec3,
    coverage: &mut f32,
) -> ContactForce {
    debug_assert!(!PLAIN || is_plain(&c.params));
    debug_assert!(known.is_none() || !hertz::<false>(&c.params));
    let (p, depth) = (&c.params, cp.depth);
    let (point, n_a) = (Vec3A::from(cp.point), Vec3A::from(n));
    let (ma, mb) = (MotionA::of(a), MotionA::of(b));
    let vrel = mb.point_velocity(point) - ma.point_velocity(point);
    let (fs, k, eta) = match known {
        // `spring_in`'s linear form: `share * stiffness * depth`, the product taken first.
        Some(l) => (l.k * depth, l.k, l.eta_point),
        None => {
            let (fs, k) = spring_in::<PLAIN>(p, c.r_eff, depth, c.share);
            (fs, k, damping(p, c.m_eff, k))
        }
    };
    let fn_ = if c.share == SPHERE_POINT_SHARE {
        resolved_normal_force_in::<PLAIN>(c, depth, -vrel.dot(n_a), (fs, k, eta), coverage)
    } else {
        *coverage = 0.0;
        fs - eta * vrel.dot(n_a)
    };
    let (kt, eta_t) = match known {
        Some(l) => (l.kt, l.eta_t_point),
        None => {
            let kt = tangential_stiffness::<PLAIN>(c, depth, c.share);
            (kt, tangential_damping::<PLAIN>(c, kt, eta))
        }
    };
    let ft = tangential_law(c, kt, n_a, vrel, fn_, eta_t, history);
    let f = n_a * fn_ + ft;
    let mut out = ContactForce::new(
        f.into(),
        f.cross(point - ma.position).into(),
        (point - mb.position).cross(f).into(),
        fn_,
    );
    adhesion_and_rolling::<PLAIN>(c, n, cp.point, (a, b), fn_, &mut out);
    out
}

/// The `coverage` a contact stores once its dashpot has been applied up to the end of the
/// contact (it is predicted to separate within the step).
const COVERED_TO_RELEASE: f32 = -1.0;

/// The largest `(w dt)^2 + 2 zeta w dt` (`w^2 = k / m*`, `2 zeta w = eta / m*`) for which a
/// contact is resolved within the step; the default step gives about 0.13 at e = 0.05.
pub(crate) const RESOLVABLE: f32 = 1.0;

/// The fraction of a step's travel within which an overlap counts as zero when deciding
/// whether a step is a contact's last (positions round to a few ulps; a contact called
/// ended a sliver early only adds a sliver of spring force in the next step, one that ends
/// unnoticed loses the rest of the step's damping).
pub(crate) const EDGE_SLACK: f32 = 0.05;

/// The normal force of a one-point contact resolved within the step, for a requested
/// restitution met at the default step (`t_c / 50`) to about 0.1% whatever the phase at
/// which the contact starts and ends (docs/validation.md).
///
/// The integrator (semi-implicit Euler) applies the force of step n over the interval
/// `[t_n - dt/2, t_n + dt/2]` around the overlap `x = depth` it was computed at, the
/// overlap moving at the approach speed `v` before `t_n` and at the next step's `v+` after.
/// So the force is the impulse of the contact law over that interval, divided by `dt`:
/// - **spring**: its integral over the overlap's piecewise linear path; at the first step of
///   the contact the interval starts where the overlap crossed zero (as far back as the last
///   step: the part of the previous interval in contact is folded in), and at the last step
///   (the overlap predicted to reach zero before the next step) it ends where the overlap
///   crosses zero;
/// - **dashpot**: the difference of its primitive `G(x) = integral eta dx = eta x / (1 + q)`
///   (`eta ~ x^q`: q = 0 linear, 1/4 Hertz) between where the last step's interval ended
///   (`coverage` stores `G` there) and where this one ends, exact however the speed varies.
///   Its sum over a contact telescopes, so no part of the contact is damped twice or not at
///   all.
///
/// `v+` depends on the force, through the two-body motion with effective mass `m_eff`:
/// inside the contact in closed form, `G` linearised at `x` (exact for the linear law); at
/// the first and last steps by three fixed-point iterations (three more as the last step if
/// the contact separates after all). At rest the force is the spring force exactly (no bias
/// in static overlaps). `(spring_force, stiffness, eta)` are [`spring`] and the damping at
/// `depth`, which the caller has computed already.
#[inline(always)]
pub fn resolved_normal_force(
    c: &PairContext,
    depth: f32,
    approach: f32,
    forces: (f32, f32, f32),
    coverage: &mut f32,
) -> f32 {
    resolved_normal_force_in::<false>(c, depth, approach, forces, coverage)
}

/// [`resolved_normal_force`], knowing the law is linear when `PLAIN`.
#[inline(always)]
fn resolved_normal_force_in<const PLAIN: bool>(
    c: &PairContext,
    depth: f32,
    approach: f32,
    (spring_force, stiffness, eta): (f32, f32, f32),
    coverage: &mut f32,
) -> f32 {
    let (m_eff, dt) = (c.m_eff, c.dt);
    let (x, v, fs) = (depth, approach, spring_force);
    if dt * (dt * stiffness + eta) > RESOLVABLE * m_eff {
        // A step too long for the contact (near or past the stability bound): the explicit
        // law, which blows up plainly where the iterations below would not converge.
        *coverage = 0.0;
        return fs + eta * v;
    }
    // A contact's first step (no coverage yet): the interval reaches back over the last
    // step, which had no force, to where the overlap was then (0 where it crossed zero
    // within that step, as it does for every contact that starts between two steps; a
    // contact found already overlapping, as a scene may start, gets no dashpot kick).
    let first = *coverage == 0.0;
    let g_start = if *coverage > 0.0 {
        *coverage
    } else if first {
        dashpot_primitive::<PLAIN>(c, eta, x - dt * v)
    } else {
        0.0
    };
    let g_x = eta * x / dashpot_exponent::<PLAIN>(&c.params);
    if !first {
        // Inside the contact: the spring at `x` over the step (midpoint rule), the dashpot
        // from the covered end to `x1 = x + dt v+ / 2`, its primitive linearised at `x`
        // (exact for the linear law); `v+ = v - dt F / m*` solved in closed form: the
        // step's impulse is `J / (1 + eta dt / 2m*)`, `J` its value at `v+ = v`.
        let impulse = fs * dt + (g_x - g_start) + 0.5 * eta * v * dt;
        let per_mass = 1.0 / (m_eff + 0.5 * eta * dt);
        let v_after = v - impulse * per_mass;
        let force = impulse * per_mass * m_eff / dt;
        if x + dt * v_after > EDGE_SLACK * dt * v_after.abs() {
            *coverage = (g_x + 0.5 * eta * dt * v_after).max(f32::MIN_POSITIVE);
            return force;
        }
        // Separating within the step: this is the contact's last step.
        return contact_edge::<PLAIN>(c, (x, v), (false, true), v_after, g_start, eta, coverage);
    }
    let v_next = v - (fs + eta * v) * dt / (m_eff + 0.5 * eta * dt);
    let last = x + dt * v_next <= EDGE_SLACK * dt * v_next.abs();
    contact_edge::<PLAIN>(c, (x, v), (true, last), v_next, g_start, eta, coverage)
}

/// The first or last step of a contact ([`resolved_normal_force`]): the spring over the part
/// of the interval in contact, `v+` by three fixed-point iterations from `v_next` (three more
/// as the last step if a first step separates after all).
#[inline(never)]
fn contact_edge<const PLAIN: bool>(
    c: &PairContext,
    (x, v): (f32, f32),
    (first, mut last): (bool, bool),
    mut v_next: f32,
    g_start: f32,
    eta: f32,
    coverage: &mut f32,
) -> f32 {
    let dt = c.dt;
    let inv_m = 1.0 / c.m_eff;
    let (mut force, mut g_end) = (0.0, 0.0);
    for _pass in 0..2 {
        for _ in 0..3 {
            let back = if first { -dt } else { -0.5 * dt };
            let ahead = if last { dt } else { 0.5 * dt };
            let spring_impulse = spring_integral::<PLAIN>(c, x, v, back, 0.0)
                + spring_integral::<PLAIN>(c, x, v_next, 0.0, ahead);
            g_end = if last {
                0.0
            } else {
                dashpot_primitive::<PLAIN>(c, eta, x + 0.5 * dt * v_next)
            };
            force = (spring_impulse + g_end - g_start) / dt;
            v_next = v - dt * force * inv_m;
        }
        // Predicted to stay but separating after all: this is the last step.
        if last || x + dt * v_next > EDGE_SLACK * dt * v_next.abs() {
            break;
        }
        last = true;
    }
    *coverage = if g_end > 0.0 {
        g_end
    } else {
        COVERED_TO_RELEASE
    };
    force
}

/// `integral of spring(x0 + v s) ds` for `s` in `[s0, s1]`, the overlap's positive part only:
/// Simpson's rule where it stays positive (exact for the linear law, within 1e-4 for Hertz
/// over a step), the elastic energy over `|v|` where it crosses zero.
#[inline(always)]
fn spring_integral<const PLAIN: bool>(c: &PairContext, x0: f32, v: f32, s0: f32, s1: f32) -> f32 {
    let (p, r_eff, share) = (&c.params, c.r_eff, c.share);
    let (a, b) = (x0 + v * s0, x0 + v * s1);
    if a > 0.0 && b > 0.0 {
        let mid = x0 + v * (0.5 * (s0 + s1));
        (s1 - s0) / 6.0
            * (spring_in::<PLAIN>(p, r_eff, a, share).0
                + 4.0 * spring_in::<PLAIN>(p, r_eff, mid, share).0
                + spring_in::<PLAIN>(p, r_eff, b, share).0)
    } else if a > 0.0 || b > 0.0 {
        let top = a.max(b);
        let exponent = if hertz::<PLAIN>(p) { 2.5 } else { 2.0 };
        spring_in::<PLAIN>(p, r_eff, top, share).0 * top / exponent / v.abs()
    } else {
        0.0
    }
}

/// `1 + q` for the dashpot `eta ~ x^q` (q = 0 linear, 1/4 Hertz).
#[inline(always)]
fn dashpot_exponent<const PLAIN: bool>(p: &PairParams) -> f32 {
    if hertz::<PLAIN>(p) { 1.25 } else { 1.0 }
}

/// The dashpot's primitive `G(x) = integral of eta from 0 to x = eta(x) x / (1 + q)` (0 for
/// `x <= 0`). `eta_linear` is the linear law's (constant) damping, passed in to save its
/// square root.
#[inline(always)]
fn dashpot_primitive<const PLAIN: bool>(c: &PairContext, eta_linear: f32, x: f32) -> f32 {
    let p = &c.params;
    let x = x.max(0.0);
    let eta = if hertz::<PLAIN>(p) {
        damping(p, c.m_eff, spring_in::<PLAIN>(p, c.r_eff, x, c.share).1)
    } else {
        eta_linear
    };
    eta * x / dashpot_exponent::<PLAIN>(p)
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
pub fn rolling_torque(
    c: &PairContext,
    n: Vec3,
    a: &BodyMotion,
    b: &BodyMotion,
    normal_force: f32,
) -> Vec3 {
    let w = b.omega - a.omega;
    let w_roll = w - n * w.dot(n);
    let limit = c.params.rolling_friction * c.r_eff * normal_force.max(0.0);
    match resisting_scale(c, limit, w_roll.length()) {
        Some(scale) => -w_roll * scale,
        None => Vec3::ZERO,
    }
}

/// Torque per unit of relative angular velocity of a resisting torque of magnitude `limit`
/// at angular speed `speed`: `limit / speed`, or less near rest, where one step of the full
/// torque would take more than `speed` away from a body of inertia `2/5 m* R*^2`. `None`
/// when there is nothing to resist.
#[inline(always)]
fn resisting_scale(c: &PairContext, limit: f32, speed: f32) -> Option<f32> {
    let step_change = limit * c.dt / (0.4 * c.m_eff * c.r_eff * c.r_eff);
    (limit > 0.0 && speed > 0.0).then(|| limit / speed.max(step_change))
}

/// Spinning resistance, the torque on side b (side a gets its negative): the constant torque
/// `-mu_s R* Fn sign(w_n) n` against the relative spin `w_n` about the normal, shrinking in
/// proportion near rest as [`rolling_torque`] does.
#[inline(always)]
pub fn spinning_torque(
    c: &PairContext,
    n: Vec3,
    a: &BodyMotion,
    b: &BodyMotion,
    normal_force: f32,
) -> Vec3 {
    let w_n = (b.omega - a.omega).dot(n);
    let limit = c.params.spinning_friction * c.r_eff * normal_force.max(0.0);
    match resisting_scale(c, limit, w_n.abs()) {
        Some(scale) => n * (-w_n * scale),
        None => Vec3::ZERO,
    }
}

/// Adds adhesion (acting at `at`, along the normal) and rolling resistance to a contact's
/// force; `normal_force` is the contact's spring-dashpot normal force (without adhesion).
#[inline(always)]
fn adhesion_and_rolling<const PLAIN: bool>(
    c: &PairContext,
    n: Vec3,
    at: Vec3,
    (a, b): (&BodyMotion, &BodyMotion),
    normal_force: f32,
    out: &mut ContactForce,
) {
    if PLAIN {
        // None of the three (`is_plain`).
        return;
    }
    let p = &c.params;
    if p.cohesion_model != COHESION_NONE {
        let pull = adhesion(p, c.r_eff);
        let f = n * -pull;
        out.force_b += f;
        out.normal_force -= pull;
        out.torque_b += (at - b.position).cross(f);
        out.torque_a += f.cross(at - a.position);
    }
    if p.rolling_friction > 0.0 {
        let tau = rolling_torque(c, n, a, b, normal_force);
        out.torque_b += tau;
        out.torque_a -= tau;
    }
    if p.spinning_friction > 0.0 {
        let tau = spinning_torque(c, n, a, b, normal_force);
        out.torque_b += tau;
        out.torque_a -= tau;
    }
}

/// Computes the contact force of `manifold` between `a` and `b` and updates the tangential
/// spring `history` and the twisting spring `twist` (zero for a new contact). The context
/// `c` holds the pair's law parameters, its effective mass and radius, the fraction of the
/// material's law each point carries (1 for contacts involving a sphere, 1/4 otherwise) and
/// the step.
#[inline]
pub fn contact_force(
    c: &PairContext,
    manifold: &Manifold,
    a: &BodyMotion,
    b: &BodyMotion,
    history: &mut Vec3,
    twist: &mut f32,
) -> ContactForce {
    contact_force_in::<false>(c, manifold, a, b, history, twist)
}

/// [`contact_force`] for a caller that knows whether the pair's law is plain
/// ([`is_plain`]): with `PLAIN = true` the tests for the Hertz law, cohesion, rolling and
/// spinning resistance are left out, in the one-point law ([`point_contact_force_in`]) and
/// in the patch law alike. The same operations on the same values otherwise, so the same
/// bits as [`contact_force`] for plain parameters (other parameters must use
/// `PLAIN = false`). The polyhedron piles' contact stage calls it with `PLAIN = true` when
/// every material pair is plain, as the sphere stages do.
#[inline(always)]
pub fn contact_force_in<const PLAIN: bool>(
    c: &PairContext,
    manifold: &Manifold,
    a: &BodyMotion,
    b: &BodyMotion,
    history: &mut Vec3,
    twist: &mut f32,
) -> ContactForce {
    contact_force_known::<PLAIN>(c, None, manifold, a, b, history, twist)
}

/// [`contact_force_in`], with the linear law's constants of context `c` (those that depend
/// on the context and the point count only: stiffness, damping, tangential stiffness and
/// damping, `1 / count`) taken from `known` when given: `known` must be
/// [`LinearLaw::of`]`(c)` (the same values computed once, so the same bits) and `c`'s law
/// linear. A stage whose pairs all share one context (one material, mass, radius and
/// shape kind: a pile of equal bodies) makes both once.
#[inline(always)]
pub fn contact_force_known<const PLAIN: bool>(
    c: &PairContext,
    known: Option<&LinearLaw>,
    manifold: &Manifold,
    a: &BodyMotion,
    b: &BodyMotion,
    history: &mut Vec3,
    twist: &mut f32,
) -> ContactForce {
    debug_assert!(!PLAIN || is_plain(&c.params));
    debug_assert!(known.is_none() || !hertz::<false>(&c.params));
    let (p, m_eff, r_eff, share, dt) = (&c.params, c.m_eff, c.r_eff, c.share, c.dt);
    let n = manifold.normal;
    if manifold.count == 1 {
        // The twist slot holds the normal coverage of one-point contacts.
        let point = manifold.points[0];
        return point_force_known::<PLAIN>(c, known, n, point, a, b, history, twist);
    }
    let pts = manifold.points();
    // The linear law's constants of this point count, if known (`LinearLaw`).
    let known = known.map(|l| ((l.k, l.kt), &l.patch[pts.len()]));
    let inv_count = match known {
        Some((_, l)) => l.inv_count,
        None => 1.0 / pts.len() as f32,
    };
    let n_a = Vec3A::from(n);
    let (ma, mb) = (MotionA::of(a), MotionA::of(b));
    // The points' coordinates (in lanes on x86_64: `patch`).
    let patch = Patch::of(manifold);
    // Springs and total stiffness first: damping is shared in proportion to stiffness.
    // The linear law's points all have the same `k`; Hertz's grows with each point's depth.
    let mut springs = [(0.0f32, 0.0f32); 4];
    let mut k_total = 0.0;
    if hertz::<PLAIN>(p) {
        for (s, cp) in springs.iter_mut().zip(pts) {
            *s = spring_in::<PLAIN>(p, r_eff, cp.depth, share);
            k_total += s.1;
        }
    } else if let Some(((k, _), l)) = known {
        springs[0].1 = k;
        k_total = l.k_total;
    } else {
        for s in springs.iter_mut().take(pts.len()) {
            s.1 = spring_in::<PLAIN>(p, r_eff, 0.0, share).1;
            k_total += s.1;
        }
    }
    let (mut centroid, depth_sum) = patch.sums();
    centroid *= inv_count;
    let mean_depth = depth_sum * inv_count;
    let eta_total = match known {
        Some((_, l)) => l.eta_total,
        None => damping(p, m_eff, k_total),
    };
    // Each point's share of the damping, `eta_total k / k_total`. The linear law's points
    // all have the same `k` (`share * stiffness`), so one evaluation gives every point's
    // bits (a division a point saved); Hertz's `k` grows with each point's depth.
    let share_of = |k: f32| {
        if k_total > 0.0 {
            eta_total * k / k_total
        } else {
            0.0
        }
    };
    let linear_eta = match known {
        _ if hertz::<PLAIN>(p) => 0.0,
        Some((_, l)) => l.eta_point,
        None => share_of(springs[0].1),
    };
    // Each point's spring force and damping (unused slots: zero, never added).
    let (fs, etas) = if hertz::<PLAIN>(p) {
        let (mut fs, mut etas) = ([0.0f32; 4], [0.0f32; 4]);
        for (i, &(f, k)) in springs.iter().enumerate().take(pts.len()) {
            fs[i] = f;
            etas[i] = share_of(k);
        }
        (f4(fs), f4(etas))
    } else {
        // `share * stiffness * depth`: the same `k` times each depth.
        (patch.linear_springs(springs[0].1), f4([linear_eta; 4]))
    };
    // The force's sums, `ContactForce`'s fields in the same order of additions.
    let NormalSums {
        mut force_b,
        mut torque_a,
        mut torque_b,
        normal_force,
    } = patch.normal_sums(n_a, &ma, &mb, fs, etas);
    // One tangential spring for the whole patch, at its centroid.
    let (kt, eta_t) = match known {
        Some(((_, kt), l)) => (kt, l.eta_t),
        None => {
            let share_total = share * pts.len() as f32;
            let kt = tangential_stiffness::<PLAIN>(c, mean_depth, share_total);
            (kt, tangential_damping::<PLAIN>(c, kt, eta_total))
        }
    };
    let vrel = mb.point_velocity(centroid) - ma.point_velocity(centroid);
    let ft = tangential_law(c, kt, n_a, vrel, normal_force, eta_t, history);
    force_b += ft;
    torque_b += (centroid - mb.position).cross(ft);
    torque_a += ft.cross(centroid - ma.position);
    // Twisting about the normal, resisted over the patch radius.
    let r_patch = patch.radius_sum(centroid, n_a) * inv_count;
    if r_patch > 0.0 {
        let w_n = (mb.omega - ma.omega).dot(n_a);
        let r2 = r_patch * r_patch;
        let k_tw = kt * r2;
        let eta_tw = eta_t * r2;
        *twist += w_n * dt;
        let mut tau = -k_tw * *twist - eta_tw * w_n;
        let cap = p.friction * normal_force.max(0.0) * r_patch;
        if tau.abs() > cap {
            tau = cap.copysign(tau);
            *twist = if k_tw > 0.0 { -tau / k_tw } else { 0.0 };
        }
        torque_b += n_a * tau;
        torque_a -= n_a * tau;
    } else {
        *twist = 0.0;
    }
    let mut out = ContactForce::new(
        force_b.into(),
        torque_a.into(),
        torque_b.into(),
        normal_force,
    );
    let centroid = Vec3::from(centroid);
    let normal_force = out.normal_force;
    adhesion_and_rolling::<PLAIN>(c, n, centroid, (a, b), normal_force, &mut out);
    out
}

/// The constants of the linear law for one contact context ([`PairContext`] with linear
/// parameters): what [`contact_force_in`] computes from the context and a manifold's point
/// count alone, computed here by the same operations on the same values (so the same bits).
/// [`contact_force_known`] takes them instead of computing them per contact: for a stage
/// whose pairs all share one context, once per stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LinearLaw {
    /// One point's stiffness, `share * stiffness`.
    k: f32,
    /// A one-point contact's normal damping (for a patch: see [`PatchLaw::eta_point`]).
    eta_point: f32,
    /// The tangential spring's stiffness (the linear law's: whatever the point count).
    kt: f32,
    /// A one-point contact's tangential damping.
    eta_t_point: f32,
    /// By point count (slots 2 to 4 used).
    patch: [PatchLaw; 5],
}

/// [`LinearLaw`]'s constants of a patch of a given point count.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct PatchLaw {
    /// `1 / count`.
    inv_count: f32,
    /// The points' total stiffness, `k` added `count` times from 0.
    k_total: f32,
    /// The patch's total normal damping.
    eta_total: f32,
    /// Each point's share of it, `eta_total k / k_total` (0 if `k_total` is not positive).
    eta_point: f32,
    /// The tangential damping.
    eta_t: f32,
}

impl LinearLaw {
    /// The constants of context `c`, whose law must be linear (`None` for Hertz).
    pub fn of(c: &PairContext) -> Option<Self> {
        if hertz::<false>(&c.params) {
            return None;
        }
        let (p, m_eff, r_eff, share) = (&c.params, c.m_eff, c.r_eff, c.share);
        // `point_contact_force_in`'s.
        let k = spring_in::<true>(p, r_eff, 0.0, share).1;
        let eta_point = damping(p, m_eff, k);
        let kt = tangential_stiffness::<true>(c, 0.0, share);
        let eta_t_point = tangential_damping::<true>(c, kt, eta_point);
        // `contact_force_in`'s, by point count.
        let mut patch = [PatchLaw::default(); 5];
        for (count, l) in patch.iter_mut().enumerate().skip(2) {
            let mut k_total = 0.0;
            for _ in 0..count {
                k_total += k;
            }
            let eta_total = damping(p, m_eff, k_total);
            let eta_point = if k_total > 0.0 {
                eta_total * k / k_total
            } else {
                0.0
            };
            *l = PatchLaw {
                inv_count: 1.0 / count as f32,
                k_total,
                eta_total,
                eta_point,
                eta_t: tangential_damping::<true>(c, kt, eta_total),
            };
        }
        Some(LinearLaw {
            k,
            eta_point,
            kt,
            eta_t_point,
            patch,
        })
    }
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

mod patch;
use patch::{NormalSums, Patch, f4};

#[cfg(test)]
mod tests;
