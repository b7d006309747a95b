//! Eigenvalues and eigenvectors of small dense symmetric matrices (cyclic Jacobi).
//!
//! For the at most 6x6 Gram matrices of [`crate::support`] and the `d x d` Bloch symbols of
//! `linpd-dynamics`: a few dozen lines that compile in no time, where a general dense
//! eigensolver (nalgebra's, or faer's monomorphized in each calling crate) costs seconds of
//! build per crate. Cyclic Jacobi is accurate to a few ulps of the largest eigenvalue (and
//! relatively accurate for well-scaled positive definite matrices); its cost, `O(n^3)` per
//! sweep with a handful of sweeps, is irrelevant at these sizes. Large matrices belong to faer.

/// Eigen-decomposition `A = V diag(values) V^T` of a symmetric matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetricEigen {
    /// Order `n` of the matrix.
    pub n: usize,
    /// Eigenvalues, ascending.
    pub values: Vec<f64>,
    /// Orthonormal eigenvectors, column-major: component `i` of the vector of `values[k]` is
    /// `vectors[i + n * k]`.
    pub vectors: Vec<f64>,
}

impl SymmetricEigen {
    /// Component `i` of the eigenvector of `values[k]`.
    pub fn vector(&self, i: usize, k: usize) -> f64 {
        self.vectors[i + self.n * k]
    }
}

/// Eigen-decomposition of the symmetric `n x n` matrix `a` (row-major; only its lower
/// triangle is read, the upper is taken as its transpose).
///
/// # Panics
/// When `a.len() != n * n`.
pub fn symmetric_eigen(a: &[f64], n: usize) -> SymmetricEigen {
    assert_eq!(a.len(), n * n, "symmetric_eigen: {} entries for a {n} x {n} matrix", a.len());
    let mut m: Vec<f64> =
        (0..n * n).map(|ij| if ij % n <= ij / n { a[ij] } else { a[(ij % n) * n + ij / n] }).collect();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    let scale2: f64 = m.iter().map(|x| x * x).sum();
    // Stop once the off-diagonal part is below round-off of the whole matrix; sweeps converge
    // quadratically, 60 is a safety cap never reached in practice.
    let tol2 = (1e-3 * f64::EPSILON) * (1e-3 * f64::EPSILON) * scale2;
    for _sweep in 0..60 {
        let off2: f64 =
            (0..n).flat_map(|p| (p + 1..n).map(move |q| (p, q))).map(|(p, q)| 2.0 * m[p * n + q].powi(2)).sum();
        if off2 <= tol2 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = m[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                // The rotation J (J_pp = J_qq = c, J_pq = s, J_qp = -s) with (J^T A J)_pq = 0:
                // t = tan(phi) is the smaller root of t^2 + 2 theta t - 1 = 0.
                let theta = (m[q * n + q] - m[p * n + p]) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    let t = 1.0 / (theta.abs() + (theta * theta + 1.0).sqrt());
                    if theta < 0.0 {
                        -t
                    } else {
                        t
                    }
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A <- A J (columns p, q), then A <- J^T A (rows p, q); V <- V J.
                for k in 0..n {
                    let (akp, akq) = (m[k * n + p], m[k * n + q]);
                    m[k * n + p] = c * akp - s * akq;
                    m[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (m[p * n + k], m[q * n + k]);
                    m[p * n + k] = c * apk - s * aqk;
                    m[q * n + k] = s * apk + c * aqk;
                }
                m[p * n + q] = 0.0;
                m[q * n + p] = 0.0;
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| m[i * n + i].total_cmp(&m[j * n + j]));
    SymmetricEigen {
        n,
        values: order.iter().map(|&k| m[k * n + k]).collect(),
        vectors: order.iter().flat_map(|&k| (0..n).map(move |i| (i, k))).map(|(i, k)| v[i * n + k]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(a: &[f64], n: usize) -> SymmetricEigen {
        let e = symmetric_eigen(a, n);
        let norm = a.iter().map(|x| x * x).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
        for k in 0..n {
            for l in 0..n {
                let dot: f64 = (0..n).map(|i| e.vector(i, k) * e.vector(i, l)).sum();
                assert!((dot - if k == l { 1.0 } else { 0.0 }).abs() <= 1e-14, "V^T V != I at ({k}, {l}): {dot}");
            }
            for i in 0..n {
                let av: f64 = (0..n).map(|j| a[i * n + j] * e.vector(j, k)).sum();
                assert!((av - e.values[k] * e.vector(i, k)).abs() <= 1e-14 * norm, "A v != lambda v");
            }
        }
        assert!(e.values.windows(2).all(|w| w[0] <= w[1]), "ascending");
        e
    }

    #[test]
    fn closed_forms() {
        // diag, 2x2 with eigenvalues 1 and 3, the 3x3 second-difference matrix 2 -+ sqrt(2), 2.
        assert_eq!(check(&[2.0, 0.0, 0.0, -1.0], 2).values, vec![-1.0, 2.0]);
        let e = check(&[2.0, 1.0, 1.0, 2.0], 2);
        assert!((e.values[0] - 1.0).abs() <= 4e-16 && (e.values[1] - 3.0).abs() <= 8e-16);
        let e = check(&[2.0, -1.0, 0.0, -1.0, 2.0, -1.0, 0.0, -1.0, 2.0], 3);
        let r = 2f64.sqrt();
        for (x, y) in e.values.iter().zip([2.0 - r, 2.0, 2.0 + r]) {
            assert!((x - y).abs() <= 1e-15 * 4.0, "{x} vs {y}");
        }
        assert!(check(&[], 0).values.is_empty());
        assert_eq!(check(&[0.0; 9], 3).values, vec![0.0; 3]);
    }

    #[test]
    fn rank_deficient_gram_and_degenerate_pairs() {
        // G = B B^T for a 6 x 2 B: rank 2, four zero eigenvalues.
        let b: Vec<[f64; 2]> = (0..6).map(|i| [1.0 + i as f64, (i as f64 * 0.7).sin()]).collect();
        let g: Vec<f64> = (0..36).map(|ij| b[ij / 6][0] * b[ij % 6][0] + b[ij / 6][1] * b[ij % 6][1]).collect();
        let e = check(&g, 6);
        let max = e.values[5];
        assert_eq!(e.values.iter().filter(|&&v| v > 1e-10 * max).count(), 2);
        // A repeated eigenvalue (rotation-invariant block) and a pseudo-random symmetric 5x5.
        check(&[3.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 1.0], 3);
        let r: Vec<f64> = (0..25).map(|ij| (((ij / 5) * 7 + (ij % 5) * 7) as f64 * 0.37).cos()).collect();
        check(&r, 5);
    }
}
