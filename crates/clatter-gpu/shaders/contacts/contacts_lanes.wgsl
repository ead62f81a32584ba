// contacts_full_poly with POLY_LANES lanes per polyhedron pair (issue 23; chosen by
// CLATTER_GPU_POLY_LANES, see src/pipeline.rs `poly_lanes_from_env`; the host prepends
// `const POLY_LANES`). The lanes of a pair spread the full separating-axis test: lane l
// takes A's and B's face axes l, l + POLY_LANES, ... into a table in workgroup memory,
// every lane then runs the one-thread face loops over that table (the same values in the
// same order, so the same best faces, ties and first separating face), then each lane
// searches its share of the edge axes (A's edges l, l + POLY_LANES, ... for the Gauss-map
// enumeration; the flattened pairs of edge directions likewise) and keeps its first
// separating axis and its best; the reduction takes the smallest separating index, else
// the largest separation with the smallest index on ties: the one-thread loop's strict `>`
// keeps the first of equal bests, and its early exit stops at the first separating axis,
// which is the smallest index. Lane 0 then runs `pair_contact` as contacts_full_poly does,
// with that result in place of nrw_sat's own loops (narrow_poly.wgsl `nrw_lanes_ready`).
// Pairs of a remembered path's class run alone on one thread (see the kernel); pairs the
// lanes cannot serve (composites, a shape with more faces than the table holds, a NaN on
// the way) run the one-thread loops on lane 0.
// Every lane of the workgroup reaches every barrier: lanes without a pair run the loops
// with nothing to do.

const LANE_SLOTS: u32 = WG / POLY_LANES;
// Face axes per body in a pair's table (32 with 8 lanes, 64 with 16).
const LANE_FACES: u32 = 1024u / LANE_SLOTS;
const LANE_NONE: u32 = 0xffffffffu;

var<workgroup> wg_lane_face: array<f32, 2048>;
// Per lane: its first separating edge-axis index, its best's index, 1 if it met a NaN.
var<workgroup> wg_lane_key: array<vec4<u32>, WG>;
var<workgroup> wg_lane_s: array<f32, WG>;
// Per pair: the winning lane's best axis.
var<workgroup> wg_lane_axis: array<vec4<f32>, LANE_SLOTS>;

// The pair a group of lanes serves, in A's frame as nrw_poly_poly sees it.
struct LanePair {
    live: bool,
    // Its class takes a remembered path first: one thread runs it alone (see the kernel).
    remembers: bool,
    a: NrwShape,
    b: NrwShape,
    rot: mat3x3<f32>,
    inv_rot: mat3x3<f32>,
    t: vec3<f32>,
}

// Candidate pair c (if `listed`) as the lanes serve it: live only when nrw_poly_poly will
// run the full test first (no remembered contact), with the inputs pair_contact gives it.
fn lane_pair(c: u32, listed: bool, remembers: bool) -> LanePair {
    var r: LanePair;
    r.live = false;
    r.remembers = remembers;
    if !listed || remembers || COMPOSITES {
        return r;
    }
    let p = pairs[c];
    let i = body_of(p.x);
    let j = body_of(p.y);
    let xj = offset_of(i, j);
    let pa = piece_at(statics[i], piece_of(p.x), vec3<f32>(0.0), bodies[i].orientation);
    let pb = piece_at(statics[j], piece_of(p.y), xj, bodies[j].orientation);
    if pa.is_sphere || pb.is_sphere {
        return r;
    }
    r.a = nrw_shape(pa.shape);
    r.b = nrw_shape(pb.shape);
    let d = pb.x - pa.x;
    let rs = r.a.radius + r.b.radius;
    if dot(d, d) >= rs * rs || r.a.num_faces > LANE_FACES || r.b.num_faces > LANE_FACES {
        return r;
    }
    let pose = nrw_relative_pose(pa.q, pb.q, d);
    r.rot = pose.rot;
    r.inv_rot = transpose(pose.rot);
    r.t = pose.t;
    r.live = true;
    return r;
}

// Whether the pair at position `pos` of the ordered list takes a remembered path first (its
// class's path, contacts_split.wgsl `pair_class`, is not the full test): found from the
// classes' ends (status[ST_CLASSES + k] after contacts_place), not from the pair's own
// words, which this kernel writes.
fn listed_remembers(pos: u32) -> bool {
    if params.full_test != 0u {
        return false;
    }
    var lo = 0u;
    var hi = SPLIT_CLASSES - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if atomicLoad(&status[ST_CLASSES + mid]) > pos {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo % 3u != 0u;
}

// One lane's share of the edge axes: its first separating index, its best (index,
// separation, axis), whether it met a NaN separation.
struct LaneEdge {
    sep: u32,
    key: u32,
    s: f32,
    axis: vec3<f32>,
    nan: bool,
}

fn lane_edge_none() -> LaneEdge {
    return LaneEdge(LANE_NONE, LANE_NONE, 0.0, vec3<f32>(0.0), false);
}

// Keeps axis `key` (separation s) as the lane's best if it beats it (the one-thread loop's
// strict `>`: the first of equal bests); a NaN is only noted.
fn lane_keep(r: ptr<function, LaneEdge>, key: u32, s: f32, axis: vec3<f32>) {
    if s != s {
        (*r).nan = true;
    } else if (*r).key == LANE_NONE || s > (*r).s {
        (*r).key = key;
        (*r).s = s;
        (*r).axis = axis;
    }
}

// nrw_edge_axes_gauss_map over A's edges lane, lane + POLY_LANES, ... (index ea *
// b.num_edges + eb, the hint's): nrw_gauss_map_strided, the one-thread loop itself.
fn lane_gauss_map(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>, lane: u32) -> LaneEdge {
    let g = nrw_gauss_map_strided(a, b, rot, inv_rot, t, lane, POLY_LANES);
    var r = lane_edge_none();
    r.nan = g.nan;
    if g.e.separated {
        r.sep = g.sep_ea * b.num_edges + g.sep_eb;
    } else if g.e.found && !g.nan {
        r.key = g.e.ea * b.num_edges + g.e.eb;
        r.s = g.e.s;
        r.axis = g.e.axis;
    }
    return r;
}

// nrw_edge_axes_by_direction over the pairs of edge directions lane, lane + POLY_LANES, ...
// (index ia * b.num_dirs + ib, the hint's), skipping as it does below max(floor, the lane's
// best): a skipped axis is at most that, so it neither separates nor beats the best, and
// the caller ignores a best at most `floor`.
fn lane_by_direction(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, t: vec3<f32>, floor: f32, lane: u32) -> LaneEdge {
    var r = lane_edge_none();
    let total = a.num_dirs * b.num_dirs;
    for (var idx = lane; idx < total; idx += POLY_LANES) {
        let ia = idx / b.num_dirs;
        let ib = idx % b.num_dirs;
        let ua = shape_f[a.dir_base + ia].xyz;
        let ax = cross(ua, rot * shape_f[b.dir_base + ib].xyz);
        let len2 = dot(ax, ax);
        if len2 < 1e-10 {
            continue;
        }
        let axis = ax / sqrt(len2);
        var ext_a = vec2<f32>(-NRW_LOWEST, NRW_LOWEST);
        var ext_b = vec2<f32>(-NRW_LOWEST, NRW_LOWEST);
        var skip = false;
        for (var part = 0u; part < 2u; part += 1u) {
            let head_a = min(4u, a.num_vertices);
            let head_b = min(4u, b.num_vertices);
            let rest = part == 1u;
            ext_a = nrw_extent_a(a, axis, select(0u, head_a, rest),
                                 select(head_a, a.num_vertices, rest), ext_a);
            ext_b = nrw_extent_b(b, axis, rot, t, select(0u, head_b, rest),
                                 select(head_b, b.num_vertices, rest), ext_b);
            let low = select(floor, max(floor, r.s), r.key != LANE_NONE);
            if !rest && ext_b.x - ext_a.y <= low && ext_a.x - ext_b.y <= low {
                skip = true;
                break;
            }
        }
        if skip {
            continue;
        }
        var s = ext_a.x - ext_b.y;
        var sa = -axis;
        if ext_b.x - ext_a.y >= ext_a.x - ext_b.y {
            s = ext_b.x - ext_a.y;
            sa = axis;
        }
        if s > 0.0 {
            r.sep = idx;
            return r;
        }
        lane_keep(&r, idx, s, sa);
    }
    return r;
}

// The full test's result for the pair, computed by its lanes (see the top): `ok` false when
// lane 0 must run the one-thread loops itself. Every lane of the workgroup must call it.
struct LaneSat {
    ok: bool,
    sat: NrwSat,
    hint: u32,
}

// One body's face loop of nrw_sat over its separations in the table (`count` from `at`):
// the first separating face (`sep`, LANE_NONE when none), else the best and second
// separations and the best face, as the one-thread loop leaves them (also where it stops).
struct LaneFaces {
    best: f32,
    second: f32,
    best_f: u32,
    sep: u32,
}

fn lane_face_loop(at: u32, count: u32) -> LaneFaces {
    var r = LaneFaces(NRW_LOWEST, NRW_LOWEST, 0u, LANE_NONE);
    for (var f = 0u; f < count; f += 1u) {
        let s = wg_lane_face[at + f];
        if s > 0.0 {
            r.sep = f;
            return r;
        }
        if f == 0u || s > r.best {
            r.second = r.best;
            r.best = s;
            r.best_f = f;
        } else if s > r.second {
            r.second = s;
        }
    }
    return r;
}

fn lane_sat(lp: LanePair, lid: u32) -> LaneSat {
    let lane = lid % POLY_LANES;
    let slot = lid / POLY_LANES;
    let base = slot * 2u * LANE_FACES;
    let a = lp.a;
    let b = lp.b;
    var out: LaneSat;
    out.ok = lp.live;
    out.hint = 0u;
    // The face separations, spread over the lanes (nrw_sat's expressions).
    if lp.live {
        for (var f = lane; f < a.num_faces; f += POLY_LANES) {
            let fc = nrw_face(a, f);
            wg_lane_face[base + f] = nrw_min_b(b, fc.xyz, lp.rot, lp.t) - fc.w;
        }
        for (var f = lane; f < b.num_faces; f += POLY_LANES) {
            let fc = nrw_face(b, f);
            let n = lp.rot * fc.xyz;
            wg_lane_face[base + LANE_FACES + f] = nrw_min_a(a, n) - (fc.w + dot(n, lp.t));
        }
    }
    workgroupBarrier();
    // nrw_sat's face loops over the table, on every lane.
    var r: NrwSat;
    r.separated = true;
    r.best_a = NRW_LOWEST;
    r.second_a = NRW_LOWEST;
    r.best_b = NRW_LOWEST;
    r.second_b = NRW_LOWEST;
    var edges = false;
    if lp.live {
        let fa = lane_face_loop(base, a.num_faces);
        var fb = LaneFaces(NRW_LOWEST, NRW_LOWEST, 0u, LANE_NONE);
        if fa.sep == LANE_NONE {
            fb = lane_face_loop(base + LANE_FACES, b.num_faces);
        }
        r.best_a = fa.best;
        r.second_a = fa.second;
        r.best_af = fa.best_f;
        r.best_b = fb.best;
        r.second_b = fb.second;
        r.best_bf = fb.best_f;
        if fa.sep != LANE_NONE {
            out.hint = nrw_hint(0u, fa.sep);
        } else if fb.sep != LANE_NONE {
            out.hint = nrw_hint(1u, fb.sep);
        } else {
            // A NaN best face would make the edge floor's decisions the loop's own.
            edges = r.best_a == r.best_a && r.best_b == r.best_b;
            out.ok = edges;
        }
    }
    // The edge axes: nrw_sat's cost rule, each lane its share.
    let cost_dirs = a.num_dirs * b.num_dirs * (a.num_vertices + b.num_vertices);
    let cost_tables = a.num_edges * b.num_faces + b.num_edges * a.num_faces + a.num_edges * b.num_edges;
    let dirs = cost_dirs <= 2u * cost_tables;
    var mine = lane_edge_none();
    if edges {
        if dirs {
            mine = lane_by_direction(a, b, lp.rot, lp.t, max(r.best_a, r.best_b), lane);
        } else {
            mine = lane_gauss_map(a, b, lp.rot, lp.inv_rot, lp.t, lane);
        }
    }
    wg_lane_key[lid] = vec4<u32>(mine.sep, mine.key, select(0u, 1u, mine.nan), 0u);
    wg_lane_s[lid] = mine.s;
    workgroupBarrier();
    // The reduction, on every lane of the pair: the smallest separating index, else the
    // largest separation, the smallest index on ties.
    var sep = LANE_NONE;
    var nan = false;
    var win = LANE_NONE;
    var win_s = 0.0;
    if edges {
        for (var l = slot * POLY_LANES; l < (slot + 1u) * POLY_LANES; l += 1u) {
            let k = wg_lane_key[l];
            nan = nan || k.z != 0u;
            sep = min(sep, k.x);
            if k.y != LANE_NONE {
                let s = wg_lane_s[l];
                if win == LANE_NONE || s > win_s || (s == win_s && k.y < win) {
                    win = k.y;
                    win_s = s;
                }
            }
        }
        if win != LANE_NONE && win == mine.key {
            wg_lane_axis[slot] = vec4<f32>(mine.axis, 0.0);
        }
    }
    workgroupBarrier();
    if edges {
        if nan {
            out.ok = false;
        } else if sep != LANE_NONE {
            out.hint = select(nrw_hint(3u, sep), nrw_hint(2u, sep), dirs);
        } else {
            r.separated = false;
            var e: NrwEdgeAxis;
            e.s = 0.0;
            e.ea = 0u;
            e.eb = 0u;
            e.axis = vec3<f32>(0.0);
            e.found = false;
            e.separated = false;
            e.hint = 0u;
            if win != LANE_NONE {
                e.found = true;
                e.s = win_s;
                e.axis = wg_lane_axis[slot].xyz;
                if dirs {
                    let eab = nrw_supporting_edges(a, b, lp.rot, lp.t, win / b.num_dirs,
                                                   win % b.num_dirs, e.axis);
                    e.ea = eab.x;
                    e.eb = eab.y;
                } else {
                    e.ea = win / b.num_edges;
                    e.eb = win % b.num_edges;
                }
            }
            r.e = e;
        }
    }
    out.sat = r;
    return out;
}

// contacts_full_poly with POLY_LANES lanes per pair: the dispatch has POLY_LANES threads
// per listed pair (contacts_size), u = 0, 1, ...; the POLY_LANES threads u of pair u /
// POLY_LANES are consecutive in a workgroup (dealt in chunks of DEAL_CHUNK, a multiple of
// POLY_LANES). A pair that remembers its contact (most touching pairs: the remembered face
// clipped alone) gains nothing from lanes, and would keep POLY_LANES threads for one: thread
// u runs pair u alone when it remembers (so a subgroup runs as many of those as
// contacts_full_poly does), and the lanes of pair u / POLY_LANES serve it only when it does
// not. Each pair runs once; one call site of pair_contact.
@compute @workgroup_size(256)
fn contacts_full_poly_lanes(@builtin(workgroup_id) wid: vec3<u32>,
                            @builtin(num_workgroups) nwg: vec3<u32>,
                            @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let spheres = atomicLoad(&status[ST_FULL_SPHERES]);
    let count = atomicLoad(&status[ST_WORK]) - spheres;
    let u = dealt_item(wid, nwg, lid, count * POLY_LANES);
    let listed = u < count * POLY_LANES;
    var c = 0u;
    var remembers = false;
    if listed {
        c = new_pairs[spheres + u / POLY_LANES].y;
        remembers = listed_remembers(spheres + u / POLY_LANES);
    }
    let lp = lane_pair(c, listed, remembers);
    let ls = lane_sat(lp, lid);
    var touched = 0u;
    for (var turn = 0u; turn < 2u; turn += 1u) {
        var run = false;
        var cr = c;
        if turn == 0u {
            // The lanes' pair, on its lane 0, with their result.
            run = listed && lid % POLY_LANES == 0u && !lp.remembers;
            nrw_lanes_ready = ls.ok;
            nrw_lanes_sat = ls.sat;
            nrw_lanes_hint = ls.hint;
        } else {
            // Pair u, if it remembers its contact, alone.
            nrw_lanes_ready = false;
            if u < count {
                cr = new_pairs[spheres + u].y;
                run = listed_remembers(spheres + u);
            }
        }
        if run && pair_contact(cr, false, PAIR_POLY) {
            touched += 1u;
        }
    }
    nrw_lanes_ready = false;
    add_status_wg(lid, ST_TOUCHING, touched);
}
