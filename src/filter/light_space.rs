//! The light-space directional method of Dal Corso et al. 2017 on the CPU
//! (f64; the reference of the wgpu pass, [`super::light_space_gpu`]):
//! scattered radiosity B(x_o) estimated from the lights' G-buffers
//! ([`crate::scene::light_map`]) with the full directional dipole
//! (Frisvad et al. 2014), shown as L_o = F_t(w_o) B / pi (eq. 5).
//!
//! # The estimator
//!
//! Per camera surface point x_o (normal n_o), channel c and light:
//!
//! - samples (r_j, alpha_j) = (-ln xi_1 / sigma, 2 pi xi_2) (eq. 12), with
//!   density sigma e^{-sigma r} / (2 pi) in (r, alpha) (eq. 11) and
//!   sigma = sigma_tr of the channel (eq. 10), one set per channel; a
//!   medium that absorbs nothing (sigma_tr = 0) is sampled with sigma =
//!   1 / the objects' bounding radius instead (any density is unbiased);
//! - x_j = x_o + r_j (cos alpha_j a + sin alpha_j b), (a, b) spanning the
//!   plane through x_o facing the light: the light's view plane for a
//!   directional light (a texture-space offset in its map), the plane
//!   perpendicular to the ray from a point light (Dal Corso 2014, section
//!   4.1: the sampling disc oriented towards the light);
//! - the light map's texel holding x_j gives x_i, n_i and the transmitted
//!   irradiance E_t = E F_t(theta_i) cos(theta_i); a texel of another object
//!   or of none adds 0;
//! - the texel's area on the surface is dA_i = dA_j cos_j d_i^2 /
//!   (cos_i d_j^2) of the sampling plane's dA_j (d the distances to a point
//!   light, cos_j the ray's cosine with the plane's normal; 1 / cos_i for a
//!   directional light), so the sample estimates eq. 7's integrand
//!   S_d E_t dA_i / dA_j / p(x_j), p(x_j) = sigma e^{-sigma r} / (2 pi r).
//!
//! Eq. 9 of Dal Corso et al. 2017 writes the cosine cos(theta_l) with
//! r dr d(alpha) as the area: eq. 8's assumption of a surface normal to
//! the light, where cos_i = 1. On a tilted surface a texel covers dA_j /
//! cos_i of it and the cosines cancel, as in Dal Corso 2014, eq. 4.2:
//! without that the estimator would converge to eq. 7 times cos(theta_i)
//! (tests/light_space.rs checks the method against eq. 7 at oblique
//! incidence).
//!
//! Then L_o = F_t(w_o) B / pi per light, B = pi times the mean of the
//! samples (eq. 9), so L_o = F_t(w_o) times that mean; the exitance
//! sensor shows M / pi = 4 C_phi(1/eta) B / pi instead (the hemisphere
//! integral of F_t cos / pi). A pixel is the mean over its surface
//! positions (the render's box filter): sample j goes to position j mod
//! side^2, each position's samples averaged, then the positions that got
//! samples.
//!
//! Random numbers: Philox4x32-10 (Salmon et al. 2011) with counter
//! (pixel, channel + 4 light, sample, 0) and the seed as key, the
//! generator of the GPU tracer; xi = (top 24 bits + 1/2) 2^-24, exact in
//! f32 and f64, so the wgpu pass draws the same samples.

use super::Image;
use crate::error::{Error, Result};
use crate::profile::analytic::directional_dipole::{DirectionalDipole, Incidence};
use crate::profile::fresnel::{fresnel_dielectric, FresnelMode};
use crate::profile::mc::gpu::philox4x32_10;
use crate::scene::{
    check_light, light_map, surface_points, LightMap, LightSource, Measure, Scene, SurfacePoints,
    LIGHT_SPACE,
};
use rayon::prelude::*;
use std::f64::consts::TAU;

/// Default light-map side: Dal Corso et al. 2017, section 5 ("a light map
/// of 512 x 512 pixels is an acceptable size").
pub const DEFAULT_LIGHT_MAP_SIDE: usize = 512;

/// Below this reduced albedo (in any channel) the method is refused: the
/// directional dipole has no albedo factor and tends to a constant as
/// alpha' -> 0 (docs/analytic.md), so its light would be made up.
pub const MIN_REDUCED_ALBEDO: f64 = 0.01;
/// Below this reduced albedo the method runs with a warning: diffusion
/// needs sigma_a << sigma_s' (Jensen et al. 2001), and docs/analytic.md
/// measures the directional dipole's total R_d off by tens of times below
/// 0.5 (the class "< 0.5").
pub const DIFFUSION_ALBEDO: f64 = 0.5;

/// Bits of a uniform number: [`crate::filter::jitter::JITTER_BITS`], exact
/// in f32 and f64.
const UNIFORM_BITS: u32 = super::jitter::JITTER_BITS;

/// xi in (0, 1) from a 32-bit draw: its top 24 bits plus one half, over
/// 2^24.
pub fn unit(x: u32) -> f64 {
    ((x >> (32 - UNIFORM_BITS)) as f64 + 0.5) / (1u32 << UNIFORM_BITS) as f64
}

/// The two uniforms of sample `j` of pixel `pixel` in channel `c` for
/// light `light`.
pub fn uniforms(seed: u64, pixel: usize, c: usize, light: usize, j: usize) -> (f64, f64) {
    let r = philox4x32_10(
        [pixel as u32, (c + 4 * light) as u32, j as u32, 0],
        [seed as u32, (seed >> 32) as u32],
    );
    (unit(r[0]), unit(r[1]))
}

/// Everything the pass reads: the lights' maps, the camera's surface
/// points, per object the dipole of each channel and the sampling
/// coefficient, and what a pixel measures.
#[derive(Clone, Debug)]
pub struct LightSpaceInput {
    pub maps: Vec<LightMap>,
    pub surface: SurfacePoints,
    /// `[object][channel]`.
    pub dipoles: Vec<[DirectionalDipole; 3]>,
    /// sigma of eq. 11 per object and channel: sigma_tr, or 1 / the
    /// bounding radius where sigma_tr is 0.
    pub sigma: Vec<[f64; 3]>,
    pub measure: Measure,
    /// Materials the dipole describes poorly ([`DIFFUSION_ALBEDO`]), said
    /// before the work.
    pub warnings: Vec<String>,
}

/// The per-pass settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightSpaceSetup {
    /// Samples per pixel, channel and light (N of eq. 9).
    pub samples: usize,
    pub seed: u64,
}

/// The dipoles of every object (exact Fresnel moments), refusing a
/// material outside the model ([`MIN_REDUCED_ALBEDO`]) and warning below
/// [`DIFFUSION_ALBEDO`].
fn dipoles_of(scene: &Scene) -> Result<(Vec<[DirectionalDipole; 3]>, Vec<String>)> {
    let mut warnings = Vec::new();
    let mut out = Vec::with_capacity(scene.objects.len());
    for (k, o) in scene.objects.iter().enumerate() {
        let mut one = Vec::with_capacity(3);
        for ch in crate::material::Channel::ALL {
            let mut m = o.material.top(ch);
            m.eta = o.eta();
            let alpha = m.reduced_albedo();
            if !(alpha >= MIN_REDUCED_ALBEDO) {
                return Err(Error::invalid(
                    LIGHT_SPACE,
                    format!("object[{k}].material"),
                    format!("{} ({} alpha' = {alpha:.4})", o.material.name, ch.name()),
                    format!(
                        "the directional dipole needs a scattering medium: below a reduced \
                         albedo of {MIN_REDUCED_ALBEDO} it has no albedo factor to vanish with \
                         and its light would be made up (docs/analytic.md)"
                    ),
                ));
            }
            if alpha < DIFFUSION_ALBEDO {
                warnings.push(format!(
                    "object[{k}] ({}): reduced albedo {alpha:.3} in {} is below \
                     {DIFFUSION_ALBEDO}, where diffusion (and the directional dipole) errs by \
                     tens of times (docs/analytic.md)",
                    o.material.name,
                    ch.name()
                ));
            }
            let d = DirectionalDipole::new(&m, FresnelMode::Exact, 1.0);
            if !(d.c_phi_exit > 0.0 && d.a.is_finite() && d.a > 0.0) {
                return Err(Error::invalid(
                    LIGHT_SPACE,
                    format!("object[{k}].eta"),
                    m.eta,
                    "the exact Fresnel moments give no boundary condition here",
                ));
            }
            one.push(d);
        }
        out.push([one[0].clone(), one[1].clone(), one[2].clone()]);
    }
    Ok((out, warnings))
}

/// Everything [`LightSpaceInput::new`] refuses, checked before any work
/// (the caps, every light, every material); the warnings of materials the
/// dipole describes poorly.
pub fn preflight(
    scene: &Scene,
    map_side: usize,
    surface_side: usize,
    samples: usize,
) -> Result<Vec<String>> {
    let cam = &scene.camera;
    // Saturating: a side large enough to wrap must still meet the cap.
    let positions = (cam.width.saturating_mul(cam.height))
        .saturating_mul(surface_side.saturating_mul(surface_side));
    let lights = scene.lights.len();
    crate::limits::check_light_space(LIGHT_SPACE, map_side, samples, positions, lights)?;
    for i in 0..lights {
        check_light(scene, i)?;
    }
    dipoles_of(scene).map(|(_, w)| w)
}

impl LightSpaceInput {
    /// The maps of every directional and point light at `map_side`, the
    /// camera's surface points at `surface_side` per pixel side, after
    /// [`preflight`].
    pub fn new(
        scene: &Scene,
        map_side: usize,
        surface_side: usize,
        samples: usize,
    ) -> Result<LightSpaceInput> {
        preflight(scene, map_side, surface_side, samples)?;
        let lights = scene.lights.len();
        let (dipoles, warnings) = dipoles_of(scene)?;
        let (lo, hi) = scene.bounds();
        let radius = 0.5 * (hi - lo).norm();
        let sigma = dipoles
            .iter()
            .map(|d| {
                d.clone().map(|d| {
                    if d.sigma_tr > 0.0 {
                        d.sigma_tr
                    } else {
                        1.0 / radius
                    }
                })
            })
            .collect();
        let maps = (0..lights)
            .map(|i| light_map(scene, i, map_side))
            .collect::<Result<Vec<_>>>()?;
        Ok(LightSpaceInput {
            maps,
            surface: surface_points(scene, surface_side)?,
            dipoles,
            sigma,
            measure: scene.camera.measure,
            warnings,
        })
    }

    /// One sample's estimate of eq. 7's integral over the plane facing
    /// light `m` at surface position `q` (module docs), before the exit
    /// factor: S_d E_t (dA_i / dA_j) / p.
    fn sample(&self, q: usize, c: usize, m: usize, (xi1, xi2): (f64, f64)) -> f64 {
        let s = &self.surface;
        let k = s.object[q] as usize;
        let map = &self.maps[m];
        let (x_o, n_o) = (s.position[q], s.normal[q]);
        let sigma = self.sigma[k][c];
        // Dal Corso et al. 2017, eq. 12.
        let r = -xi1.ln() / sigma;
        let (sa, ca) = (TAU * xi2).sin_cos();
        let (a, b, light) = match map.source {
            LightSource::Directional { .. } => (map.u, map.v, None),
            LightSource::Point { position, .. } => {
                let (a, b) = crate::scene::frame((position - x_o).normalize());
                (a, b, Some(position))
            }
        };
        let x_j = x_o + r * (ca * a + sa * b);
        let Some(t) = map.texel(x_j) else {
            return 0.0;
        };
        if map.object[t] != k as i32 {
            return 0.0;
        }
        let e = map.transmitted[c][t];
        if !(e > 0.0) {
            return 0.0;
        }
        let (x_i, n_i) = (map.position[t], map.normal[t]);
        let (w_i, area) = match light {
            None => {
                let (w, _) = map.source.at(x_i);
                (w, 1.0 / n_i.dot(&w))
            }
            Some(p) => {
                let (to_i, to_j) = (p - x_i, x_j - p);
                let (d_i2, d_j2) = (to_i.norm_squared(), to_j.norm_squared());
                let w = to_i / d_i2.sqrt();
                let cos_j = (to_j.dot(&(p - x_o).normalize()) / d_j2.sqrt()).abs();
                (w, cos_j * d_i2 / (n_i.dot(&w) * d_j2))
            }
        };
        let g = Incidence {
            x_i,
            n_i,
            w_i,
            x_o,
            n_o,
        };
        // 1 / p = 2 pi r / (sigma e^{-sigma r}), e^{-sigma r} = xi_1.
        self.dipoles[k][c].s_d(&g) * e * area * TAU * r / (sigma * xi1)
    }

    /// The exit factor at position `q` in channel `c`: F_t(w_o) for
    /// radiance, 4 C_phi(1/eta) for the exitance sensor.
    fn exit(&self, q: usize, c: usize) -> f64 {
        let s = &self.surface;
        let d = &self.dipoles[s.object[q] as usize][c];
        match self.measure {
            Measure::Radiance => 1.0 - fresnel_dielectric(s.normal[q].dot(&s.view[q]), d.eta),
            Measure::Exitance => 4.0 * d.c_phi_exit,
        }
    }

    /// Pixel `p` in channel `c` (module docs).
    fn pixel(&self, p: usize, c: usize, setup: &LightSpaceSetup) -> f64 {
        let per = self.surface.side * self.surface.side;
        let used = per.min(setup.samples);
        let mut sum = 0.0;
        for s in 0..used {
            let q = p * per + s;
            if self.surface.object[q] < 0 {
                continue;
            }
            let (mut acc, mut n) = (0.0, 0usize);
            for j in (s..setup.samples).step_by(per) {
                for m in 0..self.maps.len() {
                    acc += self.sample(q, c, m, uniforms(setup.seed, p, c, m, j));
                }
                n += 1;
            }
            sum += self.exit(q, c) * acc / n as f64;
        }
        sum / used as f64
    }

    /// The caps of `limits::check_light_space` for a pass of `setup`.
    pub fn check(&self, setup: &LightSpaceSetup) -> Result<()> {
        crate::limits::check_light_space(
            LIGHT_SPACE,
            self.maps.first().map_or(1, |m| m.side),
            setup.samples,
            self.surface.object.len(),
            self.maps.len(),
        )
    }

    /// Dipole evaluations of a pass: positions that see an object x
    /// samples x channels x lights (the method's work; each is one
    /// look-up and one S_d).
    pub fn evaluations(&self, setup: &LightSpaceSetup) -> u64 {
        let per = self.surface.side * self.surface.side;
        let n = setup.samples;
        // Position s of a pixel takes samples s, s + per, ... below n.
        let takes = |s: usize| if s < n { (n - s).div_ceil(per) } else { 0 } as u64;
        let seen: u64 = (0..self.surface.object.len())
            .filter(|&q| self.surface.object[q] >= 0)
            .map(|q| takes(q % per))
            .sum();
        seen * 3 * self.maps.len() as u64
    }
}

/// The light-space pass on the CPU: the radiance image of the method
/// (f64).
pub fn light_space_cpu(input: &LightSpaceInput, setup: &LightSpaceSetup) -> Result<Image> {
    input.check(setup)?;
    let s = &input.surface;
    let (w, h) = (s.width, s.height);
    let values: Vec<[f64; 3]> = (0..w * h)
        .into_par_iter()
        .map(|p| std::array::from_fn(|c| input.pixel(p, c, setup)))
        .collect();
    let mut img = Image::new(w, h);
    for (i, v) in values.iter().enumerate() {
        for c in 0..3 {
            img.rgb[c][i] = v[c];
        }
    }
    Ok(img)
}
