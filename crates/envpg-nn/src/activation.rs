//! Activations, applied elementwise: SiLU `x·σ(x)` with derivative `σ(x)(1 + x(1 − σ(x)))`,
//! i.e. `σ + silu(x)(1 − σ)`, which the MLP evaluates from its cached σ and activation.

use crate::Scalar;

/// `e^x` for f32 to 4e-6 relative error (x clamped to [−87, 88]), written so that loops over
/// it vectorise: range reduction `x·log₂e = n + f` with the 1.5·2²³ rounding trick, a degree-6
/// polynomial for `e^{f ln 2}`, and `2ⁿ` assembled in the exponent bits.
#[inline(always)]
pub fn fast_exp(x: f32) -> f32 {
    // max/min rather than clamp: clamp's NaN and ordering checks stop the loop from vectorising.
    #[allow(clippy::manual_clamp)]
    let x = x.max(-87.0).min(88.0);
    let t = x * std::f32::consts::LOG2_E;
    let k = t + 12_582_912.0;
    let n = k - 12_582_912.0;
    let f = (t - n) * std::f32::consts::LN_2;
    let p = 1.0 + f * (1.0 + f * (0.5 + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0 + f * (1.0 / 720.0))))));
    let ni = k.to_bits().wrapping_sub(0x4B40_0000);
    f32::from_bits(ni.wrapping_add(127) << 23) * p
}

/// SiLU over f32 slices with [`fast_exp`]: `z ← σ(z)`, `a ← z·σ(z)`.
#[inline(always)]
pub fn silu_f32(z: &mut [f32], a: &mut [f32]) {
    for (zv, av) in z.iter_mut().zip(a.iter_mut()) {
        let s = 1.0 / (1.0 + fast_exp(-*zv));
        *av = *zv * s;
        *zv = s;
    }
}

/// `σ(x) = 1/(1 + e^{−x})`.
#[inline]
pub fn sigmoid<T: Scalar>(x: T) -> T {
    T::one() / (T::one() + (-x).exp())
}

/// `x·σ(x)`.
#[inline]
pub fn silu<T: Scalar>(x: T) -> T {
    x / (T::one() + (-x).exp())
}

/// `d silu / dx`.
#[inline]
pub fn silu_grad<T: Scalar>(x: T) -> T {
    let s = T::one() / (T::one() + (-x).exp());
    s * (T::one() + x * (T::one() - s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_is_accurate_over_its_range() {
        let mut worst = 0.0f64;
        for i in -8700..=8700 {
            let x = i as f32 * 0.01;
            let exact = (x as f64).exp();
            worst = worst.max(((fast_exp(x) as f64 - exact) / exact).abs());
        }
        assert!(worst < 5e-6, "worst relative error {worst}");
        assert_eq!(fast_exp(0.0), 1.0);
        assert!(fast_exp(-200.0) > 0.0 && fast_exp(-200.0) < 1e-37);
    }

    #[test]
    fn silu_derivative_matches_central_differences() {
        for &x in &[-6.0f64, -1.3, -0.2, 0.0, 0.4, 2.5, 8.0] {
            let h = 1e-6;
            let fd = (silu(x + h) - silu(x - h)) / (2.0 * h);
            assert!((fd - silu_grad(x)).abs() < 1e-9, "x = {x}: {fd} vs {}", silu_grad(x));
        }
        // Known values: silu(0) = 0, silu'(0) = 1/2.
        assert_eq!(silu(0.0f64), 0.0);
        assert!((silu_grad(0.0f64) - 0.5).abs() < 1e-15);
        // The cached form used by the MLP.
        for &x in &[-3.0f64, 0.7, 5.0] {
            let s = sigmoid(x);
            assert!((s + silu(x) * (1.0 - s) - silu_grad(x)).abs() < 1e-14);
        }
    }
}
