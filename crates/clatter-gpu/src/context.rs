//! The GPU device: adapter choice, limits, error capture.
//!
//! One [`GpuContext`] holds the `wgpu` device and queue that the simulation (and the
//! renderer) share. It asks for the adapter's own limits, not wgpu's small defaults, so that
//! large scenes fit, and it records validation errors and device loss so that a broken
//! shader or a lost GPU is reported as an error instead of a hang or garbage.

use std::sync::{Arc, Mutex};

use thiserror::Error;

/// Errors of the GPU backend.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GpuError {
    /// No adapter (GPU or software rasteriser) was found.
    #[error(
        "no GPU adapter found ({0}); install a Vulkan driver (e.g. `apt-get install mesa-vulkan-drivers libvulkan1` for the CPU rasteriser lavapipe), or use --backend cpu"
    )]
    NoAdapter(String),
    /// The adapter refused the device we asked for.
    #[error("the GPU adapter '{adapter}' refused to create a device: {reason}")]
    Device { adapter: String, reason: String },
    /// The scene does not fit the adapter's limits.
    #[error(
        "the scene needs {need} but the GPU adapter '{adapter}' allows {limit} ({what}); {advice}"
    )]
    TooLarge {
        adapter: String,
        what: String,
        need: String,
        limit: String,
        advice: String,
    },
    /// The scene uses something the GPU backend does not support.
    #[error("the GPU backend cannot run this scene: {0}; use --backend cpu")]
    Unsupported(String),
    /// A validation or out-of-memory error, or device loss, reported by wgpu.
    #[error("GPU error on '{adapter}': {message}")]
    Runtime { adapter: String, message: String },
}

/// A device and queue with the adapter's description and an error sink.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// The limits the device was created with (the adapter's own).
    pub limits: wgpu::Limits,
    /// Whether timestamp queries are available (for `clatter bench`).
    pub timestamps: bool,
    errors: Arc<Mutex<Vec<String>>>,
    /// The simulation's compiled pipelines, built once per device (shader compilation is
    /// slow on software adapters).
    pub(crate) pipelines: Mutex<Option<Arc<dyn std::any::Any + Send + Sync>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter_name())
            .finish()
    }
}

impl GpuContext {
    /// Opens the best adapter wgpu finds (high performance first; `WGPU_BACKEND`,
    /// `WGPU_ADAPTER_NAME` and `WGPU_POWER_PREF` select another) without any window system.
    ///
    /// On a machine without a Wayland session it first turns Mesa's Vulkan device-selection
    /// layer off for the process (see [`quiet_device_select`]), so that probing prints
    /// nothing.
    pub fn new() -> Result<GpuContext, GpuError> {
        pollster::block_on(Self::new_async())
    }

    /// [`GpuContext::new`] on a device whose limits `lower` lowers from the adapter's own:
    /// what a scene does on a device with less room (e.g. the tests of scenes too large).
    pub fn with_limits(lower: impl FnOnce(&mut wgpu::Limits)) -> Result<GpuContext, GpuError> {
        pollster::block_on(async {
            let adapter = Self::adapter().await?;
            let mut limits = adapter.limits();
            lower(&mut limits);
            Self::from_adapter_with_limits(adapter, limits).await
        })
    }

    async fn new_async() -> Result<GpuContext, GpuError> {
        let adapter = Self::adapter().await?;
        Self::from_adapter(adapter).await
    }

    /// The adapter [`GpuContext::new`] opens.
    async fn adapter() -> Result<wgpu::Adapter, GpuError> {
        quiet_device_select();
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::from_env().unwrap_or(desc.backends);
        desc.flags = instance_flags(desc.flags);
        let instance = wgpu::Instance::new(desc);
        let power =
            wgpu::PowerPreference::from_env().unwrap_or(wgpu::PowerPreference::HighPerformance);
        // `WGPU_ADAPTER_NAME` as wgpu's `initialize_adapter_from_env` reads it (a
        // case-insensitive part of the adapter's name), which panics when no adapter
        // matches: here that is an error naming the adapters there are.
        let by_name = match std::env::var("WGPU_ADAPTER_NAME") {
            Ok(want) if !want.is_empty() => {
                let want_lc = want.to_lowercase();
                let adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
                let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                match adapters
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&want_lc))
                {
                    Some(a) => Ok(a),
                    None => {
                        return Err(GpuError::NoAdapter(format!(
                            "WGPU_ADAPTER_NAME={want} matches no adapter (found: {})",
                            if names.is_empty() {
                                "none".to_string()
                            } else {
                                names.join(", ")
                            }
                        )));
                    }
                }
            }
            _ => Err(()),
        };
        let adapter = match by_name {
            Ok(a) => a,
            Err(()) => instance
                .request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: power,
                    force_fallback_adapter: false,
                    compatible_surface: None,
                    apply_limit_buckets: false,
                })
                .await
                .map_err(|e| GpuError::NoAdapter(e.to_string()))?,
        };
        Ok(adapter)
    }

    /// Opens a device on `adapter` with its own limits.
    pub async fn from_adapter(adapter: wgpu::Adapter) -> Result<GpuContext, GpuError> {
        let limits = adapter.limits();
        Self::from_adapter_with_limits(adapter, limits).await
    }

    /// Opens a device on `adapter` with `limits` (at most the adapter's own).
    async fn from_adapter_with_limits(
        adapter: wgpu::Adapter,
        limits: wgpu::Limits,
    ) -> Result<GpuContext, GpuError> {
        let adapter_info = adapter.get_info();
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut required_features = wgpu::Features::empty();
        if timestamps {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("clatter"),
                required_features,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::Device {
                adapter: adapter_info.name.clone(),
                reason: e.to_string(),
            })?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let sink = errors.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut v) = sink.lock() {
                v.push(format!("device lost ({reason:?}): {message}"));
            }
        });
        Ok(GpuContext {
            device,
            queue,
            adapter_info,
            limits,
            timestamps,
            errors,
            pipelines: Mutex::new(None),
        })
    }

    /// The adapter's name and backend, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub fn adapter_name(&self) -> String {
        format!(
            "{} ({:?})",
            self.adapter_info.name, self.adapter_info.backend
        )
    }

    /// Whether the adapter is a CPU rasteriser (lavapipe, llvmpipe, WARP): correct but slow.
    pub fn is_software(&self) -> bool {
        self.adapter_info.device_type == wgpu::DeviceType::Cpu
    }

    /// Into how many contiguous runs of workgroups the adapter splits a dispatch
    /// ([`crate::layout::Params::deal`]): on a CPU rasteriser (Mesa's lavapipe and
    /// llvmpipe) one run per thread of its pool, which has `LP_NUM_THREADS` threads, by
    /// default one per CPU (at most 32); 1 on a real GPU. Only how evenly the adapter's
    /// threads share the work depends on it, never a result.
    pub fn workgroup_runs(&self) -> u32 {
        if !self.is_software() {
            return 1;
        }
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let threads = std::env::var("LP_NUM_THREADS")
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .unwrap_or(cpus);
        threads.clamp(1, 32) as u32
    }

    /// The first error wgpu reported since the last call (validation, out of memory, device
    /// lost), as a [`GpuError::Runtime`].
    pub fn take_error(&self) -> Result<(), GpuError> {
        let mut v = self.errors.lock().map_err(|_| GpuError::Runtime {
            adapter: self.adapter_name(),
            message: "error sink poisoned".into(),
        })?;
        if v.is_empty() {
            return Ok(());
        }
        let message = v.join("; ");
        v.clear();
        Err(GpuError::Runtime {
            adapter: self.adapter_name(),
            message,
        })
    }

    /// Waits for all submitted work, then reports any error wgpu recorded.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Runtime {
                adapter: self.adapter_name(),
                message: e.to_string(),
            })?;
        self.take_error()
    }
}

/// Keeps Mesa's Vulkan device-selection layer from printing
/// `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` (twice) on stderr when
/// a headless [`GpuContext`] looks for adapters on a machine without a Wayland session.
///
/// The layer (`VK_LAYER_MESA_device_select`, an implicit layer that Mesa's Vulkan drivers
/// install) reorders the GPUs so that the one driving the desktop comes first, and to find
/// it asks Wayland whenever the instance enables `VK_KHR_wayland_surface`, which wgpu always
/// does; libwayland complains when `XDG_RUNTIME_DIR` is not set. Without a Wayland socket
/// that question has no answer, and a headless context does not care which GPU drives a
/// display (wgpu orders the adapters by power preference itself), so the layer is turned
/// off with its own switch, `NODEVICE_SELECT=1`, unless the user chose a device through it
/// (`MESA_VK_DEVICE_SELECT`, `DRI_PRIME`) or set `NODEVICE_SELECT` already. The variable
/// is set once, before the first instance, and left set. Nothing else changes: OpenGL
/// (`WGPU_BACKEND=gl`) probes through EGL's surfaceless platform, which does not ask
/// Wayland. The viewer calls it too before its own (windowed) instance: under Xvfb the layer
/// asks Wayland first in the same way.
pub fn quiet_device_select() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        if !cfg!(all(
            unix,
            not(target_vendor = "apple"),
            not(target_os = "android")
        )) {
            return;
        }
        let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
        let absolute = |name: &str| {
            std::env::var_os(name).is_some_and(|v| std::path::Path::new(&v).is_absolute())
        };
        // libwayland finds a socket with XDG_RUNTIME_DIR, or with WAYLAND_DISPLAY as a path.
        let wayland_reachable = absolute("XDG_RUNTIME_DIR") || absolute("WAYLAND_DISPLAY");
        if wayland_reachable
            || set("NODEVICE_SELECT")
            || set("MESA_VK_DEVICE_SELECT")
            || set("DRI_PRIME")
        {
            return;
        }
        // SAFETY: `set_var` races with threads that read the environment through libc at
        // the same moment. This runs once, when the first context or window instance is
        // opened: in the `clatter` binary that is before any GPU driver is loaded, and clatter's own
        // threads (rayon's pool, the progress bar) read the environment only through
        // `std::env`, which takes the same lock as `set_var`. A program that opened another
        // wgpu instance on another thread first would have to avoid doing so concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    });
}

/// The instance flags clatter runs with: `base` without wgpu's validation of indirect
/// dispatch arguments where that is safe, then the `WGPU_*` environment overrides.
///
/// wgpu checks every indirect dispatch's arguments on the GPU by default (an extra dispatch
/// and barriers each time); the step records about 30 indirect dispatches, most of them
/// sized zero, and on an H100 that check cost about 12 us a dispatch, more than the step's
/// work for scenes under 100,000 bodies. clatter's kernels write every argument through
/// `write_args` (`shaders/common/args.wgsl`), which keeps each dimension within 65,535, the limit
/// the check enforces, so the check can go. On DX12 it also supplies `num_workgroups`, which
/// the kernels use, so it stays on for Windows. `WGPU_VALIDATION_INDIRECT_CALL=1` turns it
/// back on anywhere.
pub fn instance_flags(base: wgpu::InstanceFlags) -> wgpu::InstanceFlags {
    let mut flags = base;
    if !cfg!(windows) {
        flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    }
    flags.with_env()
}

/// For tests: the GPU context, shared by all tests of a test binary (pipelines are compiled
/// once per device, which matters on software adapters), or `None` with a loud message when
/// no adapter exists. When the `CI` environment variable is set, a missing adapter is a
/// failure, not a skip. (Feature `test-harness`.)
#[cfg(feature = "test-harness")]
pub fn test_context() -> Option<Arc<GpuContext>> {
    static SHARED: std::sync::OnceLock<Result<Arc<GpuContext>, GpuError>> =
        std::sync::OnceLock::new();
    match SHARED.get_or_init(|| GpuContext::new().map(Arc::new)) {
        Ok(c) => Some(c.clone()),
        Err(e) => {
            if std::env::var_os("CI").is_some() {
                panic!("CI is set but no GPU adapter is available: {e}");
            }
            eprintln!(
                "\n*** SKIPPED GPU TEST: {e} ***\n*** (set CI=1 to make this a failure) ***\n"
            );
            None
        }
    }
}
