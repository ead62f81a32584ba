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
    by_face_base: u32, // shape_u: each face's edges as a 64-bit set (2 words); 0 = none
}

// Separating-axis hint (GPU only): `collide` and `separated` test the axis in nrw_hint_in
// (0 = none) first and leave the separating axis found, if any, in nrw_hint_out. Only speed
// depends on it. Encoding: 1 + (index << 2 | kind), kind 0 = face of A, 1 = face of B,
// 2 = edge directions (index ia * b.num_dirs + ib), 3 = edges (index ea * b.num_edges + eb).
var<private> nrw_hint_in: u32 = 0u;
var<private> nrw_hint_out: u32 = 0u;
// When the separating-axis test stops at an axis that separates: the gap along it, in
// length units (a lower bound of the bodies' distance, up to rounding); 0 when the axis
// found does not say (the Gauss-map edge search's). Read only by `separated`.
var<private> nrw_sep_out: f32 = 0.0;

// What a touching polyhedron pair remembers of its contact, the twin of the CPU's hint word
// and margin (clatter-geom narrow/sat.rs `polyhedron_polyhedron`): `collide` reads
// nrw_mem_in (x: the contact hint, encoded as on the CPU, see contract.rs
// PAIR_MEMORY_CONSTANTS; y: the bits of the margin, less this step's motion already) and
// leaves in nrw_mem_out what the pair remembers after this step (x = NO_HINT: nothing).
// The manifold is the full test's either way; only speed depends on it.
var<private> nrw_mem_in: vec2<u32> = vec2<u32>(NO_HINT, 0u);
var<private> nrw_mem_out: vec2<u32> = vec2<u32>(NO_HINT, 0u);

// Anchored margins (the CPU's pairs with an `EdgeMemory`, clatter-geom narrow/slack.rs
// `Anchor`): with nrw_anchored, nrw_mem_in.y is the margin the full test stored (not less
// this step's motion), and a remembered contact's margin left is that less twice how much
// any separation can have changed since the full test's relative pose, nrw_anchor_in
// (B's relative quaternion, then B's offset in A's frame and the rotation lever; a
// negative lever: none, the full test runs). A full test that remembers a contact leaves
// its pose in nrw_anchor_out and sets nrw_anchor_written. Set by pair_contact (no
// composites); off in the batch tests, as the CPU's narrow phase without a memory.
var<private> nrw_anchored: bool = false;
var<private> nrw_anchor_in: array<vec4<f32>, 2>;
var<private> nrw_anchor_out: array<vec4<f32>, 2>;
var<private> nrw_anchor_written: bool = false;

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
    let apart = min_b > max_a || min_a > max_b;
    if apart {
        // The whole bodies projected: the gap between the extents, per unit of the axis.
        nrw_sep_out = max(min_b - max_a, min_a - max_b) / length(axis);
    }
    return apart;
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
    r.by_face_base = shape_u[h + 10u];
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

// ---------------------------------------------------------------- entry

// Overlap of shape sa at (xa, qa) and shape sb at (xb, qb) (positions of the centres of mass,
// rotations of the principal frames, quaternions x, y, z, w): the CPU's narrow::collide.
// Normal from a to b; count 0 when they do not overlap.
fn collide(sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    nrw_hint_out = 0u;
    nrw_mem_out = vec2<u32>(NO_HINT, 0u);
    nrw_anchor_written = false;
    let a = nrw_shape(sa);
    let b = nrw_shape(sb);
    if a.kind == 0u || b.kind == 0u {
        return nrw_with_sphere(a, xa, qa, b, xb, qb);
    }
    return nrw_poly_poly(a, xa, qa, b, xb, qb);
}

// `collide`'s pairs where a or b is a sphere (the other a sphere or a polyhedron); also the
// whole narrow phase of contacts_split.wgsl's `collide_kind` for PAIR_SPHERES.
fn nrw_with_sphere(a: NrwShape, xa: vec3<f32>, qa: vec4<f32>, b: NrwShape, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    if a.kind == 0u {
        if b.kind == 0u {
            return nrw_sphere_sphere(xa, a.radius, xb, b.radius);
        }
        return nrw_sphere_poly(xa, a.radius, b, xb, qb);
    }
    var m = nrw_sphere_poly(xb, b.radius, a, xa, qa);
    m.normal = -m.normal;
    return m;
}

// Whether shapes sa and sb are certainly apart: their bounding spheres are, or, for two
// polyhedra, an axis of the separating-axis test separates them (the hinted one first; the
// separating axis is left in nrw_hint_out), or, for a sphere and a polyhedron, one of the
// polyhedron's face planes does with room to spare; a lower bound of their distance is left
// in nrw_gap_out. False means "maybe touching": `collide` decides.
// Lets the contact stage find the few pairs that need a manifold with a light kernel.
fn separated(sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> bool {
    nrw_hint_out = 0u;
    let a = nrw_shape(sa);
    let b = nrw_shape(sb);
    let d = xb - xa;
    let rs = a.radius + b.radius;
    nrw_gap_out = 0.0;
    if dot(d, d) >= rs * rs {
        nrw_gap_out = nrw_gap_allowed(length(d) - rs, rs, d);
        return true;
    }
    if a.kind == 0u && b.kind == 0u {
        return false;
    }
    if a.kind == 0u || b.kind == 0u {
        // A sphere against a polyhedron: apart when the sphere's centre lies outside one of
        // the polyhedron's face planes by more than its radius and the rounding allowance
        // (the polyhedron lies inside each plane), so that nrw_sphere_poly, whose best face
        // separation is the same up to rounding, finds no contact either.
        var centre = xa;
        var radius = a.radius;
        var p = b;
        var x = xb;
        var q = qb;
        if b.kind == 0u {
            centre = xb;
            radius = b.radius;
            p = a;
            x = xa;
            q = qa;
        }
        let c = quat_rotate_inv(q, centre - x);
        var best = NRW_LOWEST;
        for (var f = 0u; f < p.num_faces; f += 1u) {
            let fc = nrw_face(p, f);
            best = max(best, dot(fc.xyz, c) - fc.w);
        }
        nrw_gap_out = nrw_gap_allowed(best - radius, rs, d);
        return nrw_gap_out > 0.0;
    }
    let inv_a = quat_conj(qa);
    let rot = nrw_mat_from_quat(quat_mul(inv_a, qb));
    nrw_sep_out = 0.0;
    let apart = nrw_sat(a, b, rot, transpose(rot), quat_rotate(inv_a, d), true, 0.0).separated;
    if apart {
        nrw_gap_out = nrw_gap_allowed(nrw_sep_out, rs, d);
    }
    return apart;
}

// After `separated` found the pair apart: a lower bound of the distance between the two
// bodies at these poses (0 when none is known), for contacts_split.wgsl's `pair_test`.
var<private> nrw_gap_out: f32 = 0.0;

// The gap `s` measured along a separating direction (or between the bounding spheres, radii
// summing to `rs`, centres `d` apart), less what the f32 arithmetic may have got wrong:
// 1e-5 of the radii (the rotations' and projections' rounding, a few ulps of the bodies'
// size, and the stored quaternions' scale, within 1e-6) and 2^-20 of the offset's 1-norm.
// Not positive (or NaN): 0, no bound.
fn nrw_gap_allowed(s: f32, rs: f32, d: vec3<f32>) -> f32 {
    let ad = abs(d);
    let g = s - (1e-5 * rs + (ad.x + ad.y + ad.z) * (1.0 / 1048576.0));
    return select(0.0, g, g > 0.0);
}
