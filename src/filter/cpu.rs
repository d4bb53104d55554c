//! The CPU backend: runs a [`Setup`] with the fastest CPU path that gives
//! the per-pixel algorithm's result. A uniform scale (no strength, depth,
//! lerp or jitter) makes every rank a fixed pixel kernel, run by
//! [`separable`](super::separable); anything else runs Freude 2014,
//! algorithm 4.1 per pixel ([`screen_space`](super::screen_space)). The
//! specular image is added after the blur. The exact 2D reference lives in
//! [`exact`](super::exact).
//!
//! Each path's own entry points live in its module (`exact`,
//! `separable`, `screen_space`); this one runs a whole [`Setup`].

use super::sample::PixelKernel;
use super::screen_space::{apply_screen_space, apply_screen_space_in_place};
use super::separable::{apply_separable_in, apply_separable_plane_in_place, Precision};
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
    let mut out = if setup.is_uniform() {
        apply_separable_in(image, &fixed_kernels(image, setup), precision)
    } else {
        apply_screen_space(image, setup)
    };
    out.add(setup.specular.as_ref());
    Ok(out)
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
    image.add(setup.specular.as_ref());
    Ok(())
}

/// [`apply_in_place`] at [`Precision::F32`] for channel `c` of a `w` x `h`
/// image held as one f32 plane (a caller's buffer, as the Python binding
/// holds each channel of a numpy image in turn): the same samples, bit for
/// bit, with a third of the memory of the f64 image's plane. The
/// fixed-kernel path only (a uniform scale, no specular, whose sum would
/// be rounded once more in f32): any other setup is an error. `halo` is
/// reused from one plane to the next. The caller has checked `setup`
/// ([`Setup::validate`]) against a `w` x `h` image.
pub fn apply_plane_f32_in_place(
    plane: &mut [f32],
    halo: &mut Vec<f32>,
    (w, h): (usize, usize),
    setup: &Setup,
    c: usize,
) -> Result<()> {
    if !setup.is_uniform() || setup.specular.is_some() || plane.len() != w * h || c > 2 {
        return Err(crate::error::Error::Unsupported(
            "one f32 plane is filtered under a uniform scale, without specular, w x h samples"
                .into(),
        ));
    }
    let kernels = fixed_kernels_at(setup, h);
    apply_separable_plane_in_place::<f32, f32>(plane, halo, (w, h), &kernels, c);
    Ok(())
}

/// Every rank as a fixed pixel kernel at the uniform step.
fn fixed_kernels(image: &Image, setup: &Setup) -> Vec<PixelKernel> {
    fixed_kernels_at(setup, image.height)
}

fn fixed_kernels_at(setup: &Setup, height: usize) -> Vec<PixelKernel> {
    let step = setup.scale.step_base(height);
    setup
        .passes
        .iter()
        .map(|t| PixelKernel::from_taps(t, step))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::disk_error::view;
    use crate::filter::signals::noise;
    use crate::filter::Taps;

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
            ..view(0.37)
        };
        let fast = apply(&img, &setup).unwrap();
        let slow = apply_screen_space(&img, &setup);
        for c in 0..3 {
            for (x, y) in fast.rgb[c].iter().zip(&slow.rgb[c]) {
                assert!((x - y).abs() < 1e-12, "{x} {y}");
            }
        }
    }

    /// One channel at a time in f32 samples gives the f32 path's samples
    /// of the whole f64 image, bit for bit, on an f32-valued image (what a
    /// float32 array holds); a setup the plane path does not run is refused.
    #[test]
    fn an_f32_plane_gives_the_f32_path_bit_for_bit() {
        let mut img = noise(37, 29, 7);
        for plane in img.rgb.iter_mut() {
            plane.iter_mut().for_each(|v| *v = f64::from(*v as f32));
        }
        let taps = Taps {
            offsets_mm: vec![-1.3, -0.4, 0.0, 0.35, 1.2],
            weights: vec![
                [0.1, 0.2, 0.05],
                [0.2; 3],
                [0.4, 0.2, 0.5],
                [0.2; 3],
                [0.1; 3],
            ],
        };
        let mut setup = Setup {
            passes: vec![taps.clone(), taps],
            ..view(0.21)
        };
        let mut whole = img.clone();
        apply_in_place(&mut whole, &setup, Precision::F32).unwrap();
        let mut halo = Vec::new();
        for c in 0..3 {
            let mut plane: Vec<f32> = img.rgb[c].iter().map(|&v| v as f32).collect();
            apply_plane_f32_in_place(&mut plane, &mut halo, (37, 29), &setup, c).unwrap();
            let got: Vec<f64> = plane.iter().map(|&v| f64::from(v)).collect();
            assert_eq!(got, whole.rgb[c], "channel {c}");
        }
        setup.jitter = true;
        let mut plane = vec![0.0f32; 37 * 29];
        assert!(apply_plane_f32_in_place(&mut plane, &mut halo, (37, 29), &setup, 0).is_err());
    }
}
