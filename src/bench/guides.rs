//! Guides and followers, work against precision (`kami bench guides`): for each guide share
//! the simulation's time per frame on the adapter and the followers' position error against
//! simulating every strand, at a few frames of the gust. Writes `guides.md`, `guides.csv`
//! and `guides.png`.

use super::{provenance, write_report, Report};
use crate::bench::plot::{self, Series};
use crate::error::Result;
use crate::gpu::Gpu;
use crate::systems::anjyo::groom::prepare;
use crate::systems::anjyo::simulation::Simulation;
use crate::systems::anjyo::{cantilever_gpu, follow};
use crate::systems::Scene;
use glam::DVec3;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// Shares of simulated strands (1 = every strand, the reference).
pub const SHARES: [f64; 5] = [1.0, 0.5, 0.25, 0.1, 0.05];
/// Frames at which the followers are compared (the gust's wind turns at frame 16).
pub const CHECK_FRAMES: [u32; 4] = [0, 10, 20, 30];

/// One share's run: seconds per frame (each frame recorded, submitted and waited for on
/// its own) and the nodes at each check frame.
struct ShareRun {
    share: f64,
    simulated: usize,
    /// Simulated segments (per substep) and follower nodes (per frame).
    segments: u64,
    follower_nodes: u64,
    followers: Vec<follow::Follower>,
    guide_ranges: Vec<(usize, usize)>,
    frame_seconds: Vec<f64>,
    /// Substeps per frame, mean.
    substeps: f64,
    /// The follower kernel alone, seconds per dispatch (median).
    follow_seconds: f64,
    nodes: Vec<Vec<DVec3>>,
}

fn run_share(gpu: &Gpu, scene: &Scene, share: f64) -> Result<ShareRun> {
    let mut scene = scene.clone();
    if let Some(d) = scene.dynamics_mut().as_mut() {
        d.guides = (share < 1.0).then_some(share);
    }
    let input = prepare(&scene)?;
    let world = crate::systems::world::WorldGpu::of_scene(gpu, &scene)?;
    let hair = cantilever_gpu::groom_gpu(gpu, &world, &input)?;
    let mut sim = Simulation::new(gpu, &world, &scene, &input, &hair)?.ok_or_else(|| {
        crate::KamiError::Invalid {
            file: String::new(),
            field: "dynamics".into(),
            value: "None".into(),
            allowed: "the guides bench needs a scene with dynamics and a dynamic group".into(),
        }
    })?;
    gpu.wait()?;
    let mut frame_seconds = Vec::new();
    let mut substeps = 0u64;
    let mut nodes = Vec::new();
    // Frame 0: the followers rebuilt (f64 reference) from the groomed guides, against the
    // groom: what interpolation alone costs before anything moves.
    let groom: Vec<DVec3> = hair
        .read_vertices(gpu)?
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let mut rest = groom.clone();
    if let Some(f) = &sim.follow {
        follow::follow(f, &groom, sim.setup.forces.head_at(0.0), &mut rest);
    }
    nodes.push(rest);
    let last = *CHECK_FRAMES.last().unwrap();
    for frame in 1..=last {
        let t = Instant::now();
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench guides"),
            });
        substeps += sim.record_frame(gpu, &mut enc, &hair)?.substeps as u64;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        frame_seconds.push(t.elapsed().as_secs_f64());
        if CHECK_FRAMES[1..].contains(&frame) {
            nodes.push(
                hair.read_vertices(gpu)?
                    .iter()
                    .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                    .collect(),
            );
        }
    }
    // The follower kernel alone (the nodes it writes are the same each time).
    let mut follow_times = Vec::new();
    if sim.follow.is_some() {
        for _ in 0..10 {
            let t = Instant::now();
            let mut enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("bench followers"),
                });
            sim.record_followers(gpu, &mut enc)?;
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            follow_times.push(t.elapsed().as_secs_f64());
        }
    }
    Ok(ShareRun {
        substeps: substeps as f64 / last as f64,
        follow_seconds: if follow_times.is_empty() {
            0.0
        } else {
            median(&follow_times)
        },
        share,
        simulated: sim.setup.strands.len(),
        segments: sim.setup.strands.iter().map(|s| s.segments as u64).sum(),
        follower_nodes: sim.follow.as_ref().map_or(0, |f| f.nodes()),
        followers: sim
            .follow
            .as_ref()
            .map_or(Vec::new(), |f| f.followers.clone()),
        guide_ranges: sim
            .setup
            .strands
            .iter()
            .map(|s| (s.first_vertex as usize, s.segments as usize))
            .collect(),
        frame_seconds,
        nodes,
    })
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Errors of the moving nodes (1..=segments) of `strands` (first vertex, segments, length)
/// against the reference: (RMS, max) in scene units, (RMS over the mean length, max of
/// node error over its strand's length).
fn errors(
    nodes: &[DVec3],
    reference: &[DVec3],
    strands: &[(usize, usize, f64)],
) -> (f64, f64, f64, f64) {
    let (mut sum, mut n, mut max, mut max_rel, mut len) = (0.0, 0usize, 0.0f64, 0.0f64, 0.0);
    for &(b, k, l) in strands {
        len += l;
        for v in b + 1..=b + k {
            let e = (nodes[v] - reference[v]).length();
            sum += e * e;
            n += 1;
            max = max.max(e);
            max_rel = max_rel.max(e / l);
        }
    }
    if n == 0 {
        return (0.0, 0.0, 0.0, 0.0);
    }
    let rms = (sum / n as f64).sqrt();
    (rms, max, rms / (len / strands.len() as f64), max_rel)
}

/// Steps per frame of the second configuration (dt divided as much: the same motion,
/// more solver work per frame, the follower kernel's cost unchanged).
pub const FINE_SPF: u32 = 8;

pub fn run(gpu: &Gpu, scene_path: &Path, out: &Path) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    let input = prepare(&scene)?;
    let lengths: Vec<f64> = input
        .roots
        .iter()
        .map(|r| r.seg_len * input.groups[r.group as usize].segments as f64)
        .collect();
    let strands = input.roots.len();
    let mut fine = scene.clone();
    if let Some(d) = fine.dynamics_mut().as_mut() {
        d.dt /= FINE_SPF as f64;
        d.steps_per_frame *= FINE_SPF;
    }
    let configs = [
        ("as in the scene".to_string(), scene),
        (
            format!("{FINE_SPF} times the steps per frame (dt / {FINE_SPF})"),
            fine,
        ),
    ];
    let mut md = String::new();
    let mut csv = String::from(
        "config,share,simulated,followers,substeps_per_frame,ms_per_frame,follow_kernel_ms,speedup,frame,follower_rms,follower_max,follower_rms_rel,follower_max_rel,guide_rms\n",
    );
    guides_intro(gpu, scene_path, strands, &mut md);
    let mut series = Vec::new();
    // (ns per simulated segment-substep at share 1, ns per follower node at best) per config.
    let mut costs = Vec::new();
    for (ci, (label, scene)) in configs.iter().enumerate() {
        let mut runs = Vec::new();
        for share in SHARES {
            runs.push(run_share(gpu, scene, share)?);
        }
        let reference = &runs[0];
        let _ = writeln!(md, "\n**{label}**\n");
        costs.push((
            median(&reference.frame_seconds) * 1e9
                / (reference.segments as f64 * reference.substeps),
            runs.iter()
                .filter(|r| r.follower_nodes > 0)
                .map(|r| r.follow_seconds * 1e9 / r.follower_nodes as f64)
                .fold(f64::INFINITY, f64::min),
        ));
        let points = share_rows(label, &runs, &lengths, &mut md, &mut csv);
        series.push(Series {
            name: format!(
                "{} STEP{} PER FRAME",
                scene.dynamics().as_ref().map_or(1, |d| d.steps_per_frame),
                if ci == 0 { "" } else { "S" }
            ),
            color: plot::palette(ci),
            points,
        });
    }
    let _ = writeln!(
        md,
        "\nFollowers keep their own groom (frame 0 is exact up to the GPU groom's f32) and turn \
         with their guides, but feel no wind, pseudo-force or collision history of their own: \
         where neighbouring strands part ways in the full simulation (the bangs over the \
         forehead, the wind's turn at frame 16) the followers cannot, which sets an error \
         floor that thinning the guides raises only slowly. The time falls less than the \
         share: the follower kernel costs about as much per node as one projective substep, \
         so with one substep per frame there is little to save; with more substeps per frame \
         the saving grows. Measured here: one segment-substep of the solver at share 1 \
         costs {:.1} ns and {:.1} ns in the two configurations (frame time over segments × \
         substeps, overheads included), one follower node {:.1} ns and {:.1} ns (the \
         follower kernel alone, its cheapest share).",
        costs[0].0, costs[1].0, costs[0].1, costs[1].1
    );
    write_report(out, "guides", &md, &csv)?;
    let img = plot::loglog(
        &format!(
            "GUIDES: FOLLOWER ERROR AT FRAME {} VS TIME",
            CHECK_FRAMES.last().unwrap()
        ),
        "MS PER FRAME (SHARES 0.5 .. 0.05)",
        "FOLLOWER RMS ERROR / HAIR LENGTH",
        &series,
        None,
    );
    let p = out.join("guides.png");
    img.save(&p).map_err(|e| crate::KamiError::Image {
        path: p.clone(),
        message: e.to_string(),
    })?;
    Ok(Report { markdown: md, csv })
}

/// The report's heading and the paragraphs on how followers are built and what the time
/// and error columns measure.
fn guides_intro(gpu: &Gpu, scene_path: &Path, strands: usize, md: &mut String) {
    let _ = writeln!(md, "### `kami bench guides` — {}\n", scene_path.display());
    let _ = writeln!(md, "{}\n", provenance());
    let _ = writeln!(
        md,
        "Adapter: {}. {strands} strands; each share simulates `ceil(share × count)` guides per \
         group (farthest-point picks on the scalp) and rebuilds the others from their 3 \
         nearest guides (`systems::anjyo::follow`).\n",
        gpu.describe()
    );
    let _ = writeln!(
        md,
        "**How followers are built** (`src/systems/anjyo/follow.rs`): guides are picked per \
         group by farthest-point sampling of the pores; each follower takes its 3 nearest \
         guides of its group with inverse-distance-squared weights; after each frame's \
         substeps the follower kernel turns every segment of the follower's own groomed \
         shape by the weighted shortest-arc rotations of its guides' same segments, keeps \
         its segment length, and pushes nodes out of the head. The share comes from the \
         scene (`Dynamics(guides: Some(0.25), ...)`) or the Anjyo panel's Dynamics section.\n"
    );
    let _ = writeln!(
        md,
        "**Time**: CPU wall time of recording, submitting and waiting for one frame of the \
         simulation (all substeps, plus the follower kernel), median over {} frames, on the \
         adapter above — on a software adapter this is CPU time, not a GPU's, and on a \
         shared machine it is noisy. *Followers* is the follower kernel alone (median of 10 \
         dispatches, each submitted and waited for). \
         **Error**: position of the followers' moving nodes against the run that simulates \
         every strand (same configuration), at frames {:?} (frame 0: the followers rebuilt \
         from the groomed guides by the f64 reference, against the groom): RMS and worst \
         node, in scene units (the head's radii are 9.6 × 11.5 × 7.8) and relative to the \
         hair length (RMS over the mean length, worst node over its own strand's). *Guides* \
         is the RMS drift of the guides themselves (fewer strands can mean fewer substeps: \
         the stiffest simulated segment sets the substep count).\n",
        CHECK_FRAMES.last().unwrap(),
        CHECK_FRAMES
    );
}

/// One configuration's table: a row per share and checked frame (time, speed-up, follower
/// and guide error against `runs[0]`, which simulates every strand); returns the plot's
/// (ms per frame, relative RMS error) points at the last checked frame.
fn share_rows(
    label: &str,
    runs: &[ShareRun],
    lengths: &[f64],
    md: &mut String,
    csv: &mut String,
) -> Vec<(f64, f64)> {
    let reference = &runs[0];
    let _ = writeln!(
        md,
        "| share | simulated | followers | substeps / frame | ms / frame | followers (ms) | speed-up | frame | followers RMS | followers worst | RMS / length | worst / length | guides RMS |"
    );
    let _ = writeln!(
        md,
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let ref_ms = median(&reference.frame_seconds) * 1e3;
    let mut points = Vec::new();
    for r in runs {
        let ms = median(&r.frame_seconds) * 1e3;
        let speedup = ref_ms / ms;
        let fol: Vec<(usize, usize, f64)> = r
            .followers
            .iter()
            .map(|f| {
                (
                    f.first_vertex as usize,
                    f.segments as usize,
                    lengths[f.strand as usize],
                )
            })
            .collect();
        let gd: Vec<(usize, usize, f64)> =
            r.guide_ranges.iter().map(|&(b, k)| (b, k, 1.0)).collect();
        for (fi, frame) in CHECK_FRAMES.iter().enumerate() {
            if r.followers.is_empty() && *frame == 0 {
                continue;
            }
            let (rms, max, rms_rel, max_rel) = errors(&r.nodes[fi], &reference.nodes[fi], &fol);
            let (g_rms, ..) = errors(&r.nodes[fi], &reference.nodes[fi], &gd);
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.1} | {ms:.1} | {:.1} | {speedup:.2} | {frame} | {rms:.3} | {max:.3} | {rms_rel:.2e} | {max_rel:.2e} | {g_rms:.1e} |",
                r.share,
                r.simulated,
                r.followers.len(),
                r.substeps,
                r.follow_seconds * 1e3
            );
            let _ = writeln!(
                csv,
                "{label},{},{},{},{},{ms:.3},{:.3},{speedup:.3},{frame},{rms:.5e},{max:.5e},{rms_rel:.5e},{max_rel:.5e},{g_rms:.5e}",
                r.share,
                r.simulated,
                r.followers.len(),
                r.substeps,
                r.follow_seconds * 1e3
            );
            if !r.followers.is_empty() && *frame == *CHECK_FRAMES.last().unwrap() {
                points.push((ms, rms_rel));
            }
        }
    }
    points
}
