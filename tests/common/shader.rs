//! naga (wgpu's shader compiler) as the tests' judge of emitted shader
//! text: a GLSL fragment shader parses, a module validates.

/// Validates `module` with every check and capability naga has; panics
/// naming `what` when it is refused.
pub fn validate(module: &naga::Module, what: &str) {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(module)
    .unwrap_or_else(|e| panic!("{what}: naga validation failed: {e:?}"));
}

/// Parses `src` as a GLSL fragment shader; panics naming `what` (and
/// printing the source) when naga refuses it.
pub fn parse_glsl(src: &str, what: &str) -> naga::Module {
    let mut front = naga::front::glsl::Frontend::default();
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
    front
        .parse(&options, src)
        .unwrap_or_else(|e| panic!("{what}: GLSL parse failed: {e:?}\n{src}"))
}
