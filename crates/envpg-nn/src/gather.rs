//! The first layer as a sum of a few weight columns, accumulated in registers.
//!
//! A first-layer pre-activation is `z = W_d·x + b + Σ_groups W[:, onehot]`; with mostly-zero
//! dense inputs it is a sum of a few dozen weight columns. Written as one axpy per column, every
//! term loads and stores all of `z` again, and the stores bound the loop. [`accumulate`] walks `z`
//! in register-sized chunks instead and adds every term to a chunk before storing it, so each
//! term costs only the loads of its weights.
//!
//! Each element still receives its terms in the listed order, one rounded multiply and one
//! rounded add per term (no fused multiply–add), so the result is bitwise that of the axpys —
//! which keeps every trained network, and every result file, unchanged.

use crate::Scalar;

/// Elements of `z` held in registers at a time: 64 f32 are eight AVX2 registers (measured a
/// little faster than 32 at width 128).
const CHUNK: usize = 64;

/// One term of [`accumulate`]: `coef · params[offset..offset + h]`.
pub(crate) type Term<T> = (T, usize);

/// `z[j] += Σ_terms coef · params[offset + j]`, terms added in order (bitwise the same as one
/// axpy per term, in order).
#[inline(always)]
pub(crate) fn accumulate<T: Scalar>(params: &[T], terms: &[Term<T>], z: &mut [T]) {
    let h = z.len();
    for &(_, off) in terms {
        assert!(off + h <= params.len(), "weight column out of range");
    }
    let mut c0 = 0;
    while c0 + CHUNK <= h {
        let mut acc = [T::zero(); CHUNK];
        acc.copy_from_slice(&z[c0..c0 + CHUNK]);
        for &(a, off) in terms {
            let col = &params[off + c0..off + c0 + CHUNK];
            for l in 0..CHUNK {
                acc[l] += a * col[l];
            }
        }
        z[c0..c0 + CHUNK].copy_from_slice(&acc);
        c0 += CHUNK;
    }
    for (j, zj) in z.iter_mut().enumerate().skip(c0) {
        let mut v = *zj;
        for &(a, off) in terms {
            v += a * params[off + j];
        }
        *zj = v;
    }
}

/// Appends `(x[i], offset + i·stride)` for every non-zero `x[i]`, in index order (NaN counts as
/// non-zero, ±0 as zero, as in a plain `x[i] != 0` test).
#[inline(always)]
pub(crate) fn push_nonzeros<T: Scalar>(x: &[T], offset: usize, stride: usize, out: &mut Vec<Term<T>>) {
    const SCAN: usize = 16;
    let mut i0 = 0;
    for chunk in x.chunks(SCAN) {
        // A branch-free test per chunk first: the routed blocks leave most chunks all zero.
        if chunk.iter().fold(false, |any, &v| any | (v != T::zero())) {
            for (i, &v) in chunk.iter().enumerate() {
                if v != T::zero() {
                    out.push((v, offset + (i0 + i) * stride));
                }
            }
        }
        i0 += chunk.len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axpys(params: &[f32], terms: &[Term<f32>], z: &mut [f32]) {
        for &(a, off) in terms {
            for (j, zj) in z.iter_mut().enumerate() {
                *zj += a * params[off + j];
            }
        }
    }

    #[test]
    fn accumulate_is_bitwise_one_axpy_per_term() {
        // Widths around the chunk size, and coefficients whose products round.
        let params: Vec<f32> =
            (0..4000).map(|i| ((i as f32) * 0.731).sin() * 1e3_f32.powf((i % 7) as f32 - 3.0)).collect();
        for h in [1, 7, 63, 64, 65, 128, 130, 200] {
            let terms: Vec<Term<f32>> =
                (0..9).map(|t| (((t as f32) * 1.37 + 0.1).cos() * 3.3, (t * 311) % (4000 - h))).collect();
            let init: Vec<f32> = (0..h).map(|j| (j as f32 * 0.17).tan()).collect();
            let (mut a, mut b) = (init.clone(), init.clone());
            accumulate(&params, &terms, &mut a);
            axpys(&params, &terms, &mut b);
            assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "h = {h}");
        }
    }

    #[test]
    fn push_nonzeros_lists_exactly_the_non_zero_entries_in_order() {
        let mut x = vec![0.0f32; 40];
        x[3] = 1.5;
        x[16] = -0.0;
        x[17] = f32::NAN;
        x[39] = -2.0;
        let mut out = Vec::new();
        push_nonzeros(&x, 100, 10, &mut out);
        let got: Vec<usize> = out.iter().map(|t| t.1).collect();
        assert_eq!(got, [130, 270, 490]);
        assert_eq!(out[0].0, 1.5);
        assert!(out[1].0.is_nan());
    }
}
