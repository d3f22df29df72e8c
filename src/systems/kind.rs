//! A kind of hair as the rest of Kami sees it: the `Kind` entry (its whole contract: scene
//! block checks, build, classify, panels, commands...), listed once in the registry's
//! `KINDS` (`systems/mod.rs`). It names no kind and nothing of the registry, so each kind's
//! `KIND` constant is written against it without an import cycle.

use crate::error::Result;
use crate::gpu::Gpu;
use crate::systems::scene::Scene;
use crate::systems::system::{Change, DrawSetup, HairSystem};
use crate::systems::ui;
use std::path::Path;

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
    /// Opens a strand file (`.hair`, OBJ, USD, Alembic) as a scene of this kind's hair, its
    /// block checked (`Scene::from_strand_file` then checks the whole scene); `None`: the
    /// kind shows no strand files.
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
