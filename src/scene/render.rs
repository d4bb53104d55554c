//! Rendering: the G-buffer, then rounds of samples per pixel and channel
//! until the budget's rule holds, rayon over tiles of pixels.

use super::gbuffer::{gbuffer, GBuffer};
use super::rounds::{trace_tile, Rounds, TileRound, TILE};
use super::samples::{SampleBudget, CONTEXT, FIRST_ROUND_SPP};
use super::trace::ChannelScene;
use super::Scene;
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::mc::{self, McConfig, PhotonBudget};
use crate::profile::Profile;
use crate::progress::Progress;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The render's metadata format.
pub const RENDER_SCHEMA: &str = "ssskit.render/1";
/// Default noise target: 1% (see [`SampleBudget::TargetError`]).
pub const DEFAULT_SCENE_ERROR: f64 = 0.01;
/// Default cap on samples per pixel.
pub const DEFAULT_MAX_SPP: u64 = 1 << 16;
/// Default cap on events (scattering events and boundary crossings) per
/// channel: a 192 x 192 sphere of skin at 4096 samples per pixel takes
/// about 5e9.
pub const DEFAULT_MAX_WORK: u64 = 20_000_000_000;
/// Default G-buffer positions per pixel side.
pub const DEFAULT_GBUFFER_SIDE: usize = 4;
/// The fewest samples per pixel a render takes: its noise (every render
/// states one, and its record is read back only with one) is estimated
/// from the spread of each pixel's samples, undefined for one.
pub const MIN_SPP: u64 = 2;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RenderConfig {
    pub budget: SampleBudget,
    pub seed: u64,
    /// Worker threads; None = rayon's default. Results do not depend on it.
    pub threads: Option<usize>,
    /// G-buffer positions per pixel side.
    pub gbuffer_side: usize,
    /// Cap on events per channel.
    pub max_work: u64,
}

impl Default for RenderConfig {
    fn default() -> RenderConfig {
        RenderConfig {
            budget: SampleBudget::TargetError {
                rel: DEFAULT_SCENE_ERROR,
                max_spp: DEFAULT_MAX_SPP,
            },
            seed: 1,
            threads: None,
            gbuffer_side: DEFAULT_GBUFFER_SIDE,
            max_work: DEFAULT_MAX_WORK,
        }
    }
}

/// How the render went, kept with the image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderInfo {
    pub schema: String,
    pub config: RenderConfigRecord,
    /// Samples per pixel of each channel.
    pub spp: [u64; 3],
    /// The noise of [`SampleBudget::TargetError`] per channel.
    pub noise: [f64; 3],
    /// Every channel met the target (always true for a fixed budget that
    /// ran to its end).
    pub converged: bool,
    /// A channel stopped at the work cap.
    pub work_capped: bool,
    pub events: [u64; 3],
    /// Paths ended by round-off (no boundary ahead inside an object).
    pub lost: [u64; 3],
    /// Total diffuse reflectance per object and channel behind the
    /// irradiance channels.
    pub rd: Vec<[f64; 3]>,
    /// Depth written where nothing is seen, scene units.
    pub far: f64,
    pub unit: super::Unit,
    pub seconds: f64,
}

/// The settings as recorded (threads left out: they change nothing).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderConfigRecord {
    pub budget: SampleBudget,
    pub seed: u64,
    pub gbuffer_side: usize,
    pub max_work: u64,
}

/// A rendered image with its G-buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct Render {
    pub width: usize,
    pub height: usize,
    /// Radiance per channel (or exitance / pi), row-major, row 0 at the top.
    pub radiance: [Vec<f64>; 3],
    /// Standard error of each pixel's mean.
    pub stderr: [Vec<f64>; 3],
    pub gbuffer: GBuffer,
    pub info: RenderInfo,
}

/// The channel names of a render in an image file, in the order of
/// [`Render::planes`].
pub fn channel_names() -> [&'static str; 14] {
    [
        "R",
        "G",
        "B",
        "stderr.R",
        "stderr.G",
        "stderr.B",
        "irradiance.R",
        "irradiance.G",
        "irradiance.B",
        "Z",
        "N.X",
        "N.Y",
        "N.Z",
        "coverage",
    ]
}

impl Render {
    /// Every plane with its channel name ([`channel_names`]).
    pub fn planes(&self) -> Vec<(&'static str, &[f64])> {
        let g = &self.gbuffer;
        let planes: [&[f64]; 14] = [
            &self.radiance[0],
            &self.radiance[1],
            &self.radiance[2],
            &self.stderr[0],
            &self.stderr[1],
            &self.stderr[2],
            &g.irradiance[0],
            &g.irradiance[1],
            &g.irradiance[2],
            &g.depth,
            &g.normal[0],
            &g.normal[1],
            &g.normal[2],
            &g.coverage,
        ];
        channel_names().into_iter().zip(planes).collect()
    }

    /// A render from named planes (as an image file holds them) and its
    /// metadata; every channel of [`channel_names`] is required.
    pub fn from_planes(
        width: usize,
        height: usize,
        mut planes: Vec<(String, Vec<f64>)>,
        info: RenderInfo,
        what: &str,
    ) -> Result<Render> {
        let mut take = |name: &str| -> Result<Vec<f64>> {
            let i = planes.iter().position(|(n, _)| n == name).ok_or_else(|| {
                Error::Unsupported(format!(
                    "{what}: no channel {name}; a scene render holds {}",
                    channel_names().join(", ")
                ))
            })?;
            let v = planes.swap_remove(i).1;
            if v.len() != width * height {
                return Err(Error::Unsupported(format!(
                    "{what}: channel {name} has {} values for {width}x{height} pixels",
                    v.len()
                )));
            }
            Ok(v)
        };
        let mut three = |p: &str| -> Result<[Vec<f64>; 3]> {
            Ok([
                take(&format!("{p}R"))?,
                take(&format!("{p}G"))?,
                take(&format!("{p}B"))?,
            ])
        };
        let radiance = three("")?;
        let stderr = three("stderr.")?;
        let irradiance = three("irradiance.")?;
        let depth = take("Z")?;
        let normal = [take("N.X")?, take("N.Y")?, take("N.Z")?];
        let coverage = take("coverage")?;
        Ok(Render {
            width,
            height,
            radiance,
            stderr,
            gbuffer: GBuffer {
                irradiance,
                depth,
                normal,
                coverage,
            },
            info,
        })
    }
}

/// The profiles of the objects' materials, by Monte Carlo (`simulate` with
/// `budget` and `seed`), one per object (objects of one material share
/// it).
pub fn material_profiles(
    scene: &Scene,
    budget: PhotonBudget,
    seed: u64,
    threads: Option<usize>,
    progress: &dyn Progress,
) -> Result<Vec<Profile>> {
    let mut done: Vec<(Material, Profile)> = Vec::new();
    let mut out = Vec::with_capacity(scene.objects.len());
    for o in &scene.objects {
        if let Some((_, p)) = done.iter().find(|(m, _)| *m == o.material) {
            out.push(p.clone());
            continue;
        }
        let cfg = McConfig {
            budget: budget.clone(),
            seed,
            threads,
            channels: Channel::ALL.to_vec(),
            grid: None,
        };
        let p = mc::simulate(&o.material, &cfg, progress)?;
        done.push((o.material.clone(), p.clone()));
        out.push(p);
    }
    Ok(out)
}

impl RenderConfig {
    /// Checks the settings against the scene (before any work).
    pub fn validate(&self, scene: &Scene) -> Result<()> {
        validate(self, None, scene)
    }
}

fn validate(cfg: &RenderConfig, rd: Option<&[[f64; 3]]>, scene: &Scene) -> Result<()> {
    let too_few = |field: &str, n: u64| {
        Error::invalid(
            CONTEXT,
            field,
            n,
            format!(
                "must be >= {MIN_SPP}: the noise the render states is the spread between a \
                 pixel's samples, which one sample does not have"
            ),
        )
    };
    match cfg.budget {
        SampleBudget::Fixed(n) if n < MIN_SPP => return Err(too_few("spp", n)),
        SampleBudget::TargetError { rel, max_spp } => {
            if !(rel > 0.0 && rel < 1.0) {
                return Err(Error::invalid(
                    CONTEXT,
                    "target_error",
                    rel,
                    "must be in (0, 1), e.g. 0.01",
                ));
            }
            if max_spp < MIN_SPP {
                return Err(too_few("max_spp", max_spp));
            }
        }
        _ => {}
    }
    if let Some(n) = cfg.threads {
        crate::limits::check_threads("worker threads", n)?;
    }
    super::gbuffer::check_side(CONTEXT, cfg.gbuffer_side)?;
    if cfg.max_work == 0 {
        return Err(Error::invalid(CONTEXT, "max_work", 0, "must be >= 1"));
    }
    if let Some(rd) = rd.filter(|rd| rd.len() != scene.objects.len()) {
        return Err(Error::Unsupported(format!(
            "{} total reflectances given for {} objects",
            rd.len(),
            scene.objects.len()
        )));
    }
    let pixels = (scene.camera.width * scene.camera.height) as u64;
    // The G-buffer's rays: per position the camera's, a shadow ray per
    // directional light, and the environment's visibility rays.
    let per_position = 1
        + scene.directional().count() as u64
        + scene.points().count() as u64
        + if scene.environment().iter().any(|&v| v > 0.0) {
            super::gbuffer::ENV_RAYS as u64
        } else {
            0
        };
    let rays = pixels
        .saturating_mul((cfg.gbuffer_side * cfg.gbuffer_side) as u64)
        .saturating_mul(per_position);
    if rays > cfg.max_work {
        return Err(Error::invalid(
            CONTEXT,
            "gbuffer_side",
            cfg.gbuffer_side,
            format!(
                "the G-buffer of {pixels} pixels at {0}x{0} positions casts {rays} rays, above \
                 the work cap of {1} (`max_work`)",
                cfg.gbuffer_side, cfg.max_work
            ),
        ));
    }
    let least = match cfg.budget {
        SampleBudget::Fixed(n) => n,
        SampleBudget::TargetError { max_spp, .. } => max_spp.min(FIRST_ROUND_SPP),
    };
    // Every sample costs at least one event.
    if pixels.saturating_mul(least) > cfg.max_work {
        return Err(Error::invalid(
            CONTEXT,
            "spp",
            least,
            format!(
                "{pixels} pixels x {least} samples cost at least one event each, above the work \
                 cap of {} events per channel (`max_work`)",
                cfg.max_work
            ),
        ));
    }
    Ok(())
}

/// Renders `scene`. `rd[k]` is object k's total diffuse reflectance per
/// channel (for the G-buffer's irradiance; see [`material_profiles`]).
pub fn render(
    scene: &Scene,
    rd: &[[f64; 3]],
    cfg: &RenderConfig,
    progress: &dyn Progress,
) -> Result<Render> {
    let start = std::time::Instant::now();
    validate(cfg, Some(rd), scene)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Unsupported(format!("cannot start worker threads: {e}")))?;
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let npx = w * h;
    // Twice the farthest corner of the objects: behind everything.
    let far = 2.0 * scene.reach() / scene.unit.mm();
    let g = pool.install(|| gbuffer(scene, rd, far, cfg.gbuffer_side, cfg.seed));
    let channels: Vec<ChannelScene> = (0..3).map(|c| ChannelScene::new(scene, c)).collect();
    let tiles: Vec<(usize, usize)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let mut rounds = Rounds::new(npx, cfg.budget, cfg.max_work);
    let mut round = 0;
    loop {
        let lens = rounds.next_lens();
        let units: Vec<(usize, (usize, usize))> = (0..3)
            .filter(|&c| lens[c] > 0)
            .flat_map(|c| tiles.iter().map(move |&t| (c, t)))
            .collect();
        if units.is_empty() {
            break;
        }
        round += 1;
        let total: u64 = (0..3).map(|c| lens[c] * npx as u64).sum();
        progress.start(total, &format!("{} round {round}", scene.origin));
        let spp = rounds.spp;
        let parts: Vec<TileRound> = pool.install(|| {
            units
                .par_iter()
                .map(|&(c, origin)| {
                    let run = (spp[c], lens[c]);
                    let tile = trace_tile(&channels[c], c, origin, run, cfg.seed, (w, h));
                    progress.advance(tile.values.len() as u64 * lens[c]);
                    tile
                })
                .collect()
        });
        progress.finish();
        rounds.add(parts, (w, h));
        rounds.close(lens, &g.coverage)?;
    }
    let (radiance, stderr) = rounds.estimates();
    Ok(Render {
        width: w,
        height: h,
        radiance,
        stderr,
        gbuffer: g,
        info: RenderInfo {
            schema: RENDER_SCHEMA.into(),
            config: RenderConfigRecord {
                budget: cfg.budget,
                seed: cfg.seed,
                gbuffer_side: cfg.gbuffer_side,
                max_work: cfg.max_work,
            },
            spp: rounds.spp,
            noise: rounds.noise,
            converged: rounds.converged(),
            work_capped: rounds.work_capped,
            events: rounds.events,
            lost: rounds.lost,
            rd: rd.to_vec(),
            far,
            unit: scene.unit,
            seconds: start.elapsed().as_secs_f64(),
        },
    })
}
