// Stages 4 and 5, **narrow** and **forces**: for each candidate pair (`contacts`, or the
// two passes of contacts_split.wgsl) and each body-wall slot (`wall_contact`, called by
// integrate.wgsl), the contact manifold (narrow.wgsl) and the DEM contact
// law of crates/clatter/src/forces.rs, line for line: a spring-dashpot per manifold point
// (share 1 for contacts with a sphere, 1/4 for polyhedron contacts), one Cundall-Strack
// tangential spring per pair at the manifold's centroid, capped by Coulomb, and a twisting
// spring for patches. Springs persist per pair in `hist` (xyz tangential, w twist).

const LINEAR_TANGENTIAL_RATIO: f32 = 0.2857142857142857; // 2/7
const TANGENTIAL_DAMPING_RATIO: f32 = 0.5;

struct Side {
    position: vec3<f32>,
    velocity: vec3<f32>,
    omega: vec3<f32>,
}

fn point_velocity(s: Side, p: vec3<f32>) -> vec3<f32> {
    return s.velocity + cross(s.omega, p - s.position);
}

// Spring force (x) and stiffness (y) of one point at overlap `depth` carrying `share`.
fn spring(p: PairParams, r_eff: f32, depth: f32, share: f32) -> vec2<f32> {
    if p.hertz != 0u {
        let contact = sqrt(r_eff * max(depth, 0.0));
        return vec2<f32>(share * 4.0 / 3.0 * p.stiffness * contact * depth,
                         share * 2.0 * p.stiffness * contact);
    }
    return vec2<f32>(share * p.stiffness * depth, share * p.stiffness);
}

fn damping(p: PairParams, m_eff: f32, k: f32) -> f32 {
    return p.damping_factor * sqrt(m_eff * max(k, 0.0));
}

fn tangential_stiffness(p: PairParams, r_eff: f32, depth: f32, share_total: f32) -> f32 {
    if p.hertz != 0u {
        return share_total * 8.0 * p.shear * sqrt(r_eff * max(depth, 0.0));
    }
    return LINEAR_TANGENTIAL_RATIO * p.stiffness;
}

struct Tangential {
    force: vec3<f32>,
    spring: vec3<f32>,
}

fn tangential_law(p: PairParams, kt: f32, n: vec3<f32>, vrel: vec3<f32>, normal_force: f32,
                  eta_n: f32, history: vec3<f32>, dt: f32) -> Tangential {
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
    xi += vt * dt;
    var ft = -kt * xi - (TANGENTIAL_DAMPING_RATIO * eta_n) * vt;
    let cap = p.friction * max(normal_force, 0.0);
    let ft_len2 = dot(ft, ft);
    if ft_len2 > cap * cap {
        ft *= cap / sqrt(ft_len2);
        xi = select(vec3<f32>(0.0), -ft / kt, kt > 0.0);
    }
    return Tangential(ft, xi);
}

struct LawResult {
    force: ContactForce,
    hist: vec4<f32>,
}

fn contact_law(p: PairParams, m_eff: f32, r_eff: f32, share: f32, m: Manifold, a: Side, b: Side,
               hist_in: vec4<f32>, dt: f32) -> LawResult {
    let n = m.normal;
    var out = ContactForce();
    if m.count == 1u {
        let point = m.points[0].xyz;
        let depth = m.points[0].w;
        let vrel = point_velocity(b, point) - point_velocity(a, point);
        let sk = spring(p, r_eff, depth, share);
        let eta = damping(p, m_eff, sk.y);
        let fn_ = sk.x - eta * dot(vrel, n);
        let kt = tangential_stiffness(p, r_eff, depth, share);
        let t = tangential_law(p, kt, n, vrel, fn_, eta, hist_in.xyz, dt);
        let f = n * fn_ + t.force;
        out.force_b = vec4<f32>(f, fn_);
        out.torque_a = vec4<f32>(cross(f, point - a.position), 0.0);
        out.torque_b = vec4<f32>(cross(point - b.position, f), 0.0);
        return LawResult(out, vec4<f32>(t.spring, 0.0));
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
    let kt = tangential_stiffness(p, r_eff, mean_depth, share_total);
    let vrel = point_velocity(b, centroid) - point_velocity(a, centroid);
    let t = tangential_law(p, kt, n, vrel, normal_force, eta_total, hist_in.xyz, dt);
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
        let eta_tw = TANGENTIAL_DAMPING_RATIO * eta_total * r2;
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
    out.force_b = vec4<f32>(force_b, normal_force);
    out.torque_a = vec4<f32>(torque_a, 0.0);
    out.torque_b = vec4<f32>(torque_b, 0.0);
    return LawResult(out, vec4<f32>(t.spring, twist));
}

fn side_of(i: u32) -> Side {
    let b = bodies[i];
    return Side(b.position.xyz, b.velocity.xyz, b.omega.xyz);
}

@compute @workgroup_size(256)
fn contacts(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
            @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let c = thread_index(wid, nwg, lid);
    var touched = 0u;
    if c < a_start[params.n] && pair_contact(c, true) {
        touched = 1u;
    }
    add_status_wg(lid, ST_TOUCHING, touched);
}

// Candidate pair c: manifold, contact law, spring; whether the pair touches. With `use_hint`
// the pair's separating-axis hint is tried first (contacts_full skips it: contacts_sat has
// just tried it).
fn pair_contact(c: u32, use_hint: bool) -> bool {
    let p = pairs[c];
    let i = p.x;
    let j = p.y;
    let si = statics[i];
    let sj = statics[j];
    let bi = bodies[i];
    let bj = bodies[j];
    // touching[c]: 1 = touching, 0 = not, 1 + hint = not, separated by the hinted axis.
    let was = touching[c];
    nrw_hint_in = select(0u, was - 1u, was >= 2u && use_hint);
    let m = collide(si.shape, bi.position.xyz, bi.orientation, sj.shape, bj.position.xyz,
                    bj.orientation);
    if m.count > 0u {
        let params_ij = pair_table[si.material * params.num_materials + sj.material];
        let share = select(0.25, 1.0, si.is_sphere != 0u || sj.is_sphere != 0u);
        let only = params.spheres_only != 0u;
        let ri = select(si.equivalent_radius, si.radius, only);
        let rj = select(sj.equivalent_radius, sj.radius, only);
        let r_eff = ri * rj / (ri + rj);
        let r = contact_law(params_ij, si.mass * sj.mass / (si.mass + sj.mass), r_eff, share, m,
                            side_of(i), side_of(j), hist[c], params.dt);
        forces[c] = r.force;
        hist[c] = r.hist;
        touching[c] = 1u;
        return true;
    }
    release_pair(c, was);
    return false;
}

// Candidate pair c does not touch this step (`was`: its touching word before): zero spring
// and force if it touched (written only on the change), and keep the axis that separated
// it, if any (`nrw_hint_out`), as next step's hint.
fn release_pair(c: u32, was: u32) {
    if was == 1u {
        forces[c] = ContactForce();
        hist[c] = vec4<f32>(0.0);
    }
    let now = select(0u, nrw_hint_out + 1u, nrw_hint_out != 0u);
    if now != was {
        touching[c] = now;
    }
}

struct WallResult {
    touching: bool,
    force: ContactForce,
}

// Body-wall slot t = body * num_walls + wall: manifold, contact law, spring (stored with
// the force for the host's read-back); the force when the body touches the wall. Called by
// integrate (integrate.wgsl).
fn wall_contact(t: u32) -> WallResult {
    let i = t / params.num_walls;
    let wall = walls[t % params.num_walls];
    let si = statics[i];
    let bi = bodies[i];
    let m = collide_plane(wall.plane.xyz, wall.plane.w, si.shape, bi.position.xyz, bi.orientation);
    if m.count > 0u {
        let params_w = pair_table[wall.material * params.num_materials + si.material];
        let share = select(0.25, 1.0, si.is_sphere != 0u);
        let fixed = Side(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        let r = contact_law(params_w, si.mass, si.equivalent_radius, share, m, fixed, side_of(i),
                            wall_hist[t], params.dt);
        wall_forces[t] = r.force;
        wall_hist[t] = r.hist;
        wall_touching[t] = 1u;
        return WallResult(true, r.force);
    } else if wall_touching[t] != 0u {
        wall_forces[t] = ContactForce();
        wall_hist[t] = vec4<f32>(0.0);
        wall_touching[t] = 0u;
    }
    return WallResult(false, ContactForce());
}
