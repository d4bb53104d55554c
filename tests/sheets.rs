//! The contact sheets as a reader sees them, drawn from a real comparison
//! (skin1's committed profile, 32-pixel signals): the sheet opens with the
//! configuration that ships beside the exact result and a zoom at native
//! pixels; a tile of the wrong colour is framed and listed; no two text
//! boxes (measured by the sheet's own layout with its bundled font)
//! overlap and none leaves the page, long labels included; and the page
//! matches its golden PNG.

mod common;

use common::golden;
use common::skin1::{comparison, SHAPES, SIZE};
use ssskit::filter::Image;
use ssskit::report::eval::compare::sheets::sheet_tiles;
use ssskit::report::eval::ship::shipped::Shipped;
use ssskit::report::present::kernel_plots::{contact_sheet, SheetOutcome};
use ssskit::report::present::layout::{collisions, Rect};
use std::path::Path;

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
    let lead = (shipped.label.as_str(), shipped.images.as_slice());
    let tiles = sheet_tiles(&cmp, "skin1", SHAPES, Some(lead)).unwrap();
    let sheet = contact_sheet(&tiles, "9-tap tables", &png).unwrap();
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
        let tiles = sheet_tiles(&cmp, "skin1", ci, None).unwrap();
        let sheet = contact_sheet(&tiles, "9-tap tables", &png).unwrap();
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

/// The shapes sheet of the comparison (no advice: the best model leads)
/// matches tests/golden/sheet-skin1-shapes.png pixel by pixel within
/// [`golden::PIXEL_TOLERANCE`]; on a mismatch the page drawn and a diff
/// image go to target/golden-diffs/. `SSSKIT_BLESS=1` rewrites the golden.
#[test]
fn the_sheet_matches_its_golden_png() {
    let cmp = comparison();
    let tiles = sheet_tiles(&cmp, "skin1", SHAPES, None).unwrap();
    golden::check_png("sheet-skin1-shapes.png", |drawn| {
        contact_sheet(&tiles, "9-tap tables", drawn).unwrap();
    });
}
