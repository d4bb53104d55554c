//! An image's three colour planes written row by row in parallel (rayon):
//! each row on its own, so the result is the same at any thread count.

/// The three colour planes of a `w` x `h` image whose pixel (x, y) is
/// `pixel(x, y)`, computed in parallel by rows (each pixel on its own, so
/// the result is the same at any thread count).
pub fn par_planes(
    w: usize,
    h: usize,
    pixel: impl Fn(usize, usize) -> [f64; 3] + Sync,
) -> [Vec<f64>; 3] {
    par_rows(w, h, |y, [r, g, b]| {
        for x in 0..w {
            let v = pixel(x, y);
            (r[x], g[x], b[x]) = (v[0], v[1], v[2]);
        }
    })
}

/// The three colour planes of a `w` x `h` image whose row `y` of each
/// plane `row(y, [r, g, b])` writes, rows in parallel.
pub fn par_rows(w: usize, h: usize, row: impl Fn(usize, [&mut [f64]; 3]) + Sync) -> [Vec<f64>; 3] {
    let mut out: [Vec<f64>; 3] = [vec![0.0; w * h], vec![0.0; w * h], vec![0.0; w * h]];
    par_span_rows(&mut out, 0..w * h, w.max(1), row);
    out
}

/// The rows of `w` values in `span` of three planes, the `j`-th of the
/// span written by `row(j, [r, g, b])`, rows in parallel.
pub fn par_span_rows(
    planes: &mut [Vec<f64>; 3],
    span: std::ops::Range<usize>,
    w: usize,
    row: impl Fn(usize, [&mut [f64]; 3]) + Sync,
) {
    use rayon::prelude::*;
    let [r, g, b] = planes;
    r[span.clone()]
        .par_chunks_mut(w)
        .zip(g[span.clone()].par_chunks_mut(w))
        .zip(b[span].par_chunks_mut(w))
        .enumerate()
        .for_each(|(j, ((r, g), b))| row(j, [r, g, b]));
}
