//! Van Gelder & Wilhelms: interactive fur on triangle meshes. Roots, coats and the shape
//! rules are set up once on the CPU (`setup`, with `setup::hair_points` as the f64
//! reference of a hair); every frame the GPU regenerates the hairs a coat draws from the
//! root table on the (possibly moving) mesh (`generate`), with distance culling and the
//! viewer's level of detail, and draws the skin and the hairs (`draw`).
//!
//! The fur has no state between frames: its hairs are a function of the clock's frame and
//! the camera, so `step` and `reset` have nothing to do. `prepare` regenerates only when
//! that function's inputs changed since the last generation (`GenKey`): a still mesh (no
//! motion, no skin) at the same culling factor keeps last frame's hairs.
//!
//! Culling is the strand share of the screen-space level of detail shared with strand hair
//! (`systems::lod`); `render.lod_tolerance_px = 0` turns it off with the rest of it. The
//! ribbon styles draw every k-th node by the same chord-error rule as strand hair (k per coat,
//! from its longest hair's segment length); tubes keep all their segments.

pub mod block;
pub mod draw;
pub mod generate;
pub mod gpu_data;
pub mod panel;
pub mod setup;
pub mod splat;

use crate::error::Result;
use crate::gpu::strands::{NODE, RECORD};
use crate::gpu::Gpu;
use crate::scene::StrandRaster;
use crate::shaders::wgsl;
use crate::systems::kind::Kind;
use crate::systems::raster;
use crate::systems::scene::Scene;
use crate::systems::system::{
    Change, DrawSetup, FrameCtx, HairSystem, RasterChoice, StepInfo, SystemStats, View,
};
use glam::DVec3;
use setup::{culling_factor, FurSetup};

/// Fur generation (Van Gelder & Wilhelms).
pub const GENERATE: &str = wgsl!(
    "common/ellipsoid.wgsl",
    "common/random.wgsl",
    "common/deform.wgsl",
    "fur/generate.wgsl",
);

/// Fur drawing: ribbons and tubes with Van Gelder & Wilhelms' shading normals.
pub const DRAW: &str = wgsl!(
    "common/strands.wgsl",
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/random.wgsl",
    "common/coverage_mask.wgsl",
    "common/coverage.wgsl",
    "common/hair_bsdf.wgsl",
    "fur/shade.wgsl",
    "fur/draw.wgsl",
);

/// Fur's thin coats through the compute rasteriser (`shaders/common/splat.wgsl`), reading
/// a single-sampled scene depth.
pub const SPLAT: &str = wgsl!(splat "common/depth_single.wgsl";
    "common/random.wgsl", "fur/shade.wgsl", "fur/splat.wgsl");

/// The same over a multisampled scene depth.
pub const SPLAT_MSAA: &str = wgsl!(splat "common/depth_msaa.wgsl";
    "common/random.wgsl", "fur/shade.wgsl", "fur/splat.wgsl");

/// Fur's shadow cast (`stage::shadow`).
pub const CAST: &str = wgsl!(
    "common/strands.wgsl",
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/shadow_cast.wgsl",
    "fur/cast.wgsl",
);

/// The fur mesh's skin: its draw and its cast into the skin map.
pub const SKIN: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/shadow_cast.wgsl",
    "common/deform.wgsl",
    "common/hair_bsdf.wgsl",
    "fur/skin.wgsl"
);

pub const KIND: Kind = Kind {
    name: "fur",
    block: "fur",
    called: "fur",
    in_scene: |s| s.fur().is_some(),
    validate: block::validate,
    read_files: block::read_files,
    files: block::files,
    counts: block::counts,
    counted: Some("fur.hairs"),
    check_limits,
    build,
    classify,
    panels: panel::PANELS,
    ui: || Box::new(panel::FurUi),
    // The hair and segment counts (`Scene::counts`) hold the fur's.
    summary: |_| None,
    moves: |s| s.fur().as_ref().is_some_and(|f| f.moves()),
    scenes: &[
        "fur",
        "fur_fig9",
        "fur_line",
        "fur_polyline",
        "fur_curve",
        "fur_tube",
        "fur_lion_head",
        "hair_and_fur",
        "fur_creature",
    ],
    shaders: &[
        ("fur/generate", GENERATE),
        ("fur/draw", DRAW),
        ("fur/splat", SPLAT),
        ("fur/splat_msaa", SPLAT_MSAA),
        ("fur/skin", SKIN),
        ("fur/cast", CAST),
    ],
    invariants: |_| Ok(()),
    fuzz_words: &[
        "Fur(",
        "Region(",
        "Coat(",
        "FurMaterial(",
        "Culling(",
        "MeshMotion(",
        "Critter",
        "CgalDemo(\"lion-head.off\")",
        "Line",
        "Polyline",
        "Curve",
        "Tube",
        "fur:",
        "hairs:",
        "regions:",
        "coats:",
        "culling:",
        "motion:",
        "skin:",
        "length_scale:",
        "share:",
        "relative_length:",
        "normal_randomize:",
        "end_randomize:",
        "direction_weight:",
        "style:",
        "enabled:",
        "full_distance:",
        "wavelength:",
    ],
    shadow_steps: false,
    cache_fps: |_| None,
    opens: None,
    merge: |_, _, _, _| {},
    commands: &[],
};

/// The hair slots at full density against the storage-binding limit, before the mesh is
/// read. Random rounding adds at most one hair per triangle and coat, which only the mesh
/// knows: `StrandBuffers::from_runs` checks the exact sizes again when they are allocated.
fn check_limits(gpu: &Gpu, scene: &Scene) -> Result<()> {
    let Some(f) = scene.fur() else { return Ok(()) };
    let shares: f64 = f.coats.iter().map(|c| c.share).sum();
    let (mut strands, mut nodes) = (0u64, 0u64);
    for c in &f.coats {
        let n = (f.hairs as f64 * c.share / shares).ceil() as u64;
        strands += n;
        nodes += n * (c.style.segments() as u64 + 1);
    }
    gpu.check_storage_size("the fur vertex buffer", nodes * NODE)?;
    gpu.check_storage_size("the fur strand table", strands * RECORD)?;
    gpu.check_storage_size("the fur strand info", strands * generate::INFO)
}

fn build(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<Box<dyn HairSystem>> {
    Ok(Box::new(FurSystem::new(gpu, scene, setup)?))
}

/// Colours, shininess and widths are uniforms written every frame: only they change without
/// a rebuild. Anything else (hairs, lengths, regions, coats, mesh, motion, seed) allocates
/// the roots again (fast) and regenerates.
pub fn classify(old: &Scene, new: &Scene) -> Change {
    let shape = |s: &Scene| {
        s.fur().clone().map(|mut f| {
            f.skin = [0.0; 3];
            for c in &mut f.coats {
                c.material = Default::default();
            }
            (s.seed, f)
        })
    };
    if shape(old) != shape(new) {
        Change::Rebuild
    } else if old.fur() != new.fur() || old.render.shading != new.render.shading {
        Change::Redraw
    } else {
        Change::None
    }
}

/// Fur of a scene: the set-up on the CPU, the generator and the draw on the GPU.
pub struct FurSystem {
    pub setup: FurSetup,
    pub generator: generate::FurGpu,
    draw: draw::FurPass,
    /// Hairs drawn per coat this frame.
    pub drawn: Vec<u32>,
    /// Width factor of this frame's hairs (culling and level of detail draw fewer, wider).
    pub width_scale: f64,
    /// Node step per coat this frame (ribbons; the screen-space level of detail).
    pub steps: Vec<u32>,
    /// Widen culled hair to keep the coverage (off only to measure what it buys).
    pub compensate_width: bool,
    /// What the hairs on the GPU were last generated from (`None`: never, or edited since).
    last_gen: Option<GenKey>,
    /// Generations recorded since the system was built.
    pub generations: u64,
    /// The scene's shading (a coat's own overrides it).
    pub shading: crate::scene::Shading,
    /// Ribbons, the compute rasteriser or the choice by width (`render.strands`), for the
    /// line, polyline and curve coats (tubes are always triangles).
    raster: StrandRaster,
    /// The widest thin coat's root width, world units: `Auto`'s width.
    widest: f64,
    /// `Auto`'s switch point on this adapter (`systems::raster`), samples.
    compute_up_to: f64,
    /// This frame's choice (`prepare`): the compute rasteriser rather than ribbons.
    in_compute: bool,
    /// The widest thin hair's width in samples at the last `prepare`.
    pub width_samples: f64,
}

/// The widest root width of the coats drawn as ribbons or by the compute rasteriser (not
/// tubes), world units.
fn widest(coats: &[block::Coat]) -> f64 {
    coats
        .iter()
        .filter(|c| c.style != block::FurStyle::Tube)
        .map(|c| c.material.width)
        .fold(0.0, f64::max)
}

/// The inputs of a generation: the frame (only when the mesh moves) and the culling factor
/// times the level of detail.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GenKey {
    frame: Option<f64>,
    factor: f64,
}

/// A fur hair's width at the tip as a share of its root width: every fur shader
/// (`ribbon_width` in `shaders/fur/shade.wgsl`, the tubes, the shadow caster) tapers it
/// linearly to this, and the exports carry the same taper.
pub const TIP_WIDTH: f64 = 0.5;

/// The drawn width at node `j` of `nodes` (0 the root), root width `root`: the shaders'
/// linear taper to [`TIP_WIDTH`].
pub fn drawn_width(root: f64, j: usize, nodes: usize) -> f64 {
    let along = j as f64 / (nodes.max(2) - 1) as f64;
    root * (1.0 + (TIP_WIDTH - 1.0) * along)
}

/// Every hair of every coat at full density (no distance culling) at `frame`, from the f64
/// reference the GPU generator matches: the polylines, the coat's width at each point as
/// drawn (tapered root to tip, [`drawn_width`]) and diffuse colour.
pub fn export_fur(setup: &FurSetup, frame: f64) -> crate::formats::Groom {
    export_fur_culled(setup, frame, 1.0, 1.0)
}

/// [`export_fur`] for the hairs drawn at culling factor `c` (each triangle's first hairs,
/// `FurSetup::culled_offsets`), their widths times `width_scale` (the widening that keeps
/// the coverage of the culled hairs).
pub fn export_fur_culled(
    setup: &FurSetup,
    frame: f64,
    c: f64,
    width_scale: f64,
) -> crate::formats::Groom {
    let mut g = crate::formats::Groom {
        widths: Some(Vec::new()),
        colors: Some(Vec::new()),
        ..Default::default()
    };
    for (ci, coat) in setup.coats.iter().enumerate() {
        let m = &setup.fur.coats[ci].material;
        let off = setup.culled_offsets(ci, c);
        for t in 0..coat.first.len() {
            for h in coat.first[t]..coat.first[t] + (off[t + 1] - off[t]) {
                let nodes = setup::hair_points(setup, ci, t, h, frame).nodes;
                g.counts.push(nodes.len() as u32);
                for (j, p) in nodes.iter().enumerate() {
                    g.points.push([p.x as f32, p.y as f32, p.z as f32]);
                    g.widths.as_mut().unwrap().push(drawn_width(
                        m.width * width_scale,
                        j,
                        nodes.len(),
                    ) as f32);
                    g.colors.as_mut().unwrap().push(m.diffuse);
                }
            }
        }
    }
    g
}

impl FurSystem {
    pub fn new(gpu: &Gpu, scene: &Scene, draw_setup: &DrawSetup) -> Result<FurSystem> {
        let fur = scene
            .fur()
            .as_ref()
            .ok_or_else(|| crate::KamiError::Invalid {
                file: String::new(),
                field: "fur".into(),
                value: "None".into(),
                allowed: "a fur block (the fur system is built only for scenes with fur)".into(),
            })?;
        let setup = FurSetup::new(fur, scene.seed)?;
        let generator = generate::FurGpu::new(gpu, &setup)?;
        let mut draw = draw::FurPass::new(
            gpu,
            draw_setup.frame_layout,
            draw_setup.splat_layouts,
            draw_setup.shadow_cast_layout,
            draw_setup.format,
            draw_setup.variant,
        )?;
        draw.set_fur(gpu, &setup, &generator);
        Ok(FurSystem {
            steps: vec![1; setup.coats.len()],
            drawn: vec![0; setup.coats.len()],
            setup,
            generator,
            draw,
            width_scale: 1.0,
            compensate_width: true,
            last_gen: None,
            generations: 0,
            shading: scene.render.shading,
            widest: widest(&fur.coats),
            raster: scene.render.strands,
            compute_up_to: crate::systems::raster::switch_for(KIND.name, &gpu.info),
            in_compute: scene.render.strands == StrandRaster::Compute,
            width_samples: 0.0,
        })
    }

    /// Whether the mesh moves with the clock (a motion or a skin): then every frame's hairs
    /// differ.
    pub fn moving(&self) -> bool {
        self.setup.fur.motion.is_some() || self.setup.skin.is_some()
    }

    /// Generate again on the next `prepare` even if nothing changed (to time generation).
    pub fn invalidate(&mut self) {
        self.last_gen = None;
    }

    /// Hairs allocated over all coats.
    pub fn total(&self) -> u64 {
        self.setup.coats.iter().map(|c| c.total as u64).sum()
    }
}

impl HairSystem for FurSystem {
    fn kind(&self) -> &'static str {
        KIND.name
    }

    fn bounds(&self) -> (DVec3, f64) {
        self.setup.bounds()
    }

    fn step(
        &mut self,
        _gpu: &Gpu,
        _enc: &mut wgpu::CommandEncoder,
        _ctx: &FrameCtx,
        _frames: u32,
    ) -> Result<StepInfo> {
        Ok(StepInfo::default())
    }

    /// Generate this frame's hairs: culling from the camera's distance to the model, times
    /// the level of detail, which widens hair by only 1/sqrt(lod).
    fn prepare(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        view: &View,
    ) -> Result<()> {
        let bounds = self.setup.bounds();
        let c = if view.lod_tolerance_px > 0.0 {
            culling_factor(
                &self.setup.fur,
                bounds,
                view.fov_y,
                (view.eye - bounds.0).length(),
            )
        } else {
            1.0
        };
        let lod = view.lod.clamp(1e-3, 1.0);
        let frame = ctx.time();
        let key = GenKey {
            frame: self.moving().then_some(frame),
            factor: c * lod,
        };
        if self.last_gen != Some(key) {
            self.generator
                .record(gpu, enc, &self.setup, frame, c * lod)?;
            self.last_gen = Some(key);
            self.generations += 1;
        }
        self.drawn.clone_from(&self.generator.drawn);
        self.width_scale = if self.compensate_width {
            1.0 / (c * lod.sqrt())
        } else {
            1.0
        };
        let seen = crate::systems::lod::Seen {
            center: bounds.0,
            radius: bounds.1,
            eye: view.eye,
            fov_y: view.fov_y,
            height_px: view.height_px,
        };
        let longest = self.setup.lengths.iter().cloned().fold(0.0, f64::max);
        self.steps = self
            .setup
            .fur
            .coats
            .iter()
            .map(|c| {
                let seg_len = longest * c.relative_length / c.style.segments() as f64;
                crate::systems::lod::segment_step(
                    seg_len,
                    crate::systems::lod::NOMINAL_TURN,
                    seen.px_per_unit(),
                    view.lod_tolerance_px,
                )
            })
            .collect();
        self.draw.prepare(
            gpu,
            &self.setup,
            frame,
            self.width_scale,
            &self.steps,
            self.shading,
        );
        self.draw.set_drawn(gpu, &self.drawn);
        self.width_samples = raster::width_in_samples(
            self.widest,
            self.width_scale,
            view.focal_samples,
            view.eye,
            bounds.0,
            bounds.1,
        );
        self.in_compute = raster::draws_in_compute(
            self.raster,
            self.width_samples,
            self.compute_up_to,
            self.in_compute,
        );
        Ok(())
    }

    fn draw_opaque(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.draw.draw_skin(pass);
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, _view: &View) {
        self.draw
            .draw_hairs(pass, &self.drawn, &self.steps, !self.splats());
    }

    fn splats(&self) -> bool {
        self.in_compute && self.draw.can_splat() && self.draw.has_thin_coats()
    }

    fn splat(&self, pass: &mut wgpu::ComputePass<'_>) {
        if self.splats() {
            let hairs = self.setup.coats.iter().map(|c| c.total).sum::<u32>();
            self.draw.splat(pass, hairs);
        }
    }

    fn casts(&self) -> bool {
        true
    }

    /// The skin is opaque: it shadows the hair behind it (the skin map).
    fn casts_opaque(&self) -> bool {
        true
    }

    fn cast_shadow(&self, pass: &mut wgpu::ComputePass<'_>) {
        let hairs = self.setup.coats.iter().map(|c| c.total).sum::<u32>();
        self.draw.cast(pass, hairs);
        self.draw.cast_skin(pass);
    }

    fn reset(&mut self, _gpu: &Gpu) -> Result<()> {
        Ok(())
    }

    fn set_variant(&mut self, gpu: &Gpu, variant: crate::gpu::pipeline::Variant) {
        self.draw.set_variant(gpu, variant);
    }

    /// A `Redraw`: new materials and skin colour (written with the next frame's uniforms).
    fn update(&mut self, _gpu: &Gpu, scene: &Scene, change: Change) -> Result<()> {
        // An edit: generate again on the next prepare, whatever it changed.
        self.last_gen = None;
        if let (Change::Redraw, Some(f)) = (change, scene.fur()) {
            for (mine, new) in self.setup.fur.coats.iter_mut().zip(&f.coats) {
                mine.material = new.material.clone();
            }
            self.setup.fur.skin = f.skin;
        }
        self.shading = scene.render.shading;
        if self.raster != scene.render.strands {
            self.raster = scene.render.strands;
            self.in_compute = self.raster == StrandRaster::Compute;
        }
        if let Some(f) = scene.fur() {
            self.widest = widest(&f.coats);
        }
        Ok(())
    }

    fn stats(&self) -> SystemStats {
        let segments = self
            .setup
            .fur
            .coats
            .iter()
            .zip(&self.setup.coats)
            .map(|(c, a)| a.total as u64 * c.style.segments() as u64)
            .sum();
        SystemStats {
            strands: self.total(),
            segments,
            simulated: 0,
            drawn: self.drawn.iter().map(|&d| d as u64).sum(),
            raster: self.draw.has_thin_coats().then(|| RasterChoice {
                compute: self.splats(),
                width_samples: self.width_samples,
            }),
        }
    }

    fn export(&self, _gpu: &Gpu, ctx: &FrameCtx) -> Result<Option<crate::formats::Groom>> {
        Ok(Some(export_fur(&self.setup, ctx.time())))
    }

    /// The hairs the last generation drew (its culling factor) at their drawn widths.
    fn export_drawn(
        &self,
        _gpu: &Gpu,
        ctx: &FrameCtx,
    ) -> Result<Option<crate::systems::system::DrawnHair>> {
        let c = self.last_gen.map_or(1.0, |k| k.factor);
        Ok(Some(crate::systems::system::DrawnHair {
            groom: export_fur_culled(&self.setup, ctx.time(), c, self.width_scale),
            absorption: None,
        }))
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}
