//! Render targets: the scene is drawn at `supersample` times the output size into a
//! multisampled colour buffer (a render-attachment-only texture: on the GL backend a
//! multisampled texture that is also bindable reads back as zeros), resolved, then averaged
//! down by `DownsamplePass` into whatever the caller draws to — a window's surface or an
//! offscreen texture that `read_rgba` copies back.

use crate::error::{KamiError, Result};
use crate::gpu::{self, bind, Gpu};

pub use crate::gpu::pipeline::{DEPTH_FORMAT, SCENE_FORMAT};

/// The supersampled, multisampled scene buffers for one output size.
pub struct SceneTargets {
    /// Whether the depth can be read by the compute rasteriser for thin strands.
    pub sampled_depth: bool,
    pub output_size: (u32, u32),
    pub size: (u32, u32),
    pub samples: u32,
    pub factor: u32,
    msaa: Option<wgpu::TextureView>,
    pub resolved: wgpu::TextureView,
    pub depth: wgpu::TextureView,
}

/// The scene targets' size in samples for `output_size` pixels, supersampled `factor`
/// times per axis at `scale_pct` percent of the resolution.
pub fn scaled_size(output_size: (u32, u32), factor: u32, scale_pct: u32) -> (u32, u32) {
    let scaled = |n: u32| {
        (u64::from(n * factor) * u64::from(scale_pct))
            .div_ceil(100)
            .max(1) as u32
    };
    (scaled(output_size.0), scaled(output_size.1))
}

impl SceneTargets {
    pub fn new(
        gpu: &Gpu,
        output_size: (u32, u32),
        samples: u32,
        factor: u32,
        sampled_depth: bool,
    ) -> Result<SceneTargets> {
        Self::scaled(gpu, output_size, samples, factor, 100, sampled_depth)
    }

    /// Targets at `scale_pct` percent of the supersampled size per axis (the resolve
    /// scales them up; `Quality::scale_pct`).
    pub fn scaled(
        gpu: &Gpu,
        output_size: (u32, u32),
        samples: u32,
        factor: u32,
        scale_pct: u32,
        sampled_depth: bool,
    ) -> Result<SceneTargets> {
        let size = scaled_size(output_size, factor, scale_pct);
        gpu.check_texture_size("the supersampled scene width", size.0)?;
        gpu.check_texture_size("the supersampled scene height", size.1)?;
        let extent = wgpu::Extent3d {
            width: size.0,
            height: size.1,
            depth_or_array_layers: 1,
        };
        let tex = |label: &str, format, sample_count, usage| {
            gpu.device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: extent,
                    mip_level_count: 1,
                    sample_count,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let msaa = (samples > 1).then(|| {
            tex(
                "scene msaa",
                SCENE_FORMAT,
                samples,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            )
        });
        let resolved = tex(
            "scene resolved",
            SCENE_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        // Sampled by the compute rasteriser for thin strands (occlusion by the head) when
        // it runs; only then, as a sampled multisampled depth is another kind of object on
        // GL.
        let depth_usage = if sampled_depth {
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING
        } else {
            wgpu::TextureUsages::RENDER_ATTACHMENT
        };
        let depth = tex("scene depth", DEPTH_FORMAT, samples, depth_usage);
        Ok(SceneTargets {
            sampled_depth,
            output_size,
            size,
            samples,
            factor,
            msaa,
            resolved,
            depth,
        })
    }

    /// Colour attachment that clears to `clear` and resolves MSAA into `resolved`.
    pub fn color_attachment(&self, clear: wgpu::Color) -> wgpu::RenderPassColorAttachment<'_> {
        let ops = wgpu::Operations {
            load: wgpu::LoadOp::Clear(clear),
            store: wgpu::StoreOp::Store,
        };
        match &self.msaa {
            Some(m) => wgpu::RenderPassColorAttachment {
                view: m,
                depth_slice: None,
                resolve_target: Some(&self.resolved),
                ops: wgpu::Operations {
                    load: ops.load,
                    store: wgpu::StoreOp::Discard,
                },
            },
            None => wgpu::RenderPassColorAttachment {
                view: &self.resolved,
                depth_slice: None,
                resolve_target: None,
                ops,
            },
        }
    }

    /// `keep`: store the depth for a pass after this one (the thin strands' occlusion).
    pub fn depth_attachment(&self, keep: bool) -> wgpu::RenderPassDepthStencilAttachment<'_> {
        wgpu::RenderPassDepthStencilAttachment {
            view: &self.depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: if keep {
                    wgpu::StoreOp::Store
                } else {
                    wgpu::StoreOp::Discard
                },
            }),
            stencil_ops: None,
        }
    }
}

/// What `DownsamplePass::draw` reads: one set of scene targets (and its supersampling
/// factor, which picks the pipeline), from `DownsamplePass::bind`.
pub struct ResolveBinding {
    group: wgpu::BindGroup,
    factor: u32,
    /// The scene is not a whole multiple of the output: scaled up bilinearly.
    scaled: bool,
}

/// Box-filter resolve of the supersampled scene into the output.
pub struct DownsamplePass {
    pipeline: wgpu::RenderPipeline,
    /// Without supersampling: a plain copy (with the thin strands and the encoding).
    pipeline_one: wgpu::RenderPipeline,
    /// Below full resolution: a bilinear scale up.
    pipeline_scaled: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    encode_srgb: bool,
    /// Bound in place of the thin-strand accumulation when nothing is splatted.
    no_accum: wgpu::Buffer,
}

impl DownsamplePass {
    pub fn new(gpu: &Gpu, output_format: wgpu::TextureFormat) -> Result<DownsamplePass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "downsample", crate::shaders::DOWNSAMPLE)?;
        let layout = bind::layout(
            device,
            "downsample",
            wgpu::ShaderStages::FRAGMENT,
            &[
                bind::texture_2d(),
                // `struct Resolve`, uploaded as eight words (`bind`).
                bind::uniform::<[u32; 8]>(),
                bind::storage::<u32>(),
            ],
        );
        let pl = gpu::pipeline::pipeline_layout(device, "downsample", &[&layout]);
        let make = |fs: &str| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("downsample"),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(output_format.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipeline = make("fs");
        let pipeline_one = make("fs_one");
        let pipeline_scaled = make("fs_scaled");
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("downsample uniform"),
            size: std::mem::size_of::<[u32; 8]>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let no_accum = gpu::storage_buffer(
            device,
            "no splat accumulation",
            &[0u8; 4 * crate::stage::splat::WORDS as usize],
            wgpu::BufferUsages::empty(),
        );
        Ok(DownsamplePass {
            pipeline,
            pipeline_one,
            pipeline_scaled,
            layout,
            uniform,
            encode_srgb: !output_format.is_srgb(),
            no_accum,
        })
    }

    /// A bind group reading `targets` (rebuilt when the targets are).
    /// `accum`: the thin strands' accumulation to composite (`stage::splat`), if any.
    pub fn bind(
        &self,
        gpu: &Gpu,
        targets: &SceneTargets,
        accum: Option<&wgpu::Buffer>,
    ) -> ResolveBinding {
        let splat = u32::from(accum.is_some());
        let out = targets.output_size;
        let scaled = targets.size != (out.0 * targets.factor, out.1 * targets.factor);
        let scale = [
            targets.size.0 as f32 / out.0.max(1) as f32,
            targets.size.1 as f32 / out.1.max(1) as f32,
        ];
        gpu.queue.write_buffer(
            &self.uniform,
            0,
            bytemuck::cast_slice(&[
                targets.factor,
                u32::from(self.encode_srgb),
                splat,
                0,
                scale[0].to_bits(),
                scale[1].to_bits(),
                0,
                0,
            ]),
        );
        let group = bind::group(
            &gpu.device,
            "downsample",
            &self.layout,
            &[
                wgpu::BindingResource::TextureView(&targets.resolved),
                self.uniform.as_entire_binding(),
                accum.unwrap_or(&self.no_accum).as_entire_binding(),
            ],
        );
        ResolveBinding {
            group,
            factor: targets.factor,
            scaled,
        }
    }

    /// Average the scene `binding` reads into the top-left `size` pixels of `output`,
    /// clearing the rest.
    pub fn draw(
        &self,
        enc: &mut wgpu::CommandEncoder,
        binding: &ResolveBinding,
        output: &wgpu::TextureView,
        size: (u32, u32),
        clear: wgpu::Color,
    ) {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("downsample"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: output,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_viewport(0.0, 0.0, size.0 as f32, size.1 as f32, 0.0, 1.0);
        pass.set_pipeline(if binding.scaled {
            &self.pipeline_scaled
        } else if binding.factor == 1 {
            &self.pipeline_one
        } else {
            &self.pipeline
        });
        pass.set_bind_group(0, &binding.group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// An offscreen RGBA8 (sRGB) output texture that can be read back. The readback buffer is
/// made once with the texture, so `render --frames` and the viewer's screenshots reuse it
/// instead of allocating an image-sized buffer per frame.
pub struct Offscreen {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub size: (u32, u32),
    pub format: wgpu::TextureFormat,
    /// Rows padded to 256 bytes, as texture-to-buffer copies need.
    staging: wgpu::Buffer,
}

pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

impl Offscreen {
    pub fn new(gpu: &Gpu, size: (u32, u32)) -> Result<Offscreen> {
        Self::with_format(gpu, size, OUTPUT_FORMAT)
    }

    /// An offscreen target of another 8-bit RGBA/BGRA format (a window's, for screenshots).
    pub fn with_format(
        gpu: &Gpu,
        size: (u32, u32),
        format: wgpu::TextureFormat,
    ) -> Result<Offscreen> {
        gpu.check_texture_size("the image width", size.0)?;
        gpu.check_texture_size("the image height", size.1)?;
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen output"),
            size: wgpu::Extent3d {
                width: size.0,
                height: size.1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("image readback"),
            size: Self::row_bytes(size.0) as u64 * size.1 as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Ok(Offscreen {
            texture,
            view,
            size,
            format,
            staging,
        })
    }

    fn row_bytes(width: u32) -> u32 {
        (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
    }

    /// Copy the image back (tests, CLI renders, screenshots) through the one staging buffer.
    pub fn read_rgba(&self, gpu: &Gpu) -> Result<image::RgbaImage> {
        let (w, h) = self.size;
        let row = Self::row_bytes(w);
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("image readback"),
            });
        enc.copy_texture_to_buffer(
            self.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &self.staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        gpu.queue.submit([enc.finish()]);
        let mut out = Vec::with_capacity((w * h * 4) as usize);
        gpu::map_read_with(gpu, &self.staging, |bytes| {
            for y in 0..h as usize {
                let start = y * row as usize;
                out.extend_from_slice(&bytes[start..start + w as usize * 4]);
            }
        })?;
        if matches!(
            self.format,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        ) {
            for px in out.chunks_exact_mut(4) {
                px.swap(0, 2);
            }
        }
        image::RgbaImage::from_raw(w, h, out)
            .ok_or_else(|| KamiError::Gpu("image size mismatch".into()))
    }
}
