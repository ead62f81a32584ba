//! One step on the GPU: the same stages, under the same names, as the CPU's
//! `clatter::step`, each recorded by its own module from its shaders in `shaders/<stage>/` (`common/` holds what every kernel includes, `test/` the harness kernels):
//!
//! 1. [`broad`]: `prepare` (does this step rebuild?), then **bin**, **sort**, **pairs**
//!    (bin.wgsl, scan.wgsl, sort.wgsl, pairs.wgsl), every dispatch sized on the GPU and zero
//!    unless a rebuild is due;
//! 2. [`contacts`]: **narrow** phase and contact **law** per candidate pair (contacts.wgsl,
//!    law.wgsl, narrow.wgsl; contacts_split.wgsl for scenes with polyhedra);
//! 3. [`integrate`]: wall contacts, the gather, the update, the rebuild check
//!    (integrate.wgsl).

pub mod broad;
pub mod contacts;
pub mod health;
pub mod integrate;

use crate::pipeline::{Dispatch, KernelSet, KernelSpec, Kernels, Size};

pub(crate) use broad::Scans;

/// Records a step's dispatches in order.
pub(crate) struct Recorder<'a> {
    base: &'a Kernels,
    contacts: &'a Kernels,
    /// The dispatches so far.
    pub ops: Vec<Dispatch>,
}

impl<'a> Recorder<'a> {
    fn push(&mut self, set: KernelSet, name: &str, size: Size, scan_level: usize) {
        let kernels = match set {
            KernelSet::Base => self.base,
            KernelSet::Contacts => self.contacts,
        };
        self.ops.push(Dispatch {
            set,
            pipeline: kernels.index(name),
            size,
            scan_level,
        });
    }

    /// A base kernel.
    pub fn base(&mut self, name: &str, size: Size) {
        self.push(KernelSet::Base, name, size, 0);
    }

    /// One of this world's contact kernels.
    pub fn contact(&mut self, name: &str, size: Size) {
        self.push(KernelSet::Contacts, name, size, 0);
    }
}

/// The full step and the lean step (the full step without the rebuild's dispatches: see
/// `GpuWorld::encode_steps`).
pub(crate) fn record(
    base: &Kernels,
    contacts: &Kernels,
    scans: &Scans,
    variant: crate::pipeline::ContactVariant,
) -> (Vec<Dispatch>, Vec<Dispatch>) {
    let mut r = Recorder {
        base,
        contacts,
        ops: Vec::new(),
    };
    broad::record(&mut r, scans);
    let first_contact = r.ops.len();
    contacts::record(&mut r, variant);
    integrate::record(&mut r);
    let full = std::mem::take(&mut r.ops);
    r.base("prepare_lean", Size::Single);
    r.ops.extend_from_slice(&full[first_contact..]);
    (full, r.ops)
}

/// Sources and kernels of the base set (every world).
pub(crate) fn base_kernels() -> (Vec<(&'static str, String)>, Vec<KernelSpec>) {
    let mut kernels: Vec<KernelSpec> = broad::KERNELS.to_vec();
    kernels.extend_from_slice(integrate::BASE_KERNELS);
    kernels.extend_from_slice(health::KERNELS);
    let mut modules = broad::modules();
    modules.push(health::module());
    (modules, kernels)
}

/// Sources and kernels of the contact set: sphere-only scenes, or any scene, with or without
/// composites.
pub(crate) fn contact_kernels(
    variant: crate::pipeline::ContactVariant,
) -> (Vec<(&'static str, String)>, Vec<KernelSpec>) {
    let (source, mut kernels) = contacts::kernels(variant);
    kernels.extend_from_slice(integrate::CONTACT_KERNELS);
    (vec![("contacts", source)], kernels)
}
