//! The MPI run (cargo feature `mpi`): rank 0 reads the scene and broadcasts its text, every
//! rank builds the same world from it, [`clatter::domain::Domain`] steps it, and rank 0
//! writes final.csv and summary.json from the gathered state (in scene order, bitwise what
//! one process writes). [`MpiComm`] is the domain's transport over rsmpi.

use std::io::Write;
use std::rc::Rc;
use std::time::Instant;

use anyhow::Context;
use clatter::domain::{Balance, Comm, Domain, Rounds, Share};
use clatter::scene::Scene;
use clatter::{Checkpoint, World};
use indicatif::{ProgressBar, ProgressStyle};
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

use super::{Invocation, Quiet, exit_status};
use crate::backend::Backend;
use crate::log::{Sample, Thermo};
use crate::output::AtomicFile;
use crate::run::{FULL_CHECK_EVERY, Outputs, Plan, blown_up, resume_plan, run_plan};
use crate::scene_io::load_scene;

/// [`Comm`] over an MPI communicator.
pub struct MpiComm {
    pub(super) world: SimpleCommunicator,
    /// The most bytes one collective round or point-to-point message carries: longer
    /// messages go in [`Rounds`] (MPI counts and offsets are `int`).
    limit: usize,
}

/// The most bytes an MPI message or a round of a collective carries ([`MpiComm`]): 1 GiB,
/// well within `int` counts and offsets (with the one byte of padding per message).
const MESSAGE_LIMIT: usize = 1 << 30;

/// The environment variable that lowers [`MESSAGE_LIMIT`] (bytes; for the tests of the
/// splitting, which cannot send gigabytes).
pub const MESSAGE_LIMIT_VAR: &str = "CLATTER_MPI_MESSAGE_LIMIT";

/// The environment variable that turns on the overlap of the ghost states' exchange with
/// the contacts that need no ghost (`1`; off otherwise: [`clatter::domain::Domain::set_overlap`]).
/// Off by default: on 2 ranks of 4,096 spheres it costs 12-14% more instructions a rank (the
/// pair list split into many short runs), and on a 16-core machine it timed 4-18% slower at
/// 1, 4 and 16 ranks than the blocking exchange it replaces (BENCHMARKS.md, "The H100 and 16
/// MPI ranks on `main` at `e2da94c`"). The results are the same bits either way.
pub const OVERLAP_VAR: &str = "CLATTER_MPI_OVERLAP";

/// Whether the steps overlap the ghost states' exchange ([`OVERLAP_VAR`] set to `1`). Every
/// rank reads the same environment (mpirun passes it to all).
pub fn overlap() -> bool {
    std::env::var(OVERLAP_VAR).is_ok_and(|v| v.trim() == "1")
}

/// The environment variable that says what the ranks' boxes balance: `bodies` (the default:
/// each rank owns as many bodies, [`clatter::domain::Balance::Bodies`]) or `work` (each
/// rank's estimated work per step, its pairs and ghosts counted,
/// [`clatter::domain::Balance::Work`]; it evens out the instruction counts but timed 2-5%
/// slower on 16 cores). Which rank steps a body changes with it, never the result; both can
/// be timed from one binary.
pub const BALANCE_VAR: &str = "CLATTER_MPI_BALANCE";

/// What the ranks' boxes balance ([`BALANCE_VAR`]; the default when unset, and, said once on
/// stderr by rank 0, when set to neither name). Every rank reads the same environment.
pub fn balance(rank: usize) -> Balance {
    let Ok(v) = std::env::var(BALANCE_VAR) else {
        return Balance::default();
    };
    Balance::from_name(&v).unwrap_or_else(|| {
        let d = Balance::default();
        if rank == 0 {
            eprintln!(
                "clatter: ignoring {BALANCE_VAR}={v:?} (expected bodies or work; using {d:?})"
            );
        }
        d
    })
}

impl MpiComm {
    /// The transport over `world`, with [`MESSAGE_LIMIT`] or the smaller limit that
    /// [`MESSAGE_LIMIT_VAR`] sets (at least 8 bytes a rank, so that the lengths go in one
    /// round).
    pub fn new(world: SimpleCommunicator) -> MpiComm {
        let ranks = world.size().max(1) as usize;
        let limit = std::env::var(MESSAGE_LIMIT_VAR)
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .map_or(MESSAGE_LIMIT, |l| l.clamp(8 * ranks, MESSAGE_LIMIT));
        MpiComm { world, limit }
    }
}

/// Touching contacts per step, counted by each rank for its share (the domain step's
/// [`clatter::StepStats::contacts`]) and summed over the ranks when asked (one all-gather
/// for many steps, not a reduction per step): the whole world's count at each step, for
/// `summary.json`'s `max_contacts` and the bench's mean contacts.
#[derive(Default)]
pub struct StepCounts {
    mine: Vec<u64>,
}

impl StepCounts {
    /// This rank's count at the next step.
    pub fn push(&mut self, contacts: usize) {
        self.mine.push(contacts as u64);
    }

    /// Steps counted since the last [`StepCounts::totals`].
    pub fn len(&self) -> usize {
        self.mine.len()
    }

    /// The whole world's count at each step counted since the last call (collective: every
    /// rank has counted the same steps). Integers, so the sum is exact in any order.
    pub fn totals(&mut self, comm: &MpiComm) -> Vec<usize> {
        let bytes: Vec<u8> = self.mine.iter().flat_map(|c| c.to_le_bytes()).collect();
        let mut sum = vec![0usize; self.mine.len()];
        for m in comm.all_gather(&bytes) {
            for (s, c) in sum.iter_mut().zip(m.chunks_exact(8)) {
                *s += u64::from_le_bytes(c.try_into().expect("8 bytes")) as usize;
            }
        }
        self.mine.clear();
        sum
    }
}

/// Work run while the ghost states travel, given the transport's progress call
/// (`Comm::all_to_all_into_during`).
type Work<'a> = &'a mut dyn FnMut(&mut dyn FnMut());

/// Byte counts as MPI takes them (`int`): a message of 2 GiB or more is refused.
fn count(n: usize) -> i32 {
    i32::try_from(n).unwrap_or_else(|_| {
        panic!("an MPI message of {n} bytes is over MPI's 2 GiB limit (docs/parallel.md)")
    })
}

/// The offsets of consecutive blocks of `counts`.
fn displacements(counts: &[i32]) -> Vec<i32> {
    counts
        .iter()
        .scan(0i32, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

/// Splits `buf` into blocks of `counts`, each without its first byte (see [`padded`]).
fn split(buf: &[u8], counts: &[i32]) -> Vec<Vec<u8>> {
    let mut at = 0;
    counts
        .iter()
        .map(|&c| {
            let b = buf[at + 1..at + c as usize].to_vec();
            at += c as usize;
            b
        })
        .collect()
}

/// `m` after one byte: no buffer MPI sees is empty. Two empty buffers of the same type share
/// Rust's dangling pointer, which Open MPI takes for the send buffer aliasing the receive
/// buffer (`MPI_ERR_ARG`).
fn padded(m: &[u8]) -> Vec<u8> {
    let mut p = Vec::with_capacity(m.len() + 1);
    p.push(0);
    p.extend_from_slice(m);
    p
}

impl MpiComm {
    /// The forward exchange into the caller's buffers (`Comm::all_to_all_into`): point to
    /// point with the ranks that have something to send or receive (a box's neighbours; the
    /// sizes are known on both sides, so none is exchanged), where an `Alltoallv` would touch
    /// every rank; nothing allocated or zeroed here. A message longer than the limit goes in
    /// pieces, received in the order sent (MPI does not let messages of one tag between two
    /// ranks overtake each other). With `max`, the all-reduce of that value is posted first,
    /// nonblocking, so that it is reduced while the ghost states travel, and its result is
    /// returned (one wait for both; `Comm::all_to_all_into_and_max`).
    ///
    /// With `during`, that work runs between posting the messages and waiting for them
    /// (`Comm::all_to_all_into_during`), each of its `progress` calls testing the requests
    /// still open (which lets Open MPI move a rendezvous-size message along meanwhile).
    fn forward(
        &self,
        send: &[Vec<u8>],
        recv: &mut [Vec<u8>],
        max: Option<f32>,
        during: Option<Work<'_>>,
    ) -> f32 {
        let me = self.rank();
        if let (Some(mine), Some(m)) = (recv.get_mut(me), send.get(me)) {
            mine.clone_from(m);
        }
        let piece = self.limit;
        let x = max.unwrap_or(0.0);
        let mut y = x;
        mpi::request::scope(|scope| {
            let reduced = if max.is_some() {
                Some(self.world.immediate_all_reduce_into(
                    scope,
                    &x,
                    &mut y,
                    SystemOperation::max(),
                ))
            } else {
                None
            };
            let mut requests = Vec::new();
            for (r, buf) in recv.iter_mut().enumerate() {
                if r != me && !buf.is_empty() {
                    let from = self.world.process_at_rank(r as mpi::Rank);
                    for chunk in buf.chunks_mut(piece) {
                        requests.push(from.immediate_receive_into_with_tag(
                            scope,
                            chunk,
                            FORWARD_TAG,
                        ));
                    }
                }
            }
            for (r, m) in send.iter().enumerate() {
                if r != me && !m.is_empty() {
                    let to = self.world.process_at_rank(r as mpi::Rank);
                    for chunk in m.chunks(piece) {
                        requests.push(to.immediate_send_with_tag(scope, chunk, FORWARD_TAG));
                    }
                }
            }
            if let Some(during) = during {
                let mut progress = || {
                    // Each test moves the messages along; the requests done are dropped.
                    requests = std::mem::take(&mut requests)
                        .into_iter()
                        .filter_map(|r| r.test().err())
                        .collect();
                };
                during(&mut progress);
            }
            for request in requests {
                request.wait();
            }
            if let Some(reduced) = reduced {
                reduced.wait();
            }
        });
        y
    }

    /// Every rank's `mine`, by rank: on every rank (`Allgatherv`), or on rank 0 alone
    /// (`Gatherv`, the others get nothing and never hold more than their own message).
    /// Every rank learns every length first, so all take the same rounds (almost always
    /// one) without another collective.
    fn gathered(&self, mine: &[u8], to_root: bool) -> Vec<Vec<u8>> {
        let mut lens = vec![0u64; self.size()];
        self.world
            .all_gather_into(&(mine.len() as u64), &mut lens[..]);
        let rounds = Rounds::new(self.limit, self.size());
        let n = lens
            .iter()
            .map(|&l| rounds.needed(l as usize))
            .max()
            .unwrap_or(1);
        let receives = !to_root || self.rank() == 0;
        let mut got: Vec<Vec<u8>> = if receives {
            lens.iter()
                .map(|&l| Vec::with_capacity(l as usize))
                .collect()
        } else {
            Vec::new()
        };
        let root = self.world.process_at_rank(0);
        for k in 0..n {
            let piece = padded(rounds.piece(mine, k));
            if !receives {
                root.gather_varcount_into(&piece[..]);
                continue;
            }
            let counts: Vec<i32> = lens
                .iter()
                .map(|&l| count(rounds.piece_len(l as usize, k) + 1))
                .collect();
            let total: usize = counts.iter().map(|&c| c as usize).sum();
            let mut buf = vec![0u8; total];
            let d = displacements(&counts);
            {
                let mut recvp = PartitionMut::new(&mut buf[..], &counts[..], &d[..]);
                if to_root {
                    root.gather_varcount_into_root(&piece[..], &mut recvp);
                } else {
                    self.world.all_gather_varcount_into(&piece[..], &mut recvp);
                }
            }
            for (g, p) in got.iter_mut().zip(split(&buf, &counts)) {
                g.extend_from_slice(&p);
            }
        }
        got
    }
}

impl Comm for MpiComm {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn all_to_all(&self, send: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        // The lengths, then as many rounds as the longest message any rank sends needs
        // (one `Alltoallv` each; almost always one).
        let lens: Vec<u64> = send.iter().map(|m| m.len() as u64).collect();
        let mut recv_lens = vec![0u64; lens.len()];
        self.world.all_to_all_into(&lens[..], &mut recv_lens[..]);
        let recv_len: Vec<usize> = recv_lens.iter().map(|&n| n as usize).collect();
        let rounds = Rounds::new(self.limit, self.size());
        let mine = send
            .iter()
            .map(Vec::len)
            .chain(recv_len.iter().copied())
            .map(|n| rounds.needed(n) as u64)
            .max()
            .unwrap_or(1);
        let mut n = 0u64;
        self.world
            .all_reduce_into(&mine, &mut n, SystemOperation::max());
        rounds.exchange(&send, &recv_len, n as usize, |pieces, lens| {
            let pieces: Vec<Vec<u8>> = pieces.iter().map(|m| padded(m)).collect();
            let counts: Vec<i32> = pieces.iter().map(|m| count(m.len())).collect();
            let recv_counts: Vec<i32> = lens.iter().map(|&l| count(l + 1)).collect();
            self.exchange(&pieces, &counts, &recv_counts)
        })
    }

    fn all_to_all_known(&self, send: Vec<Vec<u8>>, recv_len: &[usize]) -> Vec<Vec<u8>> {
        let mut recv: Vec<Vec<u8>> = recv_len.iter().map(|&n| vec![0u8; n]).collect();
        self.all_to_all_into(&send, &mut recv);
        recv
    }

    fn all_to_all_into(&self, send: &[Vec<u8>], recv: &mut [Vec<u8>]) {
        self.forward(send, recv, None, None);
    }

    fn all_to_all_into_during(
        &self,
        send: &[Vec<u8>],
        recv: &mut [Vec<u8>],
        during: &mut dyn FnMut(&mut dyn FnMut()),
    ) {
        self.forward(send, recv, None, Some(during));
    }

    fn all_to_all_into_and_max(&self, send: &[Vec<u8>], recv: &mut [Vec<u8>], x: f32) -> f32 {
        self.forward(send, recv, Some(x), None)
    }

    fn all_gather(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.gathered(mine, false)
    }

    fn gather_to_root(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.gathered(mine, true)
    }

    fn max_f32(&self, x: f32) -> f32 {
        let mut y = 0.0f32;
        self.world
            .all_reduce_into(&x, &mut y, SystemOperation::max());
        y
    }

    fn sum_u64(&self, x: u64) -> u64 {
        let mut y = 0u64;
        self.world
            .all_reduce_into(&x, &mut y, SystemOperation::sum());
        y
    }

    fn min_u64(&self, x: u64) -> u64 {
        let mut y = 0u64;
        self.world
            .all_reduce_into(&x, &mut y, SystemOperation::min());
        y
    }

    fn sum_u64s(&self, v: &mut [u64]) {
        // One `Allreduce` (no buffer MPI sees is empty: see `padded`).
        if v.is_empty() {
            return;
        }
        let mine = v.to_vec();
        self.world
            .all_reduce_into(&mine[..], v, SystemOperation::sum());
    }

    fn max_f32s(&self, v: &mut [f32]) {
        if v.is_empty() {
            return;
        }
        let mine = v.to_vec();
        self.world
            .all_reduce_into(&mine[..], v, SystemOperation::max());
    }
}

impl MpiComm {
    /// One `Alltoallv` of the padded messages `send` (`counts` bytes each) into messages of
    /// `recv_counts` bytes, split per rank.
    fn exchange(&self, send: &[Vec<u8>], counts: &[i32], recv_counts: &[i32]) -> Vec<Vec<u8>> {
        let flat: Vec<u8> = send.concat();
        let total: usize = recv_counts.iter().map(|&c| c as usize).sum();
        let mut buf = vec![0u8; total];
        let (sd, rd) = (displacements(counts), displacements(recv_counts));
        {
            let sendp = Partition::new(&flat[..], counts, &sd[..]);
            let mut recvp = PartitionMut::new(&mut buf[..], recv_counts, &rd[..]);
            self.world.all_to_all_varcount_into(&sendp, &mut recvp);
        }
        split(&buf, recv_counts)
    }

    /// Rank 0's `bytes` on every rank (the others pass anything).
    pub(super) fn broadcast(&self, bytes: Vec<u8>) -> Vec<u8> {
        let root = self.world.process_at_rank(0);
        let mut len = bytes.len() as u64;
        root.broadcast_into(&mut len);
        let mut buf = if self.rank() == 0 {
            bytes
        } else {
            vec![0u8; len as usize]
        };
        for chunk in buf.chunks_mut(self.limit) {
            root.broadcast_into(chunk);
        }
        buf
    }

    /// `result` as every rank's outcome of a step all ranks take together
    /// ([`super::agree`]). Collective.
    pub(super) fn agree<T>(&self, result: anyhow::Result<T>) -> anyhow::Result<T> {
        super::agree(self, result)
    }
}

/// `clatter run`, `resume` or `bench` on MPI ranks (collective; see the module docs). An
/// error is printed here by rank 0 before any rank exits (mpirun stops the job at the first
/// rank that exits with a failure, and rank 0 might not have said why yet); every rank then
/// returns [`Quiet`] with the exit status.
pub fn run(invocation: Invocation) -> anyhow::Result<()> {
    let universe = mpi::initialize().context("MPI could not be initialised")?;
    let comm = Rc::new(MpiComm::new(universe.world()));
    let result = match invocation {
        Invocation::Bench(args) => super::bench::bench(&comm, args),
        Invocation::Validate(args) => {
            let ranks: Rc<dyn Comm> = comm.clone();
            crate::validate::validate_on(args, Some(ranks)).and_then(|passed| {
                if passed {
                    Ok(())
                } else {
                    Err(crate::validate::Failed.into())
                }
            })
        }
        other => run_on(&comm, other),
    };
    let result = match result {
        Ok(()) => Ok(()),
        Err(e) => {
            let status = exit_status(&e);
            // A failed row is in the table rank 0 printed; an error of another rank was
            // said by rank 0.
            if !e.is::<Quiet>() && !e.is::<crate::validate::Failed>() {
                eprintln!("error: {e:#}");
            }
            Err(Quiet(status).into())
        }
    };
    comm.world.barrier();
    result
}

/// The plan and the world on every rank: rank 0 reads the scene file or the checkpoint, every
/// rank builds both from the bytes it broadcasts.
fn start(comm: &MpiComm, invocation: Invocation) -> anyhow::Result<(Plan, World)> {
    let rank = comm.rank();
    match invocation {
        Invocation::Run(args) => {
            let loaded = if rank == 0 {
                load_scene(args.scene.as_deref()).map(|(text, scene)| (text, scene.source))
            } else {
                Ok((String::new(), String::new()))
            };
            let (text, source) = comm.agree(loaded)?;
            let text = String::from_utf8(comm.broadcast(text.into_bytes()))
                .context("the scene text is not UTF-8")?;
            let source = String::from_utf8_lossy(&comm.broadcast(source.into_bytes())).into_owned();
            let scene = comm.agree(Scene::parse(&text, &source).map_err(anyhow::Error::from))?;
            let (mut plan, world) = comm.agree(run_plan(args, text, scene))?;
            plan.picture = false;
            Ok((plan, world))
        }
        Invocation::Resume(args) => {
            let path = args.checkpoint.clone();
            let what = || format!("cannot resume from {}", path.display());
            let bytes = if rank == 0 {
                std::fs::read(&path).with_context(what)
            } else {
                Ok(Vec::new())
            };
            let bytes = comm.broadcast(comm.agree(bytes)?);
            let ckpt = comm.agree(Checkpoint::from_bytes(&bytes).with_context(what))?;
            comm.agree(resume_plan(args, ckpt))
        }
        Invocation::Bench(_) | Invocation::Validate(_) => {
            unreachable!(
                "`clatter bench` and `validate` on ranks are `super::bench` and `crate::validate`"
            )
        }
    }
}

/// [`run`] on `comm`'s ranks.
fn run_on(comm: &MpiComm, invocation: Invocation) -> anyhow::Result<()> {
    let (rank, ranks) = (comm.rank(), comm.size());
    let (plan, world) = start(comm, invocation)?;
    comm.agree(check_plan(&plan))?;
    let start_step = world.step_count;
    let steps = plan.end_step.saturating_sub(start_step);
    let (bodies, walls, dt) = (world.len(), world.walls.len(), world.dt);
    if rank == 0 {
        if !plan.resumed {
            for w in &plan.scene.warnings {
                eprintln!("warning: {w}");
            }
        }
        for w in plan.health.warnings(&world) {
            eprintln!("warning: {w}");
        }
    }
    let initial = if rank == 0 && !plan.resumed {
        plan.health
            .check_initial(&world)
            .map_err(|b| blown_up(&plan, b, &world, None))
    } else {
        Ok(())
    };
    comm.agree(initial)?;
    // Rank 0's files (the frame series, energy.csv, discharge.csv, checkpoints) are one
    // process's `Outputs`, fed the gathered world at the frame and checkpoint steps, and
    // the totals reduced over the ranks at the other energy sample steps.
    let outputs = if rank == 0 {
        Outputs::create(&plan, &world, start_step).map(Some)
    } else {
        Ok(None)
    };
    let mut outputs = comm.agree(outputs)?;
    // The last good state until the first full check: the start, kept by rank 0 alone.
    let mut last_good = LastGood::Start((rank == 0).then(|| Box::new(world.clone())));
    let mut domain = Domain::with_balance(world, rank, ranks, balance(rank));
    domain.set_overlap(overlap());
    let loud = rank == 0 && !plan.quiet;

    if loud {
        let from = if plan.resumed {
            format!(" from step {start_step}")
        } else {
            String::new()
        };
        eprintln!(
            "{}: {bodies} bodies, {walls} walls, dt = {dt:.3e} s, {steps} steps{from} ({:.4} s simulated), {ranks} MPI ranks x {} threads",
            plan.scene.source,
            steps as f64 * dt as f64,
            rayon::current_num_threads()
        );
    }
    // Progress lines (`--log-every`, or by default when stderr is not a terminal, as under
    // most launchers) on rank 0, which decides when one is due (it may be by wall-clock) and
    // says so to the others: the line's kinetic energy and contacts are collective.
    let mut thermo = plan
        .log
        .map(|every| Thermo::new(every, start_step, plan.end_step));
    let bar = if loud && thermo.is_none() {
        ProgressBar::new(steps)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:30.cyan/blue} {pos}/{len} steps, {msg}, eta {eta}")
            .expect("valid template"),
    );
    // Checkpoints at the simulated times one process writes them (`run/outputs.rs`).
    let half_dt = 0.5 * dt as f64;
    let mut next_checkpoint = plan
        .checkpoint_every
        .map(|t| ((domain.local().time + half_dt) / t).floor() + 1.0);
    // summary.json's max_contacts: the most touching contacts at any step (the start too,
    // as one process counts it), reduced every `PEAK_EVERY` steps.
    let mut max_contacts = domain.contact_count(comm);
    let mut counts = StepCounts::default();
    let started = Instant::now();
    for k in 0..steps {
        let stepped = domain.step(comm);
        if let Ok(s) = &stepped {
            counts.push(s.contacts);
            if counts.len() >= PEAK_EVERY {
                max_contacts = counts
                    .totals(comm)
                    .into_iter()
                    .fold(max_contacts, usize::max);
            }
        }
        if let Err(e) = stepped {
            bar.finish_and_clear();
            // Every rank has the same error (the body is named by its scene id); the cause
            // is found from the last good state, as one process finds it.
            let good = last_good.world(&domain, comm);
            let energy = outputs.as_mut().and_then(|o| o.energy.take());
            return Err(match good {
                Some(good) => blown_up(&plan, plan.health.non_finite(&good, &e), &good, energy),
                None => Quiet(crate::report::BLOW_UP_EXIT).into(),
            });
        }
        let s = domain.local().step_count;
        let full = s.is_multiple_of(FULL_CHECK_EVERY) || s == plan.end_step;
        if full || s.is_multiple_of(plan.check_every) {
            // Each rank checks its own bodies and contacts; the verdict is reduced, the same
            // on every rank (`Domain::check`). A full check that passes keeps each rank's
            // share as the last good state.
            match domain.check(&plan.health, comm, full) {
                Ok(()) if full => last_good = LastGood::Kept(domain.share()),
                Ok(()) => {}
                Err(b) => {
                    bar.finish_and_clear();
                    let good = last_good.world(&domain, comm);
                    let energy = outputs.as_mut().and_then(|o| o.energy.take());
                    return Err(match good {
                        Some(good) => blown_up(&plan, b, &good, energy),
                        None => Quiet(crate::report::BLOW_UP_EXIT).into(),
                    });
                }
            }
        }
        // What one process writes after this step (`run/outputs.rs`): the world is gathered
        // for a frame or a checkpoint; an energy sample alone needs only the totals.
        let frame = plan.output_every.is_some_and(|n| s.is_multiple_of(n));
        let sample = s.is_multiple_of(plan.energy_every);
        let time = domain.local().time;
        let checkpoint = match (plan.checkpoint_every, &mut next_checkpoint) {
            (Some(t), Some(next)) if time + half_dt >= *next * t => {
                *next = ((time + half_dt) / t).floor() + 1.0;
                true
            }
            _ => false,
        };
        if plan.out.is_some() && (frame || checkpoint) {
            // Gathered on rank 0 alone: the other ranks keep only their shares.
            let whole = domain.gather_root(comm);
            let written = match (outputs.as_mut(), &whole) {
                (Some(o), Some(whole)) => o.after_step(&plan, whole, frame),
                _ => Ok(()),
            };
            comm.agree(written)?;
        } else if plan.out.is_some() && sample {
            // An energy sample alone: the totals reduced over the ranks (exact sums, a few
            // KiB whatever the number of bodies), bitwise one process's.
            let totals = domain.totals(comm);
            let written = outputs
                .as_mut()
                .map_or(Ok(()), |o| o.sample_totals(&totals));
            comm.agree(written)?;
        }
        if let Some(l) = &mut thermo {
            let due = comm.broadcast(vec![(rank == 0 && l.due(s)) as u8]);
            if due.first() == Some(&1) {
                let line = progress_sample(comm, &domain);
                if rank == 0 {
                    l.line(line);
                }
            }
        }
        if (k + 1) % 64 == 0 {
            bar.set_position(k + 1);
            bar.set_message(format!("{:.0} steps/s", bar.per_sec()));
        }
    }
    bar.finish_and_clear();
    if let Some(l) = &mut thermo {
        let line = progress_sample(comm, &domain);
        if rank == 0 {
            l.finish(line);
        }
    }
    let elapsed = started.elapsed().as_secs_f64();
    let max_contacts = counts
        .totals(comm)
        .into_iter()
        .fold(max_contacts, usize::max);
    let whole = domain.gather_root(comm);
    let ran = Ran {
        steps,
        start_step,
        elapsed,
        ranks,
        max_contacts,
    };
    let finished = match (outputs, &plan.out, &whole) {
        (Some(o), Some(dir), Some(whole)) => o
            .finish(&plan, dir, whole)
            .and_then(|_| finish(&plan, whole, &ran)),
        (Some(_), None, Some(whole)) => finish(&plan, whole, &ran),
        _ => Ok(()),
    };
    comm.agree(finished)
}

/// The last good state of a run on ranks: the world at the start (kept by rank 0 alone,
/// which writes `last_good.ckpt`; `None` on the others) until a full check passes, then each
/// rank's share of the world at the last full check that passed (O(its bodies), kept
/// without a message).
enum LastGood {
    Start(Option<Box<World>>),
    Kept(Share),
}

impl LastGood {
    /// The whole last good state on rank 0 (collective; `None` on the other ranks): only
    /// at a blow-up are the shares gathered, to rank 0 alone.
    fn world(&self, domain: &Domain, comm: &MpiComm) -> Option<World> {
        match self {
            LastGood::Start(world) => world.as_deref().cloned(),
            LastGood::Kept(share) => domain.gather_kept(share, comm),
        }
    }
}

/// What a progress line reports (collective): the step, the time, the whole world's kinetic
/// energy (reduced exactly, as one process sums it: [`Domain::totals`]) and touching
/// contacts.
fn progress_sample(comm: &MpiComm, domain: &Domain) -> Sample {
    let contacts = domain.contact_count(comm);
    let totals = domain.totals(comm);
    Sample {
        step: totals.step,
        time: totals.time,
        kinetic: totals.kinetic,
        contacts,
    }
}

/// Steps between the reductions of the per-step contact counts (`max_contacts`): 32 KiB a
/// rank each time.
const PEAK_EVERY: usize = 4096;

/// The tag of the per-step ghost states sent point to point ([`Comm::all_to_all_known`]);
/// every other message is a collective, which point-to-point messages never match.
const FORWARD_TAG: mpi::Tag = 17;

/// What the steps of an MPI run came to, for its summary.
struct Ran {
    steps: u64,
    start_step: u64,
    elapsed: f64,
    ranks: usize,
    /// The most touching contacts at any step of the run (and at its start).
    max_contacts: usize,
}

/// Rank 0's end of the run after `Outputs::finish` (final.csv, the series, the checkpoint):
/// the summary lines and summary.json.
fn finish(plan: &Plan, whole: &World, ran: &Ran) -> anyhow::Result<()> {
    let &Ran {
        steps,
        start_step,
        elapsed,
        ranks,
        max_contacts,
    } = ran;
    let steps_per_s = steps as f64 / elapsed.max(1e-9);
    let loud = !plan.quiet;
    if loud {
        println!("simulated time   {:.6} s", whole.time);
        println!("steps            {steps}");
        println!("wall time        {elapsed:.3} s");
        println!("backend          cpu on {ranks} MPI ranks");
        println!("steps/s          {steps_per_s:.1}");
        println!(
            "contacts         {} (max {max_contacts})",
            whole.contact_count()
        );
        println!("kinetic energy   {:.6e} J", whole.kinetic_energy());
    }
    let Some(dir) = &plan.out else {
        return Ok(());
    };
    let summary = serde_json::json!({
        "scene": plan.scene.source,
        "bodies": whole.len(),
        "walls": whole.walls.len(),
        "dt": whole.dt.to_string().parse::<f64>().unwrap_or(whole.dt as f64),
        "steps": steps,
        "step": whole.step_count,
        "resumed_from_step": plan.resumed.then_some(start_step),
        "simulated_time": whole.time,
        "wall_time_s": elapsed,
        "steps_per_s": steps_per_s,
        "threads": rayon::current_num_threads(),
        "ranks": ranks,
        "backend": "cpu",
        "contacts": whole.contact_count(),
        "max_contacts": max_contacts,
        "kinetic_energy": whole.kinetic_energy(),
        "potential_energy": whole.potential_energy(),
        "momentum": whole.momentum(),
        "broad_phase_rebuilds": whole.rebuilds,
        "removed": whole.discharged().count,
        "removed_mass": whole.discharged().mass,
    });
    let mut f = AtomicFile::create(&dir.join("summary.json"))?;
    serde_json::to_writer_pretty(f.writer(), &summary)?;
    writeln!(f.writer())?;
    f.commit()?;
    let mut written = "final.csv, summary.json, energy.csv, energy.svg".to_string();
    if !whole.sinks.is_empty() {
        written.push_str(", discharge.csv");
    }
    if loud {
        println!("results in {}/: {written}", dir.display());
    }
    Ok(())
}

/// What the MPI run does not do yet, refused before the first step (every rank finds the
/// same: the arguments and the scene or checkpoint are the same everywhere). More ranks
/// than bodies is not refused: the ranks beyond the bodies own an empty box, as ranks do
/// whose bodies all left through a sink, and the run is still one process's, bitwise.
fn check_plan(plan: &Plan) -> anyhow::Result<()> {
    if plan.backend == Backend::Gpu {
        anyhow::bail!(
            "--backend gpu: runs on several MPI ranks use the CPU pipeline (one GPU per rank is planned, docs/parallel.md)"
        );
    }
    Ok(())
}
