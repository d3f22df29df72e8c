//! The head's shading in the physical mode (`shaders/stage/head.wgsl`): a Lambertian of the
//! head's colour under the key light and Kami's even ambient, as the path tracer's head
//! (`kami bench look`), against the same formula in f64 with rays cast through the pixels.

use crate::common;
use glam::{DVec2, DVec3};
use kami::gpu::gpu_data::linear_rgb;
use kami::gpu::view::ScreenView;
use kami::stage::camera::Camera;

const SIZE: (u32, u32) = (64, 64);

/// The f64 radiance of the physical head where the ray through pixel `px` meets the drawn
/// ellipsoid (None off the head or near its silhouette, where a pixel mixes head and
/// background).
fn lambert_at(scene: &kami::Scene, view: &ScreenView, eye: DVec3, px: DVec2) -> Option<[f64; 3]> {
    let e = scene.head_ellipsoid();
    let r = e.radii * kami::stage::head::DRAWN_SCALE;
    let far = view.unproject(px, 1.0)?;
    let d = (far - eye).normalize();
    let (o, dd) = ((eye - e.center) / r, d / r);
    let (a, b, c) = (dd.dot(dd), 2.0 * o.dot(dd), o.dot(o) - 1.0);
    let disc = b * b - 4.0 * a * c;
    if disc <= 0.0 {
        return None;
    }
    let p = eye + d * ((-b - disc.sqrt()) / (2.0 * a));
    let n = ((p - e.center) / (r * r)).normalize();
    // Away from the silhouette: the mesh's facets and the pixel's footprint stay small.
    if n.dot(-d) < 0.3 {
        return None;
    }
    let light = &scene.light;
    let l = DVec3::from(light.direction).normalize();
    let k = linear_rgb(scene.head.color);
    let lc = light.color;
    let lit = 0.3 * light.ambient + light.intensity * n.dot(l).max(0.0);
    Some(std::array::from_fn(|i| {
        f64::from(k[i]) * f64::from(lc[i]) * lit
    }))
}

/// Every head pixel of a physical scene's frame (no hair, so no shadow) against the f64
/// Lambertian, worst channel within 0.02 in linear radiance (8-bit sRGB output, and the
/// head mesh's 48 x 96 facets against the exact ellipsoid); and the paper scenes' head
/// (Anjyo's mode) is not that Lambertian.
#[test]
fn the_physical_head_is_the_path_tracers_lambertian() {
    let gpu = common::gpu();
    let mut scene = common::scene("bob");
    scene.groups_mut().clear();
    scene.render.shading = kami::scene::Shading::Physical;
    let mut anjyo = scene.clone();
    anjyo.render.shading = kami::scene::Shading::Anjyo;
    let img = common::draw(&mut common::stage_one_sample(gpu, &scene), SIZE);
    let paper = common::draw(&mut common::stage_one_sample(gpu, &anjyo), SIZE);
    let cam = Camera::from_desc(&scene.camera);
    let size = DVec2::new(f64::from(SIZE.0), f64::from(SIZE.1));
    let view = ScreenView::new(cam.view_proj_f64(size.x / size.y, 1.0, 1000.0), size);
    let lin = |v: u8| f64::from(kami::gpu::gpu_data::srgb_to_linear(f32::from(v) / 255.0));
    let (mut n, mut worst, mut paper_worst) = (0, 0.0f64, 0.0f64);
    for (x, y, p) in img.enumerate_pixels() {
        let px = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
        let Some(want) = lambert_at(&scene, &view, cam.eye, px) else {
            continue;
        };
        let q = paper.get_pixel(x, y);
        for (c, w) in want.iter().enumerate() {
            worst = worst.max((lin(p.0[c]) - w).abs());
            paper_worst = paper_worst.max((lin(q.0[c]) - w).abs());
        }
        n += 1;
    }
    eprintln!("{n} head pixels: worst |error| {worst:.4}; the paper's head {paper_worst:.4}");
    assert!(n > 300, "only {n} head pixels");
    assert!(
        worst < 0.02,
        "the physical head is {worst} from the Lambertian"
    );
    assert!(
        paper_worst > 0.05,
        "the paper's head is the Lambertian ({paper_worst})"
    );
}
