//! ns per step of the kernels on FPU (m = 3, method B, hω = 2π/3, ω = 50), for profiling.
//! Usage: cargo run --release --example fpu_steps -- [single|batch|batch-h] [track 0|1] [N] [B] [m]
use std::sync::atomic::AtomicBool;
use std::time::Instant;
use trigint_core::*;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("single");
    let track = args.get(2).map(|s| s == "1").unwrap_or(true);
    let n: u64 = args
        .get(3)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000_000);
    let count: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let m: usize = args.get(5).and_then(|s| s.parse().ok()).unwrap_or(3);
    let h = 2.0 * std::f64::consts::PI / 3.0 / 50.0;
    let (co, layout, q0, p0) = fixtures::fpu_method_b(m, 50.0, h);
    let pot = Fpu::new(m).unwrap();
    let record = Record {
        save_every: Some(n),
        track,
    };
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        if mode == "single" {
            let mut go = |_| true;
            let c = Control {
                every: 1 << 20,
                report: &mut go,
            };
            let out = integrate(&pot, &layout, &co, &q0, &p0, n, Form::TwoStep, record, c).unwrap();
            assert_eq!(out.steps_done, n);
            std::hint::black_box(out);
        } else {
            let methods: Vec<MethodCoefficients> = (0..count)
                .map(|b| {
                    let hb = if mode == "batch-h" {
                        h * (1.0 + 1e-4 * b as f64)
                    } else {
                        h
                    };
                    fixtures::fpu_method_b(m, 50.0, hb).0
                })
                .collect();
            let qs: Vec<f64> = (0..count)
                .flat_map(|b| q0.iter().map(move |x| x * (1.0 + 1e-3 * b as f64)))
                .collect();
            let ps: Vec<f64> = (0..count).flat_map(|_| p0.iter().copied()).collect();
            let steps = vec![n; count];
            let stop = AtomicBool::new(false);
            let out = integrate_batch::<BatchLanes, _>(
                &pot,
                &layout,
                &methods,
                &qs,
                &ps,
                &steps,
                Form::TwoStep,
                Record {
                    save_every: None,
                    track,
                },
                &stop,
                4096,
            )
            .unwrap();
            std::hint::black_box(out);
        }
        best = best.min(t.elapsed().as_secs_f64());
    }
    let per = if mode == "single" {
        n as f64
    } else {
        (n * count as u64) as f64
    };
    println!(
        "{mode} track={track}: {:.3} ns per (trajectory-)step",
        best / per * 1e9
    );
}
