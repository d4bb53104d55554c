//! The figures of a report: each PNG with the one-line caption that says
//! what it shows, listed in report.md with a link.

/// One PNG of a report, by its file name in the report's folder.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    pub file: String,
    pub caption: String,
}

/// The contact sheet of `signal` at `mm_per_pixel`: `lead` is what opens
/// it ("what ships" or the model of lowest error), `factor` which factors
/// the models' tiles use.
pub fn sheet(file: &str, signal: &str, mm_per_pixel: f64, lead: &str, factor: &str) -> Figure {
    Figure {
        file: file.into(),
        caption: format!(
            "the {signal} signal at {mm_per_pixel} mm per pixel: {lead} beside the exact 2D \
             convolution with the profile (and both zoomed 4x where they differ most), then \
             every model's result with {factor} above its difference from the exact image \
             (white = 5% of its peak); tiles of the wrong colour framed in red"
        ),
    }
}

/// The kernel slices of `material`; `disk` where the recommended kernel is
/// a disk kernel, shown by its samples' weights per ring.
pub fn slices(file: &str, material: &str, recommended: Option<bool>) -> Figure {
    let rec = match recommended {
        Some(true) => {
            "; the recommended disk kernel in purple as its samples' weights per ring (each \
             sample's weight over the ring halfway to its neighbours' radii, over the ring's \
             area: a disk kernel rotated per pixel is the same in every direction, so the curve \
             is one in both rows)"
        }
        Some(false) => "; the recommended kernel in purple (its full factors)",
        None => "",
    };
    Figure {
        file: file.into(),
        caption: format!(
            "the 2D kernel of {material} per channel along the axis (top) and the diagonal \
             (bottom), log scale, of the ground truth (dashed) and each rank-1 model{rec}"
        ),
    }
}

/// The singular value spectra.
pub fn spectra(file: &str) -> Figure {
    Figure {
        file: file.into(),
        caption: "the singular values of each material's exact 2D kernel per channel over the \
                  first: how fast an SVD of rank N can approach it (the ground truth's, not a \
                  fitted kernel's)"
            .into(),
    }
}

/// The profile plot.
pub fn profile(file: &str, material: &str) -> Figure {
    Figure {
        file: file.into(),
        caption: format!(
            "R_d(r) of {material} per channel, linear near the centre and logarithmic over the \
             whole range: the profile every kernel is fitted to"
        ),
    }
}

/// The report's list of its figures: a link and the caption per PNG.
pub fn markdown(figures: &[Figure]) -> String {
    let mut s = String::from("\n## Figures\n\n");
    for f in figures {
        s.push_str(&format!("- [{0}]({0}): {1}.\n", f.file, f.caption));
    }
    s
}
