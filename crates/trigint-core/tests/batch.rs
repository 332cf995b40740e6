//! The batched kernel gives each trajectory the bits of the single-trajectory kernel,
//! whatever the block size, the thread count or the batch composition.

use std::sync::atomic::AtomicBool;

use trigint_core::*;

fn sinc(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.sin() / x
    }
}

/// Method A (Gautschi: ψ = sinc²(ξ/2), φ = 1; σ ≠ 1) or D (φ ≠ 1) at frequencies `omega`.
fn method(h: f64, omega: &[f64], filter: char) -> TrajectoryMethod {
    let xi: Vec<f64> = omega.iter().map(|w| h * w).collect();
    let psi: Vec<f64> = xi.iter().map(|&x| sinc(0.5 * x).powi(2)).collect();
    let phi: Vec<f64> = xi
        .iter()
        .map(|&x| {
            if filter == 'D' {
                sinc(x) * (1.0 + (0.5 * x).sin().powi(2) / 3.0)
            } else {
                1.0
            }
        })
        .collect();
    let sigma: Vec<f64> = (0..xi.len())
        .map(|i| sinc(xi[i]) * phi[i] / psi[i])
        .collect();
    TrajectoryMethod {
        coefficients: MethodCoefficients {
            h,
            one_minus_cos: xi.iter().map(|x| 2.0 * (0.5 * x).sin().powi(2)).collect(),
            sin: xi.iter().map(|x| x.sin()).collect(),
            chi: xi.iter().map(|&x| sinc(x)).collect(),
            psi,
            phi,
        },
        modified_p: (0..xi.len())
            .map(|i| if omega[i] == 0.0 { 0.0 } else { sigma[i] })
            .collect(),
        modified_q: (0..xi.len())
            .map(|i| {
                if omega[i] == 0.0 {
                    0.0
                } else {
                    sigma[i] * omega[i] * omega[i]
                }
            })
            .collect(),
    }
}

fn layout(omega: &[f64], blocks: &[usize], n_blocks: usize) -> EnergyLayout {
    EnergyLayout {
        omega2: omega.iter().map(|w| w * w).collect(),
        modified_p: vec![0.0; omega.len()],
        modified_q: vec![0.0; omega.len()],
        block: blocks.to_vec(),
        n_blocks,
    }
}

fn single<P: Potential>(
    pot: &P,
    m: &TrajectoryMethod,
    lay: &EnergyLayout,
    q0: &[f64],
    p0: &[f64],
    n: u64,
    save: u64,
) -> RunOutput {
    let mut lay = lay.clone();
    lay.modified_p = m.modified_p.clone();
    lay.modified_q = m.modified_q.clone();
    let spec = RunSpec {
        n_steps: n,
        save_every: save,
        form: Form::TwoStep,
        track_energies: true,
        progress_every: 1 << 20,
    };
    integrate(pot, &m.coefficients, &lay, q0, p0, &spec, &mut |_| true).unwrap()
}

fn check<P: Potential>(pot: &P, omega: &[f64], blocks: &[usize], n_blocks: usize, filter: char) {
    let n = omega.len();
    let count = 37;
    let lay = layout(omega, blocks, n_blocks);
    let hs: Vec<f64> = (0..count).map(|t| (0.8 + 0.05 * t as f64) / 50.0).collect();
    let methods: Vec<TrajectoryMethod> = hs.iter().map(|&h| method(h, omega, filter)).collect();
    let q0: Vec<f64> = (0..count * n)
        .map(|j| 0.1 * ((j as f64) * 0.7).sin() + if j % n == 0 { 1.0 } else { 0.0 })
        .collect();
    let p0: Vec<f64> = (0..count * n)
        .map(|j| 0.2 * ((j as f64) * 1.3).cos())
        .collect();
    let steps: Vec<u64> = (0..count).map(|t| 300 + 7 * (t as u64 % 5)).collect();
    let stop = AtomicBool::new(false);
    let mut results = Vec::new();
    for (threads, block) in [(1, 0), (2, 5), (3, 64), (1, 1)] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let spec = BatchSpec {
            save_every: Some(50),
            track_energies: true,
            block,
        };
        results.push(pool.install(|| {
            integrate_batch(pot, &methods, &lay, &q0, &p0, &steps, &spec, &stop).unwrap()
        }));
    }
    for t in 0..count {
        let s = single(
            pot,
            &methods[t],
            &lay,
            &q0[t * n..(t + 1) * n],
            &p0[t * n..(t + 1) * n],
            steps[t],
            50,
        );
        for r in &results {
            let b = &r[t];
            assert_eq!(b.status, Status::Completed);
            assert_eq!(b.steps_done, steps[t]);
            assert_eq!(b.samples.steps, s.samples.steps, "trajectory {t}");
            assert_eq!(b.samples.q, s.samples.q, "trajectory {t}");
            assert_eq!(b.samples.p, s.samples.p, "trajectory {t}");
            assert_eq!(b.samples.energies, s.samples.energies, "trajectory {t}");
            assert_eq!(b.initial_energies, s.initial_energies, "trajectory {t}");
            assert_eq!(b.max_deviation, s.max_deviation, "trajectory {t}");
        }
    }
    // A sub-batch (another composition) gives the same bits.
    let pick: Vec<usize> = vec![3, 30, 11];
    let sub_methods: Vec<TrajectoryMethod> = pick.iter().map(|&t| methods[t].clone()).collect();
    let sub_q: Vec<f64> = pick
        .iter()
        .flat_map(|&t| q0[t * n..(t + 1) * n].to_vec())
        .collect();
    let sub_p: Vec<f64> = pick
        .iter()
        .flat_map(|&t| p0[t * n..(t + 1) * n].to_vec())
        .collect();
    let sub_steps: Vec<u64> = pick.iter().map(|&t| steps[t]).collect();
    let spec = BatchSpec {
        save_every: Some(50),
        track_energies: true,
        block: 0,
    };
    let sub = integrate_batch(
        pot,
        &sub_methods,
        &lay,
        &sub_q,
        &sub_p,
        &sub_steps,
        &spec,
        &stop,
    )
    .unwrap();
    for (k, &t) in pick.iter().enumerate() {
        assert_eq!(sub[k].samples.q, results[0][t].samples.q);
        assert_eq!(sub[k].max_deviation, results[0][t].max_deviation);
    }
}

#[test]
fn fpu_batch_matches_single_runs_bit_for_bit() {
    let omega = [0.0, 0.0, 0.0, 50.0, 50.0, 50.0];
    check(&Fpu::new(3).unwrap(), &omega, &[0, 0, 0, 1, 1, 1], 1, 'A');
}

#[test]
fn polynomial_batch_with_filter_phi_and_two_blocks() {
    // U = 0.01 q1 q2 + q0^4 / 4 on frequencies (0, ω, √2 ω), method D (φ ≠ 1).
    let pot = Polynomial::new(3, vec![0.01, 0.25], &[0, 1, 1, 4, 0, 0]).unwrap();
    let omega = [0.0, 50.0, 50.0 * 2f64.sqrt()];
    check(&pot, &omega, &[0, 1, 2], 2, 'D');
}

#[test]
fn stop_flag_interrupts() {
    let omega = [0.0, 50.0];
    let lay = layout(&omega, &[0, 1], 1);
    let methods = vec![method(0.01, &omega, 'A'); 3];
    let stop = AtomicBool::new(true);
    let spec = BatchSpec {
        save_every: None,
        track_energies: true,
        block: 0,
    };
    let out = integrate_batch(
        &Fpu::new(1).unwrap(),
        &methods,
        &lay,
        &[1.0, 0.0].repeat(3),
        &[0.0, 1.0].repeat(3),
        &[100_000; 3],
        &spec,
        &stop,
    )
    .unwrap();
    assert!(out
        .iter()
        .all(|o| o.status == Status::Interrupted && o.steps_done == 4096));
}

#[test]
fn batch_blow_up_is_per_trajectory() {
    let pot = Polynomial::new(1, vec![-1.0], &[4]).unwrap();
    let omega = [1.0];
    let lay = layout(&omega, &[1], 1);
    let methods = vec![method(0.1, &omega, 'A'); 2];
    let spec = BatchSpec {
        save_every: Some(10),
        track_energies: true,
        block: 0,
    };
    let stop = AtomicBool::new(false);
    let out = integrate_batch(
        &pot,
        &methods,
        &lay,
        &[2.0, 0.01],
        &[1.0, 0.0],
        &[2000, 2000],
        &spec,
        &stop,
    )
    .unwrap();
    assert_eq!(out[0].status, Status::BlowUp);
    assert!(out[0].steps_done < 500);
    assert_eq!(out[1].status, Status::Completed);
    assert!(out[0].samples.q.iter().all(|x| x.is_finite()));
}
