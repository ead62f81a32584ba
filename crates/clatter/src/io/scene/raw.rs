//! The scene file as serde reads it: one `Raw*` struct per TOML table, every value kept with
//! its span so that errors can name the line and column. Nothing here is validated; the
//! table validators beside this file do that.

use serde::Deserialize;
use toml::Spanned;

use crate::shape_spec::{BoxSpec, ConvexSpec, PolyhedronSpec, SphereSpec};

/// The whole file: one field per top-level table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) simulation: Option<Spanned<RawSimulation>>,
    #[serde(default)]
    pub(super) material: Vec<Spanned<RawMaterial>>,
    #[serde(default)]
    pub(super) shape: Vec<Spanned<RawShape>>,
    #[serde(default)]
    pub(super) wall: Vec<Spanned<RawWall>>,
    #[serde(default)]
    pub(super) sink: Vec<Spanned<RawSink>>,
    #[serde(default)]
    pub(super) boundary: Vec<Spanned<RawBoundary>>,
    pub(super) container: Option<Spanned<RawContainer>>,
    #[serde(default)]
    pub(super) body: Vec<Spanned<RawBody>>,
    #[serde(default)]
    pub(super) group: Vec<Spanned<RawGroup>>,
}

/// `[simulation]`: run length, time step, gravity, skin and the periodic box.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSimulation {
    pub(super) duration: Option<Spanned<f64>>,
    pub(super) steps: Option<Spanned<i64>>,
    pub(super) dt: Option<Spanned<f64>>,
    pub(super) gravity: Option<Spanned<[f64; 3]>>,
    pub(super) skin: Option<Spanned<f64>>,
    pub(super) periodic: Option<Spanned<RawPeriodic>>,
}

/// `periodic = { min, max, axes }` in `[simulation]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPeriodic {
    pub(super) min: Spanned<[f64; 3]>,
    pub(super) max: Spanned<[f64; 3]>,
    pub(super) axes: Spanned<String>,
}

/// Declares `RawMaterial` with one optional key per row of the coefficient table
/// ([`material_coefficients!`](crate::material_coefficients)), so that serde keeps its span
/// and `deny_unknown_fields` still names every key a material may have.
macro_rules! raw_material {
    ($( $(#[$doc:meta])* $name:ident { $($row:tt)* } )*) => {
        /// `[[material]]`: density, contact model and its constants, the coefficients
        /// (restitution, frictions, ...), cohesion.
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        pub(super) struct RawMaterial {
            pub(super) name: Spanned<String>,
            pub(super) density: Spanned<f64>,
            pub(super) model: Option<Spanned<String>>,
            pub(super) stiffness: Option<Spanned<f64>>,
            pub(super) youngs_modulus: Option<Spanned<f64>>,
            pub(super) poisson_ratio: Option<Spanned<f64>>,
            $(pub(super) $name: Option<Spanned<f64>>,)*
            pub(super) cohesion: Option<Spanned<RawCohesion>>,
        }

        impl RawMaterial {
            /// The coefficient keys the material gives, by name, in the table's order.
            pub(super) fn coefficients(&self) -> impl Iterator<Item = (&'static str, &Spanned<f64>)> {
                [$((stringify!($name), self.$name.as_ref()),)*]
                    .into_iter()
                    .filter_map(|(name, v)| Some((name, v?)))
            }
        }
    };
}

crate::material_coefficients!(raw_material);

/// `cohesion = { model = "dmt", surface_energy = .. }` in a material.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCohesion {
    pub(super) model: Spanned<String>,
    pub(super) surface_energy: Option<Spanned<f64>>,
}

/// `[[shape]]`: a name and exactly one of the shape kinds.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawShape {
    pub(super) name: Spanned<String>,
    pub(super) sphere: Option<Spanned<SphereSpec>>,
    #[serde(rename = "box")]
    pub(super) box_: Option<Spanned<BoxSpec>>,
    pub(super) polyhedron: Option<Spanned<PolyhedronSpec>>,
    pub(super) convex: Option<Spanned<ConvexSpec>>,
    pub(super) mesh: Option<Spanned<RawMesh>>,
    pub(super) composite: Option<Spanned<Vec<Spanned<RawPiece>>>>,
}

/// One piece of `composite = [ { shape = "ball", offset = [..], orientation = [w, x, y, z] } ]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPiece {
    pub(super) shape: Spanned<String>,
    pub(super) offset: Option<Spanned<[f64; 3]>>,
    pub(super) orientation: Option<Spanned<[f64; 4]>>,
}

/// `mesh = { file = "rock.obj", scale = 0.01, mode = "hull" }`
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMesh {
    pub(super) file: Spanned<String>,
    pub(super) scale: Option<Spanned<RawScale>>,
    pub(super) mode: Option<Spanned<String>>,
}

/// A mesh scale: one factor, or one per axis.
#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or an array of three numbers")]
pub(super) enum RawScale {
    Uniform(f64),
    Axes([f64; 3]),
}

/// `[[wall]]`: an infinite plane through `point` facing along `normal`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawWall {
    pub(super) point: Spanned<[f64; 3]>,
    pub(super) normal: Spanned<[f64; 3]>,
    pub(super) material: Spanned<String>,
}

/// `[[boundary]] mesh = { file, scale }, material, motion = { .. }, start, end`
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBoundary {
    pub(super) mesh: Spanned<RawBoundaryMesh>,
    pub(super) material: Spanned<String>,
    pub(super) motion: Option<Spanned<RawMotion>>,
    pub(super) start: Option<Spanned<f64>>,
    pub(super) end: Option<Spanned<f64>>,
}

/// `mesh = { file, scale, weld }` of a `[[boundary]]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBoundaryMesh {
    pub(super) file: Spanned<String>,
    pub(super) scale: Option<Spanned<RawScale>>,
    pub(super) weld: Option<Spanned<f64>>,
}

/// `motion = { velocity = [..] }` or `{ angular_velocity = [..], center = [..] }`
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMotion {
    pub(super) velocity: Option<Spanned<[f64; 3]>>,
    pub(super) angular_velocity: Option<Spanned<[f64; 3]>>,
    pub(super) center: Option<Spanned<[f64; 3]>>,
}

/// `[[sink]]`: a box that removes the bodies whose centres enter it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSink {
    pub(super) min: Spanned<[f64; 3]>,
    pub(super) max: Spanned<[f64; 3]>,
}

/// `[container]`: a box of walls (open at the top when `top = false`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawContainer {
    pub(super) min: Spanned<[f64; 3]>,
    pub(super) max: Spanned<[f64; 3]>,
    pub(super) material: Spanned<String>,
    #[serde(default = "yes")]
    pub(super) top: bool,
}

/// `top` defaults to true: a container is closed unless it says otherwise.
fn yes() -> bool {
    true
}

/// `[[body]]`: one body, placed and moving as given.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBody {
    pub(super) shape: Spanned<String>,
    pub(super) material: Spanned<String>,
    pub(super) position: Spanned<[f64; 3]>,
    pub(super) velocity: Option<Spanned<[f64; 3]>>,
    pub(super) angular_velocity: Option<Spanned<[f64; 3]>>,
    pub(super) orientation: Option<Spanned<[f64; 4]>>,
}

/// `[[group]]`: many bodies of one or more shapes, on a lattice or placed at random.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGroup {
    pub(super) shape: Option<Spanned<String>>,
    pub(super) shapes: Option<Spanned<Vec<Spanned<String>>>>,
    pub(super) material: Spanned<String>,
    pub(super) lattice: Option<Spanned<RawLattice>>,
    pub(super) random: Option<Spanned<RawRandom>>,
    #[serde(default)]
    pub(super) random_orientation: bool,
    pub(super) velocity: Option<Spanned<[f64; 3]>>,
    pub(super) angular_velocity: Option<Spanned<[f64; 3]>>,
    pub(super) seed: Option<u64>,
}

/// `lattice = { min, max, spacing }` of a group.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLattice {
    pub(super) min: Spanned<[f64; 3]>,
    pub(super) max: Spanned<[f64; 3]>,
    pub(super) spacing: Spanned<f64>,
}

/// `random = { min, max, count, seed }` of a group.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRandom {
    pub(super) min: Spanned<[f64; 3]>,
    pub(super) max: Spanned<[f64; 3]>,
    pub(super) count: Spanned<i64>,
    pub(super) seed: Option<u64>,
}
