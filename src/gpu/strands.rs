//! The strand buffers every solver writes and every hair pass reads: one `Strand` record per
//! hair (offset into the vertices, segment count, group, drawn length, per-strand look) and
//! one `vec4` per node. Positions never travel back to the CPU in the frame loop.

use super::gpu_data::GpuStrand;
use super::{storage_buffer, Gpu};
use crate::error::{KamiError, Result};
use crate::rng::hash_unit;

/// Bytes of one node (`vec4<f32>`) and of one strand record.
pub const NODE: u64 = std::mem::size_of::<[f32; 4]>() as u64;
pub const RECORD: u64 = std::mem::size_of::<GpuStrand>() as u64;

/// A run of strands drawn with one instanced call: same node count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawRange {
    pub first_strand: u32,
    pub strand_count: u32,
    pub nodes_per_strand: u32,
}

/// Node indices are `u32` on the GPU.
fn check_vertex_count(label: &str, count: u64) -> Result<()> {
    if count > u32::MAX as u64 {
        return Err(KamiError::TooLarge {
            what: format!("the {label} vertex count"),
            needed: count,
            limit: u32::MAX as u64,
            hint: "use fewer hairs or segments".into(),
        });
    }
    Ok(())
}

pub struct StrandBuffers {
    pub strands: wgpu::Buffer,
    pub vertices: wgpu::Buffer,
    pub strand_count: u32,
    pub vertex_count: u32,
    pub ranges: Vec<DrawRange>,
}

impl StrandBuffers {
    /// Allocate for these strand records (`label` names the buffers, e.g. "hair" or "fur");
    /// the nodes are written by a solver or generator. Records must be laid out one after
    /// the other (`first_vertex` increasing), `ranges` covering them.
    pub fn new(
        gpu: &Gpu,
        label: &str,
        records: &[GpuStrand],
        ranges: Vec<DrawRange>,
    ) -> Result<StrandBuffers> {
        let vertex_count: u64 = records
            .last()
            .map_or(0, |r| r.first_vertex as u64 + r.segments as u64 + 1);
        check_vertex_count(label, vertex_count)?;
        let vbytes = vertex_count * NODE;
        gpu.check_storage_size(&format!("the {label} vertex buffer"), vbytes)?;
        gpu.check_storage_size(
            &format!("the {label} strand table"),
            records.len() as u64 * RECORD,
        )?;
        let strands = storage_buffer(
            &gpu.device,
            &format!("{label} strands"),
            bytemuck::cast_slice(records),
            wgpu::BufferUsages::COPY_SRC,
        );
        let vertices = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label} vertices")),
            size: vbytes.max(NODE),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(StrandBuffers {
            strands,
            vertices,
            strand_count: records.len() as u32,
            vertex_count: vertex_count as u32,
            ranges,
        })
    }

    /// Buffers for runs of strands of fixed node counts: `(count, segments, group)` per run,
    /// laid out one after the other (fur: one run per coat).
    pub fn from_runs(gpu: &Gpu, label: &str, runs: &[(u32, u32, u32)]) -> Result<StrandBuffers> {
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
                check_vertex_count(label, vertex)?;
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
        Self::new(gpu, label, &records, ranges)
    }

    /// Read all node positions back (tests and benchmarks only).
    pub fn read_vertices(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>> {
        super::read_buffer(gpu, &self.vertices, self.vertex_count as u64 * NODE)
    }

    /// Read the strand records back (tests and benchmarks only).
    pub fn read_strands(&self, gpu: &Gpu) -> Result<Vec<GpuStrand>> {
        super::read_buffer(gpu, &self.strands, self.strand_count as u64 * RECORD)
    }
}
