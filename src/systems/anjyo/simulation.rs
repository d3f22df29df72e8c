//! `Simulation` drives the projective-dynamics kernel over a groom: positions stay on the
//! GPU, the CPU only schedules forces (`projective::DynSetup::schedule`). The f64 reference
//! of the same step is `projective::CpuSim` (`tests/it/contract.rs` compares them). With a
//! guide share (`dynamics.guides`) the kernel simulates only the guides and the follower
//! kernel (`follow_gpu`) rebuilds the other strands after each submission's substeps.

use super::follow::FollowSetup;
use super::follow_gpu::{FollowJob, FollowPass};
use super::groom::GroomInput;
use super::projective::DynSetup;
use super::projective_gpu::{ProjectiveJob, ProjectivePass};
use crate::error::Result;
use crate::gpu::strands::StrandBuffers;
use crate::gpu::Gpu;
use crate::systems::scene::Scene;
use crate::systems::system::StepInfo;
use crate::systems::world::WorldGpu;

/// The GPU simulation of a groomed scene.
pub struct Simulation {
    pub setup: DynSetup,
    pass: ProjectivePass,
    job: ProjectiveJob,
    /// Steps taken since the rest pose.
    pub steps: u64,
    /// Steps that needed more than `max_substeps` (the angular clamp was relied on).
    pub capped_steps: u64,
    /// The followers, when only a share of the strands is simulated.
    pub follow: Option<FollowSetup>,
    follow_gpu: Option<(FollowPass, FollowJob)>,
    /// The time (frames) the followers were last rebuilt at: the end of the last recorded
    /// substep, where they read the head's pose from the world.
    pub follow_time: f64,
}

impl Simulation {
    /// Set up and initialise the simulation for a groom already bent into `hair`, over the
    /// scene's `world` (the EFF and head field the kernels bind); `None`
    /// when the scene has no dynamics (nothing is allocated then). Reads the groom's drawn
    /// lengths back once, to size the simulated strands.
    pub fn new(
        gpu: &Gpu,
        world: &WorldGpu,
        scene: &Scene,
        input: &GroomInput,
        hair: &StrandBuffers,
    ) -> Result<Option<Simulation>> {
        if scene.dynamics().is_none() {
            return Ok(None);
        }
        let visible: Vec<f64> = hair
            .read_strands(gpu)?
            .iter()
            .map(|s| s.visible as f64)
            .collect();
        let Some(setup) = DynSetup::new(scene, input, &visible) else {
            return Ok(None);
        };
        let pass = ProjectivePass::new(gpu, world)?;
        let job = pass.prepare(gpu, world, &setup, hair)?;
        let follow = FollowSetup::new(scene, input, &visible, &setup);
        let follow_gpu = match &follow {
            Some(f) => {
                let fp = FollowPass::new(gpu, world)?;
                let fj = fp.prepare(gpu, world, f, hair)?;
                Some((fp, fj))
            }
            None => None,
        };
        let sim = Simulation {
            setup,
            pass,
            job,
            steps: 0,
            capped_steps: 0,
            follow,
            follow_gpu,
            follow_time: 0.0,
        };
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("projective init"),
            });
        sim.pass.init(&mut enc, &sim.job);
        gpu.queue.submit([enc.finish()]);
        Ok(Some(sim))
    }

    /// Back to the rest pose (the caller re-grooms the nodes first).
    pub fn reset(&mut self, gpu: &Gpu) {
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("projective reset"),
            });
        self.pass.init(&mut enc, &self.job);
        gpu.queue.submit([enc.finish()]);
        self.steps = 0;
        self.capped_steps = 0;
    }

    /// Record one frame (`steps_per_frame` steps and their substeps) into `enc`. Submit
    /// before recording the next frame: the substeps' uniforms are written at submission.
    pub fn record_frame(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        hair: &StrandBuffers,
    ) -> Result<StepInfo> {
        self.record_frames(gpu, enc, hair, 1)
    }

    /// Record `frames` frames into one submission (the viewer's time scale): their
    /// substeps share one upload, so each dispatch reads its own forces and head pose.
    pub fn record_frames(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        hair: &StrandBuffers,
        frames: u32,
    ) -> Result<StepInfo> {
        let mut all = Vec::new();
        let mut info = StepInfo::default();
        for _ in 0..self.setup.params.steps_per_frame * frames {
            let (subs, capped) = self.setup.schedule(self.steps);
            if capped {
                self.capped_steps += 1;
                info.capped = true;
            }
            info.substeps += subs.len() as u32;
            all.extend(subs);
            self.steps += 1;
        }
        let forces = &self.setup.forces;
        self.pass
            .advance(gpu, enc, &mut self.job, hair, forces, &all)?;
        if let (Some((fp, fj)), Some(last)) = (&self.follow_gpu, all.last()) {
            fp.record(gpu, enc, fj, forces, last.t_end)?;
            self.follow_time = last.t_end;
        }
        Ok(info)
    }

    /// The head's pose the followers were last rebuilt at (`follow_time`).
    pub fn follow_head(&self) -> glam::DMat4 {
        self.setup.forces.head_at(self.follow_time)
    }

    /// Record the follower kernel alone, at the last pose (benchmarks: its own cost).
    /// Nothing without followers.
    pub fn record_followers(&self, gpu: &Gpu, enc: &mut wgpu::CommandEncoder) -> Result<()> {
        if let Some((fp, fj)) = &self.follow_gpu {
            fp.record(gpu, enc, fj, &self.setup.forces, self.follow_time)?;
        }
        Ok(())
    }

    /// Parameters changed without changing which strands are simulated.
    pub fn update_params(&mut self, gpu: &Gpu, params: crate::systems::anjyo::block::Dynamics) {
        if let (Some(f), Some((fp, fj))) = (self.follow.as_mut(), self.follow_gpu.as_mut()) {
            f.collision = params.collision;
            fp.set_collision(fj, params.collision);
        }
        self.setup.params = params;
        self.setup.update_max_cu();
        self.pass.update_params(gpu, &self.job, &self.setup);
    }

    /// The angle state (tests only), in the f64 reference's strand-major order (the GPU
    /// keeps it segment-major: `projective_gpu::StateLayout`).
    pub fn read_state(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>> {
        let raw: Vec<[f32; 4]> = crate::gpu::read_buffer(
            gpu,
            &self.job.state,
            self.job.layout.entries() * std::mem::size_of::<[f32; 4]>() as u64,
        )?;
        Ok(self.job.layout.to_strand_major(&self.setup, &raw))
    }
}
