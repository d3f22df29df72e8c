//! Guides and followers (what TressFX, Unity's hair and Unreal's groom do): the projective
//! solver simulates only a share of each dynamic group's strands, the *guides*; every other
//! strand, a *follower*, is rebuilt after each frame's substeps from its nearest guides
//! (`shaders/anjyo/follow.wgsl`, one invocation per follower; this file holds the set-up and
//! the f64 reference, `tests/it/guides.rs` compares them). The scene's `dynamics.guides` picks
//! the share; absent (or 1) every strand is simulated and nothing here runs.
//!
//! - **Which strands guide**: per dynamic group, `ceil(share * count)` pores picked by
//!   farthest-point sampling over the pores' positions on the scalp (head coordinates),
//!   starting from the group's first strand, ties to the lower index. Farthest-point picks
//!   spread the guides evenly whatever the pore density (a random or every-n-th pick leaves
//!   holes and clumps on a randomly drawn scalp), and the result is deterministic.
//! - **Weights**: each follower takes the `MAX_GUIDES` = 3 nearest guides of its own group
//!   (by pore distance) with Shepard's inverse-distance-squared weights w_j, normalised; a
//!   follower whose pore coincides with a guide's takes that guide alone. Computed once at
//!   set-up. (Barycentric weights would need a triangulation of the scalp; three
//!   inverse-distance neighbours are smooth enough at the shares that pay.)
//! - **Interpolation**: a follower keeps its own groom and turns it as its guides turn.
//!   For segment i, each guide j's rotation R_j,i is the shortest arc taking that guide's
//!   segment i at rest (the groom, carried by the head pose) to where it is now; the
//!   follower's segment takes the direction of sum_j w_j R_j,i (H r_i), r_i its own rest
//!   segment and H the head pose, and keeps its own length d: node by node from the pore
//!   (ridden by the head pose) toward the tip, p_i = p_{i-1} + d normalize(...). A guide
//!   with fewer simulated segments (a cut) lends the rotation of its last one; a blend that
//!   cancels keeps the previous segment's direction.
//!   *Why not the plain offset blend* (node i = own root + sum_j w_j (d / d_j)
//!   (g_j,i - g_j,0), then lengths restored): it was our first version, and it throws away
//!   each follower's own groom — every follower takes the average shape of its neighbours
//!   even at rest, which on the gust cost 1.3 % of the hair length RMS before anything moved
//!   (`kami bench guides`, frame 0); rotating the follower's own rest shape is exact at rest
//!   and costs three cross products per node more.
//! - **Head**: with `dynamics.collision`, a node that lands inside the head is pushed out
//!   with the projective solver's own response (`HeadHull::push_out` / `head_push_out`, the
//!   first segment's plane from the hull normal at the pore), so followers stay outside.
//!
//! The rest shape is the groom as it was when the simulation was set up (a copy of the
//! vertex buffer on the GPU, `rest` here).
//!
//! A follower ignores forces of its own (wind, the EFF, the pseudo-force, kicks): it moves
//! only as its guides do. What that costs in accuracy against simulating every strand is
//! measured by `kami bench guides` (`docs/guides.md`).

use super::groom::GroomInput;
use super::projective::DynSetup;
use crate::scene::hull::HeadHull;
use crate::systems::scene::Scene;
use glam::{DMat4, DVec3};

/// Guides per follower.
pub const MAX_GUIDES: usize = 3;

/// One guide as a follower reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideRef {
    /// The guide's root node in the shared vertex array.
    pub first_vertex: u32,
    /// The guide's simulated segments.
    pub segments: u32,
    /// Shepard weight w_j (the weights of a follower sum to 1).
    pub weight: f64,
}

/// One strand that follows its guides.
#[derive(Clone, Debug, PartialEq)]
pub struct Follower {
    /// Index in the strand table.
    pub strand: u32,
    pub first_vertex: u32,
    /// Moved segments: the drawn (cut) length, rounded up, as for a simulated strand.
    pub segments: u32,
    pub seg_len: f64,
    /// Pore in head coordinates.
    pub root_local: DVec3,
    /// One to `MAX_GUIDES` guides.
    pub guides: Vec<GuideRef>,
}

/// The followers of one groom and what their step reads.
#[derive(Clone, Debug)]
pub struct FollowSetup {
    pub followers: Vec<Follower>,
    pub head: HeadHull,
    /// `dynamics.collision`: push nodes out of the head.
    pub collision: bool,
}

/// The share of simulated strands a scene asks for: `None` (or 1) means every strand.
fn share(scene: &Scene) -> Option<f64> {
    scene
        .dynamics()
        .as_ref()
        .and_then(|d| d.guides)
        .filter(|&s| s < 1.0)
}

/// Guides to pick out of `n` strands at `share`.
pub fn guide_count(n: usize, share: f64) -> usize {
    ((share * n as f64).ceil() as usize).clamp(1, n.max(1))
}

/// Farthest-point sampling of `m` of `points` (indices into `points`, in pick order):
/// the first point, then repeatedly the one farthest from every pick so far (ties to the
/// lower index).
pub fn farthest_points(points: &[DVec3], m: usize) -> Vec<usize> {
    let n = points.len();
    let m = m.min(n);
    let mut picks = Vec::with_capacity(m);
    if m == 0 {
        return picks;
    }
    let mut nearest = vec![f64::INFINITY; n];
    let mut cur = 0usize;
    for _ in 0..m {
        picks.push(cur);
        let c = points[cur];
        let mut best = (f64::NEG_INFINITY, 0usize);
        for (i, p) in points.iter().enumerate() {
            let d = p.distance_squared(c);
            if d < nearest[i] {
                nearest[i] = d;
            }
            if nearest[i] > best.0 {
                best = (nearest[i], i);
            }
        }
        cur = best.1;
    }
    picks
}

/// Per strand of the groom: whether the projective solver simulates it. Every strand of a
/// dynamic group without a guide share (or with share 1); with a share, the farthest-point
/// picks of each dynamic group; in a group whose strand file flags guides (Unreal's
/// `groom_guide`), those. Strands of static groups are `false`.
pub fn guide_mask(scene: &Scene, input: &GroomInput) -> Vec<bool> {
    let dynamic = |g: u32| scene.groups()[g as usize].dynamic;
    let mut mask: Vec<bool> = input.roots.iter().map(|r| dynamic(r.group)).collect();
    // A file's own guides (Unreal's groom_guide) are its group's guides, share or not.
    for (g, p) in input.groups.iter().enumerate() {
        if let (Some(flags), true) = (&p.guides, dynamic(g as u32)) {
            let first = p.first_strand as usize;
            for (k, &f) in flags.iter().enumerate() {
                mask[first + k] = f;
            }
        }
    }
    let Some(share) = share(scene) else {
        return mask;
    };
    for g in 0..input.groups.len() as u32 {
        if !dynamic(g) || input.groups[g as usize].guides.is_some() {
            continue;
        }
        mask.iter_mut()
            .zip(&input.roots)
            .filter(|(_, r)| r.group == g)
            .for_each(|(m, _)| *m = false);
        let members: Vec<usize> = (0..input.roots.len())
            .filter(|&i| input.roots[i].group == g)
            .collect();
        let points: Vec<DVec3> = members.iter().map(|&i| input.roots[i].pos).collect();
        for k in farthest_points(&points, guide_count(members.len(), share)) {
            mask[members[k]] = true;
        }
    }
    mask
}

/// The 3 nearest guides of a pore (pore positions `guides`, same group) and their Shepard
/// weights (inverse distance squared, normalised): (index into `guides`, weight).
pub fn nearest_weights(p: DVec3, guides: &[DVec3]) -> Vec<(usize, f64)> {
    let mut best: Vec<(f64, usize)> = Vec::with_capacity(MAX_GUIDES + 1);
    for (j, g) in guides.iter().enumerate() {
        let d = p.distance_squared(*g);
        if best.len() < MAX_GUIDES || d < best[best.len() - 1].0 {
            let at = best.partition_point(|b| b.0 <= d);
            best.insert(at, (d, j));
            best.truncate(MAX_GUIDES);
        }
    }
    if let Some(&(d, j)) = best.first() {
        if d <= 1e-18 {
            return vec![(j, 1.0)];
        }
    }
    let total: f64 = best.iter().map(|b| 1.0 / b.0).sum();
    best.iter().map(|b| (b.1, 1.0 / b.0 / total)).collect()
}

impl FollowSetup {
    /// The followers of a scene whose dynamics has a guide share below 1, given the
    /// simulation set-up of its guides (`DynSetup::new`, which simulates `guide_mask`'s
    /// strands) and the groom's drawn lengths. `None` when every strand is simulated.
    pub fn new(
        scene: &Scene,
        input: &GroomInput,
        visible: &[f64],
        setup: &DynSetup,
    ) -> Option<FollowSetup> {
        if share(scene).is_none() && input.groups.iter().all(|g| g.guides.is_none()) {
            return None;
        }
        let mask = guide_mask(scene, input);
        let offsets = input.vertex_offsets();
        let mut followers = Vec::new();
        for g in 0..input.groups.len() as u32 {
            if !scene.groups()[g as usize].dynamic {
                continue;
            }
            let guides: Vec<_> = setup
                .strands
                .iter()
                .filter(|s| input.roots[s.strand as usize].group == g)
                .collect();
            if guides.is_empty() {
                continue;
            }
            let pores: Vec<DVec3> = guides.iter().map(|s| s.root_local).collect();
            for (i, r) in input.roots.iter().enumerate() {
                if r.group != g || mask[i] {
                    continue;
                }
                let k = input.groups[g as usize].segments;
                let refs = nearest_weights(r.pos, &pores)
                    .into_iter()
                    .map(|(j, w)| GuideRef {
                        first_vertex: guides[j].first_vertex,
                        segments: guides[j].segments,
                        weight: w,
                    })
                    .collect();
                followers.push(Follower {
                    strand: i as u32,
                    first_vertex: offsets[i],
                    segments: (visible[i].ceil() as u32).clamp(1, k),
                    seg_len: r.seg_len,
                    root_local: r.pos,
                    guides: refs,
                });
            }
        }
        if followers.is_empty() {
            return None;
        }
        Some(FollowSetup {
            followers,
            head: input.head.clone(),
            collision: scene.dynamics().as_ref().is_some_and(|d| d.collision),
        })
    }

    /// Follower nodes moved per frame (cost accounting).
    pub fn nodes(&self) -> u64 {
        self.followers.iter().map(|f| f.segments as u64).sum()
    }
}

/// The shortest-arc rotation taking unit `a` to unit `b`, applied to `v` (half a turn
/// about any axis across `a` when they are opposite).
pub fn rotate_arc(a: DVec3, b: DVec3, v: DVec3) -> DVec3 {
    let c = a.dot(b);
    if 1.0 + c < 1e-6 {
        let k = a.any_orthonormal_vector();
        return 2.0 * k.dot(v) * k - v;
    }
    let x = a.cross(b);
    c * v + x.cross(v) + x.dot(v) / (1.0 + c) * x
}

/// Node index of guide `g`'s segment i (from node - 1 to node), its last simulated segment
/// past its end.
fn guide_node(g: &GuideRef, i: u32) -> usize {
    (g.first_vertex + i.min(g.segments)) as usize
}

/// The f64 reference of `follow.wgsl`: rebuild every follower from its guides' current
/// nodes and the groom `rest` (the vertex array as set up), the head at pose `head`.
pub fn follow(setup: &FollowSetup, rest: &[DVec3], head: DMat4, nodes: &mut [DVec3]) {
    let head_inv = head.inverse();
    for f in &setup.followers {
        follow_strand(setup, f, rest, &head, &head_inv, nodes);
    }
}

/// One follower, root to tip.
pub fn follow_strand(
    setup: &FollowSetup,
    f: &Follower,
    rest: &[DVec3],
    head: &DMat4,
    head_inv: &DMat4,
    nodes: &mut [DVec3],
) {
    let d = f.seg_len;
    let base = f.first_vertex as usize;
    let root = head.transform_point3(f.root_local);
    nodes[base] = root;
    let mut prev_p = root;
    let mut prev_dir = head.transform_vector3(setup.head.normal(f.root_local));
    for i in 1..=f.segments {
        let v = base + i as usize;
        let own = head
            .transform_vector3(rest[v] - rest[v - 1])
            .normalize_or_zero();
        let mut blend = DVec3::ZERO;
        for g in &f.guides {
            let j = guide_node(g, i);
            let a = head
                .transform_vector3(rest[j] - rest[j - 1])
                .normalize_or_zero();
            let b = (nodes[j] - nodes[j - 1]).normalize_or_zero();
            blend += g.weight * rotate_arc(a, b, own);
        }
        let len = blend.length();
        let mut dir = if len > 1e-6 { blend / len } else { prev_dir };
        let mut pn = prev_p + dir * d;
        if setup.collision {
            let local = head_inv.transform_point3(pn);
            if setup.head.eval(local) < 0.0 {
                let lp = head_inv.transform_point3(prev_p);
                let la = head_inv.transform_vector3(prev_dir).normalize();
                let q = setup.head.push_out(lp, la, local, d);
                dir = (head.transform_point3(q) - prev_p).normalize();
                pn = prev_p + dir * d;
            }
        }
        nodes[v] = pn;
        prev_p = pn;
        prev_dir = dir;
    }
}
