//! The simulator's narrow phase: exact overlap of two shapes (or a shape and a wall plane) as
//! a contact manifold of up to four points, so that a cube resting on a face gets four support
//! points and stays flat.
//!
//! Polyhedron pairs use the separating-axis test on face normals and on the edge-edge axes
//! that survive Gauss-map pruning (only edge pairs whose arcs cross can form a face of the
//! Minkowski difference), then clip the incident face against the reference face's side planes.
//!
//! Between steps a pair may keep what its edge-axis search found ([`EdgeMemory`], through
//! [`collide_with_memory`]): the edge pairs that can pass the Gauss-map tests near the
//! rotation it was recorded at, or the direction pairs too deep to matter, so that later
//! searches visit fewer pairs for the same answer, bitwise. A sphere against a polyhedron
//! keeps there the faces and edges that may still give its closest point (see `sphere`),
//! and, found apart, gives a bound of the distance so that the caller can skip it.

use glam::Vec3;

use crate::{Pose, Shape};

mod certify;
mod clip;
mod edges;
mod lanes;
mod memory;
#[cfg(test)]
mod plane_tests;
#[cfg(test)]
mod reach_tests;
mod sat;
mod slack;
mod sphere;
#[cfg(test)]
mod test_shapes;

#[doc(hidden)]
pub use certify::wedge_certificates;
pub(crate) use lanes::SoaPoints;
pub use memory::EdgeMemory;
pub use sat::polyhedron_polyhedron;
pub use sphere::sphere_polyhedron;

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

/// What the narrow phase remembers between steps for one pair (temporal coherence), in one
/// word, with the pair's `bound` (see [`collide_with_hint`]):
/// - for a pair found apart, the axis that separated it: bodies move little per DEM step, so
///   the axis usually still separates them next step and one test replaces the full
///   separating-axis search;
/// - for polyhedra found touching, the contact the full test chose (the reference face of A
///   or of B, or an edge contact; see [`is_contact_hint`]): while the pair's margin lasts,
///   the same test would choose it again, so only that face is clipped (only the edge axes
///   are searched for an edge contact).
///
/// [`NO_HINT`] when there is none.
pub type SatHint = u32;
/// No remembered axis.
pub const NO_HINT: SatHint = u32::MAX;
/// The kind bits of a hint naming a face of A (the face index below [`HINT_CONTACT`]).
pub const HINT_FACE_A: u32 = 0;
/// The kind bits of a hint naming a face of B.
pub const HINT_FACE_B: u32 = 1 << 30;
const HINT_EDGE: u32 = 2 << 30;
/// The mask of a hint's kind bits ([`HINT_FACE_A`], [`HINT_FACE_B`], edges).
pub const HINT_KIND: u32 = 3 << 30;
/// Set in a face hint that names the reference face of a touching pair (not a separating
/// axis). Face indices stay below this bit.
pub const HINT_CONTACT: u32 = 1 << 29;
/// The contact hint of a touching pair whose contact is an edge contact (its face index,
/// `HINT_CONTACT - 1`, names no face).
pub const HINT_EDGE_CONTACT: SatHint = HINT_FACE_A | HINT_CONTACT | (HINT_CONTACT - 1);

/// Whether `hint` remembers the contact feature of a touching polyhedron pair (its `bound`
/// is then the pair's decision margin) rather than a separating axis.
#[inline]
pub fn is_contact_hint(hint: SatHint) -> bool {
    hint != NO_HINT && hint & HINT_KIND != HINT_EDGE && hint & HINT_CONTACT != 0
}

/// [`collide`] with what the pair remembers from earlier steps (`hint`, read first and
/// updated) and its `bound`:
/// - on return, for a pair found apart, `bound` is a lower bound of the distance (0 when
///   unknown): the caller may skip the pair until the bodies have moved that far;
/// - for a touching polyhedron pair, `hint` names the contact face and `bound` is its
///   margin: how much any separation of the full test may still change before one of the
///   test's decisions could turn (0 and [`NO_HINT`] when there is none). The caller
///   subtracts from `bound`, before each later call, twice a bound of how much any axis's
///   separation can have changed since (both sides of each decision move); while it stays
///   above minus twice the reference face's separation at the call's poses (for an edge
///   contact: above minus the best edge axis's separation), the
///   remembered contact stands in for the full test, and the manifold is the one the full
///   test would give, bitwise.
///
/// See [`polyhedron_polyhedron`].
pub fn collide_with_hint(
    a: &Shape,
    pa: &Pose,
    b: &Shape,
    pb: &Pose,
    hint: &mut SatHint,
    bound: &mut f32,
) -> Option<Manifold> {
    match (a, b) {
        (Shape::Polyhedron(p), Shape::Polyhedron(q)) => {
            polyhedron_polyhedron(p, pa, q, pb, hint, bound)
        }
        (Shape::Composite(_), _) | (_, Shape::Composite(_)) => {
            *bound = 0.0;
            deepest_piece_contact(a, pa, b, pb)
        }
        (Shape::Sphere { radius }, Shape::Polyhedron(p)) => {
            sphere::sphere_polyhedron_with(pa.position, *radius, p, pb, bound, None)
        }
        (Shape::Polyhedron(p), Shape::Sphere { radius }) => {
            sphere::sphere_polyhedron_with(pb.position, *radius, p, pa, bound, None)
                .map(Manifold::flipped)
        }
        _ => {
            *bound = 0.0;
            collide_convex(a, pa, b, pb)
        }
    }
}

/// [`collide_with_hint`] with the pair's [`EdgeMemory`] as well (read and updated): the
/// same manifold, bitwise. A touching polyhedron pair's remembered contact is then
/// anchored on the relative pose of the full test that stored its margin (the memory keeps
/// that pose): the caller takes nothing off `bound` for it, and the narrow phase takes off
/// twice how much any separation can have changed since that pose, so jitter in place does
/// not add up (see `slack::Anchor`); `bound` then stays the full test's margin while the
/// contact serves (a pair apart keeps [`collide_with_hint`]'s hint and bound, bitwise).
/// A polyhedron pair whose edge axes go by Gauss
/// map then visits only the edge pairs the memory holds while B's rotation relative to A
/// stays near the one it was recorded at, and a sphere against a polyhedron only the faces
/// and edges that may still give its closest point while its centre stays near the one it
/// was recorded at.
pub fn collide_with_memory(
    a: &Shape,
    pa: &Pose,
    b: &Shape,
    pb: &Pose,
    hint: &mut SatHint,
    bound: &mut f32,
    memory: &mut EdgeMemory,
) -> Option<Manifold> {
    let mut found = None;
    collide_with_memory_into(a, pa, b, pb, hint, bound, memory, &mut found);
    found
}

/// [`collide_with_memory`] written to `found` (whatever it held before) instead of
/// returned: the same manifold, bitwise. Inlined into the caller, so that a polyhedron
/// pair's manifold is written where the caller reads it (the contacts stage's pair loop):
/// returned, it went through this function's frame and the narrow phase's, ~35
/// instructions a pair on a settled cube pile (issue 23, pp38, callgrind).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn collide_with_memory_into(
    a: &Shape,
    pa: &Pose,
    b: &Shape,
    pb: &Pose,
    hint: &mut SatHint,
    bound: &mut f32,
    memory: &mut EdgeMemory,
    found: &mut Option<Manifold>,
) {
    *found = match (a, b) {
        (Shape::Polyhedron(p), Shape::Polyhedron(q)) => {
            return sat::polyhedron_pair(p, pa, q, pb, hint, bound, Some(memory), found);
        }
        (Shape::Sphere { radius }, Shape::Polyhedron(p)) => {
            sphere::sphere_polyhedron_with(pa.position, *radius, p, pb, bound, Some(memory))
        }
        (Shape::Polyhedron(p), Shape::Sphere { radius }) => {
            sphere::sphere_polyhedron_with(pb.position, *radius, p, pa, bound, Some(memory))
                .map(Manifold::flipped)
        }
        _ => collide_with_hint(a, pa, b, pb, hint, bound),
    };
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
            if p.vertices.len() <= 64 {
                // The vertices below the plane from the SIMD lanes (the same heights), and
                // the usual patch of at most four written straight into the manifold, in
                // vertex order: what `reduce` returns for four or fewer.
                let below = p.lanes().below(n_local, centre_height, p.vertices.len());
                let count = below.count_ones() as usize;
                if count == 0 {
                    return None;
                }
                if count <= 4 {
                    let mut m = Manifold {
                        normal: n,
                        count,
                        ..Default::default()
                    };
                    let mut left = below;
                    for slot in &mut m.points[..count] {
                        let v = p.vertices[left.trailing_zeros() as usize];
                        left &= left - 1;
                        let h = n_local.dot(v) + centre_height;
                        *slot = ContactPoint {
                            point: pose.transform_point(v) - n * (0.5 * h),
                            depth: -h,
                        };
                    }
                    return Some(m);
                }
            }
            plane_patch_scan(p, n, n_local, centre_height, pose)
        }
        Shape::Composite(_) => None,
    }
}

/// [`collide_plane`] for a polyhedron, for a caller that keeps its manifold in place and
/// can use how far apart a pair was found: when something touches, `Ok(())` with `out`'s
/// normal, count and used points set to those of `collide_plane`'s manifold, bit for bit
/// (the same expressions in the same order; the unused points are no part of it);
/// when nothing touches (`collide_plane` gives `None`), `Err(lowest)`:
/// - at the bounding-sphere test, `centre_height - radius` (every vertex is at most
///   `radius` from the centre, so none is lower, to the rounding of `radius`);
/// - after the vertex test, the lowest vertex height `n_local . v + centre_height` as the
///   test computed them (the smallest sum rounded once: rounding is monotonic), for a
///   finite `n_local` and `centre_height`;
/// - else (a NaN or infinite pose, the scan's path) minus infinity: nothing known.
#[inline(always)]
pub fn collide_plane_polyhedron(
    plane: &Plane,
    p: &crate::ConvexPolyhedron,
    pose: &Pose,
    out: &mut Manifold,
) -> Result<(), f32> {
    let n = plane.normal;
    let centre_height = n.dot(pose.position) - plane.offset;
    if centre_height >= p.radius {
        return Err(centre_height - p.radius);
    }
    let n_local = pose.rotation.conjugate() * n;
    if p.vertices.len() <= 64 {
        // `collide_plane_convex`'s lanes, with the manifold written into `out`.
        let below = p.lanes().below(n_local, centre_height, p.vertices.len());
        let count = below.count_ones() as usize;
        if count == 0 {
            let finite = n_local.is_finite() && centre_height.is_finite();
            return Err(if finite {
                p.lanes().min_along(n_local) + centre_height
            } else {
                f32::NEG_INFINITY
            });
        }
        if count <= 4 {
            out.normal = n;
            out.count = count;
            let mut left = below;
            for slot in &mut out.points[..count] {
                let v = p.vertices[left.trailing_zeros() as usize];
                left &= left - 1;
                let h = n_local.dot(v) + centre_height;
                *slot = ContactPoint {
                    point: pose.transform_point(v) - n * (0.5 * h),
                    depth: -h,
                };
            }
            return Ok(());
        }
    }
    match plane_patch_scan(p, n, n_local, centre_height, pose) {
        Some(m) => {
            *out = m;
            Ok(())
        }
        None => Err(f32::NEG_INFINITY),
    }
}

/// A polyhedron against a plane by a scan of its vertices (`n_local`: the plane's normal
/// in the body's frame; `centre_height`: the body's centre above the plane): every vertex
/// with `n_local . v + centre_height < 0`, in vertex order, reduced to at most four. The
/// general case of [`collide_plane`] (patches of more than four points, hulls of more than
/// 64 vertices), and the reference its lanes' path is tested against.
fn plane_patch_scan(
    p: &crate::ConvexPolyhedron,
    n: Vec3,
    n_local: Vec3,
    centre_height: f32,
    pose: &Pose,
) -> Option<Manifold> {
    // Room for the usual patch (a face's vertices) without an allocation; more go to
    // `extra`, in the same order. Not 64: the whole buffer is zeroed on every call,
    // which at 1 KiB cost more than the test of the vertices itself.
    let mut buf = [(Vec3::ZERO, 0.0f32); 16];
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

/// A manifold of at most four of the patch points `(point, depth)` with `normal` (the
/// same reduction as the narrow phase's: deepest point, then the widest support polygon).
pub fn patch(pts: &[(Vec3, f32)], normal: Vec3) -> Manifold {
    reduce(pts, normal)
}

/// Keeps at most four points of a contact patch (see [`crate::reduce::reduce`]): all of
/// them, in order, when there are four or fewer (what `reduce` returns then, taken here
/// without the call: the usual face contact), else the four it chooses.
#[inline]
fn reduce(pts: &[(Vec3, f32)], normal: Vec3) -> Manifold {
    if pts.len() <= 4 {
        let mut m = Manifold {
            normal,
            count: pts.len(),
            ..Default::default()
        };
        for (slot, &(point, depth)) in m.points.iter_mut().zip(pts) {
            *slot = ContactPoint { point, depth };
        }
        return m;
    }
    reduce_more(pts, normal)
}

/// [`reduce`] of more than four points, out of line.
#[inline(never)]
fn reduce_more(pts: &[(Vec3, f32)], normal: Vec3) -> Manifold {
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
