//! GPU context: adapter choice (headless or for a window), device creation with the
//! adapter's full limits, and small helpers shared by every pass.
//!
//! `KAMI_BACKEND=vulkan|gl|metal|dx12` forces a backend. Without it all backends are tried;
//! `Preference::Software` (tests, snapshots) picks a CPU adapter (llvmpipe, lavapipe) first so
//! images are deterministic, `Preference::Hardware` (the CLI and viewer) a real GPU first.

pub mod bind;
pub mod gpu_data;
pub mod pipeline;
pub mod shadow;
pub mod splat;
pub mod strands;
pub mod timing;
pub mod view;

use crate::error::{KamiError, Result};
use std::sync::{Arc, Mutex};

/// Invocations per workgroup of every compute kernel (one invocation per strand or hair;
/// passed to the shaders as the pipeline-overridable constant `WORKGROUP`).
pub const WORKGROUP: u32 = 64;

/// The most storage buffers one shader stage of Kami's binds, over all its bind groups
/// (Anjyo's cantilever: seven of its own and the world's EFF cells, head field and
/// per-submission samples, see `systems::world`). WebGPU guarantees 8: a kind whose kernels
/// bind more asks the adapter in its `check_limits` (`Gpu::check_storage_buffers`), before
/// anything is built, so only scenes with that kind need the larger limit
/// (`tests/it/shader_validation.rs` keeps the number true).
pub const STORAGE_BUFFERS_PER_STAGE: u32 = 10;

/// Which kind of adapter to look for first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preference {
    /// A discrete or integrated GPU if there is one, else software.
    Hardware,
    /// A software (CPU) adapter if there is one: deterministic output for tests.
    Software,
}

/// How long [`Gpu::wait`] waits for submitted work before it gives up.
pub const WAIT_LIMIT: std::time::Duration = std::time::Duration::from_secs(600);

/// Adapter, device and queue.
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Validation errors not caught by a scope (logged, and kept for `take_error`).
    errors: Arc<Mutex<Vec<String>>>,
}

/// Backends named by `KAMI_BACKEND`, or all.
pub fn backends_from_env() -> Result<wgpu::Backends> {
    parse_backend(std::env::var("KAMI_BACKEND").ok().as_deref())
}

/// Backends for a `KAMI_BACKEND` value (`None`, empty or `auto`: all).
pub fn parse_backend(value: Option<&str>) -> Result<wgpu::Backends> {
    match value.map(|v| v.trim().to_ascii_lowercase()) {
        None => Ok(wgpu::Backends::all()),
        Some(v) => match v.as_str() {
            "" | "auto" => Ok(wgpu::Backends::all()),
            "vulkan" | "vk" => Ok(wgpu::Backends::VULKAN),
            "gl" | "gles" | "opengl" => Ok(wgpu::Backends::GL),
            "metal" => Ok(wgpu::Backends::METAL),
            "dx12" => Ok(wgpu::Backends::DX12),
            _ => Err(KamiError::BadBackend(value.unwrap_or_default().to_string())),
        },
    }
}

/// Instance settings for `backends`; a window sets `display` before creating the instance
/// (needed by GL to present).
pub fn instance_descriptor(backends: wgpu::Backends) -> wgpu::InstanceDescriptor {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    // Keep wgpu's validation on in debug builds only.
    desc.flags = if cfg!(debug_assertions) {
        wgpu::InstanceFlags::debugging()
    } else {
        wgpu::InstanceFlags::empty()
    }
    .with_env();
    desc
}

fn rank(info: &wgpu::AdapterInfo, pref: Preference) -> u32 {
    use wgpu::DeviceType::*;
    let kind = match (pref, info.device_type) {
        (Preference::Software, Cpu) => 0,
        (Preference::Hardware, DiscreteGpu) => 0,
        (Preference::Hardware, IntegratedGpu) => 1,
        (_, DiscreteGpu | IntegratedGpu | VirtualGpu) => 2,
        (_, Other) => 3,
        (Preference::Hardware, Cpu) => 4,
    };
    // Prefer Vulkan over GL when otherwise equal: fuller feature set.
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    kind * 2 + backend
}

impl Gpu {
    /// A device with no window, on the backends `KAMI_BACKEND` allows.
    pub fn headless(pref: Preference) -> Result<Gpu> {
        Self::headless_on(backends_from_env()?, pref)
    }

    /// A device with no window on the given backends.
    pub fn headless_on(backends: wgpu::Backends, pref: Preference) -> Result<Gpu> {
        let instance = wgpu::Instance::new(instance_descriptor(backends));
        Self::with_instance(instance, backends, pref, None)
    }

    /// A device on `instance`, able to present to `surface` when given.
    pub fn with_instance(
        instance: wgpu::Instance,
        backends: wgpu::Backends,
        pref: Preference,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Gpu> {
        let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
        if let Some(s) = surface {
            adapters.retain(|a| a.is_surface_supported(s));
        }
        adapters.sort_by_key(|a| rank(&a.get_info(), pref));
        let adapter = adapters
            .into_iter()
            .next()
            .ok_or_else(|| KamiError::NoAdapter {
                backend_note: match std::env::var("KAMI_BACKEND") {
                    Ok(b) if !b.is_empty() => format!(" for KAMI_BACKEND={b}"),
                    _ => String::new(),
                },
            })?;
        let info = adapter.get_info();
        if pref == Preference::Software && info.device_type != wgpu::DeviceType::Cpu {
            log::warn!(
                "no software adapter found; using {} ({:?}) instead",
                info.name,
                info.backend
            );
        }
        let downlevel = adapter.get_downlevel_capabilities();
        // Compute for the solvers, storage in vertex shaders for hair drawn straight from the
        // solver's buffers; on GL, per-sample shading for sub-pixel hair coverage
        // (pipeline::hair_fragment_entry).
        let mut needed =
            wgpu::DownlevelFlags::COMPUTE_SHADERS | wgpu::DownlevelFlags::VERTEX_STORAGE;
        if info.backend == wgpu::Backend::Gl {
            needed |= wgpu::DownlevelFlags::MULTISAMPLED_SHADING;
        }
        if !downlevel.flags.contains(needed) {
            return Err(KamiError::Device(format!(
                "adapter {} ({:?}) lacks {:?}, which Kami needs; try KAMI_BACKEND=vulkan",
                info.name,
                info.backend,
                needed - downlevel.flags
            )));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("kami device"),
            // Timestamp queries where the adapter has them: per-pass GPU times
            // (`timing::GpuTimer`) for the viewer's Stats and `kami bench scale`.
            required_features: adapter.features() & timing::features(),
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| KamiError::Device(e.to_string()))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            log::error!("wgpu: {e}");
            sink.lock().unwrap().push(e.to_string());
        }));
        log::info!(
            "adapter: {} ({:?}, {:?})",
            info.name,
            info.backend,
            info.device_type
        );
        Ok(Gpu {
            instance,
            adapter,
            device,
            queue,
            info,
            errors,
        })
    }

    /// "llvmpipe (Vulkan)".
    pub fn describe(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    /// Block until all submitted work is done, for up to [`WAIT_LIMIT`].
    ///
    /// wgpu's GL backend caps one fence wait at `i32::MAX` ns (about 2.1 s), so a long
    /// submission on llvmpipe reports a timeout that is not one: we wait again until the
    /// limit is really spent.
    pub fn wait(&self) -> Result<()> {
        let start = std::time::Instant::now();
        loop {
            let left = WAIT_LIMIT.saturating_sub(start.elapsed());
            match self.device.poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: Some(left),
            }) {
                Ok(_) => return Ok(()),
                Err(wgpu::PollError::Timeout) if !left.is_zero() => continue,
                Err(e) => {
                    return Err(KamiError::Gpu(format!(
                        "waiting for the GPU ({:.1} s): {e}",
                        start.elapsed().as_secs_f64()
                    )))
                }
            }
        }
    }

    /// The first uncaptured GPU error since the last call, as an error.
    pub fn take_error(&self) -> Result<()> {
        let mut e = self.errors.lock().unwrap();
        if e.is_empty() {
            Ok(())
        } else {
            let first = e.remove(0);
            e.clear();
            Err(KamiError::Gpu(first))
        }
    }

    /// Check that this adapter lets one shader stage bind `needed` storage buffers (`what`
    /// names the kernel); WebGPU guarantees 8.
    pub fn check_storage_buffers(&self, what: &str, needed: u32) -> Result<()> {
        let offered = self.device.limits().max_storage_buffers_per_shader_stage;
        if offered < needed {
            return Err(KamiError::Device(format!(
                "adapter {} ({:?}) offers {offered} storage buffers per shader stage; {what} \
                 binds {needed}; try KAMI_BACKEND=vulkan",
                self.info.name, self.info.backend
            )));
        }
        Ok(())
    }

    /// Check that a storage buffer of `bytes` fits this adapter.
    pub fn check_storage_size(&self, what: &str, bytes: u64) -> Result<()> {
        let lim = self.device.limits();
        let limit = (lim.max_storage_buffer_binding_size).min(lim.max_buffer_size);
        if bytes > limit {
            return Err(KamiError::TooLarge {
                what: what.to_string(),
                needed: bytes,
                limit,
                hint: "use fewer hairs or segments".into(),
            });
        }
        Ok(())
    }

    /// Check a texture side against the adapter.
    pub fn check_texture_size(&self, what: &str, side: u32) -> Result<()> {
        let limit = self.device.limits().max_texture_dimension_2d;
        if side > limit {
            return Err(KamiError::TooLarge {
                what: what.to_string(),
                needed: side as u64,
                limit: limit as u64,
                hint: "lower the image size or render.supersample".into(),
            });
        }
        Ok(())
    }

    /// Workgroup counts (x, y) covering `n` invocations of `size` each, folding into y when
    /// x would pass the adapter's per-dimension limit. Kernels recover the linear index as
    /// `id.x + id.y * x * size`.
    pub fn dispatch_dims(&self, n: u32, size: u32) -> Result<(u32, u32)> {
        let groups = n.div_ceil(size).max(1);
        let max = self.device.limits().max_compute_workgroups_per_dimension;
        let x = groups.min(max);
        let y = groups.div_ceil(x);
        if y > max {
            return Err(KamiError::TooLarge {
                what: "compute dispatch".into(),
                needed: n as u64,
                limit: max as u64 * max as u64 * size as u64,
                hint: "use fewer hairs".into(),
            });
        }
        Ok((x, y))
    }
}

/// Compile a WGSL module, turning validation errors into `KamiError::Gpu`.
pub fn shader_module(
    device: &wgpu::Device,
    label: &str,
    source: &str,
) -> Result<wgpu::ShaderModule> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(KamiError::Gpu(format!("shader {label}: {e}")));
    }
    Ok(module)
}

/// Create a storage buffer with contents. An empty table gets a zeroed placeholder big
/// enough for one element of any GPU struct, since a binding must hold at least one.
pub fn storage_buffer(
    device: &wgpu::Device,
    label: &str,
    data: &[u8],
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    let placeholder = [0u8; 256];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if data.is_empty() { &placeholder } else { data },
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
    })
}

/// The compute pipelines of `entries` in `module`, all over the one bind group `layout`,
/// with the module's pipeline-overridable `constants` (numbers shared with the Rust side,
/// such as the workgroup size, are passed here rather than typed in both languages).
pub fn compute_pipelines<const N: usize>(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    module: &wgpu::ShaderModule,
    entries: [&str; N],
    constants: &[(&str, f64)],
) -> [wgpu::ComputePipeline; N] {
    compute_pipelines_over(device, label, &[Some(layout)], module, entries, constants)
}

/// `compute_pipelines` over several bind group layouts, one per group index (`None` for a
/// group the pipelines do not bind): a kernel's own group and a shared one further up.
pub fn compute_pipelines_over<const N: usize>(
    device: &wgpu::Device,
    label: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    module: &wgpu::ShaderModule,
    entries: [&str; N],
    constants: &[(&str, f64)],
) -> [wgpu::ComputePipeline; N] {
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    entries.map(|entry| {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&pl),
            module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            cache: None,
        })
    })
}

/// Read a buffer back to the CPU (tests, benchmarks, screenshots; never in the frame loop).
pub fn read_buffer<T: bytemuck::Pod>(gpu: &Gpu, src: &wgpu::Buffer, bytes: u64) -> Result<Vec<T>> {
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback staging"),
        size: bytes,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("readback"),
        });
    enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
    gpu.queue.submit([enc.finish()]);
    map_read(gpu, &staging)
}

/// Map a MAP_READ buffer and copy it out.
pub fn map_read<T: bytemuck::Pod>(gpu: &Gpu, staging: &wgpu::Buffer) -> Result<Vec<T>> {
    let mut data = Vec::new();
    map_read_with(gpu, staging, |bytes| {
        data = bytemuck::cast_slice::<u8, T>(bytes).to_vec()
    })?;
    Ok(data)
}

/// Map `staging` for reading, hand its bytes to `read`, and unmap it again so the buffer can
/// be reused (the offscreen readback keeps one for every frame).
pub fn map_read_with(gpu: &Gpu, staging: &wgpu::Buffer, read: impl FnOnce(&[u8])) -> Result<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    rx.recv()
        .map_err(|_| KamiError::Gpu("readback was dropped".into()))?
        .map_err(|e| KamiError::Gpu(format!("readback failed: {e}")))?;
    {
        let view = staging
            .slice(..)
            .get_mapped_range()
            .map_err(|e| KamiError::Gpu(format!("readback mapping: {e}")))?;
        read(&view);
    }
    staging.unmap();
    gpu.take_error()
}
