//! The periodic box of `[simulation] periodic = { .. }`: the table itself, and its checks
//! against the rest of the scene once the walls and bodies are known.

use super::raw::RawPeriodic;
use super::{SceneError, SourceFile};
use crate::periodic::Periodic;
use crate::world::{BodyInit, Wall};
use clatter_geom::PreparedShape;

/// `[simulation] periodic = { min, max, axes }`.
pub(super) fn periodic_box(cx: &SourceFile, r: &RawPeriodic) -> Result<Periodic, SceneError> {
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
pub(super) fn check_periodic(
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
