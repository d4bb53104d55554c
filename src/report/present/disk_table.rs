//! `compare`'s disk rows as a reader sees them: per material and test
//! image, the separable and the disk kernel at equal samples per pixel,
//! with the disk's bias, its noise in one frame and after K frames
//! ([`crate::report::eval::compare::disk`]).

use super::table::Table;
use crate::report::eval::compare::disk::DiskRows;

fn pct(v: f64) -> String {
    format!("{:.2}", 100.0 * v)
}

/// One row per kernel; values in % of the exact image's peak, the largest
/// channel; the bias with its noise floor after `+-`.
pub fn disk_table(rows: &[DiskRows], frames: u32) -> Table {
    let after = format!("noise after {frames} frames %");
    let mut t = Table::new(&[
        "material",
        "signal",
        "samples/px",
        "kernel",
        "bias % (+- floor)",
        "noise, 1 frame %",
        &after,
        "FLIP",
    ]);
    for m in rows {
        for r in &m.rows {
            t.push(vec![
                m.material.clone(),
                m.signal.clone(),
                r.samples_per_pixel.to_string(),
                format!("{} {}", r.family, r.layout),
                format!("{} +- {}", pct(r.bias), pct(r.bias_noise_floor)),
                pct(r.noise),
                pct(r.noise_after),
                format!("{:.4}", r.flip),
            ]);
        }
    }
    t
}
