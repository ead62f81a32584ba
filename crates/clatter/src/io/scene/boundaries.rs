//! `[[boundary]]`: triangle-mesh boundaries read from mesh files, repaired (see
//! [`crate::mesh_repair`]), with their material, motion and active time window. What the
//! repair changed is reported as a warning or a `note:` line.

use std::collections::HashMap;

use toml::Spanned;

use super::raw::RawBoundary;
use super::shapes::mesh_scale;
use super::{SceneError, SourceFile};
use crate::mesh_boundary::{Boundary, BoundaryMotion};

/// Validates every `[[boundary]]` in order, then reports their repairs: warnings go to
/// `warnings`, and the notes are returned.
pub(super) fn boundaries(
    cx: &SourceFile,
    raw: &[Spanned<RawBoundary>],
    material_names: &HashMap<String, u32>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Boundary>, Vec<String>), SceneError> {
    let boundaries = raw
        .iter()
        .enumerate()
        .map(|(k, b)| boundary(cx, k, b, material_names))
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
    Ok((boundaries, notes))
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
