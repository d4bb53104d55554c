//! Godot 4's screen-space subsurface scattering (Forward+ renderer; read
//! at godotengine/godot commit 19843743 for
//! servers/rendering/renderer_rd/shaders/effects/subsurface_scattering.glsl
//! and 006f0390 for renderer_rd/effects/ss_effects.cpp): one fixed kernel
//! table for every channel, whose only free parameters are its width on
//! screen and its tap count; the colour comes from the material's albedo.
//!
//! The kernel, as read from Godot's source:
//!
//! - subsurface_scattering.glsl holds three tables, chosen by the define
//!   USE_11_SAMPLES, USE_17_SAMPLES or USE_25_SAMPLES; SSEffects compiles
//!   them as shader versions 0, 1, 2 and binds version
//!   `subsurface_scattering_quality - 1` (project setting, "Low (Fast)",
//!   "Medium (Average)", "High (Slow)" = 1, 2, 3; default 1, Low). Each
//!   `kernel[]` is (weight, offset) for the centre and one side: the red
//!   column of iryoku's default table (strength 0.48, falloff 1;
//!   SeparableSSS.h), which `kernel::jimenez::tap_table` reproduces. main()
//!   weights the centre by kernel[0].x and do_filter adds both sides,
//!   dividing by the sum of the weights used (1 for the whole table), the
//!   same weights for r, g, b (the skin mode, negative alpha, uses the
//!   per-channel `skin_kernel` instead).
//!
//! The chain from Godot's settings to the kernel's width:
//!
//! - The material writes `SSS_STRENGTH` (BaseMaterial3D: the
//!   `subsurf_scatter_strength` property times the red channel of
//!   `subsurf_scatter_texture`, white by default) into the alpha of the
//!   RGBA16F diffuse buffer (scene_forward_clustered.glsl; negated in
//!   `SSS_MODE_SKIN`). BaseMaterial3D::set_subsurface_scattering_strength
//!   does not clamp it; only the inspector does (range 0 to 1, step 0.01).
//! - RendererRD's SSEffects::sub_surface_scattering fills the push
//!   constants: `scale` and `depth_scale` are the project settings
//!   rendering/environment/subsurface_scattering/subsurface_scattering_scale
//!   (default 0.05) and subsurface_scattering_depth_scale (default 0.01,
//!   both GLOBAL_DEF in rendering_server.cpp); `unit_size` is the x of
//!   Projection::xform4 applied to the point (1, 0, -1, 1) over its w,
//!   which for Projection::set_perspective is columns[0][0] = cot(fov_x / 2)
//!   and for set_orthogonal 2 / width: normalised device x per scene unit
//!   at depth 1.
//! - subsurface_scattering.glsl main(): the step in texture coordinates per
//!   kernel offset unit is mix(scale, unit_size / depth, depth_scale)
//!   x strength / 3 (unit_size alone for an orthogonal camera), depth the
//!   linear view depth, the same step for the horizontal and the vertical
//!   pass; do_filter samples uv + offset x step and stops at a neighbour
//!   whose abs(alpha) < 0.001.
//!
//! Texture coordinates span the screen (0 to 1) and normalised device
//! coordinates twice that, so one texture-coordinate unit across is
//! 2 depth / unit_size scene units: the horizontal step covers
//! (2 strength / 3) ((1 - depth_scale) scale depth / unit_size + depth_scale)
//! scene units per kernel unit. Only its depth_scale part is a fixed length
//! in the scene; the rest is a fixed fraction of the screen, so the width
//! in the scene grows with the camera's distance and field of view, which
//! ssskit does not know. At depth_scale 1 the step is 2 strength / 3 scene
//! units per kernel unit whatever the camera: iryoku's sssWidth
//! (Jimenez et al. 2015, SeparableSSS.h), with cot(fov_x / 2) where
//! iryoku has cot(fov_y / 2). The vertical pass steps the same texture
//! distance over the screen's height, 1 / aspect of that in the scene.

use super::jimenez::{self as sep, FitData, Separable};
use super::printed::{
    check, color, number, srgb_hex, table, triple, typed, units_line, Units, TYPED_REL,
};
use super::priority::Priority;
use super::{EngineFit, Scene};
use crate::error::{Error, Result};
use crate::filter::image::{linear_to_srgb, srgb_to_linear};
use crate::kernel::jimenez::{tap_table, JimenezParams};
use crate::kernel::taps;
use crate::numerics::Bounded;
use crate::profile::Profile;
use serde_json::{json, Map, Value};

pub const VERSION: &str = "Godot 4 Forward+ (godotengine/godot 19843743: \
     subsurface_scattering.glsl; ss_effects.cpp)";

/// Default of subsurface_scattering_scale (rendering_server.cpp).
pub const DEFAULT_SCALE: f64 = 0.05;
/// Default of subsurface_scattering_depth_scale (rendering_server.cpp).
pub const DEFAULT_DEPTH_SCALE: f64 = 0.01;
/// do_filter stops at a neighbour whose abs(alpha) is below this, so a
/// smaller strength blurs nothing (subsurface_scattering.glsl).
pub const MIN_STRENGTH: f64 = 0.001;
/// The inspector's step for subsurf_scatter_strength (BaseMaterial3D,
/// PROPERTY_HINT_RANGE "0,1,0.01").
pub const INSPECTOR_STEP: f64 = 0.01;

/// The values subsurface_scattering.glsl reads: the material's strength
/// and the two project settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// abs(alpha) of the diffuse buffer: SSS_STRENGTH.
    pub strength: f64,
    /// subsurface_scattering_scale.
    pub scale: f64,
    /// subsurface_scattering_depth_scale.
    pub depth_scale: f64,
}

/// The camera terms of the step at one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Normalised device x per scene unit at depth 1: cot(fov_x / 2), or
    /// 2 / width for an orthogonal camera (SSEffects::sub_surface_scattering).
    pub unit_size: f64,
    /// Linear view depth of the pixel, scene units.
    pub depth: f64,
    pub orthogonal: bool,
}

impl Camera {
    /// A perspective camera with horizontal field of view `fov_x` (radians)
    /// looking at a surface `depth` scene units away.
    pub fn perspective(fov_x: f64, depth: f64) -> Camera {
        Camera {
            unit_size: 1.0 / (0.5 * fov_x).tan(),
            depth,
            orthogonal: false,
        }
    }

    /// An orthogonal camera `width` scene units across.
    pub fn orthogonal(width: f64) -> Camera {
        Camera {
            unit_size: 2.0 / width,
            depth: 1.0,
            orthogonal: true,
        }
    }

    /// Scene units across the screen at the pixel's depth: normalised
    /// device x spans 2.
    pub fn screen_width(&self) -> f64 {
        if self.orthogonal {
            2.0 / self.unit_size
        } else {
            2.0 * self.depth / self.unit_size
        }
    }
}

/// Texture coordinates per kernel offset unit (subsurface_scattering.glsl
/// main: mix(scale, depth term, depth_scale) x strength / 3).
pub fn step_uv(s: &Settings, cam: &Camera) -> f64 {
    let depth_term = if cam.orthogonal {
        cam.unit_size
    } else {
        cam.unit_size / cam.depth
    };
    let mixed = s.scale * (1.0 - s.depth_scale) + depth_term * s.depth_scale;
    mixed * s.strength / 3.0
}

/// Screen pixels per kernel offset unit on the horizontal pass of a
/// screen `width_px` pixels wide.
pub fn step_pixels(s: &Settings, cam: &Camera, width_px: f64) -> f64 {
    step_uv(s, cam) * width_px
}

/// Scene units per kernel offset unit on the horizontal pass.
pub fn step_scene_units(s: &Settings, cam: &Camera) -> f64 {
    step_uv(s, cam) * cam.screen_width()
}

/// Scene units per offset unit per unit of strength on the horizontal
/// pass at depth_scale 1: 2/3 for every camera (`step_scene_units`,
/// evaluated for one).
fn step_per_strength() -> f64 {
    let exact = Settings {
        strength: 1.0,
        scale: DEFAULT_SCALE,
        depth_scale: 1.0,
    };
    step_scene_units(
        &exact,
        &Camera::perspective(std::f64::consts::FRAC_PI_2, 1.0),
    )
}

/// The strength that makes the kernel `width` scene units per offset unit
/// at depth_scale 1: 1.5 width.
pub fn strength_for_width(width: f64) -> f64 {
    width / step_per_strength()
}

/// The horizontal pass's scene units per offset unit at depth_scale 1.
pub fn width_for_strength(strength: f64) -> f64 {
    strength * step_per_strength()
}

/// Scene units per offset unit on the vertical pass: the same texture
/// step over the screen's height, 1 / `aspect` of the width.
pub fn vertical_step_scene_units(s: &Settings, cam: &Camera, aspect: f64) -> f64 {
    step_scene_units(s, cam) / aspect
}

/// The project setting subsurface_scattering_quality (its inspector label)
/// and the table it selects (SSEffects: shader version quality - 1).
pub const QUALITIES: [(&str, usize); 3] = [
    ("Low (Fast)", 11),
    ("Medium (Average)", 17),
    ("High (Slow)", 25),
];

fn quality_label(samples: usize) -> &'static str {
    QUALITIES
        .iter()
        .find(|q| q.1 == samples)
        .map_or("?", |q| q.0)
}

/// Godot's kernel: its table for `samples` taps at `mm_per_unit` mm per
/// offset unit on the horizontal pass, times the albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Godot {
    pub samples: usize,
    pub mm_per_unit: f64,
    pub albedo: [f64; 3],
}

impl Godot {
    /// The table Godot ships: the red column of iryoku's default kernel
    /// for every channel, divided by its sum as do_filter does.
    pub fn separable(&self) -> Result<Separable> {
        let n = self.samples;
        let p = JimenezParams {
            width: self.mm_per_unit,
            ..JimenezParams::default()
        };
        let mut t = tap_table(&p, n, taps::range(n) * self.mm_per_unit)?;
        let sum: f64 = t.weights.iter().map(|w| w[0]).sum();
        t.weights.iter_mut().for_each(|w| *w = [w[0] / sum; 3]);
        Ok(Separable {
            albedo: self.albedo,
            taps: t,
        })
    }
}

/// The summed squared shape error of Godot's table at `mm_per_unit`, the
/// albedo the profile's total.
fn cost(d: &FitData, p: &Profile, samples: usize, mm_per_unit: f64) -> Result<f64> {
    let k = Godot {
        samples,
        mm_per_unit,
        albedo: [1.0; 3],
    }
    .separable()?;
    let w: Vec<f64> = k.taps.weights.iter().map(|w| w[0]).collect();
    let (_, g) = d.geometry(samples, mm_per_unit)?;
    let shape = g.bilinear(&w, &w);
    Ok((0..3)
        .map(|c| sep::relative_residual(&d.targets[c], &shape, p.total_rd[c]))
        .sum())
}

/// The best width for `samples` taps and its summed squared shape error.
pub fn fit_samples(p: &Profile, samples: usize) -> Result<(Godot, f64)> {
    let d = FitData::new(p)?;
    let l = sep::best_unit(&d, |l| cost(&d, p, samples, l))?;
    let k = Godot {
        samples,
        mm_per_unit: l,
        albedo: std::array::from_fn(|c| p.total_rd[c]),
    };
    Ok((k, cost(&d, p, samples, l)?))
}

/// What stands between `strength` and Godot, in words (None: the
/// inspector takes it, to its step).
pub fn strength_warning(strength: f64) -> Option<String> {
    if strength < MIN_STRENGTH {
        Some(format!(
            "`subsurf_scatter_strength` {strength:.6} is below {MIN_STRENGTH}, where do_filter \
             stops at every neighbour (abs(alpha) < {MIN_STRENGTH}): Godot cannot blur this \
             narrow in these scene units; its narrowest kernel is {:.6} scene units per offset \
             unit",
            width_for_strength(MIN_STRENGTH)
        ))
    } else if strength < INSPECTOR_STEP {
        Some(format!(
            "`subsurf_scatter_strength` {strength:.6} is below the inspector's step \
             {INSPECTOR_STEP}, which rounds it to {:.2}: set it from a script \
             (set_subsurface_scattering_strength keeps it) or as SSS_STRENGTH in a shader",
            (strength / INSPECTOR_STEP).round() * INSPECTOR_STEP
        ))
    } else if strength > 1.0 {
        Some(format!(
            "`subsurf_scatter_strength` {strength:.4} is above the inspector's range [0, 1]: set \
             it from a script or as SSS_STRENGTH in a shader (the renderer reads abs(alpha) of \
             an RGBA16F buffer and does not clamp); no project setting widens the kernel at \
             subsurface_scattering_depth_scale 1"
        ))
    } else {
        None
    }
}

/// The inspector's value for `strength` (its step, 0.01), when it takes it.
pub fn inspector_strength(strength: f64) -> Option<f64> {
    (strength_warning(strength).is_none())
        .then(|| (strength / INSPECTOR_STEP).round() * INSPECTOR_STEP)
}

/// The values to type, each to 4 significant digits (`typed`): the
/// strength first, then the width it gives, so the two agree within the
/// rounding (`godot_from_params` checks it). 4 digits, not the inspector's
/// 0.01 step, because skin's strength is about 0.02 and that step moves its
/// width by up to a quarter (the fit's warning gives that error); a script
/// takes 4 digits, and they are finer than the colour picker's 8 bits.
/// The error is scored on these rounded values (`fit`).
pub fn params(k: &Godot, scene: Scene) -> (Map<String, Value>, Units) {
    let strength = typed(strength_for_width(k.mm_per_unit * scene.units_per_mm));
    table(vec![
        (
            "kernel_width_mm",
            json!(typed(width_for_strength(strength) / scene.units_per_mm)),
            "mm per unit of the kernel's offsets on the horizontal pass (the vertical pass \
             steps 1 / aspect of it)",
        ),
        (
            "subsurf_scatter_strength",
            json!(strength),
            "material subsurf_scatter_strength (SSS_STRENGTH) with \
             subsurface_scattering_depth_scale = 1: 1.5 x kernel_width_mm x scene units per mm \
             (the horizontal pass steps 2/3 of it in scene units per offset unit)",
        ),
        (
            "subsurface_scattering_depth_scale",
            json!(1.0),
            "project setting (default 0.01): 1 makes the step unit_size / depth, a fixed \
             length in the scene, and subsurface_scattering_scale unused; at the defaults \
             the width is mostly a fixed fraction of the screen and grows with distance",
        ),
        (
            "subsurface_scattering_quality",
            json!(quality_label(k.samples)),
            "project setting (default Low (Fast)): the table of nSamples taps",
        ),
        (
            "nSamples",
            json!(k.samples),
            "taps per pass of that table (USE_11/17/25_SAMPLES)",
        ),
        (
            "albedo_color",
            color(k.albedo.map(|a| typed(linear_to_srgb(a.clamp(0.0, 1.0))))),
            "the material's Albedo > Color as the inspector shows it (sRGB, 0 to 1: \
             BaseMaterial3D's shader reads it as source_color and decodes it): the profile's \
             total reflectance",
        ),
        (
            "albedo_color hex",
            json!(srgb_hex(k.albedo)),
            "the same colour as the colour picker's 8-bit hex field",
        ),
    ])
}

/// Godot's kernel from its values as written: the width from
/// subsurf_scatter_strength at depth_scale 1, checked against
/// kernel_width_mm; the table from the quality, checked against nSamples.
pub fn godot_from_params(p: &Map<String, Value>, scene: Scene) -> Result<Godot> {
    let depth_scale = number(p, "subsurface_scattering_depth_scale")?;
    check(
        depth_scale == 1.0,
        "subsurface_scattering_depth_scale",
        depth_scale,
        "only 1 gives a width in the scene; below 1 it depends on the camera's distance",
    )?;
    let strength = number(p, "subsurf_scatter_strength")?;
    check(
        strength > 0.0,
        "subsurf_scatter_strength",
        strength,
        "must be > 0: at 0 Godot does not blur",
    )?;
    let w = width_for_strength(strength) / scene.units_per_mm;
    let stated = number(p, "kernel_width_mm")?;
    check(
        (w - stated).abs() <= TYPED_REL * stated.abs(),
        "kernel_width_mm",
        stated,
        format!("disagrees with subsurf_scatter_strength, which gives {w} mm at these scene units"),
    )?;
    let label = p
        .get("subsurface_scattering_quality")
        .and_then(Value::as_str)
        .unwrap_or_default();
    let Some(&(_, samples)) = QUALITIES.iter().find(|q| q.0 == label) else {
        return Err(Error::invalid(
            "engine",
            "subsurface_scattering_quality",
            label,
            "expected Low (Fast), Medium (Average) or High (Slow)",
        ));
    };
    let stated = number(p, "nSamples")?;
    check(
        stated == samples as f64,
        "nSamples",
        stated,
        format!("the quality {label} selects the {samples}-tap table"),
    )?;
    let shown = triple(p, "albedo_color")?;
    for x in shown {
        super::printed::in_range("Godot's inspector", "albedo_color", x, (0.0, 1.0))?;
    }
    Ok(Godot {
        samples,
        mm_per_unit: w,
        albedo: shown.map(srgb_to_linear),
    })
}

pub fn from_params(p: &Map<String, Value>, scene: Scene) -> Result<Separable> {
    godot_from_params(p, scene)?.separable()
}

fn requirements(k: &Godot) -> Vec<String> {
    vec![
        "project setting rendering/environment/subsurface_scattering/\
         subsurface_scattering_depth_scale = 1 (default 0.01): the width is then a length in \
         the scene whatever the camera"
            .into(),
        format!(
            "project setting subsurface_scattering_quality = {} ({} taps)",
            quality_label(k.samples),
            k.samples
        ),
        "the material's subsurf_scatter_texture is unset or white (its red channel multiplies \
         the strength), and the SSS mode is not Skin (which uses the per-channel skin table)"
            .into(),
    ]
}

/// Fits Godot's width with each quality's table and keeps the best.
pub fn fit(profile: &Profile, scene: Scene) -> Result<EngineFit> {
    let k = sep::best_count(|n| fit_samples(profile, n))?;
    let (params, units) = params(&k, scene);
    // The error of what the engine renders from the values as written.
    let (model_profile, error) = sep::rendered(&from_params(&params, scene)?, profile, "godot")?;
    let strength = number(&params, "subsurf_scatter_strength")?;
    let mut warnings: Vec<String> = strength_warning(strength).into_iter().collect();
    if let Some(typed) = inspector_strength(strength) {
        if typed != strength {
            let moved = Godot {
                mm_per_unit: width_for_strength(typed) / scene.units_per_mm,
                ..k
            };
            let (_, e) = sep::rendered(&moved.separable()?, profile, "godot")?;
            let pct = |v: [f64; 3]| v.map(|x| format!("{:.1}%", Bounded(100.0 * x))).join(", ");
            warnings.push(format!(
                "the inspector rounds `subsurf_scatter_strength` to {typed:.2} ({:+.1}% width; \
                 shape error there {}): a script keeps it exact",
                Bounded(100.0 * (typed / strength - 1.0)),
                pct(e.shape)
            ));
        }
    }
    Ok(EngineFit {
        engine: "godot".into(),
        version: VERSION.into(),
        priority: Priority::Colour,
        params,
        units,
        error,
        error_for: format!(
            "the separable product K(x) K(y) of Godot's {}-tap table, each tap's weight spread \
             over its footprint, at the horizontal pass's step (the vertical pass steps \
             1 / aspect of it)",
            k.samples
        ),
        scene: vec![units_line(
            scene,
            "subsurf_scatter_strength is a length in them at subsurface_scattering_depth_scale 1",
        )],
        requirements: requirements(&k),
        warnings,
        other: None,
        rendered: None,
        walk: None,
        profile: model_profile,
    })
}
