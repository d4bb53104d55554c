//! The screen-space pass on a path-traced scene's camera and the row it
//! scores: shared by the scene comparison (`scene::compare`), the
//! light-space directional block beside it and the scene advice, a leaf
//! none of them imports back from.

use super::score::RegionError;
use crate::error::Result;
use crate::filter::{cpu, separable, FollowSurface, Image, Plane, Scale, Setup};
use crate::scene::{Projection, Scene};
use serde::{Deserialize, Serialize};

/// One variant of one model on the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneRow {
    /// The model's label in the flat-plane comparison ("svd1", ...), or the
    /// baseline's name.
    pub label: String,
    /// "depth", "depth+follow", or "baseline".
    pub variant: String,
    /// Flat-plane relative RMS (largest over channels) on the edge and
    /// shapes signals with the same tap table; None for the baselines.
    pub flat_edge: Option<f64>,
    pub flat_shapes: Option<f64>,
    /// In `scene::score::REGIONS` order.
    pub regions: Vec<RegionError>,
}

impl SceneRow {
    pub fn region(&self, name: &str) -> Option<&RegionError> {
        self.regions.iter().find(|r| r.region == name)
    }

    /// "label" or "label, variant".
    pub fn name(&self) -> String {
        if self.variant == "baseline" {
            self.label.clone()
        } else {
            format!("{} ({})", self.label, self.variant)
        }
    }
}

/// The screen-space pass's scale for the scene's camera: perspective with
/// `sss_width` = scene units per millimetre, or the orthographic footprint.
pub fn scale_of(scene: &Scene) -> Scale {
    match scene.camera.projection {
        Projection::Perspective { fov_y_deg } => Scale::Perspective {
            fov_y_deg,
            sss_width: 1.0 / scene.unit.mm(),
        },
        Projection::Orthographic { mm_per_pixel } => Scale::MmPerPixel(mm_per_pixel),
    }
}

/// The screen-space pass of `passes` over `img` on the scene's camera: the
/// scale per pixel from `depth` (Freude 2014, eq. 4.11) and, with
/// `follow` (the constant C of `scene::compare::follow_constant`), the depth-aware lerp
/// (Freude 2014, eq. 4.12); on the CPU in f64.
pub fn screen_space_pass(
    scene: &Scene,
    depth: &Plane,
    passes: &[crate::filter::Taps],
    img: &Image,
    follow: Option<f64>,
) -> Result<Image> {
    let setup = Setup {
        passes: passes.to_vec(),
        ..view_on(scene, depth, follow)
    };
    cpu::apply_with(img, &setup, separable::Precision::F64)
}

/// [`screen_space_pass`] with a disk kernel: `frames` rotations from frame
/// `seed` accumulated (plain mean), on the CPU in f64.
pub fn screen_space_disk_pass(
    scene: &Scene,
    depth: &Plane,
    kernel: &crate::kernel::disk::DiskKernelFile,
    (seed, frames): (u32, u32),
    img: &Image,
    follow: Option<f64>,
) -> Result<Image> {
    let setup =
        crate::filter::disk::DiskSetup::new(kernel, view_on(scene, depth, follow), seed, frames);
    crate::filter::disk::apply_disk(img, &setup)
}

/// The scene camera's scale, depth and lerp, no passes yet.
fn view_on(scene: &Scene, depth: &Plane, follow: Option<f64>) -> Setup {
    Setup {
        passes: Vec::new(),
        scale: scale_of(scene),
        depth: Some(depth.clone()),
        strength: None,
        follow_surface: follow.map(FollowSurface::InSceneUnits),
        specular: None,
        jitter: false,
    }
}
