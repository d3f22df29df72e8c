//! What a kind brings to the viewer, in terms that know no window. The viewer (`app`) hosts
//! each kind's panels, mouse tools and overlays; it holds each kind's state as a
//! `Box<dyn KindUi>` made by `Kind::ui` and knows no kind's types, and systems never import
//! `app`. Panels and tools edit the scene and the viewer's shared state (`Host`, plain
//! data); the viewer then hands the edited scene to the stage, which classifies the edit per
//! system (`Change`) and applies it.

use crate::error::Result;
use crate::gpu::view::ScreenView;
use crate::gpu::Gpu;
use crate::systems::scene::Scene;
use crate::systems::system::{FrameCtx, HairSystem};
use glam::DVec2;
use std::any::Any;

/// The viewer's state a kind's panels and tools may read and change.
#[derive(Clone, Debug, PartialEq)]
pub struct Host {
    /// The clock's frame as last drawn.
    pub frame: u64,
    pub playing: bool,
    /// Hair systems' diagnostic overlays (Anjyo: segments the pseudo-force acted on).
    pub overlay: bool,
    /// Simulate again from the rest pose to this frame after this frame's edits apply (the
    /// timeline's scrub, a key-frame edit's replay), see `Stage::seek`.
    pub seek: Option<u64>,
    /// The last error (failed load, bad value), shown in the UI.
    pub error: Option<String>,
    pub message: Option<String>,
    /// A scene file a panel asks the viewer to open (the Fur panel's example).
    pub open: Option<String>,
    /// The 3D view as last drawn (the scene region, in window pixels) with the head's pose:
    /// it projects points of the head's rest frame (skeleton nodes). None before the first
    /// frame.
    pub head_view: Option<ScreenView>,
    /// The same view without the head pose: world points (strips, targets, EFF cells).
    pub world_view: Option<ScreenView>,
}

impl Default for Host {
    fn default() -> Self {
        Host {
            frame: 0,
            playing: true,
            overlay: false,
            seek: None,
            error: None,
            message: None,
            open: None,
            head_view: None,
            world_view: None,
        }
    }
}

/// A key pressed over the 3D view, as the kinds' tools see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key<'a> {
    Char(&'a str),
    Delete,
    Escape,
}

/// Modifier keys held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Mods {
    pub shift: bool,
    pub ctrl: bool,
}

/// What a kind's tools see of the frame: the GPU, this kind's system in the stage (None
/// when the scene has none) and the stage's clock.
#[derive(Clone, Copy)]
pub struct Tool<'a> {
    pub gpu: &'a Gpu,
    pub system: Option<&'a dyn HairSystem>,
    pub ctx: FrameCtx<'a>,
}

/// What a panel edits: the scene, the viewer's shared state and its kind's own state.
pub struct PanelCx<'a> {
    pub scene: &'a mut Scene,
    pub host: &'a mut Host,
    pub state: &'a mut dyn KindUi,
}

/// The kind's own state behind `state`, if it is a `T`.
pub fn state<T: 'static>(state: &mut dyn KindUi) -> Option<&mut T> {
    state.as_any_mut().downcast_mut::<T>()
}

/// A kind's state in the viewer (selection, undo history, brush, mouse modes), made by
/// `Kind::ui` and kept across edits of the scene. Every method but `as_any_mut` has a
/// default that does nothing: a kind without tools implements only that.
pub trait KindUi: Any {
    fn as_any_mut(&mut self) -> &mut dyn Any;

    /// `--set KEY=VALUE` (`value` None for `KEY` alone): None when the key is not this
    /// kind's, else what came of it. `scene` is the viewer's copy; the viewer validates it
    /// afterwards and keeps the old scene on any error.
    fn set(
        &mut self,
        _scene: &mut Scene,
        _host: &mut Host,
        _key: &str,
        _value: Option<&str>,
    ) -> Option<std::result::Result<(), String>> {
        None
    }

    /// A world force was set from the command line (`--set wind=` or `gravity=`, on the
    /// viewer's copy `scene`): a kind whose hair stands still may set it moving.
    fn force_set(&mut self, _scene: &mut Scene) {}

    /// A scene was opened afresh (Files, a reload): drop what belonged to the old one.
    fn opened(&mut self) {}

    /// Whether a mouse mode of this kind is on: a left press over the view then goes to
    /// `press` (the first kind in `KINDS` order whose mode is on gets it).
    fn mouse_mode(&self, _scene: &Scene, _host: &Host) -> bool {
        false
    }

    /// A left press at `cursor` (window pixels): whether the tool took it (else the camera
    /// orbits).
    fn press(
        &mut self,
        _scene: &mut Scene,
        _host: &mut Host,
        _tool: &Tool,
        _cursor: DVec2,
    ) -> Result<bool> {
        Ok(false)
    }

    /// Whether a press is held: cursor moves go to `drag`, not to the camera.
    fn holding(&self) -> bool {
        false
    }

    /// The cursor moved to `cursor` with the press held.
    fn drag(&mut self, _scene: &mut Scene, _host: &mut Host, _tool: &Tool, _cursor: DVec2) {}

    /// The left button went up (anywhere, over the panels too).
    fn release(&mut self) {}

    /// Any button or key: the moment to close an open gesture (so a slider drag or a run
    /// of wheel turns is one undo entry).
    fn input(&mut self) {}

    /// The wheel over the view: whether the tool took it (else the camera zooms).
    fn wheel(
        &mut self,
        _scene: &mut Scene,
        _host: &Host,
        _cursor: DVec2,
        _steps: f64,
        _mods: Mods,
    ) -> bool {
        false
    }

    /// A key over the view: whether the tool took it (else the viewer's own keys).
    fn key(&mut self, _scene: &mut Scene, _host: &mut Host, _key: Key, _mods: Mods) -> bool {
        false
    }

    /// Once a frame after the clock advanced (read-backs the tools need).
    fn frame(&mut self, _scene: &Scene, _tool: &Tool) -> Result<()> {
        Ok(())
    }

    /// The systems were rebuilt or the clock jumped: drop what was read back from them.
    fn stale(&mut self) {}

    /// Whether an edit from `old` to `new` changes what was simulated before the frame
    /// shown: the viewer then simulates again to that frame.
    fn replays(&self, _old: &Scene, _new: &Scene) -> bool {
        false
    }

    /// Draw over the 3D view with egui's painter; `ppp` window pixels per egui point.
    fn overlay(
        &mut self,
        _ctx: &egui::Context,
        _scene: &Scene,
        _host: &Host,
        _frame: &FrameCtx,
        _ppp: f32,
    ) {
    }

    /// A line of help under the panels while a mouse mode is on.
    fn help(&self) -> Option<&'static str> {
        None
    }
}

/// A kind without viewer state.
#[derive(Debug, Default)]
pub struct NoState;

impl KindUi for NoState {
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

// The `--set` value parsers every kind shares (their messages are part of the CLI).

/// `on|true|1` or `off|false|0`.
pub fn on(value: Option<&str>) -> std::result::Result<bool, String> {
    match value {
        Some("on" | "true" | "1") => Ok(true),
        Some("off" | "false" | "0") => Ok(false),
        Some(_) => Err("expected on or off".into()),
        None => Err("expected KEY=VALUE".into()),
    }
}

/// `n` finite numbers, comma separated.
pub fn nums(value: Option<&str>, n: usize) -> std::result::Result<Vec<f64>, String> {
    let value = value.ok_or("expected KEY=VALUE")?;
    let v: Vec<f64> = value
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("{value:?} is not {n} number(s)"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{value:?} is not {n} finite number(s)"));
    }
    Ok(v)
}

/// A whole number (counts: 4.5 is a typo, not 4).
pub fn int(value: Option<&str>) -> std::result::Result<u32, String> {
    let value = value.ok_or("expected KEY=VALUE")?;
    value
        .trim()
        .parse::<u32>()
        .map_err(|_| format!("{value:?} is not a whole number"))
}
