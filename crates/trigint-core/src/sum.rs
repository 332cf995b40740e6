//! The kernels' one summation order, written once: [`Sum8`].
//!
//! Term k of a range goes to partial sum k mod 8; each partial sum adds its terms in order (its
//! first term starts it); [`tree`] combines the partial sums in a fixed tree. The order vectorizes
//! (eight independent chains) and never depends on how the work is split between lanes, bundles
//! or threads, so every lane of an ensemble has the bits of a single trajectory. The recursion's
//! energy sweep, the energies of a given state, the FPU's U and the compiled potentials' Σ V all
//! sum through it.

use crate::real::Real;

/// The sum of the first `m` ≤ 8 partial sums in a fixed tree: ((p0+p1)+(p2+p3))+((p4+p5)+(p6+p7)),
/// absent parts left out.
#[inline(always)]
pub fn tree<L: Real>(p: &[L; 8], m: usize) -> L {
    // The levels written out (a loop over them is not unrolled, even for a constant m).
    let pair = |a: usize| if m > a + 1 { p[a] + p[a + 1] } else { p[a] };
    if m == 0 {
        return L::zero();
    }
    let s01 = pair(0);
    if m <= 2 {
        return s01;
    }
    let s0123 = s01 + pair(2);
    if m <= 4 {
        return s0123;
    }
    let s45 = pair(4);
    if m <= 6 {
        return s0123 + s45;
    }
    s0123 + (s45 + pair(6))
}

/// Eight partial sums in the kernels' order. A plain array of numbers: in a kernel's locals it
/// lives in registers. Every method is `#[inline(always)]` so that chunks of eight written out by
/// the caller keep constant indices (which the compiler vectorizes).
#[derive(Clone, Copy)]
pub struct Sum8<L> {
    parts: [L; 8],
}

impl<L: Real> Default for Sum8<L> {
    #[inline(always)]
    fn default() -> Self {
        Self::new()
    }
}

impl<L: Real> Sum8<L> {
    #[inline(always)]
    pub fn new() -> Self {
        Sum8 {
            parts: [L::zero(); 8],
        }
    }

    /// Term k of a range, with `lane = k mod 8` and `started = k ≥ 8`.
    #[inline(always)]
    pub fn add(&mut self, lane: usize, started: bool, x: L) {
        self.parts[lane] = if started { self.parts[lane] + x } else { x };
    }

    /// Terms k … k + 7 of a range, k a multiple of 8; `FIRST` when k = 0.
    #[inline(always)]
    pub fn add8<const FIRST: bool>(&mut self, x: &[L; 8]) {
        for t in 0..8 {
            self.add(t, !FIRST, x[t]);
        }
    }

    /// Terms k … k + v.len() − 1 of a range, k a multiple of 8 (`started` when k ≥ 8).
    #[inline(always)]
    pub fn add_slice(&mut self, v: &[L], started: bool) {
        let mut chunks = v.chunks_exact(8);
        let mut started = started;
        for c in &mut chunks {
            let c: &[L; 8] = c.try_into().expect("a chunk of eight");
            if started {
                self.add8::<false>(c);
            } else {
                self.add8::<true>(c);
            }
            started = true;
        }
        for (t, &x) in chunks.remainder().iter().enumerate() {
            self.add(t, started, x);
        }
    }

    /// Terms k … k + v.len() − 1 of a range for any k = `first`: the same partial sums, term
    /// by term in order, as [`add`](Self::add) one at a time, with the whole chunks of eight in
    /// between written out (which the compiler vectorizes).
    #[inline(always)]
    pub fn add_from(&mut self, first: usize, v: &[L]) {
        let head = ((8 - first % 8) % 8).min(v.len());
        for (t, &x) in v[..head].iter().enumerate() {
            let k = first + t;
            self.add(k % 8, k >= 8, x);
        }
        let aligned = first + head;
        self.add_slice(&v[head..], aligned >= 8);
    }

    /// The sum of a range of `count` terms.
    #[inline(always)]
    pub fn total(&self, count: usize) -> L {
        tree(&self.parts, count.min(8))
    }
}

/// `pairwise!(L, start, end, |i| (a, b))`: runs the body for i in start..end (in order) and
/// returns the sums of its two terms, each through a [`Sum8`]. Written as a macro so that the
/// body is inlined into the unrolled chunks of eight (which the compiler vectorizes).
macro_rules! pairwise {
    ($l:ty, $start:expr, $end:expr, |$i:ident| $body:expr) => {{
        let (start, end): (usize, usize) = ($start, $end);
        let count = end - start;
        let mut a = $crate::sum::Sum8::<$l>::new();
        let mut b = $crate::sum::Sum8::<$l>::new();
        // Chunks of eight written out (a loop this large is not unrolled by the compiler, and
        // the partial sums would then live in memory); `base + 8 <= end` lets the compiler see
        // that every index is below `end`, so no bounds test is left. The first chunk starts
        // the sums.
        macro_rules! term {
            ($base:expr, $t:literal, $first:literal) => {{
                let $i = $base + $t;
                let (x, y) = $body;
                a.add($t, !$first, x);
                b.add($t, !$first, y);
            }};
        }
        macro_rules! chunk {
            ($base:expr, $first:literal) => {{
                term!($base, 0, $first);
                term!($base, 1, $first);
                term!($base, 2, $first);
                term!($base, 3, $first);
                term!($base, 4, $first);
                term!($base, 5, $first);
                term!($base, 6, $first);
                term!($base, 7, $first);
            }};
        }
        let mut base = start;
        if base + 8 <= end {
            chunk!(base, true);
            base += 8;
            while base + 8 <= end {
                chunk!(base, false);
                base += 8;
            }
        }
        let started = count >= 8;
        for t in 0..end - base {
            let $i = base + t;
            let (x, y) = $body;
            a.add(t, started, x);
            b.add(t, started, y);
        }
        (a.total(count), b.total(count))
    }};
}
pub(crate) use pairwise;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tree_is_the_documented_order() {
        let p: [f64; 8] = std::array::from_fn(|k| 1.0 + 0.1 * k as f64 + 1e-17 * k as f64);
        let level = |v: &[f64]| -> Vec<f64> {
            v.chunks(2)
                .map(|c| if c.len() == 2 { c[0] + c[1] } else { c[0] })
                .collect()
        };
        for m in 1..=8 {
            let mut v = p[..m].to_vec();
            while v.len() > 1 {
                v = level(&v);
            }
            assert_eq!(tree(&p, m).to_bits(), v[0].to_bits(), "m = {m}");
        }
    }

    /// Every way of feeding [`Sum8`] (term by term, chunks, slices split anywhere at multiples of
    /// eight, the macro) gives the bits of the documented order.
    #[test]
    fn every_entry_gives_the_documented_order() {
        for n in [0usize, 1, 5, 8, 13, 21, 64, 67] {
            let terms: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin() * 1e3).collect();
            let mut parts = [0.0; 8];
            for (k, &t) in terms.iter().enumerate() {
                parts[k % 8] = if k < 8 { t } else { parts[k % 8] + t };
            }
            let expected = tree(&parts, n.min(8));
            let mut one = Sum8::<f64>::new();
            for (k, &t) in terms.iter().enumerate() {
                one.add(k % 8, k >= 8, t);
            }
            assert_eq!(one.total(n).to_bits(), expected.to_bits(), "n = {n}");
            let mut sliced = Sum8::<f64>::new();
            let cut = (n / 16) * 8;
            sliced.add_slice(&terms[..cut], false);
            sliced.add_slice(&terms[cut..], cut > 0);
            assert_eq!(sliced.total(n).to_bits(), expected.to_bits(), "n = {n}");
            let (s, _) = pairwise!(f64, 0, n, |i| (terms[i], 0.0));
            assert_eq!(s.to_bits(), expected.to_bits(), "n = {n}");
            // Slices starting anywhere (the passes of the sweep of many blocks).
            for cuts in [vec![3, 11], vec![1, 2, 17, 30], vec![7, 8, 9]] {
                let mut pieces = Sum8::<f64>::new();
                let mut from = 0;
                for c in cuts.into_iter().map(|c| c.min(n)).chain([n]) {
                    pieces.add_from(from, &terms[from..c.max(from)]);
                    from = c.max(from);
                }
                assert_eq!(pieces.total(n).to_bits(), expected.to_bits(), "n = {n}");
            }
        }
    }
}
