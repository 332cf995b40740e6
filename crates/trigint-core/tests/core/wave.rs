//! The wave equation's observing sweep: the momentum and the per-mode extremes taken along in
//! the pass over the state give the bits of the separate loops.

use trigint_core::energy::{PairForms, FIRST_BLOCK, MODIFIED};
use trigint_core::fixtures::{layout, sinc, trigonometric};
use trigint_core::run::Control;
use trigint_core::*;

fn run(
    wave: &Wave,
    lay: &Layout,
    co: &MethodCoefficients,
    q0: &[f64],
    p0: &[f64],
) -> TrajectoryOutput {
    run_for(wave, lay, co, (q0, p0), 200, 50)
}

/// `n_steps` two-step steps with the energies streamed and a sample every `save_every`.
fn run_for(
    wave: &Wave,
    lay: &Layout,
    co: &MethodCoefficients,
    (q0, p0): (&[f64], &[f64]),
    n_steps: u64,
    save_every: u64,
) -> TrajectoryOutput {
    let mut go = |_| true;
    let control = Control {
        every: 1 << 20,
        report: &mut go,
    };
    let record = Record {
        save_every: Some(save_every),
        track: true,
    };
    integrate(
        wave,
        lay,
        co,
        q0,
        p0,
        n_steps,
        Form::TwoStep,
        record,
        control,
    )
    .unwrap()
}

/// The layout of frequencies `omega` (one block per run of equal ones) with the pair forms of
/// pairs (a, a + 1) for the given a's, (0, n − 1) for a = 0, and `axes` rows of weights.
fn with_pairs(omega: &[f64], a: Vec<usize>, weights: Vec<f64>, axes: usize) -> Layout {
    let n = omega.len();
    let b = a
        .iter()
        .map(|&a| if a == 0 { n - 1 } else { a + 1 })
        .collect();
    let mut lay = layout(omega);
    lay.pair_forms = Some(PairForms::new(a, b, weights, axes, n).unwrap());
    lay
}

#[test]
fn the_momentum_taken_along_has_the_bits_of_its_own_loop() {
    // u_tt = u_xx − u − u³ on 16 points: modes j = 0, ±1, …, ±7, 8 as coordinates
    // (û_0, a_1, b_1, …, a_7, b_7, û_8), one block per mode.
    let n = 16;
    let wave = Wave::new(&[n], &Chain::monomial(0.25, 4), (0..n).collect()).unwrap();
    let j = wave.grid().wavevectors().to_vec();
    let omega: Vec<f64> = j.iter().map(|&j| (1.0 + (j * j) as f64).sqrt()).collect();
    let co = trigonometric(0.05, &omega, sinc, |_| 1.0);
    let pairs: Vec<usize> = (1..n - 1).step_by(2).collect();
    let weights: Vec<f64> = pairs.iter().map(|&a| j[a] as f64).collect();
    let seen = |a, w| with_pairs(&omega, a, w, 1);
    // Consecutive pairs (a, a + 1) ride along the sweep; one more pair (0, 15) of weight 0
    // makes them not consecutive, so that they are evaluated in their own loop, with the same
    // sum (a zero term added).
    let riding = seen(pairs.clone(), weights.clone());
    let (mut a2, mut w2) = (pairs, weights);
    a2.push(0);
    w2.push(0.0);
    let separate = seen(a2, w2);
    let q0: Vec<f64> = (0..n).map(|i| 0.1 * ((i as f64) * 0.7).sin()).collect();
    let p0: Vec<f64> = (0..n).map(|i| 0.05 * ((i as f64) * 1.3).cos()).collect();
    let (x, y) = (
        run(&wave, &riding, &co, &q0, &p0),
        run(&wave, &separate, &co, &q0, &p0),
    );
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(x.steps_done, 200);
    assert_eq!(bits(&x.initial_energies), bits(&y.initial_energies));
    assert_eq!(bits(&x.max_deviation), bits(&y.max_deviation));
    assert_eq!(bits(&x.samples.q), bits(&y.samples.q));
    assert_eq!(bits(&x.samples.energies), bits(&y.samples.energies));
    // The momentum moved (collocation with aliasing does not keep it on so coarse a grid):
    // the test compares numbers, not zeros; every mode's deviation is there.
    use trigint_core::energy::{OSCILLATORY, SLOW, TOTAL};
    let k = x.max_deviation.len() - 1;
    assert_eq!(k + 1, channel_count(9, 1));
    assert!(x.initial_energies[k] != 0.0 && x.max_deviation[k] > 1e-6);
    let moved = [TOTAL, OSCILLATORY, SLOW]
        .into_iter()
        .chain(FIRST_BLOCK..=k);
    assert!(moved
        .map(|c| x.max_deviation[c])
        .all(|d| d.is_finite() && d > 0.0));
}

#[test]
fn the_momentum_of_a_grid_of_several_axes_rides_along_with_the_bits_of_its_own_loop() {
    // On a grid of 2 or 3 axes the modes' pairs (a, a + 1) come in runs, broken by the
    // self-conjugate modes' single coordinates: they ride along the sweep run by run, and give
    // the bits of the separate loop that an extra pair (0, n − 1) of weight 0 forces. Grids
    // within one pass of the sweep (256 coordinates), and grids of many passes: passes that
    // end inside a run, runs longer than a chunk of the terms (64 pairs), and one run in 1-D.
    for shape in [
        vec![6, 4],
        vec![8, 6],
        vec![4, 6, 4],
        vec![24, 20],
        vec![4, 200],
        vec![6, 8, 10],
        vec![300],
    ] {
        let wave = Wave::new(
            &shape,
            &Chain::monomial(0.25, 4),
            (0..shape.iter().product()).collect(),
        )
        .unwrap();
        let (grid, d) = (wave.grid(), shape.len());
        let n = grid.points();
        let j = grid.wavevectors();
        let omega: Vec<f64> = (0..n)
            .map(|i| {
                (1.0 + j[d * i..d * (i + 1)]
                    .iter()
                    .map(|&x| (x * x) as f64)
                    .sum::<f64>())
                .sqrt()
            })
            .collect();
        let co = trigonometric(0.05, &omega, sinc, |_| 1.0);
        let pairs: Vec<usize> = (0..n)
            .filter(|&i| grid.slots()[i].part == trigint_core::spectral::Part::Cos)
            .collect();
        let weights: Vec<f64> = (0..d)
            .flat_map(|m| pairs.iter().map(move |&a| j[d * a + m] as f64))
            .collect();
        let seen = |a, w| with_pairs(&omega, a, w, d);
        let riding = seen(pairs.clone(), weights.clone());
        let forms = riding.pair_forms.as_ref().unwrap();
        assert!(
            forms
                .riding()
                .is_some_and(|runs| runs.len() > usize::from(d > 1)),
            "{shape:?}"
        );
        assert!(
            forms.rides_along(riding.n_slow, &riding.block_ends),
            "{shape:?}"
        );
        let (mut a2, mut w2) = (pairs.clone(), Vec::new());
        a2.push(0);
        for m in 0..d {
            w2.extend_from_slice(&weights[m * pairs.len()..(m + 1) * pairs.len()]);
            w2.push(0.0);
        }
        let separate = seen(a2, w2);
        assert!(separate.pair_forms.as_ref().unwrap().riding().is_none());
        // Grid values of the same size on every grid (u = S q, SᵀS = N): larger ones blow up.
        let size = (24.0 / n as f64).sqrt();
        let q0: Vec<f64> = (0..n)
            .map(|i| size * 0.1 * ((i as f64) * 0.7).sin())
            .collect();
        let p0: Vec<f64> = (0..n)
            .map(|i| size * 0.05 * ((i as f64) * 1.3).cos())
            .collect();
        let (x, y) = (
            run(&wave, &riding, &co, &q0, &p0),
            run(&wave, &separate, &co, &q0, &p0),
        );
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(x.steps_done, 200);
        assert_eq!(
            bits(&x.initial_energies),
            bits(&y.initial_energies),
            "{shape:?}"
        );
        assert_eq!(bits(&x.max_deviation), bits(&y.max_deviation), "{shape:?}");
        assert_eq!(bits(&x.samples.q), bits(&y.samples.q), "{shape:?}");
        assert_eq!(
            bits(&x.samples.energies),
            bits(&y.samples.energies),
            "{shape:?}"
        );
        // Every axis's momentum is a number that moved, not a zero.
        let k = x.max_deviation.len();
        for c in k - d..k {
            assert!(
                x.initial_energies[c] != 0.0 && x.max_deviation[c] > 1e-9,
                "{shape:?} {c}"
            );
        }
    }
}

#[test]
fn a_prepared_layout_and_method_give_the_bits_of_a_plain_run_at_every_call() {
    // The kernels' rows kept by the prepared method from the first call are the rows the
    // second call would have made: the same bits, call after call; one-step form as well.
    let n = 16;
    let wave = Wave::new(&[n], &Chain::monomial(0.25, 4), (0..n).collect()).unwrap();
    let j = wave.grid().wavevectors().to_vec();
    let omega: Vec<f64> = j.iter().map(|&j| (1.0 + (j * j) as f64).sqrt()).collect();
    let co = trigonometric(0.05, &omega, sinc, |x| sinc(x) * sinc(x));
    let lay = layout(&omega);
    let q0: Vec<f64> = (0..n).map(|i| 0.1 * ((i as f64) * 0.7).sin()).collect();
    let p0: Vec<f64> = (0..n).map(|i| 0.05 * ((i as f64) * 1.3).cos()).collect();
    let (plain_lay, plain_co) = (lay.clone(), co.clone());
    let (lay, co) = (PreparedLayout::new(lay), PreparedMethod::new(co));
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for form in [Form::TwoStep, Form::OneStep, Form::TwoStep] {
        let call = |prepared: bool| {
            let mut go = |_| true;
            let control = Control {
                every: 1 << 20,
                report: &mut go,
            };
            let record = Record {
                save_every: Some(50),
                track: true,
            };
            let (q, p) = (&q0[..], &p0[..]);
            if prepared {
                integrate_prepared(&wave, &lay, &co, q, p, 200, form, record, control, false)
            } else {
                integrate(
                    &wave, &plain_lay, &plain_co, q, p, 200, form, record, control,
                )
            }
            .unwrap()
        };
        let (x, y) = (call(true), call(false));
        assert_eq!(x.steps_done, 200);
        assert_eq!(bits(&x.samples.q), bits(&y.samples.q));
        assert_eq!(bits(&x.samples.p), bits(&y.samples.p));
        assert_eq!(bits(&x.max_deviation), bits(&y.max_deviation));
    }
    // A state of another size is refused as before (the method's rows are checked per size).
    let mut go = |_| true;
    let control = Control {
        every: 1,
        report: &mut go,
    };
    let record = Record {
        save_every: None,
        track: false,
    };
    let short = &q0[..n - 1];
    let e = integrate_prepared(
        &wave,
        &lay,
        &co,
        short,
        short,
        5,
        Form::TwoStep,
        record,
        control,
        false,
    );
    assert!(e
        .unwrap_err()
        .to_string()
        .contains("15 entries for 16 coordinates"));
}

#[test]
fn the_energies_of_given_states_have_the_bits_of_the_observing_sweep() {
    // 32 points: modes 0, ±1, …, ±15, 16, one block each (one coordinate, fifteen of two, one).
    // `state_energies` sums runs of blocks of two in a flat loop and the others block by block;
    // the run's samples were observed by the sweep. A second layout merges blocks into ones of
    // three and four coordinates, which break the runs. (H* is left out: `state_energies` is
    // given no modified weights.)
    let n = 32;
    let wave = Wave::new(&[n], &Chain::monomial(0.25, 4), (0..n).collect()).unwrap();
    let j = wave.grid().wavevectors().to_vec();
    let omega: Vec<f64> = j.iter().map(|&j| (1.0 + (j * j) as f64).sqrt()).collect();
    let co = trigonometric(0.05, &omega, sinc, |_| 1.0);
    let q0: Vec<f64> = (0..n).map(|i| 0.1 * ((i as f64) * 0.7).sin()).collect();
    let p0: Vec<f64> = (0..n).map(|i| 0.05 * ((i as f64) * 1.3).cos()).collect();
    let modes = layout(&omega);
    let mut merged = modes.clone();
    merged.block_ends.retain(|&e| e != 1 && e != 5);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for lay in [modes, merged] {
        let out = run_for(&wave, &lay, &co, (&q0, &p0), 12, 1);
        let (s, channels) = (&out.samples, channel_count(lay.n_blocks(), 0));
        assert_eq!(s.steps.len(), 13);
        let given = run::state_energies(&wave, &lay, None, &s.q, &s.p).unwrap();
        let skip_modified = |rows: &[f64]| {
            rows.chunks(channels)
                .flat_map(|r| [&r[..MODIFIED], &r[MODIFIED + 1..]].concat())
                .collect::<Vec<_>>()
        };
        assert_eq!(
            bits(&skip_modified(&given)),
            bits(&skip_modified(&s.energies))
        );
        // every block's energy is there, and moves
        let first_block = &s.energies[FIRST_BLOCK..channels];
        assert!(first_block.iter().all(|&e| e > 0.0));
    }
}
