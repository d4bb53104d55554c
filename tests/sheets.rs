//! The contact sheets as a reader sees them, drawn from a real comparison
//! (skin1's committed profile, 32-pixel signals): the sheet opens with the
//! configuration that ships beside the exact result and a zoom at native
//! pixels; a tile of the wrong colour is framed and listed; no two text
//! boxes (measured by the sheet's own layout with its bundled font)
//! overlap and none leaves the page, long labels included; and the page
//! matches its golden PNG.

mod common;

use ssskit::filter::signals::Signal;
use ssskit::filter::Image;
use ssskit::profile::Profile;
use ssskit::report::eval::evaluate::{ImageCase, Options, Which};
use ssskit::report::eval::kernel_compare::{self, Comparison, Config, MaterialInput};
use ssskit::report::eval::shipped::Shipped;
use ssskit::report::present::kernel_plots::{contact_sheet, SheetOutcome};
use ssskit::report::present::layout::{collisions, Rect};
use std::path::{Path, PathBuf};

/// Side of the test signals: small enough to fit in a second, and narrow
/// tiles make every label wrap, the hardest case for the layout.
const SIZE: usize = 32;
/// Scale of the signals: skin1's kernel (radius holding 99% about 3 mm)
/// spans a good part of a 32-pixel tile.
const MM_PER_PIXEL: f64 = 0.25;
/// Tap count of the tables drawn.
const TAPS: usize = 9;
/// The index of the shapes case in [`comparison`].
const SHAPES: usize = 1;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn comparison() -> Comparison {
    let profile = Profile::read(&root().join("profiles/reference/skin1.json")).unwrap();
    let cases = [Signal::Edge, Signal::Shapes]
        .map(|s| ImageCase::signal(s, SIZE, MM_PER_PIXEL).unwrap())
        .to_vec();
    let cfg = Config {
        families: ["svd", "preintegrate", "manual"].map(String::from).to_vec(),
        ranks: vec![1],
        cases,
        taps: vec![TAPS],
        options: Options::default(),
        keep: Some(Which::Taps(TAPS)),
        extent_mm: None,
    };
    let input = MaterialInput {
        name: "skin1".into(),
        profile,
    };
    kernel_compare::run(&[input], &cfg, &ssskit::progress::NoProgress).unwrap()
}

/// A constant image of linear `rgb`.
fn constant(rgb: [f64; 3]) -> Image {
    let mut img = Image::new(SIZE, SIZE);
    for (plane, v) in img.rgb.iter_mut().zip(rgb) {
        plane.fill(v);
    }
    img
}

/// The pixels of `r` in the RGB8 PNG at `png`.
fn pixels(png: &Path, r: &Rect) -> Vec<[u8; 3]> {
    let img = image::open(png).unwrap().to_rgb8();
    (r.y0..r.y1)
        .flat_map(|y| (r.x0..r.x1).map(move |x| (x, y)))
        .map(|(x, y)| img.get_pixel(x as u32, y as u32).0)
        .collect()
}

fn assert_layout_reads(sheet: &SheetOutcome, png: &Path) {
    let (w, h) = image::image_dimensions(png).unwrap();
    let page = Rect::at(0, 0, (w, h));
    let mut bad = collisions(&sheet.layout.texts, &page);
    for t in &sheet.layout.texts {
        for (i, r) in sheet.layout.images.iter().enumerate() {
            if t.rect.overlaps(r) {
                bad.push(format!("'{}' {:?} covers image {i} {r:?}", t.text, t.rect));
            }
        }
    }
    assert!(bad.is_empty(), "{}:\n  {}", png.display(), bad.join("\n  "));
}

/// The sheet opens with the shipped configuration (here a pure green
/// image, whatever the models look like): the input over the exact
/// result, then the shipped image, then the zoom tiles; the green tile is
/// framed in red as a colour far from the exact one and listed as such,
/// the models of the right colour are not.
#[test]
fn the_sheet_opens_with_what_ships_and_flags_a_wrong_colour() {
    let cmp = comparison();
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("sheet.png");
    let green = constant([0.0, 0.5, 0.0]);
    let label = "recommended: exact-2d (entry+exit)preintegrate svd1-renorm + angularsvd2, 9 taps \
                 over +-2.5 mm (extent holding 95.0%)";
    let shipped = Shipped {
        label: label.into(),
        images: vec![green.clone(), green],
    };
    let sheet = contact_sheet(&cmp, "skin1", SHAPES, "9-tap tables", Some(&shipped), &png).unwrap();
    assert_layout_reads(&sheet, &png);
    // Images in tile order: input, exact, shipped, its difference, zoom of
    // the exact, zoom of the shipped, then the models.
    let imgs = &sheet.layout.images;
    let models = cmp.fitted.len();
    assert_eq!(imgs.len(), 2 * (3 + models), "{imgs:?}");
    let framed = |r: &Rect| Rect {
        x0: r.x0 + 2,
        y0: r.y0 + 2,
        x1: r.x1 - 2,
        y1: r.y1 - 2,
    };
    let inner = pixels(&png, &framed(&imgs[2]));
    assert!(
        inner.iter().all(|p| p[0] == 0 && p[2] == 0 && p[1] > 100),
        "the third image is not the shipped green one"
    );
    assert!(
        pixels(&png, &imgs[2]).contains(&[200, 0, 0]),
        "no red frame"
    );
    // The zoom of the shipped image: green where the window is drawn.
    let zoom = pixels(&png, &imgs[5]);
    assert!(
        zoom.iter()
            .filter(|p| p[0] == 0 && p[2] == 0 && p[1] > 100)
            .count()
            >= SIZE * SIZE / 2
    );
    let first_words = &sheet.layout.texts[1..]
        .iter()
        .map(|t| t.text.as_str())
        .collect::<Vec<_>>();
    assert!(
        first_words
            .iter()
            .position(|t| t.starts_with("recommended"))
            < first_words.iter().position(|t| t.starts_with("svd1")),
        "{first_words:?}"
    );
    let flagged: Vec<&str> = sheet.flags.iter().map(|f| f.model.as_str()).collect();
    assert!(flagged.contains(&label), "{flagged:?}");
    assert!(!flagged.contains(&"preintegrate"), "{flagged:?}");
}

/// Without a shipped configuration (`compare`) the sheet opens with the
/// model of the lowest error on the case; its layout reads too, on both
/// signals.
#[test]
fn without_advice_the_best_model_leads() {
    let cmp = comparison();
    let dir = tempfile::tempdir().unwrap();
    for ci in 0..2 {
        let png = dir.path().join(format!("sheet{ci}.png"));
        let sheet = contact_sheet(&cmp, "skin1", ci, "9-tap tables", None, &png).unwrap();
        assert_layout_reads(&sheet, &png);
        assert!(
            sheet
                .layout
                .texts
                .iter()
                .any(|t| t.text.starts_with("lowest")),
            "{:?}",
            sheet.layout.texts
        );
    }
}

/// A pixel of the golden sheet may differ by this much in any channel (of
/// 255) and still match. The page is drawn deterministically: the images
/// are f64 arithmetic rounded to 8 bits and the text is the bundled DejaVu
/// Sans rasterised by ab_glyph (no system font), so on another machine
/// only a libm that rounds a last bit differently can move a pixel, by one
/// step; a label moved by a pixel changes the edges of its glyphs by far
/// more than 8.
const PIXEL_TOLERANCE: u8 = 8;

/// The shapes sheet of the comparison (no advice: the best model leads)
/// matches tests/golden/sheet-skin1-shapes.png pixel by pixel within
/// [`PIXEL_TOLERANCE`]; on a mismatch the page drawn and a diff image (red
/// where a pixel differs) go to target/golden-diffs/. `SSSKIT_BLESS=1`
/// rewrites the golden.
#[test]
fn the_sheet_matches_its_golden_png() {
    let cmp = comparison();
    let golden = root().join("tests/golden/sheet-skin1-shapes.png");
    let diffs = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join("golden-diffs");
    std::fs::create_dir_all(&diffs).unwrap();
    let drawn = diffs.join("sheet-skin1-shapes.png");
    contact_sheet(&cmp, "skin1", SHAPES, "9-tap tables", None, &drawn).unwrap();
    if common::bless() {
        std::fs::copy(&drawn, &golden).unwrap();
        return;
    }
    let a = image::open(&golden).unwrap().to_rgb8();
    let b = image::open(&drawn).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions(), "page size changed");
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
        diff.save(diffs.join("sheet-skin1-shapes.diff.png"))
            .unwrap();
    }
    assert_eq!(
        bad,
        0,
        "{bad} pixels differ by more than {PIXEL_TOLERANCE}: see {}",
        diffs.display()
    );
}
