// Stage **contacts** (src/stages/contacts.rs): for each candidate pair (`contacts`, or the
// two passes of contacts_split.wgsl) and each body-wall slot (`wall_contact`, called by
// integrate.wgsl), the manifold (narrow.wgsl) and the contact law (law.wgsl). Springs
// persist per pair in `hist` (xyz tangential, w twist).

// Body i's motion in its own frame of reference (at the origin): every contact is computed
// relative to body i's position (the CPU's `World::local_motion`).
fn motion_of(i: u32) -> BodyMotion {
    let b = bodies[i];
    return BodyMotion(vec3<f32>(0.0), b.velocity.xyz, b.omega.xyz);
}

@compute @workgroup_size(256)
fn contacts(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
            @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let c = dealt_item(wid, nwg, lid, a_start[params.n]);
    var touched = 0u;
    if c < a_start[params.n] && pair_contact(c, true, PAIR_ANY) {
        touched = 1u;
    }
    add_status_wg(lid, ST_TOUCHING, touched);
}

// Which narrow phase `pair_contact` runs (`collide_kind`, contacts_split.wgsl): every kind
// (`collide`), only the pairs with a sphere, or only the pairs of two polyhedra (with
// composites: any pair without a sphere body, so every kind). Each entry point passes a
// literal, so the compiler keeps only that branch (contacts_split.wgsl).
const PAIR_ANY: u32 = 0u;
const PAIR_SPHERES: u32 = 1u;
const PAIR_POLY: u32 = 2u;

// Candidate pair c: manifold, contact law, spring; whether the pair touches. With `use_hint`
// the pair's separating-axis hint is tried first (contacts_full_* skip it: contacts_sat has
// just tried it). `kind` (PAIR_*) is the narrow phase the pair needs.
fn pair_contact(c: u32, use_hint: bool, kind: u32) -> bool {
    let p = pairs[c];
    let i = body_of(p.x);
    let j = body_of(p.y);
    let si = statics[i];
    let sj = statics[j];
    let bi = bodies[i];
    let bj = bodies[j];
    // touching[c]: 1 = touching, 0 = not, 1 + hint = not, separated by the hinted axis.
    let was = touching[c];
    nrw_hint_in = select(0u, was - 1u, was >= 2u && use_hint);
    // Body i at the origin, j at its offset (status.wgsl `offset_of`).
    let xj = offset_of(i, j);
    // The pieces in touch (the bodies themselves without composites).
    let pa = piece_at(si, piece_of(p.x), vec3<f32>(0.0), bi.orientation);
    let pb = piece_at(sj, piece_of(p.y), xj, bj.orientation);
    // What the pair remembers of its contact if it touched (pair_memory), its margin less
    // twice this step's bound on any axis's motion (CPU `remembered_narrow`).
    var mem = vec2<u32>(NO_HINT, 0u);
    if was == 1u && params.full_test == 0u {
        mem = pair_memory[c];
    }
    nrw_mem_in = mem;
    // Without composites, a remembered contact's margin is anchored on the pose of its full
    // test (CPU: the plain path's pairs have an `EdgeMemory`; narrow.wgsl nrw_anchored).
    nrw_anchored = params.composites == 0u;
    if mem.x != NO_HINT {
        if nrw_anchored {
            nrw_anchor_in[0] = pair_anchor[2u * c];
            nrw_anchor_in[1] = pair_anchor[2u * c + 1u];
        } else {
            let left = bitcast<f32>(mem.y) - 2.0 * axis_motion_bound(i, j, xj);
            nrw_mem_in = vec2<u32>(mem.x, bitcast<u32>(left));
        }
    }
    let m = collide_kind(kind, pa.shape, pa.x, pa.q, pb.shape, pb.x, pb.q);
    if m.count > 0u {
        // Written when it changed; a pair that did not touch last step may hold a word of
        // an earlier contact (or of the pair in this slot before a rebuild), which must not
        // survive as this contact's, so it is always written then.
        if was != 1u || any(nrw_mem_out != mem) {
            pair_memory[c] = nrw_mem_out;
        }
        // The pose of the full test that remembered this contact (read only with its word).
        if nrw_anchor_written {
            pair_anchor[2u * c] = nrw_anchor_out[0];
            pair_anchor[2u * c + 1u] = nrw_anchor_out[1];
        }
        let params_ij = pair_table[si.material * params.num_materials + sj.material];
        let share = select(POLYHEDRON_POINT_SHARE, SPHERE_POINT_SHARE,
                           pa.is_sphere || pb.is_sphere);
        let only = params.spheres_only != 0u;
        let ri = select(pa.law_radius, si.radius, only);
        let rj = select(pb.law_radius, sj.radius, only);
        let r_eff = ri * rj / (ri + rj);
        let context = PairContext(params_ij, si.mass * sj.mass / (si.mass + sj.mass), r_eff,
                                  share, params.dt);
        let r = contact_force(context, m, motion_of(i),
                              BodyMotion(xj, bj.velocity.xyz, bj.omega.xyz), hist[c]);
        forces[c] = r.force;
        hist[c] = r.hist;
        touching[c] = 1u;
        return true;
    }
    release_pair(c, was);
    return false;
}

// An upper bound of how much the separation along any axis of the separating-axis test of
// bodies i and j (j at offset xj) can have changed in the last step: the CPU's
// `axis_motion_bound` (step/remembered.rs, see there why): with composites, 1-norms and the
// lever 3 (r_i + r_j) and a flat rounding allowance; else the norms themselves, the centres'
// relative motion and the larger of the two frames' bounds, each turn with the quaternion
// update's rounding (TURN_ROUNDING, clatter::contract), plus the offset's and the positions' rounding.
fn axis_motion_bound(i: u32, j: u32, xj: vec3<f32>) -> f32 {
    let x = abs(xj);
    let ri = statics[i].radius;
    let rj = statics[j].radius;
    let r = ri + rj;
    let l1 = x.x + x.y + x.z;
    if (params.composites != 0u) {
        let rounding = l1 * (1.0 / 8388608.0) + 4e-6 * r;
        let vi = abs(bodies[i].velocity.xyz);
        let vj = abs(bodies[j].velocity.xyz);
        let oi = abs(bodies[i].omega.xyz);
        let oj = abs(bodies[j].omega.xyz);
        let moved = (vi.x + vi.y + vi.z + vj.x + vj.y + vj.z) * params.dt;
        let turned = (oi.x + oi.y + oi.z + oj.x + oj.y + oj.z) * params.dt;
        return (moved + turned * 3.0 * r) * 1.00001 + rounding;
    }
    let vi = bodies[i].velocity.xyz;
    let vj = bodies[j].velocity.xyz;
    let moved = (length(vj - vi) + (length(vi) + length(vj)) * (1.0 / 4194304.0)) * params.dt;
    let ti = length(bodies[i].omega.xyz) * params.dt + TURN_ROUNDING;
    let tj = length(bodies[j].omega.xyz) * params.dt + TURN_ROUNDING;
    let far = length(xj) + moved;
    // A's frame (B's vertices), then B's frame (A's vertices).
    let turn = max(tj * rj + ti * (far + rj), ti * ri + tj * (far + ri));
    let rounding = l1 * (1.0 / 8388608.0) + r * (1.0 / 16777216.0);
    return (moved + turn) * 1.00001 + rounding;
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

// Whether body-wall slot t touched in the last step (a released slot's record is all zero).
fn wall_touched(t: u32) -> bool {
    return wall_forces[t].touching != 0u;
}

// Body i's piece k (the body itself, k = 0, unless a composite) against wall w, in slot
// `wall_slot(i, w, k)` (pieces.wgsl): manifold, contact law, spring (stored with the force for
// the host's read-back); the force when the piece touches the wall. Called by integrate
// (integrate.wgsl).
fn wall_contact(i: u32, w: u32, k: u32) -> WallResult {
    let t = wall_slot(i, w, k);
    let wall = walls[w];
    let si = statics[i];
    let bi = bodies[i];
    var shape = si.shape;
    // Body i at the origin, the plane shifted by its position.
    var x = vec3<f32>(0.0);
    var q = bi.orientation;
    var radius = si.equivalent_radius;
    var sphere = si.is_sphere != 0u;
    if COMPOSITES {
        let pc = piece_at(si, k, x, q);
        shape = pc.shape;
        x = pc.x;
        q = pc.q;
        radius = pc.law_radius;
        sphere = pc.is_sphere;
    }
    let po = plane_offset_from(i, wall.plane.xyz, wall.plane.w);
    var m = collide_plane(wall.plane.xyz, po.x, shape, x, q);
    // The offset's rest below f32 on the depths (precise.rs `plane_offset`).
    for (var kp = 0u; kp < m.count; kp++) {
        m.points[kp].w += po.y;
    }
    if m.count > 0u {
        let params_w = pair_table[wall.material * params.num_materials + si.material];
        let share = select(POLYHEDRON_POINT_SHARE, SPHERE_POINT_SHARE, sphere);
        let fixed = BodyMotion(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        let context = PairContext(params_w, si.mass, radius, share, params.dt);
        let r = contact_force(context, m, fixed, motion_of(i), wall_hist[t]);
        let f = r.force;
        wall_forces[t] = WallForce(f.force_b, f.normal_force, f.torque_a, 1u, f.torque_b, 0.0);
        wall_hist[t] = r.hist;
        return WallResult(true, r.force);
    } else if wall_touched(t) {
        wall_forces[t] = WallForce();
        wall_hist[t] = vec4<f32>(0.0);
    }
    return WallResult(false, ContactForce());
}
