//! The device context: a wgpu device opened here (headless, any backend the
//! build enables: lavapipe when there is no GPU) or handed in by a host
//! program ([`Gpu::from_device`]), shader compilation with errors caught,
//! and small buffer helpers.

use wgpu::util::DeviceExt;

pub mod binding;
pub mod params;
pub mod timing;

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no Vulkan adapter found: install a Vulkan driver (on Debian, as root: apt-get install -y mesa-vulkan-drivers, which provides the lavapipe software device)")]
    NoAdapter,
    #[error("no adapter matches '{wanted}'; available: {available} (set WGPU_ADAPTER_NAME to one of them)")]
    NoMatchingAdapter { wanted: String, available: String },
    #[error("the adapter refused a device: {0}")]
    Device(#[from] wgpu::RequestDeviceError),
    #[error("shader {label} failed to compile:\n{message}")]
    Shader { label: String, message: String },
    /// A validation error scope caught an error around a device operation.
    #[error("{what}: the device refused it: {message}")]
    Validation { what: String, message: String },
    /// A device error that no error scope caught (wgpu's message).
    #[error("the device reported an error: {message}")]
    Uncaptured { message: String },
    /// Waiting for the device failed (lost, or timed out).
    #[error("waiting for the device failed: {0}")]
    Poll(#[from] wgpu::PollError),
    /// A buffer could not be mapped for reading back.
    #[error("reading a buffer back from the device failed: {0}")]
    Map(#[from] wgpu::BufferAsyncError),
    /// A mapped buffer's range could not be viewed.
    #[error("reading a buffer back from the device failed: {0}")]
    MapRange(#[from] wgpu::MapRangeError),
    /// The device dropped a readback before it finished (device lost).
    #[error("the device dropped a buffer readback before it finished (device lost?)")]
    ReadbackDropped,
    /// A WGSL binding of a kind the runtime has no bind group layout entry for.
    #[error(
        "binding {binding} ({name}) of group {group} is a {kind}, which the runtime's layout builder does not lay out"
    )]
    UnsupportedBinding { group: u32, binding: u32, name: String, kind: String },
    #[error("the device lacks wgpu's {feature} feature, which {needed_for} needs; {fix}")]
    MissingFeature { feature: &'static str, needed_for: String, fix: &'static str },
}

/// A device and its queue with what the runtime needs to know of them.
/// Cloning is cheap (wgpu's handles are reference counted): renderers keep
/// a clone to write their uniforms per frame.
#[derive(Clone)]
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub timestamps: bool,
    /// The runtime's parameter blocks are read-only storage buffers, not
    /// uniform blocks ([`params`]: on CPU adapters).
    params_in_storage: bool,
    /// The first device error no error scope caught (wgpu would panic on it
    /// otherwise); [`Gpu::wait`] and [`Gpu::read_buffer`] report it.
    uncaptured: std::sync::Arc<std::sync::Mutex<Option<String>>>,
}

/// wgpu's flags for the build (validation in debug builds), less `DEBUG`
/// unless `WGPU_DEBUG=1` asks for it; the other `WGPU_*` flag variables
/// apply as wgpu documents them. `DEBUG` writes source-line debug info into
/// every SPIR-V module, and naga finds each statement's line by scanning
/// the WGSL from its start: on generated shaders of ten thousand lines that
/// was a third of a debug build's pipeline time (the test suite's), for
/// nothing a renderer reads.
fn instance_flags() -> wgpu::InstanceFlags {
    (wgpu::InstanceFlags::from_build_config() - wgpu::InstanceFlags::DEBUG).with_env()
}

impl Gpu {
    /// Opens a device. `adapter_name` (or env WGPU_ADAPTER_NAME) selects an
    /// adapter by case-insensitive substring; otherwise the first discrete,
    /// integrated, virtual, then CPU adapter.
    /// The backends are those the build enables (the `boxforge` binary turns
    /// on Vulkan and GL; the library asks for none of its own): Vulkan first,
    /// the others when it has no adapter, or those `WGPU_BACKEND` names.
    pub fn new(adapter_name: Option<&str>) -> Result<Gpu, GpuError> {
        Gpu::with_backends(adapter_name, wgpu::Backends::from_env())
    }

    /// [`Gpu::new`] on the given backends (e.g. `wgpu::Backends::GL` to
    /// run WGSL through wgpu's GL backend); `None`: Vulkan first, as `new`.
    pub fn with_backends(adapter_name: Option<&str>, backends: Option<wgpu::Backends>) -> Result<Gpu, GpuError> {
        // WGPU_BACKEND (e.g. "gl") picks backends; otherwise Vulkan, and the
        // other enabled backends only when Vulkan has no adapter.
        let enumerate = |backends: wgpu::Backends| {
            let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
                backends,
                flags: instance_flags(),
                ..wgpu::InstanceDescriptor::new_without_display_handle()
            });
            pollster::block_on(instance.enumerate_adapters(backends))
        };
        let adapters = match backends {
            Some(backends) => enumerate(backends),
            None => {
                let vulkan = enumerate(wgpu::Backends::VULKAN);
                if vulkan.is_empty() {
                    enumerate(wgpu::Backends::all() - wgpu::Backends::VULKAN)
                } else {
                    vulkan
                }
            }
        };
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        let env_name = std::env::var("WGPU_ADAPTER_NAME").ok();
        let wanted = adapter_name.map(str::to_string).or(env_name);
        let adapter = match wanted {
            Some(w) => {
                let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                let lw = w.to_lowercase();
                adapters
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&lw))
                    .ok_or(GpuError::NoMatchingAdapter { wanted: w, available: names.join(", ") })?
            }
            None => {
                let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
                    wgpu::DeviceType::DiscreteGpu => 0,
                    wgpu::DeviceType::IntegratedGpu => 1,
                    wgpu::DeviceType::VirtualGpu => 2,
                    wgpu::DeviceType::Cpu => 3,
                    wgpu::DeviceType::Other => 4,
                };
                adapters.into_iter().min_by_key(rank).expect("non-empty")
            }
        };
        let info = adapter.get_info();
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut features = wgpu::Features::empty();
        if timestamps {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        // Hardware-filtered R32Float fetches (bench's Sigg & Hadwiger
        // reference); requested only when the adapter has it.
        if adapter.features().contains(wgpu::Features::FLOAT32_FILTERABLE) {
            features |= wgpu::Features::FLOAT32_FILTERABLE;
        }
        // SPIR-V handed to the driver as is (`verify --target`: the emitted
        // or glslang-compiled binaries run without a translation of ours).
        // u16 samples as R16Unorm (native only; without it u16 is refused with the fix).
        if adapter.features().contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM) {
            features |= wgpu::Features::TEXTURE_FORMAT_16BIT_NORM;
        }
        if adapter.features().contains(wgpu::Features::PASSTHROUGH_SHADERS) {
            features |= wgpu::Features::PASSTHROUGH_SHADERS;
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("boxforge"),
            required_features: features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))?;
        let gpu = Gpu::with_info(device, queue, info);
        gpu.catch_uncaptured_errors();
        Ok(gpu)
    }

    /// Wraps a host program's device and queue: nothing is requested of the
    /// adapter, the device's own features and limits decide which paths
    /// run (timestamps only with `TIMESTAMP_QUERY`; hardware-filtered
    /// fetches only with `FLOAT32_FILTERABLE`, else a typed error), and the
    /// host's uncaptured-error handler stays in place: errors are reported
    /// through error scopes around the runtime's own calls.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Gpu {
        let info = wgpu::AdapterInfo {
            name: "host device".into(),
            vendor: 0,
            device: 0,
            device_type: wgpu::DeviceType::Other,
            device_pci_bus_id: String::new(),
            driver: String::new(),
            driver_info: String::new(),
            backend: wgpu::Backend::Noop,
            subgroup_min_size: 0,
            subgroup_max_size: 0,
            transient_saves_memory: None,
            limit_bucket: None,
        };
        Gpu::with_info(device, queue, info)
    }

    fn with_info(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo) -> Gpu {
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let uncaptured = std::sync::Arc::new(std::sync::Mutex::new(None));
        let params_in_storage = info.device_type == wgpu::DeviceType::Cpu;
        Gpu { device, queue, info, timestamps, params_in_storage, uncaptured }
    }

    /// Records the first device error no error scope caught instead of
    /// wgpu's default panic (a device the runtime opened itself only).
    fn catch_uncaptured_errors(&self) {
        let sink = self.uncaptured.clone();
        self.device.on_uncaptured_error(std::sync::Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                // One line: wgpu's messages carry a multi-line source chain.
                *slot =
                    Some(e.to_string().lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(": "));
            }
        }));
    }

    /// Whether the runtime's parameter blocks are read-only storage buffers
    /// here (CPU adapters such as lavapipe; see [`params`]).
    pub fn params_in_storage(&self) -> bool {
        self.params_in_storage
    }

    /// This device with the parameter blocks in storage (`true`) or
    /// uniform (`false`) buffers, whatever the adapter (tests, hosts).
    pub fn with_params_in_storage(mut self, on: bool) -> Gpu {
        self.params_in_storage = on;
        self
    }

    /// A runtime template's source as this device compiles it (the
    /// parameter blocks moved to storage where [`Gpu::params_in_storage`]).
    pub fn params_source<'a>(&self, source: &'a str) -> std::borrow::Cow<'a, str> {
        if self.params_in_storage {
            std::borrow::Cow::Owned(params::in_storage(source))
        } else {
            std::borrow::Cow::Borrowed(source)
        }
    }

    /// The binding table of a runtime template's source as this device
    /// compiles it (group layouts follow the parameter blocks' address space).
    pub fn bindings_of(&self, source: &str) -> Result<Vec<boxforge::validate::Binding>, GpuError> {
        boxforge::validate::bindings_of_wgsl(&self.params_source(source))
            .map_err(|message| GpuError::Shader { label: "bindings".into(), message })
    }

    /// The layout entry of a parameter block at `binding` (compute stage).
    pub fn params_entry(&self, binding: u32) -> wgpu::BindGroupLayoutEntry {
        if self.params_in_storage {
            binding::storage_entry(binding, true)
        } else {
            binding::uniform_entry(binding)
        }
    }

    /// One line naming the adapter.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {})",
            self.info.name, self.info.device_type, self.info.backend, self.info.driver
        )
    }

    /// Compiles WGSL (a runtime template's parameter blocks placed as
    /// [`Gpu::params_source`] says); validation errors (with naga's spans)
    /// become an error.
    pub fn compile(&self, label: &str, source: &str) -> Result<wgpu::ShaderModule, GpuError> {
        let source = &*self.params_source(source);
        // naga first: its message carries the source spans.
        naga_check(source, label)?;
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader { label: label.into(), message: e.to_string() });
        }
        Ok(module)
    }

    /// A shader module from SPIR-V words, handed to the driver untouched
    /// (wgpu's `PASSTHROUGH_SHADERS`: no naga, no validation of ours, so the
    /// pipeline layout must be explicit). `entry` and its workgroup size name
    /// the one compute entry point used.
    pub fn spirv_passthrough(
        &self,
        label: &str,
        words: &[u32],
        entry: &str,
        workgroup: (u32, u32, u32),
    ) -> Result<wgpu::ShaderModule, GpuError> {
        if !self.device.features().contains(wgpu::Features::PASSTHROUGH_SHADERS) {
            return Err(GpuError::MissingFeature {
                feature: "PASSTHROUGH_SHADERS",
                needed_for: format!("running the SPIR-V of {label} as it is"),
                fix: "use a Vulkan adapter (lavapipe offers it) or the WGSL target",
            });
        }
        let entry_points = [wgpu::PassthroughShaderEntryPoint { name: entry.into(), workgroup_size: workgroup }];
        let desc = wgpu::ShaderModuleDescriptorPassthrough {
            label: Some(label),
            entry_points: std::borrow::Cow::Borrowed(&entry_points),
            spirv: Some(std::borrow::Cow::Borrowed(words)),
            ..Default::default()
        };
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        // SAFETY: the words are a SPIR-V module that spirv-val accepted (the
        // callers validate it first); a bad module is the driver's to reject.
        let module = unsafe { self.device.create_shader_module_passthrough(desc) };
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader { label: label.into(), message: e.to_string() });
        }
        Ok(module)
    }

    /// Runs `f` inside a validation error scope and reports what it caught.
    pub fn checked<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let t = f();
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Validation { what: what.to_string(), message: one_line(&e.to_string()) }),
            None => Ok(t),
        }
    }

    /// A compute pipeline with explicit bind group layouts (one per group).
    pub fn pipeline(
        &self,
        label: &str,
        shader: &wgpu::ShaderModule,
        groups: &[&wgpu::BindGroupLayout],
        entry: &str,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
        let layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
        self.checked(&format!("{label} pipeline"), || {
            self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                module: shader,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        })
    }

    /// Records one dispatch of `pipeline` with bind groups 0.. and submits it.
    pub fn dispatch(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        bind_groups: &[&wgpu::BindGroup],
        groups: (u32, u32, u32),
    ) -> Result<(), GpuError> {
        self.checked(&format!("{label} dispatch"), || {
            let mut enc = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
            {
                let mut pass =
                    enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
                pass.set_pipeline(pipeline);
                for (i, bg) in bind_groups.iter().enumerate() {
                    pass.set_bind_group(i as u32, *bg, &[]);
                }
                pass.dispatch_workgroups(groups.0, groups.1, groups.2);
            }
            self.queue.submit([enc.finish()]);
        })
    }

    pub fn storage_buffer(&self, label: &str, bytes: &[u8], writable: bool) -> wgpu::Buffer {
        let mut usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        if writable {
            usage |= wgpu::BufferUsages::COPY_SRC;
        }
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage })
    }

    /// A 3D texture of `size` texels that shaders load from and the host
    /// writes (TEXTURE_BINDING | COPY_DST): a slab, a brick pool, a page table.
    pub fn sampled_texture_3d(&self, label: &str, size: [u32; 3], format: wgpu::TextureFormat) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: size[2] },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        })
    }

    pub fn uniform_buffer(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        })
    }

    /// Copies a buffer back to the host.
    pub fn read_buffer(&self, src: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let size = src.size();
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, size);
        self.queue.submit([enc.finish()]);
        let slice = staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely())?;
        rx.recv().map_err(|_| GpuError::ReadbackDropped)??;
        let data = slice.get_mapped_range()?.to_vec();
        staging.unmap();
        self.take_uncaptured()?;
        Ok(data)
    }

    /// Waits for all submitted work; reports a device error that no scope caught.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely())?;
        self.take_uncaptured()
    }

    /// The device's limits (what requests are checked against before any upload).
    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Err with the first uncaught device error, if one happened.
    pub fn take_uncaptured(&self) -> Result<(), GpuError> {
        match self.uncaptured.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(message) => Err(GpuError::Uncaptured { message }),
            None => Ok(()),
        }
    }
}

/// wgpu's multi-line error chains as one line.
fn one_line(s: &str) -> String {
    s.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(": ")
}

/// Parses and validates WGSL with naga; the error is [`GpuError::Shader`]
/// with naga's rendered message (source spans included).
pub fn naga_check(source: &str, label: &str) -> Result<(), GpuError> {
    let r = boxforge::validate::validate_wgsl(source, label);
    match r.error {
        Some(message) => Err(GpuError::Shader { label: label.into(), message }),
        None => Ok(()),
    }
}
