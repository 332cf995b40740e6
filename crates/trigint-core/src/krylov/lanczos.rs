//! Products f(h√A) v by the Lanczos method, several f from one Krylov basis.
//!
//! With the Lanczos basis V_k of span{v, Av, …, A^{k−1}v} and T_k = V_kᵀ A V_k (tridiagonal),
//!
//!   f(h√A) v ≈ |v| V_k f(h√T_k) e₁        [Saad 1992; Hochbruck–Lubich 1997].
//!
//! The filters of every method are even functions of hω, hence analytic functions of λ = ω²:
//! the error falls geometrically in k once k exceeds about h√λ_max. The iteration stops when
//! the a posteriori estimate β_k |e_kᵀ f(h√T_k) e₁| of every f is below `tol` |f(h√T_k) e₁|
//! twice in a row (one agreeing estimate can be an early lucky small entry), or when the space
//! is invariant. No reorthogonalization: for analytic f the Lanczos approximation converges
//! without it [Druskin–Greenbaum–Knizhnerman 1998]; the estimate catches the delay.

use super::csr::{dot, norm, Csr};
use super::functions::{Function, MatrixFunctions, Values};
use super::tridiagonal::Tridiagonal;
use crate::error::CoreResult;

/// The most Lanczos steps for one product.
pub const MAX_ITERATIONS: usize = 400;

/// Coordinates per block when the products are assembled from the basis (a block of every
/// Lanczos vector stays in the cache while each function sums over it).
const BLOCK: usize = 1024;

/// What became of a product.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Product {
    /// Within the tolerance, after this many Lanczos steps.
    Converged(usize),
    /// Not within the tolerance after the most steps allowed.
    NotConverged,
}

/// The Lanczos method's buffers, reused from product to product, and its counts.
pub struct Lanczos {
    n: usize,
    tol: f64,
    max_iterations: usize,
    /// Rows of n: the Lanczos vectors.
    basis: Vec<f64>,
    w: Vec<f64>,
    alpha: Vec<f64>,
    beta: Vec<f64>,
    tri: Tridiagonal,
    values: Values,
    coeffs: Vec<Vec<f64>>,
    /// Lanczos steps taken, over every product.
    pub iterations: u64,
    /// Products taken.
    pub products: u64,
}

impl Lanczos {
    /// Buffers for vectors of length n; `tol` the relative tolerance of every product.
    pub fn new(n: usize, tol: f64, max_iterations: usize) -> Self {
        Lanczos {
            n,
            tol,
            max_iterations,
            basis: Vec::with_capacity(16 * n),
            w: vec![0.0; n],
            alpha: Vec::new(),
            beta: Vec::new(),
            tri: Tridiagonal::default(),
            values: Default::default(),
            coeffs: Vec::new(),
            iterations: 0,
            products: 0,
        }
    }

    /// `out[i] = f_which[i](h√A) v` for every requested function.
    pub fn apply(
        &mut self,
        a: &Csr,
        v: &[f64],
        functions: &dyn MatrixFunctions,
        which: &[Function],
        out: &mut [&mut [f64]],
    ) -> CoreResult<Product> {
        let n = self.n;
        self.products += 1;
        let beta0 = norm(v);
        if beta0 == 0.0 || !beta0.is_finite() {
            let fill = if beta0 == 0.0 { 0.0 } else { f64::NAN };
            for o in out.iter_mut() {
                o.fill(fill);
            }
            return Ok(Product::Converged(0));
        }
        self.alpha.clear();
        self.beta.clear();
        self.basis.clear();
        self.basis.resize(n, 0.0);
        divide(&mut self.basis, v, beta0);
        self.coeffs.resize(which.len(), Vec::new());
        let mut previous = false;
        for k in 0..self.max_iterations {
            self.iterations += 1;
            let (done, current) = self.basis.split_at(k * n);
            let current = &current[..n];
            a.apply(current, &mut self.w);
            if k > 0 {
                sub_scaled(&mut self.w, self.beta[k - 1], &done[(k - 1) * n..]);
            }
            let alpha = dot(current, &self.w);
            self.alpha.push(alpha);
            sub_scaled(&mut self.w, alpha, current);
            let b = norm(&self.w);
            self.tri.decompose(&self.alpha, &self.beta)?;
            functions.evaluate(&self.tri.theta, &mut self.values)?;
            let mut converged = true;
            for (c, f) in self.coeffs.iter_mut().zip(which) {
                c.resize(k + 1, 0.0);
                self.tri.times_first(&self.values[*f as usize], c);
                let scale = norm_small(c).max(1e-300);
                converged &= b * c[k].abs() <= self.tol * scale;
            }
            let invariant = b <= 1e-13 * alpha.abs().max(1.0);
            if invariant || (converged && previous) {
                // |v| Σ_i c_i v_i per function, a block of coordinates at a time: the basis
                // is read from memory once for all functions (the same sums in the same order).
                let (basis, coeffs) = (&self.basis, &self.coeffs);
                crate::isa::wide(
                    #[inline(always)]
                    || {
                        for start in (0..n).step_by(BLOCK) {
                            let block = start..(start + BLOCK).min(n);
                            for (o, c) in out.iter_mut().zip(coeffs) {
                                let o = &mut o[block.clone()];
                                o.fill(0.0);
                                for (i, ci) in c.iter().enumerate() {
                                    let x = &basis[i * n + block.start..i * n + block.end];
                                    for (y, x) in o.iter_mut().zip(x) {
                                        *y += ci * x;
                                    }
                                }
                                for y in o.iter_mut() {
                                    *y *= beta0;
                                }
                            }
                        }
                    },
                );
                return Ok(Product::Converged(k + 1));
            }
            previous = converged;
            self.beta.push(b);
            self.basis.resize((k + 2) * n, 0.0);
            divide(&mut self.basis[(k + 1) * n..], &self.w, b);
        }
        Ok(Product::NotConverged)
    }
}

/// y −= a x.
fn sub_scaled(y: &mut [f64], a: f64, x: &[f64]) {
    crate::isa::wide(
        #[inline(always)]
        || {
            for (y, x) in y.iter_mut().zip(x) {
                *y -= a * x;
            }
        },
    )
}

/// y = x / a.
fn divide(y: &mut [f64], x: &[f64], a: f64) {
    crate::isa::wide(
        #[inline(always)]
        || {
            for (y, x) in y.iter_mut().zip(x) {
                *y = x / a;
            }
        },
    )
}

/// The 2-norm of a short vector, summed in order.
fn norm_small(c: &[f64]) -> f64 {
    c.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::super::functions::{Filter, Trigonometric};
    use super::*;

    /// A = ω² tridiag(−1, 2, −1) of size n (fixed ends): eigenpairs in closed form.
    pub(crate) fn chain(n: usize, omega2: f64) -> Csr {
        let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
        for i in 0..n {
            for (j, x) in [(i.wrapping_sub(1), -1.0), (i, 2.0), (i + 1, -1.0)] {
                if j < n {
                    indices.push(j);
                    data.push(x * omega2);
                }
            }
            indptr.push(indices.len());
        }
        Csr::new(n, indptr, indices, data).unwrap()
    }

    #[test]
    fn an_eigenvector_gets_the_functions_of_its_eigenvalue() {
        let (n, omega2, h) = (200, 100.0, 0.05);
        let a = chain(n, omega2);
        let j = 7.0;
        let x = |i: usize| (j * std::f64::consts::PI * (i + 1) as f64 / (n + 1) as f64).sin();
        let v: Vec<f64> = (0..n).map(x).collect();
        let lambda = omega2 * (2.0 - 2.0 * (j * std::f64::consts::PI / (n + 1) as f64).cos());
        let f = Trigonometric {
            h,
            filter: Filter::C,
        };
        let mut lz = Lanczos::new(n, 1e-12, MAX_ITERATIONS);
        let (mut y1, mut y2) = (vec![0.0; n], vec![0.0; n]);
        let r = lz
            .apply(
                &a,
                &v,
                &f,
                &[Function::Chi, Function::Phi],
                &mut [&mut y1, &mut y2],
            )
            .unwrap();
        assert!(matches!(r, Product::Converged(k) if k <= 3), "{r:?}");
        let xi = h * lambda.sqrt();
        for i in 0..n {
            assert!((y1[i] - xi.sin() / xi * v[i]).abs() < 1e-13);
            assert!((y2[i] - xi.sin() / xi * v[i]).abs() < 1e-13);
        }
    }

    #[test]
    fn a_general_vector_matches_the_eigen_expansion() {
        let (n, omega2, h) = (60, 400.0, 0.04);
        let a = chain(n, omega2);
        let v: Vec<f64> = (0..n)
            .map(|i| ((i * i) as f64 * 0.37).sin() + 0.1)
            .collect();
        let f = Trigonometric {
            h,
            filter: Filter::B,
        };
        let mut lz = Lanczos::new(n, 1e-13, MAX_ITERATIONS);
        let mut y = vec![0.0; n];
        let r = lz
            .apply(&a, &v, &f, &[Function::OneMinusCos], &mut [&mut y])
            .unwrap();
        assert!(matches!(r, Product::Converged(k) if k > 3), "{r:?}");
        // exact: Σ_j (1 − cos(h√λ_j)) (s_j · v) s_j over the normalized sine eigenvectors
        let pi = std::f64::consts::PI;
        let mut exact = vec![0.0; n];
        for j in 1..=n {
            let s: Vec<f64> = (0..n)
                .map(|i| {
                    (2.0 / (n + 1) as f64).sqrt()
                        * (j as f64 * pi * (i + 1) as f64 / (n + 1) as f64).sin()
                })
                .collect();
            let lambda = omega2 * (2.0 - 2.0 * (j as f64 * pi / (n + 1) as f64).cos());
            let c = (1.0 - (h * lambda.sqrt()).cos()) * dot(&s, &v);
            for i in 0..n {
                exact[i] += c * s[i];
            }
        }
        let err = y
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-11, "{err}");
    }

    #[test]
    fn too_few_iterations_are_reported() {
        let a = chain(50, 400.0);
        let v: Vec<f64> = (0..50).map(|i| (i as f64).cos()).collect();
        let f = Trigonometric {
            h: 0.05,
            filter: Filter::B,
        };
        let mut lz = Lanczos::new(50, 1e-12, 3);
        let mut y = vec![0.0; 50];
        let r = lz
            .apply(&a, &v, &f, &[Function::Chi], &mut [&mut y])
            .unwrap();
        assert_eq!(r, Product::NotConverged);
    }
}
