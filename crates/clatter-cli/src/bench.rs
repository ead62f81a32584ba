//! `clatter bench`: steps/s against the number of bodies on a settled pile, with `--render` the
//! frames/s of a step plus an offscreen 1280x720 frame, and the LAMMPS input for the same
//! sphere pile (`scripts/bench-lammps.sh` runs both and prints the ratio).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clatter::pile::{PileParams, PileShape, pile, poured, settled_desc, tiled};
use clatter::{World, WorldDesc};
use clatter_backend::{Device, Readback, StepError, Stepper};

use clap::ValueEnum;

use crate::args::Pipeline;
use crate::backend::Backend;

/// Shape of the benchmark pile.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum BenchShape {
    /// Spheres only.
    Sphere,
    /// Cubes only.
    Cube,
    /// Tetrahedra, cubes, octahedra, dodecahedra, icosahedra and spheres in turn.
    Mixed,
}

/// How the benchmark pile is made.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum PileArg {
    /// Stacked on a cubic lattice, touching.
    Lattice,
    /// Rained into the box and settled until at rest; the settled pile is cached (see
    /// `--pile-cache`), so the settle runs once per machine.
    Poured,
}

/// Arguments of `clatter bench`.
#[derive(clap::Args, Debug)]
#[command(
    mut_arg("threads", |a| a.help("Worker threads (default: all cores)")),
    mut_arg("backend", |a| a
        .default_value("cpu")
        .help("Which pipeline to time: gpu, cpu, or auto (see `clatter run --help`). GPU times are wall clock around work that ends with a synchronising read, after the settle steps as warm-up")),
)]
pub struct BenchArgs {
    /// Shape of the bodies.
    #[arg(long, value_enum, default_value = "sphere")]
    pub shape: BenchShape,
    /// Comma-separated body counts.
    #[arg(long, value_delimiter = ',', default_value = "1024,4096,16384,65536")]
    pub bodies: Vec<usize>,
    /// Timed steps per body count.
    #[arg(long, default_value_t = 200)]
    pub steps: u64,
    /// Untimed steps that let the pile settle first.
    #[arg(long, default_value_t = 1000)]
    pub settle: u64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// `--threads` and `--backend` (default cpu here).
    #[command(flatten)]
    pub pipeline: Pipeline,
    /// Also write the settled sphere pile as a LAMMPS data file and input script into DIR
    /// (for scripts/bench-lammps.sh); only with --shape sphere and one body count.
    #[arg(long, value_name = "DIR")]
    pub emit_lammps: Option<PathBuf>,
    /// Also time steps with an offscreen 1280x720 render after each (the "fps with
    /// rendering" column; needs a GPU adapter, lavapipe/llvmpipe will do).
    #[arg(long)]
    pub render: bool,
    /// Frames timed per body count with --render.
    #[arg(long, value_name = "N", default_value_t = 20)]
    pub render_frames: u64,
    /// With --backend gpu: also time every kernel alone with timestamp queries and print
    /// milliseconds per step per kernel (the steps/s column is measured before, without).
    #[arg(long)]
    pub profile: bool,
    /// Steps timed per body count with --profile.
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub profile_steps: u64,
    /// Time a scene file instead of the piles (`default`: the embedded default scene);
    /// one row, the scene's bodies, after --settle steps. --shape and --bodies are
    /// ignored.
    #[arg(long, value_name = "FILE|default")]
    pub scene: Option<PathBuf>,
    /// How the pile is made: poured (rained into the box and settled, cached) or lattice
    /// (stacked, touching).
    #[arg(long, value_enum, default_value = "poured")]
    pub pile: PileArg,
    /// Where settled poured piles are cached (default: $CLATTER_PILE_CACHE, else
    /// $XDG_CACHE_HOME/clatter/piles, else ~/.cache/clatter/piles).
    #[arg(long, value_name = "DIR")]
    pub pile_cache: Option<PathBuf>,
    /// With --pile poured: lay the settled pile of each --bodies count K times side by side
    /// on one floor (a grid of tiles, the side walls between them left out), so that a row
    /// times K x the bodies without pouring them all: e.g. --bodies 80000 --tiles 13 times
    /// 1,040,000 bodies. The tiles start without contact history; --settle steps follow.
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub tiles: u32,
}

impl BenchArgs {
    /// With `--render`: the frames to time per body count (one step plus an offscreen render
    /// each).
    fn timed_frames(&self) -> Option<u64> {
        self.render.then_some(self.render_frames)
    }

    /// With `--profile`: the steps over which each GPU kernel is timed with timestamp
    /// queries (milliseconds per step per kernel).
    fn profiled_steps(&self) -> Option<u64> {
        self.profile.then_some(self.profile_steps)
    }
}

/// The environment variable that names the poured-pile cache directory.
pub const PILE_CACHE_VAR: &str = "CLATTER_PILE_CACHE";

/// The seed of the poured piles (positions jitter, orientations, speeds).
pub const POUR_SEED: u64 = 7;

/// A poured pile is settled when its kinetic energy is below this fraction of the energy of
/// lifting every body by its radius (`sum m g r`): a mean speed of about 1.4 cm/s for the
/// default 1 cm bodies.
pub const SETTLED_ENERGY: f64 = 1.0e-3;

/// A poured pile stops settling after this many steps even if it is not at rest (with a
/// warning; it is cached all the same).
pub const MAX_SETTLE_STEPS: u64 = 400_000;

/// Bump when the poured pile, its settling or the checkpoint format changes, so that old
/// cached piles are not used (2: checkpoint version 4, f64 positions). Not bumped for checkpoint
/// versions 5 and 6, which read version-4 piles with the same results.
const PILE_CACHE_VERSION: u32 = 2;

/// Where settled poured piles are cached: `--pile-cache DIR`, else `$CLATTER_PILE_CACHE`,
/// else `$XDG_CACHE_HOME/clatter/piles`, else `~/.cache/clatter/piles`.
pub fn pile_cache_dir(flag: Option<&Path>) -> anyhow::Result<PathBuf> {
    if let Some(dir) = flag {
        return Ok(dir.to_path_buf());
    }
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(dir) = env(PILE_CACHE_VAR) {
        return Ok(dir);
    }
    if let Some(dir) = env("XDG_CACHE_HOME") {
        return Ok(dir.join("clatter").join("piles"));
    }
    match env("HOME") {
        Some(home) => Ok(home.join(".cache").join("clatter").join("piles")),
        None => anyhow::bail!(
            "no cache directory for the poured pile: set --pile-cache DIR or {PILE_CACHE_VAR}"
        ),
    }
}

/// The cache file name of a poured pile: every parameter that changes it.
fn pile_key(name: &str, n: usize, p: &PileParams) -> String {
    format!(
        "{name}-n{n}-seed{POUR_SEED}-r{}-rho{}-k{}-e{}-mu{}-v{PILE_CACHE_VERSION}.ckpt",
        p.radius, p.density, p.stiffness, p.restitution, p.friction
    )
}

/// The poured pile of `n` bodies, settled: from the cache when it is there, else rained into
/// the box and stepped (on `backend`) until its kinetic energy is below [`SETTLED_ENERGY`],
/// with progress lines on stderr, then cached.
fn poured_pile(
    shape: PileShape,
    name: &str,
    n: usize,
    params: &PileParams,
    args: &BenchArgs,
    quiet: bool,
) -> anyhow::Result<World> {
    let dir = pile_cache_dir(args.pile_cache.as_deref())?;
    let path = dir.join(pile_key(name, n, params));
    let fresh = World::new(poured(shape, n, params, POUR_SEED));
    if path.exists() {
        let loaded = clatter::Checkpoint::load(&path)
            .map_err(anyhow::Error::from)
            .and_then(|c| Ok(c.restore_onto(fresh.clone())?));
        match loaded {
            Ok(world) => {
                eprintln!("# poured pile: reusing {}", path.display());
                return Ok(world);
            }
            Err(e) => eprintln!(
                "warning: cannot use the cached pile {} ({e:#}); settling it again",
                path.display()
            ),
        }
    }
    let mut world = fresh;
    let mut stepper =
        crate::backend::choose(args.pipeline.backend, &world, Device::Headless, true)?;
    let g = world.gravity.length() as f64;
    let target = SETTLED_ENERGY
        * world
            .consts
            .mass
            .iter()
            .zip(&world.consts.radius)
            .map(|(&m, &r)| m as f64 * g * r as f64)
            .sum::<f64>();
    eprintln!(
        "# poured pile: settling {n} {name} bodies on the {} (once; cached in {})",
        stepper.name(),
        dir.display()
    );
    let started = Instant::now();
    let mut last_line = Instant::now();
    let chunk = 500;
    let mut steps = 0;
    loop {
        stepper
            .step(&mut world, chunk, Readback::Bodies)
            .map_err(blew_up("settling the poured pile"))?;
        steps += chunk;
        let ke = world.kinetic_energy();
        let done = ke < target;
        if done || last_line.elapsed().as_secs_f64() > 2.0 || steps >= MAX_SETTLE_STEPS {
            last_line = Instant::now();
            if !quiet || done {
                eprintln!(
                    "#   step {steps}: kinetic energy {:.3e} J per body (at rest below {:.3e}), {:.0} s",
                    ke / n as f64,
                    target / n as f64,
                    started.elapsed().as_secs_f64()
                );
            }
        }
        if done {
            break;
        }
        if steps >= MAX_SETTLE_STEPS {
            eprintln!(
                "warning: the poured pile is not at rest after {steps} steps; caching it as it is"
            );
            break;
        }
    }
    stepper.sync(&mut world)?;
    // The pile is settled: a cache that cannot be written costs the next run the settling,
    // not this run its result (a warning, not an error).
    let bytes = world.checkpoint_bytes(&format!("clatter bench poured pile {name}"), "", &[]);
    let cached = std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create the pile cache {}", dir.display()))
        .and_then(|()| {
            clatter::checkpoint::write_atomic(&path, &bytes)
                .with_context(|| format!("cannot write {}", path.display()))
        });
    match cached {
        Ok(()) => eprintln!(
            "# poured pile: settled in {steps} steps ({:.0} s), cached in {}",
            started.elapsed().as_secs_f64(),
            path.display()
        ),
        Err(e) => eprintln!(
            "warning: {e:#}; the pile settled in {steps} steps ({:.0} s) is used without a cache",
            started.elapsed().as_secs_f64()
        ),
    }
    Ok(world)
}

/// Size of the frames timed by `--render`.
pub const RENDER_SIZE: (u32, u32) = (1280, 720);

/// One row of the table.
#[derive(serde::Serialize)]
pub(crate) struct Row {
    pub shape: &'static str,
    pub bodies: usize,
    pub steps: u64,
    pub steps_per_s: f64,
    pub body_steps_per_s: f64,
    /// Twice the mean touching contacts over the timed steps, per body.
    pub contacts_per_body: f64,
    /// Candidate pairs (the Verlet list) per body after the timed steps.
    pub pairs_per_body: f64,
    /// How the pile was made: `lattice`, `poured`, or `scene` (`--scene`).
    pub pile: &'static str,
    pub ms_per_step: f64,
    /// Worker threads (per rank under mpirun).
    pub threads: usize,
    /// MPI ranks (1 without mpirun).
    pub ranks: usize,
    pub dt: f32,
    pub rebuilds: u64,
    /// The whole pile's kinetic energy after the timed steps, J (the same bits on any
    /// number of threads or ranks: a check that the timed steps were the same steps).
    pub kinetic_energy: f64,
    pub backend: String,
    /// With `--render`: frames per second of one step plus an offscreen 1280x720 frame
    /// (upload, draw, wait for the GPU; no read-back).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frames_per_s: Option<f64>,
    /// With `--profile` (GPU): milliseconds per step of each kernel, timed alone.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub kernels: Vec<(String, f64)>,
    /// With `--profile`: candidate pairs in the list after the timed steps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pairs: Option<usize>,
    /// With `--profile`: the device's copy-kernel bandwidth (read + write), GB/s, for the
    /// bandwidth floor of the step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub copy_bandwidth_gb_s: Option<f64>,
    /// With `--profile` (GPU, scenes with polyhedra): what the full narrow phase ran in the
    /// last step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub full_phase: Option<FullPhaseRow>,
}

/// [`clatter_gpu::FullPhase`] in the bench's JSON: the pairs the GPU's full narrow phase ran
/// in the last step, by path.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct FullPhaseRow {
    /// Pairs with a sphere body.
    pub with_sphere: u32,
    /// Polyhedron pairs through the whole separating-axis test.
    pub full_tests: u32,
    /// Polyhedron pairs at a remembered reference face.
    pub remembered_faces: u32,
    /// Polyhedron pairs at a remembered edge contact.
    pub remembered_edges: u32,
}

impl From<clatter_gpu::FullPhase> for FullPhaseRow {
    fn from(f: clatter_gpu::FullPhase) -> Self {
        FullPhaseRow {
            with_sphere: f.with_sphere,
            full_tests: f.full_tests,
            remembered_faces: f.remembered_faces,
            remembered_edges: f.remembered_edges,
        }
    }
}

/// What `clatter bench` was asked to time, checked: the pile's shape and name, the scene's
/// world (with `--scene`), the body counts.
pub(crate) struct Plan {
    pub shape: PileShape,
    pub name: &'static str,
    pub scene_world: Option<World>,
    pub counts: Vec<usize>,
    /// The rows are poured piles (settled, cached).
    pub poured: bool,
    /// Copies of each poured pile side by side (`--tiles`; 1 for one pile).
    pub tiles: usize,
}

impl Plan {
    /// How the pile of each row was made (the table's `pile` column).
    pub fn pile(&self, args: &BenchArgs) -> &'static str {
        match (&self.scene_world, args.pile) {
            (Some(_), _) => "scene",
            (None, PileArg::Lattice) => "lattice",
            (None, PileArg::Poured) => "poured",
        }
    }

    /// The world of `n` bodies (`n` times the tiles) before the pile is poured or settled:
    /// the scene's, the lattice, or the poured pile's start (the same on every rank).
    pub fn fresh(&self, n: usize, params: &PileParams) -> World {
        match (&self.scene_world, self.poured) {
            (Some(w), _) => w.clone(),
            (None, false) => World::new(pile(self.shape, n, params)),
            (None, true) => World::new(self.tile(poured(self.shape, n, params, POUR_SEED))),
        }
    }

    /// `desc` laid out [`Plan::tiles`] times ([`clatter::pile::tiled`]).
    fn tile(&self, desc: WorldDesc) -> WorldDesc {
        // `plan` checked that the tiles go with a poured pile, whose box `tiled` needs.
        tiled(&desc, self.tiles).unwrap_or(desc)
    }
}

/// Checks the arguments (what one process and the ranks both refuse) and reads the scene of
/// `--scene` with `load` (which reads the file, or on MPI ranks takes rank 0's text).
pub(crate) fn plan(
    args: &BenchArgs,
    load: impl FnOnce(Option<&Path>) -> anyhow::Result<World>,
) -> anyhow::Result<Plan> {
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
    if args.emit_lammps.is_some() && args.scene.is_some() {
        anyhow::bail!(
            "--emit-lammps writes the bench's own sphere pile for LAMMPS: it cannot be combined with --scene"
        );
    }
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
            Some(load(path)?)
        }
        None => None,
    };
    let (name, counts) = match &scene_world {
        Some(w) => ("scene", vec![w.len()]),
        None => (name, args.bodies.clone()),
    };
    if args.timed_frames() == Some(0) {
        anyhow::bail!("--render-frames must be at least 1");
    }
    if args.profiled_steps() == Some(0) {
        anyhow::bail!("--profile-steps must be at least 1");
    }
    if args.profiled_steps().is_some() && args.pipeline.backend == Backend::Cpu {
        anyhow::bail!("--profile times GPU kernels: use it with --backend gpu");
    }
    let poured = args.scene.is_none() && args.pile == PileArg::Poured;
    if args.tiles > 1 && !poured {
        anyhow::bail!(
            "--tiles lays out copies of a poured pile: use it with --pile poured, without --scene"
        );
    }
    Ok(Plan {
        shape,
        name,
        poured,
        tiles: args.tiles as usize,
        scene_world,
        counts,
    })
}

/// The settled poured pile of `n` bodies on the plan's shape (from the cache, or settled
/// now and cached).
pub(crate) fn settled_pile(
    plan: &Plan,
    n: usize,
    params: &PileParams,
    args: &BenchArgs,
) -> anyhow::Result<World> {
    let pile = poured_pile(plan.shape, plan.name, n, params, args, args.json)?;
    if plan.tiles == 1 {
        return Ok(pile);
    }
    let desc = settled_desc(&poured(plan.shape, n, params, POUR_SEED), &pile);
    if !args.json {
        eprintln!(
            "# poured pile: {} tiles of {n} bodies side by side, {} bodies",
            plan.tiles,
            n * plan.tiles
        );
    }
    Ok(World::new(plan.tile(desc)))
}

/// Runs the benchmark for every body count.
pub fn bench(args: BenchArgs) -> anyhow::Result<()> {
    let plan = plan(&args, |path| {
        Ok(crate::scene_io::load_scene(path)?.1.world())
    })?;
    let (name, counts) = (plan.name, plan.counts.clone());
    // One device for the simulation and the renderer, so that with the GPU backend the frames
    // are drawn straight from the simulation's body buffer.
    let gpu = match args.timed_frames() {
        Some(_) => Some(std::sync::Arc::new(
            clatter_gpu::GpuContext::new().context("bench --render")?,
        )),
        None => None,
    };
    let params = PileParams::default();
    if !args.json {
        print_header(&args, gpu.as_deref(), name, 1);
    }
    let mut rows = Vec::new();
    let mut bandwidth: Option<f64> = None;
    for &n in &counts {
        let quiet = args.json || !rows.is_empty();
        let mut world = if plan.poured {
            settled_pile(&plan, n, &params, &args)?
        } else {
            plan.fresh(n, &params)
        };
        // With --tiles, the row times all the tiles' bodies.
        let n = world.len();
        let device = match &gpu {
            Some(ctx) => Device::Shared(ctx.clone()),
            None => Device::Headless,
        };
        let mut stepper = crate::backend::choose(args.pipeline.backend, &world, device, quiet)?;
        if args.profiled_steps().is_some() && !stepper.is_gpu() {
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
        let pairs_now = match stepper.as_gpu() {
            Some(g) => g.pairs(),
            None => world.contact_state().pairs.len(),
        };
        stepper.sync(&mut world)?;
        let kinetic_energy = world.kinetic_energy();
        let mut kernels = Vec::new();
        let mut pairs = None;
        let mut full_phase = None;
        if let (Some(steps), Some(gpu)) = (args.profiled_steps(), stepper.as_gpu_mut()) {
            kernels = gpu.profile(steps)?;
            pairs = Some(gpu.pairs());
            full_phase = gpu.full_phase().map(FullPhaseRow::from);
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
        let frames_per_s = match (&gpu, args.timed_frames()) {
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
            pairs_per_body: pairs_now as f64 / n as f64,
            pile: plan.pile(&args),
            ms_per_step: 1e3 * secs / args.steps as f64,
            threads: rayon::current_num_threads(),
            ranks: 1,
            dt: world.dt,
            rebuilds,
            kinetic_energy,
            backend,
            frames_per_s,
            kernels,
            pairs,
            copy_bandwidth_gb_s: args.profiled_steps().and(bandwidth),
            full_phase,
        };
        if !args.json {
            print_row(&row);
        }
        rows.push(row);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    }
    Ok(())
}

/// The table's header lines (not with `--json`): the renderer, what is timed (on how many
/// MPI ranks), the columns.
pub(crate) fn print_header(
    args: &BenchArgs,
    gpu: Option<&clatter_gpu::GpuContext>,
    name: &str,
    ranks: usize,
) {
    if let Some(ctx) = gpu {
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
        None => format!(
            "{name} pile ({})",
            match args.pile {
                PileArg::Lattice => "lattice",
                PileArg::Poured => "poured",
            }
        ),
    };
    let threads = rayon::current_num_threads();
    let workers = if ranks > 1 {
        format!("{ranks} MPI ranks x {threads} threads")
    } else {
        format!("{threads} threads")
    };
    println!(
        "# clatter bench: {what}, {workers}, {} settle + {} timed steps",
        args.settle, args.steps
    );
    print!(
        "{:>10} {:>12} {:>16} {:>14} {:>11} {:>10} {:>9}",
        "bodies", "steps/s", "body-steps/s", "contacts/body", "pairs/body", "ms/step", "rebuilds"
    );
    if gpu.is_some() {
        print!(" {:>10}", "frames/s");
    }
    println!("  backend");
}

/// One row of the table (not with `--json`), with the profile's lines under it.
pub(crate) fn print_row(row: &Row) {
    print!(
        "{:>10} {:>12.1} {:>16.3e} {:>14.2} {:>11.2} {:>10.3} {:>9}",
        row.bodies,
        row.steps_per_s,
        row.body_steps_per_s,
        row.contacts_per_body,
        row.pairs_per_body,
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
    if let Some(f) = row.full_phase {
        println!(
            "#   full narrow phase, last step: {} pairs with a sphere; polyhedron pairs: {} full tests, {} remembered faces, {} remembered edge contacts",
            f.with_sphere, f.full_tests, f.remembered_faces, f.remembered_edges
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
pub(crate) fn blew_up(when: &'static str) -> impl Fn(StepError) -> anyhow::Error {
    move |e| match e {
        StepError::Sim(e) => {
            anyhow::Error::new(e).context(format!("the pile blew up while {when}"))
        }
        StepError::Gpu(e) => e.into(),
    }
}

/// Writes `pile.data` and `in.pile` for LAMMPS (`pair_style gran/hooke/history`) with the same
/// bodies, walls, contact law parameters, time step and step count.
pub(crate) fn write_lammps(
    dir: &Path,
    world: &World,
    p: &PileParams,
    steps: u64,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut lo = glam::Vec3::splat(f32::INFINITY);
    let mut hi = glam::Vec3::splat(f32::NEG_INFINITY);
    for x in world.state.position.iter().map(|x| x.as_vec3()) {
        lo = lo.min(x);
        hi = hi.max(x);
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
