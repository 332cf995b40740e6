//! The standard benchmark problem, shared by the examples, the Criterion benchmarks and tests:
//! FPU with m stiff springs of frequency ω (GNI §I.5), a trigonometric method at step size h,
//! and the standard initial data.

use crate::{Layout, MethodCoefficients};

pub fn sinc(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.sin() / x
    }
}

/// The trigonometric method with filters (ψ, φ) at step size h for per-coordinate frequencies.
pub fn trigonometric(
    h: f64,
    omega: &[f64],
    psi: impl Fn(f64) -> f64,
    phi: impl Fn(f64) -> f64,
) -> MethodCoefficients {
    let xi: Vec<f64> = omega.iter().map(|w| h * w).collect();
    let psi: Vec<f64> = xi.iter().map(|&x| psi(x)).collect();
    let phi: Vec<f64> = xi.iter().map(|&x| phi(x)).collect();
    let chi: Vec<f64> = xi.iter().map(|&x| sinc(x)).collect();
    let sigma: Vec<f64> = (0..xi.len()).map(|i| chi[i] * phi[i] / psi[i]).collect();
    MethodCoefficients {
        h,
        one_minus_cos: xi.iter().map(|x| 2.0 * (0.5 * x).sin().powi(2)).collect(),
        psi_over_chi: (0..xi.len()).map(|i| psi[i] / chi[i]).collect(),
        sin2_over_h_chi: (0..xi.len()).map(|i| omega[i] * xi[i].sin()).collect(),
        modified_p: (0..xi.len())
            .map(|i| if omega[i] == 0.0 { 0.0 } else { sigma[i] })
            .collect(),
        modified_q: (0..xi.len())
            .map(|i| sigma[i] * omega[i] * omega[i])
            .collect(),
        chi,
        psi,
        phi,
    }
}

/// The layout of per-coordinate frequencies already in kernel order (slow first, blocks
/// contiguous).
pub fn layout(omega: &[f64]) -> Layout {
    let n_slow = omega.iter().take_while(|&&w| w == 0.0).count();
    let mut block_ends = Vec::new();
    for i in n_slow..omega.len() {
        if i + 1 == omega.len() || omega[i + 1] != omega[i] {
            block_ends.push(i + 1);
        }
    }
    Layout {
        omega2: omega.iter().map(|w| w * w).collect(),
        n_slow,
        block_ends,
        pair_forms: None,
    }
}

/// (method B, layout, q0, p0) for FPU with m stiff springs of frequency ω.
pub fn fpu_method_b(
    m: usize,
    omega: f64,
    h: f64,
) -> (MethodCoefficients, Layout, Vec<f64>, Vec<f64>) {
    let w: Vec<f64> = (0..2 * m)
        .map(|i| if i < m { 0.0 } else { omega })
        .collect();
    let co = trigonometric(h, &w, sinc, |_| 1.0);
    let (mut q0, mut p0) = (vec![0.0; 2 * m], vec![0.0; 2 * m]);
    q0[0] = 1.0;
    p0[0] = 1.0;
    q0[m] = 1.0 / omega;
    p0[m] = 1.0;
    (co, layout(&w), q0, p0)
}

/// The FPU's spring elongations over the modal variables (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ) as a sparse
/// matrix in compressed rows (ptr, cols, vals): first, inner and last springs.
pub fn fpu_springs(m: usize) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let (mut ptr, mut cols, mut vals) = (vec![0], vec![], vec![]);
    let mut push = |row: &[(usize, f64)]| {
        for &(c, v) in row {
            cols.push(c);
            vals.push(v);
        }
        ptr.push(cols.len());
    };
    push(&[(0, 1.0), (m, -1.0)]);
    for i in 1..m {
        push(&[(i, 1.0), (m + i, -1.0), (i - 1, -1.0), (m + i - 1, -1.0)]);
    }
    push(&[(m - 1, 1.0), (2 * m - 1, 1.0)]);
    (ptr, cols, vals)
}
