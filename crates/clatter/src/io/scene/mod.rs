//! Scene files (TOML): materials, shapes, walls, a box container, single bodies and groups.
//! Every key is documented in `docs/scene-format.md`. Errors name the file, the line and
//! column, and the field, and nothing is simulated or written before the whole file is valid.
//!
//! This file holds the public types ([`Scene`], [`SceneError`], [`RunLength`]), the
//! `SourceFile` helpers that check values and locate errors, and `build`, which runs one
//! validator per table, in this order, and assembles the scene:
//! - `raw.rs`: the serde structs the TOML is read into (`Raw*`), values kept with their spans;
//! - `simulation.rs`: `[simulation]` (length, dt, gravity, skin; `periodic.rs` checks its
//!   `periodic` box, and the box against walls and bodies once those are known);
//! - `materials.rs`: `[[material]]`;
//! - `shapes.rs`: `[[shape]]`, mesh shapes (hull or [`decomposed`]) and composites;
//! - `walls.rs`: `[[wall]]`, then (after the boundaries) `[container]`;
//! - `boundaries.rs`: `[[boundary]]` meshes and their repair warnings and notes;
//! - `bodies.rs`: `[[body]]`;
//! - `groups.rs`: `[[group]]`, lattice and random placement ([`random_rotation`]);
//! - `sinks.rs`: `[[sink]]` (after the body count and periodic-box checks).

mod bodies;
mod boundaries;
mod groups;
mod materials;
mod periodic;
mod raw;
mod shapes;
mod simulation;
mod sinks;
mod walls;

use std::collections::HashMap;
use std::fmt;
use std::path::Path;

use glam::{Quat, Vec3};
use toml::Spanned;

use crate::mesh_boundary::Boundary;
use crate::sink::Sink;
use crate::world::{World, WorldDesc};
use raw::RawScene;

pub use groups::random_rotation;
pub use shapes::decomposed;

/// A scene file error: where and what.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file name as given.
    pub file: String,
    /// 1-based line and column, when known.
    pub line: Option<(usize, usize)>,
    /// The field, like `material[1].density`, when known.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some((l, c)) = self.line {
            write!(f, ":{l}:{c}")?;
        }
        write!(f, ": ")?;
        if let Some(field) = &self.field {
            write!(f, "`{field}`: ")?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for SceneError {}

/// How long to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RunLength {
    /// Simulated seconds.
    Duration(f64),
    /// A number of steps.
    Steps(u64),
}

/// A validated scene: the world description and how long to run it.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Where it came from (file name, or `<default scene>`).
    pub source: String,
    /// The world to build.
    pub desc: WorldDesc,
    /// Its triangle-mesh boundaries (`[[boundary]]`).
    pub boundaries: Vec<Boundary>,
    /// How long to run.
    pub length: RunLength,
    /// Things that are legal but probably not meant (overlapping lattice, large dt...).
    pub warnings: Vec<String>,
    /// Things worth knowing that change nothing (a mesh wound inwards...), printed as
    /// `note:` lines.
    pub notes: Vec<String>,
    /// `[[sink]]` boxes ([`crate::sink`]).
    pub sinks: Vec<Sink>,
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::read(path).map(|(_, scene)| scene)
    }

    /// Reads and validates a scene file; returns its text (for checkpoints) with the scene.
    pub fn read(path: &Path) -> Result<(String, Scene), SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            file: name.clone(),
            line: None,
            field: None,
            message: format!("cannot read the scene file: {e}"),
        })?;
        let scene = Scene::parse(&text, &name)?;
        Ok((text, scene))
    }

    /// Parses and validates scene text; `file` names it in errors, and mesh files
    /// (`[[shape]] mesh = { file = .. }`) are found relative to its directory (the current
    /// directory when `file` has none, like `<default scene>`).
    pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
        let dir = Path::new(file).parent().unwrap_or(Path::new(""));
        let cx = SourceFile { file, text, dir };
        let toml_error = |e: toml::de::Error, field: Option<String>| SceneError {
            file: file.to_string(),
            line: e.span().map(|s| cx.line_col(s.start)),
            field,
            message: e.message().trim().to_string(),
        };
        let de = toml::Deserializer::parse(text).map_err(|e| toml_error(e, None))?;
        // With the path of the value that did not fit (`material[0].density`), as the
        // validators' errors name their field.
        let raw: RawScene = serde_path_to_error::deserialize(de).map_err(|e| {
            let field = field_path(e.path());
            toml_error(e.into_inner(), field)
        })?;
        build(&cx, raw)
    }

    /// The world, ready to step.
    pub fn world(&self) -> World {
        let mut w = World::with_boundaries(self.desc.clone(), self.boundaries.clone());
        w.sinks.clone_from(&self.sinks);
        w
    }

    /// Number of steps to run with time step `dt`.
    pub fn steps(&self, dt: f32) -> u64 {
        match self.length {
            RunLength::Steps(n) => n,
            RunLength::Duration(d) => {
                // `dt` is an f32, so `d / dt` lands just above an integer for round values
                // (0.35 / 1e-4 = 3500.00009): count those as the integer, not one step more.
                let n = d / dt as f64;
                let r = n.round();
                let n = if (n - r).abs() <= 1e-6 * r.max(1.0) {
                    r
                } else {
                    n.ceil()
                };
                // At least one step: `ceil` of any positive duration over dt.
                n.max(1.0) as u64
            }
        }
    }
}

/// The scene file being read: its name and text, for error locations, and its directory,
/// against which mesh file paths are resolved.
struct SourceFile<'a> {
    file: &'a str,
    text: &'a str,
    dir: &'a Path,
}

impl SourceFile<'_> {
    /// The 1-based line and column of byte `offset`.
    fn line_col(&self, offset: usize) -> (usize, usize) {
        let before = &self.text[..offset.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before
            .rfind('\n')
            .map_or(before.len(), |p| before.len() - p - 1)
            + 1;
        (line, col)
    }

    /// An error at `span`, naming `field`.
    fn err<T>(
        &self,
        span: std::ops::Range<usize>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Result<T, SceneError> {
        Err(SceneError {
            file: self.file.to_string(),
            line: Some(self.line_col(span.start)),
            field: Some(field.into()),
            message: message.into(),
        })
    }

    /// `v`, which must be positive and finite, also as the 32-bit float the simulation
    /// keeps (1e300 would be infinite there, 1e-300 zero).
    fn positive(&self, v: &Spanned<f64>, field: &str) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if !(x.is_finite() && x > 0.0) {
            self.err(
                v.span(),
                field,
                format!("must be a positive finite number, got {x}"),
            )
        } else if !(fits_f32(x) && x as f32 >= f32::MIN_POSITIVE) {
            self.err(
                v.span(),
                field,
                format!(
                    "must be between {:e} and {:e} (it is kept as a 32-bit float), got {x:e}",
                    f32::MIN_POSITIVE,
                    f32::MAX
                ),
            )
        } else {
            Ok(x)
        }
    }

    /// `v`, which must be finite and >= 0, also as a 32-bit float.
    fn non_negative(&self, v: &Spanned<f64>, field: &str) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x >= 0.0 && fits_f32(x) {
            Ok(x)
        } else {
            self.err(
                v.span(),
                field,
                format!(
                    "must be a finite number >= 0 (at most {:e}), got {x}",
                    f32::MAX
                ),
            )
        }
    }

    /// `v` as a vector, whose three components must be finite, also as 32-bit floats.
    fn vec3(&self, v: &Spanned<[f64; 3]>, field: &str) -> Result<Vec3, SceneError> {
        let a = v.get_ref();
        if a.iter().all(|&c| fits_f32(c)) {
            Ok(Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32))
        } else {
            self.err(
                v.span(),
                field,
                format!(
                    "must have three finite numbers (kept as 32-bit floats: at most {:e} in size), got {a:?}",
                    f32::MAX
                ),
            )
        }
    }

    /// `v` as a double-precision vector (body positions, kept to 48 bits), within
    /// [`MAX_POSITION`] of the origin on each axis.
    fn dvec3(&self, v: &Spanned<[f64; 3]>, field: &str) -> Result<glam::DVec3, SceneError> {
        self.vec3(v, field)?;
        let a = *v.get_ref();
        if a.iter().any(|c| c.abs() > MAX_POSITION) {
            return self.err(
                v.span(),
                field,
                format!("must be within {MAX_POSITION:e} m of the origin on each axis, got {a:?}"),
            );
        }
        Ok(glam::DVec3::from_array(a))
    }

    /// `v` as a vector, zero when absent.
    fn opt_vec3(&self, v: &Option<Spanned<[f64; 3]>>, field: &str) -> Result<Vec3, SceneError> {
        v.as_ref().map_or(Ok(Vec3::ZERO), |v| self.vec3(v, field))
    }

    /// `v` normalised (in double precision: any finite non-zero direction, 1e-13 or 1e39
    /// long, is the direction it gives); the zero vector is refused.
    fn unit(&self, v: &Spanned<[f64; 3]>, field: &str) -> Result<Vec3, SceneError> {
        let a = v.get_ref();
        if !a.iter().all(|c| c.is_finite()) {
            return self.err(
                v.span(),
                field,
                format!("must have three finite numbers, got {a:?}"),
            );
        }
        // In f32 where its length is a normal f32 (the bits scenes have always had), else
        // in f64 first.
        let n = Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        let len = n.length();
        if len.is_finite() && len >= 1e-12 {
            return Ok(n.normalize());
        }
        match normalized(a) {
            Some(n) => Ok(Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32).normalize()),
            None => self.err(v.span(), field, "must not be the zero vector"),
        }
    }

    /// `[w, x, y, z]` normalised (identity when absent); zero or non-finite is refused.
    fn quat(&self, v: &Option<Spanned<[f64; 4]>>, field: &str) -> Result<Quat, SceneError> {
        let Some(v) = v else {
            return Ok(Quat::IDENTITY);
        };
        let a = v.get_ref();
        let n = a
            .iter()
            .all(|c| c.is_finite())
            .then(|| normalized(a))
            .flatten();
        let Some(n) = n else {
            return self.err(
                v.span(),
                field,
                format!("must be a non-zero quaternion [w, x, y, z] of finite numbers, got {a:?}"),
            );
        };
        // In f32 where its length is a normal f32 (the bits scenes have always had), else
        // normalised in double precision first (a quaternion of 1e20s overflows f32's
        // square), then once more in f32 for the rounding of the cast.
        let q = Quat::from_xyzw(a[1] as f32, a[2] as f32, a[3] as f32, a[0] as f32);
        let len = q.length();
        if len.is_finite() && len >= 1e-12 {
            return Ok(q.normalize());
        }
        Ok(Quat::from_xyzw(n[1] as f32, n[2] as f32, n[3] as f32, n[0] as f32).normalize())
    }

    /// The index of the `what` named `v` in `names`; an unknown name lists the known ones.
    fn lookup(
        &self,
        names: &HashMap<String, u32>,
        v: &Spanned<String>,
        field: &str,
        what: &str,
    ) -> Result<u32, SceneError> {
        match names.get(v.get_ref()) {
            Some(&i) => Ok(i),
            None => {
                let mut known: Vec<&str> = names.keys().map(String::as_str).collect();
                known.sort_unstable();
                self.err(
                    v.span(),
                    field,
                    format!(
                        "unknown {what} `{}` (defined: {})",
                        v.get_ref(),
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                )
            }
        }
    }
}

/// A deserialization error's path as a scene field (`body[2].position`), without the
/// segments of toml's `Spanned` wrapper; `None` at the top level.
fn field_path(path: &serde_path_to_error::Path) -> Option<String> {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for segment in path.iter() {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if key.starts_with("$__") {
                    continue;
                }
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => {}
        }
    }
    (!out.is_empty()).then_some(out)
}

/// Whether `x` is finite also as the 32-bit float the simulation keeps.
fn fits_f32(x: f64) -> bool {
    x.is_finite() && (x as f32).is_finite()
}

/// `a` over its length, computed without overflow or underflow (scaled by its largest
/// component first); `None` for the zero vector.
fn normalized<const N: usize>(a: &[f64; N]) -> Option<[f64; N]> {
    let big = a.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if !(big > 0.0 && big.is_finite()) {
        return None;
    }
    let scaled = a.map(|c| c / big);
    let len = scaled.iter().map(|c| c * c).sum::<f64>().sqrt();
    Some(scaled.map(|c| c / len))
}

/// The farthest a body may start from the origin along any axis, m: the broad phase bins
/// positions in f32 cells, which lose all meaning long before f32's range (a lone body at
/// 1e28 m went NaN at its first step). Positions are exact to 3.6e-13 m at 100 m; 1e15 m is
/// far past any physical domain.
pub const MAX_POSITION: f64 = 1e15;

/// Most bodies a scene may create (keeps a typo from allocating the machine away).
pub const MAX_BODIES: usize = 50_000_000;

/// The GPU narrow phase's limit on the vertices of one polyhedron
/// (`clatter_gpu::shapes::MAX_SHAPE_VERTICES`, checked equal by a test there); a scene whose
/// hulls exceed it gets a warning, since it can only run on the CPU.
pub const GPU_SHAPE_VERTICES: usize = 64;

/// The whole scene from its raw tables: each table's validator in file order (later tables
/// refer to earlier ones by name), then the checks across tables, then the warnings that
/// need the whole scene. The first error stops it.
fn build(cx: &SourceFile, raw: RawScene) -> Result<Scene, SceneError> {
    let mut warnings = Vec::new();
    let simulation::Simulation {
        length,
        dt,
        gravity,
        skin,
        periodic,
    } = simulation::simulation(cx, &raw.simulation)?;
    let (materials, material_names) = materials::materials(cx, &raw.material)?;
    let (shapes, shape_names) = shapes::shapes(cx, &raw.shape, &mut warnings)?;
    let mut walls = walls::walls(cx, &raw.wall, &material_names)?;
    let (boundaries, notes) =
        boundaries::boundaries(cx, &raw.boundary, &material_names, &mut warnings)?;
    let container_bounds = walls::container(
        cx,
        &raw.container,
        &material_names,
        periodic.as_ref().map(|(p, _)| p),
        &mut walls,
    )?;
    let mut bodies = bodies::bodies(cx, &raw.body, &shape_names, &material_names)?;
    warnings.extend(groups::groups(
        cx,
        &raw.group,
        &shapes,
        &shape_names,
        &material_names,
        periodic.as_ref().map(|(p, _)| *p),
        &mut bodies,
    )?);
    if bodies.is_empty() {
        return cx.err(
            0..0,
            "body",
            "the scene has no bodies: add [[body]] or [[group]] entries",
        );
    }
    if bodies.len() > MAX_BODIES {
        return cx.err(
            0..0,
            "group",
            format!("the scene has {} bodies (limit {MAX_BODIES})", bodies.len()),
        );
    }
    if let Some((p, span)) = &periodic {
        periodic::check_periodic(cx, p, span.clone(), &walls, &bodies, &shapes, skin)?;
    }
    let sinks = sinks::sinks(cx, &raw.sink, &walls, periodic.as_ref().map(|(p, _)| p))?;
    if periodic.is_some() && !boundaries.is_empty() {
        warnings.push(
            "triangle-mesh boundaries are not repeated across the periodic seams: a body meets a mesh's triangles only at its wrapped position, so a mesh should span the periodic box along its periodic axes (a chute floor) or stay clear of the seams".to_string(),
        );
    }
    if let Some((lo, hi)) = container_bounds {
        // Along a periodic axis the container has no faces and a body starts at its wrapped
        // position: only the other axes can leave it outside.
        let wraps = glam::BVec3::from(periodic.as_ref().map_or([false; 3], |(p, _)| p.axes));
        let outside = bodies
            .iter()
            .filter(|b| {
                let p = b.position.as_vec3();
                !((p.cmpge(lo) | wraps).all() && (p.cmple(hi) | wraps).all())
            })
            .count();
        if outside > 0 {
            warnings.push(format!("{outside} bodies start outside the container"));
        }
    }
    Ok(Scene {
        source: cx.file.to_string(),
        desc: WorldDesc {
            shapes,
            materials,
            walls,
            bodies,
            gravity,
            dt,
            skin,
            periodic: periodic.map(|(p, _)| p),
        },
        boundaries,
        length,
        warnings,
        notes,
        sinks,
    })
}
