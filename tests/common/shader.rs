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

/// The vectors of the WGSL array constant `name` (an array constructor of
/// vector constructors of f32 literals, as the emitters write them).
pub fn wgsl_vectors(module: &naga::Module, name: &str) -> Vec<Vec<f32>> {
    use naga::{Expression, Literal};
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("constant {name} not in the module"));
    let e = &module.global_expressions;
    let scalar = |h: naga::Handle<Expression>| match e[h] {
        Expression::Literal(Literal::F32(v)) => v,
        ref other => panic!("{name}: component {other:?} is not an f32 literal"),
    };
    let Expression::Compose { ref components, .. } = e[c.init] else {
        panic!("{name} is not an array constructor");
    };
    components
        .iter()
        .map(|&v| match e[v] {
            Expression::Compose { ref components, .. } => {
                components.iter().map(|&x| scalar(x)).collect()
            }
            ref other => panic!("{name}: element {other:?} is not a vector"),
        })
        .collect()
}
