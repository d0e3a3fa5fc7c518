//! [`Inputs`]: a batch of network inputs, with its dense part either stored whole or as a list
//! of the entries that may be non-zero ([`Dense::Listed`]).
//!
//! A routed ζ-block puts a sample's few non-zero inputs at places that vary by sample: with
//! thousands of states a column has over a thousand dense inputs of which a few dozen can be
//! non-zero. Listed, such a batch takes a fraction of the memory, and the gradient with respect
//! to the inputs is computed only where they are listed. Both forms give the same bits: the
//! first layer adds the same non-zero terms in the same order, and each listed input gradient
//! is the entry the whole matrix product would have computed.

use std::borrow::Cow;

use crate::Scalar;
use crate::gather::{Term, push_nonzeros};
use crate::linear::{Mat, Op, gemm};

/// A batch of inputs: per sample one index per one-hot group, and the dense features.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a, T> {
    /// `batch × groups` indices, sample-major; each index is local to its group.
    pub onehot: &'a [u32],
    /// The dense features.
    pub dense: Dense<'a, T>,
    /// Batch size.
    pub batch: usize,
}

/// The dense features of a batch.
#[derive(Debug, Clone, Copy)]
pub enum Dense<'a, T> {
    /// Every input: `dense × batch`, column-major (one column per sample).
    Full(&'a [T]),
    /// The inputs that may be non-zero, `per_sample` of them per sample: entry `k` of sample
    /// `s` is input `index[s·per_sample + k]` with value `value[s·per_sample + k]`. Each
    /// sample's indices increase; every input not listed is zero. The gradient with respect
    /// to these inputs ([`Mlp::backward`](crate::Mlp::backward)'s `dinput`) is listed the same
    /// way.
    Listed {
        /// Input index of each entry.
        index: &'a [u32],
        /// Value of each entry.
        value: &'a [T],
        /// Entries per sample.
        per_sample: usize,
    },
}

impl<T: Scalar> Inputs<'_, T> {
    /// Inputs whose dense features are stored whole (`dense × batch`, column-major).
    pub fn full<'a>(onehot: &'a [u32], dense: &'a [T], batch: usize) -> Inputs<'a, T> {
        Inputs { onehot, dense: Dense::Full(dense), batch }
    }

    /// Values per sample of the dense part as stored (and of its input gradient).
    pub fn dense_width(&self, dim: usize) -> usize {
        match self.dense {
            Dense::Full(_) => dim,
            Dense::Listed { per_sample, .. } => per_sample,
        }
    }

    /// Panics unless the dense part describes `batch` samples of `dim` inputs.
    pub(crate) fn check_dense(&self, dim: usize) {
        match self.dense {
            Dense::Full(d) => assert_eq!(d.len(), self.batch * dim, "dense input size"),
            Dense::Listed { index, value, per_sample } => {
                assert_eq!(index.len(), self.batch * per_sample, "listed index count");
                assert_eq!(value.len(), index.len(), "listed value count");
                // Every pass checks this, so without a branch per entry.
                let ordered = index.chunks(per_sample.max(1)).fold(true, |ok, sample| {
                    let increasing = sample.windows(2).fold(true, |inc, w| inc & (w[0] < w[1]));
                    ok & increasing & sample.last().is_none_or(|&i| (i as usize) < dim)
                });
                assert!(ordered, "listed indices must increase within each sample and stay below {dim}");
            }
        }
    }

    /// Whether more than three quarters of the dense inputs (`dim` per sample) are exactly
    /// zero, counting every input not listed as zero.
    pub(crate) fn dense_mostly_zero(&self, dim: usize) -> bool {
        match self.dense {
            Dense::Full(d) => mostly_zero(d),
            Dense::Listed { value, .. } => {
                let n = dim * self.batch;
                let nonzero = value.iter().filter(|&&v| v != T::zero()).count();
                4 * (n - nonzero) > 3 * n
            }
        }
    }

    /// The dense features as a whole `dim × batch` matrix (a copy when listed).
    pub(crate) fn dense_full(&self, dim: usize) -> Cow<'_, [T]> {
        match self.dense {
            Dense::Full(d) => Cow::Borrowed(d),
            Dense::Listed { index, value, per_sample } => {
                let mut d = vec![T::zero(); dim * self.batch];
                for (e, (&i, &v)) in index.iter().zip(value).enumerate() {
                    d[(e / per_sample) * dim + i as usize] = v;
                }
                Cow::Owned(d)
            }
        }
    }

    /// Appends `(x_i, offset + i·stride)` for each non-zero dense input `x_i` of sample `s`,
    /// in index order.
    #[inline(always)]
    pub(crate) fn push_dense_terms(&self, s: usize, dim: usize, offset: usize, stride: usize, out: &mut Vec<Term<T>>) {
        match self.dense {
            Dense::Full(d) => push_nonzeros(&d[s * dim..(s + 1) * dim], offset, stride, out),
            Dense::Listed { index, value, per_sample } => {
                let r = s * per_sample..(s + 1) * per_sample;
                for (&i, &v) in index[r.clone()].iter().zip(&value[r]) {
                    if v != T::zero() {
                        out.push((v, offset + i as usize * stride));
                    }
                }
            }
        }
    }

    /// Calls `f(i, x_i)` for each non-zero dense input of sample `s`, in index order.
    #[inline(always)]
    pub(crate) fn for_each_nonzero(&self, s: usize, dim: usize, mut f: impl FnMut(usize, T)) {
        match self.dense {
            Dense::Full(d) => {
                for (i, &v) in d[s * dim..(s + 1) * dim].iter().enumerate() {
                    if v != T::zero() {
                        f(i, v);
                    }
                }
            }
            Dense::Listed { index, value, per_sample } => {
                let r = s * per_sample..(s + 1) * per_sample;
                for (&i, &v) in index[r.clone()].iter().zip(&value[r]) {
                    if v != T::zero() {
                        f(i as usize, v);
                    }
                }
            }
        }
    }
}

/// Whether more than three quarters of `x` are exactly zero: then the first layer skips the
/// zero inputs instead of running a dense product (ζ-blocks routed into slots are mostly zeros;
/// below that density the product is faster).
#[inline(always)]
pub(crate) fn mostly_zero<T: Scalar>(x: &[T]) -> bool {
    4 * x.iter().filter(|&&v| v == T::zero()).count() > 3 * x.len()
}

/// Samples per matrix product of [`listed_input_gradient`]: bounds its scratch copy of `dz`.
const GROUP: usize = 256;

/// `out[s·p + k] = W[:, index[s·p + k]] · dz[:, s]` for the listed entries (`p` per sample) of
/// `W` (`h × dim`, column-major) and `dz` (`h × batch`).
///
/// Each sample's entries fall into runs of consecutive inputs (a routed slot, the environment's
/// features); samples whose runs cover the same inputs share one matrix product over those
/// columns of `W`. Every entry is then computed by the same kernel, over the same `h` terms in
/// the same order, as in the whole product `Wᵀ·dz` — the same bits.
pub(crate) fn listed_input_gradient<T: Scalar>(
    w: &[T],
    h: usize,
    dz: &[T],
    index: &[u32],
    per_sample: usize,
    out: &mut [T],
) {
    assert_eq!(out.len(), index.len(), "listed input gradient size");
    // (first input, length, sample, first entry) of every run, grouped by the inputs covered.
    let mut runs: Vec<(u32, u32, u32, u32)> = Vec::new();
    for (s, sample) in index.chunks(per_sample.max(1)).enumerate() {
        let mut k0 = 0;
        while k0 < sample.len() {
            let mut k1 = k0 + 1;
            while k1 < sample.len() && sample[k1] == sample[k1 - 1] + 1 {
                k1 += 1;
            }
            runs.push((sample[k0], (k1 - k0) as u32, s as u32, k0 as u32));
            k0 = k1;
        }
    }
    group_runs(&mut runs, w.len() / h.max(1));
    let mut cols = Vec::with_capacity(h * GROUP);
    let mut prod = Vec::new();
    for same in runs.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (first, len) = (same[0].0 as usize, same[0].1 as usize);
        let wt = Mat::new(&w[first * h..(first + len) * h], h, len);
        for group in same.chunks(GROUP) {
            cols.clear();
            for &(_, _, s, _) in group {
                cols.extend_from_slice(&dz[s as usize * h..(s as usize + 1) * h]);
            }
            prod.clear();
            prod.resize(len * group.len(), T::zero());
            gemm(T::one(), wt, Op::T, Mat::new(&cols, h, group.len()), Op::N, T::zero(), &mut prod, len, group.len());
            for (j, &(_, _, s, k0)) in group.iter().enumerate() {
                let at = s as usize * per_sample + k0 as usize;
                out[at..at + len].copy_from_slice(&prod[j * len..(j + 1) * len]);
            }
        }
    }
}

/// Orders `runs` as `sort_unstable` would (by first input, length, sample, entry) in linear time:
/// they arrive ordered by (sample, entry), so a stable bucket sort by first input followed by a
/// stable sort by length within each bucket (usually one length, already in order) gives the
/// lexicographic order. `dim` bounds the first inputs.
fn group_runs(runs: &mut Vec<(u32, u32, u32, u32)>, dim: usize) {
    debug_assert!(runs.windows(2).all(|p| (p[0].2, p[0].3) < (p[1].2, p[1].3)), "runs in sample order");
    let mut start = vec![0usize; dim + 1];
    for r in runs.iter() {
        start[r.0 as usize + 1] += 1;
    }
    for i in 0..dim {
        start[i + 1] += start[i];
    }
    let mut sorted = vec![(0, 0, 0, 0); runs.len()];
    for &r in runs.iter() {
        let at = &mut start[r.0 as usize];
        sorted[*at] = r;
        *at += 1;
    }
    for bucket in sorted.chunk_by_mut(|x, y| x.0 == y.0) {
        bucket.sort_by_key(|r| r.1);
    }
    *runs = sorted;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_listed_input_gradient_has_the_bits_of_the_whole_product() {
        // Widths below, at and above the kernels' blocking; entries in runs of several lengths
        // shared by some samples and not others.
        for h in [7, 128, 300] {
            let dim = 90;
            let bsz = 600;
            let w: Vec<f32> = (0..h * dim).map(|i| ((i as f32) * 0.377).sin() * 1.7).collect();
            let dz: Vec<f32> = (0..h * bsz).map(|i| ((i as f32) * 0.911).cos()).collect();
            let mut whole = vec![0.0f32; dim * bsz];
            gemm(1.0, Mat::new(&w, h, dim), Op::T, Mat::new(&dz, h, bsz), Op::N, 0.0, &mut whole, dim, bsz);
            let per_sample = 3 + 4 + 4;
            let mut index = Vec::new();
            for s in 0..bsz {
                index.extend([0, 1, 2]);
                let a = 3 + 4 * (s % 5) as u32;
                let b = 3 + 4 * (5 + (s * 7 % 13) as u32);
                index.extend((a..a + 4).chain(b..b + 4));
            }
            let mut listed = vec![0.0f32; index.len()];
            listed_input_gradient(&w, h, &dz, &index, per_sample, &mut listed);
            for (e, &i) in index.iter().enumerate() {
                let s = e / per_sample;
                assert_eq!(listed[e].to_bits(), whole[s * dim + i as usize].to_bits(), "h {h}, sample {s}, input {i}");
            }
        }
    }

    #[test]
    fn runs_are_grouped_in_the_order_of_a_full_sort() {
        // Runs in (sample, entry) order with first inputs and lengths repeating out of order.
        let mut runs = Vec::new();
        for s in 0..200u32 {
            let mut k0 = 0;
            for (first, len) in [((s * 7) % 11, 1 + s % 3), (20 + (s * 5) % 4, 2), (30 + s % 2, 1 + (s / 7) % 2)] {
                runs.push((first, len, s, k0));
                k0 += len;
            }
        }
        let mut want = runs.clone();
        want.sort_unstable();
        group_runs(&mut runs, 40);
        assert_eq!(runs, want);
    }

    #[test]
    fn listed_inputs_count_unlisted_entries_as_zero_and_densify_in_place() {
        let index = [1u32, 3, 0, 2];
        let value = [0.5f64, 0.0, -1.0, 2.0];
        let x = Inputs { onehot: &[], dense: Dense::Listed { index: &index, value: &value, per_sample: 2 }, batch: 2 };
        x.check_dense(4);
        assert_eq!(&*x.dense_full(4), &[0.0, 0.5, 0.0, 0.0, -1.0, 0.0, 2.0, 0.0]);
        // 3 non-zeros of 8: five eighths are zero, not more than three quarters.
        assert!(!x.dense_mostly_zero(4));
        assert!(x.dense_mostly_zero(16));
        let mut terms = Vec::new();
        x.push_dense_terms(1, 4, 10, 100, &mut terms);
        assert_eq!(terms, [(-1.0, 10), (2.0, 210)]);
    }

    #[test]
    #[should_panic(expected = "listed indices must increase")]
    fn listed_indices_out_of_order_are_refused() {
        let x = Inputs {
            onehot: &[],
            dense: Dense::Listed { index: &[2, 1], value: &[1.0f32, 1.0], per_sample: 2 },
            batch: 1,
        };
        x.check_dense(4);
    }
}
