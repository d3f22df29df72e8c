//! Every WGSL module parses and validates with naga, without a GPU.

#[test]
fn every_shader_validates() {
    let all = kami::stage::shaders();
    assert!(all.len() >= 8, "the registry lost modules: {all:?}");
    for (name, source) in all {
        let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| {
            panic!("{name}.wgsl does not parse:\n{}", e.emit_to_string(source))
        });
        let info = naga::valid::Validator::new(
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
        every_override_setting_validates(name, source, &module, &info);
    }
}

/// The pipelines set `HAIR_PHYSICAL` (`gpu::pipeline::Variant::constants`) and wgpu
/// evaluates and validates the module again with it, per entry point: a function valid
/// before that can fail there (only when a pipeline is built, on every adapter). Both
/// settings, every entry point.
fn every_override_setting_validates(
    name: &str,
    source: &str,
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
) {
    let overrides: Vec<String> = module
        .overrides
        .iter()
        .filter_map(|(_, o)| o.name.clone())
        .filter(|n| n == "HAIR_PHYSICAL")
        .collect();
    if overrides.is_empty() {
        return;
    }
    for value in [0.0, 1.0] {
        let mut constants = naga::back::PipelineConstants::default();
        for o in &overrides {
            constants.insert(o.clone(), value);
        }
        for ep in &module.entry_points {
            if let Err(e) = naga::back::pipeline_constants::process_overrides(
                module,
                info,
                Some((ep.stage, &ep.name)),
                &constants,
            ) {
                let why = match &e {
                    naga::back::pipeline_constants::PipelineConstantError::ValidationError(v) => {
                        v.emit_to_string(source)
                    }
                    other => format!("{other:?}"),
                };
                panic!(
                    "{name}.wgsl, entry point {} with {overrides:?} = {value}:\n{why}",
                    ep.name
                );
            }
        }
    }
}

/// Every `.wgsl` file under `shaders/` (recursively) outside `common/` is a module in the
/// registry or a piece one of them includes, so a new pass cannot skip validation; and every
/// `common/` piece is used.
#[test]
fn registry_lists_every_shader_file() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files = Vec::new();
    let mut dirs = vec![root.clone()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                files.push(path);
            }
        }
    }
    assert!(
        files.len() >= 16,
        "the walk found too few shaders: {files:?}"
    );
    let all = kami::stage::shaders();
    for path in files {
        let rel = path.strip_prefix(&root).unwrap().with_extension("");
        let rel = rel.to_str().unwrap().replace('\\', "/");
        let text = std::fs::read_to_string(&path).unwrap();
        let included = all.iter().any(|(_, src)| src.contains(text.trim()));
        if rel.starts_with("common/") {
            assert!(included, "shaders/{rel}.wgsl is used by no module");
        } else {
            // A kind's own piece (a struct or a vertex stage its modules share) is validated
            // inside the modules that include it.
            assert!(
                all.iter().any(|(n, _)| *n == rel) || included,
                "shaders/{rel}.wgsl is not in kami::stage::shaders() (a Kind's `shaders`, shaders::STAGE or the forces') nor included by a module there"
            );
        }
    }
}

/// `gpu::STORAGE_BUFFERS_PER_STAGE`, which Anjyo's `check_limits` asks of the adapter, is the
/// most storage
/// buffers any registered module declares (over all its groups: a kernel's own and the
/// world's at `WORLD_GROUP`), so an adapter that passes the check can build every pipeline.
#[test]
fn the_storage_buffer_limit_covers_every_module() {
    let mut most = (0, String::new());
    for (name, source) in kami::stage::shaders() {
        let module = naga::front::wgsl::parse_str(source).unwrap();
        let n = module
            .global_variables
            .iter()
            .filter(|(_, g)| matches!(g.space, naga::AddressSpace::Storage { .. }))
            .count() as u32;
        if n > most.0 {
            most = (n, name.to_string());
        }
    }
    assert_eq!(
        most.0,
        kami::gpu::STORAGE_BUFFERS_PER_STAGE,
        "{} declares the most storage buffers",
        most.1
    );
}
