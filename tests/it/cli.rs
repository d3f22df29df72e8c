//! The command line refuses bad values and bad output places with a message that names the
//! flag, before any GPU work, and leaves nothing half-written behind.

use crate::common;
use crate::common::kami;
use crate::common::scratch;
use std::path::Path;
use std::process::Command;

/// Files in `dir` (names), to show nothing was left behind.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn refused(args: &[&str], says: &str) {
    let out = kami(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "kami {args:?} succeeded; expected an error saying {says:?}"
    );
    assert!(
        err.contains(says) && !err.contains("panicked"),
        "kami {args:?}: expected {says:?} in:\n{err}"
    );
}

#[test]
fn bad_render_values_name_the_flag() {
    let bob = common::root().join("assets/scenes/bob.ron");
    let bob = bob.to_str().unwrap();
    let dir = scratch("values");
    let png = dir.join("x.png");
    let png = png.to_str().unwrap();
    for (args, says) in [
        (vec!["--size", "0x0"], "between 1x1 and 16384x16384"),
        (vec!["--size", "20000x10"], "between 1x1 and 16384x16384"),
        (vec!["--size", "640"], "must look like 1280x720"),
        (vec!["--frames", "5..2"], "need first <= last"),
        (vec!["--frames", "0-40"], "must look like 0..40"),
        (vec!["--frames", "0..x"], "bad last frame"),
        (vec!["--msaa", "3"], "use 1 or 4"),
        (
            vec!["--strands", "lines"],
            "strands must be auto, ribbons or compute",
        ),
        (vec!["--supersample", "9"], "--supersample"),
        (vec!["--fps", "0", "--frames", "0..1"], "--fps"),
        (vec!["--gif", "a.gif"], "--gif and --apng need --frames"),
    ] {
        let mut all = vec!["render", bob, "-o", png];
        all.extend(args);
        refused(&all, says);
    }
    assert!(listing(&dir).is_empty(), "left behind: {:?}", listing(&dir));
}

/// Beyond the adapter's texture limit (16384 pixels supersampled 4x) is refused by the
/// limits check, before anything is allocated.
#[test]
fn size_beyond_the_adapter_is_refused() {
    let bob = common::root().join("assets/scenes/bob.ron");
    let dir = scratch("adapter");
    let png = dir.join("x.png");
    refused(
        &[
            "render",
            bob.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--size",
            "16384x16384",
            "--supersample",
            "4",
            "--software",
        ],
        "this adapter allows at most",
    );
    assert!(listing(&dir).is_empty(), "left behind: {:?}", listing(&dir));
}

#[test]
fn bad_output_places_are_refused_before_rendering() {
    let bob = common::root().join("assets/scenes/bob.ron");
    let bob = bob.to_str().unwrap();
    let dir = scratch("places");
    let d = |p: &str| dir.join(p).to_string_lossy().into_owned();
    std::fs::create_dir(dir.join("folder.png")).unwrap();
    std::fs::write(dir.join("plain_file"), b"x").unwrap();
    let before = listing(&dir);
    for (args, says) in [
        (vec!["-o", &d("missing/x.png")], "does not exist"),
        (vec!["-o", &d("folder.png")], "is a directory"),
        (vec!["-o", &d("x.jpg")], "must end in .png"),
        (vec!["-o", "/proc/kami.png"], "cannot write into the folder"),
        (
            vec!["--frames", "0..1", "-o", &d("plain_file")],
            "is a file; --frames writes numbered PNGs into a folder",
        ),
        (
            vec!["--frames", "0..1", "-o", &d("f"), "--gif", &d("no/a.gif")],
            "does not exist",
        ),
        (
            vec!["--frames", "0..1", "-o", &d("f"), "--apng", &d("a.gif")],
            "must end in .png or .apng",
        ),
    ] {
        let mut all = vec!["render", bob];
        all.extend(args.iter().copied());
        refused(&all, says);
    }
    // The frames folder of the last two cases is created (as `render --frames` does), empty.
    let mut after = listing(&dir);
    after.retain(|f| f != "f");
    assert_eq!(after, before, "refused runs left files behind");
    assert!(listing(&dir.join("f")).is_empty());
}

#[test]
fn bad_viewer_options_are_refused_before_the_window_opens() {
    let dir = scratch("viewer");
    let d = |p: &str| dir.join(p).to_string_lossy().into_owned();
    for (args, says) in [
        (vec!["--set", "colr=1,1,1"], "unknown key \"colr\""),
        (vec!["--set", "msaa=3"], "render.msaa"),
        (vec!["--set", "msaa=4.5"], "is not a whole number"),
        (
            vec!["--set", "strands=lines"],
            "strands must be auto, ribbons or compute",
        ),
        (vec!["--set", "10:lod"], "expected KEY=VALUE"),
        (
            vec!["--screenshot-at", "30shot.png"],
            "must look like 30:shot.png",
        ),
        (vec!["--screenshot-at", "x:shot.png"], "bad frame \"x\""),
        (vec!["--screenshot-at", "30:"], "no file name"),
        (
            vec!["--screenshot-at", &format!("5:{}", d("no/shot.png"))],
            "does not exist",
        ),
        (
            vec![
                "--exit-after-frames",
                "10",
                "--screenshot-at",
                &format!("50:{}", d("late.png")),
            ],
            "is never drawn",
        ),
        (vec!["--exit-after-frames", "0"], "--exit-after-frames"),
        (vec!["--size", "0x720"], "between 1x1"),
    ] {
        let mut all = vec!["view"];
        all.extend(args.iter().copied());
        refused(&all, says);
    }
    assert!(listing(&dir).is_empty(), "left behind: {:?}", listing(&dir));
}

/// A good render writes exactly the file asked for: no probe or partial file stays.
#[test]
fn a_good_render_leaves_only_its_image() {
    let bob = common::root().join("assets/scenes/bob.ron");
    let dir = scratch("good");
    let png = dir.join("bob.png");
    let out = kami(&[
        "render",
        bob.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "48x32",
        "--software",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(listing(&dir), vec!["bob.png".to_string()]);
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (48, 32));
}

/// A user's mistake is one clear message, even where Rust users set `RUST_BACKTRACE`: no
/// stack trace follows it, and the status is 1.
#[test]
fn a_user_error_prints_no_backtrace() {
    let out = Command::new(env!("CARGO_BIN_EXE_kami"))
        .args(["render", "no-such-scene.ron"])
        .env("RUST_BACKTRACE", "1")
        .env("RUST_LIB_BACKTRACE", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no-such-scene.ron"), "{err}");
    assert!(
        !err.to_lowercase().contains("backtrace") && err.lines().count() <= 3,
        "more than the message:\n{err}"
    );
}

/// Each bench's help says what it does under its own name (a doc comment once sat on the
/// wrong variant: `scale` showed the dynamics text and `dynamics` showed nothing).
#[test]
fn bench_help_describes_each_bench_under_its_name() {
    let out = kami(&["bench", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{help}");
    // The text listed after a bench's name.
    let text = |name: &str| {
        help.lines()
            .find_map(|l| l.trim_start().strip_prefix(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} in:\n{help}"))
            .trim_start()
            .to_string()
    };
    assert!(
        text("dynamics").starts_with("Projective dynamics"),
        "{help}"
    );
    assert!(text("scale").starts_with("GPU time per pass"), "{help}");
    // The kinds' benches come from one table (`bench::kinds`): each listed with its text.
    for k in kami::bench::kinds::KIND_BENCHES {
        let first: String = k.about.chars().take(20).collect();
        assert!(text(k.name).starts_with(&first), "{}: {help}", k.name);
    }
    let out = kami(&["bench", "dynamics", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("Projective dynamics"), "{help}");
    // A table bench's options: its input (`--scenes` for fur), `--frames`, `--out`.
    let out = kami(&["bench", "fur", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for opt in [
        "--scenes <SCENES>",
        "--frames <FRAMES>",
        "--out <OUT>",
        "--software",
    ] {
        assert!(help.contains(opt), "no {opt} in:\n{help}");
    }
    refused(&["bench", "wisps", "--frames", "0"], "--frames");
}

/// `kami render --set` drives a render with the viewer's keys through the viewer's code: the
/// image equals the render of the scene edited by hand, window keys and a later frame without
/// `--frames` are refused before any GPU work.
#[test]
fn render_set_matches_the_scene_edited_by_hand() {
    let bob = common::root().join("assets/scenes/bob.ron");
    let dir = scratch("render-set");
    let mut edited = kami::Scene::load(&bob).unwrap();
    for g in edited.groups_mut() {
        g.material.color = [0.9, 0.2, 0.1];
    }
    let by_hand = dir.join("by_hand.ron");
    std::fs::write(&by_hand, edited.to_ron()).unwrap();
    let render = |scene: &Path, png: &str, extra: &[&str]| {
        let out = dir.join(png);
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--size",
            "96x96",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let run = kami(&args);
        assert!(
            run.status.success(),
            "kami {args:?}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        image::open(&out).unwrap().to_rgba8()
    };
    let set = render(&bob, "set.png", &["--set", "color=0.9,0.2,0.1"]);
    let hand = render(&by_hand, "hand.png", &[]);
    let plain = render(&bob, "plain.png", &[]);
    assert!(
        set == hand,
        "--set color differs from the scene edited by hand"
    );
    assert!(set != plain, "--set color changed nothing");
    let bob = bob.to_str().unwrap();
    refused(
        &["render", bob, "--set", "play=off"],
        "`play` drives the viewer's window",
    );
    refused(
        &["render", bob, "--set", "3:color=1,1,1"],
        "a later frame needs --frames",
    );
    refused(&["render", bob, "--set", "color=1,2"], "--set color=1,2");
}
