//! The compute rasteriser for thin strands (`shaders/anjyo/splat.wgsl`): the GPU's
//! accumulation against the f64 reference (`kami::systems::anjyo::splat`), sample by
//! sample, with and without MSAA targets; occlusion by the head; and the composited image
//! against the ribbons'.

mod common;

use kami::gpu::gpu_data::{GpuMaterial, GpuStrand};
use kami::scene::{Scene, StrandRaster};
use kami::stage::{splat as target_splat, target, Quality, Stage};
use kami::systems::anjyo::{self, splat, AnjyoSystem};

/// A small gust: few hairs, a small image, no dynamics (frame 0 is the groom).
fn small(head: bool, msaa: u32) -> Scene {
    let mut s = common::scene("gust");
    s.dynamics = None;
    s.groups[0].count = 150;
    s.groups[1].count = 400;
    s.head.visible = head;
    s.render.msaa = msaa;
    s.render.supersample = 1;
    s.render.strands = StrandRaster::Compute;
    s
}

const SIZE: (u32, u32) = (160, 120);

struct Drawn {
    stage: Stage,
    image: image::RgbaImage,
}

fn draw(gpu: &kami::gpu::Gpu, scene: &Scene) -> Drawn {
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene)).unwrap();
    let out = target::Offscreen::new(gpu, SIZE).unwrap();
    let look = stage.look();
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    stage.render(gpu, &mut enc, &out.view, SIZE, &look).unwrap();
    gpu.queue.submit([enc.finish()]);
    let image = out.read_rgba(gpu).unwrap();
    gpu.take_error().unwrap();
    Drawn { stage, image }
}

/// The GPU's accumulation in real units, per sample.
fn gpu_samples(gpu: &kami::gpu::Gpu, stage: &Stage) -> Vec<splat::Sample> {
    let buf = stage.splat_accumulation().expect("the stage splatted");
    let words: Vec<u32> = kami::gpu::read_buffer(gpu, buf, buf.size()).unwrap();
    words
        .chunks(5)
        .map(|w| {
            let c = target_splat::COLOR_SCALE;
            [
                w[0] as f64 / c,
                w[1] as f64 / c,
                w[2] as f64 / c,
                w[3] as f64 / c,
                w[4] as f64 / target_splat::DEPTH_SCALE,
            ]
        })
        .collect()
}

/// The reference's accumulation for what the stage drew (no opaque depth).
fn reference(gpu: &kami::gpu::Gpu, stage: &Stage, scene: &Scene) -> Vec<splat::Sample> {
    let a = stage.system::<AnjyoSystem>().unwrap();
    let strands: Vec<GpuStrand> =
        kami::gpu::read_buffer(gpu, &a.hair.strands, a.hair.strands.size()).unwrap();
    let verts: Vec<[f32; 4]> =
        kami::gpu::read_buffer(gpu, &a.hair.vertices, a.hair.vertices.size()).unwrap();
    let materials: Vec<GpuMaterial> = anjyo::materials(scene);
    let drawn: Vec<[u32; 2]> = a
        .hair
        .ranges
        .iter()
        .map(|r| [r.first_strand, r.first_strand + r.strand_count])
        .collect();
    let frame = stage.last_frame_uniform();
    splat::splat(&splat::Input {
        frame: &frame,
        strands: &strands[..a.hair.strand_count as usize],
        verts: &verts,
        materials: &materials,
        lod: [a.screen.width_scale as f32, a.screen.step as f32, 0.0, 0.0],
        drawn: &drawn,
        depth: None,
    })
}

/// Sample by sample, every word of the GPU's accumulation is the f64 reference's within
/// f32 geometry and fixed-point rounding (half a unit of 1/16384 per hair in a sample):
/// the worst element is bounded, over single-sampled and multisampled targets.
#[test]
fn gpu_accumulation_matches_the_f64_reference() {
    let gpu = common::gpu();
    for msaa in [1, 4] {
        let scene = small(false, msaa);
        let d = draw(&gpu, &scene);
        if msaa > 1 && gpu.info.backend == wgpu::Backend::Gl {
            // Not over MSAA targets on GL (StrandsPass::can_splat): the ribbons draw.
            assert!(d.stage.splat_accumulation().is_none());
            continue;
        }
        let got = gpu_samples(&gpu, &d.stage);
        let want = reference(&gpu, &d.stage, &scene);
        assert_eq!(got.len(), want.len());
        let mut worst = [0.0f64; 5];
        let mut covered = 0;
        let mut total = 0.0;
        for (g, w) in got.iter().zip(&want) {
            if w[3] > 0.0 {
                covered += 1;
            }
            total += w[4];
            for k in 0..5 {
                // Relative to the sample's own size, with an absolute floor for the rounding.
                let err = (g[k] - w[k]).abs() / (1.0 + w[k].abs());
                worst[k] = worst[k].max(err);
            }
        }
        eprintln!(
            "MSAA {msaa}: {covered} samples covered, total optical depth {total:.1}, worst relative error per word {worst:?}"
        );
        // The hair is on screen: a good share of the image is covered.
        assert!(covered > 2000, "only {covered} samples covered");
        for (k, e) in worst.iter().enumerate() {
            assert!(*e < 0.005, "MSAA {msaa}: word {k} off by {e} (relative)");
        }
    }
}

/// Hair behind the head is hidden: with the head drawn, the accumulated coverage drops
/// (the far side of the groom) and no covered sample lies behind the head's depth.
#[test]
fn the_head_hides_hair_behind_it() {
    let gpu = common::gpu();
    let open = draw(&gpu, &small(false, 1));
    let shut = draw(&gpu, &small(true, 1));
    let sum = |d: &Drawn| -> f64 { gpu_samples(&gpu, &d.stage).iter().map(|s| s[4]).sum() };
    let (a, b) = (sum(&open), sum(&shut));
    eprintln!("optical depth: no head {a:.1}, head {b:.1}");
    assert!(b < 0.8 * a, "the head hid too little: {b} of {a}");
    assert!(b > 0.2 * a, "the head hid too much: {b} of {a}");
}

/// The composited image looks like the ribbons' (the same hair, shading and coverage):
/// mean difference over the hair's tiles within a few levels of 255.
#[test]
fn compute_image_matches_the_ribbons() {
    let gpu = common::gpu();
    // MSAA 4 for the ribbons' coverage; the compute rasteriser over single-sampled targets
    // (on GL it runs only there).
    let compute = draw(&gpu, &small(true, 1));
    let mut ribbons_scene = small(true, 4);
    ribbons_scene.render.strands = StrandRaster::Ribbons;
    let ribbons = draw(&gpu, &ribbons_scene);
    assert!(
        ribbons.stage.splat_accumulation().is_none(),
        "ribbons allocate no accumulation"
    );
    let (tile, pixel) = kami::bench::fur::model_error(&compute.image, &ribbons.image);
    eprintln!("compute against ribbons: tile {tile:.2}, pixel {pixel:.2} levels of 255");
    assert!(
        tile > 0.0,
        "the images are identical: was the compute path drawn?"
    );
    assert!(tile < 6.0, "tile error {tile}");
}

/// The viewer's hair share reaches the compute rasteriser: drawing half the hairs after all
/// of them (on the same stage), each widened by 1/sqrt(1/2) as the viewer's level of detail
/// does, leaves about 0.71 of the accumulated optical depth, and all of them again all of it.
#[test]
fn a_smaller_share_draws_fewer_hairs() {
    let gpu = common::gpu();
    let scene = small(false, 1);
    let mut stage = Stage::new(&gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene)).unwrap();
    let out = target::Offscreen::new(&gpu, SIZE).unwrap();
    let mut optical_depth = |share: f64| -> f64 {
        let mut look = stage.look();
        look.lod = share;
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage
            .render(&gpu, &mut enc, &out.view, SIZE, &look)
            .unwrap();
        gpu.queue.submit([enc.finish()]);
        gpu_samples(&gpu, &stage).iter().map(|s| s[4]).sum()
    };
    let (all, half, again) = (optical_depth(1.0), optical_depth(0.5), optical_depth(1.0));
    eprintln!("optical depth: all {all:.1}, half {half:.1}, all again {again:.1}");
    assert!(
        (0.6..0.85).contains(&(half / all)),
        "half the hairs gave {half} of {all}"
    );
    assert!(
        (again - all).abs() < 1e-9 * all,
        "back to every hair: {again} vs {all}"
    );
}
