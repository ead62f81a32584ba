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
//! `--profile` are refused (one process only). Rank 0 also says, per rank, the time of its own
//! steps and of the collectives within them ([`Timed`]).

use std::cell::Cell;
use std::time::{Duration, Instant};

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
            "{ranks} MPI ranks for {n} {}: a benchmark on ranks wants at most one rank per body (mpirun -np {n})",
            if n == 1 { "body" } else { "bodies" }
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
    let mut domain = Domain::with_balance(world, rank, ranks, super::mpi::balance(rank));
    domain.set_overlap(super::mpi::overlap());
    let stepped =
        |domain: &mut Domain, on: &dyn Comm, steps: u64, counts: &mut StepCounts, when| {
            for _ in 0..steps {
                match domain.step(on) {
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
    stepped(&mut domain, comm, args.settle, &mut settle, "settling")?;
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
    // Each rank also times its own steps and the collectives within them.
    let timed = Timed::new(comm);
    comm.world.barrier();
    let started = Instant::now();
    stepped(&mut domain, &timed, args.steps, &mut counts, "timing")?;
    let own = started.elapsed();
    comm.world.barrier();
    let secs = started.elapsed().as_secs_f64();
    // Touching contacts per step over all ranks, summed as one process sums them.
    let contacts: usize = counts.totals(comm).iter().sum();
    report_loads(comm, &domain);
    report_times(comm, &timed, own, args.steps);
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
        full_phase: None,
    }))
}

/// Rank 0 says on stderr how many bodies each rank owns and holds as ghosts after the
/// timed steps (collective): the balance of the decomposition and its communication volume
/// (ghost states are what is sent every step), whatever the load of the machine; its
/// candidate pairs and its estimated work ([`Domain::work`], what the default balance
/// evens out) and the balance used (`CLATTER_MPI_BALANCE`); and each
/// rank's resident memory then (before the pile is gathered for the row), in MiB, where the
/// system says it (`VmRSS` of /proc/self/status; 0 elsewhere).
fn report_loads(comm: &MpiComm, domain: &Domain) {
    let mut mine = Vec::with_capacity(80);
    mine.extend((domain.owned() as u64).to_le_bytes());
    mine.extend((domain.ghosts() as u64).to_le_bytes());
    mine.extend(resident_kib().to_le_bytes());
    // The overlap of the ghost states' exchange (over the settle and the timed steps).
    let o = domain.overlapped();
    for w in [
        o.steps,
        o.waited,
        o.fallbacks,
        o.interior_pairs,
        o.ghost_pairs,
        domain.pairs() as u64,
        domain.work(),
    ] {
        mine.extend(w.to_le_bytes());
    }
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
            "# per rank after the timed steps: owned {}; ghosts {}; resident MiB {mib}; pairs {}; estimated work ({:?} balance) {}",
            list(0),
            list(1),
            list(8),
            domain.balance(),
            list(9)
        );
        let share = all
            .iter()
            .map(|m| {
                let (i, g) = (word(m, 6) as f64, word(m, 7) as f64);
                format!("{:.0}", 100.0 * i / (i + g).max(1.0))
            })
            .collect::<Vec<_>>()
            .join(" ");
        eprintln!(
            "# per rank, overlap of the ghost states ({}): steps overlapped {}; waited {}; near-list fallbacks {}; % of pairs computed while the states travel {share}",
            if super::mpi::overlap() { "on" } else { "off" },
            list(3),
            list(4),
            list(5)
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

/// What a rank spent in the collectives of the timed steps, by kind: the states of the
/// ghosts sent every step (`forward`: with the largest displacement reduced alongside when
/// the exchange is not overlapped; when it is, only the time not spent in the work it
/// overlaps, that is posting and the last wait), the other reductions (the blow-up
/// checks, a rebuild's counts, the displacement's max of an overlapped step), and the rest
/// (a rebuild's migration and its lists); and, apart, the work done while the ghost states
/// travel (`overlapped`: the contacts with no ghost, part of the rank's work).
#[derive(Default)]
struct Spent {
    forward: Cell<Duration>,
    overlapped: Cell<Duration>,
    reduce: Cell<Duration>,
    rebuild: Cell<Duration>,
}

/// `comm` with a clock around each collective: a rank's step time split into its own work
/// and its time in communication (the waiting for slower ranks included), so that the loss
/// at many ranks can be told apart (the machine's cores slowing each other, or ranks
/// waiting). Each call goes to the same method of `comm`, so the steps are unchanged.
struct Timed<'a> {
    comm: &'a MpiComm,
    spent: Spent,
}

impl<'a> Timed<'a> {
    fn new(comm: &'a MpiComm) -> Self {
        Timed {
            comm,
            spent: Spent::default(),
        }
    }

    /// `f`'s result, its time added to `slot`.
    fn clocked<T>(&self, slot: &Cell<Duration>, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let out = f();
        slot.set(slot.get() + t.elapsed());
        out
    }
}

impl Comm for Timed<'_> {
    fn rank(&self) -> usize {
        self.comm.rank()
    }
    fn size(&self) -> usize {
        self.comm.size()
    }
    fn all_to_all(&self, send: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        self.clocked(&self.spent.rebuild, || self.comm.all_to_all(send))
    }
    fn all_to_all_known(&self, send: Vec<Vec<u8>>, recv_len: &[usize]) -> Vec<Vec<u8>> {
        self.clocked(&self.spent.forward, || {
            self.comm.all_to_all_known(send, recv_len)
        })
    }
    fn all_to_all_into(&self, send: &[Vec<u8>], recv: &mut [Vec<u8>]) {
        self.clocked(&self.spent.forward, || {
            self.comm.all_to_all_into(send, recv)
        })
    }
    fn all_to_all_into_during(
        &self,
        send: &[Vec<u8>],
        recv: &mut [Vec<u8>],
        during: &mut dyn FnMut(&mut dyn FnMut()),
    ) {
        // The work within is the rank's, not communication: clocked apart and taken off.
        let t = Instant::now();
        let mut worked = Duration::ZERO;
        self.comm
            .all_to_all_into_during(send, recv, &mut |progress| {
                let w = Instant::now();
                during(progress);
                worked += w.elapsed();
            });
        let spent = &self.spent;
        spent.overlapped.set(spent.overlapped.get() + worked);
        spent
            .forward
            .set(spent.forward.get() + t.elapsed().saturating_sub(worked));
    }
    fn all_to_all_into_and_max(&self, send: &[Vec<u8>], recv: &mut [Vec<u8>], x: f32) -> f32 {
        // The step's displacement reduction rides with the ghost states: one clock for both.
        self.clocked(&self.spent.forward, || {
            self.comm.all_to_all_into_and_max(send, recv, x)
        })
    }
    fn exchange_with(&self, send: Vec<Vec<u8>>, peers: &[bool]) -> Vec<Vec<u8>> {
        self.clocked(&self.spent.rebuild, || self.comm.exchange_with(send, peers))
    }
    fn all_gather(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.clocked(&self.spent.rebuild, || self.comm.all_gather(mine))
    }
    fn gather_to_root(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.clocked(&self.spent.rebuild, || self.comm.gather_to_root(mine))
    }
    fn max_f32(&self, x: f32) -> f32 {
        self.clocked(&self.spent.reduce, || self.comm.max_f32(x))
    }
    fn sum_u64(&self, x: u64) -> u64 {
        self.clocked(&self.spent.reduce, || self.comm.sum_u64(x))
    }
    fn sum_u64s(&self, v: &mut [u64]) {
        self.clocked(&self.spent.reduce, || self.comm.sum_u64s(v))
    }
    fn max_f32s(&self, v: &mut [f32]) {
        self.clocked(&self.spent.reduce, || self.comm.max_f32s(v))
    }
    fn min_u64(&self, x: u64) -> u64 {
        self.clocked(&self.spent.reduce, || self.comm.min_u64(x))
    }
}

/// Rank 0 says on stderr, per rank, the milliseconds per timed step of the rank's own steps
/// (to its last step, before the closing barrier) and of its collectives within them
/// (collective): work is the first less the others. At many ranks on one machine this tells
/// whether the ranks wait for each other (communication grows) or the cores slow each
/// other (work grows over one rank's).
fn report_times(comm: &MpiComm, timed: &Timed, own: Duration, steps: u64) {
    let per_step = |d: Duration| 1e3 * d.as_secs_f64() / steps.max(1) as f64;
    let spent = &timed.spent;
    let mine: Vec<u8> = [
        own,
        spent.forward.get(),
        spent.reduce.get(),
        spent.rebuild.get(),
        spent.overlapped.get(),
    ]
    .iter()
    .flat_map(|&d| per_step(d).to_le_bytes())
    .collect();
    let all = comm.all_gather(&mine);
    if comm.rank() == 0 {
        let list = |k: usize, work: bool| {
            all.iter()
                .map(|m| {
                    let at = |j: usize| {
                        m.get(8 * j..8 * j + 8)
                            .and_then(|b| b.try_into().ok())
                            .map_or(0.0, f64::from_le_bytes)
                    };
                    let v = if work {
                        at(0) - at(1) - at(2) - at(3)
                    } else {
                        at(k)
                    };
                    format!("{v:.3}")
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        eprintln!(
            "# per rank, ms per timed step: own steps {}; of which work {}; ghost states sent (with the displacement max unless overlapped) {}; other reductions {}; rebuild exchanges {}; work overlapped with the ghost states {}",
            list(0, false),
            list(0, true),
            list(1, false),
            list(2, false),
            list(3, false),
            list(4, false)
        );
    }
}
