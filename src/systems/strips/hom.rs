//! The Hair Object Model (Kazama et al., section 2.1 and figure 1): reed-shaped strips in
//! the layers of a stylist's layer model. Each layer puts `count` roots on a ring of the
//! head ellipsoid at polar angle `polar` (from the crown), spread over its azimuth range,
//! and gives every strip the same rest shape in its own vertical plane: a chain of `sticks`
//! equal rigid sticks (figure 2's motion structure) that leaves along the outward head
//! normal, turns toward straight down by `droop` and bends by `curl` degrees at every joint.
//!
//! The rest shape is built in the vertical plane of the root's outward normal, spanned by
//! the normal's horizontal direction r̂ and +y. Every turn is a rotation about the ring tangent t̂ = ŷ × r̂, whose positive sense
//! carries r̂ → −ŷ → −r̂: outward, then down, then under toward the head. So `droop` (a share
//! of the angle from the normal to straight down) and `curl` (degrees per stick) turn the
//! same way, and a positive curl tucks the ends under as a bob does.
//!
//! The chain never enters the head: a stick whose end would fall inside the layer's shell
//! (below) is turned about its start, in the plane of the stick and the point, onto the
//! shell (`Ellipsoid::push_out`), so every stick keeps its length. Later sticks keep the
//! intended direction (not the pushed one), so a strip drapes over the head's bulge and then
//! hangs as its droop and curl say.
//!
//! Layers: layer i of the scene (inner to outer) is kept outside a shell, the head
//! ellipsoid with every radius grown by `(1 + i) * SHELL * mean radius`. Inner layers
//! therefore lie closer to the scalp wherever the strips rest on the head, and an outer
//! layer lies over the inner ones instead of through them, as a stylist's layers do; where
//! strips hang free the layers' own polar angles and lengths stack them.
//!
//! **On a mesh head** (`head.mesh`) each strip's root, found on the ellipsoid as above, is
//! moved onto the mesh's scalp as the toon wisps' roots are (`roots_on_mesh`, through
//! `HeadMeshData::place_on_scalp`: the nearest point of the mesh, which must be a scalp
//! triangle within reach, then onto the SDF's zero level set); the rest shape leaves along
//! the field's outward normal there, and the layers' shells are the field's level sets
//! `SDF = margin` instead of grown ellipsoids.

use super::RestStrip;
use crate::error::{KamiError, Result};
use crate::scene::head::{push_out_implicit, Ellipsoid};
use crate::scene::hull::{root_reach, HeadMeshData, OffScalp, SDF_EPS_OUT};
use crate::scene::sdf::Sdf;
use crate::scene::Head;
use crate::systems::strips::block::{check_layers, Layer, Strips, MAX_STRIPS};
use glam::DVec3;

/// Gap between the shells of successive layers, as a share of the head's mean radius
/// (about 2 mm on the default head: a strip's thickness).
pub const SHELL: f64 = 0.02;

/// Strips the scene's layers make, in layer order.
pub fn strip_count(strips: &Strips) -> usize {
    strips.layers.iter().map(|l| l.count as usize).sum()
}

fn invalid(field: String, value: impl std::fmt::Display, allowed: &str) -> KamiError {
    KamiError::Invalid {
        file: String::new(),
        field,
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

/// Azimuths (degrees) of a layer's roots: evenly over the range, both ends included unless
/// the range is a full turn (then the end is the start again); one strip sits mid-range.
pub fn azimuths(layer: &Layer) -> Vec<f64> {
    let [a0, a1] = layer.azimuth;
    let n = layer.count as usize;
    let span = a1 - a0;
    if span >= 360.0 - 1e-9 {
        (0..n).map(|i| a0 + 360.0 * i as f64 / n as f64).collect()
    } else if n == 1 {
        vec![0.5 * (a0 + a1)]
    } else {
        (0..n)
            .map(|i| a0 + span * i as f64 / (n - 1) as f64)
            .collect()
    }
}

/// Rotate `v` about the unit `axis` by `angle` radians (right hand).
fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

/// What a layer's strips are kept outside of while the rest shape is built: the head
/// ellipsoid grown by the layer's margin, or a mesh head's SDF level set at that margin.
enum Shell<'a> {
    Ellipsoid(Ellipsoid),
    Sdf(&'a Sdf, f64),
}

impl Shell<'_> {
    fn eval(&self, q: DVec3) -> f64 {
        match self {
            Shell::Ellipsoid(e) => e.eval(q),
            Shell::Sdf(s, margin) => s.sample(q) - margin,
        }
    }

    fn push_out(&self, pivot: DVec3, a0: DVec3, q: DVec3, d: f64) -> DVec3 {
        match self {
            Shell::Ellipsoid(e) => e.push_out(pivot, a0, q, d),
            Shell::Sdf(s, margin) => push_out_implicit(
                &|p| s.sample(p) - margin,
                &|p| s.gradient(p),
                SDF_EPS_OUT,
                pivot,
                a0,
                q,
                d,
            ),
        }
    }
}

/// Unit direction from the head's centre of the ellipsoid point at `polar` and azimuth `az`
/// (degrees, as `Ellipsoid::point` measures them).
fn direction(polar: f64, az: f64) -> DVec3 {
    let (theta, phi) = (polar.to_radians(), az.to_radians());
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    )
}

/// The roots of the scene's strips on a mesh head, in strip order, with the field's outward
/// normal at each: every root found on the head ellipsoid (its layer's polar angle and
/// azimuth) and moved onto the scalp (`HeadMeshData::place_on_scalp`, within the root's
/// width or a quarter of the head's smallest radius). Refused naming the strip and its
/// layer's field when a root lies too far from the mesh, over a triangle off the scalp, or
/// where the field cannot follow the mesh.
pub fn roots_on_mesh(
    strips: &Strips,
    head: &Head,
    mesh: &HeadMeshData,
) -> Result<Vec<(DVec3, DVec3)>> {
    let hull = Ellipsoid::new(head.center, head.radii);
    let mut out = Vec::with_capacity(strip_count(strips).min(MAX_STRIPS as usize));
    for (li, layer) in strips.layers.iter().enumerate() {
        let reach = root_reach(layer.width[0], head);
        for az in azimuths(layer) {
            let si = out.len();
            let drawn = hull.center + hull.radii * direction(layer.polar, az);
            let name = if layer.name.is_empty() {
                format!("strip {si} (layer {li}, azimuth {az:.1}°)")
            } else {
                format!("strip {si} (layer {li} `{}`, azimuth {az:.1}°)", layer.name)
            };
            let refuse = |field: &str, allowed: String| {
                invalid(
                    format!("strips.layers[{li}].{field}"),
                    format!("polar {}, azimuth {az:.1} (strip {si})", layer.polar),
                    &allowed,
                )
            };
            match mesh.place_on_scalp(drawn, reach) {
                Ok(p) => out.push((p.root, mesh.sdf.gradient(p.root).normalize_or(DVec3::Y))),
                Err(OffScalp::Far { dist, reach }) => {
                    return Err(refuse(
                        "polar",
                        format!(
                            "{name}: its root on the head ellipsoid (head.radii) is {dist:.3} \
                             from the head mesh; a strip's root on a mesh head must lie within \
                             {reach:.3} of it (the root's width or a quarter of the head's \
                             smallest radius), where it is moved onto the scalp: fit head.radii \
                             to the mesh or move the layer's ring"
                        ),
                    ))
                }
                Err(OffScalp::NotScalp { triangle }) => {
                    return Err(refuse(
                        "azimuth",
                        format!(
                            "{name}: its root is nearest triangle {triangle} of the head mesh, \
                             which is not scalp (head.mesh.scalp): narrow the layer's polar \
                             angle and azimuth range to the scalp or widen the scalp regions"
                        ),
                    ))
                }
                Err(OffScalp::Unfollowed { cell }) => {
                    return Err(refuse(
                        "azimuth",
                        format!(
                            "{name}: the head's signed distance field cannot follow the mesh \
                             under its root (a feature thinner than a cell of {cell:.3}): move \
                             the layer's ring or raise head.mesh.resolution"
                        ),
                    ))
                }
            }
        }
    }
    Ok(out)
}

/// The rest strips of the scene's layers, in layer order (strip index = position here).
pub fn build(strips: &Strips, head: &Head) -> Result<Vec<RestStrip>> {
    // The scene validator's own checks (one set of bounds, the same messages): a scene
    // built in code reaches here unvalidated, and must not make NaN or a huge allocation.
    crate::scene::validate::head_shape(head)?;
    let total = check_layers(&strips.layers)?;
    let mesh = crate::scene::hull::head_mesh(head)?;
    let placed = match &mesh {
        Some(m) => Some(roots_on_mesh(strips, head, m)?),
        None => None,
    };
    let hull = Ellipsoid::new(head.center, head.radii);
    let mean_radius = hull.radii.element_sum() / 3.0;
    let mut out = Vec::with_capacity(total as usize);
    for (li, layer) in strips.layers.iter().enumerate() {
        let margin = (1 + li) as f64 * SHELL * mean_radius;
        let shell = match &mesh {
            Some(m) => Shell::Sdf(&m.sdf, margin),
            None => Shell::Ellipsoid(Ellipsoid {
                center: hull.center,
                radii: hull.radii + DVec3::splat(margin),
            }),
        };
        for az in azimuths(layer) {
            let (root, normal) = match &placed {
                Some(p) => p[out.len()],
                None => {
                    let root = hull.center + hull.radii * direction(layer.polar, az);
                    (root, hull.normal(root))
                }
            };
            out.push(strip(root, normal, &shell, layer, li as u32));
        }
    }
    Ok(out)
}

/// One strip of `layer` from `root`, leaving along the outward head `normal` there.
fn strip(root: DVec3, normal: DVec3, shell: &Shell, layer: &Layer, li: u32) -> RestStrip {
    // r̂: the normal's horizontal direction (polar in (0, 180) keeps it non-zero; on an
    // ellipsoid it is not quite the root's azimuth), so the normal lies in the plane of r̂
    // and ŷ. The ring tangent t̂ = ŷ × r̂: positive turns go outward → down → under.
    let radial = DVec3::new(normal.x, 0.0, normal.z).normalize_or(DVec3::Z);
    let axis = DVec3::Y.cross(radial);
    // The normal turns onto −ŷ about t̂ by its angle from −ŷ.
    let from_down = normal.dot(-DVec3::Y).clamp(-1.0, 1.0).acos();
    let first = rotate(normal, axis, layer.droop * from_down);
    let stick = layer.length / layer.sticks as f64;
    let curl = layer.curl.to_radians();
    let mut points = Vec::with_capacity(layer.sticks as usize + 1);
    points.push(root);
    let mut prev_dir = normal;
    for j in 0..layer.sticks {
        let want = rotate(first, axis, j as f64 * curl);
        let p = *points.last().unwrap_or(&root);
        let mut q = p + stick * want;
        if shell.eval(q) < 0.0 {
            q = shell.push_out(p, prev_dir, q, stick);
        }
        prev_dir = (q - p) / stick;
        points.push(q);
    }
    RestStrip {
        layer: li,
        points,
        normal,
        width: layer.width,
        stiffness: layer.stiffness,
        color: layer.color,
    }
}
