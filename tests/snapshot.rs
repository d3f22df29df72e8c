//! Snapshot tests: every shipped scene is groomed on the GPU and rendered headless on the
//! software adapter, then compared with its reference PNG in `tests/snapshots/`.
//!
//! Tolerance, for every scene: mean absolute difference <= 0.25 (of 255) over all RGB
//! channels, and at most 0.2 % of pixels with a channel off by more than 24. Measured
//! between lavapipe (Vulkan) and llvmpipe (GL) on Mesa 22.3: mean 0.001-0.007, largest
//! single difference 44, at most 0.008 % of pixels over 40 (the no-MSAA variant, whose
//! blending order makes it the least stable). A wrong bend, cut, shading term or
//! anti-aliasing change moves far more than that.

mod common;
use common::{check_snapshot, Tolerance};

const SIZE: (u32, u32) = (256, 256);
const TOL: Tolerance = Tolerance {
    mean: 0.25,
    threshold: 24,
    share: 0.002,
};

fn snapshot(name: &str) {
    let gpu = common::gpu();
    let scene = common::scene(name);
    let img = kami::render::render_scene(&gpu, &scene, SIZE).unwrap();
    check_snapshot(name, &img, TOL);
}

#[test]
fn bob() {
    snapshot("bob");
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
    let mut scene = common::scene("bob");
    scene.render.msaa = 1;
    scene.render.supersample = 1;
    let img = kami::render::render_scene(&gpu, &scene, SIZE).unwrap();
    check_snapshot("bob_msaa1", &img, TOL);
}

/// The wind gust (Anjyo Fig. 10) at frames 10, 15 and 20: groom, simulation and rendering
/// all on the GPU.
#[test]
fn gust_frames_10_15_20() {
    let gpu = common::gpu();
    let mut scene = common::scene("gust");
    for g in &mut scene.groups {
        g.count /= 2;
    }
    kami::render::render_animation(&gpu, &scene, SIZE, 10..=20, |f, img| {
        if f % 5 == 0 {
            check_snapshot(&format!("gust_{f:02}"), &img, TOL);
        }
        Ok(())
    })
    .unwrap();
}
