//! The transforms of a one-axis grid, each in one pass around the complex FFT of n/2 points.
//!
//! A real FFT of even length n is a complex FFT of n/2 points with a pass that combines bins
//! j and n/2 − j with a twiddle factor (before the FFT for complex-to-real, after it for
//! real-to-complex). Done by `realfft`, that pass reads and writes the half spectrum, which the
//! packing of the coordinates (u = S q) or their unpacking (Sᵀ w) reads and writes again: at
//! 2¹⁶ points each is a pass over 512 KiB, more than a core's second-level cache holds with the
//! state beside it. Here the packing is folded into the twiddle pass, so the coordinates are
//! read (or written) once and the half spectrum never exists.
//!
//! The arithmetic is `realfft`'s (3.5), term for term and with its twiddle factors and its
//! inner FFT plan, so the grid values and coordinates are the same bits as the unfused
//! transforms (a test compares them).

use std::sync::Arc;

use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

/// The twiddle factor e^{−2πi·index/n}, computed as `realfft` computes it.
fn twiddle(index: usize, n: usize) -> Complex64 {
    let angle = -2f64 * std::f64::consts::PI / n as f64 * index as f64;
    Complex64::new(angle.cos(), angle.sin())
}

/// The fused transforms of a grid of n points (n even); coordinates ordered
/// q₀, a₁, b₁, …, a_{n/2−1}, b_{n/2−1}, q_{n/2} (see [`super::Spectral`]).
pub(super) struct Line {
    n: usize,
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
    /// Half the forward twiddles, e^{−2πij/n}/2, j = 1, …: `realfft`'s real-to-complex ones.
    forward_twiddles: Twiddles,
    /// The inverse twiddles e^{2πij/n}: `realfft`'s complex-to-real ones.
    inverse_twiddles: Twiddles,
}

impl Line {
    /// `planner` must be the one `realfft` plans its inner FFTs with for the same bits (a new
    /// `FftPlanner`: its choice depends only on the length and the CPU).
    pub(super) fn new(n: usize, planner: &mut FftPlanner<f64>) -> Line {
        debug_assert!(n >= 2 && n.is_multiple_of(2));
        let count = if n.is_multiple_of(4) {
            n / 4
        } else {
            n / 4 + 1
        };
        Line {
            n,
            forward: planner.plan_fft_forward(n / 2),
            inverse: planner.plan_fft_inverse(n / 2),
            forward_twiddles: Twiddles::new((1..count).map(|i| twiddle(i, n) * 0.5)),
            inverse_twiddles: Twiddles::new((1..count).map(|i| twiddle(i, n).conj())),
        }
    }

    /// Scratch the two FFTs need.
    pub(super) fn scratch_len(&self) -> usize {
        self.forward
            .get_outofplace_scratch_len()
            .max(self.inverse.get_outofplace_scratch_len())
    }

    /// Bins of the half spectrum, n/2 + 1.
    fn bins(&self) -> usize {
        self.n / 2 + 1
    }

    /// u = S q: the packing of q into bins, the complex-to-real pre-pass and the inverse FFT
    /// of n/2 points into u (read as n/2 complex numbers). `buffer` holds at least n/2 + 1.
    pub(super) fn to_grid(
        &self,
        q: &[f64],
        u: &mut [f64],
        buffer: &mut [Complex64],
        scratch: &mut [Complex64],
    ) {
        let (n, m) = (self.n, self.bins());
        debug_assert!(q.len() == n && u.len() == n && buffer.len() >= m);
        let r = std::f64::consts::FRAC_1_SQRT_2;
        // Bin 0 < j < n/2 of the half spectrum: û_j = (a_j − i b_j)/√2; bins 0 and n/2 are real.
        let bin = |j: usize| Complex64::new(q[2 * j - 1] * r, -q[2 * j] * r);
        let (first, last) = (Complex64::new(q[0], 0.0), Complex64::new(q[n - 1], 0.0));
        let (sum, diff) = (first + last, first - last);
        buffer[0] = Complex64::new(sum.re - sum.im, diff.re - diff.im);
        // The pairs (j, m − 1 − j), 0 < j < m/2: in chunks of eight through local arrays, which
        // the compiler vectorizes, in the widest copy for this CPU (the same bits in each).
        crate::isa::wide(
            #[inline(always)]
            || {
                let (pairs, mut j) = (m / 2 - 1, 1);
                while j + CHUNK <= pairs + 1 {
                    c2r_pairs::<CHUNK>(q, j, m, &self.inverse_twiddles, buffer);
                    j += CHUNK;
                }
                while j <= pairs {
                    c2r_pairs::<1>(q, j, m, &self.inverse_twiddles, buffer);
                    j += 1;
                }
            },
        );
        if m % 2 == 1 {
            let centre = bin(m / 2);
            buffer[m / 2] = (centre + centre).conj();
        }
        self.inverse
            .process_outofplace_with_scratch(&mut buffer[..n / 2], as_complex(u), scratch);
    }

    /// out = scale · Sᵀ w: the forward FFT of n/2 points of w (read as n/2 complex numbers;
    /// used as scratch), the real-to-complex post-pass and the unpacking into coordinates.
    pub(super) fn transpose(
        &self,
        w: &mut [f64],
        out: &mut [f64],
        scale: f64,
        buffer: &mut [Complex64],
        scratch: &mut [Complex64],
    ) {
        let (n, m) = (self.n, self.bins());
        debug_assert!(w.len() == n && out.len() == n && buffer.len() >= m);
        let fft_out = &mut buffer[..n / 2];
        self.forward
            .process_outofplace_with_scratch(as_complex(w), fft_out, scratch);
        let s2 = std::f64::consts::SQRT_2 * scale;
        // Bins 0 and n/2 are real; bin 0 < j < n/2 goes to its two coordinates (see
        // `Spectral::transpose`).
        let first = buffer[0];
        out[0] = (first.re + first.im) * scale;
        out[n - 1] = (first.re - first.im) * scale;
        crate::isa::wide(
            #[inline(always)]
            || {
                let (pairs, mut j) = (m / 2 - 1, 1);
                while j + CHUNK <= pairs + 1 {
                    r2c_pairs::<CHUNK>(buffer, j, m, &self.forward_twiddles, s2, out);
                    j += CHUNK;
                }
                while j <= pairs {
                    r2c_pairs::<1>(buffer, j, m, &self.forward_twiddles, s2, out);
                    j += 1;
                }
            },
        );
        if m % 2 == 1 {
            let (c, j) = (buffer[m / 2].conj(), m / 2);
            out[2 * j - 1] = c.re * s2;
            out[2 * j] = -c.im * s2;
        }
    }
}

/// Pairs of bins per chunk of the twiddle passes.
const CHUNK: usize = 8;

/// The complex-to-real pre-pass of the pairs of bins (j + t, m − 1 − j − t), t < K, read from
/// the coordinates q: `realfft`'s formulas. The chunk is taken apart into rows of real and
/// imaginary parts first (the second bins of the pairs reversed), so that every operation runs
/// on a row (see [`r2c_pairs`]).
#[inline(always)]
fn c2r_pairs<const K: usize>(
    q: &[f64],
    j: usize,
    m: usize,
    twiddles: &Twiddles,
    buffer: &mut [Complex64],
) {
    let r = std::f64::consts::FRAC_1_SQRT_2;
    let (lo, hi) = (
        &q[2 * j - 1..2 * (j + K) - 1],
        &q[2 * (m - j - K) - 1..2 * (m - j) - 1],
    );
    let (w_re, w_im) = twiddles.chunk::<K>(j - 1);
    // Bin j + t: coordinates 2(j + t) − 1 and 2(j + t); bin m − 1 − j − t: the chunk `hi`
    // read backwards.
    let x_re: [f64; K] = std::array::from_fn(|t| lo[2 * t] * r);
    let x_im: [f64; K] = std::array::from_fn(|t| -lo[2 * t + 1] * r);
    let y_re: [f64; K] = std::array::from_fn(|t| hi[2 * (K - 1 - t)] * r);
    let y_im: [f64; K] = std::array::from_fn(|t| -hi[2 * (K - 1 - t) + 1] * r);
    let (mut left, mut right) = ([[0.0; 2]; K], [[0.0; 2]; K]);
    for t in 0..K {
        let (sum_re, sum_im) = (x_re[t] + y_re[t], x_im[t] + y_im[t]);
        let (diff_re, diff_im) = (x_re[t] - y_re[t], x_im[t] - y_im[t]);
        let (real, imag) = twiddled(sum_im, diff_re, w_re[t], w_im[t]);
        left[t] = [sum_re - real, diff_im - imag];
        right[K - 1 - t] = [sum_re + real, -imag - diff_im];
    }
    for (b, v) in buffer[j..j + K].iter_mut().zip(&left) {
        *b = Complex64::new(v[0], v[1]);
    }
    for (b, v) in buffer[m - j - K..m - j].iter_mut().zip(&right) {
        *b = Complex64::new(v[0], v[1]);
    }
}

/// realfft's twiddled terms of a pair of bins, with sum = x + x_rev, diff = x − x_rev and the
/// twiddle w: (Im(sum·w.re) + Re(diff·w.im), Im(sum·w.im) − Re(diff·w.re)), in its order (of
/// sum and diff only Im(sum) and Re(diff) enter).
#[inline(always)]
fn twiddled(sum_im: f64, diff_re: f64, w_re: f64, w_im: f64) -> (f64, f64) {
    (
        sum_im * w_re + diff_re * w_im,
        sum_im * w_im - diff_re * w_re,
    )
}

/// The real-to-complex post-pass of the pairs of bins (j + t, m − 1 − j − t), t < K, of the
/// FFT's output in `buffer`, written to their coordinates in `out` times s2 = √2·scale, in rows
/// of real and imaginary parts. (With complex numbers and −x·s2 in the imaginary parts, the
/// lanes of a vector had different operations and LLVM left the pass scalar: 8 % of a
/// 2¹⁶-point wave step's samples, against 5 % now, AMD Zen 5.)
#[inline(always)]
fn r2c_pairs<const K: usize>(
    buffer: &[Complex64],
    j: usize,
    m: usize,
    twiddles: &Twiddles,
    s2: f64,
    out: &mut [f64],
) {
    let (lo, hi) = (
        as_reals(&buffer[j..j + K]),
        as_reals(&buffer[m - j - K..m - j]),
    );
    let (w_re, w_im) = twiddles.chunk::<K>(j - 1);
    let x_re: [f64; K] = std::array::from_fn(|t| lo[2 * t]);
    let x_im: [f64; K] = std::array::from_fn(|t| lo[2 * t + 1]);
    let y_re: [f64; K] = std::array::from_fn(|t| hi[2 * (K - 1 - t)]);
    let y_im: [f64; K] = std::array::from_fn(|t| hi[2 * (K - 1 - t) + 1]);
    // Rows of the two bins' results, both in the order of t (the second reversed on storing).
    let (mut lo_re, mut lo_im, mut hi_re, mut hi_im) = ([0.0; K], [0.0; K], [0.0; K], [0.0; K]);
    for t in 0..K {
        let (sum_re, sum_im) = (x_re[t] + y_re[t], x_im[t] + y_im[t]);
        let (diff_re, diff_im) = (x_re[t] - y_re[t], x_im[t] - y_im[t]);
        let half_sum_re = 0.5 * sum_re;
        let half_diff_im = 0.5 * diff_im;
        let (real, imag) = twiddled(sum_im, diff_re, w_re[t], w_im[t]);
        // Bin j + t: (half_sum_re + real, half_diff_im + imag); bin m − 1 − j − t:
        // (half_sum_re − real, imag − half_diff_im); each bin c to (c.re·s2, −c.im·s2).
        // (−x·s2 as x·(−s2): the same bits, and one operation in every lane.)
        lo_re[t] = (half_sum_re + real) * s2;
        lo_im[t] = (half_diff_im + imag) * -s2;
        hi_re[t] = (half_sum_re - real) * s2;
        hi_im[t] = (imag - half_diff_im) * -s2;
    }
    let lo = &mut out[2 * j - 1..2 * (j + K) - 1];
    for t in 0..K {
        (lo[2 * t], lo[2 * t + 1]) = (lo_re[t], lo_im[t]);
    }
    let hi = &mut out[2 * (m - j - K) - 1..2 * (m - j) - 1];
    for t in 0..K {
        (hi[2 * (K - 1 - t)], hi[2 * (K - 1 - t) + 1]) = (hi_re[t], hi_im[t]);
    }
}

/// Twiddle factors as two rows, real and imaginary parts.
struct Twiddles {
    re: Vec<f64>,
    im: Vec<f64>,
}

impl Twiddles {
    fn new(factors: impl Iterator<Item = Complex64>) -> Twiddles {
        let (re, im) = factors.map(|w| (w.re, w.im)).unzip();
        Twiddles { re, im }
    }

    /// Factors at..at + K.
    #[inline(always)]
    fn chunk<const K: usize>(&self, at: usize) -> (&[f64; K], &[f64; K]) {
        (
            self.re[at..at + K].try_into().expect("K factors"),
            self.im[at..at + K].try_into().expect("K factors"),
        )
    }
}

/// Complex numbers as their parts (re, im interleaved).
fn as_reals(x: &[Complex64]) -> &[f64] {
    // SAFETY: `Complex64` is `#[repr(C)]` {re: f64, im: f64} (see `as_complex`); the result
    // borrows `x`.
    unsafe { std::slice::from_raw_parts(x.as_ptr() as *const f64, 2 * x.len()) }
}

/// n real numbers as n/2 complex ones (re, im interleaved), as `realfft` reads them.
fn as_complex(x: &mut [f64]) -> &mut [Complex64] {
    debug_assert!(x.len().is_multiple_of(2));
    // SAFETY: `Complex64` is `#[repr(C)]` {re: f64, im: f64}: the size and alignment of two
    // consecutive f64, so the n/2 pairs of an n-long f64 slice are valid `Complex64`s; the
    // borrow of `x` is moved into the result.
    unsafe { std::slice::from_raw_parts_mut(x.as_mut_ptr() as *mut Complex64, x.len() / 2) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use realfft::RealFftPlanner;

    fn values(n: usize, seed: f64) -> Vec<f64> {
        (0..n)
            .map(|k| (seed * (k as f64 + 1.0)).sin() * (1.0 + 0.3 * (k as f64 * 0.7).cos()))
            .collect()
    }

    /// The unfused transforms: the packing into the half spectrum, then `realfft`.
    fn unfused_to_grid(q: &[f64]) -> Vec<f64> {
        let (n, r) = (q.len(), std::f64::consts::FRAC_1_SQRT_2);
        let mut half: Vec<Complex64> = (0..n / 2 + 1)
            .map(|j| match j {
                0 => Complex64::new(q[0], 0.0),
                j if j == n / 2 => Complex64::new(q[n - 1], 0.0),
                j => Complex64::new(q[2 * j - 1] * r, -q[2 * j] * r),
            })
            .collect();
        let mut u = vec![0.0; n];
        let c2r = RealFftPlanner::<f64>::new().plan_fft_inverse(n);
        c2r.process(&mut half, &mut u).unwrap();
        u
    }

    fn unfused_transpose(w: &[f64], scale: f64) -> Vec<f64> {
        let n = w.len();
        let s2 = std::f64::consts::SQRT_2 * scale;
        let mut half = vec![Complex64::default(); n / 2 + 1];
        let r2c = RealFftPlanner::<f64>::new().plan_fft_forward(n);
        r2c.process(&mut w.to_vec(), &mut half).unwrap();
        let mut out = vec![0.0; n];
        out[0] = half[0].re * scale;
        out[n - 1] = half[n / 2].re * scale;
        for j in 1..n / 2 {
            out[2 * j - 1] = half[j].re * s2;
            out[2 * j] = -half[j].im * s2;
        }
        out
    }

    #[test]
    fn the_fused_transforms_give_realffts_bits() {
        for n in [2, 4, 6, 8, 10, 12, 30, 64, 96, 1024, 4098, 1 << 14] {
            let line = Line::new(n, &mut FftPlanner::new());
            let mut buffer = vec![Complex64::default(); n / 2 + 1];
            let mut scratch = vec![Complex64::default(); line.scratch_len()];
            let q = values(n, 0.37);
            let mut u = vec![0.0; n];
            line.to_grid(&q, &mut u, &mut buffer, &mut scratch);
            let expected = unfused_to_grid(&q);
            assert!(
                u.iter()
                    .zip(&expected)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "u = S q, n = {n}"
            );
            let w = values(n, 1.91);
            let mut out = vec![0.0; n];
            line.transpose(&mut w.clone(), &mut out, 0.25, &mut buffer, &mut scratch);
            let expected = unfused_transpose(&w, 0.25);
            assert!(
                out.iter()
                    .zip(&expected)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "Sᵀ w, n = {n}"
            );
        }
    }
}
