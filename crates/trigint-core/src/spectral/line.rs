//! The transforms of one axis, each in one pass around the complex FFT of n/2 points.
//!
//! A real FFT of even length n is a complex FFT of n/2 points with a pass that combines bins
//! j and n/2 − j with a twiddle factor (before the FFT for complex-to-real, after it for
//! real-to-complex; see [`super::twiddle`]). On a grid of one axis that pass is fused with the
//! packing of the coordinates (u = S q) or their unpacking (Sᵀ w): done by `realfft`, its pass
//! reads and writes the half spectrum, which the packing reads and writes again, at 2¹⁶ points
//! each a pass over 512 KiB, more than a core's second-level cache holds with the state beside
//! it. Here the coordinates are read (or written) once and the half spectrum never exists.
//! On the last axis of a grid of several axes the same passes run on the rows of the half
//! spectrum, in place ([`Line::row_to_grid`], [`Line::row_from_grid`]).
//!
//! The arithmetic is `realfft`'s (3.5), term for term and with its twiddle factors and its
//! inner FFT plan, so the grid values and coordinates are the same bits as `realfft`'s
//! transforms (a test compares them).

use std::sync::Arc;

use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use super::twiddle::{
    c2r_from_coordinates, c2r_in_place, over_pairs, r2c_in_place, r2c_to_coordinates, Twiddles,
    CHUNK,
};

/// The transforms of an axis of n points (n even); on a grid of one axis, coordinates ordered
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
        Line {
            n,
            forward: planner.plan_fft_forward(n / 2),
            inverse: planner.plan_fft_inverse(n / 2),
            forward_twiddles: Twiddles::new(n, true),
            inverse_twiddles: Twiddles::new(n, false),
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
        let tw = &self.inverse_twiddles;
        over_pairs!(m, c2r_from_coordinates((q, m, tw), buffer));
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
        let (buffer, tw) = (&*buffer, &self.forward_twiddles);
        over_pairs!(m, r2c_to_coordinates((buffer, m, tw, s2), out));
        if m % 2 == 1 {
            let (c, j) = (buffer[m / 2].conj(), m / 2);
            out[2 * j - 1] = c.re * s2;
            out[2 * j] = -c.im * s2;
        }
    }

    /// A row of the half spectrum (n/2 + 1 bins) to its n real values: `realfft`'s
    /// complex-to-real transform (its pre-pass in place in `row`), with the first and last
    /// imaginary parts set to +0 as the callers set them before calling `realfft` (which keeps
    /// a −0 there).
    pub(super) fn row_to_grid(
        &self,
        row: &mut [Complex64],
        out: &mut [f64],
        scratch: &mut [Complex64],
    ) {
        let (n, m) = (self.n, self.bins());
        debug_assert!(row.len() == m && out.len() == n);
        row[0].im = 0.0;
        row[m - 1].im = 0.0;
        let (first, last) = (row[0], row[m - 1]);
        let (sum, diff) = (first + last, first - last);
        row[0] = Complex64::new(sum.re - sum.im, diff.re - diff.im);
        let tw = &self.inverse_twiddles;
        over_pairs!(m, c2r_in_place((m, tw), row));
        if m % 2 == 1 {
            let centre = row[m / 2];
            row[m / 2] = (centre + centre).conj();
        }
        self.inverse
            .process_outofplace_with_scratch(&mut row[..n / 2], as_complex(out), scratch);
    }

    /// n real values w (used as scratch) to their row of the half spectrum: `realfft`'s
    /// real-to-complex transform.
    pub(super) fn row_from_grid(
        &self,
        w: &mut [f64],
        row: &mut [Complex64],
        scratch: &mut [Complex64],
    ) {
        let (n, m) = (self.n, self.bins());
        debug_assert!(w.len() == n && row.len() == m);
        self.forward
            .process_outofplace_with_scratch(as_complex(w), &mut row[..n / 2], scratch);
        let first = row[0];
        row[0] = Complex64::new(first.re + first.im, 0.0);
        row[m - 1] = Complex64::new(first.re - first.im, 0.0);
        let tw = &self.forward_twiddles;
        over_pairs!(m, r2c_in_place((m, tw), row));
        if m % 2 == 1 {
            row[m / 2].im = -row[m / 2].im;
        }
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
    fn the_row_transforms_give_realffts_bits() {
        for n in [2, 4, 6, 8, 10, 12, 30, 64, 96, 1024, 4098, 1 << 14] {
            let line = Line::new(n, &mut FftPlanner::new());
            let mut scratch = vec![Complex64::default(); line.scratch_len()];
            let mut planner = RealFftPlanner::<f64>::new();
            // A row of the half spectrum with real end points (as the planes' symmetry makes
            // them), to grid values.
            let v = values(2 * (n / 2 + 1), 0.53);
            let mut row: Vec<Complex64> = v
                .chunks_exact(2)
                .map(|c| Complex64::new(c[0], c[1]))
                .collect();
            let last = row.len() - 1;
            (row[0].im, row[last].im) = (0.0, 0.0);
            let (mut ours, mut theirs) = (vec![0.0; n], vec![0.0; n]);
            line.row_to_grid(&mut row.clone(), &mut ours, &mut scratch);
            let c2r = planner.plan_fft_inverse(n);
            c2r.process(&mut row, &mut theirs).unwrap();
            let same =
                |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same(&ours, &theirs), "row to grid, n = {n}");
            // Grid values to their row.
            let w = values(n, 1.17);
            let mut ours = vec![Complex64::default(); n / 2 + 1];
            let mut theirs = ours.clone();
            line.row_from_grid(&mut w.clone(), &mut ours, &mut scratch);
            planner
                .plan_fft_forward(n)
                .process(&mut w.clone(), &mut theirs)
                .unwrap();
            let parts = |r: &[Complex64]| r.iter().flat_map(|c| [c.re, c.im]).collect::<Vec<_>>();
            assert!(same(&parts(&ours), &parts(&theirs)), "grid to row, n = {n}");
        }
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
