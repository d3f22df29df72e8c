//! Sakai's fingertip tracker (section 6) against a synthetic hand whose tips follow a known
//! path: the shipped sequence is what the generator makes, every tracked tip lies near the
//! truth, the skeleton drawn lies on the true path with radii following the tips' spacing,
//! touching fingertips stay apart, and bad sequences fail with the file and the reason.

use kami::systems::wisps::fingers::*;
use kami::KamiError;
use std::path::{Path, PathBuf};

const SHIPPED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/depth/hand");

/// Tracked tips against the truth, in the pairing with the smaller 3D error: per tip the
/// image error (px), the depth error (mm, signed) and the 3D error (mm).
fn errors(cam: &Camera, tips: &[Tip; 2], truth: &[[f64; 3]]) -> [(f64, f64, f64); 2] {
    let err = |t: &Tip, g: &[f64; 3]| {
        let uv = cam.project(*g);
        let px = (uv[0] - t.uv[0]).hypot(uv[1] - t.uv[1]);
        let d3 = (0..3).map(|k| (t.p[k] - g[k]).powi(2)).sum::<f64>().sqrt();
        (px, t.depth_mm - g[2], d3)
    };
    let a = [err(&tips[0], &truth[0]), err(&tips[1], &truth[1])];
    let b = [err(&tips[0], &truth[1]), err(&tips[1], &truth[0])];
    if a[0].2 + a[1].2 <= b[0].2 + b[1].2 {
        a
    } else {
        b
    }
}

/// A fresh directory under the system's temp dir, removed when dropped.
struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[track_caller]
fn scratch(name: &str) -> Scratch {
    Scratch(crate::common::scratch(name))
}

fn truth_track(spec: &HandSpec) -> Vec<Option<[Tip; 2]>> {
    (0..spec.poses.len())
        .map(|i| {
            let t = spec.truth(i);
            let tip = |p: [f64; 3]| Tip {
                uv: spec.camera.project(p),
                depth_mm: p[2],
                p,
                pixels: 1,
            };
            Some([tip(t[0]), tip(t[1])])
        })
        .collect()
}

#[test]
fn shipped_sequence_is_what_synthesize_makes() {
    let seq = read_sequence(Path::new(SHIPPED)).unwrap();
    let made = synthesize(&HandSpec::default());
    assert_eq!(seq.frames.len(), 30);
    assert_eq!(seq.camera, Camera::synthetic());
    assert_eq!(made.len(), seq.frames.len());
    for (i, (a, b)) in seq.frames.iter().zip(&made).enumerate() {
        assert_eq!(a.camera, b.camera, "frame {i}");
        let differ = a.depth.iter().zip(&b.depth).filter(|(x, y)| x != y).count();
        assert_eq!(
            differ, 0,
            "frame {i}: {differ} pixels differ from synthesize"
        );
    }
    // The hand is in the picture, and some silhouette pixels have no reading.
    let f = &seq.frames[0];
    assert!(f.depth.iter().any(|&d| d != 0 && d < 500));
    assert!(f.depth.contains(&0));
}

#[test]
fn tracked_tips_lie_on_the_truth() {
    let spec = HandSpec::default();
    let seq = read_sequence(Path::new(SHIPPED)).unwrap();
    let params = TrackParams::default();
    let (mut px, mut dz, mut d3) = (0.0f64, 0.0f64, 0.0f64);
    for (i, f) in seq.frames.iter().enumerate() {
        let tips = fingertips(f, &params).unwrap_or_else(|| panic!("frame {i}: no pair"));
        for (e_px, e_z, e_3) in errors(&seq.camera, &tips, &spec.truth(i)) {
            px = px.max(e_px);
            dz = dz.max(e_z.abs());
            d3 = d3.max(e_3);
        }
        // Nearest first.
        assert!(tips[0].depth_mm <= tips[1].depth_mm, "frame {i}");
    }
    println!("worst over 30 frames: {px:.3} px, {dz:.3} mm in depth, {d3:.3} mm in 3D");
    assert!(px <= 1.0, "image error {px} px");
    assert!(dz <= 1.5, "depth error {dz} mm");
    assert!(d3 <= 2.0, "3D error {d3} mm");
}

/// Distance from `p` to the polyline through `path`.
fn to_polyline(p: [f64; 3], path: &[[f64; 3]]) -> f64 {
    let v = |a: [f64; 3]| glam::DVec3::from(a);
    path.windows(2)
        .map(|s| {
            let (a, b, p) = (v(s[0]), v(s[1]), v(p));
            let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            p.distance(a + t * (b - a))
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn skeleton_follows_the_drawn_path() {
    let spec = HandSpec::default();
    let seq = read_sequence(Path::new(SHIPPED)).unwrap();
    let params = SkeletonParams::default();
    let tracked = track(&seq, &TrackParams::default());
    let sk = skeleton_from_track(&tracked, &params).unwrap();
    let ideal = skeleton_from_track(&truth_track(&spec), &params).unwrap();
    // The true midpoint path and radii, in the head's frame.
    let truth: Vec<([f64; 3], f64)> = (0..spec.poses.len())
        .map(|i| {
            let t = spec.truth(i);
            let (a, b) = (glam::DVec3::from(t[0]), glam::DVec3::from(t[1]));
            let mid = params.to_head(((a + b) * 0.5).to_array());
            (mid, 0.5 * 0.1 * a.distance(b))
        })
        .collect();
    let path: Vec<[f64; 3]> = truth.iter().map(|t| t.0).collect();
    let (mut off, mut r_err) = (0.0f64, 0.0f64);
    for n in &sk.nodes {
        off = off.max(to_polyline(n.p, &path));
        let nearest = truth
            .iter()
            .min_by(|a, b| {
                let d = |p: [f64; 3]| glam::DVec3::from(p).distance(glam::DVec3::from(n.p));
                d(a.0).total_cmp(&d(b.0))
            })
            .unwrap();
        r_err = r_err.max((n.r - nearest.1).abs());
        assert_eq!(n.w, 1.0);
    }
    let ends = |s: &kami::systems::wisps::block::Skeleton| {
        let (a, b) = (s.nodes[0].p, s.nodes[s.nodes.len() - 1].p);
        let d = |p: [f64; 3], q: [f64; 3]| glam::DVec3::from(p).distance(glam::DVec3::from(q));
        (d(a, path[0]), d(b, path[path.len() - 1]))
    };
    let (root, tip) = ends(&sk);
    let radii: Vec<f64> = sk.nodes.iter().map(|n| n.r).collect();
    println!(
        "{} nodes (from the true tips: {}); farthest node {off:.4} cm off the true path; \
         root {root:.4} cm, tip {tip:.4} cm from the path's ends; radius error {r_err:.4} cm; \
         radii {:.3} .. {:.3} cm",
        sk.nodes.len(),
        ideal.nodes.len(),
        radii[0],
        radii[radii.len() - 1]
    );
    assert_eq!(sk.nodes.len(), ideal.nodes.len());
    assert!((10..=30).contains(&sk.nodes.len()));
    assert!(off <= 0.1, "a node is {off} cm off the path");
    assert!(root <= 0.1 && tip <= 0.1, "ends {root} {tip}");
    assert!(r_err <= 0.1, "radius error {r_err} cm");
    // The tips close from 40 to 22 mm: the wisp thins from 2.0 to 1.1 cm.
    assert!((radii[0] - 2.0).abs() <= 0.1 && (radii[radii.len() - 1] - 1.1).abs() <= 0.1);
    assert!(radii.windows(2).all(|w| w[1] < w[0] + 0.05), "{radii:?}");
    // A node each time the midpoint has moved one spacing (1 cm), the last one at the end:
    // gaps of 1 cm up to 1 cm plus a frame's step, and as many nodes as that fits along
    // the path.
    let steps: Vec<f64> = path
        .windows(2)
        .map(|w| glam::DVec3::from(w[0]).distance(glam::DVec3::from(w[1])))
        .collect();
    let (length, step) = (
        steps.iter().sum::<f64>(),
        steps.iter().fold(0.0, |a: f64, &b| a.max(b)),
    );
    let n = sk.nodes.len();
    for (i, w) in sk.nodes.windows(2).enumerate() {
        let d = glam::DVec3::from(w[0].p).distance(glam::DVec3::from(w[1].p));
        let least = if i + 2 == n { 0.5 } else { 1.0 };
        assert!(
            (least..1.0 + step + 0.05).contains(&d),
            "nodes {i} and {} are {d} cm apart",
            i + 1
        );
    }
    let (few, many) = (length / (1.0 + step) + 1.0, length + 2.0);
    println!("path {length:.2} cm long, frames {step:.2} cm apart at most: {n} nodes, between {few:.1} and {many:.1}");
    assert!((few..=many).contains(&(n as f64)));
}

#[test]
fn the_default_mapping_draws_in_front_of_the_face() {
    let m = SkeletonParams::default();
    let at = |p: [f64; 3]| m.to_head(p);
    let near = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12);
    assert!(near(at([0.0, 0.0, 400.0]), [13.0, 2.0, 0.0]));
    // 10 mm right, down, further: 1 cm towards -z, -y, -x (the face looks along +x).
    assert!(near(at([10.0, 0.0, 400.0]), [13.0, 2.0, -1.0]));
    assert!(near(at([0.0, 10.0, 400.0]), [13.0, 1.0, 0.0]));
    assert!(near(at([0.0, 0.0, 410.0]), [12.0, 2.0, 0.0]));
}

#[test]
fn skeleton_ron_pastes_into_a_scene() {
    let seq = read_sequence(Path::new(SHIPPED)).unwrap();
    let sk = skeleton_from_track(
        &track(&seq, &TrackParams::default()),
        &SkeletonParams::default(),
    )
    .unwrap();
    let ron = skeleton_ron(&sk);
    let scene = kami::Scene::from_ron(
        &format!("Scene(wisps: Some(Wisps(skeletons: [{ron}])))"),
        "pasted.ron",
    )
    .unwrap();
    let pasted = &scene.wisps().as_ref().unwrap().skeletons[0];
    assert_eq!(pasted.nodes.len(), sk.nodes.len());
    for (a, b) in pasted.nodes.iter().zip(&sk.nodes) {
        for k in 0..3 {
            assert!((a.p[k] - b.p[k]).abs() <= 0.0005 + 1e-12);
        }
        assert!((a.r - b.r).abs() <= 0.0005 + 1e-12);
    }
}

/// One frame of two fingertips at `z` mm, `gap` mm apart surface to surface, side by side.
fn pair(z: f64, gap: f64, dz: f64, x: f64) -> HandSpec {
    let r = 9.0;
    let half = r + 0.5 * gap;
    HandSpec {
        poses: vec![HandPose {
            palm: Some([x, 12.0, z + 75.0]),
            tips: vec![[x - half, 0.0, z], [x + half, 0.0, z + dz]],
        }],
        ..HandSpec::curl(1)
    }
}

#[test]
fn touching_fingertips_stay_two() {
    let params = TrackParams::default();
    let mut worst = 0.0f64;
    for (z, gap, dz, x) in [
        (380.0, 0.0, 0.0, 0.0),
        (380.0, 1.0, 0.0, 0.0),
        (380.0, 0.5, 0.0, -30.0),
        (350.0, 0.0, 3.0, 20.0),
        (420.0, 0.0, 6.0, 10.0),
        (380.0, 2.0, 0.0, 0.0),
    ] {
        let spec = pair(z, gap, dz, x);
        let f = &synthesize(&spec)[0];
        let tips =
            fingertips(f, &params).unwrap_or_else(|| panic!("z {z} gap {gap} dz {dz}: no pair"));
        for (px, e_z, _) in errors(&f.camera, &tips, &spec.truth(0)) {
            assert!(
                px <= 1.0 && e_z.abs() <= 1.5,
                "z {z} gap {gap} dz {dz}: tip off by {px} px, {e_z} mm"
            );
            worst = worst.max(px);
        }
        // Each area is one fingertip's, not both.
        assert!(tips.iter().all(|t| t.pixels < 60), "{tips:?}");
    }
    println!("touching fingertips: worst {worst:.3} px");
}

/// Two cones (fingertips seen close up) 18 px apart, the second 3 mm further back, rising
/// `slope` mm per pixel to their peaks from the saddle between them; and the ideal area
/// centres: of the pixels on each cone's side of the saddle within `threshold` of its peak.
fn cones(slope: f64, threshold: f64) -> (DepthFrame, [[f64; 2]; 2]) {
    let cam = Camera::synthetic();
    let peaks = [([70.0, 60.0], 250.0), ([88.0, 60.0], 253.0)];
    let cone = |k: usize, u: f64, v: f64| {
        let (c, z): ([f64; 2], f64) = peaks[k];
        z + slope * (u - c[0]).hypot(v - c[1])
    };
    let mut sums = [[0.0; 3]; 2];
    let mut depth = Vec::new();
    for v in 0..cam.height {
        for u in 0..cam.width {
            let (u, v) = (f64::from(u), f64::from(v));
            let (a, b) = (cone(0, u, v), cone(1, u, v));
            let k = usize::from(b < a);
            if a.min(b) <= peaks[k].1 + threshold {
                sums[k][0] += u;
                sums[k][1] += v;
                sums[k][2] += 1.0;
            }
            depth.push(if a.min(b) < 250.0 + 16.0 * slope {
                a.min(b).round() as u16
            } else {
                900
            });
        }
    }
    let centre = |s: [f64; 3]| [s[0] / s[2], s[1] / s[2]];
    (
        DepthFrame { camera: cam, depth },
        [centre(sums[0]), centre(sums[1])],
    )
}

#[test]
fn a_saddle_between_two_cones_stops_both_areas() {
    // Exact analytic depth, independent of the ray caster; the threshold reaches past the
    // saddle, so only step 3's second rule stops each area there. A saddle must rise faster
    // than the noise allowance per pixel: a shallow one needs a lower allowance.
    let mut report = Vec::new();
    for (slope, tol) in [(0.9, 0.0), (1.5, 0.0), (2.0, 1.0), (4.0, 1.0)] {
        let threshold = 12.0 * slope;
        let (f, ideal) = cones(slope, threshold);
        let params = TrackParams {
            threshold_mm: threshold,
            rise_tolerance_mm: tol,
            ..TrackParams::default()
        };
        let tips = fingertips(&f, &params).expect("two tips");
        let mut worst = 0.0f64;
        for (t, c) in tips.iter().zip(ideal) {
            worst = worst.max((t.uv[0] - c[0]).hypot(t.uv[1] - c[1]));
        }
        report.push(format!("slope {slope} tol {tol}: {worst:.3} px"));
        assert!(
            worst <= 0.5,
            "slope {slope} tol {tol}: {tips:?}, ideal {ideal:?}"
        );
    }
    println!("cones, off the ideal areas' centres: {}", report.join("; "));
}

#[test]
fn one_finger_gives_no_pair_but_its_tip() {
    let mut spec = HandSpec::curl(1);
    let t = spec.poses[0].tips[0];
    spec.poses[0].tips.truncate(1);
    let f = &synthesize(&spec)[0];
    let params = TrackParams::default();
    assert!(fingertips(f, &params).is_none());
    let [first, second] = fingertip_areas(f, &params);
    assert!(
        second.is_none(),
        "the palm taken for a fingertip: {second:?}"
    );
    let first = first.unwrap();
    let truth = HandSpec {
        poses: vec![HandPose {
            palm: None,
            tips: vec![t],
        }],
        ..spec.clone()
    }
    .truth(0)[0];
    let uv = f.camera.project(truth);
    assert!((first.uv[0] - uv[0]).hypot(first.uv[1] - uv[1]) <= 1.0);
}

#[test]
fn empty_frames_give_nothing() {
    let params = TrackParams::default();
    let cam = Camera::synthetic();
    let n = (cam.width * cam.height) as usize;
    let blank = DepthFrame {
        camera: cam,
        depth: vec![0; n],
    };
    assert_eq!(fingertip_areas(&blank, &params), [None, None]);
    let wall = DepthFrame {
        camera: cam,
        depth: vec![900; n],
    };
    assert_eq!(fingertip_areas(&wall, &params), [None, None]);
    assert_eq!(wall.mm(3, 4), Some(900.0));
    assert_eq!(wall.mm(160, 0), None);
    assert_eq!(blank.mm(0, 0), None);
    // A palm alone: a convex area, but far too wide for a fingertip.
    let mut spec = HandSpec::curl(1);
    spec.poses[0].tips.clear();
    assert!(fingertips(&synthesize(&spec)[0], &params).is_none());
}

#[test]
fn a_third_finger_further_back_is_ignored() {
    let mut spec = pair(380.0, 8.0, 4.0, 0.0);
    spec.poses[0].tips.push([0.0, -25.0, 400.0]);
    let f = &synthesize(&spec)[0];
    let tips = fingertips(f, &TrackParams::default()).unwrap();
    let truth = spec.truth(0);
    for (px, _, _) in errors(&f.camera, &tips, &truth[..2]) {
        assert!(px <= 1.0);
    }
}

#[test]
fn write_then_read_round_trips() {
    let dir = scratch("roundtrip");
    let spec = HandSpec::curl(4);
    let frames = synthesize(&spec);
    write_sequence(&dir, &frames).unwrap();
    let seq = read_sequence(&dir).unwrap();
    assert_eq!(seq.frames, frames);
    // Writing fewer frames over more would leave stale ones behind: refused.
    let err = write_sequence(&dir, &frames[..2]).unwrap_err().to_string();
    assert!(err.contains("depth_0002.png"), "{err}");
}

#[test]
fn the_cli_writes_and_tracks_a_sequence() {
    let dir = scratch("cli");
    let seq = dir.join("hand");
    let kami = env!("CARGO_BIN_EXE_kami");
    let run = |args: &[&std::ffi::OsStr]| {
        let out = std::process::Command::new(kami)
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    run(&["fingers".as_ref(), "--synthesize".as_ref(), seq.as_os_str()]);
    let sk_path = dir.join("sk.ron");
    let printed = run(&[
        "fingers".as_ref(),
        seq.as_os_str(),
        "--out".as_ref(),
        sk_path.as_os_str(),
    ]);
    let written = std::fs::read_to_string(&sk_path).unwrap();
    assert_eq!(printed.trim(), written.trim());
    let sk: kami::systems::wisps::block::Skeleton = ron::from_str(&written).unwrap();
    assert_eq!(sk.name, "hand");
    assert!(sk.nodes.len() >= 10);
}

// --- Bad input -------------------------------------------------------------------------

fn message(dir: &Path) -> String {
    match read_sequence(dir) {
        Ok(_) => panic!("{} was read", dir.display()),
        Err(e) => e.to_string(),
    }
}

/// A scratch copy of a good 3-frame sequence.
fn good(name: &str) -> Scratch {
    let dir = scratch(name);
    write_sequence(&dir, &synthesize(&HandSpec::curl(3))).unwrap();
    dir
}

fn write_png(path: &Path, w: u32, h: u32, color: png::ColorType, depth: png::BitDepth) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(color);
    enc.set_depth(depth);
    let samples = match color {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::GrayscaleAlpha => 2,
        _ => 1,
    };
    let bytes = (w * h * samples * (depth as u32)).div_ceil(8) as usize;
    let mut wr = enc.write_header().unwrap();
    wr.write_image_data(&vec![7u8; bytes]).unwrap();
    wr.finish().unwrap();
}

#[test]
fn wrong_pixel_formats_are_named() {
    use png::{BitDepth::*, ColorType::*};
    for (color, depth, found) in [
        (Grayscale, Eight, "found 8-bit grayscale"),
        (Rgb, Eight, "found 8-bit RGB"),
        (Rgb, Sixteen, "found 16-bit RGB"),
        (GrayscaleAlpha, Sixteen, "found 16-bit grayscale with alpha"),
    ] {
        let dir = good("format");
        write_png(&dir.join("depth_0001.png"), 160, 120, color, depth);
        let m = message(&dir);
        assert!(m.contains("depth_0001.png"), "{m}");
        assert!(m.contains("16-bit grayscale expected"), "{m}");
        assert!(m.contains(found), "{m}");
    }
}

#[test]
fn a_frame_of_another_size_is_named() {
    let dir = good("size");
    write_png(
        &dir.join("depth_0002.png"),
        80,
        60,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
    );
    let m = message(&dir);
    assert!(m.contains("depth_0002.png") && m.contains("80x60"), "{m}");
    assert!(m.contains("160x120"), "{m}");
}

/// A PNG that is only a header claiming `w` x `h` 16-bit gray pixels (no image data).
fn header_only(path: &Path, w: u32, h: u32) {
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        // CRC-32 of kind and data.
        let mut crc = 0xffff_ffffu32;
        for &b in &out[start..] {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xedb8_8320
                } else {
                    crc >> 1
                };
            }
        }
        out.extend_from_slice(&(!crc).to_be_bytes());
    }
    let mut out = vec![0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[16, 0, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IEND", &[]);
    std::fs::write(path, out).unwrap();
}

#[test]
fn huge_images_are_refused_from_the_header() {
    let dir = good("huge");
    header_only(&dir.join("depth_0000.png"), 100_000, 100_000);
    let m = message(&dir);
    assert!(
        m.contains("depth_0000.png") && m.contains("100000x100000"),
        "{m}"
    );
    assert!(m.contains("4096x4096"), "{m}");
}

#[test]
fn broken_files_are_named() {
    // Text named like a frame.
    let dir = good("text");
    std::fs::write(dir.join("depth_0001.png"), "not an image").unwrap();
    let m = message(&dir);
    assert!(
        m.contains("depth_0001.png") && m.contains("not a PNG file"),
        "{m}"
    );
    // A PNG cut short.
    let dir = good("cut");
    let p = dir.join("depth_0002.png");
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let m = message(&dir);
    assert!(
        m.contains("depth_0002.png") && m.contains("broken PNG"),
        "{m}"
    );
    // A header with no image data.
    let dir = good("nodata");
    header_only(&dir.join("depth_0000.png"), 160, 120);
    let m = message(&dir);
    assert!(
        m.contains("depth_0000.png") && m.contains("broken PNG"),
        "{m}"
    );
}

#[test]
fn directories_without_a_sequence_are_named() {
    let missing = std::env::temp_dir().join("kami-wisps-fingers-no-such-dir");
    let m = message(&missing);
    assert!(m.contains("kami-wisps-fingers-no-such-dir"), "{m}");
    let empty = scratch("empty");
    let m = message(&empty);
    assert!(
        m.contains(empty.to_str().unwrap()) && m.contains("no depth frames"),
        "{m}"
    );
    let file = empty.join("plain.txt");
    std::fs::write(&file, "x").unwrap();
    let m = message(&file);
    assert!(
        m.contains("plain.txt") && m.contains("not a directory"),
        "{m}"
    );
}

#[test]
fn frame_numbering_is_checked() {
    let dir = good("gap");
    std::fs::rename(dir.join("depth_0002.png"), dir.join("depth_0003.png")).unwrap();
    let m = message(&dir);
    assert!(
        m.contains("frame 2 is missing") && m.contains("depth_0003.png"),
        "{m}"
    );
    let dir = good("late");
    std::fs::rename(dir.join("depth_0000.png"), dir.join("depth_0004.png")).unwrap();
    assert!(message(&dir).contains("numbering starts at depth_0000.png"));
    let dir = good("twice");
    std::fs::copy(dir.join("depth_0001.png"), dir.join("depth_1.png")).unwrap();
    assert!(message(&dir).contains("repeats frame 1"));
    let dir = good("misnamed");
    std::fs::write(dir.join("depth_01a.png"), "x").unwrap();
    let m = message(&dir);
    assert!(
        m.contains("depth_01a.png") && m.contains("not a frame name"),
        "{m}"
    );
    // Other files are ignored.
    let dir = good("extra");
    std::fs::write(dir.join("README.md"), "notes").unwrap();
    assert_eq!(read_sequence(&dir).unwrap().frames.len(), 3);
}

#[test]
fn bad_cameras_are_named() {
    for (from, to, expect) in [
        ("fx: 150.0", "fx: 0.0", "`fx` = 0"),
        ("fy: 150.0", "fy: NaN", "`fy` = NaN"),
        ("fx: 150.0", "fx: -3.0", "`fx` = -3"),
        (
            "depth_unit_mm: 1.0",
            "depth_unit_mm: inf",
            "`depth_unit_mm` = inf",
        ),
        ("width: 160", "width: 0", "`width` = 0"),
    ] {
        let dir = good("camera");
        let p = dir.join("camera.ron");
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains(from), "{text}");
        std::fs::write(&p, text.replace(from, to)).unwrap();
        let m = message(&dir);
        assert!(m.contains("camera.ron") && m.contains(expect), "{m}");
    }
    // Syntax: the line and column.
    let dir = good("syntax");
    std::fs::write(
        dir.join("camera.ron"),
        "(\n    width: 160,\n    height: ,\n)",
    )
    .unwrap();
    let m = message(&dir);
    assert!(m.contains("camera.ron:3:"), "{m}");
    match read_sequence(&dir) {
        Err(KamiError::Parse { line, .. }) => assert_eq!(line, 3),
        other => panic!("{other:?}"),
    }
    // Missing.
    let dir = good("nocamera");
    std::fs::remove_file(dir.join("camera.ron")).unwrap();
    assert!(message(&dir).contains("camera.ron"));
}

#[test]
fn a_track_that_goes_nowhere_is_refused() {
    let spec = HandSpec::curl(2);
    let still = vec![truth_track(&spec)[0]; 5];
    let e = skeleton_from_track(&still, &SkeletonParams::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("at least 2 nodes") && e.contains("5 of 5 frames"),
        "{e}"
    );
    let e = skeleton_from_track(&[None, None], &SkeletonParams::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("0 of 2 frames"), "{e}");
    let bad = SkeletonParams {
        node_spacing: f64::NAN,
        ..SkeletonParams::default()
    };
    let e = skeleton_from_track(&truth_track(&spec), &bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("node_spacing"), "{e}");
}
