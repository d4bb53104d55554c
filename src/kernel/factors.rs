//! The separable terms every kernel model produces: a leaf that the models,
//! the tap tables and the metrics share without importing the model list.

/// Separable terms: `factors[i][c]` is the 1D factor a_i of channel c on the
/// kernel grid (cell integrals); the 2D kernel is sum_i a_i(x) a_i(y).
pub type Factors = Vec<[Vec<f64>; 3]>;
