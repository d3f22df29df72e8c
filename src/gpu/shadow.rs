//! The shadow structure's GPU side (`stage::shadow` owns the pass): the uniform every
//! shading module reads (`shaders/common/shadow.wgsl`, group 0 bindings 1 and 2 beside the
//! frame uniform) and the cast layout (group 2 of every kind's cast pipeline,
//! `shaders/common/shadow_cast.wgsl`). The read side and the cast side are different
//! buffers (the resolve copies one into the other), since wgpu forbids one buffer read-only
//! and read-write in one dispatch.

use crate::gpu;
use bytemuck::{Pod, Zeroable};

/// Fixed-point scale of cast coverage; keep in sync with `shaders/common/shadow_cast.wgsl`.
pub const FIXED: f64 = 4096.0;

/// Keep in sync with `struct ShadowParams` in `shaders/common/shadow.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShadow {
    /// xyz: centre of the light-space box; w: 1 while shadows are on.
    pub center: [f32; 4],
    /// xyz: unit axis across the light; w: half the box's size.
    pub axis_u: [f32; 4],
    /// xyz: the other axis across; w: method (0 volume, 1 deep opacity).
    pub axis_v: [f32; 4],
    /// xyz: unit towards the light; w: absorption per strand.
    pub axis_l: [f32; 4],
    /// x, y: cells across; z: slices or layers; w: 1 with a head that shadows.
    pub dims: [f32; 4],
    /// Deep opacity: where each layer ends, world distance behind the first depth.
    pub layers: [f32; 4],
    /// World to the head ellipsoid's unit sphere.
    pub head_inv: [[f32; 4]; 4],
}

const _: () = assert!(std::mem::size_of::<GpuShadow>() == 160);

/// What every shader stage may read: group 0's bindings 1 (the uniform) and 2 (the
/// resolved structure), added to the frame layout.
pub fn read_entries() -> [wgpu::BindGroupLayoutEntry; 2] {
    let all = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
    [
        gpu::uniform_entry(1, all),
        gpu::storage_entry(2, all, true),
    ]
}

/// Group 2 of a cast pipeline: the coverage being cast (read-write) and the phase.
pub fn cast_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    gpu::pipeline::layout(
        device,
        "shadow cast",
        &[
            gpu::storage_entry(0, wgpu::ShaderStages::COMPUTE, false),
            gpu::uniform_entry(1, wgpu::ShaderStages::COMPUTE),
        ],
    )
}

/// Group 0 of every draw and cast: the frame uniform (binding 0,
/// `shaders/common/frame.wgsl`) and the shadow's read side (bindings 1 and 2).
pub fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let [shadow_uniform, shadow_map] = read_entries();
    gpu::pipeline::layout(
        device,
        "frame",
        &[
            gpu::uniform_entry(
                0,
                wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
            ),
            shadow_uniform,
            shadow_map,
        ],
    )
}

/// A group 0 over `frame` with shadows off (passes drawn outside the stage: tests).
pub fn frame_group_without_shadows(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    frame: &wgpu::Buffer,
) -> wgpu::BindGroup {
    let off = wgpu::util::DeviceExt::create_buffer_init(
        device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("shadows off"),
            contents: bytemuck::bytes_of(&GpuShadow::default()),
            usage: wgpu::BufferUsages::UNIFORM,
        },
    );
    let placeholder = gpu::storage_buffer(device, "no shadows", &[], wgpu::BufferUsages::empty());
    gpu::pipeline::bind_buffers(device, "frame", layout, &[frame, &off, &placeholder])
}
