//! Straight-line codes scheduled from the graph, and their interpreter (one evaluation, or a
//! tile of many evaluations at once).

use std::collections::HashMap;

use super::graph::{Graph, Node};
use super::libm::sin_cos_lanes;
use super::ops::{Binary, Unary};
use crate::real::Real;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    Bin(Binary, u32, u32),
    Un(Unary, u32),
    Powf(u32, f64),
    /// sin a into this slot and cos a into the next one, with one libm call ([`sin_cos`](super::libm::sin_cos)):
    /// scheduled where a code needs both (U has cos q, its gradient sin q).
    SinCos(u32),
    /// The cos of the [`Instr::SinCos`] just before: already written, nothing to do.
    Filled,
}

/// A scheduled program: slots 0..n hold the inputs, then the constants, then one slot per
/// instruction.
#[derive(Debug, Clone)]
pub struct Code {
    pub n_inputs: usize,
    pub constants: Vec<f64>,
    pub instrs: Vec<Instr>,
    /// Slot of U (None when this code does not compute it).
    pub value: Option<u32>,
    /// Slot of each force component (None when this code does not compute forces).
    pub force: Option<Vec<u32>>,
}

impl Code {
    /// Schedules the nodes the roots need, in graph order (operands first).
    pub(super) fn schedule(
        g: &Graph,
        n_inputs: usize,
        value: Option<u32>,
        force: Option<&[u32]>,
    ) -> Code {
        let mut live = vec![false; g.nodes.len()];
        let mut stack: Vec<u32> = value
            .into_iter()
            .chain(force.unwrap_or(&[]).iter().copied())
            .collect();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut live[id as usize], true) {
                continue;
            }
            match g.node(id) {
                Node::Bin(_, a, b) => stack.extend([a, b]),
                Node::Un(_, a) | Node::Powf(a, _) => stack.push(a),
                Node::Powi(..) => unreachable!("powers are lowered before scheduling"),
                Node::Input(_) | Node::Const(_) => {}
            }
        }
        let mut slot = vec![u32::MAX; g.nodes.len()];
        for (id, node) in g.nodes.iter().enumerate() {
            if let Node::Input(i) = node {
                slot[id] = *i;
            }
        }
        let mut constants = Vec::new();
        for (id, node) in g.nodes.iter().enumerate() {
            if let (true, Node::Const(bits)) = (live[id], node) {
                slot[id] = (n_inputs + constants.len()) as u32;
                constants.push(f64::from_bits(*bits));
            }
        }
        // sin a and cos a both live: one SinCos where the first of them comes.
        let mut sin_of = HashMap::new();
        let mut cos_of = HashMap::new();
        for (id, node) in g.nodes.iter().enumerate() {
            match (live[id], *node) {
                (true, Node::Un(Unary::Sin, a)) => sin_of.insert(a, id),
                (true, Node::Un(Unary::Cos, a)) => cos_of.insert(a, id),
                _ => None,
            };
        }
        let base = n_inputs + constants.len();
        let mut instrs = Vec::new();
        for (id, node) in g.nodes.iter().enumerate() {
            if !live[id] || slot[id] != u32::MAX {
                continue;
            }
            let s = |a: u32| slot[a as usize];
            let ins = match *node {
                Node::Bin(op, a, b) => Instr::Bin(op, s(a), s(b)),
                Node::Un(Unary::Sin | Unary::Cos, a)
                    if sin_of.contains_key(&a) && cos_of.contains_key(&a) =>
                {
                    let (at, arg) = ((base + instrs.len()) as u32, s(a));
                    slot[sin_of[&a]] = at;
                    slot[cos_of[&a]] = at + 1;
                    instrs.extend([Instr::SinCos(arg), Instr::Filled]);
                    continue;
                }
                Node::Un(op, a) => Instr::Un(op, s(a)),
                Node::Powf(a, c) => Instr::Powf(s(a), f64::from_bits(c)),
                Node::Input(_) | Node::Const(_) | Node::Powi(..) => continue,
            };
            slot[id] = (base + instrs.len()) as u32;
            instrs.push(ins);
        }
        let slot_of = |id: u32| slot[id as usize];
        Code {
            n_inputs,
            constants,
            instrs,
            value: value.map(slot_of),
            force: force.map(|f| f.iter().map(|&id| slot[id as usize]).collect()),
        }
    }

    pub(super) fn n_slots(&self) -> usize {
        self.n_inputs + self.constants.len() + self.instrs.len()
    }

    /// A register file with the constants in place.
    pub(super) fn registers<L: Real>(&self) -> Vec<L> {
        let mut r = vec![L::zero(); self.n_slots()];
        for (k, &c) in self.constants.iter().enumerate() {
            r[self.n_inputs + k] = L::splat(c);
        }
        r
    }

    /// Runs the instructions; the inputs must already be in `r[..n_inputs]`. Every operand
    /// slot precedes the instruction that reads it (checked when the code was scheduled).
    #[inline(always)]
    pub(super) fn run<L: Real>(&self, r: &mut [L]) {
        let base = self.n_inputs + self.constants.len();
        assert!(
            r.len() >= base + self.instrs.len(),
            "register file too short"
        );
        let p = r.as_mut_ptr();
        for (k, ins) in self.instrs.iter().enumerate() {
            // SAFETY: every operand slot precedes the instruction's own slot base + k (checked
            // when the code was scheduled), and base + k < r.len() (asserted above). Each arm
            // stores its result itself: a value returned through the match of a multi-lane
            // type was split into scalar moves per lane (seen in the profile).
            unsafe {
                let get = |s: u32| *p.add(s as usize);
                let out = p.add(base + k);
                match *ins {
                    Instr::Bin(Binary::Add, a, b) => *out = get(a) + get(b),
                    Instr::Bin(Binary::Sub, a, b) => *out = get(a) - get(b),
                    Instr::Bin(Binary::Mul, a, b) => *out = get(a) * get(b),
                    Instr::Bin(Binary::Div, a, b) => *out = get(a) / get(b),
                    Instr::Un(Unary::Neg, a) => *out = -get(a),
                    Instr::Un(Unary::Sqrt, a) => *out = get(a).sqrt(),
                    Instr::Un(Unary::Abs, a) => *out = get(a).abs(),
                    Instr::Un(op, a) => *out = get(a).map(op.scalar()),
                    Instr::Powf(a, c) => *out = get(a).map2(L::splat(c), f64::powf),
                    Instr::SinCos(a) => {
                        let (sin, cos) = sin_cos_lanes(get(a));
                        *out = sin;
                        // base + k + 1 < r.len(): a Filled instruction follows every SinCos.
                        *out.add(1) = cos;
                    }
                    Instr::Filled => {}
                }
            }
        }
    }
}

impl Code {
    /// A slot-major register file for tiles of `tile` evaluations, constants in place.
    pub(super) fn tile_registers<L: Real>(&self, tile: usize) -> Vec<L> {
        let mut r = vec![L::zero(); self.n_slots() * tile];
        for (k, &c) in self.constants.iter().enumerate() {
            r[(self.n_inputs + k) * tile..][..tile].fill(L::splat(c));
        }
        r
    }

    /// Runs the instructions over `width` ≤ `tile` evaluations at once: slot s holds
    /// `r[s*tile..s*tile+width]`, and each instruction is one vectorizable loop.
    #[inline(always)]
    pub(super) fn run_tile<L: Real>(&self, r: &mut [L], tile: usize, width: usize) {
        let base = self.n_inputs + self.constants.len();
        for (k, ins) in self.instrs.iter().enumerate() {
            let (src, rest) = r.split_at_mut((base + k) * tile);
            let out = &mut rest[..width];
            let arg = |s: u32| &src[s as usize * tile..][..width];
            match *ins {
                Instr::Bin(op, a, b) => {
                    let (x, y) = (arg(a), arg(b));
                    match op {
                        Binary::Add => (0..width).for_each(|j| out[j] = x[j] + y[j]),
                        Binary::Sub => (0..width).for_each(|j| out[j] = x[j] - y[j]),
                        Binary::Mul => (0..width).for_each(|j| out[j] = x[j] * y[j]),
                        Binary::Div => (0..width).for_each(|j| out[j] = x[j] / y[j]),
                    }
                }
                // The operation chosen once per tile, not per element (a match inside the
                // loop compiled to a jump per element).
                Instr::Un(Unary::Neg, a) => {
                    let x = arg(a);
                    (0..width).for_each(|j| out[j] = -x[j]);
                }
                Instr::Un(Unary::Sqrt, a) => {
                    let x = arg(a);
                    (0..width).for_each(|j| out[j] = x[j].sqrt());
                }
                Instr::Un(Unary::Abs, a) => {
                    let x = arg(a);
                    (0..width).for_each(|j| out[j] = x[j].abs());
                }
                Instr::Un(op, a) => {
                    let (x, f) = (arg(a), op.scalar());
                    (0..width).for_each(|j| out[j] = x[j].map(f));
                }
                Instr::Powf(a, c) => {
                    let x = arg(a);
                    (0..width).for_each(|j| out[j] = x[j].map2(L::splat(c), f64::powf));
                }
                Instr::SinCos(a) => {
                    let x = arg(a);
                    // The cos goes to the next slot (the Filled instruction's).
                    let (sin, cos) = rest.split_at_mut(tile);
                    for j in 0..width {
                        (sin[j], cos[j]) = sin_cos_lanes(x[j]);
                    }
                }
                Instr::Filled => {}
            }
        }
    }
}
