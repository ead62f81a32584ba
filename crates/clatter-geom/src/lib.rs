//! Geometry for clatter: convex shapes, convex hulls, exact mass properties and the
//! contact/collision queries the simulator and the `clatter query` command are built on.
//!
//! Everything here is plain data and pure functions: no I/O, no GPU, no threads.
//! Shapes are stored in their *principal frame*: the centre of mass at the origin and the
//! inertia tensor diagonal, so a body's state needs only a position, a quaternion and three
//! principal moments.

pub mod composite;
pub mod hull;
pub mod mass;
pub mod narrow;
pub mod polyhedron;
pub mod query;
mod reduce;
pub mod shape;
pub mod triangle;

pub use composite::{Composite, Piece, PieceSpec, prepare_composite};
pub use hull::convex_hull;
pub use mass::MassProperties;
pub use polyhedron::{BoxFrame, ConvexPolyhedron, Face};
pub use shape::{PreparedShape, RegularKind, Shape, ShapeKind};

use thiserror::Error;

/// Why a shape could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeomError {
    /// A length (radius, half extent) that must be positive and finite, within
    /// [`shape::LENGTH_RANGE`], was not.
    #[error("{what} must be a positive finite number from 1e-7 to 1e7 (m), got {value}")]
    NotPositive { what: &'static str, value: f64 },
    /// A point coordinate was NaN or infinite.
    #[error("point {index} has a non-finite coordinate")]
    NonFinitePoint { index: usize },
    /// The point set spans less than three dimensions (fewer than 4 non-coplanar points).
    #[error(
        "degenerate hull: the {count} points {why}; a convex hull needs at least 4 points that are not all coplanar"
    )]
    DegenerateHull { count: usize, why: &'static str },
    /// A composite shape without pieces.
    #[error("a composite needs at least one piece")]
    EmptyComposite,
    /// A composite with more pieces than contacts can address.
    #[error(
        "a composite has {count} pieces, more than the {} allowed",
        composite::MAX_PIECES
    )]
    TooManyPieces { count: usize },
    /// A composite piece that is itself a composite.
    #[error("piece {index} is itself a composite (pieces must be spheres or convex shapes)")]
    NestedComposite { index: usize },
    /// A composite piece with a non-finite offset or orientation (or a union without volume).
    #[error("piece {index} has a non-finite offset or orientation")]
    NonFinitePiece { index: usize },
}

/// Where a shape is: the world position of its local origin (the centre of mass for prepared
/// shapes) and its rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub position: glam::Vec3,
    pub rotation: glam::Quat,
}

impl Pose {
    /// Pose at `position` with `rotation`.
    pub fn new(position: glam::Vec3, rotation: glam::Quat) -> Self {
        Self { position, rotation }
    }
    /// Local point to world.
    #[inline]
    pub fn transform_point(&self, p: glam::Vec3) -> glam::Vec3 {
        self.rotation * p + self.position
    }
    /// World point to local.
    #[inline]
    pub fn inverse_transform_point(&self, p: glam::Vec3) -> glam::Vec3 {
        self.rotation.conjugate() * (p - self.position)
    }
}
