//! Animated caches (issue 37 item 2): a groom file with time samples (USD in each encoding,
//! written by Pixar's USD; Alembic, written by the Alembic library) is read as frames at
//! the file's rate, plays on the stage (Kami's frame f shows the file's frame f mod n,
//! resampled as the rest pose is), refuses what it cannot hold, and turns into a simulated
//! rest pose on request.

use crate::common::{self, scratch};
use glam::DVec3;
use kami::formats::{self, Groom};
use std::path::Path;
use std::process::Command;

/// `tests/usd_curves.py animated PATH`: the frames USD resolves, per time code.
fn usd_animated(path: &Path) -> (f64, Vec<Vec<[f64; 3]>>) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/usd_curves.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg("animated")
        .arg(path)
        .output()
        .expect("python3 runs (install Python 3 and `python3 -m pip install usd-core`)");
    assert!(
        out.status.success(),
        "usd_curves.py animated: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut fps = 0.0;
    let mut frames = Vec::new();
    for l in String::from_utf8_lossy(&out.stdout).lines() {
        let w: Vec<&str> = l.split(' ').collect();
        match w[0] {
            "fps" => fps = w[1].parse().unwrap(),
            "frame" => {
                let v: Vec<f64> = w[2..].iter().map(|x| x.parse().unwrap()).collect();
                frames.push(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
            }
            _ => {}
        }
    }
    (fps, frames)
}

fn worst(a: &[[f32; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] as f64 - q[k]).abs()))
        .fold(0.0, f64::max)
}

/// Every encoding of one USD cache gives the frames USD itself resolves: one per time
/// code from `startTimeCode` to `endTimeCode` (samples every third code, the codes between
/// interpolated), at `timeCodesPerSecond`; a time picks the groom at that time.
#[test]
fn usd_time_samples_are_frames_at_the_file_rate() {
    let dir = scratch("usd");
    for ext in ["usda", "usdc", "usdz"] {
        let path = dir.join(format!("cache.{ext}"));
        let (fps, want) = usd_animated(&path);
        let f = formats::read_frames(&path, formats::FRAMES_BUDGET)
            .unwrap_or_else(|e| panic!("{ext}: {e}"))
            .unwrap_or_else(|| panic!("{ext}: no frames"));
        assert_eq!(f.fps, fps);
        assert_eq!(f.points.len(), 12, "{ext}: frames");
        assert_eq!(f.counts, vec![5, 5, 5]);
        for (i, t) in f.times.iter().enumerate() {
            assert!(
                (t - (1.0 + i as f64) / 30.0).abs() < 1e-12,
                "{ext}: time {i} is {t}"
            );
        }
        for (i, (got, want)) in f.points.iter().zip(&want).enumerate() {
            let e = worst(got, want);
            assert!(e < 2e-6, "{ext}: frame {i} off by {e:e}");
        }
        // The still read is the first sample; a time in seconds is the groom then.
        assert_eq!(formats::read(&path).unwrap().points, f.points[0]);
        let g = formats::read_at(&path, Some(5.0 / 30.0)).unwrap();
        assert!(worst(&g.points, &want[4]) < 2e-6, "{ext}: read at 5/30 s");
    }
}

/// An Alembic cache: one frame per positions sample, at the rate of its time sampling,
/// each with the parent transform of that sample.
#[test]
fn alembic_samples_are_frames() {
    let dir = scratch("abc");
    let (path, _) = crate::alembic::write(&dir, "animated", 0);
    let f = formats::read_frames(&path, formats::FRAMES_BUDGET)
        .unwrap()
        .expect("three samples are frames");
    assert!((f.fps - 24.0).abs() < 1e-9, "fps {}", f.fps);
    assert_eq!(f.times.len(), 3);
    assert_eq!(f.points[0], vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(f.points[1], vec![[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]);
    assert_eq!(f.points[2], vec![[2.0, 0.0, 0.0], [2.0, 3.0, 0.0]]);
    // A still file has no frames.
    let (still, _) = crate::alembic::write(&dir, "linear", 0);
    assert!(formats::read_frames(&still, formats::FRAMES_BUDGET)
        .unwrap()
        .is_none());
}

/// Frames beyond the memory budget are refused with the numbers, before they are read;
/// curves whose point counts change between frames are refused, naming the frame.
#[test]
fn caches_beyond_the_budget_or_changing_shape_are_refused() {
    let dir = scratch("refused");
    let path = dir.join("cache.usdc");
    usd_animated(&path);
    let e = formats::read_frames(&path, 1000).unwrap_err().to_string();
    assert!(
        e.contains("cache.usdc") && e.contains("12 frames of 15 points take"),
        "{e}"
    );
    let text = "#usda 1.0\ndef BasisCurves \"c\" {\n  uniform token type = \"linear\"\n  \
        int[] curveVertexCounts.timeSamples = { 1: [2], 2: [3] }\n  \
        point3f[] points.timeSamples = { 1: [(0,0,0),(0,1,0)], 2: [(0,0,0),(0,1,0),(0,2,0)] }\n}\n";
    let path = dir.join("growing.usda");
    std::fs::write(&path, text).unwrap();
    let e = formats::read_frames(&path, formats::FRAMES_BUDGET)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("growing.usda")
            && e.contains("frame 1")
            && e.contains("keep their point counts"),
        "{e}"
    );
    // A sample of points that does not match the counts: the time code and the line.
    let text = "#usda 1.0\ndef BasisCurves \"c\" {\n  uniform token type = \"linear\"\n  \
        int[] curveVertexCounts = [2]\n  \
        point3f[] points.timeSamples = { 1: [(0,0,0),(0,1,0)], 2: [(0,0,0),(0,1,0),(0,2,0)] }\n}\n";
    let path = dir.join("short.usda");
    std::fs::write(&path, text).unwrap();
    let e = formats::read_frames(&path, formats::FRAMES_BUDGET)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("short.usda:4: at time code 2: the curve vertex counts add up to 2 points but `points` (line 5) has 3"),
        "{e}"
    );
}

/// Opened as a scene, the cache plays: the stage at frame k shows the file's frame
/// k mod 12, each strand resampled to the group's segments as the rest pose is (the export
/// reads the GPU's nodes), and it is not simulated.
#[test]
fn a_cache_plays_on_the_stage_and_loops() {
    let dir = scratch("play");
    let path = dir.join("cache.usdc");
    let (_, want) = usd_animated(&path);
    let scene = kami::Scene::from_strand_file(&path).unwrap();
    let g = &scene.groups()[0];
    assert!(!g.dynamic, "a playing cache is not simulated");
    // Its rate is what `kami render --gif` plays at and the viewer paces its clock by.
    assert_eq!(scene.cache_fps(), Some(30.0));
    let segments = g.segments;
    let gpu = common::gpu();
    let mut stage = common::stage(gpu, &scene);
    let expect = |k: usize| -> Vec<[f64; 3]> {
        want[k]
            .chunks_exact(5)
            .flat_map(|s| {
                let pts: Vec<DVec3> = s.iter().map(|p| DVec3::from_array(*p)).collect();
                kami::systems::anjyo::imported::resample(&pts, segments)
                    .unwrap()
                    .into_iter()
                    .map(|p| p.to_array())
            })
            .collect()
    };
    for (frame, k) in [(0u64, 0usize), (5, 5), (11, 11), (12, 0), (15, 3)] {
        stage.seek(gpu, frame).unwrap();
        let out: Groom = stage.export(gpu).unwrap();
        let e = worst(&out.points, &expect(k));
        assert!(e < 1e-5, "frame {frame} (file frame {k}) off by {e:e}");
    }
}

/// "Simulate from here" (the Cache panel's button, `--set simulate_from_here`): the frame
/// shown becomes the rest pose, the group is simulated from it, and the scene saved then
/// reopens with that rest pose (the file read at that frame's time, not played).
#[test]
fn simulate_from_here_makes_the_shown_frame_the_rest_pose() {
    let dir = scratch("simulate");
    let path = dir.join("cache.usda");
    let (_, want) = usd_animated(&path);
    let mut scene = kami::Scene::from_strand_file(&path).unwrap();
    assert!(scene.dynamics().is_none());
    // Kami's frame 15 shows the file's frame 3.
    kami::systems::anjyo::panel::simulate_from_here(&mut scene, 15).unwrap();
    let g = &scene.groups()[0];
    let f = g.file.as_ref().unwrap();
    assert!(g.dynamic && scene.dynamics().is_some());
    assert!(f.frames.is_none() && !f.play);
    assert_eq!(f.time, Some(4.0 / 30.0));
    assert!(worst(&f.groom.as_ref().unwrap().points, &want[3]) < 2e-6);
    // Saved and reopened: the same rest pose, read from the file at that time.
    let saved = dir.join("from_here.ron");
    std::fs::write(&saved, scene.to_ron()).unwrap();
    let back = kami::Scene::load(&saved).unwrap();
    let bf = back.groups()[0].file.as_ref().unwrap();
    assert!(bf.frames.is_none());
    assert!(worst(&bf.groom.as_ref().unwrap().points, &want[3]) < 2e-6);
    // The dynamics move it from there: a sideways pull swings the strands off the file's
    // frame (they hang straight down in it).
    scene.forces.gravity = [0.0, -150.0, 400.0];
    let gpu = common::gpu();
    let mut stage = common::stage(gpu, &scene);
    stage.seek(gpu, 0).unwrap();
    let rest = stage.export(gpu).unwrap();
    stage.seek(gpu, 10).unwrap();
    let moved = stage.export(gpu).unwrap();
    let d = rest
        .points
        .iter()
        .zip(&moved.points)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f32::max))
        .fold(0.0, f32::max);
    assert!(d > 0.1, "the simulated strands did not move ({d})");
    // Nothing plays any more: the key says so.
    let e = kami::systems::anjyo::panel::simulate_from_here(&mut scene, 0).unwrap_err();
    assert!(e.contains("no hair group plays"), "{e}");
}
