//! The main job in one call: from a material to the kernels to ship. A
//! profile (Monte Carlo to the default kernel-factor rule, or an analytic model), every
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
    make_profile, make_profile_on, ProfileSource, MC_MAX_PHOTONS, MC_MAX_WORK, MC_SEED,
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
    /// Frames a disk kernel is scored on (`advise::Config::frames`).
    pub frames: u32,
    /// The model families the kernel to ship is chosen from
    /// (`advise::Config::families`); the comparison fits every model.
    pub families: Vec<String>,
}

/// What the pipeline produced.
pub struct Outcome {
    pub comparison: Comparison,
    pub advice: Advice,
    /// Files written, relative to the output folder.
    pub files: Vec<String>,
    pub stages: StageTimes,
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

/// Wall seconds of the main job's stages, as report.md's "Stage times"
/// shows them: the profile (made or read by the caller), the ground
/// truth, the fits, the comparison's images (exact and filtered), the
/// advice, and writing the files (before the report's last write); the
/// total runs from the profile's start to that write.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    pub profile: f64,
    pub truth: f64,
    pub fits: f64,
    pub images: f64,
    pub advice: f64,
    pub files: f64,
    pub total: f64,
}

impl StageTimes {
    /// The stages in order, with their seconds.
    pub fn stages(&self) -> [(&'static str, f64); 6] {
        [
            ("profile", self.profile),
            ("truth", self.truth),
            ("fits", self.fits),
            ("images", self.images),
            ("advice", self.advice),
            ("files", self.files),
        ]
    }

    /// The report's table: one row per stage and the total.
    pub fn markdown(&self) -> String {
        let mut t = crate::report::present::table::Table::new(&["stage", "wall s"]);
        for (name, s) in self.stages().into_iter().chain([("total", self.total)]) {
            // Milliseconds, so that the rows add up as the numbers do.
            t.push(vec![name.to_string(), format!("{s:.3}")]);
        }
        t.markdown()
    }
}

/// Runs the pipeline on `profile` (made in `profile_seconds`) into `dir`
/// (created). `command` is the command line the report prints. The truth
/// and each model's fit are made once, by the comparison, and the advice
/// scores and writes those same fits.
pub fn run(
    profile: &Profile,
    profile_seconds: f64,
    settings: &Settings,
    dir: &Path,
    command: &str,
    scene: Option<(&Scene, &Render)>,
    progress: &dyn Progress,
) -> Result<Outcome> {
    let t0 = std::time::Instant::now();
    let mut times = StageTimes {
        profile: profile_seconds,
        ..StageTimes::default()
    };
    let mut files = Vec::new();
    let t = std::time::Instant::now();
    std::fs::create_dir_all(dir.join("kernels"))
        .map_err(|e| Error::format(dir, format!("cannot create the output folder: {e}")))?;
    profile.write(&dir.join("profile.json"))?;
    Profile::read(&dir.join("profile.json"))?;
    files.push("profile.json".to_string());
    times.files += t.elapsed().as_secs_f64();
    let name = profile.material.name.clone();
    let cases: Vec<ImageCase> = [Signal::Edge, Signal::Shapes]
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
        // The default grid: the one the advice's truth is made on.
        extent_mm: None,
    };
    let input = MaterialInput {
        name: name.clone(),
        profile: profile.clone(),
    };
    let cmp = kernel_compare::run(std::slice::from_ref(&input), &cfg, progress)?;
    (times.truth, times.fits, times.images) =
        (cmp.seconds.truth, cmp.seconds.fits, cmp.seconds.images);
    let t = std::time::Instant::now();
    let mut acfg = advise::Config::new(settings.mm_per_pixel, settings.target);
    acfg.size = settings.size;
    acfg.budget = settings.budget;
    acfg.frames = settings.frames;
    acfg.families = settings.families.clone();
    let prepared = advise::Prepared {
        truth: cmp.truths[0].clone(),
        fits: cmp.fits[0].clone(),
    };
    let advice = advise::advise_prepared(
        profile,
        &acfg,
        scene,
        Some(prepared),
        &crate::progress::NoProgress,
    )?;
    times.advice = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let ctx = ReportContext {
        command,
        signals: &signal_names,
        factors: &[Factor::Full, Factor::Taps(settings.taps)],
        ranks: &ranks,
        options: &options,
    };
    write_files(&cmp, &advice, &ctx, settings, dir, &mut files)?;
    times.files += t.elapsed().as_secs_f64();
    times.total = profile_seconds + t0.elapsed().as_secs_f64();
    write_report(&advice, &times, dir, &mut files)?;
    Ok(Outcome {
        comparison: cmp,
        advice,
        files,
        stages: times,
    })
}

/// Every file but the report's last form: the kernels, the comparison
/// (report.md's first form, tables, plots), the profile plot, the
/// recommended kernel.
fn write_files(
    cmp: &Comparison,
    advice: &Advice,
    ctx: &ReportContext,
    settings: &Settings,
    dir: &Path,
    files: &mut Vec<String>,
) -> Result<()> {
    files.extend(
        write_fitted_kernels(cmp, &dir.join("kernels"), true)?
            .into_iter()
            .map(|f| format!("kernels/{f}")),
    );
    // The sheets open with what ships.
    let ship = if settings.plots {
        let cases: Vec<&ImageCase> = cmp.exact[0].iter().map(|e| &e.case).collect();
        Some(shipped(advice, &cases)?)
    } else {
        None
    };
    files.extend(write_comparison(
        cmp,
        ctx,
        dir,
        settings.plots,
        &format!("{}-tap tables", settings.taps),
        ship.as_ref(),
    )?);
    if settings.plots {
        let (name, profile) = (&cmp.materials[0], &cmp.profiles[0]);
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
        Some(k) => write_disk_kernel(k, dir, "recommended", files),
        None => write_kernel(&advice.kernel, dir, "recommended", true, files),
    }
}

/// report.md with the scene's ranking under its title, the advice and
/// why, and the stage times; advice.json (read back).
fn write_report(
    advice: &Advice,
    times: &StageTimes,
    dir: &Path,
    files: &mut Vec<String>,
) -> Result<()> {
    let mut md = std::fs::read_to_string(dir.join("report.md"))
        .map_err(|e| Error::format(dir.join("report.md"), e.to_string()))?;
    if let Some(sc) = &advice.scene {
        let at = md.find('\n').map_or(md.len(), |i| i + 1);
        md.insert_str(at, &format!("\n{}\n", sc.headline()));
    }
    md.push_str(&format!(
        "\n## What to ship (recommended.json, advice.json)\n\n```text\n{}```\n",
        advice_text::explain(advice)
    ));
    md.push_str(&format!(
        "\n## Stage times\n\nWall seconds of this run's stages; the truth and each fit \
         were made once, for the comparison, and the advice scored those same fits.\n\n{}",
        times.markdown()
    ));
    crate::io::write_atomic(&dir.join("report.md"), md.as_bytes())?;
    crate::io::write_json_atomic(&dir.join("advice.json"), &advice.to_json())?;
    let _: serde_json::Value = crate::io::read_json(&dir.join("advice.json"))?;
    files.push("advice.json".into());
    Ok(())
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
    if let Some(acc) = a.disk_kernel.as_ref().and_then(|k| k.accumulation.as_ref()) {
        let _ = writeln!(
            s,
            "  recommended.json records what the prediction assumes, {}: `ssskit apply` runs it \
             by default",
            acc.describe()
        );
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
