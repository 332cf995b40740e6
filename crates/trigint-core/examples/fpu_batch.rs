//! ns per trajectory-step of the batched kernel on FPU (m = 3, method B, hω = 2π/3).
//! Usage: cargo run --release --example fpu_batch -- [TRAJECTORIES] [STEPS] [THREADS] [track 0|1]
use std::sync::atomic::AtomicBool;
use std::time::Instant;
use trigint_core::*;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let count: usize = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let steps: u64 = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(200_000);
    let threads: usize = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let track = a.get(4).map(|s| s == "1").unwrap_or(true);
    let block: usize = a.get(5).and_then(|s| s.parse().ok()).unwrap_or(0);
    let (m, w) = (3usize, 50.0f64);
    let (coefficients, layout, _, _) =
        trigint_core::fixtures::fpu_method_b(m, w, 2.0 * std::f64::consts::PI / 3.0 / w);
    let method = TrajectoryMethod {
        coefficients,
        modified_p: layout.modified_p.clone(),
        modified_q: layout.modified_q.clone(),
    };
    let mut q0 = vec![0.0; count * 2 * m];
    let mut p0 = vec![0.0; count * 2 * m];
    for t in 0..count {
        q0[t * 2 * m] = 1.0 + 1e-3 * t as f64;
        p0[t * 2 * m] = 1.0;
        q0[t * 2 * m + m] = 1.0 / w;
        p0[t * 2 * m + m] = 1.0;
    }
    let varied = a.get(6).map(|s| s == "1").unwrap_or(false);
    let methods: Vec<TrajectoryMethod> = (0..count)
        .map(|t| {
            let mut m = method.clone();
            if varied {
                // a slightly different step size per trajectory, as in a scan
                m.coefficients.h *= 1.0 + 1e-6 * t as f64;
            }
            m
        })
        .collect();
    let spec = BatchSpec {
        save_every: None,
        track_energies: track,
        block,
    };
    let stop = AtomicBool::new(false);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        let out = pool.install(|| {
            integrate_batch(
                &Fpu::new(m).unwrap(),
                &methods,
                &layout,
                &q0,
                &p0,
                &vec![steps; count],
                &spec,
                &stop,
            )
            .unwrap()
        });
        best = best.min(t.elapsed().as_secs_f64());
        assert!(out.iter().all(|o| o.status == Status::Completed));
    }
    println!(
        "{:.3} ns per trajectory-step ({threads} threads)",
        best / (count as f64 * steps as f64) * 1e9
    );
}
