//! The shape syntax shared by scene files and `clatter query`:
//! `{ sphere = { radius } }`, `{ box = { half_extents } }`,
//! `{ polyhedron = { kind, radius } }`, `{ convex = { points } }`.

use clatter_geom::{RegularKind, ShapeKind};
use serde::Deserialize;

/// Exactly one of the shape variants, as written by a user.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ShapeSpec {
    /// A sphere.
    pub sphere: Option<SphereSpec>,
    /// A rectangular box.
    #[serde(rename = "box")]
    pub box_: Option<BoxSpec>,
    /// A Platonic solid by name and circumradius.
    pub polyhedron: Option<PolyhedronSpec>,
    /// The convex hull of a point list.
    pub convex: Option<ConvexSpec>,
}

/// `sphere = { radius = .. }`
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    pub radius: f64,
}

/// `box = { half_extents = [hx, hy, hz] }`
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    pub half_extents: [f64; 3],
}

/// `polyhedron = { kind = "icosahedron", radius = .. }`
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PolyhedronSpec {
    pub kind: String,
    pub radius: f64,
}

/// `convex = { points = [[x, y, z], ..] }`
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ConvexSpec {
    pub points: Vec<[f64; 3]>,
}

impl ShapeSpec {
    /// The geometric description, or a message saying which variant is wrong and why.
    /// (Positivity of sizes and hull degeneracy are checked by [`ShapeKind::prepare`].)
    pub fn to_kind(&self) -> Result<ShapeKind, String> {
        let given = [
            self.sphere.is_some(),
            self.box_.is_some(),
            self.polyhedron.is_some(),
            self.convex.is_some(),
        ]
        .iter()
        .filter(|b| **b)
        .count();
        if given != 1 {
            return Err(format!(
                "a shape needs exactly one of `sphere`, `box`, `polyhedron`, `convex` (got {given})"
            ));
        }
        if let Some(s) = &self.sphere {
            return Ok(ShapeKind::Sphere { radius: s.radius });
        }
        if let Some(b) = &self.box_ {
            return Ok(ShapeKind::Box {
                half_extents: b.half_extents,
            });
        }
        if let Some(p) = &self.polyhedron {
            let kind = RegularKind::from_name(&p.kind).ok_or_else(|| {
                format!(
                    "unknown polyhedron kind `{}` (expected one of tetrahedron, cube, octahedron, dodecahedron, icosahedron)",
                    p.kind
                )
            })?;
            return Ok(ShapeKind::Regular {
                kind,
                radius: p.radius,
            });
        }
        let c = self
            .convex
            .as_ref()
            .expect("exactly one variant is present");
        Ok(ShapeKind::Convex {
            points: c.points.clone(),
        })
    }
}
