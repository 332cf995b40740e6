//! The standard benchmark problem, shared by the examples, the Criterion benchmarks and tests:
//! FPU with m stiff springs of frequency ω (GNI §I.5), Deuflhard's method B at step size h, and
//! the standard initial data.

use crate::{EnergyLayout, MethodCoefficients};

/// (method B coefficients, energy layout, q0, p0) for FPU with m stiff springs of frequency ω.
pub fn fpu_method_b(
    m: usize,
    omega: f64,
    h: f64,
) -> (MethodCoefficients, EnergyLayout, Vec<f64>, Vec<f64>) {
    let w: Vec<f64> = (0..2 * m)
        .map(|i| if i < m { 0.0 } else { omega })
        .collect();
    let sinc = |x: f64| if x == 0.0 { 1.0 } else { x.sin() / x };
    let co = MethodCoefficients {
        h,
        one_minus_cos: w
            .iter()
            .map(|x| 2.0 * (0.5 * h * x).sin().powi(2))
            .collect(),
        sin: w.iter().map(|x| (h * x).sin()).collect(),
        chi: w.iter().map(|x| sinc(h * x)).collect(),
        psi: w.iter().map(|x| sinc(h * x)).collect(),
        phi: vec![1.0; 2 * m],
    };
    let layout = EnergyLayout {
        omega2: w.iter().map(|x| x * x).collect(),
        modified_p: w
            .iter()
            .map(|&x| if x == 0.0 { 0.0 } else { 1.0 })
            .collect(),
        modified_q: w.iter().map(|x| x * x).collect(),
        block: w.iter().map(|&x| usize::from(x != 0.0)).collect(),
        n_blocks: 1,
    };
    let (mut q0, mut p0) = (vec![0.0; 2 * m], vec![0.0; 2 * m]);
    q0[0] = 1.0;
    p0[0] = 1.0;
    q0[m] = 1.0 / omega;
    p0[m] = 1.0;
    (co, layout, q0, p0)
}
