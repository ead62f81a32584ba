//! The blow-up checks of a stepping loop, one code path for `clatter run`, `render`, `view`,
//! the Python package and whoever steps a [`Stepper`]: the host's [`Health`] checks at the
//! same steps on both executors, with the GPU doing the cheap ones on the device
//! (`GpuWorld::set_health`) and stopping only when the host must look.
//!
//! - On the CPU, [`Watch::step`] steps to each multiple of `check_every` and runs
//!   [`Health::check`] there (the full check every [`FULL_CHECK_EVERY`] steps).
//! - On the GPU, the device checks every `check_every` steps and raises an alarm when its
//!   f32 sums come near what the host would report (the kinetic energy above half of
//!   [`ENERGY_FACTOR`](clatter::health::ENERGY_FACTOR) times the available energy, a body behind a wall, a contact whose
//!   force may mean a deep overlap); the pipeline stops there, the host checks that step
//!   exactly ([`Watch::after`]), and goes on if it finds nothing. So the reports are the
//!   host's, the same words as on the CPU, and the state comes back only when needed.

use clatter::World;
use clatter::health::{BlowUp, Health};
#[cfg(feature = "gpu")]
use clatter_gpu::{GpuError, GpuWorld, HealthSetup};

use crate::backend::{Readback, StepError, Stepped, Stepper};

/// The full check (every touching contact's overlap) and the last good state, every this
/// many steps.
pub const FULL_CHECK_EVERY: u64 = 100;

/// The GPU's deep-overlap alarm looks at contacts whose force means an overlap deeper than
/// this fraction of the host's [`OVERLAP_LIMIT`](clatter::health::OVERLAP_LIMIT): a margin
/// below the host's own test for the f32 arithmetic on either side (the same law functions
/// on the same f32 inputs, a few ulps apart: 1% of the depth, 1.5% of a Hertz force, is
/// ample), and as few alarms as that allows, since each stops the pipeline and drains the
/// batches in flight (`HealthSetup::overlap_limit`; 0.9 stopped the default scene's 5,000
/// steps 14 times on lavapipe, 0.99 9 times).
pub const GPU_OVERLAP_MARGIN: f32 = 0.99;

/// The cheap checks run every this many steps unless asked otherwise (`--check-every`).
pub const CHECK_EVERY: u64 = 10;

/// Why [`Watch::step`] stopped: data for each front end to word (the command line's
/// blow-up report and exit status, Python's `SimulationError` with its attributes).
#[derive(Debug)]
pub enum WatchError {
    /// The simulation blew up: the report, with its kind, body, step, time and likely
    /// cause (the world holds the state it was found in).
    BlowUp(Box<BlowUp>),
    /// The GPU failed.
    #[cfg(feature = "gpu")]
    Gpu(GpuError),
}

#[cfg(feature = "gpu")]
impl From<GpuError> for WatchError {
    fn from(e: GpuError) -> WatchError {
        WatchError::Gpu(e)
    }
}

impl std::fmt::Display for WatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WatchError::BlowUp(b) => b.fmt(f),
            #[cfg(feature = "gpu")]
            WatchError::Gpu(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for WatchError {}

/// The blow-up checks of one run (see the module docs).
pub struct Watch {
    health: Health,
    check_every: u64,
}

impl Watch {
    /// Watches a run of `stepper` from `world` with `health` (its baseline), checking every
    /// `check_every` steps; on the GPU, also logs an energy sample every `energy_every`
    /// steps (0: none; [`GpuWorld::take_samples`]). Does not run the check before the
    /// first step ([`Health::check_initial`]).
    pub fn start(
        stepper: &mut Stepper,
        world: &World,
        health: Health,
        check_every: u64,
        energy_every: u64,
    ) -> Watch {
        let w = Watch {
            health,
            check_every: check_every.max(1),
        };
        #[cfg(feature = "gpu")]
        if let Some(g) = stepper.as_gpu_mut() {
            w.arm(g, world, energy_every);
        }
        #[cfg(not(feature = "gpu"))]
        let _ = (stepper, world, energy_every);
        w
    }

    /// Watches with the host's checks only, also on the GPU (which then hands the state
    /// back at every check step: the run loop before the device-side checks, kept for
    /// comparisons, `CLATTER_GPU_HOST_CHECKS=1`).
    pub fn host_only(health: Health, check_every: u64) -> Watch {
        Watch {
            health,
            check_every: check_every.max(1),
        }
    }

    /// Sets up the GPU's checks (again, after [`Stepper::restart`]).
    #[cfg(feature = "gpu")]
    pub fn arm(&self, gpu: &mut GpuWorld, world: &World, energy_every: u64) {
        gpu.set_health(
            world,
            HealthSetup {
                check_every: self.check_every,
                energy_every,
                snapshot_every: FULL_CHECK_EVERY,
                budget: self.health.baseline(),
                alarm_factor: 0.5 * clatter::health::ENERGY_FACTOR,
                force_floor: self.health.force_floor(),
                overlap_limit: GPU_OVERLAP_MARGIN * clatter::health::OVERLAP_LIMIT,
            },
        );
    }

    /// The checks and their baseline.
    pub fn health(&self) -> &Health {
        &self.health
    }

    /// The steps the cheap check runs at.
    pub fn check_every(&self) -> u64 {
        self.check_every
    }

    /// Whether the host needs the state at step `s` for the checks: on the CPU every
    /// multiple of `check_every`; on the GPU never (the device checks).
    pub fn due(&self, stepper: &Stepper, s: u64) -> bool {
        !stepper.is_gpu() && s.is_multiple_of(self.check_every)
    }

    /// The checks after `stepper` stopped at `world.step_count` (`stats` from its
    /// [`Stepper::step`]): the host's check when the step is a check step or the GPU raised
    /// an alarm (`full`: also every touching contact's overlap), and on a harmless alarm the
    /// GPU goes on. Returns whether the host checked.
    pub fn after(
        &self,
        stepper: &mut Stepper,
        world: &World,
        stats: &Stepped,
        full: bool,
    ) -> Result<bool, WatchError> {
        let s = world.step_count;
        let checked = full || s.is_multiple_of(self.check_every) || stats.alarm;
        if checked {
            self.health
                .check(world, full)
                .map_err(|b| WatchError::BlowUp(Box::new(b)))?;
        }
        #[cfg(feature = "gpu")]
        if stats.alarm
            && let Some(g) = stepper.as_gpu_mut()
        {
            // The GPU's f32 sums looked alarming but the host's exact check passed.
            g.clear_alarm()?;
        }
        #[cfg(not(feature = "gpu"))]
        let _ = stepper;
        Ok(checked)
    }

    /// The report for a step that failed with a non-finite state.
    pub fn non_finite(&self, world: &World, e: &clatter::SimError) -> WatchError {
        WatchError::BlowUp(Box::new(self.health.non_finite(world, e)))
    }

    /// Steps `steps` steps with the checks (see the module docs; the full check every
    /// [`FULL_CHECK_EVERY`] steps), `back` saying what comes back into `world` from the GPU
    /// at the end. Stops at the first blow-up with its report; the world then holds the
    /// state it was found in.
    pub fn step(
        &self,
        stepper: &mut Stepper,
        world: &mut World,
        steps: u64,
        back: Readback,
    ) -> Result<Stepped, WatchError> {
        // The world's step count stays behind on the GPU with `Readback::Nothing`: count.
        let start = world.step_count;
        let end = start + steps;
        let mut s = start;
        let mut total: Option<Stepped> = None;
        while s < end || total.is_none() {
            let m = if stepper.is_gpu() {
                end - s
            } else {
                (self.check_every - s % self.check_every).min(end - s)
            };
            let stats = match stepper.step(world, m, back) {
                Ok(stats) => stats,
                Err(StepError::Sim(e)) => return Err(self.non_finite(world, &e)),
                #[cfg(feature = "gpu")]
                Err(StepError::Gpu(e)) => return Err(e.into()),
            };
            s += stats.steps;
            if !stepper.is_gpu() || stats.alarm {
                // The world is current here (the CPU's, or read back for the alarm), also
                // when `back` leaves it behind between calls.
                let full = world.step_count.is_multiple_of(FULL_CHECK_EVERY);
                self.after(stepper, world, &stats, full)?;
            }
            total = Some(match total {
                None => stats,
                Some(t) => Stepped {
                    steps: t.steps + stats.steps,
                    contacts: stats.contacts,
                    max_contacts: t.max_contacts.max(stats.max_contacts),
                    mean_contacts: (t.mean_contacts * t.steps as f64
                        + stats.mean_contacts * stats.steps as f64)
                        / (t.steps + stats.steps).max(1) as f64,
                    alarm: false,
                },
            });
            if steps == 0 {
                break;
            }
        }
        Ok(total.unwrap_or(Stepped {
            steps: 0,
            contacts: 0,
            max_contacts: 0,
            mean_contacts: 0.0,
            alarm: false,
        }))
    }
}
