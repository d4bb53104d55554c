//! `ssskit materials`: the presets and their derived quantities.

use super::args::JsonArg;
use super::out::outln;
use ssskit::material::{preset, preset_names, Channel, Material};

#[derive(clap::Args)]
pub struct Args {
    /// Show only these presets or material files [default: all presets].
    #[arg(value_name = "NAME")]
    names: Vec<String>,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mats: Vec<Material> = if args.names.is_empty() {
        preset_names().iter().filter_map(|n| preset(n)).collect()
    } else {
        args.names
            .iter()
            .map(|n| Material::load(n))
            .collect::<Result<_, _>>()?
    };
    if args.json.json {
        let rows: Vec<_> = mats.iter().map(derived_json).collect();
        outln!("{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    outln!(
        "{:<12} {:>2} {:>9} {:>9} {:>6} {:>5} {:>8} {:>8} {:>9} {:>9}",
        "material",
        "ch",
        "sigma_a",
        "sigma_s",
        "g",
        "eta",
        "albedo",
        "albedo'",
        "MFP mm",
        "1/s_tr mm"
    )?;
    for m in &mats {
        for (i, _) in m.layers.iter().enumerate() {
            for ch in Channel::ALL {
                let md = m.medium(i, ch);
                let label = if m.layers.len() > 1 {
                    format!("{}[{i}]", m.name)
                } else {
                    m.name.clone()
                };
                outln!(
                    "{:<12} {:>2} {:>9.4} {:>9.4} {:>6.3} {:>5.2} {:>8.5} {:>8.5} {:>9.4} {:>9.4}",
                    label,
                    ch.name(),
                    md.sigma_a,
                    md.sigma_s,
                    md.g,
                    md.eta,
                    md.albedo(),
                    md.reduced_albedo(),
                    md.mfp(),
                    1.0 / md.sigma_tr()
                )?;
            }
        }
    }
    Ok(())
}

fn derived_json(m: &Material) -> serde_json::Value {
    let per = |f: &dyn Fn(ssskit::material::Medium) -> f64| -> Vec<f64> {
        Channel::ALL.iter().map(|&c| f(m.top(c))).collect()
    };
    serde_json::json!({
        "material": m,
        "albedo": per(&|x| x.albedo()),
        "reduced_albedo": per(&|x| x.reduced_albedo()),
        "mfp_mm": per(&|x| x.mfp()),
        "inv_sigma_tr_mm": per(&|x| 1.0 / x.sigma_tr()),
    })
}
