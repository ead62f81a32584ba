//! The simulation's GPU buffers, listed once in [`BUFFERS`]: the bind group layout, the bind
//! group, the WGSL `@binding` lines ([`wgsl_bindings`]), the allocation sizes and what
//! [`Buffers::grow`] reallocates all come from this one table. Binding `k` of group 0 is
//! `BUFFERS[k]`, and [`Buf`] names it.

use std::ops::Index;

use wgpu::util::DeviceExt;

/// How shaders access a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// `var<uniform>`.
    Uniform,
    /// `var<storage, read>`.
    Read,
    /// `var<storage, read_write>`.
    ReadWrite,
}

/// What a buffer's length is counted in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Count {
    /// One element.
    One,
    /// Status words.
    StatusWords,
    /// Bodies.
    Bodies,
    /// Bodies plus one (prefix sums).
    BodiesPlusOne,
    /// Grid cells plus one.
    CellsPlusOne,
    /// Pair-list capacity (grown on overflow).
    Pairs,
    /// Materials squared.
    MaterialPairs,
    /// Walls plus two per sink (its corners, see `Params::num_sinks`).
    WallsAndSinks,
    /// Bodies times walls times the most pieces of a body (`Dims::pieces`).
    WallSlots,
    /// Bodies, twice with composites (their rebuild orientations follow the positions).
    RebuildSlots,
    /// The energy log's slots plus one per workgroup of bodies.
    HealthSlots,
    /// The `snapshot` buffer's words: status and bodies (`layout::snapshot::words`).
    SnapshotWords,
    /// The words of the snapshot's copy of the `mesh` buffer (`layout::snapshot::mesh_words`:
    /// none without mesh boundaries).
    SnapshotMeshWords,
    /// The mesh boundaries' state words (`crate::mesh::state_words`).
    MeshWords,
}

/// One group-0 binding.
#[derive(Debug, Clone, Copy)]
pub struct Binding {
    /// The WGSL variable.
    pub name: &'static str,
    /// How shaders use it.
    pub access: Access,
    /// The WGSL type of the variable.
    pub wgsl: &'static str,
    /// Bytes per element.
    pub element: u64,
    /// Number of elements.
    pub count: Count,
    /// Whether [`Buffers::grow`] copies the old contents into the larger buffer.
    pub keep_on_grow: bool,
}

/// The sizes buffer lengths are counted in.
#[derive(Debug, Clone, Copy)]
pub struct Dims {
    /// Bodies.
    pub bodies: u64,
    /// Grid cells at most.
    pub cells: u64,
    /// Pair-list capacity.
    pub pairs: u64,
    /// Materials.
    pub materials: u64,
    /// Walls.
    pub walls: u64,
    /// Sink boxes.
    pub sinks: u64,
    /// Wall slots per body and wall: the most pieces of a body (1 without composites).
    pub pieces: u64,
    /// Whether some body is a composite.
    pub composites: bool,
    /// Triangle-mesh boundaries.
    pub boundaries: u64,
}

impl Binding {
    /// Bytes the buffer needs for `d` (at least 64: room for one element of any struct).
    pub fn size(&self, d: &Dims) -> u64 {
        let n = match self.count {
            Count::One => 1,
            Count::StatusWords => crate::layout::status::LEN as u64,
            Count::Bodies => d.bodies,
            Count::BodiesPlusOne => d.bodies + 1,
            Count::CellsPlusOne => d.cells + 1,
            Count::Pairs => d.pairs,
            Count::MaterialPairs => d.materials * d.materials,
            Count::WallsAndSinks => d.walls + 2 * d.sinks,
            Count::WallSlots => d.bodies * d.walls * d.pieces,
            Count::RebuildSlots => d.bodies * (1 + d.composites as u64),
            Count::HealthSlots => {
                crate::layout::HEALTH_LOG as u64 + d.bodies.div_ceil(crate::layout::WG as u64)
            }
            Count::SnapshotWords => crate::layout::snapshot::words(d.bodies),
            Count::SnapshotMeshWords => crate::layout::snapshot::mesh_words(d.bodies, d.boundaries),
            Count::MeshWords => crate::mesh::state_words(d.bodies, d.boundaries),
        };
        (n * self.element).max(64)
    }
}

/// A group-0 buffer that a scene needs larger than the adapter allows: found by
/// [`check_sizes`] before any buffer is allocated (wgpu would report it only as an invalid
/// buffer, and `create_buffer_init` would panic on it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Oversize {
    /// The buffer's WGSL name.
    pub name: &'static str,
    /// Bytes it needs.
    pub bytes: u64,
    /// Bytes the adapter allows for it (one binding of its kind, and one buffer).
    pub limit: u64,
    /// About how many bodies would fit: the most for which every buffer is within the limits,
    /// the other sizes scaled with the bodies (pairs per body as asked).
    pub bodies_that_fit: u64,
}

impl Oversize {
    /// The error to report, for the adapter named `adapter`.
    pub fn into_error(self, adapter: &str) -> crate::GpuError {
        crate::GpuError::TooLarge {
            adapter: adapter.to_string(),
            what: format!("largest buffer, `{}`", self.name),
            need: format!("{} bytes", self.bytes),
            limit: format!("{} bytes", self.limit),
            advice: format!(
                "about {} bodies would fit; use fewer bodies, or --backend cpu",
                self.bodies_that_fit
            ),
        }
    }
}

/// The most bytes the adapter with `limits` allows for a buffer accessed as `access`: one
/// binding of that kind, and one buffer.
pub fn limit_for(limits: &wgpu::Limits, access: Access) -> u64 {
    let binding = match access {
        Access::Uniform => limits.max_uniform_buffer_binding_size,
        Access::Read | Access::ReadWrite => limits.max_storage_buffer_binding_size,
    };
    binding.min(limits.max_buffer_size)
}

/// The first group-0 buffer larger than `limits` allow for `dims`, if any.
fn first_oversize(limits: &wgpu::Limits, dims: &Dims) -> Option<(&'static Binding, u64, u64)> {
    BUFFERS.iter().find_map(|b| {
        let (bytes, limit) = (b.size(dims), limit_for(limits, b.access));
        (bytes > limit).then_some((b, bytes, limit))
    })
}

/// `dims` scaled to `bodies` bodies: the cells and the pair capacity in proportion (rounded
/// down), the rest as they are.
fn scaled(dims: &Dims, bodies: u64) -> Dims {
    let per = |x: u64| (x as u128 * bodies as u128 / dims.bodies.max(1) as u128) as u64;
    Dims {
        bodies,
        cells: per(dims.cells),
        pairs: per(dims.pairs),
        ..*dims
    }
}

/// Checks every group-0 buffer's size for `dims` against the adapter's `limits` (the
/// largest storage or uniform binding, and the largest buffer), so that a scene too large is
/// refused with the buffer's name, its size and the limit before anything is allocated.
pub fn check_sizes(limits: &wgpu::Limits, dims: &Dims) -> Result<(), Oversize> {
    let Some((b, bytes, limit)) = first_oversize(limits, dims) else {
        return Ok(());
    };
    // Every size grows with the bodies: the most that fit, by bisection.
    let (mut lo, mut hi) = (0u64, dims.bodies);
    while lo + 1 < hi {
        let mid = lo + (hi - lo) / 2;
        if first_oversize(limits, &scaled(dims, mid)).is_none() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Err(Oversize {
        name: b.name,
        bytes,
        limit,
        bodies_that_fit: lo,
    })
}

macro_rules! buffers {
    ($($(#[$doc:meta])* $var:ident = $name:literal, $access:ident, $wgsl:literal, $elem:expr, $count:ident $(, $keep:ident)?;)*) => {
        /// A group-0 buffer, by binding index.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Buf {
            $($(#[$doc])* $var,)*
        }

        /// Every [`Buf`], in binding order.
        const ALL: &[Buf] = &[$(Buf::$var,)*];

        /// Every group-0 buffer, in binding order.
        pub const BUFFERS: &[Binding] = &[$(
            Binding {
                name: $name,
                access: Access::$access,
                wgsl: $wgsl,
                element: $elem as u64,
                count: Count::$count,
                keep_on_grow: buffers!(@keep $($keep)?),
            },
        )*];
    };
    (@keep keep) => { true };
    (@keep) => { false };
}

use clatter::contract::{BodyConsts, BodyState, ContactForce, PairParams, WallRecord};
use std::mem::size_of;

buffers! {
    /// The step's uniform parameters.
    Params = "params", Uniform, "Params", size_of::<crate::layout::Params>(), One;
    /// Body state records.
    Bodies = "bodies", ReadWrite, "array<BodyState>", size_of::<BodyState>(), Bodies;
    /// Body constant records.
    Statics = "statics", Read, "array<BodyConsts>", size_of::<BodyConsts>(), Bodies;
    /// The contact law's parameters per material pair.
    PairTable = "pair_table", Read, "array<PairParams>", size_of::<PairParams>(), MaterialPairs;
    /// Wall planes.
    Walls = "walls", Read, "array<WallRecord>", size_of::<WallRecord>(), WallsAndSinks;
    /// Status words (`layout::status`).
    Status = "status", ReadWrite, "array<atomic<u32>>", size_of::<u32>(), StatusWords;
    /// The grid of the last rebuild.
    Grid = "grid", ReadWrite, "Grid", size_of::<crate::layout::Grid>(), One;
    /// Cell key per body.
    Keys = "keys", ReadWrite, "array<u32>", size_of::<u32>(), Bodies;
    /// Bodies in cell order.
    Sorted = "sorted", ReadWrite, "array<u32>", size_of::<u32>(), Bodies;
    /// Bodies per cell.
    CellCount = "cell_count", ReadWrite, "array<atomic<u32>>", size_of::<u32>(), CellsPlusOne;
    /// First body of each cell in `sorted`.
    CellStart = "cell_start", ReadWrite, "array<u32>", size_of::<u32>(), CellsPlusOne;
    /// Positions at the last rebuild (xyz); with composites, then their orientations (body
    /// `i`'s at `n + i`). Body `i`'s `w` (written with the position by a rebuild's commit,
    /// then by every integrate in scenes with polyhedra): how far any point of the body can
    /// have moved in the last step (the CPU's `BodyBound::moved`), which `contacts_sat`
    /// takes off each pair's gap (see [`Buf::NewHist`]). (A field of an existing buffer:
    /// the shared group 0 is at lavapipe's limit of 32 storage buffers a stage.)
    RebuildPos = "rebuild_pos", ReadWrite, "array<vec4<f32>>", size_of::<[f32; 4]>(), RebuildSlots;
    /// The new pair list's per-body offsets (during a rebuild).
    NewAStart = "new_a_start", ReadWrite, "array<u32>", size_of::<u32>(), BodiesPlusOne;
    /// Body `i` is side a of pairs `a_start[i]..a_start[i + 1]`.
    AStart = "a_start", ReadWrite, "array<u32>", size_of::<u32>(), BodiesPlusOne;
    /// The new pair list (during a rebuild).
    NewPairs = "new_pairs", ReadWrite, "array<vec2<u32>>", size_of::<[u32; 2]>(), Pairs;
    /// Candidate pairs `(i, j)`, `i < j`, sorted.
    Pairs = "pairs", ReadWrite, "array<vec2<u32>>", size_of::<[u32; 2]>(), Pairs, keep;
    /// The new list's springs (during a rebuild). Outside a rebuild (zeroed by its commit,
    /// and by [`crate::GpuWorld::write_states`]), `x` of pair `c` is the pair's gap: for a
    /// pair not touching (0 for a touching one), a lower bound of its bodies' distance (0:
    /// none), from the bounding spheres or the separating axis that `contacts_sat` proved it
    /// apart with, less both bodies' motion since (`w` of [`Buf::RebuildPos`]); while it stays
    /// positive, `contacts_sat` skips the pair as apart (the CPU's `separation_bound` of a
    /// pair apart, `step::contacts::skip_apart`).
    NewHist = "new_hist", ReadWrite, "array<vec4<f32>>", size_of::<[f32; 4]>(), Pairs;
    /// Springs per pair: xyz tangential, w twist.
    Hist = "hist", ReadWrite, "array<vec4<f32>>", size_of::<[f32; 4]>(), Pairs, keep;
    /// Per pair: 1 touching, 0 not, 2 + axis: apart along that separating axis.
    Touching = "touching", ReadWrite, "array<u32>", size_of::<u32>(), Pairs;
    /// Per touching pair (`touching` 1; meaningless otherwise): what it remembers of its
    /// contact, the CPU's hint word (`contract::PAIR_MEMORY_CONSTANTS`), and the bits of its
    /// margin (the CPU's `separation_bound` of a touching pair).
    PairMemory = "pair_memory", ReadWrite, "array<vec2<u32>>", size_of::<[u32; 2]>(), Pairs;
    /// Per pair whose `pair_memory` word remembers a contact (no composites): the relative
    /// pose of the full test that stored it, two `vec4`s (B's relative quaternion; B's
    /// offset in A's frame and the rotation lever), which its margin is anchored on (the
    /// CPU's `EdgeMemory` anchor, clatter-geom `narrow::slack::Anchor`).
    PairAnchor = "pair_anchor", ReadWrite, "array<vec4<f32>>", size_of::<[f32; 8]>(), Pairs;
    /// The last step's force per pair.
    Forces = "forces", ReadWrite, "array<ContactForce>", size_of::<ContactForce>(), Pairs;
    /// Pairs per body as side b.
    BCount = "b_count", ReadWrite, "array<atomic<u32>>", size_of::<u32>(), BodiesPlusOne;
    /// Body `i` is side b of pairs `b_adj[b_start[i]..b_start[i + 1]]`.
    BStart = "b_start", ReadWrite, "array<u32>", size_of::<u32>(), BodiesPlusOne;
    /// Pair indices by side-b body.
    BAdj = "b_adj", ReadWrite, "array<u32>", size_of::<u32>(), Pairs;
    /// Springs per body and wall (`body * walls + wall`).
    WallHist = "wall_hist", ReadWrite, "array<vec4<f32>>", size_of::<[f32; 4]>(), WallSlots;
    /// The last step's force per body and wall and whether the body touched the wall.
    WallForces = "wall_forces", ReadWrite, "array<WallForce>", size_of::<crate::layout::WallForce>(), WallSlots;
    /// The triangle-mesh boundaries' state (`crate::mesh`): their time and the pose at the
    /// last rebuild, then each body's mesh contact slots (springs, normal, force).
    Mesh = "mesh", ReadWrite, "array<u32>", size_of::<u32>(), MeshWords;
    /// What the blow-up checks compare against.
    HealthParams = "health_params", Uniform, "HealthParams", size_of::<crate::layout::HealthParams>(), One;
    /// The energy log (a ring of `HEALTH_LOG` samples, status word `SAMPLES` counts them),
    /// then the checks' sums per workgroup of bodies (summed by `health_reduce`).
    Health = "health", ReadWrite, "array<HealthRecord>", size_of::<crate::layout::HealthRecord>(), HealthSlots;
    /// The last good state (health.wgsl `snapshot_state`, see `layout::snapshot`): the
    /// status words and the bodies, as words.
    Snapshot = "snapshot", ReadWrite, "array<u32>", size_of::<u32>(), SnapshotWords;
    /// The last good state's copy of `mesh`.
    SnapshotMesh = "snapshot_mesh", ReadWrite, "array<u32>", size_of::<u32>(), SnapshotMeshWords;
    /// The last good state's copy of `wall_hist`.
    SnapshotWallHist = "snapshot_wall_hist", ReadWrite, "array<vec4<f32>>", size_of::<[f32; 4]>(), WallSlots;
    /// The last good state's copy of `wall_forces`.
    SnapshotWallForces = "snapshot_wall_forces", ReadWrite, "array<WallForce>", size_of::<crate::layout::WallForce>(), WallSlots;
    /// The last good state's pair entries, springs and touching words, as words
    /// (`layout::snapshot::PAIR` per pair).
    SnapshotPairs = "snapshot_pairs", ReadWrite, "array<u32>", crate::layout::snapshot::PAIR as usize * size_of::<u32>(), Pairs, keep;
    /// The last good state's copy of `forces`.
    SnapshotForces = "snapshot_forces", ReadWrite, "array<ContactForce>", size_of::<ContactForce>(), Pairs, keep;
}

/// The buffers of the last good state: bound only in the group 0 of `snapshot_state`
/// ([`SNAPSHOT_KERNEL`]), not in the group 0 every other kernel shares. That one has 28
/// storage buffers, and with the shapes' 2 and a group 2's 2 it meets lavapipe's limit of 32
/// storage buffers a shader stage: the last good state's 6 would not fit beside them.
pub const SNAPSHOT_ONLY: &[Buf] = &[
    Buf::Snapshot,
    Buf::SnapshotMesh,
    Buf::SnapshotWallHist,
    Buf::SnapshotWallForces,
    Buf::SnapshotPairs,
    Buf::SnapshotForces,
];

/// The group 0 of `snapshot_state` (health.wgsl): what it copies, the status and the
/// parameters it reads, and the buffers of the last good state, at their bindings in
/// [`BUFFERS`].
pub const SNAPSHOT_KERNEL: &[Buf] = &[
    Buf::Params,
    Buf::Bodies,
    Buf::Status,
    Buf::RebuildPos,
    Buf::Pairs,
    Buf::Hist,
    Buf::Touching,
    Buf::Forces,
    Buf::WallHist,
    Buf::WallForces,
    Buf::Mesh,
    Buf::HealthParams,
    Buf::Snapshot,
    Buf::SnapshotMesh,
    Buf::SnapshotWallHist,
    Buf::SnapshotWallForces,
    Buf::SnapshotPairs,
    Buf::SnapshotForces,
];

/// Which group 0 a bind group layout or bind group is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group0 {
    /// The one every kernel but `snapshot_state` shares: every buffer but [`SNAPSHOT_ONLY`].
    Shared,
    /// `snapshot_state`'s: [`SNAPSHOT_KERNEL`].
    Snapshot,
}

impl Group0 {
    /// Whether binding `k` is in this group 0.
    fn has(self, k: usize) -> bool {
        let b = buf_at(k);
        match self {
            Group0::Shared => !SNAPSHOT_ONLY.contains(&b),
            Group0::Snapshot => SNAPSHOT_KERNEL.contains(&b),
        }
    }
}

/// The `@binding` declarations of group 0 (both group 0s: each kernel uses only those of
/// its own).
pub fn wgsl_bindings() -> String {
    BUFFERS
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let var = match b.access {
                Access::Uniform => "var<uniform>",
                Access::Read => "var<storage, read>",
                Access::ReadWrite => "var<storage, read_write>",
            };
            format!("@group(0) @binding({k}) {var} {}: {};\n", b.name, b.wgsl)
        })
        .collect()
}

/// The bind group layout entries of group 0 `which`.
pub fn layout_entries(which: Group0) -> Vec<wgpu::BindGroupLayoutEntry> {
    BUFFERS
        .iter()
        .enumerate()
        .filter(|&(k, _)| which.has(k))
        .map(|(k, b)| wgpu::BindGroupLayoutEntry {
            binding: k as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: match b.access {
                    Access::Uniform => wgpu::BufferBindingType::Uniform,
                    Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
                    Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        })
        .collect()
}

impl Buf {
    /// This buffer's row of [`BUFFERS`].
    pub fn binding(self) -> &'static Binding {
        &BUFFERS[self as usize]
    }

    /// Bytes of `count` elements of this buffer (no minimum: what a copy or a read-back of
    /// that many elements moves; [`Binding::size`] is the allocation).
    pub fn bytes(self, count: u64) -> u64 {
        count * self.binding().element
    }
}

/// The group-0 buffers of one world.
pub struct Buffers {
    list: Vec<wgpu::Buffer>,
}

impl Index<Buf> for Buffers {
    type Output = wgpu::Buffer;
    fn index(&self, b: Buf) -> &wgpu::Buffer {
        &self.list[b as usize]
    }
}

fn usage(b: &Binding) -> wgpu::BufferUsages {
    match b.access {
        Access::Uniform => wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        _ => {
            wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST
        }
    }
}

impl Buffers {
    /// Allocates every buffer for `dims`; `init(buf)` gives a buffer's initial bytes (zeroed
    /// where it returns `None`; padded to the table's size). Allocates nothing, and returns
    /// the first buffer too large, when one is larger than the device's limits allow.
    pub fn new(
        device: &wgpu::Device,
        dims: &Dims,
        mut init: impl FnMut(Buf) -> Option<Vec<u8>>,
    ) -> Result<Buffers, Oversize> {
        check_sizes(&device.limits(), dims)?;
        let list = BUFFERS
            .iter()
            .enumerate()
            .map(|(k, b)| {
                let size = b.size(dims);
                match init(buf_at(k)) {
                    Some(mut bytes) => {
                        if (bytes.len() as u64) < size {
                            bytes.resize(size as usize, 0);
                        }
                        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some(b.name),
                            contents: &bytes,
                            usage: usage(b),
                        })
                    }
                    None => device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(b.name),
                        size,
                        usage: usage(b),
                        mapped_at_creation: false,
                    }),
                }
            })
            .collect();
        Ok(Buffers { list })
    }

    /// Reallocates the pair-sized buffers for `dims` (a larger pair capacity), copying the
    /// contents of those marked `keep_on_grow` in `encoder`. Changes nothing, and returns the
    /// first buffer too large, when one is larger than the device's limits allow.
    pub fn grow(
        &mut self,
        device: &wgpu::Device,
        dims: &Dims,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<(), Oversize> {
        check_sizes(&device.limits(), dims)?;
        for (k, b) in BUFFERS.iter().enumerate() {
            if b.count != Count::Pairs {
                continue;
            }
            let new = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(b.name),
                size: b.size(dims),
                usage: usage(b),
                mapped_at_creation: false,
            });
            if b.keep_on_grow {
                let old = &self.list[k];
                encoder.copy_buffer_to_buffer(old, 0, &new, 0, old.size());
            }
            self.list[k] = new;
        }
        Ok(())
    }

    /// The bind group of group 0 `which` (`layout` made from its [`layout_entries`]).
    pub fn bind_group(
        &self,
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        which: Group0,
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = self
            .list
            .iter()
            .enumerate()
            .filter(|&(k, _)| which.has(k))
            .map(|(k, b)| wgpu::BindGroupEntry {
                binding: k as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("simulation"),
            layout,
            entries: &entries,
        })
    }

    /// A buffer by its WGSL name (for tests and debugging).
    pub fn by_name(&self, name: &str) -> Option<&wgpu::Buffer> {
        BUFFERS
            .iter()
            .position(|b| b.name == name)
            .map(|k| &self.list[k])
    }
}

/// The [`Buf`] of binding `k`.
fn buf_at(k: usize) -> Buf {
    ALL[k]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// GPU memory per body of a sphere pile in a box (5 walls, one material, the pair
    /// capacity of `PAIRS_PER_BODY` pairs per body): every group-0 buffer, over 1e5 bodies.
    /// Precise positions (the low part of each position in the body record and in the last
    /// good state) cost 32 bytes of it (BENCHMARKS.md).
    #[test]
    fn memory_per_body() {
        let n = 100_000u64;
        let d = Dims {
            bodies: n,
            cells: 8 * n + 64,
            pairs: 8 * n,
            materials: 1,
            walls: 5,
            sinks: 0,
            pieces: 1,
            composites: false,
            boundaries: 0,
        };
        let total: u64 = BUFFERS.iter().map(|b| b.size(&d)).sum();
        let per_body = total as f64 / n as f64;
        eprintln!("GPU memory: {per_body:.1} bytes per body ({total} bytes for {n} bodies)");
        assert_eq!(size_of::<BodyState>(), 112);
        assert!(per_body < 4000.0, "{per_body}");
    }

    #[test]
    fn the_table_and_the_names_agree() {
        assert_eq!(ALL.len(), BUFFERS.len());
        for (k, b) in ALL.iter().enumerate() {
            assert_eq!(*b as usize, k);
        }
        let wgsl = wgsl_bindings();
        assert!(
            wgsl.contains(
                "@group(0) @binding(15) var<storage, read_write> pairs: array<vec2<u32>>;"
            )
        );
        assert!(wgsl.contains("@group(0) @binding(0) var<uniform> params: Params;"));
    }
}
