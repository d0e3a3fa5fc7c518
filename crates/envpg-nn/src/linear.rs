//! Dense products on column-major slices: the three products of a linear layer
//! (`Y = W·X`, `dW += dY·Xᵀ`, `dX = Wᵀ·dY`) without materialising transposes.

use crate::Scalar;

/// A column-major matrix view: `rows × cols` over `data` (len = rows·cols).
#[derive(Clone, Copy)]
pub struct Mat<'a, T> {
    /// Entries, column-major.
    pub data: &'a [T],
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
}

impl<'a, T> Mat<'a, T> {
    /// A view of `data` as `rows × cols`.
    pub fn new(data: &'a [T], rows: usize, cols: usize) -> Self {
        assert_eq!(data.len(), rows * cols, "matrix view size");
        Self { data, rows, cols }
    }
}

/// Whether an operand is used as stored or transposed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Op {
    /// As stored.
    N,
    /// Transposed.
    T,
}

/// `C ← α·op(A)·op(B) + β·C`, with `C` column-major `m × n` in `c`.
#[allow(clippy::too_many_arguments)]
pub fn gemm<T: Scalar>(
    alpha: T,
    a: Mat<'_, T>,
    opa: Op,
    b: Mat<'_, T>,
    opb: Op,
    beta: T,
    c: &mut [T],
    m: usize,
    n: usize,
) {
    let (am, ak, rsa, csa) = match opa {
        Op::N => (a.rows, a.cols, 1isize, a.rows as isize),
        Op::T => (a.cols, a.rows, a.rows as isize, 1isize),
    };
    let (bk, bn, rsb, csb) = match opb {
        Op::N => (b.rows, b.cols, 1isize, b.rows as isize),
        Op::T => (b.cols, b.rows, b.rows as isize, 1isize),
    };
    assert!(am == m && bn == n && ak == bk, "gemm shapes: op(A) {am}×{ak}, op(B) {bk}×{bn}, C {m}×{n}");
    assert_eq!(c.len(), m * n, "gemm output size");
    if m == 0 || n == 0 {
        return;
    }
    // SAFETY: shapes and strides checked above; `c` is an exclusive borrow of m·n entries.
    unsafe {
        T::gemm_raw(
            m,
            ak,
            n,
            alpha,
            a.data.as_ptr(),
            rsa,
            csa,
            b.data.as_ptr(),
            rsb,
            csb,
            beta,
            c.as_mut_ptr(),
            1,
            m as isize,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transposed_products_match_the_definition() {
        // A: 2×3, B: 2×4 → Aᵀ·B: 3×4.
        let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // columns (1,2), (3,4), (5,6)
        let b = [1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, -1.0];
        let mut c = vec![0.0f64; 12];
        gemm(1.0, Mat::new(&a, 2, 3), Op::T, Mat::new(&b, 2, 4), Op::N, 0.0, &mut c, 3, 4);
        for i in 0..3 {
            for j in 0..4 {
                let want: f64 = (0..2).map(|r| a[i * 2 + r] * b[j * 2 + r]).sum();
                assert_eq!(c[j * 3 + i], want);
            }
        }
        // A·Bᵀ with A: 2×3, B: 4×3 → 2×4, accumulated onto existing C (β = 1).
        let b2: Vec<f64> = (0..12).map(|x| x as f64).collect();
        let mut c2 = vec![1.0f64; 8];
        gemm(2.0, Mat::new(&a, 2, 3), Op::N, Mat::new(&b2, 4, 3), Op::T, 1.0, &mut c2, 2, 4);
        for i in 0..2 {
            for j in 0..4 {
                let want: f64 = 1.0 + 2.0 * (0..3).map(|k| a[k * 2 + i] * b2[k * 4 + j]).sum::<f64>();
                assert_eq!(c2[j * 2 + i], want);
            }
        }
    }
}
