//! Shared by the integration tests: the one headless software device, scene loading,
//! snapshot comparison with written-down tolerances, scratch folders, the `kami` binary, and
//! helpers more than one module needs.
#![allow(dead_code)]

use glam::DVec3;
use kami::fuzz::CappedAlloc;
use kami::gpu::{Gpu, Preference};
use kami::systems::fur::generate::FurGpu;
use kami::systems::fur::setup::{slot_hair, FurSetup, HairPoints};
use std::alloc::{GlobalAlloc, Layout};
use std::cell::{Cell, RefCell};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};

/// The device every test shares: one per process, so one per backend (`KAMI_BACKEND` is
/// read once, when the first test asks). A software adapter (llvmpipe or lavapipe), made
/// once: creating a device costs about as much as a small test, and the old one-binary-per-
/// file suite made 75 of them.
///
/// Sharing is safe: wgpu's `Device` and `Queue` are `Send + Sync`, error scopes are
/// thread-local (`shader_module` scopes only its own thread's calls), `Gpu::wait` waits for
/// all submitted work (another test's too, which only costs time), and no test reads
/// timestamps or another test's buffers. Uncaptured errors go to one sink (`take_error`):
/// no test provokes one on purpose, so an error seen there is still a bug, though the test
/// that reports it may not be the one that caused it (run it alone to find out).
///
/// There is no silent skip: without an adapter the test fails and says how to get one.
/// Without a software adapter, wgpu would hand over a hardware one, whose images and f32
/// rounding differ from those the snapshot tolerances were measured on: that fails too,
/// unless `KAMI_TEST_HARDWARE=1` asks for it, and then the binary says so on stderr.
///
/// On GL the tests take turns: wgpu's GL backend runs every call under one EGL context lock
/// and panics after 6 s without it ("Could not lock adapter context"), so one test's long
/// frame or fence wait would fail another's `create_buffer`. A test's first `gpu()` takes a
/// process-wide turn that its thread keeps until it ends (the harness runs each test on a
/// thread of its own); no test shares the device with a thread it spawns.
pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    let gpu = GPU.get_or_init(new_gpu);
    if gpu.info.backend == wgpu::Backend::Gl {
        GL_TURN_HELD.with(|held| {
            let mut held = held.borrow_mut();
            if held.is_none() {
                // A test that panicked in its turn leaves nothing half-done on the device.
                *held = Some(GL_TURN.lock().unwrap_or_else(|e| e.into_inner()));
            }
        });
    }
    gpu
}

/// Whose turn it is on the GL device (`gpu`).
static GL_TURN: Mutex<()> = Mutex::new(());

thread_local! {
    /// This thread's turn on the GL device, released when the thread (the test) ends.
    static GL_TURN_HELD: RefCell<Option<MutexGuard<'static, ()>>> = const { RefCell::new(None) };
}

fn new_gpu() -> Gpu {
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
        eprintln!(
            "\n*** WARNING: KAMI_TEST_HARDWARE=1: these tests run on {}, not on a software \
             adapter; snapshot differences may be the adapter's ***\n",
            gpu.describe()
        );
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

/// Every shipped scene (`assets/scenes/*.ron`), by name, sorted: read from the folder, so a
/// new scene is covered without editing a list.
pub fn shipped_scenes() -> Vec<String> {
    let dir = root().join("assets/scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(!names.is_empty(), "no scenes in {}", dir.display());
    names
}

/// The shipped scenes whose hair is all grown by Anjyo's groom on the analytic (ellipsoid)
/// head: those whose nodes the groom invariants (outside the ellipsoid, exact segment
/// lengths) hold for. Scenes with a mesh head, imported strands, or no Anjyo groups at all
/// (fur, strips, wisps) are left out.
pub fn grown_scenes() -> Vec<(String, kami::Scene)> {
    let grown: Vec<_> = shipped_scenes()
        .into_iter()
        .map(|n| {
            let s = scene(&n);
            (n, s)
        })
        .filter(|(_, s)| {
            !s.groups().is_empty()
                && s.head.mesh.is_none()
                && s.groups().iter().all(|g| g.file.is_none())
        })
        .collect();
    assert!(grown.len() >= 4, "only {} grown scenes", grown.len());
    grown
}

/// A fresh, empty scratch folder for one test, under the temp dir and unique to this process,
/// the calling module and `name` (modules of the one test binary may pick the same name).
#[track_caller]
pub fn scratch(name: &str) -> PathBuf {
    let module = Path::new(std::panic::Location::caller().file())
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = std::env::temp_dir().join(format!("kami-it-{}/{module}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run the `kami` binary in the repository root, with no display (commands that would open
/// a window must fail on their options, not on the window) and a runtime dir that exists.
pub fn kami(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_kami"))
        .args(args)
        .current_dir(root())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("run kami")
}

/// The validation error `text` (a scene file's contents) gets: (field, value, allowed). It
/// must be `KamiError::Invalid` naming the file.
#[track_caller]
pub fn invalid(text: &str) -> (String, String, String) {
    match kami::Scene::from_ron(text, "test.ron") {
        Err(kami::error::KamiError::Invalid {
            file,
            field,
            value,
            allowed,
        }) => {
            assert_eq!(file, "test.ron", "a validation error names the scene file");
            (field, value, allowed)
        }
        other => panic!("expected a validation error, got {other:?}"),
    }
}

/// A stage for `scene` at the scene's own quality.
pub fn stage(gpu: &Gpu, scene: &kami::Scene) -> kami::stage::Stage {
    kami::stage::Stage::new(
        gpu,
        scene,
        kami::stage::target::OUTPUT_FORMAT,
        kami::stage::Quality::of(scene),
    )
    .unwrap()
}

/// The world `scene`'s kernels bind, as the stage makes it (`systems::world`), for tests that
/// build one kind's passes without a stage.
pub fn world(gpu: &Gpu, scene: &kami::Scene) -> kami::systems::world::WorldGpu {
    kami::systems::world::WorldGpu::of_scene(gpu, scene).unwrap()
}

/// The world of `forces` around `head` (the hull of `scene::hull::head_hull`).
pub fn world_of(
    gpu: &Gpu,
    forces: &kami::forces::Forces,
    head: &kami::scene::Head,
) -> kami::systems::world::WorldGpu {
    kami::systems::world::WorldGpu::of(gpu, forces, head).unwrap()
}

/// The world of `head` with no forces (no EFF).
pub fn still_world(gpu: &Gpu, head: &kami::scene::Head) -> kami::systems::world::WorldGpu {
    world_of(
        gpu,
        &kami::forces::Forces::new(&Default::default(), head),
        head,
    )
}

/// A world with no forces around `input`'s head hull: what the groom (the cantilever) reads.
pub fn groom_world(
    gpu: &Gpu,
    input: &kami::systems::anjyo::groom::GroomInput,
) -> kami::systems::world::WorldGpu {
    let forces = kami::forces::Forces::new(&Default::default(), &Default::default());
    kami::systems::world::WorldGpu::new(gpu, &forces, &input.head).unwrap()
}

/// `input` groomed on the GPU (in a world with no forces) and the dynamics of `scene` over
/// it, in the scene's world: what a stage builds for Anjyo's hair in motion, without a stage.
pub fn gpu_simulation(
    gpu: &Gpu,
    scene: &kami::Scene,
    input: &kami::systems::anjyo::groom::GroomInput,
) -> (
    kami::gpu::strands::StrandBuffers,
    kami::systems::anjyo::simulation::Simulation,
) {
    let hair =
        kami::systems::anjyo::cantilever_gpu::groom_gpu(gpu, &groom_world(gpu, input), input)
            .unwrap();
    let sim = kami::systems::anjyo::simulation::Simulation::new(
        gpu,
        &world(gpu, scene),
        scene,
        input,
        &hair,
    )
    .unwrap()
    .expect("the scene has dynamics");
    (hair, sim)
}

/// Shipped scene `name` with each strand group's count divided by `divisor` (quicker tests).
pub fn thinned(name: &str, divisor: u32) -> kami::Scene {
    let mut s = scene(name);
    for g in s.groups_mut() {
        g.count /= divisor;
    }
    s
}

/// One frame of `stage` drawn at `size` and read back.
pub fn draw(stage: &mut kami::stage::Stage, size: (u32, u32)) -> image::RgbaImage {
    let gpu = gpu();
    let out = kami::stage::target::Offscreen::new(gpu, size).unwrap();
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    let look = stage.look();
    stage.render(gpu, &mut enc, &out.view, size, &look).unwrap();
    gpu.queue.submit([enc.finish()]);
    out.read_rgba(gpu).unwrap()
}

/// A stage for `scene` with one sample per pixel (no MSAA, no supersampling): for tests
/// that read ids or positions, not looks.
pub fn stage_one_sample(gpu: &Gpu, scene: &kami::Scene) -> kami::stage::Stage {
    let q = kami::stage::Quality::new(1, 1);
    kami::stage::Stage::new(gpu, scene, kami::stage::target::OUTPUT_FORMAT, q).unwrap()
}

/// Run the fur generator on the GPU for `setup` at `frame` with culling `c`; returns, per
/// coat, the hairs it drew: (triangle, creation index, nodes, skin normal, plane normal,
/// random).
pub fn gpu_hairs(
    gpu: &Gpu,
    setup: &FurSetup,
    frame: f64,
    c: f64,
) -> Vec<Vec<(usize, u32, HairPoints)>> {
    let mut g = FurGpu::new(gpu, setup).unwrap();
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    g.record(gpu, &mut enc, setup, frame, c).unwrap();
    gpu.queue.submit([enc.finish()]);
    let verts = g.strands.read_vertices(gpu).unwrap();
    let strands = g.strands.read_strands(gpu).unwrap();
    let info: Vec<[f32; 4]> =
        kami::gpu::read_buffer(gpu, &g.info, g.strands.strand_count as u64 * 32).unwrap();
    let v3 = |v: [f32; 4]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
    (0..setup.coats.len())
        .map(|ci| {
            let off = setup.culled_offsets(ci, c);
            assert_eq!(g.drawn[ci], *off.last().unwrap());
            (0..g.drawn[ci])
                .map(|slot| {
                    let (t, h) = slot_hair(&off, &setup.coats[ci].first, slot);
                    let si = (g.strands.ranges[ci].first_strand + slot) as usize;
                    let s = strands[si];
                    assert_eq!(s.group as usize, ci);
                    let nodes = (0..=s.segments)
                        .map(|k| v3(verts[(s.first_vertex + k) as usize]))
                        .collect();
                    let hp = HairPoints {
                        nodes,
                        skin_normal: v3(info[2 * si]),
                        plane_normal: v3(info[2 * si + 1]),
                        rand: info[2 * si][3] as f64,
                    };
                    (t, h, hp)
                })
                .collect()
        })
        .collect()
}

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

/// The test binary's global allocator (installed in `main.rs`): `fuzz::CappedAlloc`, which
/// passes every call on to `System`, plus a per-thread record of the largest allocation.
pub struct TestAlloc;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
}

// SAFETY: every call is passed on to `CappedAlloc` (itself `System`) unchanged; `note` only
// touches a thread-local `Cell` and never allocates.
unsafe impl GlobalAlloc for TestAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: the caller's contract is CappedAlloc's.
        unsafe { CappedAlloc.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: as above.
        unsafe { CappedAlloc.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        // SAFETY: as above.
        unsafe { CappedAlloc.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { CappedAlloc.dealloc(ptr, layout) }
    }
}

/// Largest single allocation on this thread while `f` runs.
pub fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.with(|l| l.set(0));
    let out = f();
    (out, LARGEST.with(|l| l.get()))
}

/// The warnings the library logs (`log::warn!`) on this thread while `f` runs, in order. One
/// logger is installed for the whole test binary; it keeps records only for threads inside
/// this call, so tests running beside each other do not see each other's warnings.
pub fn warnings<T>(f: impl FnOnce() -> T) -> (T, Vec<String>) {
    static LOGGER: Capture = Capture;
    static INSTALL: OnceLock<()> = OnceLock::new();
    INSTALL.get_or_init(|| {
        log::set_logger(&LOGGER).expect("the tests install no other logger");
        log::set_max_level(log::LevelFilter::Warn);
    });
    CAPTURED.with(|c| *c.borrow_mut() = Some(Vec::new()));
    let out = f();
    let got = CAPTURED.with(|c| c.borrow_mut().take()).unwrap_or_default();
    (out, got)
}

thread_local! {
    static CAPTURED: RefCell<Option<Vec<String>>> = const { RefCell::new(None) };
}

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.level() <= log::Level::Warn
    }

    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            CAPTURED.with(|c| {
                if let Some(v) = c.borrow_mut().as_mut() {
                    v.push(r.args().to_string());
                }
            });
        }
    }

    fn flush(&self) {}
}

/// Run a contract test's compute entry point `main` (workgroup size 64) of `source` once per
/// output element: binding k of group 0 is `inputs[k]` (read-only storage, `slots[k]` its
/// layout), the last binding the `n` vec4<f32> results, read back.
pub fn run_contract(
    gpu: &Gpu,
    label: &str,
    source: &str,
    inputs: &[(&[u8], kami::gpu::bind::Slot)],
    n: usize,
) -> Vec<[f32; 4]> {
    use kami::gpu::bind;
    let dev = &gpu.device;
    let module = kami::gpu::shader_module(dev, label, source).unwrap();
    let mut slots: Vec<bind::Slot> = inputs.iter().map(|i| i.1).collect();
    slots.push(bind::storage_rw::<[f32; 4]>());
    let layout = bind::layout(dev, label, wgpu::ShaderStages::COMPUTE, &slots);
    let pl = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: Some(&pl),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let none = wgpu::BufferUsages::empty();
    let mut buffers: Vec<wgpu::Buffer> = inputs
        .iter()
        .map(|(bytes, _)| kami::gpu::storage_buffer(dev, label, bytes, none))
        .collect();
    let out_bytes = n * 16;
    buffers.push(kami::gpu::storage_buffer(
        dev,
        label,
        &vec![0u8; out_bytes],
        wgpu::BufferUsages::COPY_SRC,
    ));
    let refs: Vec<&wgpu::Buffer> = buffers.iter().collect();
    let group = bind::buffers(dev, label, &layout, &refs);
    let mut enc = dev.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    }
    gpu.queue.submit([enc.finish()]);
    let got = kami::gpu::read_buffer(gpu, buffers.last().unwrap(), out_bytes as u64).unwrap();
    gpu.take_error().unwrap();
    got
}
