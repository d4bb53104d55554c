//! The disk pass in f64, the CPU reference of shaders/disk.wgsl: per pixel,
//! the samples of a disk kernel (`kernel::disk`) turned by the pixel's
//! rotation ([`rotation_unit`]: interleaved gradient noise, Jimenez 2014,
//! plus a step of sqrt 2 - 1 turn per frame), scaled by the pixel's step in pixels
//! per mm (the separable pass's [`Setup::steps`]: strength, perspective
//! depth, Freude 2014, eq. 4.11), fetched bilinearly with clamped
//! positions, lerped toward the centre colour by depth difference
//! (Freude 2014, eq. 4.12, [`super::follow_t`]) and summed with their
//! weights. `frames` rotations are accumulated by `accumulate` (the plain
//! mean a temporal filter converges to under a static camera, or an
//! exponential moving average, `super::accumulate`). Rayon over rows; each
//! output pixel is computed by one thread (deterministic).
//!
//! Bilinear fetches at positions spread uniformly over the plane sample the
//! image convolved with the tent of the pixel box, so the expected estimate
//! is the exact convolution averaged over each pixel
//! (`exact::PixelSampling::Average`), the oracle of the tests.

use super::accumulate::Accumulate;
use super::bands::Bands;
use super::disk_lanes::{self, Packed, Planes, Texels};
use super::rows::{par_rows, par_span_rows};
use super::{rotation_unit, Image, Setup};
use crate::error::{Error, Result};
use crate::kernel::disk::DiskKernelFile;
use crate::kernel::disk::MAX_FRAMES;
use crate::progress::{NoProgress, Progress};
use std::f64::consts::PI;

/// One sample as the pass uses it: unrotated position in mm, RGB weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskTap {
    pub x_mm: f64,
    pub y_mm: f64,
    pub weight: [f64; 3],
}

/// Everything the disk pass needs besides the image.
#[derive(Clone, Debug)]
pub struct DiskSetup {
    pub taps: Vec<DiskTap>,
    /// Scale, depth, strength, follow-surface and specular as for the
    /// separable pass; its `passes` and `jitter` are not used.
    pub view: Setup,
    /// Added to the frame index before the rotation (wrapping).
    pub seed: u32,
    /// Rotations accumulated, frames seed, seed + 1, ...
    pub frames: u32,
    /// How they are accumulated (the plain mean unless set).
    pub accumulate: Accumulate,
}

impl DiskSetup {
    /// The taps of `kernel` under `view`.
    pub fn new(kernel: &DiskKernelFile, view: Setup, seed: u32, frames: u32) -> DiskSetup {
        let taps = kernel
            .samples
            .iter()
            .map(|s| DiskTap {
                x_mm: s.radius_mm * s.angle.cos(),
                y_mm: s.radius_mm * s.angle.sin(),
                weight: s.weight,
            })
            .collect();
        DiskSetup {
            taps,
            view,
            seed,
            frames,
            accumulate: Accumulate::Mean,
        }
    }

    /// The same pass with its frames accumulated by `accumulate`.
    pub fn accumulated_by(self, accumulate: Accumulate) -> DiskSetup {
        DiskSetup { accumulate, ..self }
    }

    /// The same pass over other frames.
    pub fn with_frames(&self, seed: u32, frames: u32) -> DiskSetup {
        DiskSetup {
            seed,
            frames,
            ..self.clone()
        }
    }

    pub fn validate(&self, image: &Image) -> Result<()> {
        self.view.validate_view(image)?;
        if self.taps.is_empty() {
            return Err(Error::Unsupported("the disk kernel has no samples".into()));
        }
        if !(1..=MAX_FRAMES).contains(&self.frames) {
            return Err(Error::invalid(
                "disk pass",
                "frames",
                self.frames,
                format!("must be in 1..={MAX_FRAMES}"),
            ));
        }
        let widest = self
            .view
            .steps_iter(image.width, image.height)
            .fold(0.0, f64::max);
        if !widest.is_finite() {
            return Err(Error::Unsupported(
                "the per-pixel kernel scale overflows (a huge strength, a tiny depth or a tiny \
                 pixel footprint): check the strength and depth images and the scale"
                    .into(),
            ));
        }
        // Four fetches of three channels per sample, pixel and frame.
        let work = 12.0 * image.len() as f64 * self.taps.len() as f64 * self.frames as f64;
        if !(work <= crate::limits::MAX_FILTER_WORK) {
            return Err(Error::Unsupported(format!(
                "applying {} disk samples over {} frame(s) to a {}x{} image would take {work:.2e} \
                 multiply-adds, above the cap of {:.0e}: use fewer samples or frames, or a \
                 smaller image",
                self.taps.len(),
                self.frames,
                image.width,
                image.height,
                crate::limits::MAX_FILTER_WORK
            )));
        }
        Ok(())
    }
}

/// The disk pass over `setup.frames` rotations (their mean), the specular
/// image added after: [`apply_disk_in_place`]'s image, read from a packed
/// copy of `image` (a fetch is four 32-byte loads, the samples four at a
/// time, `disk_lanes`) into a new image.
pub fn apply_disk(image: &Image, setup: &DiskSetup) -> Result<Image> {
    setup.validate(image)?;
    let pass = Pass::new(image, setup);
    let mut out = pass.run(&Packed::new(image), setup.seed, setup.frames);
    out.add(setup.view.specular.as_ref());
    Ok(out)
}

/// Most sample fetches (pixels x samples x frames) one disk pass on the
/// CPU may take: each costs about 350 instructions (callgrind on `ssskit
/// apply --frames`, one thread: the rotated offset, the clamped bilinear
/// fetch of three channels, the weights), some 1.6e7 fetches a second on
/// two cores, so the cap is about two minutes of work there. The filter's
/// own cap ([`crate::limits::MAX_FILTER_WORK`]) counted a fetch as 12
/// multiply-adds and let a pass run for two hours. The GPU pass, far
/// faster, is held to the filter's cap only.
pub const MAX_CPU_FETCHES: f64 = 2e9;

/// Refuses a CPU disk pass beyond [`MAX_CPU_FETCHES`], saying how many
/// frames fit.
pub fn check_cpu_work(image: &Image, setup: &DiskSetup) -> Result<()> {
    let per_frame = image.len() as f64 * setup.taps.len() as f64;
    let fetches = per_frame * setup.frames as f64;
    if fetches <= MAX_CPU_FETCHES {
        return Ok(());
    }
    let fit = (MAX_CPU_FETCHES / per_frame).floor();
    Err(Error::invalid(
        "disk pass",
        "frames",
        setup.frames,
        format!(
            "{} samples over {} frame(s) of a {}x{} image take {fetches:.2e} fetches on the \
             CPU, above its cap of {MAX_CPU_FETCHES:.0e} (about two minutes on two cores): {}; \
             or use fewer samples, a smaller image, or the GPU pass",
            setup.taps.len(),
            setup.frames,
            image.width,
            image.height,
            if fit >= 1.0 {
                format!("at most {fit} frames fit")
            } else {
                "not even one frame fits".to_string()
            }
        ),
    ))
}

/// [`apply_disk`] overwriting `image`, as `ssskit apply` runs it: bands of
/// output rows wait in a buffer until no later band's samples reach them
/// (the vertical reach of the widest rotated sample), then replace their
/// input rows. Besides the image it holds about three reaches of rows, not
/// a full-size output (796 MB at 8K in f64) nor the plane of steps.
pub fn apply_disk_in_place(image: &mut Image, setup: &DiskSetup) -> Result<()> {
    apply_disk_in_place_with(image, setup, &NoProgress)
}

/// [`apply_disk_in_place`] reporting the rows done to `progress`.
pub fn apply_disk_in_place_with(
    image: &mut Image,
    setup: &DiskSetup,
    progress: &dyn Progress,
) -> Result<()> {
    setup.validate(image)?;
    check_cpu_work(image, setup)?;
    progress.start(
        image.height as u64,
        &format!("disk pass, {} frame(s): rows", setup.frames),
    );
    sweep(image, setup, None, progress);
    progress.finish();
    image.add(setup.view.specular.as_ref());
    Ok(())
}

/// The in-place sweep in bands of `band` rows (None: from the reach).
fn sweep(image: &mut Image, setup: &DiskSetup, band: Option<usize>, progress: &dyn Progress) {
    let (w, h) = (image.width, image.height);
    let widest = setup.view.steps_iter(w, h).fold(0.0, f64::max);
    let radius = setup
        .taps
        .iter()
        .map(|t| t.x_mm.hypot(t.y_mm))
        .fold(0.0, f64::max);
    let bands = Bands::new(radius, widest, h, band);
    let reach = bands.reach;
    let cap = bands.rows(1);
    let weights = setup.accumulate.weights(setup.frames);
    let frames = Frames {
        first: setup.seed,
        weights: &weights,
    };
    let mut buf: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; cap * w]);
    // Rows `pending..a` of the output wait in `buf` from its start.
    let mut pending = 0;
    bands.sweep(|a, b| {
        let pass = Pass::new(image, setup);
        let tex = Planes(&image.rgb);
        let span = (a - pending) * w..(b - pending) * w;
        par_span_rows(&mut buf, span, w, |j, out| {
            pass.row(&tex, a + j, frames, out)
        });
        // The next band reads rows from b - reach on.
        let done = if b == h {
            h
        } else {
            b.saturating_sub(reach).max(pending)
        };
        for (c, plane) in buf.iter_mut().enumerate() {
            let n = (done - pending) * w;
            image.rgb[c][pending * w..done * w].copy_from_slice(&plane[..n]);
            plane.copy_within(n..(b - pending) * w, 0);
        }
        pending = done;
        progress.advance((b - a) as u64);
    });
}

/// The diffuse result of each frame `seed + k`, k < `frames`, apart (no
/// specular): what the error measures of `disk_error` average.
pub fn disk_frames(image: &Image, setup: &DiskSetup) -> Result<Vec<Image>> {
    setup.validate(image)?;
    check_cpu_work(image, setup)?;
    let pass = Pass::new(image, setup);
    let tex = Packed::new(image);
    Ok((0..setup.frames)
        .map(|k| pass.run(&tex, setup.seed.wrapping_add(k), 1))
        .collect())
}

/// The frames a row of the pass accumulates: seeds `first..`, each with
/// its weight.
#[derive(Clone, Copy)]
struct Frames<'w> {
    first: u32,
    weights: &'w [f64],
}

struct Pass<'a> {
    image: &'a Image,
    setup: &'a DiskSetup,
    /// [`super::Scale::step_base`] of the image's height.
    base: f64,
    depth: Option<&'a [f64]>,
    follow: Option<f64>,
    /// Each sample's weight per channel, the fourth lane zero.
    weights: Vec<[f64; 4]>,
    /// The samples' unrotated positions, mm, apart (four lanes at a time).
    tx: Vec<f64>,
    ty: Vec<f64>,
    /// Whether the samples may go four at a time ([`disk_lanes`]): AVX2,
    /// no depth-aware lerp.
    lanes: bool,
}

impl<'a> Pass<'a> {
    fn new(image: &'a Image, setup: &'a DiskSetup) -> Pass<'a> {
        let v = &setup.view;
        Pass {
            image,
            setup,
            base: v.scale.step_base(image.height),
            depth: v.depth.as_ref().map(|d| d.data.as_slice()),
            follow: v.follow_surface.map(|f| f.rate(&v.scale)),
            weights: setup
                .taps
                .iter()
                .map(|t| [t.weight[0], t.weight[1], t.weight[2], 0.0])
                .collect(),
            tx: setup.taps.iter().map(|t| t.x_mm).collect(),
            ty: setup.taps.iter().map(|t| t.y_mm).collect(),
            lanes: disk_lanes::usable(image.width, image.height)
                && !(v.follow_surface.is_some() && v.depth.is_some()),
        }
    }

    fn run(&self, tex: &Packed, first: u32, frames: u32) -> Image {
        let (w, h) = (self.image.width, self.image.height);
        let weights = self.setup.accumulate.weights(frames);
        let f = Frames {
            first,
            weights: &weights,
        };
        let rgb = par_rows(w, h, |y, out| self.row(tex, y, f, out));
        Image {
            width: w,
            height: h,
            rgb,
            alpha: self.image.alpha.clone(),
        }
    }

    /// Row `y` of the pass into `out`, in AVX2 where the CPU has it (the
    /// same operations, four lanes at once).
    fn row<T: Texels>(&self, tex: &T, y: usize, f: Frames, out: [&mut [f64]; 3]) {
        #[cfg(target_arch = "x86_64")]
        if crate::numerics::has_avx2() {
            // SAFETY: has_avx2 checked the CPU features.
            return unsafe { self.row_avx2(tex, y, f, out) };
        }
        self.row_lanes(tex, y, f, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_avx2<T: Texels>(&self, tex: &T, y: usize, f: Frames, out: [&mut [f64]; 3]) {
        self.row_lanes(tex, y, f, out)
    }

    #[inline(always)]
    fn row_lanes<T: Texels>(&self, tex: &T, y: usize, f: Frames, out: [&mut [f64]; 3]) {
        let [r, g, b] = out;
        for x in 0..self.image.width {
            let v = self.pixel(tex, x, y, f.first, f.weights);
            (r[x], g[x], b[x]) = (v[0], v[1], v[2]);
        }
    }

    /// The four pixels around (px, py), already clamped to the image, and
    /// their bilinear weights.
    #[inline(always)]
    fn corners(&self, px: f64, py: f64) -> ([usize; 4], [f64; 4]) {
        let (w, h) = (self.image.width, self.image.height);
        // px, py >= 0: truncation is floor.
        let (x0, y0) = (px as usize, py as usize);
        let (fx, fy) = (px - x0 as f64, py - y0 as f64);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        (
            [y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1],
            [
                (1.0 - fx) * (1.0 - fy),
                fx * (1.0 - fy),
                (1.0 - fx) * fy,
                fx * fy,
            ],
        )
    }

    /// The first samples, a multiple of four, added to `frame` four at a
    /// time where [`disk_lanes`] may run (an AVX2 CPU, a packed image, no
    /// lerp); how many it added (0 elsewhere).
    #[inline(always)]
    fn add_lanes<T: Texels>(
        &self,
        tex: &T,
        [x, y]: [usize; 2],
        step: f64,
        (sin, cos): (f64, f64),
        frame: &mut [f64; 4],
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if let (true, Some(texels)) = (self.lanes, tex.packed()) {
            let n = self.tx.len() / 4 * 4;
            let f = disk_lanes::Frame {
                texels,
                w: self.image.width,
                h: self.image.height,
                x,
                y,
                step,
                sin,
                cos,
            };
            // SAFETY: `lanes` checked the CPU and the image's size.
            unsafe {
                disk_lanes::add_samples(&f, &self.tx[..n], &self.ty[..n], &self.weights[..n], frame)
            };
            return n;
        }
        let _ = (tex, x, y, step, sin, cos, frame);
        0
    }

    /// Frame `first + f` weighted by `weights[f]` (`Accumulate::weights`).
    #[inline(always)]
    fn pixel<T: Texels>(
        &self,
        tex: &T,
        x: usize,
        y: usize,
        first: u32,
        weights: &[f64],
    ) -> [f64; 3] {
        let (w, h) = (self.image.width, self.image.height);
        let centre = y * w + x;
        let step = self.setup.view.step_at(self.base, centre);
        let rgb = &self.image.rgb;
        let centre_colour = [rgb[0][centre], rgb[1][centre], rgb[2][centre], 0.0];
        let mut acc = [0.0; 4];
        for (f, &wf) in (0u32..).zip(weights) {
            let mut frame = [0.0; 4];
            let turn = rotation_unit(x as u32, y as u32, first.wrapping_add(f));
            let (sin, cos) = (2.0 * PI * turn).sin_cos();
            let done = self.add_lanes(tex, [x, y], step, (sin, cos), &mut frame);
            let rest = self.setup.taps.iter().zip(&self.weights).skip(done);
            for (t, tw) in rest {
                let dx = step * (t.x_mm * cos - t.y_mm * sin);
                let dy = step * (t.x_mm * sin + t.y_mm * cos);
                let px = (x as f64 + dx).clamp(0.0, (w - 1) as f64);
                let py = (y as f64 + dy).clamp(0.0, (h - 1) as f64);
                let (idx, wt) = self.corners(px, py);
                let mut o = tex.bilinear(&idx, &wt);
                if let (Some(k), Some(d)) = (self.follow, self.depth) {
                    let ds: f64 = (0..4).map(|k| d[idx[k]] * wt[k]).sum();
                    let t = super::follow_t(k, d[centre], ds);
                    for l in 0..4 {
                        o[l] = o[l] * (1.0 - t) + centre_colour[l] * t;
                    }
                }
                for l in 0..4 {
                    frame[l] += tw[l] * o[l];
                }
            }
            for l in 0..4 {
                acc[l] += wf * frame[l];
            }
        }
        [acc[0], acc[1], acc[2]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::signals::noise;
    use crate::filter::{FollowSurface, Plane, Scale};

    #[test]
    fn bands_of_any_height_give_the_one_band_result_bit_for_bit() {
        let (w, h) = (17, 64);
        let img = noise(w, h, 5);
        let depth = Plane::from_index(w, h, |i| 1.0 + ((i * 31) % 7) as f64 * 0.1);
        let view = Setup {
            passes: vec![],
            scale: Scale::MmPerPixel(0.5),
            depth: Some(depth),
            strength: None,
            follow_surface: Some(FollowSurface::InSceneUnits(1.5)),
            specular: None,
            jitter: false,
        };
        let taps = (0..9)
            .map(|i| {
                let (r, a) = (0.3 * i as f64, 2.4 * i as f64);
                DiskTap {
                    x_mm: r * a.cos(),
                    y_mm: r * a.sin(),
                    weight: [0.1, 0.12, 0.09],
                }
            })
            .collect();
        let setup = DiskSetup {
            taps,
            view,
            seed: 3,
            frames: 2,
            accumulate: Accumulate::Mean,
        };
        // Reach: 2.4 mm x 2 px/mm + 2 = 7 rows, well under the height.
        crate::filter::band_check::assert_bands_agree(&img, &[1, 3, 8, 20], |out, band| {
            sweep(out, &setup, Some(band), &NoProgress)
        });
    }

    /// The packed image and the planes give one frame bit for bit, and the
    /// AVX2 rows (samples four at a time, `disk_lanes`) the plain ones:
    /// the layouts and lanes change where the channels and samples are
    /// summed, not the sums. Eleven samples (two groups of four and three
    /// alone) reaching past every edge, at one step and at a step per
    /// pixel (a strength image).
    #[test]
    fn layouts_and_lanes_give_the_same_frame_bit_for_bit() {
        let (w, h) = (21, 16);
        let img = noise(w, h, 11);
        let taps: Vec<DiskTap> = (0..11)
            .map(|i| {
                let (r, a) = (0.55 * i as f64, 2.4 * i as f64);
                DiskTap {
                    x_mm: r * a.cos(),
                    y_mm: r * a.sin(),
                    weight: [0.1, 0.13 - 0.01 * i as f64, 0.08],
                }
            })
            .collect();
        let strength = Plane::from_index(w, h, |i| 0.5 + ((i * 7) % 5) as f64 * 0.3);
        for strength in [None, Some(strength)] {
            let setup = DiskSetup {
                taps: taps.clone(),
                view: Setup {
                    passes: vec![],
                    scale: Scale::MmPerPixel(0.4),
                    depth: None,
                    strength,
                    follow_surface: None,
                    specular: None,
                    jitter: false,
                },
                seed: 5,
                frames: 1,
                accumulate: Accumulate::Mean,
            };
            let frame = disk_frames(&img, &setup).unwrap().swap_remove(0);
            let mut swept = img.clone();
            apply_disk_in_place(&mut swept, &setup).unwrap();
            assert_eq!(frame.rgb, swept.rgb);
            assert_ne!(frame.rgb, img.rgb);
            // Several frames, accumulated: packed and in place alike.
            let three = setup.with_frames(2, 3);
            let mut swept = img.clone();
            apply_disk_in_place(&mut swept, &three).unwrap();
            assert_eq!(apply_disk(&img, &three).unwrap().rgb, swept.rgb);
            let pass = Pass::new(&img, &setup);
            assert_eq!(pass.lanes, crate::numerics::has_avx2());
            let packed = Packed::new(&img);
            let planes = Planes(&img.rgb);
            for y in [0, 7, h - 1] {
                let mut a: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; w]);
                let mut b = a.clone();
                let [r, g, bl] = &mut a;
                let f = Frames {
                    first: 5,
                    weights: &[0.5, 0.5],
                };
                pass.row_lanes(&packed, y, f, [r, g, bl]);
                let [r, g, bl] = &mut b;
                pass.row(&planes, y, f, [r, g, bl]);
                for c in 0..3 {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a[c]), bits(&b[c]), "row {y} channel {c}");
                }
            }
        }
    }
}
