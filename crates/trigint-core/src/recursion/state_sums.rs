//! The energy sums of a state given whole (q_n, p_n), in the observing sweep's forms and
//! summation order: the initial state's observation, the one-step form's, and `ti.energies`.

use crate::coefficients::Weights;
use crate::energy::{at, kinetic, modified, oscillator, sum, Sums};
use crate::real::Real;
use crate::shape::{Shape, Storage};
use crate::sum::{pairwise, Sum8};

/// (H_ω, H*) summed over the oscillatory blocks in order, from `block(start, end)` of each;
/// each block's H_ω goes to `blocks[j]` (the per-block energies I_j, before the ½).
#[inline(always)]
fn over_blocks<L: Real>(
    ns: usize,
    ends: &[usize],
    blocks: &mut [L],
    mut block: impl FnMut(usize, usize) -> (L, L),
) -> (L, L) {
    let (mut total, mut modified) = (Sum8::new(), Sum8::new());
    let mut start = ns;
    for (j, &end) in ends.iter().enumerate() {
        let (e, m) = block(start, end);
        blocks[j] = e;
        total.add(j % 8, j >= 8, e);
        modified.add(j % 8, j >= 8, m);
        start = end;
    }
    (total.total(ends.len()), modified.total(ends.len()))
}

/// The energy sums of a state given whole (q_n, p_n): the one-step form's observation and the
/// initial state's. The same forms and summation order as [`super::two_step`].
#[inline(always)]
pub fn sums_of_state<L: Real, Sh: Shape>(
    sh: &Sh,
    w: &Weights<L, Sh::S<L>>,
    q: &[L],
    p: &[L],
    plain: bool,
    blocks: &mut [L],
) -> Sums<L> {
    let (ns, n) = (sh.ns(), sh.n());
    let (w2, mp, mq) = (w.omega2.get(), w.modified_p.get(), w.modified_q.get());
    // Every index below is below n (the shape's ranges), read without bounds tests.
    let (q, p, w2, mp, mq) = (&q[..n], &p[..n], &w2[..n], &mp[..n], &mq[..n]);
    if !Sh::FIXED {
        assert!(sh.ns() <= n && sh.block_ends().iter().all(|&e| e <= n));
    }
    let mut sums = Sums::zero();
    (sums.0[sum::KINETIC], _) = pairwise!(L, 0, ns, |i| (kinetic(at(p, i)), L::zero()));
    macro_rules! block {
        ($start:expr, $end:expr) => {
            pairwise!(L, $start, $end, |i| {
                let c = sh.coef(i);
                let (pi, qi) = (at(p, i), at(q, i));
                let m = if plain {
                    L::zero()
                } else {
                    modified(pi, qi, at(mp, c), at(mq, c))
                };
                (oscillator(pi, qi, at(w2, c)), m)
            })
        };
    }
    if sh.single_block() {
        (sums.0[sum::OSCILLATOR], sums.0[sum::MODIFIED]) = block!(ns, n);
    } else if plain {
        // H* = H_ω (its channel repeats H_ω's; the modified sum stays zero, as the sum of the
        // zero terms above would be). Runs of blocks of two coordinates (a wave equation's
        // modes) in a flat loop, as the observing sweep takes them (`many_blocks`), the others
        // through `block!`; then the blocks in order, as `over_blocks` adds them: the same bits.
        // (Block by block, the start of a 2¹⁶-point wave run spent 0.2 ms here.)
        let ends = sh.block_ends();
        let blocks = &mut blocks[..ends.len()];
        let (mut j, mut start) = (0, ns);
        while j < ends.len() {
            let mut k = j;
            while k < ends.len() && ends[k] == start + 2 * (k + 1 - j) {
                k += 1;
            }
            if k == j {
                blocks[j] = block!(start, ends[j]).0;
                (j, start) = (j + 1, ends[j]);
                continue;
            }
            let end = ends[k - 1];
            debug_assert!((start..end).all(|i| sh.coef(i) == i));
            let (qs, ps, w2s) = (&q[start..end], &p[start..end], &w2[start..end]);
            for (e, ((qq, pp), ww)) in blocks[j..k].iter_mut().zip(
                qs.chunks_exact(2)
                    .zip(ps.chunks_exact(2))
                    .zip(w2s.chunks_exact(2)),
            ) {
                *e = oscillator(pp[0], qq[0], ww[0]) + oscillator(pp[1], qq[1], ww[1]);
            }
            (j, start) = (k, end);
        }
        let mut total = Sum8::new();
        total.add_from(0, blocks);
        sums.0[sum::OSCILLATOR] = total.total(ends.len());
    } else {
        (sums.0[sum::OSCILLATOR], sums.0[sum::MODIFIED]) =
            over_blocks(ns, sh.block_ends(), blocks, |a, b| block!(a, b));
    }
    sums
}
