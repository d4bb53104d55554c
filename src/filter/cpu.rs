//! The CPU backend: runs a [`Setup`] with the fastest CPU path that gives
//! the per-pixel algorithm's result. A uniform scale (no strength, depth,
//! lerp or jitter) makes every rank a fixed pixel kernel, run by
//! [`separable`](super::separable); anything else runs Freude 2014,
//! algorithm 4.1 per pixel ([`screen_space`](super::screen_space)). The
//! specular image is added after the blur. The exact 2D reference lives in
//! [`exact`](super::exact).
//!
//! The entry points of the three CPU paths are re-exported here: callers
//! name every CPU filter as `filter::cpu::…`.

pub use super::exact::{
    check_reference_fits, convolve_2d, reference_kernel, reference_kernel_sampled,
    reference_kernels, reference_size, PixelSampling, FFT_ABOVE,
};
pub use super::screen_space::{apply_screen_space, apply_screen_space_in_place};
use super::separable::apply_separable_in;
pub use super::separable::{
    apply_separable, apply_separable_f32, apply_separable_in_place, apply_separable_into,
    PixelKernel, Precision,
};
use super::{Image, Setup};
use crate::error::Result;

/// Runs `setup` on `image` in f64: [`apply_with`] at [`Precision::F64`].
pub fn apply(image: &Image, setup: &Setup) -> Result<Image> {
    apply_with(image, setup, Precision::F64)
}

/// Runs `setup` on `image`: the fixed-kernel fast path in `precision` when
/// the scale is uniform, else the per-pixel algorithm (f64 whatever
/// `precision` says); specular added after.
pub fn apply_with(image: &Image, setup: &Setup, precision: Precision) -> Result<Image> {
    setup.validate(image)?;
    let out = if setup.is_uniform() {
        apply_separable_in(image, &fixed_kernels(image, setup), precision)
    } else {
        apply_screen_space(image, setup)
    };
    Ok(add_specular(out, setup.specular.as_ref()))
}

/// [`apply_with`] overwriting `image`, as `ssskit apply` runs it: the
/// fixed-kernel path filters in place (the image plus a ring of rows per
/// thread and halo rows of at most 1/8 of a plane); the per-pixel
/// algorithm sweeps in place too (the image plus a window of filtered rows
/// per rank, `screen_space`).
pub fn apply_in_place(image: &mut Image, setup: &Setup, precision: Precision) -> Result<()> {
    setup.validate(image)?;
    if setup.is_uniform() {
        let kernels = fixed_kernels(image, setup);
        precision.separable_in_place(image, &kernels);
    } else {
        apply_screen_space_in_place(image, setup);
    }
    add_specular_into(image, setup.specular.as_ref());
    Ok(())
}

/// Every rank as a fixed pixel kernel at the uniform step.
fn fixed_kernels(image: &Image, setup: &Setup) -> Vec<PixelKernel> {
    let step = setup.scale.step_base(image.height);
    setup
        .passes
        .iter()
        .map(|t| PixelKernel::from_taps(t, step))
        .collect()
}

fn add_specular(mut out: Image, specular: Option<&Image>) -> Image {
    add_specular_into(&mut out, specular);
    out
}

fn add_specular_into(out: &mut Image, specular: Option<&Image>) {
    if let Some(s) = specular {
        for c in 0..3 {
            out.rgb[c]
                .iter_mut()
                .zip(&s.rgb[c])
                .for_each(|(o, v)| *o += v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::signals::noise;
    use crate::filter::{Scale, Taps};

    #[test]
    fn fixed_kernels_equal_the_per_pixel_algorithm() {
        let img = noise(31, 23, 12345);
        let taps = Taps {
            offsets_mm: vec![-1.7, -0.6, -0.1, 0.0, 0.25, 0.9, 2.3],
            weights: vec![
                [0.1, 0.05, 0.0],
                [0.2, 0.1, 0.3],
                [0.1, 0.2, 0.1],
                [0.3, 0.3, 0.2],
                [0.1, 0.2, 0.2],
                [0.1, 0.1, 0.1],
                [0.1, 0.05, 0.1],
            ],
        };
        let setup = Setup {
            passes: vec![taps.clone(), taps],
            scale: Scale::MmPerPixel(0.37),
            depth: None,
            strength: None,
            follow_surface: None,
            specular: None,
            jitter: false,
        };
        let fast = apply(&img, &setup).unwrap();
        let slow = apply_screen_space(&img, &setup);
        for c in 0..3 {
            for (x, y) in fast.rgb[c].iter().zip(&slow.rgb[c]) {
                assert!((x - y).abs() < 1e-12, "{x} {y}");
            }
        }
    }
}
