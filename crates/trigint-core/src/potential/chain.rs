//! Long chains: U(q) = Σ_terms Σ_b V((L q)_b), univariate functions V of sparse linear forms.
//!
//! The common potentials of this field have this shape: springs (FPU, Toda, Morse, Lennard-Jones
//! between neighbours) and on-site terms. Each term is a univariate [`Program`] V (with its
//! exact derivative) and a [`LinearMap`] L. An evaluation computes y = L q band by band, runs V
//! and −V' over all springs in one machine-code loop (or, without machine code, interpreted over
//! tiles of springs, each instruction over a whole tile), sums V in spring order into eight
//! partial sums and applies Lᵀ(−V'(y)) to the force.

use super::compiled::{Op, Program, ProgramSpec};
use super::linear::{optional_map, LinearMap};
use super::{Potential, Scratch};
use crate::description::{FromDescription, Value};
use crate::error::{CoreError, CoreResult};
use crate::real::Real;

/// Springs per tile of the univariate evaluation.
const TILE: usize = 128;

/// One term Σ_b V((L q)_b).
#[derive(Debug, Clone)]
pub struct ChainTerm {
    pub map: LinearMap,
    pub v: Program,
}

impl ChainTerm {
    /// V from a one-coordinate tape, applied to the rows of `map`.
    pub fn new(map: LinearMap, v: &ProgramSpec) -> CoreResult<Self> {
        if v.n_inputs != 1 {
            return Err(CoreError::invalid(
                "chain",
                format!("V must be a function of one variable, got {}", v.n_inputs),
            ));
        }
        Ok(ChainTerm {
            v: Program::new(v, None)?,
            map,
        })
    }
}

impl FromDescription for Chain {
    /// `{"kind": "chain", "n", "terms": [{"v": tape, "map"}, …]}`.
    fn from_description(d: &Value) -> CoreResult<Self> {
        let terms = d
            .field("terms")?
            .to_list("terms")?
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let term = |e: CoreError| CoreError::invalid("terms", format!("term {i}: {e}"));
                let t = t.to_dict("terms").map_err(term)?;
                let map = optional_map(t)
                    .and_then(|m| {
                        m.ok_or_else(|| CoreError::invalid("map", "a chain term needs its map"))
                    })
                    .map_err(term)?;
                let v = t.field("v").and_then(|v| v.to_dict("v")).map_err(term)?;
                ChainTerm::new(map, &ProgramSpec::from_description(v).map_err(term)?)
            })
            .collect::<CoreResult<Vec<_>>>()?;
        Chain::new(d.field("n")?.to_usize("n")?, terms)
    }
}

/// U(q) = Σ_terms Σ_b V_term((L_term q)_b).
#[derive(Debug, Clone)]
pub struct Chain {
    n: usize,
    terms: Vec<ChainTerm>,
}

impl Chain {
    pub fn new(n: usize, terms: Vec<ChainTerm>) -> CoreResult<Self> {
        if terms.is_empty() {
            return Err(CoreError::invalid("chain", "needs at least one term"));
        }
        if let Some(t) = terms.iter().find(|t| t.map.cols != n) {
            return Err(CoreError::invalid(
                "chain",
                format!(
                    "a term's linear forms act on {} coordinates, not {n}",
                    t.map.cols
                ),
            ));
        }
        Ok(Chain { n, terms })
    }

    /// A one-term chain: Σ_b V((L q)_b).
    pub fn single(map: LinearMap, v: &ProgramSpec) -> CoreResult<Self> {
        let n = map.cols;
        Chain::new(n, vec![ChainTerm::new(map, v)?])
    }

    /// The tape of y ↦ c·y^k (for tests and the FPU written as a chain).
    pub fn monomial(c: f64, k: i32) -> ProgramSpec {
        ProgramSpec {
            n_inputs: 1,
            ops: vec![Op::Input(0), Op::Powi(0, k), Op::Const(c), Op::Mul(2, 1)],
            output: 3,
        }
    }
}

/// Per term: the linear forms y, V'(y) as forces, V(y); and tile register files of V's codes.
pub struct ChainWorkspace<L> {
    y: Vec<Vec<L>>,
    g: Vec<Vec<L>>,
    values: Vec<Vec<L>>,
    registers: Vec<Vec<Vec<L>>>,
}

impl Potential for Chain {
    type Workspace<L: Real> = ChainWorkspace<L>;
    const SMALL_SHAPES: bool = false;
    // An AVX-512 copy too: no faster than the AVX2 one on an AMD Zen 4 (FPU m = 1000 and Toda
    // m = 3 as chains), 5-10% faster on a Zen 5 (FPU m = 1000 streamed: 1100-1140 against
    // 1197-1213 ns per step); the planner keeps the AVX2 copy where it is faster by more than
    // its margin.
    const AVX512: bool = true;

    fn dim(&self) -> usize {
        self.n
    }

    fn workspace<L: Real>(&self) -> ChainWorkspace<L> {
        ChainWorkspace {
            y: self
                .terms
                .iter()
                .map(|t| vec![L::zero(); t.map.rows])
                .collect(),
            g: self
                .terms
                .iter()
                .map(|t| vec![L::zero(); t.map.rows])
                .collect(),
            values: self
                .terms
                .iter()
                .map(|t| vec![L::zero(); t.map.rows])
                .collect(),
            registers: self
                .terms
                .iter()
                .map(|t| t.v.tile_registers::<L>(TILE))
                .collect(),
        }
    }

    /// In its own copy per instruction set (a kernel of this module), called from the kernels.
    fn force<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        ws: &mut ChainWorkspace<L>,
    ) -> CoreResult<L> {
        crate::isa::run(&mut Evaluation {
            chain: self,
            x,
            force: Some(force),
            with_value,
            ws,
        })
    }

    /// G(x)v = Σ_terms Lᵀ(−V''(Lx) ⊙ Lv), V'' from each term's curvature program.
    fn force_derivative(
        &self,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        ws: &mut ChainWorkspace<f64>,
        s: &mut Scratch,
    ) -> CoreResult<()> {
        if s.registers.len() != self.terms.len() {
            s.registers = self
                .terms
                .iter()
                .map(|t| Ok(t.v.curvature()?.tile_registers::<f64>(TILE)))
                .collect::<CoreResult<_>>()?;
        }
        for (t, term) in self.terms.iter().enumerate() {
            let curvature = term.v.curvature()?;
            let (y, c) = (&mut ws.y[t], &mut ws.g[t]);
            term.map.apply(x, y);
            let w = Scratch::sized(&mut s.a, term.map.rows);
            term.map.apply(v, w);
            curvature.eval_tiles(
                y,
                Some(&mut c[..]),
                false,
                &mut s.registers[t],
                &mut ws.values[t],
                TILE,
            );
            for (cb, wb) in c.iter_mut().zip(w.iter()) {
                *cb *= *wb;
            }
            term.map.apply_transpose(c, out, t > 0);
        }
        Ok(())
    }

    /// As [`force`](Potential::force), without the force.
    fn value<L: Real>(&self, x: &[L], ws: &mut ChainWorkspace<L>) -> CoreResult<L> {
        crate::isa::run(&mut Evaluation {
            chain: self,
            x,
            force: None,
            with_value: true,
            ws,
        })
    }
}

/// One evaluation of a chain at x: U(x) (when `with_value`) and, where `force` is given, the
/// force into it. A kernel of its own, compiled per instruction set once per lane type, rather
/// than inlined into every copy of the stepping loops: the chain's loops (the maps, the
/// univariate tiles, the transposes) were 100 KB in each of the ten copies a bundle's loop has,
/// 2.0 of the stepping loops' 5.7 MB of machine code. A step of a chain (at least 33 springs)
/// is microseconds, so the call is not felt.
struct Evaluation<'a, L: Real> {
    chain: &'a Chain,
    x: &'a [L],
    force: Option<&'a mut [L]>,
    with_value: bool,
    ws: &'a mut ChainWorkspace<L>,
}

impl<L: Real> crate::isa::Kernel for Evaluation<'_, L> {
    type Output = CoreResult<L>;
    // (as the chain's stepping loops, see `Chain`'s `AVX512`)
    const AVX512: bool = true;

    #[inline(always)]
    fn run(&mut self) -> CoreResult<L> {
        let ws = &mut *self.ws;
        let mut value = L::zero();
        for (t, term) in self.chain.terms.iter().enumerate() {
            let y = &mut ws.y[t];
            term.map.apply(self.x, y);
            let Some(force) = self.force.as_deref_mut() else {
                value +=
                    term.v
                        .eval_tiles(y, None, true, &mut ws.registers[t], &mut ws.values[t], TILE);
                continue;
            };
            let g = &mut ws.g[t];
            value += term.v.eval_tiles(
                y,
                Some(g),
                self.with_value,
                &mut ws.registers[t],
                &mut ws.values[t],
                TILE,
            );
            // The first term writes the force, the others add to it.
            term.map.apply_transpose(g, force, t > 0);
        }
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::potential::Fpu;

    /// The FPU's springs in its modal variables.
    fn fpu_map(m: usize) -> LinearMap {
        let (ptr, cols, vals) = crate::fixtures::fpu_springs(m);
        LinearMap::from_csr(m + 1, 2 * m, &ptr, &cols, &vals).unwrap()
    }

    #[test]
    fn fpu_as_a_chain_matches_the_native_chain() {
        for m in [3, 200, 1000] {
            let chain = Chain::single(fpu_map(m), &Chain::monomial(0.25, 4)).unwrap();
            let fpu = Fpu::new(m).unwrap();
            let x: Vec<f64> = (0..2 * m).map(|i| 0.4 * (i as f64 * 0.61).sin()).collect();
            let (mut f1, mut f2) = (vec![0.0; 2 * m], vec![0.0; 2 * m]);
            let u1 = chain
                .force(&x, &mut f1, true, &mut chain.workspace())
                .unwrap();
            let u2 = fpu.force(&x, &mut f2, true, &mut fpu.workspace()).unwrap();
            assert!((u1 - u2).abs() <= 1e-14 * u2.abs(), "m={m}: {u1} {u2}");
            for i in 0..2 * m {
                assert!((f1[i] - f2[i]).abs() <= 1e-15, "m={m} i={i}");
            }
            let v = chain.value(&x, &mut chain.workspace()).unwrap();
            assert_eq!(v.to_bits(), u1.to_bits());
        }
    }
}

#[cfg(test)]
mod machine_code {
    use super::*;
    use crate::real::Lanes;

    /// V(y) = exp(−y²) cos(3y) + |y|^1.5 sign(y) + y⁴/4 over springs y_b = x_b − x_{b+1}.
    fn chain(native: bool) -> Chain {
        let v = ProgramSpec {
            n_inputs: 1,
            ops: vec![
                Op::Input(0),
                Op::Powi(0, 2),
                Op::Neg(1),
                Op::Exp(2),
                Op::Const(3.0),
                Op::Mul(4, 0),
                Op::Cos(5),
                Op::Mul(3, 6),
                Op::Abs(0),
                Op::Powf(8, 1.5),
                Op::Sign(0),
                Op::Mul(9, 10),
                Op::Powi(0, 4),
                Op::Const(0.25),
                Op::Mul(13, 12),
                Op::Add(7, 11),
                Op::Add(15, 14),
            ],
            output: 16,
        };
        let n = 12;
        let (ptr, cols, vals): (Vec<usize>, Vec<usize>, Vec<f64>) = (
            (0..n).map(|r| 2 * r).collect(),
            (0..n - 1).flat_map(|r| [r, r + 1]).collect(),
            (0..n - 1).flat_map(|_| [1.0, -1.0]).collect(),
        );
        let map = LinearMap::from_csr(n - 1, n, &ptr, &cols, &vals).unwrap();
        let mut term = ChainTerm::new(map, &v).unwrap();
        if !native {
            term.v = term.v.interpreted();
        }
        Chain::new(n, vec![term]).unwrap()
    }

    #[test]
    fn springs_through_machine_code_have_the_interpreters_bits() {
        // 11 springs: an odd count, so the last spring of one trajectory runs alone.
        let (native, plain) = (chain(true), chain(false));
        let x: Vec<f64> = (0..12).map(|i| 1.7 * (i as f64 * 0.83).sin()).collect();
        for with_value in [true, false] {
            let (mut fn_, mut fp) = (vec![0.0; 12], vec![0.0; 12]);
            let un = native
                .force(&x, &mut fn_, with_value, &mut native.workspace())
                .unwrap();
            let up = plain
                .force(&x, &mut fp, with_value, &mut plain.workspace())
                .unwrap();
            assert_eq!(un.to_bits(), up.to_bits());
            for i in 0..12 {
                assert_eq!(fn_[i].to_bits(), fp[i].to_bits(), "force {i}");
            }
        }
        let v = native.value(&x, &mut native.workspace()).unwrap();
        let vp = plain.value(&x, &mut plain.workspace()).unwrap();
        assert_eq!(v.to_bits(), vp.to_bits());
        // Lanes: each lane equals its own trajectory.
        let xl: Vec<Lanes<8>> = (0..12)
            .map(|i| Lanes(std::array::from_fn(|b| x[i] * (1.0 + 0.1 * b as f64))))
            .collect();
        let mut fl = vec![Lanes::<8>::zero(); 12];
        let ul = native
            .force(&xl, &mut fl, true, &mut native.workspace())
            .unwrap();
        for b in 0..8 {
            let xb: Vec<f64> = xl.iter().map(|v| v.0[b]).collect();
            let mut fb = vec![0.0; 12];
            let ub = plain
                .force(&xb, &mut fb, true, &mut plain.workspace())
                .unwrap();
            assert_eq!(ul.0[b].to_bits(), ub.to_bits(), "lane {b}");
            for i in 0..12 {
                assert_eq!(fl[i].0[b].to_bits(), fb[i].to_bits(), "lane {b}, force {i}");
            }
        }
    }
}
