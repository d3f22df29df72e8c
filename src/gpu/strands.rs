//! The strand buffers every solver writes and every hair pass reads: one `Strand` record per
//! hair (offset into the vertices, segment count, group, drawn length, per-strand look) and
//! one `vec4` per node. Positions never travel back to the CPU in the frame loop.

use super::gpu_data::GpuStrand;
use super::{storage_buffer, Gpu};
use crate::error::Result;
use crate::groom::GroomInput;
use crate::rng::hash_unit;

/// A run of strands drawn with one instanced call: same node count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawRange {
    pub first_strand: u32,
    pub strand_count: u32,
    pub nodes_per_strand: u32,
}

pub struct StrandBuffers {
    pub strands: wgpu::Buffer,
    pub vertices: wgpu::Buffer,
    pub strand_count: u32,
    pub vertex_count: u32,
    pub ranges: Vec<DrawRange>,
}

impl StrandBuffers {
    /// Allocate for a prepared groom (nodes are written by the groom kernel).
    pub fn new(gpu: &Gpu, input: &GroomInput) -> Result<StrandBuffers> {
        let offsets = input.vertex_offsets();
        let vertex_count = *offsets.last().unwrap();
        let records: Vec<GpuStrand> = input
            .roots
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let k = input.groups[r.group as usize].segments;
                GpuStrand {
                    first_vertex: offsets[i],
                    segments: k,
                    group: r.group,
                    flags: 0,
                    visible: k as f32,
                    ka: r.ka as f32,
                    seg_len: r.seg_len as f32,
                    rand: hash_unit(i as u32),
                }
            })
            .collect();
        let vbytes = vertex_count as u64 * 16;
        gpu.check_storage_size("the hair vertex buffer", vbytes)?;
        gpu.check_storage_size("the strand table", records.len() as u64 * 32)?;
        let strands = storage_buffer(
            &gpu.device,
            "strands",
            bytemuck::cast_slice(&records),
            wgpu::BufferUsages::COPY_SRC,
        );
        let vertices = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strand vertices"),
            size: vbytes.max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let ranges = input
            .groups
            .iter()
            .map(|g| DrawRange {
                first_strand: g.first_strand,
                strand_count: g.strand_count,
                nodes_per_strand: g.segments + 1,
            })
            .collect();
        Ok(StrandBuffers {
            strands,
            vertices,
            strand_count: records.len() as u32,
            vertex_count,
            ranges,
        })
    }

    /// Buffers for runs of strands of fixed node counts: `(count, segments, group)` per run,
    /// laid out one after the other (fur: one run per coat).
    pub fn from_runs(gpu: &Gpu, runs: &[(u32, u32, u32)]) -> Result<StrandBuffers> {
        let mut records = Vec::new();
        let mut ranges = Vec::new();
        let mut vertex = 0u64;
        for &(count, segments, group) in runs {
            ranges.push(DrawRange {
                first_strand: records.len() as u32,
                strand_count: count,
                nodes_per_strand: segments + 1,
            });
            for _ in 0..count {
                let i = records.len() as u32;
                records.push(GpuStrand {
                    first_vertex: vertex as u32,
                    segments,
                    group,
                    flags: 0,
                    visible: segments as f32,
                    ka: 1.0,
                    seg_len: 0.0,
                    rand: hash_unit(i),
                });
                vertex += segments as u64 + 1;
            }
        }
        gpu.check_storage_size("the fur vertex buffer", vertex * 16)?;
        gpu.check_storage_size("the fur strand table", records.len() as u64 * 32)?;
        if vertex > u32::MAX as u64 {
            return Err(crate::error::KamiError::TooLarge {
                what: "the fur vertex count".into(),
                needed: vertex,
                limit: u32::MAX as u64,
                hint: "use fewer hairs".into(),
            });
        }
        let strands = storage_buffer(
            &gpu.device,
            "fur strands",
            bytemuck::cast_slice(&records),
            wgpu::BufferUsages::COPY_SRC,
        );
        let vertices = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur vertices"),
            size: (vertex * 16).max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(StrandBuffers {
            strands,
            vertices,
            strand_count: records.len() as u32,
            vertex_count: vertex as u32,
            ranges,
        })
    }

    /// Read all node positions back (tests and benchmarks only).
    pub fn read_vertices(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>> {
        super::read_buffer(gpu, &self.vertices, self.vertex_count as u64 * 16)
    }

    /// Read the strand records back (tests and benchmarks only).
    pub fn read_strands(&self, gpu: &Gpu) -> Result<Vec<GpuStrand>> {
        super::read_buffer(gpu, &self.strands, self.strand_count as u64 * 32)
    }
}
