//! Scale (issue 12): per-pass GPU timing through the stage, the scaled scenes of
//! `kami bench scale` and its command-line checks. Speed itself is measured in the bench,
//! never here: these tests check that the clock reads every phase, sanely, and that the
//! sweep builds the scenes it says.

use crate::common;
use crate::common::kami;

use kami::bench::scale::scaled;
use kami::gpu::timing::{GpuTimer, Phase};
use kami::stage::{target, Quality, Stage};

/// Why this device has no timestamp queries, if that is the adapter's own limitation
/// (named); a device whose adapter offers them but which did not ask for them fails.
fn no_timestamps(gpu: &kami::gpu::Gpu) -> Option<String> {
    let wanted = kami::gpu::timing::features();
    if gpu.device.features().contains(wanted) {
        return None;
    }
    assert!(
        !gpu.adapter.features().contains(wanted),
        "{} offers timestamp queries but the device did not ask for them",
        gpu.describe()
    );
    Some(format!(
        "{} has no {:?}",
        gpu.describe(),
        wanted - gpu.adapter.features()
    ))
}

/// Timing only where asked: a stage times nothing until `enable_timing`, and then reads
/// back every phase of a frame (simulation, generation, draw, resolve) as finite, positive
/// milliseconds (each phase really holds its passes: an empty phase reads as the gap
/// between two adjacent timestamps) whose sum fits inside the whole frame. Without
/// timestamps (only where the adapter has none) the stage says so and still draws.
#[test]
fn every_phase_of_a_frame_is_timed_on_the_gpu() {
    let gpu = common::gpu();
    // Enough hair that simulating it takes longer than an empty phase on a software
    // adapter, fur beside it so the generation phase has work too, one sample per pixel
    // so the draw stays quick.
    let mut scene = scaled(&common::scene("gust"), 4000, 16).unwrap();
    *scene.fur_mut() = common::scene("hair_and_fur").fur().clone();
    scene.render.msaa = 1;
    scene.render.supersample = 1;
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene)).unwrap();
    assert!(stage.timer().is_none(), "timing is off until asked for");
    let lacks = no_timestamps(gpu);
    assert_eq!(stage.enable_timing(gpu), lacks.is_none());
    let out = target::Offscreen::new(gpu, (96, 64)).unwrap();
    let look = stage.look();
    if let Some(why) = lacks {
        eprintln!("{why}: the stage times nothing and still draws");
        assert!(stage.timer().is_none() && GpuTimer::new(gpu).is_none());
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        let info = stage.advance(gpu, &mut enc, 1).unwrap();
        assert!(info.substeps > 0, "the gust scene simulates");
        stage
            .render(gpu, &mut enc, &out.view, (96, 64), &look)
            .unwrap();
        gpu.queue.submit([enc.finish()]);
        gpu.wait().unwrap();
        return;
    }
    let mut last = None;
    // The smallest empty pair over the frames: under load one pair may read long (a CI
    // run saw 0.12 ms), and a phase is held to the floor an empty phase reads.
    let mut empty = f64::INFINITY;
    for _ in 0..3 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        let info = stage.advance(gpu, &mut enc, 2).unwrap();
        assert!(info.substeps > 0, "the gust scene simulates");
        stage
            .render(gpu, &mut enc, &out.view, (96, 64), &look)
            .unwrap();
        let t = stage.timer().unwrap();
        t.clear();
        // Two timestamps with nothing between them, in the same stream: what an empty
        // phase reads (headless, nothing else uses the panels' pair).
        t.begin(&mut enc, Phase::Panels);
        t.end(&mut enc, Phase::Panels);
        t.finish(&mut enc);
        gpu.queue.submit([enc.finish()]);
        t.submitted();
        last = t.wait(gpu).unwrap();
        if let Some(e) = last.as_ref().and_then(|t| t.get(Phase::Panels)) {
            empty = empty.min(e);
        }
    }
    let times = last.expect("timings come back after a wait");
    assert!(empty.is_finite(), "the empty pair is timed");
    eprintln!("{times:?}; an empty phase {empty} ms");
    for p in [
        Phase::Simulation,
        Phase::Generation,
        Phase::Draw,
        Phase::Resolve,
    ] {
        let ms = times
            .get(p)
            .unwrap_or_else(|| panic!("{} not timed: {times:?}", p.name()));
        assert!(ms.is_finite(), "{}: {ms}", p.name());
        assert!(
            ms > 0.0 && ms > 4.0 * empty,
            "{}: {ms} ms, no more than an empty phase ({empty} ms): its passes are not \
             between its marks",
            p.name()
        );
    }
    let frame = times.frame.expect("whole frame");
    assert!(frame > 0.0, "{times:?}");
    assert!(
        times.busy() <= frame * 1.0001 + 1e-6,
        "phases {} ms cannot exceed the frame {frame} ms",
        times.busy()
    );
}

/// Results are read without waiting: `poll` never blocks, and with more frames in flight
/// than read-back buffers the extra frames' timings are dropped (counted), not waited for.
#[test]
fn the_timer_never_waits_and_drops_what_it_cannot_hold() {
    let gpu = common::gpu();
    if let Some(why) = no_timestamps(gpu) {
        eprintln!("{why}: no timer to check");
        assert!(GpuTimer::new(gpu).is_none());
        return;
    }
    let mut timer = GpuTimer::new(gpu).unwrap();
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
        let total: u64 = s.groups().iter().map(|g| g.count as u64).sum();
        assert_eq!(total, n as u64, "{n} x {k}");
        assert!(s.groups().iter().all(|g| g.segments == k));
        for (a, b) in s.groups().iter().zip(base.groups()) {
            assert_eq!(a.length, b.length);
        }
    }
    // Proportions kept: gust is 1,800 bangs to 8,200 long hairs.
    let s = scaled(&base, 100_000, 16).unwrap();
    assert_eq!(s.groups()[0].count, 18_000);
    assert_eq!(s.groups()[1].count, 82_000);
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
