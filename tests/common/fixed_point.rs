//! Fixed-point iteration, as the tests' own solvers of integral equations
//! (Chandrasekhar's H-function) run it.

/// Iterates `x <- step(x)` from `x0` until no component moves by `tol` or
/// more in one step, or `max_steps` steps have run; the last iterate.
pub fn iterate(
    x0: Vec<f64>,
    max_steps: usize,
    tol: f64,
    step: impl Fn(&[f64]) -> Vec<f64>,
) -> Vec<f64> {
    let mut x = x0;
    for _ in 0..max_steps {
        let next = step(&x);
        let change = next
            .iter()
            .zip(&x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        x = next;
        if change < tol {
            break;
        }
    }
    x
}
