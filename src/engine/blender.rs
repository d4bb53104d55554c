//! Blender's Principled BSDF subsurface, the chain from the node's values
//! to the profile the renderer draws, for three conventions (Cycles from
//! the blender/cycles repository at its release tags, EEVEE from
//! blender/blender):
//!
//! - Cycles 4.x (`--engine-version 4`; read at v4.0.0, v4.5.0, v5.0.0):
//!   kernel/svm/closure.h (principled BSDF) sets the subsurface closure's
//!   weight to min(Base Color, 1) x Subsurface Weight x the layers' weight
//!   and its radius to Subsurface Radius x Subsurface Scale (scene units);
//!   kernel/closure/bssrdf.h `bssrdf_setup_radius` multiplies the radius
//!   by 1 / (4 pi) for Christensen-Burley and Random Walk, and
//!   `bssrdf_burley_eval` uses it as Burley's d with the albedo already in
//!   the weight: R(r) = Base Color x Burley(d = radius / (4 pi)).
//!   `bssrdf_burley_setup` (the albedo fit s(A)) is still defined but no
//!   longer called.
//! - Cycles 2.83 to 2.93 (`--engine-version 2.93`; read at v2.83.12,
//!   v2.90.1, v2.93.0): kernel/svm/svm_closure.h sets radius = Subsurface
//!   Radius x Subsurface and albedo = Subsurface Color;
//!   kernel/closure/bssrdf.h `bssrdf_setup` calls `bssrdf_burley_setup`,
//!   d = radius / (4 pi) / s(A), s = 1.9 - A + 3.5 (A - 0.8)^2
//!   (`bssrdf_burley_fitting`).
//! - EEVEE (Next), Blender 4.2 and later (`--engine-version eevee`):
//!   gpu_shader_material_principled.glsl sets sss_radius = Subsurface
//!   Radius x Subsurface Scale and the colour to the weights x min(Base
//!   Color, 1); eevee_subsurface_convolve_comp.glsl normalises that colour
//!   by its largest channel and calls `burley_setup` (eevee_shader_shared.hh):
//!   d = radius / (4 pi) / s(colour / max colour), the blur divided by the
//!   sum of its weights and multiplied by the colour.
//!
//! The node's colours are scene linear in the colour picker's RGB fields;
//! its hex field is sRGB (Blender Manual, Color Picker).

use super::burley::Burley;
use super::printed::{
    color, in_range, number, printed, require, srgb_hex, text, triple, typed, units_line, Printed,
};
use super::{Scene, Version};
use crate::error::{Error, Result};
use crate::profile::analytic::burley::diffuse_surface_scale;
use serde_json::{json, Map, Value};
use std::f64::consts::PI;

pub const VERSIONS: [Version; 3] = [
    Version {
        key: "4",
        aliases: &["4.0", "4.1", "4.2", "4.3", "4.4", "4.5", "5.0", "cycles"],
        label: "Blender 4.0 to 5.0, Cycles: Principled BSDF, Christensen-Burley \
                (read in Cycles v4.0.0, v4.5.0, v5.0.0)",
    },
    Version {
        key: "eevee",
        aliases: &["eevee-next"],
        label: "Blender 4.2 and later, EEVEE: Principled BSDF subsurface \
                (read in blender/blender's EEVEE Next shaders)",
    },
    Version {
        key: "2.93",
        aliases: &["2.83", "2.90", "2.91", "2.92"],
        label: "Blender 2.83 to 2.93, Cycles: Principled BSDF, Christensen-Burley \
                (read in Cycles v2.83.12, v2.90.1, v2.93.0)",
    },
];

/// Subsurface Radius's socket range (node_shader_bsdf_principled.cc).
pub const RADIUS_RANGE: (f64, f64) = (0.0, 100.0);
/// Subsurface Scale's socket range (Blender 4.x).
pub const SCALE_RANGE: (f64, f64) = (0.0, 10.0);
const METHOD: &str = "Christensen-Burley";

/// `bssrdf_setup_radius` / `bssrdf_burley_compatible_mfp`: d per unit of
/// radius before any albedo fit.
const D_PER_RADIUS: f64 = 0.25 / PI;

/// Cycles' Christensen-Burley closure draws the profile truncated at 16 d
/// and renormalised (kernel/closure/bssrdf.h: `bssrdf_eval` returns
/// `bssrdf_burley_pdf`, `bssrdf_burley_eval` / BURLEY_TRUNCATE_CDF, zero
/// from BURLEY_TRUNCATE d on; read at v2.93.0, v4.0.0 and v5.0.0). Its
/// render (scripts/engine-cycles) matches that, not the whole profile.
pub const BURLEY_TRUNCATE: f64 = 16.0;

pub fn error_for(v: Version) -> &'static str {
    match v.key {
        "eevee" => {
            "EEVEE's screen-space subsurface pass (eevee_subsurface_convolve_comp.glsl), its \
             expected value; it blurs nothing where the radius is under a pixel"
        }
        "2.93" => {
            "Cycles' Christensen-Burley closure (disk sampling of the normalized profile, \
             truncated at 16 d and renormalised); Random Walk renders a volume walk with the \
             same radius, not scored here"
        }
        _ => {
            "Cycles' Christensen-Burley closure (disk sampling of the normalized profile, \
             truncated at 16 d and renormalised, as Cycles 5.0.1 renders it: \
             scripts/engine-cycles); Random Walk reads the same radius as a mean free path \
             per channel for a volume walk, a different profile: --subsurface-method random-walk prints \
             values for it"
        }
    }
}

/// The albedo fit's s(A) per channel: none in Cycles 4.x, s of the colour
/// over its largest channel in EEVEE, s of the Subsurface Color in 2.93.
fn albedo_fit(v: Version, colour: [f64; 3]) -> [f64; 3] {
    match v.key {
        "eevee" => {
            let max = colour.iter().fold(1e-6f64, |m, c| m.max(*c));
            colour.map(|c| diffuse_surface_scale(c / max))
        }
        "2.93" => colour.map(diffuse_surface_scale),
        _ => [1.0; 3],
    }
}

pub fn params(b: &Burley, scene: Scene, v: Version) -> Printed {
    let u = scene.units_per_mm;
    let mut warnings = Vec::new();
    let colour = b.albedo.map(|a| typed(a.clamp(0.0, 1.0)));
    let s = albedo_fit(v, colour);
    // radius (scene units) = d (scene units) / D_PER_RADIUS x s(A).
    let radius: [f64; 3] = std::array::from_fn(|c| b.d_mm[c] * u / D_PER_RADIUS * s[c]);
    let hex = srgb_hex(colour);
    let rows = if v.key == "2.93" {
        let radius = radius.map(|r| clamp_radius(r, &mut warnings));
        vec![
            (
                "Subsurface",
                json!(1.0),
                "all of the diffuse light scatters; the Base Color is then unused",
            ),
            (
                "Subsurface Color",
                color(colour),
                "scene linear RGB (the picker's RGB fields): the profile's total reflectance \
                 and the albedo of Cycles' s(A) fit",
            ),
            (
                "Subsurface Color hex",
                json!(hex),
                "the picker's hex field (sRGB)",
            ),
            (
                "Subsurface Radius",
                color(radius),
                "scene units per channel, in [0, 100]",
            ),
            ("Subsurface Method", json!(METHOD), "the model fitted"),
        ]
    } else {
        let (scale, per_channel) = scale_and_radius(radius, &mut warnings);
        let mut rows = subsurface_rows(
            colour,
            "scene linear RGB (the picker's RGB fields), in [0, 1]: the profile's total \
             reflectance",
            per_channel,
            scale,
        );
        rows.push((
            "Subsurface Method",
            json!(METHOD),
            if v.key == "eevee" {
                "EEVEE renders every method alike; Cycles' Christensen-Burley needs \
                 --engine-version 4"
            } else {
                "the model fitted"
            },
        ));
        rows
    };
    printed(rows, warnings)
}

/// A Subsurface Radius value (scene units, or a ratio to the Scale) as the
/// socket takes it: clamped to its range, with a warning where it is cut.
fn clamp_radius(r: f64, warnings: &mut Vec<String>) -> f64 {
    let (rlo, rhi) = RADIUS_RANGE;
    if r > rhi {
        warnings.push(format!(
            "Subsurface Radius: {r:.4} is above the socket's {rhi}; {rhi} is printed, so \
             the profile renders narrower (the error includes it)"
        ));
    }
    typed(r.clamp(rlo, rhi))
}

/// Subsurface Scale and Radius of Blender 4 and later for per-channel
/// radii in scene units: the longest radius as the Scale (capped at the
/// socket's range, the radii then scaled up), each channel its ratio to
/// it, clamped to the Radius socket's range; warnings where a cap bites.
pub(super) fn scale_and_radius(radius: [f64; 3], warnings: &mut Vec<String>) -> (f64, [f64; 3]) {
    let longest = radius.iter().fold(0.0f64, |m, r| m.max(*r));
    let (_, shi) = SCALE_RANGE;
    let scale = typed(longest.min(shi));
    if longest > shi {
        warnings.push(format!(
            "Subsurface Scale: {longest:.4} is above the socket's {shi}; {shi} is printed \
             and Subsurface Radius scaled up to keep the radii"
        ));
    }
    (scale, radius.map(|r| clamp_radius(r / scale, warnings)))
}

/// The Principled BSDF's other layers in Blender 4.0 and later, each of
/// which takes its share of the subsurface weight (closure.h `principled`:
/// the metallic, transmission, coat and sheen weights, and the specular
/// layer's `closure_layering_weight`): at 0 only the subsurface renders,
/// as the fit assumes. Their defaults are 0 but for Specular IOR Level,
/// 0.5 (node_shader_bsdf_principled.cc `node_declare`).
pub const ZERO_LAYERS: [(&str, &str); 5] = [
    ("Metallic", "0: a metal has no subsurface"),
    (
        "Specular IOR Level",
        "0: no specular layer (default 0.5). At 0.5 the layer takes its Fresnel reflectance \
         (about 4% at IOR 1.5, normal incidence) out of the subsurface weight, light the \
         profile's total already leaves out: the diffuse renders that much darker. A highlight \
         from another closure (a Glossy BSDF added) keeps the colour",
    ),
    (
        "Transmission Weight",
        "0: transmission takes its share of the weight",
    ),
    ("Coat Weight", "0: the coat takes its share of the weight"),
    ("Sheen Weight", "0: the sheen takes its share of the weight"),
];

/// The rows every Blender 4 method prints: Base Color (`colour_note` says
/// what it holds) and its hex, Subsurface Weight, Radius and Scale, and
/// the other layers at 0 ([`ZERO_LAYERS`]).
pub(super) fn subsurface_rows(
    colour: [f64; 3],
    colour_note: &'static str,
    per_channel: [f64; 3],
    scale: f64,
) -> Vec<(&'static str, Value, &'static str)> {
    let layers = ZERO_LAYERS.map(|(name, why)| (name, json!(0.0), why));
    let mut rows = vec![
        ("Base Color", color(colour), colour_note),
        (
            "Base Color hex",
            json!(srgb_hex(colour)),
            "the picker's hex field (sRGB)",
        ),
        (
            "Subsurface Weight",
            json!(1.0),
            "all of the diffuse light scatters",
        ),
        (
            "Subsurface Radius",
            color(per_channel),
            "per channel, in [0, 100], times Subsurface Scale",
        ),
        ("Subsurface Scale", json!(scale), "scene units, in [0, 10]"),
    ];
    rows.extend(layers);
    rows
}

/// The other layers at 0, as printed (Blender 4.0 and later).
pub(super) fn require_zero_layers(p: &Map<String, Value>) -> Result<()> {
    for (name, why) in ZERO_LAYERS {
        require(p, name, &json!(0.0), why)?;
    }
    Ok(())
}

const UI: &str = "Blender's socket";

/// The printed Subsurface Radius (per channel) and Subsurface Scale, each
/// checked against the range Blender's UI takes.
pub(super) fn radius_and_scale(p: &Map<String, Value>) -> Result<([f64; 3], f64)> {
    let r = triple(p, "Subsurface Radius")?;
    let scale = in_range(
        UI,
        "Subsurface Scale",
        number(p, "Subsurface Scale")?,
        SCALE_RANGE,
    )?;
    for x in r {
        in_range(UI, "Subsurface Radius", x, RADIUS_RANGE)?;
    }
    Ok((r, scale))
}

/// The profile Blender renders from the values `params` prints, by the
/// chain of the module comment for version `v`.
pub fn from_params(p: &Map<String, Value>, scene: Scene, v: Version) -> Result<Burley> {
    if text(p, "Subsurface Method")? != METHOD && v.key != "eevee" {
        return Err(Error::invalid(
            "engine",
            "Subsurface Method",
            text(p, "Subsurface Method")?,
            "only Christensen-Burley renders the Burley profile",
        ));
    }
    let (colour, radius) = if v.key == "2.93" {
        require(
            p,
            "Subsurface",
            &json!(1.0),
            "below 1 Base Color's diffuse mixes in",
        )?;
        let colour = triple(p, "Subsurface Color")?;
        let r = triple(p, "Subsurface Radius")?;
        for c in 0..3 {
            in_range(UI, "Subsurface Color", colour[c], (0.0, 1.0))?;
            in_range(UI, "Subsurface Radius", r[c], RADIUS_RANGE)?;
        }
        (colour, r)
    } else {
        require(
            p,
            "Subsurface Weight",
            &json!(1.0),
            "below 1 a diffuse BSDF takes the rest",
        )?;
        require_zero_layers(p)?;
        let colour = triple(p, "Base Color")?.map(|c| c.clamp(0.0, 1.0));
        let (r, scale) = radius_and_scale(p)?;
        (colour, r.map(|x| x * scale))
    };
    let s = albedo_fit(v, colour);
    Ok(Burley {
        albedo: colour,
        d_mm: std::array::from_fn(|c| radius[c] * D_PER_RADIUS / s[c] / scene.units_per_mm),
        truncate_d: (v.key != "eevee").then_some(BURLEY_TRUNCATE),
    })
}

/// What the error assumes of the scene: its units; for Random Walk
/// (`walk`) the view and the light too.
pub fn scene_lines(scene: Scene, walk: bool) -> Vec<String> {
    let mut r = vec![units_line(
        scene,
        "Subsurface Radius x Scale is a distance in them",
    )];
    if walk {
        r.push(
            "a view along the surface's normal: Cycles starts the walk along the view ray \
             refracted through a GGX facet of the Roughness (subsurface_entry_bounce), straight \
             down at Roughness 0; a slanted view starts it slanted and the profile differs"
                .into(),
        );
        r.push(
            "light from any direction: where the walk leaves, a Lambertian BSDF of weight 1 \
             takes it (subsurface_shader_data_setup); scored with a sun at the zenith, as \
             scripts/engine-cycles renders it"
                .into(),
        );
    }
    r
}

pub fn requirements(v: Version) -> Vec<String> {
    if v.key == "2.93" {
        vec!["Metallic 0 and Transmission 0 (they take their share of the subsurface)".into()]
    } else {
        Vec::new()
    }
}
