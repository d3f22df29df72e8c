//! The viewer's editable state, kept in plain structs so the panel logic is testable without
//! a window: the panels edit a `Scene` (and a few viewer-only settings); the stage then
//! classifies the edit per hair system (`systems::Change`) and applies it, so static
//! parameters re-groom at once and dynamic ones act from the next step. Each kind's own
//! state (its editor, brush, mouse modes) is a `systems::ui::KindUi` made by its `Kind`: the
//! viewer holds it without knowing its type.

use crate::error::{KamiError, Result};
use crate::scene::{Interp, WindKey};
use crate::systems::ui::{self, Host, KindUi};
use crate::systems::Scene;
use crate::systems::KINDS;

/// An exponential moving average of a frame-time measurement, for the Stats panel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ema {
    value: Option<f64>,
}

impl Ema {
    /// Weight of a new sample.
    const NEW: f64 = 0.2;

    /// Take a sample and return the new average (the first sample is taken as is).
    pub fn add(&mut self, sample: f64) -> f64 {
        let v = match self.value {
            None => sample,
            Some(old) => (1.0 - Self::NEW) * old + Self::NEW * sample,
        };
        self.value = Some(v);
        v
    }
}

/// Viewer-only settings the panels edit besides the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSettings {
    /// Simulated frames per displayed frame (fractions accumulate).
    pub time_scale: f64,
    /// Adapt what is drawn (the share of hairs, MSAA, the resolution) to keep the frame's
    /// work under `frame_budget_ms` (`adapt`).
    pub adaptive_lod: bool,
    pub hair_fraction: f64,
    /// The frame time the adaptive level of detail keeps to: 60 ms (over 15 fps) on a
    /// software adapter, 16 ms (60 fps) on a GPU (`default_budget_ms`).
    pub frame_budget_ms: f64,
    /// Use the scene's supersampling in the viewer too (off: 1x, the interactive default;
    /// the scene's value still applies to headless renders and is saved).
    pub full_supersampling: bool,
    /// Set by the adaptive level of detail when a quarter of the hairs misses the budget:
    /// draw without MSAA in the viewer (the scene's setting is kept for renders and saving).
    pub msaa_dropped: bool,
    /// The scene's resolution in percent per axis (`SCALE_STEPS`), lowered by the adaptive
    /// level of detail after MSAA; renders and screenshots are always at 100.
    pub scale_pct: u32,
    /// Drawing at full quality because nothing moves (`still`): the hairs, MSAA and the
    /// resolution the budget dropped come back while the view stays still.
    pub refined: bool,
    /// The adaptive level of detail's own smoothing of the frame's work, restarted after
    /// each change of MSAA or resolution (a pipeline rebuild or a resize is not the frame's
    /// cost), and frames to wait before the next such change.
    busy: Ema,
    settle: u32,
    /// Live reload: reload the scene when its file or a file it names is saved (the Files
    /// panel's checkbox; `--no-watch` starts with it off).
    pub watch: bool,
}

/// The shares of hairs the adaptive level of detail draws at the least (smooth motion
/// first: on a software adapter the densest shipped grooms, the bob and the tube fur, need a
/// few percent or less to hold 15 fps, their triangles costing more than their pixels; the
/// floor is the least `--set lod` takes), and under which it takes its next lever (MSAA
/// off, then a lower resolution) while one is left.
pub const MIN_FRACTION: f64 = 0.01;
pub const LEVER_FRACTION: f64 = 0.25;
/// The resolutions the adaptive level of detail steps through, percent per axis.
pub const SCALE_STEPS: [u32; 3] = [100, 75, 50];
/// Frames after a change of MSAA or resolution before the next one.
const SETTLE_FRAMES: u32 = 8;

/// The default frame budget on an adapter: a software rasteriser aims at 15 fps with room
/// to spare, a GPU at 60.
pub fn default_budget_ms(software: bool) -> f64 {
    if software {
        60.0
    } else {
        16.0
    }
}

impl ViewSettings {
    /// Anti-aliasing and resolution the viewer draws with now.
    pub fn quality(&self, scene: &Scene) -> crate::stage::Quality {
        let full = self.full_quality(scene);
        if self.refined {
            return full;
        }
        crate::stage::Quality {
            msaa: if self.msaa_dropped { 1 } else { full.msaa },
            scale_pct: self.scale_pct,
            ..full
        }
    }

    /// What the viewer draws when nothing is dropped (screenshots, a still view).
    pub fn full_quality(&self, scene: &Scene) -> crate::stage::Quality {
        let supersample = if self.full_supersampling {
            scene.render.supersample
        } else {
            1
        };
        crate::stage::Quality::new(scene.render.msaa, supersample)
    }

    /// The share of the hairs drawn now.
    pub fn lod(&self) -> f64 {
        if self.refined {
            1.0
        } else {
            self.hair_fraction
        }
    }

    /// One step of the adaptive level of detail after a frame whose work took `busy_ms`
    /// (`scene_msaa`: the scene's MSAA). Over the budget: fewer hairs, then, below
    /// `LEVER_FRACTION`, MSAA off, then the next lower resolution (each lever taken sets
    /// the share back to a half), then fewer hairs down to `MIN_FRACTION`. Well inside it:
    /// back in the opposite order, a lever only when the frame has room for what it costs.
    pub fn adapt(&mut self, busy_ms: f64, scene_msaa: u32) {
        if !self.adaptive_lod || self.refined {
            return;
        }
        let busy = self.busy.add(busy_ms);
        if self.settle > 0 {
            self.settle -= 1;
            return;
        }
        let budget = self.frame_budget_ms;
        let lower_scale = SCALE_STEPS.iter().copied().find(|&s| s < self.scale_pct);
        let higher_scale = SCALE_STEPS
            .iter()
            .rev()
            .copied()
            .find(|&s| s > self.scale_pct);
        let can_drop_msaa = !self.msaa_dropped && scene_msaa > 1;
        if busy > budget {
            let next = self.hair_fraction * (budget / busy).max(0.5);
            if next >= LEVER_FRACTION || (!can_drop_msaa && lower_scale.is_none()) {
                self.hair_fraction = next.max(MIN_FRACTION);
            } else if can_drop_msaa {
                self.msaa_dropped = true;
                self.lever_taken();
            } else if let Some(s) = lower_scale {
                self.scale_pct = s;
                self.lever_taken();
            }
        } else if busy < 0.75 * budget {
            if self.hair_fraction < 1.0 {
                self.hair_fraction = (self.hair_fraction * 1.15).min(1.0);
            } else if let Some(s) = higher_scale.filter(|_| busy < 0.4 * budget) {
                self.scale_pct = s;
                self.lever_taken();
            } else if self.msaa_dropped && higher_scale.is_none() && busy < 0.2 * budget {
                self.msaa_dropped = false;
                self.lever_taken();
            }
        }
    }

    fn lever_taken(&mut self) {
        self.hair_fraction = 0.5;
        self.busy = Ema::default();
        self.settle = SETTLE_FRAMES;
    }

    /// Draw at full quality while `still` (nothing moved, nothing plays), and go back to
    /// the budget's levers when something moves.
    pub fn set_still(&mut self, still: bool) {
        let refined = still && self.adaptive_lod;
        if refined != self.refined {
            self.refined = refined;
            // The full-quality frames are not the live frame's cost.
            self.busy = Ema::default();
            self.settle = 2;
        }
    }

    /// What the viewer draws short of full quality now, for the Stats panel and the line
    /// printed at exit: "100 % of hairs" alone when nothing is dropped.
    pub fn dropping(&self) -> String {
        let mut s = format!("{:.0} % of hairs drawn", self.lod() * 100.0);
        if !self.refined {
            if self.msaa_dropped {
                s.push_str(", MSAA off");
            }
            if self.scale_pct < 100 {
                s.push_str(&format!(", {} % resolution", self.scale_pct));
            }
        } else if self.adaptive_lod {
            s.push_str(" (still: full quality)");
        }
        s
    }
}

impl Default for ViewSettings {
    fn default() -> Self {
        ViewSettings {
            time_scale: 1.0,
            adaptive_lod: true,
            hair_fraction: 1.0,
            frame_budget_ms: default_budget_ms(true),
            full_supersampling: false,
            msaa_dropped: false,
            scale_pct: 100,
            refined: false,
            busy: Ema::default(),
            settle: 0,
            watch: true,
        }
    }
}

/// One-shot actions requested by the panels or keys, handled by the window loop.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    Open(String),
    Save(String),
    /// Write the hair as it is now to a strand file (`.hair`, `.obj`, `.usda`).
    Export(String),
    Screenshot(String),
    Step,
    Reset,
    FrameScene,
    /// A mouse gesture in the 3D view, from `--set mouse.*` (scripts and tests drive the
    /// strips' picking, dragging and painting through the same code as the real mouse).
    Mouse(MouseEvent),
    /// Live reload: these watched files were saved (`watch::Watch`).
    Reload(Vec<std::path::PathBuf>),
}

/// A scripted mouse event in window pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MouseEvent {
    Press(f64, f64),
    Move(f64, f64),
    Release,
}

/// Frame statistics shown in the Stats panel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    pub fps: f64,
    /// The systems' warnings about the last checked frame (`Stage::warnings`, read once a
    /// second): shown in the Stats panel and printed at exit.
    pub warnings: Vec<String>,
    pub frame_ms: f64,
    /// GPU simulation time (timestamps; 0 without them).
    pub sim_ms: f64,
    /// GPU time of the scene passes: generation, draw, resolve (timestamps); the frame
    /// period on adapters without timestamps. The level of detail keeps it in budget.
    pub render_ms: f64,
    /// GPU time of the egui panels (timestamps).
    pub ui_ms: f64,
    /// CPU time to record and submit the frame's scene and panels and present it.
    pub record_ms: f64,
    /// The newest per-pass GPU times (None until the first arrive, or without timestamps).
    pub gpu: Option<crate::gpu::timing::PassTimes>,
    /// The adapter has timestamp queries.
    pub timestamps: bool,
    pub groom_ms: f64,
    pub strands: u64,
    pub segments: u64,
    pub simulated: u64,
    pub frame: u64,
    pub substeps: u32,
    pub adapter: String,
    pub size: (u32, u32),
    /// Each hair system's counts after the last frame (drawn: after level of detail).
    pub systems: Vec<(&'static str, crate::systems::SystemStats)>,
    pub frame_ema: Ema,
    pub sim_ema: Ema,
    pub render_ema: Ema,
    pub ui_ema: Ema,
    pub record_ema: Ema,
}

impl Stats {
    /// The per-pass GPU times in one line (the viewer's exit line).
    pub fn gpu_summary(&self) -> String {
        if !self.timestamps {
            return "no GPU timestamps on this adapter".into();
        }
        let sim = match self
            .gpu
            .and_then(|t| t.get(crate::gpu::timing::Phase::Simulation))
        {
            Some(_) => format!("{:.2} ms", self.sim_ms),
            None => "none".into(),
        };
        format!(
            "GPU sim {sim}, scene {:.2} ms, panels {:.2} ms",
            self.render_ms, self.ui_ms
        )
    }
}

/// Everything the panels edit.
pub struct ViewerState {
    pub scene: Scene,
    pub view: ViewSettings,
    /// The path field of the Files panel.
    pub path: String,
    /// The Files panel's strand-file path for Export.
    pub export_path: String,
    /// Head motion keys kept while head motion is switched off.
    pub parked_head_motion: Vec<crate::scene::HeadKey>,
    pub requests: Vec<Request>,
    pub stats: Stats,
    /// What the kinds' panels and tools share with the viewer: the clock, messages, the
    /// 3D view as last drawn.
    pub host: Host,
    /// Each kind's state in the viewer, in `KINDS` order (made by `Kind::ui`).
    pub kinds: Vec<Box<dyn KindUi>>,
    /// Why the last save of a watched file did not load (shown over the 3D view until
    /// dismissed or the next good save); the last good scene stays.
    pub reload_error: Option<String>,
}

impl std::fmt::Debug for ViewerState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ViewerState")
            .field("path", &self.path)
            .field("view", &self.view)
            .field("host", &self.host)
            .finish_non_exhaustive()
    }
}

impl ViewerState {
    pub fn new(scene: Scene, path: String) -> ViewerState {
        ViewerState {
            scene,
            view: ViewSettings::default(),
            path,
            export_path: "kami-hair.hair".into(),
            parked_head_motion: Vec::new(),
            requests: Vec::new(),
            stats: Stats::default(),
            host: Host::default(),
            kinds: KINDS.iter().map(|k| (k.ui)()).collect(),
            reload_error: None,
        }
    }

    /// Apply a `--set KEY=VALUE` override through the same path as the panels: it edits the
    /// state, and the window loop classifies and applies the change. Each kind's keys come
    /// first (`KindUi::set`, listed on each kind's implementation), then the viewer's own:
    /// `wind=x,y,z` and `gravity=x,y,z` (the scene's `forces` block; each kind's
    /// `KindUi::force_set` may set its still hair moving), `msaa=1|4`, `supersample=f`,
    /// `strands=ribbons|compute`, `shading=anjyo|physical`, `shadows=on|off`,
    /// `shadows.method=volume|deep`, `play=on|off`, `lod=fraction` (fixed, 0..1),
    /// `seek=FRAME`, `save=FILE`, `export=FILE`, and scripted mouse events
    /// `mouse.press=x,y`, `mouse.move=x,y`, `mouse.release` (window pixels; as with the
    /// real mouse, a press no kind's tool takes orbits the camera as it moves).
    pub fn apply_set(&mut self, assignment: &str) -> Result<()> {
        let bad = |m: String| KamiError::Option(format!("--set {assignment}: {m}"));
        // Actions have no value (`strips.key`, `mouse.release`).
        let (key, value) = match assignment.split_once('=') {
            Some((k, v)) => (k, Some(v)),
            None => (assignment, None),
        };
        let nums = |n: usize| ui::nums(value, n).map_err(bad);
        let int = || ui::int(value).map_err(bad);
        let on = || ui::on(value).map_err(bad);
        let text = || value.ok_or_else(|| bad("expected KEY=VALUE".into()));
        let mut next = self.scene.clone();
        let kind = self
            .kinds
            .iter_mut()
            .find_map(|k| k.set(&mut next, &mut self.host, key, value));
        match kind {
            Some(outcome) => outcome.map_err(bad)?,
            None => match key {
                "wind" => {
                    let w = nums(3)?;
                    self.kinds.iter_mut().for_each(|k| k.force_set(&mut next));
                    next.forces.wind = vec![WindKey {
                        frame: 0.0,
                        force: [w[0], w[1], w[2]],
                        interp: Interp::Step,
                    }];
                }
                "gravity" => {
                    let g = nums(3)?;
                    self.kinds.iter_mut().for_each(|k| k.force_set(&mut next));
                    next.forces.gravity = [g[0], g[1], g[2]];
                }
                "msaa" => next.render.msaa = int()?,
                "supersample" => next.render.supersample = int()?,
                "strands" => {
                    next.render.strands =
                        crate::scene::StrandRaster::parse(text()?.trim()).map_err(bad)?
                }
                "shading" => {
                    next.render.shading =
                        crate::scene::Shading::parse(text()?.trim()).map_err(bad)?
                }
                "shadows" => next.render.shadows.on = on()?,
                "shadows.method" => {
                    next.render.shadows.method =
                        crate::scene::ShadowMethod::parse(text()?.trim()).map_err(bad)?
                }
                "play" => self.host.playing = on()?,
                "lod" => {
                    let f = nums(1)?[0];
                    if !(0.01..=1.0).contains(&f) {
                        return Err(bad("the share of hairs must be in [0.01, 1]".into()));
                    }
                    self.view.adaptive_lod = false;
                    self.view.hair_fraction = f;
                }
                "seek" => self.host.seek = Some(int()? as u64),
                "save" => self.requests.push(Request::Save(text()?.to_string())),
                "export" => self.requests.push(Request::Export(text()?.to_string())),
                "mouse.press" | "mouse.move" => {
                    let v = nums(2)?;
                    self.requests.push(Request::Mouse(if key == "mouse.press" {
                        MouseEvent::Press(v[0], v[1])
                    } else {
                        MouseEvent::Move(v[0], v[1])
                    }));
                }
                "mouse.release" => self.requests.push(Request::Mouse(MouseEvent::Release)),
                _ if value.is_none() => return Err(bad("expected KEY=VALUE".into())),
                _ => return Err(bad(format!("unknown key {key:?}"))),
            },
        }
        crate::systems::validate(&next).map_err(|e| bad(e.to_string()))?;
        self.scene = next;
        Ok(())
    }
}

/// The viewer's `--set` keys that drive only the window (the clock, the level of detail, files,
/// the mouse): a render has none, so `kami render --set` refuses them.
pub const WINDOW_KEYS: &[&str] = &[
    "play",
    "lod",
    "seek",
    "save",
    "export",
    "mouse.press",
    "mouse.move",
    "mouse.release",
];

/// `[N:]KEY=VALUE` as `kami view --set` and `kami render --set` take it: the frame (0 when
/// absent) and the assignment.
pub fn parse_set(s: &str) -> Result<(u64, String)> {
    match s.split_once(':') {
        Some((n, rest)) if !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()) => {
            let frame = n
                .parse::<u64>()
                .map_err(|_| KamiError::Option(format!("--set {s}: frame {n} is too large")))?;
            Ok((frame, rest.to_string()))
        }
        _ => Ok((0, s.to_string())),
    }
}

/// The scenes a scripted render shows (`kami render --set`): each `(frame, KEY=VALUE)`, in
/// frame order, goes through the viewer's own path (`ViewerState::apply_set`: the same keys,
/// the same checks, each kind's keys through its `KindUi`), so a render and a viewer session
/// are driven the same way. Returns the scene at frame 0 and, for later frames, the scene
/// from that frame on. Window keys ([`WINDOW_KEYS`]) are refused.
pub fn scripted(scene: Scene, sets: &[(u64, String)]) -> Result<(Scene, Vec<(u64, Scene)>)> {
    let mut order: Vec<&(u64, String)> = sets.iter().collect();
    order.sort_by_key(|(f, _)| *f);
    let mut state = ViewerState::new(scene, String::new());
    let mut first = None;
    let mut later: Vec<(u64, Scene)> = Vec::new();
    for (frame, assignment) in order {
        let key = assignment
            .split_once('=')
            .map_or(assignment.as_str(), |(k, _)| k);
        if WINDOW_KEYS.contains(&key) {
            return Err(KamiError::Option(format!(
                "--set {assignment}: `{key}` drives the viewer's window; a render has none \
                 (window keys: {})",
                WINDOW_KEYS.join(", ")
            )));
        }
        if *frame > 0 && first.is_none() {
            first = Some(state.scene.clone());
        }
        state.apply_set(assignment)?;
        if *frame > 0 {
            match later.last_mut() {
                Some((f, s)) if f == frame => *s = state.scene.clone(),
                _ => later.push((*frame, state.scene.clone())),
            }
        }
    }
    let first = first.unwrap_or_else(|| state.scene.clone());
    Ok((first, later))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gust() -> Scene {
        Scene::from_ron(include_str!("../../assets/scenes/gust.ron"), "gust.ron").unwrap()
    }

    /// Frames of `busy_ms` work through the adaptive level of detail.
    fn run(v: &mut ViewSettings, busy_ms: f64, frames: usize) {
        for _ in 0..frames {
            v.adapt(busy_ms, 4);
        }
    }

    /// The (MSAA dropped, resolution) states `frames` frames of `busy_ms` go through.
    fn levers(v: &mut ViewSettings, busy_ms: f64, frames: usize) -> Vec<(bool, u32)> {
        let mut seen = vec![(v.msaa_dropped, v.scale_pct)];
        for _ in 0..frames {
            v.adapt(busy_ms, 4);
            let q = (v.msaa_dropped, v.scale_pct);
            if seen.last() != Some(&q) {
                seen.push(q);
            }
        }
        seen
    }

    #[test]
    fn the_budget_drops_hairs_then_msaa_then_resolution_and_takes_them_back_in_turn() {
        let mut v = ViewSettings {
            frame_budget_ms: 60.0,
            ..Default::default()
        };
        let scene = gust();
        assert_eq!(v.quality(&scene), crate::stage::Quality::new(4, 1));
        // A little over: fewer hairs, nothing else.
        run(&mut v, 80.0, 3);
        assert!(v.hair_fraction < 1.0 && v.hair_fraction >= LEVER_FRACTION);
        assert!(!v.msaa_dropped && v.scale_pct == 100, "{v:?}");
        // Far over for long: MSAA first, then each lower resolution, then the floor.
        assert_eq!(
            levers(&mut v, 400.0, 200),
            [(false, 100), (true, 100), (true, 75), (true, 50)]
        );
        assert_eq!(v.hair_fraction, MIN_FRACTION);
        assert_eq!(v.quality(&scene).msaa, 1);
        assert_eq!(v.quality(&scene).scale_pct, 50);
        assert!(v.dropping().contains("MSAA off") && v.dropping().contains("50 % resolution"));
        // Well inside: the hairs, then the resolution step by step, then MSAA.
        assert_eq!(
            levers(&mut v, 5.0, 400),
            [(true, 50), (true, 75), (true, 100), (false, 100)]
        );
        assert_eq!(v.hair_fraction, 1.0);
        assert_eq!(v.dropping(), "100 % of hairs drawn");
        // A scene without MSAA skips that lever.
        let mut v = ViewSettings::default();
        for _ in 0..100 {
            v.adapt(400.0, 1);
        }
        assert!(!v.msaa_dropped && v.scale_pct == 50);
    }

    #[test]
    fn a_still_view_draws_at_full_quality_and_the_budget_resumes_when_it_moves() {
        let scene = gust();
        let mut v = ViewSettings::default();
        run(&mut v, 1000.0, 100);
        assert!(v.msaa_dropped && v.scale_pct == 50 && v.lod() < 0.2);
        v.set_still(true);
        assert_eq!(v.quality(&scene), v.full_quality(&scene));
        assert_eq!(v.lod(), 1.0);
        assert!(v.dropping().contains("full quality"), "{}", v.dropping());
        // The slow full-quality frames do not move the levers.
        let before = (v.hair_fraction, v.msaa_dropped, v.scale_pct);
        run(&mut v, 5000.0, 50);
        assert_eq!(before, (v.hair_fraction, v.msaa_dropped, v.scale_pct));
        v.set_still(false);
        assert_eq!(v.quality(&scene).scale_pct, 50);
        assert!(v.lod() < 0.2);
        // Without the adaptive level of detail nothing is refined (the user's share stays).
        let mut v = ViewSettings {
            adaptive_lod: false,
            hair_fraction: 0.3,
            ..Default::default()
        };
        v.set_still(true);
        assert_eq!(v.lod(), 0.3);
    }

    #[test]
    fn moving_average_starts_at_the_first_sample_and_follows() {
        let mut e = Ema::default();
        assert_eq!(e.add(10.0), 10.0);
        assert!((e.add(20.0) - 12.0).abs() < 1e-12);
        for _ in 0..100 {
            e.add(20.0);
        }
        assert!((e.add(20.0) - 20.0).abs() < 1e-6);
    }

    #[test]
    fn set_overrides_edit_the_scene_or_refuse() {
        let mut s = ViewerState::new(gust(), String::new());
        s.apply_set("color=0.8,0.6,0.2").unwrap();
        assert!(s
            .scene
            .groups()
            .iter()
            .all(|g| g.material.color == [0.8, 0.6, 0.2]));
        s.apply_set("wind=0,0,-300").unwrap();
        assert_eq!(s.scene.forces.wind[0].force, [0.0, 0.0, -300.0]);
        s.apply_set("play=off").unwrap();
        assert!(!s.host.playing);
        s.apply_set("strands=compute").unwrap();
        assert_eq!(s.scene.render.strands, crate::scene::StrandRaster::Compute);
        let before = s.scene.clone();
        for bad in [
            "color=1,2",
            "rigidity=-1",
            "msaa=3",
            "nope=1",
            "width",
            "wind=1,nan,2",
            "lod=0",
            "msaa=4.5",
            "supersample=two",
            "strands=triangles",
            "colour=1,1,1",
            "Wind=0,0,1",
        ] {
            assert!(s.apply_set(bad).is_err(), "{bad} should be refused");
        }
        assert_eq!(
            s.scene, before,
            "a refused --set leaves the scene as it was"
        );
    }

    /// `shading=anjyo|physical` and the physical look's `melanin=`, `redness=` parse, reach
    /// the scene and are redraws for every kind (no regroom, no restart); bad values are
    /// refused.
    #[test]
    fn set_shading_is_a_redraw() {
        use crate::scene::Shading;
        use crate::systems::Change;
        let fur = Scene::from_ron(include_str!("../../assets/scenes/fur.ron"), "fur.ron").unwrap();
        let strips =
            Scene::from_ron(include_str!("../../assets/scenes/strips.ron"), "strips.ron").unwrap();
        for (scene, owner) in [(gust(), "anjyo"), (fur, "fur"), (strips, "strips")] {
            let mut s = ViewerState::new(scene, String::new());
            let before = s.scene.clone();
            s.apply_set("shading=physical").unwrap();
            assert_eq!(s.scene.render.shading, Shading::Physical);
            for k in crate::systems::KINDS {
                let c = (k.classify)(&before, &s.scene);
                assert!(c <= Change::Redraw, "{}: {c:?}", k.name);
            }
            let kind = crate::systems::KINDS.iter().find(|k| k.name == owner);
            assert_eq!(
                (kind.unwrap().classify)(&before, &s.scene),
                Change::Redraw,
                "{owner}"
            );
            let physical = s.scene.clone();
            s.apply_set("melanin=0.7").unwrap();
            s.apply_set("redness=0.3").unwrap();
            for k in crate::systems::KINDS {
                assert!((k.classify)(&physical, &s.scene) <= Change::Redraw);
            }
            s.apply_set("shading=anjyo").unwrap();
            assert_eq!(s.scene.render.shading, Shading::Anjyo);
            let mut bad = vec!["shading=pbr", "shading"];
            if !s.scene.groups().is_empty() {
                bad.extend(["melanin=2", "redness=-1"]);
            }
            for bad in bad {
                assert!(s.apply_set(bad).is_err(), "{bad} should be refused");
            }
        }
    }

    /// A world force set from the command line on still hair groups sets them moving
    /// (Anjyo's `KindUi::force_set`), and the viewer itself names no kind for it.
    #[test]
    fn a_force_set_on_still_groups_sets_them_moving() {
        for key in ["wind=0,0,-300", "gravity=0,-980,0"] {
            let mut still = gust();
            *still.dynamics_mut() = None;
            let mut s = ViewerState::new(still, String::new());
            s.apply_set(key).unwrap();
            assert!(s.scene.dynamics().is_some(), "{key}");
        }
    }

    /// A scripted render's scenes: sets in frame order through the viewer's path, the scene
    /// at frame 0 and one scene per later frame holding everything set up to it; window keys
    /// refused.
    #[test]
    fn scripted_sets_give_one_scene_per_frame_in_order() {
        let sets: Vec<(u64, String)> = [
            "5:wind=0,0,-300",
            "color=1,0,0",
            "2:width=0.1",
            "5:gravity=0,-980,0",
        ]
        .iter()
        .map(|s| parse_set(s).unwrap())
        .collect();
        let (first, later) = scripted(gust(), &sets).unwrap();
        assert!(first
            .groups()
            .iter()
            .all(|g| g.material.color == [1.0, 0.0, 0.0]));
        assert!(first.groups().iter().all(|g| g.material.width != 0.1));
        assert_eq!(later.iter().map(|(f, _)| *f).collect::<Vec<_>>(), [2, 5]);
        assert!(later[0].1.groups().iter().all(|g| g.material.width == 0.1));
        assert!(
            later[0].1.forces.wind.is_empty() || later[0].1.forces.wind != later[1].1.forces.wind
        );
        assert_eq!(later[1].1.forces.wind[0].force, [0.0, 0.0, -300.0]);
        assert_eq!(later[1].1.forces.gravity, [0.0, -980.0, 0.0]);
        assert!(later[1]
            .1
            .groups()
            .iter()
            .all(|g| g.material.color == [1.0, 0.0, 0.0]));
        for key in ["play=off", "lod=0.5", "mouse.release", "3:seek=1"] {
            let e = scripted(gust(), &[parse_set(key).unwrap()])
                .unwrap_err()
                .to_string();
            assert!(e.contains("drives the viewer's window"), "{key}: {e}");
        }
    }
}
