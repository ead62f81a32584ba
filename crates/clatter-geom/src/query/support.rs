//! Convex "cores" placed in a common query frame, with their support mappings in `f64`.
//!
//! A sphere is handled as its centre point (a core with no extent, [`PointCore`]) plus a radius
//! that the callers add back; a polyhedron is either in its own local frame (`Local`, no
//! transform on the support path) or moved into the query frame by a rigid transform
//! (`Moved`); a recognised rectangular box gets a sign-test support (`Box`).

use glam::{DMat3, DQuat, DVec3, Vec3};

use crate::{ConvexPolyhedron, Pose};

/// A convex point set in the query frame.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Core<'a> {
    /// A polyhedron whose local frame is the query frame.
    Local(&'a ConvexPolyhedron),
    /// A polyhedron mapped by `x -> rot * x + pos` into the query frame (`rot_t` = `rot`ᵀ).
    Moved {
        poly: &'a ConvexPolyhedron,
        rot: DMat3,
        rot_t: DMat3,
        pos: DVec3,
    },
    /// A rectangular box `pos + Σ s_i m_i`, `s_i = ±1`: the columns of `m` are the box axes
    /// (query frame) scaled by the half extents. Support is a sign test per axis.
    Box { m: DMat3, pos: DVec3 },
}

/// A rectangular box recognised in a polyhedron's principal frame: orthonormal axes (columns,
/// right-handed) and half extents. The centre is the principal-frame origin (the centre of mass).
pub(crate) use crate::polyhedron::BoxFrame as Obb;

impl Obb {
    /// Columns = axes scaled by the half extents, after mapping the axes by `rot`.
    #[inline]
    pub(crate) fn scaled(&self, rot: &DMat3) -> DMat3 {
        let a = if self.aligned { *rot } else { *rot * self.axes };
        DMat3::from_cols(
            a.x_axis * self.half.x,
            a.y_axis * self.half.y,
            a.z_axis * self.half.z,
        )
    }
}

/// Recognises a rectangular box centred on the origin: 8 vertices and 6 faces whose normals
/// come in three mutually orthogonal antiparallel pairs (within 1e-5). Such a hexahedron is a
/// box; its half extents come from the vertex bounds along each axis. Boxes not centred on the
/// origin (never the case for prepared shapes) are left to the general polyhedron path.
///
/// Run once per polyhedron by [`ConvexPolyhedron::from_faces`]; queries read the cached
/// [`ConvexPolyhedron::box_frame`] through [`as_box`].
pub(crate) fn detect_box(p: &ConvexPolyhedron) -> Option<Obb> {
    if p.vertices.len() != 8 || p.faces.len() != 6 {
        return None;
    }
    // Fast path: a box authored axis-aligned keeps its axes in the principal frame. A unit
    // normal is a signed axis iff its L1 norm is 1; six faces of a convex polyhedron with
    // axis normals are the six signed axes, i.e. an axis-aligned box. With `n·x = offset` on
    // each face, `Σ |n| offset` is twice the half extents and `Σ n offset` twice the centre.
    let mut ok = true;
    let mut twice_half = Vec3::ZERO;
    let mut twice_centre = Vec3::ZERO;
    for f in &p.faces {
        let a = f.normal.abs();
        ok &= a.x + a.y + a.z < 1.0 + 1e-5;
        twice_half += a * f.offset;
        twice_centre += f.normal * f.offset;
    }
    if ok {
        // A box not centred on the origin (never the case for prepared shapes) is left to the
        // general polyhedron path.
        if twice_centre.abs().max_element() > 1e-5 * twice_half.max_element() {
            return None;
        }
        return Some(Obb {
            axes: DMat3::IDENTITY,
            half: (twice_half * 0.5).as_dvec3(),
            aligned: true,
        });
    }
    as_box_general(p)
}

/// The cached box frame of `p`, if it is a rectangular box centred on the origin.
#[inline(always)]
pub(crate) fn as_box(p: &ConvexPolyhedron) -> Option<Obb> {
    p.box_frame
}

fn as_box_general(p: &ConvexPolyhedron) -> Option<Obb> {
    const TOL: f32 = 1e-5;
    let mut axes = [Vec3::ZERO; 3];
    let mut sum = [0.0f32; 3];
    let mut count = [0u8; 3];
    let mut k = 0;
    'faces: for f in &p.faces {
        for i in 0..k {
            let d = f.normal.dot(axes[i]);
            if d.abs() >= 1.0 - TOL {
                sum[i] += f.offset;
                count[i] += 1;
                continue 'faces;
            }
            if d.abs() > TOL {
                return None;
            }
        }
        if k == 3 {
            return None;
        }
        axes[k] = f.normal;
        sum[k] = f.offset;
        count[k] = 1;
        k += 1;
    }
    if k != 3 || count != [2, 2, 2] {
        return None;
    }
    // Centred on the origin: opposite faces at the same distance (sum of offsets = 2 half,
    // difference = 2 centre); the first face of each pair set `sum`, check the vertex bounds.
    for (i, axis) in axes.iter().enumerate() {
        let (lo, hi) = p.vertices.iter().fold((f32::MAX, f32::MIN), |(lo, hi), v| {
            let d = v.dot(*axis);
            (lo.min(d), hi.max(d))
        });
        if (hi + lo).abs() > 1e-5 * (hi - lo) {
            return None;
        }
        sum[i] = hi - lo;
    }
    let x = axes[0].as_dvec3();
    let y = axes[1].as_dvec3();
    Some(Obb {
        axes: DMat3::from_cols(x, y, x.cross(y)),
        half: DVec3::new(sum[0] as f64, sum[1] as f64, sum[2] as f64) * 0.5,
        aligned: false,
    })
}

/// Index of the vertex furthest along `d` (f32 scan: the selection can be off by about
/// 1e-7 x the polyhedron's size on near ties, which moves a support value by that much only).
#[inline(always)]
pub(crate) fn support_index(p: &ConvexPolyhedron, d: Vec3) -> usize {
    let v = &p.vertices;
    let mut best = 0;
    let mut best_d = v[0].dot(d);
    for (i, x) in v.iter().enumerate().skip(1) {
        let dd = x.dot(d);
        if dd > best_d {
            best_d = dd;
            best = i;
        }
    }
    best
}

/// A convex set with a support mapping in the query frame. GJK and EPA are generic over it so
/// that each pair of core types gets its own straight-line code.
pub(crate) trait Support {
    /// The point of the set furthest along `d` (query frame).
    fn support(&self, d: DVec3) -> DVec3;
    /// Largest distance from the set's reference point (centre of mass) to the set.
    fn radius(&self) -> f64;
}

/// A single point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PointCore(pub DVec3);

/// A polyhedron in its own frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LocalPoly<'a>(pub &'a ConvexPolyhedron);

/// A polyhedron mapped by `x -> rot * x + pos`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MovedPoly<'a> {
    pub poly: &'a ConvexPolyhedron,
    pub rot: DMat3,
    pub rot_t: DMat3,
    pub pos: DVec3,
}

/// A box `pos + Σ ±m_i`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxCore {
    pub m: DMat3,
    pub pos: DVec3,
}

impl Support for PointCore {
    #[inline(always)]
    fn support(&self, _d: DVec3) -> DVec3 {
        self.0
    }
    #[inline(always)]
    fn radius(&self) -> f64 {
        0.0
    }
}

impl Support for LocalPoly<'_> {
    #[inline(always)]
    fn support(&self, d: DVec3) -> DVec3 {
        self.0.vertices[support_index(self.0, d.as_vec3())].as_dvec3()
    }
    #[inline(always)]
    fn radius(&self) -> f64 {
        self.0.radius as f64
    }
}

impl Support for MovedPoly<'_> {
    #[inline(always)]
    fn support(&self, d: DVec3) -> DVec3 {
        let ld = self.rot_t * d;
        self.rot * self.poly.vertices[support_index(self.poly, ld.as_vec3())].as_dvec3() + self.pos
    }
    #[inline(always)]
    fn radius(&self) -> f64 {
        self.poly.radius as f64
    }
}

impl Support for BoxCore {
    #[inline(always)]
    fn support(&self, d: DVec3) -> DVec3 {
        let m = &self.m;
        let pick = |c: DVec3| if d.dot(c) >= 0.0 { c } else { -c };
        self.pos + pick(m.x_axis) + pick(m.y_axis) + pick(m.z_axis)
    }
    #[inline(always)]
    fn radius(&self) -> f64 {
        (self.m.x_axis + self.m.y_axis + self.m.z_axis).length()
    }
}

impl Support for Core<'_> {
    #[inline(always)]
    fn support(&self, d: DVec3) -> DVec3 {
        Core::support(self, d)
    }
    #[inline(always)]
    fn radius(&self) -> f64 {
        Core::radius(self)
    }
}

/// Runs `$body` with `$x`, `$y` bound to the concrete core types of the enum cores `$a`, `$b`
/// (monomorphised GJK/EPA for the common pairs, the enum dispatch otherwise).
macro_rules! with_cores {
    ($a:expr, $b:expr, |$x:ident, $y:ident| $body:expr) => {{
        use $crate::query::support::{BoxCore, Core, LocalPoly, MovedPoly};
        match ($a, $b) {
            (
                Core::Local(p),
                Core::Moved {
                    poly,
                    rot,
                    rot_t,
                    pos,
                },
            ) => {
                let $x = &LocalPoly(p);
                let $y = &MovedPoly {
                    poly,
                    rot: *rot,
                    rot_t: *rot_t,
                    pos: *pos,
                };
                $body
            }
            (Core::Box { m, pos }, Core::Box { m: m2, pos: p2 }) => {
                let $x = &BoxCore { m: *m, pos: *pos };
                let $y = &BoxCore { m: *m2, pos: *p2 };
                $body
            }
            (Core::Local(p), Core::Box { m, pos }) => {
                let $x = &LocalPoly(p);
                let $y = &BoxCore { m: *m, pos: *pos };
                $body
            }
            (
                Core::Box { m, pos: p1 },
                Core::Moved {
                    poly,
                    rot,
                    rot_t,
                    pos,
                },
            ) => {
                let $x = &BoxCore { m: *m, pos: *p1 };
                let $y = &MovedPoly {
                    poly,
                    rot: *rot,
                    rot_t: *rot_t,
                    pos: *pos,
                };
                $body
            }
            (x, y) => {
                let $x = x;
                let $y = y;
                $body
            }
        }
    }};
}
pub(crate) use with_cores;

impl<'a> Core<'a> {
    /// Builds the core of a polyhedron posed by `rot`, `pos` relative to the query frame.
    pub(crate) fn moved(poly: &'a ConvexPolyhedron, rot: DMat3, pos: DVec3) -> Self {
        Core::Moved {
            poly,
            rot,
            rot_t: rot.transpose(),
            pos,
        }
    }

    /// The core of a polyhedron at the query-frame origin (a box core when `obb` is given).
    #[inline]
    pub(crate) fn local(poly: &'a ConvexPolyhedron, obb: &Option<Obb>) -> Self {
        match obb {
            Some(o) => Core::Box {
                m: o.scaled(&DMat3::IDENTITY),
                pos: DVec3::ZERO,
            },
            None => Core::Local(poly),
        }
    }

    /// The core of a polyhedron posed by `rel` (a box core when `obb` is given).
    #[inline]
    pub(crate) fn posed(poly: &'a ConvexPolyhedron, obb: &Option<Obb>, rel: &DPose) -> Self {
        match obb {
            Some(o) => Core::Box {
                m: o.scaled(&rel.rot),
                pos: rel.pos,
            },
            None => Core::moved(poly, rel.rot, rel.pos),
        }
    }

    /// The point of the core furthest along `d` (query frame).
    #[inline(always)]
    pub(crate) fn support(&self, d: DVec3) -> DVec3 {
        match self {
            Core::Local(p) => p.vertices[support_index(p, d.as_vec3())].as_dvec3(),
            Core::Moved {
                poly,
                rot,
                rot_t,
                pos,
            } => {
                let ld = *rot_t * d;
                *rot * poly.vertices[support_index(poly, ld.as_vec3())].as_dvec3() + *pos
            }
            Core::Box { m, pos } => {
                let pick = |c: DVec3| if d.dot(c) >= 0.0 { c } else { -c };
                *pos + pick(m.x_axis) + pick(m.y_axis) + pick(m.z_axis)
            }
        }
    }

    /// Largest distance from the core's reference point (its centre of mass) to the core.
    #[inline]
    pub(crate) fn radius(&self) -> f64 {
        match self {
            Core::Local(p) | Core::Moved { poly: p, .. } => p.radius as f64,
            Core::Box { m, .. } => (m.x_axis + m.y_axis + m.z_axis).length(),
        }
    }
}

/// A pose in `f64`: rotation matrix and translation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DPose {
    pub rot: DMat3,
    pub pos: DVec3,
}

impl DPose {
    /// Converts a single-precision pose (the quaternion is renormalised in `f64`).
    #[inline]
    pub(crate) fn from_pose(p: &Pose) -> Self {
        Self::new(p.rotation.as_dquat(), p.position.as_dvec3())
    }

    /// From a quaternion (of any non-zero length: the matrix is that of the normalised
    /// quaternion, built with one division and no square root) and a translation.
    #[inline]
    pub(crate) fn new(q: DQuat, pos: DVec3) -> Self {
        let n = q.length_squared();
        if !(n > 0.0 && n.is_finite()) {
            return Self {
                rot: DMat3::IDENTITY,
                pos,
            };
        }
        let s = 2.0 / n;
        let (x, y, z, w) = (q.x, q.y, q.z, q.w);
        let (xs, ys, zs) = (x * s, y * s, z * s);
        let (wx, wy, wz) = (w * xs, w * ys, w * zs);
        let (xx, xy, xz) = (x * xs, x * ys, x * zs);
        let (yy, yz, zz) = (y * ys, y * zs, z * zs);
        let rot = DMat3::from_cols(
            DVec3::new(1.0 - (yy + zz), xy + wz, xz - wy),
            DVec3::new(xy - wz, 1.0 - (xx + zz), yz + wx),
            DVec3::new(xz + wy, yz - wx, 1.0 - (xx + yy)),
        );
        Self { rot, pos }
    }

    /// `self⁻¹ * other`: `other` expressed in the frame of `self`.
    #[inline]
    pub(crate) fn inv_mul(&self, other: &DPose) -> DPose {
        let rt = self.rot.transpose();
        DPose {
            rot: rt * other.rot,
            pos: self.inverse_vector(other.pos - self.pos),
        }
    }

    #[inline]
    pub(crate) fn point(&self, x: DVec3) -> DVec3 {
        self.rot * x + self.pos
    }

    #[inline]
    pub(crate) fn vector(&self, x: DVec3) -> DVec3 {
        self.rot * x
    }

    /// `rotᵀ x`.
    #[inline]
    pub(crate) fn inverse_vector(&self, x: DVec3) -> DVec3 {
        DVec3::new(
            self.rot.x_axis.dot(x),
            self.rot.y_axis.dot(x),
            self.rot.z_axis.dot(x),
        )
    }
}
