//! A layout and a method made once and used for many runs: their checks pass once, and the
//! kernels' rows made from a method are kept for the next run.
//!
//! A wave equation's layout and method have tens of thousands of numbers per row. Checked and
//! turned into the kernels' rows and energy weights at every call (the checks read 5 MB, the
//! rows write 6.5 MB), they made the core's 2-step call on 2^16 points take 8.0–8.6 ms instead
//! of 5.6–5.7 ms, more than two steps (Intel Xeon model 207). The binding's `_core.Layout`
//! and `_core.Method` hold these types; both are immutable, so a check that passed stays true.

use std::any::{Any, TypeId};
use std::ops::Deref;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::error::CoreResult;
use crate::real::Real;
use crate::shape::{Layout, Shape};

/// A [`Layout`] whose check ([`Layout::validate`]) runs at most once.
#[derive(Debug)]
pub struct PreparedLayout {
    layout: Layout,
    checked: OnceLock<()>,
    /// Names this layout among all made in the process (never reused): what a prepared method
    /// keeps its energy weights under.
    id: u64,
}

impl PreparedLayout {
    pub fn new(layout: Layout) -> Self {
        static MADE: AtomicU64 = AtomicU64::new(0);
        PreparedLayout {
            layout,
            checked: OnceLock::new(),
            id: MADE.fetch_add(1, Ordering::Relaxed),
        }
    }

    /// [`Layout::validate`], run at the first call; after it passed, free.
    pub fn validate(&self) -> CoreResult<()> {
        if self.checked.get().is_none() {
            self.layout.validate()?;
            let _ = self.checked.set(());
        }
        Ok(())
    }
}

impl Deref for PreparedLayout {
    type Target = Layout;
    fn deref(&self) -> &Layout {
        &self.layout
    }
}

/// Rows of one type (the kernels' rows or the energy weights, of one lane type and storage),
/// for one size and number of slow coordinates (all that [`Coef::new`] and [`Weights::new`]
/// read of a shape), and for the weights the layout they were made with.
type Key = (TypeId, usize, usize, Option<u64>);

/// Rows kept per method: a method handle is used with one layout, in one or two forms.
const KEPT: usize = 8;

/// Bytes of rows kept by all prepared methods of the process together. Beyond [`BUDGET`] a
/// method makes its rows for each run, as an unprepared one does: a 3-D grid of 2^21 points
/// has 16 MiB rows, and the Python layer keeps up to four methods per problem.
static KEPT_BYTES: AtomicUsize = AtomicUsize::new(0);
const BUDGET: usize = 256 << 20;

/// Takes `bytes` of the budget, if it has room for them.
fn reserve(bytes: usize) -> bool {
    KEPT_BYTES
        .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |held| {
            held.checked_add(bytes).filter(|&t| t <= BUDGET)
        })
        .is_ok()
}

fn release(bytes: usize) {
    KEPT_BYTES.fetch_sub(bytes, Ordering::Relaxed);
}

/// Kept rows: their key, the rows, the bytes they hold of the budget.
type Kept = (Key, Arc<dyn Any + Send + Sync>, usize);

/// A [`MethodCoefficients`] whose checks run once per coordinate count and form, with the
/// kernels' rows ([`Coef`]) and the energy weights ([`Weights`]) made once per lane type and
/// shape and kept (about 1.6 times the method's own memory; all methods together at most
/// 256 MiB).
pub struct PreparedMethod {
    method: MethodCoefficients,
    /// The (n, two-step) for which [`MethodCoefficients::validate`] passed.
    passed: Mutex<Vec<(usize, bool)>>,
    rows: Mutex<Vec<Kept>>,
}

impl PreparedMethod {
    pub fn new(method: MethodCoefficients) -> Self {
        PreparedMethod {
            method,
            passed: Mutex::new(Vec::new()),
            rows: Mutex::new(Vec::new()),
        }
    }

    /// [`MethodCoefficients::validate`]: the same checks and errors, each (n, form) checked
    /// once.
    pub fn validate(&self, n: usize, two_step: bool) -> CoreResult<()> {
        let mut passed = self.passed.lock().unwrap_or_else(|e| e.into_inner());
        if !passed.contains(&(n, two_step)) {
            self.method.validate(n, two_step)?;
            passed.push((n, two_step));
        }
        Ok(())
    }

    /// The kernels' rows for one trajectory of shape `sh`, made at the first run of this lane
    /// type and shape and shared after (the same numbers: [`Coef::new`] on this method).
    pub(crate) fn coef<L: Real, Sh: Shape>(&self, sh: &Sh) -> Arc<Coef<L, Sh::S<L>>> {
        let bytes = Coef::<L, Sh::S<L>>::ROWS * sh.n() * std::mem::size_of::<L>();
        self.kept(sh, None, bytes, || Coef::new(sh, &[&self.method]))
    }

    /// The energy weights for one trajectory of shape `sh` on `layout`, made once ([`Weights::new`]).
    pub(crate) fn weights<L: Real, Sh: Shape>(
        &self,
        sh: &Sh,
        layout: &PreparedLayout,
    ) -> Arc<Weights<L, Sh::S<L>>> {
        let bytes = Weights::<L, Sh::S<L>>::ROWS * sh.n() * std::mem::size_of::<L>();
        self.kept(sh, Some(layout.id), bytes, || {
            Weights::new(sh, &layout.omega2, &[&self.method])
        })
    }

    /// The rows under `key`, or `make()`'s, kept while the budget has room for their `bytes`.
    fn kept<T: Any + Send + Sync, Sh: Shape>(
        &self,
        sh: &Sh,
        layout: Option<u64>,
        bytes: usize,
        make: impl FnOnce() -> T,
    ) -> Arc<T> {
        let key = (TypeId::of::<T>(), sh.n(), sh.ns(), layout);
        let mut rows = self.rows.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, kept, _)) = rows.iter().find(|(k, _, _)| *k == key) {
            if let Ok(rows) = Arc::clone(kept).downcast::<T>() {
                return rows;
            }
        }
        let made = Arc::new(make());
        if rows.len() >= KEPT {
            release(rows.remove(0).2);
        }
        if reserve(bytes) {
            rows.push((key, made.clone(), bytes));
        }
        made
    }
}

impl Drop for PreparedMethod {
    fn drop(&mut self) {
        let rows = self.rows.get_mut().unwrap_or_else(|e| e.into_inner());
        for (_, _, held) in rows.drain(..) {
            release(held);
        }
    }
}

impl Deref for PreparedMethod {
    type Target = MethodCoefficients;
    fn deref(&self) -> &MethodCoefficients {
        &self.method
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Dynamic;

    fn method(n: usize) -> MethodCoefficients {
        MethodCoefficients::from_rows(0.1, |name| {
            Ok::<_, ()>(vec![if name == "chi" { 0.0 } else { 0.5 }; n])
        })
        .unwrap()
    }

    #[test]
    fn checks_run_per_size_and_form_and_keep_their_errors() {
        let m = PreparedMethod::new(method(4));
        assert!(m.validate(4, false).is_ok());
        // χ = 0: the two-step form is refused, every time, with the unprepared message
        let e = m.validate(4, true).unwrap_err().to_string();
        assert_eq!(e, method(4).validate(4, true).unwrap_err().to_string());
        assert!(m.validate(4, true).is_err());
        assert!(m.validate(5, false).is_err());
        assert_eq!(*m.passed.lock().unwrap(), vec![(4, false)]);
    }

    #[test]
    fn rows_beyond_the_budget_are_made_per_run_and_a_dropped_method_gives_its_place_back() {
        // Rows that claim most of the budget (the claim is what counts, not what they hold).
        let sh = Layout {
            omega2: vec![1.0; 4],
            n_slow: 0,
            block_ends: vec![4],
            pair_forms: None,
        }
        .dynamic();
        let big = BUDGET * 3 / 4;
        let (a, b) = (
            PreparedMethod::new(method(4)),
            PreparedMethod::new(method(4)),
        );
        let kept = a.kept(&sh, None, big, || 1u32);
        assert!(Arc::ptr_eq(&kept, &a.kept(&sh, None, big, || 2u32)));
        // b's do not fit beside a's: made at each run
        assert_eq!(*b.kept(&sh, None, big, || 3u32), 3);
        assert_eq!(*b.kept(&sh, None, big, || 4u32), 4);
        drop(a);
        // a's place given back: b keeps its rows now
        assert_eq!(*b.kept(&sh, None, big, || 5u32), 5);
        assert_eq!(*b.kept(&sh, None, big, || 6u32), 5);
    }

    #[test]
    fn rows_are_made_once_per_lane_type_and_size() {
        let m = PreparedMethod::new(method(4));
        let lay = Layout {
            omega2: vec![1.0; 4],
            n_slow: 0,
            block_ends: vec![1, 2, 3, 4],
            pair_forms: None,
        };
        let sh: Dynamic = lay.dynamic();
        let a = m.coef::<f64, _>(&sh);
        let b = m.coef::<f64, _>(&sh);
        assert!(Arc::ptr_eq(&a, &b));
        let fresh: Coef<f64, Vec<f64>> = Coef::new(&sh, &[&*m]);
        assert_eq!(a.h2_psi, fresh.h2_psi);
        assert_eq!(a.inv_2h_chi, fresh.inv_2h_chi);
        // the weights are kept per layout: another layout of the same size gets its own
        let mut bad = lay.clone();
        bad.block_ends = vec![2, 1, 4];
        let bad = PreparedLayout::new(bad);
        let said = bad.validate().unwrap_err().to_string();
        assert!(
            said.contains("block ends [2, 1, 4] must increase"),
            "{said}"
        );
        assert_eq!(bad.validate().unwrap_err().to_string(), said); // refused at every call
        let (one, two) = (PreparedLayout::new(lay.clone()), PreparedLayout::new(lay));
        assert!(one.validate().is_ok() && one.validate().is_ok());
        let w1 = m.weights::<f64, _>(&sh, &one);
        assert!(Arc::ptr_eq(&w1, &m.weights::<f64, _>(&sh, &one)));
        assert!(!Arc::ptr_eq(&w1, &m.weights::<f64, _>(&sh, &two)));
        assert_eq!(w1.omega2, vec![1.0; 4]);
    }
}
