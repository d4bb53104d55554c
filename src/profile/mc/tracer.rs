//! The photon packet walk of MCML (Wang, Jacques & Zheng 1995),
//! in f64, through a stack of layers between two ambient media.
//! z points down into the material; the top surface is z = 0.

use super::tally::{AngleLayout, BinIndex, ChunkTally, ExitScratch, ExitSums, PhotonScratch};
use crate::material::{Channel, Material};
use crate::profile::fresnel::{fresnel_dielectric, specular_normal};
use rand_core::RngCore;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Russian roulette threshold and survival chance of MCML (1e-4, 1/10).
pub const ROULETTE_THRESHOLD: f64 = 1e-4;
pub const ROULETTE_CHANCE: f64 = 0.1;
/// The default threshold here. Any threshold is unbiased; a higher one
/// ends the long low-weight tails of walks sooner, which a packet that is
/// still far from the surface rarely turns into reflectance, so the time per
/// photon falls faster than the variance rises. The Speed table of
/// docs/mc.md (`cargo bench --bench mc`, docs/records/mc-speed.json) records
/// both games' photons per second and variances per photon. Thresholds near
/// 0.1 were found to gain near the centre but lose in the far tail.
pub const DEFAULT_ROULETTE_THRESHOLD: f64 = 0.01;

/// Survival chance of the event-count roulette, played each time a packet's
/// event count doubles past the start: 2^-1/2, so that after n events a
/// packet survives with probability ~ (start/n)^1/2 and carries weight
/// ~ (n/start)^1/2.
///
/// Why this exponent: at albedo 1 a packet in a half-space is still walking
/// after n events with probability ~ n^-1/2 (the first-passage law of a
/// recurrent walk), so it exits at n with probability ~ n^-3/2. A survival
/// law Q(n) = (start/n)^a costs sum n^-1/2 Q(n) events per packet (finite for
/// a > 1/2) and adds sum n^-3/2 / Q(n) to the second moment of its weight
/// (finite for a < 1/2). At a = 1/2 both grow only like the logarithm of the
/// longest walk met, i.e. ~ log(photons); any other a makes one of them grow
/// like a power. Geometric roulette (constant survival per event) would give
/// an infinite second moment. The game is unbiased for any schedule.
pub const EVENT_ROULETTE_SURVIVAL: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// Default event count from which the event-count roulette plays.
/// Starting earlier costs fewer events per photon and a higher per-photon
/// variance of R_d; on an albedo-1 half-space (n = 1.3) the two balanced
/// for the total when the default was chosen (no record keeps that
/// comparison), while the profile near the source, made of short walks the
/// roulette never touches, gains from the time saved on long ones.
pub const DEFAULT_EVENT_ROULETTE: u64 = 1_000;

/// What happens where a packet meets the ambient medium.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BoundaryMode {
    /// Score the transmitted part (1 - R) w and continue with R w: same
    /// expectation as MCML, less variance (Wang et al. 1995).
    Split,
    /// MCML 1.2.2: reflect with probability R, else leave with all of w.
    Classic,
}

impl BoundaryMode {
    pub fn name(self) -> &'static str {
        match self {
            BoundaryMode::Split => "split",
            BoundaryMode::Classic => "classic",
        }
    }
}

/// Per-layer constants of one channel, precomputed once.
#[derive(Clone, Debug)]
pub(crate) struct LayerOptics {
    z_top: f64,
    /// +inf for a semi-infinite layer.
    z_bottom: f64,
    sigma_t: f64,
    inv_sigma_t: f64,
    /// sigma_s / sigma_t: the weight kept at each interaction.
    albedo: f64,
    g: f64,
    one_minus_g2: f64,
    one_plus_g2: f64,
    inv_2g: f64,
    /// Absolute refractive index.
    n: f64,
}

/// The layer stack of one channel with its ambient media.
#[derive(Clone, Debug)]
pub(crate) struct Stack {
    layers: Vec<LayerOptics>,
    n_above: f64,
    n_below: f64,
    /// Fresnel reflectance of the beam at entry (normal incidence unless
    /// built by `Stack::oblique`).
    pub specular: f64,
    /// The refracted beam's direction in the first layer, (ux, uz).
    launch: (f64, f64),
}

impl Stack {
    pub fn new(m: &Material, ch: Channel) -> Stack {
        let c = ch.index();
        let mut z = 0.0;
        let layers = m
            .layers
            .iter()
            .map(|l| {
                let z_top = z;
                let z_bottom = l.thickness.map_or(f64::INFINITY, |t| z + t);
                z = z_bottom;
                LayerOptics {
                    z_top,
                    z_bottom,
                    ..LayerOptics::unbounded(l.sigma_a[c], l.sigma_s[c], l.g[c], l.eta)
                }
            })
            .collect();
        Stack {
            layers,
            n_above: m.eta_above,
            n_below: m.eta_below,
            specular: specular_normal(m.eta_above, m.layers[0].eta),
            launch: (0.0, 1.0),
        }
    }

    /// The stack lit by a pencil beam at `theta_in` (radians, from the
    /// normal, in the x-z plane): the unpolarised Fresnel reflectance at
    /// that angle is reported apart and 1 - R enters along the direction
    /// Snell's law gives (MCML's launch, Wang et al. 1995, at any angle).
    pub fn oblique(m: &Material, ch: Channel, theta_in: f64) -> Stack {
        let mut s = Stack::new(m, ch);
        let (sin_i, cos_i) = theta_in.sin_cos();
        let (n_i, n_t) = (s.n_above, s.layers[0].n);
        s.specular = fresnel_dielectric(cos_i, n_t / n_i);
        let sin_t = (sin_i * n_i / n_t).min(1.0);
        s.launch = (sin_t, (1.0 - sin_t * sin_t).max(0.0).sqrt());
        s
    }
}

impl LayerOptics {
    /// The constants of a medium filling all space (also the interior of a
    /// scene's object); `n` is its refractive index.
    pub(crate) fn unbounded(sigma_a: f64, sigma_s: f64, g: f64, n: f64) -> LayerOptics {
        let sigma_t = sigma_a + sigma_s;
        LayerOptics {
            z_top: f64::NEG_INFINITY,
            z_bottom: f64::INFINITY,
            sigma_t,
            inv_sigma_t: 1.0 / sigma_t,
            albedo: sigma_s / sigma_t,
            g,
            one_minus_g2: 1.0 - g * g,
            one_plus_g2: 1.0 + g * g,
            inv_2g: if g.abs() < HG_ISOTROPIC { 0.0 } else { 0.5 / g },
            n,
        }
    }

    pub(crate) fn sigma_t(&self) -> f64 {
        self.sigma_t
    }

    /// sigma_s / sigma_t.
    pub(crate) fn albedo(&self) -> f64 {
        self.albedo
    }

    pub(crate) fn g(&self) -> f64 {
        self.g
    }
}

/// Below this |g| the HG inversion loses precision: sample isotropically.
pub(crate) const HG_ISOTROPIC: f64 = 1e-6;

/// Uniform in [0, 1) with 53 random bits.
#[inline(always)]
fn uniform(rng: &mut Xoshiro256PlusPlus) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// An optical depth -ln(xi), xi uniform in (0, 1] with 53 random bits
/// (Wang et al. 1995), inlined and branch-free (see `neg_ln`).
#[inline(always)]
fn optical_depth(rng: &mut Xoshiro256PlusPlus, t: &LogTable) -> f64 {
    let xi = ((rng.next_u64() >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64);
    neg_ln(xi, t)
}

/// (c, 1/c, ln c) for the 256 intervals of m in [1/2, 2) that the last
/// exponent bit and the top 7 mantissa bits pick (width 1/256 below 1,
/// 1/128 above), c at the centre, except c = 1 on both sides of 1 so that
/// r = m - 1 is exact there and -ln x keeps its relative accuracy near 1.
struct LogTable([(f64, f64, f64); 256]);

impl LogTable {
    fn new() -> LogTable {
        let mut t = [(1.0, 1.0, 0.0); 256];
        for (i, e) in t.iter_mut().enumerate() {
            let j = (i & 127) as f64;
            let c = match i {
                127 | 128 => 1.0,
                0..=126 => 0.5 + (j + 0.5) / 256.0,
                _ => 1.0 + (j + 0.5) / 128.0,
            };
            *e = (c, 1.0 / c, c.ln());
        }
        LogTable(t)
    }
}

/// -ln(x) for normal x in (0, 1]: x = 2^e m with m in [sqrt(1/2),
/// sqrt(2)), ln m = ln c + ln(1 + r) with c from `LogTable`, r = (m - c)/c
/// (m - c exact, |r| < 1/128) and ln(1 + r) summed to r^8 (truncation
/// below 2^-59 relative): as exact as the library log, without its call or
/// a division. The chain from the draw to the step length is what a
/// mispredicted boundary test waits on, so it is kept short: one table
/// load and a depth-4 polynomial.
#[inline(always)]
fn neg_ln(x: f64, t: &LogTable) -> f64 {
    let bits = x.to_bits();
    let mut e = ((bits >> 52) as i64) - 1023;
    let mut mb = (bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000;
    // m in [1, 2); halve it (exponent - 1) where m >= sqrt(2).
    let big = (f64::from_bits(mb) >= std::f64::consts::SQRT_2) as u64;
    mb -= big << 52;
    e += big as i64;
    let m = f64::from_bits(mb);
    let (c, inv_c, ln_c) = t.0[((mb >> 45) & 0xff) as usize];
    let r = (m - c) * inv_c;
    let r2 = r * r;
    // ln(1 + r) = r + r^2 q, q = -1/2 + r/3 - r^2/4 + ... - r^6/8 (Estrin).
    let q = (-0.5 + r * (1.0 / 3.0))
        + r2 * ((-0.25 + r * 0.2) + r2 * ((-1.0 / 6.0 + r * (1.0 / 7.0)) + r2 * -0.125));
    -(e as f64 * std::f64::consts::LN_2 + (ln_c + (r + r2 * q)))
}

/// cos(theta) from the Henyey-Greenstein phase function by inversion
/// (Wang et al. 1995; MCML SpinTheta).
#[inline(always)]
pub(crate) fn sample_hg_cos(l: &LayerOptics, xi: f64) -> f64 {
    if l.inv_2g == 0.0 {
        return 2.0 * xi - 1.0;
    }
    let t = l.one_minus_g2 / (1.0 - l.g + 2.0 * l.g * xi);
    ((l.one_plus_g2 - t * t) * l.inv_2g).clamp(-1.0, 1.0)
}

/// Bits of the azimuth that index `Azimuths`.
const AZ_BITS: u32 = 8;

/// (cos, sin) of 2 pi k / 2^AZ_BITS, k = 0..2^AZ_BITS: built once per chunk
/// (256 library calls for 8192 photons).
struct Azimuths([(f64, f64); 1 << AZ_BITS]);

impl Azimuths {
    fn new() -> Azimuths {
        let mut t = [(1.0, 0.0); 1 << AZ_BITS];
        for (k, e) in t.iter_mut().enumerate() {
            let (s, c) = (std::f64::consts::TAU * k as f64 / (1 << AZ_BITS) as f64).sin_cos();
            *e = (c, s);
        }
        Azimuths(t)
    }

    /// (cos phi, sin phi) for phi = 2 pi a / 2^32: the table's angle for the
    /// top AZ_BITS bits rotated by the rest, delta < 2 pi / 256, through
    /// Taylor series to delta^6 and delta^7 (truncation < 1e-17). No branch
    /// and no rejection loop, whose mispredicted exit (on 1 - pi/4 = 21% of
    /// draws) cost more than the arithmetic.
    #[inline(always)]
    fn cos_sin(&self, a: u32) -> (f64, f64) {
        const STEP: f64 = std::f64::consts::TAU / 4_294_967_296.0;
        let (c0, s0) = self.0[(a >> (32 - AZ_BITS)) as usize];
        let d = (a & ((1 << (32 - AZ_BITS)) - 1)) as f64 * STEP;
        let d2 = d * d;
        let cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)));
        let sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))));
        (c0 * cd - s0 * sd, s0 * cd + c0 * sd)
    }
}

/// (cos phi, sin phi) for phi uniform in [0, 2 pi), 32 random bits.
#[inline(always)]
fn sample_azimuth(rng: &mut Xoshiro256PlusPlus, az: &Azimuths) -> (f64, f64) {
    az.cos_sin(rng.next_u64() as u32)
}

/// A direction uniform on the unit sphere from one 64-bit draw: cos(theta)
/// uniform in (-1, 1) (Archimedes' hat-box theorem) from 32 bits, the
/// azimuth from the other 32; one square root, no rejection.
#[inline(always)]
fn sample_sphere(rng: &mut Xoshiro256PlusPlus, az: &Azimuths) -> (f64, f64, f64) {
    const INV32: f64 = 1.0 / 4_294_967_296.0;
    let r = rng.next_u64();
    let uz = 1.0 - 2.0 * ((r >> 32) as f64 + 0.5) * INV32;
    let (cp, sp) = az.cos_sin(r as u32);
    let st = ((1.0 - uz) * (1.0 + uz)).sqrt();
    (st * cp, st * sp, uz)
}

/// Lookup tables of the walk, built once per chunk.
struct Tables {
    az: Azimuths,
    log: LogTable,
}

/// A photon packet.
struct Packet {
    x: f64,
    y: f64,
    z: f64,
    ux: f64,
    uy: f64,
    uz: f64,
    w: f64,
    layer: usize,
    scatters: u32,
}

impl Packet {
    /// Rotates the direction by polar cosine `cos_t` and azimuth `phi`
    /// (MCML Spin, eq. 3.24-3.26 of the MCML manual).
    /// `(cp, sp)` is (cos phi, sin phi) of the azimuth.
    #[inline(always)]
    fn spin(&mut self, cos_t: f64, (cp, sp): (f64, f64)) {
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        if self.uz.abs() > 1.0 - 1e-12 {
            self.ux = sin_t * cp;
            self.uy = sin_t * sp;
            self.uz = cos_t * self.uz.signum();
        } else {
            let tmp = (1.0 - self.uz * self.uz).sqrt();
            let k = sin_t / tmp;
            let ux = k * (self.ux * self.uz * cp - self.uy * sp) + self.ux * cos_t;
            let uy = k * (self.uy * self.uz * cp + self.ux * sp) + self.uy * cos_t;
            self.uz = -sin_t * cp * tmp + self.uz * cos_t;
            self.ux = ux;
            self.uy = uy;
        }
    }
}

/// Per-run settings of the walk.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WalkSettings {
    pub mode: BoundaryMode,
    /// Interactions plus boundary hits from which the event-count roulette
    /// plays (see `EVENT_ROULETTE_SURVIVAL`): unbiased, and it bounds the
    /// unbounded walks of albedo 1.
    pub event_roulette: u64,
    /// Hard cap on events per packet (u64::MAX: none); the weight of a packet
    /// stopped there is booked as truncated (biased, reported).
    pub max_events: u64,
    pub single_scatter: bool,
    /// Weight below which Russian roulette plays (MCML: ROULETTE_THRESHOLD).
    pub roulette_threshold: f64,
    /// Events the chunk may spend (u64::MAX: no bound): the packet that
    /// crosses it is abandoned and the chunk's tally then holds more events
    /// than this, which marks it unfinished (`Job::trace` discards it).
    pub chunk_events: u64,
    /// Tally exits by angle too (None: the default walk, without the code).
    pub angular: Option<AngleLayout>,
}

/// Where a packet goes at a boundary.
enum Neighbour {
    Ambient { n: f64, top: bool },
    Layer(usize),
}

/// Russian roulette: the packet survives with probability `chance` and
/// weight w / chance, else dies (unbiased); gains and losses are booked so
/// that the energy balance closes exactly.
#[inline(always)]
fn roulette(w: &mut f64, chance: f64, rng: &mut Xoshiro256PlusPlus, tally: &mut ChunkTally) {
    if uniform(rng) < chance {
        tally.roulette_gain += *w * (1.0 / chance - 1.0);
        *w *= 1.0 / chance;
    } else {
        tally.roulette_loss += *w;
        *w = 0.0;
    }
}

/// Traces `photons` packets, scoring into `tally`.
pub(crate) fn trace_photons(
    stack: &Stack,
    bins: &BinIndex,
    set: &WalkSettings,
    rng: &mut Xoshiro256PlusPlus,
    photons: u64,
    tally: &mut ChunkTally,
    scratch: &mut PhotonScratch,
) {
    // A local copy of the generator state stays in registers across the walk
    // (through `&mut` it was stored to memory after every draw).
    let mut local = rng.clone();
    let tables = Tables {
        az: Azimuths::new(),
        log: LogTable::new(),
    };
    // The angular tally is a separate instance of the walk, so that the
    // default one carries none of its code.
    match set.angular {
        None => {
            let none = AngleLayout {
                angle_bins: 0,
                radial: 0,
            };
            for _ in 0..photons {
                trace_one::<false>(stack, bins, set, &mut local, &tables, tally, scratch, none);
            }
        }
        Some(l) => {
            if tally.exit.a.sum.len() != l.angle_bins
                || tally.exit.ra.sum.len() != l.radial * l.angle_bins
            {
                tally.exit = ExitSums::new(l);
                scratch.exit = ExitScratch::new(l);
            }
            for _ in 0..photons {
                trace_one::<true>(stack, bins, set, &mut local, &tables, tally, scratch, l);
            }
        }
    }
    *rng = local;
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn trace_one<const ANGULAR: bool>(
    stack: &Stack,
    bins: &BinIndex,
    set: &WalkSettings,
    rng: &mut Xoshiro256PlusPlus,
    tables: &Tables,
    tally: &mut ChunkTally,
    scratch: &mut PhotonScratch,
    angles: AngleLayout,
) {
    if tally.events > set.chunk_events {
        return;
    }
    // Events this packet may make: the hard cap, or one more than the
    // chunk has left (crossing the budget marks the chunk).
    let stop_at = set
        .max_events
        .min((set.chunk_events - tally.events).saturating_add(1));
    tally.photons += 1;
    tally.specular += stack.specular;
    let mut p = Packet {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        ux: stack.launch.0,
        uy: 0.0,
        uz: stack.launch.1,
        w: 1.0 - stack.specular,
        layer: 0,
        scatters: 0,
    };
    // Per-packet totals, added with their squares at the end (second moments).
    let mut rd = 0.0;
    let mut tr = 0.0;
    let mut absorbed = 0.0;
    // Remaining optical depth of the current free flight, carried across
    // interfaces as MCML's `sleft`.
    let mut tau = 0.0;
    let mut need_step = true;
    let mut events: u64 = 0;
    let mut next_event_roulette = set.event_roulette;
    while p.w > 0.0 {
        if need_step {
            // s = -ln(xi) / sigma_t (Wang et al. 1995).
            tau = optical_depth(rng, &tables.log);
            need_step = false;
        }
        let l = &stack.layers[p.layer];
        let s = tau * l.inv_sigma_t;
        let z_new = p.z + s * p.uz;
        // The division for the distance to the boundary only when it is hit.
        // Non-short-circuit tests: the sign of uz is a coin toss per event
        // in a scattering medium, a branch on it mispredicted half the time.
        let hits_bottom = (p.uz > 0.0) & (z_new >= l.z_bottom);
        let hits_top = (p.uz < 0.0) & (z_new <= l.z_top);
        if hits_bottom | hits_top {
            let z_b = if hits_bottom { l.z_bottom } else { l.z_top };
            let d_b = ((z_b - p.z) / p.uz).min(s);
            p.x += d_b * p.ux;
            p.y += d_b * p.uy;
            p.z = z_b;
            tau = (tau - d_b * l.sigma_t).max(0.0);
            if tau == 0.0 {
                need_step = true;
            }
            let to = if p.uz > 0.0 {
                if p.layer + 1 < stack.layers.len() {
                    Neighbour::Layer(p.layer + 1)
                } else {
                    Neighbour::Ambient {
                        n: stack.n_below,
                        top: false,
                    }
                }
            } else if p.layer > 0 {
                Neighbour::Layer(p.layer - 1)
            } else {
                Neighbour::Ambient {
                    n: stack.n_above,
                    top: true,
                }
            };
            let n_i = l.n;
            let cos_i = p.uz.abs();
            match to {
                Neighbour::Ambient { n, top } => {
                    let r = fresnel_dielectric(cos_i, n / n_i);
                    let escaping = match set.mode {
                        BoundaryMode::Split => (1.0 - r) * p.w,
                        BoundaryMode::Classic => {
                            if r > 0.0 && uniform(rng) < r {
                                0.0
                            } else {
                                p.w
                            }
                        }
                    };
                    if escaping > 0.0 {
                        if top {
                            rd += escaping;
                            let radius = (p.x * p.x + p.y * p.y).sqrt();
                            scratch.score_reflectance(bins, radius, escaping, p.scatters);
                            if ANGULAR {
                                // Snell's law gives the exit direction in the
                                // ambient medium, which MCML bins (RecordR).
                                let k = n_i / n;
                                let cos_out = (1.0 - (1.0 - cos_i * cos_i) * k * k).max(0.0).sqrt();
                                let ir = bins.bin(radius).unwrap_or(bins.len());
                                scratch
                                    .exit
                                    .score(angles, ir, angles.angle_bin(cos_out), escaping);
                            }
                        } else {
                            tr += escaping;
                        }
                        // Leaves R w (split) or 0 (classic; split with R = 0).
                        p.w -= escaping;
                    }
                    p.uz = -p.uz;
                }
                Neighbour::Layer(j) => {
                    let n_t = stack.layers[j].n;
                    let eta = n_t / n_i;
                    let r = fresnel_dielectric(cos_i, eta);
                    if r > 0.0 && (r >= 1.0 || uniform(rng) < r) {
                        p.uz = -p.uz;
                    } else {
                        // Snell: the tangential component scales by n_i / n_t.
                        let k = n_i / n_t;
                        let sin2_t = (1.0 - cos_i * cos_i) * k * k;
                        let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
                        p.ux *= k;
                        p.uy *= k;
                        p.uz = cos_t * p.uz.signum();
                        p.layer = j;
                    }
                }
            }
        } else {
            p.x += s * p.ux;
            p.y += s * p.uy;
            p.z = z_new;
            // Implicit absorption: deposit w sigma_a / sigma_t (Wang et al. 1995).
            let kept = p.w * l.albedo;
            absorbed += p.w - kept;
            p.w = kept;
            // The next free flight's optical depth before the new direction:
            // the log's latency then overlaps the direction sampling, and a
            // mispredicted rejection there no longer discards it.
            tau = optical_depth(rng, &tables.log);
            need_step = false;
            if l.inv_2g == 0.0 {
                // Isotropic: the new direction does not depend on the old.
                (p.ux, p.uy, p.uz) = sample_sphere(rng, &tables.az);
            } else {
                let cos_t = sample_hg_cos(l, uniform(rng));
                p.spin(cos_t, sample_azimuth(rng, &tables.az));
            }
            p.scatters = p.scatters.saturating_add(1);
        }
        events += 1;
        if p.w < set.roulette_threshold && p.w > 0.0 {
            // Wang et al. 1995.
            roulette(&mut p.w, ROULETTE_CHANCE, rng, tally);
        }
        if events >= next_event_roulette && p.w > 0.0 {
            next_event_roulette = next_event_roulette.saturating_mul(2);
            roulette(&mut p.w, EVENT_ROULETTE_SURVIVAL, rng, tally);
        }
        if events >= stop_at && p.w > 0.0 {
            if events >= set.max_events {
                tally.truncated += p.w;
                tally.truncated_photons += 1;
            }
            p.w = 0.0;
        }
    }
    tally.events += events;
    tally.rd.add(rd);
    tally.transmittance.add(tr);
    tally.absorbed.add(absorbed);
    scratch.flush(tally, set.single_scatter);
    if ANGULAR {
        scratch.exit.flush(&mut tally.exit, rd);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layer(g: f64) -> LayerOptics {
        LayerOptics {
            z_top: 0.0,
            z_bottom: f64::INFINITY,
            sigma_t: 1.0,
            inv_sigma_t: 1.0,
            albedo: 0.5,
            g,
            one_minus_g2: 1.0 - g * g,
            one_plus_g2: 1.0 + g * g,
            inv_2g: if g.abs() < HG_ISOTROPIC { 0.0 } else { 0.5 / g },
            n: 1.0,
        }
    }

    #[test]
    fn hg_sampling_has_mean_cosine_g() {
        // <cos theta> of Henyey-Greenstein is g; midpoint rule over xi.
        for g in [-0.99, -0.5, 0.0, 0.3, 0.9, 0.99] {
            let l = layer(g);
            let n = 200_000;
            let mean: f64 = (0..n)
                .map(|i| sample_hg_cos(&l, (i as f64 + 0.5) / n as f64))
                .sum::<f64>()
                / n as f64;
            assert!((mean - g).abs() < 2e-3, "g = {g}: mean cos {mean}");
            assert!(sample_hg_cos(&l, 0.0).abs() <= 1.0);
            assert!(sample_hg_cos(&l, 1.0 - 1e-16).abs() <= 1.0);
        }
    }

    #[test]
    fn fast_log_matches_the_library() {
        use rand_core::SeedableRng;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
        let t = LogTable::new();
        let mut worst: f64 = 0.0;
        for k in 0..200_000u64 {
            let x = if k < 1000 {
                // Edges: 1, just below 1, sqrt(1/2), tiny.
                [
                    1.0,
                    1.0 - f64::EPSILON / 2.0,
                    std::f64::consts::FRAC_1_SQRT_2,
                    2f64.powi(-53),
                ][(k % 4) as usize]
            } else {
                ((rng.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (neg_ln(x, &t), -x.ln());
            worst = worst.max((a - b).abs() / b.abs().max(1e-300));
            assert!(
                a >= 0.0 && (a - b).abs() <= 4.0 * f64::EPSILON * b.abs().max(1e-16),
                "{x}: {a} vs {b}"
            );
        }
        assert!(worst < 1e-14, "{worst}");
        assert_eq!(neg_ln(1.0, &t), 0.0);
    }

    #[test]
    fn azimuth_table_matches_the_library() {
        use rand_core::SeedableRng;
        let az = Azimuths::new();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let edges = [0u32, 1, (1 << 24) - 1, 1 << 24, u32::MAX, 1 << 31, 3 << 30];
        for k in 0..100_000usize {
            let a = edges.get(k).copied().unwrap_or(rng.next_u64() as u32);
            let (c, s) = az.cos_sin(a);
            // The reference's angle is itself rounded, by up to half an ulp
            // of 2 pi (4.4e-16): the bound allows that plus a few ulps.
            let (s_ref, c_ref) = (std::f64::consts::TAU * a as f64 / 4_294_967_296.0).sin_cos();
            assert!(
                (c - c_ref).abs() < 1.5e-15 && (s - s_ref).abs() < 1.5e-15,
                "{a}: ({c}, {s}) vs ({c_ref}, {s_ref})"
            );
            assert!((c * c + s * s - 1.0).abs() < 1e-15, "{a}");
        }
    }

    #[test]
    fn azimuth_is_uniform() {
        use rand_core::SeedableRng;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let az = Azimuths::new();
        let n = 200_000;
        let (mut c, mut s, mut c2, mut q1) = (0.0, 0.0, 0.0, 0);
        for _ in 0..n {
            let (cp, sp) = sample_azimuth(&mut rng, &az);
            assert!((cp * cp + sp * sp - 1.0).abs() < 1e-12);
            c += cp;
            s += sp;
            c2 += cp * cp;
            q1 += (cp > 0.0 && sp > 0.0) as usize;
        }
        let nf = n as f64;
        // Means 0, <cos^2> = 1/2, a quarter in each quadrant; 5 sigma bounds.
        assert!((c / nf).abs() < 5.0 * (0.5 / nf).sqrt());
        assert!((s / nf).abs() < 5.0 * (0.5 / nf).sqrt());
        assert!((c2 / nf - 0.5).abs() < 5.0 * (0.125 / nf).sqrt());
        assert!((q1 as f64 / nf - 0.25).abs() < 5.0 * (0.1875 / nf).sqrt());
    }

    #[test]
    fn sphere_directions_are_isotropic() {
        use rand_core::SeedableRng;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let az = Azimuths::new();
        let n = 200_000;
        let (mut mz, mut mz2, mut mx) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let (x, y, z) = sample_sphere(&mut rng, &az);
            assert!((x * x + y * y + z * z - 1.0).abs() < 1e-12);
            mz += z;
            mz2 += z * z;
            mx += x;
        }
        let nf = n as f64;
        // Uniform cos: mean 0, <z^2> = 1/3 (var of z^2 is 4/45); 5 sigma.
        assert!((mz / nf).abs() < 5.0 * (1.0 / 3.0 / nf).sqrt());
        assert!((mx / nf).abs() < 5.0 * (1.0 / 3.0 / nf).sqrt());
        assert!((mz2 / nf - 1.0 / 3.0).abs() < 5.0 * (4.0 / 45.0 / nf).sqrt());
    }

    /// A chunk's event budget bounds the walk itself: the packet that
    /// crosses it is abandoned there, and the chunk's tally says so by
    /// holding exactly one event more than the budget.
    #[test]
    fn the_chunk_budget_stops_the_walk() {
        use rand_core::SeedableRng;
        let m = crate::material::Material {
            name: "lossless".into(),
            eta_above: 1.0,
            eta_below: 1.0,
            layers: vec![crate::material::Layer {
                sigma_a: [0.0; 3],
                sigma_s: [1.0; 3],
                g: [0.9; 3],
                eta: 1.3,
                thickness: None,
            }],
        };
        let stack = Stack::new(&m, Channel::R);
        let grid = crate::profile::RadialGrid::uniform(0.1, 10.0).unwrap();
        let bins = BinIndex::new(&grid);
        let mut set = WalkSettings {
            mode: BoundaryMode::Classic,
            event_roulette: DEFAULT_EVENT_ROULETTE,
            max_events: u64::MAX,
            single_scatter: false,
            roulette_threshold: DEFAULT_ROULETTE_THRESHOLD,
            chunk_events: u64::MAX,
            angular: None,
        };
        let run = |set: &WalkSettings| {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
            let mut t = ChunkTally::new(bins.len(), false);
            let mut s = PhotonScratch::new(bins.len(), false);
            trace_photons(&stack, &bins, set, &mut rng, 200, &mut t, &mut s);
            t
        };
        let free = run(&set);
        assert_eq!(free.photons, 200);
        assert!(free.events > 20_000, "{} events", free.events);
        set.chunk_events = 5_000;
        let bounded = run(&set);
        assert_eq!(bounded.events, 5_001);
        assert!(bounded.photons < 200);
        // A budget the chunk fits in changes nothing.
        set.chunk_events = free.events;
        let fits = run(&set);
        assert_eq!((fits.events, fits.photons), (free.events, 200));
        assert_eq!(fits.rd, free.rd);
    }

    #[test]
    fn spin_keeps_unit_length() {
        let mut p = Packet {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            ux: 0.0,
            uy: 0.0,
            uz: 1.0,
            w: 1.0,
            layer: 0,
            scatters: 0,
        };
        for k in 0..1000 {
            let c = ((k * 37) % 200) as f64 / 100.0 - 1.0;
            p.spin(c, (k as f64 * 0.7).sin_cos());
            let norm = p.ux * p.ux + p.uy * p.uy + p.uz * p.uz;
            assert!((norm - 1.0).abs() < 1e-12, "{norm}");
        }
    }
}
