//! `clatter run` and `clatter resume`: load a scene (or the embedded default) or a checkpoint,
//! step it with a progress bar and the blow-up checks, print a summary, and write outputs
//! atomically (see docs/outputs.md).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::ValueEnum;
use clatter::health::{BlowUp, Health};
use clatter::scene::Scene;
use clatter::{Checkpoint, World};
use clatter_backend::{Device, Readback, StepError, Stepper, Watch, WatchError};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};

use crate::args::{Pipeline, Progress};
use crate::backend::Backend;
use crate::energy::EnergySeries;
use crate::log::{LogEvery, Sample, Thermo};
use crate::output::AtomicFile;
use crate::report::BlownUp;
use crate::scene_io::load_scene;

mod outputs;
pub(crate) use outputs::Outputs;

/// The default `--energy-every` of short runs: a sample costs a pass over every body (on the
/// GPU a reduction and its dispatches), about a tenth of a step, so a sample every step would
/// slow `run` by ~10% against `bench` on the same steps; one every 10 steps (as the blow-up
/// checks) still draws the energy plot of a 1,000-step run from 100 points.
const MIN_ENERGY_EVERY: u64 = 10;

/// The full blow-up check (overlaps) and the snapshot of the last good state, every this many
/// steps (and at every output step and the last step).
pub const FULL_CHECK_EVERY: u64 = clatter_backend::FULL_CHECK_EVERY;

/// Where `clatter run` without a scene file and without `--out` writes the default scene's
/// results (relative to the working directory), with a picture of the last step.
pub const DEFAULT_OUT: &str = "clatter-out/default";

/// With this environment variable set (not `0`), `clatter run --backend gpu` runs the
/// blow-up checks on the host as on the CPU, reading the state back every check step (the run
/// loop before the device-side checks; for timing comparisons, see BENCHMARKS.md).
pub const HOST_CHECKS_VAR: &str = "CLATTER_GPU_HOST_CHECKS";

/// Format of the series written every `--output-every` steps.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// `trace.csv`: one row per body and output step.
    Csv,
    /// `bodies_NNNNNN.vtu` per output step and `bodies.pvd` (ParaView).
    Vtk,
}

/// Output options shared by `run` and `resume`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct OutputArgs {
    /// Write final.csv, summary.json, energy.csv and energy.svg (and the series and
    /// checkpoints asked for) into DIR, created if needed.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Format(s) of the series written every --output-every steps: csv (DIR/trace.csv), vtk
    /// (DIR/bodies_NNNNNN.vtu and DIR/bodies.pvd, DIR/shapes_NNNNNN.vtu and DIR/shapes.pvd,
    /// and with mesh boundaries DIR/boundaries_NNNNNN.vtu and DIR/boundaries.pvd), or
    /// csv,vtk. Default csv.
    #[arg(long, value_enum, value_delimiter = ',', value_name = "FORMAT")]
    pub format: Vec<Format>,
    /// Write the series every N steps (vtk without it: the first and last step only).
    #[arg(long, value_name = "N")]
    pub output_every: Option<u64>,
    /// The same as --output-every (the name of earlier versions).
    #[arg(long, value_name = "N")]
    pub trace_every: Option<u64>,
    /// With --format vtk: also write the touching contacts (DIR/contacts_NNNNNN.vtu and
    /// DIR/contacts.pvd): point, normal, force.
    #[arg(long)]
    pub contacts: bool,
    /// Write the complete state to DIR/checkpoint.ckpt every T simulated seconds and at the
    /// end (`clatter resume` continues from it).
    #[arg(long, value_name = "T")]
    pub checkpoint_every: Option<f64>,
    /// Sample energy.csv every N steps (default: about 1000 samples over the run, at most
    /// one every 10 steps).
    #[arg(long, value_name = "N")]
    pub energy_every: Option<u64>,
    /// Run the cheap blow-up checks (escape, energy growth, deep overlaps) every N steps
    /// (default 10); the
    /// overlap check of all contacts runs every 100 steps and at output steps. With the GPU
    /// backend the cheap checks run on the device (the host checks only the steps they flag,
    /// output steps and the last step).
    #[arg(long, value_name = "N")]
    pub check_every: Option<u64>,
}

/// Arguments of `clatter run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Scene file (TOML, see docs/scene-format.md).
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub pipeline: Pipeline,
    /// Override the scene's run length with a number of steps.
    #[arg(long, value_name = "N")]
    pub steps: Option<u64>,
    #[command(flatten)]
    pub progress: Progress,
}

/// Arguments of `clatter resume`.
#[derive(clap::Args, Debug)]
pub struct ResumeArgs {
    /// Checkpoint file written by `clatter run --checkpoint-every`.
    pub checkpoint: PathBuf,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub pipeline: Pipeline,
    /// Run N more steps instead of going on to the end of the original run.
    #[arg(long, value_name = "N")]
    pub steps: Option<u64>,
    #[command(flatten)]
    pub progress: Progress,
}

/// What a checkpoint written by the CLI carries besides the state: how the run was going to
/// go on, so that `clatter resume` continues it the same way.
#[derive(Serialize, Deserialize, Debug, Clone, Default)]
struct RunState {
    end_step: u64,
    formats: Vec<Format>,
    output_every: Option<u64>,
    contacts: bool,
    checkpoint_every: Option<f64>,
    energy_every: Option<u64>,
    check_every: Option<u64>,
    health_baseline: Option<f64>,
}

/// Everything one invocation does.
pub(crate) struct Plan {
    pub(crate) scene: Scene,
    pub(crate) scene_text: String,
    pub(crate) end_step: u64,
    pub(crate) out: Option<PathBuf>,
    pub(crate) csv: bool,
    pub(crate) vtk: bool,
    pub(crate) output_every: Option<u64>,
    pub(crate) contacts: bool,
    pub(crate) checkpoint_every: Option<f64>,
    pub(crate) energy_every: u64,
    pub(crate) check_every: u64,
    pub(crate) health: Health,
    pub(crate) resumed: bool,
    pub(crate) quiet: bool,
    pub(crate) log: Option<LogEvery>,
    pub(crate) backend: Backend,
    /// Also render the last step into `out/final.png` (the default scene's first run).
    pub(crate) picture: bool,
}

impl Plan {
    fn run_state(&self) -> RunState {
        let mut formats = Vec::new();
        if self.csv {
            formats.push(Format::Csv);
        }
        if self.vtk {
            formats.push(Format::Vtk);
        }
        RunState {
            end_step: self.end_step,
            formats,
            output_every: self.output_every,
            contacts: self.contacts,
            checkpoint_every: self.checkpoint_every,
            energy_every: Some(self.energy_every),
            check_every: Some(self.check_every),
            health_baseline: Some(self.health.baseline()),
        }
    }

    /// Writes `world`'s checkpoint with this run's options to `path` (atomically).
    pub(crate) fn checkpoint(&self, world: &World, path: &Path) -> anyhow::Result<()> {
        let app = serde_json::to_vec(&self.run_state())?;
        let mut f = AtomicFile::create(path)?;
        f.writer().write_all(&world.checkpoint_bytes(
            &checkpoint_source(&self.scene.source),
            &self.scene_text,
            &app,
        ))?;
        f.commit()
    }
}

/// The scene's name as a checkpoint stores it: a scene file's absolute path, so that
/// `resume` from another working directory finds the mesh files it names (relative to the
/// scene file) again; anything else (the embedded default scene) as it is.
fn checkpoint_source(source: &str) -> String {
    let path = Path::new(source);
    if path.is_relative()
        && path.is_file()
        && let Ok(abs) = std::path::absolute(path)
    {
        return abs.display().to_string();
    }
    source.to_string()
}

/// The output options after checking, with a resumed run's stored ones filled in.
struct Resolved {
    csv: bool,
    vtk: bool,
    output_every: Option<u64>,
    contacts: bool,
    checkpoint_every: Option<f64>,
    energy_every: Option<u64>,
    check_every: u64,
}

impl Resolved {
    /// The plan of a run of `scene` (and its text) to `end_step` with these outputs, in
    /// `out`, as loud as `progress` says, on `pipeline`'s backend; neither resumed nor
    /// pictured.
    fn into_plan(
        self,
        end_step: u64,
        health: Health,
        out: Option<PathBuf>,
        progress: &Progress,
        pipeline: &Pipeline,
        (scene, scene_text): (Scene, String),
    ) -> Plan {
        Plan {
            end_step,
            out,
            csv: self.csv,
            vtk: self.vtk,
            output_every: self.output_every,
            contacts: self.contacts,
            checkpoint_every: self.checkpoint_every,
            energy_every: self
                .energy_every
                .unwrap_or(end_step.div_ceil(1000).max(MIN_ENERGY_EVERY)),
            check_every: self.check_every,
            health,
            resumed: false,
            quiet: progress.quiet,
            log: progress.lines(),
            backend: pipeline.backend,
            picture: false,
            scene,
            scene_text,
        }
    }
}

/// Checks the output options; `stored` are the options of the run being resumed.
fn resolve(o: &OutputArgs, stored: Option<&RunState>) -> anyhow::Result<Resolved> {
    let every = match (o.output_every, o.trace_every) {
        (Some(a), Some(b)) if a != b => anyhow::bail!(
            "--output-every {a} and --trace-every {b} disagree (they are the same option)"
        ),
        (Some(a), _) | (None, Some(a)) => Some(a),
        (None, None) => stored.and_then(|s| s.output_every),
    };
    let flag = if o.trace_every.is_some() && o.output_every.is_none() {
        "--trace-every"
    } else {
        "--output-every"
    };
    if every == Some(0) {
        anyhow::bail!("{flag} must be at least 1");
    }
    let formats = if !o.format.is_empty() {
        o.format.clone()
    } else {
        stored
            .map(|s| s.formats.clone())
            .filter(|f| !f.is_empty())
            .unwrap_or_else(|| vec![Format::Csv])
    };
    let (csv, vtk) = (
        formats.contains(&Format::Csv),
        formats.contains(&Format::Vtk),
    );
    let contacts = o.contacts || (o.format.is_empty() && stored.is_some_and(|s| s.contacts));
    if o.out.is_none() {
        if o.output_every.is_some() || o.trace_every.is_some() {
            anyhow::bail!("{flag} needs --out DIR (the series is written there)");
        }
        if !o.format.is_empty() {
            anyhow::bail!("--format needs --out DIR (the series is written there)");
        }
        if o.checkpoint_every.is_some() {
            anyhow::bail!("--checkpoint-every needs --out DIR (checkpoint.ckpt is written there)");
        }
        if o.energy_every.is_some() {
            anyhow::bail!("--energy-every needs --out DIR (energy.csv is written there)");
        }
    }
    if o.contacts && !vtk {
        anyhow::bail!("--contacts needs --format vtk (the contact series is VTK only)");
    }
    let checkpoint_every = o
        .checkpoint_every
        .or(stored.and_then(|s| s.checkpoint_every));
    if let Some(t) = checkpoint_every
        && !(t.is_finite() && t > 0.0)
    {
        anyhow::bail!("--checkpoint-every must be a positive number of simulated seconds, got {t}");
    }
    let energy_every = o.energy_every.or(stored.and_then(|s| s.energy_every));
    if energy_every == Some(0) {
        anyhow::bail!("--energy-every must be at least 1");
    }
    let check_every = o
        .check_every
        .or(stored.and_then(|s| s.check_every))
        .unwrap_or(10);
    if check_every == 0 {
        anyhow::bail!("--check-every must be at least 1");
    }
    Ok(Resolved {
        csv,
        vtk,
        output_every: every,
        contacts,
        checkpoint_every,
        energy_every,
        check_every,
    })
}

/// `clatter run`: a scene from the start.
pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let (text, scene) = load_scene(args.scene.as_deref())?;
    let (plan, world) = run_plan(args, text, scene)?;
    execute(plan, world)
}

/// The plan and the world of `clatter run` for `scene` (read from `text`); the MPI run
/// (`crate::cluster`) makes them on every rank from the text rank 0 read.
pub(crate) fn run_plan(
    mut args: RunArgs,
    text: String,
    scene: Scene,
) -> anyhow::Result<(Plan, World)> {
    // The default scene's run leaves something to open: its results in DEFAULT_OUT, with a
    // picture. A scene file without --out writes nothing (and says how to get the files).
    let picture = args.scene.is_none() && args.output.out.is_none();
    if picture {
        args.output.out = Some(PathBuf::from(DEFAULT_OUT));
    }
    let resolved = resolve(&args.output, None)?;
    let world = scene.world();
    let end_step = args.steps.unwrap_or_else(|| scene.steps(world.dt));
    let health = Health::new(&world);
    let mut plan = resolved.into_plan(
        end_step,
        health,
        args.output.out,
        &args.progress,
        &args.pipeline,
        (scene, text),
    );
    plan.picture = picture;
    Ok((plan, world))
}

/// `clatter resume`: a run continued from a checkpoint.
pub fn resume(args: ResumeArgs) -> anyhow::Result<()> {
    let path = &args.checkpoint;
    let ckpt =
        Checkpoint::load(path).with_context(|| format!("cannot resume from {}", path.display()))?;
    let (plan, world) = resume_plan(args, ckpt)?;
    execute(plan, world)
}

/// The plan and the world of `clatter resume` from `ckpt` (read from `args.checkpoint`);
/// the MPI run makes them on every rank from the bytes rank 0 read.
pub(crate) fn resume_plan(args: ResumeArgs, ckpt: Checkpoint) -> anyhow::Result<(Plan, World)> {
    let path = &args.checkpoint;
    let stored: Option<RunState> = if ckpt.app.is_empty() {
        None
    } else {
        serde_json::from_slice(&ckpt.app).ok()
    };
    let resolved = resolve(&args.output, stored.as_ref())?;
    let (scene, world) = ckpt
        .world()
        .with_context(|| format!("cannot resume from {}", path.display()))?;
    let start = world.step_count;
    let end_step = match (args.steps, &stored) {
        (Some(n), _) => start.saturating_add(n),
        (None, Some(s)) => s.end_step,
        (None, None) => scene.steps(world.dt),
    };
    if end_step < start {
        anyhow::bail!(
            "{} is at step {start}, past the end of its run (step {end_step}); give --steps N to go on",
            path.display()
        );
    }
    let health = match stored.as_ref().and_then(|s| s.health_baseline) {
        Some(b) => Health::with_baseline(&world, b),
        None => Health::new(&world),
    };
    let mut plan = resolved.into_plan(
        end_step,
        health,
        args.output.out,
        &args.progress,
        &args.pipeline,
        (scene, ckpt.scene_text.clone()),
    );
    plan.resumed = true;
    Ok((plan, world))
}

/// Steps `world` as `plan` says: the header, the stepping loop with its outputs, then the
/// summary and the final outputs (or the blow-up report).
fn execute(plan: Plan, mut world: World) -> anyhow::Result<()> {
    let mut stepper = crate::backend::choose(plan.backend, &world, Device::Headless, plan.quiet)?;
    let start = world.step_count;
    let steps = plan.end_step - start;
    print_header(&plan, &world, start, steps);
    let mut last_good = world.clone();
    if !plan.resumed
        && let Err(b) = plan.health.check_initial(&world)
    {
        return Err(blown_up(&plan, b, &last_good, None));
    }
    let mut outputs = Outputs::create(&plan, &world, start)?;
    let ran = step_loop(
        &plan,
        &mut stepper,
        &mut world,
        &mut outputs,
        &mut last_good,
        steps,
    )?;
    let elapsed = ran.elapsed;
    let steps_per_s = steps as f64 / elapsed.max(1e-9);
    if !plan.quiet {
        print_summary(&world, &stepper, steps, elapsed, ran.max_contacts);
    }
    let Some(dir) = &plan.out else {
        if !plan.quiet {
            println!(
                "no files written: --out DIR writes final.csv, summary.json and the energy plot energy.svg (--format vtk adds ParaView frames; `clatter render` draws pictures)"
            );
        }
        return Ok(());
    };
    outputs.finish(&plan, dir, &world)?;
    let summary = serde_json::json!({
        "scene": plan.scene.source,
        // The scene text's fingerprint: a run resumed into this directory continues its
        // series only when it is the same scene's (`outputs::continues_in`).
        "scene_hash": outputs::scene_hash(&plan.scene_text),
        "bodies": world.len(),
        "walls": world.walls.len(),
        // Via the f32 shortest decimal, so a scene's dt = 2e-5 reads 2e-5, not 1.9999999494757503e-5.
        "dt": world.dt.to_string().parse::<f64>().unwrap_or(world.dt as f64),
        "steps": steps,
        "step": world.step_count,
        "resumed_from_step": plan.resumed.then_some(start),
        "simulated_time": world.time,
        "wall_time_s": elapsed,
        "steps_per_s": steps_per_s,
        "threads": rayon::current_num_threads(),
        "backend": stepper.name(),
        "contacts": world.contact_count(),
        "max_contacts": ran.max_contacts,
        "kinetic_energy": world.kinetic_energy(),
        "potential_energy": world.potential_energy(),
        "momentum": world.momentum(),
        "broad_phase_rebuilds": world.rebuilds,
        "removed": world.discharged().count,
        "removed_mass": world.discharged().mass,
    });
    let mut f = AtomicFile::create(&dir.join("summary.json"))?;
    serde_json::to_writer_pretty(f.writer(), &summary)?;
    writeln!(f.writer())?;
    f.commit()?;
    let mut written = "final.csv, summary.json, energy.csv, energy.svg".to_string();
    if !world.sinks.is_empty() {
        written.push_str(", discharge.csv");
    }
    if plan.csv && plan.output_every.is_some() {
        written.push_str(", trace.csv");
    }
    if plan.vtk {
        written.push_str(", bodies.pvd and shapes.pvd (VTK)");
        if !world.boundaries.is_empty() {
            written.push_str(", boundaries.pvd");
        }
        if plan.contacts {
            written.push_str(", contacts.pvd");
        }
    }
    if plan.checkpoint_every.is_some() {
        written.push_str(", checkpoint.ckpt");
    }
    if plan.picture {
        match crate::picture::final_picture(&world, &dir.join("final.png")) {
            Ok(()) => written.push_str(", final.png"),
            Err(e) => eprintln!("warning: no picture (final.png): {e:#}"),
        }
    }
    if !plan.quiet {
        println!("results in {}/: {written}", dir.display());
    }
    Ok(())
}

/// The scene's warnings and notes, the health warnings, and (unless quiet) the header line.
fn print_header(plan: &Plan, world: &World, start: u64, steps: u64) {
    if !plan.resumed {
        for w in &plan.scene.warnings {
            eprintln!("warning: {w}");
        }
        for n in &plan.scene.notes {
            eprintln!("note: {n}");
        }
    }
    for w in plan.health.warnings(world) {
        eprintln!("warning: {w}");
    }
    if plan.quiet {
        return;
    }
    let from = if plan.resumed {
        format!(" from step {start} (t = {:.6} s)", world.time)
    } else {
        String::new()
    };
    eprintln!(
        "{}: {} bodies, {} walls, dt = {:.3e} s, {} steps{from} ({:.4} s simulated), {} threads",
        plan.scene.source,
        world.len(),
        world.walls.len(),
        world.dt,
        steps,
        steps as f64 * world.dt as f64,
        rayon::current_num_threads()
    );
    if let Some(p) = &world.periodic {
        let ranges: Vec<String> = (0..3)
            .filter(|&k| p.axes[k])
            .map(|k| format!("{} in [{}, {})", ["x", "y", "z"][k], p.min[k], p.max[k]))
            .collect();
        eprintln!(
            "periodic: {}; output positions are wrapped into the box",
            ranges.join(", ")
        );
    }
}

/// The summary printed at the end of a run (not with `--quiet`).
fn print_summary(world: &World, stepper: &Stepper, steps: u64, elapsed: f64, max_contacts: usize) {
    let steps_per_s = steps as f64 / elapsed.max(1e-9);
    println!("simulated time   {:.6} s", world.time);
    println!("steps            {steps}");
    println!("wall time        {elapsed:.3} s");
    println!("backend          {}", stepper.name());
    println!("steps/s          {steps_per_s:.1}");
    println!("body-steps/s     {:.3e}", steps_per_s * world.len() as f64);
    println!(
        "contacts         {} (max {max_contacts})",
        world.contact_count()
    );
    println!("kinetic energy   {:.6e} J", world.kinetic_energy());
}

/// Which steps the loop stops at, and which get the full blow-up check.
struct Schedule {
    output_every: Option<u64>,
    end_step: u64,
    check_every: u64,
    energy_every: u64,
    out: bool,
    period: Option<f64>,
    half_dt: f64,
    /// The cheap checks run on the GPU (the host looks only at the steps they flag).
    gpu_checks: bool,
    /// discharge.csv is written (its rows need the removed flags at the energy sample steps).
    discharge_rows: bool,
}

impl Schedule {
    fn output_step(&self, s: u64) -> bool {
        self.output_every.is_some_and(|n| s.is_multiple_of(n))
    }

    fn full_step(&self, s: u64) -> bool {
        s.is_multiple_of(FULL_CHECK_EVERY) || self.output_step(s) || s == self.end_step
    }

    /// Whether step `s` (simulated time `t` after it) needs the state on the host.
    fn due(&self, s: u64, t: f64, next_checkpoint: Option<f64>) -> bool {
        let checkpoint = self
            .period
            .is_some_and(|p| next_checkpoint.is_some_and(|next| t + self.half_dt >= next * p));
        if self.gpu_checks {
            let discharge_row = self.discharge_rows && s.is_multiple_of(self.energy_every);
            return self.output_step(s) || s == self.end_step || checkpoint || discharge_row;
        }
        self.full_step(s)
            || s.is_multiple_of(self.check_every)
            || (self.out && s.is_multiple_of(self.energy_every))
            || checkpoint
    }
}

/// What the stepping loop measured.
struct Ran {
    /// Wall-clock seconds of the loop.
    elapsed: f64,
    max_contacts: usize,
}

/// The stepping loop: steps `world` to the end of the run with the progress bar or lines,
/// the blow-up checks and the outputs due on the way.
fn step_loop(
    plan: &Plan,
    stepper: &mut Stepper,
    world: &mut World,
    outputs: &mut Outputs,
    last_good: &mut World,
    steps: u64,
) -> anyhow::Result<Ran> {
    let start = world.step_count;
    let bar = if plan.quiet || plan.log.is_some() {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(steps)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:30.cyan/blue} {pos}/{len} steps, {msg}, eta {eta}")
            .expect("valid template"),
    );
    let started = Instant::now();
    let mut max_contacts = world.contact_count();
    // On the GPU the checks, the energy samples and the last good state stay on the device
    // (`GpuWorld::set_health`): the state comes back only for outputs, checkpoints, the last
    // step, and the steps the GPU's checks stop at for the host to look.
    let energy_on_gpu = if plan.out.is_some() {
        plan.energy_every
    } else {
        0
    };
    // CLATTER_GPU_HOST_CHECKS=1: the host checks as on the CPU (for timing comparisons).
    let host_checks = std::env::var_os(HOST_CHECKS_VAR).is_some_and(|v| v != "0");
    let watch = if host_checks {
        Watch::host_only(plan.health.clone(), plan.check_every)
    } else {
        Watch::start(
            stepper,
            world,
            plan.health.clone(),
            plan.check_every,
            energy_on_gpu,
        )
    };
    let schedule = Schedule {
        output_every: plan.output_every,
        end_step: plan.end_step,
        check_every: plan.check_every,
        energy_every: plan.energy_every,
        out: plan.out.is_some(),
        period: plan.checkpoint_every,
        half_dt: 0.5 * world.dt as f64,
        gpu_checks: stepper.is_gpu() && !host_checks,
        discharge_rows: outputs.discharge.is_some(),
    };
    let mut k = 0;
    let mut last_bar = 0;
    let mut thermo = plan
        .log
        .map(|every| Thermo::new(every, start, plan.end_step));
    // Stepping stops at every step whose state is needed here. The CPU goes one step at a
    // time anyway; the GPU runs up to that step in one go and hands the state back.
    while k < steps {
        let mut m = 1;
        let mut t = world.time + world.dt as f64;
        let stop = thermo
            .as_ref()
            .map_or(u64::MAX, |l| l.stop_before(world.step_count));
        while k + m < steps
            && world.step_count + m < stop
            && !schedule.due(world.step_count + m, t, outputs.next_checkpoint)
        {
            m += 1;
            t += world.dt as f64;
        }
        let result = stepper.step(world, m, Readback::All);
        if let (Some(g), Some(e)) = (stepper.as_gpu_mut(), &mut outputs.energy) {
            for x in g.take_samples() {
                e.record(x.step, x.time, x.kinetic, x.potential, x.momentum)?;
            }
        }
        let stats = match result {
            Ok(stats) => stats,
            Err(StepError::Sim(e)) => {
                let energy = outputs.energy.take();
                return Err(stopped(plan, stepper, &bar, last_good, energy, |good| {
                    plan.health.non_finite(good, &e)
                }));
            }
            Err(StepError::Gpu(e)) => return Err(e.into()),
        };
        k += stats.steps;
        max_contacts = max_contacts.max(stats.max_contacts);
        let s = world.step_count;
        let full = schedule.full_step(s);
        match watch.after(stepper, world, &stats, full) {
            Ok(checked) => {
                if checked && full {
                    // Without the edge memories (a cache): ~8.5 MB not copied every 100 steps.
                    world.snapshot_into(last_good);
                }
            }
            Err(WatchError::BlowUp(b)) => {
                let energy = outputs.energy.take();
                return Err(stopped(plan, stepper, &bar, last_good, energy, |_| *b));
            }
            Err(WatchError::Gpu(e)) => return Err(e.into()),
        }
        outputs.after_step(plan, world, schedule.output_step(s))?;
        if k - last_bar >= 64 || stepper.is_gpu() {
            last_bar = k;
            bar.set_position(k);
            let rate = bar.per_sec();
            bar.set_message(format!("{rate:.0} steps/s, {} contacts", stats.contacts));
        }
        if let Some(l) = &mut thermo
            && l.due(s)
        {
            l.line(sample(world, stats.contacts));
        }
    }
    bar.finish_and_clear();
    if let Some(l) = &mut thermo {
        l.finish(sample(world, world.contact_count()));
    }
    Ok(Ran {
        elapsed: started.elapsed().as_secs_f64(),
        max_contacts,
    })
}

/// A run stopped by a blow-up in the loop: clears the bar, takes the GPU's last good state
/// when it is newer, and writes the report of `blow_up(last good state)` (see [`blown_up`]).
fn stopped(
    plan: &Plan,
    stepper: &Stepper,
    bar: &ProgressBar,
    last_good: &mut World,
    energy: Option<EnergySeries>,
    blow_up: impl FnOnce(&World) -> BlowUp,
) -> anyhow::Error {
    bar.finish_and_clear();
    if let Err(e) = newer_last_good(stepper, last_good) {
        return e;
    }
    let b = blow_up(last_good);
    blown_up(plan, b, last_good, energy)
}

/// What a progress line reports about `world` (which is up to date on the host: the GPU
/// reads it back at every step the loop stops at).
fn sample(world: &World, contacts: usize) -> Sample {
    Sample {
        step: world.step_count,
        time: world.time,
        kinetic: world.kinetic_energy(),
        contacts,
    }
}

/// On the GPU, the last good state kept on the device, when it is newer than `last_good`.
fn newer_last_good(stepper: &Stepper, last_good: &mut World) -> anyhow::Result<()> {
    if let Some(g) = stepper.as_gpu() {
        let mut snap = last_good.clone();
        if g.read_last_good(&mut snap)? && snap.step_count > last_good.step_count {
            *last_good = snap;
        }
    }
    Ok(())
}

/// The error of a blown-up run: the report, and where the last good state went. Writes
/// `last_good.ckpt` and commits the energy series up to the failure; the trace being written
/// is dropped (its temporary file removed), and no final.csv or summary.json is written.
/// The MPI run (`crate::cluster`) reports its blow-ups with it too, on rank 0.
pub(crate) fn blown_up(
    plan: &Plan,
    b: BlowUp,
    last_good: &World,
    energy: Option<EnergySeries>,
) -> anyhow::Error {
    let mut msg = b.to_string();
    match &plan.out {
        Some(dir) => {
            let path = dir.join("last_good.ckpt");
            let written = std::fs::create_dir_all(dir)
                .map_err(anyhow::Error::from)
                .and_then(|_| plan.checkpoint(last_good, &path));
            match written {
                Ok(()) if last_good.step_count == 0 => {
                    msg.push_str(&format!("\nthe last good state (step 0, the initial state) is in {}", path.display()))
                }
                Ok(()) => msg.push_str(&format!(
                    "\nthe last good state (step {}, t = {:.6e} s) is in {}; `clatter resume` continues from it",
                    last_good.step_count,
                    last_good.time,
                    path.display()
                )),
                Err(e) => msg.push_str(&format!("\ncould not write the last good state to {}: {e:#}", path.display())),
            }
            if let Some(e) = energy
                && let Err(e) = e.finish(
                    Some(&dir.join("energy.svg")),
                    &format!("{}: energy and momentum (blew up)", plan.scene.source),
                )
            {
                msg.push_str(&format!("\ncould not write energy.csv: {e:#}"));
            }
        }
        None => msg.push_str("\nno checkpoint was written (no --out DIR)"),
    }
    anyhow::Error::new(BlownUp(msg))
}

#[cfg(test)]
mod tests {
    use super::RunState;

    /// The stored run state reads back bit for bit: the health baseline is a double that
    /// `serde_json` without `float_roundtrip` parsed one ulp off (3.6994718373504694 came
    /// back as 3.69947183735047), so a resumed run's final checkpoint differed from a
    /// straight run's in that byte.
    #[test]
    fn the_stored_run_state_reads_back_bit_for_bit() {
        for x in [3.6994718373504694f64, 0.1 + 0.2, 1e-300, 123456.78901234567] {
            let s = RunState {
                health_baseline: Some(x),
                checkpoint_every: Some(x),
                ..Default::default()
            };
            let back: RunState = serde_json::from_slice(&serde_json::to_vec(&s).unwrap()).unwrap();
            assert_eq!(back.health_baseline.map(f64::to_bits), Some(x.to_bits()));
            assert_eq!(back.checkpoint_every.map(f64::to_bits), Some(x.to_bits()));
        }
    }
}
