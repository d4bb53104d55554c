//! Caps on work and memory, derived from the inputs and checked before any
//! allocation they guard, so that no input can make ssskit eat a shared
//! machine. Each error names the limit, the value that broke it and what to
//! change. The caps in one place:
//!
//! - worker threads: [`THREADS_PER_CORE`] x the available cores;
//! - images: at most [`MAX_IMAGE_PIXELS`] pixels and [`MAX_IMAGE_SIDE`] per
//!   side, on read and on write (so ssskit reads back every image it writes);
//! - 1D kernels applied as fixed pixel kernels: at most
//!   [`max_kernel_pixels`] wide for the image, and at most
//!   [`MAX_FILTER_WORK`] multiply-adds per filtering;
//! - the exact 2D reference convolution: at most [`MAX_FFT_CELLS`] cells in
//!   its padded FFT grid;
//! - files whose headers state counts (.mci runs, layers, bins): the counts
//!   must fit in the file's length (see `profile::mc::mci`).

use crate::error::{Error, Result};

/// Worker threads allowed per available core: more only adds scheduling
/// overhead (results never depend on the thread count).
pub const THREADS_PER_CORE: usize = 4;

/// Cores this process may run on (1 when the system does not say).
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Most worker threads a caller may ask for.
pub fn max_threads() -> usize {
    THREADS_PER_CORE * available_cores()
}

/// Refuses a thread count of 0 or above [`max_threads`]; `context` names the
/// parameter.
pub fn check_threads(context: &str, n: usize) -> Result<()> {
    let max = max_threads();
    if n == 0 || n > max {
        return Err(Error::invalid(
            context,
            "threads",
            n,
            format!(
                "must be between 1 and {max} ({THREADS_PER_CORE} per available core, {} \
                 cores); results are the same for any thread count",
                available_cores()
            ),
        ));
    }
    Ok(())
}

/// Largest image, in pixels: 2^25, room for an 8K UHD frame (7680 x 4320).
/// An image in memory takes 32 bytes per pixel (f64 RGB and alpha), 1 GiB
/// at this size, and a 16-bit RGBA PNG of it decodes within the decoder's
/// allocation limit ([`PNG_DECODE_BYTES`]).
pub const MAX_IMAGE_PIXELS: usize = 1 << 25;
/// Longest image side.
pub const MAX_IMAGE_SIDE: usize = 16384;
/// The PNG decoder's allocation limit: a 16-bit RGBA image of
/// [`MAX_IMAGE_PIXELS`] pixels (8 bytes each) fits exactly.
pub const PNG_DECODE_BYTES: u64 = 8 * MAX_IMAGE_PIXELS as u64;

/// Refuses an image size outside 1..=[`MAX_IMAGE_SIDE`] per side or above
/// [`MAX_IMAGE_PIXELS`]; `what` names the image (file or parameter).
pub fn check_image_size(what: &str, width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::invalid(
            what,
            "size",
            format!("{width}x{height}"),
            "an image needs at least one pixel",
        ));
    }
    let pixels = width.saturating_mul(height);
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE || pixels > MAX_IMAGE_PIXELS {
        return Err(Error::invalid(
            what,
            "size",
            format!("{width}x{height}"),
            format!(
                "images are limited to {MAX_IMAGE_SIDE} pixels per side and {MAX_IMAGE_PIXELS} \
                 pixels in all (e.g. 7680x4320; 1 GiB in memory): use a smaller image"
            ),
        ));
    }
    Ok(())
}

/// Widest 1D pixel kernel applied to a `width` x `height` image: four times
/// the longer side (with clamp-to-edge borders, taps further out all read the
/// border pixel), and never less than 4096.
pub fn max_kernel_pixels(width: usize, height: usize) -> usize {
    (4 * width.max(height)).max(4096)
}

/// Most multiply-adds one filtering may take (pixels x taps x channels x
/// passes): about a minute of CPU time on two cores.
pub const MAX_FILTER_WORK: f64 = 1e12;

/// Most cells of the padded FFT grid of an exact 2D convolution: 2^26,
/// three complex f64 buffers of it are 3 GiB.
pub const MAX_FFT_CELLS: usize = 1 << 26;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_cap_scales_with_cores() {
        assert!(check_threads("t", 1).is_ok());
        assert!(check_threads("t", max_threads()).is_ok());
        let e = check_threads("t", max_threads() + 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("per available core"), "{e}");
        assert!(check_threads("t", 0).is_err());
    }

    #[test]
    fn image_cap_admits_8k_and_refuses_more() {
        assert!(check_image_size("i", 7680, 4320).is_ok());
        assert!(check_image_size("i", 16384, 2048).is_ok());
        assert!(check_image_size("i", 16384, 16384).is_err());
        assert!(check_image_size("i", 16385, 1).is_err());
        assert!(check_image_size("i", 0, 5).is_err());
        assert!(check_image_size("i", usize::MAX, usize::MAX).is_err());
    }
}
