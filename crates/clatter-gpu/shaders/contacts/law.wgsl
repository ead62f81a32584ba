// The DEM contact law on the GPU: the twin of crates/clatter/src/law/mod.rs, function for
// function under the same names (tests/law.rs runs both on random contacts). Each contact
// passes a `PairContext` (its `PairParams` row, effective mass and radius, point share and
// step) and the constants of clatter::contract (both from the generated prelude).

struct BodyMotion {
    position: vec3<f32>,
    velocity: vec3<f32>,
    omega: vec3<f32>,
}

fn point_velocity(s: BodyMotion, p: vec3<f32>) -> vec3<f32> {
    return s.velocity + cross(s.omega, p - s.position);
}

// Spring force (x) and stiffness (y) of one point at overlap `depth` carrying `share`.
fn spring(p: PairParams, r_eff: f32, depth: f32, share: f32) -> vec2<f32> {
    if p.model == MODEL_HERTZ {
        let contact = sqrt(r_eff * max(depth, 0.0));
        return vec2<f32>(share * 4.0 / 3.0 * p.stiffness * contact * depth,
                         share * 2.0 * p.stiffness * contact);
    }
    return vec2<f32>(share * p.stiffness * depth, share * p.stiffness);
}

fn damping(p: PairParams, m_eff: f32, k: f32) -> f32 {
    return p.damping_factor * sqrt(m_eff * max(k, 0.0));
}

// Tangential damping (law.rs `tangential_damping`): Hertz-Mindlin's on the tangential
// stiffness, or the linear law's ratio of the normal damping.
fn tangential_damping(c: PairContext, kt: f32, eta_n: f32) -> f32 {
    if c.params.model == MODEL_HERTZ {
        return damping(c.params, c.m_eff, kt);
    }
    return TANGENTIAL_DAMPING_RATIO * eta_n;
}

fn tangential_stiffness(c: PairContext, depth: f32, share_total: f32) -> f32 {
    if c.params.model == MODEL_HERTZ {
        return share_total * 8.0 * c.params.shear * sqrt(c.r_eff * max(depth, 0.0));
    }
    return LINEAR_TANGENTIAL_RATIO * c.params.stiffness;
}

struct Tangential {
    force: vec3<f32>,
    spring: vec3<f32>,
}

fn tangential_law(c: PairContext, kt: f32, n: vec3<f32>, vrel: vec3<f32>, normal_force: f32,
                  eta_t: f32, history: vec3<f32>) -> Tangential {
    let vt = vrel - n * dot(vrel, n);
    var xi = history;
    let along = dot(xi, n);
    if along != 0.0 {
        let old_len2 = dot(xi, xi);
        xi -= n * along;
        let new_len2 = dot(xi, xi);
        if new_len2 > 0.0 {
            xi *= sqrt(old_len2 / new_len2);
        }
    }
    xi += vt * c.dt;
    let cap = c.params.friction * max(normal_force, 0.0);
    // The spring slips at the Coulomb force, then the sum with the dashpot is capped: both
    // continuous across sticking and sliding (law.rs `tangential_law` says why).
    let spring2 = kt * kt * dot(xi, xi);
    if spring2 > cap * cap {
        xi *= cap / sqrt(spring2);
    }
    var ft = -kt * xi - eta_t * vt;
    let ft_len2 = dot(ft, ft);
    if ft_len2 > cap * cap {
        ft *= cap / sqrt(ft_len2);
    }
    return Tangential(ft, xi);
}

struct LawResult {
    force: ContactForce,
    hist: vec4<f32>,
}

// One point: normal and tangential forces at `cp.xyz`, overlap `cp.w` along the unit
// normal `n` (from a to b); `coverage` the contact's normal state (law.rs). Twin of
// `point_contact_force` in law.rs.
fn point_contact_force(c: PairContext, n: vec3<f32>, cp: vec4<f32>, a: BodyMotion,
                       b: BodyMotion, history: vec3<f32>, coverage: f32) -> LawResult {
    let p = c.params;
    let point = cp.xyz;
    let depth = cp.w;
    let vrel = point_velocity(b, point) - point_velocity(a, point);
    let sk = spring(p, c.r_eff, depth, c.share);
    let eta = damping(p, c.m_eff, sk.y);
    var fn_: f32;
    var cov = 0.0;
    if c.share == SPHERE_POINT_SHARE {
        let r = resolved_normal_force(c, depth, -dot(vrel, n), sk, eta, coverage);
        fn_ = r.x;
        cov = r.y;
    } else {
        fn_ = sk.x - eta * dot(vrel, n);
    }
    let kt = tangential_stiffness(c, depth, c.share);
    let eta_t = tangential_damping(c, kt, eta);
    let t = tangential_law(c, kt, n, vrel, fn_, eta_t, history);
    let f = n * fn_ + t.force;
    var out = ContactForce();
    out.force_b = f;
    out.normal_force = fn_;
    out.torque_a = cross(f, point - a.position);
    out.torque_b = cross(point - b.position, f);
    adhesion_and_rolling(c, n, point, a, b, fn_, &out);
    return LawResult(out, vec4<f32>(t.spring, cov));
}

const COVERED_TO_RELEASE: f32 = -1.0;
const EDGE_SLACK: f32 = 0.05;
const RESOLVABLE: f32 = 1.0;

// The normal force resolved within the step (x) and the new coverage (y): law.rs
// `resolved_normal_force`, where the method is explained.
fn resolved_normal_force(c: PairContext, depth: f32, approach: f32, sk: vec2<f32>, eta: f32,
                         coverage: f32) -> vec2<f32> {
    let m_eff = c.m_eff;
    let dt = c.dt;
    let x = depth;
    let v = approach;
    let fs = sk.x;
    if dt * (dt * sk.y + eta) > RESOLVABLE * m_eff {
        return vec2<f32>(fs + eta * v, 0.0);
    }
    let first = coverage == 0.0;
    var g_start = 0.0;
    if coverage > 0.0 {
        g_start = coverage;
    } else if first {
        g_start = dashpot_primitive(c, eta, x - dt * v);
    }
    let g_x = eta * x / dashpot_exponent(c.params);
    if !first {
        let impulse = fs * dt + (g_x - g_start) + 0.5 * eta * v * dt;
        let per_mass = 1.0 / (m_eff + 0.5 * eta * dt);
        let v_after = v - impulse * per_mass;
        let force = impulse * per_mass * m_eff / dt;
        if x + dt * v_after > EDGE_SLACK * dt * abs(v_after) {
            return vec2<f32>(force, max(g_x + 0.5 * eta * dt * v_after, 1.17549435e-38));
        }
        return contact_edge(c, x, v, false, true, v_after, g_start, eta);
    }
    let v_next = v - (fs + eta * v) * dt / (m_eff + 0.5 * eta * dt);
    let last = x + dt * v_next <= EDGE_SLACK * dt * abs(v_next);
    return contact_edge(c, x, v, true, last, v_next, g_start, eta);
}

// law.rs `contact_edge`: the force (x) and the new coverage (y) of a first or last step.
fn contact_edge(c: PairContext, x: f32, v: f32, first: bool, last_in: bool, v_in: f32,
                g_start: f32, eta: f32) -> vec2<f32> {
    let dt = c.dt;
    let inv_m = 1.0 / c.m_eff;
    var last = last_in;
    var v_next = v_in;
    var force = 0.0;
    var g_end = 0.0;
    for (var attempt = 0u; attempt < 2u; attempt++) {
        for (var it = 0u; it < 3u; it++) {
            let back = select(-0.5 * dt, -dt, first);
            let ahead = select(0.5 * dt, dt, last);
            let spring_impulse = spring_integral(c, x, v, back, 0.0)
                + spring_integral(c, x, v_next, 0.0, ahead);
            if last {
                g_end = 0.0;
            } else {
                g_end = dashpot_primitive(c, eta, x + 0.5 * dt * v_next);
            }
            force = (spring_impulse + g_end - g_start) / dt;
            v_next = v - dt * force * inv_m;
        }
        if last || x + dt * v_next > EDGE_SLACK * dt * abs(v_next) {
            break;
        }
        last = true;
    }
    return vec2<f32>(force, select(COVERED_TO_RELEASE, g_end, g_end > 0.0));
}

// law.rs `spring_integral`.
fn spring_integral(c: PairContext, x0: f32, v: f32, s0: f32, s1: f32) -> f32 {
    let p = c.params;
    let r_eff = c.r_eff;
    let share = c.share;
    let a = x0 + v * s0;
    let b = x0 + v * s1;
    if a > 0.0 && b > 0.0 {
        let mid = x0 + v * (0.5 * (s0 + s1));
        return (s1 - s0) / 6.0
            * (spring(p, r_eff, a, share).x + 4.0 * spring(p, r_eff, mid, share).x
               + spring(p, r_eff, b, share).x);
    } else if a > 0.0 || b > 0.0 {
        let top = max(a, b);
        let exponent = select(2.0, 2.5, p.model == MODEL_HERTZ);
        return spring(p, r_eff, top, share).x * top / exponent / abs(v);
    }
    return 0.0;
}

// law.rs `dashpot_exponent`: 1 + q for eta ~ x^q.
fn dashpot_exponent(p: PairParams) -> f32 {
    return select(1.0, 1.25, p.model == MODEL_HERTZ);
}

// law.rs `dashpot_primitive`: G(x) = eta(x) x / (1 + q), 0 for x <= 0.
fn dashpot_primitive(c: PairContext, eta_linear: f32, x_in: f32) -> f32 {
    let x = max(x_in, 0.0);
    var eta = eta_linear;
    if c.params.model == MODEL_HERTZ {
        eta = damping(c.params, c.m_eff, spring(c.params, c.r_eff, x, c.share).y);
    }
    return eta * x / dashpot_exponent(c.params);
}

// The adhesive pull of a touching pair (DMT: 2 pi gamma R*), 0 without cohesion.
fn adhesion(p: PairParams, r_eff: f32) -> f32 {
    if p.cohesion_model == COHESION_DMT {
        return 2.0 * 3.14159274101257324 * p.surface_energy * r_eff;
    }
    return 0.0;
}

// Rolling resistance, the torque on side b (law.rs `rolling_torque`).
fn rolling_torque(c: PairContext, n: vec3<f32>, a: BodyMotion, b: BodyMotion,
                  normal_force: f32) -> vec3<f32> {
    let w = b.omega - a.omega;
    let w_roll = w - n * dot(w, n);
    let limit = c.params.rolling_friction * c.r_eff * max(normal_force, 0.0);
    let speed = length(w_roll);
    if limit > 0.0 && speed > 0.0 {
        return -w_roll * resisting_scale(c, limit, speed);
    }
    return vec3<f32>(0.0);
}

// law.rs `resisting_scale` (callers check limit > 0 and speed > 0).
fn resisting_scale(c: PairContext, limit: f32, speed: f32) -> f32 {
    let step_change = limit * c.dt / (0.4 * c.m_eff * c.r_eff * c.r_eff);
    return limit / max(speed, step_change);
}

// Spinning resistance, the torque on side b (law.rs `spinning_torque`).
fn spinning_torque(c: PairContext, n: vec3<f32>, a: BodyMotion, b: BodyMotion,
                   normal_force: f32) -> vec3<f32> {
    let w_n = dot(b.omega - a.omega, n);
    let limit = c.params.spinning_friction * c.r_eff * max(normal_force, 0.0);
    let speed = abs(w_n);
    if limit > 0.0 && speed > 0.0 {
        return n * (-w_n * resisting_scale(c, limit, speed));
    }
    return vec3<f32>(0.0);
}

// Adds adhesion (at `at`, along the normal) and rolling resistance to a contact's force.
fn adhesion_and_rolling(c: PairContext, n: vec3<f32>, at: vec3<f32>, a: BodyMotion,
                        b: BodyMotion, normal_force: f32, out: ptr<function, ContactForce>) {
    let p = c.params;
    if p.cohesion_model != COHESION_NONE {
        let pull = adhesion(p, c.r_eff);
        let f = n * -pull;
        (*out).force_b += f;
        (*out).normal_force -= pull;
        (*out).torque_b += cross(at - b.position, f);
        (*out).torque_a += cross(f, at - a.position);
    }
    if p.rolling_friction > 0.0 {
        let tau = rolling_torque(c, n, a, b, normal_force);
        (*out).torque_b += tau;
        (*out).torque_a -= tau;
    }
    if p.spinning_friction > 0.0 {
        let tau = spinning_torque(c, n, a, b, normal_force);
        (*out).torque_b += tau;
        (*out).torque_a -= tau;
    }
}

// A whole manifold; springs in `hist_in` (xyz tangential, w twist). Twin of
// `contact_force` in law.rs.
fn contact_force(c: PairContext, m: Manifold, a: BodyMotion, b: BodyMotion,
                 hist_in: vec4<f32>) -> LawResult {
    let p = c.params;
    let m_eff = c.m_eff;
    let r_eff = c.r_eff;
    let share = c.share;
    let dt = c.dt;
    let n = m.normal;
    if m.count == 1u {
        return point_contact_force(c, n, m.points[0], a, b, hist_in.xyz, hist_in.w);
    }
    let count = m.count;
    let inv_count = 1.0 / f32(count);
    var springs: array<vec2<f32>, 4>;
    var k_total = 0.0;
    var centroid = vec3<f32>(0.0);
    var mean_depth = 0.0;
    for (var k = 0u; k < count; k++) {
        springs[k] = spring(p, r_eff, m.points[k].w, share);
        k_total += springs[k].y;
        centroid += m.points[k].xyz;
        mean_depth += m.points[k].w;
    }
    centroid *= inv_count;
    mean_depth *= inv_count;
    let eta_total = damping(p, m_eff, k_total);
    var force_b = vec3<f32>(0.0);
    var torque_a = vec3<f32>(0.0);
    var torque_b = vec3<f32>(0.0);
    var normal_force = 0.0;
    for (var k = 0u; k < count; k++) {
        let cp = m.points[k].xyz;
        let vrel = point_velocity(b, cp) - point_velocity(a, cp);
        let eta = select(0.0, eta_total * springs[k].y / k_total, k_total > 0.0);
        let fn_i = springs[k].x - eta * dot(vrel, n);
        let f = n * fn_i;
        force_b += f;
        torque_b += cross(cp - b.position, f);
        torque_a += cross(f, cp - a.position);
        normal_force += fn_i;
    }
    let share_total = share * f32(count);
    let kt = tangential_stiffness(c, mean_depth, share_total);
    let eta_t = tangential_damping(c, kt, eta_total);
    let vrel = point_velocity(b, centroid) - point_velocity(a, centroid);
    let t = tangential_law(c, kt, n, vrel, normal_force, eta_t, hist_in.xyz);
    force_b += t.force;
    torque_b += cross(centroid - b.position, t.force);
    torque_a += cross(t.force, centroid - a.position);
    var r_patch = 0.0;
    for (var k = 0u; k < count; k++) {
        let d = m.points[k].xyz - centroid;
        r_patch += length(d - n * dot(d, n));
    }
    r_patch *= inv_count;
    var twist = 0.0;
    if r_patch > 0.0 {
        let w_n = dot(b.omega - a.omega, n);
        let r2 = r_patch * r_patch;
        let k_tw = kt * r2;
        let eta_tw = eta_t * r2;
        twist = hist_in.w + w_n * dt;
        var tau = -k_tw * twist - eta_tw * w_n;
        let cap = p.friction * max(normal_force, 0.0) * r_patch;
        if abs(tau) > cap {
            tau = select(-cap, cap, tau >= 0.0);
            twist = select(0.0, -tau / k_tw, k_tw > 0.0);
        }
        torque_b += n * tau;
        torque_a -= n * tau;
    }
    var out = ContactForce();
    out.force_b = force_b;
    out.normal_force = normal_force;
    out.torque_a = torque_a;
    out.torque_b = torque_b;
    adhesion_and_rolling(c, n, centroid, a, b, normal_force, &out);
    return LawResult(out, vec4<f32>(t.spring, twist));
}

