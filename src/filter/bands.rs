//! The banded in-place sweep shared by the per-pixel filters
//! (`screen_space`, `disk`): output rows are computed top to bottom in
//! bands, and a band's rows replace their input once no later band reads
//! them, so the filter holds a few reaches of rows besides the image rather
//! than a full-size output (796 MB at 8K in f64). The reach is the farthest
//! row above or below its own that a sample of a pixel reads.

/// Fewest rows per band: the rows of a band are shared between threads.
const MIN_BAND_ROWS: usize = 32;

/// Band height in reaches: what a sweep keeps beside the band is a few
/// reaches of rows (the rows the next band still reads), so a band of two
/// reaches keeps the copied or waiting rows at most as many as the new ones.
const BAND_PER_REACH: usize = 2;

/// Rows beyond `ceil(max offset x max step)` a sample reads: one for the
/// floor of a negative position, one for the second row of the linear
/// (or bilinear) fetch.
const REACH_MARGIN_ROWS: f64 = 2.0;

/// The bands of one sweep over an image `h` rows tall.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bands {
    /// Rows above or below its own that a sample can read (at most `h`).
    pub reach: usize,
    /// Output rows per band, 1..=h.
    pub band: usize,
    pub h: usize,
}

impl Bands {
    /// The bands for samples at most `offset` (mm) from their pixel under
    /// steps at most `widest` (pixels per mm): bands of `band` rows, or
    /// (None) of [`BAND_PER_REACH`] reaches and at least [`MIN_BAND_ROWS`].
    pub fn new(offset: f64, widest: f64, h: usize, band: Option<usize>) -> Bands {
        let r = (offset * widest).ceil() + REACH_MARGIN_ROWS;
        // NaN or beyond the image: every row.
        let reach = if r < h as f64 { r as usize } else { h };
        let band = band
            .unwrap_or_else(|| BAND_PER_REACH.saturating_mul(reach).max(MIN_BAND_ROWS))
            .clamp(1, h);
        Bands { reach, band, h }
    }

    /// Rows of a buffer holding a band and `reaches` reaches (at most `h`).
    pub fn rows(&self, reaches: usize) -> usize {
        self.band
            .saturating_add(reaches.saturating_mul(self.reach))
            .min(self.h)
    }

    /// Calls `f(a, b)` for each band of output rows `a..b`, top to bottom.
    pub fn sweep(&self, mut f: impl FnMut(usize, usize)) {
        let mut a = 0;
        while a < self.h {
            let b = (a + self.band).min(self.h);
            f(a, b);
            a = b;
        }
    }
}
