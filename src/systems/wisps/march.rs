//! The wisps' GPU passes: `shaders/wisps/curves.wgsl` turns node positions into Bézier
//! segments with their capsule bounds (compute), `shaders/wisps/tiles.wgsl` lists each
//! screen tile's segments (`tiles.rs`, compute), and `shaders/wisps/march.wgsl` ray-marches
//! and toon-shades the blobby surface, each pixel once (a render pipeline writing depth).
//! The f64 references are `curve.rs`, `tiles.rs` and `field.rs` (`march_tiled`).

use super::tiles::{self, GpuMarchStats, GpuMarchView, MarchStats, TilePass};
use crate::error::{KamiError, Result};
use crate::gpu::gpu_data::linear_rgb;
use crate::gpu::pipeline::{self, DrawPipeline, Variant};
use crate::gpu::{self, bind, Gpu};
use crate::shaders::wgsl;
use crate::systems::wisps::block::{Distance, MarchOn, Tones, Wisps};
use bytemuck::{Pod, Zeroable};
use glam::{DMat4, DVec3};

/// Spline and neighbour kernels.
pub const CURVES: &str = wgsl!(
    "common/chord.wgsl",
    "wisps/segments.wgsl",
    "wisps/curves.wgsl"
);

/// The ray march and toon shading (compute), with `field::RAY_SLOTS` candidate slots per ray
/// (`march_source` sets a scene's own).
pub const MARCH: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/chord.wgsl",
    "wisps/view.wgsl",
    "wisps/segments.wgsl",
    "wisps/draw.wgsl",
    "wisps/field.wgsl",
    "wisps/march.wgsl",
    "wisps/tile_quad.wgsl",
    "wisps/toon.wgsl"
);

/// The march's image drawn into the scene by depth.
pub const COMPOSITE: &str = wgsl!(
    "wisps/view.wgsl",
    "wisps/composite.wgsl",
    "wisps/tile_quad.wgsl"
);

/// The march with `slots` candidate slots per ray (a constant: WGSL sizes private arrays
/// only by constants).
pub fn march_source(slots: u32) -> String {
    let line = format!(
        "const RAY_SLOTS: u32 = {}u;",
        crate::systems::wisps::field::RAY_SLOTS
    );
    debug_assert!(MARCH.contains(&line));
    MARCH.replace(&line, &format!("const RAY_SLOTS: u32 = {slots}u;"))
}

/// The slots `wisps` need at rest (`field::ray_slots`).
pub fn scene_slots(wisps: &Wisps) -> u32 {
    let segs = super::curve::drawn_segments(wisps);
    let caps = super::curve::capsules(&segs, wisps.threshold);
    crate::systems::wisps::field::ray_slots(&caps) as u32
}

/// The wisps' shadow cast (`stage::shadow`).
pub const CAST: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/shadow_cast.wgsl",
    "wisps/segments.wgsl",
    "wisps/cast.wgsl"
);

/// The wisps' shadow cast over the segments a `CurvePass` writes.
pub struct WispCast {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    segments: u32,
}

impl WispCast {
    pub fn new(
        gpu: &Gpu,
        curves: &CurvePass,
        frame_layout: &wgpu::BindGroupLayout,
        cast_layout: &wgpu::BindGroupLayout,
    ) -> Result<WispCast> {
        let device = &gpu.device;
        let layout = bind::layout(
            device,
            "wisp cast",
            wgpu::ShaderStages::COMPUTE,
            &[bind::storage::<GpuSegment>(), bind::uniform::<[u32; 4]>()],
        );
        let module = gpu::shader_module(device, "wisp cast", CAST)?;
        let pl =
            pipeline::pipeline_layout(device, "wisp cast", &[frame_layout, &layout, cast_layout]);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("wisp cast"),
            layout: Some(&pl),
            module: &module,
            entry_point: Some("cast_shadow"),
            compilation_options: Default::default(),
            cache: None,
        });
        let count = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("wisp cast count"),
                contents: bytemuck::bytes_of(&[curves.segment_count, 0, 0, 0]),
                usage: wgpu::BufferUsages::UNIFORM,
            },
        );
        let group = bind::buffers(device, "wisp cast", &layout, &[&curves.segments, &count]);
        Ok(WispCast {
            pipeline,
            group,
            segments: curves.segment_count,
        })
    }

    /// Deposit this frame's segments (groups 0 and 2 are bound).
    pub fn cast(&self, pass: &mut wgpu::ComputePass<'_>) {
        if self.segments == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.group, &[]);
        pass.dispatch_workgroups(self.segments.div_ceil(WORKGROUP), 1, 1);
    }
}

const WORKGROUP: u32 = 64;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuWispParams {
    pub model: [[f32; 4]; 4],
    /// wisps, segments, unused, nodes
    pub counts: [u32; 4],
    /// x the surface threshold
    pub shape: [f32; 4],
}

/// A segment's capsules round its chord c0-c3 (`curve::Capsule`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuCapsule {
    /// xyz c0, w the influence radius
    pub a: [f32; 4],
    /// xyz c3, w the hit radius (< 0: the segment holds no hit)
    pub b: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuCapsule>() == 32);
const _: () = assert!(std::mem::size_of::<GpuSegment>() == 96);

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuSegment {
    /// xyz control points; w: r0, r1, w0, w1
    pub c: [[f32; 4]; 4],
    /// Control-point AABB; lo.w the Lipschitz bound, hi.w the wisp
    pub lo: [f32; 4],
    pub hi: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuWispDraw {
    pub head: [[f32; 4]; 3],
    pub diffuse: [f32; 4],
    pub shade: [f32; 4],
    pub dark: [f32; 4],
    pub specular: [f32; 4],
    pub outline: [f32; 4],
    pub march: [f32; 4],
    pub method: [u32; 4],
    /// Feathers (`toon::step`): x lit/shade, y shade/dark, z halo edge, w rim edge.
    pub feather: [f32; 4],
    /// rgb linear rim colour, w rim width (0: no rim).
    pub rim: [f32; 4],
    /// x cos, y sin of the halo's latitude offset, z halo strength, w 1 when the halo has
    /// its own colour over the shadow tones.
    pub halo: [f32; 4],
    /// rgb linear halo colour over the shade and dark tones, w unused.
    pub halo_shadow: [f32; 4],
    /// x outline taper (root to tip, `toon::outline_scale`), yzw unused.
    pub taper: [f32; 4],
}

/// The draw uniform for `wisps` with the head pose `head`.
pub fn draw_uniform(wisps: &Wisps, head: DMat4, segments: u32) -> GpuWispDraw {
    let t = &wisps.toon;
    let rgb = |c: [f32; 3], w: f64| {
        let l = linear_rgb(c);
        [l[0], l[1], l[2], w as f32]
    };
    let col = |i: usize| {
        let c = head.col(i).truncate().normalize_or_zero();
        [c.x as f32, c.y as f32, c.z as f32, 0.0]
    };
    let (method, pieces) = match wisps.march.distance {
        Distance::Newton => (0, 0),
        Distance::Polyline { pieces } => (1, pieces),
    };
    let (offset_sin, offset_cos) = t.halo_offset.to_radians().sin_cos();
    GpuWispDraw {
        head: [col(0), col(1), col(2)],
        diffuse: rgb(t.diffuse, t.t_diffuse),
        shade: rgb(t.shade, t.t_dark),
        dark: rgb(t.dark, t.t_specular),
        specular: rgb(t.specular, f64::from(u8::from(t.tones == Tones::Three))),
        outline: rgb(t.outline, t.outline_width),
        march: [
            wisps.threshold as f32,
            wisps.march.step_scale as f32,
            wisps.march.max_steps as f32,
            wisps.march.refine as f32,
        ],
        method: [method, pieces, 0, segments],
        feather: [
            t.diffuse_feather as f32,
            t.dark_feather as f32,
            t.halo_feather as f32,
            t.rim_feather as f32,
        ],
        rim: rgb(t.rim, t.rim_width),
        halo: [
            offset_cos as f32,
            offset_sin as f32,
            t.halo_strength as f32,
            f32::from(u8::from(t.halo_shadow.is_some())),
        ],
        halo_shadow: rgb(t.halo_shadow.unwrap_or(t.specular), 0.0),
        taper: [t.outline_taper as f32, 0.0, 0.0, 0.0],
    }
}

/// Segments of a scene's wisps (one fewer than the nodes of each skeleton).
pub fn segment_count(wisps: &Wisps) -> u32 {
    wisps
        .skeletons
        .iter()
        .map(|s| s.nodes.len() as u32 - 1)
        .sum()
}

/// Node count of a scene's wisps.
pub fn node_count(wisps: &Wisps) -> u32 {
    wisps.skeletons.iter().map(|s| s.nodes.len() as u32).sum()
}

/// The spline and capsule kernels over one set of node positions.
pub struct CurvePass {
    spline: wgpu::ComputePipeline,
    overlaps: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    pub segments: wgpu::Buffer,
    pub capsules: wgpu::Buffer,
    pub overlap_counts: wgpu::Buffer,
    /// Per segment `curve::PIECES + 1` points (xyz) with each piece's chord deviation (w).
    pub pieces: wgpu::Buffer,
    threshold: f32,
    bind_group: wgpu::BindGroup,
    pub wisps: u32,
    pub segment_count: u32,
    nodes: u32,
    /// The model matrix of the last recorded run (still wisps under a still head need no
    /// second run).
    last: Option<DMat4>,
}

impl CurvePass {
    /// Kernels over `positions` (xyz per node, the skeletons' nodes one after the other):
    /// the springs' buffer, or the drawn nodes when the wisps do not move by themselves.
    pub fn new(gpu: &Gpu, wisps: &Wisps, positions: &wgpu::Buffer) -> Result<CurvePass> {
        let device = &gpu.device;
        let n_wisps = wisps.skeletons.len() as u32;
        let n_seg = segment_count(wisps);
        let n_nodes = node_count(wisps);
        let mut rw = Vec::with_capacity(n_nodes as usize);
        let mut ranges = Vec::with_capacity(n_wisps as usize);
        for s in &wisps.skeletons {
            ranges.push([rw.len() as u32, s.nodes.len() as u32]);
            for n in &s.nodes {
                rw.push([n.r as f32, n.w as f32, 0.0, 0.0]);
            }
        }
        let layout = bind::layout(
            device,
            "wisp curves",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuWispParams>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<[u32; 2]>(),
                bind::storage_rw::<GpuSegment>(),
                bind::storage_rw::<GpuCapsule>(),
                bind::storage_rw::<u32>(),
                bind::storage_rw::<[f32; 4]>(),
            ],
        );
        let module = gpu::shader_module(device, "wisps/curves", CURVES)?;
        let [spline, overlaps] = gpu::compute_pipelines(
            device,
            "wisp curves",
            &layout,
            &module,
            ["spline", "overlaps"],
            &[],
        );
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisp curve params"),
            size: std::mem::size_of::<GpuWispParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let empty = wgpu::BufferUsages::empty();
        let node_rw =
            gpu::storage_buffer(device, "wisp node r,w", bytemuck::cast_slice(&rw), empty);
        let ranges =
            gpu::storage_buffer(device, "wisp ranges", bytemuck::cast_slice(&ranges), empty);
        let zeros = |label, bytes: u64| tiles::storage(device, label, bytes);
        let segments = zeros(
            "wisp segments",
            n_seg as u64 * std::mem::size_of::<GpuSegment>() as u64,
        );
        let capsules = zeros(
            "wisp capsules",
            n_seg as u64 * std::mem::size_of::<GpuCapsule>() as u64,
        );
        let overlap_counts = zeros("wisp overlap counts", n_seg as u64 * 4);
        let pieces = zeros(
            "wisp pieces",
            n_seg as u64 * (super::curve::PIECES as u64 + 1) * 16,
        );
        let bind_group = bind::buffers(
            device,
            "wisp curves",
            &layout,
            &[
                &params,
                positions,
                &node_rw,
                &ranges,
                &segments,
                &capsules,
                &overlap_counts,
                &pieces,
            ],
        );
        Ok(CurvePass {
            pieces,
            spline,
            overlaps,
            params,
            segments,
            capsules,
            overlap_counts,
            threshold: wisps.threshold as f32,
            bind_group,
            wisps: n_wisps,
            segment_count: n_seg,
            nodes: n_nodes,
            last: None,
        })
    }

    /// Record the two kernels with node positions mapped by `model`, unless the last run had
    /// the same model and `moved` is false.
    pub fn record(&mut self, gpu: &Gpu, enc: &mut wgpu::CommandEncoder, model: DMat4, moved: bool) {
        if !moved && self.last == Some(model) {
            return;
        }
        self.last = Some(model);
        let p = GpuWispParams {
            model: model.as_mat4().to_cols_array_2d(),
            counts: [self.wisps, self.segment_count, 0, self.nodes],
            shape: [self.threshold, 0.0, 0.0, 0.0],
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wisp curves"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&self.spline);
        pass.dispatch_workgroups(self.wisps.div_ceil(WORKGROUP), 1, 1);
        pass.set_pipeline(&self.overlaps);
        pass.dispatch_workgroups(self.segment_count.div_ceil(WORKGROUP), 1, 1);
    }

    /// A new surface threshold: the hit radii change, so the kernels run again.
    pub fn set_threshold(&mut self, threshold: f64) {
        if self.threshold != threshold as f32 {
            self.threshold = threshold as f32;
            self.last = None;
        }
    }

    /// Forget the last run (the positions changed behind the pass's back: a reset).
    pub fn invalidate(&mut self) {
        self.last = None;
    }

    /// The segments, capsules and wisp-overlap counts K the kernels wrote (tests, benches).
    pub fn read(&self, gpu: &Gpu) -> Result<(Vec<GpuSegment>, Vec<GpuCapsule>, Vec<u32>)> {
        let n = self.segment_count as u64;
        let segs = gpu::read_buffer::<GpuSegment>(
            gpu,
            &self.segments,
            n * std::mem::size_of::<GpuSegment>() as u64,
        )?;
        let caps = gpu::read_buffer::<GpuCapsule>(
            gpu,
            &self.capsules,
            n * std::mem::size_of::<GpuCapsule>() as u64,
        )?;
        let counts = gpu::read_buffer::<u32>(gpu, &self.overlap_counts, n * 4)?;
        Ok((segs, caps, counts))
    }
}

/// The ray-march draw: the tile lists (compute, each frame) and one quad per tile.
/// The ray march: in compute (`march` in `shaders/wisps/march.wgsl`: one workgroup per screen
/// tile, one invocation per pixel) writing colour and depth images that the composite
/// (`shaders/wisps/composite.wgsl`) draws into the scene pass by depth; or in fragments
/// (`fs` there) over the same tiles, writing colour and depth in the scene pass
/// (`block::MarchOn`). The same march and image either way.
pub struct MarchPass {
    modules: Modules,
    drawn: Drawn,
    uniform: wgpu::Buffer,
    /// Built at the first `prepare` (the tiles and the march's image need the target size).
    tiles: Option<Sized>,
    segments: u32,
    /// Per segment: outline scale and u at its ends (`toon::segment_outlines`).
    outlines: wgpu::Buffer,
    /// The largest outline scale of any wisp.
    outline_max: f32,
    /// Count steps and candidates (benches; costs atomics per pixel).
    pub counting: bool,
    /// Candidate slots per ray (`scene_slots`, or `set_slots`).
    slots: u32,
    variant: Variant,
}

/// The march's and the composite's modules and layouts.
struct Modules {
    module: wgpu::ShaderModule,
    /// Group 1 of the march in compute and in fragments.
    layout: wgpu::BindGroupLayout,
    frag_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    frag_pipeline_layout: wgpu::PipelineLayout,
    composite_module: wgpu::ShaderModule,
    composite_pipeline_layout: wgpu::PipelineLayout,
    composite_layout: wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
}

impl Modules {
    /// The march's pipelines in compute or in fragments. The march compiles the shadow
    /// lookup (it shades); the scene pass's draw takes the sample count.
    fn pipelines(&self, device: &wgpu::Device, variant: Variant, compute: bool) -> Drawn {
        let draw = |label, layout, module, fragment_entry| {
            DrawPipeline {
                label,
                layout,
                module,
                vertex_entry: "vs",
                fragment_entry,
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                vertex_buffers: &[],
                blend: None,
                format: self.format,
                variant,
                physical: None,
            }
            .build(device)
        };
        if !compute {
            return Drawn::Fragment(draw(
                "wisp march",
                &self.frag_pipeline_layout,
                &self.module,
                "fs",
            ));
        }
        let march = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("wisp march"),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some("march"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &variant.constants(None),
                ..Default::default()
            },
            cache: None,
        });
        Drawn::Compute {
            march,
            composite: draw(
                "wisp composite",
                &self.composite_pipeline_layout,
                &self.composite_module,
                "fs",
            ),
        }
    }
}

/// The pipelines of where the march runs.
enum Drawn {
    Compute {
        march: wgpu::ComputePipeline,
        composite: wgpu::RenderPipeline,
    },
    Fragment(wgpu::RenderPipeline),
}

/// What follows the target's size: the tile lists (and the march's images), with the groups.
struct Sized {
    tiles: TilePass,
    groups: Groups,
}

enum Groups {
    Compute {
        march: wgpu::BindGroup,
        composite: wgpu::BindGroup,
    },
    Fragment(wgpu::BindGroup),
}

/// The march's colour (linear, half floats) and depth images.
const MARCH_COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const MARCH_DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

const _: () = assert!(tiles::TILE == 16, "the march's workgroup is one 16x16 tile");

fn march_image(
    gpu: &Gpu,
    label: &str,
    format: wgpu::TextureFormat,
    size: (u32, u32),
) -> wgpu::TextureView {
    gpu.device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size.0.max(1),
                height: size.1.max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// Group 1 of the march: the same ten buffers in compute and in fragments (tile counts and
/// the view read by the tile quads too), and in compute the two images it writes.
fn march_layout(device: &wgpu::Device, compute: bool) -> wgpu::BindGroupLayout {
    let (all, quads) = if compute {
        (wgpu::ShaderStages::COMPUTE, wgpu::ShaderStages::COMPUTE)
    } else {
        (
            wgpu::ShaderStages::FRAGMENT,
            wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
        )
    };
    let mut slots = vec![
        bind::uniform::<GpuWispDraw>(),
        bind::storage::<GpuSegment>(),
        bind::storage::<GpuCapsule>(),
        bind::storage::<f32>(),
        bind::storage::<u32>().seen_by(quads),
        bind::storage::<u32>(),
        bind::uniform::<GpuMarchView>().seen_by(quads),
        bind::storage_rw::<GpuMarchStats>(),
        bind::storage::<[f32; 4]>(),
        bind::storage::<[f32; 4]>(),
    ];
    if compute {
        slots.push(bind::storage_texture_2d(MARCH_COLOR));
        slots.push(bind::storage_texture_2d(MARCH_DEPTH));
    }
    bind::layout(device, "wisp march", all, &slots)
}

impl MarchPass {
    pub fn new(
        gpu: &Gpu,
        curves: &CurvePass,
        wisps: &Wisps,
        frame_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
    ) -> Result<MarchPass> {
        let device = &gpu.device;
        let seg_outlines = super::toon::segment_outlines(wisps);
        let outline_max = seg_outlines.iter().map(|o| o[0]).fold(0.0f32, f32::max);
        let outlines = gpu::storage_buffer(
            device,
            "wisp outlines",
            bytemuck::cast_slice(&seg_outlines),
            wgpu::BufferUsages::empty(),
        );
        let slots = scene_slots(wisps);
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let composite_layout = bind::layout(
            device,
            "wisp composite",
            wgpu::ShaderStages::FRAGMENT,
            &[
                bind::storage::<u32>().seen_by(vf),
                bind::uniform::<GpuMarchView>().seen_by(vf),
                bind::texture_2d(),
                bind::texture_2d(),
            ],
        );
        let layout = march_layout(device, true);
        let frag_layout = march_layout(device, false);
        let modules = Modules {
            module: gpu::shader_module(device, "wisps/march", &march_source(slots))?,
            pipeline_layout: pipeline::pipeline_layout(
                device,
                "wisp march",
                &[frame_layout, &layout],
            ),
            frag_pipeline_layout: pipeline::pipeline_layout(
                device,
                "wisp march",
                &[frame_layout, &frag_layout],
            ),
            layout,
            frag_layout,
            composite_module: gpu::shader_module(device, "wisps/composite", COMPOSITE)?,
            composite_pipeline_layout: pipeline::pipeline_layout(
                device,
                "wisp composite",
                &[frame_layout, &composite_layout],
            ),
            composite_layout,
            format,
        };
        let drawn = modules.pipelines(
            device,
            variant,
            wisps.march.on.compute(gpu.info.device_type),
        );
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisp draw"),
            size: std::mem::size_of::<GpuWispDraw>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(MarchPass {
            modules,
            drawn,
            uniform,
            tiles: None,
            segments: curves.segment_count,
            outlines,
            outline_max,
            counting: false,
            slots,
            variant,
        })
    }

    /// Whether the march runs in compute.
    pub fn in_compute(&self) -> bool {
        matches!(self.drawn, Drawn::Compute { .. })
    }

    /// Rebuild the pipelines for another MSAA sample count or shadow lookup.
    pub fn set_variant(&mut self, gpu: &Gpu, variant: Variant) {
        self.variant = variant;
        self.drawn = self
            .modules
            .pipelines(&gpu.device, variant, self.in_compute());
    }

    /// Run the march where `on` says on this adapter (the groups follow at the next
    /// `prepare`).
    pub fn set_on(&mut self, gpu: &Gpu, on: MarchOn) {
        let compute = on.compute(gpu.info.device_type);
        if compute != self.in_compute() {
            self.drawn = self.modules.pipelines(&gpu.device, self.variant, compute);
            self.tiles = None;
        }
    }

    /// Candidate slots per ray.
    pub fn slots(&self) -> u32 {
        self.slots
    }

    /// Rebuild the march with `slots` candidate slots per ray (benches and tests; a scene
    /// gets `scene_slots`).
    pub fn set_slots(&mut self, gpu: &Gpu, slots: u32) -> Result<()> {
        let slots = slots.clamp(1, crate::systems::wisps::field::MAX_RAY_SLOTS as u32);
        self.modules.module = gpu::shader_module(&gpu.device, "wisps/march", &march_source(slots))?;
        self.slots = slots;
        self.set_variant(gpu, self.variant);
        Ok(())
    }

    pub fn write(&self, gpu: &Gpu, uniform: &GpuWispDraw) {
        gpu.queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(uniform));
    }

    /// Bin this frame's segments into the tiles of `view.samples` (the buffers follow the
    /// target size) and record the kernels. `outline_px`: the outline width in output pixels.
    pub fn prepare(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        curves: &CurvePass,
        view: &crate::systems::system::View,
        outline_px: f64,
    ) -> Result<()> {
        if self
            .tiles
            .as_ref()
            .is_none_or(|t| t.tiles.samples != view.samples)
        {
            let tp = TilePass::new(
                gpu,
                &curves.segments,
                &curves.capsules,
                self.segments,
                view.samples,
            )?;
            let buffers = [
                &self.uniform,
                &curves.segments,
                &curves.capsules,
                &tp.shells,
                &tp.counts,
                &tp.lists,
                &tp.view,
                &tp.stats,
                &curves.pieces,
                &self.outlines,
            ];
            let mut resources: Vec<wgpu::BindingResource> =
                buffers.iter().map(|b| b.as_entire_binding()).collect();
            let m = &self.modules;
            let groups = if self.in_compute() {
                let color = march_image(gpu, "wisp march colour", MARCH_COLOR, view.samples);
                let depth = march_image(gpu, "wisp march depth", MARCH_DEPTH, view.samples);
                resources.push(wgpu::BindingResource::TextureView(&color));
                resources.push(wgpu::BindingResource::TextureView(&depth));
                Groups::Compute {
                    march: bind::group(&gpu.device, "wisp march", &m.layout, &resources),
                    composite: bind::group(
                        &gpu.device,
                        "wisp composite",
                        &m.composite_layout,
                        &[
                            tp.counts.as_entire_binding(),
                            tp.view.as_entire_binding(),
                            wgpu::BindingResource::TextureView(&color),
                            wgpu::BindingResource::TextureView(&depth),
                        ],
                    ),
                }
            } else {
                Groups::Fragment(bind::group(
                    &gpu.device,
                    "wisp march",
                    &m.frag_layout,
                    &resources,
                ))
            };
            self.tiles = Some(Sized { tiles: tp, groups });
        }
        let Some(sized) = &self.tiles else {
            return Ok(());
        };
        let tp = &sized.tiles;
        // Outline shell half-width per unit distance: outline pixels at the focal length in
        // samples, times samples per output pixel.
        let eps_per_t = outline_px * view.samples_per_px.max(1.0) / view.focal_samples;
        let mv = tiles::march_view(
            view.view_proj,
            view.eye,
            eps_per_t,
            self.outline_max,
            view.samples,
            tp.capacity,
            self.segments,
            self.counting,
        );
        tp.record(gpu, enc, &mv);
        Ok(())
    }

    /// The march in compute, after the shadows (group 0, the frame, is bound); nothing when
    /// it runs in fragments.
    pub fn march(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (Some(sized), Drawn::Compute { march, .. }) = (&self.tiles, &self.drawn) else {
            return;
        };
        let Groups::Compute { march: group, .. } = &sized.groups else {
            return;
        };
        let (tx, ty) = sized.tiles.grid();
        pass.set_pipeline(march);
        pass.set_bind_group(1, group, &[]);
        pass.dispatch_workgroups(tx, ty, 1);
    }

    /// In the scene pass, one quad per tile some segment reaches: the composite of the march
    /// in compute, or the march in fragments.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        let Some(sized) = &self.tiles else {
            return;
        };
        let (pipeline, group) = match (&self.drawn, &sized.groups) {
            (Drawn::Compute { composite, .. }, Groups::Compute { composite: g, .. }) => {
                (composite, g)
            }
            (Drawn::Fragment(p), Groups::Fragment(g)) => (p, g),
            _ => return,
        };
        let (tx, ty) = sized.tiles.grid();
        pass.set_pipeline(pipeline);
        pass.set_bind_group(1, group, &[]);
        pass.draw(0..6, 0..tx * ty);
    }

    /// The tile pass of the last frame (tests, benches).
    pub fn tiles(&self) -> Option<&TilePass> {
        self.tiles.as_ref().map(|t| &t.tiles)
    }

    /// The last frame's counters; None before the first frame.
    pub fn read_stats(&self, gpu: &Gpu) -> Result<Option<MarchStats>> {
        let stats = self.tiles().map(|t| t.read_stats(gpu)).transpose()?;
        Ok(stats.map(|s| MarchStats {
            slots: self.slots,
            ..s
        }))
    }
}

/// Node positions of the drawn skeletons, one `[x, y, z, 1]` per node.
pub fn drawn_positions(wisps: &Wisps) -> Vec<[f32; 4]> {
    wisps
        .skeletons
        .iter()
        .flat_map(|s| s.nodes.iter())
        .map(|n| [n.p[0] as f32, n.p[1] as f32, n.p[2] as f32, 1.0])
        .collect()
}

/// A sphere holding every node's influence: the drawn skeletons grown by their reach when
/// they move (a chain can swing as far as its length round its root).
pub fn bounds(wisps: &Wisps, moving: bool) -> (DVec3, f64) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for s in &wisps.skeletons {
        let root = DVec3::from(s.nodes[0].p);
        let reach: f64 = if moving {
            s.nodes
                .windows(2)
                .map(|w| (DVec3::from(w[1].p) - DVec3::from(w[0].p)).length())
                .sum::<f64>()
                * 1.3
        } else {
            0.0
        };
        for n in &s.nodes {
            let p = DVec3::from(n.p);
            let r = n.r;
            lo = lo.min(p - DVec3::splat(r));
            hi = hi.max(p + DVec3::splat(r));
        }
        let r_max = s.nodes.iter().map(|n| n.r).fold(0.0, f64::max);
        lo = lo.min(root - DVec3::splat(reach + r_max));
        hi = hi.max(root + DVec3::splat(reach + r_max));
    }
    let c = 0.5 * (lo + hi);
    (c, (0.5 * (hi - lo)).length())
}

/// A clear error when the scene's wisps do not fit the adapter.
pub fn check_limits(gpu: &Gpu, wisps: &Wisps) -> Result<()> {
    let n_seg = segment_count(wisps) as u64;
    gpu.check_storage_size(
        "the wisp segments",
        n_seg * std::mem::size_of::<GpuSegment>() as u64,
    )?;
    if n_seg > 60_000 {
        // The overlap and binning kernels loop over every segment; llvmpipe stops loops past
        // 65,535.
        return Err(KamiError::Gpu(format!(
            "{n_seg} wisp segments: at most 60000 fit the overlap and tile kernels"
        )));
    }
    Ok(())
}
