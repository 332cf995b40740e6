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
use crate::potential::{Potential, Scratch};
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
    /// The tape and input map it was compiled from (None for a derived program), from which
    /// its second derivatives are derived when first asked for.
    source: Option<std::sync::Arc<(ProgramSpec, Option<LinearMap>)>>,
    derived: Box<Derived>,
}

/// Programs derived from a program's tape, each built at its first use.
#[derive(Debug, Clone, Default)]
struct Derived {
    tangent: OnceLock<Result<Box<Program>, String>>,
    curvature: OnceLock<Result<Box<Program>, String>>,
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
        let (mut g, value, n) = Self::graph(spec, inputs)?;
        let grad = g.adjoints(value, n, -1.0);
        let force: Vec<u32> = grad
            .into_iter()
            .map(|a| a.unwrap_or_else(|| g.constant(0.0)))
            .collect();
        let mut program = Self::from_roots(g, n, value, &force);
        program.source = Some(std::sync::Arc::new((spec.clone(), inputs.cloned())));
        Ok(program)
    }

    /// The program's tangent: a program of 2n inputs (x, v) whose value is W = ∇U(x)·v and whose
    /// force −∇W is (G(x)v, g(x)), with G = −∇²U: the Hessian–vector product, exact, derived by
    /// differentiating the adjoint program once more (forward over reverse, as a graph).
    fn tangent_of(spec: &ProgramSpec, inputs: Option<&LinearMap>) -> CoreResult<Self> {
        let (mut g, value, n) = Self::graph(spec, inputs)?;
        let grad = g.adjoints(value, n, 1.0);
        let mut w = g.constant(0.0);
        for (i, d) in grad.into_iter().enumerate() {
            if let Some(d) = d {
                let v = g.input(n + i);
                let term = g.mul(d, v);
                w = g.add(w, term);
            }
        }
        let force: Vec<u32> = g
            .adjoints(w, 2 * n, -1.0)
            .into_iter()
            .map(|a| a.unwrap_or_else(|| g.constant(0.0)))
            .collect();
        Ok(Self::from_roots(g, 2 * n, w, &force))
    }

    /// For a program of one variable: a program whose value is U'(y) and whose force is
    /// −U''(y), so that its evaluation over many arguments gives the curvature at each.
    fn curvature_of(spec: &ProgramSpec) -> CoreResult<Self> {
        let (mut g, value, n) = Self::graph(spec, None)?;
        if n != 1 {
            return Err(CoreError::invalid(
                "program",
                format!("a curvature program needs one variable, got {n}"),
            ));
        }
        let slope = g.adjoints(value, 1, 1.0)[0].unwrap_or_else(|| g.constant(0.0));
        let bend = g.adjoints(slope, 1, -1.0)[0].unwrap_or_else(|| g.constant(0.0));
        Ok(Self::from_roots(g, 1, slope, &[bend]))
    }

    /// The hash-consed graph of a tape read through `inputs`, its output node and the number
    /// of the program's coordinates.
    fn graph(spec: &ProgramSpec, inputs: Option<&LinearMap>) -> CoreResult<(Graph, u32, usize)> {
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
        Ok((g, ids[spec.output], n))
    }

    /// A program from its graph: `value` and the `force` nodes scheduled as three codes.
    fn from_roots(g: Graph, n: usize, value: u32, force: &[u32]) -> Self {
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
        Program {
            n,
            full,
            force_only,
            value_only,
            machine: Box::default(),
            source: None,
            derived: Box::default(),
        }
    }

    /// The tangent program ([`tangent_of`](Self::tangent_of)), built at first use.
    pub(crate) fn tangent(&self) -> CoreResult<&Program> {
        self.derived_program(&self.derived.tangent, |spec, map| {
            Self::tangent_of(spec, map)
        })
    }

    /// The curvature program of a one-variable program ([`curvature_of`](Self::curvature_of)),
    /// built at first use.
    pub(crate) fn curvature(&self) -> CoreResult<&Program> {
        self.derived_program(&self.derived.curvature, |spec, _| Self::curvature_of(spec))
    }

    fn derived_program<'s>(
        &'s self,
        cell: &'s OnceLock<Result<Box<Program>, String>>,
        make: impl FnOnce(&ProgramSpec, Option<&LinearMap>) -> CoreResult<Program>,
    ) -> CoreResult<&'s Program> {
        cell.get_or_init(|| match &self.source {
            Some(src) => make(&src.0, src.1.as_ref())
                .map(Box::new)
                .map_err(|e| e.to_string()),
            None => Err("a derived program has no second derivatives of its own".into()),
        })
        .as_deref()
        .map_err(|e| CoreError::invalid("program", e.clone()))
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
    /// reading x and writing the force in place and U into `u` (left alone by code 1); None
    /// when there is no machine code for these numbers.
    ///
    /// U is written where the caller keeps it, not returned: a bundle's U handed back through
    /// the `Option` and `Result` around it was four 64-byte copies, each read back at once, and
    /// the first read (one 64-byte load of what the code stored 16 bytes at a time) cannot be
    /// forwarded from the stores: half the lane loop's samples for FPU m = 3 as an expression.
    #[inline(always)]
    fn eval_native<L: Real>(
        &self,
        which: usize,
        x: &[L],
        force: Option<&mut [L]>,
        u: &mut L,
    ) -> Option<()> {
        let xf = L::as_f64s(&x[..self.n])?;
        let mut none: [f64; 0] = [];
        let gf = match force {
            Some(g) => L::as_f64s_mut(&mut g[..self.n])?,
            None => &mut none[..],
        };
        if L::LANES == 1 {
            let mut one = 0.0;
            self.machine_code()?[which].call(xf, gf, &mut one);
            if which != 1 {
                *u = L::splat(one);
            }
            return Some(());
        }
        let f = &self.bundle_code(L::LANES)?[which];
        f.call_pairs(xf, gf, L::as_f64s_mut(std::slice::from_mut(u))?, L::LANES);
        Some(())
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
    // 18.9 against 18.7 ns, 1000 of them 14.7 against 14.1 ns per trajectory-step). The lane
    // loop of ensembles (`run::lanes`, with a copy per instruction set for every potential) is:
    // 3.32 against 3.70–3.84 ns per trajectory-step (AMD Zen 5).
    const AVX512: bool = false;
    // `force` and `value` return Ok on every path (machine code or the interpreter).
    const ROW_FORCE: bool = true;

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
        let mut u = L::zero();
        self.force_into(x, force, with_value, ws, &mut u)?;
        Ok(u)
    }

    #[inline(always)]
    fn force_into<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        ws: &mut ProgramWorkspace<L>,
        u: &mut L,
    ) -> CoreResult<()> {
        if with_value {
            if self.eval_native(0, x, Some(&mut *force), u).is_none() {
                *u = Self::eval(&self.full, &mut ws.full, x, Some(force));
            }
        } else {
            // (the force-only code computes no U: zero, on both paths)
            let mut unused = L::zero();
            if self
                .eval_native(1, x, Some(&mut *force), &mut unused)
                .is_none()
            {
                Self::eval(&self.force_only, &mut ws.force_only, x, Some(force));
            }
            *u = L::zero();
        }
        Ok(())
    }

    fn force_derivative(
        &self,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        _ws: &mut ProgramWorkspace<f64>,
        s: &mut Scratch,
    ) -> CoreResult<()> {
        let t = self.tangent()?;
        let n = self.n;
        let input = Scratch::sized(&mut s.a, 2 * n);
        input[..n].copy_from_slice(&x[..n]);
        input[n..].copy_from_slice(&v[..n]);
        let both = Scratch::sized(&mut s.b, 2 * n);
        let mut unused = 0.0;
        if t.eval_native(1, input, Some(&mut *both), &mut unused)
            .is_none()
        {
            if s.registers.is_empty() {
                s.registers.push(vec![t.force_only.registers()]);
            }
            Self::eval(
                &t.force_only,
                &mut s.registers[0][0],
                input,
                Some(&mut *both),
            );
        }
        out[..n].copy_from_slice(&both[..n]);
        Ok(())
    }

    #[inline(always)]
    fn value<L: Real>(&self, x: &[L], ws: &mut ProgramWorkspace<L>) -> CoreResult<L> {
        let mut u = L::zero();
        self.value_into(x, ws, &mut u)?;
        Ok(u)
    }

    #[inline(always)]
    fn value_into<L: Real>(
        &self,
        x: &[L],
        ws: &mut ProgramWorkspace<L>,
        u: &mut L,
    ) -> CoreResult<()> {
        if self.eval_native(2, x, None, u).is_none() {
            *u = Self::eval(&self.value_only, &mut ws.value_only, x, None);
        }
        Ok(())
    }
}
