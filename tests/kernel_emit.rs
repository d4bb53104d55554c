//! The emitted shader arrays: they parse and validate with naga (wgpu 30's
//! shader compiler) in WGSL and GLSL; HLSL has no parser in naga, so its
//! text is checked by mapping HLSL's types to GLSL's (the array syntax with
//! a brace initializer is the same) and parsing that; the WGSL numbers run
//! through the project's wgpu pass reproduce the CPU result; the header
//! carries the integration notes; SVD factors sum to positive values.

mod filter_support;
use filter_support::shader::{parse_glsl, validate, wgsl_vectors};
use filter_support::*;
use ssskit::filter::{gpu, screen_space, taps_for, Taps, Which};
use ssskit::kernel::emit::{emit, Lang};
use ssskit::kernel::KernelFile;
use std::path::Path;

fn kernel(name: &str) -> KernelFile {
    KernelFile::read(Path::new(&format!("kernels/{name}.json"))).unwrap()
}

/// A fragment shader that reads every tap of every pass, so nothing is
/// dead code.
fn glsl_shader(arrays: &str, passes: usize) -> String {
    let reads: String = (0..passes)
        .map(|p| {
            format!("    for (uint i = 0u; i < sss_taps; i++) {{ s += sss_kernel_{p}[i]; }}\n")
        })
        .collect();
    format!(
        "#version 450\n{arrays}\nlayout(location = 0) out vec4 o;\nvoid main() {{\n    vec4 s = vec4(0.0);\n{reads}    o = s;\n}}\n"
    )
}

/// The 4-vectors of the WGSL constant `name`.
fn wgsl_array(module: &naga::Module, name: &str) -> Vec<[f32; 4]> {
    wgsl_vectors(module, name)
        .into_iter()
        .map(|v| <[f32; 4]>::try_from(v).unwrap_or_else(|v| panic!("{name}: {v:?} is not a vec4")))
        .collect()
}

#[test]
fn emitted_arrays_parse_and_validate_in_every_language() {
    for name in ["skin1-svd1", "skin1-svd3", "marble-preintegrate"] {
        let k = kernel(name);
        let passes = k.taps.passes.len();
        // WGSL, with the engine example of docs/engines.md using it.
        let example = std::fs::read_to_string("docs/examples/engine_pass.wgsl").unwrap();
        let src = format!("{}\n{example}", emit(&k, Lang::Wgsl).unwrap());
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{name}: WGSL: {}", e.emit_to_string(&src)));
        validate(&module, name);
        let arrays = |m: &naga::Module| -> Vec<Vec<[f32; 4]>> {
            (0..passes)
                .map(|p| wgsl_array(m, &format!("sss_kernel_{p}")))
                .collect()
        };
        let from_wgsl = arrays(&module);
        assert!(from_wgsl.iter().all(|a| a.len() == k.taps.count));
        // GLSL: the same numbers.
        let glsl = glsl_shader(&emit(&k, Lang::Glsl).unwrap(), passes);
        let m = parse_glsl(&glsl, name);
        validate(&m, name);
        assert_eq!(arrays(&m), from_wgsl, "{name}: GLSL numbers differ");
        // HLSL through GLSL's identical array grammar; the initializer
        // list's length is checked against the declared size.
        let hlsl = emit(&k, Lang::Hlsl).unwrap();
        assert!(hlsl.contains("static const float4 sss_kernel_0["));
        let mapped = hlsl
            .replace("static const float4", "const vec4")
            .replace("static const uint", "const uint")
            .replace("float4(", "vec4(");
        let m = parse_glsl(&glsl_shader(&mapped, passes), name);
        validate(&m, name);
        assert_eq!(arrays(&m), from_wgsl, "{name}: HLSL numbers differ");
    }
}

/// Drops the second tap line of the first array (a line starting `prefix`).
fn drop_a_tap(src: &str, prefix: &str) -> String {
    let mut seen = 0;
    src.lines()
        .filter(|l| {
            if l.starts_with(prefix) {
                seen += 1;
                return seen != 2;
            }
            true
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Whether a GLSL source fails to parse, to validate, or gives
/// `sss_kernel_0` a length other than `n`.
fn glsl_refused(src: &str, n: usize) -> bool {
    let mut front = naga::front::glsl::Frontend::default();
    match front.parse(
        &naga::front::glsl::Options::from(naga::ShaderStage::Fragment),
        src,
    ) {
        Err(_) => true,
        Ok(m) => {
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&m)
            .is_err()
                || std::panic::catch_unwind(|| wgsl_array(&m, "sss_kernel_0").len())
                    .map_or(true, |len| len != n)
        }
    }
}

#[test]
fn truncated_arrays_are_refused() {
    // The checks above can fail: an array one tap short of its declared
    // size is an error in each parser.
    let k = kernel("skin1-svd1");
    let cut = drop_a_tap(&emit(&k, Lang::Wgsl).unwrap(), "    vec4<f32>(");
    let refused = match naga::front::wgsl::parse_str(&cut) {
        Err(_) => true,
        Ok(m) => naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&m)
        .is_err(),
    };
    assert!(refused, "WGSL accepted a short array:\n{cut}");
    let n = k.taps.count;
    let glsl = glsl_shader(&drop_a_tap(&emit(&k, Lang::Glsl).unwrap(), "    vec4("), 1);
    assert!(glsl_refused(&glsl, n), "GLSL accepted a short array");
    let hlsl = drop_a_tap(&emit(&k, Lang::Hlsl).unwrap(), "    float4(")
        .replace("static const float4", "const vec4")
        .replace("static const uint", "const uint")
        .replace("float4(", "vec4(");
    assert!(
        glsl_refused(&glsl_shader(&hlsl, 1), n),
        "HLSL check accepted a short array"
    );
    // And the full arrays pass the same check.
    assert!(!glsl_refused(
        &glsl_shader(&emit(&k, Lang::Glsl).unwrap(), 1),
        n
    ));
}

#[test]
fn header_explains_units_pixels_depth_passes_and_sums() {
    let k = kernel("skin1-svd3");
    // The header's sentences as one line each (comments wrap at 96 columns).
    let h = emit(&k, Lang::Hlsl).unwrap().replace("\n//   ", " ");
    for needle in [
        "millimetres",
        "pixels_per_mm = sss_width * viewport_height_px / (2 * tan(fov_y / 2) * depth)",
        "linear view-space depth",
        "summed, never chained",
        "signed float target",
        "total_rd",
        "Term 2: tap weight sum per channel",
        "3 separable term(s) = 6 one-dimensional passes",
    ] {
        assert!(h.contains(needle), "header lacks '{needle}':\n{h}");
    }
    // One word for one thing: sss_passes counts one-dimensional passes
    // (two per separable term), as advise, kernels and apply do.
    for (lang, terms, passes) in [
        (
            Lang::Hlsl,
            "static const uint sss_terms = 3u;",
            "static const uint sss_passes = 6u;",
        ),
        (
            Lang::Glsl,
            "const uint sss_terms = 3u;",
            "const uint sss_passes = 6u;",
        ),
        (
            Lang::Wgsl,
            "const sss_terms: u32 = 3u;",
            "const sss_passes: u32 = 6u;",
        ),
    ] {
        let src = emit(&k, lang).unwrap();
        assert!(src.contains(terms) && src.contains(passes), "{src}");
    }
    let u = k.usage();
    assert_eq!(u.pass_weight_sums.len(), 3);
    assert!(u.signed_targets, "rank 3 has negative taps");
    assert!(!kernel("skin1-svd1").usage().signed_targets);
}

/// Sign convention: every SVD factor sums to a positive value per channel
/// (rank >= 2 terms used to come out almost all negative).
#[test]
fn svd_factors_sum_to_positive_values() {
    let profile = dipole_profile("skin1", 0.02, 12.0);
    let spec = ssskit::kernel::Kernel2DSpec {
        size: None,
        extent_mm: None,
    };
    let k = ssskit::kernel::fit_kernel_file(
        &profile,
        &spec,
        &ssskit::kernel::Model::Svd {
            rank: 3,
            renormalize: false,
        },
        17,
    )
    .unwrap();
    for (i, p) in k.passes.iter().enumerate() {
        for c in 0..3 {
            let s: f64 = p.weights.iter().map(|w| w[c]).sum();
            assert!(s > 0.0, "term {i} channel {c} sums to {s}");
        }
    }
}

/// docs/engines.md's worked example: the numbers of the emitted WGSL array,
/// as naga reads them, run through the project's wgpu pass, give the CPU
/// result of the kernel file within the GPU tolerance (1e-4 of the peak).
#[test]
fn emitted_wgsl_array_through_the_wgpu_pass_reproduces_the_cpu() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let g = gpu::Gpu::new().expect("GPU test needs an adapter (lavapipe in CI)");
    let k = kernel("skin1-svd3");
    let module = naga::front::wgsl::parse_str(&emit(&k, Lang::Wgsl).unwrap()).unwrap();
    let passes: Vec<Taps> = (0..k.taps.passes.len())
        .map(|p| {
            let mut v = wgsl_array(&module, &format!("sss_kernel_{p}"));
            // The emitted order puts the centre tap first.
            v.sort_by(|a, b| a[3].total_cmp(&b[3]));
            Taps {
                offsets_mm: v.iter().map(|t| t[3] as f64).collect(),
                weights: v
                    .iter()
                    .map(|t| [t[0] as f64, t[1] as f64, t[2] as f64])
                    .collect(),
            }
        })
        .collect();
    let (w, h) = (48, 40);
    let image = noise_image(w, h, 3, 0.0);
    let depth = step_depth(w, h);
    let setup = |passes: Vec<Taps>| {
        let follow = ssskit::filter::FollowSurface::InSceneUnits(300.0);
        perspective_setup(passes, (40.0, 0.02), depth.clone(), follow)
    };
    let from_wgsl = g.apply(&image, &setup(passes)).unwrap();
    let cpu = screen_space::apply_screen_space(
        &image,
        &setup(taps_for(&k, Which::stored(&k), None).unwrap()),
    );
    let e = max_rel(&cpu, &from_wgsl);
    eprintln!("emitted WGSL on the GPU vs the kernel file on the CPU: {e:.2e} of the peak");
    assert!(e < GPU_REL, "{e}");
    assert!(max_rel(&image, &cpu) > FILTERED, "nothing was filtered");
}
