//! Rendering: the G-buffer, then rounds of samples per pixel and channel
//! until the budget's rule holds, rayon over tiles of pixels.

use super::gbuffer::{gbuffer, GBuffer};
use super::trace::ChannelScene;
use super::Scene;
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::mc::{self, splitmix64, McConfig, PhotonBudget};
use crate::profile::Profile;
use crate::progress::Progress;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
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
/// Samples per pixel of the first round.
pub const FIRST_ROUND_SPP: u64 = 16;
/// Tile side in pixels (one rayon task per tile and channel).
const TILE: usize = 16;
/// Context of the render settings' errors.
const CONTEXT: &str = "scene render";

/// How many samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleBudget {
    /// Exactly this many per pixel and channel.
    Fixed(u64),
    /// Until the image's noise is below `rel` in every channel, or
    /// `max_spp`: noise = RMS over the pixels that see an object of the
    /// radiance's standard error, divided by the 99th percentile of their
    /// radiance (a robust peak).
    TargetError { rel: f64, max_spp: u64 },
}

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

/// The key of the stream of sample `s` of pixel `p` in stream family `c`
/// (0-2 the channels, 3 the G-buffer): a function of these only.
pub(crate) fn sample_key(seed: u64, c: u64, p: u64, s: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(splitmix64(seed) ^ (c + 1)) ^ p) ^ s)
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
    match cfg.budget {
        SampleBudget::Fixed(0) => return Err(Error::invalid(CONTEXT, "spp", 0, "must be >= 1")),
        SampleBudget::TargetError { rel, max_spp } => {
            if !(rel > 0.0 && rel < 1.0) {
                return Err(Error::invalid(
                    CONTEXT,
                    "target_error",
                    rel,
                    "must be in (0, 1), e.g. 0.01",
                ));
            }
            if max_spp == 0 {
                return Err(Error::invalid(CONTEXT, "max_spp", 0, "must be >= 1"));
            }
        }
        _ => {}
    }
    if let Some(n) = cfg.threads {
        crate::limits::check_threads("worker threads", n)?;
    }
    if !(1..=16).contains(&cfg.gbuffer_side) {
        return Err(Error::invalid(
            CONTEXT,
            "gbuffer_side",
            cfg.gbuffer_side,
            "must be in 1..=16 (positions per pixel side)",
        ));
    }
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

/// Per channel, per pixel: sums of the samples and of their squares.
struct Sums {
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

/// The noise of the target-error rule for one channel after `n` samples.
/// One round's work on a tile: channel, tile origin, per-pixel (sum,
/// sum of squares), events and lost paths.
type TileRound = (usize, (usize, usize), Vec<(f64, f64)>, u64, u64);

fn noise(s: &Sums, n: u64, coverage: &[f64]) -> f64 {
    let nf = n as f64;
    let seen: Vec<usize> = (0..coverage.len()).filter(|&i| coverage[i] > 0.0).collect();
    let pixels: Vec<usize> = if seen.is_empty() {
        (0..coverage.len()).collect()
    } else {
        seen
    };
    let mut means: Vec<f64> = pixels.iter().map(|&i| s.sum[i] / nf).collect();
    let var: f64 = pixels
        .iter()
        .map(|&i| {
            let m = s.sum[i] / nf;
            if n < 2 {
                return f64::INFINITY;
            }
            ((s.sum_sq[i] / nf - m * m).max(0.0) / (nf - 1.0)).max(0.0)
        })
        .sum::<f64>()
        / pixels.len() as f64;
    means.sort_by(f64::total_cmp);
    let peak = means[((0.99 * means.len() as f64).ceil() as usize).clamp(1, means.len()) - 1];
    if !(peak > 0.0) {
        // A black image is exact once its samples say so.
        return if var == 0.0 { 0.0 } else { f64::INFINITY };
    }
    var.sqrt() / peak
}

/// Samples per pixel of the next round, from the totals only: the first
/// round, then what error ~ N^-1/2 predicts is missing (plus 10%), at
/// least one and at most as many as done (a fixed budget doubles).
fn round_len(done: u64, ratio: f64, left: u64) -> u64 {
    let n = if done == 0 {
        FIRST_ROUND_SPP
    } else if !ratio.is_finite() {
        done
    } else {
        ((done as f64 * (1.1 * ratio * ratio - 1.0)).ceil().max(1.0) as u64).min(done)
    };
    n.min(left)
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
    let mut sums: Vec<Sums> = (0..3)
        .map(|_| Sums {
            sum: vec![0.0; npx],
            sum_sq: vec![0.0; npx],
        })
        .collect();
    let (max_spp, target) = match cfg.budget {
        SampleBudget::Fixed(n) => (n, None),
        SampleBudget::TargetError { rel, max_spp } => (max_spp, Some(rel)),
    };
    let tiles: Vec<(usize, usize)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let mut spp = [0u64; 3];
    let mut events = [0u64; 3];
    let mut lost = [0u64; 3];
    let mut ratio = [f64::INFINITY; 3];
    let mut active = [true; 3];
    let mut noise_now = [f64::INFINITY; 3];
    let mut work_capped = false;
    let mut round = 0;
    loop {
        let mut lens = [0u64; 3];
        for c in 0..3 {
            if active[c] {
                lens[c] = round_len(spp[c], ratio[c], max_spp - spp[c]);
            }
        }
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
        let parts: Vec<TileRound> = pool.install(|| {
            units
                .par_iter()
                .map(|&(c, (x0, y0))| {
                    let cs = &channels[c];
                    let mut out = Vec::with_capacity(TILE * TILE);
                    let (mut ev, mut lo) = (0u64, 0u64);
                    for y in y0..(y0 + TILE).min(h) {
                        for x in x0..(x0 + TILE).min(w) {
                            let p = (y * w + x) as u64;
                            let (mut s, mut s2) = (0.0, 0.0);
                            for k in spp[c]..spp[c] + lens[c] {
                                let mut rng = Xoshiro256PlusPlus::seed_from_u64(sample_key(
                                    cfg.seed, c as u64, p, k,
                                ));
                                let (v, st) = cs.sample(x, y, &mut rng);
                                s += v;
                                s2 += v * v;
                                ev += st.events;
                                lo += st.lost as u64;
                            }
                            out.push((s, s2));
                        }
                    }
                    progress.advance(out.len() as u64 * lens[c]);
                    (c, (x0, y0), out, ev, lo)
                })
                .collect()
        });
        progress.finish();
        for (c, (x0, y0), vals, ev, lo) in parts {
            let mut it = vals.into_iter();
            for y in y0..(y0 + TILE).min(h) {
                for x in x0..(x0 + TILE).min(w) {
                    if let Some((s, s2)) = it.next() {
                        sums[c].sum[y * w + x] += s;
                        sums[c].sum_sq[y * w + x] += s2;
                    }
                }
            }
            events[c] += ev;
            lost[c] += lo;
        }
        for c in 0..3 {
            if lens[c] == 0 {
                continue;
            }
            let first = spp[c] == 0;
            spp[c] += lens[c];
            noise_now[c] = noise(&sums[c], spp[c], &g.coverage);
            match target {
                Some(rel) => {
                    ratio[c] = noise_now[c] / rel;
                    if noise_now[c] <= rel || spp[c] >= max_spp {
                        active[c] = false;
                    } else if events[c] >= cfg.max_work {
                        active[c] = false;
                        work_capped = true;
                    }
                }
                None => {
                    if first && spp[c] < max_spp {
                        let projected = events[c] as f64 / spp[c] as f64 * max_spp as f64;
                        if projected > cfg.max_work as f64 {
                            return Err(Error::invalid(
                                CONTEXT,
                                "spp",
                                max_spp,
                                format!(
                                    "channel {}: the first {} samples per pixel took {} events: \
                                     {max_spp} would take about {projected:.2e}, above the work \
                                     cap of {} events per channel (`max_work`)",
                                    Channel::ALL[c].name(),
                                    spp[c],
                                    events[c],
                                    cfg.max_work
                                ),
                            ));
                        }
                    }
                    if spp[c] >= max_spp {
                        active[c] = false;
                    } else if events[c] >= cfg.max_work {
                        active[c] = false;
                        work_capped = true;
                    }
                }
            }
        }
    }
    let mut radiance: [Vec<f64>; 3] = Default::default();
    let mut stderr: [Vec<f64>; 3] = Default::default();
    for c in 0..3 {
        let n = spp[c] as f64;
        radiance[c] = sums[c].sum.iter().map(|s| s / n).collect();
        stderr[c] = sums[c]
            .sum
            .iter()
            .zip(&sums[c].sum_sq)
            .map(|(s, s2)| {
                if spp[c] < 2 {
                    return 0.0;
                }
                let m = s / n;
                ((s2 / n - m * m).max(0.0) / (n - 1.0)).sqrt()
            })
            .collect();
    }
    let converged = match target {
        Some(rel) => noise_now.iter().all(|&e| e <= rel),
        None => spp.iter().all(|&n| n == max_spp),
    };
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
            spp,
            noise: noise_now,
            converged,
            work_capped,
            events,
            lost,
            rd: rd.to_vec(),
            far,
            unit: scene.unit,
            seconds: start.elapsed().as_secs_f64(),
        },
    })
}
