//! Every shader parses and validates with naga — no GPU needed, so shader typos fail here first.

fn validate(label: &str, source: &str) {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(source)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(source)));
}

#[test]
fn every_render_shader_validates() {
    let shaders = sylvan_render::pipeline::shader_sources();
    assert!(shaders.len() >= 3);
    for (label, source) in shaders {
        validate(label, &source);
    }
}

#[test]
fn resolve_shader_validates() {
    validate("resolve", sylvan_gpu::RESOLVE_WGSL);
}
