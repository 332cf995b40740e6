//! The energies: their forms per coordinate (written once, summed by every kernel), the channel
//! table, the running extremes that give max |E(t_n) − E(0)|, and the saved samples.
//!
//! The channels themselves (names, order) are the table in [`crate::channels`].

use crate::real::Real;

pub use crate::channels::{sum, FIRST_BLOCK, MODIFIED, OSCILLATORY, SLOW, TOTAL};
use crate::channels::{Value, CHANNELS};

pub use crate::sum::tree;

/// `x[i]` without a bounds test, for the kernels' inner loops: a test per element splits an
/// unrolled chunk into blocks that the compiler does not vectorize, and a test of a loop-invariant
/// index is not hoisted out of a loop. Callers make sure, once before the loop, that i is in
/// range for every read (the shapes guarantee coef(i) ≤ i < n, and the slices are cut to n).
#[inline(always)]
pub(crate) fn at<L: Copy>(x: &[L], i: usize) -> L {
    debug_assert!(i < x.len());
    // SAFETY: i < x.len(), asserted by the caller for the whole range (see above).
    unsafe { *x.get_unchecked(i) }
}

/// p² of a slow coordinate (½ is applied to the sum).
#[inline(always)]
pub fn kinetic<L: Real>(p: L) -> L {
    p * p
}

/// p² + ω²q² of an oscillatory coordinate: twice its share of I_j.
#[inline(always)]
pub fn oscillator<L: Real>(p: L, q: L, omega2: L) -> L {
    p * p + omega2 * (q * q)
}

/// a p² + b q²: twice a coordinate's share of the modified energy (3.4).
#[inline(always)]
pub fn modified<L: Real>(p: L, q: L, a: L, b: L) -> L {
    a * (p * p) + b * (q * q)
}

mod pairs;
pub use pairs::{PairForms, RunOfPairs, MAX_RIDING_AXES};

/// Sums of the per-coordinate forms over one state, as a sweep accumulates them, indexed by
/// [`crate::channels::sum`].
#[derive(Clone, Copy)]
pub struct Sums<L>(pub [L; sum::COUNT]);

impl<L: Real> Sums<L> {
    #[inline(always)]
    pub fn zero() -> Self {
        Sums([L::zero(); sum::COUNT])
    }

    /// The whole-state channels from the sums and U, each as its table entry's [`Value`] says
    /// ([`crate::channels::CHANNELS`]). With `plain_modified` (H* = H_ω) the sweep left the
    /// modified sum out and the oscillator sum stands in for it.
    #[inline(always)]
    pub fn channels(mut self, u: L, plain_modified: bool) -> [L; FIRST_BLOCK] {
        if plain_modified {
            self.0[sum::MODIFIED] = self.0[sum::OSCILLATOR];
        }
        let half = L::splat(0.5);
        // The table is a constant: each channel's loop unrolls to its own expression. A plain
        // loop, not `array::from_fn`: its closure was left uninlined in a large caller (the lane
        // loop of a compiled program), a call per channel whose 64-byte result, written in 16-byte
        // pieces, was read back whole: a failed store-to-load forwarding each time.
        let mut out = [L::zero(); FIRST_BLOCK];
        for (c, out) in out.iter_mut().enumerate() {
            let Some(Value { halves, potential }) = CHANNELS[c].value else {
                unreachable!("the whole-state channels come first and have values")
            };
            let mut value = potential.then_some(u);
            for &s in halves.iter().rev() {
                let term = half * self.0[s];
                value = Some(value.map_or(term, |inner| term + inner));
            }
            *out = value.unwrap_or(L::zero());
        }
        out
    }
}

/// Room for per-axis channels appended after the blocks' (a pair form's, one per axis of a grid
/// of up to three dimensions), so that appending them copies nothing: a 2¹⁶-point wave's rows
/// of 32 769 blocks were copied whole when its momentum was added.
pub const AXES_ROOM: usize = 3;

/// `len` copies of `x`, with [`AXES_ROOM`] more to spare.
pub fn with_axes_room<T: Clone>(len: usize, x: T) -> Vec<T> {
    let mut v = Vec::with_capacity(len + AXES_ROOM);
    v.resize(len, x);
    v
}

/// Running maxima and minima of every channel, one number per lane.
#[derive(Clone)]
pub struct Extremes<L> {
    pub high: [L; FIRST_BLOCK],
    pub low: [L; FIRST_BLOCK],
    /// I_1 … I_ℓ when ℓ > 1 (for ℓ = 1, I_1 = H_ω), then the per-axis channels
    pub block_high: Vec<L>,
    pub block_low: Vec<L>,
}

/// Per-block sums Σ(p² + ω²q²) halved in place into the block energies I_j, with their
/// running maxima in `high` and minima in `low` (the same slices' lengths).
///
/// The extremes are read from a copy of each chunk of eight on the stack and written to their
/// rows: updated in place, `hi = if e > hi { e } else { hi }` is a store of a select of a load
/// from the same address, which LLVM turns into a masked store (`vmaskmovpd` with AVX2,
/// microcoded on AMD Zen 2 and 3). From the copy, which the compiler cannot see through
/// (`black_box`), it is a `vmaxpd`/`vminpd` and a plain store, the same bits. (A copy of a
/// chunk of variable length, as before, was two calls of `memcpy` per 64 blocks: 6 % of a
/// 512²-point wave step.)
#[inline(always)]
pub fn halve_into_extremes<L: Real>(sums: &mut [L], high: &mut [L], low: &mut [L]) {
    const CHUNK: usize = 8;
    let half = L::splat(0.5);
    let n = sums.len().min(high.len()).min(low.len());
    let (sums, high, low) = (&mut sums[..n], &mut high[..n], &mut low[..n]);
    let whole = n / CHUNK * CHUNK;
    let chunks = sums[..whole]
        .chunks_exact_mut(CHUNK)
        .zip(high[..whole].chunks_exact_mut(CHUNK))
        .zip(low[..whole].chunks_exact_mut(CHUNK));
    for ((s, hi), lo) in chunks {
        let s: &mut [L; CHUNK] = s.try_into().expect("a whole chunk");
        let hi: &mut [L; CHUNK] = hi.try_into().expect("a whole chunk");
        let lo: &mut [L; CHUNK] = lo.try_into().expect("a whole chunk");
        let (was_high, was_low) = std::hint::black_box((*hi, *lo));
        let e: [L; CHUNK] = std::array::from_fn(|t| half * s[t]);
        *s = e;
        *hi = std::array::from_fn(|t| was_high[t].keep_max(e[t]));
        *lo = std::array::from_fn(|t| was_low[t].keep_min(e[t]));
    }
    for i in whole..n {
        let e = half * sums[i];
        sums[i] = e;
        high[i] = high[i].keep_max(e);
        low[i] = low[i].keep_min(e);
    }
}

/// One trajectory's whole-state extremes in pairs, for the one-lane tight loop on 16 vector
/// registers: the step's channels are gathered into pairs (the last channel repeated), and
/// each step takes their max and min two numbers at a time (`maxpd`/`minpd`, the baseline's
/// instructions, in every copy) with whole-pair loads and stores, rather than a scalar load,
/// compare and store per channel and bound. Every access is a whole pair, so the next step's
/// loads are forwarded from these stores. (Written as a loop over the numbers, the vectorizer
/// made masked stores of it, `vmaskmovpd`, microcoded on AMD Zen 3: 15 → 24 ns a step.)
/// `maxpd(e, hi)` is `if e > hi { e } else { hi }` per number, [`Real::keep_max`]: the same
/// bits as [`Extremes::update`]. With `PLAIN` (H* is H_ω) H*'s channel is left out, as in
/// [`Extremes::update_channels`]: four channels, two pairs.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub struct PackedExtremes<const PLAIN: bool> {
    high: [f64; PACKED],
    low: [f64; PACKED],
}

/// Room in a row of [`PackedExtremes`]: the whole-state channels, padded to whole pairs.
pub const PACKED: usize = FIRST_BLOCK.next_multiple_of(2);

/// The channel at each place of a packed row: every whole-state channel in order, or all but
/// H*'s where it repeats H_ω's; the last one repeated to the end of the row.
const fn packed_order(plain: bool) -> [usize; PACKED] {
    let mut order = [0; PACKED];
    let (mut k, mut c) = (0, 0);
    while c < FIRST_BLOCK {
        if !(plain && c == MODIFIED) {
            order[k] = c;
            k += 1;
        }
        c += 1;
    }
    while k < PACKED {
        order[k] = order[k - 1];
        k += 1;
    }
    order
}

impl<const PLAIN: bool> PackedExtremes<PLAIN> {
    const ORDER: [usize; PACKED] = packed_order(PLAIN);
    /// The numbers taken at each step: the channels kept, padded to whole pairs.
    const USED: usize = (FIRST_BLOCK - PLAIN as usize).next_multiple_of(2);

    /// The whole-state extremes of lane 0 (a one-lane `L`).
    #[inline(always)]
    pub fn of<L: Real>(ext: &Extremes<L>) -> Self {
        PackedExtremes {
            high: std::array::from_fn(|i| ext.high[Self::ORDER[i]].lane(0)),
            low: std::array::from_fn(|i| ext.low[Self::ORDER[i]].lane(0)),
        }
    }

    /// Takes one step's channels (lane 0) into the running extremes.
    #[inline(always)]
    pub fn update<L: Real>(&mut self, main: &[L; FIRST_BLOCK]) {
        let row: [f64; PACKED] = std::array::from_fn(|i| main[Self::ORDER[i]].lane(0));
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{
                _mm_loadu_pd, _mm_max_pd, _mm_min_pd, _mm_set_pd, _mm_storeu_pd,
            };
            for c in (0..Self::USED).step_by(2) {
                // SAFETY: SSE2 is part of x86_64; c + 1 < USED <= PACKED, so each pair is in
                // bounds.
                unsafe {
                    let e = _mm_set_pd(row[c + 1], row[c]);
                    let (hi, lo) = (self.high.as_mut_ptr().add(c), self.low.as_mut_ptr().add(c));
                    _mm_storeu_pd(hi, _mm_max_pd(e, _mm_loadu_pd(hi)));
                    _mm_storeu_pd(lo, _mm_min_pd(e, _mm_loadu_pd(lo)));
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        for c in 0..Self::USED {
            self.high[c] = self.high[c].keep_max(row[c]);
            self.low[c] = self.low[c].keep_min(row[c]);
        }
    }

    /// Writes the extremes back into lane 0 of `ext` (with `PLAIN`, H*'s are then still to be
    /// repeated from H_ω's: [`Extremes::repeat_oscillatory`]).
    #[inline(always)]
    pub fn store<L: Real>(&self, ext: &mut Extremes<L>) {
        for i in 0..Self::USED {
            ext.high[Self::ORDER[i]].set_lane(0, self.high[i]);
            ext.low[Self::ORDER[i]].set_lane(0, self.low[i]);
        }
    }
}

impl<L: Real> Extremes<L> {
    /// For ℓ blocks and `axes` per-axis channels.
    pub fn new(n_blocks: usize, axes: usize) -> Self {
        let several = if n_blocks > 1 { n_blocks } else { 0 } + axes;
        Extremes {
            high: [L::splat(f64::NEG_INFINITY); FIRST_BLOCK],
            low: [L::splat(f64::INFINITY); FIRST_BLOCK],
            block_high: with_axes_room(several, L::splat(f64::NEG_INFINITY)),
            block_low: with_axes_room(several, L::splat(f64::INFINITY)),
        }
    }

    /// Extremes that own no memory, to stand in while the real ones are moved out.
    pub fn placeholder() -> Self {
        Extremes {
            high: [L::zero(); FIRST_BLOCK],
            low: [L::zero(); FIRST_BLOCK],
            block_high: Vec::new(),
            block_low: Vec::new(),
        }
    }

    /// Takes the channels of one step into the running extremes, channel by channel in place:
    /// every access has the width of one channel, whatever their number (a copy of the arrays
    /// updated element by element and written back whole was read back in another width than
    /// it was stored, which stalls store forwarding, once there were five channels). Where H* is
    /// H_ω its channel repeats H_ω's value, so its extremes are H_ω's.
    #[inline(always)]
    pub fn update(&mut self, main: &[L; FIRST_BLOCK]) {
        self.update_channels::<false>(main);
    }

    /// [`update`](Self::update), and with `PLAIN` (H* is H_ω, `plain_modified`) all but H*'s
    /// channel, which repeats H_ω's value: its extremes are left to
    /// [`repeat_oscillatory`](Self::repeat_oscillatory), called once the loop is left. Two
    /// comparisons fewer a step, in a one-trajectory loop whose additions and comparisons share
    /// two pipes (AMD Zen 4 and 5).
    #[inline(always)]
    pub fn update_channels<const PLAIN: bool>(&mut self, main: &[L; FIRST_BLOCK]) {
        // (A test in a loop that unrolls, not a filtered range: that one was left a loop over
        // the extremes in memory.)
        for c in 0..FIRST_BLOCK {
            if !(PLAIN && c == MODIFIED) {
                self.high[c] = self.high[c].keep_max(main[c]);
                self.low[c] = self.low[c].keep_min(main[c]);
            }
        }
    }

    /// H*'s extremes as H_ω's, after [`update_channels`](Self::update_channels): the numbers
    /// [`update`](Self::update) would have left, since each step's two values are the same.
    #[inline(always)]
    pub fn repeat_oscillatory(&mut self) {
        self.high[MODIFIED] = self.high[OSCILLATORY];
        self.low[MODIFIED] = self.low[OSCILLATORY];
    }

    /// Takes the per-block channels (ℓ > 1, else empty) and then the per-axis ones.
    #[inline(always)]
    pub fn update_blocks(&mut self, blocks: &[L], axes: &[L]) {
        for (j, &e) in blocks.iter().chain(axes).enumerate() {
            self.block_high[j] = self.block_high[j].keep_max(e);
            self.block_low[j] = self.block_low[j].keep_min(e);
        }
    }

    /// The per-axis channels' extremes alone (the blocks' taken by the sweep, see
    /// riders of recursion/blocks.rs).
    #[inline(always)]
    pub fn update_axes(&mut self, n_blocks: usize, axes: &[L]) {
        for (k, &e) in axes.iter().enumerate() {
            self.block_high[n_blocks + k] = self.block_high[n_blocks + k].keep_max(e);
            self.block_low[n_blocks + k] = self.block_low[n_blocks + k].keep_min(e);
        }
    }

    /// Halves the per-block sums Σ(p² + ω²q²) in place into the block energies I_j and takes
    /// their extremes, then the per-axis channels' (one loop: a wave equation has 10⁴–10⁶
    /// blocks).
    #[inline(always)]
    pub fn update_half_blocks(&mut self, blocks: &mut [L], axes: &[L]) {
        let nb = blocks.len();
        halve_into_extremes(
            blocks,
            &mut self.block_high[..nb],
            &mut self.block_low[..nb],
        );
        self.update_axes(nb, axes);
    }

    /// The extremes of lane b in channel order (I_1 = H_ω for ℓ = 1; the per-axis channels
    /// last).
    pub fn lane(&self, b: usize, n_blocks: usize) -> (Vec<f64>, Vec<f64>) {
        let pick = |main: &[L; FIRST_BLOCK], blocks: &[L]| {
            let mut v: Vec<f64> = main.iter().map(|x| x.lane(b)).collect();
            if n_blocks == 1 {
                v.push(main[OSCILLATORY].lane(b));
            }
            v.extend(blocks.iter().map(|x| x.lane(b)));
            v
        };
        (
            pick(&self.high, &self.block_high),
            pick(&self.low, &self.block_low),
        )
    }
}

/// max_n |E(t_n) − E(0)| per channel from the extremes. Rounding is monotone, so
/// max(E_n) − E_0 equals max(E_n − E_0) bit for bit.
pub fn max_deviation(initial: &[f64], high: &[f64], low: &[f64]) -> Vec<f64> {
    initial
        .iter()
        .zip(high.iter().zip(low))
        .map(|(&e0, (&hi, &lo))| (hi - e0).max(e0 - lo))
        .collect()
}

/// Saved states of one trajectory: step indices, then row-major q, p and energy rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    pub steps: Vec<u64>,
    /// The positions, in the core's coordinates except the rows marked in `q_in_user`
    pub q: Vec<f64>,
    /// Per row, whether its q is in the user's coordinates already (a run that takes them
    /// from the potential's evaluation: [`Potential::evaluated_in_user_coordinates`](crate::potential::Potential::evaluated_in_user_coordinates)):
    /// one flag per row from the recursion's bundles, empty from the other steppers (none is)
    pub q_in_user: Vec<bool>,
    pub p: Vec<f64>,
    pub energies: Vec<f64>,
}

impl Samples {
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::halve_into_extremes;

    /// The chunked update against the plain loop, bit for bit: lengths around the chunk's (and
    /// the earlier chunk's of 64), and extremes that hold, that move and that meet NaN and
    /// infinite energies.
    #[test]
    fn halved_extremes_are_the_plain_loops() {
        for n in [0, 1, 2, 7, 8, 9, 16, 63, 64, 65, 130, 200] {
            let sums: Vec<f64> = (0..n)
                .map(|j| match j % 7 {
                    3 => f64::NAN,
                    5 => f64::INFINITY,
                    _ => (j as f64 * 0.37).sin() * 4.0,
                })
                .collect();
            let high: Vec<f64> = (0..n)
                .map(|j| if j % 3 == 0 { f64::NEG_INFINITY } else { 0.5 })
                .collect();
            let low: Vec<f64> = (0..n)
                .map(|j| if j % 4 == 0 { f64::INFINITY } else { -0.5 })
                .collect();
            let (mut s1, mut h1, mut l1) = (sums.clone(), high.clone(), low.clone());
            halve_into_extremes(&mut s1, &mut h1, &mut l1);
            let (mut s2, mut h2, mut l2) = (sums, high, low);
            for j in 0..n {
                let e = 0.5 * s2[j];
                s2[j] = e;
                h2[j] = if e > h2[j] { e } else { h2[j] };
                l2[j] = if e < l2[j] { e } else { l2[j] };
            }
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&s1), bits(&s2), "n = {n}");
            assert_eq!(bits(&h1), bits(&h2), "n = {n}");
            assert_eq!(bits(&l1), bits(&l2), "n = {n}");
        }
    }

    /// Where H* is H_ω, the steps' extremes taken without H*'s (in registers and packed in
    /// pairs) and H*'s repeated from H_ω's at the end are the extremes of every channel taken at
    /// every step, bit for bit, through NaN, infinite and signed-zero energies.
    #[test]
    fn extremes_without_the_repeated_channel_are_all_channels_extremes() {
        use super::{Extremes, PackedExtremes, Sums, FIRST_BLOCK};
        let steps: Vec<[f64; FIRST_BLOCK]> = (0..300)
            .map(|j| {
                let s = Sums([
                    match j % 11 {
                        4 => f64::NAN,
                        7 => -0.0,
                        _ => (j as f64 * 0.31).sin().abs(),
                    },
                    match j % 13 {
                        5 => f64::INFINITY,
                        9 => 0.0,
                        _ => (j as f64 * 0.17).cos() * 3.0,
                    },
                    0.0,
                ]);
                s.channels((j as f64 * 0.05).sin(), true)
            })
            .collect();
        let start = Extremes::<f64>::new(1, 0);
        let (mut every, mut plain) = (start.clone(), start.clone());
        let mut packed = PackedExtremes::<true>::of(&start);
        for main in &steps {
            every.update(main);
            plain.update_channels::<true>(main);
            packed.update(main);
        }
        plain.repeat_oscillatory();
        let mut from_packed = start;
        packed.store(&mut from_packed);
        from_packed.repeat_oscillatory();
        let bits = |e: &Extremes<f64>| {
            let row = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (row(&e.high), row(&e.low))
        };
        assert_eq!(bits(&plain), bits(&every));
        assert_eq!(bits(&from_packed), bits(&every));
        assert!(every
            .high
            .iter()
            .all(|x| x.is_finite() || *x == f64::INFINITY));
    }
}
