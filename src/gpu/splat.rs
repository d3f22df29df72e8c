//! What the compute rasteriser for thin strands (`shaders/common/splat.wgsl`) writes into:
//! one accumulation of five `u32` per scene sample, read by the resolve
//! (`shaders/stage/downsample.wgsl`), and the scene pass's depth for occlusion. Made only
//! once a system splats (a scene drawn with ribbons allocates nothing here).
//!
//! Systems bind it as group 2 of their splat pipelines; the layout differs with and
//! without MSAA (the depth texture is multisampled or not), so both are built up front.
//! The binned rasteriser's tile lists (`TileBins`, group 3 of the `bin_*` kernels) are made
//! by a pass only once it bins, sized by the target's tiles.

use crate::error::Result;
use crate::gpu::{bind, Gpu};

/// `u32` words per sample: r, g, b, weight, optical depth.
pub const WORDS: u64 = 5;
/// Fixed-point scales of the accumulation (the same consts in `shaders/common/splat.wgsl` and
/// `shaders/stage/downsample.wgsl`; `tests/it/gpu_twins.rs` checks them).
pub const COLOR_SCALE: f64 = 16384.0;
pub const DEPTH_SCALE: f64 = 4096.0;
/// Tile side of the binned rasteriser, in samples (`TILE` in `shaders/common/splat.wgsl`).
pub const TILE: u32 = 16;
/// (segment, tile) references the lists hold per sample of the target: past that, a tile's
/// segments are drawn without binning (correct, slower), never dropped.
const REFS_PER_SAMPLE: u64 = 4;

/// The group 2 layouts: single-sampled and multisampled scene depth.
#[derive(Clone)]
pub struct SplatLayouts {
    single: wgpu::BindGroupLayout,
    multi: wgpu::BindGroupLayout,
}

impl SplatLayouts {
    pub fn new(device: &wgpu::Device) -> SplatLayouts {
        // `scene_depth` is a `SceneDepth`: `common/depth_single.wgsl` or `depth_msaa.wgsl`.
        let make = |depth: bind::Slot| {
            bind::layout(
                device,
                "splat target",
                wgpu::ShaderStages::COMPUTE,
                &[bind::storage_rw::<u32>(), depth],
            )
        };
        SplatLayouts {
            single: make(bind::texture_2d()),
            multi: make(bind::multisampled_texture_2d()),
        }
    }

    pub fn for_samples(&self, samples: u32) -> &wgpu::BindGroupLayout {
        if samples > 1 {
            &self.multi
        } else {
            &self.single
        }
    }
}

/// The accumulation for one set of scene targets and its bind group.
pub struct SplatTarget {
    pub accum: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
}

/// Tiles across and down a target of `size` samples.
pub fn tile_grid(size: (u32, u32)) -> (u32, u32) {
    (size.0.div_ceil(TILE), size.1.div_ceil(TILE))
}

impl SplatTarget {
    /// For targets of `size` samples with `samples` MSAA samples and depth view `depth`.
    pub fn new(
        gpu: &Gpu,
        layouts: &SplatLayouts,
        size: (u32, u32),
        samples: u32,
        depth: &wgpu::TextureView,
    ) -> Result<SplatTarget> {
        let bytes = size.0 as u64 * size.1 as u64 * WORDS * 4;
        gpu.check_storage_size("the thin-strand accumulation", bytes)?;
        let accum = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splat accumulation"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let bind_group = bind::group(
            &gpu.device,
            "splat target",
            layouts.for_samples(samples),
            &[
                accum.as_entire_binding(),
                wgpu::BindingResource::TextureView(depth),
            ],
        );
        Ok(SplatTarget { accum, bind_group })
    }
}

/// The binned rasteriser's tile lists for one target size (`bins` and `bin_refs` in
/// `shaders/common/splat.wgsl`, group 3 of its `bin_*` kernels): per tile the segment
/// counts, list offsets and write cursors, and the lists themselves.
pub struct TileBins {
    /// Tiles across and down.
    pub tiles: (u32, u32),
    pub bind_group: wgpu::BindGroup,
}

impl TileBins {
    /// The group 3 layout of the `bin_*` kernels.
    pub fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
        bind::layout(
            device,
            "splat tile bins",
            wgpu::ShaderStages::COMPUTE,
            &[bind::storage_rw::<u32>(), bind::storage_rw::<u32>()],
        )
    }

    /// For a target of `size` samples.
    pub fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        size: (u32, u32),
    ) -> TileBins {
        let tiles = tile_grid(size);
        // Zeroed at creation: each binning leaves the counts at 0 for the next.
        let bins = storage(
            device,
            "splat tile bins",
            3 * tiles.0 as u64 * tiles.1 as u64 * 4,
        );
        let samples_total = size.0 as u64 * size.1 as u64;
        let lim = device.limits();
        let limit = lim.max_storage_buffer_binding_size.min(lim.max_buffer_size);
        let refs_bytes = (REFS_PER_SAMPLE * samples_total * 4).clamp(4, limit / 4 * 4);
        let refs = storage(device, "splat tile lists", refs_bytes);
        let bind_group = bind::buffers(device, "splat tile bins", layout, &[&bins, &refs]);
        TileBins { tiles, bind_group }
    }
}

/// One kind's compute rasteriser: the kernels of `shaders/common/splat.wgsl` compiled in
/// the kind's module (its strands, node shading and drawn ranges at group 1), recorded the
/// same way for every kind. `splat` walks one strand per invocation with global atomics;
/// the four `bin_*` kernels bin segments by tile first (made only for a kind that bins).
pub struct SplatKernels {
    direct: wgpu::ComputePipeline,
    binned: Option<[wgpu::ComputePipeline; 4]>,
}

/// Where a kind's kernels come from: its WGSL over a single-sampled and a multisampled
/// scene depth, and its bind group layouts.
pub struct KernelSource<'a> {
    pub label: &'a str,
    /// The kind's module reading a single-sampled, and a multisampled, scene depth.
    pub modules: [&'a str; 2],
    /// Group 0 (the frame) and the kind's group 1.
    pub frame: &'a wgpu::BindGroupLayout,
    pub kind: &'a wgpu::BindGroupLayout,
    /// The tile lists' group 3, for a kind that bins.
    pub bins: Option<&'a wgpu::BindGroupLayout>,
}

/// A kind's kernels made on the first frame that splats, for the current sample count; a
/// build that fails is logged once and draws nothing. `reset` when the variant changes.
#[derive(Default)]
pub struct LazyKernels(std::cell::OnceCell<Option<SplatKernels>>);

impl LazyKernels {
    pub fn get(&self, build: impl FnOnce() -> Result<SplatKernels>) -> Option<&SplatKernels> {
        self.0
            .get_or_init(|| match build() {
                Ok(k) => Some(k),
                Err(e) => {
                    log::error!("the compute rasteriser for thin strands: {e}");
                    None
                }
            })
            .as_ref()
    }

    pub fn reset(&mut self) {
        self.0 = Default::default();
    }
}

impl SplatKernels {
    /// `source`'s kernels over a scene depth of `samples` samples (group 2 from `layouts`),
    /// with the pipelines' overridable `constants`.
    pub fn build(
        device: &wgpu::Device,
        source: &KernelSource,
        layouts: &SplatLayouts,
        samples: u32,
        constants: &[(&str, f64)],
    ) -> Result<SplatKernels> {
        let wgsl = source.modules[usize::from(samples > 1)];
        let module = super::shader_module(device, source.label, wgsl)?;
        Ok(SplatKernels::new(
            device,
            source.label,
            &module,
            [source.frame, source.kind, layouts.for_samples(samples)],
            source.bins,
            constants,
        ))
    }

    /// From `module` over `groups` (frame, the kind's group 1, the target's group 2), and
    /// the binning kernels over the tile lists' group 3 when `bins` is given.
    fn new(
        device: &wgpu::Device,
        label: &str,
        module: &wgpu::ShaderModule,
        groups: [&wgpu::BindGroupLayout; 3],
        bins: Option<&wgpu::BindGroupLayout>,
        constants: &[(&str, f64)],
    ) -> SplatKernels {
        let [frame, kind, target] = groups.map(Some);
        let [direct] = super::compute_pipelines_over(
            device,
            label,
            &[frame, kind, target],
            module,
            ["splat"],
            constants,
        );
        let binned = bins.map(|bins| {
            super::compute_pipelines_over(
                device,
                label,
                &[frame, kind, target, Some(bins)],
                module,
                ["bin_count", "bin_scan", "bin_scatter", "bin_raster"],
                constants,
            )
        });
        SplatKernels { direct, binned }
    }

    /// Record over `strands` strands (group 1 bound by the kind; groups 0 and 2 by the
    /// stage): binned into `bins` when given and these kernels bin, with at most `segments`
    /// drawn segments per strand, else one walk per strand.
    pub fn record(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        strands: u32,
        bins: Option<&TileBins>,
        segments: u32,
    ) {
        let groups = strands.div_ceil(64);
        if groups == 0 {
            return;
        }
        let (gx, gy) = (groups.min(65535), groups.div_ceil(65535));
        let (Some(bins), Some([count, scan, scatter, raster])) = (bins, self.binned.as_ref())
        else {
            pass.set_pipeline(&self.direct);
            pass.dispatch_workgroups(gx, gy, 1);
            return;
        };
        // One invocation per drawn segment: z is the segment's index along its strand.
        if segments == 0 {
            return;
        }
        pass.set_bind_group(3, &bins.bind_group, &[]);
        pass.set_pipeline(count);
        pass.dispatch_workgroups(gx, gy, segments);
        pass.set_pipeline(scan);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(scatter);
        pass.dispatch_workgroups(gx, gy, segments);
        pass.set_pipeline(raster);
        pass.dispatch_workgroups(bins.tiles.0, bins.tiles.1, 1);
    }
}

/// A zeroed storage buffer of `bytes` only the GPU reads and writes.
fn storage(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}
