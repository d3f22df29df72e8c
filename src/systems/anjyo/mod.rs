//! Anjyo, Usami & Kurihara 1992: cantilever-beam hairstyles on an ellipsoid head
//! (`groom`, `cantilever` + `cantilever_gpu`), one-dimensional projective dynamics
//! (`projective` + `projective_gpu`, driven by `simulation`; with a guide share only the
//! guides, the rest rebuilt by `follow` + `follow_gpu`), and ribbons with Anjyo's
//! anisotropic shading (`draw`). Every GPU kernel has its f64 CPU reference beside it.
//!
//! Per scene: the pores are drawn on the CPU (`groom::prepare`), bent once on the GPU into
//! the strand buffers, and — when the scene has `dynamics` — moved every frame by the
//! projective kernel from the forces of the stage's clock. A copy of the rest pose is kept
//! (only for dynamic scenes) so `reset` needs no re-groom.

pub mod block;
pub mod cantilever;
pub mod cantilever_gpu;
pub mod draw;
pub mod elastica;
pub mod follow;
pub mod follow_gpu;
pub mod gpu_data;
pub mod groom;
pub mod imported;
pub mod panel;
pub mod playback;
pub mod projective;
pub mod projective_gpu;
pub mod simulation;
pub mod splat;
pub mod vary;

use super::lod::{screen_lod, ScreenLod, Seen};
use super::raster;
use crate::error::Result;
use crate::gpu::strands::{StrandBuffers, NODE, RECORD};
use crate::gpu::Gpu;
use crate::scene::StrandRaster;
use crate::shaders::wgsl;
use crate::systems::kind::Kind;
use crate::systems::scene::Scene;
use crate::systems::system::{
    Change, DrawSetup, FrameCtx, HairSystem, RasterChoice, StepInfo, SystemStats, View,
};
use glam::DVec3;
use gpu_data::GpuMaterial;
use groom::GroomInput;
use simulation::Simulation;

/// Cantilever bending (groom).
pub const CANTILEVER: &str = wgsl!(
    world;
    "common/strands.wgsl",
    "common/rotate.wgsl",
    "common/loads.wgsl",
    "anjyo/cantilever.wgsl",
);

/// Projective dynamics (Anjyo section 3).
pub const PROJECTIVE: &str = wgsl!(
    world;
    "common/rotate.wgsl",
    "common/random.wgsl",
    "anjyo/projective.wgsl",
);

/// Followers rebuilt from their guides (`follow`).
pub const FOLLOW: &str = wgsl!(world; "anjyo/follow.wgsl");

/// Hair ribbons with Anjyo's anisotropic specular.
pub const DRAW: &str = wgsl!(
    "common/strands.wgsl",
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/random.wgsl",
    "common/coverage_mask.wgsl",
    "common/coverage.wgsl",
    "common/hair_bsdf.wgsl",
    "common/strand_vary.wgsl",
    "common/strand_shade.wgsl",
    "anjyo/draw.wgsl",
);

/// The strands' shadow cast (`stage::shadow`).
pub const CAST: &str = wgsl!(
    "common/strands.wgsl",
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "common/shadow_cast.wgsl",
    "common/hair_bsdf.wgsl",
    "common/random.wgsl",
    "common/strand_vary.wgsl",
    "common/strand_shade.wgsl",
    "common/strand_drawn.wgsl",
    "anjyo/cast.wgsl",
);

/// The compute rasteriser for thin strands, reading a single-sampled scene depth.
pub const SPLAT: &str = wgsl!(splat "common/depth_single.wgsl";
    "common/random.wgsl", "common/strand_vary.wgsl", "common/strand_shade.wgsl",
    "anjyo/splat.wgsl");

/// The same over a multisampled scene depth.
pub const SPLAT_MSAA: &str = wgsl!(splat "common/depth_msaa.wgsl";
    "common/random.wgsl", "common/strand_vary.wgsl", "common/strand_shade.wgsl",
    "anjyo/splat.wgsl");

pub const KIND: Kind = Kind {
    name: "anjyo",
    block: "groups",
    called: "hair group",
    in_scene: |s| !s.groups().is_empty(),
    validate: block::validate,
    read_files: block::read_files,
    files: block::files,
    counts,
    counted: Some("groups[..].count"),
    check_limits,
    build,
    classify,
    panels: panel::PANELS,
    ui: || Box::<panel::AnjyoUi>::default(),
    // The hair and segment counts (`Scene::counts`) are Anjyo's and fur's already.
    summary: |_| None,
    // Simulated, or playing a file's frames.
    moves: |s| {
        s.dynamics().is_some()
            || s.groups()
                .iter()
                .any(|g| g.file.as_ref().is_some_and(|f| f.frames.is_some()))
    },
    scenes: &[
        "gust",
        "bob",
        "swept_back",
        "ponytail",
        "short_cut",
        "pseudo_force",
        "pseudo_force_off",
        "stiffness_smooth",
        "stiffness_free",
    ],
    shaders: &[
        ("anjyo/cantilever", CANTILEVER),
        ("anjyo/projective", PROJECTIVE),
        ("anjyo/follow", FOLLOW),
        ("anjyo/draw", DRAW),
        ("anjyo/splat", SPLAT),
        ("anjyo/splat_msaa", SPLAT_MSAA),
        ("anjyo/cast", CAST),
    ],
    invariants: block::invariants,
    fuzz_words: FUZZ_WORDS,
    shadow_steps: false,
    // The first hair group playing a file cache sets the rate.
    cache_fps: |s| {
        s.groups()
            .iter()
            .find_map(|g| g.file.as_ref()?.frames.as_ref().map(|f| f.fps))
    },
    opens: Some(imported::scene_of),
    merge: block::merge_groups,
    commands: &[],
};

/// The words of Anjyo's blocks (hair groups, their roots and cuts, the dynamics) for the
/// scene fuzzer.
#[rustfmt::skip]
const FUZZ_WORDS: &[&str] = &[
    "HairGroup(", "Roots(", "Material(", "Dynamics(", "Inertia(", "PseudoForce(",
    "groom_load:", "Stiffness(", "Fluctuation(", "Cut(", "Normal", "Blend(dir: (1.0, 0.0, 0.0), weight: 0.5)",
    "Paper", "Converged(", "Uniform(force: (1.0, 0.0, 0.0))",
    "Toward(point: (0.0, 0.0, 0.0), strength: 1.0)", "Above(0.0)", "Below(0.0)",
    "HalfSpace(normal: (0.0, 0.0, 1.0), offset: 0.0)", "ByPoreHeight(low: (0.0, 1), high: (1.0, 2))",
    "Near(center: (0.0, 0.0, 0.0), radius: 1.0)", "groups:", "dynamics:", "roots:", "count:",
    "segments:", "length_jitter:", "direction_jitter:", "rigidity:", "bending:", "loads:",
    "cuts:", "dynamic:", "theta:", "phi:", "on:", "hairline: Some([(0.0, 90.0), (180.0, 60.0)])",
    "rule:", "ka:", "ka_spread:", "ks:", "kd:", "tip_width:", "dt:", "steps_per_frame:",
    "density:", "damping:", "inertia:", "pseudo_force:", "stiffness:", "fluctuation:",
    "collision:", "max_substeps:", "root:", "tip:", "top:", "top_height:", "top_blend:",
    "alpha:", "epsilon_pore:", "epsilon_tip:", "near:", "start:", "end:", "max_iterations:",
    "tolerance:", "guides:", "variation:", "Variation(", "melanin:", "tint:",
];

/// Anjyo hair of one scene: the groom, its simulation if the scene has dynamics, the draw.
pub struct AnjyoSystem {
    pub input: GroomInput,
    pub hair: StrandBuffers,
    pub sim: Option<Simulation>,
    /// The groomed rest pose, for `reset` (dynamic scenes only).
    rest: Option<wgpu::Buffer>,
    draw: draw::StrandsPass,
    /// The groups' looks, for strand-file export.
    /// The scene's groups as last applied (the materials and file looks an export writes).
    groups: Vec<block::HairGroup>,
    bounds: (DVec3, f64),
    counts: (u64, u64),
    lod: f64,
    /// The longest segment of any group (the screen-space level of detail's chord error).
    seg_len: f64,
    /// This frame's screen-space level of detail (`systems::lod`).
    pub screen: ScreenLod,
    /// Ribbons, the compute rasteriser or the choice by width (`render.strands`).
    raster: StrandRaster,
    /// The widest strand, world units (root or tip, material or file): `Auto`'s width.
    widest: f64,
    /// `Auto`'s switch point on this adapter (`systems::raster`), samples.
    compute_up_to: f64,
    /// This frame's choice (`prepare`): the compute rasteriser rather than ribbons.
    in_compute: bool,
    /// The widest strand's width in samples at the last `prepare`.
    pub width_samples: f64,
    /// Groups that play their file's frames (`playback`).
    pub playback: Option<playback::Playback>,
}

/// Check the hair buffers against the storage-binding limit before allocating them.
fn check_limits(gpu: &Gpu, scene: &Scene) -> Result<()> {
    // The cantilever binds the most storage buffers of any kernel (seven and the world's
    // three).
    gpu.check_storage_buffers("Anjyo's cantilever", crate::gpu::STORAGE_BUFFERS_PER_STAGE)?;
    let (strands, segments) = counts(scene);
    gpu.check_storage_size("the hair vertex buffer", (segments + strands) * NODE)?;
    gpu.check_storage_size("the hair strand table", strands * RECORD)?;
    Ok(())
}

fn build(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<Box<dyn HairSystem>> {
    Ok(Box::new(AnjyoSystem::new(gpu, scene, setup)?))
}

/// A sphere around the head and the longest possible hair of every group.
pub fn scene_bounds(scene: &Scene) -> (DVec3, f64) {
    let c = DVec3::from(scene.head.center);
    let head_r = scene.head.radii.iter().cloned().fold(0.0, f64::max);
    let mut r = head_r;
    for g in scene.groups() {
        if let Some(f) = &g.file {
            // A file's strands reach as far as their farthest point, in any frame.
            let reach = |pts: &[[f32; 3]]| {
                pts.iter()
                    .map(|p| (DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) - c).length())
                    .fold(0.0, f64::max)
            };
            let mut far = f.groom.as_ref().map_or(0.0, |gr| reach(&gr.points));
            for pts in f.frames.iter().flat_map(|fr| fr.points.iter()) {
                far = far.max(reach(pts));
            }
            r = r.max(far);
            continue;
        }
        let (hc, hr) = match &g.roots.on {
            Some(e) => (
                DVec3::from(e.center),
                e.radii.iter().cloned().fold(0.0, f64::max),
            ),
            None => (c, head_r),
        };
        let reach = (hc - c).length() + hr + g.length * (1.0 + g.length_jitter);
        r = r.max(reach);
    }
    (c, r)
}

/// The longest segment of the scene's hair groups (a strand file's: its reach over its
/// segments, an upper bound).
pub fn longest_segment(scene: &Scene) -> f64 {
    let (_, r) = scene_bounds(scene);
    scene
        .groups()
        .iter()
        .map(|g| {
            let len = if g.file.is_some() {
                2.0 * r
            } else {
                g.length * (1.0 + g.length_jitter)
            };
            len / g.segments.max(1) as f64
        })
        .fold(0.0, f64::max)
}

/// Strands and segments of the scene's hair groups (not its fur).
pub fn counts(scene: &Scene) -> (u64, u64) {
    // Saturating: this runs before the groups' counts are checked.
    scene.groups().iter().fold((0u64, 0u64), |(h, s), g| {
        let n = g.count as u64;
        (
            h.saturating_add(n),
            s.saturating_add(n.saturating_mul(g.segments as u64)),
        )
    })
}

/// Group materials of a scene, in group order; a strand file's own colours, opacities
/// and widths replace the material's where the file has them and the group asks for them
/// (`StrandFile::colors`, `widths`).
pub fn materials(scene: &Scene) -> Vec<GpuMaterial> {
    scene
        .groups()
        .iter()
        .map(|g| {
            let mut m = GpuMaterial::from_material(&g.material, scene.render.shading);
            m.file = file_look(g).map(|b| b as u32 as f32);
            m
        })
        .collect()
}

/// Which of its file's looks a group draws: colours, widths, opacities.
pub fn file_look(g: &block::HairGroup) -> [bool; 4] {
    let Some((f, gr)) = g.file.as_ref().and_then(|f| Some((f, f.groom.as_ref()?))) else {
        return [false; 4];
    };
    [
        f.colors && gr.colors.is_some(),
        f.widths && gr.widths.is_some(),
        f.colors && gr.opacities.is_some(),
        false,
    ]
}

/// What an edit asks of the strands: pores, lengths, rigidity, loads, cuts, head, grooming
/// load or per-strand k_a re-groom (and restart the motion from the new rest pose);
/// dynamics switched on or off, or a new guide share, rebuild; dynamics parameters and the
/// world's gravity, wind and head motion act from the next step;
/// colours, k_s, n and widths are new uniforms.
pub fn classify(old: &Scene, new: &Scene) -> Change {
    // Groups with their look-only fields made equal: what is left is the groom.
    let groom_view = |s: &Scene| {
        let mut groups = s.groups().clone();
        for g in &mut groups {
            let (ka, spread) = (g.material.ka, g.material.ka_spread);
            g.material = Default::default();
            g.material.ka = ka;
            g.material.ka_spread = spread;
            // Whether a file's own look is drawn is a look too.
            if let Some(f) = g.file.as_mut() {
                (f.colors, f.widths) = (true, true);
            }
        }
        (s.seed, s.head.center, s.head.radii, *s.groom_load(), groups)
    };
    let looks = |s: &Scene| -> Vec<_> {
        s.groups()
            .iter()
            .map(|g| (g.material.clone(), file_look(g)))
            .collect()
    };
    // The guide share decides which strands are simulated: a new set-up.
    let guides = |s: &Scene| s.dynamics().as_ref().map(|d| d.guides);
    // The world's forces the dynamics read each step (the EFF and a capture: the stage's).
    let world = |s: &Scene| {
        (
            s.forces.gravity,
            s.forces.wind.clone(),
            s.forces.head_motion.clone(),
        )
    };
    if groom_view(old) != groom_view(new)
        || old.dynamics().is_some() != new.dynamics().is_some()
        || guides(old) != guides(new)
    {
        Change::Rebuild
    } else if old.dynamics() != new.dynamics()
        || (new.dynamics().is_some() && world(old) != world(new))
    {
        Change::Resimulate
    } else if looks(old) != looks(new)
        || old.render.strands != new.render.strands
        || old.render.shading != new.render.shading
    {
        Change::Redraw
    } else {
        Change::None
    }
}

/// Per strand [`export_strands`] writes (the same ones, in order: strands cut to nothing
/// are left out): what its absorption is multiplied by (`vary::absorption`).
pub fn strand_absorption(
    materials: &[crate::systems::anjyo::block::Material],
    records: &[crate::gpu::gpu_data::GpuStrand],
) -> Vec<[f32; 3]> {
    records
        .iter()
        .filter(|r| {
            let drawn = (r.visible as f64).clamp(0.0, r.segments as f64);
            drawn.floor() >= 1.0 || drawn.fract() > 1e-6
        })
        .map(|r| vary::absorption(r.rand, &materials[r.group as usize].variation).map(|a| a as f32))
        .collect()
}

/// Polylines of the drawn hair: each strand's nodes up to its drawn (cut) length, the last
/// segment shortened to the fractional part; widths tapered root to tip as the ribbon draws
/// them (times the strand's own width, `vary`); the group's colour (a strand file has no
/// absorption: a strand's own pigment is [`strand_absorption`]'s). A group drawn with its strand file's own look (`file`, per
/// group as [`file_look`] says; `looks` per node) writes that look: widths, colours and
/// opacities (opaque for the others), so a groom goes back out as it came in.
pub fn export_strands(
    materials: &[crate::systems::anjyo::block::Material],
    file: &[[bool; 4]],
    looks: Option<&[imported::NodeLook]>,
    records: &[crate::gpu::gpu_data::GpuStrand],
    nodes: &[[f32; 4]],
) -> crate::formats::Groom {
    let opacity = looks.is_some() && file.iter().any(|f| f[2]);
    let mut g = crate::formats::Groom {
        widths: Some(Vec::new()),
        colors: Some(Vec::new()),
        opacities: opacity.then(Vec::new),
        ..Default::default()
    };
    for r in records {
        let k = r.segments as usize;
        let drawn = (r.visible as f64).clamp(0.0, k as f64);
        let whole = drawn.floor() as usize;
        let frac = drawn - whole as f64;
        // Segments drawn, the last one perhaps in part; a strand cut to nothing is left out.
        let segs = if frac > 1e-6 { whole + 1 } else { whole };
        if segs == 0 {
            continue;
        }
        let m = &materials[r.group as usize];
        let first = r.first_vertex as usize;
        for i in 0..=segs {
            let p = nodes[first + i];
            let mut q = [p[0], p[1], p[2]];
            if i == segs && frac > 1e-6 {
                let a = nodes[first + i - 1];
                let t = frac as f32;
                q = [0, 1, 2].map(|c| a[c] + t * (p[c] - a[c]));
            }
            g.points.push(q);
            let along = (i.min(whole) as f64 + if i > whole { frac } else { 0.0 }) / k as f64;
            let mut w = (m.width * (1.0 + (m.tip_width - 1.0) * along)) as f32;
            let vary = vary::width_factor(r.rand, &m.variation) as f32;
            let mut c = m.color;
            let mut o = 1.0;
            let f = file.get(r.group as usize).copied().unwrap_or_default();
            if let Some(l) = looks.and_then(|l| l.get(first + i.min(whole))) {
                if f[0] {
                    c = l.rgb;
                }
                if f[1] {
                    w = l.width;
                }
                if f[2] {
                    o = l.opacity;
                }
            }
            g.widths.as_mut().unwrap().push(w * vary);
            g.colors.as_mut().unwrap().push(c);
            if let Some(op) = g.opacities.as_mut() {
                op.push(o);
            }
        }
        g.counts.push(segs as u32 + 1);
    }
    g
}

impl AnjyoSystem {
    /// Strands and segments drawn at the last `prepare` (level of detail included).
    pub fn drawn(&self) -> (u64, u64) {
        self.hair.ranges.iter().fold((0, 0), |(h, s), r| {
            let n = draw::drawn_count(r.strand_count, self.lod) as u64;
            let segs = self.draw.drawn_nodes(r.nodes_per_strand).saturating_sub(1) as u64;
            (h + n, s + n * segs)
        })
    }

    /// The compute rasteriser binned by tile or one walk per strand with global atomics
    /// (the default; `StrandsPass::set_binned`): the same image, for side-by-side timing.
    pub fn set_binned(&mut self, binned: bool) {
        self.draw.set_binned(binned);
    }

    /// Groom the scene's hair on the GPU and set up its simulation and draw.
    pub fn new(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<AnjyoSystem> {
        let input = groom::prepare(scene)?;
        let playback = playback_of(scene, &input)?;
        let hair = cantilever_gpu::groom_gpu(gpu, setup.world, &input)?;
        let sim = Simulation::new(gpu, setup.world, scene, &input, &hair)?;
        let rest = if sim.is_some() {
            let bytes = hair.vertex_count as u64 * NODE;
            let rest = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hair rest pose"),
                size: bytes.max(NODE),
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("hair rest pose"),
                });
            enc.copy_buffer_to_buffer(&hair.vertices, 0, &rest, 0, bytes);
            gpu.queue.submit([enc.finish()]);
            Some(rest)
        } else {
            None
        };
        let mut draw = draw::StrandsPass::new(
            gpu,
            setup.frame_layout,
            setup.splat_layouts,
            setup.shadow_cast_layout,
            setup.format,
            setup.variant,
        )?;
        draw.set_hair(gpu, &hair, &materials(scene), input.looks().as_deref());
        let widest = widest(scene, &input);
        Ok(AnjyoSystem {
            input,
            hair,
            sim,
            rest,
            draw,
            groups: scene.groups().clone(),
            bounds: scene_bounds(scene),
            counts: counts(scene),
            lod: 1.0,
            seg_len: longest_segment(scene),
            screen: ScreenLod::FULL,
            raster: scene.render.strands,
            widest,
            compute_up_to: crate::systems::raster::switch_for(KIND.name, &gpu.info),
            in_compute: scene.render.strands == StrandRaster::Compute,
            width_samples: 0.0,
            playback,
        })
    }
}

/// The widest strand of the scene's groups in world units: each material's root or tip
/// width, or the widest width a group's file gives its nodes where the group draws them.
fn widest(scene: &Scene, input: &GroomInput) -> f64 {
    let materials = scene
        .groups()
        .iter()
        .map(|g| g.material.width * g.material.tip_width.max(1.0));
    let files = input
        .groups
        .iter()
        .zip(scene.groups())
        .filter(|(_, g)| file_look(g)[1])
        .filter_map(|(i, _)| i.looks.as_ref())
        .flat_map(|l| l.iter().map(|n| n.width as f64));
    materials.chain(files).fold(0.0, f64::max)
}

/// The scene's playing groups, their frames resampled (`playback::group_frames`). A group
/// that plays is not simulated: a dynamic one in a scene with dynamics is refused.
fn playback_of(scene: &Scene, input: &GroomInput) -> Result<Option<playback::Playback>> {
    let offsets = input.vertex_offsets();
    let mut groups = Vec::new();
    let mut fps = None;
    for (gi, g) in scene.groups().iter().enumerate() {
        let Some(frames) = playback::group_frames(g)? else {
            continue;
        };
        if g.dynamic && scene.dynamics().is_some() {
            return Err(crate::error::KamiError::Invalid {
                file: String::new(),
                field: format!("groups[{gi}].dynamic"),
                value: "true".into(),
                allowed: "a group that plays its file's frames is not simulated: set \
                          `dynamic: false`, or `play: false` in its file to simulate from a \
                          still frame"
                    .into(),
            });
        }
        fps = fps.or(g
            .file
            .as_ref()
            .and_then(|f| f.frames.as_ref())
            .map(|f| f.fps));
        let first = offsets[input.groups[gi].first_strand as usize] as u64;
        groups.push(playback::GroupFrames {
            at: first * crate::gpu::strands::NODE,
            frames,
        });
    }
    if groups.is_empty() {
        return Ok(None);
    }
    let frames = groups.iter().map(|g| g.frames.len()).max().unwrap_or(1);
    Ok(Some(playback::Playback::new(
        groups,
        frames,
        fps.unwrap_or(24.0),
    )))
}

impl HairSystem for AnjyoSystem {
    fn kind(&self) -> &'static str {
        KIND.name
    }

    fn bounds(&self) -> (DVec3, f64) {
        self.bounds
    }

    fn step(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        frames: u32,
    ) -> Result<StepInfo> {
        if let Some(p) = self.playback.as_mut() {
            // After these frames the clock is at ctx.frame + frames: show that one.
            p.show(gpu, &self.hair.vertices, ctx.frame + frames as u64);
        }
        let Some(sim) = self.sim.as_mut() else {
            return Ok(StepInfo::default());
        };
        // The clock is the truth: forces from the stage, steps from its frame.
        if sim.setup.forces != *ctx.forces {
            sim.setup.forces = ctx.forces.clone();
        }
        sim.steps = ctx.frame * sim.setup.params.steps_per_frame as u64;
        sim.record_frames(gpu, enc, &self.hair, frames)
    }

    fn prepare(
        &mut self,
        gpu: &Gpu,
        _enc: &mut wgpu::CommandEncoder,
        _ctx: &FrameCtx,
        view: &View,
    ) -> Result<()> {
        let seen = Seen {
            center: self.bounds.0,
            radius: self.bounds.1,
            eye: view.eye,
            fov_y: view.fov_y,
            height_px: view.height_px,
        };
        self.screen = screen_lod(&seen, self.seg_len, view.lod_tolerance_px);
        // The viewer's budget multiplies on top (its widening, 1/sqrt, is the frame's).
        self.lod = self.screen.share * view.lod;
        self.width_samples = raster::width_in_samples(
            self.widest,
            self.screen.width_scale * view.budget_widening(),
            view.focal_samples,
            view.eye,
            self.bounds.0,
            self.bounds.1,
        );
        self.in_compute = raster::draws_in_compute(
            self.raster,
            self.width_samples,
            self.compute_up_to,
            self.in_compute,
        );
        self.draw.prepare(
            &gpu.queue,
            self.screen.width_scale,
            self.screen.step,
            self.lod,
            view.samples,
        );
        Ok(())
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, _view: &View) {
        if !self.splats() {
            self.draw.draw(pass, self.lod);
        }
    }

    fn splats(&self) -> bool {
        self.in_compute && self.draw.can_splat()
    }

    fn splat(&self, pass: &mut wgpu::ComputePass<'_>) {
        if self.splats() {
            self.draw.splat(pass);
        }
    }

    fn casts(&self) -> bool {
        true
    }

    fn cast_shadow(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.draw.cast(pass);
    }

    fn reset(&mut self, gpu: &Gpu) -> Result<()> {
        if let (Some(sim), Some(rest)) = (self.sim.as_mut(), &self.rest) {
            let mut enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("hair reset"),
                });
            enc.copy_buffer_to_buffer(rest, 0, &self.hair.vertices, 0, rest.size());
            gpu.queue.submit([enc.finish()]);
            sim.reset(gpu);
        }
        if let Some(p) = self.playback.as_mut() {
            p.invalidate();
            p.show(gpu, &self.hair.vertices, 0);
            gpu.queue.submit([]);
        }
        Ok(())
    }

    fn set_variant(&mut self, gpu: &Gpu, variant: crate::gpu::pipeline::Variant) {
        self.draw.set_variant(gpu, variant);
    }

    fn update(&mut self, gpu: &Gpu, scene: &Scene, change: Change) -> Result<()> {
        if self.raster != scene.render.strands {
            self.raster = scene.render.strands;
            self.in_compute = self.raster == StrandRaster::Compute;
        }
        self.widest = widest(scene, &self.input);
        match change {
            Change::Redraw => {
                self.groups = scene.groups().clone();
                self.draw.update_materials(gpu, &materials(scene))
            }
            Change::Resimulate => {
                self.groups = scene.groups().clone();
                if let (Some(sim), Some(d)) = (self.sim.as_mut(), scene.dynamics()) {
                    sim.update_params(gpu, d.clone());
                }
                self.draw.update_materials(gpu, &materials(scene));
            }
            Change::None | Change::Rebuild => {}
        }
        Ok(())
    }

    fn playback_fps(&self) -> Option<f64> {
        self.playback.as_ref().map(|p| p.fps)
    }

    fn stats(&self) -> SystemStats {
        let drawn = self
            .hair
            .ranges
            .iter()
            .map(|r| draw::drawn_count(r.strand_count, self.lod) as u64)
            .sum();
        SystemStats {
            strands: self.counts.0,
            segments: self.counts.1,
            simulated: self
                .sim
                .as_ref()
                .map_or(0, |s| s.setup.strands.len() as u64),
            drawn,
            raster: Some(RasterChoice {
                compute: self.splats(),
                width_samples: self.width_samples,
            }),
        }
    }

    fn export(&self, gpu: &Gpu, _ctx: &FrameCtx) -> Result<Option<crate::formats::Groom>> {
        let nodes = self.hair.read_vertices(gpu)?;
        let records = self.hair.read_strands(gpu)?;
        let materials: Vec<_> = self.groups.iter().map(|g| g.material.clone()).collect();
        let file: Vec<[bool; 4]> = self.groups.iter().map(file_look).collect();
        let looks = self.input.node_looks();
        Ok(Some(export_strands(
            &materials,
            &file,
            looks.as_deref(),
            &records,
            &nodes,
        )))
    }

    /// The strands the last frame drew (the screen-space level of detail's share of each
    /// range, widened by its factor) as [`HairSystem::export`] writes them, with each one's
    /// absorption against its group's (per-strand variation), in the same order. Every node
    /// is written, where the draw may step over some (within the level of detail's bound).
    fn export_drawn(
        &self,
        gpu: &Gpu,
        _ctx: &FrameCtx,
    ) -> Result<Option<crate::systems::system::DrawnHair>> {
        let nodes = self.hair.read_vertices(gpu)?;
        let all = self.hair.read_strands(gpu)?;
        let records: Vec<_> = self
            .hair
            .ranges
            .iter()
            .flat_map(|r| {
                let first = r.first_strand as usize;
                let n = draw::drawn_count(r.strand_count, self.lod) as usize;
                all[first..first + n].iter().copied()
            })
            .collect();
        let materials: Vec<_> = self.groups.iter().map(|g| g.material.clone()).collect();
        let file: Vec<[bool; 4]> = self.groups.iter().map(file_look).collect();
        let looks = self.input.node_looks();
        let mut groom = export_strands(&materials, &file, looks.as_deref(), &records, &nodes);
        let widen = self.screen.width_scale as f32;
        if let Some(w) = groom.widths.as_mut() {
            w.iter_mut().for_each(|w| *w *= widen);
        }
        let absorption = strand_absorption(&materials, &records);
        Ok(Some(crate::systems::system::DrawnHair {
            groom,
            absorption: Some(absorption),
        }))
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}
