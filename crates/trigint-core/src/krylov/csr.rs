//! A sparse symmetric matrix in compressed sparse rows, and the vector operations of the
//! Lanczos method in one fixed summation order (the same bits for a trajectory alone or in an
//! ensemble, on any thread).

use crate::error::{CoreError, CoreResult};
use crate::sum::Sum8;

/// A in CSR: row i has the entries `data[indptr[i]..indptr[i+1]]` in the columns
/// `indices[indptr[i]..indptr[i+1]]`. Symmetry is the caller's promise (the Python layer checks
/// it); the products here use the rows as given.
#[derive(Debug, Clone, PartialEq)]
pub struct Csr {
    n: usize,
    indptr: Vec<usize>,
    /// 32-bit column indices: half the memory traffic of `usize` in the products.
    indices: Vec<u32>,
    data: Vec<f64>,
}

impl Csr {
    /// Checks the arrays: n + 1 row pointers rising from 0 to nnz, column indices below n,
    /// finite entries.
    pub fn new(
        n: usize,
        indptr: Vec<usize>,
        indices: Vec<usize>,
        data: Vec<f64>,
    ) -> CoreResult<Self> {
        let bad = |reason: String| Err(CoreError::invalid("stiffness", reason));
        if n == 0 || n > u32::MAX as usize {
            return bad(format!("{n} rows: expected 1 to {}", u32::MAX));
        }
        if indptr.len() != n + 1 || indptr[0] != 0 || indptr[n] != indices.len() {
            return bad(format!(
                "{} row pointers for {n} rows and {} entries: expected n + 1 pointers from 0 to the entry count",
                indptr.len(),
                indices.len()
            ));
        }
        if indices.len() != data.len() {
            return bad(format!(
                "{} column indices for {} entries",
                indices.len(),
                data.len()
            ));
        }
        if indptr.windows(2).any(|w| w[0] > w[1]) {
            return bad("the row pointers decrease".into());
        }
        if let Some(&j) = indices.iter().find(|&&j| j >= n) {
            return bad(format!("column index {j} for a {n} x {n} matrix"));
        }
        if let Some(x) = data.iter().find(|x| !x.is_finite()) {
            return bad(format!("an entry is not finite ({x})"));
        }
        Ok(Csr {
            n,
            indptr,
            indices: indices.into_iter().map(|j| j as u32).collect(),
            data,
        })
    }

    /// Number of rows (= columns).
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.data.len()
    }

    /// y = A x, each row summed in stored order.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        assert!(
            x.len() >= self.n && y.len() >= self.n,
            "vectors shorter than the matrix"
        );
        let (data, indices) = (&self.data[..], &self.indices[..]);
        crate::isa::wide(
            #[inline(always)]
            || {
                let mut start = 0;
                for (yi, &end) in y[..self.n].iter_mut().zip(&self.indptr[1..]) {
                    let mut s = 0.0;
                    for k in start..end {
                        // SAFETY: the row pointers rise from 0 to the entry count and every column
                        // index is below n = x.len() (both checked in `new`).
                        s += unsafe {
                            data.get_unchecked(k)
                                * x.get_unchecked(*indices.get_unchecked(k) as usize)
                        };
                    }
                    *yi = s;
                    start = end;
                }
            },
        )
    }

    /// An upper bound of the largest |eigenvalue| (Gershgorin: the largest absolute row sum).
    pub fn gershgorin(&self) -> f64 {
        (0..self.n)
            .map(|i| {
                self.data[self.indptr[i]..self.indptr[i + 1]]
                    .iter()
                    .map(|x| x.abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }
}

/// x · y, in the kernels' fixed order (eight partial sums, then a fixed tree).
pub fn dot(x: &[f64], y: &[f64]) -> f64 {
    crate::isa::wide(
        #[inline(always)]
        || {
            let mut s = Sum8::<f64>::new();
            let (mut cx, mut cy) = (x.chunks_exact(8), y.chunks_exact(8));
            let mut started = false;
            let mut count = 0;
            for (a, b) in (&mut cx).zip(&mut cy) {
                let t: [f64; 8] = std::array::from_fn(|i| a[i] * b[i]);
                if started {
                    s.add8::<false>(&t);
                } else {
                    s.add8::<true>(&t);
                }
                started = true;
                count += 8;
            }
            for (t, (a, b)) in cx.remainder().iter().zip(cy.remainder()).enumerate() {
                s.add(t, started, a * b);
                count += 1;
            }
            s.total(count)
        },
    )
}

/// |x|₂, as √(x · x).
pub fn norm(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laplacian(n: usize) -> Csr {
        let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
        for i in 0..n {
            for (j, a) in [(i.wrapping_sub(1), -1.0), (i, 2.0), (i + 1, -1.0)] {
                if j < n {
                    indices.push(j);
                    data.push(a);
                }
            }
            indptr.push(indices.len());
        }
        Csr::new(n, indptr, indices, data).unwrap()
    }

    #[test]
    fn products_and_sums_are_exact_on_small_integers() {
        let a = laplacian(5);
        let mut y = vec![0.0; 5];
        a.apply(&[1.0, 2.0, 3.0, 4.0, 5.0], &mut y);
        assert_eq!(y, vec![0.0, 0.0, 0.0, 0.0, 6.0]);
        let x: Vec<f64> = (1..=19).map(f64::from).collect();
        assert_eq!(dot(&x, &x), (1..=19).map(|k| (k * k) as f64).sum::<f64>());
        assert_eq!(a.gershgorin(), 4.0);
    }

    #[test]
    fn malformed_arrays_are_refused_with_the_reason() {
        let e = Csr::new(2, vec![0, 1], vec![0], vec![1.0]).unwrap_err();
        assert!(e.to_string().contains("row pointers"), "{e}");
        let e = Csr::new(2, vec![0, 1, 2], vec![0, 2], vec![1.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("column index 2"), "{e}");
        let e = Csr::new(1, vec![0, 1], vec![0], vec![f64::NAN]).unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
    }
}
