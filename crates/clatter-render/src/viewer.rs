//! The interactive viewer: a winit window, the simulation stepping live (on the CPU, or on
//! the GPU with the frames drawn straight from its body buffer), the scene drawn by
//! [`Renderer`] and an egui side panel with the controls and counters.
//!
//! Mouse: left drag orbits about the target, right or middle drag pans, the wheel zooms.
//! With [`ViewerOptions::screenshot`], the viewer shows a number of frames, saves the last
//! one (scene and panel) as a PNG and exits: how it is tested under Xvfb.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clatter::World;
use clatter::health::Health;
use clatter_backend::{
    BackendChoice, BackendError, CHECK_EVERY, Device, Readback, Stepper, Watch, WatchError,
};
use clatter_gpu::GpuContext;
use glam::{Quat, Vec3};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use crate::camera::{Camera, CameraSpec};
use crate::offscreen::{Targets, read_texture, save_png};
use crate::renderer::{ColorMode, DEPTH_FORMAT, Poses, RenderError, Renderer, Style};

/// What the viewer shows and how it starts.
pub struct ViewerOptions {
    /// The world at its start (Reset returns to it).
    pub world: World,
    /// Window title.
    pub title: String,
    /// Window size in pixels.
    pub size: (u32, u32),
    /// Simulation steps per displayed frame at the start (the speed slider).
    pub steps_per_frame: u32,
    /// The starting camera.
    pub camera: CameraSpec,
    /// The starting colour mode and "only in contact" toggle.
    pub style: Style,
    /// Save frame number `frames` to this PNG and exit.
    pub screenshot: Option<PathBuf>,
    /// Frames shown before the screenshot.
    pub frames: u64,
    /// Which pipeline steps the world, chosen on the window's device
    /// ([`clatter_backend::choose`]): the CPU's state is uploaded once per frame; the GPU's
    /// frames are drawn straight from its body buffer.
    pub backend: BackendChoice,
}

/// winit's OS errors begin "os error at FILE:LINE: " (a path in the build machine's cargo
/// registry): the reason alone, for a user's message.
fn without_source_path(message: &str) -> String {
    match message.strip_prefix("os error at ") {
        Some(rest) => rest
            .split_once(": ")
            .map_or(message, |(_, why)| why)
            .to_string(),
        None => message.to_string(),
    }
}

/// Errors of the viewer.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// No window system (no DISPLAY or WAYLAND_DISPLAY) or the window could not be made.
    #[error(
        "cannot open a window: {0} (is a display available? try `xvfb-run -a clatter view ...`)"
    )]
    Window(String),
    /// No adapter can draw into the window.
    #[error("no GPU adapter can draw into the window: {0}")]
    Adapter(String),
    /// `--backend gpu` and the scene cannot run on the window's adapter.
    #[error("--backend gpu: {0}")]
    Backend(Box<BackendError>),
    /// Rendering failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The simulation blew up (the blow-up checks of `clatter run`); the window showed it
    /// and was closed, or the screenshot was saved after it.
    #[error("{0}")]
    BlowUp(String),
}

/// Orbit-camera state driven by the mouse.
#[derive(Default)]
struct Mouse {
    orbit: bool,
    pan: bool,
    last: Option<(f64, f64)>,
}

/// Everything that exists once the window does.
struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    ctx: Arc<GpuContext>,
    /// The pipeline that steps the world.
    stepper: Stepper,
    /// The blow-up checks of `clatter run`.
    watch: Watch,
    renderer: Renderer,
    targets: Targets,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
}

/// Counters shown in the panel, updated about twice a second.
struct Rates {
    since: Instant,
    frames: u64,
    steps: u64,
    fps: f64,
    steps_per_s: f64,
}

struct App {
    options: ViewerOptions,
    world: World,
    gfx: Option<Gfx>,
    camera: Camera,
    style: Style,
    steps_per_frame: u32,
    paused: bool,
    step_once: bool,
    reset: bool,
    sim_error: Option<String>,
    /// The blow-up report, if the simulation blew up (returned when the viewer closes).
    blow_up: Option<String>,
    contacts_now: usize,
    mouse: Mouse,
    rates: Rates,
    frames_shown: u64,
    /// Width of the control panel, points: the scene is drawn to its right.
    panel_width: f32,
    egui: egui::Context,
    result: Result<(), ViewerError>,
}

/// Opens the window and runs until it is closed (or the screenshot is saved).
pub fn run(options: ViewerOptions) -> Result<(), ViewerError> {
    let event_loop =
        EventLoop::new().map_err(|e| ViewerError::Window(without_source_path(&e.to_string())))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let world = options.world.clone();
    let mut app = App {
        style: options.style,
        steps_per_frame: options.steps_per_frame.max(1),
        world,
        gfx: None,
        camera: Camera::framing(
            CameraSpec::Iso,
            &crate::Bounds::of_world(&options.world),
            Vec3::Z,
            1.0,
        ),
        paused: false,
        step_once: false,
        reset: false,
        sim_error: None,
        blow_up: None,
        contacts_now: 0,
        mouse: Mouse::default(),
        rates: Rates {
            since: Instant::now(),
            frames: 0,
            steps: 0,
            fps: 0.0,
            steps_per_s: 0.0,
        },
        frames_shown: 0,
        panel_width: 0.0,
        egui: egui::Context::default(),
        result: Ok(()),
        options,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewerError::Window(e.to_string()))?;
    app.result?;
    match app.blow_up {
        Some(report) => Err(ViewerError::BlowUp(report)),
        None => Ok(()),
    }
}

impl App {
    /// Stops the simulation on a blow-up: the report in the panel (and, when the viewer
    /// closes, its error).
    fn blown_up(&mut self, report: String) {
        self.sim_error = Some(format!("stopped: {report}"));
        self.blow_up = Some(report);
        self.paused = true;
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        self.result = Err(e);
        event_loop.exit();
    }

    fn create(&mut self, event_loop: &ActiveEventLoop) -> Result<Gfx, ViewerError> {
        let (w, h) = self.options.size;
        let attrs = Window::default_attributes()
            .with_title(self.options.title.clone())
            .with_inner_size(PhysicalSize::new(w, h));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(|e| ViewerError::Window(e.to_string()))?,
        );
        clatter_gpu::quiet_device_select();
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        ));
        desc.flags = clatter_gpu::instance_flags(desc.flags);
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| ViewerError::Window(format!("cannot create a drawing surface: {e}")))?;
        let adapter =
            pollster::block_on(
                instance.request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::from_env()
                        .unwrap_or(wgpu::PowerPreference::HighPerformance),
                    force_fallback_adapter: false,
                    compatible_surface: Some(&surface),
                    apply_limit_buckets: false,
                }),
            )
            .map_err(|e| ViewerError::Adapter(e.to_string()))?;
        let ctx = Arc::new(
            pollster::block_on(GpuContext::from_adapter(adapter.clone()))
                .map_err(|e| ViewerError::Adapter(e.to_string()))?,
        );
        let chosen = clatter_backend::choose(
            self.options.backend,
            &self.world,
            Device::Window(ctx.clone()),
        )
        .map_err(|e| ViewerError::Backend(Box::new(e)))?;
        if let Some(note) = chosen.choice.note() {
            eprintln!("{note}");
        }
        let caps = surface.get_capabilities(&adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| ViewerError::Adapter("the surface supports no format".into()))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&ctx.device, &config);
        let samples = if adapter
            .get_texture_format_features(format)
            .flags
            .sample_count_supported(4)
        {
            4
        } else {
            1
        };
        let mut renderer = Renderer::new(&ctx.device, &ctx.queue, format, samples);
        renderer.set_world(&self.world);
        let targets = Targets::new(&ctx.device, &renderer, config.width, config.height)?;
        self.camera = Camera::framing(
            self.options.camera,
            &renderer.bounds(),
            renderer.up(),
            // The panel (about 230 points wide) takes the left of the window.
            (config.width as f32 - 230.0 * window.scale_factor() as f32).max(1.0)
                / config.height as f32,
        );
        let egui_state = egui_winit::State::new(
            self.egui.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(ctx.limits.max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            &ctx.device,
            format,
            egui_wgpu::RendererOptions {
                msaa_samples: samples,
                depth_stencil_format: Some(DEPTH_FORMAT),
                ..Default::default()
            },
        );
        let mut stepper = chosen.stepper;
        let health = Health::new(&self.world);
        for w in health.warnings(&self.world) {
            eprintln!("warning: {w}");
        }
        if let Err(b) = health.check_initial(&self.world) {
            self.blown_up(b.to_string());
        }
        let watch = Watch::start(&mut stepper, &self.world, health, CHECK_EVERY, 0);
        Ok(Gfx {
            window,
            surface,
            config,
            ctx,
            stepper,
            watch,
            renderer,
            targets,
            egui_state,
            egui_renderer,
        })
    }

    /// Advances the simulation by this frame's steps.
    fn simulate(&mut self) {
        let Some(g) = self.gfx.as_mut() else { return };
        if self.reset {
            self.reset = false;
            self.world = self.options.world.clone();
            self.sim_error = None;
            self.blow_up = None;
            g.renderer.set_world(&self.world);
            if let Err(e) = g.stepper.restart(&self.world) {
                self.sim_error = Some(format!("reset failed: {e}"));
            }
            if let Some(gpu) = g.stepper.as_gpu_mut() {
                g.watch.arm(gpu, &self.world, 0);
            }
        }
        let n = if self.sim_error.is_some() {
            0
        } else if self.step_once {
            1
        } else if self.paused {
            0
        } else {
            self.steps_per_frame
        };
        self.step_once = false;
        if n > 0 {
            let stepped =
                g.watch
                    .step(&mut g.stepper, &mut self.world, n as u64, Readback::Nothing);
            match stepped {
                Ok(s) => {
                    self.contacts_now = s.contacts;
                    self.rates.steps += s.steps;
                }
                Err(WatchError::BlowUp(b)) => {
                    let report = b.to_string();
                    self.sim_error = Some(format!("stopped: {report}"));
                    self.blow_up = Some(report);
                    self.paused = true;
                }
                Err(WatchError::Gpu(e)) => {
                    self.sim_error = Some(format!("GPU step failed: {e}"));
                    self.paused = true;
                }
            }
        }
        if let Some(sim) = g.stepper.as_gpu() {
            // The panel's clock (the body state itself stays on the GPU).
            self.world.step_count = self.options.world.step_count + sim.steps_taken();
            self.world.time =
                self.options.world.time + sim.steps_taken() as f64 * self.world.dt as f64;
        }
    }

    /// The egui panel.
    fn panel(&mut self, ui: &mut egui::Ui, bodies: usize, adapter: &str) {
        let shown = egui::Panel::left("controls")
            .resizable(false)
            .default_size(220.0)
            .show(ui, |ui| {
                ui.heading("clatter");
                ui.horizontal(|ui| {
                    let label = if self.paused { "Run" } else { "Pause" };
                    if ui.button(label).clicked() {
                        self.paused = !self.paused;
                    }
                    if ui.button("Step").clicked() {
                        self.paused = true;
                        self.step_once = true;
                    }
                    if ui.button("Reset").clicked() {
                        self.reset = true;
                    }
                });
                ui.add(
                    egui::Slider::new(&mut self.steps_per_frame, 1..=500)
                        .logarithmic(true)
                        .text("steps/frame"),
                );
                ui.separator();
                ui.label("Colour by");
                for mode in ColorMode::ALL {
                    ui.radio_value(&mut self.style.color, mode, mode.name());
                }
                ui.checkbox(&mut self.style.only_contacts, "only in contact");
                ui.separator();
                ui.label(format!("{:.0} fps", self.rates.fps));
                ui.label(format!("{:.0} steps/s", self.rates.steps_per_s));
                ui.label(format!("{bodies} bodies"));
                ui.label(format!("{} contacts", self.contacts_now));
                ui.label(format!(
                    "t = {:.4} s (step {})",
                    self.world.time, self.world.step_count
                ));
                if let Some(e) = &self.sim_error {
                    ui.colored_label(egui::Color32::LIGHT_RED, e);
                }
                ui.separator();
                ui.small(adapter);
                ui.small("left drag: orbit, right drag: pan, wheel: zoom");
            });
        self.panel_width = shown.response.rect.width();
    }

    /// The part of the window right of the panel, pixels: `(x, width)`.
    fn scene_area(&self, width: u32, pixels_per_point: f32) -> (u32, u32) {
        let x = ((self.panel_width * pixels_per_point).round() as u32).min(width.saturating_sub(1));
        (x, width - x)
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        self.simulate();
        let Some(mut g) = self.gfx.take() else {
            return Ok(());
        };
        let out = self.draw(&mut g, event_loop);
        self.gfx = Some(g);
        out
    }

    fn draw(&mut self, g: &mut Gfx, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        let mut style = self.style;
        if g.stepper.is_gpu() {
            // Drawn from the GPU's buffer; only the contact flags and the speed scale need
            // the host's copy, so only those modes read the state back.
            if style.only_contacts || style.color != ColorMode::Material {
                g.stepper.sync(&mut self.world).map_err(RenderError::from)?;
                g.renderer.update_styles(&self.world, None);
                let vmax = self
                    .world
                    .state
                    .velocity
                    .iter()
                    .map(|v| v.length())
                    .filter(|v| v.is_finite())
                    .fold(0.0f32, f32::max);
                style.speed_max = Some(if vmax > 0.0 { vmax } else { 1.0 });
            }
        } else {
            let counts = self.world.contact_counts();
            self.contacts_now = self.world.contact_count();
            g.renderer.update(&self.world, Some(&counts));
        }
        // The panel first: it may change the style or ask for a reset.
        let input = g.egui_state.take_egui_input(&g.window);
        let bodies = self.world.len();
        let adapter = format!(
            "{} steps, drawn on {}",
            if g.stepper.is_gpu() { "GPU" } else { "CPU" },
            g.ctx.adapter_name()
        );
        let egui_ctx = self.egui.clone();
        let full = egui_ctx.run_ui(input, |ui| self.panel(ui, bodies, &adapter));
        g.egui_state
            .handle_platform_output(&g.window, full.platform_output);
        let ppp = full.pixels_per_point;
        let jobs = self.egui.tessellate(full.shapes, ppp);
        for (id, deltas) in &full.textures_delta.set {
            for delta in deltas {
                g.egui_renderer
                    .update_texture(&g.ctx.device, &g.ctx.queue, *id, delta);
            }
        }
        self.camera.fit_clip(&g.renderer.bounds());
        let (x0, scene_w) = self.scene_area(g.config.width, ppp);
        let aspect = scene_w as f32 / g.config.height as f32;
        g.renderer.prepare(&self.camera, aspect, &style);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [g.config.width, g.config.height],
            pixels_per_point: ppp,
        };
        let last =
            self.options.screenshot.is_some() && self.frames_shown + 1 >= self.options.frames;
        let mut encoder = g.ctx.device.create_command_encoder(&Default::default());
        let extra = g.egui_renderer.update_buffers(
            &g.ctx.device,
            &g.ctx.queue,
            &mut encoder,
            &jobs,
            &screen,
        );
        let frame = if last {
            None
        } else {
            match g.surface.get_current_texture() {
                wgpu::CurrentSurfaceTexture::Success(t)
                | wgpu::CurrentSurfaceTexture::Suboptimal(t) => Some(t),
                wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                    g.surface.configure(&g.ctx.device, &g.config);
                    return Ok(());
                }
                _ => return Ok(()),
            }
        };
        let view = frame
            .as_ref()
            .map(|f| f.texture.create_view(&Default::default()));
        {
            let mut pass = g
                .targets
                .begin_pass(&mut encoder, view.as_ref())
                .forget_lifetime();
            let (w, h) = (g.config.width as f32, g.config.height as f32);
            pass.set_viewport(x0 as f32, 0.0, scene_w as f32, h, 0.0, 1.0);
            let poses = match g.stepper.as_gpu() {
                Some(sim) => Poses::Gpu(sim.body_buffer()),
                None => Poses::Uploaded,
            };
            g.renderer.paint(&mut pass, poses)?;
            pass.set_viewport(0.0, 0.0, w, h, 0.0, 1.0);
            g.egui_renderer.render(&mut pass, &jobs, &screen);
        }
        g.ctx
            .queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        for id in &full.textures_delta.free {
            g.egui_renderer.free_texture(id);
        }
        if let Some(f) = frame {
            g.window.pre_present_notify();
            g.ctx.queue.present(f);
        }
        g.ctx.take_error().map_err(RenderError::from)?;
        self.frames_shown += 1;
        self.rates.frames += 1;
        let dt = self.rates.since.elapsed();
        if dt >= Duration::from_millis(500) {
            let s = dt.as_secs_f64();
            self.rates.fps = self.rates.frames as f64 / s;
            self.rates.steps_per_s = self.rates.steps as f64 / s;
            self.rates = Rates {
                since: Instant::now(),
                frames: 0,
                steps: 0,
                ..self.rates
            };
        }
        if last {
            let img = read_texture(&g.ctx.device, &g.ctx.queue, g.targets.texture())?;
            if let Some(path) = &self.options.screenshot {
                save_png(&img, path)?;
            }
            event_loop.exit();
        }
        Ok(())
    }

    fn resize(&mut self, size: PhysicalSize<u32>) -> Result<(), ViewerError> {
        let Some(g) = &mut self.gfx else {
            return Ok(());
        };
        if size.width == 0 || size.height == 0 {
            return Ok(());
        }
        g.config.width = size.width;
        g.config.height = size.height;
        g.surface.configure(&g.ctx.device, &g.config);
        g.targets = Targets::new(&g.ctx.device, &g.renderer, size.width, size.height)?;
        Ok(())
    }

    /// Orbit (about the scene's up axis and the camera's right axis) or pan by a mouse move
    /// of `(dx, dy)` pixels.
    fn drag(&mut self, dx: f32, dy: f32) {
        let up = self.gfx.as_ref().map_or(Vec3::Z, |g| g.renderer.up());
        let cam = &mut self.camera;
        let offset = cam.eye - cam.target;
        let f = cam.forward();
        let right = f.cross(cam.up).normalize_or(Vec3::X);
        if self.mouse.orbit {
            let yaw = Quat::from_axis_angle(up, -dx * 0.008);
            let mut o = yaw * offset;
            let right = yaw * right;
            let pitched = Quat::from_axis_angle(right, -dy * 0.008) * o;
            // Do not pass over the poles.
            let angle = pitched.normalize().dot(up).clamp(-1.0, 1.0).acos();
            if (0.02..std::f32::consts::PI - 0.02).contains(&angle) {
                o = pitched;
            }
            cam.eye = cam.target + o;
            if cam.forward().cross(up).length() > 1e-3 {
                cam.up = up;
            }
        } else if self.mouse.pan {
            let h = self.gfx.as_ref().map_or(600.0, |g| g.config.height as f32);
            let scale = 2.0 * offset.length() * (cam.fov_y * 0.5).tan() / h;
            let cam_up = right.cross(f);
            let shift = (-right * dx + cam_up * dy) * scale;
            cam.eye += shift;
            cam.target += shift;
        }
    }

    fn zoom(&mut self, lines: f32) {
        let cam = &mut self.camera;
        let offset = (cam.eye - cam.target) * (-0.12 * lines).exp();
        if offset.length() > 1e-5 {
            cam.eye = cam.target + offset;
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        match self.create(event_loop) {
            Ok(g) => {
                g.window.request_redraw();
                self.gfx = Some(g);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let consumed = match &mut self.gfx {
            Some(g) => g.egui_state.on_window_event(&g.window, &event).consumed,
            None => false,
        };
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Err(e) = self.resize(size) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                if down && (consumed || self.egui.is_pointer_over_egui()) {
                    return;
                }
                match button {
                    MouseButton::Left => self.mouse.orbit = down,
                    MouseButton::Right | MouseButton::Middle => self.mouse.pan = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some((x, y)) = self.mouse.last
                    && (self.mouse.orbit || self.mouse.pan)
                {
                    self.drag((position.x - x) as f32, (position.y - y) as f32);
                }
                self.mouse.last = Some((position.x, position.y));
            }
            WindowEvent::MouseWheel { delta, .. } => {
                if consumed || self.egui.is_pointer_over_egui() {
                    return;
                }
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.zoom(lines);
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(g) = &self.gfx {
            g.window.request_redraw();
        }
    }
}
