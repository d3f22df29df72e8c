//! Ribbons of the Hair Object Model (Kazama et al. 2.1: reed-shaped polygons along each
//! strip's chain of control points), built on the GPU by `shaders/strips/ribbon.wgsl` and
//! drawn with the generated strand texture by `shaders/strips/draw.wgsl`.
//!
//! Input: the points buffer of the dynamics (`array<vec4<f32>>`, world positions, index
//! `strip * stride + k`, root first) and a per-strip record built here from the rest strips.
//! Output: two vertices per control point, `2 (strip * stride + k)` and `+ 1`, at the
//! control point ∓ half the width along the side vector: u = 0 and 1 across, v = k / (n − 1)
//! along, with the strip tangent for the anisotropic shading. The width tapers linearly
//! from the layer's root width to its tip width. Slots past a strip's last point repeat it.
//!
//! The side vector does not twist. At the root it is the head's ring tangent (ŷ × the
//! outward normal, the direction along the layer's ring of roots, so at rest a ribbon lies
//! flat over the head like a shingle of the layer model), turned with the head pose and made
//! perpendicular to the first stick. Down the strip it is carried by discrete parallel
//! transport: at each point it turns by the smallest rotation taking the previous tangent
//! to this one (Rodrigues), so it never spins about the strip and a straight strip keeps
//! one side vector. Degenerate chains get stated fallbacks: a zero-length stick keeps the
//! previous direction; a side vector within 0.6° of the tangent is replaced by
//! normal × tangent (or any perpendicular); a fold of more than 172° skips the rotation.
//! `ribbon_reference` is the f64 twin of the kernel with the same branches;
//! `tests/it/strips_render.rs` bounds the worst difference.
//!
//! Points bind group: made on the first `record` and cached with a clone of the buffer
//! handle; a later `record` with another buffer (the dynamics rebuilt) makes a new one.

use super::texture::{self, StrandTexture};
use super::RestStrip;
use crate::error::{KamiError, Result};
use crate::gpu::pipeline::{self, DrawPipeline, Variant};
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::shaders::wgsl;
use crate::systems::strips::block::Look;
use bytemuck::{Pod, Zeroable};
use glam::{DMat4, DVec3};
use std::sync::Mutex;

/// The ribbon-building kernel's module (the strips kind lists it as `("strips/ribbon",
/// RIBBON)`).
pub const RIBBON: &str = wgsl!("strips/strip.wgsl", "strips/ribbon.wgsl");
/// The ribbon drawing module (`("strips/draw", DRAW)`).
pub const DRAW: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/random.wgsl",
    "common/coverage_mask.wgsl",
    "common/coverage.wgsl",
    "common/hair_bsdf.wgsl",
    "strips/strip.wgsl",
    "strips/draw.wgsl"
);

/// The strips' shadow cast (`("strips/cast", CAST)`, `stage::shadow`).
pub const CAST: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/shadow_cast.wgsl",
    "strips/strip.wgsl",
    "strips/cast.wgsl"
);

/// Strands a strip stands for in the shadow: light crossing a fully covered strip crosses
/// this many hairs (a strip is a layer of hairs, Kazama et al. 2.1).
pub const STRIP_LAYERS: f32 = 2.0;

/// The strips' shadow cast over the ribbons a `RibbonPass` builds.
pub struct StripCast {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    dims: (u32, u32),
}

impl StripCast {
    /// Deposit the ribbons built by the last `record` (groups 0 and 2 are bound).
    pub fn cast(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.group, &[]);
        pass.dispatch_workgroups(self.dims.0, self.dims.1, 1);
    }
}

/// Squared length under which a stick or a sum of directions counts as zero.
pub const TINY2: f64 = 1e-12;
/// Length under which a projected side vector counts as degenerate (sin 0.57°).
pub const SIDE_MIN: f64 = 1e-2;
/// Cosine between successive tangents under which parallel transport is skipped (a fold).
pub const FOLD_COS: f64 = -0.99;

/// One strip as the ribbon kernel reads it. Twin of `struct StripInfo` (`tests/it/gpu_twins.rs` checks it) in
/// `shaders/strips/ribbon.wgsl` and `shaders/strips/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuStripInfo {
    /// xyz: the side vector at rest (head rest frame); w: root width.
    pub side: [f32; 4],
    /// xyz: outward head normal at the root (head rest frame); w: tip width.
    pub normal: [f32; 4],
    /// rgb: linear layer colour; w: 1.
    pub color: [f32; 4],
    /// x: control points; y: layer; z, w: unused.
    pub counts: [u32; 4],
    /// The fibre-area index of the sky hidden from the strip at v = k / 7, k = 0..8
    /// (`sky::bake`; the physical mode's ambient reads it). 0: the open sky.
    pub sky: [[f32; 4]; 2],
}
const _: () = assert!(std::mem::size_of::<GpuStripInfo>() == 96);

/// One ribbon vertex. Twin of `struct RibbonVertex` (`tests/it/gpu_twins.rs` checks it) in the two WGSL files.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRibbonVertex {
    /// xyz: world position; w: u (0 or 1, across).
    pub position: [f32; 4],
    /// xyz: unit strip tangent; w: v (0 root to 1 tip).
    pub tangent: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuRibbonVertex>() == 32);

/// Twin of `struct Params` (`tests/it/gpu_twins.rs` checks it) in `shaders/strips/ribbon.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRibbonParams {
    pub head: [[f32; 4]; 4],
    /// x: strips; y: stride; z: invocations per dispatch row; w: unused.
    pub counts: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuRibbonParams>() == 80);

/// Twin of `struct StripLook` (`tests/it/gpu_twins.rs` checks it) in `shaders/strips/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuStripLook {
    /// x: specular strength; y: specular exponent; z: alpha cutoff; w: texture gain.
    pub look: [f32; 4],
    /// x: stride (control point slots per strip); y, z, w: unused.
    pub counts: [u32; 4],
    /// The physical shading mode's parameters (`bsdf.sigma_a[3]` 1 when the strips use it).
    pub bsdf: crate::systems::hair_bsdf::GpuHairBsdf,
}
const _: () = assert!(std::mem::size_of::<GpuStripLook>() == 144);

/// One strip as the f64 reference reads it (the same numbers as `GpuStripInfo`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StripInfo {
    pub points: u32,
    pub layer: u32,
    /// Root and tip width.
    pub width: [f64; 2],
    pub color: [f32; 3],
    /// Side vector at rest (the ring tangent), head rest frame.
    pub side: DVec3,
    /// Outward head normal at the root, head rest frame.
    pub normal: DVec3,
}

impl StripInfo {
    pub fn gpu(&self) -> GpuStripInfo {
        let f = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
        GpuStripInfo {
            side: f(self.side, self.width[0]),
            normal: f(self.normal, self.width[1]),
            color: [self.color[0], self.color[1], self.color[2], 1.0],
            counts: [self.points, self.layer, 0, 0],
            sky: [[0.0; 4]; 2],
        }
    }
}

/// A ribbon vertex of the f64 reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RibbonVertex {
    pub position: DVec3,
    pub u: f64,
    pub tangent: DVec3,
    pub v: f64,
}

/// The side vector at rest: the ring tangent ŷ × normal, else (a normal along ±y) the
/// normal of the plane of the first stick and the normal, else any perpendicular.
pub fn rest_side(strip: &RestStrip) -> DVec3 {
    let n = strip.normal.normalize_or(DVec3::Y);
    let ring = DVec3::Y.cross(n);
    if ring.length_squared() > 1e-18 {
        return ring.normalize();
    }
    if let [a, b, ..] = strip.points[..] {
        let t = (b - a).cross(n);
        if t.length_squared() > 1e-18 {
            return t.normalize();
        }
    }
    any_perpendicular(n)
}

/// The per-strip records of the rest strips.
pub fn strip_info(rest: &[RestStrip]) -> Vec<StripInfo> {
    rest.iter()
        .map(|s| StripInfo {
            points: s.points.len() as u32,
            layer: s.layer,
            width: s.width,
            color: s.color,
            side: rest_side(s),
            normal: s.normal.normalize_or(DVec3::Y),
        })
        .collect()
}

fn unit_or(v: DVec3, min2: f64, fallback: DVec3) -> DVec3 {
    let l2 = v.length_squared();
    if l2 > min2 {
        v / l2.sqrt()
    } else {
        fallback
    }
}

/// A unit vector perpendicular to unit `t` (the kernel's `any_perpendicular`).
pub fn any_perpendicular(t: DVec3) -> DVec3 {
    let other = if t.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    t.cross(other).normalize()
}

/// The side vector when the carried one is degenerate: normal × tangent, else any
/// perpendicular.
fn fallback_side(t: DVec3, n: DVec3) -> DVec3 {
    unit_or(n.cross(t), SIDE_MIN * SIDE_MIN, any_perpendicular(t))
}

/// The ribbons of `points` (strip-major, `stride` slots per strip) for the strips of
/// `info`, with the head at pose `head` (its rotation turns the rest side vectors): the
/// f64 reference of `shaders/strips/ribbon.wgsl`. Returns `2 × strips × stride` vertices.
pub fn ribbon_reference(
    points: &[DVec3],
    stride: usize,
    info: &[StripInfo],
    head: &DMat4,
) -> Vec<RibbonVertex> {
    let mut out = Vec::with_capacity(2 * info.len() * stride);
    for (s, strip) in info.iter().enumerate() {
        let base = s * stride;
        let n = (strip.points as usize).clamp(1, stride);
        let p = |k: usize| points[base + k];
        let normal = unit_or(head.transform_vector3(strip.normal), TINY2, DVec3::Y);
        let ring = unit_or(head.transform_vector3(strip.side), TINY2, DVec3::X);
        // Stick directions; a zero-length stick keeps the previous one (the normal at the root).
        let mut dirs = Vec::with_capacity(n.saturating_sub(1));
        let mut last = normal;
        for k in 0..n.saturating_sub(1) {
            last = unit_or(p(k + 1) - p(k), TINY2, last);
            dirs.push(last);
        }
        let tangent = |k: usize| -> DVec3 {
            if n == 1 {
                normal
            } else if k == 0 {
                dirs[0]
            } else if k == n - 1 {
                dirs[n - 2]
            } else {
                unit_or(dirs[k - 1] + dirs[k], TINY2, dirs[k])
            }
        };
        let mut t_prev = tangent(0);
        let mut side = unit_or(
            ring - ring.dot(t_prev) * t_prev,
            SIDE_MIN * SIDE_MIN,
            fallback_side(t_prev, normal),
        );
        for k in 0..stride {
            let kk = k.min(n - 1);
            let t = tangent(kk);
            if k > 0 && k < n {
                let c = t_prev.dot(t);
                if c > FOLD_COS {
                    let v = t_prev.cross(t);
                    side = side * c + v.cross(side) + v * (v.dot(side) / (1.0 + c));
                }
                side = unit_or(
                    side - side.dot(t) * t,
                    SIDE_MIN * SIDE_MIN,
                    fallback_side(t, normal),
                );
                t_prev = t;
            }
            let along = if n > 1 {
                kk as f64 / (n - 1) as f64
            } else {
                0.0
            };
            let half = 0.5 * (strip.width[0] + (strip.width[1] - strip.width[0]) * along);
            let c = p(kk);
            for (u, sign) in [(0.0, -1.0), (1.0, 1.0)] {
                out.push(RibbonVertex {
                    position: c + sign * half * side,
                    u,
                    tangent: t,
                    v: along,
                });
            }
        }
    }
    out
}

/// Runs of consecutive strips with the same point count: (first strip, strips, points).
/// One draw per run, so no strip draws the repeated slots past its tip.
fn runs(info: &[StripInfo]) -> Vec<(u32, u32, u32)> {
    let mut runs: Vec<(u32, u32, u32)> = Vec::new();
    for (i, s) in info.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.2 == s.points => r.1 += 1,
            _ => runs.push((i as u32, 1, s.points)),
        }
    }
    runs
}

/// `shading`: the scene's (the look's own overrides it); `color`: the layers' mean, the
/// pigments' fit when the look sets no melanin.
fn look_uniform(
    look: &Look,
    stride: u32,
    shading: crate::scene::Shading,
    color: [f32; 3],
) -> GpuStripLook {
    GpuStripLook {
        bsdf: crate::systems::hair_bsdf::gpu_block(shading, look.shading, &look.physical, color),
        look: [
            look.specular[0],
            look.specular[1],
            look.alpha_cutoff,
            texture::gain(look),
        ],
        counts: [stride, 0, 0, 0],
    }
}

/// Builds the ribbons from the points buffer (compute) and draws them (render).
pub struct RibbonPass {
    build: wgpu::ComputePipeline,
    build_layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    info: wgpu::Buffer,
    /// What `info` holds (`set_sky` rewrites it).
    gpu_info: Vec<GpuStripInfo>,
    vertices: wgpu::Buffer,
    /// The points buffer the cached bind group reads, and that bind group.
    bound: Mutex<Option<(wgpu::Buffer, wgpu::BindGroup)>>,
    dims: (u32, u32),
    strips: u32,
    stride: u32,
    runs: Vec<(u32, u32, u32)>,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    variant: Variant,
    /// Whether the look shades physically: the pipeline compiles that mode only then.
    physical: bool,
    pipeline: wgpu::RenderPipeline,
    draw_layout: wgpu::BindGroupLayout,
    draw_bind_group: wgpu::BindGroup,
    look_buffer: wgpu::Buffer,
    texture: StrandTexture,
    look: Look,
    /// The scene's shading (`set_shading`) and the layers' mean colour (the pigments' fit).
    shading: crate::scene::Shading,
    fit_color: [f32; 3],
}

/// The mean of the strips' colours (grey without strips).
fn mean_color(rest: &[RestStrip]) -> [f32; 3] {
    if rest.is_empty() {
        return [0.5; 3];
    }
    let n = rest.len() as f32;
    std::array::from_fn(|c| rest.iter().map(|s| s.color[c]).sum::<f32>() / n)
}

impl RibbonPass {
    /// The scene's shading, taken by the next `write_look`.
    pub fn set_shading(&mut self, shading: crate::scene::Shading) {
        self.shading = shading;
    }

    /// Passes for the ribbons of `rest` (points read with `stride` slots per strip), drawn
    /// with `look` into `format` targets of `variant.samples` samples, shading with
    /// `variant.shadow`'s lookup; `frame_layout` is the shared group 0.
    pub fn new(
        gpu: &Gpu,
        rest: &[RestStrip],
        stride: usize,
        look: &Look,
        frame_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
    ) -> Result<RibbonPass> {
        let device = &gpu.device;
        let longest = rest.iter().map(|s| s.points.len()).max().unwrap_or(1);
        if stride < longest.max(1) || stride > u32::MAX as usize / 2 {
            return Err(KamiError::Invalid {
                file: String::new(),
                field: "ribbon stride".into(),
                value: stride.to_string(),
                allowed: format!("at least the longest strip's {longest} control points"),
            });
        }
        if let Some(s) = rest.iter().position(|s| s.points.is_empty()) {
            return Err(KamiError::Invalid {
                file: String::new(),
                field: format!("strip {s} control points"),
                value: "0".into(),
                allowed: "at least one (the root)".into(),
            });
        }
        let strips = rest.len() as u32;
        let vertex_bytes =
            2 * strips as u64 * stride as u64 * std::mem::size_of::<GpuRibbonVertex>() as u64;
        gpu.check_storage_size("the strip ribbons", vertex_bytes)?;
        let info = strip_info(rest);
        let dims = gpu.dispatch_dims(strips, WORKGROUP)?;

        let build_layout = bind::layout(
            device,
            "strips ribbon",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuRibbonParams>(),
                bind::storage::<GpuStripInfo>(),
                bind::storage::<[f32; 4]>(),
                bind::storage_rw::<GpuRibbonVertex>(),
            ],
        );
        let build_module = gpu::shader_module(device, "strips ribbon", RIBBON)?;
        let [build] = gpu::compute_pipelines(
            device,
            "strips ribbon",
            &build_layout,
            &build_module,
            ["build"],
            &[
                ("WORKGROUP", WORKGROUP as f64),
                ("TINY2", TINY2),
                ("SIDE_MIN", SIDE_MIN),
                ("FOLD_COS", FOLD_COS),
            ],
        );
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips ribbon params"),
            size: std::mem::size_of::<GpuRibbonParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let gpu_info: Vec<GpuStripInfo> = info.iter().map(StripInfo::gpu).collect();
        let info_buffer = gpu::storage_buffer(
            device,
            "strips info",
            bytemuck::cast_slice(&gpu_info),
            wgpu::BufferUsages::COPY_DST,
        );
        let vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips ribbon vertices"),
            size: vertex_bytes.max(256),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });

        let module = gpu::shader_module(device, "strips draw", DRAW)?;
        let vs = wgpu::ShaderStages::VERTEX;
        let fs = wgpu::ShaderStages::FRAGMENT;
        let draw_layout = bind::layout(
            device,
            "strips draw",
            vs | fs,
            &[
                bind::storage::<GpuRibbonVertex>().seen_by(vs),
                bind::storage::<GpuStripInfo>(),
                bind::uniform::<GpuStripLook>(),
                bind::filtered_texture_2d().seen_by(fs),
                bind::sampler().seen_by(fs),
            ],
        );
        let pipeline_layout =
            pipeline::pipeline_layout(device, "strips draw", &[frame_layout, &draw_layout]);
        let initial = look_uniform(look, stride as u32, Default::default(), mean_color(rest));
        let physical = initial.bsdf.sigma_a[3] > 0.5;
        let pipeline = Self::pipeline(gpu, &module, &pipeline_layout, format, variant, physical);
        let look_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips look"),
            size: std::mem::size_of::<GpuStripLook>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.queue
            .write_buffer(&look_buffer, 0, bytemuck::bytes_of(&initial));
        let texture = texture::upload(gpu, look)?;
        let draw_bind_group = Self::draw_bind_group(
            device,
            &draw_layout,
            &vertices,
            &info_buffer,
            &look_buffer,
            &texture,
        );
        let me = RibbonPass {
            build,
            build_layout,
            params,
            info: info_buffer,
            gpu_info,
            vertices,
            bound: Mutex::new(None),
            dims,
            strips,
            stride: stride as u32,
            runs: runs(&info),
            module,
            pipeline_layout,
            format,
            variant,
            physical,
            pipeline,
            draw_layout,
            draw_bind_group,
            look_buffer,
            texture,
            look: look.clone(),
            shading: Default::default(),
            fit_color: mean_color(rest),
        };
        me.set_head(gpu, &DMat4::IDENTITY);
        Ok(me)
    }

    fn draw_bind_group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        vertices: &wgpu::Buffer,
        info: &wgpu::Buffer,
        look: &wgpu::Buffer,
        texture: &StrandTexture,
    ) -> wgpu::BindGroup {
        bind::group(
            device,
            "strips draw",
            layout,
            &[
                vertices.as_entire_binding(),
                info.as_entire_binding(),
                look.as_entire_binding(),
                wgpu::BindingResource::TextureView(&texture.view),
                wgpu::BindingResource::Sampler(&texture.sampler),
            ],
        )
    }

    fn pipeline(
        gpu: &Gpu,
        module: &wgpu::ShaderModule,
        layout: &wgpu::PipelineLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
        physical: bool,
    ) -> wgpu::RenderPipeline {
        DrawPipeline {
            label: "strips draw",
            layout,
            module,
            vertex_entry: "vs",
            fragment_entry: pipeline::hair_fragment_entry(gpu),
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            // Both faces: a strip is seen from either side as it swings.
            cull_mode: None,
            vertex_buffers: &[],
            // Without MSAA the hairs' coverage blends; with it, per-sample masks.
            blend: (variant.samples <= 1).then_some(wgpu::BlendState::ALPHA_BLENDING),
            format,
            variant,
            physical: Some(physical),
        }
        .build(&gpu.device)
    }

    /// The head pose the side vectors are turned by (written for the next submission).
    pub fn set_head(&self, gpu: &Gpu, head: &DMat4) {
        let params = GpuRibbonParams {
            head: head.as_mat4().to_cols_array_2d(),
            counts: [self.strips, self.stride, self.dims.0 * WORKGROUP, 0],
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
    }

    /// Record the ribbon build from `points` (at least `strips × stride` entries) with the
    /// head at `head`. The pose goes through `queue.write_buffer`, which lands before the
    /// submission: record once per submission.
    pub fn record(
        &self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        points: &wgpu::Buffer,
        head: &DMat4,
    ) -> Result<()> {
        if self.strips == 0 {
            return Ok(());
        }
        let need = self.strips as u64 * self.stride as u64 * 16;
        if points.size() < need {
            return Err(KamiError::Gpu(format!(
                "the strips' points buffer holds {} bytes; the ribbons of {} strips × {} \
                 slots read {need}",
                points.size(),
                self.strips,
                self.stride
            )));
        }
        self.set_head(gpu, head);
        let mut bound = self
            .bound
            .lock()
            .map_err(|_| KamiError::Gpu("the ribbon bind group lock was poisoned".into()))?;
        if bound.as_ref().is_none_or(|(b, _)| b != points) {
            let bg = bind::buffers(
                &gpu.device,
                "strips ribbon",
                &self.build_layout,
                &[&self.params, &self.info, points, &self.vertices],
            );
            *bound = Some((points.clone(), bg));
        }
        let Some((_, bg)) = bound.as_ref() else {
            return Ok(());
        };
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("strips ribbon"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.build);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(self.dims.0, self.dims.1, 1);
        Ok(())
    }

    /// The shadow cast over these ribbons, for the stage's group 0 and cast layouts.
    pub fn shadow_cast(
        &self,
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        cast_layout: &wgpu::BindGroupLayout,
    ) -> Result<StripCast> {
        let device = &gpu.device;
        let layout = bind::layout(
            device,
            "strips cast",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::storage::<GpuRibbonVertex>(),
                bind::storage::<GpuStripInfo>(),
                bind::uniform::<[u32; 4]>(),
            ],
        );
        let module = gpu::shader_module(device, "strips cast", CAST)?;
        let pl =
            pipeline::pipeline_layout(device, "strips cast", &[frame_layout, &layout, cast_layout]);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("strips cast"),
            layout: Some(&pl),
            module: &module,
            entry_point: Some("cast_shadow"),
            compilation_options: Default::default(),
            cache: None,
        });
        let counts = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("strips cast counts"),
                contents: bytemuck::bytes_of(&[
                    self.stride,
                    self.strips,
                    STRIP_LAYERS.to_bits(),
                    0,
                ]),
                usage: wgpu::BufferUsages::UNIFORM,
            },
        );
        let group = bind::buffers(
            device,
            "strips cast",
            &layout,
            &[&self.vertices, &self.info, &counts],
        );
        Ok(StripCast {
            pipeline,
            group,
            dims: self.dims,
        })
    }

    /// Draw the ribbons built by the last `record` (group 0, the frame, is bound).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        if self.strips == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.draw_bind_group, &[]);
        for &(first, count, points) in &self.runs {
            if points >= 2 {
                pass.draw(0..2 * points, first..first + count);
            }
        }
    }

    /// Rebuild the draw pipeline for another MSAA sample count or shadow lookup.
    pub fn set_variant(&mut self, gpu: &Gpu, variant: Variant) {
        self.variant = variant;
        self.rebuild(gpu);
    }

    fn rebuild(&mut self, gpu: &Gpu) {
        self.pipeline = Self::pipeline(
            gpu,
            &self.module,
            &self.pipeline_layout,
            self.format,
            self.variant,
            self.physical,
        );
    }

    /// Take a new look: the uniform always; the texture again when the hairs or the
    /// gradient changed.
    pub fn write_look(&mut self, gpu: &Gpu, look: &Look) -> Result<()> {
        if look.hairs != self.look.hairs || look.tip_shade != self.look.tip_shade {
            self.texture = texture::upload(gpu, look)?;
            self.draw_bind_group = Self::draw_bind_group(
                &gpu.device,
                &self.draw_layout,
                &self.vertices,
                &self.info,
                &self.look_buffer,
                &self.texture,
            );
        }
        let uniform = look_uniform(look, self.stride, self.shading, self.fit_color);
        let physical = uniform.bsdf.sigma_a[3] > 0.5;
        if physical != self.physical {
            self.physical = physical;
            self.rebuild(gpu);
        }
        gpu.queue
            .write_buffer(&self.look_buffer, 0, bytemuck::bytes_of(&uniform));
        self.look = look.clone();
        Ok(())
    }

    /// The sky each strip sees (`sky::bake`, one entry per strip): the physical mode's
    /// ambient reads it. A new pass has the open sky everywhere.
    pub fn set_sky(&mut self, gpu: &Gpu, sky: &[[f32; super::sky::SKY_SAMPLES]]) -> Result<()> {
        if sky.len() != self.gpu_info.len() {
            return Err(KamiError::Invalid {
                file: String::new(),
                field: "strips sky".into(),
                value: format!("{} strips", sky.len()),
                allowed: format!("one entry per strip ({})", self.gpu_info.len()),
            });
        }
        for (g, s) in self.gpu_info.iter_mut().zip(sky) {
            g.sky = [[s[0], s[1], s[2], s[3]], [s[4], s[5], s[6], s[7]]];
        }
        gpu.queue
            .write_buffer(&self.info, 0, bytemuck::cast_slice(&self.gpu_info));
        Ok(())
    }

    /// The vertex buffer (`2 × strips × stride` `GpuRibbonVertex`; tests read it back).
    pub fn vertices(&self) -> &wgpu::Buffer {
        &self.vertices
    }

    pub fn strips(&self) -> u32 {
        self.strips
    }

    pub fn stride(&self) -> u32 {
        self.stride
    }

    /// Whether the pass shades physically (its look's or the scene's shading).
    pub fn is_physical(&self) -> bool {
        self.physical
    }

    pub fn samples(&self) -> u32 {
        self.variant.samples
    }

    /// The strand texture now bound.
    pub fn texture(&self) -> &StrandTexture {
        &self.texture
    }
}
