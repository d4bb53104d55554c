//! The photon packet walk of MCML (Wang, Jacques & Zheng 1995),
//! in f64, through a stack of layers between two ambient media.
//! z points down into the material; the top surface is z = 0.

use super::tally::{AngleLayout, BinIndex, ChunkTally, ExitScratch, ExitSums, PhotonScratch};
use crate::material::{Channel, Material};
use crate::profile::fresnel::{fresnel_dielectric, specular_normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use sampling::{optical_depth, sample_azimuth, sample_sphere, Azimuths, LogTable, Tables};
pub(crate) use sampling::{sample_hg_cos, uniform};

mod boundary;
mod sampling;
use boundary::{meet_ambient, meet_layer, Neighbour};

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

    /// Whether light can leave through the bottom (the last layer is finite).
    pub fn finite(&self) -> bool {
        self.layers.last().is_some_and(|l| l.z_bottom.is_finite())
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
    /// A packet entering the stack: weight 1 - R_specular along the
    /// refracted beam.
    #[inline(always)]
    fn launch(stack: &Stack) -> Packet {
        Packet {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            ux: stack.launch.0,
            uy: 0.0,
            uz: stack.launch.1,
            w: 1.0 - stack.specular,
            layer: 0,
            scatters: 0,
        }
    }

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
    if stack.finite() {
        scratch.transmitting(tally, bins.len(), set.angular);
    }
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

/// What a packet scores over its walk, added with their squares at the end
/// (second moments).
#[derive(Default)]
struct PacketScores {
    rd: f64,
    /// The part of `rd` that left ahead of the entry point along the plane
    /// of incidence (x > 0, where an oblique beam runs).
    rd_ahead: f64,
    tr: f64,
    absorbed: f64,
}

/// The per-chunk inputs of the walk that every step reads.
struct Walk<'a> {
    stack: &'a Stack,
    bins: &'a BinIndex,
    set: &'a WalkSettings,
    tables: &'a Tables,
    angles: AngleLayout,
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
    let walk = Walk {
        stack,
        bins,
        set,
        tables,
        angles,
    };
    // Events this packet may make: the hard cap, or one more than the
    // chunk has left (crossing the budget marks the chunk).
    let stop_at = set
        .max_events
        .min((set.chunk_events - tally.events).saturating_add(1));
    tally.photons += 1;
    tally.specular += stack.specular;
    let mut p = Packet::launch(stack);
    let mut scores = PacketScores::default();
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
        }
        need_step = step::<ANGULAR>(&walk, &mut p, &mut tau, rng, &mut scores, scratch);
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
    tally.rd.add(scores.rd);
    tally.rd_ahead.add(scores.rd_ahead);
    tally.rd_ahead_cross += scores.rd * scores.rd_ahead;
    tally.transmittance.add(scores.tr);
    tally.absorbed.add(scores.absorbed);
    scratch.flush(tally, set.single_scatter);
    if ANGULAR {
        scratch.exit.flush(&mut tally.exit, scores.rd);
        if !tally.tr_exit.is_empty() {
            scratch.tr_exit.flush(&mut tally.tr_exit, scores.tr);
        }
    }
}

/// One event of the walk: the free flight of optical depth `tau` ends at
/// the layer's boundary (moved there, `tau` reduced by the depth spent) or
/// at an interaction (`tau` then the next flight's). True when the next
/// event needs a new optical depth.
#[inline(always)]
fn step<const ANGULAR: bool>(
    walk: &Walk,
    p: &mut Packet,
    tau: &mut f64,
    rng: &mut Xoshiro256PlusPlus,
    scores: &mut PacketScores,
    scratch: &mut PhotonScratch,
) -> bool {
    let l = &walk.stack.layers[p.layer];
    let s = *tau * l.inv_sigma_t;
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
        *tau = (*tau - d_b * l.sigma_t).max(0.0);
        match walk.stack.neighbour(p.layer, p.uz > 0.0) {
            Neighbour::Ambient { n, top } => {
                meet_ambient::<ANGULAR>(walk, p, l.n, n, top, rng, scores, scratch)
            }
            Neighbour::Layer(j) => meet_layer(walk.stack, p, l.n, j, rng),
        }
        *tau == 0.0
    } else {
        p.x += s * p.ux;
        p.y += s * p.uy;
        p.z = z_new;
        *tau = interact(walk.tables, l, p, rng, &mut scores.absorbed);
        false
    }
}

/// An interaction in layer `l`: implicit absorption deposits w sigma_a /
/// sigma_t into `absorbed` (Wang et al. 1995), then the packet scatters.
/// Returns the next free flight's optical depth.
#[inline(always)]
fn interact(
    tables: &Tables,
    l: &LayerOptics,
    p: &mut Packet,
    rng: &mut Xoshiro256PlusPlus,
    absorbed: &mut f64,
) -> f64 {
    let kept = p.w * l.albedo;
    *absorbed += p.w - kept;
    p.w = kept;
    // The next free flight's optical depth before the new direction:
    // the log's latency then overlaps the direction sampling, and a
    // mispredicted rejection there no longer discards it.
    let tau = optical_depth(rng, &tables.log);
    if l.inv_2g == 0.0 {
        // Isotropic: the new direction does not depend on the old.
        (p.ux, p.uy, p.uz) = sample_sphere(rng, &tables.az);
    } else {
        let cos_t = sample_hg_cos(l, uniform(rng));
        p.spin(cos_t, sample_azimuth(rng, &tables.az));
    }
    p.scatters = p.scatters.saturating_add(1);
    tau
}

#[cfg(test)]
mod tests {
    use super::*;

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
