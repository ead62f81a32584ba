// Stage **contacts** for the triangle-mesh boundaries (src/mesh.rs), twin of
// crates/clatter/src/step/boundary.rs and clatter-geom's triangle.rs: per body, its candidate
// triangles (from each boundary's grid, ascending by global id), the contact with each
// (sphere: closest feature; polyhedron: mesh_poly.wgsl), ghost contacts at internal edges
// and vertices dropped by their Voronoi regions, face contacts with coplanar triangles merged
// into one plane manifold, the deepest MESH_SLOTS matched to the body's slots and run
// through the contact law. Called by integrate (integrate.wgsl), where the force is summed;
// each body writes only its own slots. Private names start mesh_.

// Header word k of boundary b in shape_u (src/mesh.rs `pack`).
fn mesh_h(b: u32, k: u32) -> u32 {
    return shape_u[params.mesh_base + MESH_HDR * b + k];
}

fn mesh_hf(b: u32, k: u32) -> f32 {
    return bitcast<f32>(mesh_h(b, k));
}

fn mesh_hv(b: u32, k: u32) -> vec3<f32> {
    return vec3<f32>(mesh_hf(b, k), mesh_hf(b, k + 1u), mesh_hf(b, k + 2u));
}

// Vertex v of boundary b (mesh frame).
fn mesh_vert(b: u32, v: u32) -> vec3<f32> {
    return shape_f[mesh_h(b, 4u) + v].xyz;
}

// Vertex k of triangle t of boundary b (its index).
fn mesh_tri_vert(b: u32, t: u32, k: u32) -> u32 {
    return shape_u[mesh_h(b, 6u) + 3u * t + k];
}

// Boundary b's pose at the current step: the CPU's `Boundary::pose`.
fn mesh_pose(b: u32) -> MeshPose {
    let kind = mesh_h(b, 0u);
    let u = mesh_u(b);
    if kind == 1u {
        return MeshPose(vec4<f32>(0.0, 0.0, 0.0, 1.0), mesh_hv(b, 21u) * mesh_elapsed(b, u));
    }
    if kind == 2u {
        let rate = mesh_hf(b, 28u);
        if !(rate > 0.0) {
            return MeshPose(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec3<f32>(0.0));
        }
        var angle = 0.0;
        if ds_positive(u) {
            if ds_lt(u, mesh_ds(mesh_clock(b) + 7u)) {
                angle = turn_angle(rate, u);
            } else {
                angle = mesh_hf(b, 36u);
            }
        }
        return turn_pose(mesh_hv(b, 29u), mesh_hv(b, 24u), angle);
    }
    return MeshPose(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec3<f32>(0.0));
}

// The motion of boundary b's surface (side a of the law): the CPU's `Boundary::motion_at`.
fn mesh_motion(b: u32) -> BodyMotion {
    let u = mesh_u(b);
    let zero = vec3<f32>(0.0);
    let moving = (u.x > 0.0 || (u.x == 0.0 && u.y >= 0.0)) && ds_lt(u, mesh_ds(mesh_clock(b) + 7u));
    let kind = mesh_h(b, 0u);
    if !moving || kind == 0u {
        return BodyMotion(zero, zero, zero);
    }
    if kind == 1u {
        return BodyMotion(zero, mesh_hv(b, 21u), zero);
    }
    return BodyMotion(mesh_hv(b, 24u), zero, mesh_hv(b, 21u));
}

// An upper bound of how far boundary b moved since the last rebuild, at the end of this
// step: the CPU's `Boundary::displacement_bound(rebuild_time, time)`.
fn mesh_moved() -> f32 {
    var worst = 0.0;
    for (var b = 0u; b < params.num_boundaries; b++) {
        let d = abs(mesh_elapsed(b, mesh_u_next(b)) - mesh_word_f(mesh_clock(b) + 4u));
        let w = mesh_hv(b, 21u);
        let kind = mesh_h(b, 0u);
        var m = 0.0;
        if kind == 1u {
            m = sqrt(dot(w, w)) * d * 1.000001;
        } else if kind == 2u {
            m = sqrt(dot(w, w)) * d * mesh_hf(b, 27u) * 1.000001;
        }
        worst = max(worst, m);
    }
    return worst;
}

// ---------------------------------------------------------------- triangles

// Features as codes: 0 face, 1 + k edge k (vertex k to k + 1), 4 + k vertex k.
const MESH_FACE: u32 = 0u;

struct MeshClosest {
    q: vec3<f32>,
    feature: u32,
}

// The point of triangle (a, b, c) closest to p and its feature: triangle.rs
// `closest_on_triangle` (Ericson 5.1.5).
fn mesh_closest(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> MeshClosest {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return MeshClosest(a, 4u);
    }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return MeshClosest(b, 5u);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return MeshClosest(a + ab * v, 1u);
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return MeshClosest(c, 6u);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return MeshClosest(a + ac * w, 3u);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return MeshClosest(b + (c - b) * w, 2u);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    return MeshClosest(a + ab * v + ac * w, MESH_FACE);
}

// What one piece touching one triangle found (triangle.rs `TriContact`): kind 0 none,
// 1 face (the plane `normal`, `offset`), 2 an edge or vertex `feature` with a one-point
// manifold (normal, point, depth).
struct MeshHit {
    kind: u32,
    feature: u32,
    normal: vec3<f32>,
    offset: f32,
    point: vec3<f32>,
    depth: f32,
}

fn mesh_no_hit() -> MeshHit {
    return MeshHit(0u, 0u, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0);
}

// The triangle's unit normal turned towards `centre` (triangle.rs `facing`).
fn mesh_facing(a: vec3<f32>, normal: vec3<f32>, centre: vec3<f32>) -> vec3<f32> {
    return select(-normal, normal, dot(normal, centre - a) >= 0.0);
}

fn mesh_face_hit(n: vec3<f32>, a: vec3<f32>) -> MeshHit {
    return MeshHit(1u, MESH_FACE, n, dot(n, a), vec3<f32>(0.0), 0.0);
}

// A sphere against a triangle: triangle.rs `sphere_triangle`.
fn mesh_sphere_tri(centre: vec3<f32>, radius: f32, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>,
                   normal: vec3<f32>) -> MeshHit {
    let cl = mesh_closest(centre, a, b, c);
    let d = centre - cl.q;
    let dist2 = dot(d, d);
    if dist2 >= radius * radius {
        return mesh_no_hit();
    }
    let dist = sqrt(dist2);
    if cl.feature == MESH_FACE || abs(dot(d, normal)) >= (1.0 - 1e-6) * dist {
        return mesh_face_hit(mesh_facing(a, normal, centre), a);
    }
    var n = mesh_facing(a, normal, centre);
    if dist > 1e-12 * radius {
        n = d / dist;
    }
    let depth = radius - dist;
    return MeshHit(2u, cl.feature, n, 0.0, 0.5 * (cl.q + (centre - n * radius)), depth);
}

// Whether x projects inside triangle (a, b, c) with relative tolerance tol: triangle.rs
// `projects_inside`.
fn mesh_projects_inside(x: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, tol: f32) -> bool {
    var n = cross(b - a, c - a);
    n = n / max(sqrt(dot(n, n)), 1.17549435e-38);
    for (var k = 0u; k < 3u; k++) {
        var p = a;
        var q = b;
        if k == 1u {
            p = b;
            q = c;
        } else if k == 2u {
            p = c;
            q = a;
        }
        let e = q - p;
        if dot(cross(e, x - p), n) < -tol * dot(e, e) {
            return false;
        }
    }
    return true;
}

// glam's normalize_or_zero.
fn mesh_normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / sqrt(dot(v, v));
    if rcp > 0.0 && rcp <= 3.4028235e38 {
        return v * rcp;
    }
    return vec3<f32>(0.0);
}

const MESH_REGION_TOL: f32 = 1e-5;

// Whether an edge contact on edge k of triangle t of boundary b with unit normal d (mesh
// frame) is in the edge's Voronoi region: `Boundary::edge_region`.
fn mesh_edge_region(b: u32, t: u32, k: u32, d: vec3<f32>) -> bool {
    let other = shape_u[mesh_h(b, 7u) + 3u * t + k];
    if other == NONE {
        return true;
    }
    let ia = mesh_tri_vert(b, t, k);
    let ib = mesh_tri_vert(b, t, (k + 1u) % 3u);
    let va = mesh_vert(b, ia);
    let vb = mesh_vert(b, ib);
    var apex = ia;
    for (var j = 0u; j < 3u; j++) {
        let v = mesh_tri_vert(b, other, j);
        if v != ia && v != ib {
            apex = v;
            break;
        }
    }
    let e = vb - va;
    var u = mesh_normalize_or_zero(cross(shape_f[mesh_h(b, 5u) + other].xyz, e));
    if dot(u, mesh_vert(b, apex) - va) < 0.0 {
        u = -u;
    }
    return dot(d, u) <= MESH_REGION_TOL;
}

// Whether a vertex contact at vertex v with unit normal d (mesh frame) is in the vertex's
// Voronoi region: `Boundary::vertex_region`.
fn mesh_vertex_region(b: u32, v: u32, d: vec3<f32>) -> bool {
    let p = mesh_vert(b, v);
    let ls = mesh_h(b, 8u);
    let links = mesh_h(b, 9u);
    for (var k = shape_u[ls + v]; k < shape_u[ls + v + 1u]; k++) {
        let e = mesh_vert(b, shape_u[links + k]) - p;
        if !(dot(d, e) <= MESH_REGION_TOL * sqrt(dot(e, e))) {
            return false;
        }
    }
    return true;
}

// ---------------------------------------------------------------- candidates

// The body's candidate triangles this step, global ids ascending (boundary b's triangle t
// is mesh_h(b, 3) + t).
var<private> mesh_cands: array<u32, MESH_MAX_CANDS>;
var<private> mesh_ncands: u32;

// The boundary of global triangle id g.
fn mesh_boundary_of(g: u32) -> u32 {
    var b = 0u;
    while b + 1u < params.num_boundaries && g >= mesh_h(b + 1u, 3u) {
        b++;
    }
    return b;
}

// First index in keys[lo..hi) (shape_u) equal to key, or NONE.
fn mesh_find_key(base: u32, count: u32, key: u32) -> u32 {
    var lo = 0u;
    var hi = count;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        let k = shape_u[base + mid];
        if k < key {
            lo = mid + 1u;
        } else if k > key {
            hi = mid;
        } else {
            return mid;
        }
    }
    return NONE;
}

// Collects the triangles within `reach` of x (world), ascending by global id: each
// boundary's grid cells around x in its frame, merged (each cell's list is sorted), each
// triangle once, kept when its closest point is within reach. False when more than
// MESH_MAX_CANDS.
fn mesh_gather(x: vec3<f32>, reach: f32) -> bool {
    mesh_ncands = 0u;
    for (var b = 0u; b < params.num_boundaries; b++) {
        let pose = mesh_pose(b);
        let local = turn_rotate(quat_conj(pose.q), x - pose.t);
        let toc = local - mesh_hv(b, 32u);
        let far = mesh_hf(b, 35u) + reach;
        if dot(toc, toc) > far * far {
            continue;
        }
        let cell = mesh_hf(b, 17u);
        let gmin = mesh_hv(b, 18u);
        let dims = vec3<u32>(mesh_h(b, 14u), mesh_h(b, 15u), mesh_h(b, 16u));
        let dimf = vec3<f32>(dims);
        let lo = floor((local - reach - gmin) / cell);
        let hi = floor((local + reach - gmin) / cell);
        if any(hi < vec3<f32>(0.0)) || any(lo >= dimf) {
            continue;
        }
        let l = vec3<u32>(max(lo, vec3<f32>(0.0)));
        let h = vec3<u32>(min(hi, dimf - 1.0));
        // The cells' triangle ranges (at most 3 x 3 x 3: the reach is at most half a cell).
        var ranges: array<vec2<u32>, 27>;
        var nr = 0u;
        let keys = mesh_h(b, 10u);
        let nkeys = mesh_h(b, 11u);
        let starts = mesh_h(b, 12u);
        let tris = mesh_h(b, 13u);
        for (var z = l.z; z <= h.z; z++) {
            for (var y = l.y; y <= h.y; y++) {
                for (var xx = l.x; xx <= h.x; xx++) {
                    let c = mesh_find_key(keys, nkeys, (z * dims.y + y) * dims.x + xx);
                    if c != NONE {
                        if nr == 27u {
                            return false;
                        }
                        ranges[nr] = vec2<u32>(tris + shape_u[starts + c], tris + shape_u[starts + c + 1u]);
                        nr++;
                    }
                }
            }
        }
        // Merge: the smallest id above the last one, until none is left.
        var started = false;
        var last = 0u;
        loop {
            var best = NONE;
            for (var r = 0u; r < nr; r++) {
                var at = ranges[r].x;
                while at < ranges[r].y && started && shape_u[at] <= last {
                    at++;
                }
                ranges[r].x = at;
                if at < ranges[r].y {
                    best = min(best, shape_u[at]);
                }
            }
            if best == NONE {
                break;
            }
            started = true;
            last = best;
            let cl = mesh_closest(local, mesh_vert(b, mesh_tri_vert(b, best, 0u)),
                                  mesh_vert(b, mesh_tri_vert(b, best, 1u)),
                                  mesh_vert(b, mesh_tri_vert(b, best, 2u)));
            let d = cl.q - local;
            if dot(d, d) < reach * reach {
                if mesh_ncands == MESH_MAX_CANDS {
                    return false;
                }
                mesh_cands[mesh_ncands] = mesh_h(b, 3u) + best;
                mesh_ncands++;
            }
        }
    }
    return true;
}

// A candidate triangle in the world: its vertices and unit normal at `pose`.
struct MeshTri {
    a: vec3<f32>,
    b: vec3<f32>,
    c: vec3<f32>,
    n: vec3<f32>,
}

fn mesh_world_tri(b: u32, t: u32, pose: MeshPose) -> MeshTri {
    let a = mesh_local(turn_rotate(pose.q, mesh_vert(b, mesh_tri_vert(b, t, 0u))) + pose.t);
    let bb = mesh_local(turn_rotate(pose.q, mesh_vert(b, mesh_tri_vert(b, t, 1u))) + pose.t);
    let c = mesh_local(turn_rotate(pose.q, mesh_vert(b, mesh_tri_vert(b, t, 2u))) + pose.t);
    let n = turn_rotate(pose.q, shape_f[mesh_h(b, 5u) + t].xyz);
    return MeshTri(a, bb, c, n);
}

// Whether candidate triangle `tri` of boundary b supports face group (n, offset) of a
// piece of bounding radius `size`: coplanar with it (the CPU's support filter).
fn mesh_supports(tri: MeshTri, n: vec3<f32>, offset: f32, size: f32) -> bool {
    return abs(dot(tri.n, n)) >= 1.0 - 1e-6 && abs(dot(n, tri.a) - offset) <= 1e-5 * size;
}

// Whether x projects inside a candidate triangle of boundary gb (at `pose`) that supports
// the face group (n, offset): the CPU's `on_mesh`.
fn mesh_on_mesh(x: vec3<f32>, gb: u32, pose: MeshPose, n: vec3<f32>, offset: f32, size: f32) -> bool {
    for (var c = 0u; c < mesh_ncands; c++) {
        let g = mesh_cands[c];
        let b = mesh_boundary_of(g);
        if b != gb {
            continue;
        }
        let tri = mesh_world_tri(b, g - mesh_h(b, 3u), pose);
        if mesh_supports(tri, n, offset, size) && mesh_projects_inside(x, tri.a, tri.b, tri.c, 1e-6) {
            return true;
        }
    }
    return false;
}

// The manifold of shape s at (x, q) against face group (n, offset) of boundary gb:
// boundary.rs `plane_manifold`. The polyhedron fallback is mesh_plane_fallback
// (mesh_poly.wgsl).
fn mesh_plane_manifold(s: u32, x: vec3<f32>, q: vec4<f32>, gb: u32, pose: MeshPose, n: vec3<f32>,
                       offset: f32, size: f32) -> Manifold {
    let m = collide_plane(n, offset, s, x, q);
    if m.count == 0u {
        return m;
    }
    var all = true;
    for (var k = 0u; k < m.count; k++) {
        if !mesh_on_mesh(m.points[k].xyz, gb, pose, n, offset, size) {
            all = false;
        }
    }
    if all || shape_is_sphere(s) {
        return m;
    }
    return mesh_plane_fallback(s, x, q, gb, pose, n, offset, size);
}

// ---------------------------------------------------------------- per body

// This step's contacts before the law: manifolds, boundaries and pieces, in the CPU's order
// (piece by piece; MESH_ACC: src/pipeline.rs `composites_const`, room for the MESH_SLOTS kept
// of the earlier pieces and one piece's MESH_MAX_FOUND).
var<private> mesh_found: array<Manifold, MESH_ACC>;
var<private> mesh_found_b: array<u32, MESH_ACC>;
var<private> mesh_found_p: array<u32, MESH_ACC>;
var<private> mesh_nfound: u32;

// Face groups (normal, offset) and their boundaries; edge and vertex contacts.
var<private> mesh_groups: array<vec4<f32>, MESH_MAX_FOUND>;
var<private> mesh_groups_b: array<u32, MESH_MAX_FOUND>;
// The rest of each group's offset below f32 (precise.rs, mesh_contacts.rs `FaceGroup::rest`).
var<private> mesh_groups_rest: array<f32, MESH_MAX_FOUND>;
var<private> mesh_feat_n: array<vec4<f32>, MESH_MAX_FOUND>; // normal, depth
var<private> mesh_feat_p: array<vec4<f32>, MESH_MAX_FOUND>; // point, boundary (bits)
var<private> mesh_feat_key: array<vec2<u32>, MESH_MAX_FOUND>;

// Set when a body's contacts outgrow a fixed capacity (the plane fallback's point buffer).
var<private> mesh_overflow: bool;

struct MeshSum {
    f: vec3<f32>,
    t: vec3<f32>,
    touched: u32,
    ok: bool,
}

// f32 mapped to i32 so that integer order is Rust's f32::total_cmp order (narrow.wgsl's
// nrw_key, which the sphere-only narrow phase lacks).
fn mesh_key(x: f32) -> i32 {
    let i = bitcast<i32>(x);
    return i ^ i32(u32(i >> 31u) >> 1u);
}

// The deepest point of a manifold (Manifold::max_depth: 0 when none is deeper).
fn mesh_max_depth(m: Manifold) -> f32 {
    var d = 0.0;
    for (var k = 0u; k < m.count; k++) {
        d = max(d, m.points[k].w);
    }
    return d;
}

// Keeps the deepest MESH_SLOTS of mesh_found[first..mesh_nfound), deepest first, by a stable
// sort (ties keep their order): the CPU's `sort_by(max_depth)` then `truncate`.
fn mesh_keep_deepest(first: u32) {
    for (var k = first + 1u; k < mesh_nfound; k++) {
        let m = mesh_found[k];
        let b = mesh_found_b[k];
        let p = mesh_found_p[k];
        let key = mesh_key(mesh_max_depth(m));
        var j = k;
        while j > first && mesh_key(mesh_max_depth(mesh_found[j - 1u])) < key {
            mesh_found[j] = mesh_found[j - 1u];
            mesh_found_b[j] = mesh_found_b[j - 1u];
            mesh_found_p[j] = mesh_found_p[j - 1u];
            j--;
        }
        mesh_found[j] = m;
        mesh_found_b[j] = b;
        mesh_found_p[j] = p;
    }
    mesh_nfound = min(mesh_nfound, first + MESH_SLOTS);
}

// The first word of body i's slot k in `mesh`.
fn mesh_slot_at(i: u32, k: u32) -> u32 {
    return MESH_GLOBAL + MESH_BSTATE * params.num_boundaries + MESH_SLOT * (MESH_SLOTS * i + k);
}

fn mesh_v3(at: u32) -> vec3<f32> {
    return vec3<f32>(mesh_word_f(at), mesh_word_f(at + 1u), mesh_word_f(at + 2u));
}

fn mesh_set_v3(at: u32, v: vec3<f32>) {
    mesh[at] = bitcast<u32>(v.x);
    mesh[at + 1u] = bitcast<u32>(v.y);
    mesh[at + 2u] = bitcast<u32>(v.z);
}

// Clears body i's slots (a removed body, or one without contacts), writing only when one
// held a contact.
fn mesh_clear(i: u32) {
    for (var k = 0u; k < MESH_SLOTS; k++) {
        let at = mesh_slot_at(i, k);
        if mesh[at + 2u] != 0u {
            for (var w = 0u; w < MESH_SLOT; w++) {
                mesh[at + w] = 0u;
            }
        }
    }
}

// Whether body i had a triangle within its reach at the last rebuild (the CPU's active
// list), after the slots.
fn mesh_active_at(i: u32) -> u32 {
    return mesh_slot_at(params.n, 0u) + i;
}

// The contacts of one convex piece (shape s at (x, q); the body itself unless a composite)
// with the candidate triangles, appended to mesh_found as piece `piece`: boundary.rs
// `piece_contacts` (face contacts merged per plane first, then the edge and vertex contacts
// that are not ghosts; the deepest MESH_SLOTS of them). False when a capacity is exceeded.
fn mesh_piece(s: u32, x: vec3<f32>, q: vec4<f32>, piece: u32) -> bool {
    let size = shape_radius(s);
    let sphere = shape_is_sphere(s);
    var ngroups = 0u;
    var nfeat = 0u;
    var cur = NONE;
    var pose = MeshPose(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec3<f32>(0.0));
    for (var c = 0u; c < mesh_ncands; c++) {
        let g = mesh_cands[c];
        let b = mesh_boundary_of(g);
        let t = g - mesh_h(b, 3u);
        if b != cur {
            cur = b;
            pose = mesh_pose(b);
        }
        let tri = mesh_world_tri(b, t, pose);
        var hit: MeshHit;
        if sphere {
            hit = mesh_sphere_tri(x, size, tri.a, tri.b, tri.c, tri.n);
        } else {
            hit = mesh_poly_tri(s, x, q, tri.a, tri.b, tri.c, tri.n);
        }
        if hit.kind == 1u {
            var same = false;
            for (var k = 0u; k < ngroups; k++) {
                if mesh_groups_b[k] == b && dot(mesh_groups[k].xyz, hit.normal) >= 1.0 - 1e-6
                    && abs(mesh_groups[k].w - hit.offset) <= 1e-5 * size {
                    same = true;
                }
            }
            if !same {
                if ngroups == MESH_MAX_FOUND {
                    return false;
                }
                mesh_groups[ngroups] = vec4<f32>(hit.normal, hit.offset);
                let wa = turn_rotate(pose.q, mesh_vert(b, mesh_tri_vert(b, t, 0u))) + pose.t;
                let lo0 = ds3_add(Ds3(wa, vec3<f32>(0.0)), ds3_neg(mesh_origin)).lo;
                mesh_groups_rest[ngroups] = dot(hit.normal, lo0);
                mesh_groups_b[ngroups] = b;
                ngroups++;
            }
        } else if hit.kind == 2u && hit.feature != MESH_FACE {
            let d = turn_rotate(quat_conj(pose.q), hit.normal);
            var key: vec2<u32>;
            if hit.feature <= 3u {
                let k = hit.feature - 1u;
                if !mesh_edge_region(b, t, k, d) {
                    continue;
                }
                let va = mesh_tri_vert(b, t, k);
                let vc = mesh_tri_vert(b, t, (k + 1u) % 3u);
                key = vec2<u32>(min(va, vc), max(va, vc));
            } else {
                let v = mesh_tri_vert(b, t, hit.feature - 4u);
                if !mesh_vertex_region(b, v, d) {
                    continue;
                }
                key = vec2<u32>(v, NONE);
            }
            var seen = false;
            for (var k = 0u; k < nfeat; k++) {
                if bitcast<u32>(mesh_feat_p[k].w) == b && all(mesh_feat_key[k] == key) {
                    seen = true;
                }
            }
            if seen {
                continue;
            }
            if nfeat == MESH_MAX_FOUND {
                return false;
            }
            mesh_feat_n[nfeat] = vec4<f32>(hit.normal, hit.depth);
            mesh_feat_p[nfeat] = vec4<f32>(hit.point, bitcast<f32>(b));
            mesh_feat_key[nfeat] = key;
            nfeat++;
        }
    }
    // The plane manifolds first, then the edge and vertex contacts (the CPU's order).
    let start = mesh_nfound;
    for (var k = 0u; k < ngroups; k++) {
        let b = mesh_groups_b[k];
        var m = mesh_plane_manifold(s, x, q, b, mesh_pose(b), mesh_groups[k].xyz, mesh_groups[k].w, size);
        for (var p = 0u; p < m.count; p++) {
            m.points[p].w += mesh_groups_rest[k];
        }
        if m.count > 0u {
            if mesh_nfound - start == MESH_MAX_FOUND {
                return false;
            }
            mesh_found[mesh_nfound] = m;
            mesh_found_b[mesh_nfound] = b;
            mesh_found_p[mesh_nfound] = piece;
            mesh_nfound++;
        }
    }
    if mesh_overflow {
        return false;
    }
    for (var k = 0u; k < nfeat; k++) {
        if mesh_nfound - start == MESH_MAX_FOUND {
            return false;
        }
        var m = Manifold();
        m.normal = mesh_feat_n[k].xyz;
        m.count = 1u;
        m.points[0] = vec4<f32>(mesh_feat_p[k].xyz, mesh_feat_n[k].w);
        mesh_found[mesh_nfound] = m;
        mesh_found_b[mesh_nfound] = bitcast<u32>(mesh_feat_p[k].w);
        mesh_found_p[mesh_nfound] = piece;
        mesh_nfound++;
    }
    if mesh_nfound - start > MESH_SLOTS {
        mesh_keep_deepest(start);
    }
    return true;
}

// The body whose mesh contacts are being found: its centre as a pair. Triangles are taken
// relative to it (`mesh_local`) and the body sits at the origin, so a contact keeps the
// precision of its overlap at any coordinate (the CPU's `found_contacts`).
var<private> mesh_origin: Ds3;

// World point `p` relative to `mesh_origin` (subtracted as a pair, then rounded).
fn mesh_local(p: vec3<f32>) -> vec3<f32> {
    return ds3_add(Ds3(p, vec3<f32>(0.0)), ds3_neg(mesh_origin)).hi;
}

// A touching mesh contact slot at word `at`: boundary `b`, piece `p`, the normal, the
// springs and the force the law gave.
fn mesh_write_slot(at: u32, b: u32, p: u32, normal: vec3<f32>, r: LawResult) {
    mesh[at] = b;
    mesh[at + 1u] = p;
    mesh[at + 2u] = 1u;
    mesh[at + 3u] = 0u;
    mesh_set_v3(at + 4u, normal);
    mesh[at + 7u] = bitcast<u32>(r.hist.w);
    mesh_set_v3(at + 8u, r.hist.xyz);
    mesh[at + 11u] = 0u;
    let fr = r.force;
    mesh_set_v3(at + 12u, fr.force_b);
    mesh[at + 15u] = bitcast<u32>(fr.normal_force);
    mesh_set_v3(at + 16u, fr.torque_a);
    mesh[at + 19u] = bitcast<u32>(fr.pad0);
    mesh_set_v3(at + 20u, fr.torque_b);
    mesh[at + 23u] = bitcast<u32>(fr.pad1);
}

// Body i's mesh contacts this step (boundary.rs `body_slots`, `found_contacts`, `assign`):
// the slots written, the force and torque summed in slot order.
fn mesh_contacts(i: u32) -> MeshSum {
    var out = MeshSum(vec3<f32>(0.0), vec3<f32>(0.0), 0u, true);
    let st = statics[i];
    let bd = bodies[i];
    // The candidate search at the rounded position; the contacts relative to it.
    let x_world = bd.position.xyz;
    mesh_origin = body_ds(i);
    let x = vec3<f32>(0.0);
    let q = bd.orientation;
    mesh_overflow = false;
    // At a rebuild the CPU's candidates (within the radius plus the skin), and whether the
    // body has any; between rebuilds only bodies that had some, within the radius plus half
    // the skin (see src/mesh.rs). A composite's radius bounds all its pieces.
    let rebuilding = atomicLoad(&status[ST_REBUILDING]) != 0u;
    if !rebuilding && mesh[mesh_active_at(i)] == 0u {
        mesh_clear(i);
        return out;
    }
    var reach = st.radius + 0.5 * params.skin;
    if rebuilding {
        reach = st.radius + params.skin;
    }
    if !mesh_gather(x_world, reach) {
        out.ok = false;
        return out;
    }
    if rebuilding {
        mesh[mesh_active_at(i)] = select(0u, 1u, mesh_ncands > 0u);
    }
    if mesh_ncands == 0u {
        mesh_clear(i);
        return out;
    }
    // Piece by piece (one unless a composite: pieces.wgsl), each keeping its deepest
    // MESH_SLOTS; over MESH_SLOTS in all, the deepest MESH_SLOTS of them all (the CPU's
    // stable sort of the whole list). Keeping only the deepest MESH_SLOTS of the earlier
    // pieces before the next one gives the same: a contact dropped there has MESH_SLOTS
    // deeper (or as deep and earlier) ones ahead of it, which stay.
    mesh_nfound = 0u;
    var total = 0u;
    var np = 1u;
    if COMPOSITES {
        np = piece_count(st.shape);
    }
    for (var k = 0u; k < np; k++) {
        if mesh_nfound > MESH_SLOTS {
            mesh_keep_deepest(0u);
        }
        let before = mesh_nfound;
        let pc = piece_at(st, k, x, q);
        if !mesh_piece(pc.shape, pc.x, pc.q, k) {
            out.ok = false;
            return out;
        }
        total += mesh_nfound - before;
    }
    if total > MESH_SLOTS {
        mesh_keep_deepest(0u);
    }
    let nf = mesh_nfound;
    // Match each contact to the old slot of its boundary and piece with the closest normal.
    var taken = array<bool, 4>(false, false, false, false);
    var place = array<u32, 4>(NONE, NONE, NONE, NONE);
    for (var c = 0u; c < nf; c++) {
        let m = mesh_found[c];
        let b = mesh_found_b[c];
        let p = mesh_found_p[c];
        var best = SLOT_MATCH_COS;
        var best_k = NONE;
        for (var k = 0u; k < MESH_SLOTS; k++) {
            let at = mesh_slot_at(i, k);
            if mesh[at + 2u] != 0u && !taken[k] && mesh[at] == b && mesh[at + 1u] == p {
                let cosv = dot(mesh_v3(at + 4u), m.normal);
                if cosv >= best {
                    best = cosv;
                    best_k = k;
                }
            }
        }
        if best_k != NONE {
            taken[best_k] = true;
            place[c] = best_k;
        }
    }
    // Springs carried by the matched slots (read before any slot is written).
    var springs: array<vec4<f32>, 4>;
    for (var c = 0u; c < nf; c++) {
        if place[c] == NONE {
            var k = 0u;
            while taken[k] {
                k++;
            }
            taken[k] = true;
            place[c] = k;
            springs[c] = vec4<f32>(0.0);
        } else {
            let at = mesh_slot_at(i, place[c]);
            springs[c] = vec4<f32>(mesh_v3(at + 8u), mesh_word_f(at + 7u));
        }
    }
    // The law per contact (with its piece's radius and sphere flag), into the slots; the
    // other slots released.
    var forces: array<ContactForce, 4>;
    var used = array<bool, 4>(false, false, false, false);
    for (var c = 0u; c < nf; c++) {
        let m = mesh_found[c];
        let b = mesh_found_b[c];
        let p = mesh_found_p[c];
        var radius = st.equivalent_radius;
        var sphere = st.is_sphere != 0u;
        if COMPOSITES {
            let pc = piece_at(st, p, x, q);
            radius = pc.law_radius;
            sphere = pc.is_sphere;
        }
        let share = select(POLYHEDRON_POINT_SHARE, SPHERE_POINT_SHARE, sphere);
        let pp = pair_table[mesh_h(b, 1u) * params.num_materials + st.material];
        var side_a = mesh_motion(b);
        side_a.position = mesh_local(side_a.position);
        let context = PairContext(pp, st.mass, radius, share, params.dt);
        let r = contact_force(context, m, side_a, motion_of(i), springs[c]);
        let k = place[c];
        mesh_write_slot(mesh_slot_at(i, k), b, p, m.normal, r);
        forces[k] = r.force;
        used[k] = true;
    }
    for (var k = 0u; k < MESH_SLOTS; k++) {
        if used[k] {
            out.f += forces[k].force_b;
            out.t += forces[k].torque_b;
        } else {
            let at = mesh_slot_at(i, k);
            if mesh[at + 2u] != 0u {
                for (var w = 0u; w < MESH_SLOT; w++) {
                    mesh[at + w] = 0u;
                }
            }
        }
    }
    out.touched = nf;
    return out;
}
