//! The main job in one call: from a material to the kernels to ship. A
//! profile (Monte Carlo at a modest accuracy, or an analytic model), every
//! kernel model fitted and compared in kernel and image space
//! ([`super::kernel_compare`]), shader arrays for each, the report with its
//! plots, and the configuration [`super::advise`] picks at the given scale.

use super::advise::{self, Advice};
use super::evaluate::{ImageCase, Options, Which};
use super::kernel_compare::{self, Comparison, Config, Factor, MaterialInput, Row, FAMILIES};
use super::shipped::{shipped, Shipped};
use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::io::{file_stem, join_inside};
use crate::kernel::disk::DiskKernelFile;
use crate::kernel::emit::{emit, Lang};
use crate::kernel::KernelFile;
use crate::numerics::Bounded;
use crate::profile::Profile;
use crate::progress::Progress;
use crate::report::present::kernel_report::{self, ReportContext};
use crate::report::present::{advice_text, kernel_plots, plot};
use crate::scene::{Render, Scene};
use std::path::Path;

pub use crate::profile::source::{
    make_profile, make_profile_on, ProfileSource, MC_MAX_PHOTONS, MC_MAX_WORK, MC_REL_ERROR,
    MC_SEED,
};

/// Settings of the pipeline.
#[derive(Clone, Debug)]
pub struct Settings {
    pub mm_per_pixel: f64,
    /// Taps of the stored tables.
    pub taps: usize,
    /// Target relative RMS of the recommendation.
    pub target: f64,
    /// What the recommendation may cost.
    pub budget: advise::Budget,
    /// Side of the test signals, pixels.
    pub size: usize,
    pub plots: bool,
}

/// What the pipeline produced.
pub struct Outcome {
    pub comparison: Comparison,
    pub advice: Advice,
    /// Files written, relative to the output folder.
    pub files: Vec<String>,
}

/// The comparison's written form in `dir`: report.md, compare.csv,
/// compare.json (read back), and with `plots` the kernel slices, one
/// contact sheet per signal (opening with `shipped` where given, else the
/// best model; tiles of the wrong colour listed in report.md) and the
/// singular value spectra. Returns the file names written.
pub fn write_comparison(
    cmp: &Comparison,
    ctx: &ReportContext,
    dir: &Path,
    plots: bool,
    sheet_factor: &str,
    shipped: Option<&Shipped>,
) -> Result<Vec<String>> {
    let mut files = vec![
        "report.md".to_string(),
        "compare.csv".into(),
        "compare.json".into(),
    ];
    let mut md = kernel_report::report(cmp, ctx);
    let mut names = FileNames::default();
    kernel_report::csv(&cmp.rows).write_csv(&dir.join("compare.csv"))?;
    let json = dir.join("compare.json");
    crate::io::write_json_atomic(&json, &cmp.rows)?;
    let back: Vec<Row> = crate::io::read_json(&json)?;
    if back.len() != cmp.rows.len() {
        return Err(Error::format(
            &json,
            format!("read back {} rows, wrote {}", back.len(), cmp.rows.len()),
        ));
    }
    if plots {
        let mut flags = Vec::new();
        for m in &cmp.materials {
            let stem = file_stem(m);
            let name = names.claim(format!("slices_{stem}.png"), m)?;
            kernel_plots::kernel_slices(cmp, m, &join_inside(dir, &name)?)?;
            files.push(name);
            for (ci, s) in ctx.signals.iter().enumerate() {
                let label = format!("{m} {s}");
                let name = names.claim(format!("sheet_{stem}_{}.png", file_stem(s)), &label)?;
                let path = join_inside(dir, &name)?;
                let sheet = kernel_plots::contact_sheet(cmp, m, ci, sheet_factor, shipped, &path)?;
                flags.extend(sheet.flags);
                files.push(name);
            }
        }
        if cmp.fitted.iter().any(|f| f.kernel.model.name == "svd") {
            kernel_plots::spectra(cmp, &dir.join("spectra.png"))?;
            files.push("spectra.png".into());
        }
        md.push_str(&kernel_plots::flags_markdown(&flags));
    }
    crate::io::write_atomic(&dir.join("report.md"), md.as_bytes())?;
    Ok(files)
}

/// File names made from labels (materials, models, images) in one
/// folder: each must be new, so that two labels that give one file name
/// (`a/b` and `a_b`) are refused rather than one overwriting the other.
#[derive(Default)]
struct FileNames(std::collections::BTreeMap<String, String>);

impl FileNames {
    fn claim(&mut self, name: String, label: &str) -> Result<String> {
        if let Some(other) = self.0.insert(name.clone(), label.to_string()) {
            return Err(Error::Unsupported(format!(
                "'{other}' and '{label}' give the same file name '{name}' (names become file \
                 names with every character but letters, digits, '-', '_', '+' and '.' \
                 replaced by '_'): rename one"
            )));
        }
        Ok(name)
    }
}

/// Every fitted kernel of the comparison as `dir/<material>-<label>.json`
/// (read back; both names through [`file_stem`]), with its HLSL, GLSL and
/// WGSL arrays next to it when `shaders`. `dir` is created. Returns the
/// file names written.
pub fn write_fitted_kernels(cmp: &Comparison, dir: &Path, shaders: bool) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::format(dir, format!("cannot create the kernel folder: {e}")))?;
    let mut names = FileNames::default();
    let mut files = Vec::new();
    for f in &cmp.fitted {
        let label = format!("{} {}", f.material, f.spec.label);
        let stem = names.claim(
            format!("{}-{}", file_stem(&f.material), file_stem(&f.spec.label)),
            &label,
        )?;
        write_kernel(&f.kernel, dir, &stem, shaders, &mut files)?;
    }
    Ok(files)
}

/// Writes a kernel file (read back) and, with `shaders`, its three shader
/// arrays next to it.
fn write_kernel(
    kernel: &KernelFile,
    dir: &Path,
    stem: &str,
    shaders: bool,
    files: &mut Vec<String>,
) -> Result<()> {
    let path = join_inside(dir, &format!("{stem}.json"))?;
    kernel.write(&path)?;
    KernelFile::read(&path)?;
    files.push(format!("{stem}.json"));
    if !shaders {
        return Ok(());
    }
    for (lang, ext) in [
        (Lang::Hlsl, "hlsl"),
        (Lang::Glsl, "glsl"),
        (Lang::Wgsl, "wgsl"),
    ] {
        let name = format!("{stem}.{ext}");
        crate::io::write_atomic(&join_inside(dir, &name)?, emit(kernel, lang)?.as_bytes())?;
        files.push(name);
    }
    Ok(())
}

/// A disk kernel as `stem`.json with its shader arrays.
fn write_disk_kernel(
    kernel: &DiskKernelFile,
    dir: &Path,
    stem: &str,
    files: &mut Vec<String>,
) -> Result<()> {
    let path = join_inside(dir, &format!("{stem}.json"))?;
    kernel.write(&path)?;
    DiskKernelFile::read(&path)?;
    files.push(format!("{stem}.json"));
    for (lang, ext) in [
        (Lang::Hlsl, "hlsl"),
        (Lang::Glsl, "glsl"),
        (Lang::Wgsl, "wgsl"),
    ] {
        let name = format!("{stem}.{ext}");
        let text = crate::kernel::disk_emit::emit_disk(kernel, lang)?;
        crate::io::write_atomic(&join_inside(dir, &name)?, text.as_bytes())?;
        files.push(name);
    }
    Ok(())
}

/// Runs the pipeline on `profile` into `dir` (created). `command` is the
/// command line the report prints.
pub fn run(
    profile: &Profile,
    settings: &Settings,
    dir: &Path,
    command: &str,
    scene: Option<(&Scene, &Render)>,
    progress: &dyn Progress,
) -> Result<Outcome> {
    std::fs::create_dir_all(dir.join("kernels"))
        .map_err(|e| Error::format(dir, format!("cannot create the output folder: {e}")))?;
    let mut files = Vec::new();
    profile.write(&dir.join("profile.json"))?;
    Profile::read(&dir.join("profile.json"))?;
    files.push("profile.json".to_string());
    let name = profile.material.name.clone();
    let signals = [Signal::Edge, Signal::Shapes];
    let cases: Vec<ImageCase> = signals
        .iter()
        .map(|&s| ImageCase::signal(s, settings.size, settings.mm_per_pixel))
        .collect::<Result<_>>()?;
    let signal_names: Vec<String> = cases.iter().map(|c| c.name.clone()).collect();
    let options = Options::default();
    let ranks = vec![1, 2, 3];
    let cfg = Config {
        families: FAMILIES.iter().map(|s| s.to_string()).collect(),
        ranks: ranks.clone(),
        cases,
        taps: vec![settings.taps],
        options,
        keep: settings.plots.then_some(Which::Taps(settings.taps)),
        extent_mm: None,
    };
    let input = MaterialInput {
        name: name.clone(),
        profile: profile.clone(),
    };
    let cmp = kernel_compare::run(std::slice::from_ref(&input), &cfg, progress)?;
    files.extend(
        write_fitted_kernels(&cmp, &dir.join("kernels"), true)?
            .into_iter()
            .map(|f| format!("kernels/{f}")),
    );
    let factors = [Factor::Full, Factor::Taps(settings.taps)];
    let ctx = ReportContext {
        command,
        signals: &signal_names,
        factors: &factors,
        ranks: &ranks,
        options: &options,
    };
    let mut acfg = advise::Config::new(settings.mm_per_pixel, settings.target);
    acfg.size = settings.size;
    acfg.budget = settings.budget;
    let advice = advise::advise_on_scene(profile, &acfg, scene, &crate::progress::NoProgress)?;
    // The sheets open with what ships.
    let ship = if settings.plots {
        let cases: Vec<&ImageCase> = cmp.exact[0].iter().map(|e| &e.case).collect();
        Some(shipped(&advice, &cases)?)
    } else {
        None
    };
    files.extend(write_comparison(
        &cmp,
        &ctx,
        dir,
        settings.plots,
        &format!("{}-tap tables", settings.taps),
        ship.as_ref(),
    )?);
    if settings.plots {
        let panels = plot::profile_panels(&[(name.clone(), profile.clone())]);
        plot::render(
            &panels,
            2,
            &format!("R_d(r) of {name}"),
            &dir.join("profile.png"),
        )?;
        files.push("profile.png".into());
    }
    match &advice.disk_kernel {
        Some(k) => write_disk_kernel(k, dir, "recommended", &mut files)?,
        None => write_kernel(&advice.kernel, dir, "recommended", true, &mut files)?,
    }
    // The advice and why, where the comparison is read.
    let mut md = std::fs::read_to_string(dir.join("report.md"))
        .map_err(|e| Error::format(dir.join("report.md"), e.to_string()))?;
    // The scene's ranking in the report's first lines, under its title.
    if let Some(sc) = &advice.scene {
        let at = md.find('\n').map_or(md.len(), |i| i + 1);
        md.insert_str(at, &format!("\n{}\n", sc.headline()));
    }
    md.push_str(&format!(
        "\n## What to ship (recommended.json, advice.json)\n\n```text\n{}```\n",
        advice_text::explain(&advice)
    ));
    crate::io::write_atomic(&dir.join("report.md"), md.as_bytes())?;
    crate::io::write_json_atomic(&dir.join("advice.json"), &advice.to_json())?;
    let _: serde_json::Value = crate::io::read_json(&dir.join("advice.json"))?;
    files.push("advice.json".into());
    Ok(Outcome {
        comparison: cmp,
        advice,
        files,
    })
}

/// The one-screen summary: what to ship at this scale and how wrong it is,
/// the other models' errors with the same tap count, where the files are.
pub fn summary(o: &Outcome, settings: &Settings, source: &str, dir: &Path) -> String {
    use std::fmt::Write as _;
    let a = &o.advice;
    let c = a.chosen();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} at {} mm per pixel (profile: {source})",
        o.comparison.materials.join(", "),
        settings.mm_per_pixel
    );
    let rel = |e: &super::evaluate::ImageErrors| e.rel_rms.iter().cloned().fold(0.0, f64::max);
    let _ = writeln!(s, "ship: {} ({})", c.describe(), advice_text::cost_text(c));
    let _ = writeln!(
        s,
        "  worst case {:.2}% +- {:.2}% on {}, deciding signal {}; target {:.1}% {} within the \
         budget ({})",
        Bounded(100.0 * c.verdict.rel_rms),
        Bounded(100.0 * c.verdict.rel_rms_sigma),
        c.verdict.worst_signal,
        c.verdict.deciding_signal,
        Bounded(100.0 * a.target),
        if a.meets_target { "met" } else { "NOT met" },
        a.budget.describe()
    );
    if let Some(r) = &a.remedy {
        let _ = writeln!(s, "  {}", advice_text::remedy_text(r));
    }
    match &a.scene {
        Some(sc) => {
            let _ = writeln!(s, "  {}", sc.sentence());
        }
        None => {
            let _ = writeln!(
                s,
                "  scene: none given (--scene SCENE.toml --render IMG.exr scores the choice on a \
                 path-traced scene, with and without the entry and exit factors)"
            );
        }
    }
    for (sig, e) in &a.predicted {
        let _ = writeln!(
            s,
            "  {sig:<11} {:.2}% relative RMS (largest channel), FLIP {:.4}",
            Bounded(100.0 * rel(e)),
            e.flip_rgb
        );
    }
    for w in &a.warnings {
        let _ = writeln!(s, "  warning: {w}");
    }
    let _ = writeln!(
        s,
        "\nevery model with {} taps (largest relative RMS over channels, edge / shapes):",
        settings.taps
    );
    let _ = writeln!(
        s,
        "  {:<18} {:>6} {:>9} {:>9} {:>8}",
        "model", "passes", "edge", "shapes", "fit s"
    );
    for f in &o.comparison.fitted {
        let e = |i: usize| {
            f.images
                .get(i)
                .and_then(|x| x.taps.get(&settings.taps))
                .map_or(f64::NAN, &rel)
        };
        let _ = writeln!(
            s,
            "  {:<18} {:>6} {:>8.2}% {:>8.2}% {:>8.3}",
            f.spec.label,
            f.kernel.metrics.passes,
            Bounded(100.0 * e(0)),
            Bounded(100.0 * e(1)),
            f.kernel.metrics.fit_seconds
        );
    }
    let _ = writeln!(
        s,
        "\nfiles in {}: recommended.json (+ .hlsl .glsl .wgsl), advice.json, report.md, \
         compare.csv/json, kernels/ ({} models, each with shader arrays), profile.json{}",
        dir.display(),
        o.comparison.fitted.len(),
        if settings.plots { ", PNG plots" } else { "" }
    );
    s
}
