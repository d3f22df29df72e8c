//! Grooming: rest shapes of hair, computed once per scene. `prepare` turns a scene into a
//! deterministic table of roots (pores, initial directions, segment lengths, per-strand
//! ambient) and resolved group parameters; the cantilever solver bends them (on the GPU in
//! `cantilever_gpu::CantileverPass`, with `cantilever::bend_all` as the f64 reference).

use crate::error::{KamiError, Result};
use crate::gpu::gpu_data::GpuStrand;
use crate::gpu::strands::{DrawRange, StrandBuffers};
use crate::gpu::Gpu;
use crate::rng::hash_unit;
use crate::rng::Rng;
use crate::scene::hull::{HeadHull, HeadMeshData};
use crate::scene::{head::phi_in_range, Ellipsoid};
use crate::systems::anjyo::block::{Bending, CutRule, Direction, Load};
use crate::systems::anjyo::gpu_data::GpuLook;
use crate::systems::anjyo::imported::NodeLook;
use crate::systems::scene::Scene;
use glam::DVec3;

/// One hair's root, as drawn from the scene's seed.
#[derive(Clone, Debug, PartialEq)]
pub struct StrandRoot {
    pub pos: DVec3,
    /// Unloaded direction at the pore (unit).
    pub dir: DVec3,
    /// Segment length d.
    pub seg_len: f64,
    pub group: u32,
    /// Ambient coefficient k_a of this strand (Anjyo 4.1: normally distributed per strand).
    pub ka: f64,
    /// Bit i set: the group's cut i applies to this pore.
    pub cut_mask: u32,
}

/// A load resolved to world vectors: a field and the half-spaces it is limited to.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedLoad {
    pub field: LoadField,
    /// `(unit normal n, offset o)`: the load acts where `dot(n, p) >= o` for all of them.
    pub planes: Vec<(DVec3, f64)>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LoadField {
    Uniform(DVec3),
    Toward { point: DVec3, strength: f64 },
}

impl ResolvedLoad {
    /// Force per unit length on a segment whose rest (straight, unloaded) midpoint is `rest`
    /// and whose current midpoint is `at`: the regions select by the rest position, the field
    /// is evaluated where the segment is.
    pub fn at(&self, rest: DVec3, at: DVec3) -> DVec3 {
        if self.planes.iter().any(|(n, o)| n.dot(rest) < *o) {
            return DVec3::ZERO;
        }
        match self.field {
            LoadField::Uniform(f) => f,
            LoadField::Toward { point, strength } => (point - at).normalize_or_zero() * strength,
        }
    }
}

/// Bending mode with its numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BendMode {
    Paper,
    Converged { max_iterations: u32, tolerance: f64 },
}

impl From<&Bending> for BendMode {
    fn from(b: &Bending) -> Self {
        match b {
            Bending::Paper => BendMode::Paper,
            Bending::Converged {
                max_iterations,
                tolerance,
            } => BendMode::Converged {
                max_iterations: *max_iterations,
                tolerance: *tolerance,
            },
        }
    }
}

/// Per-group parameters the solver needs.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupParams {
    pub segments: u32,
    pub rigidity: f64,
    pub mode: BendMode,
    /// Gravity plus the group's combing loads.
    pub loads: Vec<ResolvedLoad>,
    pub cuts: Vec<CutRule>,
    /// Index of the group's first strand; its strands are contiguous.
    pub first_strand: u32,
    pub strand_count: u32,
    /// Rest nodes read from a strand file (`segments + 1` per strand, in order): such a
    /// group is not bent, its nodes are these (`super::imported`).
    pub shapes: Option<std::sync::Arc<Vec<DVec3>>>,
    /// The file's own look per node, when it has widths, colours or opacities.
    pub looks: Option<std::sync::Arc<Vec<NodeLook>>>,
    /// Per strand of the group: a guide the file flags (Unreal's `groom_guide`): the
    /// simulated strands, the others follow them (`follow::guide_mask`).
    pub guides: Option<Vec<bool>>,
}

impl GroupParams {
    /// Total load per unit length on a segment (see `ResolvedLoad::at`).
    pub fn load_at(&self, rest: DVec3, at: DVec3) -> DVec3 {
        self.loads.iter().map(|l| l.at(rest, at)).sum()
    }
}

/// Everything the cantilever solver reads.
#[derive(Clone, Debug)]
pub struct GroomInput {
    pub head: HeadHull,
    pub roots: Vec<StrandRoot>,
    pub groups: Vec<GroupParams>,
}

impl GroomInput {
    /// Index of each strand's first node in the shared vertex array (one per strand, plus
    /// the total at the end).
    pub fn vertex_offsets(&self) -> Vec<u32> {
        let mut off = Vec::with_capacity(self.roots.len() + 1);
        let mut acc = 0u32;
        for r in &self.roots {
            off.push(acc);
            acc += self.groups[r.group as usize].segments + 1;
        }
        off.push(acc);
        off
    }

    /// The strand buffers for this groom: one record per strand (offset, segments, group,
    /// per-strand look), one draw range per group; the nodes are written by the groom kernel.
    pub fn strand_buffers(&self, gpu: &Gpu) -> Result<StrandBuffers> {
        let offsets = self.vertex_offsets();
        let records: Vec<GpuStrand> = self
            .roots
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let k = self.groups[r.group as usize].segments;
                GpuStrand {
                    first_vertex: offsets[i],
                    segments: k,
                    group: r.group,
                    flags: 0,
                    visible: k as f32,
                    ka: r.ka as f32,
                    seg_len: r.seg_len as f32,
                    rand: hash_unit(i as u32),
                }
            })
            .collect();
        let ranges = self
            .groups
            .iter()
            .map(|g| DrawRange {
                first_strand: g.first_strand,
                strand_count: g.strand_count,
                nodes_per_strand: g.segments + 1,
            })
            .collect();
        StrandBuffers::new(gpu, "hair", &records, ranges)
    }

    /// Each node's own look (`GpuLook`, in vertex order) when a group has one; `None` when
    /// no group does, so a scene without such files binds no per-node buffer of size.
    pub fn looks(&self) -> Option<Vec<GpuLook>> {
        Some(self.node_looks()?.iter().map(NodeLook::gpu).collect())
    }

    /// The same at full precision, for export.
    pub fn node_looks(&self) -> Option<Vec<NodeLook>> {
        self.groups.iter().find(|g| g.looks.is_some())?;
        let offsets = self.vertex_offsets();
        // Groups without looks keep zeros: their materials never read them.
        let mut out = vec![NodeLook::default(); *offsets.last()? as usize];
        for g in &self.groups {
            if let Some(l) = &g.looks {
                let at = offsets[g.first_strand as usize] as usize;
                let n = l.len().min(out.len() - at);
                out[at..at + n].copy_from_slice(&l[..n]);
            }
        }
        Some(out)
    }

    pub fn total_vertices(&self) -> u64 {
        self.roots
            .iter()
            .map(|r| self.groups[r.group as usize].segments as u64 + 1)
            .sum()
    }
}

/// Draw the roots of every group from the scene's seed. Pores are uniform by area on the
/// hull's polar patch (uniform on the sphere, then rejection by the ellipsoid's area
/// element), so density does not bunch at the poles.
pub fn prepare(scene: &Scene) -> Result<GroomInput> {
    let head = scene.head_ellipsoid();
    let head_mesh = crate::scene::hull::head_mesh(&scene.head)?;
    let gravity = ResolvedLoad {
        field: LoadField::Uniform(DVec3::from(*scene.groom_load())),
        planes: vec![],
    };
    let mut roots = Vec::new();
    let mut groups = Vec::new();
    for (gi, g) in scene.groups().iter().enumerate() {
        if g.file.is_some() {
            let first = roots.len() as u32;
            let (r, nodes, looks) = super::imported::group_roots(scene.seed, gi, g)?;
            let count = r.len() as u32;
            roots.extend(r);
            groups.push(GroupParams {
                segments: g.segments,
                // Not bent: the cheapest straight beam stands in until the nodes are written.
                rigidity: 1.0,
                mode: BendMode::Paper,
                loads: vec![],
                cuts: vec![],
                first_strand: first,
                strand_count: count,
                shapes: Some(std::sync::Arc::new(nodes)),
                looks: looks.map(std::sync::Arc::new),
                // The strands `group_roots` took (every guide, `count` in all).
                guides: g.file.as_ref().and_then(|f| {
                    let groom = f.groom.as_ref()?;
                    let v = groom.guides.as_ref()?;
                    let picks = super::block::select_strands(groom, None, g.count as usize).ok()?;
                    Some(picks.into_iter().map(|i| v[i]).collect())
                }),
            });
            continue;
        }
        let hull = g
            .roots
            .on
            .as_ref()
            .map(|e| Ellipsoid::new(e.center, e.radii))
            .unwrap_or(head);
        let mut rng = Rng::new(scene.seed, gi as u64 + 1);
        let first = roots.len() as u32;
        let (t0, t1) = (g.roots.theta.0.to_radians(), g.roots.theta.1.to_radians());
        let (p0, p1) = (g.roots.phi.0.to_radians(), g.roots.phi.1.to_radians());
        let amax = hull.area_factor_max();
        // Pores on a mesh head's scalp (groups with their own ellipsoid keep it).
        let on_mesh = head_mesh.as_ref().filter(|_| g.roots.on.is_none());
        for _ in 0..g.count {
            let (pos, n, td, pd) = if let Some(m) = on_mesh {
                mesh_pore(m, scene, gi, &mut rng)?
            } else {
                let mut tries = 0u32;
                let (theta, phi) = loop {
                    let ct = rng.range(t1.cos(), t0.cos());
                    let phi = rng.range(p0, p1);
                    let theta = ct.clamp(-1.0, 1.0).acos();
                    let accept = rng.uniform() * amax <= hull.area_factor(theta, phi);
                    let below = g
                        .roots
                        .hairline_theta(phi.to_degrees())
                        .is_some_and(|t| theta.to_degrees() > t);
                    if accept && !below {
                        break (theta, phi);
                    }
                    tries += 1;
                    if tries > 1_000_000 {
                        return Err(KamiError::Invalid {
                            file: String::new(),
                            field: format!("groups[{gi}].roots"),
                            value: format!("{:?}", g.roots.theta),
                            allowed:
                                "the polar range and hairline leave (almost) no area for pores"
                                    .into(),
                        });
                    }
                };
                let pos = hull.point(theta, phi);
                (pos, hull.normal(pos), theta.to_degrees(), phi.to_degrees())
            };
            let dir = match &g.direction {
                Direction::Normal => n,
                Direction::Blend { dir, weight } => {
                    let b = (1.0 - weight) * n + weight * DVec3::from(*dir).normalize();
                    b.normalize_or(n)
                }
            };
            let dir = if g.direction_jitter > 0.0 {
                // Uniform in a cone of half-angle `direction_jitter` about `dir`.
                let cmax = g.direction_jitter.to_radians().cos();
                let ct = rng.range(cmax, 1.0);
                let st = (1.0 - ct * ct).max(0.0).sqrt();
                let a = rng.range(0.0, std::f64::consts::TAU);
                let u = dir.any_orthonormal_vector();
                let v = dir.cross(u);
                let tilted = ct * dir + st * (a.cos() * u + a.sin() * v);
                // Never into the hull.
                if tilted.dot(n) > 0.05 {
                    tilted
                } else {
                    dir
                }
            } else {
                dir
            };
            let len = g.length * (1.0 + g.length_jitter * (2.0 * rng.uniform() - 1.0));
            let ka = (g.material.ka + g.material.ka_spread * rng.normal()).max(0.0);
            let mut cut_mask = 0u32;
            for (ci, c) in g.cuts.iter().enumerate() {
                let in_theta = c.theta.is_none_or(|(a, b)| td >= a && td <= b);
                let in_phi = c.phi.is_none_or(|r| phi_in_range(pd, r));
                if in_theta && in_phi {
                    cut_mask |= 1 << ci;
                }
            }
            roots.push(StrandRoot {
                pos,
                dir,
                seg_len: len / g.segments as f64,
                group: gi as u32,
                ka,
                cut_mask,
            });
        }
        let mut loads = vec![gravity.clone()];
        loads.extend(g.loads.iter().map(resolve_load));
        groups.push(GroupParams {
            segments: g.segments,
            rigidity: g.rigidity,
            mode: BendMode::from(&g.bending),
            loads,
            cuts: g.cuts.iter().map(|c| c.rule.clone()).collect(),
            first_strand: first,
            strand_count: g.count,
            shapes: None,
            looks: None,
            guides: None,
        });
    }
    Ok(GroomInput {
        head: HeadHull::of(&scene.head, head_mesh.as_deref()),
        roots,
        groups,
    })
}

/// One pore on a mesh head's scalp: area-uniform over the scalp triangles, kept where the
/// group's polar range and hairline (about `head.center`) allow, then moved onto the SDF's
/// zero level set (two Newton steps) so the root sits on the hull that hair collides with;
/// a pore the field cannot follow within a quarter cell is drawn again.
/// Returns (position, unit normal, zenith, azimuth in degrees).
fn mesh_pore(
    m: &HeadMeshData,
    scene: &Scene,
    gi: usize,
    rng: &mut Rng,
) -> Result<(DVec3, DVec3, f64, f64)> {
    let g = &scene.groups()[gi];
    let center = DVec3::from(scene.head.center);
    for _ in 0..1_000_000u32 {
        let (ut, u, v) = (rng.uniform(), rng.uniform(), rng.uniform());
        let (mut pos, n) = m.sample(ut, u, v);
        let (td, pd) = crate::scene::hull::polar_deg(pos, center);
        let in_theta = td >= g.roots.theta.0 && td <= g.roots.theta.1;
        let below = g.roots.hairline_theta(pd).is_some_and(|t| td > t);
        if in_theta && phi_in_range(pd, g.roots.phi) && !below {
            let mesh_pos = pos;
            for _ in 0..2 {
                let gr = m.sdf.gradient(pos);
                let l2 = gr.length_squared();
                if l2 > 1e-12 {
                    pos -= m.sdf.sample(pos) * gr / l2;
                }
            }
            // Where the field cannot follow the mesh (features thinner than a cell: ear
            // rims) no hair grows.
            if (pos - mesh_pos).length() <= 0.25 * m.sdf.cell && m.sdf.sample(pos).abs() < 1e-4 {
                return Ok((pos, n, td, pd));
            }
        }
    }
    Err(KamiError::Invalid {
        file: String::new(),
        field: format!("groups[{gi}].roots"),
        value: format!("{:?}", g.roots.theta),
        allowed: "the polar range and hairline leave (almost) no scalp of the head mesh".into(),
    })
}

fn resolve_load(l: &Load) -> ResolvedLoad {
    let planes = l
        .region()
        .iter()
        .map(|r| {
            let (n, o) = r.plane();
            (DVec3::from(n), o)
        })
        .collect();
    let field = match l {
        Load::Uniform { force, .. } => LoadField::Uniform(DVec3::from(*force)),
        Load::Toward {
            point, strength, ..
        } => LoadField::Toward {
            point: DVec3::from(*point),
            strength: *strength,
        },
    };
    ResolvedLoad { field, planes }
}
