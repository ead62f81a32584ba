//! `mpirun -np N clatter run|resume|bench|validate`: a run, a benchmark or the validation
//! checks that can be split on several MPI ranks
//! (docs/parallel.md).
//!
//! This module finds out whether the process was started by an MPI launcher (whatever the
//! build); the MPI run itself (`mpi.rs`) needs the cargo feature `mpi`. A build without it
//! started on several ranks stops with an error instead of running the whole scene N times.

#[cfg(feature = "mpi")]
mod bench;
#[cfg(feature = "mpi")]
mod mpi;

use clatter::domain::Comm;

use crate::bench::BenchArgs;
use crate::run::{ResumeArgs, RunArgs};
use crate::validate::ValidateArgs;

/// What the ranks were started to do (read by the MPI run only: a build without the feature
/// just refuses it).
#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
pub enum Invocation {
    /// `clatter run`.
    Run(RunArgs),
    /// `clatter resume`.
    Resume(ResumeArgs),
    /// `clatter bench` (the CPU pipeline).
    Bench(BenchArgs),
    /// `clatter validate` (the checks that run on ranks: `--only pile`).
    Validate(ValidateArgs),
}

/// The environment variables MPI launchers set to the number of ranks: Open MPI's `mpirun`,
/// MPICH's Hydra (and Slurm's `srun` with PMI-1/2), PMIx launchers (Slurm, PRRTE).
const SIZE_VARS: [&str; 3] = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"];

/// The number of ranks when an MPI launcher started this process (`None` otherwise, or when
/// the variable is not a number).
pub fn launched() -> Option<usize> {
    SIZE_VARS
        .iter()
        .find_map(|v| std::env::var(v).ok())
        .and_then(|s| s.trim().parse().ok())
}

/// Whether `clatter run` (`resume`, `bench`, `validate`) takes the MPI path when an MPI launcher started `ranks` ranks: always
/// with the `mpi` feature (one rank too, which runs the decomposition on one rank), and on
/// several ranks without it (to say it cannot).
pub fn wanted(ranks: usize) -> bool {
    cfg!(feature = "mpi") || ranks > 1
}

/// `clatter run`, `resume`, `bench` or `validate` under an MPI launcher that started `ranks` ranks: the
/// decomposed run with the `mpi` feature; without it, the error that this build cannot.
pub fn run(invocation: Invocation, ranks: usize) -> anyhow::Result<()> {
    #[cfg(feature = "mpi")]
    {
        let _ = ranks;
        mpi::run(invocation)
    }
    #[cfg(not(feature = "mpi"))]
    {
        let _ = invocation;
        anyhow::bail!(
            "started on {ranks} MPI ranks, but this clatter was built without MPI: each rank would run the whole scene. Build it with `cargo build --release -p clatter-cli --features mpi` (docs/parallel.md), or run it without mpirun"
        )
    }
}

/// For the subcommands that do not run on several ranks: an error when started on several
/// (`name` is the subcommand). `render` and `view` draw every frame from the whole world on
/// one GPU (a gather per frame would make ranks slower than one process).
pub fn single_rank_only(name: &str) -> anyhow::Result<()> {
    match launched() {
        Some(n) if n > 1 => anyhow::bail!(
            "`clatter {name}` does not run on several MPI ranks (started on {n}); `clatter run`, `resume`, `bench` and `validate --only pile` do (docs/parallel.md)"
        ),
        _ => Ok(()),
    }
}

/// `result` as every rank's outcome of a step all ranks take together (collective): when
/// any rank failed, rank 0 returns the error (its own, or the first failing rank's message,
/// naming that rank) and the others [`Quiet`] with its exit status, so that rank 0 says
/// why once and no rank goes on to a collective the others have left.
pub fn agree<T>(comm: &dyn Comm, result: anyhow::Result<T>) -> anyhow::Result<T> {
    // An error travels as its exit status and its message.
    let mine = match &result {
        Ok(_) => Vec::new(),
        Err(e) => {
            let mut m = vec![exit_status(e)];
            m.extend(format!("{e:#}").into_bytes());
            m
        }
    };
    let all = comm.all_gather(&mine);
    let first = all.iter().position(|m| !m.is_empty());
    match (result, first) {
        (Ok(v), None) => Ok(v),
        (r, Some(k)) if comm.rank() == 0 => Err(r.err().unwrap_or_else(|| {
            anyhow::anyhow!("rank {k}: {}", String::from_utf8_lossy(&all[k][1..]))
        })),
        (_, Some(k)) => Err(Quiet(all[k][0]).into()),
        (_, None) => unreachable!("an error is a message"),
    }
}

/// The exit status `main` gives `e`: a blow-up's, a failed validation's, a [`Quiet`]
/// error's, or 1.
pub fn exit_status(e: &anyhow::Error) -> u8 {
    if e.is::<crate::report::BlownUp>() {
        crate::report::BLOW_UP_EXIT
    } else if e.is::<crate::validate::Failed>() {
        crate::validate::FAILED_EXIT
    } else if let Some(q) = e.downcast_ref::<Quiet>() {
        q.0
    } else {
        1
    }
}

/// The error every rank of an MPI run returns when the run stopped: rank 0 has printed why
/// already, before any rank exited; `main` exits with the status it carries and says nothing.
#[derive(Debug)]
pub struct Quiet(pub u8);

impl std::fmt::Display for Quiet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("stopped (rank 0 says why)")
    }
}

impl std::error::Error for Quiet {}
