//! Layers point one way (../shared/DESIGN.md): read from the sources, so a `use` that points
//! back up fails here, naming the file and the line.

use std::path::Path;

/// The `.rs` files under `dir`, recursively.
fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Layers point one way: systems import neither the viewer (`app`)
/// nor the stage; the forces import no system; the scene imports no solver, no forces and
/// no GPU; `gpu` and the shader list below them name nothing of ours above them.
#[test]
fn layers_point_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut bad = Vec::new();
    let above_scene: &[&str] = &[
        "crate::forces",
        "crate::systems",
        "crate::stage",
        "crate::app",
        "crate::bench",
        "crate::gpu",
        "wgpu::",
    ];
    let rules: [(&str, &[&str]); 5] = [
        ("systems", &["crate::app", "crate::stage"]),
        (
            "forces",
            &[
                "crate::systems",
                "crate::stage",
                "crate::app",
                "crate::bench",
            ],
        ),
        ("scene", above_scene),
        (
            "gpu",
            &[
                "crate::systems",
                "crate::stage",
                "crate::app",
                "crate::scene",
                "crate::forces",
                "crate::bench",
            ],
        ),
        (
            "shaders.rs",
            &["crate::systems", "crate::stage", "crate::app"],
        ),
    ];
    for (below, banned) in rules {
        let mut files = Vec::new();
        let at = src.join(below);
        if at.is_dir() {
            sources(&at, &mut files);
        } else {
            files.push(at);
        }
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            // Code only: comments and string literals (these rules) may name a layer.
            let code = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("//") && !l.contains('"'));
            for (n, line) in code.enumerate() {
                for b in banned.iter().filter(|b| line.contains(**b)) {
                    bad.push(format!("{}: {b} in {line:?} (code line {n})", f.display()));
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "layers pointing back up:\n{}",
        bad.join("\n")
    );
}
