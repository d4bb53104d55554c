//! The separable and disk kernel models a `--model` flag names: a leaf that
//! both `fit` and the shared flags read.

use clap::ValueEnum;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ModelArg {
    /// Rank-N SVD (Freude 2014, sec. 5.1): --rank, --renormalize.
    Svd,
    /// Pre-integration / Abel projection (Freude 2014, sec. 5.2): --method.
    Preintegrate,
    /// Guided optimization (Freude 2014, sec. 5.3): --k, --b.
    Guided,
    /// Two-Gaussian manual model (Freude 2014, sec. 5.4): --w --near --far, --preset or --fit.
    Manual,
    /// d'Eon sum of 2D Gaussians: --count, or --preset deon-skin.
    Gaussians,
    /// Jimenez's skin model (Freude 2014, eq. 4.8): --jimenez-width, --jimenez-strength, --jimenez-falloff.
    Jimenez,
    /// Importance-sampled disk (not separable): --samples, --radii.
    Disk,
}
