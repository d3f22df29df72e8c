//! The sky each strip sees (`strips::sky`): the hidden-sky index inverts 2 E_3, an open strip
//! sees all of it, a strip under flat sheets of hair gets the sheets' coverage, and in the
//! shipped layered scene inner layers see less than outer ones.

use glam::DVec3;
use kami::scene::Head;
use kami::systems::strips::block::Look;
use kami::systems::strips::sky::{self, SKY_MAX_AREA, SKY_RAYS, SKY_SAMPLES};
use kami::systems::strips::{hom, RestStrip};

/// A head far below (−z) the strips, so every strip faces +z and the head hides nothing.
fn far_head() -> Head {
    Head {
        center: [0.0, 0.0, -1.0e4],
        radii: [1.0, 1.0, 1.0],
        ..Head::default()
    }
}

/// A straight strip in the plane z = `z` from y = `half` to y = −`half`, `width` wide.
fn sheet(z: f64, half: f64, width: f64, sticks: usize) -> RestStrip {
    RestStrip {
        layer: 0,
        points: (0..=sticks)
            .map(|k| DVec3::new(0.0, half - 2.0 * half * k as f64 / sticks as f64, z))
            .collect(),
        normal: DVec3::Z,
        width: [width, width],
        stiffness: 1.0,
        color: [0.1, 0.06, 0.03],
    }
}

#[test]
fn sky_area_inverts_the_open_share() {
    for a in [0.0, 1e-3, 0.1, 0.6, 1.0, 2.5, 7.0] {
        let back = sky::area_for_share(sky::open_share(a));
        assert!((back - a).abs() < 1e-9, "A = {a}: inverted to {back}");
    }
    assert_eq!(sky::area_for_share(1.0), 0.0);
    assert_eq!(sky::area_for_share(1.5), 0.0);
    assert_eq!(sky::area_for_share(0.0), SKY_MAX_AREA);
    assert_eq!(sky::area_for_share(f64::NAN), 0.0);
}

#[test]
fn an_open_strip_sees_the_whole_sky() {
    let rest = vec![sheet(0.0, 1.0, 1.0, 4)];
    let baked = sky::bake(&rest, &far_head(), &Look::default());
    assert_eq!(baked, vec![[0.0f32; SKY_SAMPLES]]);
}

/// Under sheets wide enough to stand for infinite ones (rays that miss them leave at a cosine
/// below 1e-3, a 1e-6 share of the cosine-weighted sky), a strip's index is the sheets'
/// summed coverage: what a coat of that fibre-area index hides.
#[test]
fn a_strip_under_sheets_gets_their_coverage() {
    let look = Look::default();
    let rows = sky::row_coverage(&look);
    // The sheets are crossed near their middle (v = 1/2).
    let c = rows[rows.len() / 2];
    assert!((0.3..0.9).contains(&c), "the texture's body coverage {c}");
    for sheets in 1..=2 {
        let mut rest = vec![sheet(0.0, 1.0, 1.0, 4)];
        for k in 0..sheets {
            rest.push(sheet(0.5 * (k + 1) as f64, 2000.0, 4000.0, 1));
        }
        let baked = sky::bake(&rest, &far_head(), &look);
        let want = sheets as f64 * c;
        for (j, &a) in baked[0].iter().enumerate() {
            let err = (a as f64 - want).abs() / want;
            println!("{sheets} sheets, sample {j}: A = {a:.5}, want {want:.5}, error {err:.2e}");
            assert!(
                err < 0.01,
                "{sheets} sheets, sample {j}: A = {a}, want {want}"
            );
        }
        // The sheets themselves are open.
        assert!(
            baked[sheets].iter().all(|&a| a == 0.0),
            "{:?}",
            baked[sheets]
        );
    }
}

/// The shipped layered scene (assets/scenes/strips.ron), where strips overlap their
/// neighbours and the layers over them: the bake's `SKY_RAYS` rays per point against 16
/// times as many. Every index is finite and at least 0, and each point's error in the share
/// of the sky it sees (2 E_3(A)) is bounded.
#[test]
fn the_bake_converges_on_the_layered_scene() {
    let scene = kami::Scene::load(kami::scene::shipped("assets/scenes/strips.ron")).unwrap();
    let strips = scene.strips().clone().unwrap();
    let rest = hom::build(&strips, &scene.head).unwrap();
    let t = std::time::Instant::now();
    let baked = sky::bake(&rest, &scene.head, &strips.look);
    println!(
        "{} rays: {} strips in {:?}",
        SKY_RAYS,
        rest.len(),
        t.elapsed()
    );
    let t = std::time::Instant::now();
    let fine = sky::bake_rays(&rest, &scene.head, &strips.look, 16 * SKY_RAYS);
    println!("{} rays: {:?}", 16 * SKY_RAYS, t.elapsed());
    assert_eq!(baked.len(), rest.len());
    assert!(baked.iter().flatten().all(|a| a.is_finite() && *a >= 0.0));
    let share = |a: f32| sky::open_share(a as f64);
    let errs: Vec<f64> = baked
        .iter()
        .flatten()
        .zip(fine.iter().flatten())
        .map(|(&a, &b)| (share(a) - share(b)).abs())
        .collect();
    let worst = errs.iter().copied().fold(0.0, f64::max);
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    let index = baked.iter().flatten().map(|&a| a as f64).sum::<f64>() / errs.len() as f64;
    println!(
        "sky seen, {} points: mean error {mean:.4}, worst {worst:.4}; mean index {index:.3}",
        errs.len()
    );
    assert!(mean < 0.01, "mean error {mean}");
    assert!(worst < 0.06, "worst error {worst}");
    // The layers do hide the sky: this is not an open scene.
    assert!(index > 0.3, "mean index {index}");
}

/// The grid's walk finds every crossing the exhaustive test of every ribbon finds: the same
/// index at every point of the shipped scene (to the summation order's rounding), and the
/// bake's time at 16 times its strips (the strips bench's largest scene), where the
/// exhaustive test would take about 256 times as long.
#[test]
fn the_grid_walk_matches_the_exhaustive_bake() {
    let scene = kami::Scene::load(kami::scene::shipped("assets/scenes/strips.ron")).unwrap();
    let mut strips = scene.strips().clone().unwrap();
    let rest = hom::build(&strips, &scene.head).unwrap();
    let t = std::time::Instant::now();
    let grid = sky::bake_rays(&rest, &scene.head, &strips.look, 16);
    let t_grid = t.elapsed();
    let t = std::time::Instant::now();
    let all = sky::bake_exhaustive(&rest, &scene.head, &strips.look, 16);
    println!("16 rays: grid {t_grid:?}, exhaustive {:?}", t.elapsed());
    let worst = grid
        .iter()
        .flatten()
        .zip(all.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    println!("worst index difference {worst:.2e}");
    assert!(worst < 1e-5, "worst index difference {worst}");
    for l in &mut strips.layers {
        l.count *= 16;
    }
    let rest = hom::build(&strips, &scene.head).unwrap();
    let t = std::time::Instant::now();
    let big = sky::bake(&rest, &scene.head, &strips.look);
    println!(
        "{} strips, {} rays: {:?}",
        rest.len(),
        SKY_RAYS,
        t.elapsed()
    );
    assert!(big.iter().flatten().all(|a| a.is_finite() && *a >= 0.0));
}

/// The sky is baked only where the physical mode reads it, and a switch to the physical mode
/// bakes it: a strips stage built in Anjyo's mode and switched draws what a stage built
/// physical draws, pixel for pixel, and both differ from the open sky's.
#[test]
fn a_switch_to_physical_bakes_the_sky() {
    let gpu = crate::common::gpu();
    let size = (96, 96);
    let mut anjyo = crate::common::scene("strips");
    anjyo.render.lod_tolerance_px = 0.0;
    let mut physical = anjyo.clone();
    physical.render.shading = kami::scene::Shading::Physical;
    let mut fresh = crate::common::stage_one_sample(gpu, &physical);
    let want = crate::common::draw(&mut fresh, size);
    let mut stage = crate::common::stage_one_sample(gpu, &anjyo);
    crate::common::draw(&mut stage, size);
    stage.apply(gpu, &physical).unwrap();
    let got = crate::common::draw(&mut stage, size);
    let differ = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2))
            .count()
    };
    assert_eq!(
        differ(&got, &want),
        0,
        "switched to physical: pixels differ from a fresh stage"
    );
    // The strips with the open sky everywhere (what a missing bake draws) look otherwise.
    let strips = fresh
        .system_mut::<kami::systems::strips::StripsSystem>()
        .unwrap();
    let n = strips.rest.len();
    strips
        .ribbon
        .set_sky(gpu, &vec![[0.0; SKY_SAMPLES]; n])
        .unwrap();
    let open = crate::common::draw(&mut fresh, size);
    let n = differ(&open, &want);
    println!("{n} pixels differ under the open sky");
    assert!(
        n > 50,
        "the open sky draws like the baked one ({n} pixels differ)"
    );
}
