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

use super::RestStrip;
use crate::error::{KamiError, Result};
use crate::scene::head::Ellipsoid;
use crate::scene::Head;
use crate::systems::strips::block::{Layer, Strips};
use glam::DVec3;

/// Gap between the shells of successive layers, as a share of the head's mean radius
/// (about 2 mm on the default head: a strip's thickness).
pub const SHELL: f64 = 0.02;

/// At most this many strips in one scene (a bound that keeps a typo from allocating
/// gigabytes; the paper draws 120).
pub const MAX_STRIPS: u64 = 1 << 20;
/// At most this many sticks per strip.
pub const MAX_STICKS: u32 = 1024;

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

/// Check one layer's numbers (the scene validation may have done so; `build` must not
/// produce NaN or a huge allocation from a scene built in code either).
fn check_layer(i: usize, l: &Layer) -> Result<()> {
    let f = |name: &str| format!("strips.layers[{i}].{name}");
    if l.count == 0 {
        return Err(invalid(f("count"), l.count, "at least 1 strip"));
    }
    if !(l.polar.is_finite() && l.polar > 0.0 && l.polar < 180.0) {
        return Err(invalid(f("polar"), l.polar, "degrees in (0, 180)"));
    }
    let [a0, a1] = l.azimuth;
    if !(a0.is_finite() && a1.is_finite() && a1 >= a0) {
        return Err(invalid(
            f("azimuth"),
            format!("{:?}", l.azimuth),
            "finite degrees [from, to] with to >= from",
        ));
    }
    if !(l.length.is_finite() && l.length > 0.0) {
        return Err(invalid(f("length"), l.length, "a positive length"));
    }
    if l.sticks == 0 || l.sticks > MAX_STICKS {
        return Err(invalid(
            f("sticks"),
            l.sticks,
            &format!("1 to {MAX_STICKS} sticks"),
        ));
    }
    if !(l.width.iter().all(|w| w.is_finite() && *w >= 0.0) && l.width[0] > 0.0) {
        return Err(invalid(
            f("width"),
            format!("{:?}", l.width),
            "[root, tip] with root > 0 and tip >= 0",
        ));
    }
    if !(l.droop.is_finite() && (0.0..=1.0).contains(&l.droop)) {
        return Err(invalid(f("droop"), l.droop, "a share in [0, 1]"));
    }
    if !(l.curl.is_finite() && l.curl.abs() <= 180.0) {
        return Err(invalid(
            f("curl"),
            l.curl,
            "degrees per stick in [-180, 180]",
        ));
    }
    if !(l.stiffness.is_finite() && l.stiffness >= 0.0) {
        return Err(invalid(f("stiffness"), l.stiffness, "a multiplier >= 0"));
    }
    if !l
        .color
        .iter()
        .all(|c| c.is_finite() && (0.0..=1.0).contains(c))
    {
        return Err(invalid(
            f("color"),
            format!("{:?}", l.color),
            "linear RGB in [0, 1]",
        ));
    }
    Ok(())
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

/// The rest strips of the scene's layers, in layer order (strip index = position here).
pub fn build(strips: &Strips, head: &Head) -> Result<Vec<RestStrip>> {
    if !head.radii.iter().all(|r| r.is_finite() && *r > 0.0)
        || !head.center.iter().all(|c| c.is_finite())
    {
        return Err(invalid(
            "head".into(),
            format!("center {:?} radii {:?}", head.center, head.radii),
            "finite centre and positive radii",
        ));
    }
    let total: u64 = strips.layers.iter().map(|l| l.count as u64).sum();
    if total > MAX_STRIPS {
        return Err(invalid(
            "strips.layers[*].count".into(),
            total,
            &format!("at most {MAX_STRIPS} strips in all"),
        ));
    }
    for (i, l) in strips.layers.iter().enumerate() {
        check_layer(i, l)?;
    }
    let hull = Ellipsoid::new(head.center, head.radii);
    let mean_radius = hull.radii.element_sum() / 3.0;
    let mut out = Vec::with_capacity(total as usize);
    for (li, layer) in strips.layers.iter().enumerate() {
        let margin = (1 + li) as f64 * SHELL * mean_radius;
        let shell = Ellipsoid {
            center: hull.center,
            radii: hull.radii + DVec3::splat(margin),
        };
        for az in azimuths(layer) {
            out.push(strip(&hull, &shell, layer, li as u32, az));
        }
    }
    Ok(out)
}

/// One strip of `layer` at azimuth `az` (degrees, as `Ellipsoid::point` measures it: from
/// +x, the face, toward +z).
fn strip(hull: &Ellipsoid, shell: &Ellipsoid, layer: &Layer, li: u32, az: f64) -> RestStrip {
    let (theta, phi) = (layer.polar.to_radians(), az.to_radians());
    let dir = DVec3::new(
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    );
    let root = hull.center + hull.radii * dir;
    let normal = hull.normal(root);
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
