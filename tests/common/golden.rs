//! Golden PNGs, the resvg way: a picture drawn by the test is compared
//! pixel by pixel with the committed one under a stated tolerance; on a
//! mismatch the picture drawn and a diff image (red where a pixel
//! differs) go to target/golden-diffs/. `SSSKIT_BLESS=1` (read by
//! [`super::bless`]) rewrites the golden instead.

use std::path::{Path, PathBuf};

/// A pixel of a golden picture may differ by this much in any channel (of
/// 255) and still match. The pictures are drawn deterministically: images
/// are f64 arithmetic rounded to 8 bits and the text is the bundled
/// DejaVu Sans rasterised by ab_glyph (no system font), so on another
/// machine only a libm that rounds a last bit differently can move a
/// pixel, by one step; a label moved by a pixel changes the edges of its
/// glyphs by far more than 8.
pub const PIXEL_TOLERANCE: u8 = 8;

/// Where pictures drawn for a golden comparison and their diff images go.
pub fn diff_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join("golden-diffs");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Draws `name` (tests/golden/`name`, a PNG) with `draw` into
/// target/golden-diffs/ and compares it with the golden within
/// [`PIXEL_TOLERANCE`]; blesses it under `SSSKIT_BLESS=1`.
pub fn check_png(name: &str, draw: impl FnOnce(&Path)) {
    let golden = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name);
    let diffs = diff_dir();
    let drawn = diffs.join(name);
    draw(&drawn);
    if super::bless() {
        std::fs::copy(&drawn, &golden).unwrap();
        return;
    }
    let a = image::open(&golden)
        .unwrap_or_else(|e| panic!("{}: {e} (bless with SSSKIT_BLESS=1)", golden.display()))
        .to_rgb8();
    let b = image::open(&drawn).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions(), "{name}: page size changed");
    let mut diff = image::RgbImage::new(a.width(), a.height());
    let mut bad = 0usize;
    for (x, y, p) in a.enumerate_pixels() {
        let q = b.get_pixel(x, y);
        let off = (0..3).any(|c| p.0[c].abs_diff(q.0[c]) > PIXEL_TOLERANCE);
        bad += off as usize;
        diff.put_pixel(
            x,
            y,
            image::Rgb(if off {
                [255, 0, 0]
            } else {
                [p.0[0] / 3 + 170; 3]
            }),
        );
    }
    if bad > 0 {
        let stem = name.trim_end_matches(".png");
        diff.save(diffs.join(format!("{stem}.diff.png"))).unwrap();
    }
    assert_eq!(
        bad,
        0,
        "{name}: {bad} pixels differ by more than {PIXEL_TOLERANCE}: see {}",
        diffs.display()
    );
}
