//! # envpg-nn
//!
//! The small networks of envpg, written by hand on nalgebra because they are tiny, their inputs
//! are mostly one-hot, and Algorithm 1 needs gradients with respect to *inputs* (∇ζ) as much as
//! with respect to parameters.
//!
//! ## Main types
//! - [`Mlp`]: a multilayer perceptron whose parameters live in one flat vector (so the
//!   optimiser, checkpoints and weight broadcasts see a single slice). The first layer takes
//!   [`Inputs`]: one-hot groups (a column gather, not a dense multiply) plus dense features,
//!   stored whole or, when few can be non-zero, as a list of those ([`Dense::Listed`]).
//! - [`Cache`]: activations of a forward pass, consumed by [`Mlp::backward`], which accumulates
//!   parameter gradients and, on request, gradients with respect to the dense inputs.
//! - [`Adam`]: the Adam optimiser over a flat parameter slice.
//! - [`Scalar`]: `f32` (training) or `f64` (gradient checks).
//!
//! ## Data flow
//! features → [`Inputs`] → [`Mlp::forward`] (→ [`Cache`]) → outputs; upstream gradient →
//! [`Mlp::backward`] → flat parameter gradient (+ dense-input gradient) → [`Adam::step`].
//!
//! ```
//! use envpg_nn::{Adam, Cache, Inputs, Mlp, MlpSpec};
//! use rand::SeedableRng;
//!
//! // Inputs: one one-hot group of 3 (a state) and 1 dense feature; one hidden layer of 8.
//! let spec = MlpSpec { onehot: vec![3], dense: 1, hidden: vec![8] };
//! let mut net = Mlp::<f64>::new(spec, &mut rand_chacha::ChaCha12Rng::seed_from_u64(1), false);
//! // Two samples, states 0 and 2 with dense inputs 0.5 and -1, both with target 1.
//! let x = Inputs::full(&[0, 2], &[0.5, -1.0], 2);
//! let loss = |y: &[f64]| y.iter().map(|v| 0.5 * (v - 1.0).powi(2)).sum::<f64>();
//! let (mut cache, mut y) = (Cache::default(), [0.0; 2]);
//! net.forward(&x, &mut cache, &mut y);
//! let before = loss(&y);
//! let dout: Vec<f64> = y.iter().map(|v| v - 1.0).collect(); // ∂loss/∂y per sample
//! let mut grad = vec![0.0; net.n_params()];
//! net.backward(&x, &cache, &dout, Some(&mut grad), None);
//! Adam::new(net.n_params(), 1e-3).step(net.params_mut(), &grad);
//! net.eval(&x, &mut y);
//! assert!(loss(&y) < before, "one Adam step lowers the loss: {} -> {}", before, loss(&y));
//! ```

pub mod activation;
pub mod adam;
mod gather;
mod inputs;
pub mod linear;
pub mod mlp;

pub use adam::Adam;
pub use inputs::{Dense, Inputs};
pub use mlp::{Cache, Mlp, MlpSpec};

/// Floating-point types the networks run in.
pub trait Scalar: nalgebra::RealField + Copy + Default + Send + Sync + 'static {
    /// Converts from `f64` (rounding).
    fn of(x: f64) -> Self;
    /// Converts to `f64`.
    fn to_f64(self) -> f64;
    /// SiLU over a slice: on return `z[i]` holds σ(z_i) and `a[i]` holds `z_i·σ(z_i)`.
    fn silu_inplace(z: &mut [Self], a: &mut [Self]) {
        for (zv, av) in z.iter_mut().zip(a.iter_mut()) {
            let s = activation::sigmoid(*zv);
            *av = *zv * s;
            *zv = s;
        }
    }
    /// `C ← α·A·B + β·C` for strided row/column layouts (A: m×k, B: k×n, C: m×n), the kernel
    /// nalgebra itself uses for large products; strides make transposes free.
    ///
    /// # Safety
    /// The pointers and strides must describe valid, non-overlapping (for C) matrices.
    #[allow(clippy::too_many_arguments)]
    unsafe fn gemm_raw(
        m: usize,
        k: usize,
        n: usize,
        alpha: Self,
        a: *const Self,
        rsa: isize,
        csa: isize,
        b: *const Self,
        rsb: isize,
        csb: isize,
        beta: Self,
        c: *mut Self,
        rsc: isize,
        csc: isize,
    );
}

impl Scalar for f32 {
    #[inline]
    fn of(x: f64) -> Self {
        x as f32
    }
    /// Uses [`activation::fast_exp`] so the loop vectorises (libm's `expf` is a call per element
    /// and was half of the forward pass); σ is accurate to 4e-6 relative. Inlined into the MLP's
    /// passes, which are compiled 16 lanes wide with AVX-512, or 8 with AVX2 and FMA, where the
    /// CPU has them.
    #[inline(always)]
    fn silu_inplace(z: &mut [Self], a: &mut [Self]) {
        activation::silu_f32(z, a);
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    unsafe fn gemm_raw(
        m: usize,
        k: usize,
        n: usize,
        alpha: Self,
        a: *const Self,
        rsa: isize,
        csa: isize,
        b: *const Self,
        rsb: isize,
        csb: isize,
        beta: Self,
        c: *mut Self,
        rsc: isize,
        csc: isize,
    ) {
        // SAFETY: forwarded contract.
        unsafe { matrixmultiply::sgemm(m, k, n, alpha, a, rsa, csa, b, rsb, csb, beta, c, rsc, csc) }
    }
}

impl Scalar for f64 {
    #[inline]
    fn of(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    unsafe fn gemm_raw(
        m: usize,
        k: usize,
        n: usize,
        alpha: Self,
        a: *const Self,
        rsa: isize,
        csa: isize,
        b: *const Self,
        rsb: isize,
        csb: isize,
        beta: Self,
        c: *mut Self,
        rsc: isize,
        csc: isize,
    ) {
        // SAFETY: forwarded contract.
        unsafe { matrixmultiply::dgemm(m, k, n, alpha, a, rsa, csa, b, rsb, csb, beta, c, rsc, csc) }
    }
}
