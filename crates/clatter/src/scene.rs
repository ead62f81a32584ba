//! Scene files (TOML): materials, shapes, walls, a box container, single bodies and groups.
//! Every key is documented in `docs/scene-format.md`. Errors name the file, the line and
//! column, and the field, and nothing is simulated or written before the whole file is valid.

use std::collections::HashMap;
use std::fmt;
use std::path::Path;

use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;
use toml::Spanned;

use crate::boundary::{Boundary, BoundaryMotion};
use crate::material::{Cohesion, ContactLaw, Material};
use crate::periodic::Periodic;
use crate::shape_spec::{BoxSpec, ConvexSpec, PolyhedronSpec, ShapeSpec, SphereSpec};
use crate::sink::Sink;
use crate::world::{BodyInit, Wall, World, WorldDesc};
use clatter_geom::narrow::Plane;
use clatter_geom::{GeomError, PreparedShape};

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
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            file: name.clone(),
            line: None,
            field: None,
            message: format!("cannot read the scene file: {e}"),
        })?;
        Scene::parse(&text, &name)
    }

    /// Parses and validates scene text; `file` names it in errors, and mesh files
    /// (`[[shape]] mesh = { file = .. }`) are found relative to its directory (the current
    /// directory when `file` has none, like `<default scene>`).
    pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
        let dir = Path::new(file).parent().unwrap_or(Path::new(""));
        let cx = SourceFile { file, text, dir };
        let raw: RawScene = toml::from_str(text).map_err(|e| SceneError {
            file: file.to_string(),
            line: e.span().map(|s| cx.line_col(s.start)),
            field: None,
            message: e.message().trim().to_string(),
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
                n.max(0.0) as u64
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
    fn line_col(&self, offset: usize) -> (usize, usize) {
        let before = &self.text[..offset.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before
            .rfind('\n')
            .map_or(before.len(), |p| before.len() - p - 1)
            + 1;
        (line, col)
    }

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

    fn positive(&self, v: &Spanned<f64>, field: &str) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            self.err(
                v.span(),
                field,
                format!("must be a positive finite number, got {x}"),
            )
        }
    }

    fn non_negative(&self, v: &Spanned<f64>, field: &str) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x.is_finite() && x >= 0.0 {
            Ok(x)
        } else {
            self.err(
                v.span(),
                field,
                format!("must be a finite number >= 0, got {x}"),
            )
        }
    }

    fn vec3(&self, v: &Spanned<[f64; 3]>, field: &str) -> Result<Vec3, SceneError> {
        let a = v.get_ref();
        if a.iter().all(|c| c.is_finite()) {
            Ok(Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32))
        } else {
            self.err(
                v.span(),
                field,
                format!("must have three finite numbers, got {a:?}"),
            )
        }
    }

    fn opt_vec3(&self, v: &Option<Spanned<[f64; 3]>>, field: &str) -> Result<Vec3, SceneError> {
        v.as_ref().map_or(Ok(Vec3::ZERO), |v| self.vec3(v, field))
    }

    fn unit(&self, v: &Spanned<[f64; 3]>, field: &str) -> Result<Vec3, SceneError> {
        let n = self.vec3(v, field)?;
        if n.length() < 1e-12 {
            return self.err(v.span(), field, "must not be the zero vector");
        }
        Ok(n.normalize())
    }

    fn quat(&self, v: &Option<Spanned<[f64; 4]>>, field: &str) -> Result<Quat, SceneError> {
        let Some(v) = v else {
            return Ok(Quat::IDENTITY);
        };
        let a = v.get_ref();
        let norm = a.iter().map(|c| c * c).sum::<f64>().sqrt();
        if !a.iter().all(|c| c.is_finite()) || norm < 1e-12 {
            return self.err(
                v.span(),
                field,
                format!("must be a non-zero quaternion [w, x, y, z] of finite numbers, got {a:?}"),
            );
        }
        Ok(Quat::from_xyzw(a[1] as f32, a[2] as f32, a[3] as f32, a[0] as f32).normalize())
    }

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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    simulation: Option<Spanned<RawSimulation>>,
    #[serde(default)]
    material: Vec<Spanned<RawMaterial>>,
    #[serde(default)]
    shape: Vec<Spanned<RawShape>>,
    #[serde(default)]
    wall: Vec<Spanned<RawWall>>,
    #[serde(default)]
    sink: Vec<Spanned<RawSink>>,
    #[serde(default)]
    boundary: Vec<Spanned<RawBoundary>>,
    container: Option<Spanned<RawContainer>>,
    #[serde(default)]
    body: Vec<Spanned<RawBody>>,
    #[serde(default)]
    group: Vec<Spanned<RawGroup>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSimulation {
    duration: Option<Spanned<f64>>,
    steps: Option<Spanned<i64>>,
    dt: Option<Spanned<f64>>,
    gravity: Option<Spanned<[f64; 3]>>,
    skin: Option<Spanned<f64>>,
    periodic: Option<Spanned<RawPeriodic>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPeriodic {
    min: Spanned<[f64; 3]>,
    max: Spanned<[f64; 3]>,
    axes: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    name: Spanned<String>,
    density: Spanned<f64>,
    model: Option<Spanned<String>>,
    stiffness: Option<Spanned<f64>>,
    youngs_modulus: Option<Spanned<f64>>,
    poisson_ratio: Option<Spanned<f64>>,
    restitution: Option<Spanned<f64>>,
    friction: Option<Spanned<f64>>,
    rolling_friction: Option<Spanned<f64>>,
    spinning_friction: Option<Spanned<f64>>,
    cohesion: Option<Spanned<RawCohesion>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCohesion {
    model: Spanned<String>,
    surface_energy: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawShape {
    name: Spanned<String>,
    sphere: Option<Spanned<SphereSpec>>,
    #[serde(rename = "box")]
    box_: Option<Spanned<BoxSpec>>,
    polyhedron: Option<Spanned<PolyhedronSpec>>,
    convex: Option<Spanned<ConvexSpec>>,
    mesh: Option<Spanned<RawMesh>>,
    composite: Option<Spanned<Vec<Spanned<RawPiece>>>>,
}

/// One piece of `composite = [ { shape = "ball", offset = [..], orientation = [w, x, y, z] } ]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPiece {
    shape: Spanned<String>,
    offset: Option<Spanned<[f64; 3]>>,
    orientation: Option<Spanned<[f64; 4]>>,
}

/// `mesh = { file = "rock.obj", scale = 0.01, mode = "hull" }`
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    file: Spanned<String>,
    scale: Option<Spanned<RawScale>>,
    mode: Option<Spanned<String>>,
}

/// A mesh scale: one factor, or one per axis.
#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or an array of three numbers")]
enum RawScale {
    Uniform(f64),
    Axes([f64; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWall {
    point: Spanned<[f64; 3]>,
    normal: Spanned<[f64; 3]>,
    material: Spanned<String>,
}

/// `[[boundary]] mesh = { file, scale }, material, motion = { .. }, start, end`
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoundary {
    mesh: Spanned<RawBoundaryMesh>,
    material: Spanned<String>,
    motion: Option<Spanned<RawMotion>>,
    start: Option<Spanned<f64>>,
    end: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoundaryMesh {
    file: Spanned<String>,
    scale: Option<Spanned<RawScale>>,
    weld: Option<Spanned<f64>>,
}

/// `motion = { velocity = [..] }` or `{ angular_velocity = [..], center = [..] }`
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMotion {
    velocity: Option<Spanned<[f64; 3]>>,
    angular_velocity: Option<Spanned<[f64; 3]>>,
    center: Option<Spanned<[f64; 3]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSink {
    min: Spanned<[f64; 3]>,
    max: Spanned<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawContainer {
    min: Spanned<[f64; 3]>,
    max: Spanned<[f64; 3]>,
    material: Spanned<String>,
    #[serde(default = "yes")]
    top: bool,
}

fn yes() -> bool {
    true
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBody {
    shape: Spanned<String>,
    material: Spanned<String>,
    position: Spanned<[f64; 3]>,
    velocity: Option<Spanned<[f64; 3]>>,
    angular_velocity: Option<Spanned<[f64; 3]>>,
    orientation: Option<Spanned<[f64; 4]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGroup {
    shape: Option<Spanned<String>>,
    shapes: Option<Spanned<Vec<Spanned<String>>>>,
    material: Spanned<String>,
    lattice: Option<Spanned<RawLattice>>,
    random: Option<Spanned<RawRandom>>,
    #[serde(default)]
    random_orientation: bool,
    velocity: Option<Spanned<[f64; 3]>>,
    angular_velocity: Option<Spanned<[f64; 3]>>,
    seed: Option<u64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLattice {
    min: Spanned<[f64; 3]>,
    max: Spanned<[f64; 3]>,
    spacing: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRandom {
    min: Spanned<[f64; 3]>,
    max: Spanned<[f64; 3]>,
    count: Spanned<i64>,
    seed: Option<u64>,
}

/// Most bodies a scene may create (keeps a typo from allocating the machine away).
pub const MAX_BODIES: usize = 50_000_000;

/// The GPU narrow phase's limit on the vertices of one polyhedron
/// (`clatter_gpu::shapes::MAX_SHAPE_VERTICES`, checked equal by a test there); a scene whose
/// hulls exceed it gets a warning, since it can only run on the CPU.
pub const GPU_SHAPE_VERTICES: usize = 64;

/// The shape of `[[shape]] mesh = { .. }` (shape `k`, named `name`): the mesh file read
/// relative to the scene's directory, scaled, and its convex hull prepared. Every failure
/// names the field and the mesh file.
fn mesh_shape(
    cx: &SourceFile,
    k: usize,
    name: &str,
    m: &Spanned<RawMesh>,
) -> Result<PreparedShape, SceneError> {
    let r = m.get_ref();
    let file = r.file.get_ref();
    let path = cx.dir.join(file);
    let shown = path.display();
    let decompose = match r.mode.as_ref().map(|v| (v.get_ref().as_str(), v.span())) {
        None | Some(("hull", _)) => false,
        Some(("decompose", _)) => true,
        Some((other, span)) => {
            return cx.err(
                span,
                format!("shape[{k}].mesh.mode"),
                format!("unknown mesh mode `{other}` (expected \"hull\" or \"decompose\")"),
            );
        }
    };
    let scale = mesh_scale(cx, &r.scale, &format!("shape[{k}].mesh.scale"))?;
    let field = format!("shape[{k}].mesh.file");
    if decompose {
        let mesh = crate::mesh::read_triangles(&path).map_err(|e| SceneError {
            file: cx.file.to_string(),
            line: Some(cx.line_col(r.file.span().start)),
            field: Some(field.clone()),
            message: format!("shape `{name}`: mesh file `{shown}`: {e}"),
        })?;
        return decomposed(&mesh, scale).or_else(|e| {
            cx.err(
                r.file.span(),
                field,
                format!("shape `{name}`: mesh file `{shown}`: convex decomposition: {e}"),
            )
        });
    }
    let mesh = crate::mesh::read_mesh(&path).map_err(|e| SceneError {
        file: cx.file.to_string(),
        line: Some(cx.line_col(r.file.span().start)),
        field: Some(field.clone()),
        message: format!("shape `{name}`: mesh file `{shown}`: {e}"),
    })?;
    let points = mesh
        .vertices
        .iter()
        .map(|v| [v[0] * scale[0], v[1] * scale[1], v[2] * scale[2]])
        .collect();
    clatter_geom::ShapeKind::Convex { points }
        .prepare()
        .or_else(|e| {
            cx.err(
                r.file.span(),
                field,
                format!("shape `{name}`: mesh file `{shown}`: {e}"),
            )
        })
}

/// A mesh's `scale` (one factor or one per axis), checked positive and finite.
fn mesh_scale(
    cx: &SourceFile,
    scale: &Option<Spanned<RawScale>>,
    field: &str,
) -> Result<[f64; 3], SceneError> {
    let Some(v) = scale else {
        return Ok([1.0; 3]);
    };
    let s = match v.get_ref() {
        RawScale::Uniform(x) => [*x; 3],
        RawScale::Axes(a) => *a,
    };
    if !s.iter().all(|x| x.is_finite() && *x > 0.0) {
        let got = match v.get_ref() {
            RawScale::Uniform(x) => format!("{x}"),
            RawScale::Axes(a) => format!("{a:?}"),
        };
        return cx.err(
            v.span(),
            field,
            format!("must be a positive finite number (or three of them), got {got}"),
        );
    }
    Ok(s)
}

/// `[[boundary]]` `k`: its mesh file read relative to the scene's directory, scaled, checked
/// (see [`Boundary::new`]) and given its material and motion. Every failure names the field
/// and the mesh file.
fn boundary(
    cx: &SourceFile,
    k: usize,
    b: &Spanned<RawBoundary>,
    material_names: &HashMap<String, u32>,
) -> Result<Boundary, SceneError> {
    let r = b.get_ref();
    let m = r.mesh.get_ref();
    let material = cx.lookup(
        material_names,
        &r.material,
        &format!("boundary[{k}].material"),
        "material",
    )?;
    let scale = mesh_scale(cx, &m.scale, &format!("boundary[{k}].mesh.scale"))?;
    let time = |v: &Option<Spanned<f64>>, field: &str, default: f64| match v {
        None => Ok(default),
        Some(v) => cx.non_negative(v, &format!("boundary[{k}].{field}")),
    };
    let start = time(&r.start, "start", 0.0)?;
    let end = time(&r.end, "end", f64::INFINITY)?;
    if let Some(e) = &r.end
        && end <= start
    {
        return cx.err(
            e.span(),
            format!("boundary[{k}].end"),
            format!("must be later than `start` ({start} s), got {end} s"),
        );
    }
    let motion = match &r.motion {
        None => BoundaryMotion::Fixed,
        Some(mo) => {
            let raw = mo.get_ref();
            match (&raw.velocity, &raw.angular_velocity, &raw.center) {
                (Some(v), None, None) => BoundaryMotion::Translate {
                    velocity: cx.vec3(v, &format!("boundary[{k}].motion.velocity"))?,
                },
                (None, Some(w), Some(c)) => BoundaryMotion::Rotate {
                    angular_velocity: cx
                        .vec3(w, &format!("boundary[{k}].motion.angular_velocity"))?,
                    center: cx.vec3(c, &format!("boundary[{k}].motion.center"))?,
                },
                (None, Some(_), None) => {
                    return cx.err(
                        mo.span(),
                        format!("boundary[{k}].motion.center"),
                        "a rotation needs `center` (a point on the axis) with `angular_velocity`",
                    );
                }
                _ => {
                    return cx.err(
                        mo.span(),
                        format!("boundary[{k}].motion"),
                        "give either `velocity = [..]` (translation) or `angular_velocity = [..]` and `center = [..]` (rotation)",
                    );
                }
            }
        }
    };
    let file = m.file.get_ref();
    let path = cx.dir.join(file);
    let shown = path.display();
    let fail = |e: String| SceneError {
        file: cx.file.to_string(),
        line: Some(cx.line_col(m.file.span().start)),
        field: Some(format!("boundary[{k}].mesh.file")),
        message: format!("mesh file `{shown}`: {e}"),
    };
    let weld = match &m.weld {
        None => None,
        Some(w) => Some(cx.non_negative(w, &format!("boundary[{k}].mesh.weld"))?),
    };
    let mesh = crate::mesh::read_mesh(&path).map_err(fail)?;
    let cleaned =
        crate::mesh_repair::repair(&mesh.vertices, &mesh.triangles, scale, weld).map_err(fail)?;
    Ok(Boundary::from_repaired(
        file, cleaned, material, motion, start, end,
    ))
}

/// A composite of convex pieces approximating a (possibly non-convex) triangle mesh, scaled
/// by `scale`: parry3d's VHACD (voxel resolution 64, concavity 0.01, at most
/// [`clatter_geom::composite::MAX_PIECES`] parts), each part the exact convex hull of the
/// mesh triangles it holds. Parts too flat to have a hull are dropped.
pub fn decomposed(
    mesh: &crate::mesh::MeshTriangles,
    scale: [f64; 3],
) -> Result<PreparedShape, String> {
    use parry3d::math::Vector as PVec;
    use parry3d::transformation::vhacd::{VHACD, VHACDParameters};
    let points: Vec<PVec> = mesh
        .vertices
        .iter()
        .map(|v| {
            PVec::new(
                (v[0] * scale[0]) as f32,
                (v[1] * scale[1]) as f32,
                (v[2] * scale[2]) as f32,
            )
        })
        .collect();
    let params = VHACDParameters {
        max_convex_hulls: clatter_geom::composite::MAX_PIECES as u32,
        ..VHACDParameters::default()
    };
    let parts = VHACD::decompose(&params, &points, &mesh.triangles, true)
        .compute_exact_convex_hulls(&points, &mesh.triangles);
    let mut pieces = Vec::new();
    for (vertices, _) in parts {
        let kind = clatter_geom::ShapeKind::Convex {
            points: vertices
                .iter()
                .map(|p| [p.x as f64, p.y as f64, p.z as f64])
                .collect(),
        };
        if let Ok(shape) = kind.prepare() {
            pieces.push(clatter_geom::PieceSpec {
                offset: shape.com.as_dvec3(),
                shape,
                orientation: glam::DQuat::IDENTITY,
            });
        }
    }
    if pieces.is_empty() {
        return Err("no part of the mesh has a volume (is it closed?)".into());
    }
    clatter_geom::prepare_composite(&pieces).map_err(|e| e.to_string())
}

/// The composite `[[shape]]` number `k` (named `name`): its pieces looked up among the
/// scene's other (non-composite) shapes, placed and turned, and the union prepared.
fn composite_shape(
    cx: &SourceFile,
    k: usize,
    name: &str,
    list: &Spanned<Vec<Spanned<RawPiece>>>,
    names: &HashMap<String, u32>,
    shapes: &[PreparedShape],
    is_composite: &[bool],
) -> Result<PreparedShape, SceneError> {
    let field = format!("shape[{k}].composite");
    if list.get_ref().is_empty() {
        return cx.err(
            list.span(),
            field,
            format!("shape `{name}`: a composite needs at least one piece"),
        );
    }
    let max = clatter_geom::composite::MAX_PIECES;
    if list.get_ref().len() > max {
        return cx.err(
            list.span(),
            field,
            format!(
                "shape `{name}`: {} pieces, more than the {max} a composite may have",
                list.get_ref().len()
            ),
        );
    }
    let mut pieces = Vec::new();
    for (p, piece) in list.get_ref().iter().enumerate() {
        let r = piece.get_ref();
        let f = |x: &str| format!("shape[{k}].composite[{p}].{x}");
        let s = cx.lookup(names, &r.shape, &f("shape"), "shape")?;
        if is_composite[s as usize] {
            return cx.err(
                r.shape.span(),
                f("shape"),
                format!(
                    "shape `{name}`: piece `{}` is itself a composite (pieces must be spheres or convex shapes)",
                    r.shape.get_ref()
                ),
            );
        }
        let offset = cx.opt_vec3(&r.offset, &f("offset"))?;
        let orientation = cx.quat(&r.orientation, &f("orientation"))?;
        pieces.push(clatter_geom::PieceSpec {
            shape: shapes[s as usize].clone(),
            offset: offset.as_dvec3(),
            orientation: orientation.as_dquat(),
        });
    }
    clatter_geom::prepare_composite(&pieces)
        .or_else(|e| cx.err(list.span(), field, format!("shape `{name}`: {e}")))
}

fn build(cx: &SourceFile, raw: RawScene) -> Result<Scene, SceneError> {
    let mut warnings = Vec::new();
    // [simulation]
    let (length, dt, gravity, skin, periodic) = match &raw.simulation {
        None => {
            return cx.err(
                0..0,
                "simulation",
                "missing table [simulation] (it needs `duration` or `steps`)",
            );
        }
        Some(sim) => {
            let s = sim.get_ref();
            let length = match (&s.duration, &s.steps) {
                (Some(_), Some(st)) => {
                    return cx.err(
                        st.span(),
                        "simulation.steps",
                        "give either `duration` or `steps`, not both",
                    );
                }
                (Some(d), None) => RunLength::Duration(cx.positive(d, "simulation.duration")?),
                (None, Some(st)) => {
                    if *st.get_ref() <= 0 {
                        return cx.err(
                            st.span(),
                            "simulation.steps",
                            format!("must be a positive integer, got {}", st.get_ref()),
                        );
                    }
                    RunLength::Steps(*st.get_ref() as u64)
                }
                (None, None) => {
                    return cx.err(
                        sim.span(),
                        "simulation",
                        "needs `duration` (seconds) or `steps`",
                    );
                }
            };
            let dt =
                s.dt.as_ref()
                    .map(|d| cx.positive(d, "simulation.dt").map(|x| x as f32))
                    .transpose()?;
            let gravity = match &s.gravity {
                Some(g) => cx.vec3(g, "simulation.gravity")?,
                None => Vec3::new(0.0, 0.0, -9.81),
            };
            let skin = s
                .skin
                .as_ref()
                .map(|d| cx.non_negative(d, "simulation.skin").map(|x| x as f32))
                .transpose()?;
            let periodic = match &s.periodic {
                None => None,
                Some(p) => Some((periodic_box(cx, p.get_ref())?, p.span())),
            };
            (length, dt, gravity, skin, periodic)
        }
    };

    // [[material]]
    let mut materials = Vec::new();
    let mut material_names = HashMap::new();
    for (k, m) in raw.material.iter().enumerate() {
        let r = m.get_ref();
        let f = |name: &str| format!("material[{k}].{name}");
        if material_names
            .insert(r.name.get_ref().clone(), k as u32)
            .is_some()
        {
            return cx.err(
                r.name.span(),
                f("name"),
                format!("duplicate material name `{}`", r.name.get_ref()),
            );
        }
        let density = cx.positive(&r.density, &f("density"))? as f32;
        let model = r.model.as_ref().map(|m| (m.get_ref().as_str(), m.span()));
        let law = match model {
            None | Some(("linear", _)) => {
                let Some(k) = &r.stiffness else {
                    return cx.err(
                        m.span(),
                        f("stiffness"),
                        "missing field `stiffness` (N/m) for the linear model",
                    );
                };
                for (other, name) in [
                    (&r.youngs_modulus, "youngs_modulus"),
                    (&r.poisson_ratio, "poisson_ratio"),
                ] {
                    if let Some(o) = other {
                        return cx.err(o.span(), f(name), "only used with model = \"hertz\"");
                    }
                }
                ContactLaw::Linear {
                    stiffness: cx.positive(k, &f("stiffness"))? as f32,
                }
            }
            Some(("hertz", _)) => {
                let Some(e) = &r.youngs_modulus else {
                    return cx.err(
                        m.span(),
                        f("youngs_modulus"),
                        "missing field `youngs_modulus` (Pa) for model = \"hertz\"",
                    );
                };
                let Some(nu) = &r.poisson_ratio else {
                    return cx.err(
                        m.span(),
                        f("poisson_ratio"),
                        "missing field `poisson_ratio` for model = \"hertz\"",
                    );
                };
                if let Some(s) = &r.stiffness {
                    return cx.err(s.span(), f("stiffness"), "only used with the linear model; hertz takes youngs_modulus and poisson_ratio");
                }
                let nu_v = *nu.get_ref();
                // -1 itself would make the effective modulus infinite.
                if !(nu_v.is_finite() && nu_v > -1.0 && nu_v < 0.5) {
                    return cx.err(
                        nu.span(),
                        f("poisson_ratio"),
                        format!("must be in (-1, 0.5), got {nu_v}"),
                    );
                }
                ContactLaw::Hertz {
                    youngs_modulus: cx.positive(e, &f("youngs_modulus"))? as f32,
                    poisson_ratio: nu_v as f32,
                }
            }
            Some((other, span)) => {
                return cx.err(
                    span,
                    f("model"),
                    format!("unknown model `{other}` (expected \"linear\" or \"hertz\")"),
                );
            }
        };
        let restitution = match &r.restitution {
            Some(e) => {
                let v = *e.get_ref();
                if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                    return cx.err(
                        e.span(),
                        f("restitution"),
                        format!("must be in (0, 1], got {v}"),
                    );
                }
                v as f32
            }
            None => 0.5,
        };
        let friction = match &r.friction {
            Some(mu) => cx.non_negative(mu, &f("friction"))? as f32,
            None => 0.3,
        };
        let rolling_friction = match &r.rolling_friction {
            Some(mu) => cx.non_negative(mu, &f("rolling_friction"))? as f32,
            None => 0.0,
        };
        let spinning_friction = match &r.spinning_friction {
            Some(mu) => cx.non_negative(mu, &f("spinning_friction"))? as f32,
            None => 0.0,
        };
        let cohesion = match &r.cohesion {
            None => None,
            Some(c) => {
                let c = c.get_ref();
                match c.model.get_ref().as_str() {
                    "dmt" => {
                        let Some(g) = &c.surface_energy else {
                            return cx.err(
                                c.model.span(),
                                f("cohesion.surface_energy"),
                                "missing field `surface_energy` (J/m^2) for model = \"dmt\"",
                            );
                        };
                        Some(Cohesion::Dmt {
                            surface_energy: cx.positive(g, &f("cohesion.surface_energy"))? as f32,
                        })
                    }
                    other => {
                        return cx.err(
                            c.model.span(),
                            f("cohesion.model"),
                            format!("unknown cohesion model `{other}` (expected \"dmt\")"),
                        );
                    }
                }
            }
        };
        materials.push(Material {
            name: r.name.get_ref().clone(),
            density,
            law,
            restitution,
            friction,
            rolling_friction,
            spinning_friction,
            cohesion,
        });
    }
    if let (Some(a), Some(b)) = (
        materials
            .iter()
            .position(|m| matches!(m.law, ContactLaw::Linear { .. })),
        materials
            .iter()
            .position(|m| matches!(m.law, ContactLaw::Hertz { .. })),
    ) {
        let later = &raw.material[a.max(b)];
        let span = later
            .get_ref()
            .model
            .as_ref()
            .map_or_else(|| later.span(), |m| m.span());
        return cx.err(
            span,
            format!("material[{}].model", a.max(b)),
            format!("materials `{}` (linear) and `{}` (hertz) use different contact models; one scene uses one model", materials[a].name, materials[b].name),
        );
    }

    // [[shape]]
    let mut shapes: Vec<PreparedShape> = Vec::new();
    let mut shape_names = HashMap::new();
    // Composites refer to other shapes by name: they are built once every other shape is.
    let mut is_composite = vec![false; raw.shape.len()];
    for (k, s) in raw.shape.iter().enumerate() {
        let r = s.get_ref();
        if shape_names
            .insert(r.name.get_ref().clone(), k as u32)
            .is_some()
        {
            return cx.err(
                r.name.span(),
                format!("shape[{k}].name"),
                format!("duplicate shape name `{}`", r.name.get_ref()),
            );
        }
        if r.composite.is_some() {
            let others = [
                r.sphere.is_some(),
                r.box_.is_some(),
                r.polyhedron.is_some(),
                r.convex.is_some(),
                r.mesh.is_some(),
            ];
            if others.iter().any(|b| *b) {
                return cx.err(
                    s.span(),
                    format!("shape[{k}]"),
                    "a shape needs exactly one of `sphere`, `box`, `polyhedron`, `convex`, `mesh`, `composite` (got `composite` and another)",
                );
            }
            is_composite[k] = true;
            // A placeholder until the second pass below.
            shapes.push(
                clatter_geom::ShapeKind::Sphere { radius: 1.0 }
                    .prepare()
                    .expect("a unit sphere is valid"),
            );
            continue;
        }
        if let Some(m) = &r.mesh {
            let others = [
                r.sphere.is_some(),
                r.box_.is_some(),
                r.polyhedron.is_some(),
                r.convex.is_some(),
            ];
            if others.iter().any(|b| *b) {
                return cx.err(
                    s.span(),
                    format!("shape[{k}]"),
                    "a shape needs exactly one of `sphere`, `box`, `polyhedron`, `convex`, `mesh` (got `mesh` and another)",
                );
            }
            shapes.push(mesh_shape(cx, k, r.name.get_ref(), m)?);
            continue;
        }
        let spec = ShapeSpec {
            sphere: r.sphere.as_ref().map(|v| v.get_ref().clone()),
            box_: r.box_.as_ref().map(|v| v.get_ref().clone()),
            polyhedron: r.polyhedron.as_ref().map(|v| v.get_ref().clone()),
            convex: r.convex.as_ref().map(|v| v.get_ref().clone()),
        };
        let given = [
            r.sphere.as_ref().map(|v| ("sphere", v.span())),
            r.box_.as_ref().map(|v| ("box", v.span())),
            r.polyhedron.as_ref().map(|v| ("polyhedron", v.span())),
            r.convex.as_ref().map(|v| ("convex", v.span())),
        ];
        let kind = match spec.to_kind() {
            Ok(kind) => kind,
            Err(msg) => {
                // With exactly one variant given, the only failure is an unknown polyhedron kind.
                return match (&r.polyhedron, given.iter().flatten().count()) {
                    (Some(p), 1) => cx.err(p.span(), format!("shape[{k}].polyhedron.kind"), msg),
                    (_, 0) => cx.err(
                        s.span(),
                        format!("shape[{k}]"),
                        "a shape needs exactly one of `sphere`, `box`, `polyhedron`, `convex`, `mesh`, `composite` (got 0)",
                    ),
                    _ => cx.err(s.span(), format!("shape[{k}]"), msg),
                };
            }
        };
        let (variant, span) = given
            .into_iter()
            .flatten()
            .next()
            .expect("to_kind checked one variant");
        match kind.prepare() {
            Ok(p) => shapes.push(p),
            Err(e) => {
                let field = match &e {
                    GeomError::NotPositive { what, .. } => format!("shape[{k}].{variant}.{what}"),
                    GeomError::NonFinitePoint { index } => {
                        format!("shape[{k}].{variant}.points[{index}]")
                    }
                    GeomError::DegenerateHull { .. } if variant == "convex" => {
                        format!("shape[{k}].convex.points")
                    }
                    GeomError::DegenerateHull { .. } => format!("shape[{k}].{variant}"),
                    // Composite errors come from `composite_shape`, not from here.
                    _ => format!("shape[{k}].{variant}"),
                };
                return cx.err(span, field, format!("shape `{}`: {e}", r.name.get_ref()));
            }
        }
    }

    for (k, s) in raw.shape.iter().enumerate() {
        let r = s.get_ref();
        if let Some(list) = &r.composite {
            shapes[k] = composite_shape(
                cx,
                k,
                r.name.get_ref(),
                list,
                &shape_names,
                &shapes,
                &is_composite,
            )?;
        }
    }

    for (k, p) in shapes.iter().enumerate() {
        if let clatter_geom::Shape::Polyhedron(h) = &p.shape
            && h.vertices.len() > GPU_SHAPE_VERTICES
        {
            warnings.push(format!(
                "shape `{}` has {} hull vertices, more than the GPU backend's {GPU_SHAPE_VERTICES}: this scene runs on the CPU only",
                raw.shape[k].get_ref().name.get_ref(),
                h.vertices.len()
            ));
        }
    }

    // [[wall]] and [container]
    let mut walls = Vec::new();
    for (k, w) in raw.wall.iter().enumerate() {
        let r = w.get_ref();
        let point = cx.vec3(&r.point, &format!("wall[{k}].point"))?;
        let normal = cx.unit(&r.normal, &format!("wall[{k}].normal"))?;
        let material = cx.lookup(
            &material_names,
            &r.material,
            &format!("wall[{k}].material"),
            "material",
        )?;
        walls.push(Wall {
            plane: Plane {
                normal,
                offset: normal.dot(point),
            },
            material,
        });
    }
    let boundaries = raw
        .boundary
        .iter()
        .enumerate()
        .map(|(k, b)| boundary(cx, k, b, &material_names))
        .collect::<Result<Vec<_>, _>>()?;
    let mut notes = Vec::new();
    for (k, b) in boundaries.iter().enumerate() {
        if let Some(w) = b.repairs.warning() {
            warnings.push(format!("boundary[{k}] mesh `{}`: {w}", b.file));
        }
        if let Some(n) = b.repairs.note() {
            notes.push(format!("boundary[{k}] mesh `{}`: {n}", b.file));
        }
    }
    let mut container_bounds = None;
    if let Some(c) = &raw.container {
        let r = c.get_ref();
        let lo = cx.vec3(&r.min, "container.min")?;
        let hi = cx.vec3(&r.max, "container.max")?;
        if !(hi.cmpgt(lo).all()) {
            return cx.err(
                r.max.span(),
                "container.max",
                format!("must be greater than container.min on every axis ({hi} vs {lo})"),
            );
        }
        let material = cx.lookup(
            &material_names,
            &r.material,
            "container.material",
            "material",
        )?;
        for axis in 0..3 {
            // A periodic axis has no container faces: the box repeats instead.
            if periodic.as_ref().is_some_and(|(p, _)| p.axes[axis]) {
                continue;
            }
            let mut n = Vec3::ZERO;
            n[axis] = 1.0;
            walls.push(Wall {
                plane: Plane {
                    normal: n,
                    offset: lo[axis],
                },
                material,
            });
            if axis < 2 || r.top {
                walls.push(Wall {
                    plane: Plane {
                        normal: -n,
                        offset: -hi[axis],
                    },
                    material,
                });
            }
        }
        container_bounds = Some((lo, hi));
    }

    // [[body]]
    let mut bodies = Vec::new();
    for (k, b) in raw.body.iter().enumerate() {
        let r = b.get_ref();
        let f = |name: &str| format!("body[{k}].{name}");
        let shape = cx.lookup(&shape_names, &r.shape, &f("shape"), "shape")?;
        let material = cx.lookup(&material_names, &r.material, &f("material"), "material")?;
        bodies.push(BodyInit {
            shape,
            material,
            position: cx.vec3(&r.position, &f("position"))?,
            orientation: cx.quat(&r.orientation, &f("orientation"))?,
            velocity: cx.opt_vec3(&r.velocity, &f("velocity"))?,
            angular_velocity: cx.opt_vec3(&r.angular_velocity, &f("angular_velocity"))?,
        });
    }

    // [[group]]
    let rmax = shapes
        .iter()
        .map(|s| s.shape.bounding_radius())
        .fold(0.0, f32::max);
    let mut occupancy = Occupancy::new(2.0 * rmax, periodic.as_ref().map(|(p, _)| *p));
    for b in &bodies {
        occupancy.insert(b.position, shapes[b.shape as usize].shape.bounding_radius());
    }
    for (k, g) in raw.group.iter().enumerate() {
        let r = g.get_ref();
        let f = |name: &str| format!("group[{k}].{name}");
        // The group's shapes, taken in turn by its bodies (`shape`, or a `shapes` list).
        let group_shapes: Vec<u32> = match (&r.shape, &r.shapes) {
            (Some(one), None) => vec![cx.lookup(&shape_names, one, &f("shape"), "shape")?],
            (None, Some(list)) => {
                if list.get_ref().is_empty() {
                    return cx.err(list.span(), f("shapes"), "must name at least one shape");
                }
                let mut out = Vec::with_capacity(list.get_ref().len());
                for (j, name) in list.get_ref().iter().enumerate() {
                    out.push(cx.lookup(
                        &shape_names,
                        name,
                        &f(&format!("shapes[{j}]")),
                        "shape",
                    )?);
                }
                out
            }
            (Some(one), Some(_)) => {
                return cx.err(
                    one.span(),
                    f("shape"),
                    "give either `shape` or `shapes`, not both",
                );
            }
            (None, None) => {
                return cx.err(
                    g.span(),
                    format!("group[{k}]"),
                    "needs `shape = \"name\"` or `shapes = [\"a\", \"b\", ..]`",
                );
            }
        };
        let material = cx.lookup(&material_names, &r.material, &f("material"), "material")?;
        let velocity = cx.opt_vec3(&r.velocity, &f("velocity"))?;
        let angular_velocity = cx.opt_vec3(&r.angular_velocity, &f("angular_velocity"))?;
        let radii: Vec<f32> = group_shapes
            .iter()
            .map(|&sh| shapes[sh as usize].shape.bounding_radius())
            .collect();
        // The largest shape of the group sets the lattice warning.
        let (widest, radius) =
            radii.iter().enumerate().fold(
                (0, 0.0f32),
                |(wi, wr), (i, &r)| if r > wr { (i, r) } else { (wi, wr) },
            );
        let positions = match (&r.lattice, &r.random) {
            (Some(l), None) => {
                let l = l.get_ref();
                let lo = cx.vec3(&l.min, &f("lattice.min"))?;
                let hi = cx.vec3(&l.max, &f("lattice.max"))?;
                let spacing = cx.positive(&l.spacing, &f("lattice.spacing"))?;
                if !hi.cmpge(lo).all() {
                    return cx.err(
                        l.max.span(),
                        f("lattice.max"),
                        "must be >= lattice.min on every axis",
                    );
                }
                // The tolerance keeps `max = min + n * spacing` at n + 1 bodies despite rounding
                // (0.06 / 0.02 = 2.9999999 in f32).
                let counts = ((hi - lo).as_dvec3() / spacing + glam::DVec3::splat(1e-4)).floor()
                    + glam::DVec3::ONE;
                let total = counts.x * counts.y * counts.z;
                if total > MAX_BODIES as f64 {
                    return cx.err(
                        l.spacing.span(),
                        f("lattice.spacing"),
                        format!("would create {total:.0} bodies (limit {MAX_BODIES})"),
                    );
                }
                if (spacing as f32) < 2.0 * radius {
                    warnings.push(format!(
                        "group[{k}]: lattice spacing {spacing} is below the bounding diameter {} of shape `{}`: bodies may start overlapping",
                        2.0 * radius,
                        shape_name(&shape_names, group_shapes[widest])
                    ));
                }
                let mut out = Vec::with_capacity(total as usize);
                for z in 0..counts.z as u32 {
                    for y in 0..counts.y as u32 {
                        for x in 0..counts.x as u32 {
                            out.push(lo + Vec3::new(x as f32, y as f32, z as f32) * spacing as f32);
                        }
                    }
                }
                out
            }
            (None, Some(rr)) => {
                let rr = rr.get_ref();
                let lo = cx.vec3(&rr.min, &f("random.min"))?;
                let hi = cx.vec3(&rr.max, &f("random.max"))?;
                if !hi.cmpge(lo).all() {
                    return cx.err(
                        rr.max.span(),
                        f("random.max"),
                        "must be >= random.min on every axis",
                    );
                }
                let count = *rr.count.get_ref();
                if count <= 0 || count as usize > MAX_BODIES {
                    return cx.err(
                        rr.count.span(),
                        f("random.count"),
                        format!("must be between 1 and {MAX_BODIES}, got {count}"),
                    );
                }
                let seed = rr.seed.or(r.seed).unwrap_or(1);
                match occupancy.place_random(lo, hi, &radii, count as usize, seed) {
                    Ok(p) => p,
                    Err(placed) => {
                        return cx.err(
                            rr.count.span(),
                            f("random.count"),
                            format!("could place only {placed} of {count} bodies without overlap in the region; enlarge random.min/max or lower the count"),
                        )
                    }
                }
            }
            (Some(l), Some(_)) => {
                return cx.err(
                    l.span(),
                    f("lattice"),
                    "give either `lattice` or `random`, not both",
                );
            }
            (None, None) => {
                return cx.err(
                    g.span(),
                    format!("group[{k}]"),
                    "needs `lattice = {..}` or `random = {..}`",
                );
            }
        };
        let mut rng = ChaCha8Rng::seed_from_u64(r.seed.unwrap_or(7) ^ 0x5eed_0000 ^ k as u64);
        if r.lattice.is_some() {
            for (j, &p) in positions.iter().enumerate() {
                occupancy.insert(p, radii[j % radii.len()]);
            }
        }
        for (j, p) in positions.into_iter().enumerate() {
            let shape = group_shapes[j % group_shapes.len()];
            let orientation = if r.random_orientation {
                random_rotation(&mut rng)
            } else {
                Quat::IDENTITY
            };
            bodies.push(BodyInit {
                shape,
                material,
                position: p,
                orientation,
                velocity,
                angular_velocity,
            });
        }
    }
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
        check_periodic(cx, p, span.clone(), &walls, &bodies, &shapes, skin)?;
    }
    let sinks = sinks(cx, &raw.sink, &walls, periodic.as_ref().map(|(p, _)| p))?;
    if periodic.is_some() && !boundaries.is_empty() {
        warnings.push(
            "triangle-mesh boundaries are not repeated across the periodic seams: a body meets a mesh's triangles only at its wrapped position, so a mesh should span the periodic box along its periodic axes (a chute floor) or stay clear of the seams".to_string(),
        );
    }
    if let Some((lo, hi)) = container_bounds {
        let outside = bodies
            .iter()
            .filter(|b| !(b.position.cmpge(lo).all() && b.position.cmple(hi).all()))
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

/// `[[sink]]`: boxes with finite corners, `min <= max`, that can catch something: a box
/// entirely behind a wall plane, or entirely outside the periodic box along a periodic axis
/// (positions are wrapped into it), is refused.
fn sinks(
    cx: &SourceFile,
    raw: &[Spanned<RawSink>],
    walls: &[Wall],
    periodic: Option<&Periodic>,
) -> Result<Vec<Sink>, SceneError> {
    let mut out = Vec::new();
    for (k, r) in raw.iter().enumerate() {
        let r = r.get_ref();
        let min = cx.vec3(&r.min, &format!("sink[{k}].min"))?;
        let max = cx.vec3(&r.max, &format!("sink[{k}].max"))?;
        if let Some(axis) = (0..3).find(|&a| min[a] > max[a]) {
            return cx.err(
                r.max.span(),
                format!("sink[{k}].max"),
                format!(
                    "must not be below sink[{k}].min along {} ({} < {})",
                    ["x", "y", "z"][axis],
                    max[axis],
                    min[axis]
                ),
            );
        }
        let sink = Sink { min, max };
        for (w, wall) in walls.iter().enumerate() {
            // The corner farthest in front of the wall: if even it is behind (or on) the
            // plane, no body centre can ever be in the box.
            let n = wall.plane.normal;
            let far = Vec3::select(n.cmpge(Vec3::ZERO), max, min);
            if n.dot(far) - wall.plane.offset <= 0.0 {
                return cx.err(
                    r.min.span(),
                    format!("sink[{k}]"),
                    format!(
                        "the box [{min}, {max}] lies entirely behind wall {w} (normal {n}): no body can ever enter it"
                    ),
                );
            }
        }
        if let Some(p) = periodic {
            for a in (0..3).filter(|&a| p.axes[a]) {
                if max[a] < p.min[a] || min[a] >= p.max[a] {
                    return cx.err(
                        r.min.span(),
                        format!("sink[{k}]"),
                        format!(
                            "the box [{min}, {max}] lies outside the periodic box along {} ([{}, {})): positions are wrapped into it, so no body can ever enter the sink",
                            ["x", "y", "z"][a],
                            p.min[a],
                            p.max[a]
                        ),
                    );
                }
            }
        }
        out.push(sink);
    }
    Ok(out)
}

/// `[simulation] periodic = { min, max, axes }`.
fn periodic_box(cx: &SourceFile, r: &RawPeriodic) -> Result<Periodic, SceneError> {
    let min = cx.vec3(&r.min, "simulation.periodic.min")?;
    let max = cx.vec3(&r.max, "simulation.periodic.max")?;
    let mut axes = [false; 3];
    let text = r.axes.get_ref();
    for ch in text.chars() {
        let k = match ch {
            'x' => 0,
            'y' => 1,
            'z' => 2,
            _ => {
                return cx.err(
                    r.axes.span(),
                    "simulation.periodic.axes",
                    format!("`{text}`: axes are letters from \"xyz\", e.g. \"xy\""),
                );
            }
        };
        if axes[k] {
            return cx.err(
                r.axes.span(),
                "simulation.periodic.axes",
                format!("`{text}` names axis {ch} twice"),
            );
        }
        axes[k] = true;
    }
    if text.is_empty() {
        return cx.err(
            r.axes.span(),
            "simulation.periodic.axes",
            "names no axis (use e.g. \"x\", \"xy\" or \"xyz\")",
        );
    }
    for k in 0..3 {
        if axes[k] && max[k] <= min[k] {
            return cx.err(
                r.max.span(),
                "simulation.periodic.max",
                format!(
                    "must be greater than periodic.min along periodic axis {} ({} vs {})",
                    ["x", "y", "z"][k],
                    max[k],
                    min[k]
                ),
            );
        }
    }
    Ok(Periodic { min, max, axes })
}

/// The periodic box against the rest of the scene: long enough for the broad phase (three
/// times the largest bounding diameter plus the skin along each periodic axis), and no wall
/// facing along a periodic axis.
fn check_periodic(
    cx: &SourceFile,
    p: &Periodic,
    span: std::ops::Range<usize>,
    walls: &[Wall],
    bodies: &[BodyInit],
    shapes: &[PreparedShape],
    skin: Option<f32>,
) -> Result<(), SceneError> {
    let rmax = bodies
        .iter()
        .map(|b| shapes[b.shape as usize].shape.bounding_radius())
        .fold(0.0f32, f32::max);
    let reach = 2.0 * rmax + skin.unwrap_or(0.2 * rmax);
    for k in 0..3 {
        let len = p.max[k] - p.min[k];
        if p.axes[k] && len < 3.0 * reach {
            return cx.err(
                span,
                "simulation.periodic",
                format!(
                    "the periodic box is {len} m long along {}, less than 3 x (largest bounding diameter + skin) = {} m: make it longer",
                    ["x", "y", "z"][k],
                    3.0 * reach
                ),
            );
        }
    }
    for (k, w) in walls.iter().enumerate() {
        let n = w.plane.normal;
        if (0..3).any(|a| p.axes[a] && n[a].abs() > 1e-6) {
            return cx.err(
                span.clone(),
                "simulation.periodic",
                format!(
                    "wall {k} (normal {n}) faces along a periodic axis: walls must be parallel to the periodic axes"
                ),
            );
        }
    }
    Ok(())
}

/// Uniform random unit quaternion (Shoemake).
pub fn random_rotation(rng: &mut impl Rng) -> Quat {
    let (u1, u2, u3): (f32, f32, f32) = (rng.random(), rng.random(), rng.random());
    let tau = std::f32::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    Quat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    )
    .normalize()
}

/// The name a shape index was declared with (for messages).
fn shape_name(names: &HashMap<String, u32>, index: u32) -> &str {
    names
        .iter()
        .find(|(_, i)| **i == index)
        .map_or("?", |(n, _)| n.as_str())
}

/// Bounding spheres placed so far, on a hash grid, so random groups avoid every earlier body.
/// In a periodic box the spheres are kept wrapped into it and a new one is tested against
/// the images of its neighbours across the seams too (the nearest image, as the step sees it).
struct Occupancy {
    cell: f32,
    grid: HashMap<(i64, i64, i64), Vec<u32>>,
    placed: Vec<(Vec3, f32)>,
    periodic: Option<Periodic>,
}

impl Occupancy {
    fn new(cell: f32, periodic: Option<Periodic>) -> Self {
        Self {
            cell: cell.max(1e-12),
            grid: HashMap::new(),
            placed: Vec::new(),
            periodic,
        }
    }

    fn key(&self, p: Vec3) -> (i64, i64, i64) {
        let g = (p / self.cell).floor();
        (g.x as i64, g.y as i64, g.z as i64)
    }

    /// `p` brought into the periodic box along its periodic axes, however far outside it lies
    /// (a random region may be wider than the box); `p` itself without periodic axes.
    fn wrapped(&self, p: Vec3) -> Vec3 {
        let Some(b) = &self.periodic else {
            return p;
        };
        let mut out = p;
        for k in 0..3 {
            let len = b.max[k] - b.min[k];
            if b.axes[k] && len > 0.0 {
                out[k] = b.min[k] + (p[k] - b.min[k]).rem_euclid(len);
            }
        }
        out
    }

    fn insert(&mut self, p: Vec3, r: f32) {
        let p = self.wrapped(p);
        let k = self.key(p);
        self.grid
            .entry(k)
            .or_default()
            .push(self.placed.len() as u32);
        self.placed.push((p, r));
    }

    /// Whether a sphere of radius `r` at `p` is clear of every sphere placed so far (of their
    /// nearest images, in a periodic box).
    fn free(&self, p: Vec3, r: f32) -> bool {
        let Some(b) = &self.periodic else {
            return self.free_at(p, r);
        };
        // Neighbours within reach lie at most one cell beyond a face: images of `p` shifted
        // across the faces it is near meet them in the grid.
        let (images, count) = b.images_near(self.wrapped(p), self.cell);
        images[..count].iter().all(|&q| self.free_at(q, r))
    }

    /// Whether a sphere of radius `r` at `p` is clear of the stored spheres (no images).
    fn free_at(&self, p: Vec3, r: f32) -> bool {
        let (kx, ky, kz) = self.key(p);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = self.grid.get(&(kx + dx, ky + dy, kz + dz)) {
                        for &j in list {
                            let (q, rq) = self.placed[j as usize];
                            if (q - p).length_squared() < (r + rq) * (r + rq) {
                                return false;
                            }
                        }
                    }
                }
            }
        }
        true
    }

    /// Places `count` bounding spheres (radii taken in turn from `radii`) uniformly in `[lo, hi]`, clear of everything
    /// placed before (rejection sampling); `Err(placed)` after 10,000 misses in a row.
    fn place_random(
        &mut self,
        lo: Vec3,
        hi: Vec3,
        radii: &[f32],
        count: usize,
        seed: u64,
    ) -> Result<Vec<Vec3>, usize> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::with_capacity(count);
        let mut failures = 0usize;
        while out.len() < count {
            let p = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
            let radius = radii[out.len() % radii.len()];
            if self.free(p, radius) {
                self.insert(p, radius);
                out.push(p);
                failures = 0;
            } else {
                failures += 1;
                if failures > 10_000 {
                    return Err(out.len());
                }
            }
        }
        Ok(out)
    }
}
