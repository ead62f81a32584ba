// Stage 3, **pairs** (the CPU's broad::pairs): each body finds the bodies with a larger index
// in the 27 cells around its own whose skin-grown bounding spheres overlap its own, counted
// (`count_pairs`), scanned into offsets, then written sorted by (i, j) (`fill_pairs`).
// `carry` keeps the springs of persisting pairs, `commit` swaps in the new list, and
// `count_b` .. `sort_b` build each body's b-side pair list so forces gather in a fixed order.
// With composites a body pair becomes one entry per piece pair (`piece_pairs`, pieces.wgsl).

// Body i's partners j > i in the 27 cells around it (and, in a periodic box, around its
// images across nearby periodic faces: crates/clatter/src/periodic.rs `images_near`), in
// cell order; counts them, and with `write` also inserts each pair, sorted by j, into
// new_pairs from new_a_start[i] on.
fn scan_candidates(i: u32, write: bool) -> u32 {
    // A body removed by a sink (position.w != 0) takes part in no pair.
    if bodies[i].position.w != 0.0 {
        return 0u;
    }
    let xi = bodies[i].position.xyz;
    let ri = statics[i].radius;
    var s0 = 0u;
    if write {
        s0 = new_a_start[i];
    }
    // Images: bit k of `m` set = shifted along axis k (only where the body is near a face).
    var shift = vec3<f32>(0.0);
    var has = vec3<bool>(false);
    for (var k = 0u; k < 3u; k++) {
        let len = params.periodic_len[k];
        if len > 0.0 {
            let lo = params.periodic_min[k];
            if xi[k] - lo < grid.cell_size {
                shift[k] = len;
                has[k] = true;
            } else if (lo + len) - xi[k] <= grid.cell_size {
                shift[k] = -len;
                has[k] = true;
            }
        }
    }
    var count = 0u;
    for (var m = 0u; m < 8u; m++) {
        let bits = vec3<bool>((m & 1u) != 0u, (m & 2u) != 0u, (m & 4u) != 0u);
        if any(bits & !has) {
            continue;
        }
        let pi = xi + select(vec3<f32>(0.0), shift, bits);
        count += scan_cells(i, pi, ri, write, s0 + count);
    }
    return count;
}

// The 27 cells around `pi` (body i or one of its images): partners j > i within reach,
// inserted sorted by j among the `first - s0` already written when `write`.
fn scan_cells(i: u32, pi: vec3<f32>, ri: f32, write: bool, first: u32) -> u32 {
    let c = cell_of(pi);
    let dims = grid.dims.xyz;
    let s0 = select(0u, new_a_start[i], write);
    var count = 0u;
    let lo = vec3<u32>(max(vec3<i32>(c) - vec3<i32>(1), vec3<i32>(0)));
    let hi = min(c + vec3<u32>(1u), dims - vec3<u32>(1u));
    for (var z = lo.z; z <= hi.z; z++) {
        for (var y = lo.y; y <= hi.y; y++) {
            let row = (z * dims.y + y) * dims.x;
            let s = cell_start[row + lo.x];
            let e = cell_start[row + hi.x + 1u];
            for (var k = s; k < e; k++) {
                let j = sorted[k];
                if j > i && bodies[j].position.w == 0.0 {
                    let reach = ri + statics[j].radius + params.skin;
                    let d = bodies[j].position.xyz - pi;
                    if dot(d, d) < reach * reach && params.composites != 0u {
                        count += piece_pairs(i, j, write, s0, first + count);
                    } else if dot(d, d) < reach * reach {
                        if write {
                            var b = first + count;
                            while b > s0 && new_pairs[b - 1u].y > j {
                                new_pairs[b] = new_pairs[b - 1u];
                                b--;
                            }
                            new_pairs[b] = vec2<u32>(i, j);
                        }
                        count++;
                    }
                }
            }
        }
    }
    return count;
}

// Scenes with composites: the piece pairs of bodies i and j whose bounding spheres, grown by
// the skin, overlap at the current poses (the CPU's `piece_contacts`), one entry each, in
// piece-code order; counts them, and with `write` inserts them, sorted by j (then code, as
// they come), from `first` on.
fn piece_pairs(i: u32, j: u32, write: bool, s0: u32, first: u32) -> u32 {
    let si = statics[i];
    let sj = statics[j];
    // Relative to body i (the CPU's `piece_contacts`).
    let xi = vec3<f32>(0.0);
    let qi = bodies[i].orientation;
    let xj = offset_of(i, j);
    let qj = bodies[j].orientation;
    let nb = piece_count(sj.shape);
    var count = 0u;
    for (var a = 0u; a < piece_count(si.shape); a++) {
        let pa = piece_at(si, a, xi, qi);
        for (var k = 0u; k < nb; k++) {
            let pb = piece_at(sj, k, xj, qj);
            let reach = pa.radius + pb.radius + params.skin;
            let d = pb.x - pa.x;
            if dot(d, d) < reach * reach {
                if write {
                    var b = first + count;
                    while b > s0 && body_of(new_pairs[b - 1u].y) > j {
                        new_pairs[b] = new_pairs[b - 1u];
                        b--;
                    }
                    new_pairs[b] = vec2<u32>(pair_word(i, a), pair_word(j, k));
                }
                count++;
            }
        }
    }
    return count;
}

@compute @workgroup_size(256)
fn count_pairs(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, nwg, lid);
    if i > params.n || halted() {
        return;
    }
    if i == params.n {
        new_a_start[i] = 0u;
        return;
    }
    new_a_start[i] = scan_candidates(i, false);
}

@compute @workgroup_size(1)
fn pairs_total() {
    if halted() || atomicLoad(&status[ST_REBUILDING]) == 0u {
        return;
    }
    let total = new_a_start[params.n];
    atomicStore(&status[ST_PAIRS_NEEDED], total);
    if total > params.pair_capacity {
        // Stop here: the host grows the buffers and runs this step again.
        atomicStore(&status[ST_OVERFLOW], 1u);
        write_args(ARG_PAIRS_NEW, 0u);
        write_args(ARG_COMMIT, 0u);
        return;
    }
    atomicStore(&status[ST_PAIRS], total);
    write_args(ARG_PAIRS_NEW, (total + WG - 1u) / WG);
    write_args(ARG_COMMIT, (max(total, params.n + 1u) + WG - 1u) / WG);
    write_args(ARG_PAIRS, dealt_groups(total));
}

@compute @workgroup_size(256)
fn fill_pairs(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, nwg, lid);
    if i >= params.n || halted() {
        return;
    }
    scan_candidates(i, true);
}

// The tangential and twisting springs of pairs that persist (zero for new pairs).
@compute @workgroup_size(256)
fn carry(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
         @builtin(local_invocation_index) lid: u32) {
    let c = thread_index(wid, nwg, lid);
    if c >= new_a_start[params.n] || halted() {
        return;
    }
    // Keyed by (body pair, piece code), as the CPU's `carry_springs` (the codes are 0
    // without composites).
    let p = new_pairs[c];
    let i = body_of(p.x);
    let key = vec2<u32>(body_of(p.y), pair_code(p));
    var lo = a_start[i];
    var hi = a_start[i + 1u];
    var h = vec4<f32>(0.0);
    while lo < hi {
        let mid = (lo + hi) / 2u;
        let m = pairs[mid];
        let at = vec2<u32>(body_of(m.y), pair_code(m));
        if all(at == key) {
            h = hist[mid];
            break;
        }
        if at.x < key.x || (at.x == key.x && at.y < key.y) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    new_hist[c] = h;
}

@compute @workgroup_size(256)
fn commit(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let t = thread_index(wid, nwg, lid);
    if halted() {
        return;
    }
    if t < new_a_start[params.n] {
        pairs[t] = new_pairs[t];
        hist[t] = new_hist[t];
        // Outside a rebuild new_hist holds the pairs' gaps (contacts_split.wgsl `pair_gap`):
        // none yet for the new list.
        new_hist[t] = vec4<f32>(0.0);
        touching[t] = 0u;
        forces[t] = ContactForce();
    }
    // carry has read the old ranges: replace them.
    if t <= params.n {
        a_start[t] = new_a_start[t];
    }
    if t < params.n {
        rebuild_pos[t] = bodies[t].position;
        if params.composites != 0u {
            rebuild_pos[params.n + t] = bodies[t].orientation;
        }
    }
}

@compute @workgroup_size(256)
fn count_b(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
           @builtin(local_invocation_index) lid: u32) {
    let c = thread_index(wid, nwg, lid);
    if c >= a_start[params.n] || halted() {
        return;
    }
    atomicAdd(&b_count[body_of(pairs[c].y)], 1u);
}

@compute @workgroup_size(256)
fn copy_b(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, nwg, lid);
    if i <= params.n && !halted() {
        b_start[i] = atomicLoad(&b_count[i]);
    }
}

@compute @workgroup_size(256)
fn fill_b(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let c = thread_index(wid, nwg, lid);
    if c >= a_start[params.n] || halted() {
        return;
    }
    let j = body_of(pairs[c].y);
    let slot = b_start[j] + atomicSub(&b_count[j], 1u) - 1u;
    b_adj[slot] = c;
}

@compute @workgroup_size(256)
fn sort_b(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, nwg, lid);
    if i >= params.n || halted() {
        return;
    }
    let s = b_start[i];
    let e = b_start[i + 1u];
    for (var a = s + 1u; a < e; a++) {
        let v = b_adj[a];
        var b = a;
        while b > s && b_adj[b - 1u] > v {
            b_adj[b] = b_adj[b - 1u];
            b--;
        }
        b_adj[b] = v;
    }
}
