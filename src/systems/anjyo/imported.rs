//! Grooms made in other tools as live Anjyo hair: a hair group that names a strand file
//! (`block::StrandFile`) takes its rest pose from the file instead of the cantilever.
//! Each strand is resampled to the group's `segments` equal segments along its arc length,
//! because the projective dynamics (Anjyo section 3) moves strands of one segment length.
//! The root is the strand's first point, so it rides the head like a groomed pore.

use super::block::{
    resolve_strand_files, Bending, Direction, HairGroup, Material, Roots, StrandFile,
};
use super::gpu_data::GpuLook;
use super::groom::StrandRoot;
use crate::error::{KamiError, Result};
use crate::rng::Rng;
use crate::scene::{CameraDesc, Head, MAX_SEGMENTS, MAX_STRANDS};
use crate::systems::scene::Scene;
use glam::DVec3;
use std::path::Path;

/// `segments + 1` nodes along the polyline `points`, each exactly one segment length d
/// from the last (the projective dynamics rebuilds strands from angles and d, so unequal
/// chords would change the shape at the first step); d is chosen so that the last node
/// lands on the polyline's end (secant iteration on the arc length it reaches). `None` when
/// the polyline has no length.
pub fn resample(points: &[DVec3], segments: u32) -> Option<Vec<DVec3>> {
    resample_where(points, segments).map(|r| r.0)
}

/// Where a resampled node lies on the file's polyline: between points `i` and `i + 1`
/// (indices into the points given), at fraction `t` (so per-point values are interpolated
/// the way the node's position is).
pub type At = (usize, f64);

/// [`resample`], with where each node lies on the input.
pub fn resample_where(points: &[DVec3], segments: u32) -> Option<(Vec<DVec3>, Vec<At>)> {
    // Repeated points (a tip written twice is common in exports) are zero-length pieces the
    // walk cannot follow: drop them.
    let mut kept: Vec<DVec3> = Vec::with_capacity(points.len());
    let mut index: Vec<usize> = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        if kept.last() != Some(p) {
            kept.push(*p);
            index.push(i);
        }
    }
    if kept.len() < 2 {
        return None;
    }
    let points = &kept[..];
    let total: f64 = points.windows(2).map(|w| (w[1] - w[0]).length()).sum();
    if total.is_nan() || total <= 0.0 || !total.is_finite() {
        return None;
    }
    let k = segments.max(1);
    let mut d = total / k as f64;
    let mut best = walk(points, d, k);
    for _ in 0..40 {
        let reached = best.1;
        if (reached - total).abs() <= 1e-12 * total {
            break;
        }
        // Chords are never longer than the arc they cut: d * k <= reached-arc, so scaling d
        // by total / reached converges from below on smooth strands.
        d *= total / reached.max(1e-300);
        best = walk(points, d, k);
    }
    // Back to the caller's indices (repeated points were dropped).
    let at = best
        .2
        .iter()
        .map(|&(j, t)| (index[j + 1] - 1, t.clamp(0.0, 1.0)))
        .collect();
    Some((best.0, at))
}

/// Nodes k+1 at chord `d` from each other along `points`, the arc length the last one
/// reached (past the end, the last segment's line is followed) and each node's segment and
/// parameter on `points`.
fn walk(points: &[DVec3], d: f64, k: u32) -> (Vec<DVec3>, f64, Vec<(usize, f64)>) {
    let mut out = Vec::with_capacity(k as usize + 1);
    let mut at = Vec::with_capacity(k as usize + 1);
    let mut p = points[0];
    out.push(p);
    at.push((0, 0.0));
    // Position along the polyline: segment j, parameter t in [0, 1].
    let (mut j, mut t) = (0usize, 0.0f64);
    let mut arc_before = 0.0; // arc length up to the start of segment j
    let last = points.len() - 2;
    for _ in 0..k {
        loop {
            let (a, b) = (points[j], points[j + 1]);
            let e = b - a;
            let ee = e.length_squared();
            // |a + s e - p|^2 = d^2 for s >= t: the far root of the quadratic.
            let f = a - p;
            let (qa, qb, qc) = (ee, 2.0 * f.dot(e), f.length_squared() - d * d);
            let disc = qb * qb - 4.0 * qa * qc;
            let s = if qa > 0.0 && disc >= 0.0 {
                (-qb + disc.sqrt()) / (2.0 * qa)
            } else {
                f64::NEG_INFINITY
            };
            if s >= t && (s <= 1.0 || j == last) {
                t = s;
                p = a + e * s;
                break;
            }
            if j == last {
                // The sphere does not reach the last segment's line: go straight on.
                let dir = if ee > 0.0 { e / ee.sqrt() } else { DVec3::X };
                p += dir * d;
                t = if ee > 0.0 { (p - a).dot(e) / ee } else { 1.0 };
                break;
            }
            arc_before += ee.sqrt();
            j += 1;
            t = 0.0;
        }
        out.push(p);
        at.push((j, t));
    }
    let seg = (points[j + 1] - points[j]).length();
    (out, arc_before + t * seg, at)
}

/// What a file group brings: roots, resampled rest nodes (`segments + 1` per strand,
/// strands in order) and, when the file has widths, colours or opacities, each node's look
/// (`GpuLook`, interpolated where the node lies on the file's polyline).
pub type FileStrands = (Vec<StrandRoot>, Vec<DVec3>, Option<Vec<NodeLook>>);

/// A node's own look from its strand file: colour (0..1, as the file has it), opacity and
/// width, at full precision (the GPU gets it packed, `GpuLook`; an export writes these).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeLook {
    pub rgb: [f32; 3],
    pub opacity: f32,
    pub width: f32,
}

impl NodeLook {
    /// As the shaders read it.
    pub fn gpu(&self) -> GpuLook {
        GpuLook::new(self.rgb, self.opacity, self.width)
    }
}

/// Roots, rest nodes and looks of hair group `gi`, read from its file. The file must have
/// been read (`Scene::load` or `block::resolve_strand_files`).
pub fn group_roots(seed: u64, gi: usize, g: &HairGroup) -> Result<FileStrands> {
    let file = g
        .file
        .as_ref()
        .expect("group_roots is called for file groups only");
    let Some(groom) = file.groom.as_ref() else {
        return Err(KamiError::Invalid {
            file: String::new(),
            field: format!("groups[{gi}].file"),
            value: format!("{:?}", file.path),
            allowed: "the strand file was not read: load the scene with Scene::load or call \
                      systems::anjyo::block::resolve_strand_files"
                .into(),
        });
    };
    let mut rng = Rng::new(seed, gi as u64 + 1);
    let mut roots = Vec::with_capacity(groom.counts.len());
    let mut nodes = Vec::with_capacity(groom.counts.len() * (g.segments as usize + 1));
    // At most `count` strands, spread evenly over the file (a count lowered after loading,
    // in code or a panel, thins the groom rather than cutting off its end).
    let all: Vec<&[[f32; 3]]> = groom.strands().collect();
    let mut starts = Vec::with_capacity(all.len());
    let mut acc = 0usize;
    for s in &all {
        starts.push(acc);
        acc += s.len();
    }
    let has_look = groom.widths.is_some() || groom.colors.is_some() || groom.opacities.is_some();
    let mut looks = has_look.then(|| Vec::with_capacity(nodes.capacity()));
    // At most `count`, spread evenly, every guide kept (`block::select_strands`).
    let picks = super::block::select_strands(groom, None, g.count as usize).map_err(|m| {
        KamiError::Data {
            path: file.path.clone(),
            line: None,
            message: m,
        }
    })?;
    for si in picks {
        let pts: Vec<DVec3> = all[si]
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        let Some((n, at)) = resample_where(&pts, g.segments) else {
            return Err(KamiError::Data {
                path: file.path.clone(),
                line: None,
                message: format!("strand {si} has no length (all its points coincide)"),
            });
        };
        let seg_len = (n[1] - n[0]).length();
        let ka = (g.material.ka + g.material.ka_spread * rng.normal()).max(0.0);
        roots.push(StrandRoot {
            pos: n[0],
            dir: (n[1] - n[0]) / seg_len,
            seg_len,
            group: gi as u32,
            ka,
            cut_mask: 0,
        });
        nodes.extend(n);
        if let Some(looks) = looks.as_mut() {
            let base = starts[si];
            let last = pts.len() - 1;
            looks.extend(at.iter().map(|&(i, t)| {
                let (a, b) = (base + i, base + (i + 1).min(last));
                let lerp = |x: f32, y: f32| (x as f64 * (1.0 - t) + y as f64 * t) as f32;
                let width = groom.widths.as_ref().map_or(0.0, |w| lerp(w[a], w[b]));
                let opacity = groom.opacities.as_ref().map_or(1.0, |o| lerp(o[a], o[b]));
                let rgb = groom
                    .colors
                    .as_ref()
                    .map_or([1.0; 3], |c| [0, 1, 2].map(|k| lerp(c[a][k], c[b][k])));
                NodeLook {
                    rgb,
                    opacity,
                    width,
                }
            }));
        }
    }
    Ok((roots, nodes, looks))
}

/// A scene showing one strand file (`.hair`, `.obj` polylines, `.usda`, `.abc`): the strands as
/// one static hair group, over a head ellipsoid fitted under their roots (the file
/// carries no head; name one in a scene file for collisions that matter), the width
/// from the file's root widths or 0.4 % of the mean strand length, and a camera that
/// frames it all. What `kami view groom.hair` and the Files panel open
/// (`Scene::from_strand_file`).
pub fn scene_of(path: &Path) -> Result<Scene> {
    let groom = crate::formats::read(path)?.into_linear();
    let origin = path.display().to_string();
    if groom.counts.is_empty() {
        return Err(KamiError::Data {
            path: origin,
            line: None,
            message: "the file has no strands".into(),
        });
    }
    let n = groom.counts.len();
    let (roots, lengths, root_widths) = strand_roots(&groom);
    let mean_len = lengths.iter().sum::<f64>() / n as f64;
    let (center, radii) = head_under(&roots, mean_len);
    let mut segs: Vec<u32> = groom.counts.iter().map(|&c| c - 1).collect();
    segs.sort_unstable();
    let segments = segs[segs.len() / 2].clamp(4, MAX_SEGMENTS.min(64));
    let width = if root_widths.is_empty() {
        0.004 * mean_len
    } else {
        root_widths.iter().sum::<f64>() / root_widths.len() as f64
    };
    let reach = roots
        .iter()
        .zip(&lengths)
        .map(|(r, l)| (*r - glam::DVec3::from(center)).length() + l)
        .fold(0.0, f64::max)
        .max(1e-6);
    let c = glam::DVec3::from(center);
    let eye = c + glam::DVec3::new(2.6, 0.6, 1.9).normalize() * reach * 2.3;
    let name = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let count = (n as u64).min(MAX_STRANDS) as u32;
    let mut scene = Scene {
        head: Head {
            center,
            radii,
            ..Default::default()
        },
        camera: CameraDesc {
            eye: eye.to_array(),
            target: [c.x, c.y, c.z],
            ..Default::default()
        },
        ..Scene::default()
    };
    *scene.groups_mut() = vec![file_group(name, &origin, count, segments, width)];
    // The scene's own checks first (the registry checks the whole scene after `opens`).
    super::block::validate(&scene).map_err(|e| crate::scene::in_file(e, &origin))?;
    // The file is read again through the group, as a scene file naming it would.
    resolve_strand_files(&mut scene, Path::new(""), &origin)?;
    split_by_group_id(&mut scene, &origin)?;
    // A cache plays its frames: not simulated.
    for g in scene.groups_mut() {
        if g.file.as_ref().is_some_and(|f| f.frames.is_some()) {
            g.dynamic = false;
        }
    }
    Ok(scene)
}

/// Each strand's root, its length, and its root width where the groom has widths.
fn strand_roots(groom: &crate::formats::Groom) -> (Vec<glam::DVec3>, Vec<f64>, Vec<f64>) {
    let n = groom.counts.len();
    let mut roots = Vec::with_capacity(n);
    let mut lengths = Vec::with_capacity(n);
    let mut root_widths = Vec::new();
    let mut at = 0usize;
    for &c in &groom.counts {
        let pts = &groom.points[at..at + c as usize];
        roots.push(glam::DVec3::from(pts[0].map(f64::from)));
        lengths.push(
            pts.windows(2)
                .map(|w| {
                    (glam::DVec3::from(w[1].map(f64::from))
                        - glam::DVec3::from(w[0].map(f64::from)))
                    .length()
                })
                .sum::<f64>(),
        );
        if let Some(w) = &groom.widths {
            root_widths.push(w[at] as f64);
        }
        at += c as usize;
    }
    (roots, lengths, root_widths)
}

/// The head ellipsoid's centre and radii under the roots. Roots cover the scalp: the crown
/// at the top, the nape at the bottom. The ellipsoid has its centre at the lowest root's
/// height and sits inside every root.
fn head_under(roots: &[glam::DVec3], mean_len: f64) -> ([f64; 3], [f64; 3]) {
    let (lo, hi) = roots.iter().fold(
        (glam::DVec3::splat(f64::MAX), glam::DVec3::splat(f64::MIN)),
        |(lo, hi), r| (lo.min(*r), hi.max(*r)),
    );
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(glam::DVec3::splat(1e-3 * mean_len.max(1e-9)));
    let r0 = glam::DVec3::new(half.x, (hi.y - lo.y).max(half.y), half.z);
    let center = [mid.x, lo.y, mid.z];
    // Shrunk until every root is outside it, with a 2 % margin.
    let c0 = glam::DVec3::from(center);
    let k = roots
        .iter()
        .map(|r| ((*r - c0) / r0).length())
        .fold(f64::MAX, f64::min)
        .clamp(1e-3, 1.0);
    (center, (r0 * 0.98 * k).to_array())
}

/// The one hair group reading the whole file `origin`.
fn file_group(name: String, origin: &str, count: u32, segments: u32, width: f64) -> HairGroup {
    HairGroup {
        name,
        file: Some(StrandFile {
            path: origin.to_string(),
            scale: 1.0,
            rotate: [0.0; 3],
            translate: [0.0; 3],
            colors: true,
            widths: true,
            time: None,
            play: true,
            group_id: None,
            groom: None,
            frames: None,
        }),
        roots: Roots::default(),
        count,
        segments,
        length: 0.0,
        length_jitter: 0.0,
        direction: Direction::default(),
        direction_jitter: 0.0,
        rigidity: 0.0,
        bending: Bending::default(),
        loads: vec![],
        cuts: vec![],
        material: Material {
            width,
            ..Default::default()
        },
        dynamic: true,
    }
}

/// Unreal's groups (groom_group_id): one hair group per id, each reading its strands.
fn split_by_group_id(scene: &mut Scene, origin: &str) -> Result<()> {
    let ids: std::collections::BTreeMap<i64, u32> = scene.groups()[0]
        .file
        .as_ref()
        .and_then(|f| f.groom.as_ref()?.group_ids.clone())
        .into_iter()
        .flatten()
        .fold(Default::default(), |mut m, id| {
            *m.entry(id).or_insert(0) += 1;
            m
        });
    if ids.len() > 1 {
        let one = scene.groups_mut().remove(0);
        for (&id, &n) in &ids {
            let mut g = one.clone();
            g.name = format!("{} (group {id})", one.name);
            g.count = n;
            if let Some(f) = g.file.as_mut() {
                f.group_id = Some(id);
                f.groom = None;
                f.frames = None;
            }
            scene.groups_mut().push(g);
        }
        resolve_strand_files(scene, Path::new(""), origin)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_keeps_ends_and_spaces_nodes_equally() {
        // A straight line in uneven pieces: nodes at exact equal steps.
        let pts = [
            DVec3::ZERO,
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::new(4.0, 0.0, 0.0),
        ];
        let n = resample(&pts, 4).unwrap();
        assert_eq!(n.len(), 5);
        for (i, p) in n.iter().enumerate() {
            assert!(
                (*p - DVec3::new(i as f64, 0.0, 0.0)).length() < 1e-12,
                "{i}: {p}"
            );
        }
        // A helix sampled finely: equal chords, the end reached, every node on the curve.
        let helix: Vec<DVec3> = (0..=400)
            .map(|i| {
                let a = i as f64 * 0.03;
                DVec3::new(a.cos(), a.sin(), 0.2 * a)
            })
            .collect();
        let n = resample(&helix, 24).unwrap();
        let d = (n[1] - n[0]).length();
        for w in n.windows(2) {
            assert!(((w[1] - w[0]).length() - d).abs() < 1e-12 * d);
        }
        assert_eq!(n[0], helix[0]);
        assert!(
            (n[24] - helix[400]).length() < 1e-9,
            "tip off by {}",
            (n[24] - helix[400]).length()
        );
        for p in &n {
            let r = (p.x * p.x + p.y * p.y).sqrt();
            assert!((r - 1.0).abs() < 2e-4, "node off the helix: r = {r}");
        }
        assert!(resample(&[DVec3::ONE, DVec3::ONE], 3).is_none());
        // A repeated tip (and a repeated point inside) changes nothing.
        let pts = [
            DVec3::ZERO,
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 2.0, 0.5),
            DVec3::new(0.0, 3.0, 1.5),
            DVec3::new(0.0, 3.0, 1.5),
        ];
        let a = resample(&pts, 4).unwrap();
        let b = resample(&[pts[0], pts[1], pts[3], pts[4]], 4).unwrap();
        assert_eq!(a, b);
        assert!((a[4] - pts[4]).length() < 1e-9, "tip at {}", a[4]);
    }
}
