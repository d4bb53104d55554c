//! The written study ([`crate::report::eval::study`]): its table, the Pareto
//! panels of each section, and the files (study.md, study.json read back,
//! study.csv, pareto.png).

use super::number::{sig, sig_or_dash};
use super::pareto::{self, ParetoPanel, Point, Series};
use super::table::Table;
use crate::error::{Error, Result};
use crate::report::eval::study::{Entry, Study};
use std::path::Path;

/// The table of every entry.
pub fn table(study: &Study) -> Table {
    let mut t = Table::new(&[
        "section",
        "configuration",
        "kernel model",
        "passes",
        "samples/pixel",
        "cost",
        "cost unit",
        "profile or kernel error",
        "image rel. RMS",
        "image FLIP",
        "CPU ms/megapixel",
        "seconds",
    ]);
    let count = |v: Option<usize>| v.map_or("-".to_string(), |n| n.to_string());
    for e in &study.entries {
        t.push(vec![
            e.section.clone(),
            e.config.clone(),
            e.model.clone().unwrap_or_else(|| "-".into()),
            count(e.passes),
            count(e.samples_per_pixel),
            sig(e.cost),
            e.cost_unit.clone(),
            sig_or_dash(e.profile_or_kernel_error),
            sig_or_dash(e.rel_rms),
            sig_or_dash(e.flip),
            sig_or_dash(e.ms_per_megapixel),
            sig(e.seconds),
        ]);
    }
    t
}

fn series(
    study: &Study,
    section: &str,
    name: &str,
    err: impl Fn(&Entry) -> Option<f64>,
    label: impl Fn(&Entry) -> String,
) -> Series {
    Series {
        name: name.into(),
        points: study
            .entries
            .iter()
            .filter(|e| e.section == section)
            .filter_map(|e| {
                Some(Point {
                    cost: e.cost,
                    error: err(e)?,
                    label: label(e),
                    passes: e.passes,
                })
            })
            .collect(),
    }
}

/// The part of a configuration before its first comma ("17 taps" of "17
/// taps, auto extent (+-2.1 mm)").
fn head(e: &Entry) -> String {
    e.config.split(',').next().unwrap_or("").to_string()
}

/// The Pareto panels: one quantity per y axis, image error against what a
/// renderer pays per frame (samples per pixel, marker = passes) wherever
/// kernels are compared.
pub fn panels(study: &Study) -> Vec<ParetoPanel> {
    let m = &study.material;
    // A section split in two series by a key of the configuration.
    let split = |section: &str, key: &str, name: &str, label: &dyn Fn(&Entry) -> String| {
        let mut s = series(study, section, name, |e| e.rel_rms, label);
        let keep: Vec<bool> = study
            .entries
            .iter()
            .filter(|e| e.section == section && e.rel_rms.is_some())
            .map(|e| e.config.contains(key))
            .collect();
        let mut k = keep.iter();
        s.points.retain(|_| *k.next().unwrap_or(&false));
        s
    };
    let rank = |e: &Entry| {
        e.model
            .as_deref()
            .and_then(|m| m.strip_prefix("svd"))
            .and_then(|m| m.split('-').next())
            .map_or_else(|| head(e), |r| format!("rank {r}"))
    };
    let spp = "samples per pixel";
    let config = |e: &Entry| e.config.clone();
    let profile_models = |err: fn(&Entry) -> Option<f64>| {
        vec![series(
            study,
            "profile_model",
            "profile models",
            err,
            config,
        )]
    };
    let photons = series(
        study,
        "photons",
        "Monte Carlo",
        |e| e.profile_or_kernel_error,
        |e| e.config.replace(" photons", ""),
    );
    let disk = series(
        study,
        "disk",
        "disk kernels",
        |e| e.rel_rms,
        |e| format!("disk {}", e.samples_per_pixel.unwrap_or(0)),
    );
    let models = series(study, "kernel_model", "models", |e| e.rel_rms, config);
    let frames = crate::report::eval::disk::DEFAULT_FRAMES;
    vec![
        panel(
            format!("{m}: Monte Carlo photons"),
            ("simulation time (s)", "profile rel. L2 error"),
            vec![photons],
        ),
        panel(
            format!("{m}: taps (pre-integration)"),
            (spp, "image rel. RMS"),
            vec![
                split("taps", "auto extent", "extent chosen for the count", &head),
                split("taps", "full extent", "full kernel extent", &head),
            ],
        ),
        panel(
            format!("{m}: profile model, kernel error"),
            ("profile time (s)", "kernel RMS"),
            profile_models(|e| e.profile_or_kernel_error),
        ),
        panel(
            format!("{m}: profile model, image error (preintegrate, 17 taps)"),
            ("profile time (s)", "image rel. RMS"),
            profile_models(|e| e.rel_rms),
        ),
        panel(
            format!("{m}: SVD rank (renormalised)"),
            (spp, "image rel. RMS"),
            vec![
                split("rank", "full", "full factors", &rank),
                split("rank", "17 taps", "17 taps", &rank),
            ],
        ),
        panel(
            format!("{m}: kernel model (17 taps; disk: after {frames} frames)"),
            (spp, "image rel. RMS"),
            vec![models, disk],
        ),
    ]
}

/// A panel titled `title` with axes (x, y).
fn panel(title: String, (x, y): (&str, &str), series: Vec<Series>) -> ParetoPanel {
    ParetoPanel {
        title,
        x_label: x.into(),
        y_label: y.into(),
        series,
    }
}

/// Writes study.md, study.json (read back), study.csv and pareto.png.
pub fn write(study: &Study, dir: &Path, command: &str, plots: bool) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::format(dir, format!("cannot create the output folder: {e}")))?;
    let t = table(study);
    let md = format!(
        "# Speed/accuracy study: {}\n\n`{command}`\n\nReference profile: {}. Images: edge and \
         shapes at {} mm per pixel; image errors are the largest relative RMS over channels \
         and signals and the colour FLIP (see docs). Times are wall times on this machine and \
         its load.\n\n{}",
        study.material,
        study.reference,
        study.mm_per_pixel,
        t.markdown()
    );
    crate::io::write_atomic(&dir.join("study.md"), md.as_bytes())?;
    t.write_csv(&dir.join("study.csv"))?;
    crate::io::write_json_atomic(&dir.join("study.json"), study)?;
    let back: Study = crate::io::read_json(&dir.join("study.json"))?;
    if back.entries.len() != study.entries.len() {
        return Err(Error::format(
            dir.join("study.json"),
            "read back fewer entries",
        ));
    }
    let mut files = vec!["study.md".into(), "study.csv".into(), "study.json".into()];
    if plots {
        pareto::render(
            &panels(study),
            2,
            &format!(
                "Speed/accuracy of {} (log-log; lines join the Pareto front)",
                study.material
            ),
            &dir.join("pareto.png"),
        )?;
        files.push("pareto.png".into());
    }
    Ok(files)
}
