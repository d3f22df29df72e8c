//! Fur generation on the GPU (`shaders/fur/generate.wgsl`): the f32 twin of the f64
//! reference `setup::hair_points`, one invocation per hair slot, refilled every frame from
//! the root table and the (moving) mesh; `tests/it/fur.rs` compares them.

use super::gpu_data::GpuFurCoat;
use super::setup::{FurSetup, TABLE};
use crate::error::Result;
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::systems::fur::block::{FurStyle, MeshMotion};
use glam::DVec3;

/// Bytes of one coat's uniform record (the dynamic-offset alignment).
const SLOT: u64 = 256;
const U32: u64 = std::mem::size_of::<u32>() as u64;
/// The skin's joint matrices, the uniform `joints: array<mat4x4<f32>, MAX_JOINTS>` of
/// `shaders/fur/generate.wgsl` and `shaders/fur/skin.wgsl`.
pub type GpuJoints = [[f32; 16]; crate::scene::skinned::MAX_JOINTS];
/// Bytes of the joint-matrix uniform.
const JOINTS: u64 = std::mem::size_of::<GpuJoints>() as u64;
/// Bytes of one hair slot's info: (skin normal, random), (hair-plane normal, 0).
pub const INFO: u64 = std::mem::size_of::<[[f32; 4]; 2]>() as u64;

/// Style code shared with the shaders.
pub fn style_code(s: FurStyle) -> u32 {
    match s {
        FurStyle::Line => 0,
        FurStyle::Polyline => 1,
        FurStyle::Curve => 2,
        FurStyle::Tube => 3,
    }
}

/// The fur generator on the GPU (`shaders/fur/generate.wgsl`) and the buffers it fills: one strand
/// slot per hair a coat may draw, refilled every frame from the root table and the (moving)
/// mesh. Only `drawn[coat]` slots of each coat are written and drawn.
pub struct FurGpu {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    coats: wgpu::Buffer,
    offsets: wgpu::Buffer,
    /// Hair slots: vertices and the strand table (coat = group).
    pub strands: StrandBuffers,
    /// Two vec4 per slot: (skin normal, random), (hair-plane normal, 0).
    pub info: wgpu::Buffer,
    /// Hairs drawn per coat this frame.
    pub drawn: Vec<u32>,
    /// The mesh (two vec4 per vertex) and triangles, shared with the skin pass.
    pub mesh: wgpu::Buffer,
    pub tris: wgpu::Buffer,
    /// The skin's joint matrices (MAX_JOINTS mat4), written every frame when skinned;
    /// shared with the skin pass.
    pub joints: wgpu::Buffer,
    /// Where the skin's joints and weights start in `mesh` (0: not skinned).
    pub skin_base: u32,
    culling: f64,
    tri_count: u32,
}

/// The generation kernel's layout and pipeline (`shaders/fur/generate.wgsl`).
fn generate_pipeline(
    device: &wgpu::Device,
) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline)> {
    let module = gpu::shader_module(device, "fur generate", super::GENERATE)?;
    let layout = bind::layout(
        device,
        "fur_gen",
        wgpu::ShaderStages::COMPUTE,
        &[
            bind::dynamic_uniform::<GpuFurCoat>(),
            bind::storage::<[f32; 4]>(),
            bind::storage::<[u32; 4]>(),
            bind::storage::<u32>(),
            bind::storage::<u32>(),
            bind::storage::<[f32; 2]>(),
            bind::storage_rw::<[f32; 4]>(),
            bind::storage_rw::<[f32; 4]>(),
            bind::storage::<[f32; 4]>(),
            bind::uniform::<GpuJoints>(),
        ],
    );
    let [pipeline] = gpu::compute_pipelines(
        device,
        "fur generate",
        &layout,
        &module,
        ["generate"],
        &[
            ("WORKGROUP", WORKGROUP as f64),
            ("TABLE", TABLE as f64),
            ("EPS_OUT", crate::scene::head::EPS_OUT),
        ],
    );
    Ok((layout, pipeline))
}

/// The mesh as the kernel reads it: two vec4 per vertex (position and hair length, normal),
/// then, for a skin, two more per vertex (joint indices as floats, weights) from the
/// returned base.
fn mesh_words(setup: &FurSetup) -> (Vec<[f32; 4]>, u32) {
    let mut mesh: Vec<[f32; 4]> = setup
        .mesh
        .positions
        .iter()
        .zip(&setup.mesh.normals)
        .zip(&setup.lengths)
        .flat_map(|((p, n), l)| {
            [
                [p.x as f32, p.y as f32, p.z as f32, *l as f32],
                [n.x as f32, n.y as f32, n.z as f32, 0.0],
            ]
        })
        .collect();
    // A skin appends two vec4 per vertex: joint indices (as floats), weights.
    let skin_base = match &setup.skin {
        None => 0,
        Some(sk) => {
            let base = mesh.len() as u32;
            for (j, w) in sk.joints.iter().zip(&sk.weights) {
                mesh.push(j.map(|x| x as f32));
                mesh.push(w.map(|x| x as f32));
            }
            base
        }
    };
    (mesh, skin_base)
}

impl FurGpu {
    pub fn new(gpu: &Gpu, setup: &FurSetup) -> Result<FurGpu> {
        let device = &gpu.device;
        let (layout, pipeline) = generate_pipeline(device)?;
        let runs: Vec<(u32, u32, u32)> = setup
            .fur
            .coats
            .iter()
            .zip(&setup.coats)
            .enumerate()
            .map(|(i, (c, a))| (a.total, c.style.segments(), i as u32))
            .collect();
        let strands = StrandBuffers::from_runs(gpu, "fur", &runs)?;
        let (mesh, skin_base) = mesh_words(setup);
        let tris: Vec<[u32; 4]> = setup
            .mesh
            .triangles
            .iter()
            .map(|t| [t[0], t[1], t[2], 0])
            .collect();
        let first: Vec<u32> = setup
            .coats
            .iter()
            .flat_map(|a| a.first.iter().copied())
            .collect();
        let table: Vec<[f32; 2]> = setup
            .table
            .iter()
            .map(|b| [b[0] as f32, b[1] as f32])
            .collect();
        let dirs: Vec<[f32; 4]> = setup.directions.iter().map(|d| vec4(*d)).collect();
        let tri_count = setup.mesh.triangles.len() as u32;
        let none = wgpu::BufferUsages::empty();
        let mesh = gpu::storage_buffer(device, "fur mesh", bytemuck::cast_slice(&mesh), none);
        gpu.check_storage_size("the fur mesh", mesh.size())?;
        let dirs = gpu::storage_buffer(device, "fur directions", bytemuck::cast_slice(&dirs), none);
        let tris_buf =
            gpu::storage_buffer(device, "fur triangles", bytemuck::cast_slice(&tris), none);
        let first = gpu::storage_buffer(
            device,
            "fur first hairs",
            bytemuck::cast_slice(&first),
            none,
        );
        let offsets = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur drawn offsets"),
            size: (setup.coats.len() as u64 * (tri_count as u64 + 1) * U32).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let table = gpu::storage_buffer(
            device,
            "fur barycentric table",
            bytemuck::cast_slice(&table),
            none,
        );
        let info = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur strand info"),
            size: (strands.strand_count as u64 * INFO).max(INFO),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let coats = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur coats"),
            size: setup.coats.len() as u64 * SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let joints = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur joints"),
            size: JOINTS,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = bind::group(
            device,
            "fur_gen",
            &layout,
            &[
                bind::record(&coats, SLOT),
                mesh.as_entire_binding(),
                tris_buf.as_entire_binding(),
                first.as_entire_binding(),
                offsets.as_entire_binding(),
                table.as_entire_binding(),
                strands.vertices.as_entire_binding(),
                info.as_entire_binding(),
                dirs.as_entire_binding(),
                joints.as_entire_binding(),
            ],
        );
        Ok(FurGpu {
            pipeline,
            bind_group,
            coats,
            offsets,
            strands,
            info,
            drawn: vec![0; setup.coats.len()],
            mesh,
            tris: tris_buf,
            joints,
            skin_base,
            culling: f64::NAN,
            tri_count,
        })
    }

    /// Record the generation of every coat's drawn hairs at `frame` with culling factor `c`.
    /// Writes go through the queue: one call per submission.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        setup: &FurSetup,
        frame: f64,
        c: f64,
    ) -> Result<()> {
        let t = self.tri_count as usize;
        if c != self.culling {
            let mut all = Vec::with_capacity(setup.coats.len() * (t + 1));
            for (ci, d) in self.drawn.iter_mut().enumerate() {
                let off = setup.culled_offsets(ci, c);
                *d = off[t];
                all.extend(off);
            }
            gpu.queue
                .write_buffer(&self.offsets, 0, bytemuck::cast_slice(&all));
            self.culling = c;
        }
        let fur = &setup.fur;
        let (motion, axis, dir) = motion_uniform(fur.motion.as_ref(), frame);
        let mut bytes = Vec::new();
        for (ci, (coat, alloc)) in fur.coats.iter().zip(&setup.coats).enumerate() {
            let range = self.strands.ranges[ci];
            let first_vertex = self.first_vertex_of(ci);
            let g = GpuFurCoat {
                drawn: self.drawn[ci],
                segments: coat.style.segments(),
                style: style_code(coat.style),
                tri_count: self.tri_count,
                first_vertex: first_vertex as u32,
                first_strand: range.first_strand,
                seed: alloc.seed,
                first_base: (ci * t) as u32,
                offset_base: (ci * (t + 1)) as u32,
                rel_length: coat.relative_length as f32,
                floppiness: (1.0 - coat.stiffness).max(0.02) as f32,
                end_rand: coat.end_randomize as f32,
                dir_weight: coat.direction_weight as f32,
                skin_base: self.skin_base,
                _pad: [0; 2],
                up: vec4(DVec3::from(fur.up).normalize()),
                motion,
                motion_axis: axis,
                motion_dir: dir,
                _slot: [0; 32],
            };
            bytes.extend_from_slice(bytemuck::bytes_of(&g));
        }
        gpu.queue.write_buffer(&self.coats, 0, &bytes);
        if let Some(mats) = setup.joint_matrices(frame) {
            let m: Vec<[f32; 16]> = mats
                .iter()
                .map(|m| m.to_cols_array().map(|x| x as f32))
                .collect();
            gpu.queue
                .write_buffer(&self.joints, 0, bytemuck::cast_slice(&m));
        }
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("fur_gen"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        for (ci, &n) in self.drawn.iter().enumerate() {
            if n == 0 {
                continue;
            }
            let (x, y) = gpu.dispatch_dims(n, WORKGROUP)?;
            pass.set_bind_group(0, &self.bind_group, &[(ci as u64 * SLOT) as u32]);
            pass.dispatch_workgroups(x, y, 1);
        }
        Ok(())
    }

    /// First vertex of coat `ci`'s slots.
    fn first_vertex_of(&self, ci: usize) -> u64 {
        self.strands.ranges[..ci]
            .iter()
            .map(|r| r.strand_count as u64 * r.nodes_per_strand as u64)
            .sum()
    }
}

fn vec4(v: DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

/// The motion uniform (amplitude, k, phase, on), axis and direction.
pub fn motion_uniform(m: Option<&MeshMotion>, frame: f64) -> ([f32; 4], [f32; 4], [f32; 4]) {
    match m {
        None => ([0.0; 4], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]),
        Some(m) => (
            [
                m.amplitude as f32,
                (std::f64::consts::TAU / m.wavelength) as f32,
                (std::f64::consts::TAU * (frame / m.period).fract()) as f32,
                1.0,
            ],
            vec4(DVec3::from(m.axis).normalize()),
            vec4(DVec3::from(m.direction).normalize()),
        ),
    }
}
