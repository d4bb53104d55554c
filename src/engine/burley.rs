//! Christensen and Burley 2015 normalized diffusion as the Burley engines
//! render it: R(r) = A (e^{-r/d} + e^{-r/(3d)}) / (8 pi d r), the engine's
//! blur normalised to 1 and multiplied by a colour A (Unreal's material
//! Base Color, HDRP's Base Map colour, Blender's Base Color), the shape
//! distance d in mm on the surface. The fit takes A and d per channel
//! from the profile itself; each engine file turns them into the values a
//! user types, and back through that engine's own chain.

use super::model::{modelled, Target};
use super::priority::Priority;
use crate::error::{Error, Result};
use crate::numerics::bin_averages_resolved;
use crate::numerics::minimise_log;
use crate::profile::analytic::burley::normalized_diffusion;
use crate::profile::{Profile, RadialGrid};

/// A Burley profile per channel, as an engine renders it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Burley {
    /// The colour the normalised blur is multiplied by (= the total
    /// reflectance).
    pub albedo: [f64; 3],
    /// Shape distance d per channel, mm on the surface.
    pub d_mm: [f64; 3],
    /// Where the engine cuts the profile off, in units of d: zero beyond,
    /// the rest scaled by 1 / CDF(cut) so that the total stays A (Cycles:
    /// `bssrdf_eval` returns `bssrdf_burley_pdf`, the profile truncated at
    /// BURLEY_TRUNCATE = 16 d and divided by BURLEY_TRUNCATE_CDF,
    /// kernel/closure/bssrdf.h). None: the whole profile.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truncate_d: Option<f64>,
}

/// The radial CDF of normalized diffusion, r in units of d:
/// 1 - e^{-r} / 4 - 3 e^{-r/3} / 4 (Christensen and Burley 2015).
pub fn normalized_cdf(r_over_d: f64) -> f64 {
    1.0 - 0.25 * (-r_over_d).exp() - 0.75 * (-r_over_d / 3.0).exp()
}

impl Burley {
    /// Bin averages of channel `c` on `grid`.
    pub fn bins(&self, c: usize, grid: &RadialGrid) -> Vec<f64> {
        let (a, d) = (self.albedo[c], self.d_mm[c]);
        let whole = bin_averages_resolved(|r| normalized_diffusion(a, d, r), &grid.edges);
        let Some(cut) = self.truncate_d else {
            return whole;
        };
        let (rm, k) = (cut * d, 1.0 / normalized_cdf(cut));
        whole
            .iter()
            .zip(grid.edges.windows(2))
            .map(|(v, e)| {
                if e[1] <= rm {
                    v * k
                } else if e[0] >= rm {
                    0.0
                } else {
                    // The bin the cut falls in: its part inside, exactly.
                    let inside = normalized_cdf(rm / d) - normalized_cdf(e[0] / d);
                    a * k * inside / (crate::numerics::annulus_area(e[0], e[1]))
                }
            })
            .collect()
    }

    /// This model on `like`'s grid, as engine `engine` renders it.
    pub fn profile(&self, like: &Profile, engine: &str) -> Profile {
        let grid = RadialGrid {
            edges: like.r_edges.clone(),
        };
        let rd = (0..3).map(|c| self.bins(c, &grid)).collect();
        modelled(like, engine, "burley", rd, self.albedo.to_vec())
    }
}

/// Least squares on r R_d(r) (the shape norm) per channel: for each d the
/// best A is linear; d by a log-space search from 1e-4 to 10 times the
/// radius holding 99% of the channel.
pub fn fit(p: &Profile) -> Result<Burley> {
    fit_for(p, [f64::INFINITY; 3], Priority::Shape)
}

/// `fit` with A at most `cap` per channel (an engine colour field that
/// cannot exceed 1). With `Priority::Shape` A is the least-squares
/// amplitude, and where it is above the cap that d is scored with A = cap,
/// so d is the best one for the colour the engine can take, not for one it
/// cannot. With `Priority::Colour` A is the profile's total (capped): the
/// blur is normalised, so that is the total the engine renders, and d is
/// the best one for it.
pub fn fit_for(p: &Profile, cap: [f64; 3], priority: Priority) -> Result<Burley> {
    let mut albedo = [0.0; 3];
    let mut d_mm = [0.0; 3];
    for c in 0..3 {
        let t = Target::new(p, c);
        if t.bins == 0 {
            return Err(Error::Unsupported(format!(
                "channel {c}: no profile bins to fit"
            )));
        }
        let grid = RadialGrid {
            edges: p.r_edges[..=t.bins].to_vec(),
        };
        let shape =
            |d: f64| bin_averages_resolved(|r| normalized_diffusion(1.0, d, r), &grid.edges);
        let kept = p.total_rd[c].min(cap[c]);
        let scored = |d: f64| {
            let s = shape(d);
            if priority == Priority::Colour {
                return (kept, t.residual_at(&s, kept));
            }
            let (a, res) = t.scale_of(&s);
            if a > cap[c] {
                (cap[c], t.residual_at(&s, cap[c]))
            } else {
                (a, res)
            }
        };
        let r99 = p.r_edges[t.bins];
        let d = minimise_log(|d| scored(d).1, 1e-4 * r99, 10.0 * r99, 41);
        albedo[c] = scored(d).0;
        d_mm[c] = d;
    }
    Ok(Burley {
        albedo,
        d_mm,
        truncate_d: None,
    })
}

/// The error of the forward model (A from the dipole, d from the
/// searchlight fit and the optical coefficients; `profile --model burley`)
/// against `p`, on `p`'s grid: the baseline the fit must beat.
pub fn forward_error(p: &Profile) -> Result<super::FitError> {
    use crate::profile::analytic::{self, Options};
    let grid = RadialGrid {
        edges: p.r_edges.clone(),
    };
    let options = Options {
        channels: p.channels.clone(),
        ..Options::default()
    };
    let forward = analytic::profile(&p.material, analytic::Model::Burley, &grid, &options)?;
    super::model::error(&forward, p)
}
