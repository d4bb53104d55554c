//! The light-space directional method's flags, shared by `compare` and
//! `advise`.

use super::values::count;

/// `--directional-spp` and `--light-map-side`: the light-space directional
/// method on a scene (`compare --scene`, `advise --scene`).
#[derive(clap::Args)]
pub struct DirectionalArgs {
    /// Samples per pixel and channel of the light-space directional method on --scene, comma-separated; 0: none.
    ///
    /// Scattered radiosity from the lights' G-buffers with the full
    /// directional dipole (Dal Corso et al. 2017; docs/directional.md),
    /// against the path-traced image: each count gets rows beside the best
    /// screen-space model at half as many taps per pass and a disk kernel
    /// of as many samples, with their cost.
    #[arg(long, value_name = "N,...", value_delimiter = ',', requires = "scene",
          default_value = (2 * ssskit::kernel::taps::DEFAULT_TAPS).to_string(),
          value_parser = count::<usize>)]
    pub directional_spp: Vec<usize>,
    /// Texels per side of the light-space method's light maps.
    #[arg(long, value_name = "N", requires = "scene", value_parser = count::<usize>,
          default_value_t = ssskit::filter::light_space::DEFAULT_LIGHT_MAP_SIDE)]
    pub light_map_side: usize,
}

impl DirectionalArgs {
    /// The sample counts to run (empty for 0), checked against the caps.
    pub fn samples(&self) -> anyhow::Result<Vec<usize>> {
        if self.directional_spp == [0] {
            return Ok(Vec::new());
        }
        for &n in &self.directional_spp {
            ssskit::limits::check_light_space(
                ssskit::scene::LIGHT_SPACE,
                self.light_map_side,
                n,
                1,
                1,
            )?;
        }
        Ok(self.directional_spp.clone())
    }
}
