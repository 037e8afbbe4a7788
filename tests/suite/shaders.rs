//! Every WGSL shader parses and validates with naga (as wgpu will see it).

#[test]
fn every_shader_validates() {
    let sources = swarmshot::render::shader_sources();
    // Every file in shaders/ reaches the validator, as a pipeline of its own or as a part
    // included into one: a new shader that is not listed in `shader_sources` fails here.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files = 0;
    for entry in std::fs::read_dir(&dir).expect("shaders/ is readable") {
        let path = entry.expect("shaders/ entry").path();
        if path.extension().and_then(|e| e.to_str()) != Some("wgsl") {
            continue;
        }
        files += 1;
        let text = std::fs::read_to_string(&path).expect("shader file is readable");
        assert!(
            sources.iter().any(|(_, src)| src.contains(text.trim())),
            "{} is not validated: list it in render::shader_sources",
            path.display()
        );
    }
    assert!(
        files >= sources.len(),
        "{files} shader files for {} pipelines",
        sources.len()
    );
    for (name, src) in sources {
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        let compute = module
            .entry_points
            .iter()
            .any(|e| e.stage == naga::ShaderStage::Compute);
        let entries: &[&str] = if compute { &["cs_main"] } else { &["vs_main"] };
        for &entry in entries {
            assert!(
                module.entry_points.iter().any(|e| e.name == entry),
                "{name} lacks {entry}"
            );
        }
        // A render shader has fragment stages: fs_main, or named ones (flat_paint's
        // fs_fill and fs_picture).
        assert!(
            compute
                || module
                    .entry_points
                    .iter()
                    .any(|e| e.stage == naga::ShaderStage::Fragment),
            "{name} has no fragment entry point"
        );
    }
}
