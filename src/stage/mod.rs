//! The stage: one orchestrator for everything a scene shows. It owns the scene's hair
//! systems (built through `systems::KINDS`, only those the scene names), the head pass, the
//! frame uniform, the render targets and **one clock**. The CLI's renders, the viewer, the
//! benches and the tests all advance and draw through it, so frame N is the same pose
//! whoever asks for it.
//!
//! Per frame: `advance` records every system's motion for the next frame(s) (the forces and
//! head pose of the clock go to every system in a `FrameCtx`); `render` lets each system
//! prepare (view-dependent compute, uniforms), then draws the head, every system's opaque
//! parts and every system's hair z-buffered into one supersampled, multisampled scene pass
//! (`target::SceneTargets`), then averages it down into the output. The stage knows systems
//! only through `systems::HairSystem`.

pub mod camera;
pub mod head;
pub mod shadow;
/// The thin strands' accumulation lives in `gpu` (systems bind its layouts); named here too.
pub use crate::gpu::splat;
pub mod target;

use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::gpu_data::{linear_rgb, GpuFrame};
use crate::gpu::pipeline::Variant;
use crate::gpu::shadow::{Lookup, ShadowVariant};
use crate::gpu::timing::{GpuTimer, Phase};
use crate::gpu::{self, Gpu};
use crate::systems::world::WorldGpu;
use crate::systems::Scene;
use crate::systems::{Change, DrawSetup, FrameCtx, HairSystem, StepInfo, SystemStats, View, KINDS};
use camera::Camera;
use glam::{DMat4, DVec3};
use target::{DownsamplePass, SceneTargets};

/// Every WGSL module, as (path under `shaders/` without `.wgsl`, composed source): the
/// stage's own, the forces', and each kind's from its `Kind` (the kinds feed the registry;
/// `gpu` and `shaders` name none). `tests/it/shader_validation.rs` runs naga over all of them.
pub fn shaders() -> Vec<(&'static str, &'static str)> {
    let mut all = crate::shaders::STAGE.to_vec();
    all.push(("forces/eff", crate::systems::world::EFF_MODULE));
    for kind in KINDS {
        all.extend_from_slice(kind.shaders);
    }
    all
}

/// Anti-aliasing and resolution settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quality {
    /// MSAA samples: 1 or 4.
    pub msaa: u32,
    /// Supersampling factor per axis, 1..=4.
    pub supersample: u32,
    /// The scene's resolution in percent of the output's per axis (the viewer's budget
    /// lowers it as an artist's viewport does; 100 everywhere else). Below 100 the resolve
    /// scales the scene up bilinearly.
    pub scale_pct: u32,
}

impl Quality {
    /// `msaa` samples and `supersample` per axis at full resolution.
    pub fn new(msaa: u32, supersample: u32) -> Quality {
        Quality {
            msaa,
            supersample,
            scale_pct: 100,
        }
    }

    /// The scene's own anti-aliasing (headless renders).
    pub fn of(scene: &Scene) -> Quality {
        Quality::new(scene.render.msaa, scene.render.supersample)
    }
}

/// How the caller looks at the stage this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    pub camera: Camera,
    /// Share of the hairs drawn (level of detail); 1 for full quality.
    pub lod: f64,
    /// Systems' diagnostic overlays (Anjyo: segments the pseudo-force acted on).
    pub overlay: bool,
}

/// What `Stage::apply` did with an edit, per kind (kinds not in either scene are left out).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Applied {
    pub changes: Vec<(&'static str, Change)>,
    /// Some system was built, rebuilt or removed: the clock went back to frame 0.
    pub restarted: bool,
}

pub struct Stage {
    scene: Scene,
    forces: Forces,
    /// The scene's world on the GPU (gravity, hull, EFF, head field), uploaded once and
    /// bound by every system's simulation kernels (`systems::world`).
    world: WorldGpu,
    /// The clock: frames since the rest pose.
    frame: u64,
    systems: Vec<Box<dyn HairSystem>>,
    pub quality: Quality,
    frame_layout: wgpu::BindGroupLayout,
    frame_buffer: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    /// Built only while the scene shows the head.
    head: Option<head::HeadPass>,
    downsample: DownsamplePass,
    targets: Option<Targets>,
    /// Group 2 of the systems' compute rasterisers for thin strands.
    splat_layouts: splat::SplatLayouts,
    /// Per-pass GPU times, only when a caller asked for them (`enable_timing`).
    timer: Option<GpuTimer>,
    /// The frame uniform of the last `render` (the splat contract test rebuilds its input).
    last_frame: GpuFrame,
    /// Hair shadows (group 0's bindings 1 and 2).
    shadow: shadow::ShadowPass,
    /// The shadow lookup every shading pipeline is built with (`shadow_variant`).
    shadow_variant: ShadowVariant,
}

/// The scene targets of one output size, the resolve's bind group for them, and the thin
/// strands' accumulation once some system splats.
struct Targets {
    scene: SceneTargets,
    resolve: target::ResolveBinding,
    splat: Option<splat::SplatTarget>,
    /// Whether `resolve` composites the accumulation.
    resolve_splat: bool,
}

/// Check, before anything is allocated, that a scene rendered at `size` fits the adapter:
/// every system's buffers within the storage-binding limit, supersampled targets within the
/// texture limit.
pub fn check_limits(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<()> {
    for kind in KINDS {
        if (kind.in_scene)(scene) {
            (kind.check_limits)(gpu, scene)?;
        }
    }
    let f = scene.render.supersample;
    gpu.check_texture_size("the supersampled image width", size.0.saturating_mul(f))?;
    gpu.check_texture_size("the supersampled image height", size.1.saturating_mul(f))?;
    Ok(())
}

/// A kind's part of an edit: its index in `KINDS`, the change, the system built for it.
type Planned = (usize, Change, Option<Box<dyn HairSystem>>);

/// Frames of motion one submission of [`Stage::seek`] records (as many as the viewer's
/// playback records at most, so a seek needs no bigger step buffers than playing does).
pub const SEEK_CHUNK: u64 = 4;

/// The clock at `frame`: the forces and the head pose there.
fn clock(frame: u64, forces: &Forces) -> FrameCtx<'_> {
    FrameCtx {
        frame,
        forces,
        head: forces.head_at(frame as f64),
    }
}

/// The smallest sphere of the two centred between their centres (the clip planes only need
/// a sphere holding both).
fn merge(a: (DVec3, f64), b: (DVec3, f64)) -> (DVec3, f64) {
    let center = 0.5 * (a.0 + b.0);
    (
        center,
        (a.0 - center).length().max((b.0 - center).length()) + a.1.max(b.1),
    )
}

impl Stage {
    /// Build every system the scene names and the passes around them. `output_format` is
    /// the format of what `render` draws into (a window's surface or an offscreen texture).
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        output_format: wgpu::TextureFormat,
        quality: Quality,
    ) -> Result<Stage> {
        let device = &gpu.device;
        let frame_layout = gpu::shadow::frame_layout(device);
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniform"),
            size: std::mem::size_of::<GpuFrame>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow = shadow::ShadowPass::new(gpu, &frame_buffer)?;
        let frame_bind_group =
            gpu::shadow::frame_group(device, &frame_layout, &frame_buffer, shadow.read_view());
        let forces = Forces::new(&scene.forces, &scene.head);
        let world = WorldGpu::of(gpu, &forces, &scene.head)?;
        let mut stage = Stage {
            forces,
            world,
            scene: scene.clone(),
            frame: 0,
            systems: Vec::new(),
            quality,
            head: None,
            downsample: DownsamplePass::new(gpu, output_format)?,
            frame_buffer,
            frame_bind_group,
            frame_layout,
            targets: None,
            splat_layouts: splat::SplatLayouts::new(device),
            timer: None,
            last_frame: bytemuck::Zeroable::zeroed(),
            shadow,
            // What the scene asks for; corrected below once the systems say who casts.
            shadow_variant: shadow_variant(scene, scene.render.shadows.on, false),
        };
        stage.ensure_head(gpu)?;
        for kind in KINDS {
            if (kind.in_scene)(scene) {
                (kind.check_limits)(gpu, scene)?;
                let system = (kind.build)(gpu, scene, &stage.draw_setup(&stage.world))?;
                stage.systems.push(system);
            }
        }
        let variant = shadow_variant(scene, stage.casting(), stage.casting_opaque());
        stage.set_shadow_variant(gpu, variant);
        gpu.take_error()?;
        Ok(stage)
    }

    /// What systems are built for, over `world` (the stage's, or the one an edit makes).
    fn draw_setup<'a>(&'a self, world: &'a WorldGpu) -> DrawSetup<'a> {
        DrawSetup {
            world,
            frame_layout: &self.frame_layout,
            splat_layouts: &self.splat_layouts,
            shadow_cast_layout: &self.shadow.cast_layout,
            format: gpu::pipeline::SCENE_FORMAT,
            variant: self.variant(),
        }
    }

    /// What the scene pipelines are built for: the MSAA samples and the shadow lookup.
    fn variant(&self) -> Variant {
        Variant {
            samples: self.quality.msaa,
            shadow: self.shadow_variant,
        }
    }

    /// Whether this frame has a shadow structure: shadows on and some system casting.
    fn casting(&self) -> bool {
        self.scene.render.shadows.on && self.systems.iter().any(|s| s.casts())
    }

    /// Whether this frame's structure has the skin map: casting, and some system casts an
    /// opaque surface.
    fn casting_opaque(&self) -> bool {
        self.casting() && self.systems.iter().any(|s| s.casts_opaque())
    }

    /// Build the shading pipelines again when the shadow lookup they compile changes (a
    /// toggle, another method, the last caster gone): rare, and the price of paying nothing
    /// for a lookup a frame does not use.
    fn set_shadow_variant(&mut self, gpu: &Gpu, shadow: ShadowVariant) {
        if shadow == self.shadow_variant {
            return;
        }
        self.shadow_variant = shadow;
        let variant = self.variant();
        if let Some(h) = self.head.as_mut() {
            h.set_variant(gpu, variant);
        }
        for s in &mut self.systems {
            s.set_variant(gpu, variant);
        }
    }

    /// The head pass exists exactly while the scene shows the head.
    fn ensure_head(&mut self, gpu: &Gpu) -> Result<()> {
        match (self.scene.head.visible, self.head.is_some()) {
            (true, false) => {
                self.head = Some(head::HeadPass::new(
                    gpu,
                    &self.frame_layout,
                    gpu::pipeline::SCENE_FORMAT,
                    self.variant(),
                )?)
            }
            (false, true) => self.head = None,
            _ => {}
        }
        if let Some(h) = self.head.as_mut() {
            h.set_mesh(gpu, &self.scene.head)?;
        }
        Ok(())
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Time every pass on the GPU from now on (the viewer's Stats, `kami bench scale`).
    /// False when the adapter has no timestamp queries.
    pub fn enable_timing(&mut self, gpu: &Gpu) -> bool {
        if self.timer.is_none() {
            self.timer = GpuTimer::new(gpu);
        }
        self.timer.is_some()
    }

    /// The pass timer, when timing is on: the caller ends the frame with `finish` in its
    /// last encoder and `submitted` after submitting it, and reads times with `poll`.
    pub fn timer(&mut self) -> Option<&mut GpuTimer> {
        self.timer.as_mut()
    }

    fn mark(&mut self, enc: &mut wgpu::CommandEncoder, phase: Phase, begin: bool) {
        if let Some(t) = self.timer.as_mut() {
            if begin {
                t.begin(enc, phase);
            } else {
                t.end(enc, phase);
            }
        }
    }

    /// The frame uniform of the last frame drawn.
    pub fn last_frame_uniform(&self) -> GpuFrame {
        self.last_frame
    }

    /// The thin strands' accumulation (`stage::splat`), once some system has splatted.
    pub fn splat_accumulation(&self) -> Option<&wgpu::Buffer> {
        self.targets.as_ref()?.splat.as_ref().map(|s| &s.accum)
    }

    /// The scene pass's depth (NDC, per sample) at the last output size: what the compute
    /// rasteriser tests hair against. For tests, which run the f64 reference on it.
    pub fn scene_depth(&self) -> Option<&wgpu::TextureView> {
        Some(&self.targets.as_ref()?.scene.depth)
    }

    /// Whether the head pass is built (only while the scene shows the head).
    pub fn has_head(&self) -> bool {
        self.head.is_some()
    }

    /// The clock: frames since the rest pose.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// The clock with its forces and head pose, as every system sees it.
    pub fn ctx(&self) -> FrameCtx<'_> {
        clock(self.frame, &self.forces)
    }

    /// The scene's world on the GPU (what every simulation kernel binds at `WORLD_GROUP`).
    pub fn world(&self) -> &WorldGpu {
        &self.world
    }

    pub fn systems(&self) -> &[Box<dyn HairSystem>] {
        &self.systems
    }

    /// The system of type `T`, if the scene has one (tests and benches).
    pub fn system<T: 'static>(&self) -> Option<&T> {
        self.systems
            .iter()
            .find_map(|s| s.as_any().downcast_ref::<T>())
    }

    pub fn system_mut<T: 'static>(&mut self) -> Option<&mut T> {
        self.systems
            .iter_mut()
            .find_map(|s| s.as_any_mut().downcast_mut::<T>())
    }

    /// Every system's counts added up.
    /// The rate a system plays a file's frames at (a cache), frames per second: the
    /// viewer paces its clock by it. None when everything is simulated.
    pub fn playback_fps(&self) -> Option<f64> {
        self.systems.iter().find_map(|s| s.playback_fps())
    }

    pub fn stats(&self) -> SystemStats {
        self.systems
            .iter()
            .map(|s| s.stats())
            .fold(SystemStats::default(), |a, b| SystemStats {
                strands: a.strands + b.strands,
                segments: a.segments + b.segments,
                simulated: a.simulated + b.simulated,
                drawn: a.drawn + b.drawn,
                raster: None,
            })
    }

    /// A sphere holding the whole scene: every system's, or the head's when there is none.
    pub fn bounds(&self) -> (DVec3, f64) {
        let mut all = self.systems.iter().map(|s| s.bounds());
        match all.next() {
            Some(first) => all.fold(first, merge),
            None => (
                DVec3::from(self.scene.head.center),
                self.scene.head.radii.iter().cloned().fold(0.0, f64::max),
            ),
        }
    }

    /// The scene's own camera at full detail (headless renders).
    pub fn look(&self) -> Look {
        Look {
            camera: Camera::from_desc(&self.scene.camera),
            lod: 1.0,
            overlay: false,
        }
    }

    /// Record `frames` frames of motion of every system into `enc` and move the clock on.
    /// Submit `enc` before the next `advance`: solvers upload their step uniforms with the
    /// queue, which writes them at submission.
    pub fn advance(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        frames: u32,
    ) -> Result<StepInfo> {
        let mut info = StepInfo::default();
        if frames == 0 {
            return Ok(info);
        }
        self.mark(enc, Phase::Simulation, true);
        // A new submission: the world's samples are written from its first entry again.
        self.world.begin();
        let ctx = clock(self.frame, &self.forces);
        for s in &mut self.systems {
            info = info.merge(s.step(gpu, enc, &ctx, frames)?);
        }
        self.mark(enc, Phase::Simulation, false);
        self.frame += frames as u64;
        Ok(info)
    }

    /// Every system back to its rest pose, the clock to frame 0.
    pub fn reset(&mut self, gpu: &Gpu) -> Result<()> {
        for s in &mut self.systems {
            s.reset(gpu)?;
        }
        self.frame = 0;
        Ok(())
    }

    /// The clock to `frame` by simulating again from the rest pose (the timeline's scrub,
    /// and the clip after a key-frame edit): motion depends on the whole past, so a seek
    /// replays it. At most `SEEK_CHUNK` frames go in one submission.
    pub fn seek(&mut self, gpu: &Gpu, frame: u64) -> Result<()> {
        self.reset(gpu)?;
        while self.frame < frame {
            let n = (frame - self.frame).min(SEEK_CHUNK) as u32;
            let mut enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("seek"),
                });
            self.advance(gpu, &mut enc, n)?;
            gpu.queue.submit([enc.finish()]);
        }
        gpu.take_error()
    }

    /// Change anti-aliasing; pipelines and targets are rebuilt only when needed.
    pub fn set_quality(&mut self, gpu: &Gpu, quality: Quality) {
        let msaa_changed = quality.msaa != self.quality.msaa;
        if quality != self.quality {
            self.targets = None;
        }
        self.quality = quality;
        if msaa_changed {
            let variant = self.variant();
            if let Some(h) = self.head.as_mut() {
                h.set_variant(gpu, variant);
            }
            for s in &mut self.systems {
                s.set_variant(gpu, variant);
            }
        }
    }

    /// Take an edited scene (already validated): each kind classifies the edit and the
    /// system is rebuilt, re-simulated or re-drawn accordingly; systems the new scene adds
    /// are built, those it drops are freed. When any system is built, rebuilt or freed, the
    /// clock and every other system go back to frame 0, so all stay on one clock.
    ///
    /// Everything new is built before anything old is touched: when a build fails (a limit,
    /// an unreadable mesh) the error is returned and the stage keeps drawing the scene it had.
    pub fn apply(&mut self, gpu: &Gpu, new: &Scene) -> Result<Applied> {
        let mut applied = Applied::default();
        // The world first: rewritten in place when the new forces and head fit it; otherwise
        // (another EFF grid size, a field appearing or going, another kind of head or field
        // size) a new one, and every system is built again over it.
        let forces = Forces::new(&new.forces, &new.head);
        let hull = crate::scene::hull::head_hull(&new.head)?;
        let new_world = if self.world.fits(&forces, &hull) {
            None
        } else {
            Some(WorldGpu::new(gpu, &forces, &hull)?)
        };
        // First pass: classify, and build what must be built.
        let mut plan: Vec<Planned> = Vec::new();
        for (k, kind) in KINDS.iter().enumerate() {
            let had = self.systems.iter().any(|s| s.kind() == kind.name);
            let change = match (had, (kind.in_scene)(new)) {
                (false, false) => continue,
                (true, false) => Change::Rebuild,
                (false, true) => Change::Rebuild,
                (true, true) if new_world.is_some() => Change::Rebuild,
                (true, true) => (kind.classify)(&self.scene, new),
            };
            let built = if change == Change::Rebuild && (kind.in_scene)(new) {
                (kind.check_limits)(gpu, new)?;
                let world = new_world.as_ref().unwrap_or(&self.world);
                Some((kind.build)(gpu, new, &self.draw_setup(world))?)
            } else {
                None
            };
            applied.changes.push((kind.name, change));
            applied.restarted |= change == Change::Rebuild;
            plan.push((k, change, built));
        }
        // Second pass: swap in what was built, update the rest in place, free what left.
        let mut old = std::mem::take(&mut self.systems);
        let mut fresh = Vec::new();
        for (k, change, built) in plan {
            let name = KINDS[k].name;
            let mine = old
                .iter()
                .position(|s| s.kind() == name)
                .map(|i| old.remove(i));
            match (built, mine) {
                (Some(b), _) => {
                    fresh.push(self.systems.len());
                    self.systems.push(b);
                }
                (None, Some(mut s)) if change != Change::Rebuild => {
                    if change != Change::None {
                        if let Err(e) = s.update(gpu, new, change) {
                            // Keep every system: the refused edit leaves the stage with
                            // what it has (systems' `update` fail before they write).
                            self.systems.push(s);
                            self.systems.append(&mut old);
                            return Err(e);
                        }
                    }
                    self.systems.push(s);
                }
                _ => {}
            }
        }
        match new_world {
            Some(w) => self.world = w,
            None => self.world.write(gpu, &forces, &hull)?,
        }
        self.scene = new.clone();
        self.forces = forces;
        self.ensure_head(gpu)?;
        if applied.restarted {
            // Systems built just now are at rest already.
            for (i, s) in self.systems.iter_mut().enumerate() {
                if !fresh.contains(&i) {
                    s.reset(gpu)?;
                }
            }
            self.frame = 0;
        }
        Ok(applied)
    }

    /// Record a frame of the clock's current pose into `output` (of the output format,
    /// `size` pixels).
    pub fn render(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        output: &wgpu::TextureView,
        size: (u32, u32),
        look: &Look,
    ) -> Result<()> {
        self.render_region(gpu, enc, output, size, size, look)
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
        look: &Look,
    ) -> Result<()> {
        let size = (
            region.0.clamp(1, output_size.0),
            region.1.clamp(1, output_size.1),
        );
        // The shading pipelines compile the lookup of this frame's structure, or none.
        let casting = self.casting();
        let skin = self.casting_opaque();
        self.set_shadow_variant(gpu, shadow_variant(&self.scene, casting, skin));
        // The frame uniform first: systems that work in screen space (the wisps' tiles)
        // prepare with the same view-projection the shaders see.
        let bounds = self.bounds();
        let (mut uniform, view) = self.frame_view(look, bounds, size);
        self.mark(enc, Phase::Generation, true);
        let ctx = clock(self.frame, &self.forces);
        for s in &mut self.systems {
            s.prepare(gpu, enc, &ctx, &view)?;
        }
        let head_pose = ctx.head;
        if let Some(t) = self.timer.as_mut() {
            t.end(enc, Phase::Generation);
        }
        // Thin strands drawn by a compute rasteriser read the scene depth and need an
        // accumulation: targets are made for whether any system splats this frame, which a
        // system under `render.strands: Auto` decides in `prepare` (by its strands' width at
        // this view, whose sample size does not depend on the targets).
        let splatting = self.systems.iter().any(|s| s.splats());
        self.ensure_targets(gpu, size, splatting)?;
        self.bind_splat(gpu, splatting)?;
        self.cast_shadows(gpu, enc, bounds, casting, head_pose, &mut uniform)?;
        if let Some(t) = self.timer.as_mut() {
            t.begin(enc, Phase::Draw);
        }
        let Some(targets) = self.targets.as_ref() else {
            return Err(crate::KamiError::Gpu("scene targets missing".into()));
        };
        let bg = linear_rgb(self.scene.render.background);
        let clear = wgpu::Color {
            r: bg[0] as f64,
            g: bg[1] as f64,
            b: bg[2] as f64,
            a: 1.0,
        };
        self.draw_passes(enc, targets, &view, splatting, clear);
        if let Some(t) = self.timer.as_mut() {
            t.end(enc, Phase::Draw);
            t.begin(enc, Phase::Resolve);
        }
        self.downsample
            .draw(enc, &targets.resolve, output, size, clear);
        self.mark(enc, Phase::Resolve, false);
        Ok(())
    }

    /// Make the scene targets again when the region's size or whether a system splats
    /// changed.
    fn ensure_targets(&mut self, gpu: &Gpu, size: (u32, u32), splatting: bool) -> Result<()> {
        let stale = self
            .targets
            .as_ref()
            .is_none_or(|t| t.scene.output_size != size || t.scene.sampled_depth != splatting);
        if stale {
            let scene = SceneTargets::scaled(
                gpu,
                size,
                self.quality.msaa,
                self.quality.supersample,
                self.quality.scale_pct,
                splatting,
            )?;
            let resolve = self.downsample.bind(gpu, &scene, None);
            self.targets = Some(Targets {
                scene,
                resolve,
                splat: None,
                resolve_splat: false,
            });
        }
        Ok(())
    }

    /// This frame's uniform (before its shadow parameters) and the view the systems
    /// prepare with, for a region of `size` output pixels.
    fn frame_view(&self, look: &Look, bounds: (DVec3, f64), size: (u32, u32)) -> (GpuFrame, View) {
        let q = &self.quality;
        let samples = target::scaled_size(size, q.supersample, q.scale_pct);
        let mut uniform = frame_uniform(&self.scene, look, bounds, samples, self.quality.msaa);
        // Samples per output pixel (widths given in pixels, such as the wisps' outline).
        uniform.flags[1] = samples.1 as f32 / size.1 as f32;
        let view = View {
            eye: look.camera.eye,
            fov_y: look.camera.fov_y,
            lod: look.lod,
            height_px: size.1 as f64,
            lod_tolerance_px: self.scene.render.lod_tolerance_px,
            overlay: look.overlay,
            view_proj: DMat4::from_cols_array_2d(&uniform.view_proj.map(|c| c.map(f64::from))),
            samples,
            samples_per_px: f64::from(uniform.flags[1]),
            focal_samples: f64::from(uniform.raster[0]),
        };
        (uniform, view)
    }

    /// The splat target (made when first needed) and the resolve binding, compositing the
    /// accumulation when a system splats this frame.
    fn bind_splat(&mut self, gpu: &Gpu, splatting: bool) -> Result<()> {
        let Some(targets) = self.targets.as_mut() else {
            return Err(crate::KamiError::Gpu("scene targets missing".into()));
        };
        if splatting && targets.splat.is_none() {
            let t = &targets.scene;
            targets.splat = Some(splat::SplatTarget::new(
                gpu,
                &self.splat_layouts,
                t.size,
                t.samples,
                &t.depth,
            )?);
        }
        if splatting != targets.resolve_splat {
            let accum = targets
                .splat
                .as_ref()
                .filter(|_| splatting)
                .map(|s| &s.accum);
            targets.resolve = self.downsample.bind(gpu, &targets.scene, accum);
            targets.resolve_splat = splatting;
        }
        Ok(())
    }

    /// Hair shadows: cast and resolve, the parameters into `uniform` (written to the frame
    /// buffer, bound for every draw after), and the head posed.
    fn cast_shadows(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        bounds: (DVec3, f64),
        casting: bool,
        head_pose: DMat4,
        uniform: &mut GpuFrame,
    ) -> Result<()> {
        let settings = self.scene.render.shadows;
        let light_box = shadow::LightBox::fit(bounds, DVec3::from(self.scene.light.direction));
        let head = self
            .scene
            .head
            .visible
            .then(|| head_sphere(&self.scene, head_pose));
        let skin = self.casting_opaque();
        let mut params = shadow::params(&settings, &light_box, head, casting, skin);
        if self.shadow_variant.toon {
            // Toon wisps: shadows are steps (`shadow_toon`).
            params.center[3] = 2.0;
        }
        if self
            .shadow
            .prepare(gpu, params, casting.then_some(settings.method))?
        {
            self.frame_bind_group = gpu::shadow::frame_group(
                &gpu.device,
                &self.frame_layout,
                &self.frame_buffer,
                self.shadow.read_view(),
            );
        }
        uniform.shadow = params;
        gpu.queue
            .write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&*uniform));
        self.last_frame = *uniform;
        let systems = &self.systems;
        self.shadow.record(enc, &self.frame_bind_group, |pass| {
            for s in systems {
                s.cast_shadow(pass);
            }
        });
        if let Some(h) = &self.head {
            h.prepare(
                &gpu.queue,
                &self.scene.head_ellipsoid(),
                head_pose,
                self.scene.head.color,
                self.scene.render.shading == crate::scene::Shading::Physical,
            );
        }
        Ok(())
    }

    /// The draw passes into the scene targets: pixels in compute, the scene pass (opaque
    /// first, then every system's hair with its coverage) and the thin strands' splats.
    fn draw_passes(
        &self,
        enc: &mut wgpu::CommandEncoder,
        targets: &Targets,
        view: &View,
        splatting: bool,
        clear: wgpu::Color,
    ) {
        if self.systems.iter().any(|s| s.draws_in_compute()) {
            // Pixels in compute: what the scene pass then composites by depth.
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("pixels in compute"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            for s in &self.systems {
                s.draw_compute(&mut pass);
            }
        }
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &[Some(targets.scene.color_attachment(clear))],
                depth_stencil_attachment: Some(targets.scene.depth_attachment(splatting)),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            // Opaque first (head, skins), then every system's hair with its coverage.
            if let Some(h) = &self.head {
                h.draw(&mut pass);
            }
            for s in &self.systems {
                s.draw_opaque(&mut pass);
            }
            for s in &self.systems {
                s.draw(&mut pass, view);
            }
        }
        if let Some(sp) = targets.splat.as_ref().filter(|_| splatting) {
            enc.clear_buffer(&sp.accum, 0, None);
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("thin strands"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_bind_group(2, &sp.bind_group, &[]);
            for s in &self.systems {
                s.splat(&mut pass);
            }
        }
    }
}

/// What the shading pipelines compile of the shadow lookup for `scene` when it has a shadow
/// structure (`casting`): its method, as toon steps in a scene with a kind that reads them
/// so (`Kind::shadow_steps`).
fn shadow_variant(scene: &Scene, casting: bool, skin: bool) -> ShadowVariant {
    if !casting {
        return ShadowVariant::OFF;
    }
    ShadowVariant {
        lookup: match scene.render.shadows.method {
            crate::scene::ShadowMethod::Volume => Lookup::Volume,
            crate::scene::ShadowMethod::DeepOpacity => Lookup::DeepOpacity,
        },
        toon: crate::systems::KINDS
            .iter()
            .any(|k| k.shadow_steps && (k.in_scene)(scene)),
        skin,
    }
}

/// The head ellipsoid as drawn (its unit sphere to world at head pose `pose`); a mesh head
/// is stood for by its scene ellipsoid when it shadows hair.
fn head_sphere(scene: &Scene, pose: DMat4) -> DMat4 {
    let hull = scene.head_ellipsoid();
    pose * DMat4::from_translation(hull.center) * DMat4::from_scale(hull.radii * head::DRAWN_SCALE)
}

impl Stage {
    /// `shadow_strands`, `shadow_opaque` and `shadow_layered` at `points` as the shaders
    /// saw them in the last frame drawn (tests and `kami bench shadows`).
    pub fn probe_shadows(&self, gpu: &Gpu, points: &[DVec3]) -> Result<Vec<shadow::Probed>> {
        self.shadow.probe(
            gpu,
            &self.frame_layout,
            &self.frame_bind_group,
            self.shadow_variant,
            points,
        )
    }

    /// The shadow lookup the shading pipelines are built with now.
    pub fn shadow_variant(&self) -> ShadowVariant {
        self.shadow_variant
    }

    /// The shadow uniform of the last frame drawn (its light-space box, for the reference).
    pub fn shadow_params(&self) -> gpu::shadow::GpuShadow {
        self.shadow.last()
    }
}

/// The frame uniform for a target of `size` samples with `msaa` samples per pixel.
pub fn frame_uniform(
    scene: &Scene,
    look: &Look,
    bounds: (DVec3, f64),
    size: (u32, u32),
    msaa: u32,
) -> GpuFrame {
    let cam = &look.camera;
    let light = &scene.light;
    let (near, far) = cam.clip_planes(bounds.0, bounds.1);
    let vp = cam.view_proj(size.0 as f64 / size.1 as f64, near, far);
    let l = DVec3::from(light.direction).normalize();
    GpuFrame {
        view_proj: vp.to_cols_array_2d(),
        eye: [cam.eye.x as f32, cam.eye.y as f32, cam.eye.z as f32, 1.0],
        light_dir: [l.x as f32, l.y as f32, l.z as f32, light.intensity as f32],
        light_color: [
            light.color[0],
            light.color[1],
            light.color[2],
            light.ambient as f32,
        ],
        viewport: [
            size.0 as f32,
            size.1 as f32,
            1.0 / size.0 as f32,
            1.0 / size.1 as f32,
        ],
        raster: [
            cam.focal_px(size.1) as f32,
            scene.render.min_width as f32,
            // Full coverage compensation (1/f) turns a sparse preview into paper strips;
            // 1/sqrt(f) keeps most of the density and still reads as hair.
            (1.0 / look.lod.clamp(1e-3, 1.0).sqrt()) as f32,
            msaa.max(1) as f32,
        ],
        flags: [f32::from(u8::from(look.overlay)), 0.0, 0.0, 0.0],
        // Written by `Stage::render` once the shadow pass has fitted its box.
        shadow: Default::default(),
    }
}

impl Stage {
    /// Every system's warnings about the last drawn frame (`HairSystem::warnings`).
    pub fn warnings(&self, gpu: &Gpu) -> Result<Vec<String>> {
        let mut out = Vec::new();
        for s in &self.systems {
            out.extend(s.warnings(gpu)?);
        }
        Ok(out)
    }

    /// Every system's strands as they are now, one groom (systems in build order).
    pub fn export(&self, gpu: &Gpu) -> Result<crate::formats::Groom> {
        let mut all = crate::formats::Groom::default();
        let ctx = self.ctx();
        for s in &self.systems {
            if let Some(g) = s.export(gpu, &ctx)? {
                all.append(g);
            }
        }
        Ok(all)
    }

    /// Every system's hair as the last drawn frame shows it (`HairSystem::export_drawn`),
    /// one groom: the reference geometry of `kami bench look`.
    pub fn export_drawn(&self, gpu: &Gpu) -> Result<crate::systems::system::DrawnHair> {
        let mut all = crate::systems::system::DrawnHair::default();
        let ctx = self.ctx();
        for s in &self.systems {
            if let Some(g) = s.export_drawn(gpu, &ctx)? {
                all.append(g);
            }
        }
        Ok(all)
    }
}

/// The hair of a scene at `frame` (simulated from the rest pose), as one groom: what
/// `kami convert scene.ron out.hair --frame N` writes.
pub fn export_scene(gpu: &Gpu, scene: &Scene, frame: u64) -> Result<crate::formats::Groom> {
    check_limits(gpu, scene, (1, 1))?;
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene))?;
    stage.seek(gpu, frame)?;
    stage.export(gpu)
}

/// Render frame 0 (the rest pose) of a scene offscreen.
pub fn render_scene(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<image::RgbaImage> {
    let mut img = None;
    render_animation(gpu, scene, size, 0..=0, |_, i| {
        img = Some(i);
        Ok(())
    })?;
    img.ok_or_else(|| crate::KamiError::Gpu("frame 0 was not rendered".into()))
}

/// Render frames `first..=last` of a scene's animation offscreen with the scene's camera
/// and anti-aliasing, calling `on_frame` with each image: the CLI's `render` and the
/// snapshot tests. Frame f is the stage's clock at f (after f frames of motion). Returns
/// the number of frames whose steps hit the substep cap (the solver clamped and warned).
pub fn render_animation(
    gpu: &Gpu,
    scene: &Scene,
    size: (u32, u32),
    frames: std::ops::RangeInclusive<u32>,
    on_frame: impl FnMut(u32, image::RgbaImage) -> Result<()>,
) -> Result<u32> {
    render_animation_edited(gpu, scene, &[], size, frames, on_frame)
}

/// [`render_animation`] with edits: from each `(frame, scene)` of `edits` (frame order,
/// validated scenes) on, the stage shows that scene, taken as the viewer takes an edit
/// (`Stage::apply`: each system redrawn, re-simulated or rebuilt; a rebuild restarts the
/// motion from rest). `kami render --set N:KEY=VALUE`.
pub fn render_animation_edited(
    gpu: &Gpu,
    scene: &Scene,
    edits: &[(u64, Scene)],
    size: (u32, u32),
    frames: std::ops::RangeInclusive<u32>,
    mut on_frame: impl FnMut(u32, image::RgbaImage) -> Result<()>,
) -> Result<u32> {
    check_limits(gpu, scene, size)?;
    for (_, s) in edits {
        check_limits(gpu, s, size)?;
    }
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene))?;
    let out = target::Offscreen::new(gpu, size)?;
    let mut look = stage.look();
    let mut capped = 0;
    for f in 0..=*frames.end() {
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("animation frame"),
            });
        if f > 0 {
            capped += u32::from(stage.advance(gpu, &mut enc, 1)?.capped);
        }
        let now: Vec<&Scene> = edits
            .iter()
            .filter(|(at, _)| *at == u64::from(f))
            .map(|(_, s)| s)
            .collect();
        if !now.is_empty() {
            // The step is submitted before the edit can free what it recorded into.
            gpu.queue.submit([enc.finish()]);
            for s in now {
                stage.apply(gpu, s)?;
                stage.set_quality(gpu, Quality::of(s));
            }
            look = stage.look();
            enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("animation frame after an edit"),
                });
        }
        if f >= *frames.start() {
            stage.render(gpu, &mut enc, &out.view, size, &look)?;
            gpu.queue.submit([enc.finish()]);
            for w in stage.warnings(gpu)? {
                log::warn!("frame {f}: {w}");
            }
            on_frame(f, out.read_rgba(gpu)?)?;
        } else {
            gpu.queue.submit([enc.finish()]);
        }
    }
    gpu.take_error()?;
    Ok(capped)
}
