//! The meshed path's surface polygonised on the GPU (`block::MeshOn::Gpu`,
//! `shaders/wisps/mesher.wgsl`): the f64 mesher's surface nets (`super::mesh`, its reference)
//! over the segments `CurvePass` wrote this frame, into vertex and index buffers drawn
//! indirectly, so moving wisps are meshed every frame without their nodes coming back to the
//! CPU.
//!
//! The grid is fixed per view: a box round the sphere that holds every place the wisps can
//! reach (`march::bounds`, posed by the head), on a lattice of whole cells so the head's
//! motion never shifts it by a fraction of a cell. The buffers are sized before anything is
//! allocated from the wisps at rest (`plan`): the bricks their hit capsules can reach, the
//! vertices their surface can hold; past a capacity the kernels write nothing and count
//! what they dropped (`Counters`), which `warnings` reports.

use super::curve;
use super::march::CurvePass;
use super::mesh::{self, GridFrame, WispMesh, BRICK};
use crate::error::{KamiError, Result};
use crate::gpu::{self, bind, Gpu};
use crate::shaders::wgsl;
use crate::systems::wisps::block::{Distance, Wisps};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// The mesher's kernels.
pub const MESHER: &str = wgsl!(
    "common/chord.wgsl",
    "wisps/segments.wgsl",
    "wisps/field.wgsl",
    "wisps/mesher.wgsl"
);

const BRICK3: u64 = (BRICK * BRICK * BRICK) as u64;

/// Twin of `Mesher` in `shaders/wisps/mesher.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMesher {
    pub origin: [f32; 4],
    pub dims: [u32; 4],
    pub bricks: [u32; 4],
    pub caps: [u32; 4],
    pub offs: [u32; 4],
    pub shape: [f32; 4],
    pub method: [u32; 4],
}

/// The counters the kernels leave (`shaders/wisps/mesher.wgsl`, binding 8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Bricks reached (slots asked for).
    pub slots: u32,
    /// Vertices asked for.
    pub vertices: u32,
    /// Indices asked for.
    pub indices: u32,
    /// Bricks whose segment list was cut at the list capacity.
    pub lists_cut: u32,
    /// Bricks past the slot capacity (not meshed).
    pub slots_over: u32,
    /// Vertices past the vertex capacity (dropped, with their quads).
    pub vertices_over: u32,
    /// Quads past the index capacity (dropped).
    pub quads_over: u32,
    /// The longest segment list of a brick.
    pub longest_list: u32,
    /// Indices the indirect draw draws.
    pub drawn: u32,
}

impl Counters {
    /// Whether anything was dropped.
    pub fn overflowed(&self) -> bool {
        self.lists_cut + self.slots_over + self.vertices_over + self.quads_over > 0
    }
}

const COUNTERS: u64 = 16 * 4;
/// Byte offset of the indirect draw's arguments in the counters.
const DRAW_ARGS: u64 = 8 * 4;
/// Byte offset of the indirect dispatch over the slots.
const DISPATCH_ARGS: u64 = 13 * 4;

/// A grid and the buffers' capacities for one view of one scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    /// The grid's first point (f32 values, as the GPU reads them).
    pub origin: DVec3,
    /// The cell (an f32 value).
    pub cell: f64,
    pub dims: [u32; 3],
    pub bricks: [u32; 3],
    /// Segments a brick's list holds.
    pub list_cap: u32,
    pub slot_cap: u32,
    pub vertex_cap: u32,
    pub index_cap: u32,
}

/// Vertices per unit of surface area and squared cell the capacity allows: a plane crosses
/// at most sqrt(3) cells per cell² of its area, with half again of slack.
const VERTICES_PER_AREA: f64 = 2.6;
/// Bricks moving wisps may reach, over those they reach at rest (a wisp swung across the
/// grid's bricks, or bent, reaches others).
const SLOT_SLACK: f64 = 2.0;

/// The grid's first point for a reach round `centre`: whole cells from the world's origin
/// (moving the reach moves the grid by whole cells), two of margin, as f32 values.
fn anchor(centre: DVec3, radius: f64, cell: f64) -> DVec3 {
    ((((centre - radius) / cell).floor() - 2.0) * cell)
        .as_vec3()
        .as_dvec3()
}

impl Plan {
    /// The same grid and capacities round another centre of the same reach.
    pub fn moved_to(mut self, centre: DVec3, radius: f64) -> Plan {
        self.origin = anchor(centre, radius, self.cell);
        self
    }

    /// The grid as the f64 mesher takes it (its reference).
    pub fn frame(&self) -> GridFrame {
        GridFrame {
            origin: self.origin,
            dims: self.dims.map(|d| d as usize),
        }
    }

    fn dense(&self) -> u64 {
        self.bricks.iter().map(|&b| b as u64).product()
    }

    /// u32s in the index buffer: slot per brick, brick and list length per slot, the lists,
    /// a vertex per cell of each slot.
    fn index_words(&self) -> u64 {
        let s = self.slot_cap as u64;
        self.dense() + 2 * s + s * self.list_cap as u64 + s * BRICK3
    }

    fn offsets(&self) -> [u32; 4] {
        let s = self.slot_cap as u64;
        let d = self.dense();
        let lists = d + 2 * s;
        [
            d as u32,
            (d + s) as u32,
            lists as u32,
            (lists + s * self.list_cap as u64) as u32,
        ]
    }

    /// Bytes of the index, value, vertex and triangle buffers.
    pub fn bytes(&self) -> [u64; 4] {
        [
            self.index_words() * 4,
            self.slot_cap as u64 * BRICK3 * 4,
            self.vertex_cap as u64 * 32,
            self.index_cap as u64 * 4,
        ]
    }
}

/// The grid and capacities for `wisps` whose reach lies in the sphere (`centre`, `radius`)
/// meshed at `cell`, refused with the numbers (naming `wisps.mesh.cell`) before anything is
/// allocated where the grid passes `mesh`'s limits or a buffer passes `limit` bytes.
pub fn plan(wisps: &Wisps, centre: DVec3, radius: f64, cell: f64, limit: u64) -> Result<Plan> {
    let bad = |value: String, allowed: String| KamiError::Invalid {
        file: String::new(),
        field: "wisps.mesh.cell".into(),
        value,
        allowed,
    };
    if !(cell.is_finite() && cell > 0.0 && radius.is_finite() && centre.is_finite()) {
        return Err(bad(
            format!("{cell}"),
            "a positive cell size (scene units)".into(),
        ));
    }
    let cell = cell as f32 as f64;
    let origin = anchor(centre, radius, cell);
    let side = (2.0 * radius / cell).ceil() + 5.0;
    if side > mesh::MAX_POINTS_PER_AXIS as f64 {
        return Err(bad(
            format!("{cell}"),
            format!(
                "a cell the wisps' reach ({:.3} across) spans in at most {} points a side; this \
                 one needs {side}",
                2.0 * radius,
                mesh::MAX_POINTS_PER_AXIS
            ),
        ));
    }
    let dims = [side as u32; 3];
    let bricks = dims.map(|d| d.div_ceil(BRICK as u32));
    let dense = bricks.iter().map(|&b| b as u64).product::<u64>();
    if dense > mesh::MAX_BRICKS {
        return Err(bad(
            format!("{cell}"),
            format!(
                "a grid of at most {} bricks of {BRICK}³ cells over the wisps' reach; this cell \
                 needs {dense}",
                mesh::MAX_BRICKS
            ),
        ));
    }
    // Capacities from the wisps at rest: the bricks the f64 mesher samples there, and their
    // hit capsules' area.
    let segs = curve::drawn_segments(wisps);
    let caps = curve::capsules(&segs, wisps.threshold);
    let at_rest = mesh::reached_bricks(&mesh::Input {
        wisps: &segs,
        outlines: &[],
        taper: 0.0,
        threshold: wisps.threshold,
        method: wisps.march.distance,
        cell,
        frame: None,
    })? as u64;
    let mut area = 0.0;
    let pi = std::f64::consts::PI;
    for c in caps.iter().flatten().filter(|c| c.hit >= 0.0) {
        let l = (c.b - c.a).length();
        area += 2.0 * pi * c.hit * l + 4.0 * pi * c.hit * c.hit;
    }
    let slot_cap = ((SLOT_SLACK * at_rest as f64).ceil() as u64 + 64).min(dense);
    let n_seg = segs.iter().map(|w| w.len() as u64).sum::<u64>().max(1);
    let vertex_cap = (VERTICES_PER_AREA * area / (cell * cell)).ceil() as u64 + 4096;
    let index_cap = 7 * vertex_cap;
    if slot_cap * BRICK3 > mesh::MAX_BRICK_POINTS || vertex_cap > u32::MAX as u64 / 8 {
        return Err(bad(
            format!("{cell}"),
            format!(
                "at most {} grid points near the wisps; this cell needs {} ({slot_cap} bricks \
                 of {BRICK3}), and {vertex_cap} vertices",
                mesh::MAX_BRICK_POINTS,
                slot_cap * BRICK3,
            ),
        ));
    }
    let p = Plan {
        origin,
        cell,
        dims,
        bricks,
        // Each brick's list holds every segment (lists past 64 MiB hold fewer, counted
        // when cut).
        list_cap: n_seg.min((16 << 20) / slot_cap.max(1)).max(1) as u32,
        slot_cap: slot_cap as u32,
        vertex_cap: vertex_cap as u32,
        index_cap: index_cap as u32,
    };
    let names = ["brick index", "grid values", "vertex", "triangle"];
    for (bytes, name) in p.bytes().into_iter().zip(names) {
        if bytes > limit || p.index_words() > u32::MAX as u64 {
            return Err(bad(
                format!("{cell}"),
                format!(
                    "a GPU mesh whose buffers fit the adapter's largest storage buffer ({limit} \
                     bytes); the {name} buffer needs {bytes}: raise the cell"
                ),
            ));
        }
    }
    Ok(p)
}

/// The sized buffers of one plan.
struct Sized {
    plan: Plan,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// The GPU mesher of one wisps system.
pub struct Mesher {
    layout: wgpu::BindGroupLayout,
    pipelines: [wgpu::ComputePipeline; 6],
    params: wgpu::Buffer,
    outlines: wgpu::Buffer,
    counters: wgpu::Buffer,
    /// The indirect dispatch over the slots, copied from the counters (a buffer bound for
    /// storage cannot be a dispatch's arguments in the same pass).
    dispatch: wgpu::Buffer,
    sized: Option<Sized>,
}

/// What the draw binds: positions, normals, indices and the indirect arguments.
pub struct MeshBuffers<'a> {
    pub positions: wgpu::BufferSlice<'a>,
    pub normals: wgpu::BufferSlice<'a>,
    pub indices: &'a wgpu::Buffer,
    pub indirect: &'a wgpu::Buffer,
    pub indirect_offset: u64,
}

impl Mesher {
    pub fn new(gpu: &Gpu, wisps: &Wisps) -> Result<Mesher> {
        let device = &gpu.device;
        gpu.check_storage_buffers("the wisps' GPU mesher", 8)?;
        let layout = bind::layout(
            device,
            "wisp mesher",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuMesher>(),
                bind::storage::<super::march::GpuSegment>(),
                bind::storage::<super::march::GpuCapsule>(),
                bind::storage::<[f32; 4]>(),
                bind::storage_rw::<u32>(),
                bind::storage_rw::<f32>(),
                bind::storage_rw::<[f32; 4]>(),
                bind::storage_rw::<u32>(),
                bind::storage_rw::<[u32; 16]>(),
            ],
        );
        let module = gpu::shader_module(device, "wisps/mesher", MESHER)?;
        let pipelines = gpu::compute_pipelines(
            device,
            "wisp mesher",
            &layout,
            &module,
            ["bricks", "slots", "sample", "cells", "quads", "finish"],
            &[],
        );
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisp mesher params"),
            size: std::mem::size_of::<GpuMesher>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let outlines = super::toon::segment_outlines(wisps);
        let outlines = gpu::storage_buffer(
            device,
            "wisp mesher outlines",
            bytemuck::cast_slice(&outlines),
            wgpu::BufferUsages::COPY_DST,
        );
        let counters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisp mesher counters"),
            size: COUNTERS,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let dispatch = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisp mesher dispatch"),
            size: 16,
            usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Mesher {
            layout,
            pipelines,
            params,
            outlines,
            counters,
            dispatch,
            sized: None,
        })
    }

    /// The plan the buffers are sized for.
    pub fn plan(&self) -> Option<Plan> {
        self.sized.as_ref().map(|s| s.plan)
    }

    /// Record the six kernels over `curves`' segments on `plan`'s grid (buffers made anew
    /// when its capacities change), with `wisps`' threshold, taper, distance method and
    /// outline scales.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        curves: &CurvePass,
        wisps: &Wisps,
        plan: Plan,
    ) {
        let device = &gpu.device;
        let same_sizes = self.sized.as_ref().is_some_and(|s| {
            let mut p = s.plan;
            p.origin = plan.origin;
            p == plan
        });
        if !same_sizes {
            let [index_b, value_b, vertex_b, triangle_b] = plan.bytes();
            let storage = |label, bytes: u64, extra| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.max(256),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | extra,
                    mapped_at_creation: false,
                })
            };
            let empty = wgpu::BufferUsages::empty();
            let index = storage("wisp mesher index", index_b, empty);
            let values = storage("wisp mesher values", value_b, empty);
            let vertices = storage("wisp mesher vertices", vertex_b, wgpu::BufferUsages::VERTEX);
            let indices = storage("wisp mesher indices", triangle_b, wgpu::BufferUsages::INDEX);
            let group = bind::buffers(
                device,
                "wisp mesher",
                &self.layout,
                &[
                    &self.params,
                    &curves.segments,
                    &curves.capsules,
                    &self.outlines,
                    &index,
                    &values,
                    &vertices,
                    &indices,
                    &self.counters,
                ],
            );
            self.sized = Some(Sized {
                plan,
                vertices,
                indices,
                group,
            });
        }
        let sized = self.sized.as_mut().expect("sized above");
        sized.plan = plan;
        let dense = plan.dense() as u32;
        let groups = dense.div_ceil(64);
        let row = groups.min(32768);
        let (method, pieces) = match wisps.march.distance {
            Distance::Newton => (0, 0),
            Distance::Polyline { pieces } => (1, pieces),
        };
        let cell = plan.cell;
        let half_diag = 0.5 * cell * BRICK as f64 * 3f64.sqrt() + 3.0 * 3f64.sqrt() * cell;
        let o = plan.offsets();
        let params = GpuMesher {
            origin: [
                plan.origin.x as f32,
                plan.origin.y as f32,
                plan.origin.z as f32,
                cell as f32,
            ],
            dims: [
                plan.dims[0],
                plan.dims[1],
                plan.dims[2],
                curves.segment_count,
            ],
            bricks: [
                plan.bricks[0],
                plan.bricks[1],
                plan.bricks[2],
                plan.list_cap,
            ],
            caps: [plan.slot_cap, plan.vertex_cap, plan.index_cap, dense],
            offs: o,
            shape: [
                wisps.threshold as f32,
                wisps.toon.outline_taper as f32,
                half_diag as f32,
                0.0,
            ],
            method: [method, pieces, mesh::NEWTON, row],
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let outlines = super::toon::segment_outlines(wisps);
        gpu.queue
            .write_buffer(&self.outlines, 0, bytemuck::cast_slice(&outlines));
        enc.clear_buffer(&self.counters, 0, None);
        let [bricks, slots, sample, cells, quads, finish] = &self.pipelines;
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("wisp mesher bricks"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &sized.group, &[]);
            pass.set_pipeline(bricks);
            pass.dispatch_workgroups(row, groups.div_ceil(row), 1);
            pass.set_pipeline(slots);
            pass.dispatch_workgroups(1, 1, 1);
        }
        enc.copy_buffer_to_buffer(&self.counters, DISPATCH_ARGS, &self.dispatch, 0, 12);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wisp mesher surface"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &sized.group, &[]);
        for p in [sample, cells, quads] {
            pass.set_pipeline(p);
            pass.dispatch_workgroups_indirect(&self.dispatch, 0);
        }
        pass.set_pipeline(finish);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// The buffers the draw binds (None before the first `record`).
    pub fn buffers(&self) -> Option<MeshBuffers<'_>> {
        let s = self.sized.as_ref()?;
        let half = s.plan.vertex_cap as u64 * 16;
        Some(MeshBuffers {
            positions: s.vertices.slice(..half),
            normals: s.vertices.slice(half..2 * half),
            indices: &s.indices,
            indirect: &self.counters,
            indirect_offset: DRAW_ARGS,
        })
    }

    /// The counters of the last run (a readback: tests, benches, warnings).
    pub fn counters(&self, gpu: &Gpu) -> Result<Counters> {
        let c = gpu::read_buffer::<u32>(gpu, &self.counters, COUNTERS)?;
        Ok(Counters {
            slots: c[0],
            vertices: c[1],
            indices: c[2],
            lists_cut: c[3],
            slots_over: c[4],
            vertices_over: c[5],
            quads_over: c[6],
            longest_list: c[7],
            drawn: c[8],
        })
    }

    /// The mesh of the last run, read back (tests, benches), with its counters.
    pub fn read(&self, gpu: &Gpu) -> Result<(WispMesh, Counters)> {
        let c = self.counters(gpu)?;
        let Some(s) = &self.sized else {
            return Ok((WispMesh::default(), c));
        };
        let n = c.vertices.min(s.plan.vertex_cap) as u64;
        let all = gpu::read_buffer::<[f32; 4]>(gpu, &s.vertices, s.plan.vertex_cap as u64 * 32)?;
        let half = s.plan.vertex_cap as usize;
        let indices = if c.drawn > 0 {
            gpu::read_buffer::<u32>(gpu, &s.indices, c.drawn as u64 * 4)?
        } else {
            Vec::new()
        };
        let mesh = WispMesh {
            positions: all[..n as usize].to_vec(),
            normals: all[half..half + n as usize].to_vec(),
            indices,
            points: c.slots.min(s.plan.slot_cap) as u64 * BRICK3,
            dims: s.plan.dims.map(|d| d as usize),
            worst_offset: 0.0,
        };
        Ok((mesh, c))
    }
}
