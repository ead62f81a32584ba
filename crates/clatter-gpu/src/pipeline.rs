//! Compiled kernels and the dispatch list of a step. The stages (`crate::stages`) say which
//! kernels run in which order as a list of [`Dispatch`]es; this module compiles the kernels
//! once per device and records a list into a compute pass.

use crate::layout::wgsl_prelude;
use crate::shapes::GpuShapes;
use crate::{GpuContext, GpuError};

pub(crate) const COMMON: &str = include_str!("../shaders/common/common.wgsl");
pub(crate) const STATUS: &str = include_str!("../shaders/common/status.wgsl");
pub(crate) const MESH_TIME: &str = include_str!("../shaders/common/mesh_time.wgsl");
pub(crate) const TURN: &str = include_str!("../shaders/common/turn.wgsl");
pub(crate) const MESH: &str = include_str!("../shaders/contacts/mesh.wgsl");
pub(crate) const MESH_POLY: &str = include_str!("../shaders/contacts/mesh_poly.wgsl");
pub(crate) const MESH_SPHERES: &str = include_str!("../shaders/contacts/mesh_spheres.wgsl");
pub(crate) const MESH_NONE: &str = include_str!("../shaders/contacts/mesh_none.wgsl");
pub(crate) const ARGS: &str = include_str!("../shaders/common/args.wgsl");
/// The narrow phase: narrow.wgsl (shapes, spheres, walls, the entry points) and
/// narrow_poly.wgsl (polyhedron pairs), one text.
pub(crate) const NARROW: &str = concat!(
    include_str!("../shaders/contacts/narrow.wgsl"),
    include_str!("../shaders/contacts/narrow_poly.wgsl")
);
pub(crate) const NARROW_SPHERES: &str = include_str!("../shaders/contacts/narrow_spheres.wgsl");
pub(crate) const BIN: &str = include_str!("../shaders/broad/bin.wgsl");
pub(crate) const SCAN: &str = include_str!("../shaders/broad/scan.wgsl");
pub(crate) const SORT: &str = include_str!("../shaders/broad/sort.wgsl");
pub(crate) const PAIRS: &str = include_str!("../shaders/broad/pairs.wgsl");
pub(crate) const LAW: &str = include_str!("../shaders/contacts/law.wgsl");
pub(crate) const CONTACTS: &str = include_str!("../shaders/contacts/contacts.wgsl");
pub(crate) const CONTACTS_SPLIT: &str = include_str!("../shaders/contacts/contacts_split.wgsl");
pub(crate) const CONTACTS_LANES: &str = include_str!("../shaders/contacts/contacts_lanes.wgsl");
pub(crate) const INTEGRATE: &str = include_str!("../shaders/integrate/integrate.wgsl");
pub(crate) const HEALTH: &str = include_str!("../shaders/health/health.wgsl");
pub(crate) const PIECES: &str = include_str!("../shaders/contacts/pieces.wgsl");
/// `const COMPOSITES` for a module that includes pieces.wgsl: whether its kernels handle
/// composite bodies (the contact kernels are compiled both ways; see pieces.wgsl). With it
/// `const MESH_ACC`, the room mesh.wgsl keeps for a body's mesh contacts before the deepest
/// `MESH_SLOTS` are chosen: one piece's `MESH_MAX_FOUND`, plus the `MESH_SLOTS` kept of the
/// earlier pieces of a composite.
pub(crate) fn composites_const(composites: bool) -> &'static str {
    if composites {
        "const COMPOSITES: bool = true;\nconst MESH_ACC: u32 = MESH_SLOTS + MESH_MAX_FOUND;\n"
    } else {
        "const COMPOSITES: bool = false;\nconst MESH_ACC: u32 = MESH_MAX_FOUND;\n"
    }
}

/// Bind group 1 (src/shapes.rs) for modules without a narrow phase (which declares it).
pub(crate) const SHAPES_DECL: &str = "@group(1) @binding(0) var<storage, read> shape_f: array<vec4<f32>>;\n@group(1) @binding(1) var<storage, read> shape_u: array<u32>;\n";

/// Every simulation shader file, for the test that no file retypes a generated declaration.
#[cfg(test)]
pub(crate) const SHADER_FILES: &[(&str, &str)] = &[
    ("common.wgsl", COMMON),
    ("status.wgsl", STATUS),
    ("args.wgsl", ARGS),
    ("mesh_time.wgsl", MESH_TIME),
    ("turn.wgsl", TURN),
    ("mesh.wgsl", MESH),
    ("mesh_poly.wgsl", MESH_POLY),
    ("mesh_spheres.wgsl", MESH_SPHERES),
    ("mesh_none.wgsl", MESH_NONE),
    ("narrow.wgsl", NARROW),
    ("narrow_spheres.wgsl", NARROW_SPHERES),
    ("bin.wgsl", BIN),
    ("scan.wgsl", SCAN),
    ("sort.wgsl", SORT),
    ("pairs.wgsl", PAIRS),
    ("law.wgsl", LAW),
    ("contacts.wgsl", CONTACTS),
    ("contacts_split.wgsl", CONTACTS_SPLIT),
    ("contacts_lanes.wgsl", CONTACTS_LANES),
    ("integrate.wgsl", INTEGRATE),
    ("health.wgsl", HEALTH),
    ("pieces.wgsl", PIECES),
];

/// A kernel's source: the generated prelude, the shared helpers, then `parts`.
pub(crate) fn source(parts: &[&str]) -> String {
    let mut s = wgsl_prelude();
    s.push_str(COMMON);
    s.push_str(STATUS);
    s.push_str(MESH_TIME);
    s.push_str(TURN);
    for p in parts {
        s.push_str(p);
    }
    s
}

/// The bind group a kernel uses besides group 0 (simulation) and 1 (shapes).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Group2 {
    None,
    /// The indirect arguments (kernels that size later dispatches).
    Args,
    /// A scan level (data, sums).
    Scan,
    /// No group 2, and a group 0 of its own (`buffers::Group0::Snapshot`) instead of the
    /// shared one, and no group 1: `snapshot_state`, which binds the last good state's
    /// buffers.
    Snapshot,
}

/// How a kernel is dispatched.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Size {
    /// One workgroup of one thread.
    Single,
    /// Indirect, from an argument slot.
    Indirect(u32),
}

/// Which compiled set a kernel is in.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum KernelSet {
    /// The kernels every world uses (broad phase, bookkeeping).
    Base,
    /// This world's contact and integrate kernels (sphere-only or general).
    Contacts,
}

/// One dispatch of a step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dispatch {
    pub set: KernelSet,
    /// Index of the pipeline in its set.
    pub pipeline: usize,
    pub size: Size,
    /// The scan level's bind group (index into the world's scan groups), for `Group2::Scan`.
    pub scan_level: usize,
}

/// A kernel to compile: module name, entry point, its group 2.
pub(crate) type KernelSpec = (&'static str, &'static str, Group2);

/// Compiled pipelines, by entry-point name.
pub(crate) struct Kernels {
    pub pipelines: Vec<wgpu::ComputePipeline>,
    pub group2: Vec<Group2>,
    pub names: Vec<&'static str>,
}

impl Kernels {
    pub fn index(&self, name: &str) -> usize {
        self.names
            .iter()
            .position(|n| *n == name)
            .unwrap_or_else(|| panic!("kernel {name} is not built"))
    }
}

/// The layouts and the base kernels, shared by every world on a device; the contact kernels
/// are compiled on first use, in six variants (sphere-only scenes skip the large polyhedron
/// narrow phase, scenes without mesh boundaries the mesh contacts, scenes without composites
/// the piece code): see [`ContactVariant`].
pub(crate) struct Compiled {
    /// Group 0 (shared), group 1 (shapes), group 2 (scan or args), and the group 0 of
    /// `snapshot_state` ([`Group2::Snapshot`]).
    pub layouts: [wgpu::BindGroupLayout; 4],
    pub base: Kernels,
    /// By [`ContactVariant::index`].
    pub contact_sets: [std::sync::OnceLock<Result<Kernels, GpuError>>; 6 * CLIP_SIZES * 3],
}

/// Which contact kernel set a world uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ContactVariant {
    /// Every body is a sphere.
    pub spheres_only: bool,
    /// The scene has triangle-mesh boundaries.
    pub meshes: bool,
    /// Some body is a composite (never a sphere-only scene: a composite is not a sphere).
    pub composites: bool,
    /// Points each clipping buffer holds (`NRW_MAX_CLIP`): [`ContactVariant::clip_points`].
    pub clip: u32,
    /// Lanes per polyhedron pair in the full narrow phase: 0 (one thread per pair,
    /// `contacts_full_poly`), or one of [`POLY_LANES`] (`contacts_full_poly_lanes`,
    /// contacts_lanes.wgsl); always 0 in sphere-only scenes.
    pub lanes: u32,
}

/// The lane counts `contacts_full_poly_lanes` is compiled for (a divisor of `DEAL_CHUNK`,
/// status.wgsl, so that a pair's lanes are neighbours in one workgroup).
pub const POLY_LANES: [u32; 2] = [8, 16];

/// `CLATTER_GPU_POLY_LANES` (0, 8 or 16): how many lanes serve each polyhedron pair in the
/// full narrow phase ([`ContactVariant::lanes`]). Read when a world is built; results are
/// bitwise the same for every value, only speed differs. Unset: 8 on a
/// hardware GPU (the kernel 7.7% faster, the step 5.5%, on 40,000 poured mixed polyhedra on
/// an H200; BENCHMARKS.md), 0 on a CPU rasteriser (`software`: lavapipe, where 8 lanes took
/// 1.6x the time). Any other value takes that default, with a warning on stderr.
pub fn poly_lanes_from_env(software: bool) -> u32 {
    crate::env::u32_choice(
        "CLATTER_GPU_POLY_LANES",
        "0, 8 or 16",
        |l| l == 0 || POLY_LANES.contains(&l),
        if software { 0 } else { 8 },
    )
}

/// The clipping buffer sizes compiled: 16, 32 and 64 points.
const CLIP_SIZES: usize = 3;

impl ContactVariant {
    /// Its slot in [`Compiled::contact_sets`].
    pub fn index(self) -> usize {
        let base = if self.composites {
            4 + self.meshes as usize
        } else {
            self.spheres_only as usize + 2 * self.meshes as usize
        };
        let size = (self.clip.max(16) / 16).trailing_zeros() as usize;
        let lanes = POLY_LANES
            .iter()
            .position(|&l| l == self.lanes)
            .map_or(0, |k| k + 1);
        (lanes * 6 + base) * CLIP_SIZES + size.min(CLIP_SIZES - 1)
    }

    /// Points per clipping buffer for a scene whose longest polyhedron face has
    /// `longest_face` vertices: twice that (a convex face clipped by another's k edges gains
    /// at most k points) plus 4 to spare for rounding on nearly degenerate polygons,
    /// rounded up to a power of two from 16 to
    /// [`MAX_CLIP_POINTS`](crate::shapes::MAX_CLIP_POINTS), which scenes with meshes keep
    /// (their fallback manifold collects a body's vertices). Every buffer is zero-filled on
    /// every call (WGSL's rule for local variables), which lavapipe pays in full: most
    /// scenes' faces have 3 to 6 vertices, a quarter of the largest size.
    pub fn clip_points(longest_face: usize, meshes: bool) -> u32 {
        let max = crate::shapes::MAX_CLIP_POINTS as u32;
        if meshes {
            return max;
        }
        (2 * longest_face as u32 + 4)
            .next_power_of_two()
            .clamp(16, max)
    }
}

/// The narrow phase's text with clipping buffers of `clip` points (narrow.wgsl declares
/// [`MAX_CLIP_POINTS`](crate::shapes::MAX_CLIP_POINTS); the test `wgsl_constants_match` in
/// shapes.rs checks both declarations replaced here).
pub(crate) fn narrow_source(clip: u32) -> String {
    let max = crate::shapes::MAX_CLIP_POINTS;
    NARROW
        .replace(
            &format!("const NRW_MAX_CLIP: u32 = {max}u;"),
            &format!("const NRW_MAX_CLIP: u32 = {clip}u;"),
        )
        .replace(
            &format!("array<vec4<f32>, {max}>"),
            &format!("array<vec4<f32>, {clip}>"),
        )
}

impl Compiled {
    /// The device's compiled pipelines, built on first use.
    pub fn get(ctx: &GpuContext) -> Result<std::sync::Arc<Compiled>, GpuError> {
        let mut slot = ctx.pipelines.lock().map_err(|_| GpuError::Runtime {
            adapter: ctx.adapter_name(),
            message: "pipeline cache poisoned".into(),
        })?;
        if let Some(c) = slot
            .as_ref()
            .and_then(|a| a.clone().downcast::<Compiled>().ok())
        {
            return Ok(c);
        }
        let device = &ctx.device;
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layouts = [
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("simulation"),
                entries: &crate::buffers::layout_entries(crate::buffers::Group0::Shared),
            }),
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("shapes"),
                entries: &GpuShapes::layout_entries(wgpu::ShaderStages::COMPUTE),
            }),
            // Group 2 of the scans (data, sums) and of the argument writers (args, template).
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("scan or args"),
                entries: &[storage(0), storage(1)],
            }),
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("snapshot"),
                entries: &crate::buffers::layout_entries(crate::buffers::Group0::Snapshot),
            }),
        ];
        let (modules, kernels) = crate::stages::base_kernels();
        let base = compile(ctx, &layouts, &modules, &kernels)?;
        let c = std::sync::Arc::new(Compiled {
            layouts,
            base,
            contact_sets: std::array::from_fn(|_| std::sync::OnceLock::new()),
        });
        *slot = Some(c.clone());
        Ok(c)
    }

    /// The contact kernels of `variant`, compiled on first use.
    pub fn contacts(
        &self,
        ctx: &GpuContext,
        variant: ContactVariant,
    ) -> Result<&Kernels, GpuError> {
        self.contact_cell(variant)
            .get_or_init(|| {
                let (modules, kernels) = crate::stages::contact_kernels(variant);
                compile(ctx, &self.layouts, &modules, &kernels)
            })
            .as_ref()
            .map_err(|e| e.clone())
    }

    /// Where the contact kernels of `variant` are kept.
    pub fn contact_cell(
        &self,
        variant: ContactVariant,
    ) -> &std::sync::OnceLock<Result<Kernels, GpuError>> {
        &self.contact_sets[variant.index()]
    }
}

/// Compiles `kernels` from `modules` (name, source).
pub(crate) fn compile(
    ctx: &GpuContext,
    layouts: &[wgpu::BindGroupLayout; 4],
    modules: &[(&str, String)],
    kernels: &[KernelSpec],
) -> Result<Kernels, GpuError> {
    let device = &ctx.device;
    let base = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("base"),
        bind_group_layouts: &[Some(&layouts[0]), Some(&layouts[1])],
        immediate_size: 0,
    });
    let with_g2 = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("with group 2"),
        bind_group_layouts: &[Some(&layouts[0]), Some(&layouts[1]), Some(&layouts[2])],
        immediate_size: 0,
    });
    let snapshot = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("snapshot"),
        bind_group_layouts: &[Some(&layouts[3])],
        immediate_size: 0,
    });
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let compiled: Vec<(&str, wgpu::ShaderModule)> = modules
        .iter()
        .map(|(name, src)| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(src.as_str().into()),
            });
            (*name, module)
        })
        .collect();
    let mut out = Kernels {
        pipelines: Vec::new(),
        group2: Vec::new(),
        names: Vec::new(),
    };
    for &(module, entry_point, group2) in kernels {
        let m = &compiled
            .iter()
            .find(|(n, _)| *n == module)
            .expect("module listed")
            .1;
        let layout = match group2 {
            Group2::None => &base,
            Group2::Args | Group2::Scan => &with_g2,
            Group2::Snapshot => &snapshot,
        };
        out.pipelines.push(
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: Some(layout),
                module: m,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            }),
        );
        out.group2.push(group2);
        out.names.push(entry_point);
    }
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Runtime {
            adapter: ctx.adapter_name(),
            message: format!("shader compilation failed: {e}"),
        });
    }
    Ok(out)
}
