//! What the comparison's figures of one material show, measured here so
//! that `present::kernel_plots` only draws it: a contact sheet's tiles
//! (which image leads, each tile's colour shift from the exact tile) and
//! the kernel slices' curves (separable kernels rebuilt in 2D from their
//! factors, a disk kernel's density per ring).

use super::claims::RANK1;
use super::kernel::Comparison;
use crate::error::{Error, Result};
use crate::filter::diff;
use crate::filter::Image;
use crate::kernel::disk::DiskKernelFile;
use crate::kernel::metrics::reconstruct;
use crate::kernel::{Factors, Kernel2D, KernelFile};
use crate::numerics::annulus_area;
use crate::report::eval::colour_shift;
use crate::report::eval::evaluate::Exact;

/// The index of `material` in the comparison.
fn material_index(cmp: &Comparison, material: &str) -> Result<usize> {
    cmp.materials
        .iter()
        .position(|m| m == material)
        .ok_or_else(|| Error::Unsupported(format!("no material {material}")))
}

/// One filtered image of a contact sheet.
pub struct MeasuredTile<'a> {
    pub label: String,
    pub image: &'a Image,
    /// Delta E*ab of its mean colour from the exact tile's, at equal
    /// luminance ([`colour_shift::tile_difference`]).
    pub delta_e: f64,
}

/// A contact sheet of one material and case, measured.
pub struct SheetTiles<'a> {
    pub material: String,
    /// The exact convolution of the case.
    pub exact: &'a Exact,
    /// The first tile after the input: what ships, or else the model of
    /// the lowest relative RMS on this case (largest channel).
    pub lead: Option<MeasuredTile<'a>>,
    /// Each model's kept image, in the comparison's order.
    pub models: Vec<MeasuredTile<'a>>,
}

/// What ships, as a contact sheet opens with it: its label and its image
/// per case of the comparison (`ship::shipped::Shipped`, which this job
/// folder does not import).
pub type Lead<'a> = (&'a str, &'a [Image]);

/// The tiles of the contact sheet of `material` and case `ci`, led by
/// `shipped` where given.
pub fn sheet_tiles<'a>(
    cmp: &'a Comparison,
    material: &str,
    ci: usize,
    shipped: Option<Lead<'a>>,
) -> Result<SheetTiles<'a>> {
    let mi = material_index(cmp, material)?;
    let exact = &cmp.exact[mi][ci];
    let models: Vec<(&str, &Image)> = cmp
        .fitted
        .iter()
        .filter(|f| f.material == material)
        .filter_map(|f| f.kept.get(ci)?.as_ref().map(|i| (f.spec.label.as_str(), i)))
        .collect();
    let tile = |label: &str, image: &'a Image| MeasuredTile {
        label: label.to_string(),
        image,
        delta_e: colour_shift::tile_difference(&exact.image, image, exact.exposure_rgb),
    };
    let lead = lead(&models, &exact.image, shipped, ci)?.map(|(label, img)| tile(&label, img));
    Ok(SheetTiles {
        material: material.to_string(),
        exact,
        lead,
        models: models
            .iter()
            .map(|&(label, img)| tile(label, img))
            .collect(),
    })
}

/// The contact sheet's first tile after the input: the shipped
/// configuration's image (`shipped`), or else the model with the lowest
/// relative RMS on this case (largest channel).
fn lead<'a>(
    models: &[(&'a str, &'a Image)],
    exact: &Image,
    shipped: Option<Lead<'a>>,
    ci: usize,
) -> Result<Option<(String, &'a Image)>> {
    if let Some((label, images)) = shipped {
        return Ok(images.get(ci).map(|i| (label.to_string(), i)));
    }
    let mut best: Option<(f64, usize)> = None;
    for (i, (_, img)) in models.iter().enumerate() {
        let e = diff::compare(exact, img)?
            .rms_rel
            .iter()
            .cloned()
            .fold(0.0, f64::max);
        if best.is_none_or(|(b, _)| e < b) {
            best = Some((e, i));
        }
    }
    Ok(best.map(|(_, i)| (format!("lowest error here: {}", models[i].0), models[i].1)))
}

/// A separable kernel's 2D kernel rebuilt from its factors: per channel a
/// row-major `size` x `size` array of cells `cell_mm` wide (the kernel's
/// weights, summing to about 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Rebuilt {
    pub size: usize,
    pub cell_mm: f64,
    pub data: [Vec<f64>; 3],
}

/// `factors` rebuilt on `size` x `size` cells of `cell_mm`.
fn rebuild(factors: &Factors, size: usize, cell_mm: f64) -> Rebuilt {
    Rebuilt {
        size,
        cell_mm,
        data: std::array::from_fn(|c| reconstruct(factors, size, c)),
    }
}

/// The 2D kernel of `kernel`'s full factors, on the cells of its offsets.
pub fn rebuilt(kernel: &KernelFile) -> Rebuilt {
    let offsets = &kernel.passes[0].offsets_mm;
    let n = offsets.len();
    let cell = if n > 1 { offsets[1] - offsets[0] } else { 1.0 };
    rebuild(&kernel.factors(), n, cell)
}

/// What the kernel slices of one material show: its ground truth and the
/// rank-1 models ([`RANK1`]) rebuilt on the truth's grid.
pub struct SliceKernels<'a> {
    pub material: String,
    pub truth: &'a Kernel2D,
    /// (label, 2D kernel), in the comparison's order.
    pub models: Vec<(String, Rebuilt)>,
}

/// The kernels of the slices of `material`.
pub fn slice_kernels<'a>(cmp: &'a Comparison, material: &str) -> Result<SliceKernels<'a>> {
    let truth = &cmp.truths[material_index(cmp, material)?];
    let models = cmp
        .fitted
        .iter()
        .filter(|f| f.material == material && RANK1.contains(&f.spec.label.as_str()))
        .map(|f| {
            let k = rebuild(&f.kernel.factors(), truth.size, truth.cell_mm);
            (f.spec.label.clone(), k)
        })
        .collect();
    Ok(SliceKernels {
        material: material.to_string(),
        truth,
        models,
    })
}

/// A disk kernel's radial density of channel `c` as a step curve (mm,
/// 1/mm^2): each sample's weight spread over the ring from halfway to the
/// previous sample's radius to halfway to the next (the first ring from
/// the centre, the last as wide outside as inside), weight / ring area.
/// Samples of one radius pool their weights; those with no weight in `c`
/// (per-channel radii) are left out. After the per-pixel rotation a disk
/// kernel is the same in every direction, so one curve serves the axis and
/// the diagonal.
pub fn disk_annuli(kernel: &DiskKernelFile, c: usize) -> Vec<(f64, f64)> {
    let mut rings: Vec<(f64, f64)> = Vec::new();
    let mut samples: Vec<(f64, f64)> = kernel
        .samples
        .iter()
        .filter(|s| s.weight[c] != 0.0)
        .map(|s| (s.radius_mm, s.weight[c]))
        .collect();
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (r, w) in samples {
        match rings.last_mut() {
            Some(last) if last.0 == r => last.1 += w,
            _ => rings.push((r, w)),
        }
    }
    let n = rings.len();
    let edge = |i: usize| -> f64 {
        match i {
            0 => 0.0,
            i if i == n && n >= 2 => rings[n - 1].0 + 0.5 * (rings[n - 1].0 - rings[n - 2].0),
            i if i == n => 2.0 * rings[0].0,
            i => 0.5 * (rings[i - 1].0 + rings[i].0),
        }
    };
    let mut points = Vec::with_capacity(2 * n);
    for (i, &(_, w)) in rings.iter().enumerate() {
        let (a, b) = (edge(i), edge(i + 1));
        let d = w / annulus_area(a, b);
        points.extend([(a, d), (b, d)]);
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::disk::RadiusPdf;
    use crate::kernel::disk_fit::fit_disk;

    /// The rings of [`disk_annuli`] tile the disk from the centre outward,
    /// each sample's ring holds it, and density x ring area gives back
    /// the weights: their sum per channel, 1, for one set of radii and for
    /// radii per channel.
    #[test]
    fn disk_rings_hold_the_weights() {
        let p = crate::kernel::reference::dipole_uniform("skin1", 0.02, 6.0);
        for radii in [RadiusPdf::Widest, RadiusPdf::PerChannel] {
            let k = fit_disk(&p, 16, radii).unwrap();
            for c in 0..3 {
                let pts = disk_annuli(&k, c);
                assert_eq!(pts[0].0, 0.0);
                let mut mass = 0.0;
                for ring in pts.chunks(2) {
                    let ((a, d), (b, d2)) = (ring[0], ring[1]);
                    assert!(b > a && d == d2, "{radii:?} {c}: {ring:?}");
                    mass += d * std::f64::consts::PI * (b * b - a * a);
                }
                for w in pts.windows(2) {
                    assert!(w[1].0 >= w[0].0, "{radii:?} {c}: {pts:?}");
                }
                for s in k.samples.iter().filter(|s| s.weight[c] != 0.0) {
                    let inside = pts
                        .chunks(2)
                        .any(|r| r[0].0 <= s.radius_mm && s.radius_mm <= r[1].0);
                    assert!(inside, "{radii:?} {c}: {}", s.radius_mm);
                }
                let sum: f64 = k.samples.iter().map(|s| s.weight[c]).sum();
                assert!((mass - sum).abs() < 1e-12 && (sum - 1.0).abs() < 1e-9);
            }
        }
    }
}
