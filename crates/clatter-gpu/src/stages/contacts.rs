//! Stage 2, **contacts**: narrow phase and contact law per candidate pair. Sphere-only scenes
//! run one pass (`contacts`); scenes with polyhedra run two (contacts_split.wgsl):
//! `contacts_sat` proves most pairs apart cheaply and lists the rest, `contacts_place` orders
//! that list by class (shape pair and path, so that a subgroup runs one kind), with the pairs
//! that have a sphere body first; `contacts_full_spheres` (sphere narrow phase only) and
//! `contacts_full_poly` (polyhedron pairs only) run the full narrow phase and the law on the
//! list's two ranges, so that no workgroup mixes the two kinds' code. With
//! `CLATTER_GPU_POLY_LANES` at 8 or 16, `contacts_full_poly_lanes` (contacts_lanes.wgsl)
//! takes `contacts_full_poly`'s place: that many lanes per pair spread its separating-axis
//! test, with the same bits.

use super::Recorder;
use crate::layout::arg;
use crate::pipeline::{self, Group2, KernelSpec, Size};

/// The contact kernels' source (with integrate.wgsl, which computes the wall contacts) and
/// entry points.
pub(crate) fn kernels(variant: pipeline::ContactVariant) -> (String, Vec<KernelSpec>) {
    use pipeline::{
        ARGS, CONTACTS, CONTACTS_LANES, CONTACTS_SPLIT, INTEGRATE, LAW, MESH, MESH_NONE, MESH_POLY,
        MESH_SPHERES, NARROW_SPHERES, PIECES,
    };
    let with = pipeline::composites_const(variant.composites);
    // The mesh contacts (called by integrate) only in scenes with meshes.
    let mesh: &[&str] = match (variant.meshes, variant.spheres_only) {
        (false, _) => &[MESH_NONE],
        (true, true) => &[MESH, MESH_SPHERES],
        (true, false) => &[MESH, MESH_POLY],
    };
    if variant.spheres_only {
        let mut parts = vec![with, NARROW_SPHERES, PIECES, LAW, CONTACTS];
        parts.extend_from_slice(mesh);
        parts.push(INTEGRATE);
        (
            pipeline::source(&parts),
            vec![("contacts", "contacts", Group2::None)],
        )
    } else {
        let narrow = pipeline::narrow_source(variant.clip);
        let lanes = format!("const POLY_LANES: u32 = {}u;\n", variant.lanes.max(1));
        let mut parts = vec![with, ARGS, &narrow, PIECES, LAW, CONTACTS, CONTACTS_SPLIT];
        let full_poly = if variant.lanes > 1 {
            parts.extend_from_slice(&[&lanes, CONTACTS_LANES]);
            "contacts_full_poly_lanes"
        } else {
            "contacts_full_poly"
        };
        parts.extend_from_slice(mesh);
        parts.push(INTEGRATE);
        (
            pipeline::source(&parts),
            vec![
                ("contacts", "contacts_sat", Group2::None),
                ("contacts", "contacts_size", Group2::Args),
                ("contacts", "contacts_place", Group2::None),
                ("contacts", "contacts_full_spheres", Group2::None),
                ("contacts", full_poly, Group2::None),
            ],
        )
    }
}

/// Records the stage.
pub(crate) fn record(r: &mut Recorder<'_>, variant: pipeline::ContactVariant) {
    if variant.spheres_only {
        r.contact("contacts", Size::Indirect(arg::PAIRS));
    } else {
        r.contact("contacts_sat", Size::Indirect(arg::PAIRS));
        r.contact("contacts_size", Size::Single);
        r.contact("contacts_place", Size::Indirect(arg::WORK));
        r.contact("contacts_full_spheres", Size::Indirect(arg::FULL_SPHERES));
        let full_poly = if variant.lanes > 1 {
            "contacts_full_poly_lanes"
        } else {
            "contacts_full_poly"
        };
        r.contact(full_poly, Size::Indirect(arg::FULL_POLY));
    }
}
