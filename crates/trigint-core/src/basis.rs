//! Changes of coordinates y = x M for the states of a problem with a stiffness matrix
//! (M = Q or Qᵀ, the modal basis), in a fixed order of operations: every row is summed over k
//! in increasing order, so a state gets the same bits alone or in a batch of any size (BLAS
//! would pick another summation order for one row than for many).

/// y (rows × n) = x (rows × k) · m (k × n), all row-major; y is overwritten.
pub fn rows_times(x: &[f64], m: &[f64], k: usize, n: usize, y: &mut [f64]) {
    assert_eq!(m.len(), k * n, "matrix of {k} x {n} expected");
    let rows = x.len() / k.max(1);
    assert_eq!(y.len(), rows * n, "output of {rows} x {n} expected");
    for (xr, yr) in x.chunks_exact(k.max(1)).zip(y.chunks_exact_mut(n.max(1))) {
        yr.fill(0.0);
        for (a, mr) in xr.iter().zip(m.chunks_exact(n)) {
            for (yj, mj) in yr.iter_mut().zip(mr) {
                *yj += a * mj;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_has_the_same_bits_alone_and_in_a_batch() {
        let (k, n) = (7, 5);
        let m: Vec<f64> = (0..k * n).map(|i| (i as f64 * 0.37).sin()).collect();
        let x: Vec<f64> = (0..3 * k).map(|i| (i as f64 * 1.3).cos() * 1e3).collect();
        let mut all = vec![0.0; 3 * n];
        rows_times(&x, &m, k, n, &mut all);
        for r in 0..3 {
            let mut one = vec![0.0; n];
            rows_times(&x[r * k..(r + 1) * k], &m, k, n, &mut one);
            assert_eq!(one, all[r * n..(r + 1) * n]);
            for j in 0..n {
                let want: f64 = (0..k).map(|i| x[r * k + i] * m[i * n + j]).sum();
                assert!((one[j] - want).abs() < 1e-12 * want.abs().max(1.0));
            }
        }
    }
}
