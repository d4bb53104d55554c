//! Test signals for kernels in image space (Freude 2014, section 6.2): the vertical
//! white-black edge, the circle with two tilted adjacent squares (Freude 2014, figure
//! 6.6), a single bright pixel (shows the cross-shaped asymmetry of rank-1
//! kernels), a checker.

use super::Image;
use crate::error::Result;

/// Default size of a generated test image, width x height pixels.
pub const DEFAULT_SIZE: (usize, usize) = (256, 256);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    Edge,
    Shapes,
    Dirac,
    Checker,
}

/// Supersampling per axis for the anti-aliased shapes.
const SS: usize = 4;

/// Builds `signal` at `width` x `height`; the checker's cells are
/// `checker_px` pixels wide.
pub fn generate(signal: Signal, width: usize, height: usize, checker_px: usize) -> Result<Image> {
    crate::limits::check_image_size("signal", width, height)?;
    let mut img = Image::new(width, height);
    let value = |x: usize, y: usize| -> f64 {
        match signal {
            // White left half, black right half.
            Signal::Edge => (x < width / 2) as u8 as f64,
            Signal::Dirac => (x == width / 2 && y == height / 2) as u8 as f64,
            Signal::Checker => {
                ((x / checker_px.max(1)) + (y / checker_px.max(1))).is_multiple_of(2) as u8 as f64
            }
            Signal::Shapes => coverage(x, y, width, height),
        }
    };
    for y in 0..height {
        for x in 0..width {
            let v = value(x, y);
            for c in 0..3 {
                img.rgb[c][y * width + x] = v;
            }
        }
    }
    Ok(img)
}

/// White noise in [0, 1): every sample of R, G, B in turn (row-major) from
/// one 64-bit linear congruential stream started at `seed` (Knuth's MMIX
/// constants; the top 53 bits of each state). Not a signal of the thesis: a
/// deterministic input with every spatial frequency, for checking that two
/// paths of the filter agree.
pub fn noise(width: usize, height: usize, seed: u64) -> Image {
    let mut img = Image::new(width, height);
    let mut s = seed;
    for c in 0..3 {
        for v in img.rgb[c].iter_mut() {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v = (s >> 11) as f64 / (1u64 << 53) as f64;
        }
    }
    img
}

/// Fraction of pixel (x, y) inside the circle or the two squares.
fn coverage(x: usize, y: usize, w: usize, h: usize) -> f64 {
    let s = w.min(h) as f64;
    let mut inside = 0;
    for sy in 0..SS {
        for sx in 0..SS {
            let px = x as f64 + (sx as f64 + 0.5) / SS as f64;
            let py = y as f64 + (sy as f64 + 0.5) / SS as f64;
            if in_shapes(px, py, w as f64, h as f64, s) {
                inside += 1;
            }
        }
    }
    inside as f64 / (SS * SS) as f64
}

fn in_shapes(px: f64, py: f64, w: f64, h: f64, s: f64) -> bool {
    // Circle on the left.
    let (cx, cy, r) = (0.28 * w, 0.5 * h, 0.2 * s);
    if (px - cx).powi(2) + (py - cy).powi(2) <= r * r {
        return true;
    }
    // Two squares tilted by 20 degrees, touching along one side.
    let half = 0.11 * s;
    let (sin, cos) = 20f64.to_radians().sin_cos();
    let centre = (0.7 * w, 0.5 * h);
    for k in [-1.0, 1.0] {
        // Square centres one side apart along the tilted x axis.
        let (qx, qy) = (centre.0 + k * half * cos, centre.1 + k * half * sin);
        let (dx, dy) = (px - qx, py - qy);
        let (u, v) = (dx * cos + dy * sin, -dx * sin + dy * cos);
        if u.abs() <= half && v.abs() <= half {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signals_hold_what_they_promise() {
        let e = generate(Signal::Edge, 10, 4, 1).unwrap();
        assert_eq!(e.rgb[0][4], 1.0);
        assert_eq!(e.rgb[0][5], 0.0);
        let d = generate(Signal::Dirac, 9, 7, 1).unwrap();
        assert_eq!(d.rgb[1].iter().sum::<f64>(), 1.0);
        assert_eq!(d.rgb[1][3 * 9 + 4], 1.0);
        let s = generate(Signal::Shapes, 200, 100, 1).unwrap();
        let covered: f64 = s.rgb[0].iter().sum();
        // Circle (pi 20^2) plus two squares (2 * 22^2) in pixels.
        let expected = std::f64::consts::PI * 400.0 + 2.0 * 484.0;
        assert!((covered - expected).abs() < 0.02 * expected, "{covered}");
        let c = generate(Signal::Checker, 8, 8, 2).unwrap();
        assert_eq!(c.rgb[0].iter().sum::<f64>(), 32.0);
    }
}
