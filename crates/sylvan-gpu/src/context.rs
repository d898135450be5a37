//! Device creation on whatever adapter exists, and error capture instead of panics.

use std::sync::{Arc, Mutex};

/// What to install when no adapter exists (Debian package names).
pub const INSTALL_HINT: &str = "install Mesa's software Vulkan driver with `sudo apt-get install -y \
mesa-vulkan-drivers libvulkan1` (GL fallback: `libegl1 libegl-mesa0 libgl1-mesa-dri`), or run \
`cargo xtask test` / `cargo xtask demo`, which install it for you";

/// Errors from device creation and GPU work.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter on any backend.
    #[error("no GPU adapter found (tried {backends}) — {INSTALL_HINT}")]
    NoAdapter {
        /// The backends that were tried.
        backends: String,
    },
    /// The adapter refused the device request.
    #[error(
        "could not open a device on '{adapter}': {reason} — try another backend with WGPU_BACKEND=vulkan|gl"
    )]
    Device {
        /// Adapter name.
        adapter: String,
        /// wgpu's reason.
        reason: String,
    },
    /// A request exceeds what the device allows.
    #[error("{what} needs {needed} but this device allows at most {limit} — {fix}")]
    Limit {
        /// What was asked for.
        what: String,
        /// How much was needed.
        needed: u64,
        /// The device limit.
        limit: u64,
        /// What to do instead.
        fix: String,
    },
    /// wgpu reported a validation or out-of-memory error.
    #[error("GPU error: {0}")]
    Wgpu(String),
}

/// A headless wgpu device and queue, plus what Sylvan needs to know about the adapter.
pub struct Gpu {
    /// The wgpu instance (kept for surfaces in the viewer).
    pub instance: wgpu::Instance,
    /// The adapter in use.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// The queue.
    pub queue: wgpu::Queue,
    /// Adapter name, driver and backend.
    pub info: wgpu::AdapterInfo,
    /// Whether GPU timestamp queries (inside encoders) are available.
    pub timestamps: bool,
    errors: Arc<Mutex<Vec<String>>>,
    /// Whether the device is the caller's ([`Gpu::from_parts`]): its uncaptured-error handler
    /// is theirs, so Sylvan captures its own errors with error scopes instead.
    external: bool,
}

impl Gpu {
    /// Opens a device on the best adapter available (`WGPU_BACKEND` selects a backend).
    pub fn new() -> Result<Self, GpuError> {
        Self::open(None)
    }

    /// Opens a device on the best adapter of `backends` only (e.g. to compare Vulkan and GL in
    /// one process), whatever `WGPU_BACKEND` says.
    pub fn with_backends(backends: wgpu::Backends) -> Result<Self, GpuError> {
        Self::open(Some(backends))
    }

    fn open(backends: Option<wgpu::Backends>) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if let Some(b) = backends {
            desc.backends = b;
        }
        let backends = [
            (wgpu::Backends::VULKAN, "Vulkan"),
            (wgpu::Backends::GL, "GL"),
            (wgpu::Backends::METAL, "Metal"),
            (wgpu::Backends::DX12, "DX12"),
        ]
        .iter()
        .filter(|(b, _)| desc.backends.contains(*b))
        .map(|(_, n)| *n)
        .collect::<Vec<_>>()
        .join(", ");
        let instance = wgpu::Instance::new(desc);
        Self::with_instance(instance, None, backends)
    }

    /// Opens a device on an adapter compatible with `surface` (for windows), from `instance`.
    pub fn with_instance(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
        backends: String,
    ) -> Result<Self, GpuError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            apply_limit_buckets: false,
        }))
        .map_err(|_| GpuError::NoAdapter { backends })?;
        let info = adapter.get_info();
        let want =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let timestamps = adapter.features().contains(want);
        let mut features = if timestamps {
            want
        } else {
            wgpu::Features::empty()
        };
        // GPU-written draws that start at an instance other than 0 (`boxtree`'s lists).
        features |= adapter.features() & wgpu::Features::INDIRECT_FIRST_INSTANCE;
        // Ask for the adapter's own limits: big atlases and storage buffers need them, and
        // every allocation is checked against `device.limits()` first.
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sylvan"),
            required_features: features,
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            reason: e.to_string(),
        })?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(one_line(&e.to_string()));
            }
        }));
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
            info,
            timestamps,
            errors,
            external: false,
        })
    }

    /// Wraps a device the caller already has (their own wgpu renderer, Bevy's `RenderDevice`):
    /// Sylvan records into it and leaves its settings and its uncaptured-error handler alone.
    /// Errors of Sylvan's own resource creation are caught with error scopes
    /// ([`Gpu::scoped`]); errors in recorded work reach the caller's handler.
    ///
    /// The device should have the adapter's limits (Sylvan's atlases and storage buffers need
    /// more than wgpu's defaults); every allocation is checked against `device.limits()` first.
    pub fn from_parts(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
    ) -> Self {
        let want =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        Self {
            info: adapter.get_info(),
            timestamps: device.features().contains(want),
            instance,
            adapter,
            device,
            queue,
            errors: Arc::new(Mutex::new(Vec::new())),
            external: true,
        }
    }

    /// Whether the device is the caller's ([`Gpu::from_parts`]).
    pub fn is_external(&self) -> bool {
        self.external
    }

    /// Runs `f`, catching the validation and out-of-memory errors it causes: on a caller's
    /// device through error scopes (their handler never sees them), on Sylvan's own device
    /// through its handler. Returns `f`'s error, or the first GPU error, as `E`.
    pub fn scoped<T, E: From<GpuError>>(&self, f: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        if !self.external {
            let out = f()?;
            self.check()?;
            return Ok(out);
        }
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let first = pollster::block_on(validation.pop());
        let second = pollster::block_on(memory.pop());
        let out = out?;
        match first.or(second) {
            Some(e) => Err(GpuError::Wgpu(one_line(&e.to_string())).into()),
            None => Ok(out),
        }
    }

    /// "name (backend, driver)" for stats output.
    pub fn adapter_label(&self) -> String {
        let driver = if self.info.driver.is_empty() {
            String::new()
        } else {
            format!(", {}", self.info.driver)
        };
        format!("{} ({:?}{})", self.info.name, self.info.backend, driver)
    }

    /// Whether the adapter is a software rasteriser (lavapipe, llvmpipe).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Wgpu(e.to_string()))?;
        self.check()
    }

    /// Returns the first GPU error captured since the last check, if any.
    pub fn check(&self) -> Result<(), GpuError> {
        let mut errors = self
            .errors
            .lock()
            .map_err(|_| GpuError::Wgpu("error sink poisoned".into()))?;
        match errors.drain(..).next() {
            Some(e) => Err(GpuError::Wgpu(e)),
            None => Ok(()),
        }
    }

    /// Checks a 2D texture size against the device limit.
    pub fn check_texture_size(&self, what: &str, width: u32, height: u32) -> Result<(), GpuError> {
        let limit = self.device.limits().max_texture_dimension_2d;
        let needed = width.max(height);
        if needed > limit || width == 0 || height == 0 {
            return Err(GpuError::Limit {
                what: what.to_string(),
                needed: needed as u64,
                limit: limit as u64,
                fix: "use a smaller --size or fewer samples (--spp)".into(),
            });
        }
        Ok(())
    }
}

/// wgpu's message spans several lines (error, then causes): keep it on one.
fn one_line(text: &str) -> String {
    let parts: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    parts.join(" ")
}
