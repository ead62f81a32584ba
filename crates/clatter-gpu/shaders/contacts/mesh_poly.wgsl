// The polyhedron parts of mesh.wgsl (compiled with narrow.wgsl): a convex polyhedron against
// a triangle (triangle.rs `polyhedron_triangle`) and the manifold of a polyhedron partly
// over a plane of coplanar triangles (boundary.rs `plane_manifold`, its second half).

// Closest points of segments p0-p1 and q0-q1 (triangle.rs `closest_between_segments`,
// Ericson 5.1.9), as the two columns.
fn mesh_segments(p0: vec3<f32>, p1: vec3<f32>, q0: vec3<f32>, q1: vec3<f32>) -> mat2x3<f32> {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    var s = 0.0;
    var t = 0.0;
    if a <= 1e-20 && e <= 1e-20 {
        return mat2x3<f32>(p0, q0);
    }
    if a <= 1e-20 {
        s = 0.0;
        t = clamp(f / e, 0.0, 1.0);
    } else {
        let c = dot(d1, r);
        if e <= 1e-20 {
            t = 0.0;
            s = clamp(-c / a, 0.0, 1.0);
        } else {
            let b = dot(d1, d2);
            let denom = a * e - b * b;
            var s0 = 0.0;
            if denom > 0.0 {
                s0 = clamp((b * f - c * e) / denom, 0.0, 1.0);
            }
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t = 0.0;
                s = clamp(-c / a, 0.0, 1.0);
            } else if t0 > 1.0 {
                t = 1.0;
                s = clamp((b - c) / a, 0.0, 1.0);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    return mat2x3<f32>(p0 + d1 * s, q0 + d2 * t);
}

// Triangle vertex k (local frame) of (t0, t1, t2).
fn mesh_pick(t0: vec3<f32>, t1: vec3<f32>, t2: vec3<f32>, k: u32) -> vec3<f32> {
    if k == 0u {
        return t0;
    }
    if k == 1u {
        return t1;
    }
    return t2;
}

// Polyhedron shape s at (x, q) against triangle (a, b, c) with unit normal `normal`: the
// separating-axis test in the polyhedron's frame (triangle.rs `polyhedron_triangle`).
fn mesh_poly_tri(s: u32, x: vec3<f32>, q: vec4<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>,
                 normal: vec3<f32>) -> MeshHit {
    let p = nrw_shape(s);
    let t0 = quat_rotate_inv(q, a - x);
    let t1 = quat_rotate_inv(q, b - x);
    let t2 = quat_rotate_inv(q, c - x);
    let n_world = mesh_facing(a, normal, x);
    let n = quat_rotate_inv(q, n_world);
    let plane = dot(n, t0);
    var lowest = 3.4028235e38;
    for (var v = 0u; v < p.num_vertices; v++) {
        lowest = min(lowest, dot(n, nrw_vert(p, v)));
    }
    let face_sep = lowest - plane;
    if face_sep >= 0.0 {
        return mesh_no_hit();
    }
    var best = -3.4028235e38;
    var first = true;
    var best_axis = vec3<f32>(0.0);
    var best_kind = 0u;
    var best_index = 0u;
    var best_tk = 0u;
    for (var f = 0u; f < p.num_faces; f++) {
        let face = nrw_face(p, f);
        var lo = 3.4028235e38;
        var k_lo = 0u;
        for (var k = 0u; k < 3u; k++) {
            let h = dot(face.xyz, mesh_pick(t0, t1, t2, k));
            if h < lo || k == 0u {
                lo = h;
                k_lo = k;
            }
        }
        let sep = lo - face.w;
        if sep >= 0.0 {
            return mesh_no_hit();
        }
        if sep > best || first {
            first = false;
            best = sep;
            best_axis = -face.xyz;
            best_kind = 0u;
            best_index = f;
            best_tk = k_lo;
        }
    }
    let g = (t0 + t1 + t2) / 3.0;
    for (var e = 0u; e < p.num_edges; e++) {
        let ed = nrw_edge(p, e);
        let d = nrw_vert(p, ed.y) - nrw_vert(p, ed.x);
        for (var k = 0u; k < 3u; k++) {
            let te = mesh_pick(t0, t1, t2, (k + 1u) % 3u) - mesh_pick(t0, t1, t2, k);
            var axis = cross(d, te);
            let len2 = dot(axis, axis);
            if len2 <= 1e-12 * dot(d, d) * dot(te, te) {
                continue;
            }
            axis = axis / sqrt(len2);
            if dot(axis, -g) < 0.0 {
                axis = -axis;
            }
            var lo = 3.4028235e38;
            for (var v = 0u; v < p.num_vertices; v++) {
                lo = min(lo, dot(axis, nrw_vert(p, v)));
            }
            let hi = max(max(dot(axis, t0), dot(axis, t1)), dot(axis, t2));
            let sep = lo - hi;
            if sep >= 0.0 {
                return mesh_no_hit();
            }
            if sep > best {
                best = sep;
                best_axis = axis;
                best_kind = 1u;
                best_index = e;
                best_tk = k;
            }
        }
    }
    if best <= face_sep + 1e-3 * p.radius {
        return mesh_face_hit(n_world, a);
    }
    let depth = -best;
    var point: vec3<f32>;
    var feature: u32;
    if best_kind == 0u {
        let k = best_tk;
        let face = nrw_face(p, best_index);
        let first_v = nrw_loop_first(p, best_index);
        let len = nrw_loop_len(p, best_index);
        var centre = vec3<f32>(0.0);
        for (var j = 0u; j < len; j++) {
            centre += nrw_vert(p, shape_u[first_v + j]);
        }
        centre = centre / f32(len);
        let tol = 1e-4 * p.radius;
        let next = (k + 1u) % 3u;
        let prev = (k + 2u) % 3u;
        let tk = mesh_pick(t0, t1, t2, k);
        let tn = mesh_pick(t0, t1, t2, next);
        let tp = mesh_pick(t0, t1, t2, prev);
        var qp: vec3<f32>;
        if dot(face.xyz, tn) - dot(face.xyz, tk) <= tol {
            qp = mesh_segments(tk, tn, centre, centre)[0];
            feature = 1u + k;
        } else if dot(face.xyz, tp) - dot(face.xyz, tk) <= tol {
            qp = mesh_segments(tp, tk, centre, centre)[0];
            feature = 1u + prev;
        } else {
            qp = tk;
            feature = 4u + k;
        }
        point = qp - best_axis * (0.5 * depth);
    } else {
        let ed = nrw_edge(p, best_index);
        let k = best_tk;
        let cp = mesh_segments(nrw_vert(p, ed.x), nrw_vert(p, ed.y), mesh_pick(t0, t1, t2, k),
                               mesh_pick(t0, t1, t2, (k + 1u) % 3u));
        point = 0.5 * (cp[0] + cp[1]);
        feature = 1u + k;
    }
    return MeshHit(2u, feature, quat_rotate(q, best_axis), 0.0, quat_rotate(q, point) + x, depth);
}

// How deep the local point xl lies inside polyhedron p along -dir (triangle.rs
// `depth_inside`); -1 when outside (None).
fn mesh_depth_inside(p: NrwShape, xl: vec3<f32>, dir: vec3<f32>) -> f32 {
    var s = 3.4028235e38;
    var any = false;
    for (var f = 0u; f < p.num_faces; f++) {
        let face = nrw_face(p, f);
        let h = face.w - dot(face.xyz, xl);
        if h < 0.0 {
            return -1.0;
        }
        let toward = -dot(face.xyz, dir);
        if toward > 1e-9 {
            s = min(s, h / toward);
            any = true;
        }
    }
    if !any {
        return -1.0;
    }
    return s;
}

// The manifold of polyhedron s at (x, q) partly over the face group (n, offset) of
// boundary gb: its vertices below the plane over the group's triangles, and the
// triangles' vertices inside it, reduced to four points (boundary.rs `plane_manifold`).
fn mesh_plane_fallback(s: u32, x: vec3<f32>, q: vec4<f32>, gb: u32, pose: MeshPose, n: vec3<f32>,
                       offset: f32, size: f32) -> Manifold {
    let p = nrw_shape(s);
    var buf: NrwBuf;
    var count = 0u;
    for (var v = 0u; v < p.num_vertices; v++) {
        let xw = quat_rotate(q, nrw_vert(p, v)) + x;
        let h = dot(n, xw) - offset;
        if h < 0.0 && mesh_on_mesh(xw, gb, pose, n, offset, size) {
            if count == NRW_MAX_CLIP {
                mesh_overflow = true;
                return Manifold();
            }
            buf[count] = vec4<f32>(xw - n * (0.5 * h), -h);
            count++;
        }
    }
    let n_local = quat_rotate_inv(q, n);
    for (var c = 0u; c < mesh_ncands; c++) {
        let g = mesh_cands[c];
        let b = mesh_boundary_of(g);
        if b != gb {
            continue;
        }
        let tri = mesh_world_tri(b, g - mesh_h(b, 3u), pose);
        if !mesh_supports(tri, n, offset, size) {
            continue;
        }
        for (var k = 0u; k < 3u; k++) {
            let xv = mesh_pick(tri.a, tri.b, tri.c, k);
            let depth = mesh_depth_inside(p, quat_rotate_inv(q, xv - x), n_local);
            if depth > 0.0 {
                if count == NRW_MAX_CLIP {
                    mesh_overflow = true;
                    return Manifold();
                }
                buf[count] = vec4<f32>(xv - n * (0.5 * depth), depth);
                count++;
            }
        }
    }
    if count == 0u {
        return Manifold();
    }
    let src = NrwPatch(false, count, p, vec3<f32>(0.0), 0.0, x, q);
    return nrw_reduce(src, &buf, n);
}
