//! The blow-up checks and energy samples on the GPU (health.wgsl), recorded only when a run
//! turns them on (`GpuWorld::set_health`): after every step `health_bodies` and
//! `health_reduce` (which do nothing unless a check or a sample is due at that step), then
//! `snapshot_state` (which copies the state when the step is a snapshot step that passed its
//! checks). Not part of `clatter::step`: the CPU's twin is
//! `clatter::health`, run by the host between steps.

use crate::layout::WG;
use crate::pipeline::{self, Dispatch, Group2, KernelSet, KernelSpec, Kernels, Size};

use super::broad::grid_of;

/// The health kernels (base set).
pub(crate) const KERNELS: &[KernelSpec] = &[
    ("health", "health_bodies", Group2::None),
    ("health", "health_reduce", Group2::None),
    ("health", "snapshot_state", Group2::None),
];

/// The health module's source.
pub(crate) fn module() -> (&'static str, String) {
    ("health", pipeline::source(&[pipeline::HEALTH]))
}

/// Workgroups of `snapshot_state`: each thread copies every `SNAPSHOT_GROUPS * WG`-th
/// element, so the many steps without a snapshot cost a small dispatch that returns at once.
pub(crate) const SNAPSHOT_GROUPS: u32 = 64;

/// The dispatches after every step, for `n` bodies: the checks and samples, then the
/// snapshot.
pub(crate) fn record(base: &Kernels, n: u64) -> Vec<Dispatch> {
    let op = |name: &str, size: Size| Dispatch {
        set: KernelSet::Base,
        pipeline: base.index(name),
        size,
        scan_level: 0,
    };
    vec![
        op(
            "health_bodies",
            Size::Fixed(grid_of(n.div_ceil(WG as u64) as u32)),
        ),
        op("health_reduce", Size::Single),
        op("snapshot_state", Size::Fixed([SNAPSHOT_GROUPS, 1, 1])),
    ]
}
