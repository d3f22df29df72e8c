//! A bench's default scene is found from any working directory (`scene::shipped`): an
//! installed `kami bench strips` run outside the repository reads the shipped scene, and
//! run from the checkout it names the same relative path its reports have always named.
//! The working directory is passed in (`shipped_from`), not changed: the process's is
//! shared by every test.

use kami::scene::{shipped, shipped_from};
use std::path::{Path, PathBuf};

const STRIPS: &str = "assets/scenes/strips.ron";

#[test]
fn default_scenes_resolve_from_any_working_directory() {
    let elsewhere = std::env::temp_dir().join("kami_bench_paths_elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    assert!(!elsewhere.join(STRIPS).exists());

    // Elsewhere: the shipped scene, loaded whole (its EFF file lies beside it, named
    // relative to the scene), as `kami bench strips` loads its default.
    let found = shipped_from(&elsewhere, STRIPS);
    assert!(found.is_absolute(), "{}", found.display());
    let scene = kami::Scene::load(&found).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.strips().is_some());
    // The folder defaults of `bench backends` and `bench fur` too.
    assert!(shipped_from(&elsewhere, "assets/scenes")
        .join("gust.ron")
        .is_file());

    // From the checkout (as `cargo test` runs): the path as given.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    assert_eq!(shipped_from(root, STRIPS), PathBuf::from(STRIPS));
    assert_eq!(shipped(STRIPS), PathBuf::from(STRIPS));

    // A scene of that name in the working directory is the one read.
    let own = std::env::temp_dir().join("kami_bench_paths_own");
    std::fs::create_dir_all(own.join("assets/scenes")).unwrap();
    std::fs::write(own.join(STRIPS), "").unwrap();
    assert_eq!(shipped_from(&own, STRIPS), PathBuf::from(STRIPS));
}
