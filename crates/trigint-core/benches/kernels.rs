//! Criterion benchmarks of the kernels: FPU (m = 3, method B, hω = 2π/3), one trajectory with
//! and without streamed energies, and a batch of 256 trajectories. Run with `cargo bench`.
use std::sync::atomic::AtomicBool;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use trigint_core::*;

fn setup(m: usize) -> (MethodCoefficients, EnergyLayout, Vec<f64>, Vec<f64>) {
    trigint_core::fixtures::fpu_method_b(m, 50.0, 2.0 * std::f64::consts::PI / 3.0 / 50.0)
}

fn single(c: &mut Criterion) {
    let (co, layout, q0, p0) = setup(3);
    let pot = Fpu::new(3).unwrap();
    let n = 100_000u64;
    let mut g = c.benchmark_group("fpu_single_trajectory");
    g.throughput(Throughput::Elements(n));
    for track in [true, false] {
        let spec = RunSpec {
            n_steps: n,
            save_every: n,
            form: Form::TwoStep,
            track_energies: track,
            progress_every: 1 << 20,
        };
        g.bench_function(
            if track {
                "streamed energies"
            } else {
                "energies at samples"
            },
            |b| b.iter(|| integrate(&pot, &co, &layout, &q0, &p0, &spec, &mut |_| true).unwrap()),
        );
    }
    g.finish();
}

fn batch(c: &mut Criterion) {
    let (co, layout, q0, p0) = setup(3);
    let pot = Fpu::new(3).unwrap();
    let (count, n) = (256usize, 2_000u64);
    let method = TrajectoryMethod {
        coefficients: co,
        modified_p: layout.modified_p.clone(),
        modified_q: layout.modified_q.clone(),
    };
    let methods = vec![method; count];
    let (q0, p0) = (q0.repeat(count), p0.repeat(count));
    let stop = AtomicBool::new(false);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("fpu_batch_256_one_thread");
    g.throughput(Throughput::Elements(count as u64 * n));
    for track in [true, false] {
        let spec = BatchSpec {
            save_every: None,
            track_energies: track,
            block: 0,
        };
        g.bench_function(
            if track {
                "streamed energies"
            } else {
                "energies at the ends"
            },
            |b| {
                b.iter(|| {
                    pool.install(|| {
                        integrate_batch(
                            &pot,
                            &methods,
                            &layout,
                            &q0,
                            &p0,
                            &vec![n; count],
                            &spec,
                            &stop,
                        )
                        .unwrap()
                    })
                })
            },
        );
    }
    g.finish();
}

criterion_group! {
    name = kernels;
    config = Criterion::default().sample_size(10);
    targets = single, batch
}
criterion_main!(kernels);
