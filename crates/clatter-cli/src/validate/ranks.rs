//! `clatter validate` on MPI ranks (`mpirun -np N clatter validate --only pile`,
//! docs/parallel.md): the checks whose world is large enough to split step it decomposed
//! over the ranks ([`Spread`], on [`clatter::domain::Domain`]), bitwise as one process steps
//! it, so every rank measures the same numbers and reaches one process's verdict. The other
//! checks (one to a few dozen bodies each) are refused on ranks, saying why.

use std::rc::Rc;
use std::sync::Arc;

use anyhow::Context as _;
use clatter::World;
use clatter::domain::{Comm, Domain};
use glam::DVec3;

use super::{Ctx, Sim};
use crate::log::SuiteLog;

/// The checks that run on MPI ranks: those whose world is worth splitting (thousands of
/// bodies) and that read only what a decomposed world gives cheaply between steps (the
/// clock, the kinetic energy) and its bodies at the end ([`Spread`]).
pub const ON_RANKS: [&str; 1] = [super::pile::NAME];

/// Why the `chosen` checks cannot run on `ranks` MPI ranks (`None` when they all can).
pub fn refused(chosen: &[&str], ranks: usize) -> Option<String> {
    let not: Vec<&str> = chosen
        .iter()
        .copied()
        .filter(|n| !ON_RANKS.contains(n))
        .collect();
    let one = not.len() == 1;
    let which = if not.len() > 3 {
        format!("the other {} checks", not.len())
    } else {
        not.join(", ")
    };
    (!not.is_empty()).then(|| {
        format!(
            "on {ranks} MPI ranks `clatter validate` runs only {} (`--only pile`): {which} {} one to a few dozen bodies, too few to split over ranks; run {} without mpirun",
            ON_RANKS.join(", "),
            if one { "has" } else { "have" },
            if one { "it" } else { "them" },
        )
    })
}

/// A world stepped for a check that reads only its clock and kinetic energy between steps
/// and its bodies' positions at the end: by one process (a [`Sim`], on the chosen
/// backend), or decomposed over MPI ranks (collective: every rank calls the same methods
/// in the same order, and gets the same numbers, bitwise one process's).
pub enum Spread {
    /// One process.
    One(Box<Sim>),
    /// This rank's part of a decomposed world.
    Ranks(Box<OnRanks>),
}

/// One rank's part of a [`Spread`] world.
pub struct OnRanks {
    domain: Domain,
    comm: Rc<dyn Comm>,
    log: Option<Arc<SuiteLog>>,
}

impl Spread {
    /// `n` steps (collective on ranks).
    pub fn step(&mut self, n: u64) -> anyhow::Result<()> {
        match self {
            Spread::One(sim) => sim.step(n),
            Spread::Ranks(r) => {
                for _ in 0..n {
                    r.domain
                        .step(&*r.comm)
                        .context("stepping a validation world")?;
                }
                if let Some(l) = &r.log {
                    l.tick();
                }
                Ok(())
            }
        }
    }

    /// The simulated time, s.
    pub fn time(&self) -> f64 {
        match self {
            Spread::One(sim) => sim.world.time,
            Spread::Ranks(r) => r.domain.local().time,
        }
    }

    /// The whole world's kinetic energy, J (collective on ranks: an exact sum reduced over
    /// them, bitwise [`World::kinetic_energy`]).
    pub fn kinetic_energy(&self) -> f64 {
        match self {
            Spread::One(sim) => sim.world.kinetic_energy(),
            Spread::Ranks(r) => r.domain.totals(&*r.comm).kinetic,
        }
    }

    /// Every body's position, in scene order (collective on ranks: the bodies gathered).
    pub fn positions(&self) -> Vec<DVec3> {
        match self {
            Spread::One(sim) => sim.world.state.position.clone(),
            Spread::Ranks(r) => r.domain.gather_bodies(&*r.comm).state.position,
        }
    }
}

impl Ctx {
    /// `world` ready to step as a [`Spread`]: decomposed over the ranks when the suite runs
    /// on MPI ranks, else on the chosen backend ([`Ctx::sim`]).
    pub fn spread(&self, world: World) -> anyhow::Result<Spread> {
        let Some(comm) = &self.ranks else {
            return Ok(Spread::One(Box::new(self.sim(world)?)));
        };
        let (rank, ranks) = (comm.rank(), comm.size());
        Ok(Spread::Ranks(Box::new(OnRanks {
            domain: Domain::new(world, rank, ranks),
            comm: comm.clone(),
            log: self.log.clone(),
        })))
    }

    /// `result` as every rank's outcome (collective on ranks, [`crate::cluster::agree`]):
    /// rank 0 says why once, and no rank goes on while another stopped. `result` itself
    /// on one process.
    pub fn agree<T>(&self, result: anyhow::Result<T>) -> anyhow::Result<T> {
        match &self.ranks {
            Some(comm) => crate::cluster::agree(&**comm, result),
            None => result,
        }
    }
}
