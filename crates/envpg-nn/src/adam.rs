//! Adam (Kingma & Ba) over a flat parameter slice, with bias correction.

use serde::{Deserialize, Serialize};

use crate::Scalar;

/// Adam state for one parameter vector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Adam {
    /// Learning rate.
    pub lr: f64,
    /// First-moment decay.
    pub beta1: f64,
    /// Second-moment decay.
    pub beta2: f64,
    /// Denominator guard.
    pub eps: f64,
    /// First moments.
    pub m: Vec<f64>,
    /// Second moments.
    pub v: Vec<f64>,
    /// Steps taken.
    pub t: u64,
}

impl Adam {
    /// Adam for `n` parameters with the usual β = (0.9, 0.999), ε = 1e-8.
    pub fn new(n: usize, lr: f64) -> Self {
        Self { lr, beta1: 0.9, beta2: 0.999, eps: 1e-8, m: vec![0.0; n], v: vec![0.0; n], t: 0 }
    }

    /// One descent step `θ ← θ − lr·m̂/(√v̂ + ε)` given the gradient `g` of the loss.
    ///
    /// Moments are kept in f64 whatever `T` is; the loop is plain arithmetic so it vectorises
    /// (with AVX-512 or AVX2 where the CPU has it: every operation is correctly rounded, so the result is
    /// the same bits either way).
    pub fn step<T: Scalar>(&mut self, params: &mut [T], g: &[T]) {
        assert_eq!(params.len(), self.m.len(), "parameter count changed");
        assert_eq!(g.len(), self.m.len(), "gradient length mismatch");
        self.t += 1;
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the required CPU feature was just detected.
            unsafe { self.step_avx512(params, g) };
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the required CPU feature was just detected.
            unsafe { self.step_avx2(params, g) };
            return;
        }
        self.step_impl(params, g);
    }

    /// [`Adam::step_impl`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn step_avx2<T: Scalar>(&mut self, params: &mut [T], g: &[T]) {
        self.step_impl(params, g);
    }

    /// [`Adam::step_impl`] compiled for AVX-512.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2")]
    unsafe fn step_avx512<T: Scalar>(&mut self, params: &mut [T], g: &[T]) {
        self.step_impl(params, g);
    }

    #[inline(always)]
    fn step_impl<T: Scalar>(&mut self, params: &mut [T], g: &[T]) {
        let b1t = 1.0 - self.beta1.powi(self.t.min(i32::MAX as u64) as i32);
        let b2t = 1.0 - self.beta2.powi(self.t.min(i32::MAX as u64) as i32);
        let (b1, b2, lr, eps) = (self.beta1, self.beta2, self.lr, self.eps);
        let (c1, c2) = (1.0 / b1t, 1.0 / b2t);
        for (((p, &gv), m), v) in params.iter_mut().zip(g).zip(self.m.iter_mut()).zip(self.v.iter_mut()) {
            let gi = gv.to_f64();
            *m = b1 * *m + (1.0 - b1) * gi;
            *v = b2 * *v + (1.0 - b2) * gi * gi;
            *p = T::of(p.to_f64() - lr * (*m * c1) / ((*v * c2).sqrt() + eps));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_step_moves_each_parameter_by_lr_against_the_gradient_sign() {
        // With bias correction, m̂ = g and v̂ = g² after one step: Δθ = −lr·g/(|g| + ε).
        let mut adam = Adam::new(3, 0.1);
        let mut p = [1.0f64, -2.0, 0.5];
        adam.step(&mut p, &[3.0, -0.5, 0.0]);
        assert!((p[0] - 0.9).abs() < 1e-8 && (p[1] + 1.9).abs() < 1e-8 && p[2] == 0.5, "{p:?}");
    }

    #[test]
    fn the_vectorised_step_gives_the_same_bits_as_the_plain_loop() {
        let n = 1003;
        let mut g: Vec<f32> = (0..n).map(|i| ((i as f32) * 0.37).sin() * 10f32.powi(i as i32 % 5 - 2)).collect();
        let (mut a, mut b) = (Adam::new(n, 1e-3), Adam::new(n, 1e-3));
        let mut pa: Vec<f32> = (0..n).map(|i| (i as f32 * 0.11).cos()).collect();
        let mut pb = pa.clone();
        for _ in 0..5 {
            a.step(&mut pa, &g);
            b.t += 1;
            b.step_impl(&mut pb, &g);
            g.iter_mut().for_each(|x| *x = -0.7 * *x + 0.01);
        }
        assert!(pa.iter().zip(&pb).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert!(a.m.iter().zip(&b.m).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert!(a.v.iter().zip(&b.v).all(|(x, y)| x.to_bits() == y.to_bits()));
    }

    #[test]
    fn minimises_a_quadratic() {
        let mut adam = Adam::new(2, 0.05);
        let mut p = [3.0f64, -4.0];
        for _ in 0..2000 {
            let g = [2.0 * (p[0] - 1.0), 2.0 * (p[1] + 2.0)];
            adam.step(&mut p, &g);
        }
        assert!((p[0] - 1.0).abs() < 1e-3 && (p[1] + 2.0).abs() < 1e-3, "{p:?}");
    }
}
