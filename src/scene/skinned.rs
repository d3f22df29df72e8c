//! glTF 2.0 skinned meshes for fur (read with the `gltf` crate): the first node that has
//! both a mesh and a skin gives the skin surface (its triangle primitives merged: POSITION,
//! NORMAL when present, indices, JOINTS_0, WEIGHTS_0), the skin's joints and inverse bind
//! matrices, the whole node hierarchy (rest translation, rotation, scale) and one
//! animation's translation/rotation/scale channels (LINEAR, STEP and CUBICSPLINE).
//!
//! Linear blend skinning: a vertex p with joints j and weights w (normalised to sum 1) goes
//! to `sum_i w_i M_{j_i} p` with `M_j = G(joint node j) * IBM_j` (G: the node's global
//! transform at the animation time); its normal to `normalize(sum_i w_i L_{j_i} n)` (L: the
//! linear part, exact for rotations and uniform scales). As the spec says, the skinned mesh
//! node's own transform is ignored. Morph targets, materials, textures, cameras, other
//! skins and meshes, JOINTS_1/WEIGHTS_1 are ignored (docs/fur_skinned.md).
//!
//! Everything that cannot be used (missing accessors, attribute counts that differ, joint
//! indices beyond the skin, weights that are negative, not finite or all zero, a node cycle)
//! is refused with an error naming the file.

use crate::error::{KamiError, Result};
use crate::scene::mesh::Mesh;
use glam::{DMat4, DQuat, DVec3, DVec4};
use std::path::Path;

/// The most joints a skin may have (the GPU's joint uniform holds this many matrices).
/// Also `MAX_JOINTS` in `shaders/fur/generate.wgsl` and `shaders/fur/skin.wgsl` (array sizes,
/// so not overridable; `tests/it/gpu_twins.rs` checks them).
pub const MAX_JOINTS: usize = 64;

/// A node of the hierarchy: its parent and rest transform.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub parent: Option<usize>,
    pub translation: DVec3,
    pub rotation: DQuat,
    pub scale: DVec3,
}

/// How a channel interpolates between keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Linear,
    Step,
    /// Hermite with in/out tangents (three outputs per key).
    CubicSpline,
}

/// What a channel animates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

/// One animation channel: key times (seconds) and values (xyz or quaternion xyzw; for
/// CUBICSPLINE three per key: in-tangent, value, out-tangent).
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub node: usize,
    pub property: Property,
    pub interpolation: Interpolation,
    pub times: Vec<f64>,
    pub values: Vec<DVec4>,
}

/// One animation: its channels and duration (the last key time).
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    pub name: String,
    pub duration: f64,
    pub channels: Vec<Channel>,
}

/// The skin of a mesh: per vertex four joints and weights, the joints' nodes and inverse bind
/// matrices, the hierarchy and the animation, plus `fit`, a similarity applied after
/// skinning (the scene's `size` rescales the mesh: the skin follows by conjugation).
#[derive(Clone, Debug, PartialEq)]
pub struct Skin {
    pub joints: Vec<[u32; 4]>,
    pub weights: Vec<[f64; 4]>,
    pub joint_nodes: Vec<usize>,
    pub inverse_bind: Vec<DMat4>,
    pub nodes: Vec<Node>,
    pub animation: Option<Animation>,
    /// Seconds per scene frame are `1 / fps`.
    pub fps: f64,
    pub fit: DMat4,
}

/// A skinned mesh read from a glTF file.
#[derive(Clone, Debug)]
pub struct SkinnedMesh {
    pub mesh: Mesh,
    pub skin: Skin,
}

/// A unit quaternion from xyzw (identity for a zero or non-finite one).
fn unit_quat(v: DVec4) -> DQuat {
    v.try_normalize()
        .map(DQuat::from_vec4)
        .unwrap_or(DQuat::IDENTITY)
}

fn err(path: &str, message: impl Into<String>) -> KamiError {
    KamiError::Mesh {
        path: path.to_string(),
        line: None,
        message: message.into(),
    }
}

impl Skin {
    /// Seconds into the animation at scene frame `frame` (looping over its duration).
    pub fn seconds(&self, frame: f64) -> f64 {
        let t = frame / self.fps;
        match &self.animation {
            Some(a) if a.duration > 0.0 => t.rem_euclid(a.duration),
            _ => 0.0,
        }
    }

    /// The local transforms of every node at `seconds` (rest, then the animation's channels).
    pub fn local_transforms(&self, seconds: f64) -> Vec<(DVec3, DQuat, DVec3)> {
        let mut trs: Vec<_> = self
            .nodes
            .iter()
            .map(|n| (n.translation, n.rotation, n.scale))
            .collect();
        if let Some(a) = &self.animation {
            for c in &a.channels {
                let v = c.sample(seconds);
                let slot = &mut trs[c.node];
                match c.property {
                    Property::Translation => slot.0 = v.truncate(),
                    Property::Rotation => slot.1 = unit_quat(v),
                    Property::Scale => slot.2 = v.truncate(),
                }
            }
        }
        trs
    }

    /// The skinning matrix of every joint at scene frame `frame`:
    /// `fit * G(joint node) * IBM * fit^-1`.
    pub fn joint_matrices(&self, frame: f64) -> Vec<DMat4> {
        let trs = self.local_transforms(self.seconds(frame));
        let mut global: Vec<Option<DMat4>> = vec![None; self.nodes.len()];
        fn get(
            i: usize,
            nodes: &[Node],
            trs: &[(DVec3, DQuat, DVec3)],
            g: &mut [Option<DMat4>],
        ) -> DMat4 {
            if let Some(m) = g[i] {
                return m;
            }
            let (t, r, s) = trs[i];
            let local = DMat4::from_scale_rotation_translation(s, r, t);
            // Loading refused cycles, so this recursion ends.
            let m = match nodes[i].parent {
                Some(p) => get(p, nodes, trs, g) * local,
                None => local,
            };
            g[i] = Some(m);
            m
        }
        let fit_inv = self.fit.inverse();
        self.joint_nodes
            .iter()
            .zip(&self.inverse_bind)
            .map(|(&j, ibm)| self.fit * get(j, &self.nodes, &trs, &mut global) * *ibm * fit_inv)
            .collect()
    }

    /// Vertex `v` (position `p`, normal `n`) under the joint matrices `mats`.
    pub fn skin_vertex(&self, mats: &[DMat4], v: usize, p: DVec3, n: DVec3) -> (DVec3, DVec3) {
        let mut m = DMat4::ZERO;
        for (j, w) in self.joints[v].iter().zip(&self.weights[v]) {
            if *w != 0.0 {
                m += mats[*j as usize] * *w;
            }
        }
        let q = m.transform_point3(p);
        let nn = m.transform_vector3(n);
        (q, nn.try_normalize().unwrap_or(n))
    }
}

impl Channel {
    /// The channel's value at `t` seconds (held before the first and after the last key).
    pub fn sample(&self, t: f64) -> DVec4 {
        let n = self.times.len();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| {
            if cubic {
                self.values[3 * k + 1]
            } else {
                self.values[k]
            }
        };
        if n == 1 || t <= self.times[0] {
            return value(0);
        }
        if t >= self.times[n - 1] {
            return value(n - 1);
        }
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let dt = t1 - t0;
        let s = if dt > 0.0 { (t - t0) / dt } else { 0.0 };
        let (a, b) = (value(k), value(k + 1));
        match self.interpolation {
            Interpolation::Step => a,
            Interpolation::Linear if self.property == Property::Rotation => {
                let qa = DQuat::from_vec4(a).normalize();
                let qb = DQuat::from_vec4(b).normalize();
                DVec4::from(qa.slerp(qb, s))
            }
            Interpolation::Linear => a.lerp(b, s),
            Interpolation::CubicSpline => {
                let out_a = self.values[3 * k + 2];
                let in_b = self.values[3 * (k + 1)];
                let (s2, s3) = (s * s, s * s * s);
                a * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + out_a * (dt * (s3 - 2.0 * s2 + s))
                    + b * (-2.0 * s3 + 3.0 * s2)
                    + in_b * (dt * (s3 - s2))
            }
        }
    }
}

/// Read the first skinned mesh of `path` and `animation` (by name; None: the first one, or
/// the rest pose when the file has none); `fps` converts scene frames to seconds.
pub fn load(path: &Path, animation: Option<&str>, fps: f64) -> Result<SkinnedMesh> {
    let name = path.display().to_string();
    if !(fps.is_finite() && fps > 0.0) {
        return Err(err(&name, format!("fps must be positive, got {fps}")));
    }
    let (doc, buffers) = open(path, &name)?;
    let doc = &doc;
    let node = doc
        .nodes()
        .find(|n| n.mesh().is_some() && n.skin().is_some())
        .ok_or_else(|| err(&name, "no node has both a mesh and a skin"))?;
    let (gmesh, gskin) = (node.mesh().unwrap_or_else(|| unreachable!()), node.skin());
    let gskin = gskin.unwrap_or_else(|| unreachable!());
    let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(|d| &d.0[..]);
    let (joint_nodes, inverse_bind) = read_skin(&name, &gskin, &buffers)?;

    // The surface: every triangle primitive of the mesh, merged.
    let mut s = Surface::default();
    for (pi, prim) in gmesh.primitives().enumerate() {
        if prim.mode() != gltf::mesh::Mode::Triangles {
            log::warn!("{name}: primitive {pi} is not a triangle list: ignored");
            continue;
        }
        s.read_primitive(&name, pi, &prim, &buffers, joint_nodes.len())?;
    }
    let Surface {
        positions,
        normals,
        triangles,
        joints,
        weights,
        some_without_normals,
    } = s;
    let all_normals = !some_without_normals;
    let mesh = Mesh::new(positions, triangles, all_normals.then_some(normals), &name)?;
    let nodes = read_nodes(&name, doc)?;

    // The animation.
    let names: Vec<String> = doc
        .animations()
        .enumerate()
        .map(|(i, a)| a.name().map(str::to_string).unwrap_or(format!("#{i}")))
        .collect();
    let chosen = match animation {
        None => doc.animations().next(),
        Some(want) => Some(
            doc.animations()
                .zip(&names)
                .find(|(_, n)| n.as_str() == want)
                .map(|(a, _)| a)
                .ok_or_else(|| {
                    err(
                        &name,
                        format!("no animation named {want:?}; it has {names:?}"),
                    )
                })?,
        ),
    };
    let animation = match chosen {
        None => None,
        Some(a) => Some(read_animation(&name, &a, &names[a.index()], get)?),
    };
    Ok(SkinnedMesh {
        mesh,
        skin: Skin {
            joints,
            weights,
            joint_nodes,
            inverse_bind,
            nodes,
            animation,
            fps,
            fit: DMat4::IDENTITY,
        },
    })
}

/// The glTF document of `path` (validated) and its buffers.
fn open(path: &Path, name: &str) -> Result<(gltf::Document, Vec<gltf::buffer::Data>)> {
    let bad = |e: gltf::Error| err(name, format!("not usable glTF: {e}"));
    let bytes = std::fs::read(path).map_err(|e| err(name, format!("not usable glTF: {e}")))?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(bad)?;
    // gltf-json 1.4's validation indexes the POSITION accessor without a bounds check (a
    // panic on a bad index): check it first, then validate.
    let json = gltf.document.into_json();
    for (mi, m) in json.meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            for (sem, a) in &p.attributes {
                if a.value() >= json.accessors.len() {
                    return Err(err(
                        name,
                        format!(
                            "not usable glTF: mesh {mi} primitive {pi}: attribute {sem:?} names                              accessor {}, but there are {}",
                            a.value(),
                            json.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    let doc = gltf::Document::from_json(json).map_err(bad)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = gltf::import_buffers(&doc, Some(base), gltf.blob)
        .map_err(|e| err(name, format!("cannot read its buffers: {e}")))?;
    Ok((doc, buffers))
}

/// The skin: its joints' nodes (1 to `MAX_JOINTS`) and their inverse bind matrices (one
/// per joint, finite; identities when the skin has none).
fn read_skin(
    name: &str,
    gskin: &gltf::Skin<'_>,
    buffers: &[gltf::buffer::Data],
) -> Result<(Vec<usize>, Vec<DMat4>)> {
    let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(|d| &d.0[..]);
    let joint_nodes: Vec<usize> = gskin.joints().map(|j| j.index()).collect();
    if joint_nodes.is_empty() || joint_nodes.len() > MAX_JOINTS {
        return Err(err(
            name,
            format!(
                "the skin has {} joints: Kami skins with 1 to {MAX_JOINTS}",
                joint_nodes.len()
            ),
        ));
    }
    let inverse_bind: Vec<DMat4> = match gskin.reader(get).read_inverse_bind_matrices() {
        Some(it) => it
            .map(|m| DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from))))
            .collect(),
        None if gskin.inverse_bind_matrices().is_some() => {
            return Err(err(name, "the inverse bind matrices cannot be read"))
        }
        None => vec![DMat4::IDENTITY; joint_nodes.len()],
    };
    if inverse_bind.len() != joint_nodes.len() {
        return Err(err(
            name,
            format!(
                "{} inverse bind matrices for {} joints",
                inverse_bind.len(),
                joint_nodes.len()
            ),
        ));
    }
    if let Some(i) = inverse_bind.iter().position(|m| !m.is_finite()) {
        return Err(err(name, format!("inverse bind matrix {i} is not finite")));
    }
    Ok((joint_nodes, inverse_bind))
}

/// The mesh's triangle primitives merged, with each vertex's joints and normalised weights.
#[derive(Default)]
struct Surface {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    joints: Vec<[u32; 4]>,
    weights: Vec<[f64; 4]>,
    /// A primitive had no normals (then the mesh's are computed).
    some_without_normals: bool,
}

impl Surface {
    /// Appends triangle primitive `pi`: its positions, joints and weights (one each per
    /// vertex, the joints within the skin's `joints`, the weights finite, >= 0 and not all
    /// zero), normals where it has them, and its triangles.
    fn read_primitive(
        &mut self,
        name: &str,
        pi: usize,
        prim: &gltf::Primitive<'_>,
        buffers: &[gltf::buffer::Data],
        joints: usize,
    ) -> Result<()> {
        let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(|d| &d.0[..]);
        let missing = |what: &str| err(name, format!("primitive {pi} has no usable {what}"));
        let r = prim.reader(get);
        let base = self.positions.len() as u32;
        let p: Vec<DVec3> = r
            .read_positions()
            .ok_or_else(|| missing("POSITION"))?
            .map(|v| DVec3::from(v.map(f64::from)))
            .collect();
        let count = p.len();
        let j: Vec<[u16; 4]> = r
            .read_joints(0)
            .ok_or_else(|| missing("JOINTS_0"))?
            .into_u16()
            .collect();
        let w: Vec<[f32; 4]> = r
            .read_weights(0)
            .ok_or_else(|| missing("WEIGHTS_0"))?
            .into_f32()
            .collect();
        if j.len() != count || w.len() != count {
            return Err(err(
                name,
                format!(
                    "primitive {pi}: {count} positions but {} JOINTS_0 and {} WEIGHTS_0",
                    j.len(),
                    w.len()
                ),
            ));
        }
        match r.read_normals() {
            Some(n) => {
                let n: Vec<DVec3> = n.map(|v| DVec3::from(v.map(f64::from))).collect();
                if n.len() != count {
                    return Err(err(
                        name,
                        format!("primitive {pi}: {count} positions but {} normals", n.len()),
                    ));
                }
                self.normals.extend(n);
            }
            None => self.some_without_normals = true,
        }
        let idx: Vec<u32> = match r.read_indices() {
            Some(i) => i.into_u32().collect(),
            None if prim.indices().is_some() => return Err(missing("indices")),
            None => (0..count as u32).collect(),
        };
        if idx.len() % 3 != 0 {
            return Err(err(
                name,
                format!(
                    "primitive {pi}: {} indices is not a triangle list",
                    idx.len()
                ),
            ));
        }
        if let Some(bad) = idx.iter().find(|&&i| i as usize >= count) {
            return Err(err(
                name,
                format!("primitive {pi}: index {bad}, but there are {count} vertices"),
            ));
        }
        for (vi, (jv, wv)) in j.iter().zip(&w).enumerate() {
            let v = self.positions.len() + vi;
            if let Some(bad) = jv.iter().find(|&&x| x as usize >= joints) {
                return Err(err(
                    name,
                    format!("vertex {v} uses joint {bad}, but the skin has {joints} joints"),
                ));
            }
            if wv.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(err(
                    name,
                    format!("vertex {v} has weights {wv:?}: they must be finite and >= 0"),
                ));
            }
            let sum: f64 = wv.iter().map(|&x| x as f64).sum();
            if sum <= 0.0 {
                return Err(err(name, format!("vertex {v} has no joint weight")));
            }
            self.joints.push(jv.map(u32::from));
            self.weights.push(wv.map(|x| x as f64 / sum));
        }
        self.positions.extend(p);
        self.triangles.extend(
            idx.chunks(3)
                .map(|c| [c[0] + base, c[1] + base, c[2] + base]),
        );
        Ok(())
    }
}

/// The hierarchy, refusing cycles (a node with two parents is refused by the crate's
/// validation or counted here) and transforms that are not finite.
fn read_nodes(name: &str, doc: &gltf::Document) -> Result<Vec<Node>> {
    let count = doc.nodes().count();
    let mut nodes: Vec<Node> = doc
        .nodes()
        .map(|n| {
            let (t, r, s) = n.transform().decomposed();
            Node {
                parent: None,
                translation: DVec3::from(t.map(f64::from)),
                rotation: unit_quat(DVec4::from(r.map(f64::from))),
                scale: DVec3::from(s.map(f64::from)),
            }
        })
        .collect();
    for n in doc.nodes() {
        for c in n.children() {
            if nodes[c.index()].parent.is_some() {
                return Err(err(name, format!("node {} has two parents", c.index())));
            }
            nodes[c.index()].parent = Some(n.index());
        }
    }
    for (i, n) in nodes.iter().enumerate() {
        if !(n.translation.is_finite() && n.rotation.is_finite() && n.scale.is_finite()) {
            return Err(err(name, format!("node {i}'s transform is not finite")));
        }
        let (mut at, mut steps) = (i, 0);
        while let Some(p) = nodes[at].parent {
            at = p;
            steps += 1;
            if steps > count {
                return Err(err(name, format!("node {i} is in a cycle of parents")));
            }
        }
    }
    Ok(nodes)
}

fn read_animation<'a>(
    name: &str,
    a: &gltf::Animation<'a>,
    anim_name: &str,
    get: impl Clone + Fn(gltf::Buffer<'a>) -> Option<&'a [u8]>,
) -> Result<Animation> {
    let mut channels = Vec::new();
    for (ci, c) in a.channels().enumerate() {
        let bad = |what: String| {
            err(
                name,
                format!("animation {anim_name:?} channel {ci}: {what}"),
            )
        };
        let r = c.reader(get.clone());
        let times: Vec<f64> = r
            .read_inputs()
            .ok_or_else(|| bad("its key times cannot be read".into()))?
            .map(f64::from)
            .collect();
        use gltf::animation::util::ReadOutputs;
        let (property, values): (Property, Vec<DVec4>) = match r
            .read_outputs()
            .ok_or_else(|| bad("its values cannot be read".into()))?
        {
            ReadOutputs::Translations(it) => (
                Property::Translation,
                it.map(|v| DVec3::from(v.map(f64::from)).extend(0.0))
                    .collect(),
            ),
            ReadOutputs::Scales(it) => (
                Property::Scale,
                it.map(|v| DVec3::from(v.map(f64::from)).extend(0.0))
                    .collect(),
            ),
            ReadOutputs::Rotations(it) => (
                Property::Rotation,
                it.into_f32()
                    .map(|v| DVec4::from(v.map(f64::from)))
                    .collect(),
            ),
            ReadOutputs::MorphTargetWeights(_) => {
                log::warn!("{name}: channel {ci} animates morph weights: ignored");
                continue;
            }
        };
        let interpolation = match c.sampler().interpolation() {
            gltf::animation::Interpolation::Linear => Interpolation::Linear,
            gltf::animation::Interpolation::Step => Interpolation::Step,
            gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
        };
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        if times.is_empty() || values.len() != per_key * times.len() {
            return Err(bad(format!(
                "{} key times and {} values",
                times.len(),
                values.len()
            )));
        }
        if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
            return Err(bad("key times must be finite and increasing".into()));
        }
        if values.iter().any(|v| !v.is_finite()) {
            return Err(bad("a value is not finite".into()));
        }
        channels.push(Channel {
            node: c.target().node().index(),
            property,
            interpolation,
            times,
            values,
        });
    }
    let duration = channels
        .iter()
        .filter_map(|c| c.times.last().copied())
        .fold(0.0, f64::max);
    Ok(Animation {
        name: anim_name.to_string(),
        duration,
        channels,
    })
}
