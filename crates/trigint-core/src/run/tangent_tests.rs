//! The tangent step's second derivatives against central differences of the forces.
use crate::potential::{Chain, Fpu, LinearMap, Op, Potential, Program, ProgramSpec, Scratch, Wave};

/// G(x)v against central differences of the force.
fn check<P: Potential>(p: &P, x: &[f64], v: &[f64]) {
    let n = x.len();
    let mut ws = p.workspace::<f64>();
    let mut exact = vec![0.0; n];
    p.force_derivative(x, v, &mut exact, &mut ws, &mut Scratch::default())
        .unwrap();
    let eps = 1e-5;
    let at = |s: f64, ws: &mut P::Workspace<f64>| {
        let y: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + s * b).collect();
        let mut f = vec![0.0; n];
        p.force(&y, &mut f, false, ws).unwrap();
        f
    };
    let (plus, minus) = (at(eps, &mut ws), at(-eps, &mut ws));
    let mut err: f64 = 0.0;
    let mut size: f64 = 0.0;
    for i in 0..n {
        err = err.max(((plus[i] - minus[i]) / (2.0 * eps) - exact[i]).abs());
        size = size.max(exact[i].abs());
    }
    assert!(err <= 1e-7 * size, "error {err} against {size}");
}

fn point(n: usize, seed: f64) -> Vec<f64> {
    (0..n)
        .map(|i| 0.3 * ((i as f64 + 1.0) * seed).sin())
        .collect()
}

#[test]
fn fpu_short_long_and_mapped() {
    for m in [1, 3, 40] {
        check(
            &Fpu::new(m).unwrap(),
            &point(2 * m, 1.3),
            &point(2 * m, 0.7),
        );
    }
    // A rotation by 45° of the first two variables as the input map.
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let map = LinearMap::from_csr(2, 2, &[0, 2, 4], &[0, 1, 0, 1], &[s, s, -s, s]).unwrap();
    check(&Fpu::with_map(1, map).unwrap(), &[0.4, -0.2], &[0.3, 0.9]);
}

#[test]
fn program_chain_and_wave() {
    // U = exp(x0 − x1) + x1⁴ sin(x2) / 4
    let spec = ProgramSpec {
        n_inputs: 3,
        ops: vec![
            Op::Input(0),
            Op::Input(1),
            Op::Input(2),
            Op::Sub(0, 1),
            Op::Exp(3),
            Op::Powi(1, 4),
            Op::Sin(2),
            Op::Mul(5, 6),
            Op::Const(0.25),
            Op::Mul(7, 8),
            Op::Add(4, 9),
        ],
        output: 10,
    };
    let program = Program::new(&spec, None).unwrap();
    check(&program, &[0.2, -0.4, 0.7], &[1.0, 0.5, -0.3]);
    check(&program.interpreted(), &[0.2, -0.4, 0.7], &[1.0, 0.5, -0.3]);
    let (ptr, cols, vals) = crate::fixtures::fpu_springs(5);
    let map = LinearMap::from_csr(6, 10, &ptr, &cols, &vals).unwrap();
    let chain = Chain::single(map, &Chain::monomial(0.25, 4)).unwrap();
    check(&chain, &point(10, 0.9), &point(10, 2.1));
    let quartic_sine = ProgramSpec {
        n_inputs: 1,
        ops: vec![
            Op::Input(0),
            Op::Powi(0, 4),
            Op::Const(0.25),
            Op::Mul(2, 1),
            Op::Sin(0),
            Op::Add(3, 4),
        ],
        output: 5,
    };
    for shape in [vec![16], vec![8, 6]] {
        let n: usize = shape.iter().product();
        let order: Vec<usize> = (0..n).rev().collect();
        let wave = Wave::new(&shape, &quartic_sine, order).unwrap();
        check(&wave, &point(n, 1.7), &point(n, 0.4));
    }
}
