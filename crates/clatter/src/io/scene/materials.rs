//! `[[material]]`: density, the contact law (linear or Hertz) and its constants, the
//! coefficients of the table `material_coefficients!` (restitution, frictions, ...: each
//! checked against its range) and cohesion. Names must be unique, and one scene uses one contact
//! model.

use std::collections::HashMap;

use toml::Spanned;

use super::raw::{RawCohesion, RawMaterial};
use super::{SceneError, SourceFile};
use crate::material::{COEFFICIENTS, Cohesion, ContactLaw, Material};

/// Validates every `[[material]]` in order; returns them with their name -> index table.
pub(super) fn materials(
    cx: &SourceFile,
    raw: &[Spanned<RawMaterial>],
) -> Result<(Vec<Material>, HashMap<String, u32>), SceneError> {
    let mut materials = Vec::new();
    let mut material_names = HashMap::new();
    for (k, m) in raw.iter().enumerate() {
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
        materials.push(material(cx, k, m)?);
    }
    if let (Some(a), Some(b)) = (
        materials
            .iter()
            .position(|m| matches!(m.law, ContactLaw::Linear { .. })),
        materials
            .iter()
            .position(|m| matches!(m.law, ContactLaw::Hertz { .. })),
    ) {
        let later = &raw[a.max(b)];
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
    Ok((materials, material_names))
}

/// `[[material]]` number `k` (its name already checked unique).
fn material(cx: &SourceFile, k: usize, m: &Spanned<RawMaterial>) -> Result<Material, SceneError> {
    let r = m.get_ref();
    let f = |name: &str| format!("material[{k}].{name}");
    let density = cx.positive(&r.density, &f("density"))? as f32;
    let law = contact_law(cx, k, m)?;
    let mut material = Material::with_defaults(r.name.get_ref().clone(), density, law);
    for (name, v) in r.coefficients() {
        let value = coefficient(cx, &f(name), name, v)?;
        if let Some(c) = material.coefficient_mut(name) {
            *c = value;
        }
    }
    material.cohesion = cohesion(cx, k, &r.cohesion)?;
    Ok(material)
}

/// The value of coefficient `name` given as `v`, checked against the coefficient's range.
fn coefficient(
    cx: &SourceFile,
    field: &str,
    name: &str,
    v: &Spanned<f64>,
) -> Result<f32, SceneError> {
    let x = *v.get_ref();
    let range = COEFFICIENTS
        .iter()
        .find(|c| c.name == name)
        .map(|c| c.range);
    match range.and_then(|r| r.check(x)) {
        Some(message) => cx.err(v.span(), field, message),
        None => Ok(x as f32),
    }
}

/// The contact law of material `k`: `model` (linear by default) and the constants it takes;
/// the other model's constants are refused rather than ignored.
fn contact_law(
    cx: &SourceFile,
    k: usize,
    m: &Spanned<RawMaterial>,
) -> Result<ContactLaw, SceneError> {
    let r = m.get_ref();
    let f = |name: &str| format!("material[{k}].{name}");
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
                return cx.err(
                    s.span(),
                    f("stiffness"),
                    "only used with the linear model; hertz takes youngs_modulus and poisson_ratio",
                );
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
    Ok(law)
}

/// The `cohesion` table of material `k`, if any (only `model = "dmt"` for now).
fn cohesion(
    cx: &SourceFile,
    k: usize,
    raw: &Option<Spanned<RawCohesion>>,
) -> Result<Option<Cohesion>, SceneError> {
    let f = |name: &str| format!("material[{k}].{name}");
    let cohesion = match raw {
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
    Ok(cohesion)
}
