//! `[[body]]`: single bodies, each with its shape, material, position, orientation and
//! velocities.

use std::collections::HashMap;

use toml::Spanned;

use super::raw::RawBody;
use super::{SceneError, SourceFile};
use crate::world::BodyInit;

/// Validates every `[[body]]` in order.
pub(super) fn bodies(
    cx: &SourceFile,
    raw: &[Spanned<RawBody>],
    shape_names: &HashMap<String, u32>,
    material_names: &HashMap<String, u32>,
) -> Result<Vec<BodyInit>, SceneError> {
    let mut bodies = Vec::new();
    for (k, b) in raw.iter().enumerate() {
        let r = b.get_ref();
        let f = |name: &str| format!("body[{k}].{name}");
        let shape = cx.lookup(shape_names, &r.shape, &f("shape"), "shape")?;
        let material = cx.lookup(material_names, &r.material, &f("material"), "material")?;
        bodies.push(BodyInit {
            shape,
            material,
            position: cx.dvec3(&r.position, &f("position"))?,
            orientation: cx.quat(&r.orientation, &f("orientation"))?,
            velocity: cx.opt_vec3(&r.velocity, &f("velocity"))?,
            angular_velocity: cx.opt_vec3(&r.angular_velocity, &f("angular_velocity"))?,
        });
    }
    Ok(bodies)
}
