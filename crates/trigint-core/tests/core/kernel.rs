//! Oracles for the kernels: exact harmonic solutions, the two forms against each other, the
//! shapes against each other (bit for bit), blow-up, interruption and bad input.

use trigint_core::fixtures::{fpu_method_b, layout, sinc, trigonometric};
use trigint_core::run::{rows, Bundle, Control};
use trigint_core::shape::{Fixed, Shape};
use trigint_core::*;

fn record(save_every: u64) -> Record {
    Record {
        save_every: Some(save_every),
        track: true,
    }
}

#[allow(clippy::too_many_arguments)]
fn run<P: Potential>(
    pot: &P,
    lay: &Layout,
    co: &MethodCoefficients,
    q0: &[f64],
    p0: &[f64],
    n: u64,
    form: Form,
    rec: Record,
) -> TrajectoryOutput {
    let mut go = |_| true;
    let control = Control {
        every: 1 << 20,
        report: &mut go,
    };
    integrate(pot, lay, co, q0, p0, n, form, rec, control).unwrap()
}

/// U = 0 in n coordinates.
fn zero(n: usize) -> Program {
    let spec = ProgramSpec {
        n_inputs: n,
        ops: vec![Op::Const(0.0)],
        output: 0,
    };
    Program::new(&spec, None).unwrap()
}

/// U = c x0^k as a program.
fn monomial(n: usize, c: f64, k: i32) -> Program {
    let spec = ProgramSpec {
        n_inputs: n,
        ops: vec![Op::Input(0), Op::Powi(0, k), Op::Const(c), Op::Mul(2, 1)],
        output: 3,
    };
    Program::new(&spec, None).unwrap()
}

#[test]
fn harmonic_oscillators_are_exact_in_both_forms() {
    // U = 0: q(t) = q0 cos ωt + p0 sin(ωt)/ω; one slow and two oscillatory blocks.
    let omega = [0.0, 7.0, 31.0];
    let (q0, p0) = ([0.3, -0.2, 0.05], [0.1, 1.0, -2.0]);
    let h = 3.0 / 31.0;
    let n = 10_000;
    let co = trigonometric(h, &omega, sinc, |_| 1.0);
    for form in [Form::TwoStep, Form::OneStep] {
        let out = run(&zero(3), &layout(&omega), &co, &q0, &p0, n, form, record(n));
        let t = n as f64 * h;
        assert_eq!(out.samples.steps, vec![0, n]);
        for i in 0..3 {
            let w = omega[i];
            let (q, p) = if w == 0.0 {
                (q0[i] + p0[i] * t, p0[i])
            } else {
                (
                    q0[i] * (w * t).cos() + p0[i] * (w * t).sin() / w,
                    -q0[i] * w * (w * t).sin() + p0[i] * (w * t).cos(),
                )
            };
            let (qs, ps) = (out.samples.q[3 + i], out.samples.p[3 + i]);
            assert!(
                (qs - q).abs() < 1e-10 * (q0[i].abs() + p0[i].abs()),
                "{form:?} q{i}"
            );
            assert!(
                (ps - p).abs() < 1e-10 * (p0[i].abs() + w * q0[i].abs()),
                "{form:?} p{i}"
            );
        }
        // Every energy is conserved up to rounding (each block is an exact rotation): within
        // 2nε of its size (measured: 7e-14 two-step, 7e-13 one-step, relative).
        let bound = 2.0 * n as f64 * f64::EPSILON;
        for (d, e) in out.max_deviation.iter().zip(&out.initial_energies) {
            assert!(*d <= bound * e.abs().max(1e-300), "{form:?}: {d} for {e}");
        }
    }
}

#[test]
fn fpu_forms_agree_and_energy_is_bounded() {
    let h = 2.0 * std::f64::consts::PI / 3.0 / 50.0;
    let (co, lay, q0, p0) = fpu_method_b(3, 50.0, h);
    let pot = Fpu::new(3).unwrap();
    let a = run(&pot, &lay, &co, &q0, &p0, 1000, Form::TwoStep, record(10));
    let b = run(&pot, &lay, &co, &q0, &p0, 1000, Form::OneStep, record(10));
    assert_eq!(a.samples.steps.len(), 101);
    for (x, y) in a.samples.q.iter().zip(&b.samples.q) {
        assert!((x - y).abs() < 1e-10, "{x} vs {y}");
    }
    use trigint_core::energy::{FIRST_BLOCK, MODIFIED, OSCILLATORY, TOTAL};
    assert!((a.initial_energies[TOTAL] - 2.00120008).abs() < 1e-12);
    assert!((a.initial_energies[OSCILLATORY] - 1.0).abs() < 1e-12);
    // H_ω stays within a small multiple of ε = 0.02 (Fig. 2, top); one block carries it all.
    let oscillatory = a.max_deviation[OSCILLATORY];
    assert!(oscillatory < 0.05 && oscillatory > 1e-6);
    assert_eq!(oscillatory, a.max_deviation[FIRST_BLOCK]);
    // B is symplectic with σ = 1: H* is H_ω.
    assert_eq!(oscillatory, a.max_deviation[MODIFIED]);
}

/// One trajectory through a bundle of the given shape and number type.
#[allow(clippy::too_many_arguments)]
fn through<L: Real, Sh: Shape, P: Potential>(
    sh: &Sh,
    pot: &P,
    lay: &Layout,
    co: &MethodCoefficients,
    q0: &[f64],
    p0: &[f64],
    n: u64,
    form: Form,
) -> TrajectoryOutput {
    let mut go = |_| true;
    let mut control = Control {
        every: 1 << 20,
        report: &mut go,
    };
    let b = Bundle::<L, Sh, P>::new(
        sh,
        pot,
        form,
        record(7),
        rows(sh, &lay.omega2, &[co]),
        &[co],
        &[q0],
        &[p0],
        &[n],
    );
    b.run(&mut control).unwrap().remove(0)
}

#[test]
fn every_shape_and_number_type_gives_the_same_bits() {
    let h = 0.02;
    let (co, lay, q0, p0) = fpu_method_b(3, 50.0, h);
    let pot = Fpu::new(3).unwrap();
    for form in [Form::TwoStep, Form::OneStep] {
        let fixed =
            through::<Scalar, _, _>(&Fixed::<6, 3>::new(), &pot, &lay, &co, &q0, &p0, 500, form);
        let uniform = through::<f64, _, _>(&lay.uniform(), &pot, &lay, &co, &q0, &p0, 500, form);
        let dynamic = through::<f64, _, _>(&lay.dynamic(), &pot, &lay, &co, &q0, &p0, 500, form);
        let lanes = through::<Lanes<4>, _, _>(&lay.dynamic(), &pot, &lay, &co, &q0, &p0, 500, form);
        assert_eq!(fixed, uniform, "{form:?}");
        assert_eq!(fixed, dynamic, "{form:?}");
        assert_eq!(fixed, lanes, "{form:?}");
        assert_eq!(fixed, run(&pot, &lay, &co, &q0, &p0, 500, form, record(7)));
    }
}

#[test]
fn blow_up_keeps_the_last_finite_state_tracked_or_not() {
    // U = −q⁴ drives the solution to infinity in finite time.
    let pot = monomial(1, -1.0, 4);
    let co = trigonometric(0.1, &[1.0], sinc, |_| 1.0);
    let lay = layout(&[1.0]);
    let mut ends = vec![];
    for track in [true, false] {
        for form in [Form::TwoStep, Form::OneStep] {
            let rec = Record {
                save_every: Some(5),
                track,
            };
            let out = run(&pot, &lay, &co, &[2.0], &[1.0], 100_000, form, rec);
            assert_eq!(out.status, Status::BlowUp);
            assert!(out.steps_done < 1000);
            assert!(out
                .samples
                .q
                .iter()
                .chain(&out.samples.p)
                .all(|x| x.is_finite()));
            // The last finite state is the last sample, even off the save_every grid.
            assert_eq!(*out.samples.steps.last().unwrap(), out.steps_done);
            assert!(out.message.contains("blew up"), "{}", out.message);
            ends.push((form, out.steps_done, out.samples.clone()));
        }
    }
    // Tracking does not change where the run ends, or what it keeps.
    assert_eq!(ends[0].1, ends[2].1);
    assert_eq!(ends[0].2, ends[2].2);
    assert_eq!(ends[1].1, ends[3].1);
}

#[test]
fn a_potential_not_finite_at_the_start_is_reported_as_such() {
    // U = 1/x at x = 0.
    let spec = ProgramSpec {
        n_inputs: 1,
        ops: vec![Op::Input(0), Op::Powi(0, -1)],
        output: 1,
    };
    let pot = Program::new(&spec, None).unwrap();
    let co = trigonometric(0.1, &[1.0], sinc, |_| 1.0);
    let out = run(
        &pot,
        &layout(&[1.0]),
        &co,
        &[0.0],
        &[1.0],
        10,
        Form::TwoStep,
        record(1),
    );
    assert_eq!(out.status, Status::BlowUp);
    assert_eq!(out.steps_done, 0);
    assert!(
        out.message.contains("not finite at the initial state"),
        "{}",
        out.message
    );
}

#[test]
fn interruption_keeps_the_state_reached() {
    let (co, lay, q0, p0) = fpu_method_b(1, 10.0, 0.01);
    let pot = Fpu::new(1).unwrap();
    let mut calls = 0;
    let mut report = |_| {
        calls += 1;
        calls < 3
    };
    let control = Control {
        every: 1000,
        report: &mut report,
    };
    let out = integrate(
        &pot,
        &lay,
        &co,
        &q0,
        &p0,
        10_000,
        Form::TwoStep,
        record(300),
        control,
    )
    .unwrap();
    assert_eq!(out.status, Status::Interrupted);
    assert_eq!(out.steps_done, 3000);
    // 0, 300, …, 3000: the interruption step is on the grid here, kept once.
    assert_eq!(out.samples.steps.len(), 11);
    assert_eq!(*out.samples.steps.last().unwrap(), 3000);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let (co, lay, q0, p0) = fpu_method_b(1, 10.0, 0.01);
    let attempt = |pot: &Fpu, co: &MethodCoefficients, q: &[f64], n: u64| {
        let mut go = |_| true;
        let control = Control {
            every: 1,
            report: &mut go,
        };
        integrate(pot, &lay, co, q, &p0, n, Form::TwoStep, record(1), control)
    };
    let one = Fpu::new(1).unwrap();
    assert!(attempt(&one, &co, &[1.0], 10).is_err());
    assert!(attempt(&one, &co, &[f64::NAN, 0.0], 10).is_err());
    assert!(attempt(&one, &co, &q0, 0).is_err());
    assert!(attempt(&Fpu::new(2).unwrap(), &co, &q0, 10).is_err());
    let mut singular = co.clone();
    singular.chi[1] = 0.0;
    let err = attempt(&one, &singular, &q0, 10).unwrap_err();
    assert!(err.to_string().contains("chi vanishes"), "{err}");
}
