//! One world, two executors: which pipeline steps a [`World`], and the one interface through
//! which every front end (`run`, `resume`, `bench`, `render`, `view`, the Python package)
//! steps it.
//!
//! [`choose`] turns the user's [`BackendChoice`] into a [`Stepper`]: the CPU pipeline, which
//! steps the [`World`] in place, or (feature `gpu`) a `GpuWorld`, which keeps its own copy of
//! the state on the GPU and hands it back when asked ([`Readback`], [`Stepper::sync`]). The
//! automatic choice, and the reason it gives ([`Choice`]), live here only.

#[cfg(feature = "gpu")]
use std::sync::Arc;

use clatter::{SimError, World};
#[cfg(feature = "gpu")]
use clatter_gpu::{GpuContext, GpuError, GpuWorld};
use thiserror::Error;

/// A failure of the GPU device (validation, out of memory, device lost): `GpuError`.
#[cfg(feature = "gpu")]
pub type DeviceError = GpuError;

/// A failure of the GPU device: none can happen in a build without the GPU.
#[cfg(not(feature = "gpu"))]
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DeviceError {}

/// Which pipeline the user asked for (`--backend auto|cpu|gpu`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// The GPU when a hardware adapter is found and the scene fits it, else the CPU; the
    /// choice comes with the reason.
    #[default]
    Auto,
    /// The multi-threaded CPU pipeline (the reference).
    Cpu,
    /// The wgpu compute pipeline; an error when no adapter is found or the scene does not
    /// fit it.
    Gpu,
}

/// Where the GPU device comes from when the choice needs one.
#[derive(Clone, Debug)]
pub enum Device {
    /// Open the best adapter wgpu finds, without a window (`GpuContext::new`), only when
    /// the choice needs it.
    Headless,
    /// A device already opened with `GpuContext::new` (an offscreen renderer's, so that it
    /// draws straight from the simulation's body buffer).
    #[cfg(feature = "gpu")]
    Shared(Arc<GpuContext>),
    /// The device that draws into a window (the viewer's): picked for the window, so the
    /// messages call it the window's adapter.
    #[cfg(feature = "gpu")]
    Window(Arc<GpuContext>),
}

#[cfg(feature = "gpu")]
impl Device {
    fn open(self) -> Result<(Arc<GpuContext>, &'static str), GpuError> {
        Ok(match self {
            Device::Headless => (Arc::new(GpuContext::new()?), "the only GPU adapter"),
            Device::Shared(ctx) => (ctx, "the only GPU adapter"),
            Device::Window(ctx) => (ctx, "the window's adapter"),
        })
    }
}

/// Why a request for the GPU cannot be honoured (`auto` falls back to the CPU instead).
/// Its `Display` is the reason alone; [`BackendError::describe`] puts the front end's name
/// of the request in front.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BackendError {
    /// No GPU device could be opened.
    #[cfg(feature = "gpu")]
    #[error("{0}")]
    NoDevice(GpuError),
    /// The device was found but the scene does not fit it, or uses something the GPU
    /// pipeline does not support.
    #[cfg(feature = "gpu")]
    #[error("cannot run this scene on the GPU: {}", scene_reason(.0))]
    Scene(GpuError),
    /// This build has no GPU executor (the `gpu` feature is off).
    #[error("this module was built without GPU support (build it with the `gpu` feature)")]
    NotBuilt,
}

/// Why the GPU cannot run a scene, without repeating what [`BackendError::Scene`]'s own
/// words say ("the GPU backend cannot run this scene", "use --backend cpu" twice).
#[cfg(feature = "gpu")]
fn scene_reason(e: &GpuError) -> String {
    match e {
        GpuError::Unsupported(why) if why.contains("--backend cpu") => why.clone(),
        GpuError::Unsupported(why) => format!("{why}; use --backend cpu"),
        other => other.to_string(),
    }
}

impl BackendError {
    /// The error in a front end's words: `gpu_option` is its name for asking for the GPU
    /// (`--backend gpu`, `backend="gpu"`).
    pub fn describe(&self, gpu_option: &str) -> String {
        format!("{gpu_option}: {self}")
    }
}

/// Why the automatic choice fell back to the CPU.
#[derive(Debug, Clone, PartialEq)]
pub enum Fallback {
    /// No GPU device could be opened: why.
    NoDevice(String),
    /// The only adapter is a software rasteriser (correct, but slower than the CPU).
    Software {
        /// Which adapter: "the only GPU adapter" or "the window's adapter".
        which: &'static str,
        /// Its name.
        adapter: String,
    },
    /// The adapter cannot hold the scene, or the GPU pipeline lacks something it uses.
    DoesNotFit {
        /// The adapter's name.
        adapter: String,
        /// Why not.
        why: String,
    },
    /// This build has no GPU executor.
    NotBuilt,
}

/// Which pipeline [`choose`] picked, and why: the data of the `backend: ...` line, worded
/// by each front end with [`Choice::describe`].
#[derive(Debug, Clone, PartialEq)]
pub enum Choice {
    /// The CPU, as asked.
    Cpu,
    /// The GPU, as asked, on this adapter.
    Gpu {
        /// The adapter's name.
        adapter: String,
    },
    /// `auto` found a hardware adapter that fits the scene.
    AutoGpu {
        /// The adapter's name.
        adapter: String,
    },
    /// `auto` fell back to the CPU.
    AutoCpu(Fallback),
}

impl Choice {
    /// The choice in a front end's words (`gpu (auto: found ...)`, `cpu (auto: ...)`):
    /// `gpu_option` is its name for asking for the GPU (`--backend gpu`, `backend="gpu"`).
    pub fn describe(&self, gpu_option: &str) -> String {
        match self {
            Choice::Cpu => "cpu".into(),
            Choice::Gpu { adapter } => format!("gpu ({adapter})"),
            Choice::AutoGpu { adapter } => format!("gpu (auto: found {adapter})"),
            Choice::AutoCpu(why) => format!(
                "cpu (auto: {})",
                match why {
                    Fallback::NoDevice(e) => e.clone(),
                    Fallback::Software { which, adapter } => format!(
                        "{which}, {adapter}, is a software rasteriser, slower than the CPU pipeline; {gpu_option} uses it anyway"
                    ),
                    Fallback::DoesNotFit { adapter, why } => format!("found {adapter}, but {why}"),
                    Fallback::NotBuilt => "this module was built without GPU support".into(),
                }
            ),
        }
    }

    /// The line the command line prints on stderr (`backend: gpu (auto: found ...)`);
    /// `None` for the CPU asked for, which needs no explanation.
    pub fn note(&self) -> Option<String> {
        (*self != Choice::Cpu).then(|| format!("backend: {}", self.describe("--backend gpu")))
    }
}

/// The outcome of [`choose`].
pub struct Chosen {
    /// The pipeline that steps the world.
    pub stepper: Stepper,
    /// Which pipeline, and why.
    pub choice: Choice,
}

/// Chooses the pipeline for `world`: the one function behind every command's `--backend`.
///
/// - `Cpu`: the CPU; no device is opened.
/// - `Gpu`: the GPU on `device`, or an error saying why not.
/// - `Auto`: the GPU when the adapter is hardware and the scene fits it; the CPU when no
///   adapter is found, when the only one is a software rasteriser (lavapipe, llvmpipe,
///   WARP: correct, but slower than the CPU pipeline), or when the scene does not fit.
pub fn choose(
    choice: BackendChoice,
    world: &World,
    device: Device,
) -> Result<Chosen, BackendError> {
    match choice {
        BackendChoice::Cpu => Ok(Chosen {
            stepper: Stepper::Cpu,
            choice: Choice::Cpu,
        }),
        BackendChoice::Gpu | BackendChoice::Auto => choose_gpu(choice, world, device),
    }
}

#[cfg(not(feature = "gpu"))]
fn choose_gpu(
    choice: BackendChoice,
    _world: &World,
    _device: Device,
) -> Result<Chosen, BackendError> {
    match choice {
        BackendChoice::Gpu => Err(BackendError::NotBuilt),
        _ => Ok(Chosen {
            stepper: Stepper::Cpu,
            choice: Choice::AutoCpu(Fallback::NotBuilt),
        }),
    }
}

/// [`choose`] for `gpu` and `auto`.
#[cfg(feature = "gpu")]
fn choose_gpu(
    choice: BackendChoice,
    world: &World,
    device: Device,
) -> Result<Chosen, BackendError> {
    let gpu = |g: GpuWorld, auto: bool| {
        let adapter = g.context().adapter_name();
        Chosen {
            stepper: Stepper::Gpu(Box::new(g)),
            choice: if auto {
                Choice::AutoGpu { adapter }
            } else {
                Choice::Gpu { adapter }
            },
        }
    };
    let cpu = |why: Fallback| Chosen {
        stepper: Stepper::Cpu,
        choice: Choice::AutoCpu(why),
    };
    if choice == BackendChoice::Gpu {
        let (ctx, _) = device.open().map_err(BackendError::NoDevice)?;
        let g = GpuWorld::new(ctx, world).map_err(BackendError::Scene)?;
        return Ok(gpu(g, false));
    }
    let (ctx, which) = match device.open() {
        Ok(c) => c,
        Err(e) => return Ok(cpu(Fallback::NoDevice(e.to_string()))),
    };
    let adapter = ctx.adapter_name();
    if ctx.is_software() {
        return Ok(cpu(Fallback::Software { which, adapter }));
    }
    Ok(match GpuWorld::new(ctx, world) {
        Ok(g) => gpu(g, true),
        Err(e) => cpu(Fallback::DoesNotFit {
            adapter,
            why: e.to_string(),
        }),
    })
}

/// What comes back to the host's [`World`] after GPU steps (the CPU steps the world in
/// place, so it always has everything).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Readback {
    /// Nothing: the state stays on the GPU (timing, drawing from the GPU's body buffer).
    Nothing,
    /// Body state, step count and time, in the same transfer as the step's status.
    Bodies,
    /// Body state and the contact list with its springs and forces: outputs, health checks
    /// and checkpoints work on the world as after CPU steps.
    All,
}

/// What [`Stepper::step`] did.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Stepped {
    /// Steps taken.
    pub steps: u64,
    /// Touching contacts after the last step.
    pub contacts: usize,
    /// The most touching contacts after any of the steps (the GPU reports the last step
    /// only, so there it is `contacts`).
    pub max_contacts: usize,
    /// Touching contacts per step, averaged over the steps (on the GPU: `contacts`).
    pub mean_contacts: f64,
    /// The GPU's blow-up checks (`GpuWorld::set_health`) stopped it after `steps` steps,
    /// fewer than asked for maybe: the host checks that step itself
    /// (`clatter::health::Health::check`) and, if all is well, calls
    /// `GpuWorld::clear_alarm` and goes on ([`crate::Watch::after`]). Always false on the
    /// CPU.
    pub alarm: bool,
}

/// Why [`Stepper::step`] stopped.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StepError {
    /// The simulation blew up (a body became NaN or infinite); the world holds the state
    /// the pipeline stopped at.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The GPU failed (validation, out of memory, device lost).
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// The pipeline that steps a world: the commands call these methods and look inside only
/// for what one pipeline alone has (the GPU's body buffer, its kernel profile).
pub enum Stepper {
    /// The CPU pipeline: [`World::step`] on the world itself.
    Cpu,
    /// The GPU pipeline, with its own copy of the state.
    #[cfg(feature = "gpu")]
    Gpu(Box<GpuWorld>),
}

impl Stepper {
    /// Short name for messages and summaries: `cpu` or `gpu (<adapter>)`.
    pub fn name(&self) -> String {
        match self {
            Stepper::Cpu => "cpu".into(),
            #[cfg(feature = "gpu")]
            Stepper::Gpu(g) => format!("gpu ({})", g.context().adapter_name()),
        }
    }

    /// Whether the GPU pipeline steps the world.
    pub fn is_gpu(&self) -> bool {
        !matches!(self, Stepper::Cpu)
    }

    /// The GPU world, when the GPU steps.
    #[cfg(feature = "gpu")]
    pub fn as_gpu(&self) -> Option<&GpuWorld> {
        match self {
            Stepper::Cpu => None,
            Stepper::Gpu(g) => Some(g),
        }
    }

    /// The GPU world, mutably, when the GPU steps.
    #[cfg(feature = "gpu")]
    pub fn as_gpu_mut(&mut self) -> Option<&mut GpuWorld> {
        match self {
            Stepper::Cpu => None,
            Stepper::Gpu(g) => Some(g),
        }
    }

    /// Advances `world` by `steps` steps, stopping at the first that blows up.
    ///
    /// On the CPU, [`World::step`] `steps` times. On the GPU, the steps run there and
    /// `back` says what comes back into `world`; a body that becomes non-finite is reported
    /// as the CPU reports it ([`SimError::NonFinite`], with the step it happened in), and
    /// the world then holds the state the GPU stopped at, whatever `back` asked for.
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))]
    pub fn step(
        &mut self,
        world: &mut World,
        steps: u64,
        back: Readback,
    ) -> Result<Stepped, StepError> {
        if steps == 0 {
            let contacts = world.contact_count();
            return Ok(Stepped {
                steps: 0,
                contacts,
                max_contacts: contacts,
                mean_contacts: contacts as f64,
                alarm: false,
            });
        }
        match self {
            Stepper::Cpu => {
                let (mut last, mut max, mut sum) = (0, 0, 0);
                for _ in 0..steps {
                    let s = world.step()?;
                    last = s.contacts;
                    max = max.max(last);
                    sum += last;
                }
                Ok(Stepped {
                    steps,
                    contacts: last,
                    max_contacts: max,
                    mean_contacts: sum as f64 / steps as f64,
                    alarm: false,
                })
            }
            #[cfg(feature = "gpu")]
            Stepper::Gpu(gpu) => {
                let before = gpu.steps_taken();
                let report = match back {
                    Readback::Nothing => gpu.step(steps)?,
                    Readback::Bodies | Readback::All => gpu.step_into(steps, world)?,
                };
                if back == Readback::All {
                    gpu.read_contacts_into(world)?;
                } else if report.alarm {
                    gpu.read_into(world)?;
                }
                if let Some(body) = report.bad_body {
                    if back == Readback::Nothing {
                        gpu.read_into(world)?;
                    }
                    return Err(StepError::Sim(SimError::NonFinite {
                        body,
                        step: world.step_count + 1,
                        time: world.time + world.dt as f64,
                        dt: world.dt,
                    }));
                }
                Ok(Stepped {
                    steps: report.steps_done - before,
                    contacts: report.touching,
                    max_contacts: report.touching,
                    mean_contacts: report.touching as f64,
                    alarm: report.alarm,
                })
            }
        }
    }

    /// Brings the GPU's state (bodies, step count, time, contacts) back into `world`; on the
    /// CPU the world is always up to date and this does nothing.
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))]
    pub fn sync(&self, world: &mut World) -> Result<(), DeviceError> {
        match self {
            Stepper::Cpu => Ok(()),
            #[cfg(feature = "gpu")]
            Stepper::Gpu(g) => g.read_into(world),
        }
    }

    /// Brings only the GPU's body state, step count and time back into `world` (not the
    /// contact list); on the CPU this does nothing.
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))]
    pub fn sync_bodies(&self, world: &mut World) -> Result<(), DeviceError> {
        match self {
            Stepper::Cpu => Ok(()),
            #[cfg(feature = "gpu")]
            Stepper::Gpu(g) => g.read_bodies_into(world),
        }
    }

    /// Starts over from `world` (the viewer's Reset, or a world changed on the host): the
    /// GPU uploads it again on the same device; the CPU needs nothing.
    pub fn restart(&mut self, world: &World) -> Result<(), DeviceError> {
        #[cfg(feature = "gpu")]
        if let Stepper::Gpu(g) = self {
            **g = GpuWorld::new(g.context().clone(), world)?;
        }
        #[cfg(not(feature = "gpu"))]
        let _ = world;
        Ok(())
    }

    /// The world's step count: the world's own on the CPU; on the GPU the device's, which
    /// the world reaches at the next [`Stepper::sync`] (nothing is read back).
    pub fn step_count(&self, world: &World) -> u64 {
        match self {
            Stepper::Cpu => world.step_count,
            #[cfg(feature = "gpu")]
            Stepper::Gpu(g) => g.step_count(),
        }
    }

    /// The simulated time, as [`Stepper::step_count`] gives the step count.
    pub fn time(&self, world: &World) -> f64 {
        match self {
            Stepper::Cpu => world.time,
            #[cfg(feature = "gpu")]
            Stepper::Gpu(g) => g.time(),
        }
    }

    /// Broad-phase (pair list) rebuilds so far: the world's count on the CPU, the GPU's own
    /// since upload on the GPU.
    pub fn rebuilds(&self, world: &World) -> u64 {
        match self {
            Stepper::Cpu => world.rebuilds,
            #[cfg(feature = "gpu")]
            Stepper::Gpu(g) => g.rebuilds(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world() -> World {
        let text = include_str!("../../../scenes/bouncing-ball.toml");
        clatter::scene::Scene::parse(text, "bouncing-ball.toml")
            .expect("the scene parses")
            .world()
    }

    /// `--backend cpu` opens no device, says nothing, and steps as `World::step` does.
    #[test]
    fn cpu_stepper_is_world_step() {
        let mut a = world();
        let chosen = choose(BackendChoice::Cpu, &a, Device::Headless).expect("cpu");
        assert!(chosen.choice.note().is_none());
        let mut stepper = chosen.stepper;
        assert_eq!(stepper.name(), "cpu");
        assert!(!stepper.is_gpu());
        let mut b = a.clone();
        let s = stepper.step(&mut a, 25, Readback::Nothing).expect("steps");
        let mut max = 0;
        for _ in 0..25 {
            max = max.max(b.step().expect("steps").contacts);
        }
        assert_eq!(s.steps, 25);
        assert_eq!(s.max_contacts, max);
        assert_eq!(a.step_count, b.step_count);
        assert_eq!(a.state.position, b.state.position);
        stepper.sync(&mut a).expect("no-op");
        assert_eq!(stepper.rebuilds(&a), b.rebuilds);
    }

    /// On the GPU, the same steps come back through `Readback::All`.
    #[cfg(feature = "gpu")]
    #[test]
    fn gpu_stepper_reads_back() {
        let Some(ctx) = clatter_gpu::test_context() else {
            return;
        };
        let mut w = world();
        let chosen = choose(BackendChoice::Gpu, &w, Device::Shared(ctx)).expect("gpu");
        assert!(
            chosen
                .choice
                .note()
                .is_some_and(|n| n.starts_with("backend: gpu ("))
        );
        let mut stepper = chosen.stepper;
        assert!(stepper.is_gpu());
        let s = stepper.step(&mut w, 10, Readback::All).expect("steps");
        assert_eq!(s.steps, 10);
        assert_eq!(w.step_count, 10);
    }
}
