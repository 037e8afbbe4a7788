//! Every WGSL shader parses and validates with naga (as wgpu will see it).

#[test]
fn every_shader_validates() {
    let sources = swarmshot::render::shader_sources();
    assert!(!sources.is_empty());
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
        let entries: &[&str] = if compute {
            &["cs_main"]
        } else {
            &["vs_main", "fs_main"]
        };
        for &entry in entries {
            assert!(
                module.entry_points.iter().any(|e| e.name == entry),
                "{name} lacks {entry}"
            );
        }
    }
}
