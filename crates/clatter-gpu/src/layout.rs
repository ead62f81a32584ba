//! What the GPU pipeline shares with its shaders beyond `clatter::contract`: the step's
//! uniform [`Params`], the [`Grid`], the status words and the indirect-dispatch slots. The
//! WGSL declarations of all of them, and of the buffers ([`crate::buffers`]), are generated
//! by [`wgsl_prelude`], which every kernel is compiled after.

use clatter::contract::{Constant, GpuRecord, wgsl_constants};

pub use clatter::contract::{
    BODY_ORIENTATION_OFFSET, BODY_POSITION_OFFSET, BODY_STATE_SIZE, BodyConsts, BodyState,
    ContactForce, PairParams, WallRecord,
};

clatter::gpu_record! {
    /// Uniform parameters of the step.
    pub struct Params {
        /// Gravity, m/s^2 (w unused).
        pub gravity: [f32; 4],
        /// Number of bodies.
        pub n: u32,
        /// Number of walls.
        pub num_walls: u32,
        /// Number of materials (the pair table is `num_materials^2`).
        pub num_materials: u32,
        /// Room in the pair buffers.
        pub pair_capacity: u32,
        /// Time step, s.
        pub dt: f32,
        /// Verlet skin, m.
        pub skin: f32,
        /// `(skin / 2)^2`: a body farther than this from its rebuild position asks for a rebuild.
        pub half_skin2: f32,
        /// The smallest cell size: the largest bounding diameter plus the skin.
        pub min_cell: f32,
        /// The grid has at most this many cells.
        pub max_cells: u32,
        /// Number of indirect-dispatch slots.
        pub num_args: u32,
        /// 1 when every body is a sphere (the CPU's sphere fast path: effective radius from
        /// the bounding radius).
        pub spheres_only: u32,
        /// Always 1.0, unknown to the shader compiler: multiplying by it stops the compiler
        /// from simplifying the compensated orientation sum `(q + y) - q - y` to zero.
        pub one: f32,
        /// Lower corner of the periodic box (w unused).
        pub periodic_min: [f32; 4],
        /// Periodic box length per axis, 0 along non-periodic axes (w unused).
        pub periodic_len: [f32; 4],
    }
}

clatter::gpu_record! {
    /// The grid of the last rebuild (written by `grid_size` in bin.wgsl).
    pub struct Grid {
        /// Lower corner (w unused).
        pub min: [f32; 4],
        /// Edge of a cubic cell, m.
        pub cell_size: f32,
        /// Number of cells.
        pub cells: u32,
        /// Unused.
        pub pad0: u32,
        /// Unused.
        pub pad1: u32,
        /// Cells along x, y, z (w unused).
        pub dims: [u32; 4],
    }
}

/// Words of the status buffer (`ST_*` in WGSL).
pub mod status {
    /// Set by integrate: rebuild the pair list next step.
    pub const REBUILD: usize = 0;
    /// The pair list overflowed: everything stops until the host grows it.
    pub const OVERFLOW: usize = 1;
    /// First body with a non-finite state (`u32::MAX` if none).
    pub const BAD_BODY: usize = 2;
    /// Contacts touching in the last step.
    pub const TOUCHING: usize = 3;
    /// Candidate pairs in the list.
    pub const PAIRS: usize = 4;
    /// Steps taken on the GPU (low 32 bits).
    pub const STEPS: usize = 5;
    /// Shader-internal: this step rebuilds.
    pub const REBUILDING: usize = 6;
    /// Rebuilds so far.
    pub const REBUILDS: usize = 7;
    /// Pairs the last rebuild found (may exceed the capacity).
    pub const PAIRS_NEEDED: usize = 8;
    /// Pairs `contacts_sat` left for `contacts_full` in the last step (polyhedron scenes).
    pub const WORK: usize = 9;
    /// Shader-internal: 6 words, the bounding box (min xyz, max xyz as order-preserving u32).
    pub const BBOX: usize = 10;
    /// Set by a lean step that found a rebuild due: the pipeline stops until the next full
    /// step, which clears it and runs that step again.
    pub const STALL: usize = 16;
    /// Number of status words.
    pub const LEN: usize = 17;
}

/// Indirect-dispatch slots (`ARG_*` in WGSL); the scan levels' slots follow.
pub mod arg {
    /// Every body plus one, during a rebuild.
    pub const BODIES_REBUILD: u32 = 0;
    /// Every cell plus one, during a rebuild.
    pub const CELLS_REBUILD: u32 = 1;
    /// The new pair list, during a rebuild.
    pub const PAIRS_NEW: u32 = 2;
    /// The current pair list, every step.
    pub const PAIRS: u32 = 3;
    /// `max(new pairs, n + 1)`, during a rebuild.
    pub const COMMIT: u32 = 4;
    /// `contacts_full`: the pairs `contacts_sat` could not separate.
    pub const WORK: u32 = 5;
    /// `integrate`, every step (zero while the pipeline is stopped).
    pub const STEP_BODIES: u32 = 6;
    /// The first scan-level slot.
    pub const FIRST_SCAN: u32 = 7;
}

/// Threads per workgroup of every kernel (`WG`).
pub const WG: u32 = 256;

/// The constants the shaders share with the host.
fn constants() -> Vec<Constant> {
    use Constant::U32;
    let st = |name, v: usize| U32(name, v as u32);
    vec![
        U32("WG", WG),
        U32("NONE", u32::MAX),
        st("ST_REBUILD", status::REBUILD),
        st("ST_OVERFLOW", status::OVERFLOW),
        st("ST_BAD_BODY", status::BAD_BODY),
        st("ST_TOUCHING", status::TOUCHING),
        st("ST_PAIRS", status::PAIRS),
        st("ST_STEPS", status::STEPS),
        st("ST_REBUILDING", status::REBUILDING),
        st("ST_REBUILDS", status::REBUILDS),
        st("ST_PAIRS_NEEDED", status::PAIRS_NEEDED),
        st("ST_WORK", status::WORK),
        st("ST_BBOX", status::BBOX),
        st("ST_STALL", status::STALL),
        U32("ARG_BODIES_REBUILD", arg::BODIES_REBUILD),
        U32("ARG_CELLS_REBUILD", arg::CELLS_REBUILD),
        U32("ARG_PAIRS_NEW", arg::PAIRS_NEW),
        U32("ARG_PAIRS", arg::PAIRS),
        U32("ARG_COMMIT", arg::COMMIT),
        U32("ARG_WORK", arg::WORK),
        U32("ARG_STEP_BODIES", arg::STEP_BODIES),
        U32("ARG_SCAN0", arg::FIRST_SCAN),
    ]
}

/// Everything a simulation kernel is compiled after: the shared constants and records
/// (`clatter::contract`), the GPU's own ([`Params`], [`Grid`], status words, dispatch
/// slots), and the group-0 buffer bindings ([`crate::buffers::BUFFERS`]).
pub fn wgsl_prelude() -> String {
    [
        "// Generated from clatter::contract and clatter-gpu/src/{layout,buffers}.rs.\n".into(),
        clatter::contract::wgsl_records(),
        wgsl_constants(&constants()),
        Params::wgsl(),
        Grid::wgsl(),
        crate::buffers::wgsl_bindings(),
    ]
    .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clatter::contract::layout_mismatch;

    #[test]
    fn gpu_records_have_the_wgsl_layout() {
        assert_eq!(layout_mismatch::<Params>(), None);
        assert_eq!(layout_mismatch::<Grid>(), None);
    }

    #[test]
    fn no_shader_retypes_a_generated_declaration() {
        let generated = wgsl_prelude();
        for (file, src) in crate::pipeline::SHADER_FILES {
            for line in src.lines() {
                let decl = line.trim_start();
                let named = |prefix: &str| {
                    decl.strip_prefix(prefix)
                        .and_then(|r| r.split([' ', ':', '{']).next())
                        .filter(|name| generated.contains(&format!("{prefix}{name}")))
                };
                if let Some(name) = named("struct ").or_else(|| named("const ")) {
                    panic!("{file} declares {name}, which is generated: {line}");
                }
                assert!(
                    !decl.starts_with("@group(0)"),
                    "{file} binds group 0 itself: {line}"
                );
            }
        }
    }
}
