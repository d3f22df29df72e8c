//! A built hair system and what the stage hands it: the one clock of a frame (`FrameCtx`),
//! the view (`View`), what its pipelines are built for (`DrawSetup`), what an edit asks of
//! it (`Change`), and the `HairSystem` interface itself. Kinds implement it; the stage and
//! the viewer drive it. It names no kind and nothing of the registry (`systems/mod.rs`), so
//! the kinds that import it import nothing that lists them.

use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::Gpu;
use crate::systems::scene::Scene;
use crate::systems::world;
use glam::{DMat4, DVec3};

/// The hair as a frame draws it, as strands (`HairSystem::export_drawn`).
#[derive(Clone, Debug, Default)]
pub struct DrawnHair {
    pub groom: crate::formats::Groom,
    /// Per strand: what its absorption (sigma_a) is multiplied by against its group's, per
    /// channel (per-strand variation, `anjyo::vary`); `None`: every strand its group's.
    pub absorption: Option<Vec<[f32; 3]>>,
}

impl DrawnHair {
    /// `other`'s strands after these (a strand without its own absorption gets 1).
    pub fn append(&mut self, other: DrawnHair) {
        let (mine, theirs) = (self.groom.counts.len(), other.groom.counts.len());
        if self.absorption.is_some() || other.absorption.is_some() {
            let a = self.absorption.get_or_insert_with(|| vec![[1.0; 3]; mine]);
            a.extend(other.absorption.unwrap_or_else(|| vec![[1.0; 3]; theirs]));
        }
        self.groom.append(other.groom);
    }
}

/// The one clock of a frame, handed to every system: frames since the rest pose, the shared
/// force fields and the head pose at that frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameCtx<'a> {
    /// Frames since the rest pose: 0 is the groomed rest pose, f is after f frames of
    /// simulation. Keyed forces, head motion and mesh motion are all read at this frame.
    pub frame: u64,
    pub forces: &'a Forces,
    /// Head pose at `frame` (roots ride it; the head pass draws it).
    pub head: DMat4,
}

impl FrameCtx<'_> {
    /// The clock as a time in frames (for keyed and periodic motion).
    pub fn time(&self) -> f64 {
        self.frame as f64
    }
}

/// How the frame is looked at: what a system needs to choose its level of detail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub eye: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
    /// Share of the hairs to draw (the viewer's level of detail); 1 for full quality.
    pub lod: f64,
    /// Height of the target in pixels (the screen-space level of detail, `lod`).
    pub height_px: f64,
    /// Chord error allowed by the screen-space level of detail, pixels; 0 is full detail.
    pub lod_tolerance_px: f64,
    /// Show the system's diagnostic overlay (Anjyo: segments the pseudo-force acted on).
    pub overlay: bool,
    /// The frame's view-projection, the f32 values the shaders see (screen-space work such
    /// as the wisps' tile lists projects with exactly these).
    pub view_proj: DMat4,
    /// Size of the scene target in samples (supersampled).
    pub samples: (u32, u32),
    /// Samples per output pixel (widths given in pixels).
    pub samples_per_px: f64,
    /// Focal length in samples.
    pub focal_samples: f64,
}

impl View {
    /// How much wider the frame draws strands for the viewer's budget (`lod` below 1):
    /// `1/sqrt(lod)`, as the frame uniform's `raster.z`.
    pub fn budget_widening(&self) -> f64 {
        1.0 / self.lod.clamp(1e-3, 1.0).sqrt()
    }
}

/// What a system's pipelines are built for: the shared frame bind group (group 0,
/// `shaders/common/frame.wgsl`), the scene target format, its MSAA sample count and the
/// shadow lookup the shading compiles; and the world its simulation kernels bind.
pub struct DrawSetup<'a> {
    /// The scene's world on the GPU (gravity, hull, EFF, head field), the stage's: every
    /// simulation kernel binds its group at `world::WORLD_GROUP`. A system keeps its group,
    /// which the stage rewrites in place on edits that fit it; an edit that needs a new
    /// world builds every system again (`Stage::apply`).
    pub world: &'a world::WorldGpu,
    pub frame_layout: &'a wgpu::BindGroupLayout,
    /// Group 2 of a compute rasteriser for thin strands (`gpu::splat`).
    pub splat_layouts: &'a crate::gpu::splat::SplatLayouts,
    /// Group 2 of a cast pipeline (`gpu::shadow`, `shaders/common/shadow_cast.wgsl`).
    pub shadow_cast_layout: &'a wgpu::BindGroupLayout,
    pub format: wgpu::TextureFormat,
    pub variant: crate::gpu::pipeline::Variant,
}

/// What an edit of the scene asks of one system, least to most work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum Change {
    /// Nothing of this system changed.
    #[default]
    None,
    /// Only how it looks: new uniforms, same shape and motion.
    Redraw,
    /// Motion parameters: they act from the next step, the current pose stays.
    Resimulate,
    /// Its shape or its set-up: build the system again (a new rest pose).
    Rebuild,
}

/// What one frame of stepping did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepInfo {
    pub substeps: u32,
    /// Some step needed more substeps than allowed (the solver clamped and warned).
    pub capped: bool,
}

impl StepInfo {
    pub fn merge(self, other: StepInfo) -> StepInfo {
        StepInfo {
            substeps: self.substeps + other.substeps,
            capped: self.capped || other.capped,
        }
    }
}

/// Counts for the Stats panel and the CLI.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SystemStats {
    pub strands: u64,
    pub segments: u64,
    /// Strands the solver moves (0 for a still groom).
    pub simulated: u64,
    /// Strands drawn in the last frame (after level of detail and culling).
    pub drawn: u64,
    /// For a kind with thin strands: how the last frame rasterised them.
    pub raster: Option<RasterChoice>,
}

/// Which rasteriser drew a kind's thin strands in the last frame, and why (`render.strands:
/// Auto` chooses by width, `systems::raster`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RasterChoice {
    /// The compute rasteriser rather than ribbons.
    pub compute: bool,
    /// The widest strand's width in samples.
    pub width_samples: f64,
}

impl std::fmt::Display for RasterChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let how = if self.compute { "compute" } else { "ribbons" };
        if self.width_samples.is_finite() {
            write!(f, "{how}, {:.2} samples wide", self.width_samples)
        } else {
            write!(f, "{how}, close-up")
        }
    }
}

/// One hair system, built for one scene.
pub trait HairSystem {
    /// The kind's name (as in `KINDS`).
    fn kind(&self) -> &'static str;
    /// A sphere holding everything the system may draw.
    fn bounds(&self) -> (DVec3, f64);
    /// Record `frames` frames of motion from `ctx.frame` on (compute work only; positions
    /// stay on the GPU). Systems without dynamics do nothing.
    fn step(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        frames: u32,
    ) -> Result<StepInfo>;
    /// Before drawing `ctx.frame` for `view`: write per-frame uniforms and record any
    /// view-dependent compute work (regeneration, culling).
    fn prepare(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        view: &View,
    ) -> Result<()>;
    /// Opaque geometry (a skin), drawn before any hair of any system.
    fn draw_opaque(&self, _pass: &mut wgpu::RenderPass<'_>) {}
    /// The hair, with per-sample coverage; group 0 (the frame) is bound.
    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, view: &View);
    /// Whether `draw` composites per-pixel work recorded by `draw_compute`.
    fn draws_in_compute(&self) -> bool {
        false
    }
    /// Per-pixel work of `draw` done in compute (the wisps' march), after the shadows and
    /// before the scene pass; group 0 (the frame) is bound.
    fn draw_compute(&self, _pass: &mut wgpu::ComputePass<'_>) {}
    /// Whether this frame's hair is drawn by a compute rasteriser (`splat`) instead of
    /// `draw`: the stage then keeps the scene depth and composites the accumulation. Under
    /// `render.strands: Auto` the answer may change in `prepare` (`systems::raster`); the
    /// stage asks again after it.
    fn splats(&self) -> bool {
        false
    }
    /// Record the compute rasteriser after the scene pass; groups 0 (the frame) and 2 (the
    /// accumulation and the scene depth, `stage::splat`) are bound.
    fn splat(&self, _pass: &mut wgpu::ComputePass<'_>) {}
    /// Whether the system casts hair shadows (`cast_shadow` records something).
    fn casts(&self) -> bool {
        false
    }
    /// Whether the system also casts an opaque surface (a fur mesh's skin): the stage then
    /// adds the skin map (`stage::shadow::SKIN_TEXELS`), which `cast_shadow` fills with
    /// `deposit_triangle`.
    fn casts_opaque(&self) -> bool {
        false
    }
    /// Deposit this frame's strands into the shadow structure (`stage::shadow`); groups 0
    /// (the frame) and 2 (the structure, `shaders/common/shadow_cast.wgsl`) are bound. Runs
    /// once per casting phase.
    fn cast_shadow(&self, _pass: &mut wgpu::ComputePass<'_>) {}
    /// Back to the rest pose.
    fn reset(&mut self, gpu: &Gpu) -> Result<()>;
    /// Rebuild the draw pipelines for another MSAA sample count or shadow lookup (every
    /// pipeline whose module includes `shaders/common/shadow.wgsl` and shades takes
    /// `variant.shadow`'s constants).
    fn set_variant(&mut self, gpu: &Gpu, variant: crate::gpu::pipeline::Variant);
    /// Take an edit classified as `Redraw` or `Resimulate` by the kind's `classify`.
    fn update(&mut self, gpu: &Gpu, scene: &Scene, change: Change) -> Result<()>;
    fn stats(&self) -> SystemStats;
    /// Frames per second of a file's frames this system plays (a cache); None when its
    /// motion is simulated, one frame per clock frame.
    fn playback_fps(&self) -> Option<f64> {
        None
    }
    /// What the last drawn frame dropped that its image hides (a list that overflowed), read
    /// back from the GPU: callers ask at their own pace (the CLI after each frame, the viewer
    /// once a second). Empty when nothing was dropped.
    fn warnings(&self, _gpu: &Gpu) -> Result<Vec<String>> {
        Ok(Vec::new())
    }
    /// The hair as it is now, as polylines with widths and colours, for strand files
    /// (`kami convert scene.ron out.hair`, the viewer's Files panel); `None` for kinds that
    /// have no strands to write.
    fn export(&self, _gpu: &Gpu, _ctx: &FrameCtx) -> Result<Option<crate::formats::Groom>> {
        Ok(None)
    }
    /// The hair as the last drawn frame shows it, as strands: what a path tracer needs to
    /// draw the same picture (`kami bench look`). Where a kind draws something other than
    /// its strands (fur's culled and widened hairs, a strip's texture of fine hairs), this
    /// is that, with each strand's own absorption where strands vary; by default the same
    /// as [`HairSystem::export`].
    fn export_drawn(&self, gpu: &Gpu, ctx: &FrameCtx) -> Result<Option<DrawnHair>> {
        Ok(self.export(gpu, ctx)?.map(|groom| DrawnHair {
            groom,
            absorption: None,
        }))
    }
    /// For tests and benches that look inside one kind.
    fn as_any(&self) -> &dyn std::any::Any;
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any;
}
