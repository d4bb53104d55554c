//! Where text goes on a plot, decided before anything is drawn: tick
//! values that read (decades in plain notation, never two labels
//! touching) and point labels that never collide with one another, with a
//! marker or with the panel's edge. Pure geometry on pixel boxes measured
//! with the plot's own font, so a test can check the layout a PNG was
//! drawn from.

/// A text or marker box in pixels: left, top, right, bottom (exclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x0: i32,
    pub y0: i32,
    pub x1: i32,
    pub y1: i32,
}

impl Rect {
    /// The box of `(w, h)` pixels whose top-left corner is `(x, y)`.
    pub fn at(x: i32, y: i32, (w, h): (u32, u32)) -> Rect {
        Rect {
            x0: x,
            y0: y,
            x1: x + w as i32,
            y1: y + h as i32,
        }
    }

    /// The two boxes share at least one pixel.
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// This box lies wholly inside `o`.
    pub fn inside(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.y0 >= o.y0 && self.x1 <= o.x1 && self.y1 <= o.y1
    }

    /// Grown by `m` pixels on every side.
    pub fn grown(&self, m: i32) -> Rect {
        Rect {
            x0: self.x0 - m,
            y0: self.y0 - m,
            x1: self.x1 + m,
            y1: self.y1 + m,
        }
    }
}

/// One piece of text as drawn: what it says and its box.
#[derive(Clone, Debug, PartialEq)]
pub struct TextBox {
    pub text: String,
    pub rect: Rect,
}

/// The pairs of boxes in `boxes` that overlap, and the boxes that leave
/// `bounds`: what a readable layout has none of.
pub fn collisions(boxes: &[TextBox], bounds: &Rect) -> Vec<String> {
    let mut out = Vec::new();
    for (i, a) in boxes.iter().enumerate() {
        if !a.rect.inside(bounds) {
            out.push(format!("'{}' leaves the image at {:?}", a.text, a.rect));
        }
        for b in &boxes[i + 1..] {
            if a.rect.overlaps(&b.rect) {
                out.push(format!(
                    "'{}' {:?} overlaps '{}' {:?}",
                    a.text, a.rect, b.text, b.rect
                ));
            }
        }
    }
    out
}

/// A tick value as an axis shows it: plain notation inside 1e-3..1e4
/// ("0.002", "0.1", "1", "20", "5000"), otherwise "2e-5", "1e6". Tick
/// values are m x 10^k with a one-digit m, so no digits are lost.
pub fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let k = v.abs().log10().floor() as i32;
    let m = (v / 10f64.powi(k)).round();
    if (-3..4).contains(&k) {
        if k >= 0 {
            format!("{}", (m * 10f64.powi(k)).round())
        } else {
            format!("{:.*}", (-k) as usize, m * 10f64.powi(k))
        }
    } else {
        format!("{m}e{k}")
    }
}

/// Candidate tick sets on a log axis over `[lo, hi]`, densest first:
/// 1..9 x 10^k (only on an axis spanning under two decades), 1, 2 and 5 x
/// 10^k, every decade, then every 2nd, 3rd, ... decade.
pub fn log_tick_sets(lo: f64, hi: f64) -> Vec<Vec<f64>> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return vec![];
    }
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let within = |v: &f64| *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12);
    let with = |ms: &[f64], every: i32| -> Vec<f64> {
        (k0..=k1)
            .filter(|k| k.rem_euclid(every) == 0)
            .flat_map(|k| ms.iter().map(move |m| m * 10f64.powi(k)))
            .filter(within)
            .collect()
    };
    let mut sets = Vec::new();
    if k1 - k0 <= 2 {
        sets.push(with(&[1., 2., 3., 4., 5., 6., 7., 8., 9.], 1));
    }
    sets.push(with(&[1., 2., 5.], 1));
    for every in 1..=(k1 - k0).max(1) {
        sets.push(with(&[1.], every));
    }
    sets.retain(|s| !s.is_empty());
    sets
}

/// The densest tick set whose labels, boxed by `label_box` (the label's
/// box on the axis for a tick value of a set), keep at least `gap` pixels
/// apart; a set of two ticks or more is preferred over one of a single
/// tick.
pub fn pick_ticks(
    sets: &[Vec<f64>],
    gap: i32,
    label_box: impl Fn(f64, &[f64]) -> Rect,
) -> Vec<f64> {
    let fits = |set: &[f64]| {
        let boxes: Vec<Rect> = set
            .iter()
            .map(|&v| label_box(v, set).grown(gap / 2))
            .collect();
        boxes
            .iter()
            .enumerate()
            .all(|(i, a)| boxes[i + 1..].iter().all(|b| !a.overlaps(b)))
    };
    let fitting: Vec<&Vec<f64>> = sets.iter().filter(|s| fits(s)).collect();
    fitting
        .iter()
        .find(|s| s.len() >= 2)
        .or(fitting.first())
        .map(|s| s.to_vec())
        .unwrap_or_default()
}

/// Candidate tick sets on a linear axis over `[lo, hi]`, densest first:
/// the multiples of 1, 2 and 5 x 10^k inside the range, from steps of a
/// hundredth of the span to steps of the whole span.
pub fn linear_tick_sets(lo: f64, hi: f64) -> Vec<Vec<f64>> {
    if !(hi > lo && lo.is_finite() && hi.is_finite()) {
        return vec![];
    }
    let k0 = ((hi - lo) / 100.0).log10().floor() as i32;
    let mut sets = Vec::new();
    for k in k0..=k0 + 3 {
        for m in [1.0, 2.0, 5.0] {
            let step = m * 10f64.powi(k);
            let (a, b) = ((lo / step - 1e-9).ceil(), (hi / step + 1e-9).floor());
            let set: Vec<f64> = (a as i64..=b as i64).map(|n| n as f64 * step).collect();
            if (2..=101).contains(&set.len()) {
                sets.push(set);
            }
        }
    }
    sets
}

/// A linear tick value `v` on an axis of ticks `step` apart: plain, with
/// at most the step's decimals ("1", "1.2", never "1.0"), or n e k (`n`
/// integer, "15e-5") where the step is under 1e-3 or a value reaches 1e4,
/// with the step's exponent k on every label of the axis ("5e-4, 10e-4,
/// 15e-4", not "5e-4, 1e-3, 15e-4": one exponent reads as one scale).
pub fn linear_tick_label(v: f64, step: f64) -> String {
    if v == 0.0 || !(step > 0.0) {
        return "0".into();
    }
    let k = step.log10().floor() as i32;
    if k >= -3 && v.abs() < 1e4 {
        let s = format!("{:.*}", (-k).max(0) as usize, v);
        return match s.contains('.') {
            true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
            false => s,
        };
    }
    let n = (v / 10f64.powi(k)).round() as i64;
    format!("{n}e{k}")
}

/// Where a label goes relative to its marker at `(x, y)` for a text of
/// `size` pixels: right and above, right and below, left and above, left
/// and below, straight above, straight below, further right; `r` is the
/// marker's radius.
fn offsets(size: (u32, u32), r: i32) -> [(i32, i32); 8] {
    let (w, h) = (size.0 as i32, size.1 as i32);
    let pad = r + 2;
    [
        (pad, -h - 1),
        (pad, 1),
        (-pad - w, -h - 1),
        (-pad - w, 1),
        (-w / 2, -h - pad),
        (-w / 2, pad),
        (pad, -h / 2),
        (-pad - w, -h / 2),
    ]
}

/// The placement of point labels: each label's box, or None where no
/// position fits (the caller numbers it and lists it in a key).
pub struct Placement {
    pub boxes: Vec<Option<Rect>>,
}

/// Places the label of each marker at `points[i]` (pixels, with text
/// `sizes[i]`) at the first position of [`offsets`] whose box stays inside
/// `bounds` and overlaps no marker, no label placed before it and nothing
/// in `taken` (tick labels, legend, title). Markers are boxes of radius
/// `r`.
pub fn place_labels(
    points: &[(i32, i32)],
    sizes: &[(u32, u32)],
    r: i32,
    bounds: &Rect,
    taken: &[Rect],
) -> Placement {
    let markers: Vec<Rect> = points
        .iter()
        .map(|&(x, y)| Rect {
            x0: x - r,
            y0: y - r,
            x1: x + r + 1,
            y1: y + r + 1,
        })
        .collect();
    let mut placed: Vec<Rect> = taken.to_vec();
    let mut boxes = Vec::with_capacity(points.len());
    for (&(x, y), &size) in points.iter().zip(sizes) {
        let found = offsets(size, r).into_iter().find_map(|(dx, dy)| {
            let b = Rect::at(x + dx, y + dy, size);
            let free = b.inside(bounds)
                && !markers.iter().any(|m| m.overlaps(&b))
                && !placed.iter().any(|p| p.grown(1).overlaps(&b));
            free.then_some(b)
        });
        if let Some(b) = found {
            placed.push(b);
        }
        boxes.push(found);
    }
    Placement { boxes }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_plain_inside_the_readable_range() {
        let cases = [
            (0.001, "0.001"),
            (0.05, "0.05"),
            (0.1, "0.1"),
            (1.0, "1"),
            (20.0, "20"),
            (5000.0, "5000"),
            (1e4, "1e4"),
            (2e-4, "2e-4"),
            (3e6, "3e6"),
        ];
        for (v, want) in cases {
            assert_eq!(tick_label(v), want, "{v}");
        }
    }

    #[test]
    fn log_ticks_are_decades_and_two_and_five_where_they_fit() {
        // Under two decades: every digit is a candidate, densest first.
        let short = log_tick_sets(3.0, 90.0);
        assert_eq!(
            short[0],
            vec![3., 4., 5., 6., 7., 8., 9., 10., 20., 30., 40., 50., 60., 70., 80., 90.]
        );
        let sets = log_tick_sets(3.0, 900.0);
        assert_eq!(sets[0], vec![5., 10., 20., 50., 100., 200., 500.]);
        assert_eq!(sets[1], vec![10., 100.]);
        // 30 px per decade, labels 20 px wide with a 4 px gap: 1-2-5 is
        // too dense (2 and 5 sit 12 px apart on a log axis), decades fit.
        let px = |v: f64| (30.0 * v.log10()) as i32;
        let b = |v: f64, _: &[f64]| Rect::at(px(v) - 10, 0, (20, 12));
        assert_eq!(pick_ticks(&sets, 4, b), vec![10., 100.]);
        // 300 px per decade: 1-2-5 fits; on the short axis the nine per
        // decade do not (8 and 9 sit 15 px apart), 1-2-5 does.
        let px = |v: f64| (300.0 * v.log10()) as i32;
        let b = |v: f64, _: &[f64]| Rect::at(px(v) - 10, 0, (20, 12));
        assert_eq!(pick_ticks(&sets, 4, b), sets[0]);
        assert_eq!(pick_ticks(&short, 4, b), vec![5., 10., 20., 50.]);
    }

    #[test]
    fn linear_ticks_are_round_steps_in_plain_notation() {
        let sets = linear_tick_sets(0.0, 1.3);
        // Densest first: steps of 0.02 (66 ticks), ..., 0.5 (3 ticks), 1.
        assert_eq!(sets[0].len(), 66);
        assert!(sets.contains(&vec![0.0, 0.5, 1.0]));
        assert_eq!(sets.last().unwrap(), &vec![0.0, 1.0]);
        let steps: Vec<f64> = sets.iter().map(|s| s[1] - s[0]).collect();
        assert!(steps.windows(2).all(|w| w[1] > w[0]), "{steps:?}");
        let cases = [
            (1.0, 0.2, "1"),
            (1.2, 0.2, "1.2"),
            (0.05, 0.05, "0.05"),
            (250.0, 50.0, "250"),
            (1.5e-4, 5e-5, "15e-5"),
            (2e-4, 1e-4, "2e-4"),
            (1e-3, 5e-4, "10e-4"),
            (3e4, 1e4, "3e4"),
        ];
        for (v, step, want) in cases {
            assert_eq!(linear_tick_label(v, step), want, "{v} {step}");
        }
    }

    #[test]
    fn labels_never_overlap_markers_labels_or_the_edge() {
        // Four markers in a tight cluster and one near the right edge.
        let pts = [(100, 100), (104, 102), (108, 98), (112, 100), (395, 50)];
        let sizes = [(60, 12); 5];
        let bounds = Rect::at(0, 0, (400, 200));
        let p = place_labels(&pts, &sizes, 4, &bounds, &[]);
        let placed: Vec<TextBox> = p
            .boxes
            .iter()
            .flatten()
            .enumerate()
            .map(|(i, r)| TextBox {
                text: i.to_string(),
                rect: *r,
            })
            .collect();
        assert!(collisions(&placed, &bounds).is_empty());
        for r in p.boxes.iter().flatten() {
            for &(x, y) in &pts {
                assert!(!r.overlaps(&Rect::at(x - 4, y - 4, (9, 9))));
            }
        }
        // The one at the edge went to the left of its marker.
        assert!(p.boxes[4].unwrap().x1 <= 395);
    }

    #[test]
    fn a_moved_label_is_caught() {
        let a = TextBox {
            text: "a".into(),
            rect: Rect::at(10, 10, (30, 10)),
        };
        let mut b = TextBox {
            text: "b".into(),
            rect: Rect::at(50, 10, (30, 10)),
        };
        let bounds = Rect::at(0, 0, (100, 100));
        assert!(collisions(&[a.clone(), b.clone()], &bounds).is_empty());
        b.rect = Rect::at(30, 12, (30, 10));
        assert_eq!(collisions(&[a.clone(), b.clone()], &bounds).len(), 1);
        b.rect = Rect::at(90, 12, (30, 10));
        assert_eq!(collisions(&[a, b], &bounds).len(), 1);
    }
}
