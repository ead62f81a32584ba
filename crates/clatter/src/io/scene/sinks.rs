//! `[[sink]]`: boxes that remove the bodies whose centres enter them ([`crate::sink`]),
//! checked against the walls and the periodic box so that each can catch something.

use glam::Vec3;
use toml::Spanned;

use super::raw::RawSink;
use super::{SceneError, SourceFile};
use crate::periodic::Periodic;
use crate::sink::Sink;
use crate::world::Wall;

/// `[[sink]]`: boxes with finite corners, `min <= max`, that can catch something: a box
/// entirely behind a wall plane, or entirely outside the periodic box along a periodic axis
/// (positions are wrapped into it), is refused.
pub(super) fn sinks(
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
