//! Offscreen frames: render into a texture, read it back as an RGBA image, save PNGs. No
//! window system needed (works on lavapipe/llvmpipe in CI).

use std::path::Path;

use clatter::World;
use clatter_gpu::GpuContext;
use image::RgbaImage;

use crate::camera::{Camera, CameraSpec};
use crate::renderer::{DEPTH_FORMAT, Poses, RenderError, Renderer, Style, background};

/// Colour format of offscreen frames (sRGB, so PNGs look like the window).
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// Samples per pixel offscreen (4x multisampling: smooth edges; every WebGPU adapter has it).
pub const OFFSCREEN_SAMPLES: u32 = 4;

/// Colour (multisampled and resolved) and depth targets of one size, plus the read-back
/// buffer. Used by [`Offscreen`] and by the viewer's window.
pub struct Targets {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    msaa: Option<wgpu::TextureView>,
    resolved: wgpu::Texture,
    resolved_view: wgpu::TextureView,
    depth: wgpu::TextureView,
}

impl Targets {
    /// Targets of `width` x `height` for `renderer` (its format and sample count); the
    /// resolved colour texture can be copied from (read-back).
    pub fn new(
        device: &wgpu::Device,
        renderer: &Renderer,
        width: u32,
        height: u32,
    ) -> Result<Targets, RenderError> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadSize { width, height, max });
        }
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let samples = renderer.samples();
        let texture = |label, format, sample_count, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let resolved = texture(
            "clatter-render colour",
            renderer.format(),
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let msaa = (samples > 1).then(|| {
            texture(
                "clatter-render colour (multisampled)",
                renderer.format(),
                samples,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            )
            .create_view(&Default::default())
        });
        let depth = texture(
            "clatter-render depth",
            DEPTH_FORMAT,
            samples,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
        .create_view(&Default::default());
        let resolved_view = resolved.create_view(&Default::default());
        Ok(Targets {
            width,
            height,
            msaa,
            resolved,
            resolved_view,
            depth,
        })
    }

    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// The resolved colour texture (single-sampled).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.resolved
    }

    /// Begins a pass that clears and draws into these targets, resolving into `output`
    /// (a view of the same size and format; `None`: the targets' own resolved texture).
    pub fn begin_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        output: Option<&wgpu::TextureView>,
    ) -> wgpu::RenderPass<'e> {
        let out = output.unwrap_or(&self.resolved_view);
        let (view, resolve_target) = match &self.msaa {
            Some(m) => (m, Some(out)),
            None => (out, None),
        };
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("clatter-render frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(background()),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }
}

/// Reads an RGBA8 (or BGRA8, swizzled) texture back into an image.
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<RgbaImage, RenderError> {
    let (width, height) = (texture.width(), texture.height());
    let bgra = matches!(
        texture.format(),
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let row = 4 * width;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("clatter-render read-back"),
        size: padded as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let mut pixels = Vec::with_capacity((row * height) as usize);
    {
        let data = slice
            .get_mapped_range()
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        for y in 0..height as usize {
            let start = y * padded as usize;
            pixels.extend_from_slice(&data[start..start + row as usize]);
        }
    }
    buffer.unmap();
    if bgra {
        for px in pixels.chunks_exact_mut(4) {
            px.swap(0, 2);
        }
    }
    RgbaImage::from_raw(width, height, pixels)
        .ok_or_else(|| RenderError::Readback("image size mismatch".into()))
}

/// Renders frames of a world into images of one size, sharing the simulation's device.
pub struct Offscreen {
    /// The renderer, drawing into `targets`.
    pub renderer: Renderer,
    /// The colour and depth textures of the frame size.
    pub targets: Targets,
    device: wgpu::Device,
    queue: wgpu::Queue,
}

impl Offscreen {
    /// An offscreen renderer of `width` x `height` for `world` on `ctx`'s device.
    pub fn new(
        ctx: &GpuContext,
        world: &World,
        width: u32,
        height: u32,
    ) -> Result<Offscreen, RenderError> {
        let mut renderer =
            Renderer::new(&ctx.device, &ctx.queue, OFFSCREEN_FORMAT, OFFSCREEN_SAMPLES);
        let targets = Targets::new(&ctx.device, &renderer, width, height)?;
        renderer.set_world(world);
        Ok(Offscreen {
            renderer,
            targets,
            device: ctx.device.clone(),
            queue: ctx.queue.clone(),
        })
    }

    /// The camera `spec` asks for, framing the world as it was at creation.
    pub fn camera(&self, spec: CameraSpec) -> Camera {
        Camera::framing(
            spec,
            &self.renderer.bounds(),
            self.renderer.up(),
            self.targets.aspect(),
        )
    }

    /// Draws one frame with the poses from `poses` and reads it back.
    pub fn render(
        &mut self,
        camera: &Camera,
        style: &Style,
        poses: Poses<'_>,
    ) -> Result<RgbaImage, RenderError> {
        self.draw(camera, style, poses)?;
        read_texture(&self.device, &self.queue, self.targets.texture())
    }

    /// Draws one frame without reading it back (for timing the GPU side alone); waits for
    /// the GPU to finish.
    pub fn draw(
        &mut self,
        camera: &Camera,
        style: &Style,
        poses: Poses<'_>,
    ) -> Result<(), RenderError> {
        self.renderer.prepare(camera, self.targets.aspect(), style);
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = self.targets.begin_pass(&mut encoder, None);
            self.renderer.paint(&mut pass, poses)?;
        }
        self.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Uploads `world`'s state (poses, velocities, contact flags) for the next frame.
    pub fn update(&mut self, world: &World) {
        self.renderer.update(world, None);
    }
}

/// Saves `image` as a PNG at `path`.
pub fn save_png(image: &RgbaImage, path: &Path) -> Result<(), RenderError> {
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| RenderError::Write {
            path: path.display().to_string(),
            message: e.to_string(),
        })
}
