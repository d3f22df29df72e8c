//! Render passes and the `Renderer` that runs them. One code path serves the window and the
//! headless renders: `Renderer::render` draws into any `TextureView` of the output format.
//!
//! Per frame: the head and the hair are drawn z-buffered into supersampled, multisampled
//! scene buffers (`target::SceneTargets`), then averaged down into the output.

pub mod camera;
pub mod fur;
pub mod head;
pub mod strands;
pub mod target;

use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuFrame, GpuMaterial};
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, Gpu};
use crate::scene::{Ellipsoid, Light, Scene};
use camera::Camera;
use glam::{DMat4, DVec3};
use target::{DownsamplePass, SceneTargets};

/// Depth test shared by the scene passes.
pub fn depth_state(write: bool) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: target::DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// Anti-aliasing settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quality {
    /// MSAA samples: 1 or 4.
    pub msaa: u32,
    /// Supersampling factor per axis, 1..=4.
    pub supersample: u32,
}

/// Everything a frame shows besides the hair.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameView {
    pub camera: Camera,
    pub light: Light,
    pub background: [f32; 3],
    /// The head hull, its pose and skin colour; `None` hides it.
    pub head: Option<(Ellipsoid, DMat4, [f32; 3])>,
    /// A sphere holding the whole scene (for the clip planes).
    pub bounds: (DVec3, f64),
    /// Narrowest strand drawn, in samples.
    pub min_width: f64,
    /// Share of each group's hairs drawn (level of detail); the others are skipped and the
    /// drawn ones widened to keep the coverage. 1 for full quality.
    pub hair_fraction: f64,
    /// Colour the segments the pseudo-force acted on (viewer overlay).
    pub show_pseudo: bool,
    /// This frame's fur, when the scene has fur.
    pub fur: Option<crate::groom::fur::FurFrame>,
}

impl FrameView {
    pub fn from_scene(scene: &Scene) -> FrameView {
        FrameView {
            camera: Camera::from_desc(&scene.camera),
            light: scene.light.clone(),
            background: scene.render.background,
            head: scene
                .head
                .visible
                .then(|| (scene.head_ellipsoid(), DMat4::IDENTITY, scene.head.color)),
            bounds: scene_bounds(scene),
            min_width: scene.render.min_width,
            hair_fraction: 1.0,
            show_pseudo: false,
            fur: None,
        }
    }
}

/// A sphere around the head and the longest possible hair of every group.
pub fn scene_bounds(scene: &Scene) -> (DVec3, f64) {
    let c = DVec3::from(scene.head.center);
    let head_r = scene.head.radii.iter().cloned().fold(0.0, f64::max);
    let mut r = head_r;
    for g in &scene.groups {
        let (hc, hr) = match &g.roots.on {
            Some(e) => (
                DVec3::from(e.center),
                e.radii.iter().cloned().fold(0.0, f64::max),
            ),
            None => (c, head_r),
        };
        let reach = (hc - c).length() + hr + g.length * (1.0 + g.length_jitter);
        r = r.max(reach);
    }
    (c, r)
}

/// Group materials of a scene, in group order.
pub fn materials(scene: &Scene) -> Vec<GpuMaterial> {
    scene
        .groups
        .iter()
        .map(|g| GpuMaterial::from_material(&g.material))
        .collect()
}

pub struct Renderer {
    pub quality: Quality,
    frame_layout: wgpu::BindGroupLayout,
    /// Built only for scenes with fur.
    fur: Option<fur::FurPass>,
    fur_setup: Option<crate::groom::fur::FurSetup>,
    frame_buffer: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    head: head::HeadPass,
    strands: strands::StrandsPass,
    downsample: DownsamplePass,
    targets: Option<(SceneTargets, wgpu::BindGroup)>,
}

impl Renderer {
    pub fn new(
        gpu: &Gpu,
        output_format: wgpu::TextureFormat,
        quality: Quality,
    ) -> Result<Renderer> {
        let device = &gpu.device;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[gpu::uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniform"),
            size: std::mem::size_of::<GpuFrame>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &frame_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: frame_buffer.as_entire_binding(),
            }],
        });
        let fmt = target::SCENE_FORMAT;
        Ok(Renderer {
            quality,
            fur: None,
            fur_setup: None,
            head: head::HeadPass::new(gpu, &frame_layout, fmt, quality.msaa)?,
            strands: strands::StrandsPass::new(gpu, &frame_layout, fmt, quality.msaa)?,
            downsample: DownsamplePass::new(gpu, output_format)?,
            frame_buffer,
            frame_bind_group,
            frame_layout,
            targets: None,
        })
    }

    /// Draw this fur from now on (its pipelines are built on first use).
    pub fn set_fur(&mut self, gpu: &Gpu, fur: &crate::groom::fur::FurSystem) -> Result<()> {
        if self.fur.is_none() {
            self.fur = Some(fur::FurPass::new(
                gpu,
                &self.frame_layout,
                target::SCENE_FORMAT,
                self.quality.msaa,
            )?);
        }
        if let Some(pass) = self.fur.as_mut() {
            pass.set_fur(gpu, &fur.setup, &fur.gpu);
        }
        self.fur_setup = Some(fur.setup.clone());
        Ok(())
    }

    /// Stop drawing fur.
    pub fn clear_fur(&mut self) {
        self.fur = None;
        self.fur_setup = None;
    }

    /// Change anti-aliasing; pipelines and targets are rebuilt only when needed.
    pub fn set_quality(&mut self, gpu: &Gpu, quality: Quality) {
        if quality.msaa != self.quality.msaa {
            self.head.set_samples(gpu, quality.msaa);
            self.strands.set_samples(gpu, quality.msaa);
            if let Some(f) = self.fur.as_mut() {
                f.set_samples(gpu, quality.msaa);
            }
        }
        if quality != self.quality {
            self.targets = None;
        }
        self.quality = quality;
    }

    /// Draw this hair from now on.
    pub fn set_hair(&mut self, gpu: &Gpu, hair: &StrandBuffers, materials: &[GpuMaterial]) {
        self.strands.set_hair(gpu, hair, materials);
    }

    pub fn update_materials(&self, gpu: &Gpu, materials: &[GpuMaterial]) {
        self.strands.update_materials(&gpu.queue, materials);
    }

    /// Record a frame into `output` (of the output format, `size` pixels).
    pub fn render(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        output: &wgpu::TextureView,
        size: (u32, u32),
        view: &FrameView,
    ) -> Result<()> {
        self.render_region(gpu, enc, output, size, size, view)
    }

    /// Record a frame into the left `region` of `output` (`output_size` pixels); the rest is
    /// cleared to the background (the viewer draws its panels there).
    pub fn render_region(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        output: &wgpu::TextureView,
        output_size: (u32, u32),
        region: (u32, u32),
        view: &FrameView,
    ) -> Result<()> {
        let size = (
            region.0.clamp(1, output_size.0),
            region.1.clamp(1, output_size.1),
        );
        let stale = self
            .targets
            .as_ref()
            .is_none_or(|(t, _)| t.output_size != size);
        if stale {
            let t = SceneTargets::new(gpu, size, self.quality.msaa, self.quality.supersample)?;
            let bg = self.downsample.bind(gpu, &t);
            self.targets = Some((t, bg));
        }
        let (targets, down_bg) = self.targets.as_ref().unwrap();
        gpu.queue.write_buffer(
            &self.frame_buffer,
            0,
            bytemuck::bytes_of(&frame_uniform(view, targets.size, self.quality.msaa)),
        );
        if let Some((hull, pose, color)) = &view.head {
            self.head.prepare(&gpu.queue, hull, *pose, *color);
        }
        if let (Some(pass), Some(setup), Some(ff)) = (&self.fur, &self.fur_setup, &view.fur) {
            pass.prepare(gpu, setup, ff.frame, ff.width_scale);
        }
        let bg = linear_rgb(view.background);
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &[Some(targets.color_attachment(wgpu::Color {
                    r: bg[0] as f64,
                    g: bg[1] as f64,
                    b: bg[2] as f64,
                    a: 1.0,
                }))],
                depth_stencil_attachment: Some(targets.depth_attachment()),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            if view.head.is_some() {
                self.head.draw(&mut pass);
            }
            self.strands.draw(&mut pass, view.hair_fraction);
            if let (Some(f), Some(ff)) = (&self.fur, &view.fur) {
                f.draw(&mut pass, &ff.drawn);
            }
        }
        let clear = wgpu::Color {
            r: bg[0] as f64,
            g: bg[1] as f64,
            b: bg[2] as f64,
            a: 1.0,
        };
        self.downsample.draw(enc, down_bg, output, size, clear);
        Ok(())
    }
}

/// The fragment entry point of the hair and fur shaders on this adapter: both make the same
/// per-sample coverage decisions (`shaders/common/coverage.wgsl`); the GL backend gets the
/// per-sample one because naga cannot write a sample mask in GLSL.
pub fn hair_fragment_entry(gpu: &Gpu) -> &'static str {
    if gpu.info.backend == wgpu::Backend::Gl {
        "fs_per_sample"
    } else {
        "fs"
    }
}

/// The frame uniform for a target of `size` samples with `msaa` samples per pixel.
pub fn frame_uniform(view: &FrameView, size: (u32, u32), msaa: u32) -> GpuFrame {
    let cam = &view.camera;
    let (near, far) = cam.clip_planes(view.bounds.0, view.bounds.1);
    let vp = cam.view_proj(size.0 as f64 / size.1 as f64, near, far);
    let l = DVec3::from(view.light.direction).normalize();
    GpuFrame {
        view_proj: vp.to_cols_array_2d(),
        eye: [cam.eye.x as f32, cam.eye.y as f32, cam.eye.z as f32, 1.0],
        light_dir: [
            l.x as f32,
            l.y as f32,
            l.z as f32,
            view.light.intensity as f32,
        ],
        light_color: [
            view.light.color[0],
            view.light.color[1],
            view.light.color[2],
            view.light.ambient as f32,
        ],
        viewport: [
            size.0 as f32,
            size.1 as f32,
            1.0 / size.0 as f32,
            1.0 / size.1 as f32,
        ],
        raster: [
            cam.focal_px(size.1) as f32,
            view.min_width as f32,
            // Full coverage compensation (1/f) turns a sparse preview into paper strips;
            // 1/sqrt(f) keeps most of the density and still reads as hair.
            (1.0 / view.hair_fraction.clamp(1e-3, 1.0).sqrt()) as f32,
            msaa.max(1) as f32,
        ],
        flags: [f32::from(u8::from(view.show_pseudo)), 0.0, 0.0, 0.0],
    }
}

/// Check, before anything is allocated, that a scene rendered at `size` fits the adapter:
/// hair buffers within the storage-binding limit, supersampled targets within the texture
/// limit.
pub fn check_limits(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<()> {
    let (strands, segments) = scene.counts();
    gpu.check_storage_size("the hair vertex buffer", (segments + strands) * 16)?;
    gpu.check_storage_size("the strand table", strands * 32)?;
    let f = scene.render.supersample;
    gpu.check_texture_size("the supersampled image width", size.0.saturating_mul(f))?;
    gpu.check_texture_size("the supersampled image height", size.1.saturating_mul(f))?;
    Ok(())
}

/// Groom a scene on the GPU and render it offscreen: the CLI's `render` and the snapshot
/// tests go through here.
pub fn render_scene(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<image::RgbaImage> {
    let mut img = None;
    render_animation(gpu, scene, size, 0..=0, |_, i| {
        img = Some(i);
        Ok(())
    })?;
    Ok(img.expect("frame 0 is rendered"))
}

/// Everything drawn in a scene: hair (groomed, maybe simulated) and fur.
pub struct SceneContent {
    pub hair: StrandBuffers,
    pub sim: Option<crate::sim::Simulation>,
    pub fur: Option<crate::groom::fur::FurSystem>,
}

/// Groom, set up the simulation and the fur of a scene, and bind them to `renderer`.
pub fn build_content(gpu: &Gpu, scene: &Scene, renderer: &mut Renderer) -> Result<SceneContent> {
    let input = crate::groom::prepare(scene)?;
    let hair = crate::groom::cantilever::groom_gpu(gpu, &input)?;
    let sim = crate::sim::Simulation::new(gpu, scene, &input, &hair)?;
    renderer.set_hair(gpu, &hair, &materials(scene));
    let fur = crate::groom::fur::FurSystem::new(gpu, scene)?;
    match &fur {
        Some(f) => renderer.set_fur(gpu, f)?,
        None => renderer.clear_fur(),
    }
    Ok(SceneContent { hair, sim, fur })
}

/// The frame view of a scene, with bounds that include its fur.
pub fn view_with_fur(scene: &Scene, fur: Option<&crate::groom::fur::FurSystem>) -> FrameView {
    let mut view = FrameView::from_scene(scene);
    if let Some(f) = fur {
        let (c, r) = f.setup.bounds();
        view.bounds = if scene.groups.is_empty() {
            (c, r)
        } else {
            let (hc, hr) = view.bounds;
            let center = 0.5 * (hc + c);
            (
                center,
                (hc - center).length().max((c - center).length()) + hr.max(r),
            )
        };
    }
    view
}

/// Render frames `first..=last` of a scene's animation offscreen, calling `on_frame` with
/// each image. The groom and the simulation run on the GPU; only the images come back.
/// Frame 0 is the groomed rest pose; frame f is after f frames of simulation. Returns the
/// number of frames whose steps hit the substep cap (the solver clamped and warned).
pub fn render_animation(
    gpu: &Gpu,
    scene: &Scene,
    size: (u32, u32),
    frames: std::ops::RangeInclusive<u32>,
    mut on_frame: impl FnMut(u32, image::RgbaImage) -> Result<()>,
) -> Result<u32> {
    check_limits(gpu, scene, size)?;
    let quality = Quality {
        msaa: scene.render.msaa,
        supersample: scene.render.supersample,
    };
    let mut renderer = Renderer::new(gpu, target::OUTPUT_FORMAT, quality)?;
    let mut content = build_content(gpu, scene, &mut renderer)?;
    let out = target::Offscreen::new(gpu, size)?;
    let mut view = view_with_fur(scene, content.fur.as_ref());
    let center = DVec3::from(scene.head.center);
    let mut capped = 0;
    for f in 0..=*frames.end() {
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("animation frame"),
            });
        if f > 0 {
            if let Some(sim) = content.sim.as_mut() {
                capped += u32::from(sim.record_frame(gpu, &mut enc, &content.hair).capped);
            }
        }
        if f >= *frames.start() {
            if let (Some(d), Some(head)) = (&scene.dynamics, view.head.as_mut()) {
                head.1 = crate::sim::forces::head_at(&d.head_motion, center, f as f64);
            }
            if let Some(fur) = content.fur.as_mut() {
                view.fur = Some(fur.record(
                    gpu,
                    &mut enc,
                    f as f64,
                    view.camera.eye,
                    view.camera.fov_y,
                    1.0,
                )?);
            }
            renderer.render(gpu, &mut enc, &out.view, size, &view)?;
            gpu.queue.submit([enc.finish()]);
            on_frame(f, out.read_rgba(gpu)?)?;
        } else {
            gpu.queue.submit([enc.finish()]);
        }
    }
    gpu.take_error()?;
    Ok(capped)
}
