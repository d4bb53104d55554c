//! Analytic profile models against a Monte Carlo reference: the error of
//! the total, the relative L2 error of r R_d(r) where R_d lives, and time.

use crate::error::Result;
use crate::material::Channel;
use crate::profile::metrics::{channel_error, same_grid};
use crate::profile::Profile;

/// Default accuracy of the Monte Carlo reference the analytic models are
/// compared with: 1% relative standard error, at most 1e7 photons per
/// channel.
pub const REFERENCE_MC_ERROR: f64 = 0.01;
pub const REFERENCE_MAX_PHOTONS: u64 = 10_000_000;

/// One model in one channel of one material.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Row {
    pub material: String,
    pub channel: Channel,
    pub model: String,
    pub reduced_albedo: f64,
    pub total_model: f64,
    pub total_mc: f64,
    pub total_mc_stderr: f64,
    /// (model - mc) / mc; +inf when the reference is 0 and the model is not.
    pub rel_total_error: f64,
    /// ||r (model - mc)|| / ||r mc|| over [0, r99].
    pub rel_l2_error: f64,
    /// The same norm of the reference's own standard errors: the smallest
    /// L2 error this reference can resolve.
    pub mc_noise_l2: f64,
    /// The model's own L2 error with the reference's noise removed,
    /// sqrt(max(L2^2 - noise^2, 0)) (noise and model error add in
    /// quadrature in expectation).
    pub rel_l2_model: f64,
    /// Radius holding 99% of the reference's tabulated R_d, mm.
    pub r99: f64,
    pub model_time_s: f64,
    pub mc_time_s: f64,
}

/// Compares one model profile with the reference in every shared channel.
pub fn compare(model: &Profile, reference: &Profile, model_time_s: f64) -> Result<Vec<Row>> {
    same_grid(model, reference)?;
    let name = model.source.model.clone().unwrap_or_else(|| "?".into());
    let mut rows = Vec::new();
    for (mi, &ch) in model.channels.iter().enumerate() {
        let Some(c) = reference.channel_index(ch) else {
            continue;
        };
        let e = channel_error(&model.rd[mi], model.total_rd[mi], reference, c);
        rows.push(Row {
            material: model.material.name.clone(),
            channel: ch,
            model: name.clone(),
            reduced_albedo: model.material.top(ch).reduced_albedo(),
            total_model: model.total_rd[mi],
            total_mc: reference.total_rd[c],
            total_mc_stderr: reference
                .total_rd_stderr
                .as_ref()
                .map(|s| s[c])
                .unwrap_or(0.0),
            rel_total_error: e.total,
            rel_l2_error: e.shape,
            mc_noise_l2: e.noise,
            rel_l2_model: (e.shape * e.shape - e.noise * e.noise).max(0.0).sqrt(),
            r99: e.r99,
            model_time_s,
            mc_time_s: reference.elapsed_s,
        });
    }
    Ok(rows)
}
