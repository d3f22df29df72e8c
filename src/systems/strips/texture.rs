//! The strand texture of the Hair Object Model (Kazama et al. figure 1: reed polygons with
//! a texture of many fine hairs), generated at start-up so no image file is needed.
//!
//! u runs across the strip (0 to 1, side to side), v along it (0 root, 1 tip); row `y` of
//! the texel array is v = (y + ½) / height. `look.hairs` fine hairs run along v, each with
//! its own slight offset, width, waviness, brightness and end: the ends fall between
//! v = 1 − `TIP_SPREAD` and 1 and each hair narrows to a point over `TIP_TAPER` before its
//! end, so a strip ends in a ragged brush rather than a cut. Alpha is the share of a texel
//! the hairs cover (edges anti-aliased at texel scale), 0 in the gaps between hairs.
//!
//! Colour is linear: the root-to-tip gradient (1 at the root, `look.tip_shade` at the tip,
//! linear in v) times the hair's brightness, divided by `gain(look)` so it fits in 8 bits;
//! the draw shader multiplies by the gain again and by the layer colour. Gap texels carry
//! the gradient alone, so filtering never bleeds black into the hairs.
//!
//! Mip levels are made on the CPU by a box filter over level 0: alpha is the block's mean
//! (coverage averages), colour the alpha-weighted mean (the colour of the hairs, not of the
//! gaps).

use crate::error::Result;
use crate::gpu::Gpu;
use crate::rng::Rng;
use crate::systems::strips::block::Look;

/// Share of the strip length over which the hair ends are spread.
pub const TIP_SPREAD: f64 = 0.18;
/// Share of the strip length over which a hair narrows to its end.
pub const TIP_TAPER: f64 = 0.10;
/// Texels along the strip.
pub const HEIGHT: u32 = 256;
/// Seed of the hairs' variations (the texture is the same on every run and machine).
const SEED: u64 = 0x5354_5249_5053;

/// The format of the strand texture: linear 8-bit RGBA.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Texture size for a look: at least 4 texels per hair across (64 to 512), `HEIGHT` along.
pub fn texture_size(look: &Look) -> (u32, u32) {
    let w = (4 * look.hairs.max(1)).next_power_of_two().clamp(64, 512);
    (w, HEIGHT)
}

/// What the stored colour is divided by (the draw shader multiplies it back): the
/// brightest value of the gradient, so tips brighter than the root still fit in 8 bits.
pub fn gain(look: &Look) -> f32 {
    if look.tip_shade.is_finite() {
        look.tip_shade.max(1.0)
    } else {
        1.0
    }
}

/// The gradient's shade at `v` (1 at the root, `tip_shade` at the tip).
pub fn shade(look: &Look, v: f64) -> f64 {
    let tip = if look.tip_shade.is_finite() {
        look.tip_shade.max(0.0) as f64
    } else {
        1.0
    };
    1.0 + (tip - 1.0) * v.clamp(0.0, 1.0)
}

/// One fine hair of the texture, in texture space (u across, v along).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hair {
    center: f64,
    half_width: f64,
    /// Where along the strip (v) the hair ends.
    pub end: f64,
    /// Its brightness (times the root-to-tip gradient).
    pub bright: f64,
    wave_amp: f64,
    wave_freq: f64,
    wave_phase: f64,
}

impl Hair {
    /// The hair's centre across the strip (u) at `v`.
    pub fn u(&self, v: f64) -> f64 {
        self.center
            + self.wave_amp * (std::f64::consts::TAU * (self.wave_freq * v + self.wave_phase)).sin()
    }
    /// Its half width in u at `v`: narrowing to nothing over [`TIP_TAPER`] before its end.
    pub fn half_width(&self, v: f64) -> f64 {
        self.half_width * ((self.end - v) / TIP_TAPER).clamp(0.0, 1.0)
    }
}

fn hairs(n: u32) -> Vec<Hair> {
    let nf = n as f64;
    (0..n)
        .map(|i| {
            let mut r = Rng::new(SEED, i as u64);
            Hair {
                center: (i as f64 + 0.5 + r.range(-0.1, 0.1)) / nf,
                half_width: r.range(0.26, 0.34) / nf,
                end: 1.0 - TIP_SPREAD * r.uniform(),
                bright: r.range(0.78, 1.0),
                wave_amp: r.range(0.0, 0.05) / nf,
                wave_freq: r.range(1.0, 3.0),
                wave_phase: r.uniform(),
            }
        })
        .collect()
}

/// The hairs the texture of `look` draws (hairs are capped at half the texture's width, as
/// [`strand_texture`] caps them): the strands a strip stands for, for a path tracer that
/// needs them as curves.
pub fn texture_hairs(look: &Look) -> Vec<Hair> {
    let w = texture_size(look).0;
    hairs(look.hairs.clamp(1, (w / 2).max(1)))
}

/// Level 0 of the strand texture, `width × height` texels, row 0 at the root. Hairs are
/// capped at `width / 2` so every gap keeps at least about a texel.
pub fn strand_texture(look: &Look, width: u32, height: u32) -> Vec<[u8; 4]> {
    let (w, h) = (width.max(1), height.max(1));
    let n = look.hairs.clamp(1, (w / 2).max(1));
    let hairs = hairs(n);
    let g = gain(look) as f64;
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        let v = (y as f64 + 0.5) / h as f64;
        let base = shade(look, v);
        for x in 0..w {
            let u = (x as f64 + 0.5) / w as f64;
            let (mut cover, mut bright) = (0.0f64, 1.0);
            // Only the hairs near u can reach it (their centres move by under a spacing).
            let i = ((u * n as f64) as i64).clamp(0, n as i64 - 1);
            for hair in &hairs[(i - 2).max(0) as usize..((i + 3) as usize).min(n as usize)] {
                // Distance inside the hair's edge, in texels: anti-aliased at texel scale.
                let inside = (hair.half_width(v) - (u - hair.u(v)).abs()) * w as f64;
                let a = (inside + 0.5).clamp(0.0, 1.0);
                if a > cover {
                    cover = a;
                    bright = hair.bright;
                }
            }
            let rgb = (base * bright / g).clamp(0.0, 1.0);
            let c = (rgb * 255.0).round() as u8;
            out.push([c, c, c, (cover * 255.0).round() as u8]);
        }
    }
    out
}

/// One level of the mip chain.
#[derive(Clone, Debug, PartialEq)]
pub struct MipLevel {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[u8; 4]>,
}

/// Levels 0.. (down to 1×1) of a `width × height` texture: each texel of level k is the box
/// over the block of level 0 it covers; alpha the mean, colour the alpha-weighted mean (the
/// plain mean where the block is empty).
pub fn mip_chain(level0: &[[u8; 4]], width: u32, height: u32) -> Vec<MipLevel> {
    let (w, h) = (width as usize, height as usize);
    let mut levels = vec![MipLevel {
        width,
        height,
        texels: level0.to_vec(),
    }];
    let (mut lw, mut lh) = (width, height);
    while lw > 1 || lh > 1 {
        lw = (lw / 2).max(1);
        lh = (lh / 2).max(1);
        let mut texels = Vec::with_capacity((lw * lh) as usize);
        for y in 0..lh as usize {
            let (y0, y1) = (
                y * h / lh as usize,
                ((y + 1) * h / lh as usize).max(y * h / lh as usize + 1),
            );
            for x in 0..lw as usize {
                let (x0, x1) = (
                    x * w / lw as usize,
                    ((x + 1) * w / lw as usize).max(x * w / lw as usize + 1),
                );
                let (mut sa, mut sc, mut s, mut n) = (0.0f64, [0.0f64; 3], [0.0f64; 3], 0.0);
                for yy in y0..y1 {
                    for t in &level0[yy * w + x0..yy * w + x1] {
                        let a = t[3] as f64;
                        sa += a;
                        for c in 0..3 {
                            sc[c] += t[c] as f64 * a;
                            s[c] += t[c] as f64;
                        }
                        n += 1.0;
                    }
                }
                let rgb = |c: usize| {
                    if sa > 0.0 {
                        sc[c] / sa
                    } else {
                        s[c] / n
                    }
                };
                texels.push([
                    rgb(0).round() as u8,
                    rgb(1).round() as u8,
                    rgb(2).round() as u8,
                    (sa / n).round() as u8,
                ]);
            }
        }
        levels.push(MipLevel {
            width: lw,
            height: lh,
            texels,
        });
    }
    levels
}

/// The strand texture on the GPU, with every mip level, and its sampler.
pub struct StrandTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub sampler: wgpu::Sampler,
    pub size: (u32, u32),
    /// What the shader multiplies the stored colour by (`gain`).
    pub gain: f32,
}

/// Generate the strand texture for `look` and upload it with its mips. The sampler filters
/// linearly (trilinear between mips) and clamps at the edges: u = 0 and 1 are the strip's
/// sides, v = 0 and 1 its root and tip, and none of them should wrap round.
pub fn upload(gpu: &Gpu, look: &Look) -> Result<StrandTexture> {
    let (w, h) = texture_size(look);
    gpu.check_texture_size("the strand texture", w.max(h))?;
    let levels = mip_chain(&strand_texture(look, w, h), w, h);
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("strips strand texture"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (i, l) in levels.iter().enumerate() {
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: i as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&l.texels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * l.width),
                rows_per_image: Some(l.height),
            },
            wgpu::Extent3d {
                width: l.width,
                height: l.height,
                depth_or_array_layers: 1,
            },
        );
    }
    let view = texture.create_view(&Default::default());
    let sampler = gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("strips strand sampler"),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    });
    Ok(StrandTexture {
        texture,
        view,
        sampler,
        size: (w, h),
        gain: gain(look),
    })
}
