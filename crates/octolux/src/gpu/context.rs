//! Headless device creation: prefers a discrete GPU, falls back to whatever adapter exists
//! (Mesa's lavapipe in CI), and requests optional features only when the adapter has them.

use super::ledger::{texture_bytes, MemoryLedger};
use super::work::WorkCounter;
use crate::{Error, Result};
use std::sync::{Arc, Mutex};

/// Environment variable naming the adapter to use (a case-insensitive substring of its name).
pub const ADAPTER_ENV: &str = "OCTOLUX_ADAPTER";

/// How to pick the adapter.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// The best adapter: discrete, then integrated, then virtual, then CPU (lavapipe).
    #[default]
    Best,
    /// The first adapter whose name contains this text (case-insensitive).
    Named(String),
}

/// Options for [`GpuContext::new`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuOptions {
    /// Adapter choice; [`GpuOptions::from_env`] reads `OCTOLUX_ADAPTER`.
    pub adapter: AdapterChoice,
    /// Whether pass times come from GPU timestamp queries or CPU submit + wait.
    pub timestamps: Timestamps,
    /// At most this many bytes per storage buffer binding (None: the adapter's limit). A
    /// device capped below its adapter behaves as a smaller GPU would: its limit errors can be
    /// checked on any machine, and a setting that fits it fits every adapter that reaches it.
    pub max_storage_binding: Option<u64>,
}

/// When to time passes with GPU timestamp queries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Timestamps {
    /// When the adapter supports them, except on CPU adapters (lavapipe): their compute-pass
    /// timestamps do not bracket the work, so CPU submit + wait is the honest figure there.
    #[default]
    Auto,
    /// Whenever the adapter supports them.
    Always,
    /// Never: every pass is submitted on its own and timed on the CPU.
    Off,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            adapter: AdapterChoice::Best,
            timestamps: Timestamps::Auto,
            max_storage_binding: None,
        }
    }
}

impl GpuOptions {
    /// Default options, with the adapter taken from `OCTOLUX_ADAPTER` when it is set.
    pub fn from_env() -> GpuOptions {
        let adapter = match std::env::var(ADAPTER_ENV) {
            Ok(name) if !name.trim().is_empty() => AdapterChoice::Named(name.trim().to_string()),
            _ => AdapterChoice::Best,
        };
        GpuOptions {
            adapter,
            ..GpuOptions::default()
        }
    }
}

/// The device, queue and bookkeeping shared by every renderer stage and technique. Cloning is
/// cheap and shares everything.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The instance the adapter came from (for wgpu's own resource report and window
    /// surfaces); None on a caller's device ([`GpuContext::from_device`]).
    pub instance: Option<wgpu::Instance>,
    /// The adapter in use; None on a caller's device.
    pub adapter: Option<wgpu::Adapter>,
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Name, backend and type of the adapter.
    pub info: wgpu::AdapterInfo,
    /// Whether GPU timestamp queries are enabled.
    pub timestamps: bool,
    /// GPU memory by owner.
    pub ledger: MemoryLedger,
    /// Work counters, in a context made by [`GpuContext::with_work_counter`] (None: techniques
    /// count nothing).
    work: Option<WorkCounter>,
    errors: Arc<Mutex<Vec<String>>>,
    /// Whether GPU errors reach `errors` through this context's own handler; on a caller's
    /// device they are caught by error scopes around octolux's work instead
    /// ([`GpuContext::capture_errors`]), and the caller's handler stays its own.
    own_handler: bool,
}

/// Live wgpu objects of one instance, from wgpu's own registry (not from the ledger): a count that
/// grows from frame to frame is a leak the ledger cannot see.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ResourceCounts {
    /// Buffers.
    pub buffers: usize,
    /// Textures.
    pub textures: usize,
    /// Texture views.
    pub texture_views: usize,
    /// Bind groups.
    pub bind_groups: usize,
    /// Bind group layouts.
    pub bind_group_layouts: usize,
    /// Render and compute pipelines.
    pub pipelines: usize,
    /// Shader modules.
    pub shader_modules: usize,
    /// Command encoders and command buffers not yet consumed.
    pub command_buffers: usize,
    /// Query sets.
    pub query_sets: usize,
    /// Samplers.
    pub samplers: usize,
}

/// Serialises instance and device creation in the process. NVIDIA's Vulkan driver can crash the
/// process when several threads create instances or devices at once (parallel tests did), and
/// nothing is gained by doing it concurrently.
static DEVICE_CREATION: Mutex<()> = Mutex::new(());

/// Devices shared by [`GpuContext::shared`], one per distinct options, alive until the process
/// exits.
static SHARED: Mutex<Vec<(GpuOptions, GpuContext)>> = Mutex::new(Vec::new());

fn type_rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

const NO_ADAPTER_HELP: &str = "no GPU adapter found. octolux needs a Vulkan, Metal or DX12 \
driver. On Linux without a GPU, install Mesa's software Vulkan driver (lavapipe), e.g. \
`apt-get install mesa-vulkan-drivers` on Debian/Ubuntu or `dnf install mesa-vulkan-drivers` on \
Fedora";

impl GpuContext {
    /// Creates a headless device according to `options`.
    pub fn new(options: &GpuOptions) -> Result<GpuContext> {
        let _creating = DEVICE_CREATION.lock().unwrap_or_else(|p| p.into_inner());
        pollster::block_on(Self::new_async(options))
    }

    /// A context on a device shared by the whole process: created on the first call for these
    /// `options` and reused by every later call, so many renderers (tests, tools) share one
    /// device instead of each creating and destroying its own. Each call returns a context with
    /// an empty memory ledger of its own; GPU errors are reported device-wide. The device lives
    /// until the process exits.
    pub fn shared(options: &GpuOptions) -> Result<GpuContext> {
        let mut shared = SHARED.lock().unwrap_or_else(|p| p.into_inner());
        let ctx = match shared.iter().find(|(o, _)| o == options) {
            Some((_, ctx)) => ctx.clone(),
            None => {
                let ctx = GpuContext::new(options)?;
                shared.push((options.clone(), ctx.clone()));
                ctx
            }
        };
        Ok(ctx.with_own_ledger())
    }

    /// The same device with an empty memory ledger of its own: for a second renderer whose
    /// resources (with the same owner and names as the first one's) must be counted apart.
    pub fn with_own_ledger(&self) -> GpuContext {
        GpuContext {
            ledger: MemoryLedger::default(),
            work: None,
            ..self.clone()
        }
    }

    /// The same device with work counters and an empty memory ledger of its own: techniques
    /// created on it count their work ([`crate::gpu::work`]). Counting slows the counted
    /// passes; time frames on a context without it.
    pub fn with_work_counter(&self) -> GpuContext {
        GpuContext {
            ledger: MemoryLedger::default(),
            work: Some(WorkCounter::new(self)),
            ..self.clone()
        }
    }

    /// The work counters, where this context counts.
    pub fn work(&self) -> Option<&WorkCounter> {
        self.work.as_ref()
    }

    /// The `count_work` flag for composing a counted pass's shader.
    pub fn work_feature(&self) -> (&'static str, bool) {
        ("count_work", self.work.is_some())
    }

    /// Live wgpu objects of this context's instance, from wgpu's registry (None when the
    /// backend keeps none).
    pub fn resource_counts(&self) -> Option<ResourceCounts> {
        let report = self.instance.as_ref()?.generate_report()?;
        let hub = &report.hub;
        Some(ResourceCounts {
            buffers: hub.buffers.num_allocated,
            textures: hub.textures.num_allocated,
            texture_views: hub.texture_views.num_allocated,
            bind_groups: hub.bind_groups.num_allocated,
            bind_group_layouts: hub.bind_group_layouts.num_allocated,
            pipelines: hub.render_pipelines.num_allocated + hub.compute_pipelines.num_allocated,
            shader_modules: hub.shader_modules.num_allocated,
            command_buffers: hub.command_encoders.num_allocated + hub.command_buffers.num_allocated,
            query_sets: hub.query_sets.num_allocated,
            samplers: hub.samplers.num_allocated,
        })
    }

    async fn new_async(options: &GpuOptions) -> Result<GpuContext> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // GL lacks compute features we rely on; keep to the modern APIs.
        desc.backends &= wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        // Indirect dispatch arguments come only from our own kernels, which clamp every
        // dimension to 65535 by construction (`write_args` in voxel/svo/build.wgsl). wgpu's check
        // of them adds a validation dispatch and a barrier to every indirect call: about a
        // quarter of the octree's dynamic update (77 small dispatches) on an H100. Kept on
        // Windows, where DX12 without it reports zero for `@builtin(num_workgroups)`, and
        // wherever WGPU_VALIDATION_INDIRECT_CALL is set.
        if cfg!(not(target_os = "windows"))
            && std::env::var_os("WGPU_VALIDATION_INDIRECT_CALL").is_none()
        {
            desc.flags
                .remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
        }
        let instance = wgpu::Instance::new(desc);
        let mut adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
        if adapters.is_empty() {
            return Err(Error::Gpu(NO_ADAPTER_HELP.into()));
        }
        adapters.sort_by_key(|a| type_rank(a.get_info().device_type));
        let adapter = match &options.adapter {
            AdapterChoice::Best => adapters.swap_remove(0),
            AdapterChoice::Named(name) => {
                let wanted = name.to_lowercase();
                match adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&wanted))
                {
                    Some(i) => adapters.swap_remove(i),
                    None => {
                        let names: Vec<String> = adapters
                            .iter()
                            .map(|a| {
                                let i = a.get_info();
                                format!("'{}' ({:?}, {:?})", i.name, i.backend, i.device_type)
                            })
                            .collect();
                        return Err(Error::Gpu(format!(
                            "no adapter matches '{name}'; available: {}",
                            names.join(", ")
                        )));
                    }
                }
            }
        };
        let info = adapter.get_info();
        // CPU adapters (lavapipe) expose timestamp queries, but their compute-pass timestamps
        // do not bracket the work (16 propagation steps read as 0.02 ms); on them the honest
        // figure is CPU submit + wait per pass.
        let supported = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let timestamps = supported
            && match options.timestamps {
                Timestamps::Auto => info.device_type != wgpu::DeviceType::Cpu,
                Timestamps::Always => true,
                Timestamps::Off => false,
            };
        let mut required_features = wgpu::Features::empty();
        if timestamps {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        let mut required_limits = adapter.limits();
        if let Some(cap) = options.max_storage_binding {
            required_limits.max_storage_buffer_binding_size =
                required_limits.max_storage_buffer_binding_size.min(cap);
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("octolux"),
                required_features,
                required_limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| Error::Gpu(format!("cannot create a device on '{}': {e}", info.name)))?;
        let errors: Arc<Mutex<Vec<String>>> = Arc::default();
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            log::error!("GPU error: {e}");
            sink.lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(e.to_string());
        }));
        log::info!(
            "GPU adapter: {} ({:?}, {:?}), timestamps: {timestamps}",
            info.name,
            info.backend,
            info.device_type
        );
        Ok(GpuContext {
            instance: Some(instance),
            adapter: Some(adapter),
            device,
            queue,
            info,
            timestamps,
            ledger: MemoryLedger::default(),
            work: None,
            errors,
            own_handler: true,
        })
    }

    /// A context on a device the caller created (an engine's own `wgpu::Device` and `Queue`),
    /// after checking that it has what octolux needs ([`crate::gpu::requirements::check_device`]: the
    /// error names every missing limit). GPU timestamps are used when the device was created
    /// with `TIMESTAMP_QUERY` and is not a CPU adapter. The caller's uncaptured-error handler is
    /// left alone: octolux's work runs inside error scopes ([`GpuContext::capture_errors`]).
    pub fn from_device(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<GpuContext> {
        super::requirements::check_device(device)?;
        let info = device.adapter_info();
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
            && info.device_type != wgpu::DeviceType::Cpu;
        Ok(GpuContext {
            instance: None,
            adapter: None,
            device: device.clone(),
            queue: queue.clone(),
            info,
            timestamps,
            ledger: MemoryLedger::default(),
            work: None,
            errors: Arc::default(),
            own_handler: false,
        })
    }

    /// Runs `work` inside a validation and out-of-memory error scope on this context's device
    /// and returns the first error it raised. On a context with its own error handler the
    /// errors reported meanwhile are returned as well ([`GpuContext::check_errors`]).
    pub fn capture_errors<R>(&self, work: impl FnOnce() -> Result<R>) -> Result<R> {
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = work();
        let validation = pollster::block_on(validation.pop());
        let memory = pollster::block_on(memory.pop());
        let result = result?;
        if let Some(e) = validation.or(memory) {
            return Err(Error::Gpu(e.to_string()));
        }
        if self.own_handler {
            self.check_errors()?;
        }
        Ok(result)
    }

    /// Returns the first GPU error reported since the last call, if any.
    pub fn check_errors(&self) -> Result<()> {
        let mut errors = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        if errors.is_empty() {
            return Ok(());
        }
        let first = errors[0].clone();
        let more = errors.len() - 1;
        errors.clear();
        Err(Error::Gpu(if more > 0 {
            format!("{first} (and {more} more errors)")
        } else {
            first
        }))
    }

    /// One-line description of the adapter.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}; pass times from {})",
            self.info.name,
            self.info.backend,
            self.info.device_type,
            if self.timestamps {
                "GPU timestamps"
            } else {
                "CPU submit+wait"
            }
        )
    }

    /// Creates a buffer and records it in the ledger under `owner`/`desc.label`.
    pub fn create_buffer(&self, owner: &str, desc: &wgpu::BufferDescriptor) -> wgpu::Buffer {
        let buffer = self.device.create_buffer(desc);
        self.ledger
            .record(owner, desc.label.unwrap_or("unnamed"), desc.size);
        buffer
    }

    /// Creates a buffer with initial contents and records it in the ledger.
    pub fn create_buffer_init(
        &self,
        owner: &str,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        // Zero-sized buffers are legal but awkward to bind; keep at least one element's worth.
        let size = (contents.len() as u64).max(16).next_multiple_of(4);
        let buffer = self.create_buffer(
            owner,
            &wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        if !contents.is_empty() {
            let mut padded = contents.to_vec();
            padded.resize(contents.len().next_multiple_of(4), 0);
            self.queue.write_buffer(&buffer, 0, &padded);
        }
        buffer
    }

    /// Creates a texture and records it in the ledger under `owner`/`desc.label`.
    pub fn create_texture(&self, owner: &str, desc: &wgpu::TextureDescriptor) -> wgpu::Texture {
        let texture = self.device.create_texture(desc);
        self.ledger
            .record(owner, desc.label.unwrap_or("unnamed"), texture_bytes(desc));
        texture
    }

    /// A clear error where a storage buffer of `bytes` (for `what`, e.g. "vct-svo: the bounce
    /// table") exceeds what one binding holds on this adapter; `remedy` says what to change.
    pub fn check_storage_binding(&self, what: &str, bytes: u64, remedy: &str) -> Result<()> {
        let limit = self.device.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            return Err(Error::InvalidArgument(format!(
                "{what} needs {} MiB, more than the adapter's {} MiB per storage binding; \
                 {remedy}",
                bytes.div_ceil(1 << 20),
                limit >> 20
            )));
        }
        Ok(())
    }

    /// Compiles WGSL source into a shader module.
    pub fn shader(&self, label: &str, source: &str) -> wgpu::ShaderModule {
        self.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            })
    }

    /// A compute pipeline with an automatically derived layout.
    pub fn compute_pipeline(
        &self,
        label: &str,
        module: &wgpu::ShaderModule,
        entry: &str,
    ) -> wgpu::ComputePipeline {
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// Blocks until all submitted work is done.
    pub fn wait_idle(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| Error::Gpu(format!("waiting for the GPU failed: {e}")))
    }
}
