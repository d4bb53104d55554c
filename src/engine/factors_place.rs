//! Where each engine can take the angular entry and exit factors
//! ([`crate::kernel::angular`]: E(N.L) on the irradiance before the blur,
//! X(N.V) on the blurred exitance after it), read in the engine's source,
//! and the error a user keeps by shipping without them.
//!
//! What the sources say (the functions named are where the terms would
//! go, or what the engine puts there instead):
//!
//! - **Unreal 5** (Epic's UnrealEngine, read in the 5.8.0 source,
//!   Engine/Shaders/Private/ShadingModels.ush, `SubsurfaceProfileBxDF`, the
//!   legacy shading path that 5.7 marks deprecated for Substrate; Substrate
//!   not read):
//!   the lighting pass weights the light that the Burley pass then blurs
//!   by `Diffuse_Burley` (BRDF.ush; Burley 2012's F_D(N.L) F_D(N.V) with
//!   F_D90 = 0.5 + 2 Roughness (V.H)^2, the material's roughness, not the
//!   medium's) or `Diffuse_GGX_Rough` with MATERIAL_ROUGHDIFFUSE, times
//!   the specular layer's energy preservation at N.V. The Subsurface
//!   Profile asset has no angular term (its IOR and ScatteringDistribution
//!   only shape the transmission through thin parts). A material cannot
//!   change the per-light term: no place for E. `SubsurfaceRecombinePS`
//!   (PostProcessSubsurface.usf) multiplies the blurred light by the Base
//!   Color after the blur, so X(N.V), made in the material graph from the
//!   pixel normal and the camera vector, goes into Base Color.
//! - **Unity HDRP 17** (Unity-Technologies/Graphics,
//!   Runtime/Material/Lit/Lit.hlsl, `EvaluateBSDF`): the diffuse term lit
//!   before the subsurface pass is `DisneyDiffuse(NdotV, NdotL, LdotV,
//!   perceptualRoughness)`; the note [SSS-NOTE-TRSM] there says that the
//!   transmission at N.V belongs after the pass and is left out as too
//!   expensive. The Diffusion Profile has no angular term: no place for E.
//!   With the Texturing Mode Post-scatter the albedo multiplies the blurred
//!   light (`ApplySubsurfaceScatteringTexturingMode`, SubsurfaceScattering
//!   .compute): X(N.V) goes into the Base Map colour through Shader Graph.
//! - **Blender, Cycles 4.x** (blender/cycles, src/kernel/svm/closure.h,
//!   principled BSDF; src/kernel/integrator/subsurface.h): the subsurface
//!   closure's weight (Base Color x Subsurface Weight x the specular
//!   layer's `closure_layering_weight`) is taken where the camera path
//!   meets the surface, the exit point, so X(N.V) from the Geometry node's
//!   Normal and Incoming goes into Base Color; at the other end
//!   `subsurface_shader_data_setup` replaces the surface's shader by a
//!   Lambertian `bsdf_diffuse_setup`: no place for E. Cycles 2.83-2.93
//!   (src/kernel/kernel_subsurface.h,
//!   `subsurface_scatter_setup_diffuse_bsdf`) puts the principled diffuse
//!   (Burley 2012's retro-reflection term) there instead. EEVEE's
//!   subsurface pass multiplies the blurred light by the closure colour
//!   after the blur (eevee_subsurface_convolve_comp.glsl), and the node tree
//!   sees no single light: the same places as Cycles.
//! - **Godot 4** (godotengine/godot,
//!   servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl,
//!   `light_compute`): a material's `light()` function (`#CODE : LIGHT`)
//!   replaces the built-in diffuse (Lambert, Lambert wrap, toon or Burley
//!   2012's F_D(N.L) F_D(N.V)) per light, with NORMAL, LIGHT and VIEW:
//!   E(dot(NORMAL, LIGHT)) goes there, exactly. The result, times the
//!   albedo, is the diffuse buffer the subsurface pass blurs
//!   (scene_forward_clustered.glsl): X(dot(NORMAL, VIEW)) can only go there
//!   too, before the blur.
//! - **iryoku** (iryoku/separable-sss, Demo/Shaders/Main.fx, `RenderPS`):
//!   the application's own lighting loop, Lambertian saturate(N.L) per
//!   light, is what `SSSSBlurPS` (SeparableSSS.h) blurs; the specular
//!   (with its own Fresnel) is added after. E goes in that loop; X after
//!   the blur needs a normal buffer the demo does not keep, or goes in the
//!   loop too, before the blur.
//!
//! X applied before the blur instead of after is exact where N.V varies
//! little over the kernel's width (a surface far larger than the kernel);
//! the measure below has no blur and counts it as applied.
//!
//! The error kept: a sphere lit by one distant light and seen from that
//! light (orthographic), so that N.L = N.V = mu over its disk, the pixels
//! uniform over the disk (mu^2 uniform on [0, 1]). With the factors the
//! image is mu E(mu) X(mu) times the kernel's colour; without, mu. The
//! kept error is the RMS over the disk of the difference divided by the
//! image's peak (the norm of `compare --scene`), and the bias the mean
//! difference over the mean image with the factors; the blur is left out
//! (on a sphere far larger than the kernel it blurs both images alike).

use super::{Engine, Version};
use crate::error::Result;
use crate::kernel::angular::AngularFactors;
use crate::profile::Profile;

/// Midpoints in mu^2 of the disk average: the tables are linear in mu
/// between 9 nodes, so 4096 points put the quadrature error far below the
/// 0.01% the lines print.
const DISK_POINTS: usize = 4096;

/// Which of the two factors an engine has a place for, and where.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    /// Where E(N.L) goes, or why it cannot.
    pub entry: &'static str,
    pub entry_place: bool,
    /// Where X(N.V) goes, or why it cannot.
    pub exit: &'static str,
    pub exit_place: bool,
}

/// The places of `engine` (version `v` for Blender).
pub fn place(engine: Engine, v: Version) -> Place {
    const NO_LIGHT_HOOK: &str = "no place: the per-light diffuse term is the engine's own";
    match engine {
        Engine::Unreal => Place {
            entry: "no place: the lighting pass applies Diffuse_Burley (F_D(N.L) F_D(N.V) of \
                    the material's roughness), not the medium's",
            entry_place: false,
            exit: "in Base Color (applied after the blur by SubsurfaceRecombinePS), from \
                   dot(PixelNormalWS, CameraVector); Base Color takes at most 1",
            exit_place: true,
        },
        Engine::UnityHdrp => Place {
            entry: "no place: the lighting pass applies DisneyDiffuse (Lit.hlsl \
                    [SSS-NOTE-TRSM]), not the medium's",
            entry_place: false,
            exit: "in the Base Map colour through Shader Graph, Texturing Mode Post-scatter \
                   (the albedo multiplies the blurred light)",
            exit_place: true,
        },
        Engine::Blender => Place {
            entry: if v.key == "2.93" {
                "no place: the far end of the subsurface path is the principled diffuse \
                 (subsurface_scatter_setup_diffuse_bsdf)"
            } else {
                NO_LIGHT_HOOK
            },
            entry_place: false,
            exit: "in Base Color through nodes, from the Geometry node's Normal and \
                   Incoming (the closure is weighted where the camera sees it)",
            exit_place: true,
        },
        Engine::Godot => Place {
            entry: "in the material's light() function: DIFFUSE_LIGHT += E(dot(NORMAL, \
                    LIGHT)) x the Lambert term, per light, before the blur",
            entry_place: true,
            exit: "in light() too, x X(dot(NORMAL, VIEW)): before the blur (the diffuse \
                   buffer is blurred with the albedo in it)",
            exit_place: true,
        },
        Engine::Iryoku => Place {
            entry: "in RenderPS's light loop (Main.fx): x E(dot(light, normal)), per light, \
                    before SSSSBlurPS",
            entry_place: true,
            exit: "after SSSSBlurPS with a normal buffer, or in the same loop x \
                   X(dot(view, normal)) before the blur",
            exit_place: true,
        },
    }
}

/// The error kept on the lit sphere, per channel (fractions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kept {
    /// RMS over the disk of (image without - image with) / peak with.
    pub rms: [f64; 3],
    /// Mean over the disk of (without - with) / mean with.
    pub bias: [f64; 3],
}

/// The error kept on the lit sphere (module docs) when the entry factor
/// is left at 1 where `entry` is false and the exit factor where `exit`
/// is false.
pub fn kept(f: &AngularFactors, entry: bool, exit: bool) -> Kept {
    let mut sq = [0.0; 3];
    let mut diff = [0.0; 3];
    let mut with = [0.0; 3];
    // The peak at the nodes (mu = 1 included) as well as the midpoints.
    let mut peak = [0.0f64; 3];
    for ((&mu, e), x) in f.mu.iter().zip(&f.entry).zip(&f.exit) {
        for (c, p) in peak.iter_mut().enumerate() {
            *p = p.max(mu * e[c] * x[c]);
        }
    }
    for i in 0..DISK_POINTS {
        let mu = ((i as f64 + 0.5) / DISK_POINTS as f64).sqrt();
        let (e, x) = (f.entry_at(mu), f.exit_at(mu));
        for c in 0..3 {
            let full = mu * e[c] * x[c];
            let shipped = mu * if entry { e[c] } else { 1.0 } * if exit { x[c] } else { 1.0 };
            sq[c] += (shipped - full).powi(2);
            diff[c] += shipped - full;
            with[c] += full;
            peak[c] = peak[c].max(full);
        }
    }
    let n = DISK_POINTS as f64;
    Kept {
        rms: std::array::from_fn(|c| (sq[c] / n).sqrt() / peak[c]),
        bias: std::array::from_fn(|c| diff[c] / with[c]),
    }
}

fn pct3(v: [f64; 3]) -> String {
    v.map(|x| format!("{:.2}", 100.0 * x)).join(" / ")
}

fn table(t: &[[f64; 3]]) -> String {
    (0..3)
        .map(|c| {
            let v: Vec<String> = t.iter().map(|r| format!("{:.3}", r[c])).collect();
            format!("{} [{}]", ["r", "g", "b"][c], v.join(", "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The lines `ssskit engine` prints about the factors for `engine`: the
/// places, the values where there is one, the error kept; one line where
/// `profile` has no angular tables.
pub fn lines(engine: Engine, v: Version, profile: &Profile) -> Result<Vec<String>> {
    let Some(f) = AngularFactors::from_profile(profile)? else {
        return Ok(vec![format!(
            "entry and exit factors: the profile has no angular tables, so no values and no \
             kept error (`ssskit simulate --angle-bins 90 --incidence 30,60,80`, or the main \
             job from a material, makes them)"
        )]);
    };
    let p = place(engine, v);
    let mut out = vec![
        format!("entry factor E(N.L): {}", p.entry),
        format!("exit factor X(N.V): {}", p.exit),
    ];
    let mu: Vec<String> = f.mu.iter().map(|m| format!("{m:.3}")).collect();
    let cosines = format!("at cosines [{}]", mu.join(", "));
    if p.entry_place {
        out.push(format!("  E {cosines}: {}", table(&f.entry)));
    }
    if p.exit_place {
        out.push(format!("  X {cosines}: {}", table(&f.exit)));
    }
    let none = kept(&f, false, false);
    out.push(format!(
        "error kept without the factors (lit sphere seen from its light, r / g / b): RMS {}% \
         of the peak, bias {}%",
        pct3(none.rms),
        pct3(none.bias)
    ));
    if p.entry_place != p.exit_place {
        let part = kept(&f, p.entry_place, p.exit_place);
        out.push(format!(
            "error kept with only the {} factor in its place: RMS {}% of the peak, bias {}%",
            if p.exit_place { "exit" } else { "entry" },
            pct3(part.rms),
            pct3(part.bias)
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(e: f64, x: f64) -> AngularFactors {
        let n = 9;
        AngularFactors {
            mu: (0..n).map(|k| k as f64 / (n - 1) as f64).collect(),
            entry: vec![[e; 3]; n],
            entry_stderr: vec![[0.0; 3]; n],
            exit: vec![[x; 3]; n],
            exit_stderr: vec![[0.0; 3]; n],
            photons: 1,
        }
    }

    /// Constant factors: the image with them is c mu, without mu, so the
    /// RMS of the difference over the peak c is |1 - c| / c sqrt(<mu^2>)
    /// = |1 - c| / (c sqrt 2) (mu^2 uniform on the disk) and the bias
    /// (1 - c) / c; factors of 1 keep nothing.
    #[test]
    fn constant_factors_keep_their_closed_form() {
        let k = kept(&flat(0.8, 1.0), false, false);
        let c: f64 = 0.8;
        for ch in 0..3 {
            assert!((k.rms[ch] - (1.0 - c) / (c * 2f64.sqrt())).abs() < 1e-6);
            assert!((k.bias[ch] - (1.0 - c) / c).abs() < 1e-9);
        }
        let k = kept(&flat(0.8, 1.25), true, false);
        assert!(k.rms.iter().all(|&r| (r - 0.2 / 2f64.sqrt()).abs() < 1e-6));
        assert_eq!(kept(&flat(1.0, 1.0), false, false).rms, [0.0; 3]);
        assert_eq!(kept(&flat(0.7, 0.9), true, true).rms, [0.0; 3]);
    }
}
