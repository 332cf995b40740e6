//! Times the wave equation's two transforms and one force evaluation on a 1-D grid:
//! `cargo run --release -p trigint-core --example wave_transforms -- 65536`.

use std::time::Instant;

use trigint_core::spectral::Spectral;
use trigint_core::{Chain, Potential, Wave};

fn main() {
    let n0: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1 << 16);
    raw(n0);
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1 << 16);
    let grid = Spectral::new(&[n]).expect("grid");
    let mut ws = grid.workspace();
    let q: Vec<f64> = (0..n).map(|i| 1e-3 * ((i as f64) * 0.37).sin()).collect();
    let mut u = vec![0.0; n];
    let mut out = vec![0.0; n];
    let reps = 200;
    let t = Instant::now();
    for _ in 0..reps {
        grid.to_grid(&q, &mut u, &mut ws);
    }
    let to_grid = t.elapsed().as_secs_f64() / reps as f64;
    let t = Instant::now();
    for _ in 0..reps {
        grid.transpose(&mut u, &mut out, 1.0, &mut ws);
    }
    let transpose = t.elapsed().as_secs_f64() / reps as f64;
    let wave = Wave::new(&[n], &Chain::monomial(0.25, 4), (0..n).collect()).expect("wave");
    let mut wws = wave.workspace::<f64>();
    let t = Instant::now();
    for _ in 0..reps {
        wave.force(&q, &mut out, true, &mut wws).expect("force");
    }
    let force = t.elapsed().as_secs_f64() / reps as f64;
    println!(
        "n = {n}: to_grid {:.1} us, transpose {:.1} us, force {:.1} us",
        to_grid * 1e6,
        transpose * 1e6,
        force * 1e6
    );
}

/// r2c and c2r of realfft alone, for comparison with the transforms around them.
fn raw(n: usize) {
    use realfft::RealFftPlanner;
    let mut p = RealFftPlanner::<f64>::new();
    let (f, i) = (p.plan_fft_forward(n), p.plan_fft_inverse(n));
    let mut x = vec![0.5; n];
    let mut s = f.make_output_vec();
    let mut scr = f.make_scratch_vec();
    let mut scr2 = i.make_scratch_vec();
    let reps = 200;
    let t = Instant::now();
    for _ in 0..reps {
        f.process_with_scratch(&mut x, &mut s, &mut scr).unwrap();
        s[0].im = 0.0;
        s[n / 2].im = 0.0;
        i.process_with_scratch(&mut s, &mut x, &mut scr2).unwrap();
    }
    println!(
        "raw r2c + c2r: {:.1} us",
        t.elapsed().as_secs_f64() / reps as f64 * 1e6
    );
}
