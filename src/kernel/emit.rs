//! Shader constant arrays from a tap table: one float4 per tap, rgb weight
//! and offset in mm (the layout of Jimenez's separable SSS shader), the
//! centre tap first as that shader expects.

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
                "fit",
                "--emit",
                s,
                "expected hlsl, glsl or wgsl",
            )),
        }
    }
}

fn num(x: f64) -> String {
    let s = format!("{:.9e}", x as f32);
    // Shader languages accept exponent notation; keep a decimal point.
    if s.contains('.') {
        s
    } else {
        s.replacen('e', ".0e", 1)
    }
}

pub fn emit(k: &KernelFile, lang: Lang) -> String {
    let mut out = String::new();
    let n = k.taps.count;
    let _ = writeln!(
        out,
        "// ssskit kernel: model {} ({}), {} taps per pass, {} pass(es).\n\
         // xyz = RGB weight, w = offset in surface mm (multiply by pixels per mm).\n\
         // Centre tap first. Colour factor total_rd = ({:.6}, {:.6}, {:.6}).",
        k.model.name,
        k.material.as_ref().map(|m| m.name.as_str()).unwrap_or("?"),
        n,
        k.taps.passes.len(),
        k.total_rd[0],
        k.total_rd[1],
        k.total_rd[2]
    );
    for (p, pass) in k.taps.passes.iter().enumerate() {
        let centre = n / 2;
        let order = std::iter::once(centre).chain((0..n).filter(|&i| i != centre));
        let items: Vec<String> = order
            .map(|i| {
                let w = pass.weights[i];
                let o = pass.offsets_mm[i];
                let ctor = match lang {
                    Lang::Hlsl => "float4",
                    Lang::Glsl => "vec4",
                    Lang::Wgsl => "vec4<f32>",
                };
                format!(
                    "{ctor}({}, {}, {}, {})",
                    num(w[0]),
                    num(w[1]),
                    num(w[2]),
                    num(o)
                )
            })
            .collect();
        let body = items.join(",\n    ");
        let _ = match lang {
            Lang::Hlsl => writeln!(
                out,
                "static const float4 sss_kernel_{p}[{n}] = {{\n    {body}\n}};"
            ),
            Lang::Glsl => writeln!(
                out,
                "const vec4 sss_kernel_{p}[{n}] = vec4[{n}](\n    {body}\n);"
            ),
            Lang::Wgsl => writeln!(
                out,
                "const sss_kernel_{p}: array<vec4<f32>, {n}> = array<vec4<f32>, {n}>(\n    {body}\n);"
            ),
        };
    }
    out
}
