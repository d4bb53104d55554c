//! The WGSL the tracer runs and what the host shares with it: the uniform
//! block and layer structs, the layer stack in f32, and a generated header
//! of constants whose one definition is in Rust (the tally layout and fixed
//! point, Philox's constants, the roulette's survival chance, the isotropic
//! cut of the phase function), so the shaders declare none of their own.

use super::sums::*;
use super::{Layer, Params};
use crate::gpu::{wgsl_u32_consts, WGSL_FRESNEL, WGSL_WIDE_MUL};
use crate::material::{Channel, Material};
use crate::profile::mc::tracer::{HG_ISOTROPIC, ROULETTE_CHANCE};

pub(super) const PHILOX: &str = super::philox::PHILOX_WGSL;
pub(super) const TRACE: &str = include_str!("../../../../shaders/mc_trace.wgsl");
pub(super) const KAT: &str = include_str!("../../../../shaders/mc_kat.wgsl");

/// Threads per workgroup in mc_trace.wgsl.
pub(super) const WORKGROUP: u32 = 64;

/// z_bottom of a semi-infinite layer: beyond any reachable depth, finite so
/// that no comparison meets an infinity.
const SEMI_INFINITE: f32 = 3.0e38;

/// The layer stack of one channel, as `tracer::Stack` builds it.
pub(super) fn gpu_layers(m: &Material, ch: Channel) -> Vec<Layer> {
    let c = ch.index();
    let mut z = 0.0f64;
    m.layers
        .iter()
        .map(|l| {
            let sigma_t = l.sigma_a[c] + l.sigma_s[c];
            let z_top = z;
            z = l.thickness.map_or(f64::INFINITY, |t| z + t);
            Layer {
                z_top: z_top as f32,
                z_bottom: if z.is_finite() {
                    z as f32
                } else {
                    SEMI_INFINITE
                },
                sigma_t: sigma_t as f32,
                inv_sigma_t: (1.0 / sigma_t) as f32,
                albedo: (l.sigma_s[c] / sigma_t) as f32,
                g: l.g[c] as f32,
                n: l.eta as f32,
                _pad: 0.0,
            }
        })
        .collect()
}

/// The WGSL of `body` (mc_trace.wgsl or mc_kat.wgsl) after what it shares
/// with the host: the constants, the structs, the wide product and the
/// generator (mc_philox.wgsl).
pub(super) fn shader_source(body: &str) -> String {
    [
        &shader_consts(),
        Params::WGSL,
        Layer::WGSL,
        WGSL_WIDE_MUL,
        WGSL_FRESNEL,
        PHILOX,
        body,
    ]
    .join("\n")
}

/// The integer constants of the shaders: Philox's, the tally layout, the
/// workgroup size.
fn u32_consts() -> Vec<(&'static str, u32)> {
    let word = |name, i: usize| (name, i as u32);
    let mut v = super::philox::philox_wgsl_constants().to_vec();
    v.extend([
        word("T_RD", T_RD),
        word("T_TR", T_TR),
        word("T_ABS", T_ABS),
        word("T_BEYOND", T_BEYOND),
        word("T_LOSS", T_LOSS),
        word("T_GAIN", T_GAIN),
        word("T_TRUNC", T_TRUNC),
        word("T_TRUNC_N", T_TRUNC_N),
        word("T_EVENTS", T_EVENTS),
        word("T_SATURATED", T_SATURATED),
        word("WORK", WORK),
        word("INCOMPLETE", INCOMPLETE),
        word("TRACED", TRACED),
        word("BINS", BINS),
        word("SUM_WORDS", SUM_WORDS),
        word("MOMENT_WORDS", MOMENT_WORDS),
        ("WORKGROUP", WORKGROUP),
    ]);
    v
}

/// The f32 constants of the shaders, each the f32 rounding of the CPU
/// tracer's f64 (the rounding WGSL applied to the literals the shader once
/// spelled out): the fixed point of the tallies (also the lattice of the
/// 24-bit uniforms), the survival chance of Russian roulette, 2 pi, and the
/// |g| below which the phase function is sampled isotropically.
fn f32_consts() -> Vec<(&'static str, f32)> {
    vec![
        ("FIX", (1.0 / TALLY_RESOLUTION) as f32),
        ("ROULETTE_CHANCE", ROULETTE_CHANCE as f32),
        ("PI2", std::f64::consts::TAU as f32),
        ("HG_ISOTROPIC", HG_ISOTROPIC as f32),
    ]
}

/// WGSL declarations `const NAME: f32 = VALUEf;` of `consts`. `{:?}` of an
/// f32 is the shortest decimal that parses back to the same f32, and the
/// `f` suffix makes WGSL parse it as an f32 directly (no rounding through an
/// abstract float), so the shader holds exactly the Rust value.
fn wgsl_f32_consts(consts: &[(&str, f32)]) -> String {
    consts
        .iter()
        .map(|(name, value)| format!("const {name}: f32 = {value:?}f;\n"))
        .collect()
}

/// The header of constants prepended to every shader of the tracer.
fn shader_consts() -> String {
    wgsl_u32_consts(&u32_consts()) + &wgsl_f32_consts(&f32_consts())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_assembled_shaders_are_valid_wgsl() {
        crate::gpu::tests::assert_valid_wgsl(&shader_source(TRACE), "mc_trace");
        crate::gpu::tests::assert_valid_wgsl(&shader_source(KAT), "mc_kat");
    }

    /// The header, parsed by naga (the WGSL front end wgpu compiles with),
    /// holds each Rust value bit for bit.
    #[test]
    fn the_generated_constants_hold_the_rust_values() {
        use naga::{Expression, Literal};
        let header = shader_consts();
        let module = naga::front::wgsl::parse_str(&header).unwrap();
        let value = |name: &str| {
            let (_, c) = module
                .constants
                .iter()
                .find(|(_, c)| c.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("{name} not declared in\n{header}"));
            match module.global_expressions[c.init] {
                Expression::Literal(l) => l,
                ref e => panic!("{name}: {e:?}"),
            }
        };
        let (u, f) = (u32_consts(), f32_consts());
        for &(name, want) in &u {
            assert_eq!(value(name), Literal::U32(want), "{name}");
        }
        for &(name, want) in &f {
            let Literal::F32(got) = value(name) else {
                panic!("{name}: not an f32");
            };
            assert_eq!(got.to_bits(), want.to_bits(), "{name}: {got} vs {want}");
        }
        assert_eq!(module.constants.len(), u.len() + f.len());
        // The literals the shader spelled out before the values came from
        // Rust, as WGSL read them (an abstract float, f64, rounded to f32).
        let before = [
            ("FIX", "16777216.0"),
            ("ROULETTE_CHANCE", "0.1"),
            ("PI2", "6.283185307179586"),
            ("HG_ISOTROPIC", "1e-6"),
        ];
        for (name, literal) in before {
            let old = literal.parse::<f64>().unwrap() as f32;
            let now = f.iter().find(|c| c.0 == name).unwrap().1;
            assert_eq!(now.to_bits(), old.to_bits(), "{name}");
        }
    }

    /// Every constant of the header is used by a shader and declared by
    /// none: a shader that spelled one out again would hold a second
    /// definition.
    #[test]
    fn the_shaders_declare_no_constant_of_the_header() {
        let bodies = [TRACE, KAT, PHILOX, WGSL_WIDE_MUL, WGSL_FRESNEL];
        let names: Vec<&str> = u32_consts()
            .iter()
            .map(|c| c.0)
            .chain(f32_consts().iter().map(|c| c.0))
            .collect();
        let words = |s: &str| -> Vec<String> {
            s.split(|c: char| !(c.is_alphanumeric() || c == '_'))
                .filter(|w| !w.is_empty())
                .map(String::from)
                .collect()
        };
        for body in bodies {
            let w = words(body);
            for pair in w.windows(2) {
                let declares = ["const", "override", "let", "var", "fn", "alias"];
                assert!(
                    !(declares.contains(&pair[0].as_str()) && names.contains(&pair[1].as_str())),
                    "a shader declares {} {} itself",
                    pair[0],
                    pair[1]
                );
            }
            // No module-scope constant at all: what a shader needs comes
            // from the header.
            assert!(
                !body.lines().any(|l| l.starts_with("const ")),
                "a shader declares a module-scope constant"
            );
        }
        let all: Vec<String> = bodies.iter().flat_map(|b| words(b)).collect();
        for name in names {
            assert!(all.iter().any(|w| w == name), "{name} is used by no shader");
        }
    }
}
