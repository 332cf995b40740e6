//! The batched kernel gives each trajectory the bits of the single-trajectory kernel, whatever
//! the lane width, the thread count or the batch composition; blow-ups and stops per lane.

use std::sync::atomic::AtomicBool;

use trigint_core::fixtures::{fpu_method_b, layout, sinc, trigonometric};
use trigint_core::run::Control;
use trigint_core::*;

struct Case<P> {
    pot: P,
    lay: Layout,
    methods: Vec<MethodCoefficients>,
    q0: Vec<f64>,
    p0: Vec<f64>,
    n_steps: Vec<u64>,
}

impl<P: Potential> Case<P> {
    fn n(&self) -> usize {
        self.lay.dim()
    }

    fn single(&self, t: usize, form: Form, rec: Record) -> TrajectoryOutput {
        let n = self.n();
        let mut go = |_| true;
        let control = Control {
            every: 1 << 20,
            report: &mut go,
        };
        integrate(
            &self.pot,
            &self.lay,
            &self.methods[t],
            &self.q0[t * n..(t + 1) * n],
            &self.p0[t * n..(t + 1) * n],
            self.n_steps[t],
            form,
            rec,
            control,
        )
        .unwrap()
    }

    fn batch<L: Real>(
        &self,
        ids: &[usize],
        form: Form,
        rec: Record,
        threads: usize,
    ) -> Vec<TrajectoryOutput> {
        let n = self.n();
        let pick = |v: &[f64]| -> Vec<f64> {
            ids.iter()
                .flat_map(|&t| v[t * n..(t + 1) * n].to_vec())
                .collect()
        };
        let methods: Vec<MethodCoefficients> =
            ids.iter().map(|&t| self.methods[t].clone()).collect();
        let steps: Vec<u64> = ids.iter().map(|&t| self.n_steps[t]).collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let stop = AtomicBool::new(false);
        pool.install(|| {
            integrate_batch::<L, _>(
                &self.pot,
                &self.lay,
                &methods,
                &pick(&self.q0),
                &pick(&self.p0),
                &steps,
                form,
                rec,
                &stop,
                4096,
            )
        })
        .unwrap()
    }
}

/// FPU with m springs, with perturbed initial values and a step size (so a step count) per
/// trajectory: m = 3 on a compile-time shape, m = 5 alone on the uniform shape (in bundles on
/// the general one).
fn fpu_case(m: usize, count: usize) -> Case<Fpu> {
    let base = 2.0 * std::f64::consts::PI / 3.0 / 50.0;
    let (_, lay, q0, p0) = fpu_method_b(m, 50.0, base);
    let hs: Vec<f64> = (0..count)
        .map(|t| base * (0.97 + 0.06 * t as f64 / count as f64))
        .collect();
    Case {
        pot: Fpu::new(m).unwrap(),
        methods: hs.iter().map(|&h| fpu_method_b(m, 50.0, h).0).collect(),
        q0: (0..count)
            .flat_map(|t| q0.iter().map(move |x| x * (1.0 + 1e-3 * t as f64)))
            .collect(),
        p0: (0..count).flat_map(|_| p0.clone()).collect(),
        n_steps: hs.iter().map(|h| (20.0 / h).round() as u64).collect(),
        lay,
    }
}

/// Three blocks and a potential with transcendental functions; method D (φ ≠ 1, σ ≠ 1).
fn program_case(count: usize) -> Case<Program> {
    let omega = [0.0, 0.0, 20.0, 20.0, 33.0];
    // U = cos(x0 − x2) + exp(0.1 x1) x3² + x4⁴/4 + x0 x4
    let ops = vec![
        Op::Input(0),
        Op::Input(1),
        Op::Input(2),
        Op::Input(3),
        Op::Input(4),
        Op::Sub(0, 2),
        Op::Cos(5),
        Op::Const(0.1),
        Op::Mul(7, 1),
        Op::Exp(8),
        Op::Powi(3, 2),
        Op::Mul(9, 10),
        Op::Powi(4, 4),
        Op::Const(0.25),
        Op::Mul(13, 12),
        Op::Mul(0, 4),
        Op::Add(6, 11),
        Op::Add(16, 14),
        Op::Add(17, 15),
    ];
    let pot = Program::new(
        &ProgramSpec {
            n_inputs: 5,
            ops,
            output: 18,
        },
        None,
    )
    .unwrap();
    let psi = |x: f64| sinc(0.5 * x).powi(2);
    let phi = |x: f64| sinc(x) * (1.0 + (0.5 * x).sin().powi(2) / 3.0);
    let hs: Vec<f64> = (0..count).map(|t| 0.05 + 0.002 * t as f64).collect();
    Case {
        pot,
        lay: layout(&omega),
        methods: hs
            .iter()
            .map(|&h| trigonometric(h, &omega, psi, phi))
            .collect(),
        q0: (0..count)
            .flat_map(|t| [0.3, -0.1, 0.02 * t as f64, 0.01, -0.02])
            .collect(),
        p0: (0..count)
            .flat_map(|t| [0.1, 0.2, 0.3, -0.5, 0.1 * t as f64])
            .collect(),
        n_steps: hs.iter().map(|h| (10.0 / h).round() as u64).collect(),
    }
}

/// Equal bit for bit (NaN included).
fn same(a: &TrajectoryOutput, b: &TrajectoryOutput) -> bool {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    a.status == b.status
        && a.steps_done == b.steps_done
        && a.message == b.message
        && a.samples.steps == b.samples.steps
        && [
            (&a.initial_energies, &b.initial_energies),
            (&a.max_deviation, &b.max_deviation),
            (&a.samples.q, &b.samples.q),
            (&a.samples.p, &b.samples.p),
            (&a.samples.energies, &b.samples.energies),
        ]
        .iter()
        .all(|(x, y)| bits(x) == bits(y))
}

fn check_against_single<P: Potential>(case: &Case<P>, form: Form, rec: Record) {
    let count = case.n_steps.len();
    let all: Vec<usize> = (0..count).collect();
    let singles: Vec<TrajectoryOutput> = (0..count).map(|t| case.single(t, form, rec)).collect();
    for threads in [1, 2] {
        let b8 = case.batch::<Lanes<8>>(&all, form, rec, threads);
        let b3 = case.batch::<Lanes<3>>(&all, form, rec, threads);
        for t in 0..count {
            assert!(
                same(&b8[t], &singles[t]),
                "trajectory {t}, {threads} threads, 8 lanes"
            );
            assert!(
                same(&b3[t], &singles[t]),
                "trajectory {t}, {threads} threads, 3 lanes"
            );
        }
    }
    // Another composition: a subset in another order.
    let sub = [count - 1, 2, 0];
    for (k, out) in case
        .batch::<Lanes<8>>(&sub, form, rec, 2)
        .into_iter()
        .enumerate()
    {
        assert!(same(&out, &singles[sub[k]]));
    }
}

/// [`check_against_single`] in both forms, with the energies streamed and not, sampled.
fn check_both_forms_against_single<P: Potential>(case: &Case<P>) {
    for track in [true, false] {
        let rec = Record {
            save_every: Some(40),
            track,
        };
        check_against_single(case, Form::TwoStep, rec);
        check_against_single(case, Form::OneStep, rec);
    }
}

#[test]
fn fpu_trajectories_equal_single_runs_bit_for_bit() {
    let case = fpu_case(3, 13);
    check_both_forms_against_single(&case);
    // Without samples, the streamed diagnostics only.
    check_against_single(
        &case,
        Form::TwoStep,
        Record {
            save_every: None,
            track: true,
        },
    );
}

#[test]
fn a_uniform_block_alone_and_in_bundles_gives_the_same_bits() {
    check_both_forms_against_single(&fpu_case(5, 9));
}

#[test]
fn program_trajectories_equal_single_runs_bit_for_bit() {
    let case = program_case(10);
    let rec = Record {
        save_every: Some(25),
        track: true,
    };
    check_against_single(&case, Form::TwoStep, rec);
    check_against_single(&case, Form::OneStep, rec);
    let out = case.single(0, Form::TwoStep, rec);
    use trigint_core::energy::{FIRST_BLOCK, MODIFIED, OSCILLATORY};
    assert_eq!(out.initial_energies.len(), FIRST_BLOCK + 2); // the main channels and two blocks
                                                             // σ ≠ 1: H* differs from H_ω
    assert_ne!(out.max_deviation[OSCILLATORY], out.max_deviation[MODIFIED]);
}

#[test]
fn a_lane_that_blows_up_ends_alone_with_its_single_run_numbers() {
    // U = −x⁴/4 + x²: trajectories with large initial values escape, small ones oscillate.
    let ops = vec![
        Op::Input(0),
        Op::Powi(0, 4),
        Op::Const(-0.25),
        Op::Mul(2, 1),
        Op::Powi(0, 2),
        Op::Add(3, 4),
    ];
    let pot = Program::new(
        &ProgramSpec {
            n_inputs: 1,
            ops,
            output: 5,
        },
        None,
    )
    .unwrap();
    let count = 9;
    let case = Case {
        pot,
        lay: layout(&[3.0]),
        methods: (0..count)
            .map(|_| trigonometric(0.05, &[3.0], sinc, |_| 1.0))
            .collect(),
        q0: (0..count).map(|t| 0.5 + 0.6 * t as f64).collect(),
        p0: vec![0.0; count],
        n_steps: vec![2000; count],
    };
    for track in [true, false] {
        let rec = Record {
            save_every: Some(100),
            track,
        };
        check_against_single(&case, Form::TwoStep, rec);
        let out = case.batch::<Lanes<8>>(&(0..count).collect::<Vec<_>>(), Form::TwoStep, rec, 1);
        assert_eq!(out[0].status, Status::Completed);
        assert_eq!(out[count - 1].status, Status::BlowUp);
        let last = &out[count - 1];
        assert_eq!(*last.samples.steps.last().unwrap(), last.steps_done);
    }
}

#[test]
fn a_stop_request_interrupts_every_unfinished_trajectory() {
    let case = fpu_case(3, 5);
    let n = case.n();
    let stop = AtomicBool::new(true);
    let out = integrate_batch::<Lanes<8>, _>(
        &case.pot,
        &case.lay,
        &case.methods,
        &case.q0,
        &case.p0,
        &[100_000; 5],
        Form::TwoStep,
        Record {
            save_every: Some(1000),
            track: true,
        },
        &stop,
        4096,
    )
    .unwrap();
    for o in &out {
        assert_eq!(o.status, Status::Interrupted);
        assert_eq!(o.steps_done, 4096);
        assert_eq!(o.samples.q.len() / n, o.samples.steps.len());
    }
}

/// FPU, m = 3, in bundles whose steps run lane by lane (a compile-time shape): lanes of two
/// methods, ψ = φ = sinc (φ applied, H* ≠ H_ω summed) and method B, at amplitudes from small to
/// large, the large ones beyond what Störmer–Verlet on the soft springs survives at this step
/// size. Every compile-time variant of the lane loop, and its blow-up test, against single runs.
#[test]
fn fpu_lanes_of_two_filters_and_blow_ups_equal_single_runs() {
    let h = 2.0 * std::f64::consts::PI / 3.0 / 50.0;
    let (_, lay, q0, p0) = fpu_method_b(3, 50.0, h);
    let omega = [0.0, 0.0, 0.0, 50.0, 50.0, 50.0];
    let count = 11;
    let case = Case {
        pot: Fpu::new(3).unwrap(),
        lay,
        methods: (0..count)
            .map(|t| {
                if t % 2 == 0 {
                    trigonometric(h, &omega, sinc, sinc)
                } else {
                    fpu_method_b(3, 50.0, h).0
                }
            })
            .collect(),
        q0: (0..count)
            .flat_map(|t| q0.iter().map(move |x| x * (1.0 + 2.5 * t as f64)))
            .collect(),
        p0: (0..count).flat_map(|_| p0.clone()).collect(),
        n_steps: vec![3000; count],
    };
    for track in [true, false] {
        let rec = Record {
            save_every: Some(500),
            track,
        };
        check_against_single(&case, Form::TwoStep, rec);
        let out = case.batch::<Lanes<8>>(&(0..count).collect::<Vec<_>>(), Form::TwoStep, rec, 1);
        let status: Vec<Status> = out.iter().map(|o| o.status).collect();
        assert_eq!(status[0], Status::Completed, "{status:?}");
        assert_eq!(status[count - 1], Status::BlowUp, "{status:?}");
    }
}
