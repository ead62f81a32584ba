//! `clatter bench`: steps/s against the number of bodies on a settled pile, with `--render` the
//! frames/s of a step plus an offscreen 1280x720 frame, and the LAMMPS input for the same
//! sphere pile (`scripts/bench-lammps.sh` runs both and prints the ratio).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clatter::World;
use clatter::pile::{PileParams, PileShape, pile};
use clatter_gpu::{Device, Readback, StepError, Stepper};

use crate::BenchShape;
use crate::backend::Backend;

/// Arguments of `clatter bench`.
pub struct BenchArgs {
    pub shape: BenchShape,
    pub bodies: Vec<usize>,
    pub steps: u64,
    pub settle: u64,
    pub json: bool,
    pub emit_lammps: Option<PathBuf>,
    pub backend: Backend,
    /// With `Some(frames)`: also time that many frames of one step plus an offscreen render.
    pub render: Option<u64>,
    /// With the GPU backend: also time each kernel with timestamp queries over this many
    /// steps and print milliseconds per step per kernel.
    pub profile: Option<u64>,
    /// Time this scene file (`default`: the embedded default scene) instead of the piles.
    pub scene: Option<PathBuf>,
}

/// Size of the frames timed by `--render`.
pub const RENDER_SIZE: (u32, u32) = (1280, 720);

/// One row of the table.
#[derive(serde::Serialize)]
struct Row {
    shape: &'static str,
    bodies: usize,
    steps: u64,
    steps_per_s: f64,
    body_steps_per_s: f64,
    contacts_per_body: f64,
    ms_per_step: f64,
    threads: usize,
    dt: f32,
    rebuilds: u64,
    backend: String,
    /// With `--render`: frames per second of one step plus an offscreen 1280x720 frame
    /// (upload, draw, wait for the GPU; no read-back).
    #[serde(skip_serializing_if = "Option::is_none")]
    frames_per_s: Option<f64>,
    /// With `--profile` (GPU): milliseconds per step of each kernel, timed alone.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    kernels: Vec<(String, f64)>,
    /// With `--profile`: candidate pairs in the list after the timed steps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pairs: Option<usize>,
    /// With `--profile`: the device's copy-kernel bandwidth (read + write), GB/s, for the
    /// bandwidth floor of the step.
    #[serde(skip_serializing_if = "Option::is_none")]
    copy_bandwidth_gb_s: Option<f64>,
}

/// Runs the benchmark for every body count.
pub fn bench(args: BenchArgs) -> anyhow::Result<()> {
    if args.bodies.is_empty() || args.bodies.contains(&0) {
        anyhow::bail!("--bodies needs positive counts, e.g. --bodies 1024,4096");
    }
    if args.steps == 0 {
        anyhow::bail!("--steps must be at least 1");
    }
    let (shape, name) = match args.shape {
        BenchShape::Sphere => (PileShape::Sphere, "sphere"),
        BenchShape::Cube => (PileShape::Cube, "cube"),
        BenchShape::Mixed => (PileShape::Mixed, "mixed"),
    };
    if args.emit_lammps.is_some() && (shape != PileShape::Sphere || args.bodies.len() != 1) {
        anyhow::bail!("--emit-lammps needs --shape sphere and exactly one --bodies count");
    }
    // A scene instead of the piles: one row, the scene's bodies.
    let scene_world = match &args.scene {
        Some(path) => {
            if args.emit_lammps.is_some() {
                anyhow::bail!("--emit-lammps writes the sphere pile: it does not go with --scene");
            }
            let path = (path.as_os_str() != "default").then_some(path.as_path());
            Some(crate::run::load_scene(path)?.1.world())
        }
        None => None,
    };
    let (name, counts) = match &scene_world {
        Some(w) => ("scene", vec![w.len()]),
        None => (name, args.bodies.clone()),
    };
    if args.render == Some(0) {
        anyhow::bail!("--render-frames must be at least 1");
    }
    if args.profile == Some(0) {
        anyhow::bail!("--profile-steps must be at least 1");
    }
    if args.profile.is_some() && args.backend == Backend::Cpu {
        anyhow::bail!("--profile times GPU kernels: use it with --backend gpu");
    }
    // One device for the simulation and the renderer, so that with the GPU backend the frames
    // are drawn straight from the simulation's body buffer.
    let gpu = match args.render {
        Some(_) => Some(std::sync::Arc::new(
            clatter_gpu::GpuContext::new().context("bench --render")?,
        )),
        None => None,
    };
    let params = PileParams::default();
    if !args.json {
        if let Some(ctx) = &gpu {
            println!(
                "# rendering: {}x{} offscreen on {}",
                RENDER_SIZE.0,
                RENDER_SIZE.1,
                ctx.adapter_name()
            );
        }
        let what = match &args.scene {
            Some(p) if p.as_os_str() != "default" => format!("scene {}", p.display()),
            Some(_) => "the default scene".to_string(),
            None => format!("{name} pile"),
        };
        println!(
            "# clatter bench: {what}, {} threads, {} settle + {} timed steps",
            rayon::current_num_threads(),
            args.settle,
            args.steps
        );
        print!(
            "{:>10} {:>12} {:>16} {:>14} {:>10} {:>9}",
            "bodies", "steps/s", "body-steps/s", "contacts/body", "ms/step", "rebuilds"
        );
        if gpu.is_some() {
            print!(" {:>10}", "frames/s");
        }
        println!("  backend");
    }
    let mut rows = Vec::new();
    let mut bandwidth: Option<f64> = None;
    for &n in &counts {
        let mut world = match &scene_world {
            Some(w) => w.clone(),
            None => World::new(pile(shape, n, &params)),
        };
        let quiet = args.json || !rows.is_empty();
        let device = match &gpu {
            Some(ctx) => Device::Shared(ctx.clone()),
            None => Device::Headless,
        };
        let mut stepper = crate::backend::choose(args.backend, &world, device, quiet)?;
        if args.profile.is_some() && !stepper.is_gpu() {
            anyhow::bail!(
                "--profile times GPU kernels, but the CPU pipeline was chosen: use --backend gpu"
            );
        }
        // Settling is also the warm-up (on the GPU: pipelines compiled, buffers resident).
        stepper
            .step(&mut world, args.settle, Readback::Nothing)
            .map_err(blew_up("settling"))?;
        if let Some(dir) = &args.emit_lammps {
            stepper.sync(&mut world)?;
            write_lammps(dir, &world, &params, args.steps)?;
        }
        let rebuilds_before = stepper.rebuilds(&world);
        // Wall clock around work that ends with a synchronising read on the GPU.
        let start = Instant::now();
        let timed = stepper
            .step(&mut world, args.steps, Readback::Nothing)
            .map_err(blew_up("timing"))?;
        let secs = start.elapsed().as_secs_f64();
        let (contacts, rebuilds) = (
            timed.mean_contacts,
            stepper.rebuilds(&world) - rebuilds_before,
        );
        let mut kernels = Vec::new();
        let mut pairs = None;
        if let (Some(steps), Some(gpu)) = (args.profile, stepper.as_gpu_mut()) {
            kernels = gpu.profile(steps)?;
            pairs = Some(gpu.pairs());
            if bandwidth.is_none() {
                let bw = clatter_gpu::bandwidth::copy_bandwidth(gpu.context(), 9)?;
                bandwidth = Some(bw * 1e-9);
                if !args.json {
                    println!(
                        "# memory bandwidth (copy kernel, read + write): {:.0} GB/s",
                        bw * 1e-9
                    );
                }
            }
        }
        let backend = stepper.name();
        let sps = args.steps as f64 / secs;
        let frames_per_s = match (&gpu, args.render) {
            (Some(ctx), Some(frames)) => Some(time_frames(ctx, &mut world, &mut stepper, frames)?),
            _ => None,
        };
        let row = Row {
            shape: name,
            bodies: n,
            steps: args.steps,
            steps_per_s: sps,
            body_steps_per_s: sps * n as f64,
            contacts_per_body: 2.0 * contacts / n as f64,
            ms_per_step: 1e3 * secs / args.steps as f64,
            threads: rayon::current_num_threads(),
            dt: world.dt,
            rebuilds,
            backend,
            frames_per_s,
            kernels,
            pairs,
            copy_bandwidth_gb_s: args.profile.and(bandwidth),
        };
        if !args.json {
            print!(
                "{:>10} {:>12.1} {:>16.3e} {:>14.2} {:>10.3} {:>9}",
                row.bodies,
                row.steps_per_s,
                row.body_steps_per_s,
                row.contacts_per_body,
                row.ms_per_step,
                row.rebuilds,
            );
            if let Some(f) = row.frames_per_s {
                print!(" {f:>10.2}");
            }
            println!("  {}", row.backend);
            if let Some(p) = row.pairs {
                println!(
                    "#   {p} candidate pairs ({:.2} per body)",
                    p as f64 / row.bodies as f64
                );
            }
            if !row.kernels.is_empty() {
                let total: f64 = row.kernels.iter().map(|(_, ms)| ms).sum();
                let list: Vec<String> = row
                    .kernels
                    .iter()
                    .map(|(k, ms)| format!("{k} {ms:.4}"))
                    .collect();
                println!(
                    "#   kernels (ms/step, each timed alone; sum {total:.4}): {}",
                    list.join(", ")
                );
            }
        }
        rows.push(row);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    }
    Ok(())
}

/// Frames per second of one step and an offscreen frame (waiting for the GPU to finish
/// each), over `frames` frames after one untimed warm-up frame. With the CPU pipeline the
/// state is uploaded each frame; with the GPU pipeline the frame is drawn straight from the
/// simulation's body buffer (no round trip through the host).
fn time_frames(
    ctx: &clatter_gpu::GpuContext,
    world: &mut World,
    stepper: &mut Stepper,
    frames: u64,
) -> anyhow::Result<f64> {
    use clatter_render::{CameraSpec, Offscreen, Poses, Style};
    stepper.sync(world)?;
    let mut off = Offscreen::new(ctx, world, RENDER_SIZE.0, RENDER_SIZE.1)?;
    let camera = off.camera(CameraSpec::Iso);
    let style = Style::default();
    let mut frame = |world: &mut World| -> anyhow::Result<()> {
        stepper
            .step(world, 1, Readback::Nothing)
            .map_err(blew_up("rendering"))?;
        match stepper.as_gpu() {
            Some(gpu) => off.draw(&camera, &style, Poses::Gpu(gpu.body_buffer()))?,
            None => {
                off.update(world);
                off.draw(&camera, &style, Poses::Uploaded)?;
            }
        }
        ctx.wait()?;
        Ok(())
    };
    frame(world)?;
    let start = Instant::now();
    for _ in 0..frames {
        frame(world)?;
    }
    Ok(frames as f64 / start.elapsed().as_secs_f64())
}

/// The error of a step of the benchmark: a blow-up says what the pile was doing (`when`:
/// settling, timing, rendering); a GPU failure is reported as it is.
fn blew_up(when: &'static str) -> impl Fn(StepError) -> anyhow::Error {
    move |e| match e {
        StepError::Sim(e) => {
            anyhow::Error::new(e).context(format!("the pile blew up while {when}"))
        }
        StepError::Gpu(e) => e.into(),
    }
}

/// Writes `pile.data` and `in.pile` for LAMMPS (`pair_style gran/hooke/history`) with the same
/// bodies, walls, contact law parameters, time step and step count.
fn write_lammps(dir: &Path, world: &World, p: &PileParams, steps: u64) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut lo = glam::Vec3::splat(f32::INFINITY);
    let mut hi = glam::Vec3::splat(f32::NEG_INFINITY);
    for x in &world.state.position {
        lo = lo.min(*x);
        hi = hi.max(*x);
    }
    let r = p.radius;
    let mut data = String::new();
    use std::fmt::Write as _;
    writeln!(
        data,
        "clatter sphere pile\n\n{} atoms\n1 atom types\n",
        world.len()
    )?;
    // The walls are planes x = 0, x = wx, y = 0, y = wy, z = 0 (see pile.rs).
    let wall = |n: glam::Vec3| {
        world
            .walls
            .iter()
            .find(|w| w.plane.normal == n)
            .map(|w| w.plane.offset)
    };
    let wx = -wall(-glam::Vec3::X).unwrap_or(hi.x + r);
    let wy = -wall(-glam::Vec3::Y).unwrap_or(hi.y + r);
    writeln!(
        data,
        "{} {} xlo xhi\n{} {} ylo yhi\n{} {} zlo zhi\n",
        -r,
        wx + r,
        -r,
        wy + r,
        -r,
        hi.z + 4.0 * r
    )?;
    writeln!(data, "Atoms # sphere\n")?;
    for (i, x) in world.state.position.iter().enumerate() {
        writeln!(
            data,
            "{} 1 {} {} {} {} {}",
            i + 1,
            2.0 * r,
            p.density,
            x.x,
            x.y,
            x.z
        )?;
    }
    writeln!(data, "\nVelocities\n")?;
    for i in 0..world.len() {
        let (v, w) = (world.state.velocity[i], world.state.omega[i]);
        writeln!(
            data,
            "{} {} {} {} {} {} {}",
            i + 1,
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z
        )?;
    }
    std::fs::write(dir.join("pile.data"), data)?;

    let params = world.pair_params(0, 0);
    let m = world.consts.mass[0] as f64;
    let k = params.stiffness as f64;
    // LAMMPS's Hookean damping is m_eff * gamma_n * v_n; ours is eta * v_n with
    // eta = factor * sqrt(m_eff k), so gamma_n = factor * sqrt(k / m_eff).
    let gn_pair = params.damping_factor as f64 * (k / (m / 2.0)).sqrt();
    let gn_wall = params.damping_factor as f64 * (k / m).sqrt();
    let kt = k * clatter::contract::LINEAR_TANGENTIAL_RATIO as f64;
    let gt = clatter::contract::TANGENTIAL_DAMPING_RATIO as f64;
    let mu = params.friction;
    let mut input = std::fs::File::create(dir.join("in.pile"))?;
    writeln!(
        input,
        "# Generated by `clatter bench --emit-lammps`: the same settled sphere pile as clatter's bench.
units si
atom_style sphere
boundary f f f
newton off
comm_modify vel yes
read_data pile.data
pair_style gran/hooke/history {k} {kt} {gn_pair} {gnt_pair} {mu} 1
pair_coeff * *
neighbor {skin} bin
neigh_modify delay 0 every 1 check yes
fix integrate all nve/sphere
fix gravity all gravity 9.81 vector 0 0 -1
fix floor all wall/gran hooke/history {k} {kt} {gn_wall} {gnt_wall} {mu} 1 zplane 0.0 NULL
fix xwalls all wall/gran hooke/history {k} {kt} {gn_wall} {gnt_wall} {mu} 1 xplane 0.0 {wx}
fix ywalls all wall/gran hooke/history {k} {kt} {gn_wall} {gnt_wall} {mu} 1 yplane 0.0 {wy}
timestep {dt}
thermo 1000
run 100
run {steps}",
        gnt_pair = gn_pair * gt,
        gnt_wall = gn_wall * gt,
        skin = world.skin,
        dt = world.dt,
    )?;
    Ok(())
}
