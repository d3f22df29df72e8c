//! BVH motion capture (Biovision Hierarchy), read to drive the head with a real capture: the
//! CMU database's BVH conversion (shipped by Debian's `assimp-testmodels`) is the public head
//! motion the strips paper's hair rides on. A skeleton (`HIERARCHY`: ROOT, JOINT, End Site,
//! OFFSET, CHANNELS in any order and any rotation order) and its frames (`MOTION`); a joint's
//! global transform per frame by forward kinematics. [`HeadCapture`] turns one joint's
//! motion into the scene's head keys. Lenient where the tools artists use are and nothing is
//! lost: frame lines past the count `Frames:` announces are left out with a warning.
//!
//! Conventions (those of every BVH reader we know): a joint's local transform is the
//! translation `OFFSET + (Xposition, Yposition, Zposition)` followed by the rotation channels
//! composed in the order they are listed (`Zrotation Yrotation Xrotation` is `Rz · Ry · Rx`),
//! angles in degrees; its global transform is its parent's times its local one. A file that
//! cannot be used is refused with the line where it broke; counts are checked before
//! anything is reserved.

use super::forces::{HeadKey, Interp};
use crate::error::{KamiError, Result};
use glam::{DMat3, DMat4, DQuat, DVec3, EulerRot};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The most joints a skeleton may have (CMU's have 31; a hand-rigged one a few hundred).
pub const MAX_JOINTS: usize = 4096;
/// The most frames a file may announce (a day at 120 fps is 10 million).
pub const MAX_FRAMES: usize = 10_000_000;
/// The most channel values (frames × channels) a file may hold: 400 MB of f64.
pub const MAX_VALUES: usize = 50_000_000;
/// The largest BVH file read.
const MAX_FILE_BYTES: u64 = 1 << 30;
/// Nesting deeper than this is refused (the reader recurses once per level).
const MAX_DEPTH: usize = 256;

/// One channel of a joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    Xposition,
    Yposition,
    Zposition,
    Xrotation,
    Yrotation,
    Zrotation,
}

impl Channel {
    fn parse(s: &str) -> Option<Channel> {
        Some(match s.to_ascii_lowercase().as_str() {
            "xposition" => Channel::Xposition,
            "yposition" => Channel::Yposition,
            "zposition" => Channel::Zposition,
            "xrotation" => Channel::Xrotation,
            "yrotation" => Channel::Yrotation,
            "zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }
}

/// A ROOT or JOINT of the skeleton.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    /// Index of the parent joint (None for a ROOT); parents come before their children.
    pub parent: Option<usize>,
    pub offset: DVec3,
    pub channels: Vec<Channel>,
    /// Index of this joint's first channel in a frame's values.
    pub first_channel: usize,
    /// The OFFSET of its End Site, if it has one (the tip of a limb: the top of the head).
    pub end_site: Option<DVec3>,
}

/// A BVH file: skeleton and frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    /// The file it came from (for error messages).
    pub path: String,
    pub joints: Vec<Joint>,
    /// Channels per frame (the sum over joints).
    pub channels: usize,
    pub frames: usize,
    /// Seconds per frame.
    pub frame_time: f64,
    /// `frames × channels` values, frame-major.
    values: Vec<f64>,
}

fn data(path: &str, line: Option<usize>, message: impl Into<String>) -> KamiError {
    KamiError::Data {
        path: path.to_string(),
        line,
        message: message.into(),
    }
}

/// Whitespace tokens with their 1-based line numbers, one line at a time, so the frame data
/// can be read line by line once the header is done.
struct Lexer<'a> {
    path: &'a str,
    lines: Vec<&'a str>,
    /// Index of the current line.
    line: usize,
    toks: std::str::SplitWhitespace<'a>,
}

impl<'a> Lexer<'a> {
    fn new(path: &'a str, text: &'a str) -> Lexer<'a> {
        let lines: Vec<&str> = text.lines().collect();
        let toks = lines.first().copied().unwrap_or("").split_whitespace();
        Lexer {
            path,
            lines,
            line: 0,
            toks,
        }
    }

    /// The line number (1-based) of the token last returned, or of the end of the file.
    fn lineno(&self) -> usize {
        (self.line + 1).min(self.lines.len().max(1))
    }

    fn next(&mut self) -> Option<&'a str> {
        loop {
            if let Some(t) = self.toks.next() {
                return Some(t);
            }
            self.line += 1;
            let l = *self.lines.get(self.line)?;
            self.toks = l.split_whitespace();
        }
    }

    fn err(&self, message: impl Into<String>) -> KamiError {
        data(self.path, Some(self.lineno()), message)
    }

    fn expect_any(&mut self, what: &str) -> Result<&'a str> {
        match self.next() {
            Some(t) => Ok(t),
            None => Err(self.err(format!("the file ends where {what} was expected"))),
        }
    }

    fn expect(&mut self, word: &str) -> Result<()> {
        let t = self.expect_any(&format!("`{word}`"))?;
        if t.eq_ignore_ascii_case(word) {
            Ok(())
        } else {
            Err(self.err(format!("expected `{word}`, found `{t}`")))
        }
    }

    fn number(&mut self, what: &str) -> Result<f64> {
        let t = self.expect_any(what)?;
        let v: f64 = t
            .parse()
            .map_err(|_| self.err(format!("{what}: `{t}` is not a number")))?;
        if !v.is_finite() {
            return Err(self.err(format!("{what}: `{t}` is not finite")));
        }
        Ok(v)
    }

    fn vec3(&mut self, what: &str) -> Result<DVec3> {
        Ok(DVec3::new(
            self.number(what)?,
            self.number(what)?,
            self.number(what)?,
        ))
    }

    /// Whatever is left on the current line must be nothing.
    fn end_of_line(&mut self, after: &str) -> Result<()> {
        match self.toks.next() {
            None => Ok(()),
            Some(t) => Err(self.err(format!("unexpected `{t}` after {after}"))),
        }
    }
}

impl Bvh {
    /// Read a BVH file.
    pub fn read(path: &Path) -> Result<Bvh> {
        let io = |source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        };
        let len = std::fs::metadata(path).map_err(io)?.len();
        let name = path.display().to_string();
        if len > MAX_FILE_BYTES {
            return Err(data(
                &name,
                None,
                format!("{len} bytes: larger than the {MAX_FILE_BYTES} a BVH file may have"),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(io)?;
        Bvh::parse(&text, &name)
    }

    /// Parse BVH text; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Bvh> {
        let mut lx = Lexer::new(path, text);
        lx.expect("HIERARCHY")?;
        let mut joints = Vec::new();
        let mut channels = 0usize;
        loop {
            let t = lx.expect_any("`ROOT` or `MOTION`")?;
            if t.eq_ignore_ascii_case("ROOT") {
                parse_joint(&mut lx, &mut joints, &mut channels, None, 0)?;
            } else if t.eq_ignore_ascii_case("MOTION") {
                break;
            } else {
                return Err(lx.err(format!("expected `ROOT` or `MOTION`, found `{t}`")));
            }
        }
        if joints.is_empty() {
            return Err(lx.err("the hierarchy has no ROOT joint"));
        }
        lx.expect("Frames:")?;
        let t = lx.expect_any("the frame count")?;
        let frames: usize = t
            .parse()
            .map_err(|_| lx.err(format!("`Frames: {t}`: not a whole number of frames")))?;
        if frames == 0 || frames > MAX_FRAMES {
            return Err(lx.err(format!(
                "`Frames: {frames}`: a capture needs 1 to {MAX_FRAMES} frames"
            )));
        }
        if channels.saturating_mul(frames) > MAX_VALUES {
            return Err(lx.err(format!(
                "{frames} frames of {channels} channels: more than the {MAX_VALUES} values \
                 Kami reads"
            )));
        }
        lx.expect("Frame")?;
        lx.expect("Time:")?;
        let frame_time = lx.number("the frame time")?;
        if frame_time <= 0.0 {
            return Err(lx.err(format!(
                "`Frame Time: {frame_time}`: seconds per frame must be positive"
            )));
        }
        lx.end_of_line("the frame time")?;
        // Frame data: one frame per line, blank lines skipped.
        let mut values = Vec::new();
        let mut read = 0usize;
        let mut line = lx.line + 1;
        while read < frames {
            let Some(l) = lx.lines.get(line) else {
                return Err(data(
                    path,
                    Some(lx.lines.len()),
                    format!(
                        "the file ends after {read} of the {frames} frames `Frames:` announces \
                         (truncated?)"
                    ),
                ));
            };
            line += 1;
            if l.trim().is_empty() {
                continue;
            }
            let before = values.len();
            for t in l.split_whitespace() {
                let k = values.len() - before;
                if k >= channels {
                    break;
                }
                let v: f64 = t.parse().map_err(|_| {
                    data(
                        path,
                        Some(line),
                        format!("frame {read}, channel {k}: `{t}` is not a number"),
                    )
                })?;
                if !v.is_finite() {
                    return Err(data(
                        path,
                        Some(line),
                        format!("frame {read}, channel {k}: `{t}` is not finite"),
                    ));
                }
                values.push(v);
            }
            let n = l.split_whitespace().count();
            if n != channels {
                return Err(data(
                    path,
                    Some(line),
                    format!("frame {read} has {n} values; the hierarchy has {channels} channels"),
                ));
            }
            read += 1;
        }
        // Lines past the announced frames (public capture sets often hold one more than
        // their header says; Blender and assimp read such files): the announced frames are
        // read and the rest is left out, said once.
        let rest = &lx.lines[line.min(lx.lines.len())..];
        if let Some(first) = rest.iter().position(|l| !l.trim().is_empty()) {
            let extra = rest.iter().filter(|l| !l.trim().is_empty()).count();
            log::warn!(
                "{path}:{}: {extra} more frame line{} than the {frames} `Frames:` announces: \
                 the {frames} announced frames are read, the rest left out",
                line + first + 1,
                if extra == 1 { "" } else { "s" }
            );
        }
        Ok(Bvh {
            path: path.to_string(),
            joints,
            channels,
            frames,
            frame_time,
            values,
        })
    }

    /// Index of the joint named `name` (exact match).
    pub fn joint(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// The channel values of frame `f` (< `frames`).
    pub fn frame(&self, f: usize) -> &[f64] {
        &self.values[f * self.channels..(f + 1) * self.channels]
    }

    /// A joint's transform relative to its parent at frame `f`.
    pub fn local(&self, joint: usize, f: usize) -> DMat4 {
        let j = &self.joints[joint];
        let v = &self.frame(f)[j.first_channel..j.first_channel + j.channels.len()];
        let mut t = j.offset;
        let mut r = DMat3::IDENTITY;
        for (c, &a) in j.channels.iter().zip(v) {
            let rad = a.to_radians();
            match c {
                Channel::Xposition => t.x += a,
                Channel::Yposition => t.y += a,
                Channel::Zposition => t.z += a,
                Channel::Xrotation => r *= DMat3::from_rotation_x(rad),
                Channel::Yrotation => r *= DMat3::from_rotation_y(rad),
                Channel::Zrotation => r *= DMat3::from_rotation_z(rad),
            }
        }
        DMat4::from_translation(t) * DMat4::from_mat3(r)
    }

    /// A joint's global transform at frame `f` (file units).
    pub fn global(&self, joint: usize, f: usize) -> DMat4 {
        let mut m = self.local(joint, f);
        let mut p = self.joints[joint].parent;
        while let Some(i) = p {
            m = self.local(i, f) * m;
            p = self.joints[i].parent;
        }
        m
    }

    /// A joint's global transform at fractional frame `f` (clamped to the capture): the
    /// translations of the two frames around it blended linearly and their rotations
    /// spherically (blending the Euler channels would spin the long way at ±180°).
    pub fn global_at(&self, joint: usize, f: f64) -> DMat4 {
        let f = f.clamp(0.0, (self.frames - 1) as f64);
        let i = (f.floor() as usize).min(self.frames - 1);
        let t = f - i as f64;
        let a = self.global(joint, i);
        if t == 0.0 || i + 1 >= self.frames {
            return a;
        }
        let b = self.global(joint, i + 1);
        let (_, qa, ta) = a.to_scale_rotation_translation();
        let (_, qb, tb) = b.to_scale_rotation_translation();
        DMat4::from_rotation_translation(qa.slerp(qb, t), ta.lerp(tb, t))
    }
}

/// `ROOT`/`JOINT` body after the keyword: name, `{`, OFFSET, CHANNELS, children, `}`.
fn parse_joint(
    lx: &mut Lexer,
    joints: &mut Vec<Joint>,
    channels: &mut usize,
    parent: Option<usize>,
    depth: usize,
) -> Result<()> {
    if depth > MAX_DEPTH {
        return Err(lx.err(format!("joints nested deeper than {MAX_DEPTH}")));
    }
    if joints.len() >= MAX_JOINTS {
        return Err(lx.err(format!("more than {MAX_JOINTS} joints")));
    }
    let name = lx.expect_any("a joint name")?;
    if name == "{" {
        return Err(lx.err("a joint without a name"));
    }
    lx.expect("{")?;
    lx.expect("OFFSET")?;
    let offset = lx.vec3("OFFSET")?;
    let me = joints.len();
    joints.push(Joint {
        name: name.to_string(),
        parent,
        offset,
        channels: Vec::new(),
        first_channel: *channels,
        end_site: None,
    });
    loop {
        let t = lx.expect_any("`JOINT`, `End Site` or `}`")?;
        match t.to_ascii_uppercase().as_str() {
            "CHANNELS" => {
                if !joints[me].channels.is_empty() {
                    return Err(lx.err(format!("joint `{name}` has two CHANNELS lines")));
                }
                let t = lx.expect_any("the channel count")?;
                let n: usize = t
                    .parse()
                    .ok()
                    .filter(|n| (1..=6).contains(n))
                    .ok_or_else(|| lx.err(format!("CHANNELS `{t}`: a joint has 1 to 6")))?;
                let mut cs = Vec::with_capacity(n);
                for _ in 0..n {
                    let t = lx.expect_any("a channel name")?;
                    let c = Channel::parse(t).ok_or_else(|| {
                        lx.err(format!(
                            "`{t}` is not a channel (Xposition .. Zrotation); joint `{name}` \
                             announces {n}"
                        ))
                    })?;
                    if cs.contains(&c) {
                        return Err(lx.err(format!("joint `{name}` lists `{t}` twice")));
                    }
                    cs.push(c);
                }
                *channels += n;
                joints[me].channels = cs;
            }
            "JOINT" => parse_joint(lx, joints, channels, Some(me), depth + 1)?,
            "END" => {
                lx.expect("Site")?;
                lx.expect("{")?;
                lx.expect("OFFSET")?;
                let o = lx.vec3("End Site OFFSET")?;
                lx.expect("}")?;
                joints[me].end_site = Some(o);
            }
            "}" => return Ok(()),
            _ => {
                return Err(lx.err(format!(
                    "expected `CHANNELS`, `JOINT`, `End Site` or `}}` in joint `{name}`, found \
                     `{t}`"
                )))
            }
        }
    }
}

/// Inches per CMU skeleton unit is 1/0.45 (the ASF files say `length 0.45`), so a unit is
/// 2.54 / 0.45 = 5.644 cm. It checks out on 01_01.bvh: thigh 40.4 cm, shin 42.3 cm.
pub const CMU_CM_PER_UNIT: f64 = 2.54 / 0.45;

/// Head motion from a BVH capture (the scene's head-capture block): one joint's global
/// motion becomes one head key per scene frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadCapture {
    /// The BVH file, relative to the scene file's folder or absolute.
    pub file: String,
    /// The joint whose motion moves the head.
    #[serde(default = "default_joint")]
    pub joint: String,
    /// Centimetres per BVH unit (the default is the CMU database's, [`CMU_CM_PER_UNIT`]).
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Scene frames per second (the capture is resampled from its own frame time).
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// The first BVH frame used: the head is at rest (Kami's head pose) there. The default
    /// skips frame 0, which in the CMU conversions is a reference pose (arms out, no turns)
    /// that the subject leaves in one frame: starting there jerks the head 28°.
    #[serde(default = "one_u32")]
    pub start: u32,
    /// Scene frames to make (None: as many as the capture holds after `start`).
    #[serde(default)]
    pub frames: Option<u32>,
    /// Multiplies the translation (0 keeps the head in place and keeps only the turns: a
    /// jumping subject travels metres, out of a hair close-up).
    #[serde(default = "one")]
    pub translate: f64,
    /// The keys, filled by [`resolve`].
    #[serde(skip)]
    pub keys: Vec<HeadKey>,
}

fn default_joint() -> String {
    "Head".into()
}
fn default_scale() -> f64 {
    CMU_CM_PER_UNIT
}
fn default_fps() -> f64 {
    30.0
}
fn one() -> f64 {
    1.0
}
fn one_u32() -> u32 {
    1
}

fn invalid(field: &str, value: impl std::fmt::Display, allowed: &str) -> KamiError {
    KamiError::Invalid {
        file: String::new(),
        field: format!("forces.head_capture.{field}"),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

/// How a capture maps onto Kami's head: BVH point `x` goes to `center + scale · C (x − p0)`,
/// where `p0` is the head's centre in the capture at the first used frame (the joint's
/// origin plus half its End Site offset: midway up the skull, where Kami's head turns) and
/// `C` turns the capture about the vertical so that the head faces +x there (Kami's face
/// looks along +x). The joint's local +z is taken as its facing (the BVH rest pose faces
/// +z: CMU's toes point there). `C` is a proper turn: the capture is not mirrored, so the
/// subject's left lands on Kami's -z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapping {
    pub p0: DVec3,
    pub turn: DQuat,
    pub scale: f64,
}

impl Mapping {
    /// From the joint's global transform at the first used frame.
    pub fn new(bvh: &Bvh, joint: usize, g0: DMat4, scale: f64) -> Mapping {
        let pivot = bvh.joints[joint].end_site.unwrap_or(DVec3::ZERO) * 0.5;
        let p0 = g0.transform_point3(pivot);
        let fwd = g0.transform_vector3(DVec3::Z);
        // A turn by atan2(z, x) about +y takes the horizontal facing (x, z) onto +x.
        let yaw = if fwd.x.hypot(fwd.z) > 1e-6 {
            fwd.z.atan2(fwd.x)
        } else {
            0.0
        };
        Mapping {
            p0,
            turn: DQuat::from_rotation_y(yaw),
            scale,
        }
    }

    /// A capture point in Kami's frame (relative to the head centre).
    pub fn to_kami(&self, x: DVec3) -> DVec3 {
        self.turn * ((x - self.p0) * self.scale)
    }
}

/// The head key that moves Kami's head as the capture's `d` (a rigid motion in capture
/// space, relative to the first used frame) does: rotation `C R C⁻¹` as Euler ZYX degrees
/// (what `forces::head_at` composes), translation the pivot's displacement in cm.
fn key_of(map: &Mapping, d: DMat4, frame: f64, translate: f64) -> HeadKey {
    let (_, q, _) = d.to_scale_rotation_translation();
    let qk = map.turn * q * map.turn.inverse();
    let (z, y, x) = qk.to_euler(EulerRot::ZYX);
    let tr = map.turn * ((d.transform_point3(map.p0) - map.p0) * map.scale) * translate;
    HeadKey {
        frame,
        rotate: [x.to_degrees(), y.to_degrees(), z.to_degrees()],
        translate: tr.into(),
        interp: Interp::Linear,
    }
}

/// Read the capture `hc.file` names (relative to `dir`, the scene file's folder, unless
/// absolute) and fill `hc.keys`: one linear key per scene frame from 0, the joint's motion
/// relative to BVH frame `start`, resampled at `fps` from the file's frame time. Euler angles
/// are unwrapped key to key so that blending between keys never spins the long way.
pub fn resolve(hc: &mut HeadCapture, dir: &Path) -> Result<()> {
    if !(hc.scale.is_finite() && hc.scale > 0.0) {
        return Err(invalid("scale", hc.scale, "centimetres per BVH unit, > 0"));
    }
    if !(hc.fps.is_finite() && hc.fps > 0.0 && hc.fps <= 10_000.0) {
        return Err(invalid(
            "fps",
            hc.fps,
            "scene frames per second, in (0, 10000]",
        ));
    }
    if !hc.translate.is_finite() {
        return Err(invalid("translate", hc.translate, "a finite multiplier"));
    }
    let path = dir.join(&hc.file);
    let bvh = Bvh::read(&path)?;
    let joint = bvh.joint(&hc.joint).ok_or_else(|| {
        let names: Vec<&str> = bvh.joints.iter().map(|j| j.name.as_str()).collect();
        data(
            &bvh.path,
            None,
            format!("no joint named `{}`; it has {}", hc.joint, names.join(", ")),
        )
    })?;
    let start = hc.start as usize;
    if start >= bvh.frames {
        return Err(invalid(
            "start",
            hc.start,
            &format!("a BVH frame before the capture's last, {}", bvh.frames - 1),
        ));
    }
    // Scene frame f is BVH frame start + f · step.
    let step = 1.0 / (hc.fps * bvh.frame_time);
    let available = (((bvh.frames - 1 - start) as f64 / step + 1e-9).floor() as u64 + 1)
        .min(u32::MAX as u64) as u32;
    let frames = match hc.frames {
        None => available,
        Some(n) if n >= 1 && n <= available => n,
        Some(n) => {
            return Err(invalid(
                "frames",
                n,
                &format!("1 to {available}: what the capture holds from frame {start} at this fps"),
            ))
        }
    };
    let g0 = bvh.global(joint, start);
    let map = Mapping::new(&bvh, joint, g0, hc.scale);
    let g0_inv = g0.inverse();
    let mut keys: Vec<HeadKey> = Vec::with_capacity(frames as usize);
    for f in 0..frames {
        // The first key is the rest pose exactly (G · G⁻¹ rounds to 1e-15 off it).
        let d = match f {
            0 => DMat4::IDENTITY,
            _ => bvh.global_at(joint, start as f64 + f as f64 * step) * g0_inv,
        };
        let mut k = key_of(&map, d, f as f64, hc.translate);
        if let Some(prev) = keys.last() {
            for (a, p) in k.rotate.iter_mut().zip(prev.rotate) {
                *a += 360.0 * ((p - *a) / 360.0).round();
            }
        }
        keys.push(k);
    }
    hc.keys = keys;
    Ok(())
}
