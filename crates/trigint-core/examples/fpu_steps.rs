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
    let m = 3usize;
    let (co, layout, q0, p0) =
        trigint_core::fixtures::fpu_method_b(m, 50.0, 2.0 * std::f64::consts::PI / 3.0 / 50.0);
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
