//! The screen-space level of detail (`src/systems/lod.rs`) shared by strand hair and fur,
//! measured on the gust scene as `kami bench lod` does (`kami::bench::lod::measure`), and the
//! fur's skipped regeneration of a still mesh.

use crate::common;

use kami::bench::lod::{at_distance, measure, render};
use kami::stage::{target, Look, Quality, Stage};
use kami::systems::anjyo::AnjyoSystem;
use kami::systems::fur::FurSystem;

const SIZE: (u32, u32) = (400, 400);

/// At four times the distance where the hair fills the frame, the level of detail draws at
/// most 30 % of the strands and 15 % of the segments (measured: 25 % and 12.5 %, share 1/4
/// and node step 2), and the image stays within 4 levels of 255 (tile error) of full detail
/// (measured 2.8; another seed at full detail differs by 1.6).
#[test]
fn a_small_head_draws_fewer_strands_and_segments_with_a_small_error() {
    let gpu = common::gpu();
    let scene = common::scene("gust");
    let p = measure(gpu, &scene, 4.0, SIZE).unwrap();
    let strands = p.lod.strands as f64 / p.full.strands as f64;
    let segments = p.lod.segments as f64 / p.full.segments as f64;
    eprintln!(
        "k = 4: strands {strands:.3}, segments {segments:.3}, error {:?}, floor {:?}",
        p.lod_error, p.floor_error
    );
    assert_eq!(p.full.strands, 10_000);
    assert!(strands <= 0.30, "strands drawn {strands}");
    assert!(segments <= 0.15, "segments drawn {segments}");
    assert!(p.lod_error.0 <= 4.0, "tile error {:?}", p.lod_error);
    assert!(p.lod_error.1 <= 12.0, "pixel error {:?}", p.lod_error);
}

/// Farther still (k = 8: 1/8 of the strands, node step 3), the error stays within the same
/// 4 levels.
#[test]
fn a_tiny_head_keeps_its_look() {
    let gpu = common::gpu();
    let p = measure(gpu, &common::scene("gust"), 8.0, SIZE).unwrap();
    let segments = p.lod.segments as f64 / p.full.segments as f64;
    eprintln!(
        "k = 8: segments {segments:.3}, error {:?}, floor {:?}",
        p.lod_error, p.floor_error
    );
    assert!(segments <= 0.06, "segments drawn {segments}");
    assert!(p.lod_error.0 <= 4.0, "tile error {:?}", p.lod_error);
}

/// At the scene's own camera, and where the hair fills the frame, the level of detail draws
/// everything: the image is the full-detail one, bit for bit.
#[test]
fn full_detail_where_the_head_fills_the_frame() {
    let gpu = common::gpu();
    let scene = common::scene("gust");
    for s in [scene.clone(), at_distance(&scene, 1.0)] {
        let full = render(gpu, &s, SIZE, 0.0).unwrap();
        let lod = render(gpu, &s, SIZE, 0.5).unwrap();
        assert_eq!((lod.strands, lod.segments), (full.strands, full.segments));
        assert!(lod.image == full.image, "the image changed");
    }
}

fn frame(gpu: &kami::gpu::Gpu, stage: &mut Stage, out: &target::Offscreen, look: &Look) {
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    stage.render(gpu, &mut enc, &out.view, SIZE, look).unwrap();
    gpu.queue.submit([enc.finish()]);
}

fn generations(stage: &Stage) -> u64 {
    stage.system::<FurSystem>().unwrap().generations
}

/// A still fur mesh is generated once: a second frame with the same view keeps its hairs;
/// the viewer's level of detail changing, or the camera moving far enough to cull, generate
/// again.
#[test]
fn still_fur_is_not_regenerated() {
    let gpu = common::gpu();
    let scene = common::scene("fur_line");
    assert!(scene.fur().as_ref().unwrap().motion.is_none());
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene)).unwrap();
    let out = target::Offscreen::new(gpu, SIZE).unwrap();
    let mut look = stage.look();
    frame(gpu, &mut stage, &out, &look);
    frame(gpu, &mut stage, &out, &look);
    assert_eq!(generations(&stage), 1);
    look.lod = 0.5;
    frame(gpu, &mut stage, &out, &look);
    assert_eq!(generations(&stage), 2);
    frame(gpu, &mut stage, &out, &look);
    assert_eq!(generations(&stage), 2);
    look.camera.eye = glam::DVec3::from(scene.camera.eye) * 10.0;
    frame(gpu, &mut stage, &out, &look);
    assert_eq!(generations(&stage), 3);
}

/// A moving mesh (`fur.ron`'s travelling wave) is generated again when the clock moves,
/// and not when the same frame is drawn again.
#[test]
fn moving_fur_is_regenerated_each_frame() {
    let gpu = common::gpu();
    let scene = common::scene("fur");
    assert!(scene.fur().as_ref().unwrap().motion.is_some());
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene)).unwrap();
    let out = target::Offscreen::new(gpu, SIZE).unwrap();
    let look = stage.look();
    frame(gpu, &mut stage, &out, &look);
    frame(gpu, &mut stage, &out, &look);
    assert_eq!(generations(&stage), 1);
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    stage.advance(gpu, &mut enc, 1).unwrap();
    gpu.queue.submit([enc.finish()]);
    frame(gpu, &mut stage, &out, &look);
    assert_eq!(generations(&stage), 2);
}

/// The strand share the system drew with is the shared function's.
#[test]
fn anjyo_uses_the_shared_share() {
    let gpu = common::gpu();
    let scene = at_distance(&common::scene("gust"), 4.0);
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene)).unwrap();
    let out = target::Offscreen::new(gpu, SIZE).unwrap();
    let look = stage.look();
    frame(gpu, &mut stage, &out, &look);
    let a = stage.system::<AnjyoSystem>().unwrap();
    assert!((a.screen.share - 0.25).abs() < 1e-9, "{:?}", a.screen);
    assert!((a.screen.width_scale - 4.0).abs() < 1e-9);
}

/// Fur shares the function: far away (four times the distance where the model fills the
/// frame) its polyline coats draw every k-th node (k > 1) and a quarter of the hairs, and
/// the image stays within 4 levels of 255 (tile error) of full detail (measured: steps
/// 2 and 5, 25 % of the hairs, tile error 1.6).
#[test]
fn small_fur_draws_fewer_hairs_and_nodes_with_a_small_error() {
    let gpu = common::gpu();
    let mut scene = common::scene("fur_fig9");
    let setup = kami::systems::fur::setup::FurSetup::new(scene.fur().as_ref().unwrap(), scene.seed)
        .unwrap();
    let (centre, r) = setup.bounds();
    let full = r / (0.5 * scene.camera.fov_y.to_radians()).sin();
    let dir = (glam::DVec3::from(scene.camera.eye) - centre).normalize();
    scene.camera.eye = (centre + dir * (4.0 * full)).to_array();
    scene.camera.target = centre.to_array();
    let shot = |tol: f64| {
        let mut s = scene.clone();
        s.render.lod_tolerance_px = tol;
        let mut stage = Stage::new(gpu, &s, target::OUTPUT_FORMAT, Quality::of(&s)).unwrap();
        let out = target::Offscreen::new(gpu, SIZE).unwrap();
        let look = stage.look();
        frame(gpu, &mut stage, &out, &look);
        let f = stage.system::<FurSystem>().unwrap();
        let drawn: u64 = f.drawn.iter().map(|&d| d as u64).sum();
        (out.read_rgba(gpu).unwrap(), drawn, f.steps.clone())
    };
    let (full_img, full_n, full_steps) = shot(0.0);
    let (img, n, steps) = shot(0.5);
    let err = kami::bench::fur::model_error(&img, &full_img);
    eprintln!("fur k = 4: hairs {n} of {full_n}, steps {steps:?}, error {err:?}");
    assert!(full_steps.iter().all(|&s| s == 1));
    assert!(steps.iter().all(|&s| s > 1), "steps {steps:?}");
    assert!(n as f64 <= 0.3 * full_n as f64, "{n} of {full_n}");
    assert!(err.0 <= 4.0, "tile error {err:?}");
}

/// The viewer's budget lowers the scene's resolution (`Quality::scale_pct`): the scene is
/// drawn into smaller targets and the resolve scales it up bilinearly
/// (`stage/downsample.wgsl`'s `fs_scaled`). At 50 % the bob stays in place and keeps its
/// look (mean difference within 12 levels of 255 from full resolution; measured 9.9 on
/// lavapipe, the thin strands reading lighter at half resolution; a resolve that read the
/// small scene as if it were full size differs by 52) and is not the full-resolution image
/// (the scale is applied); back at 100 % the image is the full-resolution one again.
#[test]
fn a_lower_resolution_keeps_the_look_and_full_resolution_is_unchanged() {
    let gpu = common::gpu();
    let scene = common::thinned("bob", 10);
    let draw = |stage: &mut Stage| common::draw(stage, SIZE);
    let mean_diff = |a: &image::RgbaImage, b: &image::RgbaImage| {
        let sum: u64 = a
            .pixels()
            .zip(b.pixels())
            .map(|(p, q)| (0..3).map(|c| u64::from(p[c].abs_diff(q[c]))).sum::<u64>())
            .sum();
        sum as f64 / (3 * SIZE.0 * SIZE.1) as f64
    };
    let full_quality = Quality::new(1, 1);
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, full_quality).unwrap();
    let full = draw(&mut stage);
    stage.set_quality(
        gpu,
        Quality {
            scale_pct: 50,
            ..full_quality
        },
    );
    let half = draw(&mut stage);
    let d = mean_diff(&full, &half);
    eprintln!("50 % resolution against full: mean difference {d:.2} of 255");
    assert!(
        d < 12.0,
        "50 % resolution lost the look: mean difference {d:.2}"
    );
    assert!(
        d > 0.2,
        "50 % resolution drew the full-resolution image ({d:.3})"
    );
    stage.set_quality(gpu, full_quality);
    let back = draw(&mut stage);
    assert_eq!(
        mean_diff(&full, &back),
        0.0,
        "back at 100 % the image changed"
    );
}
