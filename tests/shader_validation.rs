//! Every WGSL module parses and validates with naga, without a GPU.

#[test]
fn every_shader_validates() {
    for (name, source) in kami::shaders::ALL {
        let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| {
            panic!("{name}.wgsl does not parse:\n{}", e.emit_to_string(source))
        });
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            // Per-sample shading (sub-pixel hair coverage): Kami requires the adapter to
            // have it.
            naga::valid::Capabilities::MULTISAMPLED_SHADING,
        )
        .validate(&module)
        .unwrap_or_else(|e| {
            panic!(
                "{name}.wgsl does not validate:\n{}",
                e.emit_to_string(source)
            )
        });
    }
}

/// The registry covers every shader file on disk (a new pass cannot skip validation).
#[test]
fn registry_lists_every_shader_file() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let stem = path.file_stem().unwrap().to_str().unwrap().to_string();
            assert!(
                kami::shaders::ALL.iter().any(|(n, _)| *n == stem),
                "shaders/{stem}.wgsl is not in kami::shaders::ALL"
            );
        }
    }
}
