//! Collision queries between any two shapes (spheres, boxes, Platonic solids, convex hulls):
//! [`intersects`], [`distance`] with closest points, [`contact`] (normal, depth, witness points
//! and a clipped contact manifold) and [`time_of_impact`] under constant linear and angular
//! velocity.
//!
//! All inputs and outputs are in the world frame and in `f32`; the work is done in `f64`
//! (GJK for distances, EPA for penetration, exact face tests for a sphere centre inside a
//! polyhedron, conservative advancement for the time of impact). A sphere is a point with a
//! radius, never a tessellation. Normals point from `a` to `b`: moving `b` along the normal
//! increases the separation.
//!
//! Tolerances and iteration caps (see each module for what is returned when a cap is hit):
//! * GJK: [`GJK_MAX_ITERATIONS`], relative tolerance [`GJK_REL_TOL`] on the distance,
//!   distances below [`GJK_ABS_TOL`] x the configuration scale count as touching;
//! * EPA: [`EPA_MAX_ITERATIONS`] / [`EPA_MAX_VERTICES`], relative tolerance [`EPA_REL_TOL`];
//! * time of impact: [`TOI_MAX_ITERATIONS`], distance tolerance [`TOI_REL_TOL`] x the sum of the
//!   bounding radii.
//!
//! Vertex selection in the support mapping is done in `f32` (the vertices are `f32`), which
//! can pick a vertex whose support value is about 1e-7 x the shape's size below the best on
//! near ties; distances and depths are therefore exact to about `1e-7 x size` absolute plus
//! the relative tolerances above.

mod boxes;
mod epa;
mod gjk;
mod manifold;
pub(crate) mod support;
mod toi;

use glam::{DVec3, Vec3};

pub use epa::{EPA_ABS_TOL, EPA_MAX_ITERATIONS, EPA_MAX_VERTICES, EPA_REL_TOL};
pub use gjk::{GJK_ABS_TOL, GJK_MAX_ITERATIONS, GJK_REL_TOL};
pub use manifold::{FACE_ALIGNMENT_COS, MAX_MANIFOLD_POINTS};
pub use toi::{Motion, TOI_MAX_ITERATIONS, TOI_REL_TOL, Toi, time_of_impact};

use crate::{ConvexPolyhedron, Pose, Shape};
use gjk::{GjkStatus, gjk};
use support::{Core, DPose, LocalPoly, Obb, PointCore, as_box, with_cores};

/// Result of [`distance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Distance {
    /// Euclidean distance between the shapes; `0.0` when they touch or overlap.
    pub distance: f32,
    /// Closest points on `a` and on `b`. When the shapes overlap both are the same point,
    /// common to both shapes.
    pub points: [Vec3; 2],
    /// Unit vector from `points[0]` to `points[1]`; zero when the shapes overlap (use
    /// [`contact`] for a penetration normal).
    pub normal: Vec3,
}

/// Contact points of a [`Contact`]: at most [`MAX_MANIFOLD_POINTS`] world points.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Manifold {
    points: [Vec3; MAX_MANIFOLD_POINTS],
    len: usize,
}

impl Manifold {
    /// The contact points (world frame).
    pub fn points(&self) -> &[Vec3] {
        &self.points[..self.len]
    }
    /// Number of points.
    pub fn len(&self) -> usize {
        self.len
    }
    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Result of [`contact`]: the penetration (or, for separated shapes, the gap) along the
/// contact normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Penetration depth: positive when the shapes overlap (the length `b` must move along
    /// `normal` to separate), negative when they are apart (minus the distance).
    pub depth: f32,
    /// Unit contact normal from `a` to `b`.
    pub normal: Vec3,
    /// Witness points on the surfaces of `a` and `b`: `points[0] - points[1] = depth * normal`,
    /// so moving `b` by `depth` along `normal` brings `points[1]` onto `points[0]`, where the
    /// shapes then touch. For shapes that are apart, the closest points.
    pub points: [Vec3; 2],
    /// Contact manifold: points half-way between the two surfaces, from clipping the
    /// reference and incident faces (one point for spheres and edge contacts).
    pub manifold: Manifold,
}

/// The two shapes expressed in one query frame (the pose of the first polyhedron).
#[derive(Clone, Copy)]
pub(crate) enum Pair<'a> {
    /// Two spheres, world frame.
    Spheres {
        ca: DVec3,
        ra: f64,
        cb: DVec3,
        rb: f64,
    },
    /// A polyhedron at `frame` and a sphere of centre `c` (in the polyhedron's frame).
    /// `swapped`: the user's `a` is the sphere.
    SpherePoly {
        poly: &'a ConvexPolyhedron,
        obb: Option<Obb>,
        frame: DPose,
        c: DVec3,
        r: f64,
        swapped: bool,
    },
    /// Two polyhedra: `a` at `frame`, `b` at `frame * rel`.
    Polys {
        a: &'a ConvexPolyhedron,
        b: &'a ConvexPolyhedron,
        oa: Option<Obb>,
        ob: Option<Obb>,
        frame: DPose,
        rel: DPose,
    },
}

impl<'a> Pair<'a> {
    /// The pair for single-precision poses, converting only the rotations that matter.
    #[inline]
    pub(crate) fn from_poses(a: &'a Shape, pa: &Pose, b: &'a Shape, pb: &Pose) -> Self {
        let sphere_pose = |p: &Pose| DPose {
            rot: glam::DMat3::IDENTITY,
            pos: p.position.as_dvec3(),
        };
        match (a, b) {
            (Shape::Sphere { .. }, Shape::Sphere { .. }) => {
                Pair::new(a, &sphere_pose(pa), b, &sphere_pose(pb))
            }
            (Shape::Polyhedron(_), Shape::Sphere { .. }) => {
                Pair::new(a, &DPose::from_pose(pa), b, &sphere_pose(pb))
            }
            (Shape::Sphere { .. }, Shape::Polyhedron(_)) => {
                Pair::new(a, &sphere_pose(pa), b, &DPose::from_pose(pb))
            }
            _ => Pair::new(a, &DPose::from_pose(pa), b, &DPose::from_pose(pb)),
        }
    }

    pub(crate) fn new(a: &'a Shape, pa: &DPose, b: &'a Shape, pb: &DPose) -> Self {
        match (a, b) {
            (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) => Pair::Spheres {
                ca: pa.pos,
                ra: *ra as f64,
                cb: pb.pos,
                rb: *rb as f64,
            },
            (Shape::Polyhedron(p), Shape::Sphere { radius }) => Pair::SpherePoly {
                poly: p,
                obb: as_box(p),
                frame: *pa,
                c: pa.inverse_vector(pb.pos - pa.pos),
                r: *radius as f64,
                swapped: false,
            },
            (Shape::Sphere { radius }, Shape::Polyhedron(p)) => Pair::SpherePoly {
                poly: p,
                obb: as_box(p),
                frame: *pb,
                c: pb.inverse_vector(pa.pos - pb.pos),
                r: *radius as f64,
                swapped: true,
            },
            (Shape::Polyhedron(x), Shape::Polyhedron(y)) => Pair::Polys {
                a: x,
                b: y,
                oa: as_box(x),
                ob: as_box(y),
                frame: *pa,
                rel: pa.inv_mul(pb),
            },
            // The queries are for convex shapes (`clatter query` builds no composites): a
            // composite is answered as its bounding sphere.
            (Shape::Polyhedron(p), Shape::Composite(c)) => Pair::SpherePoly {
                poly: p,
                obb: as_box(p),
                frame: *pa,
                c: pa.inverse_vector(pb.pos - pa.pos),
                r: c.radius as f64,
                swapped: false,
            },
            (Shape::Composite(c), Shape::Polyhedron(p)) => Pair::SpherePoly {
                poly: p,
                obb: as_box(p),
                frame: *pb,
                c: pb.inverse_vector(pa.pos - pb.pos),
                r: c.radius as f64,
                swapped: true,
            },
            (Shape::Composite(_) | Shape::Sphere { .. }, _) => Pair::Spheres {
                ca: pa.pos,
                ra: a.bounding_radius() as f64,
                cb: pb.pos,
                rb: b.bounding_radius() as f64,
            },
        }
    }
}

/// Internal result in the query frame, for the internal order of the pair.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Raw {
    /// Signed separation: distance when apart, minus the depth when penetrating.
    pub sep: f64,
    /// Unit normal from the internal `a` to the internal `b` (zero when unknown).
    pub normal: DVec3,
    pub pa: DVec3,
    pub pb: DVec3,
    /// The shapes overlap (for distance queries: `pa == pb` is a common point).
    pub overlap: bool,
}

/// Maps a query-frame result to the world and the user's order: (points, normal).
#[inline]
fn to_world(frame: &DPose, swapped: bool, r: &Raw) -> ([Vec3; 2], Vec3) {
    let pa = frame.point(r.pa).as_vec3();
    let pb = frame.point(r.pb).as_vec3();
    let n = frame.vector(r.normal).as_vec3();
    if swapped {
        ([pb, pa], -n)
    } else {
        ([pa, pb], n)
    }
}

/// Largest `n·c - offset` over the faces (positive: `c` is outside that face's plane).
#[inline]
fn face_separation(p: &ConvexPolyhedron, c: DVec3) -> (f64, usize) {
    let cf = c.as_vec3();
    let mut best = f32::NEG_INFINITY;
    let mut bi = 0;
    for (i, f) in p.faces.iter().enumerate() {
        let s = f.normal.dot(cf) - f.offset;
        if s > best {
            best = s;
            bi = i;
        }
    }
    // Re-evaluate the chosen face in f64.
    let f = &p.faces[bi];
    (f.normal.as_dvec3().dot(c) - f.offset as f64, bi)
}

/// Sphere against sphere: signed separation along the centre line.
fn spheres(ca: DVec3, ra: f64, cb: DVec3, rb: f64) -> Raw {
    let d = cb - ca;
    let len = d.length();
    let n = if len > 0.0 { d / len } else { DVec3::X };
    Raw {
        sep: len - ra - rb,
        normal: n,
        pa: ca + n * ra,
        pb: cb - n * rb,
        overlap: len <= ra + rb,
    }
}

/// Distance-type result for two spheres: for overlapping spheres, a common point (the middle
/// of the overlap of the two diameters on the centre line) and a zero normal.
#[inline]
fn spheres_distance(ca: DVec3, ra: f64, cb: DVec3, rb: f64) -> Raw {
    let r = spheres(ca, ra, cb, rb);
    if !r.overlap {
        return r;
    }
    let len = (cb - ca).dot(r.normal);
    let lo = (-ra).max(len - rb);
    let hi = ra.min(len + rb);
    let q = ca + r.normal * (0.5 * (lo + hi));
    Raw {
        sep: 0.0,
        normal: DVec3::ZERO,
        pa: q,
        pb: q,
        overlap: true,
    }
}

/// Distance-type result for a polyhedron (internal `a`) and a sphere (internal `b`).
fn sphere_poly_distance(p: &ConvexPolyhedron, obb: &Option<Obb>, c: DVec3, r: f64) -> Raw {
    if let Some(o) = obb {
        return boxes::sphere_box(o, c, r, true);
    }
    let (s, _) = face_separation(p, c);
    if s <= 0.0 {
        return Raw {
            sep: 0.0,
            normal: DVec3::ZERO,
            pa: c,
            pb: c,
            overlap: true,
        };
    }
    let g = gjk(&LocalPoly(p), &PointCore(c), -c, None);
    let d = g.distance();
    if g.status == GjkStatus::Overlapping || d <= r {
        let q = g.pa;
        return Raw {
            sep: 0.0,
            normal: DVec3::ZERO,
            pa: q,
            pb: q,
            overlap: true,
        };
    }
    let n = (c - g.pa) / d;
    Raw {
        sep: d - r,
        normal: n,
        pa: g.pa,
        pb: c - n * r,
        overlap: false,
    }
}

/// Contact-type result for a polyhedron (internal `a`) and a sphere (internal `b`).
fn sphere_poly_contact(p: &ConvexPolyhedron, obb: &Option<Obb>, c: DVec3, r: f64) -> Raw {
    if let Some(o) = obb {
        return boxes::sphere_box(o, c, r, false);
    }
    let (s, f) = face_separation(p, c);
    if s > 0.0 {
        let g = gjk(&LocalPoly(p), &PointCore(c), -c, None);
        let d = g.distance();
        if g.status != GjkStatus::Overlapping && d > 0.0 {
            let n = (c - g.pa) / d;
            return Raw {
                sep: d - r,
                normal: n,
                pa: g.pa,
                pb: c - n * r,
                overlap: d <= r,
            };
        }
    }
    // Centre inside (or on the surface): the nearest face plane gives the exact depth.
    let n = p.faces[f].normal.as_dvec3();
    let s = s.min(0.0);
    Raw {
        sep: s - r,
        normal: n,
        pa: c - n * s,
        pb: c - n * r,
        overlap: true,
    }
}

/// Distance-type result for two polyhedra in the query frame.
fn polys_distance(a: &Core, b: &Core, dir: DVec3) -> Raw {
    let g = with_cores!(a, b, |x, y| gjk(x, y, dir, None));
    if g.status == GjkStatus::Overlapping {
        return Raw {
            sep: 0.0,
            normal: DVec3::ZERO,
            pa: g.pa,
            pb: g.pb,
            overlap: true,
        };
    }
    let d = g.v.length();
    Raw {
        sep: d,
        normal: -g.v / d,
        pa: g.pa,
        pb: g.pb,
        overlap: false,
    }
}

/// Contact-type result (without manifold) for two polyhedra in the query frame.
#[allow(clippy::too_many_arguments)]
fn polys_contact(oa: &Option<Obb>, ob: &Option<Obb>, ca: &Core, cb: &Core, rel: &DPose) -> Raw {
    if let (Some(x), Some(y)) = (oa, ob) {
        if let Some(r) = boxes::box_box(x, y, rel, false) {
            return r;
        }
        return polys_distance(ca, cb, -rel.pos);
    }
    let (g, e) = with_cores!(ca, cb, |x, y| {
        let g = gjk(x, y, -rel.pos, None);
        let e = (g.status == GjkStatus::Overlapping).then(|| epa::epa(x, y, &g.simplex));
        (g, e)
    });
    let Some(e) = e else {
        let d = g.v.length();
        return Raw {
            sep: d,
            normal: -g.v / d,
            pa: g.pa,
            pb: g.pb,
            overlap: false,
        };
    };
    Raw {
        sep: -e.depth,
        normal: e.normal,
        pa: e.pa,
        pb: e.pb,
        overlap: true,
    }
}

impl Pair<'_> {
    /// Distance-type result and how to map it to the world.
    pub(crate) fn distance_raw(&self) -> (Raw, DPose, bool) {
        match *self {
            Pair::Spheres { ca, ra, cb, rb } => (spheres_distance(ca, ra, cb, rb), IDENTITY, false),
            Pair::SpherePoly {
                poly,
                obb,
                frame,
                c,
                r,
                swapped,
            } => (sphere_poly_distance(poly, &obb, c, r), frame, swapped),
            Pair::Polys {
                a,
                b,
                oa,
                ob,
                frame,
                rel,
            } => {
                let (ca, cb) = (Core::local(a, &oa), Core::posed(b, &ob, &rel));
                (polys_distance(&ca, &cb, -rel.pos), frame, false)
            }
        }
    }
}

const IDENTITY: DPose = DPose {
    rot: glam::DMat3::IDENTITY,
    pos: DVec3::ZERO,
};

/// True when the shapes touch or overlap (distance <= 0, with touching decided to about
/// [`GJK_ABS_TOL`] x the configuration scale).
pub fn intersects(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose) -> bool {
    let d = (pose_b.position - pose_a.position).as_dvec3();
    let reach = a.bounding_radius() as f64 + b.bounding_radius() as f64;
    if d.length_squared() > reach * reach {
        return false;
    }
    if let (Shape::Sphere { .. }, Shape::Sphere { .. }) = (a, b) {
        return true; // the bounding test above is exact for two spheres
    }
    match Pair::from_poses(a, pose_a, b, pose_b) {
        Pair::Spheres { .. } => true,
        Pair::SpherePoly {
            poly, obb, c, r, ..
        } => {
            if let Some(o) = obb {
                let cb = o.axes.transpose() * c;
                let q = cb.clamp(-o.half, o.half);
                return (cb - q).length_squared() <= r * r;
            }
            let (s, _) = face_separation(poly, c);
            if s > r {
                return false;
            }
            if s <= 0.0 {
                return true;
            }
            let g = gjk(&LocalPoly(poly), &PointCore(c), -c, Some(r));
            match g.status {
                GjkStatus::BeyondMargin => false,
                GjkStatus::WithinMargin | GjkStatus::Overlapping => true,
                GjkStatus::Separated | GjkStatus::MaxIterations => g.v.length() <= r,
            }
        }
        Pair::Polys {
            a, b, oa, ob, rel, ..
        } => {
            if let (Some(x), Some(y)) = (&oa, &ob) {
                return boxes::box_box(x, y, &rel, true).is_some();
            }
            let (ca, cb) = (Core::local(a, &oa), Core::posed(b, &ob, &rel));
            let g = with_cores!(&ca, &cb, |x, y| gjk(x, y, -rel.pos, Some(0.0)));
            matches!(g.status, GjkStatus::Overlapping | GjkStatus::WithinMargin)
        }
    }
}

/// Distance and closest points (world frame). Overlapping shapes give distance 0, a common
/// point as both points and a zero normal.
pub fn distance(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose) -> Distance {
    if let (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) = (a, b) {
        let (ca, cb) = (pose_a.position.as_dvec3(), pose_b.position.as_dvec3());
        let r = spheres_distance(ca, *ra as f64, cb, *rb as f64);
        return Distance {
            distance: r.sep.max(0.0) as f32,
            points: [r.pa.as_vec3(), r.pb.as_vec3()],
            normal: r.normal.as_vec3(),
        };
    }
    // A sphere against a polyhedron: only the polyhedron's pose is converted.
    let sphere_poly = match (a, b) {
        (Shape::Polyhedron(p), Shape::Sphere { radius }) => {
            Some((p, pose_a, pose_b, radius, false))
        }
        (Shape::Sphere { radius }, Shape::Polyhedron(p)) => Some((p, pose_b, pose_a, radius, true)),
        _ => None,
    };
    if let Some((poly, pp, ps, radius, swapped)) = sphere_poly {
        let frame = DPose::from_pose(pp);
        let c = frame.inverse_vector(ps.position.as_dvec3() - frame.pos);
        let r = match as_box(poly) {
            Some(o) => boxes::sphere_box(&o, c, *radius as f64, true),
            None => sphere_poly_distance(poly, &None, c, *radius as f64),
        };
        // The sphere's point is its centre moved back along the normal (one rotation saved).
        let pa = frame.point(r.pa);
        let n = frame.vector(r.normal);
        let pb = if r.overlap {
            pa
        } else {
            ps.position.as_dvec3() - n * *radius as f64
        };
        let (pa, pb, n) = (pa.as_vec3(), pb.as_vec3(), n.as_vec3());
        let (points, normal) = if swapped {
            ([pb, pa], -n)
        } else {
            ([pa, pb], n)
        };
        return Distance {
            distance: r.sep.max(0.0) as f32,
            points,
            normal,
        };
    }
    let (r, frame, swapped) = Pair::from_poses(a, pose_a, b, pose_b).distance_raw();
    let (points, normal) = to_world(&frame, swapped, &r);
    Distance {
        distance: r.sep.max(0.0) as f32,
        points,
        normal,
    }
}

/// Penetration depth, normal, witness points and contact manifold (world frame). For shapes
/// that are apart, the depth is minus the distance and the points are the closest points, so
/// the result is continuous through first contact.
pub fn contact(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose) -> Contact {
    if let (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) = (a, b) {
        let (ca, cb) = (pose_a.position.as_dvec3(), pose_b.position.as_dvec3());
        let r = spheres(ca, *ra as f64, cb, *rb as f64);
        let mut manifold = Manifold::default();
        manifold.points[0] = ((r.pa + r.pb) * 0.5).as_vec3();
        manifold.len = 1;
        return Contact {
            depth: (-r.sep) as f32,
            normal: r.normal.as_vec3(),
            points: [r.pa.as_vec3(), r.pb.as_vec3()],
            manifold,
        };
    }
    let (r, frame, swapped, pts) = match Pair::from_poses(a, pose_a, b, pose_b) {
        Pair::Spheres { ca, ra, cb, rb } => {
            let r = spheres(ca, ra, cb, rb);
            (
                r,
                IDENTITY,
                false,
                manifold::Points::single((r.pa + r.pb) * 0.5),
            )
        }
        Pair::SpherePoly {
            poly,
            obb,
            frame,
            c,
            r,
            swapped,
        } => {
            let r = sphere_poly_contact(poly, &obb, c, r);
            (
                r,
                frame,
                swapped,
                manifold::Points::single((r.pa + r.pb) * 0.5),
            )
        }
        Pair::Polys {
            a,
            b,
            oa,
            ob,
            frame,
            rel,
        } => {
            let (ca, cb) = (Core::local(a, &oa), Core::posed(b, &ob, &rel));
            let mut r = polys_contact(&oa, &ob, &ca, &cb, &rel);
            let m = manifold::clip(a, b, &rel, r.normal, r.pa, r.pb, r.sep);
            if let Some((wa, wb)) = m.witness {
                (r.pa, r.pb) = (wa, wb);
            }
            (r, frame, false, m)
        }
    };
    let (points, normal) = to_world(&frame, swapped, &r);
    let mut manifold = Manifold::default();
    for i in 0..pts.n {
        manifold.points[i] = frame.point(pts.p[i]).as_vec3();
    }
    manifold.len = pts.n;
    Contact {
        depth: (-r.sep) as f32,
        normal,
        points,
        manifold,
    }
}
