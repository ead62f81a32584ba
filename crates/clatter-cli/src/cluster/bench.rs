//! `mpirun -np N clatter bench` (cargo feature `mpi`): the timed steps decomposed over the
//! ranks, as `clatter run` steps a scene on them ([`clatter::domain::Domain`]).
//!
//! Every rank builds the same start (the lattice, the poured pile's start, or the scene
//! rank 0 reads and broadcasts); a poured pile is settled or taken from the cache by rank 0
//! alone and broadcast as checkpoint bytes. The settle steps (the warm-up) and the timed
//! steps run on all ranks, each with its `--threads` threads; the timing is between two
//! barriers, so it is the slowest rank's. Rank 0 gathers the whole pile after the timed
//! steps and prints the row: its contacts, pairs, rebuilds and kinetic energy are one
//! process's (bitwise), only the timings differ. The GPU pipeline, `--render` and
//! `--profile` are refused (one process only).

use std::time::Instant;

use clatter::domain::{Comm, Domain};
use clatter::pile::PileParams;
use clatter::{Checkpoint, World};
use mpi::traits::*;

use super::mpi::{MpiComm, StepCounts};
use crate::backend::Backend;
use crate::bench::{self, BenchArgs, Row};
use crate::scene_io::load_scene;

/// `clatter bench` on `comm`'s ranks (collective); errors are agreed on by all ranks.
pub fn bench(comm: &MpiComm, args: BenchArgs) -> anyhow::Result<()> {
    let (rank, ranks) = (comm.rank(), comm.size());
    comm.agree(refused(&args))?;
    // The scene of --scene: rank 0 reads it, every rank parses rank 0's text.
    let plan = bench::plan(&args, |path| {
        let loaded = if rank == 0 {
            load_scene(path).map(|(text, scene)| (text, scene.source))
        } else {
            Ok((String::new(), String::new()))
        };
        let (text, source) = comm.agree(loaded)?;
        let text = String::from_utf8_lossy(&comm.broadcast(text.into_bytes())).into_owned();
        let source = String::from_utf8_lossy(&comm.broadcast(source.into_bytes())).into_owned();
        let scene =
            comm.agree(clatter::scene::Scene::parse(&text, &source).map_err(anyhow::Error::from))?;
        Ok(scene.world())
    });
    let plan = comm.agree(plan)?;
    if let Some(&n) = plan.counts.iter().find(|&&n| n < ranks) {
        comm.agree::<()>(Err(anyhow::anyhow!(
            "{ranks} MPI ranks for {n} bodies: use at most one rank per body (mpirun -np {n})"
        )))?;
    }
    let params = PileParams::default();
    if rank == 0 && !args.json {
        bench::print_header(&args, None, plan.name, ranks);
    }
    let mut rows = Vec::new();
    for &n in &plan.counts {
        let world = start(comm, &plan, n, &params, &args)?;
        // The row is rank 0's (the other ranks get `None`).
        if let Some(row) = time(comm, world, &plan, &params, &args)? {
            if !args.json {
                bench::print_row(&row);
            }
            rows.push(row);
        }
    }
    if rank == 0 && args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    }
    Ok(())
}

/// What `bench` does not do on several ranks (the same verdict on every rank).
fn refused(args: &BenchArgs) -> anyhow::Result<()> {
    if args.pipeline.backend == Backend::Gpu {
        anyhow::bail!(
            "--backend gpu: `clatter bench` on MPI ranks times the CPU pipeline (one GPU per rank is planned, docs/parallel.md); time the GPU without mpirun"
        );
    }
    if args.render || args.profile {
        anyhow::bail!(
            "--render and --profile time the GPU on one process: run `clatter bench` without mpirun for them"
        );
    }
    Ok(())
}

/// The pile of `n` bodies on every rank, before its settle steps: a poured pile is rank 0's
/// (from the cache, or settled there and cached), sent as checkpoint bytes; a lattice or a
/// scene every rank builds itself.
fn start(
    comm: &MpiComm,
    plan: &bench::Plan,
    n: usize,
    params: &PileParams,
    args: &BenchArgs,
) -> anyhow::Result<World> {
    let fresh = plan.fresh(n, params);
    if !plan.poured {
        return Ok(fresh);
    }
    let bytes = if comm.rank() == 0 {
        bench::settled_pile(plan, n, params, args)
            .map(|w| w.checkpoint_bytes("clatter bench poured pile", "", &[]))
    } else {
        Ok(Vec::new())
    };
    let bytes = comm.broadcast(comm.agree(bytes)?);
    let restored = Checkpoint::from_bytes(&bytes)
        .map_err(anyhow::Error::from)
        .and_then(|c| Ok(c.restore_onto(fresh)?));
    comm.agree(restored)
}

/// The settle steps and the timed steps of one row on all ranks; the row on rank 0, which
/// alone gathers the pile (`None` on the other ranks, which keep only their shares).
fn time(
    comm: &MpiComm,
    world: World,
    plan: &bench::Plan,
    params: &PileParams,
    args: &BenchArgs,
) -> anyhow::Result<Option<Row>> {
    let (rank, ranks) = (comm.rank(), comm.size());
    let n = world.len();
    let mut domain = Domain::new(world, rank, ranks);
    let stepped = |domain: &mut Domain, steps: u64, counts: &mut StepCounts, when| {
        for _ in 0..steps {
            match domain.step(comm) {
                Ok(s) => counts.push(s.contacts),
                // Every rank has the same error: rank 0 says it.
                Err(e) if rank == 0 => {
                    return Err(bench::blew_up(when)(clatter_backend::StepError::Sim(e)));
                }
                Err(_) => return Err(super::Quiet(1).into()),
            }
        }
        Ok(())
    };
    let mut settle = StepCounts::default();
    stepped(&mut domain, args.settle, &mut settle, "settling")?;
    if let Some(dir) = &args.emit_lammps {
        let written = match domain.gather_root(comm) {
            Some(whole) => bench::write_lammps(dir, &whole, params, args.steps),
            None => Ok(()),
        };
        comm.agree(written)?;
    }
    let rebuilds_before = domain.local().rebuilds;
    let mut counts = StepCounts::default();
    // The slowest rank's wall time: every rank starts together and waits for the last.
    comm.world.barrier();
    let started = Instant::now();
    stepped(&mut domain, args.steps, &mut counts, "timing")?;
    comm.world.barrier();
    let secs = started.elapsed().as_secs_f64();
    // Touching contacts per step over all ranks, summed as one process sums them.
    let contacts: usize = counts.totals(comm).iter().sum();
    report_loads(comm, &domain);
    let Some(whole) = domain.gather_root(comm) else {
        return Ok(None);
    };
    let sps = args.steps as f64 / secs;
    Ok(Some(Row {
        shape: plan.name,
        bodies: n,
        steps: args.steps,
        steps_per_s: sps,
        body_steps_per_s: sps * n as f64,
        contacts_per_body: 2.0 * (contacts as f64 / args.steps as f64) / n as f64,
        pairs_per_body: whole.contact_state().pairs.len() as f64 / n as f64,
        pile: plan.pile(args),
        ms_per_step: 1e3 * secs / args.steps as f64,
        threads: rayon::current_num_threads(),
        ranks,
        dt: whole.dt,
        rebuilds: whole.rebuilds - rebuilds_before,
        kinetic_energy: whole.kinetic_energy(),
        backend: format!("cpu on {ranks} MPI ranks"),
        frames_per_s: None,
        kernels: Vec::new(),
        pairs: None,
        copy_bandwidth_gb_s: None,
    }))
}

/// Rank 0 says on stderr how many bodies each rank owns and holds as ghosts after the
/// timed steps (collective): the balance of the decomposition and its communication volume
/// (ghost states are what is sent every step), whatever the load of the machine; and each
/// rank's resident memory then (before the pile is gathered for the row), in MiB, where the
/// system says it (`VmRSS` of /proc/self/status; 0 elsewhere).
fn report_loads(comm: &MpiComm, domain: &Domain) {
    let mut mine = Vec::with_capacity(24);
    mine.extend((domain.owned() as u64).to_le_bytes());
    mine.extend((domain.ghosts() as u64).to_le_bytes());
    mine.extend(resident_kib().to_le_bytes());
    let all = comm.all_gather(&mine);
    if comm.rank() == 0 {
        let word = |m: &[u8], k: usize| {
            m.get(8 * k..8 * k + 8)
                .and_then(|b| b.try_into().ok())
                .map_or(0, u64::from_le_bytes)
        };
        let list = |k: usize| {
            all.iter()
                .map(|m| word(m, k).to_string())
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mib = all
            .iter()
            .map(|m| format!("{:.1}", word(m, 2) as f64 / 1024.0))
            .collect::<Vec<_>>()
            .join(" ");
        eprintln!(
            "# per rank after the timed steps: owned {}; ghosts {}; resident MiB {mib}",
            list(0),
            list(1)
        );
    }
}

/// This process's resident memory in KiB (`VmRSS` of /proc/self/status), 0 where there is
/// no such file.
fn resident_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmRSS:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        })
        .unwrap_or(0)
}
