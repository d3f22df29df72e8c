//! Sakai's toon wisps: skeletons (the scene block, `block`) interpolated by natural cubic
//! splines and converted to Bézier segments (`curve`, on the GPU in `march::CurvePass`), the
//! blobby density around them (`field`, the f64 reference of the ray march in
//! `shaders/wisps/march.wgsl`), the toon shading and its controls (`toon`, the f64 reference
//! of `shaders/wisps/toon.wgsl`), mass springs with RK4 (`springs`, on the GPU in
//! `springs_gpu`), the depth-camera fingertip tracker that draws skeletons (`fingers`) and
//! the Toon and Skeleton panels (`panel`).
//!
//! Every frame the curve kernels rebuild the segments from the node positions (the springs'
//! primaries, or the drawn nodes under the head pose), and the march draws the surface as
//! opaque geometry with depth, before any strand hair or fur.
//!
//! The springs feel the scene's shared forces (`crate::forces::Forces`: gravity, keyed
//! wind, the EFF, head motion) and collide with the scene's head hull (the ellipsoid or a
//! mesh head's SDF); on a mesh head the wisps' roots are moved onto its scalp first
//! (`crate::systems::wisps::block::on_mesh_head`).

pub mod block;
pub mod curve;
pub mod edit;
pub mod field;
pub mod fingers;
pub mod march;
pub mod mesh;
pub mod mesh_gpu;
pub mod mesh_pass;
pub mod panel;
pub mod springs;
pub mod springs_gpu;
pub mod tiles;
pub mod tools;
pub mod toon;

use crate::error::{KamiError, Result};
use crate::gpu::Gpu;
use crate::systems::kind::Kind;
use crate::systems::scene::Scene;
use crate::systems::system::{
    Change, DrawSetup, FrameCtx, HairSystem, StepInfo, SystemStats, View,
};
use crate::systems::wisps::block::{MeshOn, Wisps};
use glam::{DMat4, DVec3};
use march::{CurvePass, MarchPass};

pub const KIND: Kind = Kind {
    name: "wisps",
    block: "wisps",
    called: "wisps",
    in_scene: |s| s.wisps().is_some(),
    validate: block::validate,
    read_files: |_, _, _| Ok(()),
    files: |_, _| Vec::new(),
    counts: |_| (0, 0),
    counted: None,
    check_limits: |gpu, scene| match scene.wisps() {
        Some(w) => march::check_limits(gpu, w),
        None => Ok(()),
    },
    build,
    classify,
    panels: panel::PANELS,
    ui: || Box::<tools::WispsUi>::default(),
    // Toon wisps are skeletons, not strands: named on their own.
    summary: |s| {
        s.wisps().as_ref().map(|w| {
            format!(
                "{} toon wisps ({} spline segments)",
                w.skeletons.len(),
                march::segment_count(w)
            )
        })
    },
    moves: |s| s.wisps().as_ref().is_some_and(|w| w.springs.is_some()),
    scenes: &[
        "toon",
        "toon_divide",
        "toon_shake",
        "toon_wind",
        "toon_mesh_head",
    ],
    shaders: &[
        ("wisps/curves", march::CURVES),
        ("wisps/march", march::MARCH),
        ("wisps/composite", march::COMPOSITE),
        ("wisps/cast", march::CAST),
        // The toon shading is compiled inside the march module.
        ("wisps/toon", march::MARCH),
        ("wisps/springs", springs_gpu::SPRINGS),
        ("wisps/tiles", tiles::TILES),
        ("wisps/mesh", mesh_pass::MESH),
        ("wisps/mesher", mesh_gpu::MESHER),
    ],
    invariants: |_| Ok(()),
    fuzz_words: &[
        "Wisps(",
        "Skeleton(",
        "Node(",
        "March(",
        "Toon(",
        "Springs(",
        "Bundle(",
        "Placed(",
        "Newton",
        "Polyline(pieces: 4)",
        "Two",
        "Three",
        "Rk4",
        "SemiImplicitEuler",
        "wisps:",
        "skeletons:",
        "threshold:",
        "toon:",
        "march:",
        "springs:",
        "bundles:",
        "nodes:",
        "outline:",
        "p:",
        "r:",
        "w:",
        "distance:",
        "max_steps:",
        "refine:",
        "step_scale:",
        "tones:",
        "shade:",
        "dark:",
        "t_diffuse:",
        "t_dark:",
        "t_specular:",
        "outline_width:",
        "outline_taper:",
        "diffuse_feather:",
        "dark_feather:",
        "halo_feather:",
        "halo_offset:",
        "halo_strength:",
        "halo_shadow:",
        "rim:",
        "rim_width:",
        "rim_feather:",
        "mass:",
        "sub_mass:",
        "ring:",
        "frame_time:",
        "substeps:",
        "integrator:",
        "hold_shape:",
        "collide:",
        "release_from:",
        "root:",
        "triangle:",
        "offset:",
    ],
    // Toon shading reads the shadow as steps (Sakai).
    shadow_steps: true,
    cache_fps: |_| None,
    opens: None,
    merge: |_, _, _, _| {},
    // Tracks finger skeletons from photographs (Sakai section 6).
    commands: &[crate::systems::kind::KindCommand {
        command: fingers::command,
        run: fingers::run_command,
    }],
};

fn build(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<Box<dyn HairSystem>> {
    Ok(Box::new(WispsSystem::new(gpu, scene, setup)?))
}

/// Toon colours, thresholds, march settings and the drawing path are a `Redraw` (the
/// meshed path meshes again where they change the surface or its outline scales). Skeletons, springs
/// and the head (collision, rest lengths, a mesh head's scalp and SDF) build the system
/// again, and so do the shared gravity (the natural lengths hold the drawn shape under it)
/// and the EFF's grid; the EFF's cells (the brush) act from the next step (`Resimulate`:
/// the stage rewrites them in the world the kernel binds, `systems::world`). Keyed wind,
/// the EFF's gust keys and head motion are read from the stage's forces at every step: no
/// change.
pub fn classify(old: &Scene, new: &Scene) -> Change {
    let grid = |s: &Scene| {
        crate::forces::Forces::new(&s.forces, &s.head)
            .eff
            .map(|e| (e.dims(), e.origin(), e.cell_size()))
    };
    let shape = |s: &Scene| {
        s.wisps().clone().map(|mut w| {
            w.toon = Default::default();
            w.march = Default::default();
            w.threshold = 0.0;
            w.draw = Default::default();
            w.mesh = Default::default();
            let gravity = s.forces.gravity;
            let moving = w.springs.is_some();
            (
                w,
                s.head.center,
                s.head.radii,
                s.head.mesh.clone(),
                moving.then(|| (gravity, grid(s))),
            )
        })
    };
    let moving = new.wisps().as_ref().is_some_and(|w| w.springs.is_some());
    if shape(old) != shape(new) {
        Change::Rebuild
    } else if moving && old.forces.eff != new.forces.eff {
        Change::Resimulate
    } else if old.wisps() != new.wisps() {
        Change::Redraw
    } else {
        Change::None
    }
}

/// Where the node positions come from.
enum Nodes {
    /// The drawn skeletons, posed by the head each frame (the buffer is bound by the
    /// curve pass; kept here so it lives as long as the system).
    Still(#[allow(dead_code)] wgpu::Buffer),
    /// The mass springs' primaries, already in world space.
    Springs(Box<springs_gpu::SpringsGpu>),
}

/// Toon wisps of one scene.
pub struct WispsSystem {
    pub wisps: Wisps,
    nodes: Nodes,
    pub curves: CurvePass,
    pub draw: MarchPass,
    cast: march::WispCast,
    /// The meshed path, built when the scene first draws with it.
    pub mesh: Option<Meshed>,
    frame_layout: wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
    variant: crate::gpu::pipeline::Variant,
}

/// The meshed path's state.
pub struct Meshed {
    pub pass: mesh_pass::MeshPass,
    /// Mesh again before the next frame (the surface or its outline scales changed).
    dirty: bool,
    /// The last meshing.
    pub last: MeshInfo,
    /// The GPU mesher, where the surface is polygonised on the GPU (`block::MeshOn`), and
    /// its plan with what it was made for (cell, threshold, reach).
    pub gpu: Option<mesh_gpu::Mesher>,
    plan: Option<((f64, f64, f64), mesh_gpu::Plan)>,
    /// Moving wisps' nodes at the last meshing on the CPU.
    meshed_nodes: Vec<[f32; 4]>,
}

/// What the last meshing cost and made.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshInfo {
    /// Wall time of `mesh::polygonise` (and, for moving wisps, reading their nodes back);
    /// on the GPU, of planning and recording the kernels.
    pub ms: f64,
    pub cell: f64,
    pub points: u64,
    pub triangles: usize,
    /// Meshings since the system was built.
    pub count: u64,
}

impl WispsSystem {
    pub fn new(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<WispsSystem> {
        let wisps = scene.wisps().clone().ok_or_else(|| KamiError::Invalid {
            file: String::new(),
            field: "wisps".into(),
            value: "None".into(),
            allowed: "a wisps block (the wisps system is built only for scenes with wisps)".into(),
        })?;
        march::check_limits(gpu, &wisps)?;
        // On a mesh head the roots go onto its scalp (the drawn shape moves with them).
        let wisps = crate::systems::wisps::block::on_mesh_head(&wisps, &scene.head)?;
        let nodes = match &wisps.springs {
            Some(sp) => {
                let forces = crate::forces::Forces::new(&scene.forces, &scene.head);
                if forces.gravity == DVec3::ZERO {
                    log::warn!(
                        "the wisps' springs feel no gravity: the scene's shared gravity \
                         (forces.gravity) is zero (set forces: ForcesDesc(gravity: \
                         (0.0, -980.0, 0.0)) for the weight in cm/s²)"
                    );
                }
                // The natural lengths are solved here (eq 24), once per build, under the
                // shared gravity.
                let lattice = springs::Lattice::build(&wisps, sp, &scene.head, &forces)?;
                Nodes::Springs(Box::new(springs_gpu::SpringsGpu::new(
                    gpu,
                    setup.world,
                    &lattice,
                    sp,
                )?))
            }
            None => Nodes::Still(crate::gpu::storage_buffer(
                &gpu.device,
                "wisp drawn nodes",
                bytemuck::cast_slice(&march::drawn_positions(&wisps)),
                wgpu::BufferUsages::empty(),
            )),
        };
        let positions = match &nodes {
            Nodes::Still(b) => b,
            Nodes::Springs(s) => s.positions(),
        };
        let curves = CurvePass::new(gpu, &wisps, positions)?;
        let draw = MarchPass::new(
            gpu,
            &curves,
            &wisps,
            setup.frame_layout,
            setup.format,
            setup.variant,
        )?;
        let cast =
            march::WispCast::new(gpu, &curves, setup.frame_layout, setup.shadow_cast_layout)?;
        let mut system = WispsSystem {
            wisps,
            nodes,
            curves,
            draw,
            cast,
            mesh: None,
            frame_layout: setup.frame_layout.clone(),
            format: setup.format,
            variant: setup.variant,
        };
        system.follow_draw(gpu)?;
        Ok(system)
    }

    fn moving(&self) -> bool {
        self.wisps.springs.is_some()
    }

    /// Whether this frame draws the mesh (`mesh_pass::auto_draws_mesh`).
    pub fn meshed(&self) -> bool {
        self.mesh.is_some()
    }

    /// Whether the meshed path polygonises on the GPU on this adapter (`block::MeshOn`).
    pub fn meshes_on_gpu(&self, device_type: wgpu::DeviceType) -> bool {
        match self.wisps.mesh.on {
            MeshOn::Gpu => true,
            MeshOn::Cpu => false,
            MeshOn::Auto => mesh_pass::auto_meshes_on_gpu(device_type, self.moving()),
        }
    }

    /// Build or drop the meshed path, and its GPU mesher, as `wisps.draw` and
    /// `wisps.mesh.on` say on this adapter.
    fn follow_draw(&mut self, gpu: &Gpu) -> Result<()> {
        let want = mesh_pass::auto_draws_mesh(self.wisps.draw, gpu.info.device_type, self.moving());
        let on_gpu = self.meshes_on_gpu(gpu.info.device_type);
        if want && self.mesh.is_none() {
            self.mesh = Some(Meshed {
                pass: mesh_pass::MeshPass::new(gpu, &self.frame_layout, self.format, self.variant)?,
                dirty: true,
                last: MeshInfo::default(),
                gpu: None,
                plan: None,
                meshed_nodes: Vec::new(),
            });
        } else if !want {
            self.mesh = None;
        }
        if let Some(m) = &mut self.mesh {
            if on_gpu && m.gpu.is_none() {
                m.gpu = Some(mesh_gpu::Mesher::new(gpu, &self.wisps)?);
                m.pass.clear();
            } else if !on_gpu && m.gpu.is_some() {
                m.gpu = None;
                m.plan = None;
                m.dirty = true;
            }
        }
        Ok(())
    }

    /// The cell the meshed path uses in `view`: `wisps.mesh.cell`, or where that is 0
    /// `mesh::auto_cell` of the wisps' radii, but no finer than `mesh::AUTO_CELL_PX` output
    /// pixels at the nearest point of the wisps' bounds (finer cells change no pixel there),
    /// and for moving wisps coarser under the viewer's budget.
    pub fn mesh_cell(&self, view: &View) -> f64 {
        if self.wisps.mesh.cell > 0.0 {
            return self.wisps.mesh.cell;
        }
        let (centre, radius) = self.bounds();
        let near = (view.eye - centre).length() - radius;
        let px = if near > 0.0 && view.focal_samples > 0.0 {
            near * view.samples_per_px.max(1.0) / view.focal_samples
        } else {
            0.0
        };
        let cell = mesh::auto_cell(&self.wisps).max(mesh::AUTO_CELL_PX * px);
        if self.moving() {
            // Moving wisps are meshed every frame: under the viewer's budget (`lod` below 1)
            // the cell grows as the strands widen, 1/sqrt(lod), up to `mesh::MOVING_COARSEST`
            // times (the image error stays near the bound there). Headless renders draw at
            // lod 1.
            cell * view.budget_widening().min(mesh::MOVING_COARSEST)
        } else {
            cell
        }
    }

    /// Mesh the wisps again where they moved or changed: a still hairstyle once, in the
    /// head's frame; moving wisps every frame their nodes moved, in world space, from the
    /// node positions the springs reached by the last frame (read back: the mesh trails the
    /// springs by a frame).
    fn remesh(&mut self, gpu: &Gpu, view: &View) -> Result<()> {
        let moving = self.moving();
        let (cell, kept) = self.kept_cell(view);
        let Some(m) = &mut self.mesh else {
            return Ok(());
        };
        if !m.dirty && !moving && kept {
            return Ok(());
        }
        let start = std::time::Instant::now();
        let segs = match &self.nodes {
            Nodes::Still(_) => curve::drawn_segments(&self.wisps),
            Nodes::Springs(s) => {
                let n = march::node_count(&self.wisps) as u64;
                let p: Vec<[f32; 4]> = crate::gpu::read_buffer(gpu, s.positions(), n * 16)?;
                // Settled springs: no node has moved `mesh::SETTLED` of a cell since the last
                // meshing, and nothing else changed, so the mesh stands.
                let moved = m
                    .meshed_nodes
                    .iter()
                    .zip(&p)
                    .map(|(a, b)| {
                        let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
                        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) as f64
                    })
                    .fold(0.0, f64::max)
                    .sqrt();
                if !m.dirty
                    && kept
                    && m.meshed_nodes.len() == p.len()
                    && moved < mesh::SETTLED * cell
                {
                    return Ok(());
                }
                let mut k = 0;
                let segs = self
                    .wisps
                    .skeletons
                    .iter()
                    .map(|sk| {
                        let nodes: Vec<(DVec3, f64, f64)> = sk
                            .nodes
                            .iter()
                            .map(|nd| {
                                let q = p[k];
                                k += 1;
                                (
                                    DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64),
                                    nd.r,
                                    nd.w,
                                )
                            })
                            .collect();
                        curve::segments(&nodes)
                    })
                    .collect();
                m.meshed_nodes = p;
                segs
            }
        };
        let outlines = mesh::wisp_outlines(&self.wisps, &segs);
        let polygon = mesh::polygonise(&mesh::Input {
            wisps: &segs,
            outlines: &outlines,
            taper: self.wisps.toon.outline_taper,
            threshold: self.wisps.threshold,
            method: self.wisps.march.distance,
            cell,
            frame: None,
        })?;
        m.pass.upload(gpu, &polygon)?;
        m.dirty = false;
        m.last = MeshInfo {
            ms: start.elapsed().as_secs_f64() * 1e3,
            cell,
            points: polygon.points,
            triangles: polygon.triangles(),
            count: m.last.count + 1,
        };
        Ok(())
    }

    /// The cell for `view` and whether it is the last meshing's. For still wisps the view's
    /// cell moves the mesh only past a factor (zooming about it re-meshes once, not every
    /// frame); moving wisps, meshed every frame they move, take the view's cell as it is
    /// (a factor would hold their budget's coarser cell off: 1.3 is inside 1.5).
    fn kept_cell(&self, view: &View) -> (f64, bool) {
        let cell = self.mesh_cell(view);
        let last = self.mesh.as_ref().map_or(0.0, |m| m.last.cell);
        let kept = last > 0.0
            && !self.moving()
            && self.wisps.mesh.cell == 0.0
            && (cell / last).ln().abs() < mesh::CELL_HYSTERESIS.ln()
            || last > 0.0 && cell == last;
        (if kept { last } else { cell }, kept)
    }

    /// Record the GPU mesher over this frame's segments (posed by `head`: the mesh is drawn
    /// as it is, in world space). Its plan is made again when the cell, threshold or reach
    /// change.
    fn remesh_gpu(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        view: &View,
        head: DMat4,
    ) -> Result<()> {
        let start = std::time::Instant::now();
        let (cell, _) = self.kept_cell(view);
        let (centre, radius) = self.bounds();
        let centre = head.transform_point3(centre);
        let key = (cell, self.wisps.threshold, radius);
        let Some(m) = &mut self.mesh else {
            return Ok(());
        };
        let plan = match m.plan {
            Some((k, p)) if k == key => p.moved_to(centre, radius),
            _ => {
                let lim = gpu.device.limits();
                let limit = lim.max_storage_buffer_binding_size.min(lim.max_buffer_size);
                mesh_gpu::plan(&self.wisps, centre, radius, cell, limit)?
            }
        };
        m.plan = Some((key, plan));
        let Some(g) = &mut m.gpu else {
            return Ok(());
        };
        g.record(gpu, enc, &self.curves, &self.wisps, plan);
        m.dirty = false;
        m.last = MeshInfo {
            ms: start.elapsed().as_secs_f64() * 1e3,
            cell,
            points: 0,
            triangles: 0,
            count: m.last.count + 1,
        };
        Ok(())
    }

    /// The mass springs on the GPU, when the wisps move (tests and tools read them back).
    pub fn springs(&self) -> Option<&springs_gpu::SpringsGpu> {
        match &self.nodes {
            Nodes::Springs(s) => Some(s),
            Nodes::Still(_) => None,
        }
    }
}

impl HairSystem for WispsSystem {
    fn kind(&self) -> &'static str {
        KIND.name
    }

    fn bounds(&self) -> (DVec3, f64) {
        march::bounds(&self.wisps, self.moving())
    }

    fn step(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        frames: u32,
    ) -> Result<StepInfo> {
        match &mut self.nodes {
            Nodes::Still(_) => Ok(StepInfo::default()),
            Nodes::Springs(s) => {
                s.record(gpu, enc, ctx.forces, ctx.frame, frames)?;
                Ok(StepInfo {
                    substeps: frames * self.wisps.springs.as_ref().map_or(0, |p| p.substeps),
                    capped: false,
                })
            }
        }
    }

    fn prepare(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        view: &View,
    ) -> Result<()> {
        let model = match &self.nodes {
            Nodes::Still(_) => ctx.head,
            Nodes::Springs(_) => WORLD,
        };
        self.curves.set_threshold(self.wisps.threshold);
        // The segments feed the shadow cast whichever way the surface is drawn.
        self.curves.record(gpu, enc, model, self.moving());
        let uniform = march::draw_uniform(&self.wisps, ctx.head, self.curves.segment_count);
        if self.meshed() {
            let on_gpu = self.mesh.as_ref().is_some_and(|m| m.gpu.is_some());
            let drawn_model = if on_gpu {
                self.remesh_gpu(gpu, enc, view, ctx.head)?;
                WORLD
            } else {
                self.remesh(gpu, view)?;
                model
            };
            let outline_px = self.wisps.toon.outline_width;
            let eps_per_t = outline_px * view.samples_per_px.max(1.0) / view.focal_samples;
            if let Some(m) = &mut self.mesh {
                m.pass.write(gpu, &uniform, drawn_model, eps_per_t);
            }
            return Ok(());
        }
        self.draw
            .prepare(gpu, enc, &self.curves, view, self.wisps.toon.outline_width)?;
        self.draw.write(gpu, &uniform);
        Ok(())
    }

    fn draw_opaque(&self, pass: &mut wgpu::RenderPass<'_>) {
        match &self.mesh {
            Some(m) => match m.gpu.as_ref().and_then(|g| g.buffers()) {
                Some(b) => m.pass.draw_gpu(pass, b),
                None => m.pass.draw(pass),
            },
            None => self.draw.draw(pass),
        }
    }

    fn draw(&self, _pass: &mut wgpu::RenderPass<'_>, _view: &View) {}

    fn draws_in_compute(&self) -> bool {
        !self.meshed() && self.draw.in_compute()
    }

    fn draw_compute(&self, pass: &mut wgpu::ComputePass<'_>) {
        if !self.meshed() {
            self.draw.march(pass);
        }
    }

    fn casts(&self) -> bool {
        true
    }

    fn cast_shadow(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.cast.cast(pass);
    }

    fn reset(&mut self, gpu: &Gpu) -> Result<()> {
        if let Nodes::Springs(s) = &mut self.nodes {
            s.reset(gpu)?;
        }
        self.curves.invalidate();
        Ok(())
    }

    fn set_variant(&mut self, gpu: &Gpu, variant: crate::gpu::pipeline::Variant) {
        self.variant = variant;
        self.draw.set_variant(gpu, variant);
        if let Some(m) = &mut self.mesh {
            m.pass.set_variant(gpu, variant);
        }
    }

    /// A `Redraw`: toon colours, thresholds, march settings and the drawing path; a
    /// `Resimulate`: those (the EFF's new cells are the world's, which the stage rewrites).
    /// The mesh is made again where the surface or its outline scales change.
    fn update(&mut self, gpu: &Gpu, scene: &Scene, change: Change) -> Result<()> {
        if let (Change::Redraw | Change::Resimulate, Some(w)) = (change, scene.wisps()) {
            let surface = |x: &Wisps| (x.threshold, x.toon.outline_taper, x.march.distance, x.mesh);
            let remesh = surface(&self.wisps) != surface(w);
            self.wisps.toon = w.toon.clone();
            self.draw.set_on(gpu, w.march.on);
            self.wisps.march = w.march;
            self.wisps.threshold = w.threshold;
            self.wisps.draw = w.draw;
            self.wisps.mesh = w.mesh;
            self.follow_draw(gpu)?;
            if let Some(m) = &mut self.mesh {
                m.dirty |= remesh;
            }
        }
        Ok(())
    }

    fn stats(&self) -> SystemStats {
        let n = self.wisps.skeletons.len() as u64;
        SystemStats {
            strands: n,
            segments: self.curves.segment_count as u64,
            simulated: if self.moving() { n } else { 0 },
            drawn: n,
            raster: None,
        }
    }

    /// Tile lists or ray lists that overflowed in the last frame (counted by the march).
    fn warnings(&self, gpu: &Gpu) -> Result<Vec<String>> {
        if let Some(m) = &self.mesh {
            let Some(g) = &m.gpu else {
                return Ok(Vec::new());
            };
            let c = g.counters(gpu)?;
            return Ok(c
                .overflowed()
                .then(|| {
                    format!(
                        "the GPU mesher dropped {} bricks, {} vertices and {} quads past its \
                         capacities ({} brick lists cut): raise wisps.mesh.cell or mesh on the \
                         CPU (wisps.mesh.on=cpu)",
                        c.slots_over, c.vertices_over, c.quads_over, c.lists_cut
                    )
                })
                .into_iter()
                .collect());
        }
        Ok(self
            .draw
            .read_stats(gpu)?
            .and_then(|s| s.warning())
            .into_iter()
            .collect())
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}

/// Identity for nodes the springs already place in world space.
const WORLD: DMat4 = DMat4::IDENTITY;
