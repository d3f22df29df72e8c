//! Screen tiles for the wisps' ray march (`shaders/wisps/tiles.wgsl`): every frame each
//! segment's influence capsule is projected to a rectangle of tiles and every tile lists, in
//! segment order, the segments whose rectangle holds it; the march (`shaders/wisps/march.wgsl`)
//! then draws one quad per non-empty tile and marches each pixel once over its tile's list.
//! A list holds at most `capacity` segments: a tile with more keeps the first and is counted
//! in the stats the CLI, the viewer and the tests read (never dropped silently). f64
//! reference: `tile_rects` and `tile_lists` here.

use super::curve::Capsule;
use super::march::{GpuCapsule, GpuSegment};
use crate::error::{KamiError, Result};
use crate::gpu::{self, bind, Gpu};
use crate::shaders::wgsl;
use bytemuck::{Pod, Zeroable};
use glam::{DMat4, DVec3, DVec4};

/// The bounds and binning kernels.
pub const TILES: &str = wgsl!("wisps/view.wgsl", "wisps/segments.wgsl", "wisps/tiles.wgsl");

/// Tile side in samples.
pub const TILE: u32 = 16;

/// Most segments one tile lists (more are counted as an overflow).
pub const MAX_CAPACITY: u32 = 1024;

/// Twin of `View` (`tests/it/gpu_twins.rs` checks it) in `shaders/wisps/tiles.wgsl` and `march.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMarchView {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    /// xyz the eye, w the outline shell's half-width per unit distance (0: no outline).
    pub eye: [f32; 4],
    /// width, height (samples), tile side, the largest outline scale of a wisp.
    pub size: [f32; 4],
    /// tiles across, tiles down, list capacity, segments.
    pub tiles: [u32; 4],
    /// x 1: count steps and candidates.
    pub flags: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuMarchView>() == 192);

/// The march's counters as the shaders hold them (`stats: array<atomic<u32>, 8>`), read
/// back into [`MarchStats`].
pub type GpuMarchStats = [u32; 8];

/// What one frame of the march counted (`stats` in the shaders).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MarchStats {
    /// Rays whose answer lies beyond a candidate their full list dropped (more candidates
    /// touched the ray at once than `field::ray_slots` gave the scene).
    pub ray_overflow: u32,
    /// Tiles whose list overflowed its capacity.
    pub tile_overflow: u32,
    /// Most segments any tile had.
    pub most_in_a_tile: u32,
    /// Field samples of every ray (when counting).
    pub steps: u32,
    /// Candidates of every ray (when counting).
    pub candidates: u32,
    /// Rays with at least one candidate (when counting).
    pub rays: u32,
    /// Pixels the march drew: surface or outline (when counting).
    pub covered: u32,
    /// The most candidates one ray had touching it at once where its list overflowed (the
    /// slots it needed; 0 without overflow).
    pub slots_needed: u32,
    /// The slots the lists hold (`field::ray_slots`).
    pub slots: u32,
}

impl MarchStats {
    /// Nothing was dropped this frame.
    pub fn complete(&self) -> bool {
        self.ray_overflow == 0 && self.tile_overflow == 0
    }

    /// A warning line for the CLI and the viewer, or None.
    pub fn warning(&self) -> Option<String> {
        (!self.complete()).then(|| {
            format!(
                "wisps: {} tile list(s) overflowed (most segments in a tile: {}), {} ray(s) reached a candidate their full list dropped (a ray had {} candidates touching it at once, the lists hold {}): the image may miss wisp density",
                self.tile_overflow, self.most_in_a_tile, self.ray_overflow, self.slots_needed, self.slots
            )
        })
    }
}

/// The tile grid of a target of `samples`.
pub fn grid(samples: (u32, u32)) -> (u32, u32) {
    (samples.0.div_ceil(TILE), samples.1.div_ceil(TILE))
}

/// List capacity per tile for `segments` on a grid of `tiles`, within the adapter's storage
/// limit; an error naming the numbers where not even 16 per tile fit.
pub fn capacity(gpu: &Gpu, segments: u32, tiles: u64) -> Result<u32> {
    let lim = gpu.device.limits();
    let limit = lim.max_storage_buffer_binding_size.min(lim.max_buffer_size);
    let fit = (limit / (tiles.max(1) * 4)).min(u64::from(u32::MAX)) as u32;
    let cap = segments.clamp(1, MAX_CAPACITY).min(fit);
    if cap < 16.min(segments.max(1)) {
        return Err(KamiError::TooLarge {
            what: format!("the wisp tile lists ({tiles} tiles of {TILE}x{TILE} samples)"),
            needed: tiles * 16 * 4,
            limit,
            hint: "render a smaller image".into(),
        });
    }
    Ok(cap)
}

/// The view uniform for the march.
#[allow(clippy::too_many_arguments)]
pub fn march_view(
    view_proj: DMat4,
    eye: DVec3,
    eps_per_t: f64,
    outline_max: f32,
    samples: (u32, u32),
    capacity: u32,
    segments: u32,
    counting: bool,
) -> GpuMarchView {
    let (tx, ty) = grid(samples);
    let e = eye.as_vec3();
    GpuMarchView {
        view_proj: view_proj.as_mat4().to_cols_array_2d(),
        inv_view_proj: view_proj.inverse().as_mat4().to_cols_array_2d(),
        eye: [e.x, e.y, e.z, eps_per_t as f32],
        size: [samples.0 as f32, samples.1 as f32, TILE as f32, outline_max],
        tiles: [tx, ty, capacity, segments],
        flags: [u32::from(counting), 0, 0, 0],
    }
}

/// f64 twin of `bound`: each capsule's rectangle of tiles `[x0, y0, x1, y1]` (x0 > x1: none).
pub fn tile_rects(
    caps: &[Capsule],
    boxes: &[(DVec3, DVec3)],
    view_proj: DMat4,
    samples: (u32, u32),
) -> Vec<[i32; 4]> {
    let (tx, ty) = grid(samples);
    let (w, h) = (f64::from(samples.0), f64::from(samples.1));
    let last = [tx as i32 - 1, ty as i32 - 1];
    caps.iter()
        .zip(boxes)
        .map(|(c, &(blo, bhi))| {
            let r = DVec3::splat(c.influence);
            let lo = (c.a.min(c.b) - r).max(blo);
            let hi = (c.a.max(c.b) + r).min(bhi);
            let (mut plo, mut phi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            let mut behind = false;
            for k in 0..8 {
                let p = DVec3::new(
                    if k & 1 != 0 { hi.x } else { lo.x },
                    if k & 2 != 0 { hi.y } else { lo.y },
                    if k & 4 != 0 { hi.z } else { lo.z },
                );
                let clip = view_proj * DVec4::new(p.x, p.y, p.z, 1.0);
                behind |= clip.w <= 1e-6;
                let px = [
                    (clip.x / clip.w * 0.5 + 0.5) * w,
                    (0.5 - 0.5 * clip.y / clip.w) * h,
                ];
                for i in 0..2 {
                    plo[i] = plo[i].min(px[i]);
                    phi[i] = phi[i].max(px[i]);
                }
            }
            if behind {
                return [0, 0, last[0], last[1]];
            }
            if phi[0] < -1.0 || phi[1] < -1.0 || plo[0] > w + 1.0 || plo[1] > h + 1.0 {
                return [1, 1, 0, 0];
            }
            let t = f64::from(TILE);
            let q = |v: f64, i: usize| ((v / t).floor() as i32).clamp(0, last[i]);
            [
                q(plo[0] - 1.0, 0),
                q(plo[1] - 1.0, 1),
                q(phi[0] + 1.0, 0),
                q(phi[1] + 1.0, 1),
            ]
        })
        .collect()
}

/// f64 twin of `bin`: every tile's segments (indices into `rects`), in order.
pub fn tile_lists(rects: &[[i32; 4]], samples: (u32, u32)) -> Vec<Vec<u32>> {
    let (tx, ty) = grid(samples);
    let mut out = vec![Vec::new(); (tx * ty) as usize];
    for (j, r) in rects.iter().enumerate() {
        for y in r[1]..=r[3] {
            for x in r[0]..=r[2] {
                out[(y as u32 * tx + x as u32) as usize].push(j as u32);
            }
        }
    }
    out
}

/// The tile buffers and kernels, sized for one target size (rebuilt when it changes).
pub struct TilePass {
    bound: wgpu::ComputePipeline,
    bin: wgpu::ComputePipeline,
    pub view: wgpu::Buffer,
    pub rects: wgpu::Buffer,
    pub shells: wgpu::Buffer,
    pub counts: wgpu::Buffer,
    pub lists: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    pub samples: (u32, u32),
    pub capacity: u32,
    segments: u32,
}

/// A zeroed storage buffer that kernels write and tests read back (at least 256 bytes).
pub fn storage(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(256),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

impl TilePass {
    /// Buffers for a target of `samples` over the curve pass's `segments` and `capsules`.
    pub fn new(
        gpu: &Gpu,
        segments_buf: &wgpu::Buffer,
        capsules: &wgpu::Buffer,
        segments: u32,
        samples: (u32, u32),
    ) -> Result<TilePass> {
        let device = &gpu.device;
        let (tx, ty) = grid(samples);
        let tiles = u64::from(tx) * u64::from(ty);
        let cap = capacity(gpu, segments, tiles)?;
        let layout = bind::layout(
            device,
            "wisp tiles",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuMarchView>(),
                bind::storage::<GpuSegment>(),
                bind::storage::<GpuCapsule>(),
                bind::storage_rw::<[i32; 4]>(),
                bind::storage_rw::<f32>(),
                bind::storage_rw::<u32>(),
                bind::storage_rw::<u32>(),
                bind::storage_rw::<GpuMarchStats>(),
            ],
        );
        let module = gpu::shader_module(device, "wisps/tiles", TILES)?;
        let [bound, bin] = gpu::compute_pipelines(
            device,
            "wisp tiles",
            &layout,
            &module,
            ["bound", "bin"],
            &[],
        );
        let view = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisp march view"),
            size: std::mem::size_of::<GpuMarchView>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let n = u64::from(segments);
        let rects = storage(device, "wisp tile rects", n * 16);
        let shells = storage(device, "wisp shell radii", n * 4);
        let counts = storage(device, "wisp tile counts", tiles * 4);
        let lists = storage(device, "wisp tile lists", tiles * u64::from(cap) * 4);
        let stats = storage(device, "wisp march stats", 32);
        let bind_group = bind::buffers(
            device,
            "wisp tiles",
            &layout,
            &[
                &view,
                segments_buf,
                capsules,
                &rects,
                &shells,
                &counts,
                &lists,
                &stats,
            ],
        );
        Ok(TilePass {
            bound,
            bin,
            view,
            rects,
            shells,
            counts,
            lists,
            stats,
            bind_group,
            samples,
            capacity: cap,
            segments,
        })
    }

    /// Tiles across and down.
    pub fn grid(&self) -> (u32, u32) {
        grid(self.samples)
    }

    /// Write the view and record both kernels (and clear the stats).
    pub fn record(&self, gpu: &Gpu, enc: &mut wgpu::CommandEncoder, view: &GpuMarchView) {
        gpu.queue
            .write_buffer(&self.view, 0, bytemuck::bytes_of(view));
        enc.clear_buffer(&self.stats, 0, None);
        let (tx, ty) = self.grid();
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wisp tiles"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&self.bound);
        pass.dispatch_workgroups(self.segments.div_ceil(64), 1, 1);
        pass.set_pipeline(&self.bin);
        pass.dispatch_workgroups(tx.div_ceil(8), ty.div_ceil(8), 1);
    }

    /// The last frame's counters (blocks until the GPU is done).
    pub fn read_stats(&self, gpu: &Gpu) -> Result<MarchStats> {
        let s = gpu::read_buffer::<u32>(gpu, &self.stats, 32)?;
        Ok(MarchStats {
            ray_overflow: s[0],
            tile_overflow: s[1],
            most_in_a_tile: s[2],
            steps: s[3],
            candidates: s[4],
            rays: s[5],
            covered: s[6],
            slots_needed: s[7],
            slots: 0,
        })
    }

    /// Every tile's list as the kernels wrote it (tests).
    pub fn read_lists(&self, gpu: &Gpu) -> Result<Vec<Vec<u32>>> {
        let (tx, ty) = self.grid();
        let tiles = u64::from(tx * ty);
        let counts = gpu::read_buffer::<u32>(gpu, &self.counts, tiles * 4)?;
        let lists =
            gpu::read_buffer::<u32>(gpu, &self.lists, tiles * u64::from(self.capacity) * 4)?;
        let cap = self.capacity as usize;
        Ok(counts
            .iter()
            .enumerate()
            .map(|(t, &n)| lists[t * cap..t * cap + n as usize].to_vec())
            .collect())
    }
}
