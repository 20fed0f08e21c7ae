//! physics-mcp patch 5: nalgebra's dynamic-vector `dot` and `axpy`, operation for operation, on
//! plain slices.
//!
//! The release's generic (multibody) joint constraints solved with `jacobians.rows(..)` and
//! `solver_vels.rows(..)` views: every solver iteration built strided `DVectorView`s and ran
//! nalgebra's generic kernels over them (a few hundred instructions for a 7-entry row, most of it
//! view and stride bookkeeping). These functions compute exactly what those kernels compute —
//! the same products, added in the same order into the same accumulators — on contiguous
//! slices, so every result keeps its bits. Only `GenericJointConstraint::solve` uses them: in the
//! generic contact constraints they measured dearer than nalgebra's kernels (PATCHES.md patch 5).

use crate::math::Real;

/// `a · b` as nalgebra 0.35's `Matrix::dot` computes it for a dynamic column vector
/// (`Matrix::dotx`): eight accumulators over each full block of eight entries, folded into the
/// result pairwise (`acc0 + acc4`, `acc1 + acc5`, `acc2 + acc6`, `acc3 + acc7`, in that order),
/// then the remaining entries added one by one. The result starts at `+0.0`, so an empty dot
/// product is `+0.0`, as nalgebra's.
#[inline(always)]
pub(crate) fn dot(a: &[Real], b: &[Real]) -> Real {
    assert_eq!(a.len(), b.len(), "Dot product dimensions mismatch.");
    let mut res: Real = 0.0;
    let (mut acc0, mut acc1, mut acc2, mut acc3): (Real, Real, Real, Real) = (0.0, 0.0, 0.0, 0.0);
    let (mut acc4, mut acc5, mut acc6, mut acc7): (Real, Real, Real, Real) = (0.0, 0.0, 0.0, 0.0);
    let (blocks_a, blocks_b) = (a.chunks_exact(8), b.chunks_exact(8));
    let (tail_a, tail_b) = (blocks_a.remainder(), blocks_b.remainder());
    for (x, y) in blocks_a.zip(blocks_b) {
        acc0 += x[0] * y[0];
        acc1 += x[1] * y[1];
        acc2 += x[2] * y[2];
        acc3 += x[3] * y[3];
        acc4 += x[4] * y[4];
        acc5 += x[5] * y[5];
        acc6 += x[6] * y[6];
        acc7 += x[7] * y[7];
    }
    res += acc0 + acc4;
    res += acc1 + acc5;
    res += acc2 + acc6;
    res += acc3 + acc7;
    for (x, y) in tail_a.iter().zip(tail_b) {
        res += *x * *y;
    }
    res
}

/// `y ← alpha·x + y`, as nalgebra 0.35's `Vector::axpy(alpha, x, 1.0)` computes it
/// (`array_axcpy`: `alpha·x·1 + 1·y` per entry, where both multiplications by one are exact).
#[inline(always)]
pub(crate) fn axpy(y: &mut [Real], alpha: Real, x: &[Real]) {
    assert_eq!(y.len(), x.len(), "Axpy: mismatched vector shapes.");
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi = alpha * *xi + *yi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alloc_prelude::*;
    use crate::math::DVector;

    /// Bit for bit nalgebra's on every length from 0 to 63 (up to seven blocks of eight and every
    /// tail), three sets of values with signed zeros spread over 32 binades, so that another order
    /// of the additions changes the result (the test checks that it does for a plain sequential
    /// sum; a swapped fold of the accumulators, `acc2 + acc6` after `acc3 + acc7`, fails too).
    #[test]
    fn same_bits_as_nalgebra() {
        let value = |i: usize, s: u32| -> Real {
            if i % 11 == 5 {
                return -0.0;
            }
            let h = (i as u32 + 1).wrapping_mul(2_654_435_761).wrapping_add(s.wrapping_mul(40_503));
            let mantissa = 1.0 + (h & 0xffff) as Real / 65536.0;
            let exponent = ((h >> 16) % 17) as i32 - 8;
            let sign = if (h >> 24) & 1 == 1 { -1.0 } else { 1.0 };
            let mut scale: Real = 1.0; // 4^exponent, exactly
            for _ in 0..exponent.unsigned_abs() {
                scale *= 4.0;
            }
            if exponent < 0 {
                scale = 1.0 / scale;
            }
            sign * mantissa * scale
        };
        let mut order_matters = false;
        for (n, (sa, sb)) in (0..64).flat_map(|n| [(1, 7), (3, 11), (5, 13)].map(|s| (n, s))) {
            let a: Vec<Real> = (0..n).map(|i| value(i, sa)).collect();
            let b: Vec<Real> = (0..n).map(|i| value(i, sb)).collect();
            let (va, vb) = (DVector::from_column_slice(&a), DVector::from_column_slice(&b));
            assert_eq!(dot(&a, &b).to_bits(), va.dot(&vb).to_bits(), "dot, n = {n}");
            let sequential = a.iter().zip(&b).fold(0.0 as Real, |r, (x, y)| r + x * y);
            order_matters |= sequential.to_bits() != dot(&a, &b).to_bits();
            for alpha in [0.0, -0.0, 1.5e-3, -7.25] {
                let mut y = b.clone();
                axpy(&mut y, alpha, &a);
                let mut vy = vb.clone();
                vy.rows_mut(0, n).axpy(alpha, &va.rows(0, n), 1.0);
                let bits = |v: &[Real]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&y), bits(vy.as_slice()), "axpy, n = {n}, alpha = {alpha}");
            }
        }
        assert!(order_matters, "the values must tell summation orders apart");
    }
}
