//! Every chart ssskit writes, drawn from real data as a reader sees it:
//! R_d(r) of profile files (`plot`, the main job's profile.png, `engine
//! --plot`), analytic models against Monte Carlo (`compare --profiles`),
//! kernel slices and singular value spectra (`compare`), and the
//! error-against-cost page (`study`). For each, from the layout code's own
//! boxes measured with the bundled font: no two texts overlap, none
//! leaves the image, every tick label reads (plain notation inside
//! 1e-3..1e4); and each page matches its golden PNG.

mod common;

use common::golden;
use common::skin1::{comparison, profile, TAPS};
use ssskit::kernel::disk::DiskKernelFile;
use ssskit::kernel::KernelFile;
use ssskit::profile::analytic::Model;
use ssskit::profile::source::{make_profile_on, ProfileSource};
use ssskit::profile::Profile;
use ssskit::report::eval::compare::kernel::Comparison;
use ssskit::report::eval::compare::sheets::{disk_annuli, slice_kernels};
use ssskit::report::eval::disk::disk_kernel;
use ssskit::report::eval::radial::{comparison_figure, profile_figure};
use ssskit::report::present::kernel_plots::Recommended;
use ssskit::report::present::layout::{collisions, Rect, TextBox};
use ssskit::report::present::pareto::{self, ParetoPanel, Point, Series};
use ssskit::report::present::{kernel_plots, plot, profile_tables};
use std::path::Path;

/// The plot kinds, each drawn by [`draw`].
const KINDS: [&str; 5] = ["profile", "compare", "slices", "spectra", "pareto"];

struct Data {
    skin1: Profile,
    marble: Profile,
    analytic: Vec<Profile>,
    cmp: Comparison,
    /// The disk kernel the advice would ship for skin1 (32 samples): the
    /// slices show it as the recommended kernel.
    disk: DiskKernelFile,
}

fn data() -> Data {
    let skin1 = profile();
    let marble =
        Profile::read(&common::skin1::root().join("profiles/reference/marble.json")).unwrap();
    let analytic = Model::ALL
        .iter()
        .map(|&m| {
            let src = ProfileSource::analytic(m);
            let (p, _) =
                make_profile_on(&skin1.material, &src, None, &ssskit::progress::NoProgress)
                    .unwrap();
            p
        })
        .collect();
    Data {
        disk: disk_kernel(&skin1, 32).unwrap(),
        skin1,
        marble,
        analytic,
        cmp: comparison(),
    }
}

/// The study's kernel-model panel from the comparison's measurements:
/// relative RMS on the shapes signal (largest channel) against 1D samples
/// per pixel, of the full factors and of the tap tables, one series per
/// family, passes as the marker.
fn pareto_panels(cmp: &Comparison) -> Vec<ParetoPanel> {
    let mut series: Vec<Series> = Vec::new();
    for f in &cmp.fitted {
        let family = f.spec.label.split(['1', '-']).next().unwrap().to_string();
        let case = &f.images[common::skin1::SHAPES];
        for (e, what) in [
            (&case.full, "full".to_string()),
            (&case.taps[&TAPS], format!("{TAPS} taps")),
        ] {
            let point = Point {
                cost: e.samples_per_pixel as f64,
                error: e.rel_rms.iter().cloned().fold(0.0, f64::max),
                label: format!("{} ({what})", f.spec.label),
                passes: Some(passes(&f.kernel)),
            };
            match series.iter_mut().find(|s| s.name == family) {
                Some(s) => s.points.push(point),
                None => series.push(Series {
                    name: family.clone(),
                    points: vec![point],
                }),
            }
        }
    }
    vec![ParetoPanel {
        title: "skin1, shapes: image error against cost".into(),
        x_label: "samples per pixel".into(),
        y_label: "relative RMS (largest channel)".into(),
        series,
    }]
}

fn passes(k: &KernelFile) -> usize {
    2 * k.passes.len()
}

/// Draws plot `kind` of `d` into `out`; returns the boxes of its texts.
fn draw(kind: &str, d: &Data, out: &Path) -> Vec<TextBox> {
    match kind {
        "profile" => plot::render(
            &plot::profile_panels(&profile_figure(&[
                ("skin1 mcml".into(), d.skin1.clone()),
                ("marble mcml".into(), d.marble.clone()),
            ])),
            2,
            "R_d(r): skin1.json, marble.json",
            out,
        ),
        "compare" => plot::render(
            &profile_tables::comparison_panels(&comparison_figure(&d.skin1, &d.analytic)),
            3,
            "skin1: analytic models vs Monte Carlo",
            out,
        ),
        "slices" => kernel_plots::kernel_slices(
            &slice_kernels(&d.cmp, "skin1").unwrap(),
            Some(&Recommended::Disk {
                label: "disk, 32 samples".into(),
                annuli: std::array::from_fn(|c| disk_annuli(&d.disk, c)),
            }),
            out,
        ),
        "spectra" => kernel_plots::spectra(&d.cmp, out),
        "pareto" => pareto::render(&pareto_panels(&d.cmp), 1, "skin1: cost", out),
        _ => unreachable!("{kind}"),
    }
    .unwrap()
}

/// Tick labels as the axes write them: plain numbers inside 1e-3..1e4,
/// never "5.0e-1" nor "1.000".
fn reads_as_a_tick(t: &str) -> bool {
    let plain = t
        .parse::<f64>()
        .is_ok_and(|v| v == 0.0 || (1e-3..1e4).contains(&v.abs()));
    let short = !t.contains('.') || !t.ends_with('0');
    let sci = t.split_once('e').is_some_and(|(m, k)| {
        m.parse::<i64>().is_ok() && k.parse::<i32>().is_ok_and(|k| !(-3..4).contains(&k))
    });
    (plain && short && !t.contains('e')) || sci
}

fn assert_layout_reads(kind: &str, boxes: &[TextBox], png: &Path) {
    let (w, h) = image::image_dimensions(png).unwrap();
    let bad = collisions(boxes, &Rect::at(0, 0, (w, h)));
    assert!(bad.is_empty(), "{kind}:\n  {}", bad.join("\n  "));
    let numbers: Vec<&str> = boxes
        .iter()
        .map(|b| b.text.as_str())
        .filter(|t| t.starts_with(|c: char| c.is_ascii_digit()) && !t.contains(' '))
        .collect();
    assert!(numbers.len() >= 4, "{kind}: no tick labels in {boxes:?}");
    for t in numbers {
        assert!(reads_as_a_tick(t), "{kind}: tick label {t:?}");
    }
}

/// Every kind's page: its texts never collide nor leave the image, its
/// ticks read, and it matches tests/golden/plot-<kind>.png.
#[test]
fn every_plot_reads_and_matches_its_golden() {
    let d = data();
    for kind in KINDS {
        let mut boxes = Vec::new();
        golden::check_png(&format!("plot-{kind}.png"), |out| {
            boxes = draw(kind, &d, out);
            assert_layout_reads(kind, &boxes, out);
        });
        if kind == "slices" {
            // Every panel's legend names the recommended kernel.
            let n = boxes
                .iter()
                .filter(|b| b.text == "recommended: disk, 32 samples")
                .count();
            assert_eq!(n, 6, "{boxes:?}");
        }
    }
}
