//! The main job in one call: from a material to the kernels to ship. A
//! profile (Monte Carlo to the default kernel-factor rule, or an analytic model), every
//! kernel model fitted and compared in kernel and image space
//! ([`crate::report::eval::compare::kernel`]), shader arrays for each, the report with its
//! plots, and the configuration [`crate::report::eval::advise`] picks at the given scale.

use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::filter::Which;
use crate::io::{file_stem, join_inside};
use crate::numerics::Bounded;
use crate::profile::Profile;
use crate::progress::{Clock, Progress};
use crate::report::eval::advise::{self, Advice};
use crate::report::eval::compare::engine_tables::{engine_tables, EngineTables};
use crate::report::eval::compare::kernel::{Comparison, Config, MaterialInput, Row, FAMILIES};
use crate::report::eval::compare::sheets::{disk_annuli, rebuilt, sheet_tiles, slice_kernels};
use crate::report::eval::compare::{self, claims};
use crate::report::eval::evaluate::{ImageCase, Options};
use crate::report::eval::radial::profile_figure;
use crate::report::eval::ship::preview::{self, Preview, PreviewKernel};
use crate::report::eval::ship::shipped::{shipped, Shipped};
use crate::report::eval::ship::stage_times::StageTimes;
use crate::report::kernel_files::{
    write_disk_kernel, write_fitted_kernels, write_kernel, FileNames,
};
use crate::report::present::figures::{self, Figure};
use crate::report::present::kernel_plots::{self, Recommended};
use crate::report::present::kernel_report::{self, ReportContext};
use crate::report::present::ship_report::{self, ShipReport};
use crate::report::present::{advice_text, engine_section, plot, preview_panel};
use crate::scene::{Render, Scene};
use std::path::Path;

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
    /// The engine whose files are written beside recommended.json
    /// ([`crate::report::eval::ship::engine_step`]).
    pub engine: Option<crate::engine::Engine>,
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
    /// The engine step, where asked.
    pub engine: Option<crate::report::eval::ship::engine_step::EngineStep>,
}

/// The comparison's files in `dir` but report.md: compare.csv,
/// compare.json (read back), and with `plots` the kernel slices (with
/// `recommended` where given), one contact sheet per signal (opening with
/// `shipped` where given, else the best model) and the singular value
/// spectra; with the report's markdown (tiles of the wrong colour listed)
/// and each figure's caption.
pub struct Written {
    pub files: Vec<String>,
    pub figures: Vec<Figure>,
    pub markdown: String,
}

/// Writes the comparison's files (see [`Written`]).
pub fn comparison_files(
    cmp: &Comparison,
    ctx: &ReportContext,
    dir: &Path,
    plots: bool,
    sheet_factor: &str,
    (shipped, recommended): (Option<&Shipped>, Option<&Recommended>),
    engines: &EngineTables,
) -> Result<Written> {
    let mut files = vec!["compare.csv".to_string(), "compare.json".into()];
    let mut figs = Vec::new();
    let claims = claims::claims(cmp, ctx.signals, ctx.factors, ctx.ranks);
    let mut md = kernel_report::report(cmp, ctx, engines, &claims);
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
        let lead = if shipped.is_some() {
            "what ships"
        } else {
            "the model of lowest error on it"
        };
        for m in &cmp.materials {
            let stem = file_stem(m);
            for (ci, s) in ctx.signals.iter().enumerate() {
                let label = format!("{m} {s}");
                let name = names.claim(format!("sheet_{stem}_{}.png", file_stem(s)), &label)?;
                let path = join_inside(dir, &name)?;
                let opening = shipped.map(|sh| (sh.label.as_str(), sh.images.as_slice()));
                let tiles = sheet_tiles(cmp, m, ci, opening)?;
                let sheet = kernel_plots::contact_sheet(&tiles, sheet_factor, &path)?;
                flags.extend(sheet.flags);
                let mm = cmp
                    .exact
                    .first()
                    .and_then(|e| e.get(ci))
                    .map_or(f64::NAN, |e| e.case.mm_per_pixel);
                figs.push(figures::sheet(&name, s, mm, lead, sheet_factor));
                files.push(name);
            }
            let name = names.claim(format!("slices_{stem}.png"), m)?;
            let kernels = slice_kernels(cmp, m)?;
            kernel_plots::kernel_slices(&kernels, recommended, &join_inside(dir, &name)?)?;
            let disk = recommended.map(|r| matches!(r, Recommended::Disk { .. }));
            figs.push(figures::slices(&name, m, disk));
            files.push(name);
        }
        if cmp.fitted.iter().any(|f| f.kernel.model.name == "svd") {
            kernel_plots::spectra(cmp, &dir.join("spectra.png"))?;
            figs.push(figures::spectra("spectra.png"));
            files.push("spectra.png".into());
        }
        md.push_str(&kernel_plots::flags_markdown(&flags));
    }
    Ok(Written {
        files,
        figures: figs,
        markdown: md,
    })
}

/// The comparison's written form in `dir` (`compare`): its files
/// ([`comparison_files`]) and report.md with the list of its figures.
/// Returns the file names written.
pub fn write_comparison(
    cmp: &Comparison,
    ctx: &ReportContext,
    dir: &Path,
    plots: bool,
    sheet_factor: &str,
) -> Result<Vec<String>> {
    let engines = engine_tables(&cmp.materials, &cmp.profiles);
    let w = comparison_files(cmp, ctx, dir, plots, sheet_factor, (None, None), &engines)?;
    let mut md = w.markdown;
    if !w.figures.is_empty() {
        md.push_str(&figures::markdown(&w.figures));
    }
    crate::io::write_atomic(&dir.join("report.md"), md.as_bytes())?;
    let mut files = vec!["report.md".to_string()];
    files.extend(w.files);
    Ok(files)
}

/// The output folder with its `kernels/` and the profile, read back.
fn write_profile(profile: &Profile, dir: &Path, files: &mut Vec<String>) -> Result<()> {
    std::fs::create_dir_all(dir.join("kernels"))
        .map_err(|e| Error::format(dir, format!("cannot create the output folder: {e}")))?;
    profile.write(&dir.join("profile.json"))?;
    Profile::read(&dir.join("profile.json"))?;
    files.push("profile.json".to_string());
    Ok(())
}

/// The main job's comparison: the edge and shapes signals at the scale,
/// every family, ranks 1 to 3, the stored tap count.
fn comparison_config(settings: &Settings) -> Result<Config> {
    let cases: Vec<ImageCase> = [Signal::Edge, Signal::Shapes]
        .iter()
        .map(|&s| ImageCase::signal(s, settings.size, settings.mm_per_pixel))
        .collect::<Result<_>>()?;
    Ok(Config {
        families: FAMILIES.iter().map(|s| s.to_string()).collect(),
        ranks: vec![1, 2, 3],
        cases,
        taps: vec![settings.taps],
        options: Options::default(),
        keep: settings.plots.then_some(Which::Taps(settings.taps)),
        // The default grid: the one the advice's truth is made on.
        extent_mm: None,
    })
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
    let t0 = Clock::start();
    let mut times = StageTimes {
        profile: profile_seconds,
        ..StageTimes::default()
    };
    times.cpu[0] = crate::progress::process_cpu_seconds();
    let mut files = Vec::new();
    let t = Clock::start();
    write_profile(profile, dir, &mut files)?;
    let files_clock = t.elapsed();
    let name = profile.material.name.clone();
    let cfg = comparison_config(settings)?;
    let signal_names: Vec<String> = cfg.cases.iter().map(|c| c.name.clone()).collect();
    let input = MaterialInput {
        name: name.clone(),
        profile: profile.clone(),
    };
    let cmp = compare::kernel::run(std::slice::from_ref(&input), &cfg, progress)?;
    (times.truth, times.fits, times.images) =
        (cmp.seconds.truth, cmp.seconds.fits, cmp.seconds.images);
    times.cpu[1..4].copy_from_slice(&cmp.seconds.cpu);
    let t = Clock::start();
    // The engine tables fill the cores the advice's serial steps leave.
    let (advice, engines) = rayon::join(
        || advice_on(profile, settings, &cmp, scene, progress),
        || engine_tables(&cmp.materials, &cmp.profiles),
    );
    let advice = advice?;
    (times.advice, times.cpu[4]) = t.elapsed();
    let ctx = ReportContext {
        command,
        signals: &signal_names,
        factors: &[Which::Full, Which::Taps(settings.taps)],
        ranks: &cfg.ranks,
        options: &cfg.options,
    };
    let (preview, pieces) = preview_and_files(
        Shared {
            profile,
            settings,
            dir,
            progress,
        },
        (&cmp, &advice, &ctx, &engines),
        &mut times,
        &mut files,
        files_clock,
    )?;
    let engine = engine_files(settings, profile, dir, progress, &mut times, &mut files)?;
    let (wall, cpu) = t0.elapsed();
    (times.total, times.cpu[7]) = (profile_seconds + wall, times.cpu[0] + cpu);
    let engine_md = engine
        .as_ref()
        .map(|step| engine_section::section(&step.section()));
    let report = ShipReport {
        advice: &advice,
        material: &name,
        command,
        stem: RECOMMENDED,
        preview: preview
            .as_ref()
            .map(|p| p.as_ref().map(|p| (p, PREVIEW_PNG)).map_err(Clone::clone)),
        sheet: pieces.sheet.as_ref(),
        figures: &pieces.figures,
        comparison: &pieces.markdown,
        engine: engine_md.as_deref(),
        stage_times: &ship_report::stage_table(&times),
    };
    write_report(&advice, &ship_report::report(&report), dir, &mut files)?;
    progress.set_total(files.len() as u64);
    progress.advance(files.len() as u64);
    progress.finish();
    Ok(Outcome {
        comparison: cmp,
        advice,
        files,
        stages: times,
        engine,
    })
}

/// What the last steps of [`run`] share.
struct Shared<'a> {
    profile: &'a Profile,
    settings: &'a Settings,
    dir: &'a Path,
    progress: &'a dyn Progress,
}

/// The preview (a path trace) and the files (mostly one thread) at once:
/// the preview's stage ends with it, the files' runs on from there (and
/// holds `files_clock`, the profile's file written before the comparison).
#[allow(clippy::type_complexity)]
fn preview_and_files(
    sh: Shared,
    (cmp, advice, ctx, engines): (&Comparison, &Advice, &ReportContext, &EngineTables),
    times: &mut StageTimes,
    files: &mut Vec<String>,
    files_clock: (f64, f64),
) -> Result<(Option<std::result::Result<Preview, String>>, Pieces)> {
    let Shared {
        profile,
        settings,
        dir,
        progress,
    } = sh;
    let t = Clock::start();
    let mut written = Vec::new();
    let ((preview, preview_clock), pieces) = rayon::join(
        || {
            let p = settings
                .plots
                .then(|| preview_of(profile, advice, progress));
            (p.transpose(), t.elapsed())
        },
        || write_files(cmp, advice, ctx, settings, dir, engines, &mut written),
    );
    let (preview, mut pieces) = (preview?, pieces?);
    (times.preview, times.cpu[5]) = preview_clock;
    progress.start(0, "report and files");
    files.extend(written);
    if let Some(Ok(p)) = &preview {
        preview_panel::preview_panel(p, &dir.join(PREVIEW_PNG))?;
        pieces
            .figures
            .insert(0, preview_panel::figure(p, PREVIEW_PNG));
        files.push(PREVIEW_PNG.into());
    }
    let (wall, cpu) = t.elapsed();
    let (wall, cpu) = (wall - times.preview, cpu - times.cpu[5]);
    (times.files, times.cpu[6]) = (files_clock.0 + wall, files_clock.1 + cpu);
    Ok((preview, pieces))
}

/// The advice on the comparison's own truth and fits (made once).
fn advice_on(
    profile: &Profile,
    settings: &Settings,
    cmp: &Comparison,
    scene: Option<(&Scene, &Render)>,
    progress: &dyn Progress,
) -> Result<Advice> {
    let mut acfg = advise::Config::new(settings.mm_per_pixel, settings.target);
    acfg.size = settings.size;
    acfg.budget = settings.budget;
    acfg.frames = settings.frames;
    acfg.families = settings.families.clone();
    let prepared = advise::Prepared {
        truth: cmp.truths[0].clone(),
        fits: cmp.fits[0].clone(),
    };
    advise::advise_prepared(profile, &acfg, scene, Some(prepared), progress)
}

/// The engine's fit and files beside the kernel where asked (`kernels
/// --engine`, [`crate::report::eval::ship::engine_step`]), timed as the engine stage.
fn engine_files(
    settings: &Settings,
    profile: &Profile,
    dir: &Path,
    progress: &dyn Progress,
    times: &mut StageTimes,
    files: &mut Vec<String>,
) -> Result<Option<crate::report::eval::ship::engine_step::EngineStep>> {
    let Some(e) = settings.engine else {
        return Ok(None);
    };
    let t = Clock::start();
    let step = crate::report::eval::ship::engine_step::run(e, profile, dir, progress)?;
    files.extend(step.files.iter().map(|f| f.0.clone()));
    times.engine = Some(t.elapsed());
    Ok(Some(step))
}

/// The recommended kernel's file stem.
const RECOMMENDED: &str = "recommended";
/// The preview's file.
const PREVIEW_PNG: &str = "preview.png";

/// The material's preview with what ships, or why the scene tracer cannot
/// render the material.
fn preview_of(
    profile: &Profile,
    advice: &Advice,
    progress: &dyn Progress,
) -> Result<std::result::Result<Preview, String>> {
    progress.start(1, "preview");
    let p = match preview::obstacle(profile) {
        Some(why) => Err(why),
        None => Ok(preview::preview(profile, &PreviewKernel::shipped(advice))?),
    };
    progress.advance(1);
    progress.finish();
    Ok(p)
}

/// What report.md is made of besides the advice: the comparison's
/// markdown, the figures with their captions and the sheet its first
/// screen points to.
struct Pieces {
    markdown: String,
    figures: Vec<Figure>,
    sheet: Option<Figure>,
}

/// Every file but report.md and advice.json: the kernels, the comparison
/// (tables, plots), the profile plot, the recommended kernel.
fn write_files(
    cmp: &Comparison,
    advice: &Advice,
    ctx: &ReportContext,
    settings: &Settings,
    dir: &Path,
    engines: &EngineTables,
    files: &mut Vec<String>,
) -> Result<Pieces> {
    files.extend(
        write_fitted_kernels(cmp, &dir.join("kernels"), true)?
            .into_iter()
            .map(|f| format!("kernels/{f}")),
    );
    // The sheets open with what ships, the slices show it.
    let ship = if settings.plots {
        let cases: Vec<&ImageCase> = cmp.exact[0].iter().map(|e| &e.case).collect();
        Some(shipped(advice, &cases)?)
    } else {
        None
    };
    // Only the plots read the recommended kernel (a separable one rebuilt
    // in 2D from its factors).
    let recommended = settings.plots.then(|| {
        let label = advice.chosen().describe();
        match &advice.disk_kernel {
            Some(kernel) => Recommended::Disk {
                label,
                annuli: std::array::from_fn(|c| disk_annuli(kernel, c)),
            },
            None => Recommended::Separable {
                label,
                kernel: rebuilt(&advice.kernel),
            },
        }
    });
    let w = comparison_files(
        cmp,
        ctx,
        dir,
        settings.plots,
        &format!("{}-tap tables", settings.taps),
        (ship.as_ref(), recommended.as_ref()),
        engines,
    )?;
    files.extend(w.files);
    let mut figs = w.figures;
    if settings.plots {
        let (name, profile) = (&cmp.materials[0], &cmp.profiles[0]);
        let profiles = [(name.clone(), profile.clone())];
        let panels = plot::profile_panels(&profile_figure(&profiles));
        plot::render(
            &panels,
            2,
            &format!("R_d(r) of {name}"),
            &dir.join("profile.png"),
        )?;
        figs.push(figures::profile("profile.png", name));
        files.push("profile.png".into());
    }
    match &advice.disk_kernel {
        Some(k) => write_disk_kernel(k, dir, RECOMMENDED, files)?,
        None => write_kernel(&advice.kernel, dir, RECOMMENDED, true, files)?,
    }
    let sheet = figs
        .iter()
        .find(|f| f.file.starts_with("sheet_") && f.file.ends_with("_shapes.png"))
        .or_else(|| figs.iter().find(|f| f.file.starts_with("sheet_")))
        .cloned();
    Ok(Pieces {
        markdown: w.markdown,
        figures: figs,
        sheet,
    })
}

/// report.md (`md`) and advice.json (read back).
fn write_report(advice: &Advice, md: &str, dir: &Path, files: &mut Vec<String>) -> Result<()> {
    crate::io::write_atomic(&dir.join("report.md"), md.as_bytes())?;
    files.push("report.md".into());
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
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} at {} mm per pixel (profile: {source})",
        o.comparison.materials.join(", "),
        settings.mm_per_pixel
    );
    let rel = |e: &crate::report::eval::evaluate::ImageErrors| {
        e.rel_rms.iter().cloned().fold(0.0, f64::max)
    };
    let _ = writeln!(s, "ship: {}", advice_text::ship_text(a));
    let _ = writeln!(s, "  {}", advice_text::worst_case_text(a));
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
    if let Some(step) = &o.engine {
        let names: Vec<&str> = step.files.iter().map(|f| f.0.as_str()).collect();
        let _ = writeln!(
            s,
            "{} files: {} (how to import them: report.md, \"Into {}\")",
            step.fit.engine,
            names.join(", "),
            step.fit.engine
        );
    }
    s
}
