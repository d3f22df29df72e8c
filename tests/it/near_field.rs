//! The strand ribbons' near field in the physical mode (`shaders/anjyo/draw.wgsl`,
//! `vs_near`/`fs_near`): a fragment shows the bin of the fibre's width under it, not the
//! far field. One straight strand wide on screen, lit from the side, against the f64 bins
//! (`hair_bsdf::dual_parts`) placed across the ribbon as on a cylinder.

use crate::common;
use kami::formats::Groom;
use kami::gpu::gpu_data::srgb_to_linear;
use kami::scene::{CameraDesc, Light, Shading, StrandRaster};
use kami::systems::hair_bsdf::{bin_weight, dual_parts, Angles, Bsdf, DualScattering, BINS};

const SIZE: (u32, u32) = (96, 96);
/// The strand's width (world) and where it hangs: far from the head, across the view.
const WIDTH: f32 = 4.0;
const Z: f32 = 30.0;

/// One straight strand from y = 5 to y = -5 at z = `Z`, seen from +z, lit by `light`, with
/// no ambient, no shadows and no head: what the ribbon shows is the key light's scattering
/// alone.
fn one_strand(light: [f64; 3]) -> kami::Scene {
    let groom = Groom {
        counts: vec![2],
        points: vec![[0.0, 5.0, Z], [0.0, -5.0, Z]],
        widths: Some(vec![WIDTH; 2]),
        ..Default::default()
    };
    // The bob's material on the one strand, read as a file group of 8 segments.
    let mut scene = crate::imported::imported_scene(common::scene("bob"), groom, 8);
    scene.head.visible = false;
    scene.render.shading = Shading::Physical;
    scene.render.shadows.on = false;
    scene.render.strands = StrandRaster::Ribbons;
    scene.camera = CameraDesc {
        eye: [0.0, 0.0, f64::from(Z) + 50.0],
        target: [0.0, 0.0, f64::from(Z)],
        up: [0.0, 1.0, 0.0],
        fov_y: 20.0,
    };
    scene.light = Light {
        direction: light,
        intensity: 1.0,
        ambient: 0.0,
        color: [1.0, 1.0, 1.0],
    };
    kami::systems::validate(&scene).unwrap();
    scene
}

/// The f64 radiance at offset `h_cell` (sin gamma, gamma as `Bsdf::radiance_bins` measures
/// it) on the strand's middle, seen from the eye: the bin's mean plus the even part.
fn want_at(scene: &kami::Scene, bsdf: &Bsdf, dual: &DualScattering, h_cell: f64) -> [f64; 3] {
    let l = scene.light.direction;
    let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
    let a = Angles::new([0.0, 0.0, 1.0], l.map(|x| x / n), [0.0, -1.0, 0.0]);
    let (bins, back) = dual_parts(bsdf, dual, &a, 0.0);
    let edge = |j: usize| {
        (-0.5 * std::f64::consts::PI + j as f64 * std::f64::consts::PI / BINS as f64).sin()
    };
    let k = (0..BINS)
        .find(|&k| h_cell <= edge(k + 1))
        .unwrap_or(BINS - 1);
    let e = std::f64::consts::PI * scene.light.intensity;
    std::array::from_fn(|c| e * (bins[k][c] / bin_weight(k) + back[c]))
}

/// Across the ribbon's middle row, each pixel against the f64 bin under it: the light on
/// the screen's right (+x) puts gamma's negative half there (the R lobe's highlight faces
/// the light). Pixels within 0.06 in h of a bin's edge or the ribbon's are left out.
#[test]
fn a_fragment_shows_the_bin_of_the_fibre_under_it() {
    let gpu = common::gpu();
    let scene = one_strand([0.8, 0.3, 0.5]);
    let m = &scene.groups()[0].material;
    let bsdf = m.physical.hair(m.color).bsdf();
    let dual = DualScattering::new(&bsdf);
    let mut stage = common::stage_one_sample(gpu, &scene);
    let img = common::draw(&mut stage, SIZE);
    gpu.take_error().unwrap();
    let y = SIZE.1 / 2;
    let bg = img.get_pixel(0, y).0;
    let on: Vec<u32> = (0..SIZE.0)
        .filter(|&x| img.get_pixel(x, y).0 != bg)
        .collect();
    assert!(
        on.len() > 12,
        "the ribbon covers {} pixels of its row",
        on.len()
    );
    let (x0, x1) = (f64::from(on[0]), f64::from(*on.last().unwrap()) + 1.0);
    let (centre, half) = (0.5 * (x0 + x1), 0.5 * (x1 - x0));
    let lin = |v: u8| f64::from(srgb_to_linear(f32::from(v) / 255.0));
    let edges = [-0.8660254, -0.5, 0.0, 0.5, 0.8660254];
    let (mut n, mut worst, mut mirrored) = (0, 0.0f64, 0.0f64);
    for &x in &on {
        let h_geom = (f64::from(x) + 0.5 - centre) / half;
        if h_geom.abs() > 0.94 || edges.iter().any(|e| (h_geom - e).abs() < 0.06) {
            continue;
        }
        let want = want_at(&scene, &bsdf, &dual, -h_geom);
        let other = want_at(&scene, &bsdf, &dual, h_geom);
        let p = img.get_pixel(x, y).0;
        for c in 0..3 {
            let tol = 0.01 + 0.03 * want[c];
            worst = worst.max((lin(p[c]) - want[c]).abs() / tol);
            mirrored = mirrored.max((lin(p[c]) - other[c]).abs() / tol);
        }
        n += 1;
    }
    eprintln!("{n} pixels across the ribbon: worst error {worst:.2} of the bound; against the mirrored bins {mirrored:.2}");
    assert!(n >= 8, "only {n} pixels away from the bins' edges");
    assert!(
        worst <= 1.0,
        "a fragment is {worst} times the bound from its bin"
    );
    assert!(
        mirrored > 1.0,
        "the mirrored bins fit as well ({mirrored}): the light does not tell the sides apart"
    );
}
