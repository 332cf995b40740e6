//! The complex FFTs along the first d − 1 axes of the half spectrum of a grid of several axes,
//! whose lines are strided: a line along axis 0 of a 512² grid has a point every 4 KiB, one per
//! page. They are gathered into contiguous lines a group at a time, transformed, and put back.

use rustfft::num_complex::Complex64;
use rustfft::Fft;

use super::{Spectral, SpectralWorkspace};

/// Lines of the half spectrum per group of [`Spectral::along_axis`]: 64 bytes of each row,
/// about a cache line (the rows are not aligned to one).
pub(super) const LINES: usize = 4;

/// [`LINES`] lines of the half spectrum (element i of line c at `half[i * stride + c]`) into
/// `group`, line after line.
#[inline(always)]
fn gather_lines(half: &[Complex64], stride: usize, group: &mut [Complex64]) {
    let n = group.len() / LINES;
    let [a, b, c, d] = lines_of(group, n);
    let rows = half.chunks(stride);
    for ((((a, b), c), d), row) in a.iter_mut().zip(b).zip(c).zip(d).zip(rows) {
        let row: &[Complex64; LINES] = row[..LINES].try_into().expect("a row holds the group");
        (*a, *b, *c, *d) = (row[0], row[1], row[2], row[3]);
    }
}

/// The inverse of [`gather_lines`].
#[inline(always)]
fn scatter_lines(group: &mut [Complex64], stride: usize, half: &mut [Complex64]) {
    let n = group.len() / LINES;
    let [a, b, c, d] = lines_of(group, n);
    let rows = half.chunks_mut(stride);
    for ((((a, b), c), d), row) in a.iter().zip(b.iter()).zip(c.iter()).zip(d.iter()).zip(rows) {
        row[..LINES].copy_from_slice(&[*a, *b, *c, *d]);
    }
}

/// The group's [`LINES`] lines of n numbers.
#[inline(always)]
fn lines_of(group: &mut [Complex64], n: usize) -> [&mut [Complex64]; LINES] {
    let (a, rest) = group.split_at_mut(n);
    let (b, rest) = rest.split_at_mut(n);
    let (c, d) = rest.split_at_mut(n);
    [a, b, c, d]
}

impl Spectral {
    /// The complex FFT of every line of the half spectrum along `axis` (< d − 1), in place:
    /// [`LINES`] neighbouring lines at a time, so that the cache lines (and pages) of the half
    /// spectrum are read and written about once per group, not once per line.
    pub(super) fn along_axis(&self, axis: usize, fft: &dyn Fft<f64>, ws: &mut SpectralWorkspace) {
        let n = self.half[axis];
        let stride: usize = self.half[axis + 1..].iter().product();
        let outer: usize = self.half[..axis].iter().product();
        for o in 0..outer {
            let mut s = 0;
            while s < stride {
                let lines = if stride - s >= LINES { LINES } else { 1 };
                let base = o * n * stride + s;
                let group = &mut ws.line[..lines * n];
                let half = &mut ws.half[base..base + (n - 1) * stride + lines];
                if lines == LINES {
                    gather_lines(half, stride, group);
                } else {
                    for (c, x) in group.iter_mut().zip(half.iter().step_by(stride)) {
                        *c = *x;
                    }
                }
                // (an FFT of each of the group's lines, each the same bits as alone)
                fft.process_with_scratch(group, &mut ws.scratch);
                if lines == LINES {
                    scatter_lines(group, stride, half);
                } else {
                    for (c, x) in group.iter().zip(half.iter_mut().step_by(stride)) {
                        *x = *c;
                    }
                }
                s += lines;
            }
        }
    }
}
