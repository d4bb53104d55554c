//! The written study ([`crate::report::study`]): its table, the Pareto
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
        "cost",
        "cost unit",
        "profile or kernel error",
        "image rel. RMS",
        "image FLIP",
    ]);
    for e in &study.entries {
        t.push(vec![
            e.section.clone(),
            e.config.clone(),
            sig(e.cost),
            e.cost_unit.clone(),
            sig_or_dash(e.profile_or_kernel_error),
            sig_or_dash(e.rel_rms),
            sig_or_dash(e.flip),
        ]);
    }
    t
}

fn series(study: &Study, section: &str, name: &str, err: impl Fn(&Entry) -> Option<f64>) -> Series {
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
                    label: e.config.clone(),
                })
            })
            .collect(),
    }
}

/// The Pareto panels, one per section.
pub fn panels(study: &Study) -> Vec<ParetoPanel> {
    let m = &study.material;
    let split = |section: &str, key: &str, name: &str| Series {
        name: name.into(),
        points: series(study, section, name, |e| e.rel_rms)
            .points
            .into_iter()
            .filter(|p| p.label.contains(key))
            .map(|p| Point {
                label: p.label.split(',').next().unwrap_or("").to_string(),
                ..p
            })
            .collect(),
    };
    // A section split in two series by a key of the configuration.
    let two_way = |what: &str, x_label: &str, section: &str, keys: [(&str, &str); 2]| ParetoPanel {
        title: format!("{m}: {what}"),
        x_label: x_label.into(),
        y_label: "image rel. RMS".into(),
        series: keys.iter().map(|(k, n)| split(section, k, n)).collect(),
    };
    vec![
        ParetoPanel {
            title: format!("{m}: Monte Carlo photons"),
            x_label: "simulation time (s)".into(),
            y_label: "profile rel. L2 error".into(),
            series: vec![series(study, "photons", "Monte Carlo", |e| {
                e.profile_or_kernel_error
            })],
        },
        ParetoPanel {
            title: format!("{m}: profile model"),
            x_label: "profile time (s)".into(),
            y_label: "error".into(),
            series: vec![
                series(study, "profile_model", "kernel RMS", |e| {
                    e.profile_or_kernel_error
                }),
                series(study, "profile_model", "image rel. RMS", |e| e.rel_rms),
            ],
        },
        two_way(
            "taps (pre-integration)",
            "samples per pixel",
            "taps",
            [
                ("auto extent", "extent chosen for the count"),
                ("full extent", "full kernel extent"),
            ],
        ),
        two_way(
            "SVD rank (renormalised)",
            "filter time (ms per megapixel, CPU)",
            "rank",
            [("full", "full factors"), ("17 taps", "17 taps")],
        ),
        ParetoPanel {
            title: format!("{m}: kernel model (17 taps)"),
            x_label: "fit time (s)".into(),
            y_label: "image rel. RMS".into(),
            series: vec![series(study, "kernel_model", "models", |e| e.rel_rms)],
        },
    ]
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
