//! The [`Program`] potential: U and its force as three scheduled codes (U with g, g alone, U
//! alone), their machine code compiled at first use per walk, the interpreter behind it.

use std::sync::OnceLock;

use super::code::Code;
use super::graph::Graph;
use super::jit::{self, Compiled, Walk};
use super::ops::{Binary, Op, ProgramSpec, Unary};
use crate::description::{FromDescription, Value};
use crate::error::{CoreError, CoreResult};
use crate::potential::linear::{optional_map, LinearMap};
use crate::potential::Potential;
use crate::real::Real;
use crate::sum::Sum8;

#[derive(Debug, Clone)]
pub struct Program {
    pub(super) n: usize,
    /// U and g together, g alone, U alone.
    pub(super) full: Code,
    pub(super) force_only: Code,
    pub(super) value_only: Code,
    /// The three codes as machine code, each compiled at its first use (≈ 1 ms): for one
    /// trajectory; for bundles of 2, 4, …, 256 lanes (index log₂ W − 1); and, for a
    /// one-coordinate program, over many arguments (a chain's springs). None inside: that
    /// walk is interpreted, with the same bits.
    machine: Box<MachineCode>,
}

#[derive(Debug, Clone, Default)]
struct MachineCode {
    one: OnceLock<Option<Vec<Compiled>>>,
    bundles: [OnceLock<Option<Vec<Compiled>>>; BUNDLE_WIDTHS],
    over_arguments: OnceLock<Option<Vec<Compiled>>>,
}

/// Bundle widths with machine code: 2¹ … 2⁸ (= MAX_LANES) lanes.
const BUNDLE_WIDTHS: usize = 8;

/// Register files of the three codes, constants in place.
pub struct ProgramWorkspace<L> {
    full: Vec<L>,
    force_only: Vec<L>,
    value_only: Vec<L>,
}

impl FromDescription for Program {
    /// `{"kind": "program", "n", "ops", "output", "map"?}`: a tape (see
    /// [`ProgramSpec::from_description`]) and the linear map its inputs are read through.
    fn from_description(d: &Value) -> CoreResult<Self> {
        Program::new(
            &ProgramSpec::from_description(d)?,
            optional_map(d)?.as_ref(),
        )
    }
}

impl Program {
    /// Compiles a tape. With `inputs`, the tape's coordinates are x = T y for the sparse map T
    /// (rows: the tape's coordinates, columns: the program's), e.g. the modal coordinates of a
    /// stiffness matrix; the program then acts on y and returns Tᵀ(−∇U).
    pub fn new(spec: &ProgramSpec, inputs: Option<&LinearMap>) -> CoreResult<Self> {
        let bad = |reason: String| Err(CoreError::invalid("program", reason));
        if spec.n_inputs == 0 {
            return bad("needs at least one coordinate".into());
        }
        if spec.ops.is_empty() || spec.output >= spec.ops.len() {
            return bad(format!(
                "output {} is not one of the {} operations",
                spec.output,
                spec.ops.len()
            ));
        }
        let n = match inputs {
            None => spec.n_inputs,
            Some(t) => {
                if t.rows != spec.n_inputs {
                    return bad(format!(
                        "the coordinate map has {} rows for {} coordinates",
                        t.rows, spec.n_inputs
                    ));
                }
                t.cols
            }
        };
        let mut g = Graph::default();
        // x_i as nodes: the inputs themselves, or Σ_j T_ij y_j in the map's order.
        let coordinate: Vec<u32> = match inputs {
            None => (0..n).map(|i| g.input(i)).collect(),
            Some(t) => {
                let mut x: Vec<Option<u32>> = vec![None; t.rows];
                for (r, c, v) in t.entries() {
                    let y = g.input(c);
                    let cv = g.constant(v);
                    let term = g.mul(cv, y);
                    x[r] = Some(match x[r] {
                        None => term,
                        Some(prev) => g.add(prev, term),
                    });
                }
                x.into_iter()
                    .map(|e| e.unwrap_or_else(|| g.constant(0.0)))
                    .collect()
            }
        };
        let mut ids: Vec<u32> = Vec::with_capacity(spec.ops.len());
        for (k, op) in spec.ops.iter().enumerate() {
            let arg = |a: usize| -> CoreResult<u32> {
                if a < k {
                    Ok(ids[a])
                } else {
                    Err(CoreError::invalid(
                        "program",
                        format!("operation {k} reads operation {a}, which does not come before it"),
                    ))
                }
            };
            let id = match *op {
                Op::Input(i) => {
                    if i >= spec.n_inputs {
                        return bad(format!(
                            "operation {k} reads coordinate {i} of {}",
                            spec.n_inputs
                        ));
                    }
                    coordinate[i]
                }
                Op::Const(c) => {
                    if !c.is_finite() {
                        return bad(format!("operation {k} is the non-finite constant {c}"));
                    }
                    g.constant(c)
                }
                Op::Add(a, b) => g.binary(Binary::Add, arg(a)?, arg(b)?),
                Op::Sub(a, b) => g.binary(Binary::Sub, arg(a)?, arg(b)?),
                Op::Mul(a, b) => g.binary(Binary::Mul, arg(a)?, arg(b)?),
                Op::Div(a, b) => g.binary(Binary::Div, arg(a)?, arg(b)?),
                Op::Neg(a) => g.unary(Unary::Neg, arg(a)?),
                Op::Powi(a, e) => g.powi(arg(a)?, e),
                Op::Powf(a, c) => {
                    if !c.is_finite() {
                        return bad(format!("operation {k} has the exponent {c}"));
                    }
                    g.powf(arg(a)?, c)
                }
                Op::Sqrt(a) => g.unary(Unary::Sqrt, arg(a)?),
                Op::Exp(a) => g.unary(Unary::Exp, arg(a)?),
                Op::Log(a) => g.unary(Unary::Log, arg(a)?),
                Op::Sin(a) => g.unary(Unary::Sin, arg(a)?),
                Op::Cos(a) => g.unary(Unary::Cos, arg(a)?),
                Op::Tan(a) => g.unary(Unary::Tan, arg(a)?),
                Op::Sinh(a) => g.unary(Unary::Sinh, arg(a)?),
                Op::Cosh(a) => g.unary(Unary::Cosh, arg(a)?),
                Op::Tanh(a) => g.unary(Unary::Tanh, arg(a)?),
                Op::Abs(a) => g.unary(Unary::Abs, arg(a)?),
                Op::Sign(a) => g.unary(Unary::Sign, arg(a)?),
            };
            ids.push(id);
        }
        let value = ids[spec.output];
        let grad = g.adjoints(value, n, -1.0);
        let force: Vec<u32> = grad
            .into_iter()
            .map(|a| a.unwrap_or_else(|| g.constant(0.0)))
            .collect();
        let roots: Vec<u32> = std::iter::once(value)
            .chain(force.iter().copied())
            .collect();
        let (g, roots) = g.lower_powers(&roots);
        let (value, force) = (roots[0], &roots[1..]);
        let (full, force_only, value_only) = (
            Code::schedule(&g, n, Some(value), Some(force)),
            Code::schedule(&g, n, None, Some(force)),
            Code::schedule(&g, n, Some(value), None),
        );
        Ok(Program {
            n,
            full,
            force_only,
            value_only,
            machine: Box::default(),
        })
    }

    /// The same program without machine code: every evaluation interpreted (for comparing the
    /// two, and where compiling is not wanted).
    pub fn interpreted(self) -> Self {
        Program {
            machine: Box::new(MachineCode {
                one: OnceLock::from(None),
                bundles: std::array::from_fn(|_| OnceLock::from(None)),
                over_arguments: OnceLock::from(None),
            }),
            ..self
        }
    }

    fn compile(&self, walk: Walk) -> Option<Vec<Compiled>> {
        jit::compile(&[&self.full, &self.force_only, &self.value_only], walk)
    }

    /// The machine code of the three codes for one trajectory, compiled on first use (None:
    /// interpreted).
    fn machine_code(&self) -> Option<&[Compiled]> {
        self.machine
            .one
            .get_or_init(|| self.compile(Walk::One))
            .as_deref()
    }

    /// The machine code for bundles of `width` lanes (a power of two from 2 to 256).
    pub(super) fn bundle_code(&self, width: usize) -> Option<&[Compiled]> {
        if !width.is_power_of_two() || width < 2 {
            return None;
        }
        self.machine
            .bundles
            .get(width.trailing_zeros() as usize - 1)?
            .get_or_init(|| self.compile(Walk::Pairs { stride: width }))
            .as_deref()
    }

    /// The machine code of a one-coordinate program over many arguments.
    fn argument_code(&self) -> Option<&[Compiled]> {
        if self.n != 1 {
            return None;
        }
        self.machine
            .over_arguments
            .get_or_init(|| self.compile(Walk::Pairs { stride: 0 }))
            .as_deref()
    }

    /// Whether one-trajectory evaluations run machine code (compiling it if not yet done).
    pub fn is_native(&self) -> bool {
        self.machine_code().is_some()
    }

    /// Register files for [`eval_tiles`](Self::eval_tiles): one per code.
    pub(crate) fn tile_registers<L: Real>(&self, tile: usize) -> Vec<Vec<L>> {
        [&self.full, &self.force_only, &self.value_only]
            .iter()
            .map(|c| c.tile_registers(tile))
            .collect()
    }

    /// A one-coordinate program over many arguments: its force (−V') at each `y[b]` into `g`,
    /// and Σ_b V(y[b]) in the kernels' fixed summation order when `with_value`. Inlined into
    /// the kernel copies (an outlined copy is compiled for the baseline instruction set only).
    #[inline(always)]
    pub(crate) fn eval_tiles<L: Real>(
        &self,
        y: &[L],
        mut g: Option<&mut [L]>,
        with_value: bool,
        registers: &mut [Vec<L>],
        values: &mut [L],
        tile: usize,
    ) -> L {
        let which = match (g.is_some(), with_value) {
            (true, true) => 0,
            (true, false) => 1,
            _ => 2,
        };
        if let Some(parts) = self.eval_arguments_native(which, y, g.as_deref_mut(), values) {
            return parts.total(y.len());
        }
        let code = [&self.full, &self.force_only, &self.value_only][which];
        let r = &mut registers[which];
        // Σ_b V(y_b) in the fixed order of the kernels' sums: term b into partial sum b mod 8,
        // the partial sums combined by a fixed tree (eight independent chains, not one).
        debug_assert!(tile.is_multiple_of(8));
        let mut parts = Sum8::new();
        for start in (0..y.len()).step_by(tile) {
            let width = tile.min(y.len() - start);
            r[..width].copy_from_slice(&y[start..start + width]);
            code.run_tile(r, tile, width);
            if let (Some(g), Some(slots)) = (g.as_deref_mut(), &code.force) {
                let s = slots[0] as usize * tile;
                g[start..start + width].copy_from_slice(&r[s..s + width]);
            }
            if let (true, Some(s)) = (with_value, code.value) {
                parts.add_slice(&r[s as usize * tile..][..width], start > 0);
            }
        }
        parts.total(y.len())
    }

    /// [`eval_tiles`](Self::eval_tiles) through machine code over all arguments at once (the
    /// last one alone when their number of doubles is odd): V into `values`, −V' into `g`;
    /// returns the partial sums of V. None when there is no machine code.
    #[inline(always)]
    fn eval_arguments_native<L: Real>(
        &self,
        which: usize,
        y: &[L],
        g: Option<&mut [L]>,
        values: &mut [L],
    ) -> Option<Sum8<L>> {
        let yf = L::as_f64s(y)?;
        let pairs = &self.argument_code()?[which];
        let vf = L::as_f64s_mut(&mut values[..y.len()])?;
        let mut none: [f64; 0] = [];
        let gf = match g {
            Some(g) => L::as_f64s_mut(&mut g[..y.len()])?,
            None => &mut none[..],
        };
        let (n, even) = (yf.len(), yf.len() & !1);
        pairs.call_pairs(yf, gf, vf, even);
        if n > even {
            // Compiled only for an odd count (bundles of 8 lanes never need it); where it
            // compiles, the pairs did too.
            let one = &self.machine_code()?[which];
            let tail = if gf.is_empty() { gf } else { &mut gf[even..] };
            one.call(&yf[even..], tail, &mut vf[even]);
        }
        let mut parts = Sum8::new();
        if which != 1 {
            parts.add_slice(&values[..y.len()], false);
        }
        Some(parts)
    }

    /// The code that computes U and g (for inspection, tests and code generation).
    pub fn full_code(&self) -> &Code {
        &self.full
    }

    /// Number of instructions of the force-only code.
    pub fn force_instructions(&self) -> usize {
        self.force_only.instrs.len()
    }

    /// One trajectory or one bundle through machine code `which` (0: U and g, 1: g, 2: U),
    /// reading x and writing the force in place; None when there is none for these numbers.
    #[inline(always)]
    fn eval_native<L: Real>(&self, which: usize, x: &[L], force: Option<&mut [L]>) -> Option<L> {
        let xf = L::as_f64s(&x[..self.n])?;
        let mut none: [f64; 0] = [];
        let gf = match force {
            Some(g) => L::as_f64s_mut(&mut g[..self.n])?,
            None => &mut none[..],
        };
        if L::LANES == 1 {
            let mut u = 0.0;
            self.machine_code()?[which].call(xf, gf, &mut u);
            return Some(L::splat(u));
        }
        let f = &self.bundle_code(L::LANES)?[which];
        let mut u = L::zero();
        f.call_pairs(
            xf,
            gf,
            L::as_f64s_mut(std::slice::from_mut(&mut u))?,
            L::LANES,
        );
        Some(u)
    }

    #[inline(always)]
    fn eval<L: Real>(code: &Code, r: &mut [L], x: &[L], force: Option<&mut [L]>) -> L {
        r[..code.n_inputs].copy_from_slice(&x[..code.n_inputs]);
        code.run(r);
        if let (Some(f), Some(slots)) = (force, &code.force) {
            for (fi, &s) in f.iter_mut().zip(slots) {
                *fi = r[s as usize];
            }
        }
        code.value.map_or(L::zero(), |s| r[s as usize])
    }
}

impl Potential for Program {
    type Workspace<L: Real> = ProgramWorkspace<L>;
    // The force is a call to machine code compiled for 128-bit vectors: an AVX-512 copy of the
    // loop around it is no faster than the AVX2 one (FPU m = 3 as an expression: one trajectory
    // 18.9 against 18.7 ns, 1000 of them 14.7 against 14.1 ns per trajectory-step).
    const AVX512: bool = false;

    fn dim(&self) -> usize {
        self.n
    }

    fn workspace<L: Real>(&self) -> ProgramWorkspace<L> {
        ProgramWorkspace {
            full: self.full.registers(),
            force_only: self.force_only.registers(),
            value_only: self.value_only.registers(),
        }
    }

    #[inline(always)]
    fn force<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        ws: &mut ProgramWorkspace<L>,
    ) -> CoreResult<L> {
        if let Some(u) = self.eval_native(if with_value { 0 } else { 1 }, x, Some(force)) {
            return Ok(u);
        }
        Ok(if with_value {
            Self::eval(&self.full, &mut ws.full, x, Some(force))
        } else {
            Self::eval(&self.force_only, &mut ws.force_only, x, Some(force))
        })
    }

    #[inline(always)]
    fn value<L: Real>(&self, x: &[L], ws: &mut ProgramWorkspace<L>) -> CoreResult<L> {
        if let Some(u) = self.eval_native(2, x, None) {
            return Ok(u);
        }
        Ok(Self::eval(&self.value_only, &mut ws.value_only, x, None))
    }
}
