//! The reference scene `kami bench look` hands the path tracer: Mitsuba 3 XML (camera, key
//! light, environment, shapes), `bsplinecurve` text files of the strands and OBJ meshes of
//! the head and skin, guarded by `tests/it/look.rs`; and the single fibre that checks
//! Mitsuba's `hair` BSDF reads the written curves as Kami's f64 reference does
//! ([`write_fibre_check`]).

use crate::error::{KamiError, Result};
use crate::formats::Groom;
use crate::gpu::gpu_data::linear_rgb;
use crate::stage::camera::Camera;
use crate::systems::Scene;
use glam::DVec3;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// The parameters of Mitsuba's `hair` BSDF for one group of strands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MitsubaHair {
    /// Pigment concentrations (Mitsuba's `eumelanin`, `pheomelanin`).
    pub eumelanin: f64,
    pub pheomelanin: f64,
    /// Longitudinal and azimuthal roughness (`longitudinal_roughness`, `azimuthal_roughness`).
    pub beta_m: f64,
    pub beta_n: f64,
    /// Cuticle scale tilt in degrees (`scale_tilt`).
    pub alpha_deg: f64,
    /// Index of refraction of the fibre (`int_ior`; `ext_ior` is written 1, Kami's air,
    /// where Mitsuba's default is 1.000277).
    pub eta: f64,
}

impl MitsubaHair {
    /// The same material as Kami's f64 reference takes it.
    pub fn params(&self) -> crate::systems::hair_bsdf::HairParams {
        crate::systems::hair_bsdf::HairParams {
            eumelanin: self.eumelanin,
            pheomelanin: self.pheomelanin,
            beta_m: self.beta_m,
            beta_n: self.beta_n,
            alpha: self.alpha_deg,
            eta: self.eta,
        }
    }
}

/// Mitsuba's own defaults for its `hair` BSDF (Chiang et al. 2016's brown hair): eumelanin
/// 1.3, pheomelanin 0.2, beta_m = beta_n = 0.3, alpha 2 degrees, eta 1.55.
pub const MITSUBA_DEFAULT_HAIR: MitsubaHair = MitsubaHair {
    eumelanin: 1.3,
    pheomelanin: 0.2,
    beta_m: 0.3,
    beta_n: 0.3,
    alpha_deg: 2.0,
    eta: 1.55,
};

/// The reference's BSDF for the strands drawn in `rgb` (Kami's sRGB colour of the group, as
/// the export writes it: strands are grouped by it): the physical look of the first group
/// drawn in that colour (an Anjyo group's `material`, a fur coat's `material`, the strips'
/// `look`), as `hair_bsdf::Physical::hair` gives it to Kami's physical mode. Every row is
/// compared with this one reference, whatever Kami's row shades with. A colour no group
/// has (none should) gets Mitsuba's default brown hair ([`MITSUBA_DEFAULT_HAIR`]).
pub fn hair_params(scene: &Scene, rgb: [f32; 3]) -> MitsubaHair {
    let near = |c: [f32; 3]| c.iter().zip(rgb).all(|(a, b)| (a - b).abs() <= 1.0 / 255.0);
    let physical = scene
        .groups()
        .iter()
        .map(|g| (g.material.color, &g.material.physical))
        .chain(
            scene
                .fur()
                .iter()
                .flat_map(|f| &f.coats)
                .map(|c| (c.material.diffuse, &c.material.physical)),
        )
        .chain(
            scene
                .strips()
                .iter()
                .flat_map(|s| s.layers.iter().map(move |l| (l.color, &s.look.physical))),
        )
        .find(|(c, _)| near(*c));
    let Some((color, physical)) = physical else {
        return MITSUBA_DEFAULT_HAIR;
    };
    let h = physical.hair(color);
    MitsubaHair {
        eumelanin: h.eumelanin,
        pheomelanin: h.pheomelanin,
        beta_m: h.beta_m,
        beta_n: h.beta_n,
        alpha_deg: h.alpha,
        eta: h.eta,
    }
}

/// Kami's ambient as the reference's uniform environment: the radiance a Lambertian of the
/// head's colour needs to get the head shader's ambient term (0.3 x ambient, `head.wgsl`).
pub use crate::systems::hair_bsdf::AMBIENT_RADIANCE;

/// The directional light's irradiance: pi x intensity x colour, so a white Lambertian facing
/// the light reflects `intensity` (Kami's unit light).
pub fn irradiance(scene: &Scene) -> [f64; 3] {
    let l = &scene.light;
    l.color
        .map(|c| std::f64::consts::PI * l.intensity * f64::from(c))
}

/// The uniform environment's radiance (see [`AMBIENT_RADIANCE`]).
pub fn environment(scene: &Scene) -> [f64; 3] {
    let l = &scene.light;
    l.color.map(|c| AMBIENT_RADIANCE * l.ambient * f64::from(c))
}

/// The Mitsuba shape the strands are written as. Mitsuba's `hair` BSDF takes the fibre's
/// axis to be its shading frame's second axis (`sin theta = w.y`), which `bsplinecurve`
/// sets to the curve's tangent; `linearcurve` puts the tangent in the first axis, so on it
/// the BSDF scatters as if the fibre ran around its own circumference (on one fibre, 0.27 to
/// 3.6 times what it gives on a `bsplinecurve`, which is Kami's f64 S within 0.5 %:
/// docs/look.md, "The reference's fibres lay crosswise"). [`write_fibre_check`] guards it.
pub const CURVE_SHAPE: &str = "bsplinecurve";

/// Mitsuba's `bsplinecurve` text of the strands `which` of `groom`: per control point
/// `x y z radius` (radius = width / 2, scene units), a blank line between curves. The
/// polyline's points are the control points of a uniform cubic B-spline, the root and tip
/// three times and every other point twice: the spline then starts at the root and ends at
/// the tip, runs straight along the middle two thirds of every segment and rounds each joint
/// within 1/48 of the neighbouring segments' difference (|a - 2b + c| / 48 from b), with no
/// zero tangent inside the strand.
pub fn curve_text(groom: &Groom, which: &[usize], source: &str) -> Result<String> {
    let widths = groom.widths.as_ref().ok_or_else(|| KamiError::Data {
        path: source.into(),
        line: None,
        message: "the exported groom has no widths: the path tracer needs a radius per point"
            .into(),
    })?;
    if !matches!(groom.basis, crate::formats::curves::Basis::Linear) {
        return Err(KamiError::Data {
            path: source.into(),
            line: None,
            message: format!(
                "the exported groom's basis is {:?}; the reference writes polylines only",
                groom.basis
            ),
        });
    }
    let mut first = Vec::with_capacity(groom.counts.len() + 1);
    let mut at = 0usize;
    for &c in &groom.counts {
        first.push(at);
        at += c as usize;
    }
    if at != groom.points.len() || widths.len() != at {
        return Err(KamiError::Data {
            path: source.into(),
            line: None,
            message: format!(
                "the exported groom's counts sum to {at}, but it has {} points and {} widths",
                groom.points.len(),
                widths.len()
            ),
        });
    }
    let mut s = String::new();
    for (k, &i) in which.iter().enumerate() {
        if k > 0 {
            s.push('\n');
        }
        let n = groom.counts[i] as usize;
        if n < 2 {
            return Err(KamiError::Data {
                path: source.into(),
                line: None,
                message: format!(
                    "the exported groom's strand {i} has {n} point(s); a strand needs 2"
                ),
            });
        }
        let r = first[i]..first[i] + n;
        for (j, (p, w)) in groom.points[r.clone()].iter().zip(&widths[r]).enumerate() {
            let times = if j == 0 || j + 1 == n { 3 } else { 2 };
            for _ in 0..times {
                let _ = writeln!(s, "{} {} {} {}", p[0], p[1], p[2], 0.5 * w);
            }
        }
    }
    Ok(s)
}

/// A triangle mesh as OBJ with per-vertex normals.
fn obj_text(positions: &[DVec3], normals: &[DVec3], triangles: &[[u32; 3]]) -> String {
    let mut s = String::new();
    for p in positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for n in normals {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in triangles {
        let [a, b, c] = t.map(|i| i + 1);
        let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
    }
    s
}

/// The head ellipsoid as drawn (`stage::head::DRAWN_SCALE` inside the hull), a latitude-
/// longitude mesh fine enough that its facets are under a pixel at the bench's size.
fn ellipsoid_mesh(center: DVec3, radii: DVec3) -> (Vec<DVec3>, Vec<DVec3>, Vec<[u32; 3]>) {
    let (rings, segs) = (96u32, 192u32);
    let r = radii * crate::stage::head::DRAWN_SCALE;
    let (mut p, mut n, mut t) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..=rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..=segs {
            let ph = std::f64::consts::TAU * j as f64 / segs as f64;
            let u = DVec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            p.push(center + u * r);
            n.push((u / r).normalize());
        }
    }
    let w = segs + 1;
    for i in 0..rings {
        for j in 0..segs {
            let (a, b, c, d) = (
                i * w + j,
                i * w + j + 1,
                (i + 1) * w + j,
                (i + 1) * w + j + 1,
            );
            t.push([a, c, b]);
            t.push([b, c, d]);
        }
    }
    (p, n, t)
}

fn rgb(c: [f64; 3]) -> String {
    format!("{}, {}, {}", c[0], c[1], c[2])
}

fn lin(c: [f32; 3]) -> [f64; 3] {
    linear_rgb(c).map(f64::from)
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Path-tracer settings: samples per pixel and the longest path.
pub const MAX_DEPTH: u32 = 24;

/// Write the reference scene for `scene`'s `groom` (exported by Kami at the compared frame)
/// into `dir`: `scene.xml` (camera, key light, environment, shapes) and the files it names
/// (`hair_N.txt` per colour group, `head.obj`, `skin.obj`). Returns the XML's path.
///
/// The camera is Kami's (`perspective`, `fov_axis` y, `look_at` eye/target/up, the same
/// image size); the key light a `directional` emitter shining along `-light.direction` with
/// [`irradiance`]; Kami's ambient a `constant` environment of [`environment`] (hidden from
/// the camera: the script composites the background); hair strands of one colour share a
/// `hair` BSDF ([`hair_params`]); the head (ellipsoid or mesh) and fur's skin are `diffuse`
/// of their linear colours.
pub fn write_mitsuba(
    dir: &Path,
    scene: &Scene,
    groom: &Groom,
    size: (u32, u32),
    spp: u32,
    source: &str,
) -> Result<PathBuf> {
    let shapes = write_shapes(dir, scene, groom, None, source)?;
    write_view(dir, "scene.xml", scene, &shapes, size, spp)
}

/// Strands whose absorption (per-strand variation) differs are binned by its log per
/// channel, rounded to this step: one `hair` BSDF per bin, its sigma_a within 2.5 % of
/// every strand's in it.
pub const ABSORPTION_STEP: f64 = 0.05;

/// The bin of an absorption multiplier (`ABSORPTION_STEP`s of its log per channel).
fn absorption_bin(a: [f32; 3]) -> [i32; 3] {
    a.map(|x| (f64::from(x).max(1e-6).ln() / ABSORPTION_STEP).round() as i32)
}

/// Write the shapes' files of the reference (`hair_N.txt`, `head.obj`, `skin.obj`) into
/// `dir` and return the XML that names them, for [`write_view`]: one set of files serves
/// every camera and light the bench renders. `absorption` (per strand, where strands vary):
/// each strand's sigma_a against its group's; such strands go to the BSDF of their bin,
/// whose sigma_a is the group's ([`hair_params`]) times the bin's multiplier.
pub fn write_shapes(
    dir: &Path,
    scene: &Scene,
    groom: &Groom,
    absorption: Option<&[[f32; 3]]>,
    source: &str,
) -> Result<String> {
    std::fs::create_dir_all(dir).map_err(|source| KamiError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    if absorption.is_some_and(|a| a.len() != groom.counts.len()) {
        return Err(KamiError::Data {
            path: source.into(),
            line: None,
            message: format!(
                "{} strands drawn, but {} absorptions",
                groom.counts.len(),
                absorption.map_or(0, <[_]>::len)
            ),
        });
    }
    let mut x = String::new();
    // Strands grouped by colour (the export's colour of each strand's root) and absorption
    // bin, one BSDF each.
    type Key = ([f32; 3], [i32; 3]);
    let mut groups: Vec<(Key, Vec<usize>)> = Vec::new();
    let mut at = 0usize;
    for (i, &c) in groom.counts.iter().enumerate() {
        let col = groom
            .colors
            .as_ref()
            .and_then(|cs| cs.get(at).copied())
            .unwrap_or([0.5; 3]);
        at += c as usize;
        let key = (col, absorption.map_or([0; 3], |a| absorption_bin(a[i])));
        match groups.iter_mut().find(|(g, _)| *g == key) {
            Some((_, v)) => v.push(i),
            None => groups.push((key, vec![i])),
        }
    }
    for (k, ((col, bin), strands)) in groups.iter().enumerate() {
        let name = format!("hair_{k}.txt");
        write_file(&dir.join(&name), &curve_text(groom, strands, source)?)?;
        let h = hair_params(scene, *col);
        let pigment = if *bin == [0; 3] {
            melanin_xml(&h)
        } else {
            let base = h.params().sigma_a();
            let s: [f64; 3] =
                std::array::from_fn(|i| base[i] * (f64::from(bin[i]) * ABSORPTION_STEP).exp());
            format!("<rgb name=\"sigma_a\" value=\"{}\"/>", rgb(s))
        };
        x.push_str(&hair_shape(&name, &pigment, &h));
    }

    let mut mesh = |name: &str, (p, n, t): (Vec<DVec3>, Vec<DVec3>, Vec<[u32; 3]>), color| {
        write_file(&dir.join(name), &obj_text(&p, &n, &t))?;
        let _ = writeln!(
            x,
            "  <shape type=\"obj\">\n    <string name=\"filename\" value=\"{name}\"/>\n    <bsdf type=\"diffuse\">\n      <rgb name=\"reflectance\" value=\"{}\"/>\n    </bsdf>\n  </shape>",
            rgb(lin(color))
        );
        Result::Ok(())
    };
    if scene.head.visible {
        let m = match crate::scene::hull::head_mesh(&scene.head)? {
            Some(m) => (
                m.mesh.positions.clone(),
                m.mesh.normals.clone(),
                m.mesh.triangles.clone(),
            ),
            None => ellipsoid_mesh(
                DVec3::from(scene.head.center),
                DVec3::from(scene.head.radii),
            ),
        };
        mesh("head.obj", m, scene.head.color)?;
    }
    if let Some(fur) = scene.fur() {
        let setup = crate::systems::fur::setup::FurSetup::new(fur, scene.seed)?;
        let (p, n) = setup.posed_mesh(0.0);
        mesh("skin.obj", (p, n, setup.mesh.triangles.clone()), fur.skin)?;
    }
    Ok(x)
}

/// The pigment lines of a `hair` BSDF given by melanin.
fn melanin_xml(h: &MitsubaHair) -> String {
    format!(
        "<float name=\"eumelanin\" value=\"{}\"/>\n      <float name=\"pheomelanin\" value=\"{}\"/>",
        h.eumelanin, h.pheomelanin
    )
}

/// The XML of one shape of strands: the curve file `name` ([`curve_text`]) as
/// [`CURVE_SHAPE`] with a `hair` BSDF of `h`'s roughness, tilt and index and `pigment`'s
/// absorption.
fn hair_shape(name: &str, pigment: &str, h: &MitsubaHair) -> String {
    format!(
        "  <shape type=\"{CURVE_SHAPE}\">\n    <string name=\"filename\" value=\"{name}\"/>\n    <bsdf type=\"hair\">\n      {pigment}\n      <float name=\"longitudinal_roughness\" value=\"{}\"/>\n      <float name=\"azimuthal_roughness\" value=\"{}\"/>\n      <float name=\"scale_tilt\" value=\"{}\"/>\n      <float name=\"int_ior\" value=\"{}\"/>\n      <float name=\"ext_ior\" value=\"1\"/>\n    </bsdf>\n  </shape>\n",
        h.beta_m, h.beta_n, h.alpha_deg, h.eta
    )
}

/// The single fibre's radius and pixels across its image ([`write_fibre_check`]).
pub const FIBRE_RADIUS: f64 = 0.01;
pub const FIBRE_PIXELS: u32 = 32;

/// The directions towards the light the single-fibre check lights the fibre from, the fibre
/// along x and the camera on +z: in its normal plane from the front and at 45 degrees of
/// azimuth, out of it by 24 degrees, and from behind (transmission).
pub const FIBRE_LIGHTS: [[f64; 3]; 4] = [
    [0.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [0.5, 0.5, 1.0],
    [0.0, 0.3, -1.0],
];

/// Write `fibre_<k>.xml` and `fibre.txt` into `dir`: one straight fibre of `h` along x
/// (three points, so a joint is in it), written as the strands are ([`curve_text`],
/// [`hair_shape`]), seen by an orthographic camera on +z whose frame it crosses, lit only
/// by a `directional` light of unit irradiance towards `FIBRE_LIGHTS[k]`, direct light only
/// (paths of two vertices). The mean radiance over the fibre's pixels (alpha-weighted) is
/// then the far-field S of Kami's f64 reference (`hair_bsdf::Bsdf::radiance`) for the view
/// +z, that light and the tangent +x: `kami bench look` compares the two before it renders
/// a reference.
pub fn write_fibre_check(dir: &Path, h: &MitsubaHair, k: usize, spp: u32) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|source| KamiError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let w = (2.0 * FIBRE_RADIUS) as f32;
    let groom = Groom {
        counts: vec![3],
        points: vec![[-5.0, 0.0, 0.0], [0.5, 0.0, 0.0], [5.0, 0.0, 0.0]],
        widths: Some(vec![w; 3]),
        ..Default::default()
    };
    write_file(
        &dir.join("fibre.txt"),
        &curve_text(&groom, &[0], "the single-fibre check")?,
    )?;
    let to_light = DVec3::from(FIBRE_LIGHTS[k]).normalize();
    let half = 2.0 * FIBRE_RADIUS;
    let mut x = String::from("<scene version=\"3.0.0\">\n");
    let _ = writeln!(
        x,
        "  <integrator type=\"path\">\n    <integer name=\"max_depth\" value=\"2\"/>\n    <boolean name=\"hide_emitters\" value=\"true\"/>\n  </integrator>"
    );
    let _ = writeln!(
        x,
        "  <sensor type=\"orthographic\">\n    <transform name=\"to_world\">\n      <scale value=\"{half}, {half}, 1\"/>\n      <lookat origin=\"0.3, 0, 1\" target=\"0.3, 0, 0\" up=\"0, 1, 0\"/>\n    </transform>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{spp}\"/>\n    </sampler>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{FIBRE_PIXELS}\"/>\n      <integer name=\"height\" value=\"{FIBRE_PIXELS}\"/>\n      <string name=\"pixel_format\" value=\"rgba\"/>\n      <rfilter type=\"box\"/>\n    </film>\n  </sensor>"
    );
    let _ = writeln!(
        x,
        "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"1, 1, 1\"/>\n  </emitter>",
        rgb((-to_light).to_array())
    );
    x.push_str(&hair_shape("fibre.txt", &melanin_xml(h), h));
    x.push_str("</scene>\n");
    let xml = dir.join(format!("fibre_{k}.xml"));
    write_file(&xml, &x)?;
    Ok(xml)
}

/// Write `name` in `dir`: the scene XML of `scene`'s camera and light (see
/// [`write_mitsuba`]) around `shapes` (from [`write_shapes`] into the same `dir`).
pub fn write_view(
    dir: &Path,
    name: &str,
    scene: &Scene,
    shapes: &str,
    size: (u32, u32),
    spp: u32,
) -> Result<PathBuf> {
    let cam = Camera::from_desc(&scene.camera);
    let dist = (cam.target - cam.eye).length().max(1e-6);
    let mut x = String::from("<scene version=\"3.0.0\">\n");
    let _ = writeln!(
        x,
        "  <integrator type=\"path\">\n    <integer name=\"max_depth\" value=\"{MAX_DEPTH}\"/>\n    <boolean name=\"hide_emitters\" value=\"true\"/>\n  </integrator>"
    );
    let _ = writeln!(
        x,
        "  <sensor type=\"perspective\">\n    <string name=\"fov_axis\" value=\"y\"/>\n    <float name=\"fov\" value=\"{}\"/>\n    <float name=\"near_clip\" value=\"{}\"/>\n    <float name=\"far_clip\" value=\"{}\"/>\n    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{spp}\"/>\n    </sampler>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      <integer name=\"height\" value=\"{}\"/>\n      <string name=\"pixel_format\" value=\"rgba\"/>\n      <rfilter type=\"box\"/>\n    </film>\n  </sensor>",
        cam.fov_y.to_degrees(),
        dist * 1e-3,
        dist * 1e3,
        rgb(cam.eye.to_array()),
        rgb(cam.target.to_array()),
        rgb(cam.up.to_array()),
        size.0,
        size.1
    );
    let to_light = DVec3::from(scene.light.direction).normalize();
    let _ = writeln!(
        x,
        "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
        rgb((-to_light).to_array()),
        rgb(irradiance(scene))
    );
    let _ = writeln!(
        x,
        "  <emitter type=\"constant\">\n    <rgb name=\"radiance\" value=\"{}\"/>\n  </emitter>",
        rgb(environment(scene))
    );

    x.push_str(shapes);
    x.push_str("</scene>\n");
    let xml = dir.join(name);
    write_file(&xml, &x)?;
    Ok(xml)
}
