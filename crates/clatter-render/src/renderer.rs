//! The renderer: one instanced, depth-tested, lit draw per shape, then the walls.
//!
//! Body poses come from a storage buffer of [`BodyState`] records, the GPU simulation's own
//! layout: either the renderer's copy of a CPU [`World`] (uploaded by [`Renderer::update`])
//! or the simulation's buffer itself ([`Poses::Gpu`]), so a GPU run is drawn without reading
//! its state back. The vertex shader reads each instance's position, orientation and velocity
//! from that buffer; the per-body style (material colour, in-contact flag) comes from the CPU.

use std::str::FromStr;

use bytemuck::{Pod, Zeroable};
use clatter::World;
use clatter_gpu::BodyState;
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use crate::camera::{Bounds, Camera, up_of};
use crate::mesh::{Mesh, Vertex, WallVertex, boundary_triangles, wall_quads};

/// The background (linear RGB): a dark slate blue.
pub const BACKGROUND: [f64; 3] = [0.012, 0.016, 0.026];

/// The shader: the simulation's `BodyState` record and quaternion helpers, then ours.
fn shader() -> String {
    use clatter::contract::GpuRecord;
    [
        BodyState::wgsl().as_str(),
        include_str!("../../clatter-gpu/shaders/common/common.wgsl"),
        include_str!("../shaders/scene.wgsl"),
    ]
    .join("\n")
}

/// Depth buffer format.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Errors of the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The GPU context could not be created or reported an error.
    #[error(transparent)]
    Gpu(#[from] clatter_gpu::GpuError),
    /// The requested image size is zero or beyond the adapter's texture limit.
    #[error("image size {width}x{height} is not possible: each side must be 1..={max} pixels")]
    BadSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// The adapter's largest texture side.
        max: u32,
    },
    /// The body buffer given to [`Poses::Gpu`] is too small for the world's bodies.
    #[error("the body buffer holds {bytes} bytes but {bodies} bodies need {need}")]
    BufferTooSmall {
        /// The buffer's size, bytes.
        bytes: u64,
        /// The world's bodies.
        bodies: usize,
        /// Bytes the bodies need.
        need: u64,
    },
    /// Reading the image back failed.
    #[error("reading the rendered image back failed: {0}")]
    Readback(String),
    /// Writing the PNG failed.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// How bodies are coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColorMode {
    /// One colour per material (shaded a little per body so neighbours stand apart).
    #[default]
    Material,
    /// By speed: blue (at rest) through green and yellow to red (the fastest).
    Speed,
    /// Orange when the body touches something (a body or a wall) in the last step, grey if not.
    Contact,
}

impl ColorMode {
    /// Every mode, in the order the viewer lists them.
    pub const ALL: [ColorMode; 3] = [ColorMode::Material, ColorMode::Speed, ColorMode::Contact];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ColorMode::Material => "material",
            ColorMode::Speed => "speed",
            ColorMode::Contact => "contact",
        }
    }

    fn code(self) -> u32 {
        match self {
            ColorMode::Material => 0,
            ColorMode::Speed => 1,
            ColorMode::Contact => 2,
        }
    }
}

impl FromStr for ColorMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ColorMode::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("unknown colour mode '{s}': use material, speed or contact"))
    }
}

/// What to show and how.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Style {
    /// How bodies are coloured.
    pub color: ColorMode,
    /// Draw only the bodies that touch something now (the force network of a pile).
    pub only_contacts: bool,
    /// The speed at the red end of the speed ramp, m/s; `None`: the fastest body's speed at
    /// the last [`Renderer::update`] (1 m/s on the GPU path without an update).
    pub speed_max: Option<f32>,
}

/// Material colours (linear RGB), by material index modulo their count.
pub const PALETTE: [[f32; 3]; 8] = [
    [0.90, 0.42, 0.10],
    [0.12, 0.38, 0.85],
    [0.18, 0.65, 0.25],
    [0.80, 0.12, 0.30],
    [0.55, 0.25, 0.80],
    [0.85, 0.75, 0.10],
    [0.10, 0.65, 0.65],
    [0.55, 0.55, 0.55],
];

/// Where the body poses come from for a draw.
#[derive(Debug, Clone, Copy)]
pub enum Poses<'a> {
    /// The renderer's own buffer, filled by [`Renderer::update`] from a CPU world.
    Uploaded,
    /// A buffer of [`BodyState`] records in body order (the GPU simulation's), created with
    /// `BufferUsages::STORAGE` on the renderer's device.
    Gpu(&'a wgpu::Buffer),
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct FrameUniform {
    view_proj: [[f32; 4]; 4],
    light_dir: [f32; 4],
    mode: u32,
    only_contacts: u32,
    speed_max: f32,
    _pad: f32,
}

/// One shape's draw: its index range in the mesh buffers and its instance range.
#[derive(Debug, Clone)]
struct Draw {
    indices: std::ops::Range<u32>,
    base_vertex: i32,
    instances: std::ops::Range<u32>,
}

/// The static geometry of one world: meshes, instance order, walls.
struct Geometry {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    draws: Vec<Draw>,
    instance_body: wgpu::Buffer,
    walls: Option<(wgpu::Buffer, wgpu::Buffer, u32)>,
    /// Boundary mesh triangles (wall vertices, three per triangle) and their vertex count;
    /// rewritten by [`Renderer::update`] when a boundary moves.
    boundaries: Option<(wgpu::Buffer, u32)>,
    bodies: usize,
}

/// The body renderer; see the module documentation.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    format: wgpu::TextureFormat,
    samples: u32,
    layout: wgpu::BindGroupLayout,
    body_pipeline: wgpu::RenderPipeline,
    wall_pipeline: wgpu::RenderPipeline,
    uniform: wgpu::Buffer,
    geometry: Option<Geometry>,
    poses: wgpu::Buffer,
    styles: wgpu::Buffer,
    uploaded_group: Option<wgpu::BindGroup>,
    auto_speed_max: f32,
    bounds: Bounds,
    up: Vec3,
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A cheap per-body brightness jitter in 0.82..1.0, so that touching bodies of one material
/// stand apart.
fn jitter(i: usize) -> f32 {
    let h = (i as u32).wrapping_mul(2654435761) >> 24;
    0.82 + 0.18 * h as f32 / 255.0
}

/// The pipeline of the translucent walls: tested against the bodies' depth, never hiding
/// them.
fn wall_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    pipeline_layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    multisample: wgpu::MultisampleState,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("clatter-render walls"),
        layout: Some(pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_wall"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<WallVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![
                    0 => Float32x3, 1 => Float32x2, 2 => Float32, 3 => Float32
                ],
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        // Translucent: tested against the bodies' depth, never hiding them.
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample,
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_wall"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Renderer {
    /// A renderer drawing into `format` targets with `samples` samples per pixel (1 or 4).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> Renderer {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("clatter-render scene"),
            source: wgpu::ShaderSource::Wgsl(shader().into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("clatter-render bodies"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage_entry(1),
                storage_entry(2),
                storage_entry(3),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("clatter-render"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let multisample = wgpu::MultisampleState {
            count: samples,
            mask: !0,
            alpha_to_coverage_enabled: false,
        };
        let body_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("clatter-render bodies"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_body"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<Vertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: Some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample,
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_body"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let wall_pipeline = wall_pipeline(device, &module, &pipeline_layout, format, multisample);
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("clatter-render frame"),
            size: std::mem::size_of::<FrameUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let empty = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: std::mem::size_of::<BodyState>() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Renderer {
            device: device.clone(),
            queue: queue.clone(),
            format,
            samples,
            layout,
            body_pipeline,
            wall_pipeline,
            uniform,
            geometry: None,
            poses: empty("clatter-render poses"),
            styles: empty("clatter-render styles"),
            uploaded_group: None,
            auto_speed_max: 1.0,
            bounds: Bounds {
                min: Vec3::splat(-0.5),
                max: Vec3::splat(0.5),
            },
            up: Vec3::Z,
        }
    }

    /// The colour format this renderer draws into.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Samples per pixel of the targets this renderer draws into.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// What the world showed at the last [`Renderer::set_world`]: for framing the camera.
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// The scene's up direction (against gravity).
    pub fn up(&self) -> Vec3 {
        self.up
    }

    /// Builds the static geometry of `world` (shape meshes, the instance order, the wall
    /// quads around the current bodies) and uploads its state. Call again when the bodies or
    /// shapes change (a reset), not every frame.
    pub fn set_world(&mut self, world: &World) {
        let n = world.len();
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut order: Vec<u32> = Vec::with_capacity(n);
        let mut draws = Vec::new();
        for (s, shape) in world.shapes.iter().enumerate() {
            let first = order.len() as u32;
            order.extend((0..n as u32).filter(|&i| world.consts.shape[i as usize] == s as u32));
            if order.len() as u32 == first {
                continue;
            }
            let mesh = Mesh::of_shape(&shape.shape);
            let base_vertex = vertices.len() as i32;
            let first_index = indices.len() as u32;
            vertices.extend_from_slice(&mesh.vertices);
            indices.extend_from_slice(&mesh.indices);
            draws.push(Draw {
                indices: first_index..indices.len() as u32,
                base_vertex,
                instances: first..order.len() as u32,
            });
        }
        let buffer = |label, contents: &[u8], usage| {
            self.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
        };
        // Buffers may not be empty: pad with a zero.
        if vertices.is_empty() {
            vertices.push(Vertex::zeroed());
            indices.push(0);
        }
        if order.is_empty() {
            order.push(0);
        }
        self.bounds = Bounds::of_world(world);
        self.up = up_of(world);
        let (wv, wi) = wall_quads(&world.walls, &self.bounds, self.up);
        let walls = (!wi.is_empty()).then(|| {
            (
                buffer(
                    "clatter-render wall vertices",
                    bytemuck::cast_slice(&wv),
                    wgpu::BufferUsages::VERTEX,
                ),
                buffer(
                    "clatter-render wall indices",
                    bytemuck::cast_slice(&wi),
                    wgpu::BufferUsages::INDEX,
                ),
                wi.len() as u32,
            )
        });
        let bv = boundary_triangles(world, boundary_light(self.up));
        let boundaries = (!bv.is_empty()).then(|| {
            (
                buffer(
                    "clatter-render boundary triangles",
                    bytemuck::cast_slice(&bv),
                    wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                ),
                bv.len() as u32,
            )
        });
        self.geometry = Some(Geometry {
            vertices: buffer(
                "clatter-render vertices",
                bytemuck::cast_slice(&vertices),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: buffer(
                "clatter-render indices",
                bytemuck::cast_slice(&indices),
                wgpu::BufferUsages::INDEX,
            ),
            draws,
            instance_body: buffer(
                "clatter-render instance order",
                bytemuck::cast_slice(&order),
                wgpu::BufferUsages::STORAGE,
            ),
            walls,
            boundaries,
            bodies: n,
        });
        let records = (n.max(1) * std::mem::size_of::<BodyState>()) as u64;
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        if self.poses.size() < records {
            self.poses = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("clatter-render poses"),
                size: records,
                usage,
                mapped_at_creation: false,
            });
        }
        let styles = (n.max(1) * 16) as u64;
        if self.styles.size() < styles {
            self.styles = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("clatter-render styles"),
                size: styles,
                usage,
                mapped_at_creation: false,
            });
        }
        self.uploaded_group = None;
        self.update(world, None);
    }

    /// Uploads the bodies' poses and velocities (for [`Poses::Uploaded`]) and their styles.
    /// `contacts` is per body the number of touching contacts (`World::contact_counts`);
    /// `None` counts it here.
    pub fn update(&mut self, world: &World, contacts: Option<&[u32]>) {
        let n = world
            .len()
            .min(self.geometry.as_ref().map_or(0, |g| g.bodies));
        let mut records = Vec::with_capacity(n);
        let mut vmax = 0.0f32;
        for i in 0..n {
            let (x, v, q) = (
                world.state.position_f32(i),
                world.state.velocity[i],
                world.state.orientation[i],
            );
            let speed = v.length();
            if speed.is_finite() {
                vmax = vmax.max(speed);
            }
            records.push(BodyState {
                // w = 1: removed by a sink, not drawn (as in the simulation's own buffer).
                position: [x.x, x.y, x.z, if world.is_removed(i) { 1.0 } else { 0.0 }],
                velocity: [v.x, v.y, v.z, 0.0],
                orientation: q.to_array(),
                ..Default::default()
            });
        }
        self.auto_speed_max = if vmax > 0.0 { vmax } else { 1.0 };
        if world.boundaries.iter().any(|b| b.moves())
            && let Some((buffer, count)) =
                self.geometry.as_ref().and_then(|g| g.boundaries.as_ref())
        {
            let bv = boundary_triangles(world, boundary_light(self.up));
            if bv.len() as u32 == *count {
                self.queue
                    .write_buffer(buffer, 0, bytemuck::cast_slice(&bv));
            }
        }
        if !records.is_empty() {
            self.queue
                .write_buffer(&self.poses, 0, bytemuck::cast_slice(&records));
        }
        self.update_styles(world, contacts);
    }

    /// Uploads only the per-body styles (material colour, in-contact flag): what the GPU
    /// path ([`Poses::Gpu`]) needs from the CPU.
    pub fn update_styles(&mut self, world: &World, contacts: Option<&[u32]>) {
        let n = world
            .len()
            .min(self.geometry.as_ref().map_or(0, |g| g.bodies));
        let owned;
        let counts = match contacts {
            Some(c) => c,
            None => {
                owned = world.contact_counts();
                &owned
            }
        };
        let styles: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let c = PALETTE[world.consts.material[i] as usize % PALETTE.len()];
                let j = jitter(i);
                let touching = counts.get(i).is_some_and(|&k| k > 0);
                [
                    c[0] * j,
                    c[1] * j,
                    c[2] * j,
                    if touching { 1.0 } else { 0.0 },
                ]
            })
            .collect();
        if !styles.is_empty() {
            self.queue
                .write_buffer(&self.styles, 0, bytemuck::cast_slice(&styles));
        }
    }

    fn bind_group(&self, poses: &wgpu::Buffer, geometry: &Geometry) -> wgpu::BindGroup {
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("clatter-render bodies"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: poses.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.styles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: geometry.instance_body.as_entire_binding(),
                },
            ],
        })
    }

    /// Writes the frame's camera and style; call before [`Renderer::paint`] in each frame.
    pub fn prepare(&mut self, camera: &Camera, aspect: f32, style: &Style) {
        let view_proj: Mat4 = camera.view_proj(aspect);
        let l = camera.light_dir();
        let u = FrameUniform {
            view_proj: view_proj.to_cols_array_2d(),
            light_dir: [l.x, l.y, l.z, 0.0],
            mode: style.color.code(),
            only_contacts: style.only_contacts as u32,
            speed_max: style.speed_max.unwrap_or(self.auto_speed_max),
            _pad: 0.0,
        };
        self.queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&u));
        if self.uploaded_group.is_none()
            && let Some(g) = &self.geometry
        {
            self.uploaded_group = Some(self.bind_group(&self.poses, g));
        }
    }

    /// Records the bodies and walls into `pass` (whose targets have this renderer's format,
    /// sample count and a [`DEPTH_FORMAT`] depth attachment).
    pub fn paint(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        poses: Poses<'_>,
    ) -> Result<(), RenderError> {
        let Some(g) = &self.geometry else {
            return Ok(());
        };
        let owned;
        let group = match poses {
            Poses::Uploaded => match &self.uploaded_group {
                Some(b) => b,
                None => {
                    owned = self.bind_group(&self.poses, g);
                    &owned
                }
            },
            Poses::Gpu(buffer) => {
                let need = (g.bodies * std::mem::size_of::<BodyState>()) as u64;
                if buffer.size() < need {
                    return Err(RenderError::BufferTooSmall {
                        bytes: buffer.size(),
                        bodies: g.bodies,
                        need,
                    });
                }
                owned = self.bind_group(buffer, g);
                &owned
            }
        };
        pass.set_bind_group(0, group, &[]);
        if !g.draws.is_empty() {
            pass.set_pipeline(&self.body_pipeline);
            pass.set_vertex_buffer(0, g.vertices.slice(..));
            pass.set_index_buffer(g.indices.slice(..), wgpu::IndexFormat::Uint32);
            for d in &g.draws {
                pass.draw_indexed(d.indices.clone(), d.base_vertex, d.instances.clone());
            }
        }
        if let Some((v, i, count)) = &g.walls {
            pass.set_pipeline(&self.wall_pipeline);
            pass.set_vertex_buffer(0, v.slice(..));
            pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..*count, 0, 0..1);
        }
        if let Some((v, count)) = &g.boundaries {
            pass.set_pipeline(&self.wall_pipeline);
            pass.set_vertex_buffer(0, v.slice(..));
            pass.draw(0..*count, 0..1);
        }
        Ok(())
    }
}

/// The fixed light the boundary meshes' flat shading is computed for: mostly from above.
fn boundary_light(up: Vec3) -> Vec3 {
    let side = if up.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    (up * 0.85 + side * 0.4).normalize_or(up)
}

/// The clear colour of frames.
pub fn background() -> wgpu::Color {
    wgpu::Color {
        r: BACKGROUND[0],
        g: BACKGROUND[1],
        b: BACKGROUND[2],
        a: 1.0,
    }
}
