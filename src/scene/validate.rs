//! Scene validation: every number is checked before it reaches a solver or the GPU, and a
//! failure names the field (`groups[1].rigidity`), the value and what is allowed. Adapter
//! limits (buffer and texture sizes) are checked later, where the adapter is known. This
//! file checks the shared blocks (`shared`) and holds the small checks every kind's block
//! uses (`systems/<kind>/block.rs`); `systems::validate` runs them all.

use super::*;
use crate::error::{KamiError, Result};

/// Most segments per strand (the GPU kernels keep per-strand state in loops over k).
pub const MAX_SEGMENTS: u32 = 256;
/// Most strands in one scene.
pub const MAX_STRANDS: u64 = 4_000_000;
/// Largest image side.
pub const MAX_SIZE: u32 = 16384;

pub fn bad(field: &str, value: impl std::fmt::Display, allowed: &str) -> KamiError {
    KamiError::Invalid {
        file: String::new(),
        field: field.to_string(),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

pub fn finite(field: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(bad(field, v, "must be a finite number"))
    }
}

/// `lo <= v <= hi`.
pub fn within(field: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    finite(field, v)?;
    if v < lo || v > hi {
        return Err(bad(field, v, &format!("must be in [{lo}, {hi}]")));
    }
    Ok(())
}

/// `0 < v <= hi`.
pub fn positive(field: &str, v: f64, hi: f64) -> Result<()> {
    finite(field, v)?;
    if v <= 0.0 || v > hi {
        return Err(bad(field, v, &format!("must be in (0, {hi}]")));
    }
    Ok(())
}

pub fn vec3(field: &str, v: [f64; 3], max_abs: f64) -> Result<()> {
    for (i, c) in v.iter().enumerate() {
        within(&format!("{field}[{i}]"), *c, -max_abs, max_abs)?;
    }
    Ok(())
}

pub fn nonzero(field: &str, v: [f64; 3]) -> Result<()> {
    vec3(field, v, 1e9)?;
    if v.iter().map(|c| c * c).sum::<f64>() < 1e-18 {
        return Err(bad(field, format!("{v:?}"), "must be a non-zero vector"));
    }
    Ok(())
}

pub fn color(field: &str, c: [f32; 3], hi: f64) -> Result<()> {
    for (i, v) in c.iter().enumerate() {
        within(&format!("{field}[{i}]"), *v as f64, 0.0, hi)?;
    }
    Ok(())
}

pub fn theta_range(field: &str, r: (f64, f64)) -> Result<()> {
    within(&format!("{field}.0"), r.0, 0.0, 180.0)?;
    within(&format!("{field}.1"), r.1, 0.0, 180.0)?;
    if r.0 >= r.1 {
        return Err(bad(
            field,
            format!("{r:?}"),
            "must be (low, high) with low < high, degrees",
        ));
    }
    Ok(())
}

pub fn phi_range(field: &str, r: (f64, f64)) -> Result<()> {
    within(&format!("{field}.0"), r.0, -720.0, 720.0)?;
    within(&format!("{field}.1"), r.1, -720.0, 720.0)?;
    if r.0 >= r.1 || r.1 - r.0 > 360.0 {
        return Err(bad(
            field,
            format!("{r:?}"),
            "must be (low, high) with low < high and high - low <= 360, degrees",
        ));
    }
    Ok(())
}

/// The largest coordinate or length a scene may name.
pub const BIG: f64 = 1e6;

/// The head ellipsoid's centre and radii: what the kinds' builders need of a head (they run
/// this same check on a head built in code, not one of their own).
pub fn head_shape(head: &Head) -> Result<()> {
    vec3("head.center", head.center, BIG)?;
    for (i, r) in head.radii.iter().enumerate() {
        positive(&format!("head.radii[{i}]"), *r, BIG)?;
    }
    Ok(())
}

/// Check the blocks every scene shares: the head (and its mesh), the forces, the camera,
/// the light and the render settings.
pub fn shared(
    head: &Head,
    forces: &ForcesDesc,
    camera: &CameraDesc,
    light: &Light,
    render: &RenderSettings,
) -> Result<()> {
    head_shape(head)?;
    color("head.color", head.color, 1.0)?;
    if let Some(m) = &head.mesh {
        validate_head_mesh(m)?;
    }
    validate_forces(forces)?;
    let c = camera;
    vec3("camera.eye", c.eye, BIG)?;
    vec3("camera.target", c.target, BIG)?;
    nonzero("camera.up", c.up)?;
    let view = [
        c.target[0] - c.eye[0],
        c.target[1] - c.eye[1],
        c.target[2] - c.eye[2],
    ];
    let vl = view.iter().map(|v| v * v).sum::<f64>().sqrt();
    if vl < 1e-9 {
        return Err(bad(
            "camera.target",
            format!("{:?}", c.target),
            "must differ from camera.eye",
        ));
    }
    let ul = c.up.iter().map(|v| v * v).sum::<f64>().sqrt();
    let cross = [
        view[1] * c.up[2] - view[2] * c.up[1],
        view[2] * c.up[0] - view[0] * c.up[2],
        view[0] * c.up[1] - view[1] * c.up[0],
    ];
    if cross.iter().map(|v| v * v).sum::<f64>().sqrt() < 1e-6 * vl * ul {
        return Err(bad(
            "camera.up",
            format!("{:?}", c.up),
            "must not be parallel to the view direction",
        ));
    }
    within("camera.fov_y", c.fov_y, 1.0, 170.0)?;

    nonzero("light.direction", light.direction)?;
    within("light.intensity", light.intensity, 0.0, 100.0)?;
    within("light.ambient", light.ambient, 0.0, 100.0)?;
    color("light.color", light.color, 10.0)?;

    let r = render;
    for (name, v) in [("render.size.0", r.size.0), ("render.size.1", r.size.1)] {
        if v == 0 || v > MAX_SIZE {
            return Err(bad(name, v, &format!("must be in [1, {MAX_SIZE}] pixels")));
        }
    }
    color("render.background", r.background, 1.0)?;
    if r.msaa != 1 && r.msaa != 4 {
        return Err(bad("render.msaa", r.msaa, "must be 1 or 4 samples"));
    }
    if !(1..=4).contains(&r.supersample) {
        return Err(bad(
            "render.supersample",
            r.supersample,
            "must be in [1, 4]",
        ));
    }
    within("render.min_width", r.min_width, 0.25, 8.0)?;
    within("render.lod_tolerance_px", r.lod_tolerance_px, 0.0, 16.0)?;
    within("render.shadows.absorption", r.shadows.absorption, 0.0, 10.0)?;
    if let Some(k) = r.shadows.layered_offset {
        within("render.shadows.layered_offset", k, 0.0, 8.0)?;
    }
    Ok(())
}

/// The world's forces (`forces`): finite values, keys in frame order, the EFF block (its
/// file and the head capture's are read and checked when the scene loads).
fn validate_forces(f: &ForcesDesc) -> Result<()> {
    vec3("forces.gravity", f.gravity, 1e9)?;
    for (i, k) in f.wind.iter().enumerate() {
        within(&format!("forces.wind[{i}].frame"), k.frame, -1e9, 1e9)?;
        vec3(&format!("forces.wind[{i}].force"), k.force, 1e9)?;
        if i > 0 && k.frame <= f.wind[i - 1].frame {
            return Err(bad(
                &format!("forces.wind[{i}].frame"),
                k.frame,
                "keys must be in increasing frame order",
            ));
        }
    }
    for (i, k) in f.head_motion.iter().enumerate() {
        within(
            &format!("forces.head_motion[{i}].frame"),
            k.frame,
            -1e9,
            1e9,
        )?;
        vec3(&format!("forces.head_motion[{i}].rotate"), k.rotate, 1e5)?;
        vec3(
            &format!("forces.head_motion[{i}].translate"),
            k.translate,
            BIG,
        )?;
        if i > 0 && k.frame <= f.head_motion[i - 1].frame {
            return Err(bad(
                &format!("forces.head_motion[{i}].frame"),
                k.frame,
                "keys must be in increasing frame order",
            ));
        }
    }
    if let Some(e) = &f.eff {
        e.validate()?;
    }
    Ok(())
}

/// SDF resolutions a mesh head may ask for (cells on the longest axis): below 8 the head is
/// a blob, above 256 the build takes minutes and the field tens of MB.
pub const SDF_RESOLUTION: (u32, u32) = (8, 256);

/// Most scalp regions.
const MAX_SCALP_REGIONS: usize = 64;

/// Where a mesh comes from (`head.mesh.source`, `fur.mesh`): a file name that is not empty,
/// a positive glTF frame rate (`<field>.fps`), a bare CGAL demo file name (`example` shows
/// one).
pub fn mesh_source(field: &str, s: &MeshSource, example: &str) -> Result<()> {
    match s {
        MeshSource::File(p) if p.trim().is_empty() => {
            Err(bad(field, "\"\"", "must name an .obj, .off or .ply file"))
        }
        MeshSource::Gltf { file, .. } if file.trim().is_empty() => {
            Err(bad(field, "\"\"", "must name a .gltf or .glb file"))
        }
        MeshSource::Gltf { fps, .. } => positive(&format!("{field}.fps"), *fps, 1e4),
        MeshSource::CgalDemo(n)
            if n.is_empty() || n.contains(['/', '\\']) || n.starts_with('.') =>
        {
            Err(bad(
                field,
                format!("CgalDemo({n:?})"),
                &format!("must be a file name in the CGAL demo meshes, e.g. \"{example}\""),
            ))
        }
        _ => Ok(()),
    }
}

fn validate_head_mesh(m: &HeadMesh) -> Result<()> {
    mesh_source("head.mesh.source", &m.source, "head.off")?;
    positive("head.mesh.scale", m.scale, BIG)?;
    vec3("head.mesh.rotate", m.rotate, 3600.0)?;
    vec3("head.mesh.translate", m.translate, BIG)?;
    let (lo, hi) = SDF_RESOLUTION;
    if m.resolution < lo || m.resolution > hi {
        return Err(bad(
            "head.mesh.resolution",
            m.resolution,
            &format!("must be in [{lo}, {hi}] (SDF cells on the longest axis)"),
        ));
    }
    if m.scalp.len() > MAX_SCALP_REGIONS {
        return Err(bad(
            "head.mesh.scalp",
            m.scalp.len(),
            &format!("at most {MAX_SCALP_REGIONS} regions"),
        ));
    }
    for (i, r) in m.scalp.iter().enumerate() {
        let f = format!("head.mesh.scalp[{i}]");
        match r {
            ScalpRegion::Polar { theta, phi } => {
                within(&format!("{f}.theta.0"), theta.0, 0.0, 180.0)?;
                within(&format!("{f}.theta.1"), theta.1, 0.0, 180.0)?;
                if theta.0 > theta.1 {
                    return Err(bad(
                        &format!("{f}.theta"),
                        format!("{theta:?}"),
                        "must be increasing",
                    ));
                }
                within(&format!("{f}.phi.0"), phi.0, -360.0, 360.0)?;
                within(&format!("{f}.phi.1"), phi.1, -360.0, 720.0)?;
                if phi.0 > phi.1 {
                    return Err(bad(
                        &format!("{f}.phi"),
                        format!("{phi:?}"),
                        "must be increasing",
                    ));
                }
            }
            ScalpRegion::Sphere { center, radius } => {
                vec3(&format!("{f}.center"), *center, BIG)?;
                positive(&format!("{f}.radius"), *radius, BIG)?;
            }
            ScalpRegion::HalfSpace { normal, offset } => {
                vec3(&format!("{f}.normal"), *normal, BIG)?;
                if normal.iter().all(|c| *c == 0.0) {
                    return Err(bad(&format!("{f}.normal"), "[0, 0, 0]", "must not be zero"));
                }
                within(&format!("{f}.offset"), *offset, -BIG, BIG)?;
            }
        }
    }
    Ok(())
}
