//! Potentials U(q) with their forces g(q) = −∇U(q), evaluated on one trajectory or on a bundle
//! of lanes by the same code.
//!
//! Kinds: [`Fpu`] (the FPU chain, written out in Rust: the reference), [`Program`] (any
//! expression, compiled from a tape with its exact gradient), [`Chain`] (Σ_b V_b((Lq)_b):
//! univariate programs of sparse linear forms, for long chains), [`Wave`] (mean_x V(u) of a
//! field in real Fourier coordinates, through two FFTs). The binding adds Python
//! callables. The kernels are generic over [`Potential`]; each kind is one type, so the force is
//! inlined into the step loop wherever the kind allows it.

mod chain;
mod compiled;
mod fpu;
mod linear;
mod native;
mod wave;

pub use chain::{Chain, ChainTerm};
pub use compiled::{Op, Program, ProgramSpec};
pub use fpu::Fpu;
pub use linear::{LinearMap, Segment, SegmentCoef};
pub use native::Native;
pub use wave::Wave;

use crate::error::{CoreError, CoreResult};
use crate::real::Real;

/// Scratch buffers of [`Potential::force_derivative`], sized by the potential at first use and
/// reused between calls.
#[derive(Default)]
pub struct Scratch {
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    pub c: Vec<f64>,
    /// Register files of programs evaluated over tiles (one list per term).
    pub registers: Vec<Vec<Vec<f64>>>,
}

impl Scratch {
    /// `v` resized to `n` (zeros where it grew).
    pub fn sized(v: &mut Vec<f64>, n: usize) -> &mut [f64] {
        if v.len() != n {
            v.resize(n, 0.0);
        }
        &mut v[..n]
    }
}

/// A potential U: ℝⁿ → ℝ with its force g = −∇U, on numbers of any lane width.
pub trait Potential: Sync {
    /// Scratch space an evaluation needs, made once per run (or per bundle) and reused.
    type Workspace<L: Real>: Send;

    /// Compiled code that gains from the compile-time shapes and the per-CPU copies of the
    /// kernels (false for Python callbacks, whose cost is the call: they take the run-time
    /// shape and one copy, which keeps the build small).
    const SPECIALIZE: bool = true;

    /// Worth an AVX-512 copy of the kernels besides the AVX2 one (false where it measured no
    /// faster than the AVX2 copy: compiled programs, whose force is a call to machine code, and
    /// wave equations, whose step is two FFTs that choose their own instructions). Each
    /// copy is the whole inlined tight loop to optimize, per shape, lane type and variant.
    const AVX512: bool = Self::SPECIALIZE;

    /// Worth the compile-time shapes of small problems (false for chains, which are for long
    /// ones: fewer copies of the kernels to build).
    const SMALL_SHAPES: bool = Self::SPECIALIZE;

    /// Whether this kind has an [`inline_force`](Self::inline_force), which the kernels of
    /// compile-time shapes then use: the state stays in registers (a call that may take it by
    /// reference puts it in memory), and a bundle's steps run as a loop over its lanes that the
    /// compiler vectorizes (see `run::lanes`).
    const INLINE_FORCE: bool = false;

    /// Whether a bundle's lane loop (see `run::lanes`) may take this kind's force as a call on
    /// the bundle's rows, made before the lanes' steps: a kind without an inline force whose
    /// [`force`](Self::force) and [`value`](Self::value) never fail (compiled programs). The
    /// rest of the step then runs lane by lane as for an inline force, not in the bundle's own
    /// arithmetic.
    const ROW_FORCE: bool = false;

    /// Whether [`inline_force`](Self::inline_force) serves this potential as it is configured.
    fn inline_force_ready(&self) -> bool {
        false
    }

    /// g(x) into `f`, and U(x) when `with_value`: [`force`](Self::force)'s numbers, bit for
    /// bit (and with `with_value`, the U of [`value`](Self::value)), written as arithmetic that
    /// inlines, with no call and no branch on the potential's settings. Called only when
    /// [`inline_force_ready`](Self::inline_force_ready).
    #[inline(always)]
    fn inline_force<L: Real>(&self, _x: &[L], _f: &mut [L], _with_value: bool) -> L {
        unreachable!("inline_force of a potential without one")
    }

    /// G(x)v = −∇²U(x) v into `out` as arithmetic that inlines: the numbers of
    /// [`force_derivative`](Self::force_derivative), bit for bit, for the tangent's lane loop
    /// (`run::tangent_lanes`). Called only when [`inline_force_ready`](Self::inline_force_ready).
    #[inline(always)]
    fn inline_force_derivative<L: Real>(&self, _x: &[L], _v: &[L], _out: &mut [L]) {
        unreachable!("inline_force_derivative of a potential without one")
    }

    /// Number of coordinates.
    fn dim(&self) -> usize;

    fn workspace<L: Real>(&self) -> Self::Workspace<L>;

    /// Writes g(x) = −∇U(x) into `force` and returns U(x) when `with_value` (otherwise any
    /// number, unused). The same operations in the same order for every lane width.
    fn force<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        ws: &mut Self::Workspace<L>,
    ) -> CoreResult<L>;

    /// [`force`](Self::force) with its return value written into `u`: the same numbers. A kind
    /// whose U comes from machine code writes it there in place (compiled programs): a bundle's
    /// U returned by value went through a chain of 64-byte copies.
    #[inline(always)]
    fn force_into<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        ws: &mut Self::Workspace<L>,
        u: &mut L,
    ) -> CoreResult<()> {
        *u = self.force(x, force, with_value, ws)?;
        Ok(())
    }

    /// [`value`](Self::value) written into `u` (see [`force_into`](Self::force_into)).
    #[inline(always)]
    fn value_into<L: Real>(
        &self,
        x: &[L],
        ws: &mut Self::Workspace<L>,
        u: &mut L,
    ) -> CoreResult<()> {
        *u = self.value(x, ws)?;
        Ok(())
    }

    /// The point of the last [`Potential::force`] evaluation in the user's coordinates, where
    /// the potential made them on the way: a wave equation's grid values u = S x of one
    /// trajectory. A run keeps a sample's q from here (the potential evaluated at q, φ = 1)
    /// rather than transforming it back: the same transform of the same numbers, so the same
    /// bits, and on a 2¹⁶-point grid 0.1 ms a sample saved. None: no such values.
    fn evaluated_in_user_coordinates<'w, L: Real>(
        &self,
        _ws: &'w Self::Workspace<L>,
    ) -> Option<&'w [f64]> {
        None
    }

    /// U(x) alone.
    fn value<L: Real>(&self, x: &[L], ws: &mut Self::Workspace<L>) -> CoreResult<L>;

    /// The derivative of the force along v, G(x)v = d/dε g(x + εv)|₀ = −∇²U(x) v, into `out`:
    /// what the tangent step applies to a deviation (see [`crate::tangent`]). Exact for every
    /// native kind (FPU and stiffness maps analytically, compiled programs, chains and wave
    /// equations through the second derivative derived from the tape). `scratch` is reused
    /// between calls. The default says that this potential has none.
    fn force_derivative(
        &self,
        _x: &[f64],
        _v: &[f64],
        _out: &mut [f64],
        _ws: &mut Self::Workspace<f64>,
        _scratch: &mut Scratch,
    ) -> CoreResult<()> {
        Err(CoreError::invalid(
            "potential",
            "this potential has no second derivatives (the tangent map needs G(x)v = -Hess U(x) v)",
        ))
    }

    /// [`force_derivative`](Self::force_derivative) at the x of the [`force`](Self::force)
    /// just evaluated, with `evaluated` what
    /// [`evaluated_in_user_coordinates`](Self::evaluated_in_user_coordinates) gave after it: a
    /// potential that made them there (a wave's grid values u = S x) starts from them instead
    /// of making them again (the same transform of the same numbers, so the same bits). The
    /// caller guarantees that the last evaluation in that workspace was `force` at this x (not
    /// an inline force, which leaves no values, nor a `value` after it). The default ignores
    /// them; it is inlined, so that the potentials without an override keep their
    /// `force_derivative` inlined at the call site.
    #[inline(always)]
    fn force_derivative_after_force(
        &self,
        _evaluated: Option<&[f64]>,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        ws: &mut Self::Workspace<f64>,
        scratch: &mut Scratch,
    ) -> CoreResult<()> {
        self.force_derivative(x, v, out, ws, scratch)
    }

    /// Checks that `n` coordinates fit this potential.
    fn check_dim(&self, n: usize) -> CoreResult<()> {
        if n == self.dim() {
            Ok(())
        } else {
            Err(CoreError::DimensionMismatch {
                expected: self.dim(),
                got: n,
            })
        }
    }
}
