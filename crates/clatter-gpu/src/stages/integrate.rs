//! Stage 3, **integrate**: wall contacts, the gather of every body's forces in a fixed
//! order, semi-implicit Euler, the rebuild check (integrate.wgsl); then `end_step`
//! (bin.wgsl) counts the step.

use super::Recorder;
use crate::layout::arg;
use crate::pipeline::{Group2, KernelSpec, Size};

/// `integrate` is compiled with the contact kernels (it calls `wall_contact`).
pub(crate) const CONTACT_KERNELS: &[KernelSpec] = &[("contacts", "integrate", Group2::None)];
/// `end_step` is a base kernel.
pub(crate) const BASE_KERNELS: &[KernelSpec] = &[("bin", "end_step", Group2::None)];

/// Records the stage.
pub(crate) fn record(r: &mut Recorder<'_>) {
    r.contact("integrate", Size::Indirect(arg::STEP_BODIES));
    r.base("end_step", Size::Single);
}
