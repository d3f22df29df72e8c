//! Hair shadows from the key light (docs/shadows.md). Each frame, before the scene pass, the
//! stage clears a light-space structure, lets every system cast its strands into it
//! (`HairSystem::cast_shadow`, with `shaders/common/shadow_cast.wgsl`), resolves it into
//! "strands crossed towards the light" and binds the result in group 0 for every draw
//! (`shaders/common/shadow.wgsl`). Two methods, both measured by `kami bench shadows`:
//!
//! - **Volume**: a 64^3 grid whose third axis is the light direction; strands add their
//!   projected coverage (width times length across the light, over the cell's area) to the
//!   cell they pass, and the resolve sums each column along the light.
//! - **Deep opacity** (Yuksel & Keyser 2008): a 256^2 light-space map of each texel's first
//!   depth (one casting phase), then 4 opacity layers behind that depth (a second phase),
//!   summed in the resolve.
//!
//! Opaque casters (a fur mesh's skin, `HairSystem::casts_opaque`) add a **skin map**: a
//! 256^2 light-space map of the nearest skin's depth, rasterised from the skin's triangles
//! in the same cast pass and read by `shadow_opaque` (the head stays an analytic
//! ellipsoid).
//!
//! The light-space box is fitted to the stage's bounding sphere each frame. Buffers exist
//! only while shadows are on and some system casts, the skin map only while one casts
//! opaque. [`reference_strands`] is the f64 reference of `shadow_strands` (brute force over
//! every segment), [`reference_skin`] of the skin map's answer (a ray against every
//! triangle).

use crate::error::{KamiError, Result};
use crate::gpu::gpu_data::GpuFrame;
use crate::gpu::shadow::{self as layouts, GpuShadow};
use crate::gpu::{self, bind, Gpu};
use crate::scene::{ShadowMethod, Shadows};
use glam::{DMat4, DVec3};

/// Cells across the volume's box and slices along the light.
pub const VOLUME_CELLS: u32 = 64;
/// Texels across the deep opacity map.
pub const DEEP_TEXELS: u32 = 256;
/// Deep opacity layers behind the first depth.
pub const DEEP_LAYERS: u32 = 4;
/// Where the deep opacity layers end, in units of the box's size / 64 behind the first depth
/// (layers widen with depth, as Yuksel & Keyser's do).
pub const DEEP_LAYER_ENDS: [f64; 4] = [1.0, 2.0, 4.0, 8.0];
/// Texels across the skin map (`SHADOW_SKIN` in `shaders/common/shadow.wgsl`).
pub const SKIN_TEXELS: u32 = 256;
/// How far behind the nearest skin a point must lie to be in its shadow, in skin texels: a
/// surface's depth varies across the texel it is read from, so the skin would shadow
/// itself, and the roots of hair on its lit side, without it.
pub const SKIN_BIAS_TEXELS: f64 = 2.0;

/// How far towards the light a point on a strand lying in layers (Anjyo's hair) reads the
/// structure (`shadow_layered`), in units of the box's size / 64 (a volume cell): the
/// scene's `layered_offset`, else the method's own. Chosen against the path tracer (`kami
/// bench look`'s offsets table, docs/shadows.md): at the point itself the smoothing counts
/// half the point's own layer, and the outermost layer comes out dark.
pub fn layered_offset(settings: &Shadows) -> f64 {
    settings.layered_offset.unwrap_or(match settings.method {
        ShadowMethod::Volume => LAYERED_OFFSET_VOLUME,
        ShadowMethod::DeepOpacity => LAYERED_OFFSET_DEEP,
    })
}
/// The volume's offset: two cells (its smoothing in depth is one slice and a tent across).
pub const LAYERED_OFFSET_VOLUME: f64 = 2.0;
/// Deep opacity's: one unit (its first layer; the first depth already finds the surface).
pub const LAYERED_OFFSET_DEEP: f64 = 1.0;

/// The box is this much bigger than the stage's bounding sphere (strands on its edge).
const MARGIN: f64 = 1.02;

/// The light-space box of one frame, in f64 (the reference uses the same).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBox {
    pub center: DVec3,
    pub half: f64,
    pub u: DVec3,
    pub v: DVec3,
    /// Unit vector towards the light.
    pub l: DVec3,
}

impl LightBox {
    /// Fitted to a bounding sphere, for a light towards `direction`.
    pub fn fit(bounds: (DVec3, f64), direction: DVec3) -> LightBox {
        let l = direction.normalize();
        let a = if l.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let u = l.cross(a).normalize();
        let v = l.cross(u);
        LightBox {
            center: bounds.0,
            half: (bounds.1 * MARGIN).max(1e-6),
            u,
            v,
            l,
        }
    }

    /// (across u, across v, depth from the box's light side), world units.
    pub fn coords(&self, p: DVec3) -> DVec3 {
        let q = p - self.center;
        DVec3::new(q.dot(self.u), q.dot(self.v), self.half - q.dot(self.l))
    }

    /// Cell size across the light of `method`.
    pub fn cell(&self, method: ShadowMethod) -> f64 {
        2.0 * self.half / cells(method) as f64
    }
}

fn cells(method: ShadowMethod) -> u32 {
    match method {
        ShadowMethod::Volume => VOLUME_CELLS,
        ShadowMethod::DeepOpacity => DEEP_TEXELS,
    }
}

/// f32 words of the resolved structure (and u32 words cast) of `method`, before the skin
/// map's.
fn words(method: ShadowMethod) -> u64 {
    let n = cells(method) as u64;
    match method {
        ShadowMethod::Volume => n * n * VOLUME_CELLS as u64,
        ShadowMethod::DeepOpacity => n * n * (1 + DEEP_LAYERS as u64),
    }
}

/// Words of the whole structure: the method's, then the skin map's when there is one.
fn all_words(method: ShadowMethod, skin: bool) -> u64 {
    words(method)
        + if skin {
            SKIN_TEXELS as u64 * SKIN_TEXELS as u64
        } else {
            0
        }
}

/// The skin map's depth bias in world units for a box (`SKIN_BIAS_TEXELS`).
pub fn skin_bias(b: &LightBox) -> f64 {
    SKIN_BIAS_TEXELS * 2.0 * b.half / SKIN_TEXELS as f64
}

/// The uniform for one frame. `head` is the head ellipsoid's unit-sphere-to-world matrix
/// when a head shadows the hair; `skin` whether some system casts an opaque skin.
pub fn params(
    settings: &Shadows,
    b: &LightBox,
    head: Option<DMat4>,
    on: bool,
    skin: bool,
) -> GpuShadow {
    let f = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
    let method = settings.method;
    let n = cells(method) as f32;
    let unit = 2.0 * b.half / 64.0;
    GpuShadow {
        center: f(b.center, f64::from(u8::from(on))),
        axis_u: f(b.u, b.half),
        axis_v: f(
            b.v,
            match method {
                ShadowMethod::Volume => 0.0,
                ShadowMethod::DeepOpacity => 1.0,
            },
        ),
        axis_l: f(b.l, settings.absorption),
        dims: [
            n,
            n,
            match method {
                ShadowMethod::Volume => VOLUME_CELLS as f32,
                ShadowMethod::DeepOpacity => DEEP_LAYERS as f32,
            },
            f32::from(u8::from(head.is_some())),
        ],
        layers: DEEP_LAYER_ENDS.map(|e| (e * unit) as f32),
        layered: [
            (layered_offset(settings) * unit) as f32,
            f32::from(u8::from(skin)),
            if skin { words(method) as f32 } else { 0.0 },
            if skin { skin_bias(b) as f32 } else { 0.0 },
        ],
        head_inv: head
            .map(|m| m.inverse())
            .unwrap_or(DMat4::IDENTITY)
            .as_mat4()
            .to_cols_array_2d(),
    }
}

/// The cast and resolved buffers of one method.
struct Grid {
    method: ShadowMethod,
    /// Whether the structure ends with the skin map.
    skin: bool,
    cast: wgpu::Buffer,
    resolved: wgpu::Buffer,
    /// What group 0 reads: `resolved` copied after the resolve.
    map: wgpu::Texture,
    view: wgpu::TextureView,
    /// Group 2 of the cast pipelines, per phase.
    cast_groups: [wgpu::BindGroup; 2],
    resolve_group: wgpu::BindGroup,
}

/// The stage's shadow pass: the uniform and, while shadows are on, the structure.
pub struct ShadowPass {
    /// Bound in group 0 while shadows are off (the shaders read nothing from it then).
    placeholder: wgpu::TextureView,
    pub cast_layout: wgpu::BindGroupLayout,
    params_group: wgpu::BindGroup,
    resolve_layout: wgpu::BindGroupLayout,
    resolve: wgpu::ComputePipeline,
    module: wgpu::ShaderModule,
    phases: [wgpu::Buffer; 2],
    grid: Option<Grid>,
    last: GpuShadow,
}

/// The shadow pass's own module (resolve and probe).
pub const MODULE: &str = crate::shaders::SHADOW;

impl ShadowPass {
    /// `frame` is the stage's frame uniform (the resolve reads its `shadow`).
    pub fn new(gpu: &Gpu, frame: &wgpu::Buffer) -> Result<ShadowPass> {
        let device = &gpu.device;
        let placeholder = layouts::map_texture(device, 0).create_view(&Default::default());
        let cs = wgpu::ShaderStages::COMPUTE;
        let params_layout =
            bind::layout(device, "shadow params", cs, &[bind::uniform::<GpuFrame>()]);
        let params_group = bind::buffers(device, "shadow params", &params_layout, &[frame]);
        let resolve_layout = bind::layout(
            device,
            "shadow resolve",
            cs,
            &[bind::storage::<u32>(), bind::storage_rw::<f32>()],
        );
        let module = gpu::shader_module(device, "shadow", MODULE)?;
        let pl = gpu::pipeline::pipeline_layout(
            device,
            "shadow resolve",
            &[&params_layout, &resolve_layout],
        );
        let resolve = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("shadow resolve"),
            layout: Some(&pl),
            module: &module,
            entry_point: Some("resolve"),
            compilation_options: Default::default(),
            cache: None,
        });
        let phases = [0u32, 1].map(|p| {
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("shadow phase"),
                    contents: bytemuck::bytes_of(&[p, 0, 0, 0]),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            )
        });
        Ok(ShadowPass {
            placeholder,
            cast_layout: layouts::cast_layout(device),
            params_group,
            resolve_layout,
            resolve,
            module,
            phases,
            grid: None,
            last: GpuShadow::default(),
        })
    }

    /// What group 0 binds at binding 1: the resolved structure, or the placeholder.
    pub fn read_view(&self) -> &wgpu::TextureView {
        self.grid.as_ref().map_or(&self.placeholder, |g| &g.view)
    }

    /// The uniform of the last frame.
    pub fn last(&self) -> GpuShadow {
        self.last
    }

    /// Take this frame's box (the caller writes it into the frame uniform) and make (or
    /// free) the structure, with a skin map when `uniform` says so; true when the view
    /// group 0 must bind changed.
    pub fn prepare(
        &mut self,
        gpu: &Gpu,
        uniform: GpuShadow,
        method: Option<ShadowMethod>,
    ) -> Result<bool> {
        self.last = uniform;
        let skin = uniform.layered[1] > 0.5;
        let had = self.grid.as_ref().map(|g| (g.method, g.skin));
        if had == method.map(|m| (m, skin)) {
            return Ok(false);
        }
        self.grid = match method {
            None => None,
            Some(m) => Some(self.grid(gpu, m, skin)?),
        };
        Ok(true)
    }

    fn grid(&self, gpu: &Gpu, method: ShadowMethod, skin: bool) -> Result<Grid> {
        let bytes = all_words(method, skin) * 4;
        gpu.check_storage_size("the shadow structure", bytes)?;
        let buffer = |label| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let cast = buffer("shadow cast");
        let resolved = buffer("shadow resolved");
        let cast_groups = [0, 1].map(|p| {
            bind::buffers(
                &gpu.device,
                "shadow cast",
                &self.cast_layout,
                &[&cast, &self.phases[p]],
            )
        });
        let resolve_group = bind::buffers(
            &gpu.device,
            "shadow resolve",
            &self.resolve_layout,
            &[&cast, &resolved],
        );
        let map = layouts::map_texture(&gpu.device, all_words(method, skin));
        let view = map.create_view(&Default::default());
        Ok(Grid {
            method,
            skin,
            cast,
            resolved,
            map,
            view,
            cast_groups,
            resolve_group,
        })
    }

    /// Record this frame's casting and resolve (nothing while shadows are off): `cast`
    /// records every system's casting into a pass with groups 0 (`frame`) and 2 bound.
    pub fn record(
        &self,
        enc: &mut wgpu::CommandEncoder,
        frame: &wgpu::BindGroup,
        mut cast: impl FnMut(&mut wgpu::ComputePass<'_>),
    ) {
        let Some(g) = &self.grid else { return };
        enc.clear_buffer(&g.cast, 0, None);
        let phases: &[usize] = match g.method {
            ShadowMethod::Volume => &[1],
            ShadowMethod::DeepOpacity => &[0, 1],
        };
        // One pass per phase: the second reads the first depths the first wrote.
        for &p in phases {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("shadow cast"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, frame, &[]);
            pass.set_bind_group(2, &g.cast_groups[p], &[]);
            cast(&mut pass);
        }
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("shadow resolve"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.resolve);
        pass.set_bind_group(0, &self.params_group, &[]);
        pass.set_bind_group(1, &g.resolve_group, &[]);
        let n = cells(g.method);
        let texels = if g.skin { SKIN_TEXELS * SKIN_TEXELS } else { 0 };
        pass.dispatch_workgroups((n * n).max(texels).div_ceil(64), 1, 1);
        drop(pass);
        let size = g.map.size();
        enc.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer: &g.resolved,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(layouts::ROW * 4),
                    rows_per_image: None,
                },
            },
            g.map.as_image_copy(),
            size,
        );
    }

    /// `shadow_strands`, `shadow_opaque` and `shadow_layered` at `points` as the shaders see
    /// them this frame (`frame_layout`/`frame` are the stage's group 0, `lookup` what the
    /// shading pipelines compile). For tests and the bench.
    pub fn probe(
        &self,
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        frame: &wgpu::BindGroup,
        lookup: gpu::shadow::ShadowVariant,
        points: &[DVec3],
    ) -> Result<Vec<Probed>> {
        if points.is_empty() {
            return Ok(Vec::new());
        }
        let device = &gpu.device;
        let layout = bind::layout(
            device,
            "shadow probe",
            wgpu::ShaderStages::COMPUTE,
            &[bind::storage::<[f32; 4]>(), bind::storage_rw::<[f32; 4]>()],
        );
        // Group 2, group 1 left empty: the resolve's globals hold group 1 of the same module,
        // and no two globals of a module share a binding (backends that emit the whole
        // module, such as HLSL, would overlap their registers).
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow probe"),
            bind_group_layouts: &[Some(frame_layout), None, Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("shadow probe"),
            layout: Some(&pl),
            module: &self.module,
            entry_point: Some("probe"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &lookup.constants(),
                ..Default::default()
            },
            cache: None,
        });
        let data: Vec<[f32; 4]> = points
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
            .collect();
        let input = gpu::storage_buffer(
            device,
            "probe points",
            bytemuck::cast_slice(&data),
            wgpu::BufferUsages::empty(),
        );
        let bytes = points.len() as u64 * 16;
        let output = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe out"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = bind::buffers(device, "shadow probe", &layout, &[&input, &output]);
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("shadow probe"),
        });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("shadow probe"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, frame, &[]);
            pass.set_bind_group(2, &group, &[]);
            pass.dispatch_workgroups((points.len() as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([enc.finish()]);
        let out: Vec<[f32; 4]> = gpu::read_buffer(gpu, &output, bytes)?;
        if out.len() != points.len() {
            return Err(KamiError::Gpu("shadow probe: short readback".into()));
        }
        Ok(out
            .iter()
            .map(|o| Probed {
                strands: o[0] as f64,
                opaque: o[1] as f64,
                layered: o[2] as f64,
            })
            .collect())
    }
}

/// What the shaders read at one point (`ShadowPass::probe`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probed {
    /// `shadow_strands`.
    pub strands: f64,
    /// `shadow_opaque`.
    pub opaque: f64,
    /// `shadow_layered`.
    pub layered: f64,
}

/// One segment of a groom for the reference: its ends and width.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub a: DVec3,
    pub b: DVec3,
    pub width: f64,
}

/// The f64 reference of `shadow_strands`, brute force over every segment: the expected
/// number of strands crossed on the way from each point towards the light. Every segment is
/// cut into `PIECES` pieces; a piece of length l_perp across the light adds its projected
/// area w * l_perp spread by a 2D Gaussian of deviation `blur` (across the light, so the
/// integral is the piece's area over the cell's area as the GPU deposits it) and counts for
/// points at least `depth_blur` behind it (a linear ramp of that width about the point's
/// depth). `blur` and `depth_blur` are the smoothing of the method compared with.
pub fn reference_strands(
    b: &LightBox,
    segments: &[Segment],
    points: &[DVec3],
    blur: f64,
    depth_blur: f64,
) -> Vec<f64> {
    const PIECES: usize = 8;
    let mut pieces = Vec::with_capacity(segments.len() * PIECES);
    for s in segments {
        let d = s.b - s.a;
        let across = (d - d.dot(b.l) * b.l).length();
        let area = s.width * across / PIECES as f64;
        if area <= 0.0 {
            continue;
        }
        for k in 0..PIECES {
            let c = b.coords(s.a + d * ((k as f64 + 0.5) / PIECES as f64));
            pieces.push((c, area));
        }
    }
    let norm = 1.0 / (2.0 * std::f64::consts::PI * blur * blur);
    let reach2 = (4.0 * blur) * (4.0 * blur);
    points
        .iter()
        .map(|&p| {
            let c = b.coords(p);
            let mut n = 0.0;
            for &(q, area) in &pieces {
                let dx = q.x - c.x;
                let dy = q.y - c.y;
                let r2 = dx * dx + dy * dy;
                if r2 > reach2 {
                    continue;
                }
                let ahead = ((c.z - q.z) / depth_blur.max(1e-12) + 0.5).clamp(0.0, 1.0);
                if ahead > 0.0 {
                    n += area * norm * (-0.5 * r2 / (blur * blur)).exp() * ahead;
                }
            }
            n
        })
        .collect()
}

/// The Gaussian deviation and depth ramp that match a method's smoothing (bilinear spread on
/// casting and bilinear filter on reading, each a tent of one cell: deviation about 0.58
/// cells; in depth the volume's slice, deep opacity's first layer).
pub fn reference_blur(b: &LightBox, method: ShadowMethod) -> (f64, f64) {
    let cell = b.cell(method);
    let depth = match method {
        ShadowMethod::Volume => 2.0 * b.half / VOLUME_CELLS as f64,
        ShadowMethod::DeepOpacity => DEEP_LAYER_ENDS[0] * 2.0 * b.half / 64.0,
    };
    (0.58 * cell, depth)
}

/// The f64 reference of `shadow_opaque` for an ellipsoid head (`head` maps the unit sphere
/// to world): 0 when the ray towards the light meets the ellipsoid drawn 2 % smaller.
pub fn reference_opaque(head: DMat4, l: DVec3, p: DVec3) -> f64 {
    let inv = head.inverse();
    let o = inv.transform_point3(p);
    let d = inv.transform_vector3(l);
    let (a, bb, c) = (d.dot(d), o.dot(d), o.dot(o) - 0.98 * 0.98);
    let disc = bb * bb - a * c;
    if disc < 0.0 || a <= 0.0 {
        return 1.0;
    }
    if (-bb + disc.sqrt()) / a > 0.0 {
        0.0
    } else {
        1.0
    }
}

/// The f64 reference of the skin map's answer (`shadow_skin`) at `p`: 0 when the ray from
/// `p` towards the light (`l`, unit) meets one of `triangles` farther than `bias` from `p`
/// (Moller-Trumbore, both faces), 1 otherwise. The map stands for this at its texels'
/// centres, so the two agree wherever the answer does not change within a texel or two.
pub fn reference_skin(triangles: &[[DVec3; 3]], l: DVec3, bias: f64, p: DVec3) -> f64 {
    let hit = triangles
        .iter()
        .any(|t| crate::scene::mesh::ray_triangle(p, l, t).is_some_and(|(t, _, _)| t > bias));
    if hit {
        0.0
    } else {
        1.0
    }
}

impl LightBox {
    /// The box a frame's uniform describes (the f32 values the shaders used).
    pub fn of(u: &GpuShadow) -> LightBox {
        let v = |a: [f32; 4]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        LightBox {
            center: v(u.center),
            half: u.axis_u[3] as f64,
            u: v(u.axis_u),
            v: v(u.axis_v),
            l: v(u.axis_l),
        }
    }
}

/// A groom's segments (its polylines with each segment's mean width; `width` for a groom
/// without widths).
pub fn segments_of(groom: &crate::formats::Groom, width: f64) -> Vec<Segment> {
    let mut out = Vec::new();
    let mut start = 0usize;
    for &c in &groom.counts {
        let n = c as usize;
        for i in start..(start + n).saturating_sub(1) {
            let w = groom
                .widths
                .as_ref()
                .map_or(width, |w| 0.5 * (w[i] as f64 + w[i + 1] as f64));
            out.push(Segment {
                a: DVec3::from(groom.points[i].map(f64::from)),
                b: DVec3::from(groom.points[i + 1].map(f64::from)),
                width: w,
            });
        }
        start += n;
    }
    out
}

/// The last frame's `shadow_strands` at `points` on the GPU beside the f64 reference for
/// `segments` (the hair drawn), with the reference smoothed as the stage's method smooths.
pub fn against_reference(
    gpu: &Gpu,
    stage: &super::Stage,
    segments: &[Segment],
    points: &[DVec3],
) -> Result<Vec<(f64, f64)>> {
    against(gpu, stage, segments, points, false)
}

/// The same for `shadow_layered`: the reference read at each point moved towards the light
/// by the frame's offset (`layered_offset`).
pub fn layered_against_reference(
    gpu: &Gpu,
    stage: &super::Stage,
    segments: &[Segment],
    points: &[DVec3],
) -> Result<Vec<(f64, f64)>> {
    against(gpu, stage, segments, points, true)
}

fn against(
    gpu: &Gpu,
    stage: &super::Stage,
    segments: &[Segment],
    points: &[DVec3],
    layered: bool,
) -> Result<Vec<(f64, f64)>> {
    let u = stage.shadow_params();
    let b = LightBox::of(&u);
    let method = if u.axis_v[3] > 0.5 {
        ShadowMethod::DeepOpacity
    } else {
        ShadowMethod::Volume
    };
    let (blur, depth) = reference_blur(&b, method);
    let offset = if layered {
        b.l * f64::from(u.layered[0])
    } else {
        DVec3::ZERO
    };
    let moved: Vec<DVec3> = points.iter().map(|p| *p + offset).collect();
    let reference = reference_strands(&b, segments, &moved, blur, depth);
    let got = stage.probe_shadows(gpu, points)?;
    Ok(got
        .iter()
        .zip(reference)
        .map(|(g, r)| (if layered { g.layered } else { g.strands }, r))
        .collect())
}
