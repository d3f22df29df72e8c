//! Shared by the integration tests: one way to get a headless software device, scene
//! loading, and snapshot comparison with written-down tolerances.
#![allow(dead_code)]

use glam::DVec3;
use kami::gpu::{Gpu, Preference};
use std::path::{Path, PathBuf};

/// A device on a software adapter (llvmpipe or lavapipe; `KAMI_BACKEND` picks the backend).
/// There is no silent skip: without an adapter the test fails and says how to get one.
/// Without a software adapter, wgpu would hand over a hardware one, whose images and f32
/// rounding differ from those the snapshot tolerances were measured on: that fails too,
/// unless `KAMI_TEST_HARDWARE=1` asks for it, and then every test binary says so on stderr.
pub fn gpu() -> Gpu {
    let gpu = match Gpu::headless(Preference::Software) {
        Ok(g) => g,
        Err(e) => panic!(
            "no GPU adapter for the tests: {e}\nOn Debian: apt-get install -y mesa-vulkan-drivers \
             libegl-mesa0 libgl1-mesa-dri (then KAMI_BACKEND=vulkan or gl)"
        ),
    };
    if gpu.info.device_type != wgpu::DeviceType::Cpu {
        let allowed = std::env::var("KAMI_TEST_HARDWARE").is_ok_and(|v| v == "1");
        assert!(
            allowed,
            "the tests found no software adapter and would run on {}: the snapshot \
             tolerances were measured on llvmpipe and lavapipe. Install Mesa's software \
             drivers (apt-get install -y mesa-vulkan-drivers libegl-mesa0 libgl1-mesa-dri), or \
             set KAMI_TEST_HARDWARE=1 to run on this adapter anyway",
            gpu.describe()
        );
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            eprintln!(
                "\n*** WARNING: KAMI_TEST_HARDWARE=1: these tests run on {}, not on a software \
                 adapter; snapshot differences may be the adapter's ***\n",
                gpu.describe()
            )
        });
    }
    gpu
}

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn scene(name: &str) -> kami::Scene {
    kami::Scene::load(root().join("assets/scenes").join(format!("{name}.ron")))
        .unwrap_or_else(|e| panic!("shipped scene {name} does not load: {e}"))
}

/// The shipped scenes.
pub const SCENES: &[&str] = &["bob", "swept_back", "ponytail", "short_cut"];

/// How far a rendering may drift from its reference: the mean absolute difference over all
/// RGB channels (0..255), and the share of pixels whose largest channel difference exceeds
/// `threshold`.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    pub mean: f64,
    pub threshold: u8,
    pub share: f64,
}

/// Compare `img` with `tests/snapshots/{name}.png`. On failure, `{name}.new.png` and
/// `{name}.diff.png` are written beside it; `UPDATE_SNAPSHOTS=1` accepts the new image.
pub fn check_snapshot(name: &str, img: &image::RgbaImage, tol: Tolerance) {
    let dir = root().join("tests/snapshots");
    let reference = dir.join(format!("{name}.png"));
    let update = std::env::var("UPDATE_SNAPSHOTS").is_ok_and(|v| v == "1");
    if update {
        img.save(&reference).unwrap();
        return;
    }
    let Ok(want) = image::open(&reference) else {
        img.save(dir.join(format!("{name}.new.png"))).unwrap();
        panic!("no reference {}; look at {name}.new.png and run UPDATE_SNAPSHOTS=1 cargo test to accept it", reference.display());
    };
    let want = want.to_rgba8();
    assert_eq!(
        want.dimensions(),
        img.dimensions(),
        "snapshot {name}: size changed"
    );
    let (mean, share, diff) = compare(&want, img, tol.threshold);
    if mean > tol.mean || share > tol.share {
        img.save(dir.join(format!("{name}.new.png"))).unwrap();
        diff.save(dir.join(format!("{name}.diff.png"))).unwrap();
        panic!(
            "snapshot {name}: mean difference {mean:.3} (allowed {}), {:.3}% of pixels off by more than {} (allowed {:.3}%); see {name}.new.png and {name}.diff.png in {}",
            tol.mean,
            share * 100.0,
            tol.threshold,
            tol.share * 100.0,
            dir.display()
        );
    }
}

/// (mean absolute difference, share of pixels over threshold, diff image x4).
pub fn compare(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
    threshold: u8,
) -> (f64, f64, image::RgbaImage) {
    let mut sum = 0u64;
    let mut over = 0u64;
    let mut diff = image::RgbaImage::new(a.width(), a.height());
    for ((pa, pb), pd) in a.pixels().zip(b.pixels()).zip(diff.pixels_mut()) {
        let mut worst = 0u8;
        for c in 0..3 {
            let d = pa[c].abs_diff(pb[c]);
            sum += d as u64;
            worst = worst.max(d);
            pd[c] = d.saturating_mul(4);
        }
        pd[3] = 255;
        if worst > threshold {
            over += 1;
        }
    }
    let n = (a.width() * a.height()) as f64;
    (sum as f64 / (3.0 * n), over as f64 / n, diff)
}

/// Is a path under the repository (for messages).
pub fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

/// A UV sphere (mesh and winding tests) with one vertex per pole, counter-clockwise seen from outside.
pub fn uv_sphere(centre: DVec3, r: f64, rings: u32, sectors: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut p = vec![centre + DVec3::Y * r];
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..sectors {
            let phi = std::f64::consts::TAU * j as f64 / sectors as f64;
            let u = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            p.push(centre + u * r);
        }
    }
    p.push(centre - DVec3::Y * r);
    let south = p.len() as u32 - 1;
    let at = |i: u32, j: u32| 1 + (i - 1) * sectors + j % sectors;
    let mut t = Vec::new();
    for j in 0..sectors {
        t.push([0, at(1, j + 1), at(1, j)]);
        t.push([south, at(rings - 1, j), at(rings - 1, j + 1)]);
        for i in 1..rings - 1 {
            t.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            t.push([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    for tri in &t {
        let [a, b, c] = tri.map(|i| p[i as usize]);
        assert!(
            (b - a).cross(c - a).dot(a - centre) > 0.0,
            "the test sphere is inside out"
        );
    }
    (p, t)
}

/// Positions and triangles as OFF text.
pub fn off_text(p: &[DVec3], t: &[[u32; 3]]) -> String {
    let mut s = format!("OFF\n{} {} 0\n", p.len(), t.len());
    for v in p {
        s += &format!("{} {} {}\n", v.x, v.y, v.z);
    }
    for f in t {
        s += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    s
}

/// |a| up to whole turns: the GPU and the CPU may rewrap an angle by 2 pi at different
/// steps (`projective::rewrap`), which is the same direction.
pub fn wrapped(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let r = a.rem_euclid(t);
    r.min(t - r)
}

pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q) as usize]
}

/// The projective kernel's nodes (`gpu`, as read back) against the f64 reference's
/// (`cpu`): per strand of `input` the largest node distance over the hair length, sorted.
pub fn strand_errors(
    input: &kami::systems::anjyo::groom::GroomInput,
    gpu: &[[f32; 4]],
    cpu: &[DVec3],
) -> Vec<f64> {
    let offsets = input.vertex_offsets();
    let mut errs: Vec<f64> = input
        .roots
        .iter()
        .enumerate()
        .map(|(s, r)| {
            let len = r.seg_len * input.groups[r.group as usize].segments as f64;
            (offsets[s]..offsets[s + 1])
                .map(|i| {
                    let p = gpu[i as usize];
                    assert!(p.iter().all(|c| c.is_finite()));
                    (DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) - cpu[i as usize]).length()
                        / len
                })
                .fold(0.0, f64::max)
        })
        .collect();
    errs.sort_by(f64::total_cmp);
    errs
}

/// The angle states (theta, phi) of the reference (`cpu`) and the kernel (`gpu`): the worst
/// difference up to whole turns, and the share of entries within 1e-3 rad.
pub fn angle_agreement(cpu: &[[f64; 4]], gpu: &[[f32; 4]]) -> (f64, f64) {
    let diff =
        |c: &[f64; 4], g: &[f32; 4]| wrapped(c[0] - g[0] as f64).max(wrapped(c[2] - g[2] as f64));
    let worst = cpu
        .iter()
        .zip(gpu)
        .map(|(c, g)| diff(c, g))
        .fold(0.0, f64::max);
    let close = cpu
        .iter()
        .zip(gpu)
        .filter(|(c, g)| diff(c, g) < 1e-3)
        .count();
    (worst, close as f64 / gpu.len() as f64)
}

/// The projective contract's bounds: per-strand errors (sorted, relative to the hair
/// length) median <= 1e-4, 99 % <= 1e-2, at most 2 % beyond 1e-2, none beyond 5e-2; no
/// angle off by 0.25 rad or more, and at least `min_close` of them within 1e-3 rad.
pub fn assert_projective_agrees(errs: &[f64], worst_angle: f64, close: f64, min_close: f64) {
    let n = errs.len();
    let beyond = errs.iter().filter(|&&e| e > 1e-2).count();
    eprintln!(
        "{n} strands: median {:.2e}, 99% {:.2e}, worst {:.2e}; worst angle {worst_angle:.3} rad, {:.2} % of angles within 1e-3",
        quantile(errs, 0.5),
        quantile(errs, 0.99),
        errs[n - 1],
        100.0 * close
    );
    assert!(
        quantile(errs, 0.5) < 1e-4,
        "median {:.2e}",
        quantile(errs, 0.5)
    );
    assert!(
        quantile(errs, 0.99) < 1e-2,
        "99% {:.2e}",
        quantile(errs, 0.99)
    );
    assert!(
        beyond as f64 <= 0.02 * n as f64,
        "{beyond} of {n} strands beyond 1e-2"
    );
    assert!(errs[n - 1] < 5e-2, "worst strand {:.2e}", errs[n - 1]);
    assert!(
        worst_angle < 0.25,
        "an angle differs by {worst_angle:.3} rad"
    );
    assert!(
        close >= min_close,
        "only {:.2} % of angle entries agree",
        100.0 * close
    );
}
