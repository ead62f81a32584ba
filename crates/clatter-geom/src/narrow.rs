//! The simulator's narrow phase: exact overlap of two shapes (or a shape and a wall plane) as
//! a contact manifold of up to four points, so that a cube resting on a face gets four support
//! points and stays flat.
//!
//! Polyhedron pairs use the separating-axis test on face normals and on the edge-edge axes
//! that survive Gauss-map pruning (only edge pairs whose arcs cross can form a face of the
//! Minkowski difference), then clip the incident face against the reference face's side planes.

use glam::Vec3;

use crate::{ConvexPolyhedron, Pose, Shape};

/// One point of a contact manifold.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactPoint {
    /// World position, halfway through the overlap.
    pub point: Vec3,
    /// Overlap depth along the manifold normal (> 0 when overlapping).
    pub depth: f32,
}

/// Contact between shape `a` and shape `b`: a unit normal pointing from `a` towards `b` and
/// up to four points. Pushing `b` along `normal` by `depth` separates them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Manifold {
    pub normal: Vec3,
    pub points: [ContactPoint; 4],
    pub count: usize,
}

impl Manifold {
    /// The used points.
    #[inline]
    pub fn points(&self) -> &[ContactPoint] {
        &self.points[..self.count]
    }

    /// The deepest overlap of the manifold.
    pub fn max_depth(&self) -> f32 {
        self.points().iter().map(|p| p.depth).fold(0.0, f32::max)
    }

    fn single(normal: Vec3, point: Vec3, depth: f32) -> Self {
        let mut m = Manifold { normal, count: 1, ..Default::default() };
        m.points[0] = ContactPoint { point, depth };
        m
    }

    fn flipped(mut self) -> Self {
        self.normal = -self.normal;
        self
    }
}

/// Overlap of `a` at `pa` and `b` at `pb`; `None` when they do not overlap.
pub fn collide(a: &Shape, pa: &Pose, b: &Shape, pb: &Pose) -> Option<Manifold> {
    collide_with_hint(a, pa, b, pb, &mut NO_HINT.clone())
}

/// A separating axis remembered between steps for one pair (temporal coherence): bodies move
/// little per DEM step, so the axis that separated them last step usually still does, and
/// one test replaces the full separating-axis search. [`NO_HINT`] when there is none.
pub type SatHint = u32;
/// No remembered axis.
pub const NO_HINT: SatHint = u32::MAX;
const HINT_FACE_A: u32 = 0;
const HINT_FACE_B: u32 = 1 << 30;
const HINT_EDGE: u32 = 2 << 30;
const HINT_KIND: u32 = 3 << 30;

/// [`collide`] with a per-pair separating-axis `hint` that is read first and updated.
pub fn collide_with_hint(a: &Shape, pa: &Pose, b: &Shape, pb: &Pose, hint: &mut SatHint) -> Option<Manifold> {
    match (a, b) {
        (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) => {
            sphere_sphere(pa.position, *ra, pb.position, *rb)
        }
        (Shape::Sphere { radius }, Shape::Polyhedron(p)) => sphere_polyhedron(pa.position, *radius, p, pb),
        (Shape::Polyhedron(p), Shape::Sphere { radius }) => {
            sphere_polyhedron(pb.position, *radius, p, pa).map(Manifold::flipped)
        }
        (Shape::Polyhedron(p), Shape::Polyhedron(q)) => polyhedron_polyhedron(p, pa, q, pb, hint),
    }
}

/// Two spheres by centre and radius.
#[inline]
pub fn sphere_sphere(ca: Vec3, ra: f32, cb: Vec3, rb: f32) -> Option<Manifold> {
    let d = cb - ca;
    let dist2 = d.length_squared();
    let rsum = ra + rb;
    if dist2 >= rsum * rsum {
        return None;
    }
    let dist = dist2.sqrt();
    let normal = if dist > 1e-12 * rsum { d / dist } else { Vec3::Z };
    let depth = rsum - dist;
    Some(Manifold::single(normal, ca + normal * (ra - 0.5 * depth), depth))
}

/// Closest point of a convex polygon (a face loop of `p`) to `x`, all in `p`'s local frame.
fn closest_on_face(p: &ConvexPolyhedron, f: usize, x: Vec3) -> Vec3 {
    let face = p.faces[f];
    let lp = p.face_loop(f);
    let proj = x - face.normal * (face.normal.dot(x) - face.offset);
    let mut inside = true;
    for k in 0..lp.len() {
        let a = p.vertices[lp[k] as usize];
        let b = p.vertices[lp[(k + 1) % lp.len()] as usize];
        if (b - a).cross(proj - a).dot(face.normal) < 0.0 {
            inside = false;
            break;
        }
    }
    if inside {
        return proj;
    }
    let mut best = proj;
    let mut best_d = f32::INFINITY;
    for k in 0..lp.len() {
        let a = p.vertices[lp[k] as usize];
        let b = p.vertices[lp[(k + 1) % lp.len()] as usize];
        let q = closest_on_segment(a, b, x);
        let d = (q - x).length_squared();
        if d < best_d {
            best_d = d;
            best = q;
        }
    }
    best
}

#[inline]
fn closest_on_segment(a: Vec3, b: Vec3, x: Vec3) -> Vec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    a + ab * ((x - a).dot(ab) / len2).clamp(0.0, 1.0)
}

/// Sphere `a` (centre, radius) against polyhedron `b` at `pose`; normal from sphere to polyhedron.
pub fn sphere_polyhedron(centre: Vec3, radius: f32, p: &ConvexPolyhedron, pose: &Pose) -> Option<Manifold> {
    let c = pose.inverse_transform_point(centre);
    if c.length_squared() >= (p.radius + radius) * (p.radius + radius) {
        return None;
    }
    let mut best_face = 0;
    let mut best_sep = f32::NEG_INFINITY;
    for (i, f) in p.faces.iter().enumerate() {
        let s = f.normal.dot(c) - f.offset;
        if s > best_sep {
            best_sep = s;
            best_face = i;
        }
    }
    if best_sep >= radius {
        return None;
    }
    let (surface, n_local, depth) = if best_sep <= 0.0 {
        // Centre inside: push out through the nearest face.
        let n = p.faces[best_face].normal;
        (c - n * best_sep, -n, radius - best_sep)
    } else {
        let mut q = c;
        let mut best_d2 = f32::INFINITY;
        for (i, f) in p.faces.iter().enumerate() {
            if f.normal.dot(c) - f.offset > 0.0 {
                let cand = closest_on_face(p, i, c);
                let d2 = (cand - c).length_squared();
                if d2 < best_d2 {
                    best_d2 = d2;
                    q = cand;
                }
            }
        }
        let dist = best_d2.sqrt();
        if dist >= radius {
            return None;
        }
        let n = if dist > 1e-12 { (q - c) / dist } else { -p.faces[best_face].normal };
        (q, n, radius - dist)
    };
    let deepest = c + n_local * radius;
    let mid = 0.5 * (surface + deepest);
    Some(Manifold::single(pose.rotation * n_local, pose.transform_point(mid), depth))
}

/// A wall: the half-space `normal . x <= offset` is solid; bodies live on the side the unit
/// `normal` points to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub normal: Vec3,
    pub offset: f32,
}

/// A shape against a wall plane; the normal points from the wall into the body (the plane's normal).
pub fn collide_plane(plane: &Plane, s: &Shape, pose: &Pose) -> Option<Manifold> {
    let n = plane.normal;
    let centre_height = n.dot(pose.position) - plane.offset;
    match s {
        Shape::Sphere { radius } => {
            let depth = radius - centre_height;
            if depth <= 0.0 {
                return None;
            }
            Some(Manifold::single(n, pose.position - n * (radius - 0.5 * depth), depth))
        }
        Shape::Polyhedron(p) => {
            if centre_height >= p.radius {
                return None;
            }
            let n_local = pose.rotation.conjugate() * n;
            let mut buf = [(Vec3::ZERO, 0.0f32); 64];
            let mut count = 0;
            let mut extra = Vec::new();
            for &v in &p.vertices {
                let h = n_local.dot(v) + centre_height;
                if h < 0.0 {
                    let world = pose.transform_point(v) - n * (0.5 * h);
                    if count < buf.len() {
                        buf[count] = (world, -h);
                        count += 1;
                    } else {
                        extra.push((world, -h));
                    }
                }
            }
            if count == 0 {
                return None;
            }
            if extra.is_empty() {
                Some(reduce(&buf[..count], n))
            } else {
                let mut all = buf[..count].to_vec();
                all.extend(extra);
                Some(reduce(&all, n))
            }
        }
    }
}

/// Keeps at most four points of a contact patch: the deepest, the one furthest from it, then
/// those that enlarge the covered area most (so the patch's support polygon is preserved).
fn reduce(pts: &[(Vec3, f32)], normal: Vec3) -> Manifold {
    let mut m = Manifold { normal, ..Default::default() };
    if pts.len() <= 4 {
        for (i, &(p, d)) in pts.iter().enumerate() {
            m.points[i] = ContactPoint { point: p, depth: d };
        }
        m.count = pts.len();
        return m;
    }
    let a = (0..pts.len()).max_by(|&i, &j| pts[i].1.total_cmp(&pts[j].1)).unwrap_or(0);
    let pa = pts[a].0;
    let b = (0..pts.len())
        .max_by(|&i, &j| (pts[i].0 - pa).length_squared().total_cmp(&(pts[j].0 - pa).length_squared()))
        .unwrap_or(0);
    let pb = pts[b].0;
    let area = |p: Vec3, q: Vec3, r: Vec3| (q - p).cross(r - p).dot(normal);
    let c = (0..pts.len())
        .max_by(|&i, &j| area(pa, pb, pts[i].0).abs().total_cmp(&area(pa, pb, pts[j].0).abs()))
        .unwrap_or(0);
    let pc = pts[c].0;
    // The fourth point: the one furthest outside the triangle, i.e. adding the most area.
    let sign = area(pa, pb, pc).signum();
    let gain = |p: Vec3| {
        (-sign * area(pa, pb, p))
            .max(-sign * area(pb, pc, p))
            .max(-sign * area(pc, pa, p))
    };
    let d = (0..pts.len())
        .filter(|&i| i != a && i != b && i != c)
        .max_by(|&i, &j| gain(pts[i].0).total_cmp(&gain(pts[j].0)));
    let mut idx = vec![a, b, c];
    if let Some(d) = d {
        idx.push(d);
    }
    idx.dedup();
    for (k, &i) in idx.iter().enumerate() {
        m.points[k] = ContactPoint { point: pts[i].0, depth: pts[i].1 };
    }
    m.count = idx.len();
    m
}

/// Separation of `q`'s vertices (given in `p`'s frame) along `p`'s face `f`.
#[inline]
fn face_separation(p: &ConvexPolyhedron, f: usize, q_verts: &[Vec3]) -> f32 {
    let face = p.faces[f];
    let mut m = f32::INFINITY;
    for &v in q_verts {
        m = m.min(face.normal.dot(v));
    }
    m - face.offset
}

const MAX_VERTS: usize = 64;

/// Two convex polyhedra.
pub fn polyhedron_polyhedron(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    hint: &mut SatHint,
) -> Option<Manifold> {
    let d = pb.position - pa.position;
    let rs = a.radius + b.radius;
    if d.length_squared() >= rs * rs {
        return None;
    }
    // Everything in A's frame: B's rotation and offset relative to A.
    let inv_a = pa.rotation.conjugate();
    let rot_q = inv_a * pb.rotation;
    let rot = glam::Mat3::from_quat(rot_q);
    let inv_rot = rot.transpose();
    let t = inv_a * d;
    // The axis that separated this pair last step, if any, tested on support points in each
    // body's own frame (no vertex transformed).
    if *hint != NO_HINT {
        let idx = (*hint & !HINT_KIND) as usize;
        let min_along = |p: &ConvexPolyhedron, dir: Vec3| p.vertices.iter().map(|v| dir.dot(*v)).fold(f32::INFINITY, f32::min);
        let separated = match *hint & HINT_KIND {
            HINT_FACE_A => idx < a.faces.len() && {
                let f = a.faces[idx];
                min_along(b, inv_rot * f.normal) + f.normal.dot(t) - f.offset > 0.0
            },
            HINT_FACE_B => idx < b.faces.len() && {
                let f = b.faces[idx];
                let n = rot * f.normal;
                min_along(a, n) - n.dot(t) - f.offset > 0.0
            },
            _ => {
                let (ea, eb) = (idx >> 15, idx & 0x7fff);
                ea < a.edges.len() && eb < b.edges.len() && {
                    let [a0, a1] = a.edges[ea];
                    let [b0, b1] = b.edges[eb];
                    let pa0 = a.vertices[a0 as usize];
                    let db = rot * (b.vertices[b1 as usize] - b.vertices[b0 as usize]);
                    let axis = (a.vertices[a1 as usize] - pa0).cross(db);
                    let axis = if axis.dot(pa0) < 0.0 { -axis } else { axis };
                    let lo_b = min_along(b, inv_rot * axis) + axis.dot(t);
                    let hi_a = -min_along(a, -axis);
                    axis.length_squared() > 0.0 && lo_b > hi_a
                }
            }
        };
        if separated {
            return None;
        }
    }
    let mut heap_b = Vec::new();
    let mut buf_b = [Vec3::ZERO; MAX_VERTS];
    let bv: &[Vec3] = if b.vertices.len() <= MAX_VERTS {
        for (i, &v) in b.vertices.iter().enumerate() {
            buf_b[i] = rot * v + t;
        }
        &buf_b[..b.vertices.len()]
    } else {
        heap_b.extend(b.vertices.iter().map(|&v| rot * v + t));
        &heap_b
    };
    let mut heap_a = Vec::new();
    let mut buf_a = [Vec3::ZERO; MAX_VERTS];
    let av: &[Vec3] = if a.vertices.len() <= MAX_VERTS {
        for (i, &v) in a.vertices.iter().enumerate() {
            buf_a[i] = inv_rot * (v - t);
        }
        &buf_a[..a.vertices.len()]
    } else {
        heap_a.extend(a.vertices.iter().map(|&v| inv_rot * (v - t)));
        &heap_a
    };
    // Face axes of A.
    let mut best_a = (f32::NEG_INFINITY, 0usize);
    for f in 0..a.faces.len() {
        let s = face_separation(a, f, bv);
        if s > 0.0 {
            *hint = HINT_FACE_A | f as u32;
            return None;
        }
        if s > best_a.0 {
            best_a = (s, f);
        }
    }
    let mut best_b = (f32::NEG_INFINITY, 0usize);
    for f in 0..b.faces.len() {
        let s = face_separation(b, f, av);
        if s > 0.0 {
            *hint = HINT_FACE_B | f as u32;
            return None;
        }
        if s > best_b.0 {
            best_b = (s, f);
        }
    }
    // Edge-edge axes that are faces of the Minkowski difference. B's face normals are
    // rotated into A's frame once (negated: the Minkowski difference uses -B).
    let mut heap_n = Vec::new();
    let mut buf_n = [Vec3::ZERO; MAX_VERTS];
    let neg_nb: &[Vec3] = if b.faces.len() <= MAX_VERTS {
        for (i, f) in b.faces.iter().enumerate() {
            buf_n[i] = -(rot * f.normal);
        }
        &buf_n[..b.faces.len()]
    } else {
        heap_n.extend(b.faces.iter().map(|f| -(rot * f.normal)));
        &heap_n
    };
    let mut best_e = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
    let scale = a.radius.max(b.radius);
    for (ea, &[a0, a1]) in a.edges.iter().enumerate() {
        let [fa0, fa1] = a.edge_faces[ea];
        let na0 = a.faces[fa0 as usize].normal;
        let na1 = a.faces[fa1 as usize].normal;
        let bxa = na1.cross(na0);
        let pa0 = a.vertices[a0 as usize];
        let da = a.vertices[a1 as usize] - pa0;
        for (eb, &[b0, b1]) in b.edges.iter().enumerate() {
            let [fb0, fb1] = b.edge_faces[eb];
            let c = neg_nb[fb0 as usize];
            let d = neg_nb[fb1 as usize];
            // Gauss-map test (inlined is_minkowski_face with the A-side cross hoisted).
            let cba = c.dot(bxa);
            let dba = d.dot(bxa);
            if cba * dba >= 0.0 {
                continue;
            }
            let dxc = d.cross(c);
            let adc = na0.dot(dxc);
            let bdc = na1.dot(dxc);
            if adc * bdc >= 0.0 || cba * bdc <= 0.0 {
                continue;
            }
            let pb0 = bv[b0 as usize];
            let db = bv[b1 as usize] - pb0;
            let axis = da.cross(db);
            let len2 = axis.length_squared();
            if len2 < 1e-10 * da.length_squared() * db.length_squared() {
                continue;
            }
            let mut axis = axis / len2.sqrt();
            if axis.dot(pa0) < 0.0 {
                axis = -axis;
            }
            let s = axis.dot(pb0 - pa0);
            if s > 0.0 {
                if ea < 0x8000 && eb < 0x8000 {
                    *hint = HINT_EDGE | ((ea as u32) << 15) | eb as u32;
                }
                return None;
            }
            if s > best_e.0 {
                best_e = (s, ea, eb, axis);
            }
        }
    }
    *hint = NO_HINT;
    let face_best = best_a.0.max(best_b.0);
    let tol = 1e-3 * scale;
    if best_e.0 > face_best + tol {
        let (s, ea, eb, axis) = best_e;
        let [a0, a1] = a.edges[ea];
        let [b0, b1] = b.edges[eb];
        let (qa, qb) = segment_closest(
            a.vertices[a0 as usize],
            a.vertices[a1 as usize],
            bv[b0 as usize],
            bv[b1 as usize],
        );
        let mid = 0.5 * (qa + qb);
        return Some(Manifold::single(pa.rotation * axis, pa.transform_point(mid), -s));
    }
    // Face contact: prefer A's face unless B's is clearly better.
    if best_b.0 > best_a.0 + tol {
        // Reference face on B: work in B's frame with A as incident.
        clip_faces(b, best_b.1, a, av, inv_rot).map(|m| to_world(m, pb).flipped())
    } else {
        clip_faces(a, best_a.1, b, bv, rot).map(|m| to_world(m, pa))
    }
}

fn to_world(mut m: Manifold, pose: &Pose) -> Manifold {
    m.normal = pose.rotation * m.normal;
    for p in &mut m.points[..m.count] {
        p.point = pose.transform_point(p.point);
    }
    m
}

/// Clips the incident face of `inc` (vertices `inc_v` in `refp`'s frame) against reference face
/// `rf` of `refp`. Normal: the reference face's outward normal (from `refp` to `inc`).
fn clip_faces(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: &[Vec3],
    inc_rot: glam::Mat3,
) -> Option<Manifold> {
    let rface = refp.faces[rf];
    let n = rface.normal;
    // Incident face: the one most anti-parallel to the reference normal.
    let n_inc = inc_rot.transpose() * n;
    let mut inc_face = 0;
    let mut best = f32::INFINITY;
    for (f, face) in inc.faces.iter().enumerate() {
        let d = face.normal.dot(n_inc);
        if d < best {
            best = d;
            inc_face = f;
        }
    }
    let mut poly: Vec<Vec3> = inc.face_loop(inc_face).iter().map(|&i| inc_v[i as usize]).collect();
    let mut tmp = Vec::with_capacity(poly.len() + 4);
    let rl = refp.face_loop(rf);
    for k in 0..rl.len() {
        let v0 = refp.vertices[rl[k] as usize];
        let v1 = refp.vertices[rl[(k + 1) % rl.len()] as usize];
        let side = (v1 - v0).cross(n); // outward for a CCW loop
        let off = side.dot(v0);
        tmp.clear();
        for i in 0..poly.len() {
            let p = poly[i];
            let q = poly[(i + 1) % poly.len()];
            let dp = side.dot(p) - off;
            let dq = side.dot(q) - off;
            if dp <= 0.0 {
                tmp.push(p);
            }
            if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                tmp.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
        std::mem::swap(&mut poly, &mut tmp);
        if poly.is_empty() {
            break;
        }
    }
    let mut pts: Vec<(Vec3, f32)> = Vec::with_capacity(poly.len());
    for p in poly {
        let depth = rface.offset - n.dot(p);
        if depth > 0.0 {
            pts.push((p + n * (0.5 * depth), depth));
        }
    }
    if pts.is_empty() {
        return None;
    }
    Some(reduce(&pts, n))
}

/// Closest points of segments `p0-p1` and `q0-q1`.
fn segment_closest(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> (Vec3, Vec3) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let c = d1.dot(r);
    let b = d1.dot(d2);
    let denom = a * e - b * b;
    let mut s = if denom > 1e-12 * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = if e > 0.0 { (b * s + f) / e } else { 0.0 };
    if t < 0.0 {
        t = 0.0;
        s = if a > 0.0 { (-c / a).clamp(0.0, 1.0) } else { 0.0 };
    } else if t > 1.0 {
        t = 1.0;
        s = if a > 0.0 { ((b - c) / a).clamp(0.0, 1.0) } else { 0.0 };
    }
    (p0 + d1 * s, q0 + d2 * t)
}
