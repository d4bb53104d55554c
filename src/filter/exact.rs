//! The exact 2D reference: the image convolved with the full 2D kernel of
//! the profile, M_e = E * R_d (Freude 2014, eq. 5.2), the ground truth the
//! separable approximations are measured against in image space (Freude
//! 2014, section 5.1, figure 5.6; table 6.4).
//! Direct summation for small kernels, an FFT (rustfft) above
//! [`FFT_ABOVE`]; borders clamped in both. Rayon over rows and columns, no
//! cross-thread sums (deterministic).

use super::{clamp_index, Image};
use crate::error::{Error, Result};
use crate::kernel::{Kernel2D, Kernel2DSpec};
use crate::profile::radius::default_extent;
use crate::profile::Profile;
use rayon::prelude::*;
use rustfft::num_complex::Complex;

/// Where the exact convolution is taken in each output pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelSampling {
    /// Averaged over the pixel (a box pixel filter, what a camera or a path
    /// tracer records): [`Kernel2D::pixel_averaged`].
    Average,
    /// At the pixel centre ([`Kernel2D::from_profile`]'s cell integrals):
    /// the discretisation the separable filters' pixel kernels share, which
    /// the image-space comparison of kernel models uses.
    Centre,
}

/// The ground-truth 2D kernel of `profile` with cells the size of one pixel
/// (`mm_per_pixel`), covering the radius that holds 99.9% of R_d, sampling
/// the convolution at the pixel centres ([`PixelSampling::Centre`]).
pub fn reference_kernel(profile: &Profile, mm_per_pixel: f64) -> Result<Kernel2D> {
    reference_kernel_sampled(profile, mm_per_pixel, PixelSampling::Centre)
}

/// [`reference_kernel`] with the convolution taken as `sampling` says; the
/// averaged kernel is one pixel wider on each side (the tent of the pixel
/// box reaches one pixel further).
pub fn reference_kernel_sampled(
    profile: &Profile,
    mm_per_pixel: f64,
    sampling: PixelSampling,
) -> Result<Kernel2D> {
    let spec = reference_spec(profile, mm_per_pixel, sampling)?;
    match sampling {
        PixelSampling::Centre => Kernel2D::from_profile(profile, &spec),
        PixelSampling::Average => {
            Kernel2D::pixel_averaged(profile, spec.size.unwrap_or(1), mm_per_pixel)
        }
    }
}

/// Cells per side of [`reference_kernel`]'s kernel.
pub fn reference_size(profile: &Profile, mm_per_pixel: f64) -> Result<usize> {
    Ok(
        reference_spec(profile, mm_per_pixel, PixelSampling::Centre)?
            .size
            .unwrap_or(1),
    )
}

/// [`reference_kernel`] of each profile, in order: the kernels on one grid
/// of profiles on one radial grid (the bootstrap replicates of one
/// profile) integrated together ([`Kernel2D::from_profiles`]).
pub fn reference_kernels(profiles: &[&Profile], mm_per_pixel: f64) -> Result<Vec<Kernel2D>> {
    let items: Vec<(&Profile, Kernel2DSpec)> = profiles
        .iter()
        .map(|&p| Ok((p, reference_spec(p, mm_per_pixel, PixelSampling::Centre)?)))
        .collect::<Result<_>>()?;
    Kernel2D::from_profiles(&items)
}

/// The grid of [`reference_kernel_sampled`]: one pixel per cell out to the
/// radius holding 99.9% of every channel (one pixel more for `Average`).
fn reference_spec(
    profile: &Profile,
    mm_per_pixel: f64,
    sampling: PixelSampling,
) -> Result<Kernel2DSpec> {
    super::check_mm_per_pixel(mm_per_pixel)?;
    let radius = default_extent(profile, 0..profile.channels.len());
    let half = (radius / mm_per_pixel).ceil().max(1.0) as usize;
    let half = match sampling {
        PixelSampling::Centre => half,
        PixelSampling::Average => half + 1,
    };
    let size = 2 * half + 1;
    if size > crate::kernel::kernel2d::MAX_SIZE {
        return Err(Error::invalid(
            super::SCALE,
            "mm_per_pixel",
            mm_per_pixel,
            format!(
                "the exact reference kernel would be {size} pixels wide, at most {}: use a \
                 coarser scale",
                crate::kernel::kernel2d::MAX_SIZE
            ),
        ));
    }
    Ok(Kernel2DSpec {
        size: Some(size),
        extent_mm: Some(size as f64 * mm_per_pixel / 2.0),
    })
}

/// Kernel sizes above this use the FFT.
pub const FFT_ABOVE: usize = 21;

/// Refuses an exact 2D convolution of a `width` x `height` image with a
/// `size` x `size` kernel whose padded FFT grid exceeds
/// [`crate::limits::MAX_FFT_CELLS`] (memory and minutes of work), before
/// anything is allocated.
pub fn check_reference_fits(width: usize, height: usize, size: usize) -> Result<()> {
    let r = size / 2;
    let cells = (width + 2 * r).saturating_mul(height + 2 * r);
    if size > FFT_ABOVE && cells > crate::limits::MAX_FFT_CELLS {
        return Err(Error::Unsupported(format!(
            "the exact 2D reference of a {width}x{height} image with a {size}x{size} kernel \
             needs an FFT grid of {cells} cells, above the cap of {} (3 GiB of buffers): use a \
             coarser pixel scale or a smaller image",
            crate::limits::MAX_FFT_CELLS
        )));
    }
    Ok(())
}

/// Exact 2D convolution (clamped borders) with the kernel's cells taken as
/// pixels: out(x, y) = sum K(i, j) I(x + i, y + j).
pub fn convolve_2d(image: &Image, k: &Kernel2D) -> Image {
    let mut out = Image::new(image.width, image.height);
    out.alpha = image.alpha.clone();
    if image.is_empty() {
        return out;
    }
    for c in 0..3 {
        out.rgb[c] = if k.size > FFT_ABOVE {
            convolve_2d_fft(&image.rgb[c], image.width, image.height, &k.data[c], k.size)
        } else {
            convolve_2d_direct(&image.rgb[c], image.width, image.height, &k.data[c], k.size)
        };
    }
    out
}

pub fn convolve_2d_direct(src: &[f64], w: usize, h: usize, k: &[f64], size: usize) -> Vec<f64> {
    let r = (size / 2) as i64;
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
        for j in 0..size {
            let sy = clamp_index(y as i64 + j as i64 - r, h);
            let row = &src[sy * w..sy * w + w];
            for i in 0..size {
                let kv = k[j * size + i];
                if kv == 0.0 {
                    continue;
                }
                for (x, a) in o.iter_mut().enumerate() {
                    *a += kv * row[clamp_index(x as i64 + i as i64 - r, w)];
                }
            }
        }
    });
    out
}

/// Smallest n' >= n with no prime factor above 5 (fast FFT sizes).
fn smooth_size(n: usize) -> usize {
    let mut m = n.max(1);
    loop {
        let mut v = m;
        for p in [2, 3, 5] {
            while v.is_multiple_of(p) {
                v /= p;
            }
        }
        if v == 1 {
            return m;
        }
        m += 1;
    }
}

pub fn convolve_2d_fft(src: &[f64], w: usize, h: usize, k: &[f64], size: usize) -> Vec<f64> {
    let r = size / 2;
    let (pw, ph) = (w + 2 * r, h + 2 * r);
    let (nx, ny) = (smooth_size(pw), smooth_size(ph));
    let zero = Complex::new(0.0, 0.0);
    // The image extended by clamping, zero beyond the padded extent.
    let mut a = vec![zero; nx * ny];
    a.par_chunks_mut(nx)
        .enumerate()
        .take(ph)
        .for_each(|(y, row)| {
            let sy = clamp_index(y as i64 - r as i64, h);
            for (x, v) in row.iter_mut().enumerate().take(pw) {
                *v = Complex::new(src[sy * w + clamp_index(x as i64 - r as i64, w)], 0.0);
            }
        });
    // The kernel flipped (correlation), wrapped around the origin.
    let mut b = vec![zero; nx * ny];
    for j in 0..size {
        for i in 0..size {
            let (u, v) = (i as i64 - r as i64, j as i64 - r as i64);
            let x = (-u).rem_euclid(nx as i64) as usize;
            let y = (-v).rem_euclid(ny as i64) as usize;
            b[y * nx + x] = Complex::new(k[j * size + i], 0.0);
        }
    }
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let (fx, fy) = (planner.plan_fft_forward(nx), planner.plan_fft_forward(ny));
    let (ix, iy) = (planner.plan_fft_inverse(nx), planner.plan_fft_inverse(ny));
    let mut t = vec![zero; nx * ny];
    fft_2d(&mut a, nx, ny, &*fx, &*fy, &mut t);
    fft_2d(&mut b, nx, ny, &*fx, &*fy, &mut t);
    a.par_iter_mut().zip(&b).for_each(|(x, y)| *x *= y);
    drop(b);
    fft_2d(&mut a, nx, ny, &*ix, &*iy, &mut t);
    let norm = 1.0 / (nx * ny) as f64;
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
        for (x, v) in o.iter_mut().enumerate() {
            *v = a[(y + r) * nx + x + r].re * norm;
        }
    });
    out
}

/// One image convolved with many kernels at once, by FFT: the kernels'
/// spectra are made once, two kernels per complex spectrum (K_a + i K_b:
/// the image is real, so the real part of the product's inverse is the
/// image convolved with K_a and the imaginary part with K_b), and each
/// image then costs one forward and one inverse transform per pair and
/// channel instead of three transforms per kernel and channel. Borders
/// clamped as in [`convolve_2d`]; equal to it to rounding.
pub struct KernelBank {
    w: usize,
    h: usize,
    /// Half-width of the largest kernel, pixels.
    r: usize,
    nx: usize,
    ny: usize,
    count: usize,
    /// Per channel, per pair of kernels, the spectrum of K_a + i K_b.
    pairs: [Vec<Vec<Complex<f64>>>; 3],
}

impl KernelBank {
    /// The spectra of `kernels` for images of `w` x `h` pixels.
    pub fn new(kernels: &[&Kernel2D], w: usize, h: usize) -> KernelBank {
        let r = kernels.iter().map(|k| k.size / 2).max().unwrap_or(0);
        KernelBank::with_half(kernels, w, h, r)
    }

    /// [`Self::new`] padded for kernels up to `r` pixels from the centre
    /// (at least the largest of `kernels`): banks of a few kernels each,
    /// made in turn to bound memory, pad as one bank of all would, so that
    /// every image is the one that bank gives, bit for bit (the padding
    /// sets the transforms' size; the pairs must be the same too).
    pub fn with_half(kernels: &[&Kernel2D], w: usize, h: usize, r: usize) -> KernelBank {
        let r = kernels.iter().map(|k| k.size / 2).fold(r, usize::max);
        let (nx, ny) = (smooth_size(w + 2 * r), smooth_size(h + 2 * r));
        let mut planner = rustfft::FftPlanner::<f64>::new();
        let (fx, fy) = (planner.plan_fft_forward(nx), planner.plan_fft_forward(ny));
        let pairs = std::array::from_fn(|c| {
            kernels
                .chunks(2)
                .map(|pair| {
                    let mut b = vec![Complex::new(0.0, 0.0); nx * ny];
                    for (part, k) in pair.iter().enumerate() {
                        let kr = (k.size / 2) as i64;
                        for j in 0..k.size {
                            for i in 0..k.size {
                                // Flipped (correlation), wrapped around the origin.
                                let x = (kr - i as i64).rem_euclid(nx as i64) as usize;
                                let y = (kr - j as i64).rem_euclid(ny as i64) as usize;
                                let v = k.data[c][j * k.size + i];
                                if part == 0 {
                                    b[y * nx + x].re = v;
                                } else {
                                    b[y * nx + x].im = v;
                                }
                            }
                        }
                    }
                    fft_2d(
                        &mut b,
                        nx,
                        ny,
                        &*fx,
                        &*fy,
                        &mut vec![Complex::new(0.0, 0.0); nx * ny],
                    );
                    b
                })
                .collect()
        });
        KernelBank {
            w,
            h,
            r,
            nx,
            ny,
            count: kernels.len(),
            pairs,
        }
    }

    /// Bytes of one pair's spectra (three channels) in a bank for images of
    /// `w` x `h` pixels and kernels up to `r` pixels from the centre.
    pub fn pair_bytes(w: usize, h: usize, r: usize) -> usize {
        let (nx, ny) = (smooth_size(w + 2 * r), smooth_size(h + 2 * r));
        3 * nx * ny * std::mem::size_of::<Complex<f64>>()
    }

    /// `image` convolved with each kernel, in the bank's order.
    pub fn convolve(&self, image: &Image) -> Result<Vec<Image>> {
        if (image.width, image.height) != (self.w, self.h) {
            return Err(Error::Unsupported(format!(
                "kernel bank for {}x{} images given {}x{}",
                self.w, self.h, image.width, image.height
            )));
        }
        let (w, h, r, nx, ny) = (self.w, self.h, self.r, self.nx, self.ny);
        let mut planner = rustfft::FftPlanner::<f64>::new();
        let (fx, fy) = (planner.plan_fft_forward(nx), planner.plan_fft_forward(ny));
        let (ix, iy) = (planner.plan_fft_inverse(nx), planner.plan_fft_inverse(ny));
        let mut out: Vec<Image> = (0..self.count)
            .map(|_| {
                let mut i = Image::new(w, h);
                i.alpha = image.alpha.clone();
                i
            })
            .collect();
        let norm = 1.0 / (nx * ny) as f64;
        // Reused by every channel and pair: fresh buffers of this size are
        // fresh pages, zeroed by the kernel on every touch.
        let zero = Complex::new(0.0, 0.0);
        let (mut prod, mut scratch) = (vec![zero; nx * ny], vec![zero; nx * ny]);
        for c in 0..3 {
            let src = &image.rgb[c];
            let mut a = vec![zero; nx * ny];
            a.par_chunks_mut(nx)
                .enumerate()
                .take(h + 2 * r)
                .for_each(|(y, row)| {
                    let sy = clamp_index(y as i64 - r as i64, h);
                    for (x, v) in row.iter_mut().enumerate().take(w + 2 * r) {
                        *v = Complex::new(src[sy * w + clamp_index(x as i64 - r as i64, w)], 0.0);
                    }
                });
            fft_2d(&mut a, nx, ny, &*fx, &*fy, &mut scratch);
            for (p, spec) in self.pairs[c].iter().enumerate() {
                prod.par_iter_mut()
                    .zip(&a)
                    .zip(spec)
                    .for_each(|((o, x), y)| *o = x * y);
                fft_2d(&mut prod, nx, ny, &*ix, &*iy, &mut scratch);
                for part in 0..2 {
                    let Some(o) = out.get_mut(2 * p + part) else {
                        continue;
                    };
                    o.rgb[c].par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                        for (x, v) in row.iter_mut().enumerate() {
                            let z = prod[(y + r) * nx + x + r];
                            *v = if part == 0 { z.re } else { z.im } * norm;
                        }
                    });
                }
            }
        }
        Ok(out)
    }
}

/// The 2D transform of `data` (rows of `nx`), `t` a buffer of the same
/// size for the transposed rows.
fn fft_2d(
    data: &mut [Complex<f64>],
    nx: usize,
    ny: usize,
    fx: &dyn rustfft::Fft<f64>,
    fy: &dyn rustfft::Fft<f64>,
    t: &mut [Complex<f64>],
) {
    data.par_chunks_mut(nx).for_each(|row| fx.process(row));
    transpose(data, t, nx, ny);
    t.par_chunks_mut(ny).for_each(|col| fy.process(col));
    transpose(t, data, ny, nx);
}

/// `dst[x * h + y] = src[y * w + x]` for a w x h `src`.
fn transpose(src: &[Complex<f64>], dst: &mut [Complex<f64>], w: usize, h: usize) {
    dst.par_chunks_mut(h).enumerate().for_each(|(x, col)| {
        for (y, v) in col.iter_mut().enumerate() {
            *v = src[y * w + x];
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::signals::noise;

    #[test]
    fn fft_equals_direct_convolution() {
        let img = noise(37, 29, 12345);
        let size = 25;
        let k: Vec<f64> = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f64 - 12.0, (i / size) as f64 - 12.0);
                // Asymmetric on purpose: catches a flipped kernel.
                (-(x * x + 0.5 * y * y) / 20.0).exp() * (1.0 + 0.1 * x)
            })
            .collect();
        let a = convolve_2d_direct(&img.rgb[0], 37, 29, &k, size);
        let b = convolve_2d_fft(&img.rgb[0], 37, 29, &k, size);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-11, "{x} {y}");
        }
    }

    /// The bank gives each kernel's convolution, whatever its size and
    /// its place in a pair (an odd count leaves the last one alone).
    #[test]
    fn kernel_bank_equals_one_convolution_per_kernel() {
        let img = noise(37, 29, 777);
        let kernel = |size: usize, tilt: f64| {
            let h = (size / 2) as f64;
            let data: Vec<f64> = (0..size * size)
                .map(|i| {
                    let (x, y) = ((i % size) as f64 - h, (i / size) as f64 - h);
                    (-(x * x + 0.5 * y * y) / 20.0).exp() * (1.0 + tilt * x)
                })
                .collect();
            Kernel2D {
                size,
                cell_mm: 1.0,
                data: [data.clone(), data.iter().map(|v| 0.5 * v).collect(), data],
                total_rd: [1.0; 3],
                captured: [1.0; 3],
            }
        };
        let ks = [kernel(25, 0.1), kernel(11, -0.2), kernel(31, 0.05)];
        let bank = KernelBank::new(&ks.iter().collect::<Vec<_>>(), 37, 29);
        let got = bank.convolve(&img).unwrap();
        // Banks of a pair and a single padded as the one bank of all
        // (`with_half`, advise's replicates a group at a time) give its
        // images bit for bit.
        let parts = [&ks[..2], &ks[2..]];
        let in_parts: Vec<Image> = parts
            .iter()
            .flat_map(|p| {
                let b = KernelBank::with_half(&p.iter().collect::<Vec<_>>(), 37, 29, 15);
                b.convolve(&img).unwrap()
            })
            .collect();
        for (a, b) in got.iter().zip(&in_parts) {
            for c in 0..3 {
                let bits = |i: &Image| i.rgb[c].iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(a), bits(b));
            }
        }
        assert_eq!(got.len(), 3);
        for (k, g) in ks.iter().zip(&got) {
            let want = convolve_2d(&img, k);
            for c in 0..3 {
                for (x, y) in want.rgb[c].iter().zip(&g.rgb[c]) {
                    assert!((x - y).abs() < 1e-11, "{x} {y}");
                }
            }
        }
    }
}
