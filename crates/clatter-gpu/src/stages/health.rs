//! The blow-up checks and energy samples on the GPU (health.wgsl), recorded only when a run
//! turns them on (`GpuWorld::set_health`): the step's last kernel is then `end_step_gate`
//! instead of `end_step` (it counts the step, as `end_step` does, and in the same thread
//! sizes the three dispatches after it for that step: nothing unless a check, a sample or a
//! snapshot is due, so the steps in between cost three empty indirect dispatches), then
//! `health_bodies` and `health_reduce` (the checks and samples), then `snapshot_state`
//! (which copies the state when the step is a snapshot step that passed its checks). The
//! gate reads the GPU's own step count, so it stays right when a batch stalls and its steps
//! shift (which is also why the host cannot leave them out of the steps it records). Not
//! part of `clatter::step`: the CPU's twin is `clatter::health`, run by the host between
//! steps.

use crate::layout::arg;
use crate::pipeline::{self, Dispatch, Group2, KernelSet, KernelSpec, Kernels, Size};

/// The health kernels (base set).
pub(crate) const KERNELS: &[KernelSpec] = &[
    ("health", "end_step_gate", Group2::Args),
    ("health", "health_bodies", Group2::None),
    ("health", "health_reduce", Group2::None),
    ("health", "snapshot_state", Group2::Snapshot),
];

/// The health module's source.
pub(crate) fn module() -> (&'static str, String) {
    (
        "health",
        pipeline::source(&[pipeline::ARGS, pipeline::HEALTH]),
    )
}

/// Workgroups of `snapshot_state`: each thread copies every `SNAPSHOT_GROUPS * WG`-th
/// element, so the many steps without a snapshot cost a small dispatch that returns at once.
pub(crate) const SNAPSHOT_GROUPS: u32 = 64;

/// The dispatches that end every step in place of `end_step` (the last dispatch of the step's
/// list): the step's count and the gate, the checks and samples, then the snapshot.
pub(crate) fn record(base: &Kernels) -> Vec<Dispatch> {
    let op = |name: &str, size: Size| Dispatch {
        set: KernelSet::Base,
        pipeline: base.index(name),
        size,
        scan_level: 0,
    };
    vec![
        op("end_step_gate", Size::Single),
        op("health_bodies", Size::Indirect(arg::HEALTH)),
        op("health_reduce", Size::Indirect(arg::HEALTH_REDUCE)),
        op("snapshot_state", Size::Indirect(arg::SNAPSHOT)),
    ]
}
