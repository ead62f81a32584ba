//! Stage 1, **broad** phase, as the CPU's `clatter::step::broad`: `prepare` decides whether
//! this step rebuilds (flagged by the last integrate) and sizes the rebuild's dispatches
//! (zero otherwise, so the host never waits); **bin** (bounding box, grid, cell keys),
//! **sort** (cell ranges by prefix sum, bodies dropped into cells in index order), **pairs**
//! (27-cell search, sorted pair list, springs carried over, the b-side adjacency).

use super::Recorder;
use crate::buffers::{Buf, Buffers};
use crate::layout::{WG, arg};
use crate::pipeline::{self, Group2, KernelSpec, Size};

/// The broad phase's kernels, in the order they run.
pub(crate) const KERNELS: &[KernelSpec] = &[
    ("bin", "prepare", Group2::Args),
    ("bin", "prepare_lean", Group2::Args),
    ("bin", "bbox", Group2::None),
    ("bin", "grid_size", Group2::None),
    ("bin", "bin", Group2::None),
    ("bin", "copy_cells", Group2::None),
    ("scan", "scan_block", Group2::Scan),
    ("scan", "scan_add", Group2::Scan),
    ("sort", "scatter", Group2::None),
    ("sort", "sort_cells", Group2::None),
    ("pairs", "count_pairs", Group2::None),
    ("pairs", "pairs_total", Group2::Args),
    ("pairs", "fill_pairs", Group2::None),
    ("pairs", "carry", Group2::None),
    ("pairs", "commit", Group2::None),
    ("pairs", "count_b", Group2::None),
    ("pairs", "copy_b", Group2::None),
    ("pairs", "fill_b", Group2::None),
    ("pairs", "sort_b", Group2::None),
];

/// The broad phase's shader modules.
pub(crate) fn modules() -> Vec<(&'static str, String)> {
    use pipeline::{ARGS, BIN, PAIRS, PIECES, SCAN, SHAPES_DECL, SORT};
    vec![
        ("bin", pipeline::source(&[ARGS, BIN])),
        ("scan", pipeline::source(&[SCAN])),
        ("sort", pipeline::source(&[SORT])),
        (
            "pairs",
            // Piece pairs are found only when `params.composites` says so.
            pipeline::source(&[
                ARGS,
                BIN,
                SHAPES_DECL,
                pipeline::composites_const(true),
                PIECES,
                PAIRS,
            ]),
        ),
    ]
}

/// One exclusive scan (reduce-then-scan over 256-element blocks, recursively): per level,
/// its bind group (level data, next level's sums) and its dispatch slot.
pub(crate) struct ScanPlan {
    first_group: usize,
    slots: Vec<u32>,
}

/// The three scans of a rebuild (cell counts, pairs per body, b-side counts), their level
/// buffers and bind groups, and the indirect-argument template.
pub(crate) struct Scans {
    pub bind_groups: Vec<wgpu::BindGroup>,
    /// Keeps the level buffers alive.
    _sums: Vec<wgpu::Buffer>,
    cells: ScanPlan,
    a_side: ScanPlan,
    b_side: ScanPlan,
    /// Initial dispatch arguments, 3 words per slot.
    pub template: Vec<[u32; 3]>,
}

/// Workgroups as a 2D grid within the 65,535 limit per dimension.
pub(crate) fn grid_of(groups: u32) -> [u32; 3] {
    if groups == 0 {
        [0, 0, 1]
    } else {
        [groups.min(65535), groups.div_ceil(65535), 1]
    }
}

impl Scans {
    /// Plans the scans for `n` bodies and at most `max_cells` cells.
    pub fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        bufs: &Buffers,
        n: u64,
        max_cells: u64,
    ) -> Scans {
        let groups = |count: u64| count.div_ceil(WG as u64) as u32;
        let mut template = vec![[0u32; 3]; arg::FIRST_SCAN as usize];
        template[arg::BODIES_REBUILD as usize] = grid_of(groups(n + 1));
        template[arg::CELLS_REBUILD as usize] = grid_of(groups(max_cells + 1));
        // Level lengths: sums of 256-blocks until one block remains.
        let levels = |len: u64| {
            let mut v = vec![len];
            while let Some(&l) = v.last().filter(|&&l| l > WG as u64) {
                v.push(l.div_ceil(WG as u64));
            }
            v
        };
        let sums_of = |lv: &[u64], label: &str| -> Vec<wgpu::Buffer> {
            lv[1..]
                .iter()
                .map(|&l| {
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(label),
                        size: std::mem::size_of::<u32>() as u64 * l,
                        usage: wgpu::BufferUsages::STORAGE,
                        mapped_at_creation: false,
                    })
                })
                .collect()
        };
        let (cell_levels, body_levels) = (levels(max_cells + 1), levels(n + 1));
        let cell_sums = sums_of(&cell_levels, "cell scan sums");
        let body_sums = sums_of(&body_levels, "body scan sums");
        let dummy = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scan placeholder"),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let mut bind_groups = Vec::new();
        let mut plan = |data: &wgpu::Buffer, sums: &[wgpu::Buffer], lv: &[u64]| {
            let first_group = bind_groups.len();
            let mut slots = Vec::new();
            for (l, &len) in lv.iter().enumerate() {
                let d = if l == 0 { data } else { &sums[l - 1] };
                let s = sums.get(l).unwrap_or(&dummy);
                bind_groups.push(device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("scan level"),
                    layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: d.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: s.as_entire_binding(),
                        },
                    ],
                }));
                slots.push(template.len() as u32);
                template.push(grid_of(groups(len)));
            }
            ScanPlan { first_group, slots }
        };
        let cells = plan(&bufs[Buf::CellStart], &cell_sums, &cell_levels);
        let a_side = plan(&bufs[Buf::NewAStart], &body_sums, &body_levels);
        let b_side = plan(&bufs[Buf::BStart], &body_sums, &body_levels);
        let mut sums = cell_sums;
        sums.extend(body_sums);
        sums.push(dummy);
        Scans {
            bind_groups,
            _sums: sums,
            cells,
            a_side,
            b_side,
            template,
        }
    }
}

impl Recorder<'_> {
    /// The dispatches of one scan: up the levels, then back down.
    fn scan(&mut self, p: &ScanPlan) {
        let levels = p.slots.len();
        for l in 0..levels {
            self.scan_level("scan_block", p.slots[l], p.first_group + l);
        }
        for l in (0..levels.saturating_sub(1)).rev() {
            self.scan_level("scan_add", p.slots[l], p.first_group + l);
        }
    }

    fn scan_level(&mut self, name: &str, slot: u32, group: usize) {
        self.base(name, Size::Indirect(slot));
        if let Some(last) = self.ops.last_mut() {
            last.scan_level = group;
        }
    }
}

/// Records the stage.
pub(crate) fn record(r: &mut Recorder<'_>, scans: &Scans) {
    let bodies = Size::Indirect(arg::BODIES_REBUILD);
    let cells = Size::Indirect(arg::CELLS_REBUILD);
    let new_pairs = Size::Indirect(arg::PAIRS_NEW);
    r.base("prepare", Size::Single);
    // bin
    r.base("bbox", bodies);
    r.base("grid_size", Size::Single);
    r.base("bin", bodies);
    r.base("copy_cells", cells);
    // sort
    r.scan(&scans.cells);
    r.base("scatter", bodies);
    r.base("sort_cells", cells);
    // pairs
    r.base("count_pairs", bodies);
    r.scan(&scans.a_side);
    r.base("pairs_total", Size::Single);
    r.base("fill_pairs", bodies);
    r.base("carry", new_pairs);
    r.base("commit", Size::Indirect(arg::COMMIT));
    r.base("count_b", new_pairs);
    r.base("copy_b", bodies);
    r.scan(&scans.b_side);
    r.base("fill_b", new_pairs);
    r.base("sort_b", bodies);
}
