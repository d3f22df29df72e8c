//! `kami bench look`: Kami's image of shipped scenes against a path tracer's (Mitsuba 3, its
//! `hair` BSDF after Chiang et al. 2016) of the same groom, camera, lights and size: mean
//! FLIP and Kami's ms per frame for every shading mode x shadows row, and the image pairs.
//!
//! Kami writes the reference scene here (Mitsuba XML, `bsplinecurve` text files, OBJ meshes:
//! [`write_mitsuba`], guarded by `tests/it/look.rs`); `scripts/look_reference.py` renders it,
//! caches it and computes FLIP. Before any reference, [`fibre_check`] has Mitsuba render one
//! fibre written the same way and refuses to go on unless it matches Kami's f64 BSDF. Mitsuba and FLIP are bench dependencies only
//! (`scripts/look-deps.sh`); `cargo test` needs neither.

pub mod hair;
mod mitsuba;
mod views;

pub use mitsuba::*;
pub use views::{close_up, lit, Lighting, View, CLOSE_SHARE, LIGHT_RISE};

use super::{provenance, write_report, Report};
use crate::error::{KamiError, Result};
use crate::gpu::timing::PassTimes;
use crate::gpu::Gpu;
use crate::scene::{ShadowMethod, Shadows};
use crate::stage::{self, target, Quality, Stage};
use crate::systems::Scene;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The shipped scenes compared: the bob (strand hair on the ellipsoid) plain and with
/// per-strand variation, fur on the critter (its skin in the reference too) and the strips.
pub const SCENES: [&str; 4] = [
    "assets/scenes/bob.ron",
    "assets/scenes/bob_varied.ron",
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
/// scene's method.
pub fn look_row(scene: &mut Scene, shading: Shading, shadows: bool) {
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
}

/// One drawn row: Kami's image and its frame time.
pub struct Drawn {
    pub image: image::RgbaImage,
    pub ms: f64,
    /// "gpu-timestamps" or "cpu-wait".
    pub clock: &'static str,
    /// The hair as drawn (`Stage::export_drawn`), where asked for.
    pub hair: Option<crate::systems::system::DrawnHair>,
}

/// Draw frame 0 of `scene` at `size`: one untimed frame, then the mean of `frames` frames
/// (generation, draw and resolve; no simulation) from GPU timestamps where the adapter has
/// them, else the CPU clock around a wait; with `export`, the hair as drawn too.
pub fn draw(
    gpu: &Gpu,
    scene: &Scene,
    size: (u32, u32),
    frames: u32,
    export: bool,
) -> Result<Drawn> {
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
    let hair = if export {
        Some(stage.export_drawn(gpu)?)
    } else {
        None
    };
    gpu.take_error()?;
    Ok(Drawn {
        image,
        ms: ms.iter().sum::<f64>() / ms.len().max(1) as f64,
        clock: if timed { "gpu-timestamps" } else { "cpu-wait" },
        hair,
    })
}

/// The hair one untimed frame of `scene` at `size` draws, as strands (what the reference
/// gets: `Stage::export_drawn`).
pub fn drawn_hair(
    gpu: &Gpu,
    scene: &Scene,
    size: (u32, u32),
) -> Result<crate::systems::system::DrawnHair> {
    Ok(draw(gpu, scene, size, 0, true)?
        .hair
        .expect("draw exports when asked"))
}

/// Bench options.
pub struct Options {
    pub scenes: Vec<PathBuf>,
    pub size: (u32, u32),
    /// The reference's samples per pixel to start from.
    pub spp: u32,
    /// The most samples per pixel a reference is raised to while its noise is not well
    /// below the goal ([`raised_spp`]).
    pub max_spp: u32,
    pub frames: u32,
    pub python: PathBuf,
    pub cache: PathBuf,
    /// The cameras (default both) and lights (default all three) rendered.
    pub views: Vec<View>,
    pub lights: Vec<Lighting>,
}

/// The instructions printed when Mitsuba or FLIP is missing.
pub const DEPS: &str = "kami bench look needs Mitsuba 3 and FLIP for Python: run \
    scripts/look-deps.sh (pip install mitsuba flip-evaluator numpy), or name another \
    interpreter with --python";

/// Silhouettes that overlap less than this (intersection over union of the two images'
/// hair-and-head masks) are unlike shapes: the report brackets their FLIP.
pub const MIN_OVERLAP: f64 = 0.8;

/// The goal of issue 36: FLIP over the hair's pixels in the physical mode.
pub const GOAL_FLIP: f64 = 0.10;

/// The reference's noise on the hair's pixels (FLIP between its two seeds) is well below
/// the goal at half of it: above that, the reference is rendered again with more samples.
pub const WELL_BELOW_GOAL: f64 = GOAL_FLIP / 2.0;

/// The samples per pixel to render a reference with next, after one at `spp` measured
/// `noise_hair`: twice as many while the noise is above [`WELL_BELOW_GOAL`] and that stays
/// within `max_spp`; None when it is well below, or more would pass `max_spp`.
pub fn raised_spp(noise_hair: f64, spp: u32, max_spp: u32) -> Option<u32> {
    let next = spp.checked_mul(2)?;
    (noise_hair > WELL_BELOW_GOAL && next <= max_spp).then_some(next)
}

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

/// Samples per pixel of the single-fibre check's renders.
pub const FIBRE_SPP: u32 = 1024;

/// The most the single fibre's radiance may differ from Kami's f64 S, relative, per channel.
/// Mitsuba's `hair` on a `bsplinecurve` is within 0.5 % of it; on a `linearcurve` 0.27 to 3.6
/// times it.
pub const FIBRE_TOLERANCE: f64 = 0.02;

/// Render the single fibre of [`write_fibre_check`] under each of [`FIBRE_LIGHTS`] with
/// Mitsuba (cached like the references) and compare its mean radiance with Kami's f64
/// `Bsdf::radiance` for the same view, light and tangent, Mitsuba's default brown hair. What
/// it guards is how the reference is written (the curve shape, its control points, the BSDF's
/// parameters and frame), on which every FLIP the bench reports depends. Returns the worst
/// relative difference; an error naming the light above [`FIBRE_TOLERANCE`].
pub fn fibre_check(o: &Options) -> Result<f64> {
    use crate::systems::hair_bsdf::Angles;
    let h = MITSUBA_DEFAULT_HAIR;
    let bsdf = h.params().bsdf();
    let dir = o.cache.join("fibre_check");
    let mut worst = 0.0f64;
    for (k, l) in FIBRE_LIGHTS.iter().enumerate() {
        let xml = write_fibre_check(&dir, &h, k, FIBRE_SPP)?;
        let err = |message: String| KamiError::Data {
            path: xml.display().to_string(),
            line: None,
            message,
        };
        let spp = FIBRE_SPP.to_string();
        let text = run_script(
            o,
            &[
                "--fibre".as_ref(),
                "--xml".as_ref(),
                xml.as_os_str(),
                "--spp".as_ref(),
                spp.as_ref(),
                "--cache".as_ref(),
                o.cache.as_os_str(),
            ],
        )
        .map_err(|m| err(format!("the single-fibre check failed: {m}")))?;
        let got: Vec<f64> = text
            .lines()
            .find_map(|l| l.strip_prefix("radiance="))
            .map(|v| v.split(',').filter_map(|x| x.trim().parse().ok()).collect())
            .unwrap_or_default();
        if got.len() != 3 || got.iter().any(|x: &f64| !x.is_finite()) {
            return Err(err(format!(
                "the single-fibre check printed no radiance: {text}"
            )));
        }
        let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
        let want = bsdf.radiance(&Angles::new(
            [0.0, 0.0, 1.0],
            l.map(|x| x / n),
            [1.0, 0.0, 0.0],
        ));
        for c in 0..3 {
            let rel = (got[c] - want[c]).abs() / want[c].abs().max(1e-12);
            worst = worst.max(rel);
            if rel > FIBRE_TOLERANCE {
                return Err(err(format!(
                    "Mitsuba's hair BSDF on the written curve gives {:.5}, {:.5}, {:.5} for one fibre lit from {l:?}, Kami's f64 reference {:.5}, {:.5}, {:.5} ({:.1} % off in channel {c}, more than {:.0} %): the reference would not be the material Kami shades (is the curve shape one whose shading frame Mitsuba's `hair` reads, `bsplinecurve`?)",
                    got[0], got[1], got[2], want[0], want[1], want[2], 100.0 * rel, 100.0 * FIBRE_TOLERANCE
                )));
            }
        }
    }
    Ok(worst)
}

/// One row's comparison: what the script printed (FLIP over the whole image beside the
/// reference's own noise, Mitsuba's time) and the figures over the hair's pixels
/// ([`hair::measure`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Compared {
    pub flip: f64,
    pub noise: f64,
    pub hair: hair::HairStats,
    pub reference_s: f64,
    pub cached: bool,
}

/// Read the script's result line (`flip=F noise=N reference_s=S cached=0|1`).
pub fn parse_compared(text: &str) -> std::result::Result<Compared, String> {
    let line = text
        .lines()
        .rfind(|l| l.starts_with("flip="))
        .ok_or_else(|| format!("printed no result line: {text}"))?;
    let get = |key: &str| -> std::result::Result<f64, String> {
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(key))
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("no number for {key} in {line:?}"))
    };
    Ok(Compared {
        flip: get("flip=")?,
        noise: get("noise=")?,
        hair: hair::HairStats::default(),
        reference_s: get("reference_s=")?,
        cached: get("cached=")? > 0.5,
    })
}

/// Run `scripts/look_reference.py` with `args` under `o.python`: its stdout, or what it
/// printed (stdout, then stderr) when it could not run or failed.
fn run_script(o: &Options, args: &[&std::ffi::OsStr]) -> std::result::Result<String, String> {
    let out = std::process::Command::new(&o.python)
        .arg(script())
        .args(args)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", o.python.display()))?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    if out.status.success() {
        Ok(text)
    } else {
        Err(format!("{text}{}", String::from_utf8_lossy(&out.stderr)))
    }
}

/// Compare Kami's `image` (saved at `kami`) with the reference of `xml`; the pair image
/// goes to `pair`, the script's maps beside `kami`.
fn compare(
    o: &Options,
    spp: u32,
    xml: &Path,
    scene: &Scene,
    (image, kami): (&image::RgbaImage, &Path),
    pair: &Path,
) -> Result<Compared> {
    let maps = kami.with_extension("maps");
    let bg = scene.render.background;
    let err = |message: String| KamiError::Data {
        path: script().display().to_string(),
        line: None,
        message,
    };
    let (background, spp) = (format!("{},{},{}", bg[0], bg[1], bg[2]), spp.to_string());
    let text = run_script(
        o,
        &[
            "--xml".as_ref(),
            xml.as_os_str(),
            "--background".as_ref(),
            background.as_ref(),
            "--spp".as_ref(),
            spp.as_ref(),
            "--kami".as_ref(),
            kami.as_os_str(),
            "--pair".as_ref(),
            pair.as_os_str(),
            "--cache".as_ref(),
            o.cache.as_os_str(),
            "--maps".as_ref(),
            maps.as_os_str(),
        ],
    )
    .map_err(|m| err(format!("failed on {}: {m}", xml.display())))?;
    let mut c = parse_compared(&text).map_err(err)?;
    c.hair = hair::measure(image, &maps, pair, bg)?;
    Ok(c)
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into())
}

fn save(image: &image::RgbaImage, path: &Path) -> Result<()> {
    image.save(path).map_err(|e| KamiError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// The shading x shadows rows under a light: all four under the scene's key light; under
/// the side and back lights shadows on only (what those lights test is light through and
/// behind the hair).
pub fn rows(lighting: Lighting) -> &'static [(Shading, bool)] {
    match lighting {
        Lighting::Key => &ROWS,
        Lighting::Side | Lighting::Back => &ROWS_LIT,
    }
}

/// The rows under the side and back lights.
pub const ROWS_LIT: [(Shading, bool); 2] = [(Shading::Anjyo, true), (Shading::Physical, true)];

/// One measured row of the report.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub view: View,
    pub lighting: Lighting,
    pub shading: Shading,
    pub shadows: bool,
    pub ms: f64,
    pub clock: &'static str,
    /// The reference's samples per pixel (the light's, raised while it was noisy).
    pub spp: u32,
    pub c: Compared,
    pub pair: String,
}

impl Row {
    /// A row of the goal: the physical mode with shadows on.
    pub fn is_goal(&self) -> bool {
        self.shading == Shading::Physical && self.shadows
    }

    fn key(&self) -> String {
        format!(
            "{}_{}_{}_{}_{}",
            self.scene,
            self.view.name(),
            self.lighting.name(),
            self.shading.name(),
            if self.shadows { "on" } else { "off" }
        )
    }
}

/// Run the bench; writes `look.md`, `look.csv`, the offsets table and the goal's rows' image
/// pairs (`<scene>_<view>_<light>_<mode>_<shadows>.png`) into `out`, and each reference
/// scene with Kami's images and the other pairs into `<cache>/scene_<scene>/<view>/`.
pub fn run(gpu: &Gpu, o: &Options, out: &Path) -> Result<Report> {
    check_deps(&o.python)?;
    let fibre = fibre_check(o)?;
    std::fs::create_dir_all(out).map_err(|source| KamiError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let mut rows_out: Vec<Row> = Vec::new();
    let mut offsets: Vec<(String, ShadowMethod, Shading, f64, bool, Compared)> = Vec::new();
    for path in &o.scenes {
        let base = Scene::load(path)?;
        let name = stem(path);
        let source = path.display().to_string();
        let aspect = f64::from(o.size.0) / f64::from(o.size.1);
        // The close-up is aimed at the strands as they stand at frame 0.
        let rest = stage::export_scene(gpu, &base, 0)?;
        for &view in &o.views {
            let mut framed = base.clone();
            if view == View::Close {
                framed.camera = close_up(&base, &rest, aspect, &source)?;
            }
            // The reference draws the hair as Kami drew it from this camera (fur's culling,
            // strips' texture hairs); its files serve every light (tens of MB of curves, kept
            // beside the cache, not in `out`).
            let groom = drawn_hair(gpu, &framed, o.size)?;
            let work = o.cache.join(format!("scene_{name}")).join(view.name());
            let shapes = write_shapes(
                &work,
                &framed,
                &groom.groom,
                groom.absorption.as_deref(),
                &source,
            )?;
            for &lighting in &o.lights {
                let mut lit_scene = framed.clone();
                lit_scene.light = lit(&base, &framed.camera, lighting);
                let xml_name = format!("{}.xml", lighting.name());
                let xml = write_view(&work, &xml_name, &lit_scene, &shapes, o.size, o.spp)?;
                // Raised while the reference's noise is not well below the goal; the rows
                // after the first start where it ended.
                let mut spp = o.spp;
                for &(shading, shadows) in rows(lighting) {
                    let mut scene = lit_scene.clone();
                    look_row(&mut scene, shading, shadows);
                    let d = draw(gpu, &scene, o.size, o.frames, false)?;
                    let mut row = Row {
                        scene: name.clone(),
                        view,
                        lighting,
                        shading,
                        shadows,
                        ms: d.ms,
                        clock: d.clock,
                        spp,
                        c: Compared::default(),
                        pair: String::new(),
                    };
                    row.pair = format!("{}.png", row.key());
                    let kami = work.join(format!("kami_{}", row.pair));
                    save(&d.image, &kami)?;
                    // The goal's rows' pairs go to `out`; the others stay beside the cache.
                    let pair = if row.is_goal() {
                        out.join(&row.pair)
                    } else {
                        work.join(format!("pair_{}", row.pair))
                    };
                    row.c = compare(o, spp, &xml, &scene, (&d.image, &kami), &pair)?;
                    while let Some(more) = raised_spp(row.c.hair.noise_hair, spp, o.max_spp) {
                        spp = more;
                        row.c = compare(o, spp, &xml, &scene, (&d.image, &kami), &pair)?;
                    }
                    row.spp = spp;
                    rows_out.push(row);
                }
                if view == View::Scene && lighting == Lighting::Key && !base.groups().is_empty() {
                    let at = (xml.as_path(), spp);
                    offsets_rows(gpu, o, &lit_scene, &name, &work, at, &mut offsets)?;
                }
            }
        }
    }
    let (md, csv) = report(gpu, o, &rows_out, fibre);
    write_report(out, "look", &md, &csv)?;
    let (md_off, csv_off) = offsets_report(gpu, &offsets);
    write_report(out, "look_offsets", &md_off, &csv_off)?;
    Ok(Report { markdown: md, csv })
}

/// The layered offset (`stage::shadow::layered_offset`) of a scene with Anjyo's strands:
/// FLIP for each method, shading mode and offset, shadows on, against `xml` rendered at
/// `spp` (the key light's rows' last).
fn offsets_rows(
    gpu: &Gpu,
    o: &Options,
    base: &Scene,
    name: &str,
    work: &Path,
    (xml, spp): (&Path, u32),
    offsets: &mut Vec<(String, ShadowMethod, Shading, f64, bool, Compared)>,
) -> Result<()> {
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
                let d = draw(gpu, &scene, o.size, 1, false)?;
                let row = format!("{name}_{}_{method:?}_{k}", shading.name());
                let kami = work.join(format!("kami_offset_{row}.png"));
                save(&d.image, &kami)?;
                let pair = work.join(format!("pair_offset_{row}.png"));
                let c = compare(o, spp, xml, &scene, (&d.image, &kami), &pair)?;
                offsets.push((name.to_string(), method, shading, k, k == own, c));
            }
        }
    }
    Ok(())
}

/// A hair FLIP as the report shows it: bracketed where the silhouettes overlap less than
/// [`MIN_OVERLAP`] (unlike shapes).
fn hair_cell(c: &Compared) -> String {
    if c.hair.overlap < MIN_OVERLAP {
        format!("({:.3})", c.hair.flip_hair)
    } else {
        format!("{:.3}", c.hair.flip_hair)
    }
}

/// look.md and look.csv: every row, then the goal's rows (physical, shadows on).
fn report(gpu: &Gpu, o: &Options, rows: &[Row], fibre: f64) -> (String, String) {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "### `kami bench look`\n\n{}\n\nAdapter: **{}**. Each scene at frame 0, {}x{} pixels, with its own MSAA and supersampling, from the scene's camera and a close-up (*close*: the same eye, narrowed onto the hair's near side so half its extent fills the frame), under the scene's key light and a light from the side and from behind (*side*, *back*: shadows on only). *ms*: Kami's frame (generation, draw, resolve), the mean of {} frames after one untimed. *FLIP hair*: mean FLIP (LDR, 67 pixels per degree) of Kami's image against Mitsuba 3 (`scalar_rgb`, `path` integrator, `hair` BSDF, longest path {MAX_DEPTH}) over the pixels where either image differs from the background (hair and head); *noise hair*: the same between two seeds of the reference; *spp*: the reference's samples per pixel, {} to start with and doubled, up to {}, while its noise hair is above {WELL_BELOW_GOAL} (half the goal); *overlap*: intersection over union of the two images' masks (a FLIP in brackets compares silhouettes that overlap less than {MIN_OVERLAP}); *share*: the masks' share of the frame; *FLIP image*, *noise image*: the means over the whole image. *reference s*: Mitsuba's time for both seeds (as recorded when rendered; `cached` in the CSV says whether this run took them from `--cache`). The reference draws the strands Kami drew: fur's culled hairs at their widened width, tapered to the tip as drawn, each strip's texture hairs, as `bsplinecurve`s (`mitsuba::CURVE_SHAPE`). *Single fibre*: before any reference, Mitsuba rendered one fibre written the same way under {} directional lights (direct light only, {FIBRE_SPP} spp); its mean radiance was within {:.2} % of Kami's f64 S in every channel (the bench refuses above {:.0} %).\n",
        provenance(),
        gpu.describe(),
        o.size.0,
        o.size.1,
        o.frames,
        o.spp,
        o.max_spp,
        FIBRE_LIGHTS.len(),
        100.0 * fibre,
        100.0 * FIBRE_TOLERANCE
    );
    let _ = writeln!(
        md,
        "| scene | view | light | shading | shadows | ms per frame | FLIP hair | noise hair | spp | overlap | share | FLIP image | noise image | reference s |\n|---|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let mut csv = String::from(
        "scene,view,light,shading,shadows,ms,clock,flip_hair,noise_hair,spp,overlap,share,flip,noise,reference_s,cached,pair\n",
    );
    for r in rows {
        let sh = if r.shadows { "on" } else { "off" };
        let c = &r.c;
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {sh} | {:.2} | {} | {:.3} | {} | {:.3} | {:.2} | {:.3} | {:.3} | {:.0} |",
            r.scene,
            r.view.name(),
            r.lighting.name(),
            r.shading.name(),
            r.ms,
            hair_cell(c),
            c.hair.noise_hair,
            r.spp,
            c.hair.overlap,
            c.hair.share,
            c.flip,
            c.noise,
            c.reference_s
        );
        let _ = writeln!(
            csv,
            "{},{},{},{},{sh},{:.4},{},{:.5},{:.5},{},{:.5},{:.5},{:.5},{:.5},{:.1},{},{}",
            r.scene,
            r.view.name(),
            r.lighting.name(),
            r.shading.name(),
            r.ms,
            r.clock,
            c.hair.flip_hair,
            c.hair.noise_hair,
            r.spp,
            c.hair.overlap,
            c.hair.share,
            c.flip,
            c.noise,
            c.reference_s,
            u8::from(c.cached),
            r.pair
        );
    }
    let clocks: Vec<&str> = rows.iter().map(|r| r.clock).collect();
    let _ = writeln!(
        md,
        "\nClock: {}. Pairs of the goal's rows (physical, shadows on) beside this report, the others' in `<cache>/scene_<scene>/<view>/pair_*.png`: `<scene>_<view>_<light>_<shading>_<shadows>.png` (Kami | Mitsuba | FLIP map | masks: grey both, red Kami only, blue the reference only).\n",
        if clocks.iter().all(|c| *c == "gpu-timestamps") {
            "GPU timestamps"
        } else {
            "the CPU clock around a wait where the adapter has no timestamps"
        }
    );
    goal_table(&mut md, rows);
    (md, csv)
}

/// The goal's table: physical with shadows on, each scene, view and light, against
/// [`GOAL_FLIP`] and twice Anjyo's frame time (shadows on, the same view and light).
fn goal_table(md: &mut String, rows: &[Row]) {
    let _ = writeln!(
        md,
        "#### The goal: hair FLIP of {GOAL_FLIP} or less in the physical mode, at no more than twice Anjyo's frame time\n\n| scene | view | light | FLIP hair | noise hair | spp | overlap | physical / Anjyo ms | met |\n|---|---|---|---:|---:|---:|---:|---:|---|"
    );
    // Rows meeting the whole goal, its FLIP half (with the silhouettes' overlap) and its
    // frame-time half.
    let (mut met_rows, mut flip_rows, mut time_rows) = (0usize, 0usize, 0usize);
    for r in rows.iter().filter(|r| r.is_goal()) {
        let anjyo = rows.iter().find(|a| {
            a.shading == Shading::Anjyo
                && a.shadows
                && a.scene == r.scene
                && a.view == r.view
                && a.lighting == r.lighting
        });
        let ratio = anjyo.map(|a| r.ms / a.ms.max(1e-9));
        let flip_met = r.c.hair.flip_hair <= GOAL_FLIP && r.c.hair.overlap >= MIN_OVERLAP;
        let time_met = ratio.is_some_and(|q| q <= 2.0);
        let met = flip_met && time_met;
        flip_rows += usize::from(flip_met);
        time_rows += usize::from(time_met);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {:.3} | {} | {:.3} | {} | {} |",
            r.scene,
            r.view.name(),
            r.lighting.name(),
            hair_cell(&r.c),
            r.c.hair.noise_hair,
            r.spp,
            r.c.hair.overlap,
            ratio.map_or("—".into(), |q| format!("{q:.2}")),
            if met { "yes" } else { "no" }
        );
        met_rows += usize::from(met);
    }
    let goal: Vec<&Row> = rows.iter().filter(|r| r.is_goal()).collect();
    let by = |a: &&&Row, b: &&&Row| a.c.hair.flip_hair.total_cmp(&b.c.hair.flip_hair);
    if let (Some(lo), Some(hi)) = (goal.iter().min_by(by), goal.iter().max_by(by)) {
        let noise =
            |f: fn(f64, f64) -> f64, x: f64| goal.iter().map(|r| r.c.hair.noise_hair).fold(x, f);
        let _ = writeln!(
            md,
            "\n**On the hair's pixels, physical with shadows:** FLIP from {:.3} ({}, {}, {}) to {:.3} ({}, {}, {}), the reference's noise {:.3} to {:.3}; the goal met in {met_rows} of {} rows (its FLIP in {flip_rows}, its frame time in {time_rows}).",
            lo.c.hair.flip_hair,
            lo.scene,
            lo.view.name(),
            lo.lighting.name(),
            hi.c.hair.flip_hair,
            hi.scene,
            hi.view.name(),
            hi.lighting.name(),
            noise(f64::min, f64::INFINITY),
            noise(f64::max, 0.0),
            goal.len()
        );
    }
}

/// look_offsets.md and .csv.
fn offsets_report(
    gpu: &Gpu,
    offsets: &[(String, ShadowMethod, Shading, f64, bool, Compared)],
) -> (String, String) {
    let mut md = format!(
        "### `kami bench look`: the layered offset\n\n{}\n\nAdapter: **{}**. Mean FLIP against the same references as look.md (the scene's camera and light), shadows on, for scenes with Anjyo's strands, as `render.shadows.layered_offset` (cells of the box's size / 64) moves where those strands read the shadow structure; *default*: the method's own offset.\n\n| scene | method | shading | offset | default | FLIP hair | FLIP image |\n|---|---|---|---:|---|---:|---:|\n",
        provenance(),
        gpu.describe()
    );
    let mut csv = String::from("scene,method,shading,offset,default,flip_hair,flip\n");
    for (name, method, shading, k, own, c) in offsets {
        let default = if *own { "yes" } else { "" };
        let _ = writeln!(
            md,
            "| {name} | {method:?} | {} | {k} | {default} | {:.3} | {:.3} |",
            shading.name(),
            c.hair.flip_hair,
            c.flip
        );
        let _ = writeln!(
            csv,
            "{name},{method:?},{},{k},{},{:.5},{:.5}",
            shading.name(),
            u8::from(*own),
            c.hair.flip_hair,
            c.flip
        );
    }
    (md, csv)
}
