//! The headless wgpu context: adapter choice, device creation, tracked resource creation and
//! read-back.
//!
//! A process opens one device per adapter and feature set and shares it between its contexts
//! (see [`GpuContext::with_options`]): drivers do not promise that a process may create and
//! destroy devices without end, and a service renders job after job.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, mpsc};

use wgpu::util::DeviceExt;

use crate::GpuError;
use crate::memory::{MemoryReport, MemoryTracker, texture_bytes};

/// Environment variable that picks an adapter by a substring of its name (case-insensitive),
/// e.g. `GI_ADAPTER=llvmpipe` or `GI_ADAPTER=H100`.
pub const ADAPTER_ENV: &str = "GI_ADAPTER";

/// Environment variable that turns "no adapter" from a skipped GPU test into a failure. CI sets
/// it so GPU tests cannot pass silently on a machine without Vulkan.
pub const REQUIRE_GPU_ENV: &str = "GI_REQUIRE_GPU";

/// How to pick the adapter and what the device must offer.
#[derive(Clone, Debug)]
pub struct GpuOptions {
    /// Case-insensitive substring of the adapter name to use. `None` takes the best adapter by
    /// type: discrete, then integrated, then virtual, then CPU (lavapipe).
    pub adapter_name: Option<String>,
    /// Minimum limits the product needs; an adapter below any of them fails with
    /// [`GpuError::LimitTooSmall`]. The device is always created with the adapter's own
    /// (usually larger) limits, so big GPUs get big buffers. The default is WebGPU's baseline
    /// (128 MiB storage bindings, 8 storage buffers per stage), which lavapipe meets.
    pub required_limits: wgpu::Limits,
    /// Features without which the context fails with [`GpuError::MissingFeature`].
    pub required_features: wgpu::Features,
    /// Features enabled when the adapter has them. The default asks for timestamp queries
    /// (for [`GpuTimer`](crate::GpuTimer)); add `SHADER_INT64` only for shaders that use
    /// `u64`, since every enabled feature is one more thing a smaller adapter may lack.
    pub optional_features: wgpu::Features,
    /// Whether the context shares the process's device for these options or opens its own.
    pub sharing: DeviceSharing,
}

/// Whether a context shares a device with the process's other contexts
/// ([`GpuContext::with_options`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DeviceSharing {
    /// [`Shared`](Self::Shared) on a hardware adapter, [`Dedicated`](Self::Dedicated) on a
    /// software one (lavapipe). A software adapter runs each queue's work on the CPU, one
    /// command buffer at a time, so contexts on different threads render in parallel only on
    /// devices of their own; opening one costs little there.
    #[default]
    Auto,
    /// One device per adapter and feature set for the whole process, opened by the first
    /// context that asks and kept until the process ends or the device is lost. Drivers do
    /// not promise that a process may create and destroy devices without end (on the H100 a
    /// process stopped finding the adapter after about 30), and a service renders job after
    /// job; creating a tier also skips the device's start-up.
    Shared,
    /// A device of the context's own, destroyed with the context's last resource.
    Dedicated,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self {
            adapter_name: None,
            required_limits: wgpu::Limits::default(),
            required_features: wgpu::Features::empty(),
            optional_features: wgpu::Features::TIMESTAMP_QUERY
                | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
                | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES,
            sharing: DeviceSharing::Auto,
        }
    }
}

impl GpuOptions {
    /// The defaults, with the adapter filter taken from [`ADAPTER_ENV`] when it is set.
    pub fn from_env() -> Self {
        Self {
            adapter_name: std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty()),
            ..Self::default()
        }
    }
}

/// A headless Vulkan device and queue, with memory accounting of the resources made through it.
///
/// On a hardware adapter, contexts opened with the same options share one device and queue
/// ([`Self::with_options`], [`DeviceSharing`]); each has its own memory accounting. A tier owns
/// its context, so the memory a tier reports is its own even when other tiers of the process
/// render on the same device.
pub struct GpuContext {
    /// The logical device.
    pub device: wgpu::Device,
    /// The device's only queue.
    pub queue: wgpu::Queue,
    /// Name, type, driver and backend of the adapter in use.
    pub adapter_info: wgpu::AdapterInfo,
    /// Features enabled on the device.
    pub features: wgpu::Features,
    /// Limits of the device (the adapter's own limits).
    pub limits: wgpu::Limits,
    pub(crate) memory: Arc<MemoryTracker>,
    /// Which device this is, among those this process opened: `wgpu::Device`'s own equality
    /// compares ids that restart with every instance.
    serial: u64,
}

/// The next device serial ([`GpuContext::shares_device_with`]).
static NEXT_SERIAL: AtomicU64 = AtomicU64::new(0);

/// A device the process keeps open for every context that asks for the same adapter and
/// features, until the device is lost.
struct SharedDevice {
    key: DeviceKey,
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_info: wgpu::AdapterInfo,
    features: wgpu::Features,
    limits: wgpu::Limits,
    /// Set by the device-lost callback: the next context opens a new device.
    lost: Arc<AtomicBool>,
    serial: u64,
}

/// What decides which shared device serves a context: the options that change the device.
/// Required limits do not: the device always has the adapter's own limits, and each context
/// checks its requirement against them.
#[derive(Clone, Debug, PartialEq, Eq)]
struct DeviceKey {
    adapter_name: Option<String>,
    required_features: wgpu::Features,
    optional_features: wgpu::Features,
}

impl DeviceKey {
    fn of(options: &GpuOptions) -> Self {
        Self {
            adapter_name: options
                .adapter_name
                .as_ref()
                .map(|name| name.to_lowercase()),
            required_features: options.required_features,
            optional_features: options.optional_features,
        }
    }
}

/// The devices this process has open, one per [`DeviceKey`]. The lock is held while a device
/// is opened, so concurrent first contexts open it once.
static SHARED_DEVICES: Mutex<Vec<SharedDevice>> = Mutex::new(Vec::new());

impl GpuContext {
    /// Opens the best Vulkan adapter (or the one named by [`ADAPTER_ENV`]) with the default
    /// options. Blocks until the device exists.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_options(&GpuOptions::from_env())
    }

    /// A context on a Vulkan adapter chosen and checked by `options`. Blocks until the device
    /// exists.
    ///
    /// With [`DeviceSharing::Shared`] (the default on hardware adapters) the first context
    /// for an adapter and feature set opens the device; later ones, from any thread, share it,
    /// each with a memory account of its own. A shared device stays open for the life of the
    /// process. When it is lost (a driver reset), the next context opens a new one.
    pub fn with_options(options: &GpuOptions) -> Result<Self, GpuError> {
        if options.sharing == DeviceSharing::Dedicated {
            return Ok(Self::on(&open_device(options)?));
        }
        let key = DeviceKey::of(options);
        let mut devices = SHARED_DEVICES
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        devices.retain(|d| !d.lost.load(Ordering::Acquire));
        let shareable = |d: &SharedDevice| {
            options.sharing == DeviceSharing::Shared
                || d.adapter_info.device_type != wgpu::DeviceType::Cpu
        };
        if let Some(shared) = devices.iter().find(|d| d.key == key && shareable(d)) {
            check_limits(&options.required_limits, &shared.limits)?;
            return Ok(Self::on(shared));
        }
        let opened = open_device(options)?;
        let context = Self::on(&opened);
        if shareable(&opened) {
            devices.push(opened);
        }
        Ok(context)
    }

    /// A context on a device the caller opened, e.g. an engine's own, so the tiers render on
    /// it. Its features and limits are the device's; nothing is checked here, and a tier
    /// whose needs the device misses fails at its creation.
    pub fn from_device(adapter: &wgpu::Adapter, device: wgpu::Device, queue: wgpu::Queue) -> Self {
        Self {
            features: device.features(),
            limits: device.limits(),
            device,
            queue,
            adapter_info: adapter.get_info(),
            memory: Arc::default(),
            serial: NEXT_SERIAL.fetch_add(1, Ordering::Relaxed),
        }
    }

    /// Another context on this one's device and queue, with a memory account of its own: for
    /// a second tier on a device the caller opened ([`Self::from_device`]), whose memory is
    /// then reported apart from the first's.
    pub fn share(&self) -> Self {
        Self {
            device: self.device.clone(),
            queue: self.queue.clone(),
            adapter_info: self.adapter_info.clone(),
            features: self.features,
            limits: self.limits.clone(),
            memory: Arc::default(),
            serial: self.serial,
        }
    }

    /// A new context, with its own memory account, on `shared`'s device.
    fn on(shared: &SharedDevice) -> Self {
        Self {
            device: shared.device.clone(),
            queue: shared.queue.clone(),
            adapter_info: shared.adapter_info.clone(),
            features: shared.features,
            limits: shared.limits.clone(),
            memory: Arc::default(),
            serial: shared.serial,
        }
    }

    /// Whether `self` and `other` render on the same device: contexts this crate opened on
    /// one shared device do. Contexts made with [`Self::from_device`] share with none.
    pub fn shares_device_with(&self, other: &GpuContext) -> bool {
        self.serial == other.serial
    }

    /// A context for a GPU test, or `None` when the test should be skipped. With no adapter it
    /// prints a loud notice and returns `None`, unless [`REQUIRE_GPU_ENV`] is set: then it
    /// panics, so CI (which sets it) cannot pass GPU tests without running them. Any other
    /// error panics.
    pub fn new_or_skip(test_name: &str) -> Option<Self> {
        match Self::new() {
            Ok(ctx) => Some(ctx),
            Err(err @ GpuError::NoAdapter { .. }) => {
                if std::env::var_os(REQUIRE_GPU_ENV).is_some() {
                    panic!("{test_name}: {err} ({REQUIRE_GPU_ENV} is set, so this is a failure)");
                }
                eprintln!(
                    "\n*** SKIPPED GPU TEST {test_name}: {err}. \
                     Set {REQUIRE_GPU_ENV}=1 to make this a failure. ***\n"
                );
                None
            }
            Err(err) => panic!("{test_name}: GPU context creation failed: {err}"),
        }
    }

    /// Whether [`GpuTimer`](crate::GpuTimer) can time passes on the GPU. Without it the timer
    /// falls back to CPU wall-clock timing around submit-and-wait.
    pub fn supports_timestamps(&self) -> bool {
        self.features.contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Creates a tracked buffer of `size` bytes. It stays counted (and alive) until released.
    pub fn create_buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        });
        self.memory.track_buffer(label, &buffer);
        buffer
    }

    /// Creates a tracked buffer holding `contents` (padded to 4 bytes).
    pub fn create_buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        let buffer = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            });
        self.memory.track_buffer(label, &buffer);
        buffer
    }

    /// Creates a tracked texture, counted under its label at the bytes of all its mip levels,
    /// layers and samples.
    ///
    /// # Panics
    /// If `desc.label` is `None`: every GPU object of the product is named.
    pub fn create_texture(&self, desc: &wgpu::TextureDescriptor) -> wgpu::Texture {
        let label = desc
            .label
            .expect("GpuContext::create_texture: textures must be labeled");
        let texture = self.device.create_texture(desc);
        self.memory
            .track_texture(label, texture_bytes(desc), &texture);
        texture
    }

    /// Queues `data` into `buffer` at offset 0. When it does not fit, `buffer` is first
    /// released and replaced by one of the next power-of-two size with the same usage, counted
    /// under `label` (bind groups holding the old one must be rebuilt). For per-frame lists
    /// whose length varies: the buffer only grows, so steady frames allocate nothing.
    pub fn write_growing(&self, buffer: &mut wgpu::Buffer, label: &str, data: &[u8]) {
        if data.len() as u64 > buffer.size() {
            let usage = buffer.usage();
            self.release_buffer(buffer);
            *buffer = self.create_buffer(label, (data.len() as u64).next_power_of_two(), usage);
        }
        if !data.is_empty() {
            self.queue.write_buffer(buffer, 0, data);
        }
    }

    /// Stops counting `buffer` and destroys it (every clone of the handle becomes unusable).
    /// Returns false if this context did not create it.
    pub fn release_buffer(&self, buffer: &wgpu::Buffer) -> bool {
        self.memory.release_buffer(buffer)
    }

    /// Stops counting `texture` and destroys it. Returns false if this context did not create
    /// it.
    pub fn release_texture(&self, texture: &wgpu::Texture) -> bool {
        self.memory.release_texture(texture)
    }

    /// Releases every tracked resource whose label starts with `prefix` (e.g. `"bvh."` when a
    /// scene's BVH is rebuilt) and returns how many there were.
    pub fn release_labeled(&self, prefix: &str) -> usize {
        self.memory.release_labeled(prefix)
    }

    /// Bytes of the live tracked buffers and textures, per label and in total.
    pub fn memory(&self) -> MemoryReport {
        self.memory.report()
    }

    /// Creates a command encoder labeled `label`.
    pub fn create_encoder(&self, label: &str) -> wgpu::CommandEncoder {
        self.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }

    /// Creates a compute pipeline for `entry_point` of `module` with an automatic layout. Auto
    /// layouts spare writing bind group layouts by hand, at the cost that bind groups must be
    /// made from `pipeline.get_bind_group_layout(i)` and cannot be shared between pipelines.
    pub fn create_compute_pipeline(
        &self,
        label: &str,
        module: &wgpu::ShaderModule,
        entry_point: &str,
    ) -> wgpu::ComputePipeline {
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// Creates a compute pipeline for `entry_point` of `module` with an explicit layout: bind
    /// group `i` has layout `groups[i]` (`None` for a group the pipeline does not use). Explicit
    /// layouts let one bind group serve several pipelines, and keep bindings an entry point
    /// leaves unused, which an automatic layout would drop.
    pub fn create_compute_pipeline_with_layouts(
        &self,
        label: &str,
        module: &wgpu::ShaderModule,
        entry_point: &str,
        groups: &[Option<&wgpu::BindGroupLayout>],
    ) -> wgpu::ComputePipeline {
        let layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&format!("{label}.layout")),
                bind_group_layouts: groups,
                immediate_size: 0,
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// Submits `encoder` and blocks until the GPU has finished all submitted work.
    pub fn submit_and_wait(&self, encoder: wgpu::CommandEncoder) {
        self.queue.submit([encoder.finish()]);
        self.wait();
    }

    /// Blocks until the GPU has finished all submitted work.
    pub fn wait(&self) {
        // An error here means the device was lost, which the device-lost path reports loudly.
        if let Err(err) = self.device.poll(wgpu::PollType::wait_indefinitely()) {
            tracing::error!(%err, "waiting for the GPU failed");
        }
    }

    /// Copies `buffer` (which needs `COPY_SRC`) to a staging buffer, waits for the GPU and
    /// returns its contents as `T`s. For tests and tools: it stalls the GPU.
    ///
    /// # Panics
    /// On any [`GpuError::Readback`] from [`GpuContext::try_read_buffer`].
    pub fn read_buffer<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer) -> Vec<T> {
        self.try_read_buffer(buffer)
            .unwrap_or_else(|err| panic!("GpuContext::read_buffer: {err}"))
    }

    /// [`GpuContext::read_buffer`] returning an error instead of panicking: when the buffer
    /// lacks `COPY_SRC`, its size is not a multiple of 4 bytes and of `size_of::<T>()`, or
    /// mapping fails. The staging buffer is transient and not counted in [`Self::memory`].
    pub fn try_read_buffer<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
    ) -> Result<Vec<T>, GpuError> {
        let size = buffer.size();
        let element = size_of::<T>() as u64;
        if !buffer.usage().contains(wgpu::BufferUsages::COPY_SRC) {
            return Err(GpuError::Readback("the buffer lacks COPY_SRC usage".into()));
        }
        if !size.is_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT)
            || (element > 0 && !size.is_multiple_of(element))
        {
            return Err(GpuError::Readback(format!(
                "size {size} is not a multiple of 4 and of the element size {element}"
            )));
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("gi_gpu.readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.create_encoder("gi_gpu.readback");
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.queue.submit([encoder.finish()]);

        let (sender, receiver) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |result| {
            // The receiver outlives this callback: it waits below.
            let _ = sender.send(result);
        });
        self.wait();
        receiver
            .recv()
            .map_err(|_| GpuError::Readback("the map callback never ran".into()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let values = {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            // Copies into a fresh Vec so `T`'s alignment never depends on the mapping's.
            bytemuck::pod_collect_to_vec(&view)
        };
        staging.unmap();
        staging.destroy();
        Ok(values)
    }
}

/// Opens a device as `options` ask: the adapter, its limits checked, the features enabled.
/// Its device-lost callback logs the loss and marks the device lost.
fn open_device(options: &GpuOptions) -> Result<SharedDevice, GpuError> {
    let mut instance_desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    instance_desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(instance_desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    let adapter = pick_adapter(adapters, options.adapter_name.as_deref()).ok_or_else(|| {
        GpuError::NoAdapter {
            filter: options.adapter_name.clone(),
        }
    })?;
    let adapter_info = adapter.get_info();
    let adapter_limits = adapter.limits();
    check_limits(&options.required_limits, &adapter_limits)?;

    let adapter_features = adapter.features();
    let missing = options.required_features - adapter_features;
    if !missing.is_empty() {
        return Err(GpuError::MissingFeature(missing));
    }
    let features = options.required_features | (options.optional_features & adapter_features);

    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("gi_gpu.device"),
        required_features: features,
        required_limits: adapter_limits.clone(),
        ..Default::default()
    }))
    .map_err(|e| GpuError::RequestDevice(e.to_string()))?;
    tracing::info!(
        adapter = %adapter_info.name,
        device_type = ?adapter_info.device_type,
        driver = %adapter_info.driver_info,
        sharing = ?options.sharing,
        "GPU device opened"
    );
    let lost = Arc::new(AtomicBool::new(false));
    let lost_flag = Arc::clone(&lost);
    device.set_device_lost_callback(move |reason, message| {
        lost_flag.store(true, Ordering::Release);
        if reason == wgpu::DeviceLostReason::Destroyed {
            tracing::info!("GPU device destroyed; the next context opens a new one");
        } else {
            tracing::error!(%message, "GPU device lost; the next context opens a new one");
        }
    });
    Ok(SharedDevice {
        key: DeviceKey::of(options),
        device,
        queue,
        adapter_info,
        features,
        limits: adapter_limits,
        lost,
        serial: NEXT_SERIAL.fetch_add(1, Ordering::Relaxed),
    })
}

/// The adapter whose name contains `filter` (case-insensitive), else the best by device type;
/// ties keep enumeration order.
fn pick_adapter(adapters: Vec<wgpu::Adapter>, filter: Option<&str>) -> Option<wgpu::Adapter> {
    let rank = |t: wgpu::DeviceType| match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let filter = filter.map(str::to_lowercase);
    adapters
        .into_iter()
        .filter(|a| {
            filter
                .as_ref()
                .is_none_or(|f| a.get_info().name.to_lowercase().contains(f))
        })
        .min_by_key(|a| rank(a.get_info().device_type))
}

/// The first limit in `required` that `available` does not meet, as an error.
fn check_limits(required: &wgpu::Limits, available: &wgpu::Limits) -> Result<(), GpuError> {
    let mut failure = None;
    required.check_limits_with_fail_fn(available, true, |limit, needed, available| {
        failure = Some(GpuError::LimitTooSmall {
            limit,
            needed,
            available,
        });
    });
    failure.map_or(Ok(()), Err)
}
