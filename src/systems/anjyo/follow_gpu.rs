//! The follower kernel (`shaders/anjyo/follow.wgsl`): the f32 twin of `follow::follow`,
//! one invocation per follower, dispatched once per submission after the projective
//! substeps (a follower depends only on its guides' nodes and the head pose at that moment,
//! so once per submission is the same as once per frame). `tests/it/guides.rs` compares it
//! with the f64 reference.
//!
//! Its two GPU structs live here rather than in Anjyo's `gpu_data` because nothing else
//! reads them; same rules (`#[repr(C)]`, `Pod`, a size check, a twin checked by `tests/it/gpu_twins.rs`).

use super::follow::{FollowSetup, MAX_GUIDES};
use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::systems::world::{WorldGpu, WorldSteps, WORLD_GROUP};
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// Twin of `struct FollowParams` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/follow.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuFollowParams {
    pub follower_count: u32,
    pub row_stride: u32,
    pub collision: u32,
    /// The world sample (`world_steps`) of the head's pose at the end of the frame.
    pub sample: u32,
}
const _: () = assert!(std::mem::size_of::<GpuFollowParams>() == 16);

/// Twin of `struct Follower` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/follow.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuFollower {
    /// First vertex, moved segments, guide count, unused.
    pub ids: [u32; 4],
    /// xyz pore in head coordinates, w segment length.
    pub root: [f32; 4],
    pub guide_first: [u32; 4],
    pub guide_segs: [u32; 4],
    /// Shepard weights w_j.
    pub weight: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuFollower>() == 80);
const _: () = assert!(MAX_GUIDES <= 4);

/// The follower pipeline.
pub struct FollowPass {
    /// For an ellipsoid head (the SDF path compiled out) and for a mesh head's SDF.
    ellipsoid: wgpu::ComputePipeline,
    sdf: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// Buffers of one groom's followers.
pub struct FollowJob {
    params: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// The world's samples: `record` binds the group `sample` returns at `WORLD_GROUP`.
    steps: WorldSteps,
    /// Whether the world's head is a mesh's SDF (the pipeline with the SDF path).
    sdf_head: bool,
    dims: (u32, u32),
    base: GpuFollowParams,
}

impl FollowPass {
    /// The pipelines, over the layout of `world` at `WORLD_GROUP`.
    pub fn new(gpu: &Gpu, world: &WorldGpu) -> Result<FollowPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "follow", super::FOLLOW)?;
        let layout = bind::layout(
            device,
            "follow",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuFollowParams>(),
                bind::storage::<GpuFollower>(),
                bind::storage_rw::<[f32; 4]>(),
                bind::storage::<[f32; 4]>(),
            ],
        );
        // One pipeline per head kind: with the SDF path compiled out for an ellipsoid head
        // (SDF_HEAD, common/sdf.wgsl), which a software adapter would otherwise run too.
        let pipeline = |sdf: bool| {
            let [p] = world.compute_pipelines(
                device,
                "follow",
                &layout,
                &module,
                ["follow"],
                &[
                    ("WORKGROUP", WORKGROUP as f64),
                    ("EPS_OUT", crate::scene::head::EPS_OUT),
                    ("SDF_EPS_OUT", crate::scene::hull::SDF_EPS_OUT),
                    ("SDF_HEAD", f64::from(u8::from(sdf))),
                ],
            );
            p
        };
        Ok(FollowPass {
            ellipsoid: pipeline(false),
            sdf: pipeline(true),
            layout,
        })
    }

    /// Upload the followers.
    pub fn prepare(
        &self,
        gpu: &Gpu,
        world: &WorldGpu,
        setup: &FollowSetup,
        hair: &StrandBuffers,
    ) -> Result<FollowJob> {
        let device = &gpu.device;
        let dims = gpu.dispatch_dims(setup.followers.len() as u32, WORKGROUP)?;
        let records: Vec<GpuFollower> = setup
            .followers
            .iter()
            .map(|f| {
                let mut r = GpuFollower {
                    ids: [f.first_vertex, f.segments, f.guides.len() as u32, 0],
                    root: [
                        f.root_local.x as f32,
                        f.root_local.y as f32,
                        f.root_local.z as f32,
                        f.seg_len as f32,
                    ],
                    ..Default::default()
                };
                for (j, g) in f.guides.iter().enumerate() {
                    r.guide_first[j] = g.first_vertex;
                    r.guide_segs[j] = g.segments;
                    r.weight[j] = g.weight as f32;
                }
                r
            })
            .collect();
        let bytes = std::mem::size_of_val(records.as_slice()) as u64;
        gpu.check_storage_size("the follower table", bytes)?;
        let base = GpuFollowParams {
            follower_count: setup.followers.len() as u32,
            row_stride: dims.0 * WORKGROUP,
            collision: u32::from(setup.collision),
            ..Default::default()
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("follow params"),
            contents: bytemuck::bytes_of(&base),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let followers = gpu::storage_buffer(
            device,
            "followers",
            bytemuck::cast_slice(&records),
            wgpu::BufferUsages::empty(),
        );
        // The rest shape: the groom as it is now, before any step.
        let rest = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("follow rest pose"),
            size: hair.vertices.size(),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("follow rest pose"),
        });
        enc.copy_buffer_to_buffer(&hair.vertices, 0, &rest, 0, hair.vertices.size());
        gpu.queue.submit([enc.finish()]);
        let bind_group = bind::buffers(
            device,
            "follow",
            &self.layout,
            &[&params, &followers, &hair.vertices, &rest],
        );
        Ok(FollowJob {
            params,
            bind_group,
            steps: world.steps(),
            sdf_head: world.sdf_head(),
            dims,
            base,
        })
    }

    /// Sample the world's head pose at `t` (frames) and record the follower dispatch (once
    /// per submission, after the substeps: the pose is written when the queue is submitted).
    pub fn record(
        &self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        job: &FollowJob,
        forces: &Forces,
        t: f64,
    ) -> Result<()> {
        let (sample, world) = job.steps.sample(gpu, forces, &[t])?;
        let p = GpuFollowParams { sample, ..job.base };
        gpu.queue
            .write_buffer(&job.params, 0, bytemuck::bytes_of(&p));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("follow"),
            timestamp_writes: None,
        });
        pass.set_pipeline(if job.sdf_head {
            &self.sdf
        } else {
            &self.ellipsoid
        });
        pass.set_bind_group(0, &job.bind_group, &[]);
        pass.set_bind_group(WORLD_GROUP, &world, &[]);
        pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
        Ok(())
    }

    /// The collision switch changed (tuning from the viewer).
    pub fn set_collision(&self, job: &mut FollowJob, collision: bool) {
        job.base.collision = u32::from(collision);
    }
}
