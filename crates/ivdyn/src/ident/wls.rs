//! The two-step weighted least squares of the identification practice: an OLS fit, then
//! every joint's rows weighted by the inverse of its residual variance.

/// Two-step WLS weights: `1 / rms_j^2` per joint (floored at `1e-6` of the largest RMS).
pub fn per_joint_weights(rms: &[f64]) -> Vec<f64> {
    let floor = rms.iter().cloned().fold(0.0, f64::max) * 1e-6 + 1e-12;
    rms.iter().map(|r| 1.0 / (r * r).max(floor * floor)).collect()
}

/// Per-row weights of `rows` rows laid out sample-major over the joints of `w`.
pub fn row_weights(w: &[f64], rows: usize) -> Vec<f64> {
    let n = w.len();
    (0..rows).map(|r| w[r % n]).collect()
}
