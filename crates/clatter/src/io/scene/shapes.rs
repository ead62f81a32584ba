//! `[[shape]]`: spheres, boxes, polyhedra, convex hulls of points, convex hulls or convex
//! decompositions of mesh files, and composites of other shapes. Names must be unique;
//! composites are built last, from the other shapes.

use std::collections::HashMap;

use toml::Spanned;

use super::raw::{RawMesh, RawPiece, RawScale, RawShape};
use super::{GPU_SHAPE_VERTICES, SceneError, SourceFile};
use crate::shape_spec::ShapeSpec;
use clatter_geom::{GeomError, PreparedShape};

/// Validates and prepares every `[[shape]]` in order; returns them with their name -> index
/// table, and warns of hulls too large for the GPU backend.
pub(super) fn shapes(
    cx: &SourceFile,
    raw: &[Spanned<RawShape>],
    warnings: &mut Vec<String>,
) -> Result<(Vec<PreparedShape>, HashMap<String, u32>), SceneError> {
    let mut shapes: Vec<PreparedShape> = Vec::new();
    let mut shape_names = HashMap::new();
    // Composites refer to other shapes by name: they are built once every other shape is.
    let mut is_composite = vec![false; raw.len()];
    for (k, s) in raw.iter().enumerate() {
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
        shapes.push(primitive_shape(cx, k, s)?);
    }

    for (k, s) in raw.iter().enumerate() {
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
                raw[k].get_ref().name.get_ref(),
                h.vertices.len()
            ));
        }
    }
    Ok((shapes, shape_names))
}

/// `[[shape]]` number `k` given as one of `sphere`, `box`, `polyhedron` or `convex`, prepared;
/// an error names the variant's field that is wrong.
fn primitive_shape(
    cx: &SourceFile,
    k: usize,
    s: &Spanned<RawShape>,
) -> Result<PreparedShape, SceneError> {
    let r = s.get_ref();
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
        Ok(p) => Ok(p),
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
            cx.err(span, field, format!("shape `{}`: {e}", r.name.get_ref()))
        }
    }
}

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
pub(super) fn mesh_scale(
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
