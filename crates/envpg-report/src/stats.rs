//! Small statistics used by the reports.

/// Mean of `xs` (NaN when empty).
pub fn mean(xs: &[f64]) -> f64 {
    xs.iter().sum::<f64>() / xs.len() as f64
}

/// Sample standard deviation (n − 1); 0 for fewer than two values.
pub fn std(xs: &[f64]) -> f64 {
    if xs.len() < 2 {
        return 0.0;
    }
    let m = mean(xs);
    (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (xs.len() - 1) as f64).sqrt()
}

/// Trailing moving average over `window` points (shorter at the start).
pub fn moving_average(xs: &[f64], window: usize) -> Vec<f64> {
    let w = window.max(1);
    let mut out = Vec::with_capacity(xs.len());
    let mut sum = 0.0;
    for i in 0..xs.len() {
        sum += xs[i];
        if i >= w {
            sum -= xs[i - w];
        }
        out.push(sum / (i + 1).min(w) as f64);
    }
    out
}

/// The median element index of `xs` by value (the lower one for even lengths).
pub fn median_index(xs: &[f64]) -> Option<usize> {
    let mut idx: Vec<usize> = (0..xs.len()).collect();
    idx.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    idx.get((xs.len().max(1) - 1) / 2).copied()
}

/// Decimals that show `x` to six significant digits (at least one): J of the UAV network
/// (≈ 12) gets 4, a clustering distortion (≈ 0.14) 6.
pub fn decimals(x: f64) -> usize {
    if !x.is_finite() || x == 0.0 {
        return 4;
    }
    (5 - x.abs().log10().floor() as i64).clamp(1, 15) as usize
}

/// `x` to six significant digits in fixed notation.
pub fn fixed(x: f64) -> String {
    format!("{x:.*}", decimals(x))
}

/// `mean ± std` of `xs`, both to the mean's [`decimals`].
pub fn mean_std(xs: &[f64]) -> String {
    let (m, d) = (mean(xs), std(xs));
    format!("{m:.p$} ± {d:.p$}", p = decimals(m))
}

/// `x` to `digits` significant digits, trailing zeros dropped (for settings and scales).
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let d = (digits as i64 - 1 - x.abs().log10().floor() as i64).max(0) as usize;
    let s = format!("{x:.d$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moving_average_is_trailing() {
        assert_eq!(moving_average(&[1.0, 3.0, 5.0, 7.0], 2), [1.0, 2.0, 4.0, 6.0]);
        assert_eq!(moving_average(&[2.0, 4.0], 100), [2.0, 3.0]);
    }

    #[test]
    fn spread() {
        assert_eq!(mean(&[1.0, 2.0, 3.0]), 2.0);
        assert_eq!(std(&[1.0, 2.0, 3.0]), 1.0);
        assert_eq!(std(&[5.0]), 0.0);
        assert_eq!(median_index(&[3.0, 1.0, 2.0]), Some(2));
        assert_eq!(median_index(&[4.0, 1.0, 3.0, 2.0]), Some(3));
    }

    #[test]
    fn numbers_keep_six_significant_digits_whatever_their_magnitude() {
        assert_eq!(fixed(12.490629536849628), "12.4906");
        assert_eq!(fixed(0.06272790439817083), "0.0627279");
        assert_eq!(fixed(0.144051309), "0.144051");
        assert_eq!(fixed(153.6), "153.600");
        assert_eq!(sig(0.0065 * 153.6, 3), "0.998");
        assert_eq!(sig(6.2, 3), "6.2");
        assert_eq!(sig(1e-5, 3), "0.00001");
    }
}
