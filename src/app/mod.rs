//! The interactive viewer: a winit window drawn with wgpu, egui panels beside the scene.
//! The scene is drawn by the same `Renderer` as the headless renders (one path, two
//! targets); egui is drawn on top in the same frame. The panels edit `params::ViewerState`;
//! each frame the edit is classified (`params::Changes`) and applied: re-groom for static
//! parameters, new parameters for the next simulation step, new uniforms for the look.

pub mod camera;
pub mod panels;
pub mod params;

use crate::error::{KamiError, Result};
use crate::gpu::{self, Gpu, Preference};
use crate::render::{self, target::Offscreen, FrameView, Renderer, SceneContent};
use crate::scene::Scene;
use camera::OrbitCamera;
use glam::DVec3;
use params::{Changes, Request, ViewerState};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// The adaptive level of detail never draws fewer than this share of the hairs.
pub const MIN_FRACTION: f64 = 0.1;

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
}

/// Open the viewer and run until the window closes.
pub fn run(options: ViewerOptions) -> Result<()> {
    let (scene, path) = match &options.scene {
        Some(p) => (Scene::load(p)?, p.display().to_string()),
        None => (
            Scene::from_ron(DEFAULT_SCENE, "gust.ron (built in)")?,
            "assets/scenes/gust.ron".to_string(),
        ),
    };
    for (_, set) in &options.sets {
        // Refuse bad overrides before opening a window.
        ViewerState::new(scene.clone(), String::new()).apply_set(set)?;
    }
    let event_loop = EventLoop::new().map_err(|e| KamiError::Window(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        state: ViewerState::new(scene, path),
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
            "viewer: {} frames, {:.1} fps; sim {:.1} ms, scene {:.1} ms, panels {:.1} ms, present {:.1} ms; {:.0} % of hairs drawn, {}x{} on {}",
            app.gfx.as_ref().map_or(0, |g| g.frames),
            st.fps,
            st.sim_ms,
            st.render_ms,
            st.ui_ms,
            st.present_ms,
            app.state.view.hair_fraction * 100.0,
            st.size.0,
            st.size.1,
            st.adapter
        );
    }
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

#[derive(Default)]
struct Mouse {
    pos: Option<(f64, f64)>,
    orbit: bool,
    pan: bool,
    shift: bool,
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    renderer: Renderer,
    egui_renderer: egui_wgpu::Renderer,
    egui_state: egui_winit::State,
    hair: SceneContent,
    /// Frames of fur motion shown (advances while playing).
    fur_frame: f64,
    camera: OrbitCamera,
    mouse: Mouse,
    /// Scene as last applied (to classify the next edit).
    applied: Scene,
    zero_size: bool,
    frames: u64,
    sim_clock: f64,
    last_frame: Instant,
}

struct App {
    state: ViewerState,
    options: ViewerOptions,
    gfx: Option<Gfx>,
    egui_ctx: egui::Context,
    error: Option<KamiError>,
}

/// Groom, simulation and fur of a scene, bound to the renderer.
fn build(gpu: &Gpu, scene: &Scene, renderer: &mut Renderer) -> Result<SceneContent> {
    render::check_limits(gpu, scene, scene.render.size)?;
    render::build_content(gpu, scene, renderer)
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
        let mut renderer = Renderer::new(&gpu, format, quality)?;
        let t = Instant::now();
        let hair = build(&gpu, scene, &mut renderer)?;
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
        self.state.stats.adapter = gpu.describe();
        self.gfx = Some(Gfx {
            camera: OrbitCamera::from_desc(&scene.camera),
            applied: scene.clone(),
            window,
            surface,
            config,
            gpu,
            renderer,
            egui_renderer,
            egui_state,
            hair,
            fur_frame: 0.0,
            mouse: Mouse::default(),
            zero_size: false,
            frames: 0,
            sim_clock: 0.0,
            last_frame: Instant::now(),
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
                        other => self.state.error = Some(other.to_string()),
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
            WindowEvent::ModifiersChanged(m) => g.mouse.shift = m.state().shift_key(),
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => g.mouse.orbit = down,
                    MouseButton::Right | MouseButton::Middle => g.mouse.pan = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let Some(last) = g.mouse.pos {
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
                g.camera.zoom(steps);
            }
            WindowEvent::PinchGesture { delta, .. } => g.camera.zoom(delta * 8.0),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Space) => {
                        self.state.view.playing = !self.state.view.playing
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

/// Apply an edit classified by `Changes`.
fn apply(g: &mut Gfx, state: &mut ViewerState) -> Result<()> {
    let quality = state.view.quality(&state.scene);
    if quality != g.renderer.quality {
        g.renderer.set_quality(&g.gpu, quality);
    }
    if let Err(e) = crate::scene::validate(&state.scene) {
        // Keep what is drawn; say what is wrong.
        state.error = Some(e.to_string());
        return Ok(());
    }
    let ch = Changes::between(&g.applied, &state.scene);
    if !ch.any() {
        return Ok(());
    }
    let scene = &state.scene;
    if ch.regroom || ch.dynamics_toggled || ch.fur {
        let t = Instant::now();
        g.hair = build(&g.gpu, scene, &mut g.renderer)?;
        g.sim_clock = 0.0;
        state.stats.groom_ms = t.elapsed().as_secs_f64() * 1e3;
    } else {
        if ch.dynamics {
            if let (Some(sim), Some(d)) = (g.hair.sim.as_mut(), &scene.dynamics) {
                sim.update_params(&g.gpu, d.clone());
            }
        }
        if ch.look {
            g.renderer
                .update_materials(&g.gpu, &render::materials(scene));
        }
    }
    g.applied = scene.clone();
    state.error = None;
    Ok(())
}

fn handle_requests(g: &mut Gfx, state: &mut ViewerState, shots: &mut Vec<PathBuf>) -> Result<()> {
    for req in std::mem::take(&mut state.requests) {
        match req {
            Request::Open(path) => match Scene::load(&path) {
                Ok(scene) => {
                    g.camera = OrbitCamera::from_desc(&scene.camera);
                    state.scene = scene;
                    state.group = 0;
                    state.message = Some(format!("opened {path}"));
                }
                Err(e) => state.error = Some(e.to_string()),
            },
            Request::Save(path) => {
                let mut scene = state.scene.clone();
                scene.camera = g.camera.desc();
                match std::fs::write(&path, scene.to_ron()) {
                    Ok(()) => state.message = Some(format!("saved {path}")),
                    Err(e) => state.error = Some(format!("cannot save {path}: {e}")),
                }
            }
            Request::Screenshot(path) => shots.push(PathBuf::from(path)),
            Request::Step => {
                if let Some(sim) = g.hair.sim.as_mut() {
                    let mut enc = g.gpu.device.create_command_encoder(&Default::default());
                    sim.record_frame(&g.gpu, &mut enc, &g.hair.hair);
                    g.gpu.queue.submit([enc.finish()]);
                }
            }
            Request::Reset => {
                g.hair = build(&g.gpu, &state.scene, &mut g.renderer)?;
                g.sim_clock = 0.0;
                g.fur_frame = 0.0;
            }
            Request::FrameScene => {
                let (c, r) = render::view_with_fur(&state.scene, g.hair.fur.as_ref()).bounds;
                g.camera.frame(c, r);
            }
        }
    }
    Ok(())
}

fn frame(
    g: &mut Gfx,
    state: &mut ViewerState,
    ctx: &egui::Context,
    options: &ViewerOptions,
) -> Result<()> {
    let now = Instant::now();
    let dt = now.duration_since(g.last_frame).as_secs_f64();
    g.last_frame = now;
    if dt > 0.0 && g.frames > 0 {
        // Frame rate from the mean frame time (an average of rates would overweight fast frames).
        let ms = dt * 1e3;
        state.stats.frame_ms = if state.stats.frame_ms == 0.0 {
            ms
        } else {
            0.9 * state.stats.frame_ms + 0.1 * ms
        };
        state.stats.fps = 1e3 / state.stats.frame_ms;
    }
    for (at, set) in &options.sets {
        if *at == g.frames {
            state.apply_set(set)?;
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
    let mut output = ctx.run_ui(raw, |ui| panel_left = panels::show(ui, state));
    g.egui_state
        .handle_platform_output(&g.window, std::mem::take(&mut output.platform_output));
    // egui's texture changes are applied now, whatever happens to this frame.
    let mut textures = std::mem::take(&mut output.textures_delta);
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

#[allow(clippy::too_many_arguments)]
fn frame_body(
    g: &mut Gfx,
    state: &mut ViewerState,
    ctx: &egui::Context,
    output: egui::FullOutput,
    panel_left: f32,
    mut shots: Vec<PathBuf>,
) -> Result<()> {
    handle_requests(g, state, &mut shots)?;
    apply(g, state)?;

    // Simulation: `time_scale` frames per drawn frame.
    let t = Instant::now();
    let mut substeps = 0;
    if let Some(sim) = g.hair.sim.as_mut() {
        if state.view.playing {
            g.sim_clock += state.view.time_scale;
            let due = (g.sim_clock.floor() as u32).min(4);
            g.sim_clock -= g.sim_clock.floor();
            if due > 0 {
                let mut enc = g.gpu.device.create_command_encoder(&Default::default());
                substeps += sim
                    .record_frames(&g.gpu, &mut enc, &g.hair.hair, due)
                    .substeps;
                g.gpu.queue.submit([enc.finish()]);
                g.gpu.wait()?;
            }
        }
        state.stats.simulated = sim.setup.strands.len() as u64;
        state.stats.frame = sim.steps / sim.setup.params.steps_per_frame as u64;
    } else {
        state.stats.simulated = 0;
    }
    let sim_ms = t.elapsed().as_secs_f64() * 1e3;
    state.stats.sim_ms = if state.stats.sim_ms == 0.0 {
        sim_ms
    } else {
        0.8 * state.stats.sim_ms + 0.2 * sim_ms
    };
    if substeps > 0 {
        state.stats.substeps = substeps;
    }
    let (strands, segments) = state.scene.counts();
    state.stats.strands = strands;
    state.stats.segments = segments;

    // A minimised window has no surface to draw into.
    let (w, h) = (g.config.width, g.config.height);
    if g.zero_size || w == 0 || h == 0 || g.window.is_minimized() == Some(true) {
        g.frames += 1;
        return Ok(());
    }
    state.stats.size = (w, h);
    let surface_tex = match g.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
        wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
            g.surface.configure(&g.gpu.device, &g.config);
            return Ok(());
        }
        other => {
            log::warn!("surface: {other:?}; skipping a frame");
            return Ok(());
        }
    };
    let target = surface_tex.texture.create_view(&Default::default());

    let mut view = render::view_with_fur(&state.scene, g.hair.fur.as_ref());
    view.camera = g.camera.camera();
    if state.view.playing {
        g.fur_frame += state.view.time_scale;
    }
    if let Some(fur) = g.hair.fur.as_mut() {
        let mut enc = g.gpu.device.create_command_encoder(&Default::default());
        let lod = state.view.hair_fraction;
        view.fur = Some(fur.record(
            &g.gpu,
            &mut enc,
            g.fur_frame,
            view.camera.eye,
            view.camera.fov_y,
            lod,
        )?);
        g.gpu.queue.submit([enc.finish()]);
    }
    view.hair_fraction = state.view.hair_fraction;
    view.show_pseudo = state.view.show_pseudo;
    if let (Some(d), Some(head), Some(sim)) =
        (&state.scene.dynamics, view.head.as_mut(), &g.hair.sim)
    {
        let frame = sim.steps as f64 / d.steps_per_frame as f64;
        head.1 = crate::sim::forces::head_at(
            &d.head_motion,
            DVec3::from(state.scene.head.center),
            frame,
        );
    }
    // Scene width: the window minus the panel egui reserved on the right.
    let scene_w = ((panel_left * output.pixels_per_point).round().max(1.0) as u32).min(w);

    let paint = ctx.tessellate(output.shapes, output.pixels_per_point);
    let screen = egui_wgpu::ScreenDescriptor {
        size_in_pixels: [w, h],
        pixels_per_point: output.pixels_per_point,
    };

    let (scene_ms, ui_ms) = draw(g, &target, (w, h), scene_w, &view, &paint, &screen)?;
    let t = Instant::now();
    g.gpu.queue.present(surface_tex);
    g.gpu.wait()?;
    let present_ms = t.elapsed().as_secs_f64() * 1e3;
    let ema = |old: f64, new: f64| {
        if old == 0.0 {
            new
        } else {
            0.8 * old + 0.2 * new
        }
    };
    state.stats.render_ms = ema(state.stats.render_ms, scene_ms);
    state.stats.ui_ms = ema(state.stats.ui_ms, ui_ms);
    state.stats.present_ms = ema(state.stats.present_ms, present_ms);
    let render_ms = scene_ms;

    for path in shots {
        let shot = Offscreen::with_format(&g.gpu, (w, h), g.config.format)?;
        draw(g, &shot.view, (w, h), scene_w, &view, &paint, &screen)?;
        let img = shot.read_rgba(&g.gpu)?;
        match img.save(&path) {
            Ok(()) => state.message = Some(format!("screenshot {}", path.display())),
            Err(e) => state.error = Some(format!("cannot write {}: {e}", path.display())),
        }
    }
    // Level of detail: keep the frame inside the budget by drawing a share of the hairs.
    // First fewer hairs (down to MIN_FRACTION), then no MSAA; back in the opposite order.
    if state.view.adaptive_lod {
        let budget = state.view.frame_budget_ms;
        let v = &mut state.view;
        if render_ms > budget {
            if v.hair_fraction <= MIN_FRACTION && !v.msaa_dropped && state.scene.render.msaa > 1 {
                v.msaa_dropped = true;
                v.hair_fraction = 0.5;
            } else {
                v.hair_fraction =
                    (v.hair_fraction * (budget / render_ms).max(0.5)).max(MIN_FRACTION);
            }
        } else if render_ms < 0.6 * budget {
            if v.hair_fraction >= 1.0 && v.msaa_dropped && render_ms < 0.2 * budget {
                v.msaa_dropped = false;
                v.hair_fraction = 0.5;
            } else {
                v.hair_fraction = (v.hair_fraction * 1.15).min(1.0);
            }
        }
    } else {
        state.view.msaa_dropped = false;
    }
    g.frames += 1;
    Ok(())
}

/// Scene then panels into `target`.
fn draw(
    g: &mut Gfx,
    target: &wgpu::TextureView,
    size: (u32, u32),
    scene_w: u32,
    view: &FrameView,
    paint: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) -> Result<(f64, f64)> {
    // Scene and panels are submitted and timed separately: the Stats panel says which one
    // limits the frame rate.
    let t = Instant::now();
    let mut enc = g
        .gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("viewer scene"),
        });
    g.renderer
        .render_region(&g.gpu, &mut enc, target, size, (scene_w, size.1), view)?;
    g.gpu.queue.submit([enc.finish()]);
    g.gpu.wait()?;
    let scene_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let mut enc = g
        .gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("viewer panels"),
        });
    g.egui_renderer
        .update_buffers(&g.gpu.device, &g.gpu.queue, &mut enc, paint, screen);
    {
        let pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("egui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let mut pass = pass.forget_lifetime();
        g.egui_renderer.render(&mut pass, paint, screen);
    }
    g.gpu.queue.submit([enc.finish()]);
    g.gpu.wait()?;
    g.gpu.take_error()?;
    Ok((scene_ms, t.elapsed().as_secs_f64() * 1e3))
}
