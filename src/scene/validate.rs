//! Scene validation: every number is checked before it reaches a solver or the GPU, and a
//! failure names the field (`groups[1].rigidity`), the value and what is allowed. Adapter
//! limits (buffer and texture sizes) are checked later, where the adapter is known.

use super::*;
use crate::error::{KamiError, Result};

/// Most segments per strand (the GPU kernels keep per-strand state in loops over k).
pub const MAX_SEGMENTS: u32 = 256;
/// Most strands in one scene.
pub const MAX_STRANDS: u64 = 4_000_000;
/// Largest image side.
pub const MAX_SIZE: u32 = 16384;

fn bad(field: &str, value: impl std::fmt::Display, allowed: &str) -> KamiError {
    KamiError::Invalid {
        file: String::new(),
        field: field.to_string(),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

fn finite(field: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(bad(field, v, "must be a finite number"))
    }
}

/// `lo <= v <= hi`.
fn within(field: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    finite(field, v)?;
    if v < lo || v > hi {
        return Err(bad(field, v, &format!("must be in [{lo}, {hi}]")));
    }
    Ok(())
}

/// `0 < v <= hi`.
fn positive(field: &str, v: f64, hi: f64) -> Result<()> {
    finite(field, v)?;
    if v <= 0.0 || v > hi {
        return Err(bad(field, v, &format!("must be in (0, {hi}]")));
    }
    Ok(())
}

fn vec3(field: &str, v: [f64; 3], max_abs: f64) -> Result<()> {
    for (i, c) in v.iter().enumerate() {
        within(&format!("{field}[{i}]"), *c, -max_abs, max_abs)?;
    }
    Ok(())
}

fn nonzero(field: &str, v: [f64; 3]) -> Result<()> {
    vec3(field, v, 1e9)?;
    if v.iter().map(|c| c * c).sum::<f64>() < 1e-18 {
        return Err(bad(field, format!("{v:?}"), "must be a non-zero vector"));
    }
    Ok(())
}

fn color(field: &str, c: [f32; 3], hi: f64) -> Result<()> {
    for (i, v) in c.iter().enumerate() {
        within(&format!("{field}[{i}]"), *v as f64, 0.0, hi)?;
    }
    Ok(())
}

fn theta_range(field: &str, r: (f64, f64)) -> Result<()> {
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

fn phi_range(field: &str, r: (f64, f64)) -> Result<()> {
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

const BIG: f64 = 1e6;

/// Most fur regions: each vertex is tested against every region.
const MAX_FUR_REGIONS: usize = 64;

/// Check every field of a parsed scene.
pub fn validate(s: &Scene) -> Result<()> {
    vec3("head.center", s.head.center, BIG)?;
    for (i, r) in s.head.radii.iter().enumerate() {
        positive(&format!("head.radii[{i}]"), *r, BIG)?;
    }
    color("head.color", s.head.color, 1.0)?;
    if let Some(m) = &s.head.mesh {
        validate_head_mesh(m)?;
    }
    vec3("groom_load", s.groom_load, 1e9)?;
    validate_forces(&s.forces)?;

    if s.groups.is_empty() && s.fur.is_none() && s.wisps.is_none() && s.strips.is_none() {
        return Err(bad(
            "groups",
            "[]",
            "a scene needs at least one hair group, fur, wisps or strips",
        ));
    }
    if let Some(f) = &s.fur {
        validate_fur(f)?;
    }
    if let Some(w) = &s.wisps {
        validate_wisps(w)?;
        wisps_on_shared_forces(s, w)?;
    }
    if let Some(st) = &s.strips {
        validate_strips(st)?;
    }
    let (strands, _) = s.counts();
    if strands > MAX_STRANDS {
        return Err(bad(
            if s.fur.is_some() {
                "groups[..].count + fur.hairs"
            } else {
                "groups[..].count"
            },
            strands,
            &format!("the total must be at most {MAX_STRANDS} hairs"),
        ));
    }
    for (gi, g) in s.groups.iter().enumerate() {
        validate_group(&format!("groups[{gi}]"), g)?;
    }

    let c = &s.camera;
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

    nonzero("light.direction", s.light.direction)?;
    within("light.intensity", s.light.intensity, 0.0, 100.0)?;
    within("light.ambient", s.light.ambient, 0.0, 100.0)?;
    color("light.color", s.light.color, 10.0)?;

    let r = &s.render;
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
    if let Some(d) = &s.dynamics {
        validate_dynamics(d)?;
    }
    Ok(())
}

/// The world's forces (`forces`): finite values, keys in frame order, the EFF block (its
/// file and the head capture's are read and checked when the scene loads).
fn validate_forces(f: &crate::scene::ForcesDesc) -> Result<()> {
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

fn validate_dynamics(d: &Dynamics) -> Result<()> {
    positive("dynamics.dt", d.dt, 10.0)?;
    if d.steps_per_frame == 0 || d.steps_per_frame > 1000 {
        return Err(bad(
            "dynamics.steps_per_frame",
            d.steps_per_frame,
            "must be in [1, 1000]",
        ));
    }
    positive("dynamics.density", d.density, 1e6)?;
    within("dynamics.damping", d.damping, 0.0, 1e4)?;
    let inr = &d.inertia;
    positive("dynamics.inertia.root", inr.root, 1e6)?;
    positive("dynamics.inertia.tip", inr.tip, 1e6)?;
    positive("dynamics.inertia.top", inr.top, 1e6)?;
    within("dynamics.inertia.top_height", inr.top_height, -BIG, BIG)?;
    positive("dynamics.inertia.top_blend", inr.top_blend, BIG)?;
    if let Some(pf) = &d.pseudo_force {
        within("dynamics.pseudo_force.alpha", pf.alpha, -1.0, 1.0)?;
        within(
            "dynamics.pseudo_force.epsilon_pore",
            pf.epsilon_pore,
            0.0,
            1.0,
        )?;
        within(
            "dynamics.pseudo_force.epsilon_tip",
            pf.epsilon_tip,
            0.0,
            1.0,
        )?;
        within("dynamics.pseudo_force.near", pf.near, 0.0, BIG)?;
    }
    within("dynamics.stiffness.root", d.stiffness.root, 0.0, 180.0)?;
    within("dynamics.stiffness.tip", d.stiffness.tip, 0.0, 180.0)?;
    within("dynamics.stiffness.start", d.stiffness.start, 0.0, 0.99)?;
    within("dynamics.stiffness.end", d.stiffness.end, 0.01, 1.0)?;
    if d.stiffness.end <= d.stiffness.start {
        return Err(bad(
            "dynamics.stiffness.end",
            d.stiffness.end,
            &format!(
                "must be greater than dynamics.stiffness.start ({})",
                d.stiffness.start
            ),
        ));
    }
    if let Some(f) = &d.fluctuation {
        within("dynamics.fluctuation.amplitude", f.amplitude, 0.0, 90.0)?;
        if f.period == 0 || f.period > 100_000 {
            return Err(bad(
                "dynamics.fluctuation.period",
                f.period,
                "must be in [1, 100000] frames",
            ));
        }
    }
    if let Some(g) = d.guides {
        positive("dynamics.guides", g, 1.0)?;
    }
    if d.max_substeps == 0 || d.max_substeps > 4096 {
        return Err(bad(
            "dynamics.max_substeps",
            d.max_substeps,
            "must be in [1, 4096]",
        ));
    }
    Ok(())
}

/// A group read from a strand file: its placement; what only grown hair has is refused
/// rather than silently ignored.
fn validate_file_group(p: &str, g: &HairGroup, f: &crate::scene::StrandFile) -> Result<()> {
    if f.path.is_empty() {
        return Err(bad(
            &format!("{p}.file.path"),
            "\"\"",
            "names the strand file",
        ));
    }
    positive(&format!("{p}.file.scale"), f.scale, BIG)?;
    vec3(&format!("{p}.file.rotate"), f.rotate, 1e6)?;
    vec3(&format!("{p}.file.translate"), f.translate, BIG)?;
    if !g.cuts.is_empty() {
        return Err(bad(
            &format!("{p}.cuts"),
            g.cuts.len(),
            "a group read from a file keeps the file's lengths: cut it in the tool that made it",
        ));
    }
    if !g.loads.is_empty() {
        return Err(bad(
            &format!("{p}.loads"),
            g.loads.len(),
            "a group read from a file is not bent: its loads would do nothing",
        ));
    }
    material(&format!("{p}.material"), &g.material)
}

fn validate_group(p: &str, g: &HairGroup) -> Result<()> {
    if g.count == 0 {
        return Err(bad(&format!("{p}.count"), 0, "must be at least 1"));
    }
    if g.segments == 0 || g.segments > MAX_SEGMENTS {
        return Err(bad(
            &format!("{p}.segments"),
            g.segments,
            &format!("must be in [1, {MAX_SEGMENTS}]"),
        ));
    }
    if let Some(f) = &g.file {
        return validate_file_group(p, g, f);
    }
    positive(&format!("{p}.length"), g.length, BIG)?;
    within(&format!("{p}.length_jitter"), g.length_jitter, 0.0, 0.95)?;
    within(
        &format!("{p}.direction_jitter"),
        g.direction_jitter,
        0.0,
        90.0,
    )?;
    positive(&format!("{p}.rigidity"), g.rigidity, 1e15)?;

    theta_range(&format!("{p}.roots.theta"), g.roots.theta)?;
    phi_range(&format!("{p}.roots.phi"), g.roots.phi)?;
    if let Some(e) = &g.roots.on {
        vec3(&format!("{p}.roots.on.center"), e.center, BIG)?;
        for (i, r) in e.radii.iter().enumerate() {
            positive(&format!("{p}.roots.on.radii[{i}]"), *r, BIG)?;
        }
    }
    if let Some(line) = &g.roots.hairline {
        let hp = format!("{p}.roots.hairline");
        if line.len() < 2 || line.len() > 64 {
            return Err(bad(&hp, line.len(), "needs 2 to 64 (phi, theta) points"));
        }
        for (i, (phi, theta)) in line.iter().enumerate() {
            within(&format!("{hp}[{i}].0"), *phi, -720.0, 720.0)?;
            within(&format!("{hp}[{i}].1"), *theta, 0.0, 180.0)?;
            if i > 0 && *phi <= line[i - 1].0 {
                return Err(bad(
                    &format!("{hp}[{i}].0"),
                    phi,
                    "phi must increase along the hairline",
                ));
            }
        }
        if line[line.len() - 1].0 - line[0].0 >= 360.0 {
            return Err(bad(
                &hp,
                format!("{:?}..{:?}", line[0].0, line[line.len() - 1].0),
                "must span less than 360 degrees of phi",
            ));
        }
    }
    if let Direction::Blend { dir, weight } = &g.direction {
        nonzero(&format!("{p}.direction.dir"), *dir)?;
        within(&format!("{p}.direction.weight"), *weight, 0.0, 1.0)?;
    }
    if let Bending::Converged {
        max_iterations,
        tolerance,
    } = &g.bending
    {
        if *max_iterations == 0 || *max_iterations > 100_000 {
            return Err(bad(
                &format!("{p}.bending.max_iterations"),
                max_iterations,
                "must be in [1, 100000]",
            ));
        }
        within(&format!("{p}.bending.tolerance"), *tolerance, 1e-12, 0.1)?;
    }
    if g.loads.len() > 8 {
        return Err(bad(
            &format!("{p}.loads"),
            g.loads.len(),
            "at most 8 loads per group",
        ));
    }
    for (li, l) in g.loads.iter().enumerate() {
        let lp = format!("{p}.loads[{li}]");
        match l {
            Load::Uniform { force, .. } => vec3(&format!("{lp}.force"), *force, 1e9)?,
            Load::Toward {
                point, strength, ..
            } => {
                vec3(&format!("{lp}.point"), *point, BIG)?;
                within(&format!("{lp}.strength"), *strength, -1e9, 1e9)?;
            }
        }
        if l.region().len() > 4 {
            return Err(bad(
                &format!("{lp}.region"),
                l.region().len(),
                "at most 4 half-spaces per load",
            ));
        }
        for (ri, r) in l.region().iter().enumerate() {
            let rp = format!("{lp}.region[{ri}]");
            match r {
                Region::Above(y) | Region::Below(y) => within(&rp, *y, -BIG, BIG)?,
                Region::HalfSpace { normal, offset } => {
                    nonzero(&format!("{rp}.normal"), *normal)?;
                    within(&format!("{rp}.offset"), *offset, -BIG, BIG)?;
                }
            }
        }
    }
    if g.cuts.len() > 16 {
        return Err(bad(
            &format!("{p}.cuts"),
            g.cuts.len(),
            "at most 16 cuts per group",
        ));
    }
    for (ci, c) in g.cuts.iter().enumerate() {
        let cp = format!("{p}.cuts[{ci}]");
        if let Some(t) = c.theta {
            theta_range(&format!("{cp}.theta"), t)?;
        }
        if let Some(f) = c.phi {
            phi_range(&format!("{cp}.phi"), f)?;
        }
        match &c.rule {
            CutRule::Below(y) => within(&format!("{cp}.rule"), *y, -BIG, BIG)?,
            CutRule::ByPoreHeight { low, high } => {
                within(&format!("{cp}.rule.low.0"), low.0, -BIG, BIG)?;
                within(&format!("{cp}.rule.high.0"), high.0, -BIG, BIG)?;
                if low.0 >= high.0 {
                    return Err(bad(
                        &format!("{cp}.rule"),
                        format!("{low:?}..{high:?}"),
                        "low height must be below high height",
                    ));
                }
                for (n, v) in [("low.1", low.1), ("high.1", high.1)] {
                    if v > g.segments {
                        return Err(bad(
                            &format!("{cp}.rule.{n}"),
                            v,
                            &format!("must be at most the group's {} segments", g.segments),
                        ));
                    }
                }
            }
            CutRule::Near { center, radius } => {
                vec3(&format!("{cp}.rule.center"), *center, BIG)?;
                positive(&format!("{cp}.rule.radius"), *radius, BIG)?;
            }
        }
    }
    material(&format!("{p}.material"), &g.material)
}

/// A hair group's look.
fn material(mp: &str, m: &crate::scene::Material) -> Result<()> {
    color(&format!("{mp}.color"), m.color, 1.0)?;
    within(&format!("{mp}.ka"), m.ka, 0.0, 10.0)?;
    within(&format!("{mp}.ka_spread"), m.ka_spread, 0.0, 5.0)?;
    within(&format!("{mp}.ks"), m.ks, 0.0, 10.0)?;
    within(&format!("{mp}.shininess"), m.shininess, 0.0, 10000.0)?;
    within(&format!("{mp}.kd"), m.kd, 0.0, 10.0)?;
    positive(&format!("{mp}.width"), m.width, 1e3)?;
    within(&format!("{mp}.tip_width"), m.tip_width, 0.0, 1.0)?;
    Ok(())
}

/// SDF resolutions a mesh head may ask for (cells on the longest axis): below 8 the head is
/// a blob, above 256 the build takes minutes and the field tens of MB.
pub const SDF_RESOLUTION: (u32, u32) = (8, 256);

/// Most scalp regions.
const MAX_SCALP_REGIONS: usize = 64;

fn validate_head_mesh(m: &crate::scene::HeadMesh) -> Result<()> {
    use crate::scene::ScalpRegion;
    match &m.source {
        fur::MeshSource::File(p) if p.trim().is_empty() => {
            return Err(bad(
                "head.mesh.source",
                "\"\"",
                "must name an .obj, .off or .ply file",
            ));
        }
        fur::MeshSource::Gltf { file, .. } if file.trim().is_empty() => {
            return Err(bad(
                "head.mesh.source",
                "\"\"",
                "must name a .gltf or .glb file",
            ));
        }
        fur::MeshSource::Gltf { fps, .. } => positive("head.mesh.source.fps", *fps, 1e4)?,
        fur::MeshSource::CgalDemo(n)
            if n.is_empty() || n.contains(['/', '\\']) || n.starts_with('.') =>
        {
            return Err(bad(
                "head.mesh.source",
                format!("CgalDemo({n:?})"),
                "must be a file name in the CGAL demo meshes, e.g. \"head.off\"",
            ));
        }
        _ => {}
    }
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

fn validate_fur(f: &fur::Fur) -> Result<()> {
    match &f.mesh {
        fur::MeshSource::File(p) if p.trim().is_empty() => {
            return Err(bad(
                "fur.mesh",
                "\"\"",
                "must name an .obj, .off or .ply file",
            ));
        }
        fur::MeshSource::Gltf { file, .. } if file.trim().is_empty() => {
            return Err(bad("fur.mesh", "\"\"", "must name a .gltf or .glb file"));
        }
        fur::MeshSource::Gltf { fps, .. } => positive("fur.mesh.fps", *fps, 1e4)?,
        fur::MeshSource::CgalDemo(n)
            if n.is_empty() || n.contains(['/', '\\']) || n.starts_with('.') =>
        {
            return Err(bad(
                "fur.mesh",
                format!("CgalDemo({n:?})"),
                "must be a file name in the CGAL demo meshes, e.g. \"lion-head.off\"",
            ));
        }
        _ => {}
    }
    if let Some(size) = f.size {
        positive("fur.size", size, BIG)?;
    }
    // Above the scene's strand cap the total check would blame the hair groups instead.
    if f.hairs == 0 || u64::from(f.hairs) > MAX_STRANDS {
        return Err(bad(
            "fur.hairs",
            f.hairs,
            &format!("must be in [1, {MAX_STRANDS}]"),
        ));
    }
    positive("fur.length", f.length, BIG)?;
    if f.regions.len() > MAX_FUR_REGIONS {
        return Err(bad(
            "fur.regions",
            f.regions.len(),
            &format!("at most {MAX_FUR_REGIONS} regions"),
        ));
    }
    for (i, r) in f.regions.iter().enumerate() {
        vec3(&format!("fur.regions[{i}].center"), r.center, BIG)?;
        positive(&format!("fur.regions[{i}].radius"), r.radius, BIG)?;
        within(
            &format!("fur.regions[{i}].length_scale"),
            r.length_scale,
            0.0,
            100.0,
        )?;
        if let Some(d) = r.direction {
            nonzero(&format!("fur.regions[{i}].direction"), d)?;
        }
    }
    nonzero("fur.direction", f.direction)?;
    nonzero("fur.up", f.up)?;
    if f.coats.is_empty() || f.coats.len() > 4 {
        return Err(bad("fur.coats", f.coats.len(), "needs 1 to 4 coats"));
    }
    for (i, c) in f.coats.iter().enumerate() {
        let p = format!("fur.coats[{i}]");
        positive(&format!("{p}.share"), c.share, 1e6)?;
        positive(&format!("{p}.relative_length"), c.relative_length, 100.0)?;
        within(&format!("{p}.stiffness"), c.stiffness, 0.0, 1.0)?;
        within(
            &format!("{p}.normal_randomize"),
            c.normal_randomize,
            0.0,
            1.0,
        )?;
        within(&format!("{p}.end_randomize"), c.end_randomize, 0.0, 2.0)?;
        within(
            &format!("{p}.direction_weight"),
            c.direction_weight,
            0.0,
            1.0,
        )?;
        let m = &c.material;
        color(&format!("{p}.material.ambient"), m.ambient, 10.0)?;
        color(&format!("{p}.material.diffuse"), m.diffuse, 10.0)?;
        color(&format!("{p}.material.specular"), m.specular, 10.0)?;
        within(
            &format!("{p}.material.shininess"),
            m.shininess,
            0.0,
            10000.0,
        )?;
        positive(&format!("{p}.material.width"), m.width, BIG)?;
    }
    // Overlapping regions multiply their length scales: bound the longest hair that can
    // result, or it overflows f32 on the GPU (64 regions of scale 100 alone give 1e128).
    let grow: f64 = f.regions.iter().map(|r| r.length_scale.max(1.0)).product();
    let coat_len = f
        .coats
        .iter()
        .map(|c| c.relative_length)
        .fold(0.0, f64::max);
    let longest = f.length * grow * coat_len;
    if longest > BIG {
        return Err(bad(
            "fur.regions",
            format!("a longest hair of {longest:e}"),
            &format!(
                "fur.length x the regions' length_scale (multiplied where they overlap) x the \
                 largest coat relative_length must be at most {BIG:e}"
            ),
        ));
    }
    if let Some(d) = f.culling.full_distance {
        positive("fur.culling.full_distance", d, BIG)?;
    }
    if let Some(m) = &f.motion {
        within("fur.motion.amplitude", m.amplitude, -BIG, BIG)?;
        // The GPU gets 2 pi / wavelength as f32: below ~1e-38 that is infinite.
        within("fur.motion.wavelength", m.wavelength, 1e-6, BIG)?;
        positive("fur.motion.period", m.period, 1e9)?;
        nonzero("fur.motion.axis", m.axis)?;
        nonzero("fur.motion.direction", m.direction)?;
    }
    color("fur.skin", f.skin, 1.0)?;
    Ok(())
}

/// Most wisps in a scene and nodes per skeleton (the GPU keeps a wisp's spline solve in one
/// invocation's registers).
pub const MAX_WISPS: usize = 4096;
pub const MAX_WISP_NODES: usize = 64;

/// The wisps in the scene's shared forces: a gravity of their own (`wisps.springs.gravity`,
/// read before the springs fell under the shared one) is accepted with a warning when it
/// equals the shared gravity (`forces.gravity`, what `forces::Forces::from_scene` reads;
/// zero without the block) and refused otherwise; on a mesh head every root must lie over
/// the scalp (`wisps::place_root`, refused naming the skeleton's root).
fn wisps_on_shared_forces(s: &Scene, w: &super::wisps::Wisps) -> Result<()> {
    if let Some(g) = w.springs.as_ref().and_then(|sp| sp.gravity) {
        vec3("wisps.springs.gravity", g, 1e9)?;
        let shared = s.forces.gravity;
        if g == shared {
            log::warn!(
                "`wisps.springs.gravity` = {g:?} is no longer read (the wisps fall under the \
                 scene's shared gravity, `forces.gravity`, which equals it): remove it"
            );
        } else {
            return Err(bad(
                "wisps.springs.gravity",
                format!("{g:?}"),
                &format!(
                    "the wisps no longer keep a gravity of their own: they fall under the \
                     scene's shared gravity, `forces.gravity` (now {shared:?}, world units/s²); \
                     move the value there (forces: ForcesDesc(gravity: ({:?}, {:?}, {:?}))) and \
                     remove it here",
                    g[0], g[1], g[2]
                ),
            ));
        }
    }
    // Roots on a mesh head, checked here when the mesh can be read now, so that a root off
    // the scalp names the scene file; a mesh that cannot be read yet (a path relative to the
    // scene file is resolved after validation) is placed, and refused, when the wisps are
    // built, and its own errors name the mesh file.
    if s.head.mesh.is_some() {
        if let Ok(Some(mesh)) = super::hull::head_mesh(&s.head) {
            for si in 0..w.skeletons.len() {
                super::wisps::place_root(w, si, &s.head, &mesh)?;
            }
        }
    }
    Ok(())
}

fn validate_wisps(w: &wisps::Wisps) -> Result<()> {
    use wisps::Distance;
    if w.skeletons.is_empty() {
        return Err(bad("wisps.skeletons", "[]", "needs at least one skeleton"));
    }
    if w.skeletons.len() > MAX_WISPS {
        return Err(bad(
            "wisps.skeletons",
            format!("{} skeletons", w.skeletons.len()),
            &format!("at most {MAX_WISPS}"),
        ));
    }
    positive("wisps.threshold", w.threshold, 1e3)?;
    for (si, sk) in w.skeletons.iter().enumerate() {
        let f = format!("wisps.skeletons[{si}].nodes");
        if sk.nodes.len() < 2 {
            return Err(bad(
                &f,
                format!("{} node(s)", sk.nodes.len()),
                "a skeleton needs at least 2 nodes (a root and a tip)",
            ));
        }
        if sk.nodes.len() > MAX_WISP_NODES {
            return Err(bad(
                &f,
                format!("{} nodes", sk.nodes.len()),
                &format!("at most {MAX_WISP_NODES}"),
            ));
        }
        within(
            &format!("wisps.skeletons[{si}].outline"),
            sk.outline,
            0.0,
            8.0,
        )?;
        for (ni, n) in sk.nodes.iter().enumerate() {
            vec3(&format!("{f}[{ni}].p"), n.p, BIG)?;
            positive(&format!("{f}[{ni}].r"), n.r, BIG)?;
            positive(&format!("{f}[{ni}].w"), n.w, BIG)?;
            if ni > 0 {
                let q = sk.nodes[ni - 1].p;
                let d2: f64 = (0..3).map(|k| (n.p[k] - q[k]).powi(2)).sum();
                let scale = n.r.min(sk.nodes[ni - 1].r);
                if d2.sqrt() <= 1e-6 * scale.max(1e-9) {
                    return Err(bad(
                        &format!("{f}[{ni}].p"),
                        format!("{:?}", n.p),
                        &format!(
                            "coincides with node {}: neighbouring nodes must differ",
                            ni - 1
                        ),
                    ));
                }
            }
        }
    }
    let t = &w.toon;
    for (name, c) in [
        ("diffuse", t.diffuse),
        ("shade", t.shade),
        ("dark", t.dark),
        ("specular", t.specular),
        ("outline", t.outline),
    ] {
        color(&format!("wisps.toon.{name}"), c, 1.0)?;
    }
    within("wisps.toon.t_diffuse", t.t_diffuse, 0.0, 1.0)?;
    within("wisps.toon.t_dark", t.t_dark, 0.0, 1.0)?;
    within("wisps.toon.t_specular", t.t_specular, -1.0, 1.0)?;
    within("wisps.toon.outline_width", t.outline_width, 0.0, 32.0)?;
    within("wisps.toon.outline_taper", t.outline_taper, 0.0, 1.0)?;
    within("wisps.toon.diffuse_feather", t.diffuse_feather, 0.0, 1.0)?;
    within("wisps.toon.dark_feather", t.dark_feather, 0.0, 1.0)?;
    within("wisps.toon.halo_feather", t.halo_feather, 0.0, 1.0)?;
    within("wisps.toon.halo_offset", t.halo_offset, -90.0, 90.0)?;
    within("wisps.toon.halo_strength", t.halo_strength, 0.0, 4.0)?;
    if let Some(c) = t.halo_shadow {
        color("wisps.toon.halo_shadow", c, 1.0)?;
    }
    color("wisps.toon.rim", t.rim, 1.0)?;
    within("wisps.toon.rim_width", t.rim_width, 0.0, 1.0)?;
    within("wisps.toon.rim_feather", t.rim_feather, 0.0, 1.0)?;
    let m = &w.march;
    if m.max_steps == 0 || m.max_steps > 4096 {
        return Err(bad(
            "wisps.march.max_steps",
            m.max_steps,
            "must be in [1, 4096]",
        ));
    }
    if m.refine > 32 {
        return Err(bad("wisps.march.refine", m.refine, "must be in [0, 32]"));
    }
    within("wisps.march.step_scale", m.step_scale, 0.05, 8.0)?;
    if let Distance::Polyline { pieces } = m.distance {
        if pieces == 0 || pieces > 64 {
            return Err(bad(
                "wisps.march.distance.pieces",
                pieces,
                "must be in [1, 64]",
            ));
        }
    }
    if let Some(sp) = &w.springs {
        positive("wisps.springs.mass", sp.mass, BIG)?;
        positive("wisps.springs.sub_mass", sp.sub_mass, BIG)?;
        positive("wisps.springs.ring", sp.ring, 1.0)?;
        positive("wisps.springs.stiffness", sp.stiffness, 1e12)?;
        within("wisps.springs.damping", sp.damping, 0.0, 1e9)?;
        positive("wisps.springs.frame_time", sp.frame_time, 10.0)?;
        if sp.substeps == 0 || sp.substeps > 1000 {
            return Err(bad(
                "wisps.springs.substeps",
                sp.substeps,
                "must be in [1, 1000]",
            ));
        }
    }
    for (bi, b) in w.bundles.iter().enumerate() {
        if b.wisps.len() < 2 {
            return Err(bad(
                &format!("wisps.bundles[{bi}].wisps"),
                format!("{:?}", b.wisps),
                "a bundle joins at least 2 wisps",
            ));
        }
        for (k, &i) in b.wisps.iter().enumerate() {
            let Some(sk) = w.skeletons.get(i) else {
                return Err(bad(
                    &format!("wisps.bundles[{bi}].wisps[{k}]"),
                    i,
                    &format!("must name a skeleton (0..{})", w.skeletons.len()),
                ));
            };
            if b.release_from > sk.nodes.len() {
                return Err(bad(
                    &format!("wisps.bundles[{bi}].release_from"),
                    b.release_from,
                    &format!(
                        "must be at most the node count of skeleton {i} ({})",
                        sk.nodes.len()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Most strips in a scene (the paper's 120 with a wide margin; one GPU invocation each).
pub const MAX_STRIPS: u64 = 65_536;
/// Most sticks per strip (the GPU walks a chain in one invocation).
pub const MAX_STRIP_STICKS: u32 = 64;
/// Most key-frame edits (the GPU reads them all for every control point).
pub const MAX_STRIP_EDITS: usize = 16;
/// Most simulation steps per rendered frame.
const MAX_STEPS_PER_FRAME: f64 = 4096.0;

fn validate_strips(st: &strips::Strips) -> Result<()> {
    if st.layers.is_empty() {
        return Err(bad("strips.layers", "[]", "needs at least one layer"));
    }
    let mut total = 0u64;
    for (i, l) in st.layers.iter().enumerate() {
        let f = |name: &str| format!("strips.layers[{i}].{name}");
        if l.count == 0 {
            return Err(bad(&f("count"), 0, "a layer needs at least one strip"));
        }
        total += l.count as u64;
        within(&f("polar"), l.polar, 0.0, 180.0)?;
        if l.polar <= 0.0 || l.polar >= 180.0 {
            return Err(bad(
                &f("polar"),
                l.polar,
                "must be strictly between 0 and 180 degrees",
            ));
        }
        for (k, a) in l.azimuth.iter().enumerate() {
            within(&f(&format!("azimuth[{k}]")), *a, -720.0, 720.0)?;
        }
        if l.azimuth[1] < l.azimuth[0] || l.azimuth[1] - l.azimuth[0] > 360.0 {
            return Err(bad(
                &f("azimuth"),
                format!("{:?}", l.azimuth),
                "must be [from, to] with from <= to <= from + 360",
            ));
        }
        positive(&f("length"), l.length, BIG)?;
        if l.sticks == 0 || l.sticks > MAX_STRIP_STICKS {
            return Err(bad(
                &f("sticks"),
                l.sticks,
                &format!("must be in 1..={MAX_STRIP_STICKS}"),
            ));
        }
        positive(&f("width[0]"), l.width[0], BIG)?;
        positive(&f("width[1]"), l.width[1], BIG)?;
        within(&f("droop"), l.droop, 0.0, 1.0)?;
        within(&f("curl"), l.curl, -90.0, 90.0)?;
        within(&f("stiffness"), l.stiffness, 0.0, 1e6)?;
        color(&f("color"), l.color, 1.0)?;
    }
    if total > MAX_STRIPS {
        return Err(bad(
            "strips.layers[..].count",
            total,
            &format!("the total must be at most {MAX_STRIPS} strips"),
        ));
    }
    let m = &st.motion;
    positive("strips.motion.inertia", m.inertia, BIG)?;
    within("strips.motion.damping", m.damping, 0.0, BIG)?;
    within("strips.motion.stiffness", m.stiffness, 0.0, 1e9)?;
    within("strips.motion.stiffness_tip", m.stiffness_tip, 0.0, 1.0)?;
    within("strips.motion.spring", m.spring, 0.0, 1e9)?;
    within("strips.motion.collision", m.collision, 0.0, 1e9)?;
    positive("strips.motion.frame_time", m.frame_time, 10.0)?;
    positive("strips.motion.steps_per_second", m.steps_per_second, 1e6)?;
    let steps = m.frame_time * m.steps_per_second;
    if steps > MAX_STEPS_PER_FRAME {
        return Err(bad(
            "strips.motion.steps_per_second",
            m.steps_per_second,
            &format!("frame_time x steps_per_second must be at most {MAX_STEPS_PER_FRAME} steps per frame"),
        ));
    }
    let l = &st.look;
    if l.hairs == 0 || l.hairs > 256 {
        return Err(bad("strips.look.hairs", l.hairs, "must be in 1..=256"));
    }
    within("strips.look.tip_shade", l.tip_shade as f64, 0.0, 10.0)?;
    within("strips.look.alpha_cutoff", l.alpha_cutoff as f64, 0.0, 1.0)?;
    within("strips.look.specular[0]", l.specular[0] as f64, 0.0, 10.0)?;
    within("strips.look.specular[1]", l.specular[1] as f64, 1.0, 4096.0)?;
    if st.edits.len() > MAX_STRIP_EDITS {
        return Err(bad(
            "strips.edits",
            st.edits.len(),
            &format!("at most {MAX_STRIP_EDITS} key-frame edits"),
        ));
    }
    for (i, e) in st.edits.iter().enumerate() {
        let f = |name: &str| format!("strips.edits[{i}].{name}");
        if e.strip as u64 >= total {
            return Err(bad(
                &f("strip"),
                e.strip,
                &format!("names no strip: the layers have {total}"),
            ));
        }
        if e.to <= e.from {
            return Err(bad(
                &f("to"),
                e.to,
                "the second key frame must come after `from`",
            ));
        }
        vec3(&f("target"), e.target, BIG)?;
        positive(&f("radius"), e.radius, BIG)?;
    }
    Ok(())
}
