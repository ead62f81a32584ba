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

    #[inline(always)]
    fn single(normal: Vec3, point: Vec3, depth: f32) -> Self {
        let mut m = Manifold {
            normal,
            count: 1,
            ..Default::default()
        };
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
    collide_with_hint(a, pa, b, pb, &mut NO_HINT.clone(), &mut 0.0)
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
///
/// `separation` receives a lower bound of the distance when polyhedra are found apart (0 when
/// unknown or touching); see [`polyhedron_polyhedron`].
pub fn collide_with_hint(
    a: &Shape,
    pa: &Pose,
    b: &Shape,
    pb: &Pose,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<Manifold> {
    *separation = 0.0;
    match (a, b) {
        (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) => {
            sphere_sphere(pa.position, *ra, pb.position, *rb)
        }
        (Shape::Sphere { radius }, Shape::Polyhedron(p)) => {
            sphere_polyhedron(pa.position, *radius, p, pb)
        }
        (Shape::Polyhedron(p), Shape::Sphere { radius }) => {
            sphere_polyhedron(pb.position, *radius, p, pa).map(Manifold::flipped)
        }
        (Shape::Polyhedron(p), Shape::Polyhedron(q)) => {
            polyhedron_polyhedron(p, pa, q, pb, hint, separation)
        }
        _ => deepest_piece_contact(a, pa, b, pb),
    }
}

/// Two convex shapes (spheres or polyhedra); `None` for a composite. Kept apart from
/// [`collide_with_hint`] so that the composite path does not make it recursive.
fn collide_convex(a: &Shape, pa: &Pose, b: &Shape, pb: &Pose) -> Option<Manifold> {
    match (a, b) {
        (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) => {
            sphere_sphere(pa.position, *ra, pb.position, *rb)
        }
        (Shape::Sphere { radius }, Shape::Polyhedron(p)) => {
            sphere_polyhedron(pa.position, *radius, p, pb)
        }
        (Shape::Polyhedron(p), Shape::Sphere { radius }) => {
            sphere_polyhedron(pb.position, *radius, p, pa).map(Manifold::flipped)
        }
        (Shape::Polyhedron(p), Shape::Polyhedron(q)) => {
            polyhedron_polyhedron(p, pa, q, pb, &mut NO_HINT.clone(), &mut 0.0)
        }
        _ => None,
    }
}

/// A piece's world pose, for a piece at `local` in a shape at `pose`.
#[inline]
pub fn piece_pose(pose: &Pose, local: &Pose) -> Pose {
    Pose::new(
        pose.transform_point(local.position),
        pose.rotation * local.rotation,
    )
}

/// Composites in the single-manifold queries: every piece pair is collided and the manifold
/// with the deepest point is returned. (The simulator does not use this: it keeps one contact,
/// with its own springs, per piece pair.)
fn deepest_piece_contact(a: &Shape, pa: &Pose, b: &Shape, pb: &Pose) -> Option<Manifold> {
    let mut best: Option<(f32, Manifold)> = None;
    for (sa, la) in a.pieces() {
        for (sb, lb) in b.pieces() {
            if let Some(m) = collide_convex(sa, &piece_pose(pa, &la), sb, &piece_pose(pb, &lb)) {
                let depth = m.points().iter().map(|p| p.depth).fold(f32::MIN, f32::max);
                if best.as_ref().is_none_or(|(d, _)| depth > *d) {
                    best = Some((depth, m));
                }
            }
        }
    }
    best.map(|(_, m)| m)
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
    let normal = if dist > 1e-12 * rsum {
        d / dist
    } else {
        Vec3::Z
    };
    let depth = rsum - dist;
    Some(Manifold::single(
        normal,
        ca + normal * (ra - 0.5 * depth),
        depth,
    ))
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
pub fn sphere_polyhedron(
    centre: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    pose: &Pose,
) -> Option<Manifold> {
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
        let n = if dist > 1e-12 {
            (q - c) / dist
        } else {
            -p.faces[best_face].normal
        };
        (q, n, radius - dist)
    };
    let deepest = c + n_local * radius;
    let mid = 0.5 * (surface + deepest);
    Some(Manifold::single(
        pose.rotation * n_local,
        pose.transform_point(mid),
        depth,
    ))
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
    if let Shape::Composite(_) = s {
        // The deepest piece (see `deepest_piece_contact`); the simulator collides each piece.
        let mut best: Option<(f32, Manifold)> = None;
        for (sp, local) in s.pieces() {
            if let Some(m) = collide_plane_convex(plane, sp, &piece_pose(pose, &local)) {
                let depth = m.points().iter().map(|p| p.depth).fold(f32::MIN, f32::max);
                if best.as_ref().is_none_or(|(d, _)| depth > *d) {
                    best = Some((depth, m));
                }
            }
        }
        return best.map(|(_, m)| m);
    }
    collide_plane_convex(plane, s, pose)
}

/// [`collide_plane`] for a sphere or polyhedron (`None` for a composite).
#[inline]
fn collide_plane_convex(plane: &Plane, s: &Shape, pose: &Pose) -> Option<Manifold> {
    let n = plane.normal;
    let centre_height = n.dot(pose.position) - plane.offset;
    match s {
        Shape::Sphere { radius } => {
            let depth = radius - centre_height;
            if depth <= 0.0 {
                return None;
            }
            Some(Manifold::single(
                n,
                pose.position - n * (radius - 0.5 * depth),
                depth,
            ))
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
        Shape::Composite(_) => None,
    }
}

/// A manifold of at most four of the patch points `(point, depth)` with `normal` (the
/// same reduction as the narrow phase's: deepest point, then the widest support polygon).
pub fn patch(pts: &[(Vec3, f32)], normal: Vec3) -> Manifold {
    reduce(pts, normal)
}

/// Keeps at most four points of a contact patch (see [`crate::reduce::reduce`]).
fn reduce(pts: &[(Vec3, f32)], normal: Vec3) -> Manifold {
    let (idx, count) = crate::reduce::reduce(pts, normal);
    let mut m = Manifold {
        normal,
        count,
        ..Default::default()
    };
    for (k, &i) in idx[..count].iter().enumerate() {
        m.points[k] = ContactPoint {
            point: pts[i].0,
            depth: pts[i].1,
        };
    }
    m
}

/// Separation of `q`'s vertices (given in `p`'s frame) along `p`'s face `f`.
#[inline]
fn face_separation(p: &ConvexPolyhedron, f: usize, q: &SoaPoints) -> f32 {
    let face = p.faces[f];
    q.min_along(face.normal) - face.offset
}

/// Points as separate x, y, z arrays padded to a multiple of 4 (with copies of the first
/// point), so that "smallest projection on an axis" compiles to packed SIMD.
#[derive(Default)]
struct SoaPoints {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl SoaPoints {
    fn fill(&mut self, pts: &[Vec3]) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
        let pad = pts.len().next_multiple_of(4);
        for k in 0..pad {
            let v = pts[if k < pts.len() { k } else { 0 }];
            self.x.push(v.x);
            self.y.push(v.y);
            self.z.push(v.z);
        }
    }

    /// Largest projection on `n`.
    #[inline]
    fn max_along(&self, n: Vec3) -> f32 {
        -self.min_along(-n)
    }

    /// Smallest projection on `n`.
    #[inline]
    fn min_along(&self, n: Vec3) -> f32 {
        let mut m = [f32::INFINITY; 4];
        for ((xs, ys), zs) in self
            .x
            .chunks_exact(4)
            .zip(self.y.chunks_exact(4))
            .zip(self.z.chunks_exact(4))
        {
            for k in 0..4 {
                let d = n.x * xs[k] + n.y * ys[k] + n.z * zs[k];
                m[k] = if d < m[k] { d } else { m[k] };
            }
        }
        let a = if m[0] < m[1] { m[0] } else { m[1] };
        let b = if m[2] < m[3] { m[2] } else { m[3] };
        if a < b { a } else { b }
    }
}

/// Two convex polyhedra.
///
/// When the bodies are apart, `separation` receives a lower bound of their distance (the gap
/// along the separating axis found, or between the bounding spheres), else 0: the simulator
/// skips the pair until the bodies have moved that far.
pub fn polyhedron_polyhedron(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<Manifold> {
    *separation = 0.0;
    let d = pb.position - pa.position;
    let rs = a.radius + b.radius;
    let d2 = d.length_squared();
    if d2 >= rs * rs {
        *separation = d2.sqrt() - rs;
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
        let min_along = |p: &ConvexPolyhedron, dir: Vec3| {
            let mut m = f32::INFINITY;
            for v in &p.vertices {
                let d = dir.dot(*v);
                m = if d < m { d } else { m };
            }
            m
        };
        // Signed gap along the remembered axis (a distance: the axis is a unit vector).
        let gap = match *hint & HINT_KIND {
            HINT_FACE_A if idx < a.faces.len() => {
                let f = a.faces[idx];
                min_along(b, inv_rot * f.normal) + f.normal.dot(t) - f.offset
            }
            HINT_FACE_B if idx < b.faces.len() => {
                let f = b.faces[idx];
                let n = rot * f.normal;
                min_along(a, n) - n.dot(t) - f.offset
            }
            HINT_EDGE if (idx >> 15) < a.edges.len() && (idx & 0x7fff) < b.edges.len() => {
                let (ea, eb) = (idx >> 15, idx & 0x7fff);
                let [a0, a1] = a.edges[ea];
                let [b0, b1] = b.edges[eb];
                let pa0 = a.vertices[a0 as usize];
                let db = rot * (b.vertices[b1 as usize] - b.vertices[b0 as usize]);
                let axis = (a.vertices[a1 as usize] - pa0)
                    .cross(db)
                    .normalize_or_zero();
                let axis = if axis.dot(pa0) < 0.0 { -axis } else { axis };
                let lo_b = min_along(b, inv_rot * axis) + axis.dot(t);
                let hi_a = -min_along(a, -axis);
                if axis == Vec3::ZERO { 0.0 } else { lo_b - hi_a }
            }
            _ => 0.0,
        };
        if gap > 0.0 {
            *separation = gap;
            return None;
        }
    }
    SCRATCH.with_borrow_mut(|sc| sat_full(a, pa, b, pb, rot, inv_rot, t, sc, hint, separation))
}

/// Per-thread buffers of the separating-axis test (no allocation or zeroing per pair).
#[derive(Default)]
struct Scratch {
    av: Vec<Vec3>,
    bv: Vec<Vec3>,
    b_soa: SoaPoints,
    a_local: SoaPoints,
    tables: Vec<f32>,
    clip: ClipBuffers,
}

/// Buffers of the face clipping.
#[derive(Default)]
struct ClipBuffers {
    poly: Vec<Vec3>,
    tmp: Vec<Vec3>,
    pts: Vec<(Vec3, f32)>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// The full separating-axis test with B at rotation `rot` and offset `t` in A's frame.
#[allow(clippy::too_many_arguments)]
fn sat_full(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    rot: glam::Mat3,
    inv_rot: glam::Mat3,
    t: Vec3,
    sc: &mut Scratch,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<Manifold> {
    let Scratch {
        av,
        bv,
        b_soa,
        a_local,
        tables,
        clip,
    } = sc;
    bv.clear();
    bv.extend(b.vertices.iter().map(|&v| rot * v + t));
    let bv: &[Vec3] = bv;
    b_soa.fill(bv);
    a_local.fill(&a.vertices);
    // Face axes of A.
    let mut best_a = (f32::NEG_INFINITY, 0usize);
    for f in 0..a.faces.len() {
        let s = face_separation(a, f, b_soa);
        if s > 0.0 {
            *hint = HINT_FACE_A | f as u32;
            *separation = s;
            return None;
        }
        if s > best_a.0 {
            best_a = (s, f);
        }
    }
    // Face axes of B, tested in A's frame: B's face plane `n.x = offset` becomes
    // `(R n).x = offset + (R n).t`, and A's own vertices need no transform.
    let mut best_b = (f32::NEG_INFINITY, 0usize);
    for (f, face) in b.faces.iter().enumerate() {
        let n = rot * face.normal;
        let s = a_local.min_along(n) - (face.offset + n.dot(t));
        if s > 0.0 {
            *hint = HINT_FACE_B | f as u32;
            *separation = s;
            return None;
        }
        if s > best_b.0 {
            best_b = (s, f);
        }
    }
    let (nda, ndb) = (a.edge_dirs.len(), b.edge_dirs.len());
    let cost_dirs = nda * ndb * (a.vertices.len() + bv.len());
    let cost_tables = a.edges.len() * b.faces.len()
        + b.edges.len() * a.faces.len()
        + a.edges.len() * b.edges.len();
    let best_e = if cost_dirs <= 2 * cost_tables {
        edge_axes_by_direction(a, b, rot, a_local, b_soa, bv, hint, separation)?
    } else {
        edge_axes_gauss_map(a, b, rot, inv_rot, bv, tables, hint, separation)?
    };
    let scale = a.radius.max(b.radius);
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
        return Some(Manifold::single(
            pa.rotation * axis,
            pa.transform_point(mid),
            -s,
        ));
    }
    // Face contact: prefer A's face unless B's is clearly better.
    if best_b.0 > best_a.0 + tol {
        // Reference face on B: work in B's frame with A as incident.
        av.clear();
        av.extend(a.vertices.iter().map(|&v| inv_rot * (v - t)));
        clip_faces(b, best_b.1, a, av, inv_rot, clip).map(|m| to_world(m, pb).flipped())
    } else {
        clip_faces(a, best_a.1, b, bv, rot, clip).map(|m| to_world(m, pa))
    }
}

/// The best edge-edge axis `(separation, edge of A, edge of B, axis in A's frame)`, or `None`
/// when an edge axis separates the bodies (recorded in `hint`).
type EdgeAxis = (f32, usize, usize, Vec3);

/// Edge axes by enumerating edge pairs that pass the Gauss-map test (good for many edges).
#[allow(clippy::too_many_arguments)]
fn edge_axes_gauss_map(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rot: glam::Mat3,
    inv_rot: glam::Mat3,
    bv: &[Vec3],
    tables: &mut Vec<f32>,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<EdgeAxis> {
    // Edge-edge axes that are faces of the Minkowski difference (Gauss-map pruning: the arcs
    // of edge `ea` of A and of edge `eb` of -B must cross). The four arc/normal products of
    // each pair come from two small tables instead of being recomputed per pair.
    let (nfa, nfb) = (a.faces.len(), b.faces.len());
    let (nea, neb) = (a.edges.len(), b.edges.len());
    tables.clear();
    tables.resize(nea * nfb + neb * nfa, 0.0);
    let (t1, t2) = tables.split_at_mut(nea * nfb);
    // t1[ea][kb] = (-nb_kb) . arcA_ea, with B's normal rotated into A's frame.
    for (ea, arc) in a.edge_arcs.iter().enumerate() {
        let arc = inv_rot * *arc;
        for (kb, f) in b.faces.iter().enumerate() {
            t1[ea * nfb + kb] = -f.normal.dot(arc);
        }
    }
    // t2[eb][ka] = na_ka . arcB_eb (arc rotated into A's frame).
    for (eb, arc) in b.edge_arcs.iter().enumerate() {
        let arc = rot * *arc;
        for (ka, f) in a.faces.iter().enumerate() {
            t2[eb * nfa + ka] = f.normal.dot(arc);
        }
    }
    let mut best_e = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
    for (ea, &[a0, a1]) in a.edges.iter().enumerate() {
        let [fa0, fa1] = a.edge_faces[ea];
        let row1 = &t1[ea * nfb..(ea + 1) * nfb];
        let pa0 = a.vertices[a0 as usize];
        let da = a.vertices[a1 as usize] - pa0;
        for (eb, &[fb0, fb1]) in b.edge_faces.iter().enumerate() {
            let cba = row1[fb0 as usize];
            let dba = row1[fb1 as usize];
            if cba * dba >= 0.0 {
                continue;
            }
            let adc = t2[eb * nfa + fa0 as usize];
            let bdc = t2[eb * nfa + fa1 as usize];
            if adc * bdc >= 0.0 || cba * bdc <= 0.0 {
                continue;
            }
            let [b0, b1] = b.edges[eb];
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
                *separation = s;
                return None;
            }
            if s > best_e.0 {
                best_e = (s, ea, eb, axis);
            }
        }
    }
    Some(best_e)
}

/// Edge axes by enumerating pairs of unique edge directions and projecting both bodies
/// (good for boxes: 3 x 3 axes). Any axis is a valid separating-axis candidate, and the
/// Minkowski-face normals are among these, so the smallest overlap is still the exact one.
#[allow(clippy::too_many_arguments)]
fn edge_axes_by_direction(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rot: glam::Mat3,
    a_local: &SoaPoints,
    b_soa: &SoaPoints,
    bv: &[Vec3],
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<EdgeAxis> {
    let mut best = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
    for (ia, &ua) in a.edge_dirs.iter().enumerate() {
        for (ib, ub) in b.edge_dirs.iter().enumerate() {
            let axis = ua.cross(rot * *ub);
            let len2 = axis.length_squared();
            if len2 < 1e-10 {
                continue;
            }
            let axis = axis / len2.sqrt();
            let (min_a, max_a) = (a_local.min_along(axis), a_local.max_along(axis));
            let (min_b, max_b) = (b_soa.min_along(axis), b_soa.max_along(axis));
            // Separation pushing B along +axis, and along -axis; keep the larger.
            let (s, axis) = if min_b - max_a >= min_a - max_b {
                (min_b - max_a, axis)
            } else {
                (min_a - max_b, -axis)
            };
            if s > 0.0 {
                // Remember one concrete edge pair with these directions for the next step.
                let ea = a
                    .edge_dir_of
                    .iter()
                    .position(|&d| d as usize == ia)
                    .unwrap_or(0);
                let eb = b
                    .edge_dir_of
                    .iter()
                    .position(|&d| d as usize == ib)
                    .unwrap_or(0);
                if ea < 0x8000 && eb < 0x8000 {
                    *hint = HINT_EDGE | ((ea as u32) << 15) | eb as u32;
                }
                *separation = s;
                return None;
            }
            if s > best.0 {
                best = (s, ia, ib, axis);
            }
        }
    }
    if best.0 == f32::NEG_INFINITY {
        return Some(best);
    }
    // The supporting edges: A's edge of direction ia furthest along the axis, B's edge of
    // direction ib furthest against it.
    let (_, ia, ib, axis) = best;
    let mut ea_best = (f32::NEG_INFINITY, 0usize);
    for (e, &[v0, v1]) in a.edges.iter().enumerate() {
        if a.edge_dir_of[e] as usize == ia {
            let h = axis.dot(a.vertices[v0 as usize] + a.vertices[v1 as usize]);
            if h > ea_best.0 {
                ea_best = (h, e);
            }
        }
    }
    let mut eb_best = (f32::INFINITY, 0usize);
    for (e, &[v0, v1]) in b.edges.iter().enumerate() {
        if b.edge_dir_of[e] as usize == ib {
            let h = axis.dot(bv[v0 as usize] + bv[v1 as usize]);
            if h < eb_best.0 {
                eb_best = (h, e);
            }
        }
    }
    Some((best.0, ea_best.1, eb_best.1, axis))
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
    clip: &mut ClipBuffers,
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
    let ClipBuffers { poly, tmp, pts } = clip;
    poly.clear();
    poly.extend(inc.face_loop(inc_face).iter().map(|&i| inc_v[i as usize]));
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
        std::mem::swap(poly, tmp);
        if poly.is_empty() {
            break;
        }
    }
    pts.clear();
    for &p in poly.iter() {
        let depth = rface.offset - n.dot(p);
        if depth > 0.0 {
            pts.push((p + n * (0.5 * depth), depth));
        }
    }
    if pts.is_empty() {
        // The separating-axis test found overlap but the incident face clips away entirely
        // (deep or oblique overlap): keep the contact with the incident body's deepest vertex
        // rather than losing it.
        let deepest = inc_v
            .iter()
            .copied()
            .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))?;
        let depth = rface.offset - n.dot(deepest);
        if depth <= 0.0 {
            return None;
        }
        return Some(Manifold::single(n, deepest + n * (0.5 * depth), depth));
    }
    Some(reduce(pts, n))
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
    let mut s = if denom > 1e-12 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = if e > 0.0 { (b * s + f) / e } else { 0.0 };
    if t < 0.0 {
        t = 0.0;
        s = if a > 0.0 {
            (-c / a).clamp(0.0, 1.0)
        } else {
            0.0
        };
    } else if t > 1.0 {
        t = 1.0;
        s = if a > 0.0 {
            ((b - c) / a).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    (p0 + d1 * s, q0 + d2 * t)
}
