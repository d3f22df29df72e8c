//! Scale (issue 12): per-pass GPU timing through the stage, the scaled scenes of
//! `kami bench scale` and its command-line checks. Speed itself is measured in the bench,
//! never here: these tests check that the clock reads every phase, sanely, and that the
//! sweep builds the scenes it says.

mod common;

use kami::bench::scale::scaled;
use kami::gpu::timing::{GpuTimer, Phase};
use kami::stage::{target, Quality, Stage};
use std::process::Command;

fn kami(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_kami"))
        .args(args)
        .current_dir(common::root())
        .output()
        .expect("run kami")
}

/// Timing only where asked: a stage times nothing until `enable_timing`, and then reads
/// back every phase of a frame (simulation, generation, draw, resolve) as finite,
/// non-negative milliseconds whose sum fits inside the whole frame.
#[test]
fn every_phase_of_a_frame_is_timed_on_the_gpu() {
    let gpu = common::gpu();
    let scene = scaled(&common::scene("gust"), 600, 8).unwrap();
    let mut stage = Stage::new(&gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene)).unwrap();
    assert!(stage.timer().is_none(), "timing is off until asked for");
    let has = gpu
        .device
        .features()
        .contains(kami::gpu::timing::features());
    assert_eq!(stage.enable_timing(&gpu), has);
    if !has {
        eprintln!(
            "{}: no timestamp queries; nothing more to check",
            gpu.describe()
        );
        return;
    }
    let out = target::Offscreen::new(&gpu, (96, 64)).unwrap();
    let look = stage.look();
    let mut last = None;
    for _ in 0..3 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        let info = stage.advance(&gpu, &mut enc, 1).unwrap();
        assert!(info.substeps > 0, "the gust scene simulates");
        stage
            .render(&gpu, &mut enc, &out.view, (96, 64), &look)
            .unwrap();
        let t = stage.timer().unwrap();
        t.clear();
        t.finish(&mut enc);
        gpu.queue.submit([enc.finish()]);
        t.submitted();
        last = t.wait(&gpu).unwrap();
    }
    let times = last.expect("timings come back after a wait");
    for p in [
        Phase::Simulation,
        Phase::Generation,
        Phase::Draw,
        Phase::Resolve,
    ] {
        let ms = times
            .get(p)
            .unwrap_or_else(|| panic!("{} not timed: {times:?}", p.name()));
        assert!(ms.is_finite() && ms >= 0.0, "{}: {ms}", p.name());
    }
    assert_eq!(times.get(Phase::Panels), None, "no panels headless");
    let frame = times.frame.expect("whole frame");
    assert!(frame > 0.0, "{times:?}");
    assert!(
        times.busy() <= frame * 1.0001 + 1e-6,
        "phases {} ms cannot exceed the frame {frame} ms",
        times.busy()
    );
    // The draw at least takes time: the frame's passes are really measured.
    assert!(times.get(Phase::Draw).unwrap() > 0.0, "{times:?}");
}

/// Results are read without waiting: `poll` never blocks, and with more frames in flight
/// than read-back buffers the extra frames' timings are dropped (counted), not waited for.
#[test]
fn the_timer_never_waits_and_drops_what_it_cannot_hold() {
    let gpu = common::gpu();
    let Some(mut timer) = GpuTimer::new(&gpu) else {
        eprintln!("{}: no timestamp queries", gpu.describe());
        return;
    };
    // Six frames recorded back to back, none read: the ring holds four.
    for _ in 0..6 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        timer.begin(&mut enc, Phase::Simulation);
        timer.end(&mut enc, Phase::Simulation);
        timer.finish(&mut enc);
    }
    assert_eq!(
        timer.dropped, 2,
        "two frames found no free read-back buffer"
    );
    // An end without a begin records nothing and a frame with nothing timed reads nothing.
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    timer.end(&mut enc, Phase::Draw);
    timer.finish(&mut enc);
    assert_eq!(timer.dropped, 2);
}

/// The bench's scenes: the requested strands over the groups in their proportions, every
/// group re-segmented, the hair length kept; counts the scene cannot hold are refused.
#[test]
fn scaled_scenes_have_the_counts_asked_for() {
    let base = common::scene("gust");
    for (n, k) in [(1000, 8), (12_345, 32), (2, 64)] {
        let s = scaled(&base, n, k).unwrap();
        let total: u64 = s.groups.iter().map(|g| g.count as u64).sum();
        assert_eq!(total, n as u64, "{n} x {k}");
        assert!(s.groups.iter().all(|g| g.segments == k));
        for (a, b) in s.groups.iter().zip(&base.groups) {
            assert_eq!(a.length, b.length);
        }
    }
    // Proportions kept: gust is 1,800 bangs to 8,200 long hairs.
    let s = scaled(&base, 100_000, 16).unwrap();
    assert_eq!(s.groups[0].count, 18_000);
    assert_eq!(s.groups[1].count, 82_000);
    let err = scaled(&base, 5_000_000, 8).unwrap_err().to_string();
    assert!(err.contains("groups[..].count"), "{err}");
    let err = scaled(&base, 1, 8).unwrap_err().to_string();
    assert!(err.contains("one per hair group"), "{err}");
}

#[test]
fn bench_scale_refuses_bad_values_naming_the_flag() {
    for (args, says) in [
        (vec!["--strands", "0"], "strand count 0 must be between 1"),
        (
            vec!["--strands", "10,x"],
            "strand count \"x\" is not a whole number",
        ),
        (
            vec!["--segments", "300"],
            "segments per strand 300 must be between 1 and 256",
        ),
        (vec!["--size", "0x5"], "between 1x1"),
        (vec!["--frames", "0"], "--frames"),
    ] {
        let mut all = vec!["bench", "scale", "--software"];
        all.extend(args);
        let out = kami(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{all:?} succeeded");
        assert!(
            err.contains(says) && !err.contains("panicked"),
            "{all:?}: expected {says:?} in {err}"
        );
    }
    // A scene without dynamic hair is refused naming the file.
    let out = kami(&[
        "bench",
        "scale",
        "--software",
        "--scene",
        "assets/scenes/fur.ron",
        "--out",
        "target/scale-refused",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("assets/scenes/fur.ron") && err.contains("dynamic"),
        "{err}"
    );
}
