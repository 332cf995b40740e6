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
    forward_twiddles: Vec<Complex64>,
    /// The inverse twiddles e^{2πij/n}: `realfft`'s complex-to-real ones.
    inverse_twiddles: Vec<Complex64>,
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
            forward_twiddles: (1..count).map(|i| twiddle(i, n) * 0.5).collect(),
            inverse_twiddles: (1..count).map(|i| twiddle(i, n).conj()).collect(),
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
/// the coordinates q: `realfft`'s formulas.
#[inline(always)]
fn c2r_pairs<const K: usize>(
    q: &[f64],
    j: usize,
    m: usize,
    twiddles: &[Complex64],
    buffer: &mut [Complex64],
) {
    let r = std::f64::consts::FRAC_1_SQRT_2;
    let (lo, hi) = (
        &q[2 * j - 1..2 * (j + K) - 1],
        &q[2 * (m - j - K) - 1..2 * (m - j) - 1],
    );
    let tw = &twiddles[j - 1..j - 1 + K];
    let (mut left, mut right) = ([Complex64::default(); K], [Complex64::default(); K]);
    for t in 0..K {
        let x = Complex64::new(lo[2 * t] * r, -lo[2 * t + 1] * r);
        // Bin m − 1 − j − t: coordinates 2(m − 1 − j − t) − 1 and 2(m − 1 − j − t).
        let at = 2 * (K - 1 - t);
        let x_rev = Complex64::new(hi[at] * r, -hi[at + 1] * r);
        let sum = x + x_rev;
        let diff = x - x_rev;
        let (real, imag) = twiddled(sum, diff, tw[t]);
        left[t] = Complex64::new(sum.re - real, diff.im - imag);
        right[K - 1 - t] = Complex64::new(sum.re + real, -imag - diff.im);
    }
    buffer[j..j + K].copy_from_slice(&left);
    buffer[m - j - K..m - j].copy_from_slice(&right);
}

/// realfft's twiddled terms of a pair of bins, with sum = x + x_rev, diff = x − x_rev and the
/// twiddle w: (Im(sum·w.re) + Re(diff·w.im), Im(sum·w.im) − Re(diff·w.re)), in its order.
#[inline(always)]
fn twiddled(sum: Complex64, diff: Complex64, w: Complex64) -> (f64, f64) {
    let twiddled_re_sum = sum * w.re;
    let twiddled_im_sum = sum * w.im;
    let twiddled_re_diff = diff * w.re;
    let twiddled_im_diff = diff * w.im;
    (
        twiddled_re_sum.im + twiddled_im_diff.re,
        twiddled_im_sum.im - twiddled_re_diff.re,
    )
}

/// The real-to-complex post-pass of the pairs of bins (j + t, m − 1 − j − t), t < K, of the
/// FFT's output in `buffer`, written to their coordinates in `out` times s2 = √2·scale.
#[inline(always)]
fn r2c_pairs<const K: usize>(
    buffer: &[Complex64],
    j: usize,
    m: usize,
    twiddles: &[Complex64],
    s2: f64,
    out: &mut [f64],
) {
    let (lo, hi) = (&buffer[j..j + K], &buffer[m - j - K..m - j]);
    let tw = &twiddles[j - 1..j - 1 + K];
    let (mut left, mut right) = ([[0.0; 2]; K], [[0.0; 2]; K]);
    for t in 0..K {
        let (x, x_rev) = (lo[t], hi[K - 1 - t]);
        let sum = x + x_rev;
        let diff = x - x_rev;
        let half_sum_re = 0.5 * sum.re;
        let half_diff_im = 0.5 * diff.im;
        let (real, imag) = twiddled(sum, diff, tw[t]);
        // Bin j + t: (half_sum_re + real, half_diff_im + imag); bin m − 1 − j − t:
        // (half_sum_re − real, imag − half_diff_im); each bin c to (c.re·s2, −c.im·s2).
        left[t] = [(half_sum_re + real) * s2, -(half_diff_im + imag) * s2];
        right[K - 1 - t] = [(half_sum_re - real) * s2, -(imag - half_diff_im) * s2];
    }
    let lo = out[2 * j - 1..2 * (j + K) - 1].chunks_exact_mut(2);
    for (o, v) in lo.zip(&left) {
        o.copy_from_slice(v);
    }
    let hi = out[2 * (m - j - K) - 1..2 * (m - j) - 1].chunks_exact_mut(2);
    for (o, v) in hi.zip(&right) {
        o.copy_from_slice(v);
    }
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
