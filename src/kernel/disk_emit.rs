//! Shader constant arrays of a disk kernel: each sample's unrotated
//! position in mm (x, y) = radius (cos angle, sin angle), so that a shader
//! turns the whole pattern by one 2x2 rotation per pixel instead of a cosine
//! per sample, and its RGB weight; a header says how to rotate, scale and
//! sum them.

use super::disk::DiskKernelFile;
use super::emit::{comment, const_array, const_u32, num, vec_type, Lang};
use crate::error::{Error, Result};

/// The arrays `sss_disk_points` (float2, mm) and `sss_disk_weights`
/// (float3) of `k` in `lang`, with `sss_disk_count`.
pub fn emit_disk(k: &DiskKernelFile, lang: Lang) -> Result<String> {
    let n = k.samples.len();
    // Validated radii are at most 1e6 mm and weights finite: the f32 cast
    // keeps them finite except for weights beyond f32 (refused here).
    if let Some((i, s)) = k
        .samples
        .iter()
        .enumerate()
        .find(|(_, s)| s.weight.iter().any(|w| !(w.abs() <= f32::MAX as f64)))
    {
        return Err(Error::invalid(
            "shader",
            format!("samples[{i}].weight"),
            format!("{:?}", s.weight),
            "shader arrays hold f32: weights must be at most f32::MAX",
        ));
    }
    let usage = k.usage();
    let mut out = String::new();
    let rgb = |v: [f64; 3]| format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2]);
    comment(
        &mut out,
        &format!(
            "ssskit disk kernel ({}), {n} samples per pixel, radii from the {} pdf \
             (importance-sampled R_d, stratified inverse CDF, golden-angle spiral).",
            k.material.as_ref().map(|m| m.name.as_str()).unwrap_or("?"),
            k.model.params["radii"].as_str().unwrap_or("?"),
        ),
    );
    comment(
        &mut out,
        "Layout: sss_disk_points[i] = radius_mm x (cos angle, sin angle), millimetres on the \
         surface before the per-pixel rotation; sss_disk_weights[i] = RGB weight \
         (dimensionless, R_d / pdf).",
    );
    comment(&mut out, &format!("Rotation: {}.", usage.rotation));
    comment(&mut out, &format!("Pixels: {}.", usage.pixels_per_mm));
    comment(&mut out, &format!("Weights: {}.", usage.weights));
    comment(&mut out, &frames_text(k));
    comment(&mut out, &format!("Depth: {}.", usage.depth));
    comment(
        &mut out,
        &format!("total_rd = {}: {}.", rgb(k.total_rd), usage.total_rd),
    );
    let (f2, f3) = (vec_type(lang, 2), vec_type(lang, 3));
    const_u32(&mut out, lang, "sss_disk_count", n);
    if let Some(a) = &k.accumulation {
        const_u32(&mut out, lang, "sss_disk_frames", a.frames);
    }
    let points: Vec<String> = k
        .samples
        .iter()
        .map(|s| {
            let (x, y) = (s.radius_mm * s.angle.cos(), s.radius_mm * s.angle.sin());
            format!("{f2}({}, {})", num(x), num(y))
        })
        .collect();
    let weights: Vec<String> = k
        .samples
        .iter()
        .map(|s| {
            let w = s.weight;
            format!("{f3}({}, {}, {})", num(w[0]), num(w[1]), num(w[2]))
        })
        .collect();
    const_array(&mut out, lang, &f2, "sss_disk_points", n, &points);
    const_array(&mut out, lang, &f3, "sss_disk_weights", n, &weights);
    if let Some(a) = &k.angular {
        super::emit::emit_angular(&mut out, a, lang)?;
    }
    Ok(out)
}

/// The header's "Frames:" line: what the kernel's predicted error assumes
/// (its [`Accumulation`](super::disk::Accumulation)), or that it records
/// none.
fn frames_text(k: &DiskKernelFile) -> String {
    match &k.accumulation {
        Some(a) => format!(
            "Frames: the predicted error (ssskit advise) is that of {}: accumulate \
             sss_disk_frames frames with frame = {} + k in the rotation (ssskit apply runs them \
             by default); one frame shows about sqrt({}) times the noise, and a moving camera \
             without reprojection more.",
            a.describe(),
            a.first_frame,
            a.frames
        ),
        None => "Frames: none recorded (no predicted error; ssskit apply runs 1 frame unless \
                 --frames): accumulate frames with a changing `frame`."
            .to_string(),
    }
}
