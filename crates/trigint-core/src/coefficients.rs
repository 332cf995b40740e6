//! The per-coordinate numbers of a method, and the products the kernels read.
//!
//! Every method of the paper is the recursion (2.5),
//!
//!   q_{n+1} − 2 cos(hω̃) q_n + q_{n−1} = h² ψ g(φ q_n),   2h χ p_n = q_{n+1} − q_{n−1},
//!
//! with per-coordinate numbers c = cos(hω̃), χ, ψ, φ (ω̃ = ω and χ = sinc(hω) for the
//! trigonometric methods (2.2)). The Python layer evaluates the filter functions and hands
//! these arrays over, one [`MethodCoefficients`] per trajectory; here they are checked and turned
//! into the products the kernels use ([`Coef`]), one number per lane, so that a method is data
//! and the loop is one.
//!
//! The kernels take 1 − c = 2 sin²(½hω̃) rather than c: it is known to full relative precision,
//! so the summed form of the recursion has no systematic phase error from the rounding of
//! cos(hω̃), which for small hω̃ is amplified by 1/sin(hω̃).

use crate::error::{CoreError, CoreResult};
use crate::real::{first_failing, Real};
use crate::shape::{Shape, Storage};

/// The method table, written once: each row is one per-coordinate array of a method's numbers,
/// named as the Python layer names it. The struct, [`MethodCoefficients::ROWS`] (exported to
/// Python as `_core.METHOD_ROWS`), [`MethodCoefficients::rows`] (validation, conversion) and
/// [`MethodCoefficients::from_rows`] (the binding) are all generated from this list: a new row
/// is one line here plus the product the kernels read in [`Coef`].
macro_rules! method_table {
    ($($(#[doc = $doc:expr])* $field:ident,)*) => {
        /// One trajectory's method numbers per coordinate (in the kernels' coordinate order), as
        /// evaluated at hω̃_i; slow coordinates carry Störmer–Verlet's (c = χ = ψ = φ = 1).
        #[derive(Debug, Clone, PartialEq)]
        pub struct MethodCoefficients {
            pub h: f64,
            $($(#[doc = $doc])* pub $field: Vec<f64>,)*
        }

        impl MethodCoefficients {
            /// The rows' names, in table order.
            pub const ROWS: &'static [&'static str] = &[$(stringify!($field)),*];

            /// Every row with its name, in table order.
            pub fn rows(&self) -> Vec<(&'static str, &[f64])> {
                vec![$((stringify!($field), &self.$field[..])),*]
            }

            /// A method from its step size and a source of rows by name (`row(name)` is called
            /// once per row, in table order).
            pub fn from_rows<E>(
                h: f64,
                mut row: impl FnMut(&'static str) -> Result<Vec<f64>, E>,
            ) -> Result<Self, E> {
                Ok(MethodCoefficients {
                    h,
                    $($field: row(stringify!($field))?,)*
                })
            }
        }
    };
}

method_table! {
    /// 1 − cos(hω̃_i) = 2 sin²(½hω̃_i), to full relative precision.
    one_minus_cos,
    /// χ(hω̃_i); sinc(hω_i) for the trigonometric methods. The two-step form needs χ ≠ 0.
    chi,
    /// ψ(hω̃_i)
    psi,
    /// φ(hω̃_i)
    phi,
    /// ψ/χ, with its limit where χ = 0 (one-step form).
    psi_over_chi,
    /// sin²(hω̃_i)/(hχ), with its limit where χ = 0 (one-step form; ω sin(hω) for (2.2)).
    sin2_over_h_chi,
    /// Weight of ½p_i² in the modified oscillatory energy (3.4).
    modified_p,
    /// Weight of ½q_i² in the modified oscillatory energy (3.4).
    modified_q,
}

impl MethodCoefficients {
    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.one_minus_cos.len()
    }

    /// Checks the step size, the lengths, finiteness and, for the two-step form, χ ≠ 0.
    pub fn validate(&self, n: usize, two_step: bool) -> CoreResult<()> {
        if !(self.h.is_finite() && self.h > 0.0) {
            return Err(CoreError::invalid(
                "h",
                format!("must be finite and > 0, got {}", self.h),
            ));
        }
        for (name, v) in self.rows() {
            if v.len() != n {
                return Err(CoreError::invalid(
                    "coefficients",
                    format!("`{name}` has {} entries for {n} coordinates", v.len()),
                ));
            }
            if let Some(i) = first_failing(v, f64::is_finite) {
                return Err(CoreError::invalid(
                    "coefficients",
                    format!("`{name}` is not finite at coordinate {i}: {}", v[i]),
                ));
            }
        }
        if two_step {
            if let Some(i) = first_failing(&self.chi, |x| x != 0.0) {
                return Err(CoreError::invalid(
                    "coefficients",
                    format!(
                        "chi vanishes at coordinate {i}: the two-step momentum \
                         p_n = (q_(n+1) - q_(n-1)) / (2 h chi) is undefined there"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The products the kernels read, one number per lane: per-lane scalars for the slow
/// coordinates (Störmer–Verlet) and per-coordinate rows for the oscillatory ones.
#[derive(Clone)]
pub struct Coef<L, S> {
    /// h, h², ½h², 1/(2h), ½h per lane: the slow coordinates' numbers.
    pub h: L,
    pub h2: L,
    pub half_h2: L,
    pub inv_2h: L,
    pub half_h: L,
    /// 1 − c and 2(1 − c)
    pub omc: S,
    pub two_omc: S,
    /// h²ψ and ½h²ψ
    pub h2_psi: S,
    pub half_h2_psi: S,
    pub phi: S,
    /// 1/(2hχ) and hχ
    pub inv_2h_chi: S,
    pub h_chi: S,
    /// One-step form: −sin²(hω̃)/(hχ), ½h c ψ/χ and ½h ψ/χ [GNI XIII (2.7)–(2.9)].
    pub p_from_q: S,
    pub half_h_psi0: S,
    pub half_h_psi1: S,
    /// φ ≡ 1 in every lane: the force is evaluated at q_n itself, in one pass with U(q_n).
    pub phi_is_identity: bool,
}

/// The energy weights in the kernels' storage: ω_i² and the modified energy's per-lane weights.
#[derive(Clone)]
pub struct Weights<L, S> {
    pub omega2: S,
    pub modified_p: S,
    pub modified_q: S,
    /// H* is H_ω in every lane (σ ≡ 1, ω̃ = ω): its sums are skipped and the value copied.
    pub plain_modified: bool,
    _lane: std::marker::PhantomData<L>,
}

/// Lane b's number for coordinate i, from lane b's method (lanes beyond `methods` repeat the
/// last one: they are padding that is never reported). Set-up code: the numbers come through
/// `&dyn Fn`, so this and [`row`] are compiled once per lane type and shape, not once per
/// number (which bought no speed and cost build time).
#[inline(never)]
fn lanes<L: Real>(methods: &[&MethodCoefficients], f: &dyn Fn(&MethodCoefficients) -> f64) -> L {
    let mut v = L::zero();
    for b in 0..L::LANES {
        v.set_lane(b, f(methods[b.min(methods.len() - 1)]));
    }
    v
}

/// A row of bundle numbers: `f` makes one method's row (all coordinates in one tight loop; a
/// call per number through `&dyn Fn` cost 2.3 ms per row at 2^16 coordinates), lane b takes
/// method b's (lanes beyond `methods` repeat the last one).
#[inline(never)]
fn row<L: Real, Sh: Shape>(
    sh: &Sh,
    methods: &[&MethodCoefficients],
    f: &dyn Fn(&MethodCoefficients) -> Vec<f64>,
) -> Sh::S<L> {
    let n = sh.n();
    let last = methods.len() - 1;
    let mut one = f(methods[0]);
    if L::LANES == 1 && one.len() == n {
        // One trajectory in `f64`: the row made is the kernel's row, not filled with zeros first
        // and not copied (writing zeros into a 2^16-point wave call's 14 rows cost 0.3 ms).
        match L::vec_from_f64s(one) {
            Ok(v) => return Sh::S::<L>::from_vec(v),
            Err(v) => one = v,
        }
    }
    let mut s = Sh::S::<L>::filled(n, L::zero());
    for b in 0..L::LANES {
        if b > 0 && b <= last {
            one = f(methods[b]);
        }
        for (x, &y) in s.get_mut().iter_mut().zip(&one) {
            x.set_lane(b, y);
        }
    }
    s
}

/// g(a_i) for each i: the loop of one row.
#[inline(always)]
fn each(a: &[f64], g: impl Fn(f64) -> f64) -> Vec<f64> {
    a.iter().map(|&x| g(x)).collect()
}

impl<L: Real, S: Storage<L>> Coef<L, S> {
    /// Its per-coordinate rows (`omc` … `half_h_psi1`).
    pub const ROWS: usize = 10;

    /// The kernel numbers of up to `L::LANES` trajectories (validated beforehand).
    pub fn new<Sh: Shape<S<L> = S>>(sh: &Sh, methods: &[&MethodCoefficients]) -> Self {
        // each row's arithmetic in the order it always had (the same bits): (h·h)·ψ_i, …
        Coef {
            h: lanes(methods, &|m| m.h),
            h2: lanes(methods, &|m| m.h * m.h),
            half_h2: lanes(methods, &|m| 0.5 * m.h * m.h),
            inv_2h: lanes(methods, &|m| 1.0 / (2.0 * m.h)),
            half_h: lanes(methods, &|m| 0.5 * m.h),
            omc: row::<L, Sh>(sh, methods, &|m| m.one_minus_cos.clone()),
            two_omc: row::<L, Sh>(sh, methods, &|m| each(&m.one_minus_cos, |x| 2.0 * x)),
            h2_psi: row::<L, Sh>(sh, methods, &|m| {
                let h2 = m.h * m.h;
                each(&m.psi, |x| h2 * x)
            }),
            half_h2_psi: row::<L, Sh>(sh, methods, &|m| {
                let a = 0.5 * m.h * m.h;
                each(&m.psi, |x| a * x)
            }),
            phi: row::<L, Sh>(sh, methods, &|m| m.phi.clone()),
            inv_2h_chi: row::<L, Sh>(sh, methods, &|m| {
                let a = 2.0 * m.h;
                each(&m.chi, |x| 1.0 / (a * x))
            }),
            h_chi: row::<L, Sh>(sh, methods, &|m| each(&m.chi, |x| m.h * x)),
            p_from_q: row::<L, Sh>(sh, methods, &|m| each(&m.sin2_over_h_chi, |x| -x)),
            half_h_psi0: row::<L, Sh>(sh, methods, &|m| {
                let a = 0.5 * m.h;
                (m.one_minus_cos.iter().zip(&m.psi_over_chi))
                    .map(|(&omc, &r)| a * (1.0 - omc) * r)
                    .collect()
            }),
            half_h_psi1: row::<L, Sh>(sh, methods, &|m| {
                let a = 0.5 * m.h;
                each(&m.psi_over_chi, |x| a * x)
            }),
            phi_is_identity: methods
                .iter()
                .all(|m| m.phi[sh.ns()..].iter().all(|&x| x == 1.0)),
        }
    }
}

/// Lane b of a row of bundle numbers, as one trajectory's row.
#[inline(always)]
fn lane_row<L: Real, S: Storage<L>, T: Storage<f64>>(row: &S, b: usize) -> T {
    let v = row.get();
    let mut t = T::filled(v.len(), 0.0);
    for (x, y) in t.get_mut().iter_mut().zip(v) {
        *x = y.lane(b);
    }
    t
}

impl<L: Real, S: Storage<L>> Coef<L, S> {
    /// Lane b's numbers as one trajectory's (for the lane loop, which runs each lane's step in
    /// `f64`: inlined, only the numbers the step reads are loaded).
    #[inline(always)]
    pub fn lane<T: Storage<f64>>(&self, b: usize) -> Coef<f64, T> {
        Coef {
            h: self.h.lane(b),
            h2: self.h2.lane(b),
            half_h2: self.half_h2.lane(b),
            inv_2h: self.inv_2h.lane(b),
            half_h: self.half_h.lane(b),
            omc: lane_row(&self.omc, b),
            two_omc: lane_row(&self.two_omc, b),
            h2_psi: lane_row(&self.h2_psi, b),
            half_h2_psi: lane_row(&self.half_h2_psi, b),
            phi: lane_row(&self.phi, b),
            inv_2h_chi: lane_row(&self.inv_2h_chi, b),
            h_chi: lane_row(&self.h_chi, b),
            p_from_q: lane_row(&self.p_from_q, b),
            half_h_psi0: lane_row(&self.half_h_psi0, b),
            half_h_psi1: lane_row(&self.half_h_psi1, b),
            phi_is_identity: self.phi_is_identity,
        }
    }
}

impl<L: Real, S: Storage<L>> Weights<L, S> {
    /// Its per-coordinate rows (`omega2`, `modified_p`, `modified_q`).
    pub const ROWS: usize = 3;

    pub fn new<Sh: Shape<S<L> = S>>(
        sh: &Sh,
        omega2: &[f64],
        methods: &[&MethodCoefficients],
    ) -> Self {
        let (ns, n) = (sh.ns(), sh.n());
        let plain_modified = methods
            .iter()
            .all(|m| (ns..sh.n()).all(|i| m.modified_p[i] == 1.0 && m.modified_q[i] == omega2[i]));
        Weights {
            omega2: row::<L, Sh>(sh, methods, &|_| omega2[..n].to_vec()),
            modified_p: row::<L, Sh>(sh, methods, &|m| m.modified_p[..n].to_vec()),
            modified_q: row::<L, Sh>(sh, methods, &|m| m.modified_q[..n].to_vec()),
            plain_modified,
            _lane: std::marker::PhantomData,
        }
    }

    /// Lane b's weights as one trajectory's (see [`Coef::lane`]).
    #[inline(always)]
    pub fn lane<T: Storage<f64>>(&self, b: usize) -> Weights<f64, T> {
        Weights {
            omega2: lane_row(&self.omega2, b),
            modified_p: lane_row(&self.modified_p, b),
            modified_q: lane_row(&self.modified_q, b),
            plain_modified: self.plain_modified,
            _lane: std::marker::PhantomData,
        }
    }
}
