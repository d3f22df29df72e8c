//! Animated caches played as hair (issue 37): a hair group whose strand file holds several
//! frames (USD time samples, Alembic samples; `block::StrandFile::frames`) shows them in
//! turn instead of being simulated. Each frame's strands are resampled as the rest pose is
//! (`imported::resample`, `segments + 1` nodes per strand, the same strands), once, when the
//! system is built; at every step the frame the clock is at is written into the group's
//! nodes, so the strands are drawn, lit and shadowed as any other hair. Kami's frame `f`
//! shows the file's frame `f mod n` (the clock plays one file frame per frame, looping).
//! The group is static: the solver never touches its nodes.

use super::block::HairGroup;
use super::imported::resample;
use crate::error::{KamiError, Result};
use crate::gpu::Gpu;
use glam::DVec3;

/// The frames of one playing group, as the GPU reads its nodes.
pub struct GroupFrames {
    /// Byte offset of the group's first node in the shared vertex buffer.
    pub at: u64,
    /// Nodes of each frame (`[x, y, z, 1]`, as the rest pose is written).
    pub frames: Vec<Vec<[f32; 4]>>,
}

/// Every playing group of a scene.
pub struct Playback {
    pub groups: Vec<GroupFrames>,
    /// Frames of the longest cache (shorter ones hold their last frame).
    pub frames: usize,
    /// The file's rate, frames per second (the first playing group's).
    pub fps: f64,
    /// The frame last written.
    shown: Option<usize>,
}

impl Playback {
    pub fn new(groups: Vec<GroupFrames>, frames: usize, fps: f64) -> Playback {
        Playback {
            groups,
            frames,
            fps,
            shown: Some(0),
        }
    }

    /// The file frame Kami's frame `frame` shows.
    pub fn frame_at(&self, frame: u64) -> usize {
        (frame % self.frames.max(1) as u64) as usize
    }

    /// Write the nodes of Kami's frame `frame` (nothing when they are already there).
    pub fn show(&mut self, gpu: &Gpu, vertices: &wgpu::Buffer, frame: u64) {
        let k = self.frame_at(frame);
        if self.shown == Some(k) {
            return;
        }
        for g in &self.groups {
            let f = &g.frames[k.min(g.frames.len() - 1)];
            gpu.queue
                .write_buffer(vertices, g.at, bytemuck::cast_slice(f));
        }
        self.shown = Some(k);
    }

    /// Forget what was written (the rest pose was copied over it).
    pub fn invalidate(&mut self) {
        self.shown = None;
    }
}

/// The nodes of each frame of a playing file group: its strands (the same `count` taken,
/// spread evenly, as `imported::group_roots` takes them) resampled to `segments`. A strand
/// that has no length in some frame keeps its nodes of the frame before.
pub fn group_frames(g: &HairGroup) -> Result<Option<Vec<Vec<[f32; 4]>>>> {
    let Some((file, frames)) = g.file.as_ref().and_then(|f| Some((f, f.frames.as_ref()?))) else {
        return Ok(None);
    };
    let n = frames.counts.len();
    let take = (g.count as usize).min(n);
    let per = g.segments as usize + 1;
    let need = frames.points.len() as u64 * (take * per) as u64 * 16;
    if need > crate::formats::FRAMES_BUDGET {
        return Err(KamiError::Data {
            path: file.path.clone(),
            line: None,
            message: format!(
                "{} frames of {take} strands of {per} nodes take {:.2} GiB on the GPU side, over \
                 Kami's {:.2} GiB: lower the group's count or segments, or set `play: false`",
                frames.points.len(),
                need as f64 / (1u64 << 30) as f64,
                crate::formats::FRAMES_BUDGET as f64 / (1u64 << 30) as f64
            ),
        });
    }
    let mut starts = Vec::with_capacity(n);
    let mut acc = 0usize;
    for &c in &frames.counts {
        starts.push(acc);
        acc += c as usize;
    }
    let mut out: Vec<Vec<[f32; 4]>> = Vec::with_capacity(frames.points.len());
    for (k, pts) in frames.points.iter().enumerate() {
        let mut nodes = Vec::with_capacity(take * per);
        for j in 0..take {
            let si = j * n / take;
            let strand: Vec<DVec3> = pts[starts[si]..starts[si] + frames.counts[si] as usize]
                .iter()
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                .collect();
            match resample(&strand, g.segments) {
                Some(r) => {
                    nodes.extend(r.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0]))
                }
                None if k > 0 => {
                    let before = &out[k - 1][j * per..(j + 1) * per];
                    nodes.extend_from_slice(before);
                }
                None => {
                    return Err(KamiError::Data {
                        path: file.path.clone(),
                        line: None,
                        message: format!("strand {si} has no length in the first frame"),
                    })
                }
            }
        }
        out.push(nodes);
    }
    Ok(Some(out))
}
