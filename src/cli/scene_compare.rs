//! `compare --scene`: every kernel model through the screen-space pass on
//! a render's G-buffer (`ssskit scene`), against the path-traced image;
//! the back-lit rows, the light-space method and the contact sheets.

use super::out::outln;
use super::progress::Bar;
use super::scene::scene_and_render;
use anyhow::{bail, Context};
use ssskit::scene::{Render, Scene};
use std::path::Path;

/// What `compare --scene` passes on.
pub(super) struct CompareArgs<'a> {
    pub scene: &'a Path,
    pub render: &'a Path,
    pub families: Vec<String>,
    pub ranks: Vec<usize>,
    pub taps: Vec<usize>,
    pub pixels_per_degree: f64,
    pub size: usize,
    pub follow_mm: Option<f64>,
    /// Photons per channel and incidence of the angular factors (0: none).
    pub angular_photons: u64,
    /// Thickness table of the scene's object: the back-lit rows.
    pub transmission: Option<&'a Path>,
    pub seed: u64,
    pub plots: bool,
    pub out: &'a Path,
    /// The light-space directional method's rows (None: not run).
    pub directional: Option<ssskit::report::eval::scene::directional::DirectionalConfig>,
}

/// The light-space method's checks on the scene, before any work: its
/// warnings, or (the method refused) the reason, said on stderr, and the
/// comparison then runs without it.
fn directional_preflight(
    scene: &Scene,
    r: &Render,
    cfg: Option<ssskit::report::eval::scene::directional::DirectionalConfig>,
) -> Option<ssskit::report::eval::scene::directional::DirectionalConfig> {
    let d = cfg?;
    let most = d.samples.iter().copied().max().unwrap_or(1);
    let side = r.info.config.gbuffer_side;
    match ssskit::filter::light_space::preflight(scene, d.map_side, side, most) {
        Ok(warnings) => {
            for w in warnings {
                super::errors::warn(&format!("light-space directional method: {w}"));
            }
            Some(d)
        }
        Err(e) => {
            super::errors::warn(&format!("no light-space directional rows: {e}"));
            None
        }
    }
}

/// The entry and exit factors of the scene's material from `photons` per
/// channel and incidence (None for 0, or when the scene's lights leave
/// nothing for them to weigh: said on stderr).
fn angular_factors(
    scene: &Scene,
    photons: u64,
    seed: u64,
) -> anyhow::Result<Option<ssskit::kernel::angular::AngularFactors>> {
    if photons == 0 {
        return Ok(None);
    }
    if let Some(why) = ssskit::report::eval::scene::compare::angular_obstacle(scene) {
        super::errors::warn(&format!("{why}: no angular rows"));
        return Ok(None);
    }
    let material = &scene.objects[0].material;
    let f = ssskit::kernel::angular::simulate_factors(material, photons, seed, None, &Bar::new())
        .with_context(|| format!("the angular factors of {}", material.name))?;
    Ok(Some(f))
}

/// scene.json of `compare --scene`: the comparison's numbers, the
/// light-space block (or why the scene has none) and the transmission's.
fn scene_json(
    scene: &std::path::Path,
    cmp: &ssskit::report::eval::scene::compare::SceneComparison,
    r: &ssskit::scene::Render,
    transmission: Option<serde_json::Value>,
) -> anyhow::Result<serde_json::Value> {
    use ssskit::report::eval::scene::compare::dominance;
    Ok(serde_json::json!({
        "scene": scene.display().to_string(),
        "dominance": dominance(cmp),
        "mm_per_pixel": cmp.mm_per_pixel,
        "follow_mm": cmp.follow_mm,
        "follow_constant": cmp.follow_constant,
        "noise": cmp.noise,
        "angular": cmp.angular,
        "angular_note": cmp.angular_note,
        "spp": r.info.spp,
        "rows": cmp.rows,
        "directional": match &cmp.directional {
            Some(Ok(b)) => serde_json::to_value(b)?,
            Some(Err(why)) => serde_json::json!({ "refused": why }),
            None => serde_json::Value::Null,
        },
        "transmission": transmission,
    }))
}

/// `compare --scene`: the screen-space error of every kernel model on the
/// scene's G-buffer against its path-traced image; writes scene.md,
/// scene.json, record.json and the contact sheet.
pub(super) fn compare(a: CompareArgs) -> anyhow::Result<()> {
    use ssskit::report::eval::scene::compare::{compare_scene, SceneConfig};
    use ssskit::report::present::record::{machine_line, Record};
    use ssskit::report::present::scene_tables::{contact_sheet, named_tables, page};
    let (scene, r, profiles) = scene_and_render(a.scene, a.render)?;
    let Some(profile) = profiles.first() else {
        bail!(
            "--render {}: its record holds no profile",
            a.render.display()
        );
    };
    let directional = directional_preflight(&scene, &r, a.directional);
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(a.out)
        .with_context(|| format!("--out-dir {}", a.out.display()))?;
    let dir = staged.path();
    let cfg = SceneConfig {
        families: a.families,
        ranks: a.ranks,
        taps: a.taps,
        options: ssskit::report::eval::evaluate::Options {
            round_to_f32: true,
            pixels_per_degree: a.pixels_per_degree,
        },
        follow_mm: a.follow_mm,
        signal_size: a.size,
        keep_images: a.plots,
        angular: angular_factors(&scene, a.angular_photons, a.seed)?,
        directional,
    };
    let cmp = compare_scene(&scene, &r, profile, &cfg, &Bar::new())?;
    let head = format!(
        "Scene {}: {}x{} pixels, {} samples per pixel (r), {:.3} mm per pixel at the object's \
         median depth; the lerp completes at a depth difference of {:.3} mm (C = {:.4} in the \
         pass's convention).",
        a.scene.display(),
        r.width,
        r.height,
        r.info.spp[0],
        cmp.mm_per_pixel,
        cmp.follow_mm,
        cmp.follow_constant
    );
    use ssskit::report::present::directional_tables as dt;
    let back = a
        .transmission
        .map(|t| super::transmission::scene_block(&scene, &r, profile, t, a.pixels_per_degree))
        .transpose()?;
    let mut tables = named_tables(&cmp);
    tables.extend(dt::named_table(&cmp));
    let mut md = page(&cmp, &head) + &dt::section(&cmp);
    if let Some((b, t)) = &back {
        md = format!("{}\n\n{}\n\n{md}", b.headline, t.markdown());
        tables.push(("transmission", t.clone()));
    }
    ssskit::io::write_atomic(&dir.join("scene.md"), md.as_bytes())?;
    let transmission = back
        .as_ref()
        .map(|b| serde_json::to_value(&b.0))
        .transpose()?;
    let json = scene_json(a.scene, &cmp, &r, transmission)?;
    let text = serde_json::to_string_pretty(&json)? + "\n";
    ssskit::io::write_atomic(&dir.join("scene.json"), text.as_bytes())?;
    let mut rec = Record::new(&super::profile_source::command_line(a.out), &machine_line());
    for (name, t) in &tables {
        rec.tables.insert(name.to_string(), t.into());
    }
    rec.data = json;
    rec.write(&dir.join("record.json"))?;
    if a.plots {
        let name = a.scene.file_name().map_or_else(
            || a.scene.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        contact_sheet(&cmp, &name, &dir.join("contact-sheet.png"))?;
        if let Some((b, _)) = &back {
            ssskit::report::present::transmission_plots::scene_sheet(
                b,
                &cmp,
                &format!(
                    "{name}: lit from behind, each way to show it above |image - path traced|"
                ),
                &dir.join("transmission-sheet.png"),
            )?;
        }
    }
    staged.commit()?;
    print_compare(&cmp, back.as_ref(), &head, &tables)?;
    eprintln!(
        "-> {}/scene.md, scene.json, record.json{}",
        a.out.display(),
        if a.plots { ", contact-sheet.png" } else { "" }
    );
    Ok(())
}

/// `scene compare`'s answer on standard output: a transmission table asked
/// for by flag first, then the directional verdict (the first line when no
/// table is asked for), the head and the main table.
fn print_compare(
    cmp: &ssskit::report::eval::scene::compare::SceneComparison,
    back: Option<&(
        ssskit::report::eval::scene::transmission::TransmissionComparison,
        ssskit::report::present::table::Table,
    )>,
    head: &str,
    tables: &[(&str, ssskit::report::present::table::Table)],
) -> anyhow::Result<()> {
    use ssskit::report::eval::scene::compare::dominance;
    use ssskit::report::present::directional_tables as dt;
    if let Some((b, t)) = back {
        outln!("{}\n\n{}\n", b.headline, t.markdown())?;
    }
    if let Some(h) = dt::headline(cmp) {
        outln!("{h}\n")?;
    }
    let d = dominance(cmp);
    if let Some(h) = d.as_ref().and_then(|d| d.headline()) {
        outln!("{h}")?;
    }
    outln!("{head}\n\n{}", tables[0].1.markdown())?;
    if let Some((_, t)) = tables.iter().find(|(n, _)| *n == "directional") {
        outln!(
            "Light-space directional method beside the screen-space passes:\n\n{}",
            t.markdown()
        )?;
    }
    if let Some(d) = d {
        outln!("{}", d.sentence())?;
    }
    Ok(())
}
