//! Oracles for the kernels: exact harmonic solutions, form equivalence, energy bounds,
//! sampling, blow-up and storage-independent bits.

use trigint_core::*;

fn sinc(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.sin() / x
    }
}

/// Deuflhard's method B (ψ = sinc, φ = 1) at frequencies `omega`.
fn method_b(h: f64, omega: &[f64]) -> MethodCoefficients {
    let xi: Vec<f64> = omega.iter().map(|w| h * w).collect();
    MethodCoefficients {
        h,
        one_minus_cos: xi.iter().map(|x| 2.0 * (0.5 * x).sin().powi(2)).collect(),
        sin: xi.iter().map(|x| x.sin()).collect(),
        chi: xi.iter().map(|&x| sinc(x)).collect(),
        psi: xi.iter().map(|&x| sinc(x)).collect(),
        phi: vec![1.0; omega.len()],
    }
}

fn layout(omega: &[f64]) -> EnergyLayout {
    let mut distinct: Vec<f64> = Vec::new();
    let block = omega
        .iter()
        .map(|&w| {
            if w == 0.0 {
                return 0;
            }
            match distinct.iter().position(|&d| d == w) {
                Some(j) => j + 1,
                None => {
                    distinct.push(w);
                    distinct.len()
                }
            }
        })
        .collect();
    EnergyLayout {
        omega2: omega.iter().map(|w| w * w).collect(),
        modified_p: omega
            .iter()
            .map(|&w| if w == 0.0 { 0.0 } else { 1.0 })
            .collect(),
        modified_q: omega.iter().map(|w| w * w).collect(),
        block,
        n_blocks: distinct.len(),
    }
}

fn spec(n_steps: u64, save_every: u64, form: Form) -> RunSpec {
    RunSpec {
        n_steps,
        save_every,
        form,
        track_energies: true,
        progress_every: 1 << 20,
    }
}

fn fpu_omega(m: usize, w: f64) -> Vec<f64> {
    let mut o = vec![0.0; m];
    o.extend(std::iter::repeat(w).take(m));
    o
}

fn fpu_initial(m: usize, w: f64) -> (Vec<f64>, Vec<f64>) {
    let (mut q, mut p) = (vec![0.0; 2 * m], vec![0.0; 2 * m]);
    q[0] = 1.0;
    p[0] = 1.0;
    q[m] = 1.0 / w;
    p[m] = 1.0;
    (q, p)
}

#[test]
fn harmonic_oscillator_is_exact() {
    // U = 0: q(t) = q0 cos ωt + p0 sin(ωt)/ω, for every step size with sin(hω) ≠ 0.
    let zero = Polynomial::new(3, vec![], &[]).unwrap();
    let omega = [0.0, 7.0, 31.0];
    let (q0, p0) = ([0.3, -0.2, 0.05], [0.1, 1.0, -2.0]);
    for form in [Form::TwoStep, Form::OneStep] {
        let h = 3.0 / 31.0;
        let n = 10_000;
        let out = integrate(
            &zero,
            &method_b(h, &omega),
            &layout(&omega),
            &q0,
            &p0,
            &spec(n, n, form),
            &mut |_| true,
        )
        .unwrap();
        let t = n as f64 * h;
        let last = out.samples.steps.len() - 1;
        assert_eq!(out.samples.steps[last], n);
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
            let scale = (q0[i].abs() + p0[i].abs() / w.max(1.0)).max(1e-300);
            assert!(
                (out.samples.q[3 * last + i] - q).abs() < 1e-10 * scale.max(q.abs()),
                "{form:?} q[{i}]"
            );
            assert!(
                (out.samples.p[3 * last + i] - p).abs() < 1e-10 * (p0[i].abs() + w * q0[i].abs()),
                "{form:?} p[{i}]"
            );
        }
    }
}

#[test]
fn fpu_forms_agree_and_energy_is_bounded() {
    let (m, w) = (3, 50.0);
    let omega = fpu_omega(m, w);
    let (q0, p0) = fpu_initial(m, w);
    let pot = Fpu::new(m).unwrap();
    let h = 2.0 * std::f64::consts::PI / 3.0 / w;
    let co = method_b(h, &omega);
    let lay = layout(&omega);
    let a = integrate(
        &pot,
        &co,
        &lay,
        &q0,
        &p0,
        &spec(1000, 10, Form::TwoStep),
        &mut |_| true,
    )
    .unwrap();
    let b = integrate(
        &pot,
        &co,
        &lay,
        &q0,
        &p0,
        &spec(1000, 10, Form::OneStep),
        &mut |_| true,
    )
    .unwrap();
    assert_eq!(a.samples.steps.len(), 101);
    for (x, y) in a.samples.q.iter().zip(&b.samples.q) {
        assert!((x - y).abs() < 1e-10, "{x} vs {y}");
    }
    assert!((a.initial_energies[0] - 2.00120008).abs() < 1e-12);
    assert!((a.initial_energies[1] - 1.0).abs() < 1e-12);
    // Oscillatory energy stays within a small multiple of ε = 0.02 (Fig. 2, top), and the
    // single block carries all of it.
    assert!(a.max_deviation[1] < 0.05, "{:?}", a.max_deviation);
    assert_eq!(a.max_deviation[1], a.max_deviation[4]);
    assert!(a.max_deviation[1] > 1e-6);
}

#[test]
fn fixed_and_vector_storage_give_identical_bits() {
    // m = 3 runs on [f64; 6]; m = 5 on Vec. Compare m = 3 against the Vec kernel directly.
    let (m, w) = (3, 50.0);
    let omega = fpu_omega(m, w);
    let (q0, p0) = fpu_initial(m, w);
    let pot = Fpu::new(m).unwrap();
    let co = method_b(0.02, &omega);
    let k = co.kernel();
    let lay = layout(&omega);
    fn run<K: Stepper>(
        mut kernel: K,
        lay: &EnergyLayout,
        q0: &[f64],
        p0: &[f64],
    ) -> (Vec<f64>, Vec<f64>) {
        let mut rec = Recorder::<K::S>::new(lay, true, 7, 500);
        assert!(kernel.start(q0, p0, &mut rec).unwrap());
        for _ in 0..500 {
            assert!(kernel.step(&mut rec).unwrap());
        }
        (rec.samples.q.clone(), rec.max_deviation())
    }
    use trigint_core::stepper::{OneStep, Stepper, TwoStep};
    let a = run(TwoStep::<_, [f64; 6]>::new(&pot, &k), &lay, &q0, &p0);
    let b = run(TwoStep::<_, Vec<f64>>::new(&pot, &k), &lay, &q0, &p0);
    assert_eq!(a, b);
    let c = run(OneStep::<_, [f64; 6]>::new(&pot, &k), &lay, &q0, &p0);
    let d = run(OneStep::<_, Vec<f64>>::new(&pot, &k), &lay, &q0, &p0);
    assert_eq!(c, d);
}

#[test]
fn blow_up_stops_and_keeps_samples() {
    // A strongly repulsive quartic potential: U = -q^4 drives the solution to infinity.
    let pot = Polynomial::new(1, vec![-1.0], &[4]).unwrap();
    let co = method_b(0.1, &[1.0]);
    let out = integrate(
        &pot,
        &co,
        &layout(&[1.0]),
        &[2.0],
        &[1.0],
        &spec(100_000, 5, Form::TwoStep),
        &mut |_| true,
    )
    .unwrap();
    assert_eq!(out.status, Status::BlowUp);
    assert!(out.steps_done < 1000);
    assert!(out.samples.q.iter().all(|x| x.is_finite()));
    assert_eq!(*out.samples.steps.last().unwrap(), out.steps_done / 5 * 5);
}

#[test]
fn interruption_keeps_samples() {
    let pot = Fpu::new(1).unwrap();
    let co = method_b(0.01, &[0.0, 10.0]);
    let mut spec = spec(10_000, 100, Form::TwoStep);
    spec.progress_every = 1000;
    let mut calls = 0;
    let out = integrate(
        &pot,
        &co,
        &layout(&[0.0, 10.0]),
        &[1.0, 0.1],
        &[0.0, 0.0],
        &spec,
        &mut |_| {
            calls += 1;
            calls < 3
        },
    )
    .unwrap();
    assert_eq!(out.status, Status::Interrupted);
    assert_eq!(out.steps_done, 3000);
    assert_eq!(out.samples.steps.len(), 31);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let pot = Fpu::new(1).unwrap();
    let lay = layout(&[0.0, 10.0]);
    let mut co = method_b(0.01, &[0.0, 10.0]);
    let s = spec(10, 1, Form::TwoStep);
    assert!(integrate(&pot, &co, &lay, &[1.0], &[0.0, 0.0], &s, &mut |_| true).is_err());
    assert!(integrate(
        &pot,
        &co,
        &lay,
        &[f64::NAN, 0.0],
        &[0.0, 0.0],
        &s,
        &mut |_| true
    )
    .is_err());
    assert!(integrate(
        &Fpu::new(2).unwrap(),
        &co,
        &lay,
        &[0.0, 0.0],
        &[0.0, 0.0],
        &s,
        &mut |_| true
    )
    .is_err());
    co.chi[1] = 0.0;
    assert!(integrate(&pot, &co, &lay, &[0.0, 0.0], &[0.0, 0.0], &s, &mut |_| true).is_err());
}
