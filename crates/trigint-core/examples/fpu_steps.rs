//! ns/step of the single-trajectory kernel on FPU (m = 3, method B, hω = 2π/3).
//! Usage: cargo run --release --example fpu_steps -- [N_STEPS] [track: 0|1] [form: 2|1]
use std::time::Instant;
use trigint_core::*;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args
        .get(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000_000);
    let track = args.get(2).map(|s| s == "1").unwrap_or(true);
    let form = if args.get(3).map(|s| s == "1").unwrap_or(false) {
        Form::OneStep
    } else {
        Form::TwoStep
    };
    let (m, w) = (3usize, 50.0f64);
    let h = 2.0 * std::f64::consts::PI / 3.0 / w;
    let omega: Vec<f64> = (0..2 * m).map(|i| if i < m { 0.0 } else { w }).collect();
    let sinc = |x: f64| if x == 0.0 { 1.0 } else { x.sin() / x };
    let co = MethodCoefficients {
        h,
        one_minus_cos: omega
            .iter()
            .map(|x| 2.0 * (0.5 * h * x).sin().powi(2))
            .collect(),
        sin: omega.iter().map(|x| (h * x).sin()).collect(),
        chi: omega.iter().map(|x| sinc(h * x)).collect(),
        psi: omega.iter().map(|x| sinc(h * x)).collect(),
        phi: vec![1.0; 2 * m],
    };
    let layout = EnergyLayout {
        omega2: omega.iter().map(|x| x * x).collect(),
        modified_p: omega
            .iter()
            .map(|&x| if x == 0.0 { 0.0 } else { 1.0 })
            .collect(),
        modified_q: omega.iter().map(|x| x * x).collect(),
        block: omega
            .iter()
            .map(|&x| if x == 0.0 { 0 } else { 1 })
            .collect(),
        n_blocks: 1,
    };
    let mut q0 = vec![0.0; 2 * m];
    let mut p0 = vec![0.0; 2 * m];
    q0[0] = 1.0;
    p0[0] = 1.0;
    q0[m] = 1.0 / w;
    p0[m] = 1.0;
    let spec = RunSpec {
        n_steps: n,
        save_every: n,
        form,
        track_energies: track,
        progress_every: 1 << 20,
    };
    let pot = Fpu::new(m).unwrap();
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        let out = integrate(&pot, &co, &layout, &q0, &p0, &spec, &mut |_| true).unwrap();
        best = best.min(t.elapsed().as_secs_f64());
        assert_eq!(out.steps_done, n);
    }
    println!("{:.3} ns/step", best / n as f64 * 1e9);
}
