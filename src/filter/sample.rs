//! What the fixed-kernel path works with, shared by the strip sweep
//! ([`super::sweep`]) and its callers ([`super::separable`]): a 1D kernel
//! on whole pixels, the sample types it runs in and their per-thread
//! buffers.

use super::Taps;

/// A 1D kernel on whole pixels: `weights[k]` at pixel offset `first + k`.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelKernel {
    pub first: i64,
    pub weights: Vec<[f64; 3]>,
}

impl PixelKernel {
    /// The taps at a constant step (pixels per mm): each tap's linear
    /// interpolation between its two neighbouring pixels is folded into the
    /// integer kernel. With clamp-to-edge sampling this equals the per-pixel
    /// algorithm exactly (clamping the position or the two indices gives the
    /// same samples).
    pub fn from_taps(t: &Taps, step: f64) -> PixelKernel {
        // A tap within round-off of a whole pixel stays one entry; the
        // bounds come from the same snapped positions as the loop below.
        let pos: Vec<f64> = t
            .offsets_mm
            .iter()
            .map(|o| {
                let p = o * step;
                if (p - p.round()).abs() < 1e-9 {
                    p.round()
                } else {
                    p
                }
            })
            .collect();
        let lo = pos.iter().fold(f64::INFINITY, |a, &p| a.min(p.floor())) as i64;
        let hi = pos.iter().fold(f64::NEG_INFINITY, |a, &p| a.max(p.floor())) as i64 + 1;
        let mut weights = vec![[0.0; 3]; (hi - lo + 1) as usize];
        for (&p, w) in pos.iter().zip(&t.weights) {
            let i0 = p.floor();
            let f = p - i0;
            let k = (i0 as i64 - lo) as usize;
            for c in 0..3 {
                weights[k][c] += w[c] * (1.0 - f);
                weights[k + 1][c] += w[c] * f;
            }
        }
        PixelKernel { first: lo, weights }
    }
}

/// Per-thread buffers, kept between calls: a renderer's frame allocates
/// nothing once the threads have run one frame.
pub struct Scratch<T> {
    pub(super) pad: Vec<T>,
    pub(super) ring: Vec<T>,
    pub(super) offsets: Vec<usize>,
}

impl<T> Default for Scratch<T> {
    fn default() -> Scratch<T> {
        Scratch::new()
    }
}

impl<T> Scratch<T> {
    pub const fn new() -> Scratch<T> {
        Scratch {
            pad: Vec::new(),
            ring: Vec::new(),
            offsets: Vec::new(),
        }
    }
}

/// The working precision of the fixed-kernel path (and the sample type of
/// the planes it reads and writes).
pub trait Sample:
    Copy
    + Default
    + Send
    + Sync
    + std::ops::Add<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::AddAssign
    + std::iter::Sum
    + 'static
{
    fn from_f64(v: f64) -> Self;
    fn to_f64(self) -> f64;
    /// The same value in this precision (exact when widening; an f32 to
    /// f32 round trip through f64 compiles to nothing).
    #[inline(always)]
    fn from_sample<S: Sample>(v: S) -> Self {
        Self::from_f64(v.to_f64())
    }
    /// Runs `f` with this thread's buffers of this precision.
    fn with_scratch<R>(f: impl FnOnce(&mut Scratch<Self>) -> R) -> R;
}

thread_local! {
    static SCRATCH_F64: std::cell::RefCell<Scratch<f64>> =
        const { std::cell::RefCell::new(Scratch::new()) };
    static SCRATCH_F32: std::cell::RefCell<Scratch<f32>> =
        const { std::cell::RefCell::new(Scratch::new()) };
}

impl Sample for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    fn with_scratch<R>(f: impl FnOnce(&mut Scratch<f64>) -> R) -> R {
        SCRATCH_F64.with_borrow_mut(f)
    }
}

impl Sample for f32 {
    #[inline(always)]
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn with_scratch<R>(f: impl FnOnce(&mut Scratch<f32>) -> R) -> R {
        SCRATCH_F32.with_borrow_mut(f)
    }
}
