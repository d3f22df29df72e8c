//! The panels' pixels, kept between frames. On a software adapter egui's render pass (a few
//! thousand small triangles of text over a 340-pixel-wide panel) costs more than the rest of
//! a still frame, yet the panels rarely change from one frame to the next. So egui draws into
//! a window-sized texture (premultiplied alpha over transparent), and only where its shapes
//! changed since the last frame (`damage`: the shapes that differ, in their clip rectangles);
//! each frame then composites that texture over the scene with egui's own blending, inside
//! the rectangle the panels cover. Compositing "over" is associative, so the result is what
//! drawing egui straight onto the scene gives (up to 8-bit rounding where a pixel is partly
//! transparent, e.g. anti-aliased edges over the 3D view).

use crate::gpu::bind;
use egui::epaint::ClippedShape;
use egui::{Pos2, Rect};

/// What of the cached panels must be drawn again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damage {
    /// Nothing changed: composite what is cached.
    None,
    /// Redraw this rectangle (window pixels, `[x0, y0, x1, y1)`).
    Rect([u32; 4]),
    /// Redraw everything (first frame, new size, new font atlas, a different shape list).
    Full,
}

/// Extra pixels around a changed shape: anti-aliasing feathers edges by about a pixel.
const MARGIN_PX: f32 = 2.0;

/// Where a shape can leave pixels: its visual bounds inside its clip rectangle (points).
fn footprint(s: &ClippedShape) -> Rect {
    (s.transform_after_tessellation * s.shape.visual_bounding_rect()).intersect(s.clip_rect)
}

/// The union of the shapes' footprints (points); `Rect::NOTHING` for none.
pub fn covered(shapes: &[ClippedShape]) -> Rect {
    shapes.iter().fold(Rect::NOTHING, |acc, s| {
        let f = footprint(s);
        if f.is_positive() {
            acc.union(f)
        } else {
            acc
        }
    })
}

/// A rectangle in points as whole window pixels (outwards, with the anti-aliasing margin,
/// inside the window); None when empty.
pub fn to_pixels(r: Rect, ppp: f32, size: (u32, u32)) -> Option<[u32; 4]> {
    if !r.is_positive() {
        return None;
    }
    let clamp = |v: f32, max: u32| v.clamp(0.0, max as f32) as u32;
    let x0 = clamp((r.min.x * ppp - MARGIN_PX).floor(), size.0);
    let y0 = clamp((r.min.y * ppp - MARGIN_PX).floor(), size.1);
    let x1 = clamp((r.max.x * ppp + MARGIN_PX).ceil(), size.0);
    let y1 = clamp((r.max.y * ppp + MARGIN_PX).ceil(), size.1);
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1, y1])
}

/// A pixel rectangle in points (exact: egui's scissor, `round(ppp * clip)`, gives it back).
fn to_points(px: [u32; 4], ppp: f32) -> Rect {
    Rect::from_min_max(
        Pos2::new(px[0] as f32 / ppp, px[1] as f32 / ppp),
        Pos2::new(px[2] as f32 / ppp, px[3] as f32 / ppp),
    )
}

/// What changed between the shapes drawn last (`prev`, None when nothing is cached) and
/// this frame's. Shape lists are compared in order: a list of another length (a panel opened,
/// a popup shown) redraws everything; otherwise the footprints of the shapes that differ,
/// before and after, are redrawn.
pub fn damage(
    prev: Option<&[ClippedShape]>,
    shapes: &[ClippedShape],
    ppp: f32,
    size: (u32, u32),
) -> Damage {
    let Some(prev) = prev else {
        return Damage::Full;
    };
    if prev.len() != shapes.len() {
        return Damage::Full;
    }
    let mut dirty = Rect::NOTHING;
    for (a, b) in prev.iter().zip(shapes) {
        if a != b {
            for f in [footprint(a), footprint(b)] {
                if f.is_positive() {
                    dirty = dirty.union(f);
                }
            }
        }
    }
    match to_pixels(dirty, ppp, size) {
        None => Damage::None,
        Some(px) => Damage::Rect(px),
    }
}

/// The shapes to tessellate for a redraw of `px`: those that reach into it, clipped to it.
pub fn clipped_to(shapes: &[ClippedShape], px: [u32; 4], ppp: f32) -> Vec<ClippedShape> {
    let r = to_points(px, ppp);
    shapes
        .iter()
        .filter_map(|s| {
            let clip = s.clip_rect.intersect(r);
            (clip.is_positive() && footprint(s).intersects(clip)).then(|| ClippedShape {
                clip_rect: clip,
                ..s.clone()
            })
        })
        .collect()
}

/// A redraw of the cache, prepared on the CPU, encoded with the next frame.
pub struct Pending {
    pub paint: Vec<egui::ClippedPrimitive>,
    /// None: clear the whole cache first; Some: clear and redraw only this pixel rectangle.
    pub region: Option<[u32; 4]>,
}

/// The cached panels and the two small pipelines that clear a rectangle of it and
/// composite it over the scene.
pub struct PanelCache {
    texture: Option<(wgpu::TextureView, wgpu::BindGroup, (u32, u32))>,
    layout: wgpu::BindGroupLayout,
    composite: wgpu::RenderPipeline,
    clear: wgpu::RenderPipeline,
    /// The shapes the cache holds (None: nothing valid cached) and their pixels per point.
    shapes: Option<(Vec<ClippedShape>, f32)>,
    /// A new font atlas (or other egui texture) arrived: the next redraw is full.
    pub textures_changed: bool,
    /// Where the panels are, in window pixels (the composite's scissor); None: nothing.
    pub covered: Option<[u32; 4]>,
    pub pending: Option<Pending>,
}

const SHADER: &str = r"
@group(0) @binding(0) var panels: texture_2d<f32>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

@fragment
fn fs_composite(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return textureLoad(panels, vec2<i32>(p.xy), 0);
}

@fragment
fn fs_clear() -> @location(0) vec4<f32> {
    return vec4<f32>(0.0);
}
";

impl PanelCache {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("panel cache"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let layout = bind::layout(
            device,
            "panel cache",
            wgpu::ShaderStages::FRAGMENT,
            &[bind::texture_2d()],
        );
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("panel cache"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let empty = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("panel cache clear"),
            bind_group_layouts: &[],
            immediate_size: 0,
        });
        // egui's own blending (premultiplied alpha, "over"), so compositing the cache gives
        // what drawing egui onto the scene gives.
        let over = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
        };
        let pipeline = |label, layout, entry, blend| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    buffers: &[],
                    compilation_options: Default::default(),
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                    compilation_options: Default::default(),
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let composite = pipeline("panel composite", &pl, "fs_composite", Some(over));
        let clear = pipeline("panel clear", &empty, "fs_clear", None);
        PanelCache {
            texture: None,
            layout,
            composite,
            clear,
            shapes: None,
            textures_changed: false,
            covered: None,
            pending: None,
        }
    }

    /// Take this frame's egui shapes: decide what to redraw and tessellate only that.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        ctx: &egui::Context,
        shapes: Vec<ClippedShape>,
        ppp: f32,
        size: (u32, u32),
    ) {
        if self.texture.as_ref().is_none_or(|t| t.2 != size) {
            let tex = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("panel cache"),
                size: wgpu::Extent3d {
                    width: size.0,
                    height: size.1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let view = tex.create_view(&Default::default());
            let group = bind::group(
                device,
                "panel cache",
                &self.layout,
                &[wgpu::BindingResource::TextureView(&view)],
            );
            self.texture = Some((view, group, size));
            self.shapes = None;
        }
        let prev = self
            .shapes
            .as_ref()
            .filter(|(_, p)| *p == ppp && !self.textures_changed)
            .map(|(s, _)| s.as_slice());
        // A redraw not yet encoded (a frame skipped after `prepare`) is merged into a full one.
        let d = if self.pending.is_some() {
            Damage::Full
        } else {
            damage(prev, &shapes, ppp, size)
        };
        self.covered = to_pixels(covered(&shapes), ppp, size);
        self.pending = match d {
            Damage::None => None,
            Damage::Full => Some(Pending {
                paint: ctx.tessellate(shapes.clone(), ppp),
                region: None,
            }),
            Damage::Rect(px) => Some(Pending {
                paint: ctx.tessellate(clipped_to(&shapes, px, ppp), ppp),
                region: Some(px),
            }),
        };
        self.textures_changed = false;
        self.shapes = Some((shapes, ppp));
    }

    /// Encode the pending redraw of the cache (if any), then composite the cache over
    /// `target` inside the panels' rectangle.
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        enc: &mut wgpu::CommandEncoder,
        egui: &mut egui_wgpu::Renderer,
        target: &wgpu::TextureView,
        screen: &egui_wgpu::ScreenDescriptor,
    ) {
        let Some((view, bind, _)) = &self.texture else {
            return;
        };
        if let Some(p) = self.pending.take() {
            egui.update_buffers(device, queue, enc, &p.paint, screen);
            let load = match p.region {
                None => wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                Some(_) => wgpu::LoadOp::Load,
            };
            let mut pass = begin(enc, "panel cache", view, load);
            if let Some([x0, y0, x1, y1]) = p.region {
                pass.set_scissor_rect(x0, y0, x1 - x0, y1 - y0);
                pass.set_pipeline(&self.clear);
                pass.draw(0..3, 0..1);
            }
            egui.render(&mut pass, &p.paint, screen);
        }
        if let Some([x0, y0, x1, y1]) = self.covered {
            let mut pass = begin(enc, "panel composite", target, wgpu::LoadOp::Load);
            pass.set_scissor_rect(x0, y0, x1 - x0, y1 - y0);
            pass.set_pipeline(&self.composite);
            pass.set_bind_group(0, bind, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

/// A render pass into `view` (egui's renderer wants one without the encoder's lifetime).
fn begin(
    enc: &mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'static> {
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
    .forget_lifetime()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One egui pass of a small panel (a label with `text`, `extra` more buttons) on an
    /// 800x600 window; the shapes it paints.
    fn shapes(ctx: &egui::Context, text: &str, extra: usize) -> Vec<ClippedShape> {
        let input = egui::RawInput {
            screen_rect: Some(Rect::from_min_size(Pos2::ZERO, egui::vec2(800.0, 600.0))),
            ..Default::default()
        };
        let mut label = Rect::NOTHING;
        let mut out = ctx.run_ui(input, |ui| {
            egui::Panel::right("p").show(ui, |ui| {
                ui.label("a fixed label");
                label = ui.label(text).rect;
                for i in 0..extra {
                    let _ = ui.button(format!("button {i}"));
                }
            });
        });
        // No renderer takes egui's texture uploads here (debug builds check they were taken).
        out.textures_delta.clear();
        // The label's rectangle rides along as the last shape's clip (checked below).
        let mut s = out.shapes;
        s.push(ClippedShape::new(label, egui::Shape::Noop));
        s
    }

    /// Settle egui (its first passes lay out and may ask for another) and return the
    /// shapes of a steady frame.
    fn steady(ctx: &egui::Context, text: &str, extra: usize) -> Vec<ClippedShape> {
        for _ in 0..3 {
            shapes(ctx, text, extra);
        }
        shapes(ctx, text, extra)
    }

    #[test]
    fn nothing_cached_or_a_new_shape_list_redraws_everything() {
        let ctx = egui::Context::default();
        let a = steady(&ctx, "fps 20.0", 0);
        assert_eq!(damage(None, &a, 1.0, (800, 600)), Damage::Full);
        let b = steady(&ctx, "fps 20.0", 1);
        assert_eq!(damage(Some(&a), &b, 1.0, (800, 600)), Damage::Full);
    }

    #[test]
    fn unchanged_panels_redraw_nothing() {
        let ctx = egui::Context::default();
        let a = steady(&ctx, "fps 20.0", 2);
        let b = shapes(&ctx, "fps 20.0", 2);
        assert_eq!(damage(Some(&a), &b, 1.0, (800, 600)), Damage::None);
    }

    #[test]
    fn a_changed_value_redraws_its_label_only() {
        let ctx = egui::Context::default();
        let a = steady(&ctx, "fps 20.0", 2);
        let b = shapes(&ctx, "fps 21.5", 2);
        let label = b.last().unwrap().clip_rect;
        let Damage::Rect(px) = damage(Some(&a[..a.len() - 1]), &b[..b.len() - 1], 1.0, (800, 600))
        else {
            panic!("a changed label must damage a rectangle");
        };
        // The rectangle is the label's glyphs (old and new): inside the label's row, and
        // most of it.
        let lp = to_pixels(label, 1.0, (800, 600)).unwrap();
        assert!(
            px[0] >= lp[0] && px[1] >= lp[1] && px[2] <= lp[2] && px[3] <= lp[3],
            "{px:?} vs label {lp:?}"
        );
        let area = |r: [u32; 4]| (r[2] - r[0]) * (r[3] - r[1]);
        assert!(2 * area(px) >= area(lp), "{px:?} vs label {lp:?}");
        // And what is redrawn there is the label: its shapes, clipped to the rectangle.
        let redrawn = clipped_to(&b[..b.len() - 1], px, 1.0);
        assert!(!redrawn.is_empty());
        let r = to_points(px, 1.0);
        assert!(redrawn.iter().all(|s| r.contains_rect(s.clip_rect)));
    }

    #[test]
    fn pixel_rectangles_stay_in_the_window() {
        let r = Rect::from_min_max(Pos2::new(-10.0, 5.0), Pos2::new(900.0, 20.5));
        assert_eq!(to_pixels(r, 1.0, (800, 600)), Some([0, 3, 800, 23]));
        assert_eq!(to_pixels(Rect::NOTHING, 1.0, (800, 600)), None);
        // The round trip egui's scissor makes: round(ppp * (px / ppp)) == px.
        for ppp in [1.0f32, 1.25, 1.5, 2.0] {
            let px = [3, 7, 371, 719];
            let p = to_points(px, ppp);
            let back = [p.min.x, p.min.y, p.max.x, p.max.y].map(|v| (v * ppp).round() as u32);
            assert_eq!(back, px);
        }
    }
}
