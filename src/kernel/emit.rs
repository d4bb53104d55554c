//! Shader constant arrays from a tap table: one float4 per tap, rgb weight
//! and offset in mm (the layout of Jimenez's separable SSS shader), the
//! centre tap first as that shader expects.

use super::transmission::ThicknessFit;
use super::KernelFile;
use crate::error::{Error, Result};
use std::fmt::Write;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lang {
    Hlsl,
    Glsl,
    Wgsl,
}

impl std::str::FromStr for Lang {
    type Err = Error;
    fn from_str(s: &str) -> Result<Lang> {
        match s.to_ascii_lowercase().as_str() {
            "hlsl" => Ok(Lang::Hlsl),
            "glsl" => Ok(Lang::Glsl),
            "wgsl" => Ok(Lang::Wgsl),
            _ => Err(Error::invalid(
                "shader",
                "language",
                s,
                "expected hlsl, glsl or wgsl",
            )),
        }
    }
}

pub(crate) fn num(x: f64) -> String {
    let s = format!("{:.9e}", x as f32);
    // Shader languages accept exponent notation; keep a decimal point.
    if s.contains('.') {
        s
    } else {
        s.replacen('e', ".0e", 1)
    }
}

/// Wraps `text` into `//` comment lines of about 90 columns.
pub(crate) fn comment(out: &mut String, text: &str) {
    let mut line = String::from("//");
    for word in text.split_whitespace() {
        if line.len() + word.len() > 90 && line.len() > 2 {
            let _ = writeln!(out, "{line}");
            line = String::from("//  ");
        }
        line.push(' ');
        line.push_str(word);
    }
    let _ = writeln!(out, "{line}");
}

/// Refuses a tap table with a value a shader's f32 cannot hold: beyond
/// f32::MAX it would be written as `inf`, which no shader compiler
/// accepts. Values below f32's smallest normal round towards 0 as the GPU
/// would store them.
fn check_f32(k: &KernelFile) -> Result<()> {
    let mut values: Vec<(String, f64)> = Vec::new();
    for (p, pass) in k.taps.passes.iter().enumerate() {
        for (i, &o) in pass.offsets_mm.iter().enumerate() {
            values.push((format!("taps.passes[{p}].offsets_mm[{i}]"), o));
        }
        for (i, w) in pass.weights.iter().enumerate() {
            for (c, &v) in w.iter().enumerate() {
                values.push((format!("taps.passes[{p}].weights[{i}][{c}]"), v));
            }
        }
    }
    if let Some(a) = &k.angular {
        for (name, t) in [("entry", &a.entry), ("exit", &a.exit)] {
            for (i, w) in t.iter().enumerate() {
                for (c, &v) in w.iter().enumerate() {
                    values.push((format!("angular.{name}[{i}][{c}]"), v));
                }
            }
        }
    }
    for (field, v) in values {
        if !(v.abs() <= f32::MAX as f64) {
            return Err(Error::invalid(
                "shader",
                field,
                v,
                format!(
                    "shader arrays hold f32: values must be finite and at most {:e} in \
                     magnitude",
                    f32::MAX
                ),
            ));
        }
    }
    Ok(())
}

/// The shader constant arrays of `k`'s tap table in `lang`; refused when a
/// value does not fit an f32.
pub fn emit(k: &KernelFile, lang: Lang) -> Result<String> {
    check_f32(k)?;
    let mut out = String::new();
    header(&mut out, k);
    tables(&mut out, k, lang);
    extras(&mut out, k, lang)?;
    Ok(out)
}

/// The comments that say what the tables are and how to run them.
fn header(out: &mut String, k: &KernelFile) {
    let n = k.taps.count;
    let usage = k.usage();
    let rgb = |v: [f64; 3]| format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2]);
    comment(
        out,
        &format!(
            "ssskit kernel: model {} ({}), {} taps per pass, {} separable term(s) = {} \
             one-dimensional passes (sss_terms, sss_passes).",
            k.model.name,
            k.material.as_ref().map(|m| m.name.as_str()).unwrap_or("?"),
            n,
            k.taps.passes.len(),
            2 * k.taps.passes.len(),
        ),
    );
    comment(
        out,
        "Layout: one vec4 per tap, xyz = RGB weight (dimensionless), w = offset in \
         millimetres on the surface; the centre tap first (Jimenez's separable SSS layout).",
    );
    comment(out, &format!("Pixels: {}.", usage.pixels_per_mm));
    comment(out, &format!("Depth: {}.", usage.depth));
    // The kernel file names its per-term tables `taps.passes`: a term p
    // here is one of them, run as two one-dimensional passes.
    comment(
        out,
        &format!(
            "Terms (sss_kernel_p; the kernel file's taps.passes[p]): {}.",
            usage.passes
        ),
    );
    comment(
        out,
        &format!("total_rd = {}: {}.", rgb(k.total_rd), usage.total_rd),
    );
    for (p, s) in usage.pass_weight_sums.iter().enumerate() {
        comment(
            out,
            &format!("Term {p}: tap weight sum per channel {}.", rgb(*s)),
        );
    }
    comment(
        out,
        &format!(
            "2D weight sum (sum over passes of the squared pass sums): {}{}.",
            rgb(usage.kernel_sum),
            if usage.signed_targets {
                "; some taps are negative: signed float targets"
            } else {
                ""
            }
        ),
    );
}

/// The counts and each term's tap table, the centre tap first.
fn tables(out: &mut String, k: &KernelFile, lang: Lang) {
    let n = k.taps.count;
    const_u32(out, lang, "sss_taps", n);
    const_u32(out, lang, "sss_terms", k.taps.passes.len());
    const_u32(out, lang, "sss_passes", 2 * k.taps.passes.len());
    let ty = vec_type(lang, 4);
    for (p, pass) in k.taps.passes.iter().enumerate() {
        let centre = n / 2;
        let order = std::iter::once(centre).chain((0..n).filter(|&i| i != centre));
        let items: Vec<String> = order
            .map(|i| {
                let w = pass.weights[i];
                let o = pass.offsets_mm[i];
                format!(
                    "{ty}({}, {}, {}, {})",
                    num(w[0]),
                    num(w[1]),
                    num(w[2]),
                    num(o)
                )
            })
            .collect();
        const_array(out, lang, &ty, &format!("sss_kernel_{p}"), n, &items);
    }
}

/// The type of a vector of `dims` f32 in `lang`.
pub(crate) fn vec_type(lang: Lang, dims: usize) -> String {
    match lang {
        Lang::Hlsl => format!("float{dims}"),
        Lang::Glsl => format!("vec{dims}"),
        Lang::Wgsl => format!("vec{dims}<f32>"),
    }
}

/// A u32 constant `name` in `lang`, on its own line.
pub(crate) fn const_u32(out: &mut String, lang: Lang, name: &str, v: impl std::fmt::Display) {
    let _ = match lang {
        Lang::Hlsl => writeln!(out, "static const uint {name} = {v}u;"),
        Lang::Glsl => writeln!(out, "const uint {name} = {v}u;"),
        Lang::Wgsl => writeln!(out, "const {name}: u32 = {v}u;"),
    };
}

/// A constant array `name` of `n` values of type `ty` in `lang`, `items`
/// in the type's constructor form, one a line.
pub(crate) fn const_array(
    out: &mut String,
    lang: Lang,
    ty: &str,
    name: &str,
    n: usize,
    items: &[String],
) {
    let body = items.join(",\n    ");
    let _ = match lang {
        Lang::Hlsl => writeln!(out, "static const {ty} {name}[{n}] = {{\n    {body}\n}};"),
        Lang::Glsl => writeln!(out, "const {ty} {name}[{n}] = {ty}[{n}](\n    {body}\n);"),
        Lang::Wgsl => writeln!(
            out,
            "const {name}: array<{ty}, {n}> = array<{ty}, {n}>(\n    {body}\n);"
        ),
    };
}

/// What a kernel file carries beside its taps: the angular factors and the
/// thickness function.
fn extras(out: &mut String, k: &KernelFile, lang: Lang) -> Result<()> {
    if let Some(a) = &k.angular {
        emit_angular(out, a, lang)?;
    }
    if let Some(t) = &k.transmission {
        transmittance_fn(out, t, lang)?;
    }
    Ok(())
}

/// The angular factor tables and their lookups (linear between the nodes
/// mu_k = k / (n - 1), clamped: [`super::angular::lookup`]), with where
/// each goes and their standard errors; also the disk kernel's header's.
/// Refuses a value beyond f32.
pub(crate) fn emit_angular(
    out: &mut String,
    a: &super::angular::AngularFactors,
    lang: Lang,
) -> Result<()> {
    for (name, t) in [("entry", &a.entry), ("exit", &a.exit)] {
        for (i, w) in t.iter().enumerate() {
            if let Some(&v) = w.iter().find(|v| !(v.abs() <= f32::MAX as f64)) {
                return Err(Error::invalid(
                    "shader",
                    format!("angular.{name}[{i}]"),
                    v,
                    "shader arrays hold f32: values must be finite and at most f32::MAX",
                ));
            }
        }
    }
    let n = a.mu.len();
    let last = n - 1;
    comment(
        out,
        &format!(
            "Angular factors, {n} nodes at N.L or N.V = k / {last}, linear between them. \
             Entry, sss_entry_factor(N.L) = R_d(theta_in) / R_d(0): per light, in the lighting \
             pass, before the blur (the irradiance written for the blur is the sum over lights \
             of E_l max(N.L_l, 0) sss_entry_factor(N.L_l)). Exit, sss_exit_factor(N.V) = pi L / \
             M, the radiance seen from V relative to a Lambertian exit: after the blur, the \
             blurred result times sss_exit_factor(N.V). From {} photons per channel and \
             incidence.",
            a.photons
        ),
    );
    for (name, se) in [("sss_entry", &a.entry_stderr), ("sss_exit", &a.exit_stderr)] {
        let rows: Vec<String> = se
            .iter()
            .map(|v| format!("({:.1e} {:.1e} {:.1e})", v[0], v[1], v[2]))
            .collect();
        comment(
            out,
            &format!("{name} standard errors per node: {}.", rows.join(" ")),
        );
    }
    for (name, table) in [("sss_entry", &a.entry), ("sss_exit", &a.exit)] {
        let ty = vec_type(lang, 3);
        let items: Vec<String> = table
            .iter()
            .map(|v| format!("{ty}({}, {}, {})", num(v[0]), num(v[1]), num(v[2])))
            .collect();
        const_array(out, lang, &ty, name, n, &items);
        let scale = num(last as f64);
        let _ = match lang {
            Lang::Hlsl => writeln!(
                out,
                "float3 {name}_factor(float mu) {{\n    float x = saturate(mu) * {scale};\n    \
                 uint i = min(uint(x), {}u);\n    return lerp({name}[i], {name}[i + 1u], x - \
                 float(i));\n}}",
                last - 1
            ),
            Lang::Glsl => writeln!(
                out,
                "vec3 {name}_factor(float mu) {{\n    float x = clamp(mu, 0.0, 1.0) * {scale};\n    \
                 uint i = min(uint(x), {}u);\n    return mix({name}[i], {name}[i + 1u], x - \
                 float(i));\n}}",
                last - 1
            ),
            Lang::Wgsl => writeln!(
                out,
                "fn {name}_factor(mu: f32) -> vec3<f32> {{\n    var t = {name};\n    \
                 let x = clamp(mu, 0.0, 1.0) * {scale};\n    let i = min(u32(x), {}u);\n    \
                 return mix(t[i], t[i + 1u], x - f32(i));\n}}",
                last - 1
            ),
        };
    }
    Ok(())
}

/// The shader function `sss_transmittance(thickness_mm)` of `f` in `lang`,
/// with its fit in the header; refused when a coefficient does not fit an
/// f32.
fn transmittance_fn(out: &mut String, f: &ThicknessFit, lang: Lang) -> Result<()> {
    for (c, t) in f.terms.iter().enumerate() {
        if let Some(v) = t.iter().find(|v| !(v.abs() <= f32::MAX as f64)) {
            return Err(Error::invalid(
                "shader",
                format!("transmission.terms[{c}]"),
                v,
                "shader constants are f32: values must be finite and at most f32::MAX",
            ));
        }
    }
    let pct = |v: [f64; 3]| v.map(|x| format!("{:.1}%", 100.0 * x)).join(", ");
    comment(
        out,
        &format!(
            "Transmittance through a thickness: sss_transmittance(t) = the scattered light \
             leaving the unlit face of a slab of {} t mm thick lit from behind (normal beam), per \
             incident light, RGB; a1 exp(-b1 t) + a2 exp(-b2 t) fitted to `ssskit transmission` over {} \
             to {} mm (clamped there); relative error over the table's rows (r, g, b): max {}, \
             RMS {}. Multiply by the light behind and give it a Lambertian exit (divide by pi \
             for radiance).",
            f.material,
            num(f.range_mm[0]),
            num(f.range_mm[1]),
            pct(f.max_rel_error),
            pct(f.rms_rel_error)
        ),
    );
    let term = |c: usize, exp: &str| {
        let [a1, b1, a2, b2] = f.terms[c];
        format!(
            "{} * {exp}(-{} * t) + {} * {exp}(-{} * t)",
            num(a1),
            num(b1),
            num(a2),
            num(b2)
        )
    };
    let (lo, hi) = (num(f.range_mm[0]), num(f.range_mm[1]));
    let body = |ctor: &str| {
        format!(
            "{ctor}(\n        {},\n        {},\n        {})",
            term(0, "exp"),
            term(1, "exp"),
            term(2, "exp")
        )
    };
    let _ = match lang {
        Lang::Hlsl => writeln!(
            out,
            "float3 sss_transmittance(float thickness_mm) {{\n    float t = clamp(thickness_mm, \
             {lo}, {hi});\n    return {};\n}}",
            body("float3")
        ),
        Lang::Glsl => writeln!(
            out,
            "vec3 sss_transmittance(float thickness_mm) {{\n    float t = clamp(thickness_mm, \
             {lo}, {hi});\n    return {};\n}}",
            body("vec3")
        ),
        Lang::Wgsl => writeln!(
            out,
            "fn sss_transmittance(thickness_mm: f32) -> vec3<f32> {{\n    let t = \
             clamp(thickness_mm, {lo}, {hi});\n    return {};\n}}",
            body("vec3<f32>")
        ),
    };
    Ok(())
}
