//! What the compute rasteriser for thin strands (`shaders/anjyo/splat.wgsl`) writes into:
//! one accumulation of five `u32` per scene sample, read by the resolve
//! (`shaders/stage/downsample.wgsl`), and the scene pass's depth for occlusion. Made only
//! once a system splats (a scene drawn with ribbons allocates nothing here).
//!
//! Systems bind it as group 2 of their splat pipelines; the layout differs with and
//! without MSAA (the depth texture is multisampled or not), so both are built up front.
//! The binned rasteriser's tile lists (`TileBins`, group 3 of the `bin_*` kernels) are made
//! by a pass only once it bins, sized by the target's tiles.

use crate::gpu::{bind, Gpu};

/// `u32` words per sample: r, g, b, weight, optical depth.
pub const WORDS: u64 = 5;
/// Fixed-point scales of the accumulation (the same consts in `shaders/anjyo/splat.wgsl` and
/// `shaders/stage/downsample.wgsl`; `tests/it/gpu_twins.rs` checks them).
pub const COLOR_SCALE: f64 = 16384.0;
pub const DEPTH_SCALE: f64 = 4096.0;
/// Tile side of the binned rasteriser, in samples (`TILE` in `shaders/anjyo/splat.wgsl`).
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
    ) -> crate::error::Result<SplatTarget> {
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
/// `shaders/anjyo/splat.wgsl`, group 3 of its `bin_*` kernels): per tile the segment
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

/// A zeroed storage buffer of `bytes` only the GPU reads and writes.
fn storage(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}
