//! Eigenvalues and eigenvectors of a symmetric tridiagonal matrix by the implicit QL method
//! with Wilkinson shifts (EISPACK tql2; Wilkinson & Reinsch, *Handbook for Automatic
//! Computation* II (1971), contribution II/2). The Lanczos matrices T_k are small (k ≲ 100),
//! so the O(k³) cost per call is below one pass over a long vector.

use crate::error::{CoreError, CoreResult};

/// The eigen-decomposition T = Z diag(θ) Zᵀ of a symmetric tridiagonal T, in reusable buffers.
#[derive(Debug, Default, Clone)]
pub struct Tridiagonal {
    /// The eigenvalues θ (in no particular order).
    pub theta: Vec<f64>,
    /// Z row-major (k × k): column j is the eigenvector of θ_j.
    pub z: Vec<f64>,
    e: Vec<f64>,
}

/// The most QL sweeps for one eigenvalue (in practice two or three).
const MAX_SWEEPS: usize = 60;

impl Tridiagonal {
    /// Decomposes T with diagonal `alpha` (k entries) and off-diagonal `beta` (k − 1 entries).
    pub fn decompose(&mut self, alpha: &[f64], beta: &[f64]) -> CoreResult<()> {
        let n = alpha.len();
        debug_assert_eq!(beta.len() + 1, n.max(1));
        self.theta.clear();
        self.theta.extend_from_slice(alpha);
        self.e.clear();
        self.e.extend_from_slice(beta);
        self.e.push(0.0);
        self.z.clear();
        self.z.resize(n * n, 0.0);
        for i in 0..n {
            self.z[i * n + i] = 1.0;
        }
        let (d, e, z) = (&mut self.theta, &mut self.e, &mut self.z);
        for l in 0..n {
            let mut sweeps = 0;
            loop {
                // the first negligible off-diagonal entry at or after l
                let mut m = l;
                while m + 1 < n {
                    let dd = d[m].abs() + d[m + 1].abs();
                    if e[m].abs() <= f64::EPSILON * dd {
                        break;
                    }
                    m += 1;
                }
                if m == l {
                    break;
                }
                sweeps += 1;
                if sweeps > MAX_SWEEPS {
                    return Err(CoreError::invalid(
                        "tridiagonal",
                        format!("the QL iteration did not converge in {MAX_SWEEPS} sweeps"),
                    ));
                }
                let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
                let mut r = g.hypot(1.0);
                g = d[m] - d[l] + e[l] / (g + r.copysign(g));
                let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
                let mut deflated = false;
                let mut i = m;
                while i > l {
                    i -= 1;
                    let f = s * e[i];
                    let b = c * e[i];
                    r = f.hypot(g);
                    e[i + 1] = r;
                    if r == 0.0 {
                        // underflow: split the matrix here and sweep again
                        d[i + 1] -= p;
                        e[m] = 0.0;
                        deflated = true;
                        break;
                    }
                    s = f / r;
                    c = g / r;
                    g = d[i + 1] - p;
                    r = (d[i] - g) * s + 2.0 * c * b;
                    p = s * r;
                    d[i + 1] = g + p;
                    g = c * r - b;
                    for k in 0..n {
                        let f = z[k * n + i + 1];
                        z[k * n + i + 1] = s * z[k * n + i] + c * f;
                        z[k * n + i] = c * z[k * n + i] - s * f;
                    }
                }
                if deflated {
                    continue;
                }
                d[l] -= p;
                e[l] = g;
                e[m] = 0.0;
            }
        }
        Ok(())
    }

    /// y = Z diag(f) Zᵀ e₁ = f(T) e₁ for the values f_j = f(θ_j).
    pub fn times_first(&self, f: &[f64], y: &mut [f64]) {
        let n = self.theta.len();
        for (i, yi) in y.iter_mut().enumerate().take(n) {
            let mut s = 0.0;
            for j in 0..n {
                s += self.z[i * n + j] * (f[j] * self.z[j]);
            }
            *yi = s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_second_difference_matrix_has_its_known_spectrum_and_vectors() {
        // tridiag(−1, 2, −1) of size k: θ_j = 2 − 2 cos(jπ/(k+1)), and f(T) = T for f = θ
        let k = 9;
        let mut t = Tridiagonal::default();
        t.decompose(&[2.0; 9], &[-1.0; 8]).unwrap();
        let mut got = t.theta.clone();
        got.sort_by(f64::total_cmp);
        for (j, g) in got.iter().enumerate() {
            let exact = 2.0 - 2.0 * ((j + 1) as f64 * std::f64::consts::PI / (k + 1) as f64).cos();
            assert!((g - exact).abs() < 1e-14, "{g} vs {exact}");
        }
        let mut y = vec![0.0; k];
        t.times_first(&t.theta.clone(), &mut y);
        let mut want = vec![0.0; k];
        (want[0], want[1]) = (2.0, -1.0);
        for (a, b) in y.iter().zip(&want) {
            assert!((a - b).abs() < 1e-14, "{y:?}");
        }
        // and f = 1 gives e₁ (Z is orthogonal)
        t.times_first(&[1.0; 9], &mut y);
        assert!((y[0] - 1.0).abs() < 1e-14 && y[1..].iter().all(|x| x.abs() < 1e-14));
    }

    #[test]
    fn a_one_by_one_matrix_is_its_own_eigenvalue() {
        let mut t = Tridiagonal::default();
        t.decompose(&[3.5], &[]).unwrap();
        assert_eq!(
            (t.theta.as_slice(), t.z.as_slice()),
            (&[3.5][..], &[1.0][..])
        );
    }
}
