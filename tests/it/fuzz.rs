//! The fuzz harness in `cargo test`: every seed of `tests/fuzz_corpus/` replays without a
//! finding, and a short fixed-seed run per target finds nothing (the long run is
//! `cargo run --release --example fuzz`, docs/fuzzing.md). A failure prints the input.

use kami::fuzz::{self, Finding, Target};
use std::path::Path;

/// Inputs per target in `cargo test`: about a second each in the debug build.
const ITERS: u64 = 20_000;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn seeds(target: Target) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let dir = target.corpus_dir(root());
    let files = fuzz::load_corpus(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    assert!(files.len() >= 3, "{} has too few seeds", dir.display());
    files
}

fn short_run(target: Target) {
    assert!(fuzz::allocations_watched(), "CappedAlloc is not installed");
    let seeds: Vec<Vec<u8>> = seeds(target).into_iter().map(|(_, b)| b).collect();
    let start = std::time::Instant::now();
    let stats = fuzz::fuzz(target, &seeds, ITERS, 1, |_, _| {});
    eprintln!(
        "{}: {} inputs in {:.1} s, {} outcome classes, corpus {} -> {}, {} refused through a contained panic",
        target.name(),
        stats.inputs,
        start.elapsed().as_secs_f64(),
        stats.classes,
        stats.corpus.0,
        stats.corpus.1,
        stats.contained
    );
    // Only the binary USD reader contains panics (openusd's); nothing else may.
    if target != Target::Usdc {
        assert_eq!(stats.contained, 0, "contained panics outside openusd");
    }
    let report: Vec<String> = stats
        .distinct
        .iter()
        .map(|(f, input)| fuzz::describe(target, f, input))
        .collect();
    assert!(
        report.is_empty(),
        "{} findings in {} inputs:\n{}",
        stats.findings,
        stats.inputs,
        report.join("\n")
    );
    // The mutator must get past the first error of each format, or this run tests little.
    assert!(
        stats.classes >= 10,
        "only {} outcome classes",
        stats.classes
    );
}

#[test]
fn scene_short_run() {
    short_run(Target::Scene);
}

#[test]
fn obj_short_run() {
    short_run(Target::Obj);
}

#[test]
fn off_short_run() {
    short_run(Target::Off);
}

#[test]
fn ply_short_run() {
    short_run(Target::Ply);
}

#[test]
fn hair_short_run() {
    short_run(Target::Hair);
}

#[test]
fn lines_short_run() {
    short_run(Target::Lines);
}

#[test]
fn usda_short_run() {
    short_run(Target::Usda);
}

#[test]
fn usdc_short_run() {
    short_run(Target::Usdc);
}

#[test]
fn abc_short_run() {
    short_run(Target::Abc);
}

/// Every seed (and every input once found and kept as a seed) runs without a finding.
#[test]
fn corpus_replays_cleanly() {
    let mut report = Vec::new();
    for target in Target::ALL {
        for (path, bytes) in seeds(target) {
            if let Err(f) = fuzz::run_one(target, &bytes) {
                report.push(format!(
                    "{}: {}",
                    path.display(),
                    fuzz::describe(target, &f, &bytes)
                ));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

/// The harness sees what it is for: a panic, a large allocation and a broken promise of
/// each kind of input (mesh, groom, scene).
#[test]
fn the_harness_reports_panics_allocations_and_broken_promises() {
    let panic = fuzz::run_guarded(b"x", || panic!("boom {}", 7));
    match panic {
        Err(Finding { signature, detail }) => {
            assert!(
                signature.starts_with("panic at tests/it/fuzz.rs:"),
                "{signature}"
            );
            assert!(detail.ends_with("boom 7"), "{detail}");
        }
        other => panic!("expected a finding, got {other:?}"),
    }
    let big = fuzz::run_guarded(b"x", || {
        let v = std::hint::black_box(Vec::<u8>::with_capacity(fuzz::ALLOC_CAP + 1));
        Ok(format!("{}", v.capacity()))
    });
    assert!(
        matches!(&big, Err(f) if f.signature == "allocation above the cap"),
        "{big:?}"
    );
    let fine = fuzz::run_guarded(b"x", || Ok(format!("{:?}", vec![0u8; 1 << 20].len())));
    assert!(fine.is_ok(), "{fine:?}");
    // A mesh that loads with a zero normal breaks the loaders' promise of unit normals.
    let mut mesh =
        kami::scene::mesh::Mesh::from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap();
    fuzz::check_mesh(&mesh).unwrap();
    mesh.normals[0] = glam::DVec3::ZERO;
    assert!(fuzz::check_mesh(&mesh).is_err());
    // Finite but so far out that the bounding box centre overflows: `fit` makes NaNs.
    mesh.normals[0] = glam::DVec3::Z;
    for (p, x) in mesh.positions.iter_mut().zip([1.0e308, 1.7e308, 1.5e308]) {
        p.x = x;
    }
    assert!(fuzz::check_mesh(&mesh).is_err(), "fit overflows");
    // A groom: invariants, finite attributes and the `.hair` round trip.
    let groom = kami::formats::Groom {
        counts: vec![2, 3],
        points: vec![
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 2.0, 0.5],
        ],
        widths: Some(vec![0.1; 5]),
        opacities: Some(vec![1.0; 5]),
        colors: None,
        ..Default::default()
    };
    fuzz::check_groom(&groom).unwrap();
    let mut broken = groom.clone();
    broken.counts[1] = 4;
    let f = fuzz::check_groom(&broken).expect_err("counts that do not add up");
    assert_eq!(f.signature, "accepted groom breaks its invariants");
    let mut broken = groom.clone();
    broken.opacities.as_mut().unwrap()[3] = f32::NAN;
    fuzz::check_groom(&broken).expect_err("a NaN opacity");
    // A strand of 65,537 points is more than `.hair` counts: not written, not a finding.
    let long = kami::formats::Groom {
        counts: vec![65_537],
        points: (0..65_537).map(|i| [0.0, i as f32, 0.0]).collect(),
        ..Default::default()
    };
    assert!(kami::formats::hair::to_bytes(&long, "long").is_err());
    fuzz::check_groom(&long).unwrap();
    // A scene holding a NaN where validate should have refused it.
    let mut scene = kami::Scene::load(root().join("tests/fuzz_corpus/scene/minimal.ron")).unwrap();
    fuzz::check_scene(&scene).unwrap();
    scene.groups_mut()[0].length_jitter = f64::NAN;
    assert!(fuzz::check_scene(&scene).is_err());
}

/// Each kind's invariants (`Kind::invariants`) run on every scene the fuzzer sees accepted.
/// Anjyo's catches a hairline that gives a non-finite zenith, which validation must refuse
/// first; no other kind objects to that scene.
#[test]
fn kind_invariants_catch_what_validation_must_refuse() {
    let mut s = crate::common::scene("bob");
    s.groups_mut()[0].roots.hairline = Some(vec![(0.0, f64::NAN), (180.0, 60.0)]);
    let broken: Vec<_> = kami::systems::KINDS
        .iter()
        .filter_map(|k| (k.invariants)(&s).err())
        .collect();
    assert_eq!(broken.len(), 1, "{broken:?}");
    assert_eq!(broken[0].0, "hairline gives a non-finite theta");
    assert!(kami::systems::validate(&s).is_err());
    let bob = crate::common::scene("bob");
    assert!(kami::systems::KINDS
        .iter()
        .all(|k| (k.invariants)(&bob).is_ok()));
}
