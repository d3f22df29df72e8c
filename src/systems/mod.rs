//! Hair systems: each kind of hair (Anjyo's strands, Van Gelder's fur, Sakai's wisps, Kazama's
//! strips and the kinds to come) is one self-contained module behind the `HairSystem`
//! interface, listed once in `KINDS`. The stage (`stage`) knows systems only through this
//! module: it asks each kind the scene names to build itself, hands every system the same clock
//! (`FrameCtx`) each frame, and draws them all into one depth-tested pass. The viewer's panels,
//! tools and `--set` keys, its Files list, the CLI's summary line, the shader registry, the
//! fuzzer's words, the limits check, the scene bounds and the scene's checks and files iterate
//! `KINDS` too, so adding a kind is a new folder and one entry in the `kinds!` list below, which writes
//! `KINDS` and the kind's fields of `Scene` (docs/adding-a-kind.md).
//!
//! A system owns everything of its kind: its scene block (`<kind>/block.rs`), CPU references,
//! GPU passes, draw pipelines, its shaders (`shaders/<kind>/`), its egui panels and its viewer
//! state (`ui::KindUi`). It knows no window and imports neither `app` nor `stage`.

pub mod anjyo;
pub mod fur;
pub mod hair_bsdf;
pub mod lod;
pub mod scene;
pub mod strips;
pub mod ui;
pub mod wisps;
pub mod world;

use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::Gpu;
use glam::{DMat4, DVec3};
use std::path::Path;

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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SystemStats {
    pub strands: u64,
    pub segments: u64,
    /// Strands the solver moves (0 for a still groom).
    pub simulated: u64,
    /// Strands drawn in the last frame (after level of detail and culling).
    pub drawn: u64,
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
    /// `draw`: the stage then keeps the scene depth and composites the accumulation.
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
    /// For tests and benches that look inside one kind.
    fn as_any(&self) -> &dyn std::any::Any;
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any;
}

/// An egui panel a kind brings to the viewer.
pub struct Panel {
    pub title: &'static str,
    /// Open when the viewer starts with this scene.
    pub open: fn(&Scene) -> bool,
    /// Shown on scenes without this kind too, because it offers to add the kind (the Fur
    /// panel's example); other panels show only while the scene has the kind.
    pub adds: bool,
    pub show: fn(&mut egui::Ui, &mut ui::PanelCx),
}

/// A kind of hair: its whole contract with the rest of Kami. The stage builds it and
/// classifies edits of it; the viewer hosts its panels, tools and `--set` keys (`ui`); the
/// CLI prints its summary and asks whether it moves; the fuzzer adds its words; the shader
/// registry (`stage::shaders`) adds its modules.
pub struct Kind {
    pub name: &'static str,
    /// The scene field holding the kind's block (`groups`, `fur`...), for messages.
    pub block: &'static str,
    /// What one says a scene needs at least one of ("hair group", "fur"...).
    pub called: &'static str,
    /// Whether the scene names hair of this kind (only those systems are built, and only
    /// those kinds' panels show).
    pub in_scene: fn(&Scene) -> bool,
    /// Check every field of the kind's block (`systems/<kind>/block.rs`), before anything is
    /// built; errors name the field, the loader adds the file.
    pub validate: fn(&Scene) -> Result<()>,
    /// Read or resolve the files the kind's block names, relative to the scene file's
    /// folder (the path) when relative; the `&str` names the scene in errors.
    pub read_files: fn(&mut Scene, &Path, &str) -> Result<()>,
    /// The files `read_files` read or resolved for the block, on a loaded scene (the
    /// viewer watches them and reloads when one is saved); the path is the scene file's
    /// folder, as for `read_files`.
    pub files: fn(&Scene, &Path) -> Vec<std::path::PathBuf>,
    /// Strands and segments the kind grows (the CLI's counts and the scene's strand limit);
    /// (0, 0) for kinds that grow no strands.
    pub counts: fn(&Scene) -> (u64, u64),
    /// The field the strand limit names when this kind's strands count towards it
    /// (`groups[..].count`); `None` when the kind grows no counted strands.
    pub counted: Option<&'static str>,
    /// Check, before anything is allocated, that the scene's hair of this kind fits the
    /// adapter's limits.
    pub check_limits: fn(&Gpu, &Scene) -> Result<()>,
    pub build: fn(&Gpu, &Scene, &DrawSetup) -> Result<Box<dyn HairSystem>>,
    /// What an edit from the first scene to the second asks of this kind.
    pub classify: fn(&Scene, &Scene) -> Change,
    pub panels: &'static [Panel],
    /// The kind's state in the viewer: mouse tools, overlays, `--set` keys.
    pub ui: fn() -> Box<dyn ui::KindUi>,
    /// What the CLI's summary line says of this kind beyond the scene's hair and segment
    /// counts (`kami render`), when the scene has it.
    pub summary: fn(&Scene) -> Option<String>,
    /// Whether the scene's hair of this kind moves over frames (`kami render --frames`
    /// warns when nothing does).
    pub moves: fn(&Scene) -> bool,
    /// Shipped scenes (stems under `assets/scenes/`) offered by the viewer's Files panel.
    pub scenes: &'static [&'static str],
    /// (path under `shaders/` without `.wgsl`, composed source) of every WGSL module.
    pub shaders: &'static [(&'static str, &'static str)],
    /// What must hold of the kind's block in any scene validation accepted, beyond finite
    /// numbers (the fuzzer checks it on every accepted scene): `Err((signature, detail))`
    /// when it does not.
    pub invariants: fn(&Scene) -> std::result::Result<(), (&'static str, String)>,
    /// Tokens of the kind's scene block for the scene fuzzer's dictionary (`fuzz`).
    pub fuzz_words: &'static [&'static str],
    /// Whether the kind's hair reads the shadow as toon steps rather than a smooth fraction:
    /// the stage compiles the shading pipelines' shadow lookup that way when the scene has
    /// this kind (a property of the kind, known before any system is built).
    pub shadow_steps: bool,
    /// The rate of the first file cache the kind's block plays (frames per second), if any
    /// (`Scene::cache_fps`).
    pub cache_fps: fn(&Scene) -> Option<f64>,
    /// Opens a strand file (`.hair`, OBJ, USD, Alembic) as a scene of this kind's hair,
    /// validated (`Scene::from_strand_file`); `None`: the kind shows no strand files.
    pub opens: Option<fn(&Path) -> Result<Scene>>,
    /// A reload's merge of the kind's block finer than the whole block (`merge_edits`):
    /// `(base, ours, theirs, out)`, with `out` already holding the block-wise pick.
    pub merge: fn(&Scene, &Scene, &Scene, &mut Scene),
    /// Commands the kind adds to `kami` (`kami fingers`), listed after `bench`.
    pub commands: &'static [KindCommand],
}

/// A command a kind adds to `kami`, defined in the kind's folder.
pub struct KindCommand {
    /// Its options and help: a clap command named as the command.
    pub command: fn() -> clap::Command,
    /// Run it on what the command line gave.
    pub run: fn(&clap::ArgMatches) -> Result<()>,
}

scene::kinds! {
    // Every kind of hair Kami knows, in drawing order, with the fields its block adds to the
    // scene file (`Scene`): adding a kind is its folder and one entry here.
    anjyo {
        /// The load Anjyo's groom is styled under: the hair's weight per unit length, in the
        /// units of `rigidity` (a setting of the groom, not a force of the world: hair in
        /// motion falls under `forces.gravity`).
        #[serde(default = "anjyo::block::default_groom_load")]
        groom_load: [f64; 3] = anjyo::block::default_groom_load(),
        /// Anjyo's hair groups; empty when the scene shows only other kinds.
        #[serde(default)]
        groups: Vec<anjyo::block::HairGroup> = Vec::new(),
        /// Hair in motion (Anjyo section 3). Absent: the groom is static and no simulation
        /// buffers or passes are built.
        #[serde(default)]
        dynamics: Option<anjyo::block::Dynamics> = None,
    },
    fur {
        /// Fur on a triangle mesh (Van Gelder & Wilhelms).
        #[serde(default)]
        fur: Option<fur::block::Fur> = None,
    },
    wisps {
        /// Toon wisps (Sakai): skeletons drawn as a ray-marched blobby surface.
        #[serde(default)]
        wisps: Option<wisps::block::Wisps> = None,
    },
    strips {
        /// Directable strips (Kazama et al.): layered reed strips on damped angular springs.
        #[serde(default)]
        strips: Option<strips::block::Strips> = None,
    },
}

/// The kind called `name`.
pub fn kind(name: &str) -> Option<&'static Kind> {
    KINDS.iter().copied().find(|k| k.name == name)
}
