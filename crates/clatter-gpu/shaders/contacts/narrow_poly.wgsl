// The narrow phase's polyhedron pairs, the second half of narrow.wgsl (split only for size;
// the kernels include both, see src/pipeline.rs `NARROW`): the separating-axis test over face
// and edge axes (Gauss-map pruning or unique edge directions), face clipping, and
// nrw_poly_poly, the port of clatter-geom's narrow/sat.rs, edges.rs and clip.rs.

// ---------------------------------------------------------------- polyhedra

// Closest points of segments p0-p1 and q0-q1 (returned as the two columns).
fn nrw_segment_closest(p0: vec3<f32>, p1: vec3<f32>, q0: vec3<f32>, q1: vec3<f32>) -> mat2x3<f32> {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let c = dot(d1, r);
    let b = dot(d1, d2);
    let denom = a * e - b * b;
    var s = 0.0;
    if denom > 1e-12 * a * e {
        s = clamp((b * f - c * e) / denom, 0.0, 1.0);
    }
    var t = 0.0;
    if e > 0.0 {
        t = (b * s + f) / e;
    }
    if t < 0.0 {
        t = 0.0;
        s = 0.0;
        if a > 0.0 {
            s = clamp(-c / a, 0.0, 1.0);
        }
    } else if t > 1.0 {
        t = 1.0;
        s = 0.0;
        if a > 0.0 {
            s = clamp((b - c) / a, 0.0, 1.0);
        }
    }
    return mat2x3<f32>(p0 + d1 * s, q0 + d2 * t);
}

// B's vertex i in A's frame (the CPU's `bv`): rot * v + t.
fn nrw_bv(b: NrwShape, i: u32, rot: mat3x3<f32>, t: vec3<f32>) -> vec3<f32> {
    return rot * nrw_vert(b, i) + t;
}

// The incident body's vertex i in the reference body's frame: `rot * v + t` when the
// incident body is B (CPU `bv`), `rot * (v - t)` when it is A (CPU `av`, rot = inv_rot).
fn nrw_inc_vert(p: NrwShape, i: u32, rot: mat3x3<f32>, t: vec3<f32>, inc_is_a: bool) -> vec3<f32> {
    let v = nrw_vert(p, i);
    if inc_is_a {
        return rot * (v - t);
    }
    return rot * v + t;
}

// Smallest projection of A's own vertices on n.
fn nrw_min_a(a: NrwShape, n: vec3<f32>) -> f32 {
    var m = dot(n, nrw_vert(a, 0u));
    for (var i = 1u; i < a.num_vertices; i += 1u) {
        let d = dot(n, nrw_vert(a, i));
        if d < m {
            m = d;
        }
    }
    return m;
}

fn nrw_max_a(a: NrwShape, n: vec3<f32>) -> f32 {
    var m = dot(n, nrw_vert(a, 0u));
    for (var i = 1u; i < a.num_vertices; i += 1u) {
        let d = dot(n, nrw_vert(a, i));
        if d > m {
            m = d;
        }
    }
    return m;
}

// The extent `e` (min in x, max in y) widened by the projections on n of A's vertices
// lo..hi (exact: the min and max of the same products in any grouping).
fn nrw_extent_a(a: NrwShape, n: vec3<f32>, lo: u32, hi: u32, e: vec2<f32>) -> vec2<f32> {
    var r = e;
    for (var i = lo; i < hi; i += 1u) {
        let d = dot(n, nrw_vert(a, i));
        if d < r.x {
            r.x = d;
        }
        if d > r.y {
            r.y = d;
        }
    }
    return r;
}

// nrw_extent_a for B's vertices lo..hi (in A's frame).
fn nrw_extent_b(b: NrwShape, n: vec3<f32>, rot: mat3x3<f32>, t: vec3<f32>, lo: u32, hi: u32,
                e: vec2<f32>) -> vec2<f32> {
    var r = e;
    for (var i = lo; i < hi; i += 1u) {
        let d = dot(n, nrw_bv(b, i, rot, t));
        if d < r.x {
            r.x = d;
        }
        if d > r.y {
            r.y = d;
        }
    }
    return r;
}

// Smallest projection of B's vertices (in A's frame) on n.
fn nrw_min_b(b: NrwShape, n: vec3<f32>, rot: mat3x3<f32>, t: vec3<f32>) -> f32 {
    var m = dot(n, nrw_bv(b, 0u, rot, t));
    for (var i = 1u; i < b.num_vertices; i += 1u) {
        let d = dot(n, nrw_bv(b, i, rot, t));
        if d < m {
            m = d;
        }
    }
    return m;
}

fn nrw_max_b(b: NrwShape, n: vec3<f32>, rot: mat3x3<f32>, t: vec3<f32>) -> f32 {
    var m = dot(n, nrw_bv(b, 0u, rot, t));
    for (var i = 1u; i < b.num_vertices; i += 1u) {
        let d = dot(n, nrw_bv(b, i, rot, t));
        if d > m {
            m = d;
        }
    }
    return m;
}

// The best edge-edge axis: separation, A's edge, B's edge, axis in A's frame; `separated`
// when an edge axis separates the bodies, `found` false when no axis was tested.
struct NrwEdgeAxis {
    s: f32,
    ea: u32,
    eb: u32,
    axis: vec3<f32>,
    found: bool,
    separated: bool,
    // When separated: the separating axis as a hint (see nrw_hint_in).
    hint: u32,
}

// The edges of B (64-bit set, low word first) whose two faces' products with A's arc may
// have a negative product (CPU `crossing_candidates`): one strictly positive and the other
// strictly negative (the edges in exactly one positive face and exactly one negative face),
// or either neither (zero or NaN). Every edge left out fails the Gauss-map test anyway.
fn nrw_crossing_candidates(b: NrwShape, arc_a: vec3<f32>) -> vec2<u32> {
    var pos = vec2<u32>(0u);
    var neg = vec2<u32>(0u);
    var other = vec2<u32>(0u);
    for (var kb = 0u; kb < b.num_faces; kb += 1u) {
        let v = -dot(nrw_face(b, kb).xyz, arc_a);
        let at = b.by_face_base + 2u * kb;
        let edges = vec2<u32>(shape_u[at], shape_u[at + 1u]);
        if v > 0.0 {
            pos ^= edges;
        } else if v < 0.0 {
            neg ^= edges;
        } else {
            other |= edges;
        }
    }
    return (pos & neg) | other;
}

// The Gauss-map search over A's edges first, first + stride, ...: the loop of
// nrw_edge_axes_gauss_map (stride 1) and of each lane of contacts_full_poly_lanes
// (contacts_lanes.wgsl, stride POLY_LANES), written once so that both make the same
// decisions on the same arithmetic. It stops at the first separating axis (sep_ea, sep_eb);
// else it keeps the largest separation, the first of equal ones (a NaN is kept only when
// it comes first, as the one-thread loop does, and noted in `nan`).
struct NrwGaussMap {
    // The best axis (`hint` left 0).
    e: NrwEdgeAxis,
    sep_ea: u32,
    sep_eb: u32,
    nan: bool,
}

fn nrw_gauss_map_strided(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>, first: u32, stride: u32) -> NrwGaussMap {
    var r = NrwGaussMap(NrwEdgeAxis(0.0, 0u, 0u, vec3<f32>(0.0), false, false, 0u), 0u, 0u, false);
    let use_bits = b.by_face_base != 0u;
    for (var ea = first; ea < a.num_edges; ea += stride) {
        let e_a = nrw_edge(a, ea);
        let arc_a = inv_rot * shape_f[a.arc_base + ea].xyz;
        let pa0 = nrw_vert(a, e_a.x);
        let da = nrw_vert(a, e_a.y) - pa0;
        let na0 = nrw_face(a, e_a.z).xyz;
        let na1 = nrw_face(a, e_a.w).xyz;
        var bits = vec2<u32>(0u);
        if use_bits {
            bits = nrw_crossing_candidates(b, arc_a);
        }
        var next = 0u;
        loop {
            // The next edge of B to visit: the lowest candidate bit, or every edge in turn.
            var eb = 0u;
            if use_bits {
                if bits.x != 0u {
                    eb = firstTrailingBit(bits.x);
                    bits.x &= bits.x - 1u;
                } else if bits.y != 0u {
                    eb = 32u + firstTrailingBit(bits.y);
                    bits.y &= bits.y - 1u;
                } else {
                    break;
                }
            } else {
                if next >= b.num_edges {
                    break;
                }
                eb = next;
                next += 1u;
            }
            let e_b = nrw_edge(b, eb);
            let cba = -dot(nrw_face(b, e_b.z).xyz, arc_a);
            let dba = -dot(nrw_face(b, e_b.w).xyz, arc_a);
            if cba * dba >= 0.0 {
                continue;
            }
            let arc_b = rot * shape_f[b.arc_base + eb].xyz;
            let adc = dot(na0, arc_b);
            let bdc = dot(na1, arc_b);
            if adc * bdc >= 0.0 || cba * bdc <= 0.0 {
                continue;
            }
            let pb0 = nrw_bv(b, e_b.x, rot, t);
            let db = nrw_bv(b, e_b.y, rot, t) - pb0;
            let ax = cross(da, db);
            let len2 = dot(ax, ax);
            if len2 < 1e-10 * dot(da, da) * dot(db, db) {
                continue;
            }
            var axis = ax / sqrt(len2);
            if dot(axis, pa0) < 0.0 {
                axis = -axis;
            }
            let s = dot(axis, pb0 - pa0);
            if s > 0.0 {
                r.e.separated = true;
                r.sep_ea = ea;
                r.sep_eb = eb;
                return r;
            }
            if s != s {
                r.nan = true;
            }
            if !r.e.found || s > r.e.s {
                r.e.found = true;
                r.e.s = s;
                r.e.ea = ea;
                r.e.eb = eb;
                r.e.axis = axis;
            }
        }
    }
    return r;
}

// Edge axes over edge pairs whose Gauss-map arcs cross (CPU `edge_axes_gauss_map`; the
// CPU's two product tables are recomputed per pair). Where B has its edges by face as bit
// sets, only the candidates of nrw_crossing_candidates are visited, in increasing order, so
// the same edges meet the same tests in the same order as when every edge is visited.
fn nrw_edge_axes_gauss_map(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>) -> NrwEdgeAxis {
    let g = nrw_gauss_map_strided(a, b, rot, inv_rot, t, 0u, 1u);
    var r = g.e;
    if r.separated {
        r.hint = nrw_hint(3u, g.sep_ea * b.num_edges + g.sep_eb);
    }
    return r;
}

// Edge axes over pairs of unique edge directions, projecting both bodies (CPU
// `edge_axes_by_direction`), then the supporting edges of the best pair. `floor` (not
// positive): axes whose separation is at most `floor` may be skipped (the caller ignores a
// best axis not above it); an axis above it is found as without it.
fn nrw_edge_axes_by_direction(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, t: vec3<f32>, floor: f32) -> NrwEdgeAxis {
    var r: NrwEdgeAxis;
    r.s = 0.0;
    r.ea = 0u;
    r.eb = 0u;
    r.axis = vec3<f32>(0.0);
    r.found = false;
    r.separated = false;
    r.hint = 0u;
    var ia_best = 0u;
    var ib_best = 0u;
    for (var ia = 0u; ia < a.num_dirs; ia += 1u) {
        let ua = shape_f[a.dir_base + ia].xyz;
        for (var ib = 0u; ib < b.num_dirs; ib += 1u) {
            let ax = cross(ua, rot * shape_f[b.dir_base + ib].xyz);
            let len2 = dot(ax, ax);
            if len2 < 1e-10 {
                continue;
            }
            let axis = ax / sqrt(len2);
            // Both bodies' extents in one pass each, the first 4 vertices of each first
            // (CPU `edge_axes_by_direction`): their extents lie inside the bodies' (the same
            // products, from the one call site of each), so when they already overlap by
            // more than the best axis so far, so do the bodies, and the axis can neither win
            // nor separate (the best is not positive); nor matter when they overlap by at
            // least `-floor`. Exact: an axis above `floor` meets the same decisions.
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
                let low = select(floor, max(floor, r.s), r.found);
                if !rest && ext_b.x - ext_a.y <= low && ext_a.x - ext_b.y <= low {
                    skip = true;
                    break;
                }
            }
            if skip {
                continue;
            }
            let min_a = ext_a.x;
            let max_a = ext_a.y;
            let min_b = ext_b.x;
            let max_b = ext_b.y;
            var s = min_a - max_b;
            var sa = -axis;
            if min_b - max_a >= min_a - max_b {
                s = min_b - max_a;
                sa = axis;
            }
            if s > 0.0 {
                r.separated = true;
                r.hint = nrw_hint(2u, ia * b.num_dirs + ib);
                nrw_sep_out = s;
                return r;
            }
            if !r.found || s > r.s {
                r.found = true;
                r.s = s;
                ia_best = ia;
                ib_best = ib;
                r.axis = sa;
            }
        }
    }
    if !r.found {
        return r;
    }
    let eab = nrw_supporting_edges(a, b, rot, t, ia_best, ib_best, r.axis);
    r.ea = eab.x;
    r.eb = eab.y;
    return r;
}

// The supporting edges (A's, B's) of the best pair of edge directions (ia, ib) along `axis`
// (nrw_edge_axes_by_direction; also contacts_lanes.wgsl).
fn nrw_supporting_edges(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, t: vec3<f32>, ia_best: u32,
                        ib_best: u32, axis: vec3<f32>) -> vec2<u32> {
    var r = vec2<u32>(0u);
    var ha = 0.0;
    var fa = false;
    for (var e = 0u; e < a.num_edges; e += 1u) {
        if shape_u[a.edge_dir_base + e] == ia_best {
            let ev = nrw_edge(a, e);
            let h = dot(axis, nrw_vert(a, ev.x) + nrw_vert(a, ev.y));
            if !fa || h > ha {
                fa = true;
                ha = h;
                r.x = e;
            }
        }
    }
    var hb = 0.0;
    var fb = false;
    for (var e = 0u; e < b.num_edges; e += 1u) {
        if shape_u[b.edge_dir_base + e] == ib_best {
            let ev = nrw_edge(b, e);
            let h = dot(axis, nrw_bv(b, ev.x, rot, t) + nrw_bv(b, ev.y, rot, t));
            if !fb || h < hb {
                fb = true;
                hb = h;
                r.y = e;
            }
        }
    }
    return r;
}

// Clips the incident face of `inc` (vertices mapped into refp's frame by nrw_inc_vert with
// (inc_m, inc_t, inc_is_a)) against reference face rf of refp; `inc_rot` is the rotation from
// inc's frame into refp's. Normal: the reference face's outward normal. Result in refp's frame.
fn nrw_clip_faces(refp: NrwShape, rf: u32, inc: NrwShape, inc_m: mat3x3<f32>, inc_t: vec3<f32>, inc_is_a: bool, inc_rot: mat3x3<f32>) -> Manifold {
    let rface = nrw_face(refp, rf);
    let n = rface.xyz;
    // Incident face: the one most anti-parallel to the reference normal.
    let n_inc = transpose(inc_rot) * n;
    var inc_face = 0u;
    var best = 0.0;
    for (var f = 0u; f < inc.num_faces; f += 1u) {
        let d = dot(nrw_face(inc, f).xyz, n_inc);
        if f == 0u || d < best {
            best = d;
            inc_face = f;
        }
    }
    var poly: NrwBuf;
    var tmp: NrwBuf;
    var len = nrw_loop_len(inc, inc_face);
    let ifirst = nrw_loop_first(inc, inc_face);
    for (var i = 0u; i < len; i += 1u) {
        poly[i] = vec4<f32>(nrw_inc_vert(inc, shape_u[ifirst + i], inc_m, inc_t, inc_is_a), 0.0);
    }
    let rfirst = nrw_loop_first(refp, rf);
    let rlen = nrw_loop_len(refp, rf);
    for (var k = 0u; k < rlen; k += 1u) {
        let v0 = nrw_vert(refp, shape_u[rfirst + k]);
        let v1 = nrw_vert(refp, shape_u[rfirst + (k + 1u) % rlen]);
        let side = cross(v1 - v0, n); // outward for a CCW loop
        let off = dot(side, v0);
        var olen = 0u;
        for (var i = 0u; i < len; i += 1u) {
            let p = poly[i].xyz;
            let q = poly[(i + 1u) % len].xyz;
            let dp = dot(side, p) - off;
            let dq = dot(side, q) - off;
            if dp <= 0.0 && olen < NRW_MAX_CLIP {
                tmp[olen] = vec4<f32>(p, 0.0);
                olen += 1u;
            }
            if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0)) && olen < NRW_MAX_CLIP {
                tmp[olen] = vec4<f32>(p + (q - p) * (dp / (dp - dq)), 0.0);
                olen += 1u;
            }
        }
        for (var i = 0u; i < olen; i += 1u) {
            poly[i] = tmp[i];
        }
        len = olen;
        if len == 0u {
            break;
        }
    }
    // Points below the reference face, moved halfway through the overlap, into tmp.
    var count = 0u;
    for (var i = 0u; i < len; i += 1u) {
        let p = poly[i].xyz;
        let depth = rface.w - dot(n, p);
        if depth > 0.0 {
            tmp[count] = vec4<f32>(p + n * (0.5 * depth), depth);
            count += 1u;
        }
    }
    if count == 0u {
        // The incident face clips away entirely (deep or oblique overlap): keep the contact
        // with the incident body's deepest vertex (min_by(total_cmp): the first minimum).
        var deepest = nrw_inc_vert(inc, 0u, inc_m, inc_t, inc_is_a);
        var kd = nrw_key(dot(n, deepest));
        for (var i = 1u; i < inc.num_vertices; i += 1u) {
            let v = nrw_inc_vert(inc, i, inc_m, inc_t, inc_is_a);
            let k = nrw_key(dot(n, v));
            if k < kd {
                kd = k;
                deepest = v;
            }
        }
        let depth = rface.w - dot(n, deepest);
        if depth <= 0.0 {
            return nrw_none();
        }
        return nrw_single(n, deepest + n * (0.5 * depth), depth);
    }
    let src = NrwPatch(false, count, refp, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), vec4<f32>(0.0));
    return nrw_reduce(src, &tmp, n);
}

// The separating-axis test of two polyhedra (B in A's frame by rot, inv_rot, t): the hinted
// axis, A's face axes, B's face axes, then the edge axes; stops at the first axis that
// separates them (and leaves it in nrw_hint_out). Without `faces`, the edge axes alone (a
// remembered edge contact). `second_a` and `second_b` are the best of each body's other
// faces (for the contact's margin).
struct NrwSat {
    separated: bool,
    best_a: f32,
    best_af: u32,
    second_a: f32,
    best_b: f32,
    best_bf: u32,
    second_b: f32,
    e: NrwEdgeAxis,
}

// Below every separation (the CPU's f32::NEG_INFINITY as a start).
const NRW_LOWEST: f32 = -3.4028235e38;

// The full test's result computed by a group of lanes (contacts_lanes.wgsl), for the pair
// this thread runs next, and the hint it leaves when separated: nrw_sat takes it, once, in
// place of its own loops when `nrw_lanes_ready`. Never set outside that kernel.
var<private> nrw_lanes_ready: bool = false;
var<private> nrw_lanes_sat: NrwSat;
var<private> nrw_lanes_hint: u32 = 0u;

fn nrw_sat(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>, faces: bool, floor_in: f32) -> NrwSat {
    if faces && nrw_lanes_ready && nrw_hint_in == 0u {
        nrw_lanes_ready = false;
        if nrw_lanes_sat.separated {
            nrw_hint_out = nrw_lanes_hint;
        }
        return nrw_lanes_sat;
    }
    var r: NrwSat;
    r.separated = true;
    r.best_a = NRW_LOWEST;
    r.second_a = NRW_LOWEST;
    r.best_b = NRW_LOWEST;
    r.second_b = NRW_LOWEST;
    if faces {
        if nrw_hint_in != 0u && nrw_hint_separates(a, b, rot, t, nrw_hint_in) {
            nrw_hint_out = nrw_hint_in;
            return r;
        }
        // Face axes of A.
        for (var f = 0u; f < a.num_faces; f += 1u) {
            let fc = nrw_face(a, f);
            let s = nrw_min_b(b, fc.xyz, rot, t) - fc.w;
            if s > 0.0 {
                nrw_hint_out = nrw_hint(0u, f);
                nrw_sep_out = s;
                return r;
            }
            if f == 0u || s > r.best_a {
                r.second_a = r.best_a;
                r.best_a = s;
                r.best_af = f;
            } else if s > r.second_a {
                r.second_a = s;
            }
        }
        // Face axes of B, in A's frame.
        for (var f = 0u; f < b.num_faces; f += 1u) {
            let fc = nrw_face(b, f);
            let n = rot * fc.xyz;
            let s = nrw_min_a(a, n) - (fc.w + dot(n, t));
            if s > 0.0 {
                nrw_hint_out = nrw_hint(1u, f);
                nrw_sep_out = s;
                return r;
            }
            if f == 0u || s > r.best_b {
                r.second_b = r.best_b;
                r.best_b = s;
                r.best_bf = f;
            } else if s > r.second_b {
                r.second_b = s;
            }
        }
    }
    // Edge axes: the cheaper enumeration, by the CPU's cost rule.
    let cost_dirs = a.num_dirs * b.num_dirs * (a.num_vertices + b.num_vertices);
    let cost_tables = a.num_edges * b.num_faces + b.num_edges * a.num_faces + a.num_edges * b.num_edges;
    if cost_dirs <= 2u * cost_tables {
        // Edge axes at or below the best face axis (or, without the face axes, the caller's
        // `floor_in`) change no decision (CPU `edge_search`'s floor).
        var floor = floor_in;
        if faces {
            floor = max(r.best_a, r.best_b);
        }
        r.e = nrw_edge_axes_by_direction(a, b, rot, t, floor);
    } else {
        r.e = nrw_edge_axes_gauss_map(a, b, rot, inv_rot, t);
    }
    if r.e.separated {
        nrw_hint_out = r.e.hint;
        return r;
    }
    r.separated = false;
    return r;
}

// The margin of the full test's decisions for a face contact less the reference face's
// separation (CPU `contact_margin`, see there why): the face serves while its separation
// at the later pose plus this margin exceeds the motion since. `second` the best other
// face of the reference body, `other` the best face of the other body, `largest` the
// larger of the best face and the best edge axis, `ref_b` whether the reference face is B's.
fn nrw_contact_margin(second: f32, other: f32, largest: f32, ref_b: bool, tol: f32) -> f32 {
    var cross = tol - other;
    if ref_b {
        cross = -(other + tol);
    }
    return min(min(-second, cross), tol - largest);
}

// The separation along reference face `face` (of B when ref_b, else of A; in range) at the
// current poses (CPU `reference_separation`): the smallest projection of the other body's
// vertices on its normal, less its offset, as the full test computes it up to rounding.
fn nrw_reference_separation(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>, ref_b: bool, face: u32) -> f32 {
    var p = b;
    var fc = nrw_face(a, face);
    var n = inv_rot * fc.xyz;
    var shift = dot(fc.xyz, t) - fc.w;
    if ref_b {
        p = a;
        fc = nrw_face(b, face);
        n = rot * fc.xyz;
        shift = -(fc.w + dot(n, t));
    }
    var m = 3.0e38;
    for (var i = 0u; i < p.num_vertices; i += 1u) {
        m = min(m, dot(n, nrw_vert(p, i)));
    }
    return m + shift;
}

// Whether point p (in refp's frame) is at least delta inside every face plane of refp.
fn nrw_inside(refp: NrwShape, p: vec3<f32>, delta: f32) -> bool {
    for (var f = 0u; f < refp.num_faces; f += 1u) {
        let fc = nrw_face(refp, f);
        // (Written so that a NaN fails the test too.)
        if !(dot(fc.xyz, p) - fc.w <= -delta) {
            return false;
        }
    }
    return true;
}

// Whether the bodies certainly overlap by more than delta, for a face contact m in the
// reference body's frame (CPU `overlap_certified`): the centroid of the incident points,
// moved back along the normal, is delta inside the reference body.
fn nrw_overlap_certified(refp: NrwShape, m: Manifold, delta: f32) -> bool {
    var c = vec3<f32>(0.0);
    for (var i = 0u; i < m.count; i += 1u) {
        c += m.points[i].xyz - m.normal * (0.5 * m.points[i].w);
    }
    return nrw_inside(refp, c / f32(m.count), delta);
}

// Whether `hint` remembers the contact of a touching pair (CPU `is_contact_hint`; kind
// 2 << 30 is the CPU's separating edge axis, never a contact).
fn nrw_is_contact_hint(hint: u32) -> bool {
    return hint != NO_HINT && (hint & HINT_KIND) != (2u << 30u) && (hint & HINT_CONTACT) != 0u;
}

// The paths of nrw_poly_poly: the full test, the remembered reference face clipped alone,
// the edge axes alone for a remembered edge contact.
const NRW_FULL: u32 = 0u;
const NRW_FACE: u32 = 1u;
const NRW_EDGE: u32 = 2u;

// B's rotation into A's frame and B's offset there, from the orientations and the offset
// d = xb - xa in world space (nrw_poly_poly; contacts_lanes.wgsl, which must see the same
// bits).
struct NrwPose {
    rot: mat3x3<f32>,
    t: vec3<f32>,
    // The relative quaternion `rot` is built from (CPU `Relative::q`).
    q: vec4<f32>,
}

fn nrw_relative_pose(qa: vec4<f32>, qb: vec4<f32>, d: vec3<f32>) -> NrwPose {
    let inv_a = quat_conj(qa);
    let q = quat_mul(inv_a, qb);
    return NrwPose(nrw_mat_from_quat(q), quat_rotate(inv_a, d), q);
}

// How far from 1 a quaternion's squared norm may be for the anchored bound (CPU slack.rs
// `UNIT`).
const NRW_UNIT: f32 = 4e-6;

// An upper bound of how much any separation of the full test at the anchored pose
// (nrw_anchor_in) can have changed at relative quaternion q and offset t, for bodies whose
// radii sum to `radii` (CPU slack.rs `Anchor::moved`, see there why, the same operations
// in the same order); negative when none is known (no anchor, or not unit quaternions).
fn nrw_anchor_moved(q: vec4<f32>, t: vec3<f32>, radii: f32) -> f32 {
    let q0 = nrw_anchor_in[0];
    let t0 = nrw_anchor_in[1].xyz;
    let lever = nrw_anchor_in[1].w;
    let s = abs(dot(q, q) - 1.0);
    let s0 = abs(dot(q0, q0) - 1.0);
    if !(lever >= 0.0 && s < NRW_UNIT && s0 < NRW_UNIT) {
        return -1.0;
    }
    let dt = abs(t - t0);
    let turn = 2.0 * length(q - q0) + 4.0 * s;
    let moved = turn * lever + (dt.x + dt.y + dt.z) * (1.0 + 1e-5);
    return moved + (1e-5 * radii + 4.0 * s0 * lever);
}

// Anchors the contact the full test remembers on relative pose (q, t) (CPU slack.rs
// `Anchor::at`).
fn nrw_anchor_at(a: NrwShape, b: NrwShape, q: vec4<f32>, t: vec3<f32>) {
    let lever = max(b.radius, a.radius + length(t) * (1.0 + 1e-6));
    nrw_anchor_out[0] = q;
    nrw_anchor_out[1] = vec4<f32>(t, lever);
    nrw_anchor_written = true;
}

// Two convex polyhedra (CPU `polyhedron_polyhedron`): what the pair remembers (nrw_mem_in)
// first, while its margin lasts (the remembered face clipped alone if the overlap is
// certain; the edge axes alone for an edge contact, while the best stays above the margin:
// that also rules out a separating axis, with no overlap check, as on the CPU's
// `remembered_edge`), else the full separating-axis test; what the pair
// remembers next is left in nrw_mem_out. Each path's decisions are the full test's, so the
// manifold is too; one call site each for the clipping, the edge manifold and the axes (an
// inlined copy could round differently under FMA contraction, and costs compile time).
fn nrw_poly_poly(a: NrwShape, xa: vec3<f32>, qa: vec4<f32>, b: NrwShape, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    // (Here, not only in `collide`: collide_kind calls this directly, and a thread may run
    // several pairs.)
    nrw_anchor_written = false;
    let d = xb - xa;
    let rs = a.radius + b.radius;
    if dot(d, d) >= rs * rs {
        return nrw_none();
    }
    // Everything in A's frame: B's rotation and offset relative to A.
    let pose = nrw_relative_pose(qa, qb, d);
    let rot = pose.rot;
    let inv_rot = transpose(rot);
    let t = pose.t;
    let scale = max(a.radius, b.radius);
    let tol = 1e-3 * scale;
    // Rounding of the separations and the near-parallel edge axes left out (see sat.rs).
    let eps = 1e-4 * scale;
    // The overlap the remembered paths need: above the rounding of the separations.
    let delta = 2e-5 * (a.radius + b.radius);
    let hint = nrw_mem_in.x;
    var margin = bitcast<f32>(nrw_mem_in.y);
    if nrw_anchored && nrw_is_contact_hint(hint) {
        // The stored margin less twice the motion since the full test (CPU
        // `polyhedron_pair`); none known: no margin (the full test runs).
        let w = nrw_anchor_moved(pose.q, t, a.radius + b.radius);
        margin = select(-3.0e38, margin - 2.0 * w, w >= 0.0);
    }
    let kind = hint & HINT_KIND;
    let face = hint & ~(HINT_KIND | HINT_CONTACT);
    var mode = NRW_FULL;
    if nrw_is_contact_hint(hint) {
        if hint == HINT_EDGE_CONTACT {
            // With no margin left the edge search cannot keep the edge (its best axis is
            // never positive): the full test (CPU `remembered_edge`).
            if margin > 0.0 {
                mode = NRW_EDGE;
            }
        } else if (kind == HINT_FACE_B && face < b.num_faces) || (kind != HINT_FACE_B && face < a.num_faces) {
            // The pair stores twice the margin less the face's separation (CPU
            // `contact_margin`): the face serves while `margin + 2 s > 0`.
            if margin + 2.0 * nrw_reference_separation(a, b, rot, inv_rot, t, kind == HINT_FACE_B, face) > 0.0 {
                mode = NRW_FACE;
            }
        }
    }
    // A remembered edge contact's word is twice its room (CPU `remembered_edge`): the edge
    // serves while `half + best_e > 0`.
    let half = 0.5 * margin;
    // At most two passes: a remembered path, then the full test if it cannot decide.
    for (var attempt = 0u; attempt < 2u; attempt += 1u) {
        var b_ref = kind == HINT_FACE_B;
        var rf = face;
        var keep = vec2<u32>(hint, nrw_mem_in.y);
        if mode != NRW_FACE {
            // Without the face axes, edge axes at or below `-half` fail the edge test.
            let sat = nrw_sat(a, b, rot, inv_rot, t, mode == NRW_FULL, -half);
            if sat.separated {
                if mode == NRW_EDGE {
                    mode = NRW_FULL;
                    continue;
                }
                return nrw_none();
            }
            let e = sat.e;
            let face_best = max(sat.best_a, sat.best_b);
            // An edge contact: the full test's rule, or the remembered edge's margin.
            var edge_wins = e.found && e.s > face_best + tol;
            if mode == NRW_EDGE {
                edge_wins = e.found && e.s + half > 0.0;
            }
            if edge_wins {
                let ev_a = nrw_edge(a, e.ea);
                let ev_b = nrw_edge(b, e.eb);
                let cl = nrw_segment_closest(nrw_vert(a, ev_a.x), nrw_vert(a, ev_a.y), nrw_bv(b, ev_b.x, rot, t), nrw_bv(b, ev_b.y, rot, t));
                if mode == NRW_FULL {
                    // Remembered with twice the room above the best face's level.
                    keep = vec2<u32>(HINT_EDGE_CONTACT, bitcast<u32>(2.0 * (-(face_best + tol) - eps)));
                    nrw_anchor_at(a, b, pose.q, t);
                }
                nrw_mem_out = keep;
                let mid = 0.5 * (cl[0] + cl[1]);
                return nrw_single(quat_rotate(qa, e.axis), quat_rotate(qa, mid) + xa, -e.s);
            }
            if mode == NRW_EDGE {
                mode = NRW_FULL;
                continue;
            }
            // Face contact: prefer A's face unless B's is clearly better.
            b_ref = sat.best_b > sat.best_a + tol;
            var best = sat.best_a;
            var second = sat.second_a;
            var other = sat.best_b;
            rf = sat.best_af;
            var kind_now = 0u;
            if b_ref {
                best = sat.best_b;
                second = sat.second_b;
                other = sat.best_a;
                rf = sat.best_bf;
                kind_now = HINT_FACE_B;
            }
            let largest = max(face_best, select(face_best, e.s, e.found));
            // Twice the margin (CPU `contact_margin`): the face serves while `m_now + 2 s > 0`.
            let m_now = 2.0 * (nrw_contact_margin(second, other, largest, b_ref, tol) - eps);
            keep = vec2<u32>(NO_HINT, 0u);
            if m_now + 2.0 * best > 0.0 {
                keep = vec2<u32>(kind_now | HINT_CONTACT | rf, bitcast<u32>(m_now));
                nrw_anchor_at(a, b, pose.q, t);
            }
        }
        // One call site for the clipping.
        var refp = a;
        var inc = b;
        var inc_m = rot;
        var xr = xa;
        var qr = qa;
        if b_ref {
            // Reference face on B: B's frame, A incident with vertices inv_rot * (v - t).
            refp = b;
            inc = a;
            inc_m = inv_rot;
            xr = xb;
            qr = qb;
        }
        var m = nrw_clip_faces(refp, rf, inc, inc_m, t, b_ref, inc_m);
        if mode == NRW_FACE && (m.count == 0u || !nrw_overlap_certified(refp, m, delta)) {
            mode = NRW_FULL;
            continue;
        }
        if m.count == 0u {
            return m;
        }
        nrw_mem_out = keep;
        m = nrw_to_world(m, xr, qr);
        if b_ref {
            m.normal = -m.normal;
        }
        return m;
    }
    // Not reached: the second pass is the full test, which returns.
    return nrw_none();
}
