//! Blender's Principled BSDF with Cycles' Random Walk subsurface: the
//! node's values fitted to a profile through the walk of `cycles_walk`,
//! printed, read back and scored.
//!
//! The fit, per channel, from a tabulated unit walk (`walk_table`): the
//! Base Color (through Cycles' remap to the walk's alpha) that reflects
//! the profile's total, and the extinction that fits r R_d(r) over the
//! radius holding 99% of the profile for it (the norm of the Burley fits);
//! or, shape first, both by least squares. One walk in a medium of unit
//! extinction serves every extinction and, for g = 0, every alpha (each
//! exit weighted by alpha^n). For g > 0 the paths after the ninth
//! scattering depend on alpha (the similarity medium): a first walk at the
//! alpha of the profile's mean reflectance gives each channel a colour,
//! and each channel is fitted again from a walk at that colour's alpha.
//! The printed values' profile comes from the walks' exits (for g > 0 a
//! walk per channel at its printed alpha; `walk_profile`).

use super::blender::{scale_and_radius, scene_lines, subsurface_rows};
use super::cycles_walk::{self, UnitWalk, ANISOTROPY_RANGE};
use super::model::{check, check_scene, error};
use super::printed::{printed, triple, typed, Printed};
use super::priority::Priority;
use super::walk_profile::{channels, rendered, METHOD, SEED};
use super::walk_table::{fit_channel, Table};
use super::{EngineFit, FitError, OtherFit, Scene};
use crate::error::{Error, Result};
use crate::numerics::Bounded;
use crate::profile::Profile;
use crate::progress::{NoProgress, Progress};
use serde_json::{json, Map, Value};
use std::f64::consts::PI;

/// Walks of the printed values' profile: the claim's edge response then
/// scatters by about 0.05% of the step (binomial, 1 / sqrt(4 N) at most),
/// a quarter of the lowest render noise recorded in
/// docs/records/engine-cycles.json.
pub const WALKS: usize = 1 << 22;
/// For g > 0, each walk the fit reads its values from has this share of
/// the walks: the fit's table only chooses the values; their error comes
/// from the full walks at the printed alphas.
const FIT_SHARE: usize = 4;
/// The fewest walks of a fit's table (one chunk of `cycles_walk`).
const MIN_FIT_WALKS: usize = 1 << 15;
/// For g > 0 a channel is refitted from a walk at its new colour's alpha
/// until the colour moves by less than this, relative: four times the 4
/// printed digits' rounding (5e-4), so the last table's paths are those of
/// the printed alpha to within what printing moves it.
const REFIT_TOL: f64 = 2e-3;
/// At most this many walks per channel for g > 0 (the refits converge in
/// two or three on the reference materials at g = 0.5 and 0.9).
const MAX_REFITS: usize = 4;

/// How the walk is fitted: what it keeps first, the walks of the printed
/// values' profile, and whether the other priority is scored too.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    pub priority: Priority,
    pub walks: usize,
    pub other: bool,
}

/// Cycles' anisotropy for the profile's material (one layer, one g),
/// clamped as `bssrdf_setup` clamps it, and a warning where that moves it.
fn anisotropy(p: &Profile) -> Result<(f64, Option<String>)> {
    let layers = &p.material.layers;
    let g = layers.first().map_or([f64::NAN; 3], |l| l.g);
    if layers.len() != 1 || g.iter().any(|x| *x != g[0]) {
        return Err(Error::Unsupported(
            "Cycles' Random Walk takes one anisotropy for all channels: the profile's \
             material must be one layer with one g"
                .into(),
        ));
    }
    let (lo, hi) = ANISOTROPY_RANGE;
    let clamped = g[0].clamp(lo, hi);
    let warning = (clamped != g[0]).then(|| {
        format!(
            "the material's g = {} is outside [{lo}, {hi}], where Cycles' bssrdf_setup clamps \
             the anisotropy: the walk is fitted and scored at g = {clamped}, which scatters \
             {} than the material",
            g[0],
            if g[0] > hi {
                "more widely"
            } else {
                "less widely"
            }
        )
    });
    Ok((clamped, warning))
}

/// The fitted (colour, extinction) per channel for each priority asked,
/// and the tables they were read from (for g = 0 one table, whose walk
/// the printed values' profile reuses).
struct Fitted {
    main: Values,
    other: Option<Values>,
    tables: Vec<Table>,
}

type Values = [(f64, f64); 3];

/// The values per channel read from channel `c`'s table `t(c)`, for the
/// priority asked and, where asked, the other.
fn both<'a>(
    p: &Profile,
    g: f64,
    o: &Options,
    t: impl Fn(usize) -> &'a Table,
) -> (Values, Option<Values>) {
    let main = std::array::from_fn(|c| fit_channel(p, c, g, t(c), o.priority));
    let other = o
        .other
        .then(|| std::array::from_fn(|c| fit_channel(p, c, g, t(c), o.priority.other())));
    (main, other)
}

/// One run of `walks` walks at `alpha`, announced to `progress` as its
/// own stage.
fn walk(
    what: &str,
    walks: usize,
    (alpha, g, seed): (f64, f64, u64),
    progress: &dyn Progress,
) -> Result<UnitWalk> {
    progress.start(walks as u64, &format!("Cycles' Random Walk, {what}: walks"));
    UnitWalk::run(walks, alpha, g, seed, progress)
}

fn fit_walks(p: &Profile, g: f64, o: &Options, progress: &dyn Progress) -> Result<Fitted> {
    let mean_total = p.total_rd.iter().sum::<f64>() / 3.0;
    let first_alpha = cycles_walk::channel(mean_total.min(1.0), 1.0, g).alpha;
    if g == 0.0 {
        let run = walk("the fit", o.walks, (first_alpha, g, SEED), progress)?;
        let table = Table::new(run);
        let (main, other) = both(p, g, o, |_| &table);
        return Ok(Fitted {
            main,
            other,
            tables: vec![table],
        });
    }
    let n = (o.walks / FIT_SHARE).max(MIN_FIT_WALKS);
    let first = Table::new(walk("a first fit", n, (first_alpha, g, SEED), progress)?);
    let tables = (0..3)
        .map(|c| {
            refit(
                p,
                c,
                g,
                o,
                n,
                fit_channel(p, c, g, &first, o.priority).0,
                progress,
            )
        })
        .collect::<Result<Vec<_>>>()?;
    let (main, other) = both(p, g, o, |c| &tables[c]);
    Ok(Fitted {
        main,
        other,
        tables,
    })
}

/// Channel `c`'s table for g > 0: walks at the alpha of its colour,
/// refitted until the colour moves by less than REFIT_TOL (the paths after
/// the ninth scattering depend on alpha, so a table read at another alpha
/// is a little off), at most MAX_REFITS walks.
fn refit(
    p: &Profile,
    c: usize,
    g: f64,
    o: &Options,
    n: usize,
    mut colour: f64,
    progress: &dyn Progress,
) -> Result<Table> {
    let mut k = 0;
    loop {
        let alpha = cycles_walk::channel(colour, 1.0, g).alpha;
        let seed = SEED + 1 + (3 * k + c) as u64;
        let what = format!("channel {} (fit {})", ["r", "g", "b"][c], k + 1);
        let table = Table::new(walk(&what, n, (alpha, g, seed), progress)?);
        let next = fit_channel(p, c, g, &table, o.priority).0;
        k += 1;
        if (next - colour).abs() <= REFIT_TOL * colour || k == MAX_REFITS {
            return Ok(table);
        }
        colour = next;
    }
}

/// The Random Walk values fitted to `p` (one-layer material: its g and
/// eta are printed as the node's Anisotropy and IOR).
pub fn fit(p: &Profile, scene: Scene, o: &Options, progress: &dyn Progress) -> Result<EngineFit> {
    check(p)?;
    check_scene(scene)?;
    let (g, g_warning) = anisotropy(p)?;
    let eta = p.material.layers[0].eta;
    let fitted = fit_walks(p, g, o, progress)?;
    let shared = (g == 0.0).then(|| &fitted.tables[0].walk);
    let mut printed = params(fitted.main, g, eta, scene);
    let (profile, walk_profile) = rendered(&printed.params, scene, p, shared, o.walks, progress)?;
    let error = error(&profile, p)?;
    let other = match fitted.other {
        Some(values) => Some(other_fit(p, scene, (g, eta), values, &fitted, o.priority)?),
        None => None,
    };
    progress.finish();
    printed.warnings.extend(g_warning);
    if o.priority == Priority::Colour {
        printed
            .warnings
            .extend(unreached_colours(&printed.params, p, &error));
    }
    Ok(EngineFit {
        engine: "blender".into(),
        version: format!(
            "Blender 4.0 to 5.0, Cycles: Principled BSDF, {METHOD} (read in Cycles v4.0.0, v5.0.0)"
        ),
        priority: o.priority,
        params: printed.params,
        units: printed.units,
        error,
        error_for: ERROR_FOR.into(),
        scene: scene_lines(scene, true),
        requirements: Vec::new(),
        warnings: printed.warnings,
        other,
        rendered: None,
        walk: Some(walk_profile),
        profile,
    })
}

/// The other priority's values scored: through the same walk where g = 0
/// (exact), else from each channel's fit table (an estimate, said so).
fn other_fit(
    p: &Profile,
    scene: Scene,
    (g, eta): (f64, f64),
    values: [(f64, f64); 3],
    fitted: &Fitted,
    priority: Priority,
) -> Result<OtherFit> {
    let printed = params(values, g, eta, scene);
    if g == 0.0 {
        let walk = &fitted.tables[0].walk;
        let (profile, _) = rendered(
            &printed.params,
            scene,
            p,
            Some(walk),
            walk.walks,
            &NoProgress,
        )?;
        return Ok(OtherFit {
            priority: priority.other(),
            error: error(&profile, p)?,
            note: None,
        });
    }
    let (ch, _) = channels(&printed.params, scene)?;
    let mut est = p.clone();
    for (c, chan) in ch.iter().enumerate() {
        let cum = fitted.tables[c].cumulative(chan.alpha);
        est.rd[c] = cum.bins(&p.r_edges, chan.sigma_t, chan.throughput);
        est.total_rd[c] = chan.throughput * cum.total;
    }
    Ok(OtherFit {
        priority: priority.other(),
        error: error(&est, p)?,
        note: Some(format!(
            "estimated from the fit's walks ({} per channel, at the kept values' alpha), not from \
             walks at its own",
            fitted.tables[0].walk.walks
        )),
    })
}

/// Warnings for channels whose total the walk cannot reach with a Base
/// Color in [0, 1]: Cycles' remap was fitted for another start, and a
/// walk entering straight down reflects less than the albedo.
fn unreached_colours(params: &Map<String, Value>, p: &Profile, e: &FitError) -> Vec<String> {
    let colour = triple(params, "Base Color").unwrap_or([0.0; 3]);
    (0..3)
        .filter(|&c| colour[c] >= 1.0 && e.total[c] < 0.0)
        .map(|c| {
            format!(
                "channel {}: even Base Color 1 reflects less than the profile's total {:.4} in \
                 Cycles' walk (total {:+.1}%): Base Color is 1",
                ["r", "g", "b"][c],
                p.total_rd[c],
                Bounded(100.0 * e.total[c])
            )
        })
        .collect()
}

pub const ERROR_FOR: &str = "Cycles' Random Walk (the walk of subsurface_random_walk.h: entry \
     straight down under a normal view at Roughness 0, exit at the first surface crossing, \
     alpha from Cycles' remap with its 0.2 floor, at most 256 flights), by ssskit's Monte Carlo \
     of that walk; rendered by Cycles 5.0.1 in scripts/engine-cycles";

/// The node's values from the fitted colour and extinction per channel.
fn params(fitted: [(f64, f64); 3], g: f64, eta: f64, scene: Scene) -> Printed {
    let mut warnings = Vec::new();
    let colour = fitted.map(|(b, _)| typed(b.clamp(0.0, 1.0)));
    // radius (scene units) = 4 pi d, d = 1 / (sigma_t (1 - g)).
    let radius = fitted.map(|(_, s)| 4.0 * PI / (s * (1.0 - g)) * scene.units_per_mm);
    let (scale, per_channel) = scale_and_radius(radius, &mut warnings);
    let mut rows = subsurface_rows(
        colour,
        "scene linear RGB (the picker's RGB fields), in [0, 1]: the walk's alpha through \
         Cycles' remap, fitted (not the total reflectance)",
        per_channel,
        scale,
    );
    rows.extend([
        (
            "Subsurface Anisotropy",
            json!(g),
            "the material's g, in [0, 0.9]",
        ),
        (
            "IOR",
            json!(eta),
            "the material's; at a normal view and Roughness 0 it bends nothing",
        ),
        (
            "Roughness",
            json!(0.0),
            "0: the walk enters straight down under a normal view (subsurface_entry_bounce's \
             GGX facet of this roughness)",
        ),
        ("Subsurface Method", json!(METHOD), "the model fitted"),
    ]);
    printed(rows, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::printed::number;

    /// The fit reads the walk from its fine table (cumulative weight
    /// interpolated within bins 2.9% wide) and prints 4 digits, where the
    /// profile it fits was binned from the exits themselves; the values it
    /// recovers from a profile the walk itself made differ by less than
    /// this, relative (the same walks: no Monte Carlo noise between them).
    const RECOVER_TOL: f64 = 0.01;
    /// Walks of the made profile and of the fits: the same seed and count,
    /// so the fits walk the very walks that made it (a quarter of WALKS
    /// keeps the test to seconds).
    const TEST_WALKS: usize = WALKS / 4;

    #[test]
    fn the_fit_recovers_the_values_of_a_walk_profile() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/reference/skin1.json");
        let like = Profile::read(std::path::Path::new(path)).unwrap();
        let scene = Scene::default();
        let values = params([(0.6, 1.2), (0.3, 2.0), (0.05, 3.5)], 0.0, 1.4, scene);
        let (made, _) =
            rendered(&values.params, scene, &like, None, TEST_WALKS, &NoProgress).unwrap();
        for priority in [Priority::Shape, Priority::Colour] {
            let o = Options {
                priority,
                walks: TEST_WALKS,
                other: false,
            };
            let got = fit(&made, scene, &o, &NoProgress).unwrap();
            recovered(&values.params, &got, priority);
        }
    }

    fn recovered(values: &Map<String, Value>, got: &EngineFit, priority: Priority) {
        let radius = |p: &Map<String, Value>| {
            let s = number(p, "Subsurface Scale").unwrap();
            triple(p, "Subsurface Radius").unwrap().map(|r| r * s)
        };
        let (want_r, got_r) = (radius(values), radius(&got.params));
        let want_c = triple(values, "Base Color").unwrap();
        let got_c = triple(&got.params, "Base Color").unwrap();
        for c in 0..3 {
            let rel = |a: f64, b: f64| (a - b).abs() / b;
            assert!(
                rel(got_r[c], want_r[c]) < RECOVER_TOL && rel(got_c[c], want_c[c]) < RECOVER_TOL,
                "{priority:?}, channel {c}: radius {} for {}, Base Color {} for {}",
                got_r[c],
                want_r[c],
                got_c[c],
                want_c[c]
            );
        }
        assert!(
            got.error.shape.iter().all(|e| *e < RECOVER_TOL),
            "{:?}",
            got.error
        );
    }

    /// Records what a fit reports.
    #[derive(Default)]
    struct Recorder {
        started: std::sync::Mutex<Vec<u64>>,
        done: std::sync::atomic::AtomicU64,
        finished: std::sync::atomic::AtomicBool,
        stop: bool,
    }

    impl Progress for Recorder {
        fn start(&self, total: u64, _what: &str) {
            self.started.lock().unwrap().push(total);
        }
        fn advance(&self, n: u64) {
            self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
        fn finish(&self) {
            self.finished
                .store(true, std::sync::atomic::Ordering::Relaxed);
        }
        fn cancelled(&self) -> bool {
            self.stop
        }
    }

    fn skin1_with_g(g: f64) -> Profile {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/reference/skin1.json");
        let mut p = Profile::read(std::path::Path::new(path)).unwrap();
        p.material.layers[0].g = [g; 3];
        p
    }

    /// The walks a fit announces, run by run, are the walks it reports
    /// done, at g = 0 (one run) and g > 0 (a first run, one or more per
    /// channel, then the printed values' run per channel); a fit asked to
    /// stop stops with the caller's message.
    #[test]
    fn the_fit_reports_every_walk_it_runs() {
        let o = Options {
            priority: Priority::Colour,
            walks: 1 << 16,
            other: false,
        };
        for g in [0.0, 0.5] {
            let rec = Recorder::default();
            fit(&skin1_with_g(g), Scene::default(), &o, &rec).unwrap();
            let started = rec.started.lock().unwrap().clone();
            let done = rec.done.load(std::sync::atomic::Ordering::Relaxed);
            assert_eq!(done, started.iter().sum::<u64>(), "g {g}");
            // g = 0: one run; g > 0: a first, at least one per channel,
            // the printed values' three.
            let runs = if g == 0.0 {
                1..=1
            } else {
                7..=1 + 3 * MAX_REFITS + 3
            };
            assert!(runs.contains(&started.len()), "g {g}: {started:?}");
            assert!(rec.finished.load(std::sync::atomic::Ordering::Relaxed));
        }
        let stop = Recorder {
            stop: true,
            ..Recorder::default()
        };
        let err = fit(&skin1_with_g(0.0), Scene::default(), &o, &stop).unwrap_err();
        assert!(
            err.to_string().contains(crate::progress::INTERRUPTED),
            "{err}"
        );
    }

    /// A material's g outside Cycles' [0, 0.9] is clamped, as
    /// `bssrdf_setup` clamps it, and the fit says so.
    #[test]
    fn a_clamped_anisotropy_is_a_warning() {
        let (g, warning) = anisotropy(&skin1_with_g(0.9999)).unwrap();
        assert_eq!(g, ANISOTROPY_RANGE.1);
        assert!(warning.unwrap().contains("0.9999"));
        assert_eq!(anisotropy(&skin1_with_g(0.3)).unwrap(), (0.3, None));
    }

    /// Where g > 0 each channel's colour is refitted from a walk at its own
    /// alpha until it settles: the printed values' walk then reflects the
    /// profile's total within COLOUR_TOL (one table at the mean alpha
    /// misses skin1's blue by about 4% at g = 0.9).
    #[test]
    fn the_colour_holds_where_g_is_above_0() {
        use crate::engine::priority::COLOUR_TOL;
        let p = skin1_with_g(0.5);
        let o = Options {
            priority: Priority::Colour,
            walks: 1 << 18,
            other: false,
        };
        let f = fit(&p, Scene::default(), &o, &NoProgress).unwrap();
        for c in 0..3 {
            assert!(
                f.error.total[c].abs() <= COLOUR_TOL,
                "channel {c}: total {}",
                f.error.total[c]
            );
        }
    }
}
