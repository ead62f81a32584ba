//! `clatter run`: load a scene (or the embedded default), step it with a progress bar, print a
//! summary, and write outputs atomically.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clatter::scene::Scene;
use indicatif::{ProgressBar, ProgressStyle};

use crate::output::{write_state_rows, AtomicFile, STATE_HEADER};

/// The embedded default scene: mixed polyhedra poured into a box.
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/default.toml");

/// Arguments of `clatter run`.
pub struct RunArgs {
    pub scene: Option<PathBuf>,
    pub out: Option<PathBuf>,
    pub trace_every: Option<u64>,
    pub steps: Option<u64>,
    pub quiet: bool,
}

/// Runs a scene to the end.
pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::parse(DEFAULT_SCENE, "<default scene>")?,
    };
    if args.trace_every == Some(0) {
        anyhow::bail!("--trace-every must be at least 1");
    }
    if args.trace_every.is_some() && args.out.is_none() {
        anyhow::bail!("--trace-every needs --out DIR (trace.csv is written there)");
    }
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let mut world = scene.world();
    let steps = args.steps.unwrap_or_else(|| scene.steps(world.dt));
    let tc = world.shortest_contact_duration();
    if tc.is_finite() && (world.dt as f64) > tc / 10.0 {
        eprintln!(
            "warning: dt = {:.3e} s is more than 1/10 of the shortest contact duration {:.3e} s: contacts will be poorly resolved or blow up",
            world.dt, tc
        );
    }
    if !args.quiet {
        eprintln!(
            "{}: {} bodies, {} walls, dt = {:.3e} s, {} steps ({:.4} s simulated), {} threads",
            scene.source,
            world.len(),
            world.walls.len(),
            world.dt,
            steps,
            steps as f64 * world.dt as f64,
            rayon::current_num_threads()
        );
    }
    let mut trace = None;
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
        if let Some(every) = args.trace_every {
            let mut f = AtomicFile::create(&dir.join("trace.csv"))?;
            writeln!(f.writer(), "step,time,{STATE_HEADER}")?;
            write_state_rows(f.writer(), &world, "0,0,")?;
            trace = Some((f, every));
        }
    }
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(steps) };
    bar.set_style(
        ProgressStyle::with_template("{bar:40.cyan/blue} {pos}/{len} steps {per_sec} eta {eta} {msg}")
            .expect("valid template"),
    );
    let start = Instant::now();
    let mut max_contacts = 0usize;
    let mut last_contacts = 0usize;
    for s in 0..steps {
        let stats = world.step()?;
        last_contacts = stats.contacts;
        max_contacts = max_contacts.max(stats.contacts);
        if let Some((f, every)) = &mut trace
            && (s + 1) % *every == 0
        {
            let prefix = format!("{},{},", world.step_count, world.time);
            write_state_rows(f.writer(), &world, &prefix)?;
        }
        if s % 64 == 0 {
            bar.set_position(s);
            bar.set_message(format!("{} contacts", stats.contacts));
        }
    }
    bar.finish_and_clear();
    let elapsed = start.elapsed().as_secs_f64();
    let ke = world.kinetic_energy();
    let steps_per_s = steps as f64 / elapsed.max(1e-9);
    if !args.quiet {
        println!("simulated time   {:.6} s", world.time);
        println!("steps            {steps}");
        println!("wall time        {elapsed:.3} s");
        println!("steps/s          {steps_per_s:.1}");
        println!("body-steps/s     {:.3e}", steps_per_s * world.len() as f64);
        println!("contacts         {last_contacts} (max {max_contacts})");
        println!("kinetic energy   {ke:.6e} J");
    }
    if let Some(dir) = &args.out {
        if let Some((f, _)) = trace {
            f.commit()?;
        }
        let mut f = AtomicFile::create(&dir.join("final.csv"))?;
        writeln!(f.writer(), "{STATE_HEADER}")?;
        write_state_rows(f.writer(), &world, "")?;
        f.commit()?;
        let momentum = world.momentum();
        let summary = serde_json::json!({
            "scene": scene.source,
            "bodies": world.len(),
            "walls": world.walls.len(),
            // Via the f32 shortest decimal, so a scene's dt = 2e-5 reads 2e-5, not 1.9999999494757503e-5.
            "dt": world.dt.to_string().parse::<f64>().unwrap_or(world.dt as f64),
            "steps": steps,
            "simulated_time": world.time,
            "wall_time_s": elapsed,
            "steps_per_s": steps_per_s,
            "threads": rayon::current_num_threads(),
            "contacts": last_contacts,
            "max_contacts": max_contacts,
            "kinetic_energy": ke,
            "potential_energy": world.potential_energy(),
            "momentum": momentum,
            "broad_phase_rebuilds": world.rebuilds,
        });
        let mut f = AtomicFile::create(&dir.join("summary.json"))?;
        serde_json::to_writer_pretty(f.writer(), &summary)?;
        writeln!(f.writer())?;
        f.commit()?;
    }
    Ok(())
}
