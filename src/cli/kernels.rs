//! `ssskit kernels`: the main job in one command. Profile, every kernel
//! model, shader arrays, the comparison report with plots, and what to ship.

use super::args::{
    self, BudgetArgs, EngineChoice, FramesArg, ImageErrorArg, ModelsArg, ProfileModel,
    ProfileSourceArgs, ReportArgs, SceneCheckArgs, TapsArg,
};
use super::out::out;
use super::profile_source::command_line;
use ssskit::report::eval::advise::ADVISED_FAMILIES;
use ssskit::report::pipeline::{self, Settings};

#[derive(clap::Args)]
#[command(
    mut_args(args::profile_source(ProfileModel::Mc)),
    mut_args(args::report())
)]
#[command(mut_arg("image_error", args::alias("--target-error")))]
#[command(mut_arg("models", |a| args::default(ADVISED_FAMILIES.join(","))(a)
    .help("Kernel models, comma-separated, or all: what ships is chosen from these (every \
           model is compared)")))]
#[command(mut_arg("mm_per_pixel", |a| a
    .default_value(None::<&str>)
    .help("Scale: surface millimetres per pixel [default: 0.1, or the scene's with --scene]")))]
#[command(mut_arg("engine", |a| a
    .help("Engine: its files are written beside recommended.json [default: none]")
    .long_help("Engine: its own subsurface model is fitted to the profile as `ssskit engine` \
                fits it by default, and its files (what `engine --out-dir` writes) are \
                written beside recommended.json; report.md says how to import them \
                [default: none]")))]
pub struct Args {
    #[command(flatten)]
    profile: ProfileSourceArgs,
    #[command(flatten)]
    report: ReportArgs,
    #[command(flatten)]
    taps: TapsArg,
    #[command(flatten)]
    target: ImageErrorArg,
    #[command(flatten)]
    budget: BudgetArgs,
    #[command(flatten)]
    scene: SceneCheckArgs,
    #[command(flatten)]
    factors: args::FactorsArg,
    #[command(flatten)]
    engine: EngineChoice,
    #[command(flatten)]
    frames: FramesArg,
    #[command(flatten)]
    models: ModelsArg,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let scene = super::scene::scene_check(&a.scene)?;
    let scene_mm = scene
        .as_ref()
        .map(|(s, r, _)| ssskit::report::eval::scene::compare::median_mm_per_pixel(s, r));
    let given = a.report.mm_per_pixel.mm_per_pixel;
    let mm_per_pixel = super::errors::positive(
        "--mm-per-pixel",
        given
            .or(scene_mm)
            .unwrap_or_else(|| a.report.mm_per_pixel.or_default()),
    )?;
    if let (Some(m), Some(_)) = (scene_mm, given) {
        super::scene::agrees_with_scene(mm_per_pixel, m)?;
    }
    ssskit::kernel::taps::check_count(a.taps.taps)?;
    let target = a.target.fraction()?;
    let engine = a.engine.engine.map(ssskit::engine::Engine::from);
    if let Some(e) = engine {
        ssskit::report::eval::ship::engine_step::check(e)?;
    }
    ssskit::report::eval::disk::check_frames(a.frames.frames)?;
    let out_dir = a.report.out_dir.path()?;
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(out_dir)?;
    let t0 = std::time::Instant::now();
    let (profile, source) = a
        .profile
        .load_for_scene(scene.as_ref().map(|(_, _, p)| p.as_slice()), &a.factors)?;
    let profile_seconds = t0.elapsed().as_secs_f64();
    eprintln!("{}: profile {source}", profile.material.name);
    let settings = Settings {
        mm_per_pixel,
        taps: a.taps.taps,
        target,
        budget: a.budget.budget(),
        size: a.report.signal_size.signal_size,
        plots: !a.report.no_plots.no_plots,
        engine,
        frames: a.frames.frames,
        families: a.models.families(),
    };
    let outcome = pipeline::run(
        &profile,
        profile_seconds,
        &settings,
        staged.path(),
        &command_line(out_dir),
        scene.as_ref().map(|(s, r, _)| (s, r)),
        &super::progress::Bar::new(),
    )?;
    staged.commit()?;
    out!(
        "{}",
        pipeline::summary(&outcome, &settings, &source, out_dir)
    )?;
    eprintln!(
        "{} files in {:.1} s",
        outcome.files.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
