//! Sakai's depth-camera interface (section 6): the artist draws a wisp's skeleton by moving
//! two fingertips in front of a depth camera. The tracker finds the two nearest convex areas
//! of each depth frame by region growing (the paper's steps 1-8); the skeleton follows the
//! midpoint of the two tips, its radius set by their spacing.
//!
//! Kami drives no camera: a recorded sequence is a directory of 16-bit grayscale depth PNGs
//! (`depth_0000.png`, `depth_0001.png`, ...) and a `camera.ron` (pinhole intrinsics, depth
//! unit). `synthesize` renders a hand whose fingertips follow a known path, so the tracker is
//! checked against the truth; `assets/depth/hand` is its output.
//!
//! Camera coordinates are millimetres: x right, y down, z away from the camera (the depth
//! a camera reports is this z, not the length of the ray). Pixel centres sit at integer (u, v).

use crate::error::{KamiError, Result};
use crate::systems::wisps::block::{Node, Skeleton};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// Largest depth image accepted (each side), checked from the header before decoding.
pub const MAX_SIDE: u32 = 4096;
/// Most frames in a sequence.
pub const MAX_FRAMES: usize = 10_000;
/// Most pixels over a whole sequence (256 MiB of 16-bit depth).
pub const MAX_TOTAL_PIXELS: u64 = 1 << 27;
/// Most nodes a scene's skeleton may hold (the scene validation's limit).
use super::block::MAX_WISP_NODES as MAX_NODES;
/// camera.ron is a few lines; anything far larger is not one.
const MAX_CAMERA_BYTES: u64 = 64 << 10;

/// Pinhole intrinsics of the depth camera, as stored in `camera.ron`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    /// Focal lengths, pixels.
    pub fx: f64,
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    pub cy: f64,
    /// Millimetres per depth count (1 for most cameras' 16-bit output).
    pub depth_unit_mm: f64,
}

impl Camera {
    /// The synthetic camera: 160x120, about a 56 degree horizontal field of view.
    pub fn synthetic() -> Camera {
        Camera {
            width: 160,
            height: 120,
            fx: 150.0,
            fy: 150.0,
            cx: 79.5,
            cy: 59.5,
            depth_unit_mm: 1.0,
        }
    }

    /// Image position of a camera-space point (mm).
    pub fn project(&self, p: [f64; 3]) -> [f64; 2] {
        [
            self.cx + self.fx * p[0] / p[2],
            self.cy + self.fy * p[1] / p[2],
        ]
    }

    /// The camera-space point (mm) at depth `z_mm` seen at image position `uv`.
    pub fn back_project(&self, uv: [f64; 2], z_mm: f64) -> [f64; 3] {
        [
            (uv[0] - self.cx) * z_mm / self.fx,
            (uv[1] - self.cy) * z_mm / self.fy,
            z_mm,
        ]
    }

    /// The first value that makes no sense, as "`field` = value: what is allowed".
    pub fn check(&self) -> std::result::Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if v == 0 || v > MAX_SIDE {
                return Err(format!("`{name}` = {v}: must be 1 to {MAX_SIDE} pixels"));
            }
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0 && v <= 1e6) {
                return Err(format!(
                    "`{name}` = {v}: the focal length must be a finite number of pixels, \
                     above 0 and at most 1e6"
                ));
            }
        }
        for (name, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !(v.is_finite() && v.abs() <= 1e6) {
                return Err(format!(
                    "`{name}` = {v}: the principal point must be a finite number of pixels"
                ));
            }
        }
        let u = self.depth_unit_mm;
        if !(u.is_finite() && u > 0.0 && u <= 1000.0) {
            return Err(format!(
                "`depth_unit_mm` = {u}: millimetres per depth count, above 0 and at most 1000"
            ));
        }
        Ok(())
    }
}

/// One depth image.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthFrame {
    pub camera: Camera,
    /// Row-major depth counts (`camera.depth_unit_mm` each); 0 = no reading.
    pub depth: Vec<u16>,
}

impl DepthFrame {
    /// Depth in millimetres at pixel (u, v); None where the camera had no reading or
    /// outside the image.
    pub fn mm(&self, u: u32, v: u32) -> Option<f64> {
        if u >= self.camera.width || v >= self.camera.height {
            return None;
        }
        let i = v as usize * self.camera.width as usize + u as usize;
        let d = *self.depth.get(i)?;
        (d != 0).then(|| f64::from(d) * self.camera.depth_unit_mm)
    }
}

/// A recorded sequence read from a directory.
#[derive(Clone, Debug, PartialEq)]
pub struct Sequence {
    pub dir: PathBuf,
    pub camera: Camera,
    pub frames: Vec<DepthFrame>,
}

// ---------------------------------------------------------------------------------------
// The synthetic hand.

/// A hand at one frame: fingers are capsules from their tip spheres back into the palm.
#[derive(Clone, Debug, PartialEq)]
pub struct HandPose {
    /// Palm ellipsoid centre (mm); None: no palm (fingers only, for tests).
    pub palm: Option<[f64; 3]>,
    /// Centres of the fingertip spheres (mm).
    pub tips: Vec<[f64; 3]>,
}

/// What `synthesize` renders: a wall, a palm and fingers pointing at the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct HandSpec {
    pub camera: Camera,
    /// Depth of the background wall (mm); 0: no wall (no reading behind the hand).
    pub wall_mm: f64,
    pub finger_radius_mm: f64,
    /// Palm semi-axes along x, y, z (mm): flat in z, facing the camera.
    pub palm_radii_mm: [f64; 3],
    /// A surface seen more obliquely than this (cosine between ray and normal) gives no
    /// reading, as at real depth cameras' silhouettes; 0 keeps every hit.
    pub grazing_cos: f64,
    pub poses: Vec<HandPose>,
}

impl HandSpec {
    /// A finger's base: in the palm's mid-plane at 0.8 of the tip's sideways offset from
    /// the palm's centre, so the fingers lean back into the palm by a few degrees.
    fn finger_base(palm: DVec3, tip: DVec3) -> DVec3 {
        DVec3::new(
            palm.x + 0.8 * (tip.x - palm.x),
            palm.y + 0.8 * (tip.y - palm.y),
            palm.z,
        )
    }

    /// Ground truth at frame `i`: on each fingertip sphere, the point on the ray through
    /// its centre (what the tracker's area centre and nearest depth estimate), in mm.
    pub fn truth(&self, i: usize) -> Vec<[f64; 3]> {
        self.poses[i]
            .tips
            .iter()
            .map(|&c| {
                let c = DVec3::from(c);
                (c - self.finger_radius_mm * c.normalize()).to_array()
            })
            .collect()
    }

    /// A hand whose two tips draw a curl over `frames` frames: the midpoint follows a cubic
    /// Bezier, the spacing narrows from 40 to 22 mm (a wisp thinning to its tip) and the
    /// pair turns so that first one tip, then the other, is nearer the camera. Only
    /// +, *, / and sqrt, so the same on every IEEE machine (the shipped files must match).
    pub fn curl(frames: usize) -> HandSpec {
        let ctrl = [
            DVec3::new(-60.0, -45.0, 420.0),
            DVec3::new(-70.0, 10.0, 370.0),
            DVec3::new(20.0, 40.0, 340.0),
            DVec3::new(60.0, 45.0, 390.0),
        ];
        let poses = (0..frames)
            .map(|i| {
                let s = if frames > 1 {
                    i as f64 / (frames - 1) as f64
                } else {
                    0.0
                };
                let t = 1.0 - s;
                let m = ctrl[0] * (t * t * t)
                    + ctrl[1] * (3.0 * t * t * s)
                    + ctrl[2] * (3.0 * t * s * s)
                    + ctrl[3] * (s * s * s);
                let spacing = 40.0 - 18.0 * s;
                let e = DVec3::new(1.0, 0.25, 0.6 - 1.1 * s).normalize();
                HandPose {
                    palm: Some((m + DVec3::new(0.0, 12.0, 75.0)).to_array()),
                    tips: vec![
                        (m - 0.5 * spacing * e).to_array(),
                        (m + 0.5 * spacing * e).to_array(),
                    ],
                }
            })
            .collect();
        HandSpec {
            camera: Camera::synthetic(),
            wall_mm: 900.0,
            finger_radius_mm: 9.0,
            palm_radii_mm: [40.0, 48.0, 18.0],
            grazing_cos: 0.12,
            poses,
        }
    }
}

impl Default for HandSpec {
    /// The shipped sequence (`assets/depth/hand`): 30 frames of `curl`.
    fn default() -> Self {
        HandSpec::curl(30)
    }
}

/// Nearest hit (depth along z since the ray's z is 1, and the outward normal) of the ray
/// `d` from the camera centre with a sphere.
fn hit_sphere(d: DVec3, c: DVec3, r: f64) -> Option<(f64, DVec3)> {
    let a = d.dot(d);
    let b = d.dot(c);
    let disc = b * b - a * (c.dot(c) - r * r);
    if disc < 0.0 {
        return None;
    }
    let t = (b - disc.sqrt()) / a;
    (t > 0.0).then(|| (t, (t * d - c) / r))
}

/// A capsule: the cylinder between `c0` and `c1` and the spheres at both ends.
fn hit_capsule(d: DVec3, c0: DVec3, c1: DVec3, r: f64) -> Option<(f64, DVec3)> {
    let mut best = nearer(hit_sphere(d, c0, r), hit_sphere(d, c1, r));
    let axis = c1 - c0;
    let len = axis.length();
    if len > 0.0 {
        let k = axis / len;
        let w = -c0;
        let dp = d - d.dot(k) * k;
        let wp = w - w.dot(k) * k;
        let a = dp.dot(dp);
        let b = wp.dot(dp);
        let c = wp.dot(wp) - r * r;
        let disc = b * b - a * c;
        if a > 0.0 && disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            let q = w + t * d;
            let s = q.dot(k);
            if t > 0.0 && (0.0..=len).contains(&s) {
                best = nearer(best, Some((t, (q - s * k) / r)));
            }
        }
    }
    best
}

/// An axis-aligned ellipsoid, as the unit sphere in scaled coordinates.
fn hit_ellipsoid(d: DVec3, c: DVec3, radii: DVec3) -> Option<(f64, DVec3)> {
    let ds = d / radii;
    let cs = c / radii;
    let (t, _) = hit_sphere(ds, cs, 1.0)?;
    let n = ((t * d - c) / (radii * radii)).normalize();
    Some((t, n))
}

fn nearer(a: Option<(f64, DVec3)>, b: Option<(f64, DVec3)>) -> Option<(f64, DVec3)> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if y.0 < x.0 { y } else { x }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// Render the spec's depth frames by casting one ray per pixel centre. Depth is rounded to
/// whole counts; 0 where nothing is hit or the surface is too oblique.
pub fn synthesize(spec: &HandSpec) -> Vec<DepthFrame> {
    let cam = spec.camera;
    let r = spec.finger_radius_mm;
    spec.poses
        .iter()
        .map(|pose| {
            let fingers: Vec<(DVec3, DVec3)> = pose
                .tips
                .iter()
                .map(|&t| {
                    let t = DVec3::from(t);
                    let palm = pose
                        .palm
                        .map_or(t + DVec3::new(0.0, 12.0, 75.0), DVec3::from);
                    (t, HandSpec::finger_base(palm, t))
                })
                .collect();
            let mut depth = Vec::with_capacity(cam.width as usize * cam.height as usize);
            for v in 0..cam.height {
                for u in 0..cam.width {
                    let d = DVec3::new(
                        (f64::from(u) - cam.cx) / cam.fx,
                        (f64::from(v) - cam.cy) / cam.fy,
                        1.0,
                    );
                    let mut hit = None;
                    if spec.wall_mm > 0.0 {
                        hit = Some((spec.wall_mm, DVec3::NEG_Z));
                    }
                    if let Some(p) = pose.palm {
                        let palm =
                            hit_ellipsoid(d, DVec3::from(p), DVec3::from(spec.palm_radii_mm));
                        hit = nearer(hit, palm);
                    }
                    for &(c0, c1) in &fingers {
                        hit = nearer(hit, hit_capsule(d, c0, c1, r));
                    }
                    let count = match hit {
                        Some((z, n)) if n.dot(d).abs() >= spec.grazing_cos * d.length() => {
                            (z / cam.depth_unit_mm).round().clamp(0.0, 65535.0) as u16
                        }
                        _ => 0,
                    };
                    depth.push(count);
                }
            }
            DepthFrame { camera: cam, depth }
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// Files.

fn bad_file(path: &Path, message: impl Into<String>) -> KamiError {
    KamiError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, message.into()),
    }
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> KamiError + '_ {
    move |source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The frame number of a `depth_<digits>.png` name; Some(None) for another `depth_` name
/// (a misnamed frame is an error, not silently skipped); None for unrelated files.
fn frame_number(name: &str) -> Option<Option<usize>> {
    let rest = name.strip_prefix("depth_")?;
    let digits = rest.strip_suffix(".png");
    Some(digits.and_then(|d| {
        (!d.is_empty() && d.len() <= 9 && d.bytes().all(|b| b.is_ascii_digit()))
            .then(|| d.parse().ok())
            .flatten()
    }))
}

/// Write frames as `depth_0000.png`, ... (16-bit grayscale) and `camera.ron` into `dir`,
/// creating it. Refuses a directory holding frames past the new last one, which would
/// otherwise be read back as part of the sequence.
pub fn write_sequence(dir: &Path, frames: &[DepthFrame]) -> Result<()> {
    let Some(first) = frames.first() else {
        return Err(bad_file(dir, "no frames to write"));
    };
    let cam = first.camera;
    cam.check().map_err(|m| bad_file(dir, m))?;
    for (i, f) in frames.iter().enumerate() {
        if f.camera != cam || f.depth.len() != cam.width as usize * cam.height as usize {
            return Err(bad_file(
                dir,
                format!("frame {i} has another camera or size than frame 0"),
            ));
        }
    }
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let mut stale: Option<(usize, String)> = None;
    for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
        let name = entry.map_err(io_err(dir))?.file_name();
        if let Some(name) = name.to_str() {
            if let Some(Some(n)) = frame_number(name) {
                if n >= frames.len() && stale.as_ref().is_none_or(|s| n < s.0) {
                    stale = Some((n, name.to_string()));
                }
            }
        }
    }
    if let Some((_, name)) = stale {
        return Err(bad_file(
            &dir.join(name),
            format!(
                "already here, past the {} frames being written: remove it or write \
                 elsewhere",
                frames.len()
            ),
        ));
    }
    for (i, f) in frames.iter().enumerate() {
        let path = dir.join(format!("depth_{i:04}.png"));
        let file = std::fs::File::create(&path).map_err(io_err(&path))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), cam.width, cam.height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Sixteen);
        enc.set_compression(png::Compression::High);
        let bytes: Vec<u8> = f.depth.iter().flat_map(|d| d.to_be_bytes()).collect();
        enc.write_header()
            .and_then(|mut w| {
                w.write_image_data(&bytes)?;
                w.finish()
            })
            .map_err(|e| KamiError::Image {
                path: path.clone(),
                message: e.to_string(),
            })?;
    }
    let ron = ron::ser::to_string_pretty(&cam, ron::ser::PrettyConfig::new())
        .expect("a camera always serialises");
    let path = dir.join("camera.ron");
    std::fs::write(
        &path,
        format!(
            "// Pinhole intrinsics of depth_*.png: pixels; depth counts of depth_unit_mm.\n\
             {ron}\n"
        ),
    )
    .map_err(io_err(&path))
}

/// Read `camera.ron`: parse errors carry line and column, bad values name the field.
fn read_camera(path: &Path) -> Result<Camera> {
    let meta = std::fs::metadata(path).map_err(io_err(path))?;
    if meta.len() > MAX_CAMERA_BYTES {
        return Err(bad_file(
            path,
            format!("{} bytes: camera.ron is a few lines", meta.len()),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let cam: Camera = ron::from_str(&text).map_err(|e| KamiError::Parse {
        path: path.display().to_string(),
        line: e.span.start.line,
        col: e.span.start.col,
        message: e.code.to_string(),
    })?;
    cam.check().map_err(|m| bad_file(path, m))?;
    Ok(cam)
}

fn describe(color: png::ColorType, depth: png::BitDepth) -> String {
    let c = match color {
        png::ColorType::Grayscale => "grayscale",
        png::ColorType::Rgb => "RGB",
        png::ColorType::Indexed => "indexed (palette)",
        png::ColorType::GrayscaleAlpha => "grayscale with alpha",
        png::ColorType::Rgba => "RGBA",
    };
    format!("{}-bit {c}", depth as u8)
}

/// Read one depth PNG of `cam`'s size; the header is checked before anything is decoded.
fn read_frame(path: &Path, cam: &Camera) -> Result<DepthFrame> {
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    let mut reader = BufReader::new(file);
    let mut sig = [0u8; 8];
    let got = reader
        .by_ref()
        .take(8)
        .read(&mut sig)
        .map_err(io_err(path))?;
    if got < 8 || sig != [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a] {
        return Err(bad_file(
            path,
            "not a PNG file (no PNG signature): 16-bit grayscale PNG expected",
        ));
    }
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    let limit = (MAX_SIDE as usize) * (MAX_SIDE as usize) * 2 + (1 << 20);
    let mut dec = png::Decoder::new_with_limits(BufReader::new(file), png::Limits { bytes: limit });
    let broken = |e: png::DecodingError| bad_file(path, format!("broken PNG: {e}"));
    let info = dec.read_header_info().map_err(broken)?;
    let (w, h) = (info.width, info.height);
    if w > MAX_SIDE || h > MAX_SIDE {
        return Err(bad_file(
            path,
            format!("{w}x{h} pixels: depth images up to {MAX_SIDE}x{MAX_SIDE} are read"),
        ));
    }
    if info.color_type != png::ColorType::Grayscale || info.bit_depth != png::BitDepth::Sixteen {
        return Err(bad_file(
            path,
            format!(
                "16-bit grayscale expected, found {}",
                describe(info.color_type, info.bit_depth)
            ),
        ));
    }
    if (w, h) != (cam.width, cam.height) {
        return Err(bad_file(
            path,
            format!(
                "{w}x{h} pixels, but camera.ron and the frames before say {}x{}",
                cam.width, cam.height
            ),
        ));
    }
    let mut reader = dec.read_info().map_err(broken)?;
    let mut buf = vec![0u8; w as usize * h as usize * 2];
    reader.next_frame(&mut buf).map_err(broken)?;
    let depth = buf
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect();
    Ok(DepthFrame {
        camera: *cam,
        depth,
    })
}

/// Read a sequence: `depth_0000.png` onwards, numbered without gaps, and `camera.ron`.
/// Other files in the directory are ignored.
pub fn read_sequence(dir: &Path) -> Result<Sequence> {
    let meta = std::fs::metadata(dir).map_err(io_err(dir))?;
    if !meta.is_dir() {
        return Err(bad_file(
            dir,
            "not a directory: a depth sequence is a directory of depth_0000.png, ... and \
             camera.ron",
        ));
    }
    let mut numbered = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
        let name = entry.map_err(io_err(dir))?.file_name();
        let Some(name) = name.to_str() else { continue };
        match frame_number(name) {
            None => {}
            Some(None) => {
                return Err(bad_file(
                    &dir.join(name),
                    "not a frame name: frames are named depth_0000.png, depth_0001.png, ...",
                ))
            }
            Some(Some(n)) => numbered.push((n, name.to_string())),
        }
    }
    if numbered.is_empty() {
        return Err(bad_file(
            dir,
            "no depth frames: expected depth_0000.png, depth_0001.png, ... and camera.ron",
        ));
    }
    if numbered.len() > MAX_FRAMES {
        return Err(bad_file(
            dir,
            format!(
                "{} frames: sequences of up to {MAX_FRAMES} are read",
                numbered.len()
            ),
        ));
    }
    numbered.sort();
    for (i, (n, name)) in numbered.iter().enumerate() {
        if *n != i {
            let what = if *n < i {
                format!("{name} repeats frame {n}")
            } else if i == 0 {
                format!("the first frame is {name}; numbering starts at depth_0000.png")
            } else {
                format!(
                    "frame {i} is missing: {} is followed by {name}",
                    numbered[i - 1].1
                )
            };
            return Err(bad_file(
                dir,
                format!("{what} (frames are numbered 0, 1, 2, ... without gaps)"),
            ));
        }
    }
    let camera = read_camera(&dir.join("camera.ron"))?;
    let total = numbered.len() as u64 * u64::from(camera.width) * u64::from(camera.height);
    if total > MAX_TOTAL_PIXELS {
        return Err(bad_file(
            dir,
            format!("{total} pixels in all: sequences of up to {MAX_TOTAL_PIXELS} are read"),
        ));
    }
    let frames = numbered
        .iter()
        .map(|(_, name)| read_frame(&dir.join(name), &camera))
        .collect::<Result<Vec<_>>>()?;
    Ok(Sequence {
        dir: dir.to_path_buf(),
        camera,
        frames,
    })
}

// ---------------------------------------------------------------------------------------
// The tracker.

/// Settings of the fingertip tracker (millimetres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackParams {
    /// Step 3's threshold: an area holds pixels at most this much deeper than its seed.
    pub threshold_mm: f64,
    /// Step 3's second rule ("relative depth becoming less than that of outside points")
    /// allows this much noise: a point outside the area must be nearer than an area pixel
    /// by more than this to stop the growth there.
    pub rise_tolerance_mm: f64,
    /// An area reaching further than this from its centre is not a fingertip (the palm, the
    /// wall): the tracker then reports no pair.
    pub max_tip_radius_mm: f64,
    /// An area of fewer pixels is noise, not a fingertip.
    pub min_pixels: usize,
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            threshold_mm: 12.0,
            rise_tolerance_mm: 1.0,
            max_tip_radius_mm: 25.0,
            min_pixels: 3,
        }
    }
}

/// A tracked fingertip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tip {
    /// Centre of the area, pixels (step 8: the mean of its pixel positions).
    pub uv: [f64; 2],
    /// Depth of the area's seed, its nearest point (mm).
    pub depth_mm: f64,
    /// `uv` back-projected at `depth_mm`: the fingertip in camera space (mm).
    pub p: [f64; 3],
    /// Pixels in the area.
    pub pixels: usize,
}

/// The 8-neighbours of pixel `i` inside the image.
fn neighbours(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (u, v) = ((i % w) as isize, (i / w) as isize);
    (-1..=1isize)
        .flat_map(move |dv| (-1..=1isize).map(move |du| (u + du, v + dv)))
        .filter(move |&(x, y)| {
            (x, y) != (u, v) && x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h
        })
        .map(move |(x, y)| y as usize * w + x as usize)
}

/// Steps 2-3: grow an area from `seed` one ring of pixels at a time, never into `taken`.
///
/// Our reading of step 3 ("terminate expanding of the area if relative depth of the point
/// exceeds a given threshold or is becoming less than relative depth of outside points"):
/// a pixel's relative depth is its depth minus the seed's. Growing outward from a fingertip
/// goes down its flanks, away from the camera, so relative depth rises ring by ring; where
/// the points outside the area are nearer instead, the growth has reached a valley and
/// beyond it lies another convex object (the other fingertip, touching this one in the
/// image). So:
/// (a) a pixel joins only if it has a reading and its relative depth is at most
///     `threshold_mm`;
/// (b) an area pixel that has a point outside the area nearer than itself (by more than
///     `rise_tolerance_mm`) stops expanding: it adds none of its neighbours.
/// Both act per pixel: growth stops there and goes on elsewhere. (b) is deliberately
/// stronger than refusing only the nearer pixel: that would still let the area walk along
/// the other tip's rim, which lies at the valley's depth, and wrap around it. Each ring is
/// judged against the area as it stood before the ring, so the order of visits does not
/// matter. A saddle rising less than `rise_tolerance_mm` per pixel is not seen by (b).
fn grow(frame: &DepthFrame, seed: usize, taken: &[bool], p: &TrackParams) -> Vec<usize> {
    let (w, h) = (frame.camera.width as usize, frame.camera.height as usize);
    let unit = frame.camera.depth_unit_mm;
    let mm = |i: usize| f64::from(frame.depth[i]) * unit;
    let limit = mm(seed) + p.threshold_mm;
    let mut inside = vec![false; w * h];
    inside[seed] = true;
    let outside = |inside: &[bool], q: usize| !inside[q] && !taken[q] && frame.depth[q] != 0;
    let mut area = vec![seed];
    let mut ring = vec![seed];
    let mut next = Vec::new();
    while !ring.is_empty() {
        next.clear();
        for &i in &ring {
            // Outside points include the other area's: a nearer area beside this one is
            // the far side of a valley too.
            let rises =
                |q: usize| !inside[q] && frame.depth[q] != 0 && mm(q) < mm(i) - p.rise_tolerance_mm;
            // (b)
            if neighbours(i, w, h).any(rises) {
                continue;
            }
            // (a)
            next.extend(neighbours(i, w, h).filter(|&q| outside(&inside, q) && mm(q) <= limit));
        }
        next.sort_unstable();
        next.dedup();
        for &q in &next {
            inside[q] = true;
        }
        area.extend_from_slice(&next);
        std::mem::swap(&mut ring, &mut next);
    }
    area
}

/// Step 8 for one area: its centre, or None if it is no fingertip (too small or too wide).
fn tip_of(frame: &DepthFrame, seed: usize, area: &[usize], p: &TrackParams) -> Option<Tip> {
    let cam = &frame.camera;
    let w = cam.width as usize;
    if area.len() < p.min_pixels.max(1) {
        return None;
    }
    let n = area.len() as f64;
    let (su, sv) = area.iter().fold((0.0, 0.0), |(a, b), &i| {
        (a + (i % w) as f64, b + (i / w) as f64)
    });
    let uv = [su / n, sv / n];
    let z = f64::from(frame.depth[seed]) * cam.depth_unit_mm;
    let reach = area
        .iter()
        .map(|&i| {
            let dx = ((i % w) as f64 - uv[0]) * z / cam.fx;
            let dy = ((i / w) as f64 - uv[1]) * z / cam.fy;
            dx.hypot(dy)
        })
        .fold(0.0, f64::max);
    (reach <= p.max_tip_radius_mm).then(|| Tip {
        uv,
        depth_mm: z,
        p: cam.back_project(uv, z),
        pixels: area.len(),
    })
}

/// Steps 1-8, reporting each fingertip found: the first is the one nearest the camera; the
/// second is None when only one finger is up (the next convex area is the palm or the
/// wall, too wide for a fingertip). Both None on an empty frame.
pub fn fingertip_areas(frame: &DepthFrame, params: &TrackParams) -> [Option<Tip>; 2] {
    let cam = &frame.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let d = &frame.depth;
    if d.len() != w * h {
        return [None, None];
    }
    // Step 1: the nearest pixel with a reading (ties: the first in row order).
    let Some(seed1) = (0..d.len()).filter(|&i| d[i] != 0).min_by_key(|&i| d[i]) else {
        return [None, None];
    };
    // Steps 2-4.
    let none = vec![false; w * h];
    let area1 = grow(frame, seed1, &none, params);
    let Some(tip1) = tip_of(frame, seed1, &area1, params) else {
        return [None, None];
    };
    // Step 5: the nearest pixel outside the first area. The paragraph before the steps
    // calls fingertips "the 2 nearest convex areas", so it must also be convex: no
    // neighbour nearer than it. Otherwise the first finger's own flank, just past the
    // threshold, would win whenever the second tip is further back than the threshold.
    let mut taken = none;
    for &i in &area1 {
        taken[i] = true;
    }
    let convex = |i: usize| neighbours(i, w, h).all(|n| d[n] == 0 || d[n] >= d[i]);
    let seed2 = (0..d.len())
        .filter(|&i| d[i] != 0 && !taken[i] && convex(i))
        .min_by_key(|&i| d[i]);
    // Steps 6-8.
    let tip2 = seed2.and_then(|s| tip_of(frame, s, &grow(frame, s, &taken, params), params));
    [Some(tip1), tip2]
}

/// The two fingertips of a frame, nearest first; None unless both are found (one finger up,
/// an empty frame, a nearest area too wide or too small for a fingertip).
pub fn fingertips(frame: &DepthFrame, params: &TrackParams) -> Option<[Tip; 2]> {
    match fingertip_areas(frame, params) {
        [Some(a), Some(b)] => Some([a, b]),
        _ => None,
    }
}

/// `fingertips` of every frame.
pub fn track(seq: &Sequence, params: &TrackParams) -> Vec<Option<[Tip; 2]>> {
    seq.frames.iter().map(|f| fingertips(f, params)).collect()
}

// ---------------------------------------------------------------------------------------
// The skeleton.

/// How tracked tips become skeleton nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct SkeletonParams {
    pub name: String,
    /// Head units per millimetre (0.1: centimetres, the shipped scenes' unit).
    pub scale: f64,
    /// Camera-to-head rotation (rows), applied after `scale`.
    pub rotation: [[f64; 3]; 3],
    /// Head-frame point of the camera origin.
    pub offset: [f64; 3],
    /// Node radius over the tips' spacing (in head units): 0.5 makes the two fingertips
    /// pinch the wisp's diameter.
    pub radius_per_spacing: f64,
    pub min_radius: f64,
    pub max_radius: f64,
    /// A new node once the midpoint has moved this far from the last (head units).
    pub node_spacing: f64,
}

impl Default for SkeletonParams {
    /// Drawing as if facing the head: away from the camera is towards the face (-x), image
    /// down is -y, image right is -z; the camera point 400 mm ahead maps 13 cm in front of
    /// the head's centre, about 3 cm in front of the default face.
    fn default() -> Self {
        SkeletonParams {
            name: "fingers".into(),
            scale: 0.1,
            rotation: [[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]],
            offset: [53.0, 2.0, 0.0],
            radius_per_spacing: 0.5,
            min_radius: 0.1,
            max_radius: 10.0,
            node_spacing: 1.0,
        }
    }
}

impl SkeletonParams {
    /// A camera-space point (mm) in the head's frame.
    pub fn to_head(&self, p: [f64; 3]) -> [f64; 3] {
        let q = DVec3::from(p) * self.scale;
        let r = &self.rotation;
        let row = |k: usize| DVec3::from(r[k]).dot(q) + self.offset[k];
        [row(0), row(1), row(2)]
    }

    fn check(&self) -> std::result::Result<(), String> {
        let pos = |name: &str, v: f64| {
            (v.is_finite() && v > 0.0)
                .then_some(())
                .ok_or_else(|| format!("`{name}` = {v}: must be a finite number above 0"))
        };
        pos("scale", self.scale)?;
        pos("radius_per_spacing", self.radius_per_spacing)?;
        pos("min_radius", self.min_radius)?;
        pos("max_radius", self.max_radius)?;
        pos("node_spacing", self.node_spacing)?;
        if self.min_radius > self.max_radius {
            return Err("`min_radius` is above `max_radius`".into());
        }
        let all = self.rotation.iter().flatten().chain(&self.offset);
        if !all.into_iter().all(|v| v.is_finite()) {
            return Err("`rotation` and `offset` must be finite".into());
        }
        Ok(())
    }
}

fn track_error(message: String) -> KamiError {
    KamiError::Option(format!("fingers: {message}"))
}

/// Sakai's "skeleton parameters depend on fingertip positions and the distance between
/// fingertips": a node at the tips' midpoint (in the head's frame) whenever it has moved
/// `node_spacing` since the last node, and at the last tracked frame if it moved half that;
/// radius from the tips' spacing, weight 1. Frames without two tips are skipped.
pub fn skeleton_from_track(
    track: &[Option<[Tip; 2]>],
    params: &SkeletonParams,
) -> Result<Skeleton> {
    params.check().map_err(track_error)?;
    let node = |tips: &[Tip; 2]| {
        let a = DVec3::from(tips[0].p);
        let b = DVec3::from(tips[1].p);
        let r = params.radius_per_spacing * params.scale * a.distance(b);
        Node {
            p: params.to_head(((a + b) * 0.5).to_array()),
            r: r.clamp(params.min_radius, params.max_radius),
            w: 1.0,
        }
    };
    let dist = |a: &Node, b: &Node| DVec3::from(a.p).distance(DVec3::from(b.p));
    let tracked: Vec<Node> = track.iter().flatten().map(node).collect();
    let mut nodes: Vec<Node> = Vec::new();
    for n in &tracked {
        match nodes.last() {
            Some(last) if dist(last, n) < params.node_spacing => {}
            _ => nodes.push(*n),
        }
    }
    if let (Some(end), Some(last)) = (tracked.last(), nodes.last()) {
        if dist(last, end) >= 0.5 * params.node_spacing {
            nodes.push(*end);
        }
    }
    if nodes.len() < 2 {
        return Err(track_error(format!(
            "two fingertips were found in {} of {} frames and their midpoint never moved {} \
             (the node spacing, in head units) from where it started: a skeleton needs at \
             least 2 nodes (move the fingers further, or lower the node spacing)",
            tracked.len(),
            track.len(),
            params.node_spacing
        )));
    }
    if nodes.len() > MAX_NODES {
        return Err(track_error(format!(
            "the track makes {} nodes, a skeleton holds at most {MAX_NODES}: raise the node \
             spacing above {}",
            nodes.len(),
            params.node_spacing
        )));
    }
    Ok(Skeleton {
        name: params.name.clone(),
        nodes,
        outline: 1.0,
    })
}

/// A skeleton as RON, ready to paste into a scene's `wisps.skeletons` (to 0.001 units).
pub fn skeleton_ron(skeleton: &Skeleton) -> String {
    let round = |v: f64| (v * 1000.0).round() / 1000.0 + 0.0;
    let sk = Skeleton {
        name: skeleton.name.clone(),
        nodes: skeleton
            .nodes
            .iter()
            .map(|n| Node {
                p: n.p.map(round),
                r: round(n.r),
                w: round(n.w),
            })
            .collect(),
        outline: skeleton.outline,
    };
    let cfg = ron::ser::PrettyConfig::new()
        .struct_names(true)
        .depth_limit(2);
    ron::ser::to_string_pretty(&sk, cfg).expect("a skeleton always serialises")
}

/// What `kami fingers DIR` does: read, track with the default settings, draw the skeleton
/// (named after the directory). Also returns the number of frames with both tips found.
pub fn skeleton_from_dir(dir: &Path) -> Result<(Skeleton, usize, usize)> {
    let seq = read_sequence(dir)?;
    let tips = track(&seq, &TrackParams::default());
    let found = tips.iter().flatten().count();
    let params = SkeletonParams {
        name: dir
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("fingers")
            .to_string(),
        ..SkeletonParams::default()
    };
    let sk = skeleton_from_track(&tips, &params).map_err(|e| match e {
        KamiError::Option(m) => KamiError::Option(format!("{}: {m}", dir.display())),
        other => other,
    })?;
    Ok((sk, found, seq.frames.len()))
}

/// Draw a toon-wisp skeleton with two fingertips (Sakai section 6): track a depth
/// sequence (depth_0000.png ... and camera.ron) and print the skeleton as RON.
#[derive(clap::Parser)]
#[command(name = "fingers")]
struct Fingers {
    /// Directory of the depth sequence, e.g. assets/depth/hand.
    #[arg(required_unless_present = "synthesize")]
    dir: Option<PathBuf>,
    /// Write the synthetic hand sequence into this directory instead of tracking.
    #[arg(long, conflicts_with_all = ["dir", "out"])]
    synthesize: Option<PathBuf>,
    /// Also write the skeleton to this file.
    #[arg(short, long)]
    out: Option<PathBuf>,
}

/// `kami fingers`, the kind's own command (listed in the kind's `Kind::commands`): its
/// options and help.
pub fn command() -> clap::Command {
    <Fingers as clap::CommandFactory>::command()
}

/// Run `kami fingers`: write the synthetic sequence (`--synthesize`), or track `DIR` and
/// print the skeleton as RON (the summary on stderr), also to `--out`.
pub fn run_command(m: &clap::ArgMatches) -> Result<()> {
    let a = <Fingers as clap::FromArgMatches>::from_arg_matches(m)
        .map_err(|e| KamiError::Option(e.to_string()))?;
    if let Some(to) = a.synthesize {
        let frames = synthesize(&HandSpec::default());
        write_sequence(&to, &frames)?;
        println!(
            "wrote {} depth frames and camera.ron to {}",
            frames.len(),
            to.display()
        );
    } else if let Some(dir) = a.dir {
        let (skeleton, found, frames) = skeleton_from_dir(&dir)?;
        let ron = skeleton_ron(&skeleton);
        eprintln!(
            "two fingertips in {found} of {frames} frames: {} nodes",
            skeleton.nodes.len()
        );
        println!("{ron}");
        if let Some(out) = a.out {
            std::fs::write(&out, format!("{ron}\n"))
                .map_err(|e| KamiError::Option(format!("cannot write {}: {e}", out.display())))?;
        }
    }
    Ok(())
}
