//! Rust structs and their WGSL twins, checked by the compiler that reads the shaders
//! (issue 35 item 3): every `#[repr(C)]` struct Kami uploads is listed here with the WGSL
//! struct (or storage array) it must match and the shader files that declare it; naga
//! parses each registered module that holds the file, lays the struct out as the GPU will,
//! and its size, alignment and member offsets and sizes must be the Rust ones. A drifted
//! field fails here instead of drawing garbage. No GPU needed.
//!
//! Rust fields and WGSL members are paired in order, padding (`_`-prefixed names) left out
//! on both sides; a trailing `_` field that pads a dynamic-offset uniform's 256-byte slot
//! ends the WGSL struct. Where a Rust field holds several WGSL members (a matrix as rows: `head` in
//! Rust, `head_x`, `head_y`, `head_z` in WGSL), each Rust field must start where a member
//! starts and cover exactly the members up to the next field.

use std::collections::HashMap;
use std::mem::{offset_of, size_of};

/// One Rust struct and its WGSL twin.
struct Twin {
    rust: &'static str,
    size: usize,
    /// (field, offset, size), in declaration order.
    fields: Vec<(&'static str, usize, usize)>,
    /// The WGSL struct's name, or `@name` for a storage array `var<storage> name:
    /// array<T>` whose element the Rust struct is.
    wgsl: &'static str,
    /// The shader files (under `shaders/`) that declare it: each copy is checked.
    files: &'static [&'static str],
}

macro_rules! twin {
    ($t:ty, [$($f:ident),* $(,)?], $wgsl:literal, [$($file:literal),+ $(,)?]) => {{
        let z: $t = bytemuck::Zeroable::zeroed();
        let _ = &z;
        Twin {
            rust: stringify!($t),
            size: size_of::<$t>(),
            fields: vec![$((stringify!($f), offset_of!($t, $f), std::mem::size_of_val(&z.$f))),*],
            wgsl: $wgsl,
            files: &[$($file),+],
        }
    }};
}

fn twins() -> Vec<Twin> {
    use kami::forces::eff::GpuEffGrid;
    use kami::gpu::gpu_data::{GpuFrame, GpuHead, GpuStrand};
    use kami::gpu::shadow::GpuShadow;
    use kami::systems::anjyo::follow_gpu::{GpuFollowParams, GpuFollower};
    use kami::systems::anjyo::gpu_data::*;
    use kami::systems::fur::gpu_data::{GpuFurCoat, GpuFurMaterial, GpuSkin};
    use kami::systems::hair_bsdf::GpuHairBsdf;
    use kami::systems::strips::dynamics_gpu as sd;
    use kami::systems::strips::ribbon::{
        GpuRibbonParams, GpuRibbonVertex, GpuStripInfo, GpuStripLook,
    };
    use kami::systems::wisps::march::{GpuCapsule, GpuSegment, GpuWispDraw, GpuWispParams};
    use kami::systems::wisps::springs_gpu::{GpuEdge, GpuMassPoint, GpuSpringParams, GpuSubstep};
    use kami::systems::wisps::tiles::GpuMarchView;
    use kami::systems::world::{GpuWorld, GpuWorldStep};
    vec![
        twin!(
            GpuEffGrid,
            [origin, cell, dims, outside],
            "EffGrid",
            ["forces/eff.wgsl"]
        ),
        twin!(
            GpuWorld,
            [hull_center, hull_radii],
            "World",
            ["common/world.wgsl"]
        ),
        twin!(
            GpuWorldStep,
            [force, head, head_inv],
            "WorldStep",
            ["common/world.wgsl"]
        ),
        twin!(
            GpuStrand,
            [
                first_vertex,
                segments,
                group,
                flags,
                visible,
                ka,
                seg_len,
                rand
            ],
            "Strand",
            ["common/strands.wgsl"]
        ),
        twin!(
            GpuFrame,
            [
                view_proj,
                eye,
                light_dir,
                light_color,
                viewport,
                raster,
                flags,
                shadow
            ],
            "Frame",
            ["common/frame.wgsl"]
        ),
        twin!(
            GpuHead,
            [model, rotation, color, inv_radii2],
            "Head",
            ["stage/head.wgsl"]
        ),
        twin!(
            GpuStep,
            [h, accel, kick, samples, _pad],
            "Step",
            ["anjyo/projective.wgsl"]
        ),
        twin!(
            GpuShadow,
            [center, axis_u, axis_v, axis_l, dims, layers, layered, head_inv],
            "ShadowParams",
            ["common/frame.wgsl"]
        ),
        twin!(
            GpuFollowParams,
            [follower_count, row_stride, collision, sample],
            "FollowParams",
            ["anjyo/follow.wgsl"]
        ),
        twin!(
            GpuFollower,
            [ids, root, guide_first, guide_segs, weight],
            "Follower",
            ["anjyo/follow.wgsl"]
        ),
        twin!(GpuRoot, [pos, dir], "Root", ["anjyo/cantilever.wgsl"]),
        twin!(
            GpuGroomGroup,
            [
                segments,
                mode,
                max_iterations,
                first_load,
                load_count,
                first_cut,
                cut_count,
                _pad0,
                rigidity,
                tolerance,
                _pad1
            ],
            "Group",
            ["anjyo/cantilever.wgsl"]
        ),
        twin!(
            GpuLoad,
            [field, params, planes],
            "Load",
            ["common/loads.wgsl"]
        ),
        twin!(GpuCut, [kind, _pad, a], "Cut", ["anjyo/cantilever.wgsl"]),
        twin!(
            GpuGroomParams,
            [strand_count, total_vertices, row_stride, chunk],
            "Params",
            ["anjyo/cantilever.wgsl"]
        ),
        twin!(
            GpuMaterial,
            [color_ks, params, file, bsdf, variation, vary_single],
            "Material",
            ["anjyo/draw.wgsl"]
        ),
        twin!(
            GpuLook,
            [rgba, width],
            "@looks",
            ["common/strand_shade.wgsl"]
        ),
        twin!(
            GpuDynParams,
            [
                strand_count,
                row_stride,
                collision,
                pseudo,
                density,
                damping,
                seed,
                fluct_amp,
                pseudo_alpha,
                eps_pore,
                eps_tip,
                near,
                sigma_root,
                sigma_tip,
                sigma_start,
                inertia_root,
                inertia_tip,
                sigma_end,
                state_stride,
                _pad
            ],
            "DynParams",
            ["anjyo/projective.wgsl"]
        ),
        twin!(
            GpuDynStrand,
            [ids, root, extra],
            "DynStrand",
            ["anjyo/projective.wgsl"]
        ),
        twin!(
            GpuFurCoat,
            [
                drawn,
                segments,
                style,
                tri_count,
                first_vertex,
                first_strand,
                seed,
                first_base,
                offset_base,
                rel_length,
                floppiness,
                end_rand,
                dir_weight,
                skin_base,
                _pad,
                up,
                motion,
                motion_axis,
                motion_dir,
                _slot
            ],
            "Coat",
            ["fur/generate.wgsl"]
        ),
        twin!(
            GpuFurMaterial,
            [ambient, diffuse, specular, extra, bsdf],
            "FurMaterial",
            ["fur/draw.wgsl"]
        ),
        // The shadow cast reads the same buffer under its own name.
        twin!(
            GpuFurMaterial,
            [ambient, diffuse, specular, extra, bsdf],
            "CastMaterial",
            ["fur/cast.wgsl"]
        ),
        twin!(
            GpuSkin,
            [color, motion, motion_axis, motion_dir, skin, coat],
            "Skin",
            ["fur/skin.wgsl"]
        ),
        twin!(
            GpuHairBsdf,
            [sigma_a, v, tilt, misc, a_f, back, ambient],
            "HairBsdf",
            ["common/hair_bsdf.wgsl"]
        ),
        twin!(
            sd::GpuParams,
            [
                count,
                stride,
                row_stride,
                extras,
                gravity,
                collision,
                flags,
                extra_center,
                extra_accel
            ],
            "Params",
            ["strips/dynamics.wgsl"]
        ),
        twin!(
            sd::GpuStep,
            [k0, k1, samples, ramp0, ramp1],
            "Step",
            ["strips/dynamics.wgsl"]
        ),
        twin!(
            sd::GpuStrip,
            [root, info],
            "Strip",
            ["strips/dynamics.wgsl"]
        ),
        twin!(
            sd::GpuJoint,
            [c0, c1, c2, rest, goal, full_step, half_step, forced],
            "Joint",
            ["strips/dynamics.wgsl"]
        ),
        twin!(
            GpuStripInfo,
            [side, normal, color, counts, sky],
            "StripInfo",
            ["strips/strip.wgsl"]
        ),
        twin!(
            GpuRibbonVertex,
            [position, tangent],
            "RibbonVertex",
            ["strips/strip.wgsl"]
        ),
        twin!(
            GpuRibbonParams,
            [head, counts],
            "Params",
            ["strips/ribbon.wgsl"]
        ),
        twin!(
            GpuStripLook,
            [look, counts, bsdf],
            "StripLook",
            ["strips/draw.wgsl"]
        ),
        twin!(
            GpuWispParams,
            [model, counts, shape],
            "Params",
            ["wisps/curves.wgsl"]
        ),
        twin!(GpuSegment, [c, lo, hi], "Segment", ["wisps/segments.wgsl"]),
        twin!(GpuCapsule, [a, b], "Capsule", ["wisps/segments.wgsl"]),
        twin!(
            kami::systems::wisps::mesh_gpu::GpuMesher,
            [origin, dims, bricks, caps, offs, shape, method],
            "Mesher",
            ["wisps/mesher.wgsl"]
        ),
        twin!(
            GpuWispDraw,
            [
                head,
                diffuse,
                shade,
                dark,
                specular,
                outline,
                march,
                method,
                feather,
                rim,
                halo,
                halo_shadow,
                taper
            ],
            "Draw",
            ["wisps/draw.wgsl"]
        ),
        twin!(
            GpuSpringParams,
            [count, row_stride, collide, _pad, step],
            "Params",
            ["wisps/springs.wgsl"]
        ),
        twin!(GpuSubstep, [sample], "Substep", ["wisps/springs.wgsl"]),
        twin!(
            GpuMassPoint,
            [rest, edges],
            "MassPoint",
            ["wisps/springs.wgsl"]
        ),
        twin!(GpuEdge, [other, rest, k], "Edge", ["wisps/springs.wgsl"]),
        twin!(
            GpuMarchView,
            [view_proj, inv_view_proj, eye, size, tiles, flags],
            "View",
            ["wisps/view.wgsl"]
        ),
    ]
}

/// A registered module holding `file` (its text inside the module's source), parsed and
/// laid out; cached by module name.
fn module_with<'a>(
    file: &str,
    cache: &'a mut HashMap<&'static str, (naga::Module, naga::proc::Layouter)>,
) -> (&'static str, &'a (naga::Module, naga::proc::Layouter)) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("shaders")
        .join(file);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
    let (name, source) = kami::stage::shaders()
        .into_iter()
        .find(|(_, s)| s.contains(text.trim()))
        .unwrap_or_else(|| panic!("no registered shader module includes shaders/{file}"));
    let entry = cache.entry(name).or_insert_with(|| {
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).expect("layout");
        (module, layouter)
    });
    (name, entry)
}

/// What differs between `t` and its twin in one module; empty when they agree.
fn compare(t: &Twin, module: &naga::Module, layouter: &naga::proc::Layouter) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(var) = t.wgsl.strip_prefix('@') {
        let Some((_, g)) = module
            .global_variables
            .iter()
            .find(|(_, g)| g.name.as_deref() == Some(var))
        else {
            return vec![format!("no global `{var}`")];
        };
        match module.types[g.ty].inner {
            naga::TypeInner::Array {
                stride, base: _, ..
            } => {
                if stride as usize != t.size {
                    out.push(format!(
                        "`{var}` strides {stride} bytes, {} is {} bytes",
                        t.rust, t.size
                    ));
                }
            }
            _ => out.push(format!("`{var}` is not an array")),
        }
        return out;
    }
    let Some((handle, ty)) = module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some(t.wgsl))
    else {
        return vec![format!("no struct `{}`", t.wgsl)];
    };
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        return vec![format!("`{}` is not a struct", t.wgsl)];
    };
    // A trailing `_` field pads a dynamic-offset uniform's slot (256 bytes): the WGSL
    // struct ends where it begins.
    let size = match t.fields.last() {
        Some(f) if f.0.starts_with('_') && f.1 >= *span as usize => f.1,
        _ => t.size,
    };
    if *span as usize != size {
        out.push(format!(
            "`{}` is {span} bytes, {} is {size}",
            t.wgsl, t.rust
        ));
    }
    let align = layouter[handle].alignment.round_up(1) as usize;
    if t.size % align != 0 {
        out.push(format!(
            "{} is {} bytes, not a multiple of `{}`'s alignment {align} (arrays of it would stride differently)",
            t.rust, t.size, t.wgsl
        ));
    }
    let wgsl: Vec<(String, usize, usize)> = members
        .iter()
        .filter(|m| !m.name.as_deref().unwrap_or("").starts_with('_'))
        .map(|m| {
            (
                m.name.clone().unwrap_or_default(),
                m.offset as usize,
                layouter[m.ty].size as usize,
            )
        })
        .collect();
    let rust: Vec<&(&str, usize, usize)> =
        t.fields.iter().filter(|f| !f.0.starts_with('_')).collect();
    if wgsl.len() == rust.len() {
        for (w, r) in wgsl.iter().zip(&rust) {
            if (w.1, w.2) != (r.1, r.2) {
                out.push(format!(
                    "`{}.{}` is {} bytes at {}, `{}.{}` {} bytes at {}",
                    t.wgsl, w.0, w.2, w.1, t.rust, r.0, r.2, r.1
                ));
            }
        }
    } else {
        // A Rust field over several members: it starts at a member and ends where the next
        // Rust field (or the struct) begins, on a member boundary.
        for (i, r) in rust.iter().enumerate() {
            let end = rust.get(i + 1).map_or(t.size, |n| n.1);
            let starts = wgsl.iter().any(|w| w.1 == r.1);
            let covered: usize = wgsl
                .iter()
                .filter(|w| w.1 >= r.1 && w.1 < end)
                .map(|w| w.2)
                .sum();
            if !starts || covered > r.2 || r.1 + r.2 > end {
                out.push(format!(
                    "`{}.{}` ({} bytes at {}) does not line up with `{}`'s members {:?}",
                    t.rust,
                    r.0,
                    r.2,
                    r.1,
                    t.wgsl,
                    wgsl.iter().map(|w| (&w.0, w.1)).collect::<Vec<_>>()
                ));
            }
        }
    }
    out
}

#[test]
fn every_gpu_struct_matches_its_wgsl_twin() {
    let mut cache = HashMap::new();
    let mut problems = Vec::new();
    let twins = twins();
    for t in &twins {
        for file in t.files {
            let (name, (module, layouter)) = module_with(file, &mut cache);
            for p in compare(t, module, layouter) {
                problems.push(format!("{} / shaders/{file} (module {name}): {p}", t.rust));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(twins.len() >= 37, "the list lost twins");
}

/// The check fails on a drifted field: a twin whose Rust side lists its fields in another
/// order, and one whose size is off, are both reported.
#[test]
fn a_drifted_field_is_reported() {
    let mut cache = HashMap::new();
    let (_, (module, layouter)) = module_with("anjyo/cantilever.wgsl", &mut cache);
    let mut t = twins().into_iter().find(|t| t.rust == "GpuRoot").unwrap();
    assert!(compare(&t, module, layouter).is_empty());
    t.fields.swap(0, 1);
    t.fields[0].1 = 16;
    t.fields[1].1 = 0;
    assert!(!compare(&t, module, layouter).is_empty());
    t.size += 16;
    let p = compare(&t, module, layouter).join("\n");
    assert!(p.contains("`Root` is 32 bytes, GpuRoot is 48"), "{p}");
}

/// The value of the WGSL `const name` in `module`, as f64 (a literal initialiser).
fn wgsl_const(module: &naga::Module, name: &str) -> Option<f64> {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))?;
    match module.global_expressions[c.init] {
        naga::Expression::Literal(l) => Some(match l {
            naga::Literal::F32(v) => f64::from(v),
            naga::Literal::F64(v) | naga::Literal::AbstractFloat(v) => v,
            naga::Literal::U32(v) => f64::from(v),
            naga::Literal::I32(v) => f64::from(v),
            naga::Literal::AbstractInt(v) => v as f64,
            _ => return None,
        }),
        _ => None,
    }
}

/// Numbers Rust and WGSL both use that cannot be pipeline-overridable constants (an array
/// size, a fixed-point scale read in several modules): (file under `shaders/`, WGSL const,
/// the Rust value it must equal, where that lives).
fn twin_constants() -> Vec<(&'static str, &'static str, f64, &'static str)> {
    use kami::gpu::{shadow, splat};
    let joints = kami::scene::skinned::MAX_JOINTS as f64;
    vec![
        (
            "wisps/mesher.wgsl",
            "BRICK",
            kami::systems::wisps::mesh::BRICK as f64,
            "systems::wisps::mesh::BRICK",
        ),
        (
            "fur/generate.wgsl",
            "MAX_JOINTS",
            joints,
            "scene::skinned::MAX_JOINTS",
        ),
        (
            "fur/skin.wgsl",
            "MAX_JOINTS",
            joints,
            "scene::skinned::MAX_JOINTS",
        ),
        (
            "common/splat.wgsl",
            "COLOR_SCALE",
            splat::COLOR_SCALE,
            "gpu::splat::COLOR_SCALE",
        ),
        (
            "common/splat.wgsl",
            "DEPTH_SCALE",
            splat::DEPTH_SCALE,
            "gpu::splat::DEPTH_SCALE",
        ),
        (
            "common/splat.wgsl",
            "TILE",
            splat::TILE as f64,
            "gpu::splat::TILE",
        ),
        (
            "stage/downsample.wgsl",
            "COLOR_SCALE",
            splat::COLOR_SCALE,
            "gpu::splat::COLOR_SCALE",
        ),
        (
            "stage/downsample.wgsl",
            "DEPTH_SCALE",
            splat::DEPTH_SCALE,
            "gpu::splat::DEPTH_SCALE",
        ),
        (
            "common/shadow_cast.wgsl",
            "SHADOW_FIXED",
            shadow::FIXED,
            "gpu::shadow::FIXED",
        ),
        (
            "stage/shadow.wgsl",
            "FIXED",
            shadow::FIXED,
            "gpu::shadow::FIXED",
        ),
        (
            "common/shadow_cast.wgsl",
            "SHADOW_DEPTH_SCALE",
            shadow::DEPTH_SCALE,
            "gpu::shadow::DEPTH_SCALE",
        ),
        (
            "stage/shadow.wgsl",
            "DEPTH_SCALE",
            shadow::DEPTH_SCALE,
            "gpu::shadow::DEPTH_SCALE",
        ),
        (
            "common/strand_shade.wgsl",
            "VARY_TABLE",
            kami::systems::hair_bsdf::VARY_TABLE as f64,
            "systems::hair_bsdf::VARY_TABLE",
        ),
        (
            "common/shadow.wgsl",
            "SHADOW_ROW",
            f64::from(shadow::ROW),
            "gpu::shadow::ROW",
        ),
    ]
}

/// Every shared constant has the Rust value in every shader that declares it, read by naga.
#[test]
fn shared_constants_match_their_rust_values() {
    let mut cache = HashMap::new();
    let mut problems = Vec::new();
    for (file, name, want, rust) in twin_constants() {
        let (module_name, (module, _)) = module_with(file, &mut cache);
        match wgsl_const(module, name) {
            Some(v) if v == want => {}
            Some(v) => problems.push(format!(
                "shaders/{file} (module {module_name}): const {name} = {v}, {rust} = {want}"
            )),
            None => problems.push(format!(
                "shaders/{file} (module {module_name}): no literal const {name} (Rust: {rust})"
            )),
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
