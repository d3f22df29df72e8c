//! Passes declare their bindings by type, in order. A layout is a list of [`Slot`]s whose
//! binding numbers are their positions (as Bevy's `BindGroupLayoutEntries::sequential`), and a
//! bind group is the list of resources in the same order: no binding number is typed by hand
//! outside this module. A buffer slot takes its `min_binding_size` from the Rust type it holds
//! (the struct, or the element of a runtime-sized array), so wgpu checks at pipeline creation
//! that the shader's view of the binding fits the Rust type, and at bind time that the buffer
//! holds at least one.

use bytemuck::Pod;
use std::num::NonZeroU64;

/// One binding of a layout: its type, and the stages that see it where they differ from the
/// layout's own (`seen_by`).
#[derive(Clone, Copy, Debug)]
pub struct Slot {
    pub ty: wgpu::BindingType,
    pub visibility: Option<wgpu::ShaderStages>,
}

impl Slot {
    fn of(ty: wgpu::BindingType) -> Self {
        Self {
            ty,
            visibility: None,
        }
    }

    /// This binding is seen by `stages` rather than the layout's stages.
    pub fn seen_by(self, stages: wgpu::ShaderStages) -> Self {
        Self {
            visibility: Some(stages),
            ..self
        }
    }
}

/// The size of `T` as a binding's minimum (a zero-sized type leaves the minimum to the
/// shader).
fn min_size<T: Pod>() -> Option<NonZeroU64> {
    NonZeroU64::new(std::mem::size_of::<T>() as u64)
}

fn buffer(ty: wgpu::BufferBindingType, dynamic: bool, min: Option<NonZeroU64>) -> Slot {
    Slot::of(wgpu::BindingType::Buffer {
        ty,
        has_dynamic_offset: dynamic,
        min_binding_size: min,
    })
}

/// A uniform block holding a `T`.
pub fn uniform<T: Pod>() -> Slot {
    buffer(wgpu::BufferBindingType::Uniform, false, min_size::<T>())
}

/// A uniform block holding a `T`, read at a dynamic offset (one record per dispatch: the
/// substeps of a frame, the coats of a fur).
pub fn dynamic_uniform<T: Pod>() -> Slot {
    buffer(wgpu::BufferBindingType::Uniform, true, min_size::<T>())
}

/// A read-only storage buffer of `T` (a struct, or the element of a runtime-sized array).
pub fn storage<T: Pod>() -> Slot {
    buffer(
        wgpu::BufferBindingType::Storage { read_only: true },
        false,
        min_size::<T>(),
    )
}

/// A read-write storage buffer of `T` (a struct, or the element of a runtime-sized array).
pub fn storage_rw<T: Pod>() -> Slot {
    buffer(
        wgpu::BufferBindingType::Storage { read_only: false },
        false,
        min_size::<T>(),
    )
}

/// A 2D float texture read with `textureLoad` (no sampler, not multisampled).
pub fn texture_2d() -> Slot {
    Slot::of(wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable: false },
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: false,
    })
}

/// A multisampled 2D float texture read with `textureLoad` (`texture_multisampled_2d<f32>`).
pub fn multisampled_texture_2d() -> Slot {
    Slot::of(wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable: false },
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: true,
    })
}

/// A 2D float texture read through a filtering sampler.
pub fn filtered_texture_2d() -> Slot {
    Slot::of(wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable: true },
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: false,
    })
}

/// A filtering sampler.
pub fn sampler() -> Slot {
    Slot::of(wgpu::BindingType::Sampler(
        wgpu::SamplerBindingType::Filtering,
    ))
}

/// A 2D storage texture of `format`, written only.
pub fn storage_texture_2d(format: wgpu::TextureFormat) -> Slot {
    Slot::of(wgpu::BindingType::StorageTexture {
        access: wgpu::StorageTextureAccess::WriteOnly,
        format,
        view_dimension: wgpu::TextureViewDimension::D2,
    })
}

/// The entries of a layout whose bindings are `slots` in order, seen by `visibility` unless a
/// slot says otherwise.
pub fn entries(visibility: wgpu::ShaderStages, slots: &[Slot]) -> Vec<wgpu::BindGroupLayoutEntry> {
    slots
        .iter()
        .enumerate()
        .map(|(i, s)| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: s.visibility.unwrap_or(visibility),
            ty: s.ty,
            count: None,
        })
        .collect()
}

/// A bind group layout whose bindings are `slots` in order.
pub fn layout(
    device: &wgpu::Device,
    label: &str,
    visibility: wgpu::ShaderStages,
    slots: &[Slot],
) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries(visibility, slots),
    })
}

/// A bind group over `layout` binding `resources` in order (the order of its slots).
pub fn group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: r.clone(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// One `bytes`-long record of `buffer` at a dynamic offset: the resource of a
/// `dynamic_uniform` slot (the offset is given when the group is bound).
pub fn record(buffer: &wgpu::Buffer, bytes: u64) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: wgpu::BufferSize::new(bytes),
    })
}

/// A bind group over `layout` binding whole `buffers` in order.
pub fn buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let resources: Vec<wgpu::BindingResource> =
        buffers.iter().map(|b| b.as_entire_binding()).collect();
    group(device, label, layout, &resources)
}
