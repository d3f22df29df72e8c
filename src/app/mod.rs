//! The interactive viewer: a winit window drawn with wgpu, egui panels beside the scene.
//! The scene is a `Stage`, advanced and drawn exactly as the headless renders do it (one
//! clock, one render path, two targets); egui is drawn on top in the same frame. The panels
//! edit `params::ViewerState`; each frame the stage takes the edited scene and each hair
//! system classifies the edit (`systems::Change`): rebuild for its shape, new parameters for
//! the next step, new uniforms for the look. The kinds' mouse tools, keys and overlays are
//! hosted through `systems::ui::KindUi`: the viewer names no kind.
//!
//! The clock: the first frame drawn is frame 0 (the rest pose); while playing, each drawn
//! frame advances `time_scale` frames (fractions accumulate), so drawn frame k of a run at
//! time scale 1 shows frame k, the same pose `kami render --frames k..k` writes.

pub mod camera;
pub mod panel_cache;
pub mod panels;
pub mod params;
pub mod watch;

use crate::error::{KamiError, Result};
use crate::gpu::timing::Phase;
use crate::gpu::view::ScreenView;
use crate::gpu::{self, Gpu, Preference};
use crate::stage::{self, target::Offscreen, Look, Stage};
use crate::systems::ui::{self as kind_ui, Mods, Tool};
use crate::systems::Scene;
use crate::systems::KINDS;
use camera::OrbitCamera;
use glam::DVec2;
use params::{Request, ViewerState};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

pub use params::MIN_FRACTION;

/// The default scene: hair that moves (the paper's gust), embedded so `kami view` works
/// from any directory.
pub const DEFAULT_SCENE: &str = include_str!("../../assets/scenes/gust.ron");

/// How the viewer was started.
#[derive(Clone, Debug, Default)]
pub struct ViewerOptions {
    pub scene: Option<PathBuf>,
    /// Window size in logical pixels.
    pub size: (u32, u32),
    pub software: bool,
    /// Close after this many frames (tests, scripts).
    pub exit_after_frames: Option<u64>,
    /// Screenshots of the whole window (scene and panels): (frame, file).
    pub screenshots: Vec<(u64, PathBuf)>,
    /// `--set` overrides applied at a frame, through the panels' path: (frame, KEY=VALUE).
    pub sets: Vec<(u64, String)>,
    /// Hide the panels: the scene fills the window (clean captures, comparisons with
    /// `kami render`).
    pub no_panels: bool,
    /// Reload the scene file from scratch every N drawn frames (long-run leak checks).
    pub reload_every: Option<u64>,
    /// Write the resident memory every `MEMORY_EVERY` frames here, as CSV (leak checks).
    pub memory_log: Option<PathBuf>,
    /// Start with live reload off (`--no-watch`; the Files panel switches it).
    pub no_watch: bool,
}

/// Frames between two resident-memory samples.
pub const MEMORY_EVERY: u64 = 50;

/// The process's resident memory in MiB (Linux: `/proc/self/status`); None elsewhere. On a
/// software adapter this includes every GPU buffer and texture.
pub fn resident_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Open the viewer and run until the window closes.
pub fn run(options: ViewerOptions) -> Result<()> {
    let (scene, path) = match &options.scene {
        Some(p) => (Scene::load(p)?, p.display().to_string()),
        None => (
            Scene::from_ron(DEFAULT_SCENE, "gust.ron (built in)")?,
            // The shipped file behind it, found from any working directory (a reload reads it).
            crate::scene::shipped("assets/scenes/gust.ron")
                .display()
                .to_string(),
        ),
    };
    for (_, set) in &options.sets {
        // Refuse bad overrides before opening a window.
        ViewerState::new(scene.clone(), String::new()).apply_set(set)?;
    }
    let mut state = ViewerState::new(scene, path);
    state.view.watch = !options.no_watch;
    let event_loop = EventLoop::new().map_err(|e| KamiError::Window(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        state,
        options,
        gfx: None,
        egui_ctx: egui::Context::default(),
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| KamiError::Window(e.to_string()))?;
    let st = &app.state.stats;
    if app.gfx.is_some() {
        println!(
            "viewer: {} frames drawn (clock at frame {}), {:.1} fps; {}, CPU recording {:.1} ms; {}, {}x{} on {}",
            app.gfx.as_ref().map_or(0, |g| g.frames),
            st.frame,
            st.fps,
            st.gpu_summary(),
            st.record_ms,
            app.state.view.dropping(),
            st.size.0,
            st.size.1,
            st.adapter
        );
    }
    for w in &st.warnings {
        println!("viewer: warning at the last check: {w}");
    }
    if let Some(g) = app
        .gfx
        .as_ref()
        .filter(|g| g.watched.reloads + g.watched.failed > 0)
    {
        println!(
            "reload: {} reloads on save, {} saves that did not load; {} files watched",
            g.watched.reloads,
            g.watched.failed,
            g.watched.watch.len()
        );
    }
    if let Some(g) = &app.gfx {
        report_memory(g, app.options.memory_log.as_deref())?;
    }
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Print how resident memory moved over the run (from the first sample after a tenth of the
/// frames, so start-up allocations do not count as growth) and write the samples as CSV.
fn report_memory(g: &Gfx, log: Option<&std::path::Path>) -> Result<()> {
    let m = &g.memory;
    let (Some(first), Some(last)) = (m.iter().find(|s| s.0 >= g.frames / 10), m.last()) else {
        return Ok(());
    };
    let peak = m.iter().map(|s| s.1).fold(0.0, f64::max);
    println!(
        "memory: {:.1} MiB resident at frame {}, {:.1} MiB at frame {} ({:+.1} MiB), peak {:.1} MiB; {} reloads",
        first.1,
        first.0,
        last.1,
        last.0,
        last.1 - first.1,
        peak,
        g.reloads
    );
    if let Some(path) = log {
        let mut csv = String::from("frame,resident_mib,reloads\n");
        for (f, mib, r) in m {
            csv.push_str(&format!("{f},{mib:.2},{r}\n"));
        }
        std::fs::write(path, csv).map_err(|source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    }
    Ok(())
}

#[derive(Default)]
struct Mouse {
    pos: Option<(f64, f64)>,
    orbit: bool,
    pan: bool,
    shift: bool,
    ctrl: bool,
}

impl Mouse {
    fn mods(&self) -> Mods {
        Mods {
            shift: self.shift,
            ctrl: self.ctrl,
        }
    }
}

/// The first kind (in `KINDS` order) whose mouse mode is on: a left press goes to it.
fn mouse_kind(s: &ViewerState) -> Option<usize> {
    s.kinds.iter().position(|k| k.mouse_mode(&s.scene, &s.host))
}

/// What kind `i`'s tools see of the stage: its system and the clock.
fn tool(g: &Gfx, i: usize) -> Tool<'_> {
    Tool {
        gpu: &g.gpu,
        system: g
            .stage
            .systems()
            .iter()
            .find(|s| s.kind() == KINDS[i].name)
            .map(|s| s.as_ref()),
        ctx: g.stage.ctx(),
    }
}

/// A left press at `cursor` for kind `i`'s mouse mode: whether its tool took it.
fn press(g: &Gfx, s: &mut ViewerState, i: usize, cursor: DVec2) -> Result<bool> {
    let t = tool(g, i);
    s.kinds[i].press(&mut s.scene, &mut s.host, &t, cursor)
}

/// The cursor moved with a press held: to the kind holding it. Returns whether one did.
fn drag(g: &Gfx, s: &mut ViewerState, cursor: DVec2) -> bool {
    let Some(i) = s.kinds.iter().position(|k| k.holding()) else {
        return false;
    };
    let t = tool(g, i);
    s.kinds[i].drag(&mut s.scene, &mut s.host, &t, cursor);
    true
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    stage: Stage,
    egui_renderer: egui_wgpu::Renderer,
    egui_state: egui_winit::State,
    /// The panels' pixels between frames, redrawn where egui's shapes changed.
    panels: panel_cache::PanelCache,
    /// Fractions of a frame the clock owes (time scales below 1).
    clock_debt: f64,
    /// When the clock last advanced while playing (a cache's wall-time pacing).
    last_advance: Option<Instant>,
    /// The last edited scene the stage refused (not retried every frame; shown in red).
    refused: Option<Scene>,
    camera: OrbitCamera,
    mouse: Mouse,
    zero_size: bool,
    /// Frames drawn (the `--exit-after-frames`, `--screenshot-at` and `--set` count).
    frames: u64,
    last_frame: Instant,
    /// The last frame's period and the part of it spent waiting for the surface (a vsync
    /// wait is not work: `ViewSettings::adapt` keeps the work inside the budget).
    period_ms: f64,
    acquire_ms: f64,
    /// The camera of the last frame and since when nothing has moved (`params::still`).
    last_camera: Option<crate::gpu::view::Camera>,
    still_since: Option<Instant>,
    /// This frame rebuilt something (`frame_body`).
    stalled: bool,
    /// Scene files loaded from scratch (Open, `--reload-every`).
    reloads: u64,
    /// (frame, resident MiB, reloads so far) every `MEMORY_EVERY` frames.
    memory: Vec<(u64, f64, u64)>,
    /// Live reload: the files watched and the scene as last read from them.
    watched: Watched,
}

/// Live reload's state: the files of the scene shown and the scene as the file last gave
/// it (the base of `merge_edits`: what differs from it in the viewer was edited there).
struct Watched {
    watch: watch::Watch,
    base: Scene,
    /// Saves reloaded, and saves that did not load.
    reloads: u64,
    failed: u64,
}

impl Watched {
    /// Watch the scene `path` now shows (opened, saved, reloaded), `scene` as it is there.
    fn show(&mut self, path: &Path, scene: &Scene) {
        self.show_since(path, scene, &watch::Seen::default());
    }

    /// As `show`, the files new to the watch taken as `earlier` saw them (a reload).
    fn show_since(&mut self, path: &Path, scene: &Scene, earlier: &watch::Seen) {
        self.watch.set_since(path, scene.files(path), earlier);
        self.base = scene.clone();
    }
}

struct App {
    state: ViewerState,
    options: ViewerOptions,
    gfx: Option<Gfx>,
    egui_ctx: egui::Context,
    error: Option<KamiError>,
}

/// The stage of a scene for the window's output format.
fn build(
    gpu: &Gpu,
    scene: &Scene,
    format: wgpu::TextureFormat,
    quality: stage::Quality,
) -> Result<Stage> {
    stage::check_limits(gpu, scene, scene.render.size)?;
    let mut stage = Stage::new(gpu, scene, format, quality)?;
    // Per-pass GPU times for Stats and the level of detail, read back without waiting.
    stage.enable_timing(gpu);
    Ok(stage)
}

impl App {
    fn init(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let (w, h) = self.options.size;
        let attrs = Window::default_attributes()
            .with_title("Kami 髪")
            .with_inner_size(winit::dpi::LogicalSize::new(w, h));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(|e| KamiError::Window(e.to_string()))?,
        );
        let backends = gpu::backends_from_env()?;
        let mut desc = gpu::instance_descriptor(backends);
        desc.display = Some(Box::new(event_loop.owned_display_handle()));
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| KamiError::Window(format!("cannot create a surface: {e}")))?;
        let pref = if self.options.software {
            Preference::Software
        } else {
            Preference::Hardware
        };
        let gpu = Gpu::with_instance(instance, backends, pref, Some(&surface))?;
        let caps = surface.get_capabilities(&gpu.adapter);
        // egui wants a non-sRGB target (it blends in gamma space); the scene's resolve pass
        // encodes sRGB itself into such a target, so one plain format serves both.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| {
                matches!(
                    f,
                    wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm
                )
            })
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| KamiError::Window("the surface supports no format".into()))?;

        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&gpu.device, &config);
        gpu.take_error()?;
        let scene = &self.state.scene;
        let quality = self.state.view.quality(scene);
        let t = Instant::now();
        let stage = build(&gpu, scene, format, quality)?;
        self.state.stats.groom_ms = t.elapsed().as_secs_f64() * 1e3;
        let egui_renderer =
            egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        let egui_state = egui_winit::State::new(
            self.egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let panels = panel_cache::PanelCache::new(&gpu.device, format);
        self.state.stats.adapter = gpu.describe();
        self.state.view.frame_budget_ms =
            params::default_budget_ms(gpu.info.device_type == wgpu::DeviceType::Cpu);
        self.state.stats.timestamps = gpu
            .device
            .features()
            .contains(crate::gpu::timing::features());
        let path = PathBuf::from(&self.state.path);
        let watched = Watched {
            watch: watch::Watch::new(&path, scene.files(&path)),
            base: scene.clone(),
            reloads: 0,
            failed: 0,
        };
        self.gfx = Some(Gfx {
            watched,
            camera: OrbitCamera::from_desc(&scene.camera),
            window,
            surface,
            config,
            gpu,
            stage,
            egui_renderer,
            egui_state,
            panels,
            clock_debt: 0.0,
            last_advance: None,
            refused: None,
            mouse: Mouse::default(),
            zero_size: false,
            frames: 0,
            last_frame: Instant::now(),
            period_ms: 0.0,
            acquire_ms: 0.0,
            last_camera: None,
            still_since: None,
            stalled: false,
            reloads: 0,
            memory: Vec::new(),
        });
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        if let Err(e) = self.init(event_loop) {
            self.error = Some(e);
            event_loop.exit();
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(g) = &self.gfx {
            g.window.request_redraw();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(g) = self.gfx.as_mut() else { return };
        let response = g.egui_state.on_window_event(&g.window, &event);
        // The kinds' tools: a button or key closes an open gesture (so a slider drag, or a
        // run of wheel turns, is one undo entry), and a left release ends a drag even over
        // the panels.
        if matches!(
            event,
            WindowEvent::MouseInput { .. } | WindowEvent::KeyboardInput { .. }
        ) {
            self.state.kinds.iter_mut().for_each(|k| k.input());
        }
        if let WindowEvent::MouseInput {
            state: ElementState::Released,
            button: MouseButton::Left,
            ..
        } = event
        {
            self.state.kinds.iter_mut().for_each(|k| k.release());
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                // Minimised windows report zero: keep the last configuration, draw nothing.
                g.zero_size = size.width == 0 || size.height == 0;
                if !g.zero_size {
                    g.config.width = size.width;
                    g.config.height = size.height;
                    g.surface.configure(&g.gpu.device, &g.config);
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = frame(g, &mut self.state, &self.egui_ctx, &self.options) {
                    // Scene errors are shown in the UI; device trouble ends the viewer.
                    match e {
                        KamiError::Gpu(_) | KamiError::Window(_) | KamiError::Device(_) => {
                            self.error = Some(e);
                            event_loop.exit();
                        }
                        other => self.state.host.error = Some(other.to_string()),
                    }
                }
                if self
                    .options
                    .exit_after_frames
                    .is_some_and(|n| g.frames >= n)
                {
                    event_loop.exit();
                }
            }
            _ if response.consumed => {}
            WindowEvent::ModifiersChanged(m) => {
                g.mouse.shift = m.state().shift_key();
                g.mouse.ctrl = m.state().control_key();
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                let mode = if down { mouse_kind(&self.state) } else { None };
                match button {
                    // A kind's mouse mode (the skeleton editor, the strips' picking and
                    // dragging, the EFF brush): a press its tool takes does not orbit.
                    MouseButton::Left if mode.is_some() => {
                        let cursor = g.mouse.pos.map(|p| DVec2::new(p.0, p.1));
                        let took = cursor
                            .zip(mode)
                            .map(|(c, i)| press(g, &mut self.state, i, c));
                        g.mouse.orbit = match took {
                            Some(Ok(took)) => !took,
                            Some(Err(e)) => {
                                self.state.host.error = Some(e.to_string());
                                false
                            }
                            None => true,
                        };
                    }
                    MouseButton::Left => g.mouse.orbit = down,
                    MouseButton::Right | MouseButton::Middle => g.mouse.pan = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if drag(g, &mut self.state, DVec2::new(p.0, p.1)) {
                    // A kind's tool holds the press.
                } else if let Some(last) = g.mouse.pos {
                    let (dx, dy) = (p.0 - last.0, p.1 - last.1);
                    if g.mouse.pan || (g.mouse.orbit && g.mouse.shift) {
                        g.camera.pan(dx, dy, g.config.height as f64);
                    } else if g.mouse.orbit {
                        g.camera.orbit(dx, dy);
                    }
                }
                g.mouse.pos = Some(p);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                let (mods, s) = (g.mouse.mods(), &mut self.state);
                let took = g.mouse.pos.is_some_and(|p| {
                    let cursor = DVec2::new(p.0, p.1);
                    s.kinds
                        .iter_mut()
                        .any(|k| k.wheel(&mut s.scene, &s.host, cursor, steps, mods))
                });
                if !took {
                    g.camera.zoom(steps);
                }
            }
            WindowEvent::PinchGesture { delta, .. } => g.camera.zoom(delta * 8.0),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                // The kinds' keys first (undo and redo, the editor's Delete and Escape,
                // the strips' K), then the viewer's own.
                let key = match event.logical_key.as_ref() {
                    Key::Character(c) => Some(kind_ui::Key::Char(c)),
                    Key::Named(NamedKey::Delete) => Some(kind_ui::Key::Delete),
                    Key::Named(NamedKey::Escape) => Some(kind_ui::Key::Escape),
                    _ => None,
                };
                let (mods, s) = (g.mouse.mods(), &mut self.state);
                let took = key.is_some_and(|key| {
                    s.kinds
                        .iter_mut()
                        .any(|k| k.key(&mut s.scene, &mut s.host, key, mods))
                });
                if took {
                    return;
                }
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Space) => {
                        self.state.host.playing = !self.state.host.playing
                    }
                    Key::Character(c) => match c.to_ascii_lowercase().as_str() {
                        "f" => self.state.requests.push(Request::FrameScene),
                        "n" => self.state.requests.push(Request::Step),
                        "r" => self.state.requests.push(Request::Reset),
                        "s" => self
                            .state
                            .requests
                            .push(Request::Screenshot("kami-screenshot.png".into())),
                        _ => {}
                    },
                    _ => {}
                }
            }
            _ => {}
        }
    }
}

/// Hand the edited scene to the stage, which classifies the edit per hair system and
/// rebuilds, re-simulates or re-draws what it must.
fn apply(g: &mut Gfx, state: &mut ViewerState) -> Result<()> {
    let quality = state.view.quality(&state.scene);
    if quality != g.stage.quality {
        g.stage.set_quality(&g.gpu, quality);
    }
    if state.scene == *g.stage.scene() || g.refused.as_ref() == Some(&state.scene) {
        return Ok(());
    }
    if let Err(e) = crate::systems::validate(&state.scene) {
        // Keep what is drawn; say what is wrong.
        state.host.error = Some(e.to_string());
        return Ok(());
    }
    let replay = state
        .kinds
        .iter()
        .any(|k| k.replays(g.stage.scene(), &state.scene));
    let t = Instant::now();
    // A refused edit leaves the stage drawing what it had; the error shows in the panel.
    let applied = match g.stage.apply(&g.gpu, &state.scene) {
        Ok(a) => a,
        Err(e) => {
            g.refused = Some(state.scene.clone());
            return Err(e);
        }
    };
    g.refused = None;
    // What the tools read back may belong to the old systems.
    state.kinds.iter_mut().for_each(|k| k.stale());
    if applied.restarted {
        g.clock_debt = 0.0;
        state.stats.groom_ms = t.elapsed().as_secs_f64() * 1e3;
    }
    // An edit of the past (the strips' key frames change the clip from their first key
    // on): replay it to the frame shown (or where the edit asked to look).
    if replay && !applied.restarted && state.host.seek.is_none() {
        state.host.seek = Some(g.stage.frame());
    }
    state.host.error = None;
    Ok(())
}

fn handle_requests(g: &mut Gfx, state: &mut ViewerState, shots: &mut Vec<PathBuf>) -> Result<()> {
    for req in std::mem::take(&mut state.requests) {
        match req {
            // Open builds a fresh stage (also when the file did not change: "reload" means
            // from scratch); a scene that fails to load or build leaves the old one drawn.
            Request::Open(path) => {
                let built = Scene::load(&path).and_then(|scene| {
                    let quality = state.view.quality(&scene);
                    let t = Instant::now();
                    let stage = build(&g.gpu, &scene, g.config.format, quality)?;
                    Ok((scene, stage, t.elapsed()))
                });
                match built {
                    Ok((scene, stage, took)) => {
                        g.stage = stage;
                        g.refused = None;
                        g.clock_debt = 0.0;
                        g.reloads += 1;
                        g.camera = OrbitCamera::from_desc(&scene.camera);
                        state.stats.groom_ms = took.as_secs_f64() * 1e3;
                        g.watched.show(Path::new(&path), &scene);
                        state.scene = scene;
                        state.kinds.iter_mut().for_each(|k| k.opened());
                        state.host.error = None;
                        state.reload_error = None;
                        state.host.message = Some(format!("opened {path}"));
                    }
                    Err(e) => state.host.error = Some(e.to_string()),
                }
            }
            Request::Save(path) => {
                let mut scene = state.scene.clone();
                scene.camera = g.camera.desc();
                // Through a temporary file and a rename: a failed save keeps the old file.
                let tmp = format!("{path}.partial");
                let saved = std::fs::write(&tmp, scene.to_ron())
                    .and_then(|()| std::fs::rename(&tmp, &path))
                    .inspect_err(|_| {
                        let _ = std::fs::remove_file(&tmp);
                    });
                match saved {
                    Ok(()) => {
                        // The viewer now shows that file: live reload watches it (and does
                        // not take this write for an edit).
                        g.watched.show(Path::new(&path), &scene);
                        g.watched.watch.restamp(Path::new(&path));
                        state.host.message = Some(format!("saved {path}"));
                    }
                    Err(e) => state.host.error = Some(format!("cannot save {path}: {e}")),
                }
            }
            Request::Export(path) => {
                let written = g.stage.export(&g.gpu).and_then(|groom| {
                    crate::formats::write(Path::new(&path), &groom)?;
                    Ok(groom)
                });
                match written {
                    Ok(groom) => {
                        state.host.message = Some(format!(
                            "exported {} strands ({} points) at frame {} to {path}",
                            groom.counts.len(),
                            groom.points.len(),
                            g.stage.frame()
                        ))
                    }
                    Err(e) => state.host.error = Some(format!("cannot export {path}: {e}")),
                }
            }
            Request::Screenshot(path) => shots.push(PathBuf::from(path)),
            Request::Step => {
                let mut enc =
                    g.gpu
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("viewer step"),
                        });
                g.stage.advance(&g.gpu, &mut enc, 1)?;
                g.gpu.queue.submit([enc.finish()]);
            }
            Request::Reset => {
                g.stage.reset(&g.gpu)?;
                g.clock_debt = 0.0;
            }
            Request::FrameScene => {
                let (c, r) = g.stage.bounds();
                g.camera.frame(c, r);
            }
            // Scripted gestures take the real mouse's path through the kinds' tools; a press
            // no tool takes orbits the camera, as a left drag does.
            Request::Mouse(ev) => match ev {
                params::MouseEvent::Press(x, y) => {
                    g.mouse.pos = Some((x, y));
                    let took = match mouse_kind(state) {
                        Some(i) => press(g, state, i, DVec2::new(x, y))?,
                        None => false,
                    };
                    g.mouse.orbit = !took;
                }
                params::MouseEvent::Move(x, y) => {
                    if !drag(g, state, DVec2::new(x, y)) && g.mouse.orbit {
                        if let Some((x0, y0)) = g.mouse.pos {
                            g.camera.orbit(x - x0, y - y0);
                        }
                    }
                    g.mouse.pos = Some((x, y));
                }
                params::MouseEvent::Release => {
                    g.mouse.orbit = false;
                    state.kinds.iter_mut().for_each(|k| k.release())
                }
            },
            Request::Reload(changed) => reload(g, state, &changed),
        }
    }
    Ok(())
}

/// Live reload: the watched files `changed` were saved. The scene file is read again and
/// merged with the viewer's edits (`systems::merge_edits`: what the file did not
/// change keeps the viewer's edit); when that merge does not build, the file as written is
/// tried. A change of the scene file alone goes to the stage as an edit would (a new look
/// keeps the motion as it is; what must be rebuilt is simulated again to the frame shown);
/// a change of a file it names (a mesh the scene text does not hold) builds a fresh stage,
/// simulated again to the frame shown. The camera stays unless the file's camera block
/// changed; play or pause, the time scale, the level of detail and the panels stay. An
/// edit that does not load changes nothing drawn: its error shows over the view and in
/// the log, and the next good save clears it. One `reload:` line per save goes to stdout.
fn reload(g: &mut Gfx, state: &mut ViewerState, changed: &[PathBuf]) {
    let path = g.watched.watch.path().to_path_buf();
    let frame = g.stage.frame();
    let what = changed
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    // The files the saved text names, as they are before it loads (see `watch::Seen`).
    let earlier = crate::scene::read_bytes(&path)
        .and_then(|b| Scene::from_bytes(&b, &path.display().to_string()))
        .map(|s| watch::Seen::now(s.files(&path)))
        .unwrap_or_default();
    let loaded = Scene::load(&path).and_then(|theirs| {
        let merged = crate::systems::merge_edits(&g.watched.base, &state.scene, theirs.clone());
        let in_place = changed.iter().all(|p| *p == path);
        match rebuild(g, state, &merged, in_place, frame) {
            Ok(()) => Ok((theirs, merged)),
            Err(e) if merged != theirs => {
                log::warn!("{}: the viewer's edits on the saved scene do not build ({e}); showing the file as saved", path.display());
                rebuild(g, state, &theirs, in_place, frame)?;
                Ok((theirs.clone(), theirs))
            }
            Err(e) => Err(e),
        }
    });
    match loaded {
        Ok((theirs, shown)) => {
            // The file's camera when it changed there; else the one the user orbits.
            let camera = if theirs.camera != g.watched.base.camera {
                g.camera = OrbitCamera::from_desc(&theirs.camera);
                "from the file"
            } else {
                "kept"
            };
            // The kinds' tools: what they read back is stale; a kind whose block was
            // rebuilt (or came or went) drops its selection and history, like an Open.
            for (i, k) in KINDS.iter().enumerate() {
                let (was, is) = ((k.in_scene)(&state.scene), (k.in_scene)(&shown));
                let rebuilt = was != is
                    || (is
                        && (k.classify)(&state.scene, &shown) == crate::systems::Change::Rebuild);
                if rebuilt {
                    state.kinds[i].opened();
                }
                state.kinds[i].stale();
            }
            g.refused = None;
            g.watched.show_since(&path, &theirs, &earlier);
            g.watched.reloads += 1;
            state.scene = shown;
            state.reload_error = None;
            state.host.message = Some(format!("reloaded {} ({what} saved)", path.display()));
            let eye = g.camera.desc().eye;
            println!(
                "reload: {what} saved; {} reloaded at frame {} (reload {}); camera {camera}, eye ({:.3}, {:.3}, {:.3})",
                path.display(),
                g.stage.frame(),
                g.watched.reloads,
                eye[0],
                eye[1],
                eye[2]
            );
        }
        Err(e) => {
            g.watched.failed += 1;
            println!(
                "reload: {what} saved; it does not load: {e}; still showing the last good scene at frame {frame}"
            );
            // The error names the file and the place.
            state.reload_error = Some(format!("the save does not load: {e}"));
            // Files the saved text names that the last good scene did not (a mesh not
            // written yet) are watched too, from their stamps before the load, so that
            // writing one reloads, even while this load ran.
            let mut files: Vec<PathBuf> = g.watched.watch.files().map(Path::to_path_buf).collect();
            let before = files.len();
            for p in earlier.paths() {
                if !files.iter().any(|q| q == p) {
                    files.push(p.to_path_buf());
                }
            }
            if files.len() > before {
                g.watched.watch.set_since(&path, files, &earlier);
            }
        }
    }
}

/// Show `scene` (already merged): through the stage's edit path when only the scene file
/// changed (`in_place`), else a fresh stage; either way back at `frame` when the clock
/// restarted. A scene that does not validate, or a fresh stage that does not build, changes
/// nothing; an error inside the stage's edit path (`Stage::apply`, after the scene loaded
/// and validated: a head that does not build) may leave the quality or part of the edit
/// applied.
fn rebuild(
    g: &mut Gfx,
    state: &mut ViewerState,
    scene: &Scene,
    in_place: bool,
    frame: u64,
) -> Result<()> {
    crate::systems::validate(scene)?;
    let t = Instant::now();
    let quality = state.view.quality(scene);
    if in_place {
        let replay = state
            .kinds
            .iter()
            .any(|k| k.replays(g.stage.scene(), scene));
        if quality != g.stage.quality {
            g.stage.set_quality(&g.gpu, quality);
        }
        let applied = g.stage.apply(&g.gpu, scene)?;
        if applied.restarted || replay {
            g.stage.seek(&g.gpu, frame)?;
        }
        if applied.restarted {
            state.stats.groom_ms = t.elapsed().as_secs_f64() * 1e3;
        }
    } else {
        let mut stage = build(&g.gpu, scene, g.config.format, quality)?;
        stage.seek(&g.gpu, frame)?;
        g.stage = stage;
        state.stats.groom_ms = t.elapsed().as_secs_f64() * 1e3;
    }
    Ok(())
}

/// A save that did not load: its error over the top of the 3D view (seen with or without
/// the panels), until dismissed or the next good save.
fn reload_error(ctx: &egui::Context, state: &mut ViewerState, panel_left: f32) {
    let Some(e) = &state.reload_error else {
        return;
    };
    let width = panel_left.min(ctx.content_rect().width()) - 24.0;
    let mut dismissed = false;
    egui::Area::new(egui::Id::unique("reload error"))
        .fixed_pos(egui::pos2(8.0, 8.0))
        .show(ctx, |ui| {
            egui::Frame::popup(ui.style())
                .fill(egui::Color32::from_rgb(96, 22, 18))
                .show(ui, |ui| {
                    ui.set_max_width(width.max(120.0));
                    ui.colored_label(egui::Color32::from_rgb(255, 214, 205), e);
                    ui.horizontal(|ui| {
                        ui.label("the last good scene stays; the next good save reloads");
                        dismissed = ui.button("dismiss").clicked();
                    });
                });
        });
    if dismissed {
        state.reload_error = None;
    }
}

/// How long nothing must move before the view is drawn at full quality.
const STILL_AFTER: std::time::Duration = std::time::Duration::from_millis(250);

/// Frames between reads of the systems' warnings.
const WARNINGS_EVERY: u64 = 60;

fn frame(
    g: &mut Gfx,
    state: &mut ViewerState,
    ctx: &egui::Context,
    options: &ViewerOptions,
) -> Result<()> {
    let now = Instant::now();
    let dt = now.duration_since(g.last_frame).as_secs_f64();
    g.last_frame = now;
    g.period_ms = dt * 1e3;
    if dt > 0.0 && g.frames > 0 {
        // Frame rate from the mean frame time (an average of rates would overweight fast frames).
        state.stats.frame_ms = state.stats.frame_ema.add(dt * 1e3);
        state.stats.fps = 1e3 / state.stats.frame_ms;
    }
    for (at, set) in &options.sets {
        if *at == g.frames {
            state.apply_set(set)?;
        }
    }
    if options
        .reload_every
        .is_some_and(|n| g.frames > 0 && g.frames % n == 0)
    {
        state.requests.push(Request::Open(state.path.clone()));
    }
    if state.view.watch {
        if let Some(changed) = g.watched.watch.poll(now) {
            state.requests.push(Request::Reload(changed));
        }
    }
    if g.frames % WARNINGS_EVERY == WARNINGS_EVERY - 1 {
        // A read-back waits for the GPU: once a second, not every frame.
        let now = g.stage.warnings(&g.gpu)?;
        for w in now.iter().filter(|w| !state.stats.warnings.contains(w)) {
            log::warn!("{w}");
        }
        state.stats.warnings = now;
    }
    if g.frames % MEMORY_EVERY == 0 {
        if let Some(mib) = resident_mib() {
            g.memory.push((g.frames, mib, g.reloads));
        }
    }
    let shots: Vec<PathBuf> = options
        .screenshots
        .iter()
        .filter(|(f, _)| *f == g.frames)
        .map(|(_, p)| p.clone())
        .collect();

    // Panels first: their edits apply to this frame.
    let raw = g.egui_state.take_egui_input(&g.window);
    let mut panel_left = f32::MAX;
    let no_panels = options.no_panels;
    let (win_w, win_h) = (g.config.width, g.config.height);
    let (camera, bounds) = (g.camera.camera(), g.stage.bounds());
    let clock = g.stage.ctx();
    let mut output = ctx.run_ui(raw, |ui| {
        if !no_panels {
            panel_left = panels::show(ui, state);
        }
        // The 3D view as drawn this frame (the region left of the panels), for the kinds'
        // picking and overlays: with the head's pose (skeleton nodes) and without it (EFF
        // cells, strips and targets are in world space).
        let ppp = ui.ctx().pixels_per_point();
        let scene_w = ((panel_left * ppp).round().max(1.0) as u32).min(win_w);
        let size = DVec2::new(f64::from(scene_w), f64::from(win_h.max(1)));
        let at = |model| ScreenView::from_camera(&camera, model, size, bounds);
        state.host.head_view = Some(at(clock.head));
        state.host.world_view = Some(at(glam::DMat4::IDENTITY));
        for k in &mut state.kinds {
            k.overlay(ui.ctx(), &state.scene, &state.host, &clock, ppp);
        }
        reload_error(ui.ctx(), state, panel_left);
    });
    g.egui_state
        .handle_platform_output(&g.window, std::mem::take(&mut output.platform_output));
    // egui's texture changes are applied now, whatever happens to this frame.
    let mut textures = std::mem::take(&mut output.textures_delta);
    if !textures.set.is_empty() {
        g.panels.textures_changed = true;
    }
    for (id, deltas) in textures.set.drain() {
        for delta in deltas {
            g.egui_renderer
                .update_texture(&g.gpu.device, &g.gpu.queue, id, &delta);
        }
    }
    let free: Vec<egui::TextureId> = textures.free.drain().collect();
    let result = frame_body(g, state, ctx, output, panel_left, shots);
    for id in &free {
        g.egui_renderer.free_texture(id);
    }
    result
}

fn frame_body(
    g: &mut Gfx,
    state: &mut ViewerState,
    ctx: &egui::Context,
    output: egui::FullOutput,
    panel_left: f32,
    mut shots: Vec<PathBuf>,
) -> Result<()> {
    let now = Instant::now();
    let edited = note_stillness(g, state, now);
    // A frame that loads, edits, or builds other pipelines or targets is no measure of the
    // live frame's cost: the next frame's period, which holds it, is not taken.
    let rebuilds = edited || state.view.quality(&state.scene) != g.stage.quality;
    let stalled_before = std::mem::replace(&mut g.stalled, rebuilds);
    handle_requests(g, state, &mut shots)?;
    apply(g, state)?;
    if let Some(f) = state.host.seek.take() {
        g.stage.seek(&g.gpu, f)?;
        g.clock_debt = 0.0;
        g.last_advance = None;
        state.kinds.iter_mut().for_each(|k| k.stale());
    }
    advance_clock(g, state, now)?;
    // The kinds' tools read back what they follow (the picked strip's outline).
    for i in 0..state.kinds.len() {
        let t = tool(g, i);
        state.kinds[i].frame(&state.scene, &t)?;
    }
    let counts = g.stage.stats();
    state.stats.simulated = counts.simulated;
    state.stats.frame = g.stage.frame();
    state.host.frame = state.stats.frame;
    state.stats.strands = counts.strands;
    state.stats.segments = counts.segments;

    // A minimised window has no surface to draw into.
    let (w, h) = (g.config.width, g.config.height);
    if g.zero_size || w == 0 || h == 0 || g.window.is_minimized() == Some(true) {
        g.frames += 1;
        return Ok(());
    }
    state.stats.size = (w, h);
    let Some((surface_tex, acquire_ms)) = acquire(g) else {
        return Ok(());
    };
    let target = surface_tex.texture.create_view(&Default::default());

    let look = Look {
        camera: g.camera.camera(),
        lod: state.view.lod(),
        overlay: state.host.overlay,
    };
    // Scene width: the window minus the panel egui reserved on the right.
    let scene_w = ((panel_left * output.pixels_per_point).round().max(1.0) as u32).min(w);

    // egui's shapes: tessellated and drawn into the panel cache only where they changed.
    g.panels.prepare(
        &g.gpu.device,
        g.config.format,
        ctx,
        output.shapes,
        output.pixels_per_point,
        (w, h),
    );
    let screen = egui_wgpu::ScreenDescriptor {
        size_in_pixels: [w, h],
        pixels_per_point: output.pixels_per_point,
    };

    let t = Instant::now();
    draw(g, &target, (w, h), scene_w, &look, &screen)?;
    g.gpu.queue.present(surface_tex);
    let record_ms = t.elapsed().as_secs_f64() * 1e3;
    let st = &mut state.stats;
    st.record_ms = st.record_ema.add(record_ms);
    note_times(g, st);
    let render_ms = st.render_ms;

    if !shots.is_empty() {
        let frame = Canvas {
            size: (w, h),
            scene_w,
            look: &look,
            screen: &screen,
        };
        screenshots(g, state, shots, &frame)?;
    }
    adapt_lod(g, state, render_ms, stalled_before);
    g.acquire_ms = acquire_ms;
    g.frames += 1;
    Ok(())
}

/// Whether this frame edits the scene; marks the view still when nothing was edited, moved
/// or playing for a moment. A still view is drawn at full quality: what the frame budget
/// dropped comes back within a second.
fn note_stillness(g: &mut Gfx, state: &mut ViewerState, now: Instant) -> bool {
    let camera = g.camera.camera();
    let edited =
        !state.requests.is_empty() || state.host.seek.is_some() || state.scene != *g.stage.scene();
    let moved = edited || state.host.playing || g.last_camera != Some(camera);
    g.last_camera = Some(camera);
    if moved {
        g.still_since = None;
    } else if g.still_since.is_none() {
        g.still_since = Some(now);
    }
    state
        .view
        .set_still(g.still_since.is_some_and(|t| now - t >= STILL_AFTER));
    edited
}

/// The clock: `time_scale` frames per drawn frame, from the second drawn frame on. The
/// motion is submitted on its own (the strips' picking reads it back) and never waited
/// for: the GPU times of every pass come back from timestamps a few frames later.
fn advance_clock(g: &mut Gfx, state: &mut ViewerState, now: Instant) -> Result<()> {
    if state.host.playing && g.frames > 0 {
        // A cache plays at its file's rate in wall time (frames per second times the
        // seconds since the last advance, a stall counting at most a quarter second);
        // simulated hair one frame per drawn frame, so that a run is reproducible.
        let per_draw = match g.stage.playback_fps() {
            Some(fps) => {
                let dt = g
                    .last_advance
                    .map_or(0.0, |t| now.duration_since(t).as_secs_f64());
                dt.min(0.25) * fps
            }
            None => 1.0,
        };
        g.last_advance = Some(now);
        g.clock_debt += state.view.time_scale * per_draw;
        let due = (g.clock_debt.floor() as u32).min(4);
        g.clock_debt -= g.clock_debt.floor();
        if due > 0 {
            let mut enc = g
                .gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("viewer advance"),
                });
            let info = g.stage.advance(&g.gpu, &mut enc, due)?;
            g.gpu.queue.submit([enc.finish()]);
            if info.substeps > 0 {
                state.stats.substeps = info.substeps;
            }
        }
    }
    Ok(())
}

/// The surface's next texture and the milliseconds spent waiting for it; `None` when there
/// is none this frame (an outdated or lost surface is configured again).
fn acquire(g: &mut Gfx) -> Option<(wgpu::SurfaceTexture, f64)> {
    let acquire = Instant::now();
    let acquired = g.surface.get_current_texture();
    let acquire_ms = acquire.elapsed().as_secs_f64() * 1e3;
    match acquired {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
            Some((t, acquire_ms))
        }
        wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
            g.surface.configure(&g.gpu.device, &g.config);
            None
        }
        other => {
            log::warn!("surface: {other:?}; skipping a frame");
            None
        }
    }
}

/// GPU times of an earlier frame, when they have arrived (never waited for), and each
/// system's counts, into the Stats panel.
fn note_times(g: &mut Gfx, st: &mut params::Stats) {
    if let Some(times) = g.stage.timer().and_then(|t| t.poll(&g.gpu)) {
        st.gpu = Some(times);
        if let Some(ms) = times.get(Phase::Simulation) {
            st.sim_ms = st.sim_ema.add(ms);
        }
        let scene_ms = [Phase::Generation, Phase::Draw, Phase::Resolve]
            .iter()
            .filter_map(|p| times.get(*p))
            .sum::<f64>();
        st.render_ms = st.render_ema.add(scene_ms);
        if let Some(ms) = times.get(Phase::Panels) {
            st.ui_ms = st.ui_ema.add(ms);
        }
    } else if g.stage.timer().is_none() {
        // No timestamps on this adapter: the frame period is all there is to go by.
        st.render_ms = st.frame_ms;
    }
    st.systems = g
        .stage
        .systems()
        .iter()
        .map(|s| (s.kind(), s.stats()))
        .collect();
}

/// What one drawn frame is drawn with: its size, the scene's width, the view and egui's
/// screen.
struct Canvas<'a> {
    size: (u32, u32),
    scene_w: u32,
    look: &'a Look,
    screen: &'a egui_wgpu::ScreenDescriptor,
}

/// The screenshots asked for this frame. A screenshot is always at full quality: every
/// hair, the scene's MSAA, full resolution (a share the user set by hand stays).
fn screenshots(
    g: &mut Gfx,
    state: &mut ViewerState,
    shots: Vec<PathBuf>,
    frame: &Canvas,
) -> Result<()> {
    let (w, h) = frame.size;
    let live = g.stage.quality;
    let full = state.view.full_quality(&state.scene);
    g.stage.set_quality(&g.gpu, full);
    let look = Look {
        lod: if state.view.adaptive_lod {
            1.0
        } else {
            state.view.hair_fraction
        },
        ..*frame.look
    };
    for path in shots {
        let shot = Offscreen::with_format(&g.gpu, (w, h), g.config.format)?;
        draw(g, &shot.view, (w, h), frame.scene_w, &look, frame.screen)?;
        let img = shot.read_rgba(&g.gpu)?;
        match img.save(&path) {
            Ok(()) => state.host.message = Some(format!("screenshot {}", path.display())),
            Err(e) => state.host.error = Some(format!("cannot write {}: {e}", path.display())),
        }
    }
    g.stage.set_quality(&g.gpu, live);
    g.stalled = true;
    Ok(())
}

/// Level of detail: keep the frame's work inside the budget (`ViewSettings::adapt`): the
/// frame's period less its wait for the surface, or the GPU's time where the GPU is the
/// slower.
fn adapt_lod(g: &Gfx, state: &mut ViewerState, render_ms: f64, stalled_before: bool) {
    if state.view.adaptive_lod {
        let gpu_ms = if state.stats.timestamps {
            render_ms + state.stats.ui_ms
        } else {
            0.0
        };
        if g.frames > 1 && !stalled_before {
            state.view.adapt(
                (g.period_ms - g.acquire_ms).max(gpu_ms),
                state.scene.render.msaa,
            );
        }
    } else {
        state.view.msaa_dropped = false;
        state.view.scale_pct = 100;
    }
}

/// Scene then panels into `target`, in one submission that nothing waits for.
fn draw(
    g: &mut Gfx,
    target: &wgpu::TextureView,
    size: (u32, u32),
    scene_w: u32,
    look: &Look,
    screen: &egui_wgpu::ScreenDescriptor,
) -> Result<()> {
    let mut enc = g
        .gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("viewer frame"),
        });
    g.stage
        .render_region(&g.gpu, &mut enc, target, size, (scene_w, size.1), look)?;
    if let Some(t) = g.stage.timer() {
        t.begin(&mut enc, Phase::Panels);
    }
    g.panels.encode(
        &g.gpu.device,
        &g.gpu.queue,
        &mut enc,
        &mut g.egui_renderer,
        target,
        screen,
    );
    if let Some(t) = g.stage.timer() {
        t.end(&mut enc, Phase::Panels);
        t.finish(&mut enc);
    }
    g.gpu.queue.submit([enc.finish()]);
    if let Some(t) = g.stage.timer() {
        t.submitted();
    }
    g.gpu.take_error()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One egui pass of the reload error box on an 800x600 window with `events`; the texts
    /// painted, with their rectangles.
    fn texts(
        ctx: &egui::Context,
        state: &mut ViewerState,
        events: Vec<egui::Event>,
    ) -> Vec<(String, egui::Rect)> {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(800.0, 600.0),
            )),
            events,
            ..Default::default()
        };
        let mut out = ctx.run_ui(input, |ui| reload_error(ui.ctx(), state, 500.0));
        out.textures_delta.clear();
        out.shapes
            .into_iter()
            .filter_map(|s| match s.shape {
                egui::Shape::Text(t) => {
                    Some((t.galley.text().to_string(), t.visual_bounding_rect()))
                }
                _ => None,
            })
            .collect()
    }

    /// A save that did not load shows its error, file and place, over the view until the
    /// dismiss button is clicked.
    #[test]
    fn a_reload_error_shows_until_dismissed() {
        let scene = Scene::from_ron(DEFAULT_SCENE, "gust.ron").unwrap();
        let mut state = ViewerState::new(scene, String::new());
        let ctx = egui::Context::default();
        assert!(
            texts(&ctx, &mut state, vec![]).is_empty(),
            "no error, no box"
        );
        let error = "the save does not load: groom.ron:14:24: Expected identifier";
        state.reload_error = Some(error.into());
        let mut shown = Vec::new();
        for _ in 0..3 {
            shown = texts(&ctx, &mut state, vec![]);
        }
        assert!(shown.iter().any(|(t, _)| t == error), "{shown:?}");
        let (_, button) = shown
            .iter()
            .find(|(t, _)| t == "dismiss")
            .expect("a dismiss button");
        let at = button.center();
        let press = |pressed| egui::Event::PointerButton {
            pos: at,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: Default::default(),
        };
        texts(
            &ctx,
            &mut state,
            vec![egui::Event::PointerMoved(at), press(true)],
        );
        assert!(state.reload_error.is_some(), "dismissed on the press");
        texts(&ctx, &mut state, vec![press(false)]);
        assert_eq!(state.reload_error, None, "the click did not dismiss it");
        assert!(texts(&ctx, &mut state, vec![]).is_empty());
    }
}
