//! Convex "cores" placed in a common query frame, with their support mappings in `f64`.
//!
//! A sphere is handled as its centre point (a core with no extent) plus a radius that the
//! callers add back; a polyhedron is either in its own local frame (`Local`, no transform on the
//! support path) or moved into the query frame by a rigid transform (`Moved`).

use glam::{DMat3, DQuat, DVec3, Vec3};

use crate::{ConvexPolyhedron, Pose};

/// A convex point set in the query frame.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Core<'a> {
    /// A single point (the centre of a sphere).
    Point(DVec3),
    /// A polyhedron whose local frame is the query frame.
    Local(&'a ConvexPolyhedron),
    /// A polyhedron mapped by `x -> rot * x + pos` into the query frame (`rot_t` = `rot`ᵀ).
    Moved {
        poly: &'a ConvexPolyhedron,
        rot: DMat3,
        rot_t: DMat3,
        pos: DVec3,
    },
}

/// Index of the vertex furthest along `d` (f32 scan: the selection can be off by about
/// 1e-7 x the polyhedron's size on near ties, which moves a support value by that much only).
#[inline]
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

impl<'a> Core<'a> {
    /// Builds the core of a polyhedron posed by `rot`, `pos` relative to the query frame.
    pub(crate) fn moved(poly: &'a ConvexPolyhedron, rot: DMat3, pos: DVec3) -> Self {
        Core::Moved { poly, rot, rot_t: rot.transpose(), pos }
    }

    /// The point of the core furthest along `d` (query frame).
    #[inline]
    pub(crate) fn support(&self, d: DVec3) -> DVec3 {
        match self {
            Core::Point(p) => *p,
            Core::Local(p) => p.vertices[support_index(p, d.as_vec3())].as_dvec3(),
            Core::Moved { poly, rot, rot_t, pos } => {
                let ld = *rot_t * d;
                *rot * poly.vertices[support_index(poly, ld.as_vec3())].as_dvec3() + *pos
            }
        }
    }

    /// Largest distance from the core's reference point (its centre of mass) to the core.
    #[inline]
    pub(crate) fn radius(&self) -> f64 {
        match self {
            Core::Point(_) => 0.0,
            Core::Local(p) | Core::Moved { poly: p, .. } => p.radius as f64,
        }
    }

    /// The core's reference point (centre of mass) in the query frame.
    #[inline]
    pub(crate) fn center(&self) -> DVec3 {
        match self {
            Core::Point(p) => *p,
            Core::Local(_) => DVec3::ZERO,
            Core::Moved { pos, .. } => *pos,
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

    /// From a quaternion (normalised here) and a translation.
    #[inline]
    pub(crate) fn new(q: DQuat, pos: DVec3) -> Self {
        let q = q.normalize();
        let q = if q.is_finite() { q } else { DQuat::IDENTITY };
        Self { rot: DMat3::from_quat(q), pos }
    }

    /// `self⁻¹ * other`: `other` expressed in the frame of `self`.
    #[inline]
    pub(crate) fn inv_mul(&self, other: &DPose) -> DPose {
        let rt = self.rot.transpose();
        DPose { rot: rt * other.rot, pos: rt * (other.pos - self.pos) }
    }

    #[inline]
    pub(crate) fn point(&self, x: DVec3) -> DVec3 {
        self.rot * x + self.pos
    }

    #[inline]
    pub(crate) fn vector(&self, x: DVec3) -> DVec3 {
        self.rot * x
    }
}
