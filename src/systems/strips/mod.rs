//! Kazama, Sugisaki and Morishima's directable strips: the Hair Object Model (layered reed
//! strips, `hom`), its motion on damped angular springs (eq 1; the f64 reference in
//! `dynamics`, the WGSL kernel in `dynamics_gpu`), ribbons built on the GPU from the control
//! points and drawn with a generated strand texture (`ribbon`, `texture`), the marker
//! capture round trip that fits the EFF (`capture`) and key-frame editing (`keyframe`).

pub mod block;
pub mod capture;
pub mod dynamics;
pub mod dynamics_gpu;
pub mod hom;
pub mod keyframe;
pub mod panel;
pub mod pick;
pub mod ribbon;
pub mod sky;
pub mod texture;
pub mod tools;

use crate::error::{KamiError, Result};
use crate::forces::Forces;
use crate::gpu::Gpu;
use crate::scene::Head;
use crate::systems::kind::{Kind, Panel};
use crate::systems::scene::Scene;
use crate::systems::strips::block::Strips;
use crate::systems::system::{
    Change, DrawSetup, FrameCtx, HairSystem, StepInfo, SystemStats, View,
};
use glam::DVec3;
use ribbon::RibbonPass;

/// One strip of the Hair Object Model at rest, in the head's rest frame: what `hom` builds
/// from the scene's layers and what the dynamics and the ribbons start from.
#[derive(Clone, Debug, PartialEq)]
pub struct RestStrip {
    /// Index of its layer in `Strips::layers`.
    pub layer: u32,
    /// Control points, root first (`sticks + 1` of them); the root lies on the head.
    pub points: Vec<DVec3>,
    /// Outward head normal at the root (the chain's first stick is measured from it).
    pub normal: DVec3,
    /// Ribbon width at the root and at the tip.
    pub width: [f64; 2],
    /// Multiplier of the motion's stiffness (the layer's).
    pub stiffness: f64,
    pub color: [f32; 3],
}

pub const KIND: Kind = Kind {
    name: "strips",
    block: "strips",
    called: "strips",
    in_scene: |s| s.strips().is_some(),
    validate: block::validate,
    read_files: |_, _, _| Ok(()),
    files: |_, _| Vec::new(),
    counts: |_| (0, 0),
    counted: None,
    check_limits,
    build,
    classify,
    panels: PANELS,
    ui: || Box::<tools::StripsUi>::default(),
    // Strips are ribbons on chains of sticks: named on their own.
    summary: |s| {
        s.strips().as_ref().map(|st| {
            let n: u64 = st.layers.iter().map(|l| u64::from(l.count)).sum();
            let sticks: u64 = st
                .layers
                .iter()
                .map(|l| u64::from(l.count) * u64::from(l.sticks))
                .sum();
            format!("{n} strips ({sticks} sticks)")
        })
    },
    moves: |s| s.strips().is_some(),
    scenes: &["strips", "eff_capture", "strips_turn", "strips_mesh_head"],
    shaders: &[
        ("strips/dynamics", dynamics_gpu::DYNAMICS),
        ("strips/ribbon", ribbon::RIBBON),
        ("strips/draw", ribbon::DRAW),
        ("strips/cast", ribbon::CAST),
    ],
    invariants: |_| Ok(()),
    fuzz_words: &[
        "Strips(",
        "Layer(",
        "Motion(",
        "Look(",
        "Edit(",
        "Nearest",
        "Trilinear",
        "strips:",
        "layers:",
        "motion:",
        "look:",
        "edits:",
        "polar:",
        "azimuth:",
        "sticks:",
        "droop:",
        "curl:",
        "stiffness_tip:",
        "spring:",
        "steps_per_second:",
        "sampling:",
        "preload:",
        "tip_shade:",
        "alpha_cutoff:",
        "strip:",
        "from:",
        "to:",
    ],
    shadow_steps: false,
    cache_fps: |_| None,
    opens: None,
    merge: |_, _, _, _| {},
    commands: &[],
};

pub const PANELS: &[Panel] = &[
    Panel {
        title: "Strips",
        open: |s| s.strips().is_some(),
        adds: false,
        show: panel::strips,
    },
    Panel {
        title: "EFF",
        open: |s| s.strips().is_some() && s.forces.eff.is_some(),
        adds: false,
        show: panel::eff,
    },
    Panel {
        title: "Key frames",
        open: |s| s.strips().is_some(),
        adds: false,
        show: panel::keyframes,
    },
];

/// Control points of the scene's strips (each strip has its layer's sticks + 1; the GPU
/// keeps the longest as every strip's stride).
fn point_slots(st: &Strips) -> u64 {
    let count: u64 = st.layers.iter().map(|l| u64::from(l.count)).sum();
    let stride = st.layers.iter().map(|l| l.sticks + 1).max().unwrap_or(0);
    count * u64::from(stride)
}

fn check_limits(gpu: &Gpu, scene: &Scene) -> Result<()> {
    let Some(st) = scene.strips() else {
        return Ok(());
    };
    gpu.check_storage_buffers("the strips' motion", dynamics_gpu::STORAGE_BUFFERS)?;
    let slots = point_slots(st);
    gpu.check_storage_size("the strips' control points", slots * 16)?;
    // Two ribbon vertices per control point (position, tangent, u/v, colour: 64 bytes).
    gpu.check_storage_size("the strips' ribbon vertices", slots * 2 * 64)?;
    Ok(())
}

fn build(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<Box<dyn HairSystem>> {
    Ok(Box::new(StripsSystem::new(gpu, scene, setup)?))
}

/// What an edit asks of the strips. The look is a `Redraw`. The joints' I1, I2 and τ, the
/// forces' settings (gravity, spring, collision, sampling, the step rate), the EFF's cells,
/// the head capture and the key-frame edits act from the next step (`Resimulate`: new
/// propagators, key-frame edits solved again, the pose kept; the viewer replays the clip
/// after a key-frame edit, the others act from the frame shown). The layers, the head and the EFF's grid size build the strips again,
/// and the clip restarts at frame 0.
pub fn classify(old: &Scene, new: &Scene) -> Change {
    let (Some(a), Some(b)) = (old.strips(), new.strips()) else {
        return if old.strips() == new.strips() {
            Change::None
        } else {
            Change::Rebuild
        };
    };
    let grid = |s: &Scene| {
        Forces::new(&s.forces, &s.head)
            .eff
            .map(|e| (e.dims(), e.origin(), e.cell_size()))
    };
    if a.layers != b.layers || old.head != new.head || grid(old) != grid(new) {
        return Change::Rebuild;
    }
    // An edit's keys or target: solve the extra forces again (the viewer then replays
    // the clip, see `Stage::seek`), no new pipelines while a target is dragged.
    if a.motion != b.motion || a.edits != b.edits || old.forces != new.forces {
        return Change::Resimulate;
    }
    if a.look != b.look || old.render.shading != new.render.shading {
        Change::Redraw
    } else {
        Change::None
    }
}

/// Kazama's strips of one scene: the rest strips, their motion on the GPU (reading the
/// stage's world: the EFF, the head's field), and the ribbons drawn from their control points.
pub struct StripsSystem {
    pub strips: Strips,
    pub head: Head,
    pub rest: Vec<RestStrip>,
    /// The solved key-frame edits (their extra forces are on the GPU).
    pub solved: Vec<keyframe::Solved>,
    pub dynamics: dynamics_gpu::DynamicsGpu,
    pub ribbon: RibbonPass,
    /// The ribbons' shadow cast.
    cast: ribbon::StripCast,
    /// How far beyond the head the strips can reach (the bounds).
    reach: f64,
    /// The look's hair count the ribbons' sky was baked for; None before the first bake.
    sky_hairs: Option<u32>,
}

impl StripsSystem {
    pub fn new(gpu: &Gpu, scene: &Scene, setup: &DrawSetup) -> Result<StripsSystem> {
        let strips = scene.strips().clone().ok_or_else(|| KamiError::Invalid {
            file: String::new(),
            field: "strips".into(),
            value: "None".into(),
            allowed: "a strips block (the strips system is built only for scenes with strips)"
                .into(),
        })?;
        check_limits(gpu, scene)?;
        let head = scene.head.clone();
        let forces = Forces::new(&scene.forces, &scene.head);
        let rest = hom::build(&strips, &head)?;
        let solved = keyframe::solve(&rest, &strips.motion, &forces, &head, &strips.edits)?;
        let rig = dynamics::Rig::posed(&rest, &strips.motion, &head, forces.gravity)?;
        let mut dynamics = dynamics_gpu::DynamicsGpu::new(gpu, setup.world, &rig, &strips.motion)?;
        dynamics.set_extra(gpu, &solved.iter().map(|s| s.extra).collect::<Vec<_>>())?;
        let mut ribbon = RibbonPass::new(
            gpu,
            &rest,
            rig.stride(),
            &strips.look,
            setup.frame_layout,
            setup.format,
            setup.variant,
        )?;
        if !scene.render.shading.is_anjyo() {
            ribbon.set_shading(scene.render.shading);
            ribbon.write_look(gpu, &strips.look)?;
        }
        let reach = strips
            .layers
            .iter()
            .map(|l| l.length + l.width[0])
            .fold(0.0, f64::max);
        let mut me = StripsSystem {
            strips,
            head,
            rest,
            solved,
            dynamics,
            cast: ribbon.shadow_cast(gpu, setup.frame_layout, setup.shadow_cast_layout)?,
            ribbon,
            reach,
            sky_hairs: None,
        };
        let look = me.strips.look.clone();
        me.refresh_sky(gpu, &look)?;
        Ok(me)
    }

    /// Bake the strips' sky (`sky::bake`) when the physical mode reads it and it is missing
    /// or stale: its coverage is the texture's, so new hairs make it stale. Anjyo's mode
    /// never pays for it.
    fn refresh_sky(&mut self, gpu: &Gpu, look: &block::Look) -> Result<()> {
        if self.ribbon.is_physical() && self.sky_hairs != Some(look.hairs) {
            self.ribbon
                .set_sky(gpu, &sky::bake(&self.rest, &self.head, look))?;
            self.sky_hairs = Some(look.hairs);
        }
        Ok(())
    }
}

impl StripsSystem {
    /// The strips as the GPU last posed them, one world-space polyline each (the viewer's
    /// picking reads them back when the mouse asks, never every frame of a render).
    pub fn pose(&self, gpu: &Gpu) -> Result<Vec<Vec<DVec3>>> {
        let points = self.dynamics.read_points(gpu)?;
        let lens: Vec<usize> = self.rest.iter().map(|r| r.points.len()).collect();
        Ok(pick::polylines(
            &points,
            self.dynamics.stride() as usize,
            &lens,
        ))
    }
}

impl HairSystem for StripsSystem {
    fn kind(&self) -> &'static str {
        KIND.name
    }

    fn bounds(&self) -> (DVec3, f64) {
        let r = self.head.radii.iter().copied().fold(0.0, f64::max);
        (DVec3::from(self.head.center), r + self.reach)
    }

    fn step(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        frames: u32,
    ) -> Result<StepInfo> {
        self.dynamics
            .record(gpu, enc, ctx.forces, ctx.frame, frames)?;
        Ok(StepInfo {
            substeps: frames * dynamics::steps_per_frame(&self.strips.motion),
            capped: false,
        })
    }

    fn prepare(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        ctx: &FrameCtx,
        _view: &View,
    ) -> Result<()> {
        self.ribbon
            .record(gpu, enc, self.dynamics.points(), &ctx.head)
    }

    fn casts(&self) -> bool {
        true
    }

    fn cast_shadow(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.cast.cast(pass);
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, _view: &View) {
        self.ribbon.draw(pass);
    }

    fn reset(&mut self, gpu: &Gpu) -> Result<()> {
        self.dynamics.reset(gpu)
    }

    fn set_variant(&mut self, gpu: &Gpu, variant: crate::gpu::pipeline::Variant) {
        self.ribbon.set_variant(gpu, variant);
    }

    fn update(&mut self, gpu: &Gpu, scene: &Scene, change: Change) -> Result<()> {
        let Some(st) = scene.strips() else {
            return Ok(());
        };
        match change {
            Change::Redraw => {
                self.ribbon.set_shading(scene.render.shading);
                self.ribbon.write_look(gpu, &st.look)?;
            }
            Change::Resimulate => {
                // Everything that can fail first, so a refused edit leaves the GPU as it was.
                let forces = Forces::new(&scene.forces, &scene.head);
                // τ, I1 and I2 act from the next step too: new joint constants, same pose.
                let rig =
                    dynamics::Rig::posed(&self.rest, &st.motion, &scene.head, forces.gravity)?;
                let solved =
                    keyframe::solve(&self.rest, &st.motion, &forces, &scene.head, &st.edits)?;
                let extra: Vec<dynamics::ExtraForce> = solved.iter().map(|s| s.extra).collect();
                dynamics_gpu::check_extras(&extra)?;
                self.dynamics.check_rig(&rig)?;
                self.dynamics.set_rig(rig)?;
                self.dynamics.update_params(gpu, &st.motion);
                self.solved = solved;
                self.dynamics.set_extra(gpu, &extra)?;
                self.ribbon.set_shading(scene.render.shading);
                self.ribbon.write_look(gpu, &st.look)?;
            }
            _ => {}
        }
        self.refresh_sky(gpu, &st.look)?;
        self.strips = st.clone();
        Ok(())
    }

    fn stats(&self) -> SystemStats {
        let n = self.rest.len() as u64;
        SystemStats {
            strands: n,
            segments: self
                .rest
                .iter()
                .map(|r| r.points.len().saturating_sub(1) as u64)
                .sum(),
            simulated: n,
            drawn: n,
            raster: None,
        }
    }

    /// The strips' centre lines (their control points as drawn now), with the ribbon's
    /// width running root to tip and the layer's colour: a strand file has no ribbons.
    fn export(&self, gpu: &Gpu, _ctx: &FrameCtx) -> Result<Option<crate::formats::Groom>> {
        let lines = self.pose(gpu)?;
        let mut g = crate::formats::Groom {
            widths: Some(Vec::new()),
            colors: Some(Vec::new()),
            ..Default::default()
        };
        for (line, rest) in lines.iter().zip(&self.rest) {
            if line.len() < 2 {
                continue;
            }
            g.counts.push(line.len() as u32);
            for (i, p) in line.iter().enumerate() {
                let u = i as f64 / (line.len() - 1) as f64;
                g.points.push([p.x as f32, p.y as f32, p.z as f32]);
                g.widths
                    .as_mut()
                    .unwrap()
                    .push((rest.width[0] + u * (rest.width[1] - rest.width[0])) as f32);
                g.colors.as_mut().unwrap().push(rest.color);
            }
        }
        Ok(Some(g))
    }

    /// The fine hairs the strand texture draws on each ribbon (`texture::texture_hairs`),
    /// placed across the ribbon as drawn (`ribbon::ribbon_reference` at the frame's head
    /// pose), each with its drawn width, ending where its texture hair ends.
    fn export_drawn(
        &self,
        gpu: &Gpu,
        ctx: &FrameCtx,
    ) -> Result<Option<crate::systems::system::DrawnHair>> {
        let lines = self.pose(gpu)?;
        let stride = self.dynamics.stride() as usize;
        let mut points = Vec::with_capacity(lines.len() * stride);
        for line in &lines {
            let last = line.last().copied().unwrap_or_default();
            points.extend((0..stride).map(|k| line.get(k).copied().unwrap_or(last)));
        }
        let info = ribbon::strip_info(&self.rest);
        let verts = ribbon::ribbon_reference(&points, stride, &info, &ctx.head);
        Ok(Some(crate::systems::system::DrawnHair {
            groom: texture_strands(
                &texture::texture_hairs(&self.strips.look),
                &verts,
                stride,
                &self.rest,
            ),
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

/// Samples per stick of a texture hair (the ribbon is straight between control points, the
/// hair's wave is not).
const HAIR_SAMPLES_PER_STICK: usize = 4;

/// The texture's `hairs` as strands on the ribbons `verts` (two per control point slot, u = 0
/// and 1, `stride` slots per strip): each hair at its u across the ribbon at every sample,
/// its width its texture width times the ribbon's, its colour the strip's, ending at its end.
pub fn texture_strands(
    hairs: &[texture::Hair],
    verts: &[ribbon::RibbonVertex],
    stride: usize,
    rest: &[RestStrip],
) -> crate::formats::Groom {
    let mut g = crate::formats::Groom {
        widths: Some(Vec::new()),
        colors: Some(Vec::new()),
        ..Default::default()
    };
    let (widths, colors) = (g.widths.as_mut().unwrap(), g.colors.as_mut().unwrap());
    for (s, strip) in rest.iter().enumerate() {
        let n = strip.points.len().clamp(1, stride);
        if n < 2 {
            continue;
        }
        let edge = |k: usize, side: usize| verts[2 * (s * stride + k) + side].position;
        // The two edges at v (linear between control points, as the quads are drawn).
        let at = |v: f64| {
            let x = v.clamp(0.0, 1.0) * (n - 1) as f64;
            let k = (x as usize).min(n - 2);
            let f = x - k as f64;
            (
                edge(k, 0).lerp(edge(k + 1, 0), f),
                edge(k, 1).lerp(edge(k + 1, 1), f),
            )
        };
        let steps = HAIR_SAMPLES_PER_STICK * (n - 1);
        for h in hairs {
            let mut count = 0u32;
            for j in 0..=steps {
                let v = (j as f64 / steps as f64).min(h.end);
                let (a, b) = at(v);
                let p = a.lerp(b, h.u(v));
                g.points.push([p.x as f32, p.y as f32, p.z as f32]);
                widths.push((2.0 * h.half_width(v) * (b - a).length()) as f32);
                colors.push(strip.color);
                count += 1;
                if v >= h.end {
                    break;
                }
            }
            g.counts.push(count);
        }
    }
    g
}
