//! Snapshot tests: every shipped scene is groomed on the GPU and rendered headless on the
//! software adapter (thin strands as ribbons: `scene` below), then compared with its
//! reference PNG in `tests/snapshots/`.
//!
//! Tolerance, for every scene: mean absolute difference <= 0.25 (of 255) over all RGB
//! channels, and at most 0.2 % of pixels with a channel off by more than 24. Measured
//! between lavapipe (Vulkan) and llvmpipe (GL) on Mesa 22.3 over all the images: mean
//! 0.0000-0.006, largest single difference 54 (the gust), at most 0.006 % of pixels over 24.
//! A wrong bend, cut, shading term or anti-aliasing change moves far more than that (the
//! switch from alpha to coverage to per-sample coverage moved the hair scenes by mean
//! 0.2-12).

use crate::common;
use common::{check_snapshot, Tolerance};

/// A shipped scene drawn with ribbons: under the default `render.strands: Auto` thin hair
/// goes to the compute rasteriser where the adapter can run it over the scene's targets
/// (not over MSAA targets on GL), so one reference could not hold on both backends. The
/// compute rasteriser and `Auto` have their own tests (`tests/it/splat.rs`: the f64
/// contract per kind, Auto's choice and its frames).
fn scene(name: &str) -> kami::Scene {
    let mut s = common::scene(name);
    s.render.strands = kami::scene::StrandRaster::Ribbons;
    s
}

const SIZE: (u32, u32) = (256, 256);
const TOL: Tolerance = Tolerance {
    mean: 0.25,
    threshold: 24,
    share: 0.002,
};

fn snapshot(name: &str) {
    let gpu = common::gpu();
    let scene = scene(name);
    let img = kami::stage::render_scene(gpu, &scene, SIZE).unwrap();
    check_snapshot(name, &img, TOL);
}

#[test]
fn bob() {
    snapshot("bob");
}

/// The bob with per-strand melanin, width and tint (`Material.variation`), in both modes.
#[test]
fn bob_varied() {
    snapshot("bob_varied");
    physical("bob_varied", "bob_varied_physical", SIZE, false);
}

/// Shadows off draws exactly what Kami drew before shadows existed: this reference is the
/// bob's snapshot from before them, unchanged.
#[test]
fn bob_shadows_off() {
    let gpu = common::gpu();
    let mut scene = scene("bob");
    scene.render.shadows.on = false;
    let img = kami::stage::render_scene(gpu, &scene, SIZE).unwrap();
    check_snapshot("bob_shadows_off", &img, TOL);
}

#[test]
fn swept_back() {
    snapshot("swept_back");
}

#[test]
fn ponytail() {
    snapshot("ponytail");
}

#[test]
fn short_cut() {
    snapshot("short_cut");
}

/// Without MSAA, sub-pixel coverage goes through alpha blending instead of alpha to
/// coverage: a separate code path, so a separate snapshot.
#[test]
fn bob_blended_no_msaa() {
    let gpu = common::gpu();
    let mut scene = scene("bob");
    scene.render.msaa = 1;
    scene.render.supersample = 1;
    let img = kami::stage::render_scene(gpu, &scene, SIZE).unwrap();
    check_snapshot("bob_msaa1", &img, TOL);
}

/// The wind gust (Anjyo Fig. 10) at frames 10, 15 and 20: groom, simulation and rendering
/// all on the GPU.
#[test]
fn gust_frames_10_15_20() {
    let gpu = common::gpu();
    let mut scene = scene("gust");
    for g in scene.groups_mut() {
        g.count /= 2;
    }
    kami::stage::render_animation(gpu, &scene, SIZE, 10..=20, |f, img| {
        if f % 5 == 0 {
            check_snapshot(&format!("gust_{f:02}"), &img, TOL);
        }
        Ok(())
    })
    .unwrap();
}

/// One frame of a dynamic scene, with half its hairs (the look stays, the test is faster).
fn animated(name: &str, frame: u32, out: &str) {
    let gpu = common::gpu();
    let mut scene = scene(name);
    for g in scene.groups_mut() {
        g.count /= 2;
    }
    kami::stage::render_animation(gpu, &scene, SIZE, frame..=frame, |_, img| {
        check_snapshot(out, &img, TOL);
        Ok(())
    })
    .unwrap();
}

/// The pseudo-force field (Anjyo Fig. 11) at frame 10, seen from the side the force pushes
/// into the head: with it the hair lies on the head; without it, that hair has gone through.
#[test]
fn pseudo_force_on_and_off() {
    animated("pseudo_force", 10, "pseudo_force_10");
    animated("pseudo_force_off", 10, "pseudo_force_off_10");
}

/// Joint-angle stiffness (Anjyo Fig. 12) at frame 20: the same kicks frizz free hair and
/// leave hair with sigma = 12 degrees away from the pore smooth.
#[test]
fn stiffness_free_and_smooth() {
    animated("stiffness_free", 20, "stiffness_free_20");
    animated("stiffness_smooth", 20, "stiffness_smooth_20");
}

/// Fur (Van Gelder & Wilhelms) in each style with Figure 2's Figure 8 look, the Figure 9
/// look (overcoat and undercoat), the animated critter mid-wave, and a real mesh.
#[test]
fn fur_line() {
    snapshot("fur_line");
}

#[test]
fn fur_polyline() {
    snapshot("fur_polyline");
}

#[test]
fn fur_curve() {
    snapshot("fur_curve");
}

#[test]
fn fur_tube() {
    snapshot("fur_tube");
}

#[test]
fn fur_fig9() {
    snapshot("fur_fig9");
}

/// The default fur scene at frame 6 of its body wave: the fur rides the deformed mesh.
#[test]
fn fur_moving_frame_6() {
    let gpu = common::gpu();
    let scene = scene("fur");
    kami::stage::render_animation(gpu, &scene, SIZE, 6..=6, |_, img| {
        check_snapshot("fur_frame_06", &img, TOL);
        Ok(())
    })
    .unwrap();
}

/// The CGAL lion head from Debian's libcgal-demo (installed by `.ci/run`).
#[test]
fn fur_lion_head() {
    snapshot("fur_lion_head");
}

/// Two hair systems in one scene on one clock, composited by depth in one pass: Anjyo hair
/// in a gust on the head, fur on a waving critter in front of it, at frame 6 (both moved).
#[test]
fn hair_and_fur_frame_6() {
    let gpu = common::gpu();
    let scene = scene("hair_and_fur");
    kami::stage::render_animation(gpu, &scene, SIZE, 6..=6, |_, img| {
        check_snapshot("hair_and_fur_06", &img, TOL);
        Ok(())
    })
    .unwrap();
}

/// An imported groom (issue 14): `wavy.hair` read as live Anjyo hair, at rest and at frame
/// 12 of the head turn, every other strand.
#[test]
fn imported_groom_frames_0_and_12() {
    let gpu = common::gpu();
    let mut scene = scene("imported_groom");
    scene.groups_mut()[0].count /= 2;
    kami::stage::render_animation(gpu, &scene, SIZE, 0..=12, |f, img| {
        if f % 12 == 0 {
            check_snapshot(&format!("imported_groom_{f:02}"), &img, TOL);
        }
        Ok(())
    })
    .unwrap();
}

/// Item 6 of issue 25: every strand kind in the physical shading mode with its shadows (on by
/// default, so every snapshot above is the Anjyo mode with shadows): the bob, fur on the
/// lion's head, and the strips at rest (one sample per pixel, as `strips::strips_snapshots`
/// draws them). The toon wisps have one shading (toon) and its hard shadow steps are in
/// `wisps::toon` and `shadows::wisps_cast_a_toon_step`.
fn physical(name: &str, out: &str, size: (u32, u32), one_sample: bool) {
    let gpu = common::gpu();
    let mut scene = scene(name);
    assert!(scene.render.shadows.on, "{name}: shadows are on by default");
    scene.render.shading = kami::scene::Shading::Physical;
    if one_sample {
        scene.render.supersample = 1;
        scene.render.msaa = 1;
    }
    let img = kami::stage::render_scene(gpu, &scene, size).unwrap();
    check_snapshot(out, &img, TOL);
}

#[test]
fn bob_physical() {
    physical("bob", "bob_physical", SIZE, false);
}

#[test]
fn fur_lion_head_physical() {
    physical("fur_lion_head", "fur_lion_head_physical", SIZE, false);
}

#[test]
fn strips_physical() {
    physical("strips", "strips_physical", (160, 128), true);
}
