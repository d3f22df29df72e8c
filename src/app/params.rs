//! The viewer's editable state, kept in plain structs so the panel logic is testable without
//! a window: the panels edit a `Scene` (and a few viewer-only settings); the stage then
//! classifies the edit per hair system (`systems::Change`) and applies it, so static
//! parameters re-groom at once and dynamic ones act from the next step.

use crate::error::{KamiError, Result};
use crate::scene::{Dynamics, Interp, Scene, WindKey};

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
    pub playing: bool,
    /// Simulated frames per displayed frame (fractions accumulate).
    pub time_scale: f64,
    /// Hair systems' diagnostic overlays (Anjyo: segments the pseudo-force acted on).
    pub overlay: bool,
    /// Adapt the share of hairs drawn to keep the frame time under `frame_budget_ms`.
    pub adaptive_lod: bool,
    pub hair_fraction: f64,
    pub frame_budget_ms: f64,
    /// Use the scene's supersampling in the viewer too (off: 1x, the interactive default;
    /// the scene's value still applies to headless renders and is saved).
    pub full_supersampling: bool,
    /// Set by the adaptive level of detail when even the fewest hairs miss the budget: draw
    /// without MSAA in the viewer (the scene's setting is kept for renders and saving).
    pub msaa_dropped: bool,
    /// Edit the wisps' skeletons with the mouse in the 3D view (left click picks and drags
    /// a node, the wheel sets its radius, ...) and draw them over the view.
    pub edit_skeletons: bool,
    /// Draw the EFF's cells as arrows and the key-frame targets over the view.
    pub eff_arrows: bool,
    /// The strips' mouse mode (Key frames panel): a left press on a target marker drags
    /// it, on a strip picks it; `K` sets a first key for the picked strip.
    pub edit_strips: bool,
    /// The EFF brush's mouse mode (EFF panel): a left drag paints the drag's direction into
    /// the cells under the cursor.
    pub paint_eff: bool,
}

impl ViewSettings {
    /// Anti-aliasing the viewer draws with.
    pub fn quality(&self, scene: &Scene) -> crate::stage::Quality {
        crate::stage::Quality {
            msaa: if self.msaa_dropped {
                1
            } else {
                scene.render.msaa
            },
            supersample: if self.full_supersampling {
                scene.render.supersample
            } else {
                1
            },
        }
    }
}

impl Default for ViewSettings {
    fn default() -> Self {
        ViewSettings {
            playing: true,
            time_scale: 1.0,
            overlay: false,
            adaptive_lod: true,
            hair_fraction: 1.0,
            frame_budget_ms: 80.0,
            full_supersampling: false,
            msaa_dropped: false,
            edit_skeletons: false,
            eff_arrows: false,
            edit_strips: false,
            paint_eff: false,
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
#[derive(Clone, Debug)]
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
    /// The last error (failed load, bad value), shown in the UI.
    pub error: Option<String>,
    pub message: Option<String>,
    pub stats: Stats,
    /// Hair group edited by the per-group panels.
    pub group: usize,
    /// The toon wisps' skeleton editor (selection, undo history); the Skeletons panel and
    /// the mouse mode (`view.edit_skeletons`) drive it. A scene opened afresh starts a new
    /// one.
    pub editor: crate::systems::wisps::edit::Editor,
    /// The 3D view as last drawn (the scene region, in window pixels), for the skeleton
    /// editor: picking, dragging, the overlay. None before the first frame.
    pub edit_view: Option<crate::systems::wisps::edit::View>,
    /// The same view without the head pose: world points (strips, targets, EFF cells).
    pub world_view: Option<crate::systems::wisps::edit::View>,
    /// The EFF panel's brush and file path.
    pub brush: crate::systems::strips::panel::Brush,
    /// The Key frames panel's strip and edit length.
    pub key_strip: u32,
    pub key_span: u32,
    /// Simulate again from the rest pose to this frame after this frame's edits apply (the
    /// timeline's scrub, a key-frame edit's replay), see `Stage::seek`.
    pub seek: Option<u64>,
    /// What the timeline's pointer holds, and the timeline's length (frames) when it took
    /// hold.
    pub timeline_grab: Option<(crate::systems::strips::pick::TimelineGrab, u32)>,
    /// The strips as last read back for the mouse mode: (frame, world polylines).
    pub strip_pose: Option<(u64, Vec<Vec<glam::DVec3>>)>,
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
            error: None,
            message: None,
            stats: Stats::default(),
            group: 0,
            editor: Default::default(),
            edit_view: None,
            world_view: None,
            brush: Default::default(),
            key_strip: 0,
            key_span: 20,
            seek: None,
            timeline_grab: None,
            strip_pose: None,
        }
    }

    /// A key-frame edit of the picked strip (`key_strip`) whose first key is the current
    /// frame and second `key_span` frames later; the clip is shown at the second key,
    /// paused, so its target can be dragged at once.
    pub fn add_strip_edit(&mut self) -> Result<()> {
        use crate::scene::MAX_STRIP_EDITS;
        let count = self.scene.strips.as_ref().map_or(0, |st| st.edits.len());
        if count >= MAX_STRIP_EDITS {
            return Err(KamiError::Option(format!(
                "a scene holds at most {MAX_STRIP_EDITS} key-frame edits"
            )));
        }
        let frame = u32::try_from(self.stats.frame).unwrap_or(u32::MAX - 1_000);
        let e = crate::systems::strips::panel::new_edit(
            &self.scene,
            self.key_strip,
            frame,
            self.key_span,
        )?;
        self.seek = Some(u64::from(e.to));
        self.view.playing = false;
        if let Some(st) = self.scene.strips.as_mut() {
            st.edits.push(e);
        }
        Ok(())
    }

    /// Apply a `--set KEY=VALUE` override through the same path as the panels: it edits the
    /// state, and the window loop classifies and applies the change. Keys: `color=r,g,b`,
    /// `width=w`, `ks=k`, `shininess=n`, `rigidity=EI` (all groups), `wind=x,y,z` and
    /// `gravity=x,y,z` (the scene's `forces` block; they set still hair groups moving), `stiffness=root,tip`, `damping=rate`, `pseudo=on|off`,
    /// `msaa=1|4`, `supersample=f`, `strands=ribbons|compute`, `play=on|off`,
    /// `lod=fraction` (fixed, 0..1),
    /// `fur.hairs=N`, `fur.stiffness=s` (all coats), `fur.culling=on|off`,
    /// `wisps.edit=on|off` (the skeleton editor's mouse mode and overlay),
    /// `wisps.max_steps=N` (the ray march's step budget: cheap previews), the Toon panel's
    /// controls `wisps.toon.NAME=VALUE` and the wisps' outline scales `wisps.outline[.N]=S`
    /// (`systems::wisps::panel::set_key`), `strips.edit=on|off`
    /// and `eff.paint=on|off` (the strips' and the EFF brush's mouse modes), `strips.key`
    /// (a first key now for the picked strip), `seek=FRAME`, `save=FILE`, and scripted mouse
    /// events `mouse.press=x,y`, `mouse.move=x,y`, `mouse.release` (window pixels).
    pub fn apply_set(&mut self, assignment: &str) -> Result<()> {
        let bad = |m: String| KamiError::Option(format!("--set {assignment}: {m}"));
        // Actions without a value: `strips.key`, `mouse.release`.
        let (key, value) = match assignment {
            "strips.key" | "mouse.release" => (assignment, ""),
            _ => assignment
                .split_once('=')
                .ok_or_else(|| bad("expected KEY=VALUE".into()))?,
        };
        let nums = |n: usize| -> Result<Vec<f64>> {
            let v: Vec<f64> = value
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| bad(format!("{value:?} is not {n} number(s)")))?;
            if v.len() != n || v.iter().any(|x| !x.is_finite()) {
                return Err(bad(format!("{value:?} is not {n} finite number(s)")));
            }
            Ok(v)
        };
        // Counts (samples, factors, hairs) are whole numbers: 4.5 is a typo, not 4.
        let int = || -> Result<u32> {
            value
                .trim()
                .parse::<u32>()
                .map_err(|_| bad(format!("{value:?} is not a whole number")))
        };
        let on = || match value {
            "on" | "true" | "1" => Ok(true),
            "off" | "false" | "0" => Ok(false),
            _ => Err(bad("expected on or off".into())),
        };
        let mut next = self.scene.clone();
        match key {
            "color" => {
                let c = nums(3)?;
                for g in &mut next.groups {
                    g.material.color = [c[0] as f32, c[1] as f32, c[2] as f32];
                }
            }
            "width" => {
                let w = nums(1)?[0];
                next.groups.iter_mut().for_each(|g| g.material.width = w);
            }
            "ks" => {
                let k = nums(1)?[0];
                next.groups.iter_mut().for_each(|g| g.material.ks = k);
            }
            "shininess" => {
                let n = nums(1)?[0];
                next.groups
                    .iter_mut()
                    .for_each(|g| g.material.shininess = n);
            }
            "rigidity" => {
                let e = nums(1)?[0];
                next.groups.iter_mut().for_each(|g| g.rigidity = e);
            }
            "wind" => {
                let w = nums(3)?;
                moving(&mut next);
                next.forces.wind = vec![WindKey {
                    frame: 0.0,
                    force: [w[0], w[1], w[2]],
                    interp: Interp::Step,
                }];
            }
            "gravity" => {
                let g = nums(3)?;
                moving(&mut next);
                next.forces.gravity = [g[0], g[1], g[2]];
            }
            "stiffness" => {
                let s = nums(2)?;
                let d = dynamics(&mut next);
                d.stiffness.root = s[0];
                d.stiffness.tip = s[1];
            }
            "damping" => dynamics(&mut next).damping = nums(1)?[0],
            "pseudo" => {
                dynamics(&mut next).pseudo_force = on()?.then(|| crate::scene::PseudoForce {
                    alpha: -0.75,
                    epsilon_pore: 0.1,
                    epsilon_tip: 1.0,
                    near: 1.5,
                });
            }
            "msaa" => next.render.msaa = int()?,
            "supersample" => next.render.supersample = int()?,
            "strands" => {
                next.render.strands =
                    crate::scene::StrandRaster::parse(value.trim()).map_err(bad)?
            }
            "play" => self.view.playing = on()?,
            "lod" => {
                let f = nums(1)?[0];
                if !(0.01..=1.0).contains(&f) {
                    return Err(bad("the share of hairs must be in [0.01, 1]".into()));
                }
                self.view.adaptive_lod = false;
                self.view.hair_fraction = f;
            }
            "fur.hairs" | "fur.stiffness" | "fur.culling" => {
                let f = next
                    .fur
                    .as_mut()
                    .ok_or_else(|| bad("the scene has no fur".into()))?;
                match key {
                    "fur.hairs" => f.hairs = int()?,
                    "fur.stiffness" => {
                        let v = nums(1)?[0];
                        f.coats.iter_mut().for_each(|c| c.stiffness = v);
                    }
                    _ => f.culling.enabled = on()?,
                }
            }
            "wisps.max_steps" => {
                next.wisps
                    .as_mut()
                    .ok_or_else(|| bad("the scene has no wisps".into()))?
                    .march
                    .max_steps = int()?;
            }
            k if k.starts_with("wisps.toon.") || k.starts_with("wisps.outline") => {
                let w = next
                    .wisps
                    .as_mut()
                    .ok_or_else(|| bad("the scene has no wisps".into()))?;
                crate::systems::wisps::panel::set_key(w, key, value).map_err(bad)?;
            }
            "wisps.edit" => {
                let edit = on()?;
                if edit && next.wisps.is_none() {
                    return Err(bad("the scene has no wisps".into()));
                }
                self.view.edit_skeletons = edit;
            }
            "strips.edit" | "eff.paint" => {
                let on = on()?;
                if on && next.strips.is_none() {
                    return Err(bad("the scene has no strips".into()));
                }
                if on && key == "eff.paint" && next.forces.eff.is_none() {
                    return Err(bad("the scene has no EFF".into()));
                }
                if key == "strips.edit" {
                    self.view.edit_strips = on;
                    self.view.paint_eff &= !on;
                } else {
                    self.view.paint_eff = on;
                    self.view.edit_strips &= !on;
                }
            }
            "strips.key" => return self.add_strip_edit().map_err(|e| bad(e.to_string())),
            "seek" => self.seek = Some(int()? as u64),
            "save" => self.requests.push(Request::Save(value.to_string())),
            "export" => self.requests.push(Request::Export(value.to_string())),
            "mouse.press" | "mouse.move" => {
                let v = nums(2)?;
                self.requests.push(Request::Mouse(if key == "mouse.press" {
                    MouseEvent::Press(v[0], v[1])
                } else {
                    MouseEvent::Move(v[0], v[1])
                }));
            }
            "mouse.release" => self.requests.push(Request::Mouse(MouseEvent::Release)),
            _ => return Err(bad(format!("unknown key {key:?}"))),
        }
        crate::scene::validate(&next).map_err(|e| bad(e.to_string()))?;
        self.scene = next;
        Ok(())
    }
}

/// The scene's dynamics, created with defaults if absent.
fn dynamics(scene: &mut Scene) -> &mut Dynamics {
    scene.dynamics.get_or_insert_with(Dynamics::default)
}

/// A force set on hair groups that stand still sets them moving (as it did when the forces
/// sat in their dynamics block).
fn moving(scene: &mut Scene) {
    if !scene.groups.is_empty() {
        dynamics(scene);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gust() -> Scene {
        Scene::from_ron(include_str!("../../assets/scenes/gust.ron"), "gust.ron").unwrap()
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
            .groups
            .iter()
            .all(|g| g.material.color == [0.8, 0.6, 0.2]));
        s.apply_set("wind=0,0,-300").unwrap();
        assert_eq!(s.scene.forces.wind[0].force, [0.0, 0.0, -300.0]);
        s.apply_set("play=off").unwrap();
        assert!(!s.view.playing);
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
}
