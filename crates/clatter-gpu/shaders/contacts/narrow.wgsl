// The narrow phase, a port of clatter-geom's narrow.rs (`collide`, `collide_plane`): the overlap
// of two shapes, or of a shape and a wall, as a manifold of up to four points. Included after
// common.wgsl; declares bind group 1 (src/shapes.rs), no entry point; private names start nrw_.
// Ties break as on the CPU: `s > best` keeps the first of equals; on nrw_key() (f32 in
// total_cmp order) `>=` keeps the last maximum (max_by) and `<` the first minimum (min_by).

@group(1) @binding(0) var<storage, read> shape_f: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> shape_u: array<u32>;

// Capacity of each half of the clipping array (MAX_CLIP_POINTS in src/shapes.rs).
const NRW_MAX_CLIP: u32 = 64u;
// Words per shape header in shape_u (SHAPE_HEADER_WORDS).
const NRW_HDR: u32 = 12u;

// A contact manifold: unit normal from shape a to shape b (from the wall into the body for
// planes), `count` points (0 = no contact) with the world position in xyz and the overlap
// depth in w. 80 bytes in storage.
struct Manifold {
    normal: vec3<f32>,
    count: u32,
    points: array<vec4<f32>, 4>,
}

// One shape's header: its counts and where its tables start in shape_f / shape_u.
struct NrwShape {
    kind: u32,
    radius: f32,
    num_vertices: u32,
    num_faces: u32,
    num_edges: u32,
    num_dirs: u32, // unique edge directions
    vertex_base: u32, // shape_f: vertices
    face_base: u32, // shape_f: faces (normal, offset)
    arc_base: u32, // shape_f: edge arcs
    dir_base: u32, // shape_f: unique edge directions
    face_loop_base: u32, // shape_u: (first, count) of each face's vertex loop
    edge_base: u32, // shape_u: (v0, v1, f0, f1) per edge
    edge_dir_base: u32, // shape_u: direction index per edge
}

// Separating-axis hint (GPU only): `collide` and `separated` test the axis in nrw_hint_in
// (0 = none) first and leave the separating axis found, if any, in nrw_hint_out. Only speed
// depends on it. Encoding: 1 + (index << 2 | kind), kind 0 = face of A, 1 = face of B,
// 2 = edge directions (index ia * b.num_dirs + ib), 3 = edges (index ea * b.num_edges + eb).
var<private> nrw_hint_in: u32 = 0u;
var<private> nrw_hint_out: u32 = 0u;

fn nrw_hint(kind: u32, index: u32) -> u32 {
    return 1u + ((index << 2u) | kind);
}

// Whether the hinted axis separates A and B (B in A's frame by rot, t): both bodies
// projected on it, a gap between the intervals.
fn nrw_hint_separates(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, t: vec3<f32>, hint: u32) -> bool {
    let code = hint - 1u;
    let kind = code & 3u;
    let index = code >> 2u;
    var axis = vec3<f32>(0.0);
    if kind == 0u {
        if index >= a.num_faces {
            return false;
        }
        axis = nrw_face(a, index).xyz;
    } else if kind == 1u {
        if index >= b.num_faces {
            return false;
        }
        axis = rot * nrw_face(b, index).xyz;
    } else if kind == 2u {
        if b.num_dirs == 0u || index >= a.num_dirs * b.num_dirs {
            return false;
        }
        axis = cross(shape_f[a.dir_base + index / b.num_dirs].xyz, rot * shape_f[b.dir_base + index % b.num_dirs].xyz);
    } else {
        if b.num_edges == 0u || index >= a.num_edges * b.num_edges {
            return false;
        }
        let e_a = nrw_edge(a, index / b.num_edges);
        let e_b = nrw_edge(b, index % b.num_edges);
        axis = cross(nrw_vert(a, e_a.y) - nrw_vert(a, e_a.x), rot * (nrw_vert(b, e_b.y) - nrw_vert(b, e_b.x)));
    }
    if dot(axis, axis) == 0.0 {
        return false;
    }
    let min_a = nrw_min_a(a, axis);
    let max_a = nrw_max_a(a, axis);
    let min_b = nrw_min_b(b, axis, rot, t);
    let max_b = nrw_max_b(b, axis, rot, t);
    return min_b > max_a || min_a > max_b;
}

// Scratch for clipping and reduction: NRW_MAX_CLIP points (xyz, depth in w). Two separate
// arrays (polygon and output) compile much faster on llvmpipe than one twice as long.
alias NrwBuf = array<vec4<f32>, 64>;

fn nrw_shape(s: u32) -> NrwShape {
    let h = s * NRW_HDR;
    var r: NrwShape;
    r.kind = shape_u[h];
    r.radius = bitcast<f32>(shape_u[h + 1u]);
    r.num_vertices = shape_u[h + 2u];
    r.num_faces = shape_u[h + 3u];
    r.num_edges = shape_u[h + 4u];
    r.num_dirs = shape_u[h + 5u];
    r.vertex_base = shape_u[h + 6u];
    r.face_base = r.vertex_base + r.num_vertices;
    r.arc_base = r.face_base + r.num_faces;
    r.dir_base = r.arc_base + r.num_edges;
    r.face_loop_base = shape_u[h + 7u];
    r.edge_base = shape_u[h + 8u];
    r.edge_dir_base = shape_u[h + 9u];
    return r;
}

// Whether shape s is a sphere (else a convex polyhedron).
fn shape_is_sphere(s: u32) -> bool {
    return shape_u[s * NRW_HDR] == 0u;
}

// Bounding-sphere radius of shape s about its centre of mass (the sphere's radius).
fn shape_radius(s: u32) -> f32 {
    return bitcast<f32>(shape_u[s * NRW_HDR + 1u]);
}

fn nrw_vert(p: NrwShape, i: u32) -> vec3<f32> {
    return shape_f[p.vertex_base + i].xyz;
}

// Face f: outward normal in xyz, plane offset in w.
fn nrw_face(p: NrwShape, f: u32) -> vec4<f32> {
    return shape_f[p.face_base + f];
}

fn nrw_loop_first(p: NrwShape, f: u32) -> u32 {
    return shape_u[p.face_loop_base + 2u * f];
}

fn nrw_loop_len(p: NrwShape, f: u32) -> u32 {
    return shape_u[p.face_loop_base + 2u * f + 1u];
}

// Edge e: vertices (x, y) and adjacent faces (z, w).
fn nrw_edge(p: NrwShape, e: u32) -> vec4<u32> {
    let b = p.edge_base + 4u * e;
    return vec4<u32>(shape_u[b], shape_u[b + 1u], shape_u[b + 2u], shape_u[b + 3u]);
}

// f32 mapped to i32 so that integer order is Rust's f32::total_cmp order.
fn nrw_key(x: f32) -> i32 {
    let i = bitcast<i32>(x);
    return i ^ i32(u32(i >> 31u) >> 1u);
}

// Rust's f32::signum: 1 for +0 and positives, -1 for -0 and negatives.
fn nrw_signum(x: f32) -> f32 {
    return select(1.0, -1.0, (bitcast<u32>(x) >> 31u) == 1u);
}

// glam's Mat3::from_quat.
fn nrw_mat_from_quat(q: vec4<f32>) -> mat3x3<f32> {
    let x2 = q.x + q.x;
    let y2 = q.y + q.y;
    let z2 = q.z + q.z;
    let xx = q.x * x2;
    let xy = q.x * y2;
    let xz = q.x * z2;
    let yy = q.y * y2;
    let yz = q.y * z2;
    let zz = q.z * z2;
    let wx = q.w * x2;
    let wy = q.w * y2;
    let wz = q.w * z2;
    return mat3x3<f32>(
        vec3<f32>(1.0 - (yy + zz), xy + wz, xz - wy),
        vec3<f32>(xy - wz, 1.0 - (xx + zz), yz + wx),
        vec3<f32>(xz + wy, yz - wx, 1.0 - (xx + yy)),
    );
}

fn nrw_none() -> Manifold {
    var m: Manifold;
    m.normal = vec3<f32>(0.0);
    m.count = 0u;
    return m;
}

fn nrw_single(normal: vec3<f32>, point: vec3<f32>, depth: f32) -> Manifold {
    var m = nrw_none();
    m.normal = normal;
    m.count = 1u;
    m.points[0] = vec4<f32>(point, depth);
    return m;
}

fn nrw_to_world(m_in: Manifold, x: vec3<f32>, q: vec4<f32>) -> Manifold {
    var m = m_in;
    m.normal = quat_rotate(q, m.normal);
    for (var i = 0u; i < m.count; i += 1u) {
        m.points[i] = vec4<f32>(quat_rotate(q, m.points[i].xyz) + x, m.points[i].w);
    }
    return m;
}

// ---------------------------------------------------------------- spheres

fn nrw_sphere_sphere(ca: vec3<f32>, ra: f32, cb: vec3<f32>, rb: f32) -> Manifold {
    let d = cb - ca;
    let dist2 = dot(d, d);
    let rsum = ra + rb;
    if dist2 >= rsum * rsum {
        return nrw_none();
    }
    let dist = sqrt(dist2);
    var normal = vec3<f32>(0.0, 0.0, 1.0);
    if dist > 1e-12 * rsum {
        normal = d / dist;
    }
    let depth = rsum - dist;
    return nrw_single(normal, ca + normal * (ra - 0.5 * depth), depth);
}

fn nrw_closest_on_segment(a: vec3<f32>, b: vec3<f32>, x: vec3<f32>) -> vec3<f32> {
    let ab = b - a;
    let len2 = dot(ab, ab);
    if len2 <= 0.0 {
        return a;
    }
    return a + ab * clamp(dot(x - a, ab) / len2, 0.0, 1.0);
}

// Closest point of face f's polygon to x (local frame).
fn nrw_closest_on_face(p: NrwShape, f: u32, x: vec3<f32>) -> vec3<f32> {
    let face = nrw_face(p, f);
    let n = face.xyz;
    let proj = x - n * (dot(n, x) - face.w);
    let first = nrw_loop_first(p, f);
    let len = nrw_loop_len(p, f);
    var inside = true;
    for (var k = 0u; k < len; k += 1u) {
        let a = nrw_vert(p, shape_u[first + k]);
        let b = nrw_vert(p, shape_u[first + (k + 1u) % len]);
        if dot(cross(b - a, proj - a), n) < 0.0 {
            inside = false;
            break;
        }
    }
    if inside {
        return proj;
    }
    var best = proj;
    var best_d = 0.0;
    var found = false;
    for (var k = 0u; k < len; k += 1u) {
        let a = nrw_vert(p, shape_u[first + k]);
        let b = nrw_vert(p, shape_u[first + (k + 1u) % len]);
        let q = nrw_closest_on_segment(a, b, x);
        let d = dot(q - x, q - x);
        if !found || d < best_d {
            found = true;
            best_d = d;
            best = q;
        }
    }
    return best;
}

// Sphere (centre, radius) against polyhedron p at (x, q); normal from sphere to polyhedron.
fn nrw_sphere_poly(centre: vec3<f32>, radius: f32, p: NrwShape, x: vec3<f32>, q: vec4<f32>) -> Manifold {
    let c = quat_rotate_inv(q, centre - x);
    let rr = p.radius + radius;
    if dot(c, c) >= rr * rr {
        return nrw_none();
    }
    var best_face = 0u;
    var best_sep = 0.0;
    for (var f = 0u; f < p.num_faces; f += 1u) {
        let fc = nrw_face(p, f);
        let s = dot(fc.xyz, c) - fc.w;
        if f == 0u || s > best_sep {
            best_sep = s;
            best_face = f;
        }
    }
    if best_sep >= radius {
        return nrw_none();
    }
    var surface: vec3<f32>;
    var n_local: vec3<f32>;
    var depth: f32;
    if best_sep <= 0.0 {
        // Centre inside: push out through the nearest face.
        let n = nrw_face(p, best_face).xyz;
        surface = c - n * best_sep;
        n_local = -n;
        depth = radius - best_sep;
    } else {
        var qq = c;
        var best_d2 = 0.0;
        var found = false;
        for (var f = 0u; f < p.num_faces; f += 1u) {
            let fc = nrw_face(p, f);
            if dot(fc.xyz, c) - fc.w > 0.0 {
                let cand = nrw_closest_on_face(p, f, c);
                let d2 = dot(cand - c, cand - c);
                if !found || d2 < best_d2 {
                    found = true;
                    best_d2 = d2;
                    qq = cand;
                }
            }
        }
        if !found {
            return nrw_none();
        }
        let dist = sqrt(best_d2);
        if dist >= radius {
            return nrw_none();
        }
        if dist > 1e-12 {
            n_local = (qq - c) / dist;
        } else {
            n_local = -nrw_face(p, best_face).xyz;
        }
        surface = qq;
        depth = radius - dist;
    }
    let deepest = c + n_local * radius;
    let mid = 0.5 * (surface + deepest);
    return nrw_single(quat_rotate(q, n_local), quat_rotate(q, mid) + x, depth);
}

// ---------------------------------------------------------------- reduction

fn nrw_area(p: vec3<f32>, q: vec3<f32>, r: vec3<f32>, normal: vec3<f32>) -> f32 {
    return dot(cross(q - p, r - p), normal);
}

// Where nrw_reduce finds its candidate points: `count` clipped points in a buffer, or the
// `count` vertices of polyhedron p tested against a wall (nrw_plane_pt), recomputed on each
// pass rather than gathered (a private array costs much shader compile time on llvmpipe).
struct NrwPatch {
    on_wall: bool,
    count: u32,
    p: NrwShape,
    n_local: vec3<f32>,
    centre_height: f32,
    x: vec3<f32>,
    q: vec4<f32>,
}

// Candidate i of the patch: point in xyz, depth in w (w <= 0: not a candidate).
fn nrw_patch_pt(src: NrwPatch, buf: ptr<function, NrwBuf>, i: u32, normal: vec3<f32>) -> vec4<f32> {
    if src.on_wall {
        return nrw_plane_pt(src.p, i, src.n_local, src.centre_height, normal, src.x, src.q);
    }
    return (*buf)[i];
}

// Keeps at most four of the patch's points: the deepest, the one furthest from it, the one
// making the largest triangle, then the one adding the most area (CPU `reduce`). Candidate
// indices follow the CPU's point order, and `>=` on nrw_key keeps the last of equal maxima.
fn nrw_reduce(src: NrwPatch, buf: ptr<function, NrwBuf>, normal: vec3<f32>) -> Manifold {
    var m = nrw_none();
    m.normal = normal;
    var count = 0u;
    for (var i = 0u; i < src.count; i += 1u) {
        let pt = nrw_patch_pt(src, buf, i, normal);
        if pt.w > 0.0 {
            if count < 4u {
                m.points[count] = pt;
            }
            count += 1u;
        }
    }
    if count <= 4u {
        m.count = count;
        return m;
    }
    var a = 0u;
    var ka = 0;
    var first = true;
    for (var i = 0u; i < src.count; i += 1u) {
        let pt = nrw_patch_pt(src, buf, i, normal);
        if pt.w > 0.0 {
            let k = nrw_key(pt.w);
            if first || k >= ka {
                first = false;
                ka = k;
                a = i;
            }
        }
    }
    let pa4 = nrw_patch_pt(src, buf, a, normal);
    let pa = pa4.xyz;
    var b = 0u;
    var kb = 0;
    first = true;
    for (var i = 0u; i < src.count; i += 1u) {
        let pt = nrw_patch_pt(src, buf, i, normal);
        if pt.w > 0.0 {
            let d = pt.xyz - pa;
            let k = nrw_key(dot(d, d));
            if first || k >= kb {
                first = false;
                kb = k;
                b = i;
            }
        }
    }
    let pb4 = nrw_patch_pt(src, buf, b, normal);
    let pb = pb4.xyz;
    var c = 0u;
    var kc = 0;
    first = true;
    for (var i = 0u; i < src.count; i += 1u) {
        let pt = nrw_patch_pt(src, buf, i, normal);
        if pt.w > 0.0 {
            let k = nrw_key(abs(nrw_area(pa, pb, pt.xyz, normal)));
            if first || k >= kc {
                first = false;
                kc = k;
                c = i;
            }
        }
    }
    let pc4 = nrw_patch_pt(src, buf, c, normal);
    let pc = pc4.xyz;
    let sign = nrw_signum(nrw_area(pa, pb, pc, normal));
    var d = 0u;
    var kd = 0;
    var found = false;
    for (var i = 0u; i < src.count; i += 1u) {
        if i == a || i == b || i == c {
            continue;
        }
        let pt = nrw_patch_pt(src, buf, i, normal);
        if pt.w > 0.0 {
            let g = max(max(-sign * nrw_area(pa, pb, pt.xyz, normal), -sign * nrw_area(pb, pc, pt.xyz, normal)), -sign * nrw_area(pc, pa, pt.xyz, normal));
            let k = nrw_key(g);
            if !found || k >= kd {
                found = true;
                kd = k;
                d = i;
            }
        }
    }
    // idx = [a, b, c, d?] with consecutive duplicates removed (Vec::dedup).
    m.points[0] = pa4;
    var n = 1u;
    var last = a;
    if b != last {
        m.points[n] = pb4;
        n += 1u;
        last = b;
    }
    if c != last {
        m.points[n] = pc4;
        n += 1u;
        last = c;
    }
    if found && d != last {
        m.points[n] = nrw_patch_pt(src, buf, d, normal);
        n += 1u;
    }
    m.count = n;
    return m;
}

// ---------------------------------------------------------------- wall planes

// Shape s at (x, q) against the wall `dot(n, p) <= offset` (solid side); the normal points
// from the wall into the body (the plane's normal).
fn collide_plane(n: vec3<f32>, offset: f32, s: u32, x: vec3<f32>, q: vec4<f32>) -> Manifold {
    let p = nrw_shape(s);
    let centre_height = dot(n, x) - offset;
    if p.kind == 0u {
        let depth = p.radius - centre_height;
        if depth <= 0.0 {
            return nrw_none();
        }
        return nrw_single(n, x - n * (p.radius - 0.5 * depth), depth);
    }
    if centre_height >= p.radius {
        return nrw_none();
    }
    // The vertices below the wall; nrw_reduce reads no buffer for them.
    let src = NrwPatch(true, p.num_vertices, p, quat_rotate_inv(q, n), centre_height, x, q);
    var unused: NrwBuf;
    return nrw_reduce(src, &unused, n);
}

// Vertex i of p against the wall: world point moved halfway through the overlap in xyz,
// depth in w (w <= 0: the vertex is not below the wall).
fn nrw_plane_pt(p: NrwShape, i: u32, n_local: vec3<f32>, centre_height: f32, n: vec3<f32>, x: vec3<f32>, q: vec4<f32>) -> vec4<f32> {
    let v = nrw_vert(p, i);
    let h = dot(n_local, v) + centre_height;
    if !(h < 0.0) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(quat_rotate(q, v) + x - n * (0.5 * h), -h);
}

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

// Edge axes over edge pairs whose Gauss-map arcs cross (CPU `edge_axes_gauss_map`; the
// CPU's two product tables are recomputed per pair).
fn nrw_edge_axes_gauss_map(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>) -> NrwEdgeAxis {
    var r: NrwEdgeAxis;
    r.s = 0.0;
    r.ea = 0u;
    r.eb = 0u;
    r.axis = vec3<f32>(0.0);
    r.found = false;
    r.separated = false;
    r.hint = 0u;
    for (var ea = 0u; ea < a.num_edges; ea += 1u) {
        let e_a = nrw_edge(a, ea);
        let arc_a = inv_rot * shape_f[a.arc_base + ea].xyz;
        let pa0 = nrw_vert(a, e_a.x);
        let da = nrw_vert(a, e_a.y) - pa0;
        let na0 = nrw_face(a, e_a.z).xyz;
        let na1 = nrw_face(a, e_a.w).xyz;
        for (var eb = 0u; eb < b.num_edges; eb += 1u) {
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
                r.separated = true;
                r.hint = nrw_hint(3u, ea * b.num_edges + eb);
                return r;
            }
            if !r.found || s > r.s {
                r.found = true;
                r.s = s;
                r.ea = ea;
                r.eb = eb;
                r.axis = axis;
            }
        }
    }
    return r;
}

// Edge axes over pairs of unique edge directions, projecting both bodies (CPU
// `edge_axes_by_direction`), then the supporting edges of the best pair.
fn nrw_edge_axes_by_direction(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, t: vec3<f32>) -> NrwEdgeAxis {
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
            let min_a = nrw_min_a(a, axis);
            let max_a = nrw_max_a(a, axis);
            let min_b = nrw_min_b(b, axis, rot, t);
            let max_b = nrw_max_b(b, axis, rot, t);
            var s = min_a - max_b;
            var sa = -axis;
            if min_b - max_a >= min_a - max_b {
                s = min_b - max_a;
                sa = axis;
            }
            if s > 0.0 {
                r.separated = true;
                r.hint = nrw_hint(2u, ia * b.num_dirs + ib);
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
    var ha = 0.0;
    var fa = false;
    for (var e = 0u; e < a.num_edges; e += 1u) {
        if shape_u[a.edge_dir_base + e] == ia_best {
            let ev = nrw_edge(a, e);
            let h = dot(r.axis, nrw_vert(a, ev.x) + nrw_vert(a, ev.y));
            if !fa || h > ha {
                fa = true;
                ha = h;
                r.ea = e;
            }
        }
    }
    var hb = 0.0;
    var fb = false;
    for (var e = 0u; e < b.num_edges; e += 1u) {
        if shape_u[b.edge_dir_base + e] == ib_best {
            let ev = nrw_edge(b, e);
            let h = dot(r.axis, nrw_bv(b, ev.x, rot, t) + nrw_bv(b, ev.y, rot, t));
            if !fb || h < hb {
                fb = true;
                hb = h;
                r.eb = e;
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
// separates them (and leaves it in nrw_hint_out).
struct NrwSat {
    separated: bool,
    best_a: f32,
    best_af: u32,
    best_b: f32,
    best_bf: u32,
    e: NrwEdgeAxis,
}

fn nrw_sat(a: NrwShape, b: NrwShape, rot: mat3x3<f32>, inv_rot: mat3x3<f32>, t: vec3<f32>) -> NrwSat {
    var r: NrwSat;
    r.separated = true;
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
            return r;
        }
        if f == 0u || s > r.best_a {
            r.best_a = s;
            r.best_af = f;
        }
    }
    // Face axes of B, in A's frame.
    for (var f = 0u; f < b.num_faces; f += 1u) {
        let fc = nrw_face(b, f);
        let n = rot * fc.xyz;
        let s = nrw_min_a(a, n) - (fc.w + dot(n, t));
        if s > 0.0 {
            nrw_hint_out = nrw_hint(1u, f);
            return r;
        }
        if f == 0u || s > r.best_b {
            r.best_b = s;
            r.best_bf = f;
        }
    }
    // Edge axes: the cheaper enumeration, by the CPU's cost rule.
    let cost_dirs = a.num_dirs * b.num_dirs * (a.num_vertices + b.num_vertices);
    let cost_tables = a.num_edges * b.num_faces + b.num_edges * a.num_faces + a.num_edges * b.num_edges;
    if cost_dirs <= 2u * cost_tables {
        r.e = nrw_edge_axes_by_direction(a, b, rot, t);
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

// Two convex polyhedra: the full separating-axis test (CPU `polyhedron_polyhedron` without a
// hint, i.e. `sat_full`).
fn nrw_poly_poly(a: NrwShape, xa: vec3<f32>, qa: vec4<f32>, b: NrwShape, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    let d = xb - xa;
    let rs = a.radius + b.radius;
    if dot(d, d) >= rs * rs {
        return nrw_none();
    }
    // Everything in A's frame: B's rotation and offset relative to A.
    let inv_a = quat_conj(qa);
    let rot = nrw_mat_from_quat(quat_mul(inv_a, qb));
    let inv_rot = transpose(rot);
    let t = quat_rotate(inv_a, d);
    let sat = nrw_sat(a, b, rot, inv_rot, t);
    if sat.separated {
        return nrw_none();
    }
    let best_a = sat.best_a;
    let best_af = sat.best_af;
    let best_b = sat.best_b;
    let best_bf = sat.best_bf;
    let e = sat.e;
    let scale = max(a.radius, b.radius);
    let face_best = max(best_a, best_b);
    let tol = 1e-3 * scale;
    if e.found && e.s > face_best + tol {
        let ev_a = nrw_edge(a, e.ea);
        let ev_b = nrw_edge(b, e.eb);
        let cl = nrw_segment_closest(nrw_vert(a, ev_a.x), nrw_vert(a, ev_a.y), nrw_bv(b, ev_b.x, rot, t), nrw_bv(b, ev_b.y, rot, t));
        let mid = 0.5 * (cl[0] + cl[1]);
        return nrw_single(quat_rotate(qa, e.axis), quat_rotate(qa, mid) + xa, -e.s);
    }
    // Face contact: prefer A's face unless B's is clearly better. One call site for the
    // clipping (each inlined copy of its private array costs compile time).
    let b_ref = best_b > best_a + tol;
    var refp = a;
    var inc = b;
    var rf = best_af;
    var inc_m = rot;
    var xr = xa;
    var qr = qa;
    if b_ref {
        // Reference face on B: B's frame, A incident with vertices inv_rot * (v - t).
        refp = b;
        inc = a;
        rf = best_bf;
        inc_m = inv_rot;
        xr = xb;
        qr = qb;
    }
    var m = nrw_clip_faces(refp, rf, inc, inc_m, t, b_ref, inc_m);
    if m.count == 0u {
        return m;
    }
    m = nrw_to_world(m, xr, qr);
    if b_ref {
        m.normal = -m.normal;
    }
    return m;
}

// ---------------------------------------------------------------- entry

// Overlap of shape sa at (xa, qa) and shape sb at (xb, qb) (positions of the centres of mass,
// rotations of the principal frames, quaternions x, y, z, w): the CPU's narrow::collide.
// Normal from a to b; count 0 when they do not overlap.
fn collide(sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    nrw_hint_out = 0u;
    let a = nrw_shape(sa);
    let b = nrw_shape(sb);
    if a.kind == 0u {
        if b.kind == 0u {
            return nrw_sphere_sphere(xa, a.radius, xb, b.radius);
        }
        return nrw_sphere_poly(xa, a.radius, b, xb, qb);
    }
    if b.kind == 0u {
        var m = nrw_sphere_poly(xb, b.radius, a, xa, qa);
        m.normal = -m.normal;
        return m;
    }
    return nrw_poly_poly(a, xa, qa, b, xb, qb);
}

// Whether shapes sa and sb are certainly apart: their bounding spheres are, or, for two
// polyhedra, an axis of the separating-axis test separates them (the hinted one first; the
// separating axis is left in nrw_hint_out). False means "maybe touching": `collide` decides.
// Lets the contact stage find the few pairs that need a manifold with a light kernel.
fn separated(sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> bool {
    nrw_hint_out = 0u;
    let a = nrw_shape(sa);
    let b = nrw_shape(sb);
    let d = xb - xa;
    let rs = a.radius + b.radius;
    if dot(d, d) >= rs * rs {
        return true;
    }
    if a.kind == 0u || b.kind == 0u {
        return false;
    }
    let inv_a = quat_conj(qa);
    let rot = nrw_mat_from_quat(quat_mul(inv_a, qb));
    return nrw_sat(a, b, rot, transpose(rot), quat_rotate(inv_a, d)).separated;
}
