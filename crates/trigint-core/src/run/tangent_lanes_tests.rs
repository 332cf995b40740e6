//! The bundled tangent against the one-trajectory tangent: the same bits per lane.
use super::*;
use crate::fixtures::{layout, sinc, trigonometric};
use crate::potential::Fpu;
use crate::real::Lanes;

/// FPU m = 3 (ω = 50) at step sizes around hω = 2, with φ ≡ 1 (method B) or φ = sinc.
fn batch(count: usize, phi_sinc: bool) -> (Layout, Vec<MethodCoefficients>, Vec<f64>, Vec<f64>) {
    let omega = [0.0, 0.0, 0.0, 50.0, 50.0, 50.0];
    let methods = (0..count)
        .map(|t| {
            let h = (1.0 + 0.1 * t as f64) / 50.0;
            if phi_sinc {
                trigonometric(h, &omega, |x| sinc(x) * sinc(x), sinc)
            } else {
                trigonometric(h, &omega, sinc, |_| 1.0)
            }
        })
        .collect();
    let q0: Vec<f64> = (0..count * 6)
        .map(|i| 0.2 * ((i as f64) * 0.7).sin())
        .collect();
    let p0: Vec<f64> = (0..count * 6)
        .map(|i| 0.3 * ((i as f64) * 1.3).cos())
        .collect();
    (layout(&omega), methods, q0, p0)
}

fn alone(
    pot: &Fpu,
    lay: &Layout,
    m: &MethodCoefficients,
    q: &[f64],
    p: &[f64],
    dev: (&[f64], &[f64]),
    steps: u64,
) -> TangentOutput {
    let mut go_on = |_| true;
    let mut control = Control {
        every: 1 << 20,
        report: &mut go_on,
    };
    let request = TangentRequest {
        n_steps: steps,
        renormalize_every: 16,
        sample_every: steps,
    };
    tangent(
        pot,
        lay,
        m,
        q,
        p,
        dev.0,
        dev.1,
        &[1.0; 6],
        &request,
        &mut control,
    )
    .unwrap()
}

#[test]
fn lanes_give_each_trajectory_its_own_numbers() {
    let pot = Fpu::new(3).unwrap();
    // 11 trajectories: one full bundle of 8 and one of 3 (padded), different lengths.
    for (k, phi_sinc) in [(1, false), (1, true), (2, true)] {
        let (lay, methods, q0, p0) = batch(11, phi_sinc);
        let steps: Vec<u64> = (0..11).map(|t| 200 + 37 * t as u64).collect();
        let dq0: Vec<f64> = (0..6 * k).map(|i| ((i as f64) * 0.9).cos()).collect();
        let dp0: Vec<f64> = (0..6 * k).map(|i| ((i as f64) * 0.4).sin()).collect();
        let stop = AtomicBool::new(false);
        let out = tangent_batch::<Lanes<8>, _>(
            &pot,
            &lay,
            &methods,
            &q0,
            &p0,
            &steps,
            (&dq0, &dp0),
            &[1.0; 6],
            16,
            &stop,
            4096,
        )
        .unwrap();
        for t in 0..11 {
            let one = alone(
                &pot,
                &lay,
                &methods[t],
                &q0[6 * t..6 * t + 6],
                &p0[6 * t..6 * t + 6],
                (&dq0, &dp0),
                steps[t],
            );
            assert_eq!(out[t].steps, one.steps, "trajectory {t}");
            assert_eq!(out[t].steps_done, one.steps_done);
            let bits =
                |v: &[Vec<f64>]| -> Vec<u64> { v.iter().flatten().map(|x| x.to_bits()).collect() };
            assert_eq!(
                bits(&out[t].log_growth),
                bits(&one.log_growth),
                "trajectory {t}, K = {k}"
            );
            assert_eq!(out[t].megno[0].to_bits(), one.megno[0].to_bits());
            assert!(one.log_growth[0][0].is_finite() && one.log_growth[0][0] != 0.0);
        }
    }
}

#[test]
fn a_lane_that_blows_up_ends_where_it_would_alone() {
    let pot = Fpu::new(3).unwrap();
    let (lay, methods, mut q0, p0) = batch(8, false);
    // Trajectory 5 starts far out and blows up; its neighbours run on.
    for x in &mut q0[30..36] {
        *x = 6.0;
    }
    let steps = vec![300; 8];
    let (dq0, dp0) = (vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0], vec![0.0; 6]);
    let out = tangent_batch::<Lanes<8>, _>(
        &pot,
        &lay,
        &methods,
        &q0,
        &p0,
        &steps,
        (&dq0, &dp0),
        &[1.0; 6],
        16,
        &AtomicBool::new(false),
        4096,
    )
    .unwrap();
    let one = alone(
        &pot,
        &lay,
        &methods[5],
        &q0[30..36],
        &p0[30..36],
        (&dq0, &dp0),
        300,
    );
    assert_eq!(one.status, crate::output::Status::BlowUp);
    assert_eq!(out[5].status, one.status);
    assert_eq!(out[5].steps_done, one.steps_done);
    assert_eq!(out[5].message, one.message);
    assert_eq!(out[4].status, crate::output::Status::Completed);
    assert_eq!(out[4].steps_done, 300);
}
