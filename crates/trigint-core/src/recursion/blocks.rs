//! The observing sweep of many blocks: a wave equation's 10⁴–10⁶ Fourier modes, each its own
//! block, observed in one pass over the state per step; and the two-step step that takes it
//! ([`two_step_riding`]), kept apart from the step of one block so that no loop of one block
//! carries this sweep's code.

use super::{
    modified, observe_slow, oscillator, state_rows, step_rows, two_step_one_block, FastRows,
    Observe, State, Term,
};
use crate::coefficients::{Coef, Weights};
use crate::energy::{halve_into_extremes, PairForms, MAX_RIDING_AXES};
use crate::energy::{sum, Sums};
use crate::real::Real;
use crate::shape::{Shape, Storage};
use crate::sum::Sum8;

/// What the observing sweep of many blocks takes along in the same pass over the state, so
/// that a wave equation's 10⁵ coordinates are read from the outer caches once per step rather
/// than once per quantity. The same terms in the same order as the separate loops (the
/// extremes of [`crate::energy::Extremes::update_half_blocks`], the sums of
/// [`PairForms::evaluate`]), so the same bits.
pub struct Riders<'a, L> {
    /// The running max and min of each block's energy: the sweep halves the per-block sums into
    /// I_j and takes their extremes.
    pub extremes: Option<(&'a mut [L], &'a mut [L])>,
    /// Pair forms that [`PairForms::rides_along`] a sweep of these blocks, and where their
    /// per-axis values go; the sweep then advances q itself.
    pub pairs: Option<(&'a PairForms, &'a mut [L])>,
}

impl<L> Riders<'_, L> {
    pub fn none() -> Self {
        Riders {
            extremes: None,
            pairs: None,
        }
    }
}

/// Coordinates per pass of [`many_blocks`], at most (unless one block is longer): the state,
/// rows and block sums of a pass stay in the first-level cache between its loops.
const PASS: usize = 256;

/// Pairs per chunk of the pair forms' terms in [`many_blocks`].
const PAIR_CHUNK: usize = 64;

/// The observing sweep of many blocks (a wave equation has one per Fourier mode, 10⁴–10⁶ of
/// them), in passes of whole blocks (about [`PASS`] coordinates, a multiple of eight blocks):
/// the step over the pass's coordinates in one flat loop with p_n kept, each block's sums
/// from (q_n, p_n), what [`Riders`] asks for, then q advanced unless `store`.
///
/// The order of the sums: within a block its terms as [`observe_range`] sums them (term t into
/// partial sum t mod 8, the tree; a block of one or two coordinates is its term or the sum of
/// its two); over the blocks, block j into partial sum j mod 8 (see [`crate::sum`]). Nothing
/// depends on where the passes are cut. (One sweep per loop over 10⁵ coordinates would read
/// the state from the outer caches once per loop.) Inlined into the hot loop, where `plain`
/// and the riders are known: outlined, the 2¹⁶-point wave step took 355 instead of 320 µs.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn many_blocks<L: Real, Sh: Shape>(
    sh: &Sh,
    (q, d, p, f): (&mut [L], &mut [L], &mut [L], &[L]),
    store: bool,
    fast: &FastRows<'_, L, Sh>,
    w: &Weights<L, Sh::S<L>>,
    plain: bool,
    blocks: &mut [L],
    mut riders: Riders<'_, L>,
) -> (L, L) {
    let (ns, n) = (sh.ns(), sh.n());
    let (w2, mp, mq) = (
        &w.omega2.get()[..n],
        &w.modified_p.get()[..n],
        &w.modified_q.get()[..n],
    );
    let ends = sh.block_ends();
    let blocks = &mut blocks[..ends.len()];
    let (mut total, mut modified_total) = (Sum8::new(), Sum8::new());
    // The pair forms' sums, and the next pair.
    let mut pair_sums = [Sum8::<L>::new(); MAX_RIDING_AXES];
    let (mut next_pair, mut next_run) = (0, 0);
    let mut pair_terms = riders.pairs.as_ref().map(|_| [L::zero(); PAIR_CHUNK]);
    let keep_blocks = store || riders.extremes.is_none();
    // No block longer than two: a pass of twice as many coordinates as blocks is then all
    // blocks of two (blocks of 1 and 3 coordinates would pass the count alone).
    let at_most_pairs = sh.longest_block() <= 2;
    // The pair forms need q_n: a sweep that computes them is asked to advance q itself.
    debug_assert!(!(store && riders.pairs.is_some()));
    // Shapes of many blocks read their numbers at each coordinate (see `Shape::coef`).
    debug_assert!(sh.uniform().is_none() && (ns..n).all(|i| sh.coef(i) == i));
    let (mut j, mut start) = (0, ns);
    while j < ends.len() {
        // The pass: blocks j..j_end, coordinates start..end.
        let mut j_end = (j + 8).min(ends.len());
        while j_end < ends.len() && ends[(j_end + 8).min(ends.len()) - 1] - start <= PASS {
            j_end = (j_end + 8).min(ends.len());
        }
        let end = ends[j_end - 1];
        // p_n of the pass: in its place where it is asked for (a sample), else in the first
        // coordinates of `p`, which every pass reuses, so that they stay in the first-level
        // cache (on a 2¹⁶-point wave, 1 MiB a step less to and from the outer caches).
        let scratch = if store { start } else { 0 };
        for (i, pi) in (start..end).zip(&mut p[scratch..scratch + end - start]) {
            let next;
            (next, *pi, _, _) = fast.at(i, d[i], q[i], f[i]);
            d[i] = next;
        }
        let ps = &p[scratch..scratch + end - start];
        // The blocks' energies likewise: in their places where read after the sweep (a sample,
        // or no extremes riding), else in the first places of `blocks`.
        let energies = if keep_blocks {
            &mut blocks[j..j_end]
        } else {
            &mut blocks[..j_end - j]
        };
        let (qs, w2s) = (&q[start..end], &w2[start..end]);
        if plain && at_most_pairs && end - start == 2 * (j_end - j) {
            // Blocks of two coordinates each (the modes of a wave equation): a flat loop.
            for (e, ((qq, pp), ww)) in energies.iter_mut().zip(
                qs.chunks_exact(2)
                    .zip(ps.chunks_exact(2))
                    .zip(w2s.chunks_exact(2)),
            ) {
                *e = oscillator(pp[0], qq[0], ww[0]) + oscillator(pp[1], qq[1], ww[1]);
            }
        } else {
            let terms = |i: usize| {
                let (pi, qi) = (ps[i - start], q[i]);
                let m = if plain {
                    L::zero()
                } else {
                    modified(pi, qi, mp[i], mq[i])
                };
                (oscillator(pi, qi, w2[i]), m)
            };
            let mut a = start;
            for (jj, &b) in ends.iter().enumerate().take(j_end).skip(j) {
                let (e, m) = match b - a {
                    1 => terms(a),
                    2 => {
                        let ((e0, m0), (e1, m1)) = (terms(a), terms(a + 1));
                        (e0 + e1, m0 + m1)
                    }
                    count => {
                        let (mut e, mut m) = (Sum8::new(), Sum8::new());
                        for t in 0..count {
                            let (x, y) = terms(a + t);
                            e.add(t % 8, t >= 8, x);
                            m.add(t % 8, t >= 8, y);
                        }
                        (e.total(count), m.total(count))
                    }
                };
                energies[jj - j] = e;
                if !plain {
                    modified_total.add(jj % 8, jj >= 8, m);
                }
                a = b;
            }
        }
        total.add_from(j, energies);
        if let Some((high, low)) = &mut riders.extremes {
            halve_into_extremes(energies, &mut high[j..j_end], &mut low[j..j_end]);
        }
        if let Some((forms, _)) = &riders.pairs {
            // Every pair inside this pass (no block end splits one): q_n and p_n are here.
            let runs = forms.riding().expect("checked by rides_along");
            let (count, axes) = (forms.pairs().0.len(), forms.axes());
            let buffer = pair_terms.as_mut().expect("made with the pair forms");
            while let Some(run) = runs.get(next_run) {
                // The run's pairs t whose second coordinate at + 2(t − first) + 1 is below
                // `end`. (Counted one by one, this was a tenth of the 2¹⁶-point wave sweep's
                // time.)
                let below = if end > run.at + 1 {
                    ((end - run.at) / 2).min(run.len)
                } else {
                    0
                };
                let upto = run.first + below;
                for lo in (next_pair..upto).step_by(PAIR_CHUNK) {
                    let hi = (lo + PAIR_CHUNK).min(upto);
                    let from = run.at + 2 * (lo - run.first);
                    let to = from + 2 * (hi - lo);
                    let (qs, ps) = (&q[from..to], &ps[from - start..to - start]);
                    let x = &mut buffer[..hi - lo];
                    for (m, sum) in pair_sums.iter_mut().enumerate().take(axes) {
                        let wm = &forms.weights()[m * count + lo..m * count + hi];
                        for (((x, qq), pp), &wt) in x
                            .iter_mut()
                            .zip(qs.chunks_exact(2))
                            .zip(ps.chunks_exact(2))
                            .zip(wm)
                        {
                            *x = L::splat(wt) * (qq[0] * pp[1] - qq[1] * pp[0]);
                        }
                        sum.add_from(lo, x);
                    }
                }
                next_pair = next_pair.max(upto);
                if below < run.len {
                    break;
                }
                next_run += 1;
            }
        }
        if !store {
            for i in start..end {
                q[i] += d[i];
            }
        }
        (j, start) = (j_end, end);
    }
    if let Some((forms, out)) = riders.pairs {
        debug_assert_eq!(next_pair, forms.pairs().0.len());
        for (k, sum) in out.iter_mut().zip(&pair_sums) {
            *k = sum.total(next_pair);
        }
    }
    let m = if plain {
        L::zero()
    } else {
        modified_total.total(ends.len())
    };
    (total.total(ends.len()), m)
}

/// [`two_step`](super::two_step) with [`Riders`] (taken only by the sweep of many blocks: a
/// shape of one block must pass none).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn two_step_riding<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
    obs: Observe,
    plain: bool,
    blocks: &mut [L],
    riders: Riders<'_, L>,
) -> Sums<L> {
    debug_assert!(
        (riders.extremes.is_none() && riders.pairs.is_none()) || !sh.single_block(),
        "riders need the sweep of many blocks"
    );
    if obs == Observe::No || sh.single_block() {
        return two_step_one_block(sh, k, w, st, obs, plain);
    }
    let (q, d, p, f) = state_rows(sh, st);
    let store = obs == Observe::State;
    let mut sums = Sums::zero();
    sums.0[sum::KINETIC] = observe_slow(sh.ns(), k, (q, d, p, f), store);
    let fast = FastRows {
        sh,
        rows: step_rows(sh, k, w),
        plain,
    };
    (sums.0[sum::OSCILLATOR], sums.0[sum::MODIFIED]) =
        many_blocks(sh, (q, d, p, f), store, &fast, w, plain, blocks, riders);
    sums
}
