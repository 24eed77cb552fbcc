//! Opening a GPU device with wgpu, and the guards that keep the GPU path from panicking.
//!
//! [`GpuContext::new`] looks for adapters on the requested backends (Vulkan by default; Metal
//! on Apple and DX12 on Windows where built), picks the best (discrete before integrated before
//! virtual before software), checks the request's buffer sizes against the adapter's limits
//! *before* opening the device, and opens it with the adapter's own limits. Failures are
//! [`GpuError`]s with one actionable line: no adapter (what to install), only a software
//! adapter when a hardware one was required, an adapter too small (which limit, by how much),
//! a device that will not open.
//!
//! wgpu's default handler of uncaptured errors panics. The context replaces it with one that
//! records the error; every operation of this crate also runs inside error scopes
//! ([`GpuContext::scoped`]) and a lost device is recorded by its callback and reported as
//! [`GpuError::DeviceLost`] by the next operation, before any work is submitted.

use std::sync::{Arc, Mutex};

pub use wgpu::Backends;

use crate::error::{one_line, GpuError, Result};

/// What a caller needs from a device. [`GpuContext::new`] refuses an adapter that cannot give
/// it before opening anything.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuRequest {
    /// The wgpu backends to search (`WGPU_BACKEND`, e.g. `vulkan`, overrides it).
    pub backends: wgpu::Backends,
    /// Whether a software adapter (lavapipe, llvmpipe, WARP) is acceptable.
    pub allow_software: bool,
    /// The largest single storage-buffer binding the caller will make, bytes
    /// (`max_storage_buffer_binding_size`: 128 MiB on lavapipe).
    pub storage_binding_bytes: u64,
    /// The largest buffer the caller will allocate, bytes (`max_buffer_size`).
    pub buffer_bytes: u64,
}

impl Default for GpuRequest {
    /// Any adapter, software included, on the platform's native backends, with buffers up to
    /// 16 MiB (every adapter that wgpu supports gives 128 MiB).
    fn default() -> Self {
        Self {
            backends: wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12,
            allow_software: true,
            storage_binding_bytes: 16 << 20,
            buffer_bytes: 16 << 20,
        }
    }
}

/// What kind of device an adapter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DeviceKind {
    /// A GPU with its own memory.
    Discrete,
    /// A GPU sharing the CPU's memory.
    Integrated,
    /// A virtual or hosted GPU.
    Virtual,
    /// Software rendering on the CPU (lavapipe, llvmpipe, WARP).
    Software,
    /// The driver did not say.
    Other,
}

impl DeviceKind {
    fn of(t: wgpu::DeviceType) -> Self {
        match t {
            wgpu::DeviceType::DiscreteGpu => DeviceKind::Discrete,
            wgpu::DeviceType::IntegratedGpu => DeviceKind::Integrated,
            wgpu::DeviceType::VirtualGpu => DeviceKind::Virtual,
            wgpu::DeviceType::Cpu => DeviceKind::Software,
            wgpu::DeviceType::Other => DeviceKind::Other,
        }
    }

    /// Preference order of [`GpuContext::new`]: lower is better.
    fn rank(self) -> u8 {
        match self {
            DeviceKind::Discrete => 0,
            DeviceKind::Integrated => 1,
            DeviceKind::Virtual => 2,
            DeviceKind::Other => 3,
            DeviceKind::Software => 4,
        }
    }

    /// Short name: `discrete GPU`, `integrated GPU`, `virtual GPU`, `CPU`, `unknown`.
    pub fn name(self) -> &'static str {
        match self {
            DeviceKind::Discrete => "discrete GPU",
            DeviceKind::Integrated => "integrated GPU",
            DeviceKind::Virtual => "virtual GPU",
            DeviceKind::Software => "CPU",
            DeviceKind::Other => "unknown",
        }
    }
}

/// The adapter a context runs on, for the user and for reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    /// The device name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub name: String,
    /// The wgpu backend, e.g. `Vulkan`.
    pub backend: String,
    /// What kind of device it is.
    pub kind: DeviceKind,
    /// Driver name and version, e.g. `llvmpipe, Mesa 22.3.6 (LLVM 15.0.6)`.
    pub driver: String,
}

impl AdapterSummary {
    fn of(info: &wgpu::AdapterInfo) -> Self {
        let backend = match info.backend {
            wgpu::Backend::Vulkan => "Vulkan".to_string(),
            wgpu::Backend::Metal => "Metal".to_string(),
            wgpu::Backend::Dx12 => "DX12".to_string(),
            wgpu::Backend::Gl => "GL".to_string(),
            other => other.to_string(),
        };
        let driver = [info.driver.as_str(), info.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(", ");
        Self {
            name: info.name.clone(),
            backend,
            kind: DeviceKind::of(info.device_type),
            driver,
        }
    }

    /// Whether the adapter renders in software on the CPU.
    pub fn is_software(&self) -> bool {
        self.kind == DeviceKind::Software
    }
}

impl std::fmt::Display for AdapterSummary {
    /// `name (backend, kind)`, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, CPU)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, {})", self.name, self.backend, self.kind.name())
    }
}

/// State the device's callbacks write and every operation reads.
#[derive(Default)]
struct Health {
    /// Set by the device-lost callback.
    lost: Option<String>,
    /// Errors that escaped every error scope (recorded instead of wgpu's default panic).
    uncaptured: Vec<String>,
}

struct Inner {
    /// The instance and adapter the device was opened from: a presenter on the same device
    /// makes its window surface with them ([`GpuContext::instance`]).
    instance: wgpu::Instance,
    adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
    summary: AdapterSummary,
    limits: wgpu::Limits,
    features: wgpu::Features,
    health: Arc<Mutex<Health>>,
    gate: crate::lockstep::SubmissionGate,
    traffic: crate::traffic::Traffic,
}

/// An open GPU device and its queue, with the adapter it runs on. Cheap to clone (shared).
#[derive(Clone)]
pub struct GpuContext {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.inner.summary)
            .finish_non_exhaustive()
    }
}

impl GpuContext {
    /// Opens a device that meets `request` on the best adapter (see the module docs).
    pub fn new(request: &GpuRequest) -> Result<Self> {
        pollster::block_on(Self::new_async(request))
    }

    async fn new_async(request: &GpuRequest) -> Result<Self> {
        let desc = wgpu::InstanceDescriptor {
            backends: request.backends,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        }
        .with_env();
        let backends = desc.backends & wgpu::Instance::enabled_backend_features();
        let instance = wgpu::Instance::new(desc);
        let mut adapters = instance.enumerate_adapters(backends).await;
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter {
                backends: backend_names(backends),
            });
        }
        adapters.sort_by_key(|a| DeviceKind::of(a.get_info().device_type).rank());
        if !request.allow_software {
            let software: Vec<String> = adapters
                .iter()
                .map(|a| AdapterSummary::of(&a.get_info()))
                .filter(AdapterSummary::is_software)
                .map(|s| s.to_string())
                .collect();
            adapters.retain(|a| a.get_info().device_type != wgpu::DeviceType::Cpu);
            if adapters.is_empty() {
                return Err(GpuError::SoftwareOnly {
                    adapters: software.join(", "),
                });
            }
        }
        let adapter = adapters.swap_remove(0);
        let summary = AdapterSummary::of(&adapter.get_info());
        let limits = adapter.limits();
        check_limit(
            &summary,
            "the requested storage binding",
            request.storage_binding_bytes,
            "max_storage_buffer_binding_size",
            limits.max_storage_buffer_binding_size,
        )?;
        check_limit(
            &summary,
            "the requested buffer",
            request.buffer_bytes,
            "max_buffer_size",
            limits.max_buffer_size,
        )?;
        // Timestamp queries where the adapter has them (lavapipe does): per-pass GPU times.
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("fovea-gpu"),
                required_features: features,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::RequestDevice {
                adapter: summary.to_string(),
                reason: one_line(&e.to_string()),
            })?;
        let health = Arc::new(Mutex::new(Health::default()));
        {
            let health = health.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                if let Ok(mut h) = health.lock() {
                    h.uncaptured.push(one_line(&e.to_string()));
                }
            }));
        }
        {
            let health = health.clone();
            device.set_device_lost_callback(move |reason, message| {
                if let Ok(mut h) = health.lock() {
                    h.lost = Some(one_line(&format!("{reason:?}: {message}")));
                }
            });
        }
        Ok(Self {
            inner: Arc::new(Inner {
                instance,
                adapter,
                device,
                queue,
                summary,
                limits,
                features,
                health,
                gate: Default::default(),
                traffic: Default::default(),
            }),
        })
    }

    /// Whether the device writes timestamps (`wgpu::Features::TIMESTAMP_QUERY`), so passes
    /// can report their GPU time.
    pub fn has_timestamps(&self) -> bool {
        self.inner
            .features
            .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// The adapter the device runs on.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.inner.summary
    }

    /// The wgpu instance the device was opened from: a window surface for a presenter that
    /// draws with this very device is made with it (`Instance::create_surface`), so that the
    /// frames and the window share one device (issue 37, item 6).
    pub fn instance(&self) -> &wgpu::Instance {
        &self.inner.instance
    }

    /// Whether this device's adapter can present to `surface` (made with [`Self::instance`]).
    pub fn can_present_to(&self, surface: &wgpu::Surface<'_>) -> bool {
        self.inner.adapter.is_surface_supported(surface)
    }

    /// `surface`'s formats, present modes and alpha modes on this device's adapter.
    pub fn surface_capabilities(&self, surface: &wgpu::Surface<'_>) -> wgpu::SurfaceCapabilities {
        surface.get_capabilities(&self.inner.adapter)
    }

    /// `surface`'s default configuration on this device's adapter at `width` × `height`
    /// pixels; `None` when the adapter cannot present to it.
    pub fn surface_config(
        &self,
        surface: &wgpu::Surface<'_>,
        width: u32,
        height: u32,
    ) -> Option<wgpu::SurfaceConfiguration> {
        surface.get_default_config(&self.inner.adapter, width, height)
    }

    /// The device's limits (the adapter's own).
    pub fn limits(&self) -> &wgpu::Limits {
        &self.inner.limits
    }

    /// The wgpu device, for passes outside this crate. Errors of work recorded on it outside
    /// [`Self::scoped`] are recorded, not raised, and reported by the next scoped operation.
    pub fn device(&self) -> &wgpu::Device {
        &self.inner.device
    }

    /// The wgpu queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.inner.queue
    }

    /// Submits a pass's command buffers to the queue — with the other eye's in one
    /// submission while both eyes render in lockstep ([`crate::lockstep`]). Every pass of
    /// this crate submits through here.
    pub fn submit(&self, buffers: impl IntoIterator<Item = wgpu::CommandBuffer>) {
        let since = std::time::Instant::now();
        self.inner
            .gate
            .submit(&self.inner.queue, buffers.into_iter().collect());
        self.inner.traffic.blocked(since);
    }

    /// The device's submission gate.
    pub(crate) fn gate(&self) -> &crate::lockstep::SubmissionGate {
        &self.inner.gate
    }

    /// The device's transfer counters ([`crate::traffic`]).
    pub(crate) fn traffic_counters(&self) -> &crate::traffic::Traffic {
        &self.inner.traffic
    }

    /// [`GpuError::DeviceLost`] once the device is lost, or an error recorded outside every
    /// scope as [`GpuError::Validation`]; `Ok` otherwise.
    pub fn check_health(&self) -> Result<()> {
        // Lets wgpu run its callbacks (the device-lost one among them) without blocking.
        let polled = self.inner.device.poll(wgpu::PollType::Poll);
        let mut h = self.inner.health.lock().map_err(|_| GpuError::DeviceLost {
            reason: "a thread panicked while holding the device state".to_string(),
        })?;
        if let Some(reason) = &h.lost {
            return Err(GpuError::DeviceLost {
                reason: reason.clone(),
            });
        }
        if let Err(e) = polled {
            return Err(GpuError::DeviceLost {
                reason: one_line(&e.to_string()),
            });
        }
        if !h.uncaptured.is_empty() {
            let message = h.uncaptured.join("; ");
            h.uncaptured.clear();
            return Err(GpuError::Validation {
                what: "earlier work".to_string(),
                message,
            });
        }
        Ok(())
    }

    /// The largest storage binding a buffer can have on this device, bytes: the smaller of
    /// `max_storage_buffer_binding_size` and `max_buffer_size` (what
    /// [`Self::check_storage_binding`] accepts).
    pub fn max_binding_bytes(&self) -> u64 {
        self.inner
            .limits
            .max_storage_buffer_binding_size
            .min(self.inner.limits.max_buffer_size)
    }

    /// [`GpuError::AdapterTooSmall`] when a storage binding of `bytes` exceeds the device's
    /// limits; call before allocating.
    pub fn check_storage_binding(&self, what: &str, bytes: u64) -> Result<()> {
        check_limit(
            &self.inner.summary,
            what,
            bytes,
            "max_storage_buffer_binding_size",
            self.inner.limits.max_storage_buffer_binding_size,
        )?;
        check_limit(
            &self.inner.summary,
            what,
            bytes,
            "max_buffer_size",
            self.inner.limits.max_buffer_size,
        )
    }

    /// Runs `f` (which records or submits work on the device) inside validation and
    /// out-of-memory error scopes, after checking the device's health; returns what `f`
    /// returned, or the first error wgpu reported for it.
    pub fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        self.check_health()?;
        let device = &self.inner.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let validation = pollster::block_on(validation.pop());
        let oom = pollster::block_on(oom.pop());
        if let Some(e) = oom {
            return Err(GpuError::OutOfMemory {
                what: format!("{what} ({})", one_line(&e.to_string())),
            });
        }
        if let Some(e) = validation {
            return Err(GpuError::Validation {
                what: what.to_string(),
                message: one_line(&e.to_string()),
            });
        }
        self.check_health()?;
        Ok(out)
    }

    /// Blocks until the queue is idle; [`GpuError::DeviceLost`] if it never will be.
    pub fn wait_idle(&self, what: &str) -> Result<()> {
        let since = std::time::Instant::now();
        let polled = self.inner.device.poll(wgpu::PollType::wait_indefinitely());
        self.inner.traffic.waited(since);
        polled.map_err(|e| GpuError::DeviceLost {
            reason: format!("waiting for {what}: {}", one_line(&e.to_string())),
        })?;
        self.check_health()
    }
}

fn check_limit(
    adapter: &AdapterSummary,
    what: &str,
    needed: u64,
    limit_name: &'static str,
    limit: u64,
) -> Result<()> {
    if needed > limit {
        return Err(GpuError::AdapterTooSmall {
            adapter: adapter.to_string(),
            what: what.to_string(),
            needed,
            limit_name,
            limit,
        });
    }
    Ok(())
}

/// `Vulkan, Metal` etc., for messages; `none built` when the set is empty.
fn backend_names(backends: wgpu::Backends) -> String {
    let names: Vec<&str> = [
        (wgpu::Backends::VULKAN, "Vulkan"),
        (wgpu::Backends::METAL, "Metal"),
        (wgpu::Backends::DX12, "DX12"),
        (wgpu::Backends::GL, "GL"),
    ]
    .iter()
    .filter(|(b, _)| backends.contains(*b))
    .map(|&(_, n)| n)
    .collect();
    if names.is_empty() {
        "searched: no backend built into this binary".to_string()
    } else {
        format!("searched: {}", names.join(", "))
    }
}

impl GpuContext {
    /// How this device's submissions went so far: how many, how many carried both eyes'
    /// work, how many the passes posted.
    pub fn submission_counts(&self) -> crate::lockstep::SubmissionCounts {
        self.gate().counts()
    }
}

/// The device as the meeting point of both eyes' submissions
/// (`fovea_render::pipeline::lockstep`; [`crate::lockstep`]).
impl fovea_render::pipeline::Lockstep for GpuContext {
    fn enter(&self) {
        self.gate().enter();
    }

    fn leave(&self) {
        self.gate().leave(self.queue());
    }
}

impl GpuContext {
    /// What this device has moved and waited for so far
    /// ([`TrafficCounts`](crate::traffic::TrafficCounts)).
    pub fn traffic(&self) -> crate::traffic::TrafficCounts {
        self.traffic_counters()
            .snapshot(self.submission_counts().submissions)
    }

    /// `wgpu::Device::create_buffer`, counted.
    pub(crate) fn create_buffer(&self, desc: &wgpu::BufferDescriptor<'_>) -> wgpu::Buffer {
        self.traffic_counters().buffer(desc.size);
        self.device().create_buffer(desc)
    }

    /// `wgpu::Queue::write_buffer`, counted.
    pub(crate) fn write_buffer(&self, buffer: &wgpu::Buffer, offset: u64, data: &[u8]) {
        self.traffic_counters().uploaded(data.len() as u64);
        self.queue().write_buffer(buffer, offset, data);
    }

    /// `wgpu::Device::create_bind_group`, counted.
    pub(crate) fn create_bind_group(
        &self,
        desc: &wgpu::BindGroupDescriptor<'_>,
    ) -> wgpu::BindGroup {
        self.traffic_counters().bind_group();
        self.device().create_bind_group(desc)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn too_small_names_the_limit_and_the_numbers() {
        let a = AdapterSummary {
            name: "llvmpipe".into(),
            backend: "Vulkan".into(),
            kind: DeviceKind::Software,
            driver: String::new(),
        };
        assert!(check_limit(&a, "x", 10, "max_buffer_size", 10).is_ok());
        let e = check_limit(&a, "the LP buffer", 11, "max_buffer_size", 10)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("llvmpipe (Vulkan, CPU)")
                && e.contains("the LP buffer needs 11 bytes")
                && e.contains("`max_buffer_size` is 10"),
            "{e}"
        );
        assert!(!e.contains('\n'));
    }

    #[test]
    fn device_kinds_rank_hardware_first() {
        use wgpu::DeviceType as T;
        let mut kinds = [
            T::Cpu,
            T::Other,
            T::VirtualGpu,
            T::IntegratedGpu,
            T::DiscreteGpu,
        ]
        .map(DeviceKind::of);
        kinds.sort_by_key(|k| k.rank());
        assert_eq!(kinds[0], DeviceKind::Discrete);
        assert_eq!(kinds[4], DeviceKind::Software);
    }
}
