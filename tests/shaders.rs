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
        for entry in ["vs_main", "fs_main"] {
            assert!(
                module.entry_points.iter().any(|e| e.name == entry),
                "{name} lacks {entry}"
            );
        }
    }
}
