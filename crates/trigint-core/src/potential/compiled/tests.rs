//! Tests of compiled programs: gradients, bits of machine code and interpreter, bad tapes.

use super::code::{Code, Instr};
use super::libm::sin_cos;
use super::ops::{Op, ProgramSpec};
use super::program::Program;
use crate::potential::{Fpu, LinearMap, Potential};
use crate::real::{Lanes, Real, Scalar};

/// A xorshift generator of 64-bit words.
fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}

/// U = exp(x) cos(x).
fn exp_times_cos() -> ProgramSpec {
    ProgramSpec {
        n_inputs: 1,
        ops: vec![Op::Input(0), Op::Exp(0), Op::Cos(0), Op::Mul(1, 2)],
        output: 3,
    }
}

/// U = ¼ Σ (linear form)⁴ of the FPU chain, m = 3, as SymPy hands it over: each term
/// x⁴/4 with the linear forms written with negations.
pub(crate) fn fpu_tape(m: usize) -> ProgramSpec {
    let mut ops = Vec::new();
    let mut push = |op: Op| {
        ops.push(op);
        ops.len() - 1
    };
    let inputs: Vec<usize> = (0..2 * m).map(|i| push(Op::Input(i))).collect();
    let (x0, x1) = inputs.split_at(m);
    let quarter = push(Op::Const(0.25));
    let mut forms = vec![];
    let a = push(Op::Neg(x1[0]));
    forms.push(push(Op::Add(x0[0], a)));
    for i in 1..m {
        let t = push(Op::Neg(x0[i - 1]));
        let t = push(Op::Add(t, x0[i]));
        let u = push(Op::Neg(x1[i - 1]));
        let t = push(Op::Add(t, u));
        let u = push(Op::Neg(x1[i]));
        forms.push(push(Op::Add(t, u)));
    }
    forms.push(push(Op::Add(x0[m - 1], x1[m - 1])));
    let mut total = None;
    for y in forms {
        let p = push(Op::Powi(y, 4));
        let term = push(Op::Mul(quarter, p));
        total = Some(match total {
            None => term,
            Some(t) => push(Op::Add(t, term)),
        });
    }
    let output = total.unwrap();
    ProgramSpec {
        n_inputs: 2 * m,
        ops,
        output,
    }
}

#[test]
fn fpu_program_matches_the_native_chain_to_rounding_with_few_instructions() {
    let m = 3;
    let prog = Program::new(&fpu_tape(m), None).unwrap();
    // 8 for the linear forms, 8 for the cubes, 6 for the forces (+ negations folded).
    assert!(
        prog.force_instructions() <= 24,
        "{:?}",
        prog.force_only.instrs
    );
    let fpu = Fpu::new(m).unwrap();
    let x = [0.9, -0.3, 0.2, 0.02, 0.01, -0.015];
    let (mut f1, mut f2) = ([0.0; 6], [0.0; 6]);
    let u1 = prog
        .force(&x, &mut f1, true, &mut prog.workspace())
        .unwrap();
    let u2 = fpu.force(&x, &mut f2, true, &mut fpu.workspace()).unwrap();
    assert!((u1 - u2).abs() <= 1e-15 * u2.abs());
    for i in 0..6 {
        assert!(
            (f1[i] - f2[i]).abs() <= 1e-15 * f2[i].abs().max(1e-300),
            "{i}"
        );
    }
    let v = prog.value(&x, &mut prog.workspace()).unwrap();
    assert_eq!(v.to_bits(), u1.to_bits());
}

#[test]
fn transcendental_gradients_are_exact() {
    // U = exp(x0) sin(x1) + sqrt(x0^2 + 1)/tanh(x1) + |x0| x1^(3/2) + log(cosh(x0)) - 1/x1
    let ops = vec![
        Op::Input(0),
        Op::Input(1),
        Op::Exp(0),
        Op::Sin(1),
        Op::Mul(2, 3),
        Op::Powi(0, 2),
        Op::Const(1.0),
        Op::Add(5, 6),
        Op::Sqrt(7),
        Op::Tanh(1),
        Op::Div(8, 9),
        Op::Add(4, 10),
        Op::Abs(0),
        Op::Powf(1, 1.5),
        Op::Mul(12, 13),
        Op::Add(11, 14),
        Op::Cosh(0),
        Op::Log(16),
        Op::Add(15, 17),
        Op::Powi(1, -1),
        Op::Sub(18, 19),
    ];
    let spec = ProgramSpec {
        n_inputs: 2,
        ops,
        output: 20,
    };
    let prog = Program::new(&spec, None).unwrap();
    let u = |x: f64, y: f64| {
        x.exp() * y.sin() + (x * x + 1.0).sqrt() / y.tanh() + x.abs() * y.powf(1.5) + x.cosh().ln()
            - 1.0 / y
    };
    for &(x, y) in &[(0.3, 0.7), (-1.2, 2.5), (0.8, 0.1)] {
        let mut f = [0.0; 2];
        let v = prog
            .force(&[x, y], &mut f, true, &mut prog.workspace())
            .unwrap();
        assert!((v - u(x, y)).abs() < 1e-14 * u(x, y).abs());
        let gx = x.exp() * y.sin()
            + x / (x * x + 1.0).sqrt() / y.tanh()
            + x.signum() * y.powf(1.5)
            + x.tanh();
        let gy = x.exp() * y.cos()
            - (x * x + 1.0).sqrt() * (1.0 - y.tanh().powi(2)) / y.tanh().powi(2)
            + x.abs() * 1.5 * y.sqrt()
            + 1.0 / (y * y);
        assert!((f[0] + gx).abs() < 1e-13 * gx.abs(), "{} vs {}", f[0], -gx);
        assert!((f[1] + gy).abs() < 1e-13 * gy.abs(), "{} vs {}", f[1], -gy);
    }
}

#[test]
fn machine_code_gives_the_interpreters_bits() {
    // Every operation, several times over, in three coordinates: U = Σ of
    // tan(x0)·sinh(x1)/cosh(x2) + sign(x0)|x1|^0.7 + exp(−x2²) log(1 + x0²)
    // + sqrt(1 + x1⁴) cos(x2) sin(x0) − tanh(x0 x1 x2) + (x0 − x2)⁻³.
    let ops = vec![
        Op::Input(0),
        Op::Input(1),
        Op::Input(2),
        Op::Tan(0),
        Op::Sinh(1),
        Op::Cosh(2),
        Op::Mul(3, 4),
        Op::Div(6, 5),
        Op::Sign(0),
        Op::Abs(1),
        Op::Powf(9, 0.7),
        Op::Mul(8, 10),
        Op::Powi(2, 2),
        Op::Neg(12),
        Op::Exp(13),
        Op::Const(1.0),
        Op::Powi(0, 2),
        Op::Add(15, 16),
        Op::Log(17),
        Op::Mul(14, 18),
        Op::Powi(1, 4),
        Op::Add(15, 20),
        Op::Sqrt(21),
        Op::Cos(2),
        Op::Sin(0),
        Op::Mul(22, 23),
        Op::Mul(25, 24),
        Op::Mul(0, 1),
        Op::Mul(27, 2),
        Op::Tanh(28),
        Op::Sub(0, 2),
        Op::Powi(30, -3),
        Op::Add(7, 11),
        Op::Add(32, 19),
        Op::Add(33, 26),
        Op::Sub(34, 29),
        Op::Add(35, 31),
    ];
    let spec = ProgramSpec {
        n_inputs: 3,
        ops,
        output: 36,
    };
    let native = Program::new(&spec, None).unwrap();
    assert!(native.is_native(), "no machine code on this host");
    let plain = native.clone().interpreted();
    let (mut wn, mut wp) = (native.workspace::<f64>(), plain.workspace::<f64>());
    let mut next = xorshift(0x2545_f491_4f6c_dd1d);
    let mut uniform = || (next() >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0;
    let mut points: Vec<[f64; 3]> = (0..500)
        .map(|_| [uniform(), uniform(), uniform()])
        .collect();
    points.extend([
        [0.0, 0.0, 1.0],
        [1.0, -0.0, 1.0],
        [f64::NAN, 1.0, 2.0],
        [800.0, 1.0, 2.0],
    ]);
    for x in &points {
        for with_value in [true, false] {
            let (mut fn_, mut fp) = ([0.0; 3], [0.0; 3]);
            let un = native.force(x, &mut fn_, with_value, &mut wn).unwrap();
            let up = plain.force(x, &mut fp, with_value, &mut wp).unwrap();
            for i in 0..3 {
                assert_eq!(fn_[i].to_bits(), fp[i].to_bits(), "force {i} at {x:?}");
            }
            if with_value {
                assert_eq!(un.to_bits(), up.to_bits(), "U at {x:?}");
            }
        }
        let (vn, vp) = (
            native.value(x, &mut wn).unwrap(),
            plain.value(x, &mut wp).unwrap(),
        );
        assert_eq!(vn.to_bits(), vp.to_bits(), "U alone at {x:?}");
        let mut fs = [Scalar(0.0); 3];
        let xs = x.map(Scalar);
        let us = native
            .force(&xs, &mut fs, true, &mut native.workspace())
            .unwrap();
        assert_eq!(us.0.to_bits(), vp.to_bits());
    }
    // Bundles run machine code over lane pairs: each lane has the interpreter's bits.
    fn bundles<const W: usize>(native: &Program, plain: &Program, points: &[[f64; 3]]) {
        let mut ws = native.workspace::<Lanes<W>>();
        for chunk in points.chunks_exact(W) {
            let x: [Lanes<W>; 3] =
                std::array::from_fn(|i| Lanes(std::array::from_fn(|b| chunk[b][i])));
            let mut f = [Lanes::<W>::zero(); 3];
            let u = native.force(&x, &mut f, true, &mut ws).unwrap();
            let mut g = [Lanes::<W>::zero(); 3];
            native.force(&x, &mut g, false, &mut ws).unwrap();
            let v = native.value(&x, &mut ws).unwrap();
            for (b, p) in chunk.iter().enumerate() {
                let mut fp = [0.0; 3];
                let up = plain
                    .force(p, &mut fp, true, &mut plain.workspace())
                    .unwrap();
                assert_eq!(u.0[b].to_bits(), up.to_bits(), "U, lane {b} of {W}");
                assert_eq!(v.0[b].to_bits(), up.to_bits(), "U alone, lane {b} of {W}");
                for i in 0..3 {
                    assert_eq!(f[i].0[b].to_bits(), fp[i].to_bits(), "force {i}, lane {b}");
                    assert_eq!(g[i].0[b].to_bits(), fp[i].to_bits(), "force {i}, lane {b}");
                }
            }
        }
    }
    bundles::<2>(&native, &plain, &points);
    bundles::<8>(&native, &plain, &points);
    bundles::<3>(&native, &plain, &points);
    assert!(native.bundle_code(8).is_some() && native.bundle_code(3).is_none());
}

#[test]
fn sin_cos_has_the_bits_of_sin_and_cos() {
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
    let mut xs = vec![
        0.0,
        -0.0,
        1e-300,
        5e-324,
        0.855469,
        2.426265,
        1e22,
        f64::MAX,
    ];
    xs.extend([f64::NAN, f64::INFINITY, f64::NEG_INFINITY]);
    for k in 0..400_000 {
        let r = next();
        let unit = (r >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        // Each of glibc's ranges: |x| < 0.86, < 2.43, < 1.05e8 and beyond (other reductions).
        xs.push(match k % 5 {
            0 => unit * 2.0,
            1 => unit * 6.0,
            2 => unit * 400.0,
            3 => unit * 4e9,
            _ => f64::from_bits(r),
        });
    }
    for x in xs {
        let (s, c) = sin_cos(x);
        assert_eq!(s.to_bits(), x.sin().to_bits(), "sin {x:e}");
        assert_eq!(c.to_bits(), x.cos().to_bits(), "cos {x:e}");
    }
}

#[test]
fn sin_and_cos_of_one_argument_share_a_call_with_unchanged_bits() {
    // U = exp(x) cos(x): U and g need cos x and sin x (one SinCos), U alone only cos x.
    let native = Program::new(&exp_times_cos(), None).unwrap();
    let merged = |c: &Code| c.instrs.iter().any(|i| matches!(i, Instr::SinCos(_)));
    assert!(merged(&native.full) && merged(&native.force_only) && !merged(&native.value_only));
    let plain = native.clone().interpreted();
    for k in 0..2000 {
        let x = (k as f64 - 1000.0) * 0.0137;
        for prog in [&native, &plain] {
            let mut f = [0.0];
            let u = prog
                .force(&[x], &mut f, true, &mut prog.workspace())
                .unwrap();
            let alone = prog.value(&[x], &mut prog.workspace()).unwrap();
            assert_eq!(u.to_bits(), alone.to_bits(), "U at {x}");
            assert_eq!(u.to_bits(), (x.exp() * x.cos()).to_bits());
            // −U' = −(eˣ cos x − eˣ sin x) in some order of the same products: to rounding.
            let g = -(x.exp() * x.cos() - x.exp() * x.sin());
            assert!((f[0] - g).abs() <= 4.0 * f64::EPSILON * x.exp(), "g at {x}");
        }
    }
}

#[test]
fn lanes_give_each_trajectory_its_bits() {
    let prog = Program::new(&exp_times_cos(), None).unwrap();
    let xs: [f64; 8] = std::array::from_fn(|b| 0.37 * b as f64 - 1.1);
    let mut f = [Lanes::<8>::zero()];
    let v = prog
        .force(&[Lanes(xs)], &mut f, true, &mut prog.workspace())
        .unwrap();
    for b in 0..8 {
        let mut g = [0.0];
        let u = prog
            .force(&[xs[b]], &mut g, true, &mut prog.workspace())
            .unwrap();
        assert_eq!(
            (v.0[b].to_bits(), f[0].0[b].to_bits()),
            (u.to_bits(), g[0].to_bits())
        );
    }
}

#[test]
fn a_coordinate_map_composes() {
    // U(x) = x0 * x1 with x = T y, T = [[1, 1], [1, -1]]: U = y0² − y1².
    let spec = ProgramSpec {
        n_inputs: 2,
        ops: vec![Op::Input(0), Op::Input(1), Op::Mul(0, 1)],
        output: 2,
    };
    let t = LinearMap::from_csr(2, 2, &[0, 2, 4], &[0, 1, 0, 1], &[1.0, 1.0, 1.0, -1.0]).unwrap();
    let prog = Program::new(&spec, Some(&t)).unwrap();
    let mut f = [0.0; 2];
    let v = prog
        .force(&[3.0, 2.0], &mut f, true, &mut prog.workspace())
        .unwrap();
    assert_eq!(v, 5.0);
    assert_eq!(f, [-6.0, 4.0]);
}

#[test]
fn bad_tapes_are_refused() {
    let forward = ProgramSpec {
        n_inputs: 1,
        ops: vec![Op::Add(1, 1), Op::Input(0)],
        output: 0,
    };
    assert!(Program::new(&forward, None).is_err());
    let out_of_range = ProgramSpec {
        n_inputs: 1,
        ops: vec![Op::Input(3)],
        output: 0,
    };
    assert!(Program::new(&out_of_range, None).is_err());
    let nan = ProgramSpec {
        n_inputs: 1,
        ops: vec![Op::Const(f64::NAN)],
        output: 0,
    };
    assert!(Program::new(&nan, None).is_err());
}
