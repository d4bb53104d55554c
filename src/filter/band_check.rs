//! What the in-place sweeps' unit tests share.

use super::Image;

/// Filters a copy of `img` as one band of its whole height and a copy
/// per band height in `bands`, asserts each equals the one-band result
/// bit for bit (the sweeps' promise: the band height changes nothing)
/// and that the result is not the input; returns the one-band result.
pub fn assert_bands_agree(
    img: &Image,
    bands: &[usize],
    filter: impl Fn(&mut Image, usize),
) -> Image {
    let mut whole = img.clone();
    filter(&mut whole, img.height);
    for &band in bands {
        let mut banded = img.clone();
        filter(&mut banded, band);
        for c in 0..3 {
            for (i, (a, b)) in banded.rgb[c].iter().zip(&whole.rgb[c]).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "band {band}, c {c}, pixel {i}");
            }
        }
    }
    assert_ne!(
        whole.rgb[0], img.rgb[0],
        "the filter left the image as it was"
    );
    whole
}
