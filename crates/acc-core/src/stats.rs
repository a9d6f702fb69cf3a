//! Small statistics shared by every crate: the root mean square, written once.

/// Root mean square `√(Σx²/n)` of the values (same unit as the values); 0 for none.
///
/// ```
/// assert_eq!(acc_core::stats::rms([3.0, -3.0, 3.0, -3.0]), 3.0);
/// assert_eq!(acc_core::stats::rms(std::iter::empty()), 0.0);
/// ```
pub fn rms<I: IntoIterator<Item = f64>>(values: I) -> f64 {
    let (s, n) = values
        .into_iter()
        .fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        0.0
    } else {
        (s / n as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::rms;

    #[test]
    fn rms_of_a_sine_is_its_amplitude_over_root_two() {
        let n = 1000;
        let x = (0..n).map(|k| 2.0 * (2.0 * std::f64::consts::PI * k as f64 / n as f64).sin());
        assert!((rms(x) - 2.0 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(rms([1.0, 7.0].iter().copied()), 5.0);
    }
}
