//! Which factors of a kernel file a pass runs, and the taps that makes:
//! the full-resolution factors (resampled to pixels under a uniform
//! scale), the stored real-time table, or a table of another count built
//! from the full factors.

use super::{resample_to_pixels, Taps};
use crate::error::{Error, Result};
use crate::kernel::KernelFile;

/// Which factors of a kernel file a pass runs: the full-resolution factors
/// or an N-tap table (the stored one when N is its count, else one rebuilt
/// from the full factors); also which image-space error a table shows
/// (`report::eval::compare::kernel`). The one such choice in the crate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    Full,
    Taps(usize),
}

impl Which {
    /// The kernel file's own tap table.
    pub fn stored(kernel: &KernelFile) -> Which {
        Which::Taps(kernel.taps.count)
    }

    pub fn describe(&self) -> String {
        match self {
            Which::Full => "full-resolution factors".into(),
            Which::Taps(n) => format!("{n}-tap table"),
        }
    }
}

/// The taps to run for `which` of `kernel`. Full-resolution factors under
/// a uniform orthographic scale are resampled to whole pixels (each
/// sample's weight is spread over its cell and integrated over each pixel,
/// which preserves the sum); otherwise their samples are used as taps. A
/// tap count other than the stored table's is built from the full factors
/// ([`crate::kernel::taps::tap_table`]), which needs them on an odd uniform
/// grid centred on 0.
pub fn taps_for(
    kernel: &KernelFile,
    which: Which,
    uniform_mm_per_pixel: Option<f64>,
) -> Result<Vec<Taps>> {
    Ok(match which {
        Which::Taps(n) if n == kernel.taps.count => {
            kernel.taps.passes.iter().map(Taps::from).collect()
        }
        Which::Taps(n) => {
            let (k, f) = grid_of(kernel)?;
            let table = crate::kernel::taps::tap_table(&k, &f, n)?;
            table.passes.iter().map(Taps::from).collect()
        }
        Which::Full => kernel
            .passes
            .iter()
            .map(|p| match uniform_mm_per_pixel {
                Some(m) => resample_to_pixels(&Taps::from(p), m),
                None => Taps::from(p),
            })
            .collect(),
    })
}

/// The kernel file's full factors on their grid, as the fit produced them,
/// and the model's own 2D kernel on that grid (the tap table reads only the
/// grid's geometry).
fn grid_of(kernel: &KernelFile) -> Result<(crate::kernel::Kernel2D, crate::kernel::Factors)> {
    let first = &kernel.passes[0].offsets_mm;
    let size = first.len();
    let uniform = kernel.passes.iter().all(|p| p.offsets_mm == *first)
        && size % 2 == 1
        && size >= 3
        && first[size / 2] == 0.0;
    let cell = if size >= 3 {
        (first[size - 1] - first[0]) / (size - 1) as f64
    } else {
        0.0
    };
    let even = uniform
        && first
            .windows(2)
            .all(|w| ((w[1] - w[0]) - cell).abs() <= 1e-9 * cell);
    if !even {
        return Err(Error::Unsupported(format!(
            "kernel '{}': its factors are not on an odd uniform grid centred on 0, so no \
             other tap count can be built from them (use its stored {} taps)",
            kernel.model.name, kernel.taps.count
        )));
    }
    let factors = kernel.factors();
    let data = std::array::from_fn(|c| crate::kernel::metrics::reconstruct(&factors, size, c));
    Ok((
        crate::kernel::Kernel2D {
            size,
            cell_mm: cell,
            data,
            total_rd: kernel.total_rd,
            captured: [1.0; 3],
        },
        factors,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{fit_kernel_file, Kernel2DSpec, Model};

    /// The factors and grid read back from a kernel file rebuild its stored
    /// tap table exactly: what `taps_for` does for another tap count starts
    /// from the fit's own factors.
    #[test]
    fn a_rebuilt_tap_table_equals_the_fitted_one() {
        let p = crate::kernel::reference::dipole_uniform("skin1", 0.01, 8.0);
        let spec = Kernel2DSpec {
            size: Some(41),
            extent_mm: None,
        };
        let model = Model::Svd {
            rank: 2,
            renormalize: false,
        };
        let k = fit_kernel_file(&p, &spec, &model, 17).unwrap();
        let (grid, f) = grid_of(&k).unwrap();
        let rebuilt = crate::kernel::taps::tap_table(&grid, &f, 17).unwrap();
        assert_eq!(rebuilt.passes.len(), k.taps.passes.len());
        for (a, b) in rebuilt.passes.iter().zip(&k.taps.passes) {
            for (x, y) in a.offsets_mm.iter().zip(&b.offsets_mm) {
                assert!((x - y).abs() < 1e-12);
            }
            for (x, y) in a.weights.iter().zip(&b.weights) {
                for c in 0..3 {
                    assert!((x[c] - y[c]).abs() < 1e-12 * y[c].abs().max(1e-300));
                }
            }
        }
    }
}
