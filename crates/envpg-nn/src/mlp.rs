//! [`Mlp`]: a multilayer perceptron `R^{one-hot groups + dense} → R` with SiLU hidden layers,
//! parameters in one flat vector, and backprop to parameters and to the dense inputs.

use rand::Rng;
use rand_distr::{Distribution, Uniform};
use serde::{Deserialize, Serialize};

use crate::Scalar;
use crate::gather::{Term, accumulate};
use crate::inputs::{Dense, Inputs, listed_input_gradient};
use crate::linear::{Mat, Op, gemm};

/// Shape of an [`Mlp`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MlpSpec {
    /// Sizes of the one-hot input groups (e.g. `[|S|, |A|]`).
    pub onehot: Vec<usize>,
    /// Number of dense inputs.
    pub dense: usize,
    /// Widths of the hidden layers.
    pub hidden: Vec<usize>,
}

/// Activations of a forward pass, needed by [`Mlp::backward`].
#[derive(Debug, Clone, Default)]
pub struct Cache<T> {
    /// σ(z) per hidden layer (`width × batch`): with `a = z·σ(z)` it gives the SiLU derivative
    /// `σ + a(1 − σ)` without a second exponential.
    sig: Vec<Vec<T>>,
    /// Activations per hidden layer.
    a: Vec<Vec<T>>,
    batch: usize,
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct LayerLayout {
    rows: usize,
    cols: usize,
    w: usize,
    b: usize,
}

/// The network. Layer 0's weight matrix has one column per one-hot entry (all groups), then
/// one per dense input; the output layer has one row.
#[derive(Debug, Clone, PartialEq)]
pub struct Mlp<T> {
    spec: MlpSpec,
    layers: Vec<LayerLayout>,
    group_offsets: Vec<usize>,
    onehot_total: usize,
    params: Vec<T>,
}

/// A pass `pub fn $name` that runs `$imp` (an `#[inline(always)]` method) compiled for the widest
/// vector instructions the CPU has: AVX-512 (`$avx512`), else AVX2 and FMA (`$avx2`), else the
/// plain build. Each element gets the same operations in the same order whatever the width (no
/// fused multiply–add is written, and the compiler forms none), so every build gives the same bits.
macro_rules! widest_isa {
    ($(#[$doc:meta])* pub fn $name:ident / $avx2:ident / $avx512:ident / $imp:ident($($arg:ident: $ty:ty),* $(,)?)) => {
        $(#[$doc])*
        pub fn $name(&self, $($arg: $ty),*) {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the required CPU feature was just detected.
                return unsafe { self.$avx512($($arg),*) };
            }
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                // SAFETY: the required CPU features were just detected.
                return unsafe { self.$avx2($($arg),*) };
            }
            self.$imp($($arg),*)
        }

        /// The pass compiled for AVX2 and FMA (the helpers are inlined into it).
        ///
        /// # Safety
        /// The CPU must support AVX2 and FMA.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn $avx2(&self, $($arg: $ty),*) {
            self.$imp($($arg),*)
        }

        /// The pass compiled for AVX-512 (16 f32 a register).
        ///
        /// # Safety
        /// The CPU must support AVX-512F.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx2,fma")]
        unsafe fn $avx512(&self, $($arg: $ty),*) {
            self.$imp($($arg),*)
        }
    };
}

impl<T: Scalar> Mlp<T> {
    /// A network of shape `spec` with PyTorch-style uniform initialisation
    /// (±1/√fan_in, fan_in counting one active entry per one-hot group); with `zero_output`
    /// the last layer starts at zero (constant output).
    pub fn new<R: Rng + ?Sized>(spec: MlpSpec, rng: &mut R, zero_output: bool) -> Self {
        assert!(!spec.hidden.is_empty(), "at least one hidden layer");
        let onehot_total: usize = spec.onehot.iter().sum();
        let mut group_offsets = Vec::new();
        let mut acc = 0;
        for &g in &spec.onehot {
            group_offsets.push(acc);
            acc += g;
        }
        let mut layers = Vec::new();
        let mut off = 0;
        let mut cols = onehot_total + spec.dense;
        for &h in spec.hidden.iter().chain(std::iter::once(&1)) {
            layers.push(LayerLayout { rows: h, cols, w: off, b: off + h * cols });
            off += h * cols + h;
            cols = h;
        }
        let mut params = vec![T::zero(); off];
        let n_layers = layers.len();
        for (l, lay) in layers.iter().enumerate() {
            if zero_output && l + 1 == n_layers {
                continue;
            }
            let fan_in = if l == 0 { spec.onehot.len() + spec.dense } else { lay.cols };
            let bound = 1.0 / (fan_in.max(1) as f64).sqrt();
            let u = Uniform::new_inclusive(-bound, bound).expect("finite bound");
            for p in &mut params[lay.w..lay.b + lay.rows] {
                *p = T::of(u.sample(rng));
            }
        }
        Self { spec, layers, group_offsets, onehot_total, params }
    }

    /// The shape.
    pub fn spec(&self) -> &MlpSpec {
        &self.spec
    }
    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.params.len()
    }
    /// The flat parameter vector.
    pub fn params(&self) -> &[T] {
        &self.params
    }
    /// The flat parameter vector, mutably.
    pub fn params_mut(&mut self) -> &mut [T] {
        &mut self.params
    }
    /// Replaces the parameters (same length).
    pub fn set_params(&mut self, p: &[T]) {
        assert_eq!(p.len(), self.params.len(), "parameter count");
        self.params.copy_from_slice(p);
    }
    /// Sets the output bias (e.g. to the mean return so a critic starts neither optimistic nor
    /// pessimistic).
    pub fn set_output_bias(&mut self, b: T) {
        let last = self.layers.last().expect("layers");
        self.params[last.b] = b;
    }

    fn check_inputs(&self, x: &Inputs<'_, T>) {
        assert_eq!(x.onehot.len(), x.batch * self.spec.onehot.len(), "one-hot index count");
        x.check_dense(self.spec.dense);
    }

    widest_isa! {
        /// Forward pass: writes one output per sample into `out` and fills `cache`.
        ///
        /// The first layer (and, for one hidden layer, the whole network) runs column by column so
        /// every intermediate stays in L1; its arithmetic for a sample never depends on the rest
        /// of the batch. Deeper layers use a matrix product.
        pub fn forward / forward_avx2 / forward_avx512 / forward_impl(
            x: &Inputs<'_, T>,
            cache: &mut Cache<T>,
            out: &mut [T],
        )
    }

    #[inline(always)]
    fn forward_impl(&self, x: &Inputs<'_, T>, cache: &mut Cache<T>, out: &mut [T]) {
        self.check_inputs(x);
        let bsz = x.batch;
        assert_eq!(out.len(), bsz, "output size");
        let n_hidden = self.spec.hidden.len();
        cache.batch = bsz;
        cache.sig.resize(n_hidden, Vec::new());
        cache.a.resize(n_hidden, Vec::new());
        let h0 = self.layers[0].rows;
        let mut sig0 = std::mem::take(&mut cache.sig[0]);
        let mut a0 = std::mem::take(&mut cache.a[0]);
        sig0.clear();
        sig0.resize(h0 * bsz, T::zero());
        a0.resize(h0 * bsz, T::zero());
        // Dense inputs that are mostly zero (slotted blocks) join the bias and one-hot columns as
        // terms of one register-blocked sum per column (`gather`); otherwise the dense part is
        // one matrix product for the whole batch. Then SiLU and (one hidden layer) the output dot
        // per column while the column is hot in L1.
        let dense = self.spec.dense;
        let sparse = dense > 0 && x.dense_mostly_zero(dense);
        if dense > 0 && !sparse {
            let lay = &self.layers[0];
            let w = &self.params[lay.w + h0 * self.onehot_total..lay.b];
            let wd = Mat::new(w, h0, dense);
            let xd = x.dense_full(dense);
            gemm(T::one(), wd, Op::N, Mat::new(&xd, dense, bsz), Op::N, T::zero(), &mut sig0, h0, bsz);
        }
        let last = &self.layers[n_hidden];
        let mut terms = Vec::with_capacity(if sparse { dense } else { 0 } + self.spec.onehot.len() + 1);
        for s in 0..bsz {
            let z = &mut sig0[s * h0..(s + 1) * h0];
            let a = &mut a0[s * h0..(s + 1) * h0];
            self.layer0_terms(x, s, sparse, &mut terms);
            accumulate(&self.params, &terms, z);
            T::silu_inplace(z, a);
            if n_hidden == 1 {
                out[s] = self.params[last.b] + dot(&self.params[last.w..last.b], a);
            }
        }
        cache.sig[0] = sig0;
        cache.a[0] = a0;
        if n_hidden == 1 {
            return;
        }
        for l in 1..n_hidden {
            let h = self.layers[l].rows;
            let mut z = std::mem::take(&mut cache.sig[l]);
            z.clear();
            z.resize(h * bsz, T::zero());
            self.affine(l, &cache.a[l - 1], &mut z, bsz);
            let a = &mut cache.a[l];
            a.clear();
            a.resize(z.len(), T::zero());
            T::silu_inplace(&mut z, a);
            cache.sig[l] = z;
        }
        let w = &self.params[last.w..last.b];
        for (s, o) in out.iter_mut().enumerate() {
            *o = self.params[last.b] + dot(w, &cache.a[n_hidden - 1][s * last.cols..(s + 1) * last.cols]);
        }
    }

    widest_isa! {
        /// Outputs only, without keeping activations for a backward pass: with one hidden layer
        /// each column is computed start to finish in a small buffer, so nothing large is written.
        pub fn eval / eval_avx2 / eval_avx512 / eval_impl(x: &Inputs<'_, T>, out: &mut [T])
    }

    #[inline(always)]
    fn eval_impl(&self, x: &Inputs<'_, T>, out: &mut [T]) {
        if self.spec.hidden.len() > 1 {
            self.forward_impl(x, &mut Cache::default(), out);
            return;
        }
        self.check_inputs(x);
        assert_eq!(out.len(), x.batch, "output size");
        let h = self.layers[0].rows;
        let last = &self.layers[1];
        let (w_out, b_out) = (&self.params[last.w..last.b], self.params[last.b]);
        let mut z = vec![T::zero(); h];
        let mut a = vec![T::zero(); h];
        let mut terms = Vec::with_capacity(self.spec.dense + self.spec.onehot.len() + 1);
        for s in 0..x.batch {
            z.iter_mut().for_each(|v| *v = T::zero());
            self.layer0_terms(x, s, true, &mut terms);
            accumulate(&self.params, &terms, &mut z);
            T::silu_inplace(&mut z, &mut a);
            out[s] = b_out + dot(w_out, &a);
        }
    }

    /// Whether [`Mlp::eval`] and [`Mlp::forward`] give the same bits on `x`: always with more than
    /// one hidden layer, and with one when the dense inputs are absent or mostly zero (then both
    /// sum the same terms in the same order; otherwise `forward` takes the dense part as one
    /// matrix product).
    pub fn eval_matches_forward(&self, x: &Inputs<'_, T>) -> bool {
        self.spec.hidden.len() > 1 || self.spec.dense == 0 || x.dense_mostly_zero(self.spec.dense)
    }

    /// The terms of layer 0's pre-activation of sample `s`, in the order they are added: the
    /// non-zero dense inputs (if `dense_terms`), the bias, then the gathered one-hot columns.
    #[inline(always)]
    fn layer0_terms(&self, x: &Inputs<'_, T>, s: usize, dense_terms: bool, terms: &mut Vec<Term<T>>) {
        let lay = &self.layers[0];
        let h = lay.rows;
        terms.clear();
        let dense = self.spec.dense;
        if dense_terms {
            x.push_dense_terms(s, dense, lay.w + h * self.onehot_total, h, terms);
        }
        terms.push((T::one(), lay.b));
        let groups = self.spec.onehot.len();
        for g in 0..groups {
            let idx = x.onehot[s * groups + g] as usize;
            debug_assert!(idx < self.spec.onehot[g], "one-hot index out of range");
            terms.push((T::one(), lay.w + (self.group_offsets[g] + idx) * h));
        }
    }

    /// `out = W_l · input + b_l` for a dense layer `l ≥ 1`.
    fn affine(&self, l: usize, input: &[T], out: &mut [T], bsz: usize) {
        let lay = &self.layers[l];
        let w = Mat::new(&self.params[lay.w..lay.b], lay.rows, lay.cols);
        let bias = &self.params[lay.b..lay.b + lay.rows];
        for s in 0..bsz {
            out[s * lay.rows..(s + 1) * lay.rows].copy_from_slice(bias);
        }
        gemm(T::one(), w, Op::N, Mat::new(input, lay.cols, bsz), Op::N, T::one(), out, lay.rows, bsz);
    }

    widest_isa! {
        /// Backward pass for the upstream gradient `dout` (one per sample): adds the parameter
        /// gradient into `grad` (if given, flat, same layout as the parameters) and writes the
        /// gradient with respect to the dense inputs into `dinput` (if given: `dense × batch`, or
        /// for [`Dense::Listed`] inputs one entry per listed input, in their order).
        pub fn backward / backward_avx2 / backward_avx512 / backward_impl(
            x: &Inputs<'_, T>,
            cache: &Cache<T>,
            dout: &[T],
            grad: Option<&mut [T]>,
            dinput: Option<&mut [T]>,
        )
    }

    #[inline(always)]
    fn backward_impl(
        &self,
        x: &Inputs<'_, T>,
        cache: &Cache<T>,
        dout: &[T],
        grad: Option<&mut [T]>,
        dinput: Option<&mut [T]>,
    ) {
        self.check_inputs(x);
        let bsz = x.batch;
        assert_eq!(cache.batch, bsz, "cache is from another batch");
        assert_eq!(dout.len(), bsz, "upstream gradient size");
        let n_hidden = self.spec.hidden.len();
        let mut grad = grad;
        if let Some(g) = grad.as_deref() {
            assert_eq!(g.len(), self.params.len(), "gradient buffer size");
        }
        let dense = self.spec.dense;
        if let Some(di) = dinput.as_deref() {
            assert_eq!(di.len(), x.dense_width(dense) * bsz, "input gradient buffer size");
        }
        let out = &self.layers[n_hidden];
        let h_last = out.cols;
        let w_out = &self.params[out.w..out.b];
        if let Some(g) = grad.as_deref_mut() {
            let gw = &mut g[out.w..out.b];
            for (s, &d) in dout.iter().enumerate() {
                axpy(d, &cache.a[n_hidden - 1][s * h_last..(s + 1) * h_last], gw);
            }
            g[out.b] += dout.iter().fold(T::zero(), |a, &b| a + b);
        }
        // Deeper layers (if any) as matrix products, down to dA of layer 0.
        let mut da_deep: Option<Vec<T>> = None;
        if n_hidden > 1 {
            let mut da = vec![T::zero(); h_last * bsz];
            for (s, &d) in dout.iter().enumerate() {
                axpy(d, w_out, &mut da[s * h_last..(s + 1) * h_last]);
            }
            for l in (1..n_hidden).rev() {
                let lay = &self.layers[l];
                let h = lay.rows;
                let mut dz = da;
                for ((d, &sg), &a) in dz.iter_mut().zip(&cache.sig[l]).zip(&cache.a[l]) {
                    *d *= sg + a * (T::one() - sg);
                }
                if let Some(g) = grad.as_deref_mut() {
                    gemm(
                        T::one(),
                        Mat::new(&dz, h, bsz),
                        Op::N,
                        Mat::new(&cache.a[l - 1], lay.cols, bsz),
                        Op::T,
                        T::one(),
                        &mut g[lay.w..lay.b],
                        h,
                        lay.cols,
                    );
                    add_row_sums(&dz, h, bsz, &mut g[lay.b..lay.b + h]);
                }
                let mut prev = vec![T::zero(); lay.cols * bsz];
                gemm(
                    T::one(),
                    Mat::new(&self.params[lay.w..lay.b], h, lay.cols),
                    Op::T,
                    Mat::new(&dz, h, bsz),
                    Op::N,
                    T::zero(),
                    &mut prev,
                    lay.cols,
                    bsz,
                );
                da = prev;
            }
            da_deep = Some(da);
        }
        // Layer 0: dZ column by column, then the dense products for the whole batch.
        let lay = &self.layers[0];
        let h = lay.rows;
        let groups = self.spec.onehot.len();
        let mut dz = vec![T::zero(); h * bsz];
        for s in 0..bsz {
            let d = &mut dz[s * h..(s + 1) * h];
            match &da_deep {
                Some(da) => d.copy_from_slice(&da[s * h..(s + 1) * h]),
                None => {
                    for (dv, &w) in d.iter_mut().zip(w_out) {
                        *dv = w * dout[s];
                    }
                }
            }
            for ((dv, &sg), &a) in
                d.iter_mut().zip(&cache.sig[0][s * h..(s + 1) * h]).zip(&cache.a[0][s * h..(s + 1) * h])
            {
                *dv *= sg + a * (T::one() - sg);
            }
        }
        let wd = Mat::new(&self.params[lay.w + h * self.onehot_total..lay.b], h, dense);
        if let Some(g) = grad {
            let (gw, gb) = g[lay.w..lay.b + h].split_at_mut(lay.b - lay.w);
            add_row_sums(&dz, h, bsz, gb);
            for s in 0..bsz {
                for gi in 0..groups {
                    let c = self.group_offsets[gi] + x.onehot[s * groups + gi] as usize;
                    axpy(T::one(), &dz[s * h..(s + 1) * h], &mut gw[c * h..(c + 1) * h]);
                }
            }
            if dense > 0 && x.dense_mostly_zero(dense) {
                let gwd = &mut gw[h * self.onehot_total..];
                for s in 0..bsz {
                    x.for_each_nonzero(s, dense, |i, xi| {
                        axpy(xi, &dz[s * h..(s + 1) * h], &mut gwd[i * h..(i + 1) * h])
                    });
                }
            } else if dense > 0 {
                let xd = x.dense_full(dense);
                gemm(
                    T::one(),
                    Mat::new(&dz, h, bsz),
                    Op::N,
                    Mat::new(&xd, dense, bsz),
                    Op::T,
                    T::one(),
                    &mut gw[h * self.onehot_total..],
                    h,
                    dense,
                );
            }
        }
        if let Some(di) = dinput
            && dense > 0
        {
            match x.dense {
                Dense::Full(_) => gemm(T::one(), wd, Op::T, Mat::new(&dz, h, bsz), Op::N, T::zero(), di, dense, bsz),
                Dense::Listed { index, per_sample, .. } => {
                    listed_input_gradient(wd.data, h, &dz, index, per_sample, di)
                }
            }
        }
    }
}

/// `Σ a_i b_i`, accumulated in 8 interleaved partial sums so it vectorises (a single running
/// sum is a serial chain of floating-point additions the compiler may not reorder).
#[inline(always)]
fn dot<T: Scalar>(a: &[T], b: &[T]) -> T {
    let mut acc = [T::zero(); 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (xa, xb) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += xa[l] * xb[l];
        }
    }
    let tail = ra.iter().zip(rb).fold(T::zero(), |t, (&x, &y)| t + x * y);
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// `y += α x`.
#[inline(always)]
fn axpy<T: Scalar>(alpha: T, x: &[T], y: &mut [T]) {
    for (yv, &xv) in y.iter_mut().zip(x) {
        *yv += alpha * xv;
    }
}

/// `out[i] += Σ_s m[i, s]` for a column-major `rows × cols` matrix.
#[inline(always)]
fn add_row_sums<T: Scalar>(m: &[T], rows: usize, cols: usize, out: &mut [T]) {
    for s in 0..cols {
        for (o, v) in out.iter_mut().zip(&m[s * rows..(s + 1) * rows]) {
            *o += *v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inputs::mostly_zero;
    use rand::SeedableRng;
    use rand_chacha::ChaCha12Rng;

    fn net() -> (Mlp<f64>, Vec<u32>, Vec<f64>, usize) {
        let mut rng = ChaCha12Rng::seed_from_u64(7);
        let spec = MlpSpec { onehot: vec![5, 3], dense: 4, hidden: vec![6, 7] };
        let mlp = Mlp::new(spec, &mut rng, false);
        let bsz = 3;
        let onehot = vec![0, 2, 4, 1, 2, 0];
        let dense: Vec<f64> = (0..12).map(|i| ((i as f64) * 0.37).sin()).collect();
        (mlp, onehot, dense, bsz)
    }

    /// Loss L = Σ_s w_s·f(x_s) with fixed weights, so dL/df = w.
    fn loss(m: &Mlp<f64>, onehot: &[u32], dense: &[f64], bsz: usize) -> f64 {
        let mut out = vec![0.0; bsz];
        m.forward(&Inputs::full(onehot, dense, bsz), &mut Cache::default(), &mut out);
        out.iter().enumerate().map(|(s, o)| (s as f64 + 1.0) * o).sum()
    }

    /// Checks the parameter and input gradients of `m` at these inputs against central
    /// differences of [`loss`].
    fn assert_gradients_match_central_differences(m: &mut Mlp<f64>, onehot: &[u32], dense: &[f64], bsz: usize) {
        let x = Inputs::full(onehot, dense, bsz);
        let mut cache = Cache::default();
        let mut out = vec![0.0; bsz];
        m.forward(&x, &mut cache, &mut out);
        let dout: Vec<f64> = (0..bsz).map(|s| s as f64 + 1.0).collect();
        let mut g = vec![0.0; m.n_params()];
        let mut di = vec![0.0; dense.len()];
        m.backward(&x, &cache, &dout, Some(&mut g), Some(&mut di));
        let h = 1e-6;
        for i in 0..m.n_params() {
            let p0 = m.params()[i];
            m.params_mut()[i] = p0 + h;
            let fp = loss(m, onehot, dense, bsz);
            m.params_mut()[i] = p0 - h;
            let fm = loss(m, onehot, dense, bsz);
            m.params_mut()[i] = p0;
            let fd = (fp - fm) / (2.0 * h);
            assert!((fd - g[i]).abs() < 1e-7 * (1.0 + fd.abs()), "param {i}: fd {fd} vs {}", g[i]);
        }
        let mut d = dense.to_vec();
        for i in 0..d.len() {
            let v = d[i];
            d[i] = v + h;
            let fp = loss(m, onehot, &d, bsz);
            d[i] = v - h;
            let fm = loss(m, onehot, &d, bsz);
            d[i] = v;
            let fd = (fp - fm) / (2.0 * h);
            assert!((fd - di[i]).abs() < 1e-7 * (1.0 + fd.abs()), "input {i}: fd {fd} vs {}", di[i]);
        }
    }

    #[test]
    fn parameter_and_input_gradients_match_central_differences() {
        let (mut m, onehot, dense, bsz) = net();
        assert_gradients_match_central_differences(&mut m, &onehot, &dense, bsz);
    }

    #[test]
    fn one_hot_gather_equals_a_dense_one_hot_product() {
        // The same network with the one-hot groups fed as dense 0/1 inputs gives the same output.
        let (m, onehot, dense, bsz) = net();
        let spec2 = MlpSpec { onehot: vec![], dense: 8 + 4, hidden: vec![6, 7] };
        let mut m2 = Mlp::<f64>::new(spec2, &mut ChaCha12Rng::seed_from_u64(1), false);
        m2.set_params(m.params());
        let mut dense2 = vec![0.0; 12 * bsz];
        for s in 0..bsz {
            dense2[s * 12 + onehot[s * 2] as usize] = 1.0;
            dense2[s * 12 + 5 + onehot[s * 2 + 1] as usize] = 1.0;
            dense2[s * 12 + 8..s * 12 + 12].copy_from_slice(&dense[s * 4..s * 4 + 4]);
        }
        let (mut o1, mut o2) = (vec![0.0; bsz], vec![0.0; bsz]);
        m.forward(&Inputs::full(&onehot, &dense, bsz), &mut Cache::default(), &mut o1);
        m2.forward(&Inputs::full(&[], &dense2, bsz), &mut Cache::default(), &mut o2);
        for s in 0..bsz {
            assert!((o1[s] - o2[s]).abs() < 1e-12);
        }
    }

    #[test]
    fn mostly_zero_inputs_skip_zeros_and_keep_exact_gradients() {
        // Inputs that are mostly zero take the skip-zeros path of layer 0 (forward and weight
        // gradient); outputs, parameter and input gradients must match central differences.
        for hidden in [vec![6], vec![6, 7]] {
            let spec = MlpSpec { onehot: vec![5, 3], dense: 10, hidden };
            let mut m = Mlp::<f64>::new(spec, &mut ChaCha12Rng::seed_from_u64(4), false);
            let onehot = vec![0, 2, 4, 1, 2, 0];
            let bsz = 3;
            let mut dense = vec![0.0; 10 * bsz];
            for (s, i) in [(0, 1), (0, 7), (1, 3), (2, 0), (2, 9)] {
                dense[s * 10 + i] = 0.3 + 0.1 * (s + i) as f64;
            }
            assert!(mostly_zero(&dense));
            let x = Inputs::full(&onehot, &dense, bsz);
            let (mut out, mut out2) = (vec![0.0; bsz], vec![0.0; bsz]);
            m.forward(&x, &mut Cache::default(), &mut out);
            m.eval(&x, &mut out2);
            // Bit for bit: the learner reads one forward pass both as values and for backprop.
            for s in 0..bsz {
                assert_eq!(out[s].to_bits(), out2[s].to_bits(), "eval {} vs forward {}", out2[s], out[s]);
            }
            assert_gradients_match_central_differences(&mut m, &onehot, &dense, bsz);
        }
    }

    #[test]
    fn listed_dense_inputs_give_the_bits_of_the_whole_inputs() {
        // Per sample, 3 listed entries out of 12 inputs (mostly zero: the skip-zeros path) or
        // 10 of 12 (the matrix-product path); some listed values are zero.
        for (listed, hidden) in [(3, vec![6]), (3, vec![6, 7]), (10, vec![6]), (10, vec![5, 4])] {
            let (dim, bsz) = (12, 5);
            let spec = MlpSpec { onehot: vec![4], dense: dim, hidden };
            let m = Mlp::<f32>::new(spec, &mut ChaCha12Rng::seed_from_u64(11), false);
            let onehot: Vec<u32> = (0..bsz as u32).map(|s| s % 4).collect();
            let (mut index, mut value, mut whole) = (Vec::new(), Vec::new(), vec![0.0f32; dim * bsz]);
            for s in 0..bsz {
                for k in 0..listed {
                    let i = (s + 5 * k) % dim;
                    let v = if (s + k) % 4 == 0 { 0.0 } else { ((s * 7 + k) as f32 * 0.61).sin() };
                    whole[s * dim + i] = v;
                    index.push(i as u32);
                }
                index[s * listed..].sort_unstable();
                value.extend(index[s * listed..].iter().map(|&i| whole[s * dim + i as usize]));
            }
            let full = Inputs::full(&onehot, &whole, bsz);
            let list = Inputs {
                onehot: &onehot,
                dense: Dense::Listed { index: &index, value: &value, per_sample: listed },
                batch: bsz,
            };
            let run = |x: &Inputs<'_, f32>| {
                let (mut cache, mut out, mut evals) = (Cache::default(), vec![0.0; bsz], vec![0.0; bsz]);
                m.forward(x, &mut cache, &mut out);
                m.eval(x, &mut evals);
                let dout: Vec<f32> = (0..bsz).map(|s| 0.5 - s as f32).collect();
                let mut g = vec![0.0; m.n_params()];
                let mut di = vec![0.0; x.dense_width(dim) * bsz];
                m.backward(x, &cache, &dout, Some(&mut g), Some(&mut di));
                (out, evals, g, di)
            };
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let (a, b) = (run(&full), run(&list));
            assert_eq!(bits(&a.0), bits(&b.0), "forward, {listed} listed");
            assert_eq!(bits(&a.1), bits(&b.1), "eval, {listed} listed");
            assert_eq!(bits(&a.2), bits(&b.2), "parameter gradient, {listed} listed");
            for (e, &i) in index.iter().enumerate() {
                let s = e / listed;
                assert_eq!(
                    a.3[s * dim + i as usize].to_bits(),
                    b.3[e].to_bits(),
                    "input gradient of sample {s}, input {i}"
                );
            }
        }
    }

    /// The passes compiled for AVX-512 and for AVX2 give the bits of the plain build (each
    /// element gets the same operations in the same order, only more lanes at a time), on the
    /// column path (one hidden layer of 128, mostly-zero inputs) and the matrix-product path.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn every_instruction_set_gives_the_bits_of_the_plain_build() {
        #[derive(Debug, Clone, Copy)]
        enum Isa {
            Plain,
            Avx2,
            Avx512,
        }
        /// Forward, eval and backward outputs of `m` built for `isa`, as bits.
        fn run(m: &Mlp<f32>, x: &Inputs<'_, f32>, dout: &[f32], isa: Isa) -> [Vec<u32>; 4] {
            let (bsz, dim) = (x.batch, m.spec.dense);
            let (mut cache, mut out, mut evals) = (Cache::default(), vec![0.0; bsz], vec![0.0; bsz]);
            let (mut g, mut di) = (vec![0.0; m.n_params()], vec![0.0; dim * bsz]);
            // SAFETY: the caller runs each instruction set only where the CPU has it.
            unsafe {
                match isa {
                    Isa::Plain => {
                        m.forward_impl(x, &mut cache, &mut out);
                        m.eval_impl(x, &mut evals);
                        m.backward_impl(x, &cache, dout, Some(&mut g), Some(&mut di));
                    }
                    Isa::Avx2 => {
                        m.forward_avx2(x, &mut cache, &mut out);
                        m.eval_avx2(x, &mut evals);
                        m.backward_avx2(x, &cache, dout, Some(&mut g), Some(&mut di));
                    }
                    Isa::Avx512 => {
                        m.forward_avx512(x, &mut cache, &mut out);
                        m.eval_avx512(x, &mut evals);
                        m.backward_avx512(x, &cache, dout, Some(&mut g), Some(&mut di));
                    }
                }
            }
            [out, evals, g, di].map(|v| v.iter().map(|x| x.to_bits()).collect())
        }
        let mut isas = vec![];
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            isas.push(Isa::Avx2);
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            isas.push(Isa::Avx512);
        }
        eprintln!("checked against the plain build: {isas:?}");
        for (hidden, nonzero) in [(vec![128], 3), (vec![6, 7], 12)] {
            let (dim, bsz) = (12, 9);
            let spec = MlpSpec { onehot: vec![5, 3], dense: dim, hidden };
            let m = Mlp::<f32>::new(spec, &mut ChaCha12Rng::seed_from_u64(5), false);
            let onehot: Vec<u32> = (0..bsz as u32).flat_map(|s| [s % 5, s % 3]).collect();
            let dense: Vec<f32> =
                (0..dim * bsz).map(|i| if i % dim < nonzero { ((i as f32) * 0.73).sin() * 3.0 } else { 0.0 }).collect();
            let x = Inputs::full(&onehot, &dense, bsz);
            let dout: Vec<f32> = (0..bsz).map(|s| 0.5 - s as f32).collect();
            let plain = run(&m, &x, &dout, Isa::Plain);
            for &isa in &isas {
                assert_eq!(run(&m, &x, &dout, isa), plain, "{isa:?}, hidden {:?}", m.spec.hidden);
            }
        }
    }

    #[test]
    fn eval_without_cache_matches_forward() {
        for hidden in [vec![6], vec![16], vec![6, 7]] {
            let spec = MlpSpec { onehot: vec![5, 3], dense: 4, hidden };
            let m = Mlp::<f64>::new(spec, &mut ChaCha12Rng::seed_from_u64(9), false);
            let onehot = vec![0, 2, 4, 1, 2, 0];
            let dense: Vec<f64> = (0..12).map(|i| ((i as f64) * 0.37).sin()).collect();
            let x = Inputs::full(&onehot, &dense, 3);
            let (mut o1, mut o2) = (vec![0.0; 3], vec![0.0; 3]);
            m.forward(&x, &mut Cache::default(), &mut o1);
            m.eval(&x, &mut o2);
            for s in 0..3 {
                assert!((o1[s] - o2[s]).abs() < 1e-12, "{o1:?} vs {o2:?}");
            }
        }
    }

    #[test]
    fn zero_output_layer_gives_a_constant_and_the_bias_moves_it() {
        let spec = MlpSpec { onehot: vec![4], dense: 2, hidden: vec![5] };
        let mut m = Mlp::<f32>::new(spec, &mut ChaCha12Rng::seed_from_u64(3), true);
        m.set_output_bias(2.5);
        let mut out = vec![0.0f32; 2];
        m.forward(&Inputs::full(&[0, 3], &[0.1, 0.2, -1.0, 4.0], 2), &mut Cache::default(), &mut out);
        assert_eq!(out, vec![2.5, 2.5]);
    }
}
