//! `[[wall]]` planes and the `[container]` box, whose faces become walls too (none along a
//! periodic axis, and no lid when `top = false`).

use std::collections::HashMap;

use glam::Vec3;
use toml::Spanned;

use super::raw::{RawContainer, RawWall};
use super::{SceneError, SourceFile};
use crate::periodic::Periodic;
use crate::world::Wall;
use clatter_geom::narrow::Plane;

/// Validates every `[[wall]]` in order: a finite point, a non-zero normal, a known material.
pub(super) fn walls(
    cx: &SourceFile,
    raw: &[Spanned<RawWall>],
    material_names: &HashMap<String, u32>,
) -> Result<Vec<Wall>, SceneError> {
    let mut walls = Vec::new();
    for (k, w) in raw.iter().enumerate() {
        let r = w.get_ref();
        let point = cx.vec3(&r.point, &format!("wall[{k}].point"))?;
        let normal = cx.unit(&r.normal, &format!("wall[{k}].normal"))?;
        let material = cx.lookup(
            material_names,
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
    Ok(walls)
}

/// Validates `[container]`, if any, and appends its faces to `walls`; returns its corners
/// (for the bodies-outside warning).
pub(super) fn container(
    cx: &SourceFile,
    raw: &Option<Spanned<RawContainer>>,
    material_names: &HashMap<String, u32>,
    periodic: Option<&Periodic>,
    walls: &mut Vec<Wall>,
) -> Result<Option<(Vec3, Vec3)>, SceneError> {
    let mut container_bounds = None;
    if let Some(c) = raw {
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
            material_names,
            &r.material,
            "container.material",
            "material",
        )?;
        for axis in 0..3 {
            // A periodic axis has no container faces: the box repeats instead.
            if periodic.is_some_and(|p| p.axes[axis]) {
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
    Ok(container_bounds)
}
