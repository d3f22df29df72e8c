//! The cantilever bending kernel (`shaders/anjyo/cantilever.wgsl`): the f32 twin of the f64
//! reference in `cantilever.rs`, one invocation per strand; `tests/it/contract.rs` compares them.

use super::gpu_data::{GpuCut, GpuGroomGroup, GpuGroomParams, GpuLoad, GpuRoot};
use super::groom::{BendMode, GroomInput, LoadField, ResolvedLoad};
use crate::error::Result;
use crate::gpu::gpu_data::GpuStrand;
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::systems::anjyo::block::CutRule;
use crate::systems::world::{WorldGpu, WORLD_GROUP};
use wgpu::util::DeviceExt;

/// The cantilever kernel (`shaders/anjyo/cantilever.wgsl`): long-lived pipelines and layout.
pub struct CantileverPass {
    bend: wgpu::ComputePipeline,
    iterate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// One groom's uploaded inputs and bind group, ready to dispatch.
pub struct CantileverJob {
    bind_group: wgpu::BindGroup,
    /// The world's group (the head's hull and field), bound at `WORLD_GROUP`.
    world: wgpu::BindGroup,
    dims: (u32, u32),
    /// `iterate` dispatches needed (0 when no group uses the converged mode).
    iterate_dispatches: u32,
}

/// Converged-mode iterations per dispatch: llvmpipe ends a shader's loops after 65,535
/// iterations in total per invocation, so one dispatch must stay well below that. The loop
/// count of one iteration is about k (2 + 2 L + 84): target and rebuild passes over the
/// segments, L load-and-plane loops per load evaluation, 84 for a hull push-out.
pub fn iterations_per_dispatch(segments: u32, load_loops: u32) -> u32 {
    const BUDGET: u32 = 40_000;
    let per_iteration = segments.max(1) * (2 + 2 * load_loops + 84);
    (BUDGET / per_iteration).clamp(1, 64)
}

impl CantileverPass {
    /// The pipelines, over the layout of `world` at `WORLD_GROUP`.
    pub fn new(gpu: &Gpu, world: &WorldGpu) -> Result<CantileverPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "cantilever", super::CANTILEVER)?;
        let vec4 = bind::storage_rw::<[f32; 4]>;
        let layout = bind::layout(
            device,
            "cantilever",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuGroomParams>(),
                bind::storage::<GpuRoot>(),
                bind::storage::<GpuGroomGroup>(),
                bind::storage::<GpuLoad>(),
                bind::storage::<GpuCut>(),
                bind::storage_rw::<GpuStrand>(),
                vec4(),
                vec4(),
            ],
        );
        let [bend, iterate, finish] = world.compute_pipelines(
            device,
            "cantilever",
            &layout,
            &module,
            ["bend", "iterate", "finish"],
            &[
                ("WORKGROUP", WORKGROUP as f64),
                ("EPS_OUT", crate::scene::head::EPS_OUT),
                ("SDF_EPS_OUT", crate::scene::hull::SDF_EPS_OUT),
                ("CONTACT_BAND", super::cantilever::CONTACT_BAND),
            ],
        );
        Ok(CantileverPass {
            bend,
            iterate,
            finish,
            layout,
        })
    }

    /// Upload a prepared groom's roots and parameters. The scratch buffer of the converged
    /// mode is only allocated when a group uses it.
    pub fn prepare(
        &self,
        gpu: &Gpu,
        world: &WorldGpu,
        input: &GroomInput,
        strands: &StrandBuffers,
    ) -> Result<CantileverJob> {
        let device = &gpu.device;
        let roots: Vec<GpuRoot> = input
            .roots
            .iter()
            .map(|r| GpuRoot {
                pos: [
                    r.pos.x as f32,
                    r.pos.y as f32,
                    r.pos.z as f32,
                    r.seg_len as f32,
                ],
                dir: [
                    r.dir.x as f32,
                    r.dir.y as f32,
                    r.dir.z as f32,
                    f32::from_bits(r.cut_mask),
                ],
            })
            .collect();
        let mut groups = Vec::new();
        let mut loads = Vec::new();
        let mut cuts = Vec::new();
        for g in &input.groups {
            let (mode, max_iterations, tolerance) = match g.mode {
                BendMode::Paper => (0, 0, 0.0),
                BendMode::Converged {
                    max_iterations,
                    tolerance,
                } => (1, max_iterations, tolerance as f32),
            };
            groups.push(GpuGroomGroup {
                segments: g.segments,
                mode,
                max_iterations,
                first_load: loads.len() as u32,
                load_count: g.loads.len() as u32,
                first_cut: cuts.len() as u32,
                cut_count: g.cuts.len() as u32,
                rigidity: g.rigidity as f32,
                tolerance,
                ..Default::default()
            });
            loads.extend(g.loads.iter().map(gpu_load));
            cuts.extend(g.cuts.iter().map(gpu_cut));
        }
        let converged = input
            .groups
            .iter()
            .any(|g| matches!(g.mode, BendMode::Converged { .. }));
        // Two vec4 per node for the converged iteration; a placeholder otherwise.
        let node2 = std::mem::size_of::<[[f32; 4]; 2]>() as u64;
        let scratch_bytes = if converged {
            strands.vertex_count as u64 * node2
        } else {
            crate::gpu::strands::NODE
        };
        gpu.check_storage_size("the converged-bending scratch buffer", scratch_bytes)?;
        let dims = gpu.dispatch_dims(strands.strand_count, WORKGROUP)?;
        let (mut chunk, mut most) = (64u32, 0u32);
        for g in &input.groups {
            if let BendMode::Converged { max_iterations, .. } = g.mode {
                let load_loops: u32 = g.loads.iter().map(|l| 1 + l.planes.len() as u32).sum();
                chunk = chunk.min(iterations_per_dispatch(g.segments, load_loops));
                most = most.max(max_iterations);
            }
        }
        let params = GpuGroomParams {
            strand_count: strands.strand_count,
            total_vertices: strands.vertex_count,
            row_stride: dims.0 * WORKGROUP,
            chunk,
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cantilever params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let none = wgpu::BufferUsages::empty();
        let roots = gpu::storage_buffer(
            device,
            "cantilever roots",
            bytemuck::cast_slice(&roots),
            none,
        );
        let groups = gpu::storage_buffer(
            device,
            "cantilever groups",
            bytemuck::cast_slice(&groups),
            none,
        );
        let loads = gpu::storage_buffer(
            device,
            "cantilever loads",
            bytemuck::cast_slice(&loads),
            none,
        );
        let cuts =
            gpu::storage_buffer(device, "cantilever cuts", bytemuck::cast_slice(&cuts), none);
        let scratch = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cantilever scratch"),
            size: scratch_bytes,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let bind_group = bind::buffers(
            device,
            "cantilever",
            &self.layout,
            &[
                &params,
                &roots,
                &groups,
                &loads,
                &cuts,
                &strands.strands,
                &strands.vertices,
                &scratch,
            ],
        );
        Ok(CantileverJob {
            bind_group,
            world: world.group().clone(),
            dims,
            iterate_dispatches: most.div_ceil(chunk),
        })
    }

    /// Record the bend of every strand.
    pub fn dispatch(&self, enc: &mut wgpu::CommandEncoder, job: &CantileverJob) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("cantilever"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &job.bind_group, &[]);
        pass.set_bind_group(WORLD_GROUP, &job.world, &[]);
        pass.set_pipeline(&self.bend);
        pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
        if job.iterate_dispatches > 0 {
            pass.set_pipeline(&self.iterate);
            for _ in 0..job.iterate_dispatches {
                pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
            }
        }
        pass.set_pipeline(&self.finish);
        pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
    }
}

fn gpu_load(l: &ResolvedLoad) -> GpuLoad {
    let mut out = GpuLoad::default();
    match l.field {
        LoadField::Uniform(f) => out.field = [f.x as f32, f.y as f32, f.z as f32, 0.0],
        LoadField::Toward { point, strength } => {
            out.field = [point.x as f32, point.y as f32, point.z as f32, 1.0];
            out.params[0] = strength as f32;
        }
    }
    out.params[1] = l.planes.len() as f32;
    for (i, (n, o)) in l.planes.iter().enumerate() {
        out.planes[i] = [n.x as f32, n.y as f32, n.z as f32, *o as f32];
    }
    out
}

fn gpu_cut(c: &CutRule) -> GpuCut {
    match c {
        CutRule::Below(y) => GpuCut {
            kind: 0,
            a: [*y as f32, 0.0, 0.0, 0.0],
            ..Default::default()
        },
        CutRule::ByPoreHeight { low, high } => GpuCut {
            kind: 1,
            a: [low.0 as f32, low.1 as f32, high.0 as f32, high.1 as f32],
            ..Default::default()
        },
        CutRule::Near { center, radius } => GpuCut {
            kind: 2,
            a: [
                center[0] as f32,
                center[1] as f32,
                center[2] as f32,
                *radius as f32,
            ],
            ..Default::default()
        },
    }
}

/// Groom a whole scene on the GPU and wait: strand buffers holding the bent hair. `world` is
/// the scene's (its hull is `input.head`).
pub fn groom_gpu(gpu: &Gpu, world: &WorldGpu, input: &GroomInput) -> Result<StrandBuffers> {
    let strands = input.strand_buffers(gpu)?;
    let pass = CantileverPass::new(gpu, world)?;
    let job = pass.prepare(gpu, world, input, &strands)?;
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("groom"),
        });
    pass.dispatch(&mut enc, &job);
    gpu.queue.submit([enc.finish()]);
    // Groups read from strand files keep the file's shapes: their nodes replace what the
    // kernel wrote (queued writes run before the next submission, so after the bending).
    let offsets = input.vertex_offsets();
    let mut wrote = false;
    for g in &input.groups {
        let Some(shapes) = &g.shapes else { continue };
        let nodes: Vec<[f32; 4]> = shapes
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
            .collect();
        let at = offsets[g.first_strand as usize] as u64 * crate::gpu::strands::NODE;
        gpu.queue
            .write_buffer(&strands.vertices, at, bytemuck::cast_slice(&nodes));
        wrote = true;
    }
    if wrote {
        gpu.queue.submit([]);
    }
    gpu.wait()?;
    gpu.take_error()?;
    Ok(strands)
}
