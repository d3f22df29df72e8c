//! `kami bench look`: Kami's image of shipped scenes against a path tracer's (Mitsuba 3, its
//! `hair` BSDF after Chiang et al. 2016) of the same groom, camera, lights and size: mean
//! FLIP and Kami's ms per frame for every shading mode x shadows row, and the image pairs.
//!
//! Kami writes the reference scene here (Mitsuba XML, `linearcurve` text files, OBJ meshes:
//! [`write_mitsuba`], guarded by `tests/it/look.rs`); `scripts/look_reference.py` renders it,
//! caches it and computes FLIP. Mitsuba and FLIP are bench dependencies only
//! (`scripts/look-deps.sh`); `cargo test` needs neither.

use super::{provenance, write_report, Report};
use crate::error::{KamiError, Result};
use crate::formats::Groom;
use crate::gpu::gpu_data::linear_rgb;
use crate::gpu::timing::PassTimes;
use crate::gpu::Gpu;
use crate::scene::{ShadowMethod, Shadows};
use crate::stage::camera::Camera;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::Scene;
use glam::DVec3;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The shipped scenes compared: the bob (strand hair on the ellipsoid), fur on the critter
/// (its skin in the reference too) and the strips.
pub const SCENES: [&str; 3] = [
    "assets/scenes/bob.ron",
    "assets/scenes/fur_polyline.ron",
    "assets/scenes/strips.ron",
];

/// The layered offsets the offsets table compares (cells).
pub const OFFSETS: [f64; 4] = [0.0, 1.0, 2.0, 3.0];

/// A shading mode of Kami's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    /// Anjyo et al. 1992 eqs 8-9 (the paper scenes' default).
    Anjyo,
    /// The physically based mode (R, TT, TRT; melanin).
    Physical,
}

impl Shading {
    pub fn name(self) -> &'static str {
        match self {
            Shading::Anjyo => "anjyo",
            Shading::Physical => "physical",
        }
    }
}

/// The rows of every scene: each shading mode without and with shadows.
pub const ROWS: [(Shading, bool); 4] = [
    (Shading::Anjyo, false),
    (Shading::Anjyo, true),
    (Shading::Physical, false),
    (Shading::Physical, true),
];

/// Set `scene` up for one row: the scene's shading mode for every group (a group's own
/// choice is cleared so the row is what it says) and the shadows on or off with the
/// scene's method. Returns whether this build has the row (every row, now).
pub fn look_row(scene: &mut Scene, shading: Shading, shadows: bool) -> bool {
    scene.render.shading = match shading {
        Shading::Anjyo => crate::scene::Shading::Anjyo,
        Shading::Physical => crate::scene::Shading::Physical,
    };
    for g in scene.groups_mut() {
        g.material.shading = None;
    }
    if let Some(f) = scene.fur_mut().as_mut() {
        for c in &mut f.coats {
            c.material.shading = None;
        }
    }
    if let Some(s) = scene.strips_mut().as_mut() {
        s.look.shading = None;
    }
    scene.render.shadows.on = shadows;
    true
}

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

/// Mitsuba's `linearcurve` text of the strands `which` of `groom`: per control point
/// `x y z radius` (radius = width / 2, scene units), a blank line between curves.
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
        let r = first[i]..first[i] + groom.counts[i] as usize;
        for (p, w) in groom.points[r.clone()].iter().zip(&widths[r]) {
            let _ = writeln!(s, "{} {} {} {}", p[0], p[1], p[2], 0.5 * w);
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
    std::fs::create_dir_all(dir).map_err(|source| KamiError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
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

    // Strands grouped by colour (the export's colour of each strand's root), one BSDF each.
    let mut groups: Vec<([f32; 3], Vec<usize>)> = Vec::new();
    let mut at = 0usize;
    for (i, &c) in groom.counts.iter().enumerate() {
        let col = groom
            .colors
            .as_ref()
            .and_then(|cs| cs.get(at).copied())
            .unwrap_or([0.5; 3]);
        at += c as usize;
        match groups.iter_mut().find(|(g, _)| *g == col) {
            Some((_, v)) => v.push(i),
            None => groups.push((col, vec![i])),
        }
    }
    for (k, (col, strands)) in groups.iter().enumerate() {
        let name = format!("hair_{k}.txt");
        write_file(&dir.join(&name), &curve_text(groom, strands, source)?)?;
        let h = hair_params(scene, *col);
        let _ = writeln!(
            x,
            "  <shape type=\"linearcurve\">\n    <string name=\"filename\" value=\"{name}\"/>\n    <bsdf type=\"hair\">\n      <float name=\"eumelanin\" value=\"{}\"/>\n      <float name=\"pheomelanin\" value=\"{}\"/>\n      <float name=\"longitudinal_roughness\" value=\"{}\"/>\n      <float name=\"azimuthal_roughness\" value=\"{}\"/>\n      <float name=\"scale_tilt\" value=\"{}\"/>\n      <float name=\"int_ior\" value=\"{}\"/>\n      <float name=\"ext_ior\" value=\"1\"/>\n    </bsdf>\n  </shape>",
            h.eumelanin, h.pheomelanin, h.beta_m, h.beta_n, h.alpha_deg, h.eta
        );
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
        let mats = setup.joint_matrices(0.0);
        let (p, n): (Vec<DVec3>, Vec<DVec3>) = (0..setup.mesh.positions.len())
            .map(|v| setup.vertex_at(v, 0.0, mats.as_deref()))
            .unzip();
        mesh("skin.obj", (p, n, setup.mesh.triangles.clone()), fur.skin)?;
    }
    x.push_str("</scene>\n");
    let xml = dir.join("scene.xml");
    write_file(&xml, &x)?;
    Ok(xml)
}

/// One drawn row: Kami's image and its frame time.
pub struct Drawn {
    pub image: image::RgbaImage,
    pub ms: f64,
    /// "gpu-timestamps" or "cpu-wait".
    pub clock: &'static str,
}

/// Draw frame 0 of `scene` at `size`: one untimed frame, then the mean of `frames` frames
/// (generation, draw and resolve; no simulation) from GPU timestamps where the adapter has
/// them, else the CPU clock around a wait.
pub fn draw(gpu: &Gpu, scene: &Scene, size: (u32, u32), frames: u32) -> Result<Drawn> {
    stage::check_limits(gpu, scene, size)?;
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene))?;
    stage.seek(gpu, 0)?;
    let timed = stage.enable_timing(gpu);
    let out = target::Offscreen::new(gpu, size)?;
    let look = stage.look();
    let mut ms = Vec::new();
    for f in 0..=frames {
        let t = Instant::now();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.render(gpu, &mut enc, &out.view, size, &look)?;
        let mut times = None::<PassTimes>;
        if timed {
            let timer = stage.timer().expect("timing enabled");
            timer.clear();
            timer.finish(&mut enc);
            gpu.queue.submit([enc.finish()]);
            timer.submitted();
            times = timer.wait(gpu)?;
        } else {
            gpu.queue.submit([enc.finish()]);
        }
        gpu.wait()?;
        let wall = t.elapsed().as_secs_f64() * 1e3;
        if f > 0 {
            ms.push(times.map_or(wall, |t| t.frame.unwrap_or_else(|| t.busy())));
        }
    }
    let image = out.read_rgba(gpu)?;
    gpu.take_error()?;
    Ok(Drawn {
        image,
        ms: ms.iter().sum::<f64>() / ms.len().max(1) as f64,
        clock: if timed { "gpu-timestamps" } else { "cpu-wait" },
    })
}

/// Bench options.
pub struct Options {
    pub scenes: Vec<PathBuf>,
    pub size: (u32, u32),
    pub spp: u32,
    pub frames: u32,
    pub python: PathBuf,
    pub cache: PathBuf,
}

/// The instructions printed when Mitsuba or FLIP is missing.
pub const DEPS: &str = "kami bench look needs Mitsuba 3 and FLIP for Python: run \
    scripts/look-deps.sh (pip install mitsuba flip-evaluator numpy), or name another \
    interpreter with --python";

fn script() -> PathBuf {
    crate::scene::shipped("scripts/look_reference.py")
}

/// Fails with [`DEPS`] unless `python` imports Mitsuba, FLIP and numpy.
pub fn check_deps(python: &Path) -> Result<()> {
    let out = std::process::Command::new(python)
        .args(["-c", "import mitsuba, flip_evaluator, numpy"])
        .output();
    match out {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(KamiError::Data {
            path: python.display().to_string(),
            line: None,
            message: format!(
                "{DEPS} ({})",
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("import failed")
            ),
        }),
        Err(e) => Err(KamiError::Data {
            path: python.display().to_string(),
            line: None,
            message: format!("{DEPS} (cannot run it: {e})"),
        }),
    }
}

/// What the script printed for one row.
struct Compared {
    flip: f64,
    noise: f64,
    reference_s: f64,
    cached: bool,
}

fn compare(o: &Options, xml: &Path, scene: &Scene, kami: &Path, pair: &Path) -> Result<Compared> {
    let bg = scene.render.background;
    let err = |message: String| KamiError::Data {
        path: script().display().to_string(),
        line: None,
        message,
    };
    let out = std::process::Command::new(&o.python)
        .arg(script())
        .arg("--xml")
        .arg(xml)
        .arg("--background")
        .arg(format!("{},{},{}", bg[0], bg[1], bg[2]))
        .arg("--spp")
        .arg(o.spp.to_string())
        .arg("--kami")
        .arg(kami)
        .arg("--pair")
        .arg(pair)
        .arg("--cache")
        .arg(&o.cache)
        .output()
        .map_err(|e| err(format!("cannot run {}: {e}", o.python.display())))?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        return Err(err(format!(
            "failed on {}: {}{}",
            xml.display(),
            text,
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    let line = text
        .lines()
        .rfind(|l| l.starts_with("flip="))
        .ok_or_else(|| err(format!("printed no result line: {text}")))?;
    let get = |key: &str| -> Result<f64> {
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(key))
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| err(format!("no number for {key} in {line:?}")))
    };
    Ok(Compared {
        flip: get("flip=")?,
        noise: get("noise=")?,
        reference_s: get("reference_s=")?,
        cached: get("cached=")? > 0.5,
    })
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into())
}

/// Run the bench; writes `look.md`, `look.csv` and the image pairs
/// (`<scene>_<mode>_<shadows>.png`) into `out`, and each reference scene with Kami's images
/// into `<cache>/scene_<scene>/`.
pub fn run(gpu: &Gpu, o: &Options, out: &Path) -> Result<Report> {
    check_deps(&o.python)?;
    std::fs::create_dir_all(out).map_err(|source| KamiError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "### `kami bench look`\n\n{}\n\nAdapter: **{}**. Each scene at frame 0, {}x{} pixels, with its own MSAA and supersampling. *ms*: Kami's frame (generation, draw, resolve), the mean of {} frames after one untimed. *FLIP*: mean FLIP (LDR, 67 pixels per degree) of Kami's image against Mitsuba 3 (`scalar_rgb`, `path` integrator, `hair` BSDF, {} spp, longest path {MAX_DEPTH}); *noise*: the same between two seeds of the reference. *reference s*: Mitsuba's time for both seeds (as recorded when rendered; `cached` in the CSV says whether this run took them from `--cache`).\n",
        provenance(),
        gpu.describe(),
        o.size.0,
        o.size.1,
        o.frames,
        o.spp
    );
    let _ = writeln!(
        md,
        "| scene | shading | shadows | ms per frame | clock | FLIP | noise | reference s |"
    );
    let _ = writeln!(md, "|---|---|---|---:|---|---:|---:|---:|");
    let mut csv =
        String::from("scene,shading,shadows,ms,clock,flip,noise,reference_s,cached,pair\n");
    // The layered offset (`stage::shadow::layered_offset`) of scenes with Anjyo's strands:
    // FLIP for each method, shading mode and offset, shadows on.
    let mut md_off = format!(
        "### `kami bench look`: the layered offset\n\n{}\n\nAdapter: **{}**. Mean FLIP against the same references as look.md, shadows on, for scenes with Anjyo's strands, as `render.shadows.layered_offset` (cells of the box's size / 64) moves where those strands read the shadow structure; *default*: the method's own offset.\n\n| scene | method | shading | offset | default | FLIP |\n|---|---|---|---:|---|---:|\n",
        provenance(),
        gpu.describe()
    );
    let mut csv_off = String::from("scene,method,shading,offset,default,flip\n");
    for path in &o.scenes {
        let base = Scene::load(path)?;
        let name = stem(path);
        // The groom as Kami holds it at frame 0 (the reference is the same for every row).
        let groom = stage::export_scene(gpu, &base, 0)?;
        // The reference scene (tens of MB of curves) goes beside the cache, not into `out`.
        let work = o.cache.join(format!("scene_{name}"));
        let xml = write_mitsuba(
            &work,
            &base,
            &groom,
            o.size,
            o.spp,
            &path.display().to_string(),
        )?;
        if !base.groups().is_empty() {
            for method in [ShadowMethod::Volume, ShadowMethod::DeepOpacity] {
                for shading in [Shading::Anjyo, Shading::Physical] {
                    for k in OFFSETS {
                        let mut scene = base.clone();
                        look_row(&mut scene, shading, true);
                        scene.render.shadows.method = method;
                        scene.render.shadows.layered_offset = Some(k);
                        let own = stage::shadow::layered_offset(&Shadows {
                            layered_offset: None,
                            ..scene.render.shadows
                        });
                        let d = draw(gpu, &scene, o.size, 1)?;
                        let row = format!("{name}_{}_{method:?}_{k}", shading.name());
                        let kami = work.join(format!("kami_offset_{row}.png"));
                        d.image.save(&kami).map_err(|e| KamiError::Image {
                            path: kami.clone(),
                            message: e.to_string(),
                        })?;
                        let pair = work.join(format!("pair_offset_{row}.png"));
                        let c = compare(o, &xml, &scene, &kami, &pair)?;
                        let default = if k == own { "yes" } else { "" };
                        let _ = writeln!(
                            md_off,
                            "| {name} | {method:?} | {} | {k} | {default} | {:.3} |",
                            shading.name(),
                            c.flip
                        );
                        let _ = writeln!(
                            csv_off,
                            "{name},{method:?},{},{k},{},{:.5}",
                            shading.name(),
                            u8::from(k == own),
                            c.flip
                        );
                    }
                }
            }
        }
        for (shading, shadows) in ROWS {
            let sh = if shadows { "on" } else { "off" };
            let mut scene = base.clone();
            if !look_row(&mut scene, shading, shadows) {
                let _ = writeln!(
                    md,
                    "| {name} | {} | {sh} | — | — | — | — | — |",
                    shading.name()
                );
                let _ = writeln!(csv, "{name},{},{sh},,,,,,,", shading.name());
                continue;
            }
            let d = draw(gpu, &scene, o.size, o.frames)?;
            let row = format!("{name}_{}_{sh}", shading.name());
            let kami = work.join(format!("kami_{row}.png"));
            d.image.save(&kami).map_err(|e| KamiError::Image {
                path: kami.clone(),
                message: e.to_string(),
            })?;
            let pair = out.join(format!("{row}.png"));
            let c = compare(o, &xml, &scene, &kami, &pair)?;
            let _ = writeln!(
                md,
                "| {name} | {} | {sh} | {:.2} | {} | {:.3} | {:.3} | {:.0} |",
                shading.name(),
                d.ms,
                d.clock,
                c.flip,
                c.noise,
                c.reference_s
            );
            let _ = writeln!(
                csv,
                "{name},{},{sh},{:.4},{},{:.5},{:.5},{:.1},{},{row}.png",
                shading.name(),
                d.ms,
                d.clock,
                c.flip,
                c.noise,
                c.reference_s,
                u8::from(c.cached)
            );
        }
    }
    let _ = writeln!(
        md,
        "\n— : a mode this build does not have. Pairs: `<scene>_<shading>_<shadows>.png` (Kami | Mitsuba | FLIP map)."
    );
    write_report(out, "look", &md, &csv)?;
    write_report(out, "look_offsets", &md_off, &csv_off)?;
    Ok(Report { markdown: md, csv })
}
