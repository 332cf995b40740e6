//! The energy channels of given states, as a run observes its initial state: the same sums
//! (`recursion::sums_of_state`, the forms and summation order of the observing sweep), the
//! same channel table, the block energies and the pair forms. What `ti.energies` reports for a
//! problem with frequencies, so that no second implementation of the channels exists.

use crate::channels::{channel_count, OSCILLATORY};
use crate::coefficients::{MethodCoefficients, Weights};
use crate::error::{CoreError, CoreResult};
use crate::potential::Potential;
use crate::recursion::sums_of_state;
use crate::run::check_state_rows;
use crate::shape::Layout;

/// The channels (in output order, [`crate::channels::channel_names`]) of each state: rows of
/// `q` and `p`, n = `layout.dim()` values each, in the core's coordinates. `modified` gives the
/// modified energy's weights (a_i, b_i) of (3.4); without them H* is H_ω.
///
/// ```
/// use trigint_core::{channel_names, run::state_energies, Fpu, Layout};
/// // one slow and one stiff coordinate (ω = 2), at q = 0
/// let layout = Layout { omega2: vec![0.0, 4.0], n_slow: 1, block_ends: vec![2], pair_forms: None };
/// let pot = Fpu::new(1).unwrap(); // U(0) = 0
/// let row = state_energies(&pot, &layout, None, &[0.0, 0.0], &[1.0, 1.0]).unwrap();
/// let names = channel_names(1, 0);
/// let e = |name: &str| row[names.iter().position(|n| n == name).unwrap()];
/// assert_eq!((e("total"), e("oscillatory"), e("slow")), (1.0, 0.5, 0.5));
/// assert_eq!((e("modified_oscillatory"), e("oscillatory_1")), (0.5, 0.5)); // H* = H_ω = I_1
/// ```
pub fn state_energies<P: Potential>(
    pot: &P,
    layout: &Layout,
    modified: Option<(&[f64], &[f64])>,
    q: &[f64],
    p: &[f64],
) -> CoreResult<Vec<f64>> {
    layout.validate()?;
    let n = layout.dim();
    pot.check_dim(n)?;
    check_state_rows(q, p, n)?;
    let (a, b) = modified.unwrap_or((&[], &[]));
    if modified.is_some() && (a.len() != n || b.len() != n) {
        return Err(CoreError::invalid(
            "modified",
            format!("{} and {} weights for {n} coordinates", a.len(), b.len()),
        ));
    }
    // Only the weights' rows are read; without weights, a_i = 1 and b_i = ω_i²: H* = H_ω.
    let weights_only = MethodCoefficients::from_rows(0.0, |name| {
        Ok::<_, CoreError>(match (name, modified) {
            ("modified_p", Some(_)) => a.to_vec(),
            ("modified_q", Some(_)) => b.to_vec(),
            ("modified_p", None) => vec![1.0; n],
            ("modified_q", None) => layout.omega2.clone(),
            _ => Vec::new(),
        })
    })?;
    let sh = layout.dynamic();
    let w = Weights::<f64, Vec<f64>>::new(&sh, &layout.omega2, &[&weights_only]);
    let (n_blocks, axes) = (layout.n_blocks(), layout.n_axes());
    let mut blocks = vec![0.0; n_blocks.max(1)];
    let mut pairs = vec![0.0; axes];
    let mut ws = pot.workspace::<f64>();
    let mut rows = Vec::with_capacity(q.len() / n.max(1) * channel_count(n_blocks, axes));
    for (q, p) in q.chunks_exact(n.max(1)).zip(p.chunks_exact(n.max(1))) {
        let u = pot.value(q, &mut ws)?;
        let sums = sums_of_state(&sh, &w, q, p, w.plain_modified, &mut blocks);
        let main = sums.channels(u, w.plain_modified);
        rows.extend_from_slice(&main);
        // ℓ = 1: the row repeats H_ω as I_1; ℓ > 1: the sweep's block sums, halved.
        match n_blocks {
            0 => {}
            1 => rows.push(main[OSCILLATORY]),
            _ => rows.extend(blocks.iter().map(|&s| 0.5 * s)),
        }
        if let Some(f) = &layout.pair_forms {
            f.evaluate(q, p, &mut pairs);
            rows.extend_from_slice(&pairs);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Fpu;

    #[test]
    fn rows_and_weights_of_the_wrong_size_are_errors_that_say_so() {
        let layout = Layout {
            omega2: vec![0.0, 4.0],
            n_slow: 1,
            block_ends: vec![2],
            pair_forms: None,
        };
        let pot = Fpu::new(1).unwrap();
        let e = state_energies(&pot, &layout, None, &[0.0; 3], &[0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("expected rows of 2 values"), "{e}");
        let weights = Some((&[1.0][..], &[4.0][..]));
        let e = state_energies(&pot, &layout, weights, &[0.0; 2], &[0.0; 2]).unwrap_err();
        assert!(
            e.to_string().contains("1 and 1 weights for 2 coordinates"),
            "{e}"
        );
        // two states, each row as the channels of one
        let rows = state_energies(&pot, &layout, None, &[0.0; 4], &[1.0, 1.0, 2.0, 0.0]).unwrap();
        assert_eq!(rows.len(), 2 * crate::channel_count(1, 0));
        assert_eq!(rows[crate::channel_count(1, 0)], 2.0); // H of (p0, p1) = (2, 0)
    }
}
