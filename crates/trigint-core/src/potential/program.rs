//! Compiled potentials: U given as a straight-line program (a tape), with −∇U derived here by
//! reverse-mode differentiation of the program.
//!
//! The Python layer turns the user's expression into a tape of [`Op`]s (sharing every common
//! subexpression, expanding nothing). Here the tape is rebuilt as a hash-consed graph, which
//! shares subexpressions again and folds constants and signs (a + (−b) → a − b, (−a)·b → −(a·b):
//! rewrites that are exact); its adjoint program is added with the seed −1, so the adjoints of the
//! inputs are the forces g = −∇U directly; integer powers become multiplication chains; and three
//! straight-line programs are scheduled: U with g, g alone, and U alone. An evaluation runs one of
//! them over numbers of any lane width: each instruction is the same IEEE operation (or the same
//! libm call) for every lane, so every lane gets the bits of a single-trajectory evaluation.
//! One trajectory, bundles of 2ᵏ lanes and a one-variable program over many arguments run the
//! same codes as machine code (`jit.rs`), with the same bits.

use std::collections::HashMap;
use std::sync::OnceLock;

use super::jit::{self, Compiled, Walk};
use super::linear::LinearMap;
use super::Potential;
use crate::error::{CoreError, CoreResult};
use crate::real::Real;

/// One operation of a tape; operands are the indices of earlier operations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    Input(usize),
    Const(f64),
    Add(usize, usize),
    Sub(usize, usize),
    Mul(usize, usize),
    Div(usize, usize),
    Neg(usize),
    /// a^k for an integer k
    Powi(usize, i32),
    /// a^c for a constant c (libm pow)
    Powf(usize, f64),
    Sqrt(usize),
    Exp(usize),
    Log(usize),
    Sin(usize),
    Cos(usize),
    Tan(usize),
    Sinh(usize),
    Cosh(usize),
    Tanh(usize),
    Abs(usize),
    /// −1, 0 or 1 (the derivative of |a|)
    Sign(usize),
}

/// A tape as the Python layer builds it: U = value of `ops[output]` in `n_inputs` coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramSpec {
    pub n_inputs: usize,
    pub ops: Vec<Op>,
    pub output: usize,
}

/// Functions of one argument.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unary {
    Neg,
    Sqrt,
    Exp,
    Log,
    Sin,
    Cos,
    Tan,
    Sinh,
    Cosh,
    Tanh,
    Abs,
    Sign,
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        x
    }
}

impl Unary {
    /// The scalar function (the same one every lane calls).
    pub fn scalar(self) -> fn(f64) -> f64 {
        match self {
            Unary::Neg => |x| -x,
            Unary::Sqrt => f64::sqrt,
            Unary::Exp => f64::exp,
            Unary::Log => f64::ln,
            Unary::Sin => f64::sin,
            Unary::Cos => f64::cos,
            Unary::Tan => f64::tan,
            Unary::Sinh => f64::sinh,
            Unary::Cosh => f64::cosh,
            Unary::Tanh => f64::tanh,
            Unary::Abs => f64::abs,
            Unary::Sign => sign,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Binary {
    Add,
    Sub,
    Mul,
    Div,
}

impl Binary {
    fn scalar(self, a: f64, b: f64) -> f64 {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
        }
    }
}

/// A node of the graph; constants are keyed by their bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Node {
    Input(u32),
    Const(u64),
    Bin(Binary, u32, u32),
    Un(Unary, u32),
    Powi(u32, i32),
    Powf(u32, u64),
}

/// A hash-consed expression graph: every node once, operands before the nodes that use them.
#[derive(Default)]
struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Node, u32>,
}

impl Graph {
    fn node(&self, id: u32) -> Node {
        self.nodes[id as usize]
    }

    fn constant_of(&self, id: u32) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    fn intern(&mut self, node: Node) -> u32 {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    fn constant(&mut self, c: f64) -> u32 {
        self.intern(Node::Const(c.to_bits()))
    }

    fn input(&mut self, i: usize) -> u32 {
        self.intern(Node::Input(i as u32))
    }

    fn neg_of(&self, id: u32) -> Option<u32> {
        match self.node(id) {
            Node::Un(Unary::Neg, a) => Some(a),
            _ => None,
        }
    }

    fn unary(&mut self, op: Unary, a: u32) -> u32 {
        if let Some(c) = self.constant_of(a) {
            return self.constant(op.scalar()(c));
        }
        if op == Unary::Neg {
            if let Some(inner) = self.neg_of(a) {
                return inner;
            }
            // −(x − y) = y − x exactly (up to the sign of a zero).
            if let Node::Bin(Binary::Sub, x, y) = self.node(a) {
                return self.binary(Binary::Sub, y, x);
            }
        }
        self.intern(Node::Un(op, a))
    }

    fn binary(&mut self, op: Binary, a: u32, b: u32) -> u32 {
        if let (Some(x), Some(y)) = (self.constant_of(a), self.constant_of(b)) {
            return self.constant(op.scalar(x, y));
        }
        let (ca, cb) = (self.constant_of(a), self.constant_of(b));
        match op {
            Binary::Add => {
                if cb == Some(0.0) {
                    return a;
                }
                if ca == Some(0.0) {
                    return b;
                }
                if let Some(y) = self.neg_of(b) {
                    return self.binary(Binary::Sub, a, y);
                }
                if let Some(x) = self.neg_of(a) {
                    return self.binary(Binary::Sub, b, x);
                }
            }
            Binary::Sub => {
                if cb == Some(0.0) {
                    return a;
                }
                if ca == Some(0.0) {
                    return self.unary(Unary::Neg, b);
                }
                if let Some(y) = self.neg_of(b) {
                    return self.binary(Binary::Add, a, y);
                }
            }
            Binary::Mul => {
                for (c, other) in [(ca, b), (cb, a)] {
                    if c == Some(1.0) {
                        return other;
                    }
                    if c == Some(-1.0) {
                        return self.unary(Unary::Neg, other);
                    }
                }
                if let Some(x) = self.neg_of(a) {
                    let m = self.binary(Binary::Mul, x, b);
                    return self.unary(Unary::Neg, m);
                }
                if let Some(y) = self.neg_of(b) {
                    let m = self.binary(Binary::Mul, a, y);
                    return self.unary(Unary::Neg, m);
                }
            }
            Binary::Div => {
                if cb == Some(1.0) {
                    return a;
                }
                if let Some(x) = self.neg_of(a) {
                    let d = self.binary(Binary::Div, x, b);
                    return self.unary(Unary::Neg, d);
                }
                if let Some(y) = self.neg_of(b) {
                    let d = self.binary(Binary::Div, a, y);
                    return self.unary(Unary::Neg, d);
                }
            }
        }
        // a + b = b + a and a·b = b·a exactly: one canonical order shares more.
        let (a, b) = if matches!(op, Binary::Add | Binary::Mul) && b < a {
            (b, a)
        } else {
            (a, b)
        };
        self.intern(Node::Bin(op, a, b))
    }

    fn add(&mut self, a: u32, b: u32) -> u32 {
        self.binary(Binary::Add, a, b)
    }

    fn mul(&mut self, a: u32, b: u32) -> u32 {
        self.binary(Binary::Mul, a, b)
    }

    fn powi(&mut self, a: u32, k: i32) -> u32 {
        match k {
            0 => self.constant(1.0),
            1 => a,
            _ => {
                if let Some(c) = self.constant_of(a) {
                    return self.constant(c.powi(k));
                }
                self.intern(Node::Powi(a, k))
            }
        }
    }

    fn powf(&mut self, a: u32, c: f64) -> u32 {
        if c == 1.0 {
            return a;
        }
        if let Some(x) = self.constant_of(a) {
            return self.constant(x.powf(c));
        }
        self.intern(Node::Powf(a, c.to_bits()))
    }

    /// a^k by repeated squaring: a³ = (a·a)·a, a⁴ = (a·a)·(a·a); the squares are shared.
    fn power_chain(&mut self, a: u32, k: i32) -> u32 {
        if k < 0 {
            let p = self.power_chain(a, -k);
            let one = self.constant(1.0);
            return self.binary(Binary::Div, one, p);
        }
        match k {
            0 => self.constant(1.0),
            1 => a,
            _ => {
                let half = self.power_chain(a, k / 2);
                let square = self.mul(half, half);
                if k % 2 == 1 {
                    self.mul(square, a)
                } else {
                    square
                }
            }
        }
    }

    /// Adds ∂/∂a of node `out` times the seed: returns the adjoint of each input (None where
    /// `out` does not depend on it).
    fn adjoints(&mut self, out: u32, n_inputs: usize, seed: f64) -> Vec<Option<u32>> {
        let mut adj: Vec<Option<u32>> = vec![None; out as usize + 1];
        adj[out as usize] = Some(self.constant(seed));
        let mut grad = vec![None; n_inputs];
        for id in (0..=out).rev() {
            let Some(bar) = adj[id as usize] else {
                continue;
            };
            let give = |g: &mut Graph, adj: &mut Vec<Option<u32>>, a: u32, term: u32| {
                adj[a as usize] = Some(match adj[a as usize] {
                    None => term,
                    Some(prev) => g.add(prev, term),
                });
            };
            match self.node(id) {
                Node::Input(i) => grad[i as usize] = Some(bar),
                Node::Const(_) => {}
                Node::Bin(op, a, b) => match op {
                    Binary::Add => {
                        give(self, &mut adj, a, bar);
                        give(self, &mut adj, b, bar);
                    }
                    Binary::Sub => {
                        give(self, &mut adj, a, bar);
                        let t = self.unary(Unary::Neg, bar);
                        give(self, &mut adj, b, t);
                    }
                    Binary::Mul => {
                        let ta = self.mul(bar, b);
                        give(self, &mut adj, a, ta);
                        let tb = self.mul(bar, a);
                        give(self, &mut adj, b, tb);
                    }
                    Binary::Div => {
                        // y = a/b: ā += ȳ/b, b̄ −= (ȳ/b)·y
                        let q = self.binary(Binary::Div, bar, b);
                        give(self, &mut adj, a, q);
                        let t = self.mul(q, id);
                        let t = self.unary(Unary::Neg, t);
                        give(self, &mut adj, b, t);
                    }
                },
                Node::Powi(a, k) => {
                    // Constants first, so that the seed and k fold into one number.
                    let kc = self.constant(f64::from(k));
                    let s = self.mul(bar, kc);
                    let p = self.powi(a, k - 1);
                    let t = self.mul(s, p);
                    give(self, &mut adj, a, t);
                }
                Node::Powf(a, cbits) => {
                    let c = f64::from_bits(cbits);
                    let cc = self.constant(c);
                    let s = self.mul(bar, cc);
                    let p = self.powf(a, c - 1.0);
                    let t = self.mul(s, p);
                    give(self, &mut adj, a, t);
                }
                Node::Un(op, a) => {
                    let t = match op {
                        Unary::Neg => self.unary(Unary::Neg, bar),
                        Unary::Sqrt => {
                            let half = self.constant(0.5);
                            let s = self.mul(bar, half);
                            self.binary(Binary::Div, s, id)
                        }
                        Unary::Exp => self.mul(bar, id),
                        Unary::Log => self.binary(Binary::Div, bar, a),
                        Unary::Sin => {
                            let c = self.unary(Unary::Cos, a);
                            self.mul(bar, c)
                        }
                        Unary::Cos => {
                            let s = self.unary(Unary::Sin, a);
                            let t = self.mul(bar, s);
                            self.unary(Unary::Neg, t)
                        }
                        Unary::Tan => {
                            let one = self.constant(1.0);
                            let y2 = self.mul(id, id);
                            let d = self.add(one, y2);
                            self.mul(bar, d)
                        }
                        Unary::Sinh => {
                            let c = self.unary(Unary::Cosh, a);
                            self.mul(bar, c)
                        }
                        Unary::Cosh => {
                            let s = self.unary(Unary::Sinh, a);
                            self.mul(bar, s)
                        }
                        Unary::Tanh => {
                            let one = self.constant(1.0);
                            let y2 = self.mul(id, id);
                            let d = self.binary(Binary::Sub, one, y2);
                            self.mul(bar, d)
                        }
                        Unary::Abs => {
                            let s = self.unary(Unary::Sign, a);
                            self.mul(bar, s)
                        }
                        Unary::Sign => continue,
                    };
                    give(self, &mut adj, a, t);
                }
            }
        }
        grad
    }

    /// A copy with every power a^k written as multiplications.
    fn lower_powers(&self, roots: &[u32]) -> (Graph, Vec<u32>) {
        let mut g = Graph::default();
        let mut map: Vec<u32> = Vec::with_capacity(self.nodes.len());
        for &node in &self.nodes {
            let m = |id: u32| map[id as usize];
            let id = match node {
                Node::Input(i) => g.input(i as usize),
                Node::Const(bits) => g.constant(f64::from_bits(bits)),
                Node::Bin(op, a, b) => g.binary(op, m(a), m(b)),
                Node::Un(op, a) => g.unary(op, m(a)),
                Node::Powi(a, k) => g.power_chain(m(a), k),
                Node::Powf(a, c) => g.powf(m(a), f64::from_bits(c)),
            };
            map.push(id);
        }
        let roots = roots.iter().map(|&r| map[r as usize]).collect();
        (g, roots)
    }
}

/// One straight-line instruction; its result goes to the next free slot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    Bin(Binary, u32, u32),
    Un(Unary, u32),
    Powf(u32, f64),
    /// sin a into this slot and cos a into the next one, with one libm call ([`sin_cos`]):
    /// scheduled where a code needs both (U has cos q, its gradient sin q).
    SinCos(u32),
    /// The cos of the [`Instr::SinCos`] just before: already written, nothing to do.
    Filled,
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
extern "C" {
    /// glibc's sin and cos with one range reduction (`<math.h>`, GNU extension).
    fn sincos(x: f64, sin: *mut f64, cos: *mut f64);
}

/// [`sin_cos`] as the C ABI calls it, for machine code: sin x to `*sin`, cos x to `*cos`.
/// With glibc `sincos` itself (no wrapper between the compiled code and libm).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub const SIN_COS_C: unsafe extern "C" fn(f64, *mut f64, *mut f64) = sincos;

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub const SIN_COS_C: unsafe extern "C" fn(f64, *mut f64, *mut f64) = {
    unsafe extern "C" fn two_calls(x: f64, sin: *mut f64, cos: *mut f64) {
        // SAFETY: the caller passes two valid doubles to write.
        unsafe {
            *sin = x.sin();
            *cos = x.cos();
        }
    }
    two_calls
};

/// (sin x, cos x) through [`SIN_COS_C`]. With glibc one `sincos` call, whose results are bit
/// for bit those of `sin` and `cos` (the same kernels after the same reduction; tested on 2·10⁸
/// arguments across the whole double range, and in this crate's tests), so a code that merges
/// the two calls and one that does not compute the same bits. Elsewhere the two calls.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    let (mut s, mut c) = (0.0, 0.0);
    // SAFETY: SIN_COS_C writes one double through each pointer, both valid locals.
    unsafe { SIN_COS_C(x, &mut s, &mut c) };
    (s, c)
}

/// [`sin_cos`] lane by lane.
#[inline(always)]
fn sin_cos_lanes<L: Real>(x: L) -> (L, L) {
    let (mut sin, mut cos) = (x, x);
    for j in 0..L::LANES {
        let (s, c) = sin_cos(x.lane(j));
        sin.set_lane(j, s);
        cos.set_lane(j, c);
    }
    (sin, cos)
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
    fn schedule(g: &Graph, n_inputs: usize, value: Option<u32>, force: Option<&[u32]>) -> Code {
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

    fn n_slots(&self) -> usize {
        self.n_inputs + self.constants.len() + self.instrs.len()
    }

    /// A register file with the constants in place.
    fn registers<L: Real>(&self) -> Vec<L> {
        let mut r = vec![L::zero(); self.n_slots()];
        for (k, &c) in self.constants.iter().enumerate() {
            r[self.n_inputs + k] = L::splat(c);
        }
        r
    }

    /// Runs the instructions; the inputs must already be in `r[..n_inputs]`. Every operand
    /// slot precedes the instruction that reads it (checked when the code was scheduled).
    #[inline(always)]
    fn run<L: Real>(&self, r: &mut [L]) {
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
    fn tile_registers<L: Real>(&self, tile: usize) -> Vec<L> {
        let mut r = vec![L::zero(); self.n_slots() * tile];
        for (k, &c) in self.constants.iter().enumerate() {
            r[(self.n_inputs + k) * tile..][..tile].fill(L::splat(c));
        }
        r
    }

    /// Runs the instructions over `width` ≤ `tile` evaluations at once: slot s holds
    /// `r[s*tile..s*tile+width]`, and each instruction is one vectorizable loop.
    #[inline(always)]
    fn run_tile<L: Real>(&self, r: &mut [L], tile: usize, width: usize) {
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

/// Term j of `v` into partial sum j mod 8 (`v` starts at a multiple of 8).
#[inline(always)]
fn add_in_eights<L: Real>(parts: &mut [L; 8], v: &[L]) {
    let mut chunks = v.chunks_exact(8);
    for c in &mut chunks {
        for t in 0..8 {
            parts[t] += c[t];
        }
    }
    for (t, x) in chunks.remainder().iter().enumerate() {
        parts[t] += *x;
    }
}

/// A potential compiled from a tape: U and its exact force −∇U.
#[derive(Debug, Clone)]
pub struct Program {
    n: usize,
    /// U and g together, g alone, U alone.
    full: Code,
    force_only: Code,
    value_only: Code,
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
    fn bundle_code(&self, width: usize) -> Option<&[Compiled]> {
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
            return crate::energy::tree(&parts, y.len().min(8));
        }
        let code = [&self.full, &self.force_only, &self.value_only][which];
        let r = &mut registers[which];
        // Σ_b V(y_b) in the fixed order of the kernels' sums: term b into partial sum b mod 8,
        // the partial sums combined by `energy::tree` (eight independent chains, not one).
        debug_assert!(tile.is_multiple_of(8));
        let mut parts = [L::zero(); 8];
        for start in (0..y.len()).step_by(tile) {
            let width = tile.min(y.len() - start);
            r[..width].copy_from_slice(&y[start..start + width]);
            code.run_tile(r, tile, width);
            if let (Some(g), Some(slots)) = (g.as_deref_mut(), &code.force) {
                let s = slots[0] as usize * tile;
                g[start..start + width].copy_from_slice(&r[s..s + width]);
            }
            if let (true, Some(s)) = (with_value, code.value) {
                add_in_eights(&mut parts, &r[s as usize * tile..][..width]);
            }
        }
        crate::energy::tree(&parts, y.len().min(8))
    }

    /// [`eval_tiles`](Self::eval_tiles) through machine code over all arguments at once (the
    /// last one alone when their number of doubles is odd): V into `values`, −V' into `g`;
    /// returns the eight partial sums of V. None when there is no machine code.
    #[inline(always)]
    fn eval_arguments_native<L: Real>(
        &self,
        which: usize,
        y: &[L],
        g: Option<&mut [L]>,
        values: &mut [L],
    ) -> Option<[L; 8]> {
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
        let mut parts = [L::zero(); 8];
        if which != 1 {
            add_in_eights(&mut parts, &values[..y.len()]);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::potential::Fpu;
    use crate::real::{Lanes, Scalar};

    /// A xorshift generator of 64-bit words.
    fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        }
    }

    /// U = exp(x) cos(x).
    fn exp_times_cos() -> ProgramSpec {
        ProgramSpec {
            n_inputs: 1,
            ops: vec![Op::Input(0), Op::Exp(0), Op::Cos(0), Op::Mul(1, 2)],
            output: 3,
        }
    }

    /// U = ¼ Σ (linear form)⁴ of the FPU chain, m = 3, as SymPy hands it over: each term
    /// x⁴/4 with the linear forms written with negations.
    pub(crate) fn fpu_tape(m: usize) -> ProgramSpec {
        let mut ops = Vec::new();
        let mut push = |op: Op| {
            ops.push(op);
            ops.len() - 1
        };
        let inputs: Vec<usize> = (0..2 * m).map(|i| push(Op::Input(i))).collect();
        let (x0, x1) = inputs.split_at(m);
        let quarter = push(Op::Const(0.25));
        let mut forms = vec![];
        let a = push(Op::Neg(x1[0]));
        forms.push(push(Op::Add(x0[0], a)));
        for i in 1..m {
            let t = push(Op::Neg(x0[i - 1]));
            let t = push(Op::Add(t, x0[i]));
            let u = push(Op::Neg(x1[i - 1]));
            let t = push(Op::Add(t, u));
            let u = push(Op::Neg(x1[i]));
            forms.push(push(Op::Add(t, u)));
        }
        forms.push(push(Op::Add(x0[m - 1], x1[m - 1])));
        let mut total = None;
        for y in forms {
            let p = push(Op::Powi(y, 4));
            let term = push(Op::Mul(quarter, p));
            total = Some(match total {
                None => term,
                Some(t) => push(Op::Add(t, term)),
            });
        }
        let output = total.unwrap();
        ProgramSpec {
            n_inputs: 2 * m,
            ops,
            output,
        }
    }

    #[test]
    fn fpu_program_matches_the_native_chain_to_rounding_with_few_instructions() {
        let m = 3;
        let prog = Program::new(&fpu_tape(m), None).unwrap();
        // 8 for the linear forms, 8 for the cubes, 6 for the forces (+ negations folded).
        assert!(
            prog.force_instructions() <= 24,
            "{:?}",
            prog.force_only.instrs
        );
        let fpu = Fpu::new(m).unwrap();
        let x = [0.9, -0.3, 0.2, 0.02, 0.01, -0.015];
        let (mut f1, mut f2) = ([0.0; 6], [0.0; 6]);
        let u1 = prog
            .force(&x, &mut f1, true, &mut prog.workspace())
            .unwrap();
        let u2 = fpu.force(&x, &mut f2, true, &mut fpu.workspace()).unwrap();
        assert!((u1 - u2).abs() <= 1e-15 * u2.abs());
        for i in 0..6 {
            assert!(
                (f1[i] - f2[i]).abs() <= 1e-15 * f2[i].abs().max(1e-300),
                "{i}"
            );
        }
        let v = prog.value(&x, &mut prog.workspace()).unwrap();
        assert_eq!(v.to_bits(), u1.to_bits());
    }

    #[test]
    fn transcendental_gradients_are_exact() {
        // U = exp(x0) sin(x1) + sqrt(x0^2 + 1)/tanh(x1) + |x0| x1^(3/2) + log(cosh(x0)) - 1/x1
        let ops = vec![
            Op::Input(0),
            Op::Input(1),
            Op::Exp(0),
            Op::Sin(1),
            Op::Mul(2, 3),
            Op::Powi(0, 2),
            Op::Const(1.0),
            Op::Add(5, 6),
            Op::Sqrt(7),
            Op::Tanh(1),
            Op::Div(8, 9),
            Op::Add(4, 10),
            Op::Abs(0),
            Op::Powf(1, 1.5),
            Op::Mul(12, 13),
            Op::Add(11, 14),
            Op::Cosh(0),
            Op::Log(16),
            Op::Add(15, 17),
            Op::Powi(1, -1),
            Op::Sub(18, 19),
        ];
        let spec = ProgramSpec {
            n_inputs: 2,
            ops,
            output: 20,
        };
        let prog = Program::new(&spec, None).unwrap();
        let u = |x: f64, y: f64| {
            x.exp() * y.sin()
                + (x * x + 1.0).sqrt() / y.tanh()
                + x.abs() * y.powf(1.5)
                + x.cosh().ln()
                - 1.0 / y
        };
        for &(x, y) in &[(0.3, 0.7), (-1.2, 2.5), (0.8, 0.1)] {
            let mut f = [0.0; 2];
            let v = prog
                .force(&[x, y], &mut f, true, &mut prog.workspace())
                .unwrap();
            assert!((v - u(x, y)).abs() < 1e-14 * u(x, y).abs());
            let gx = x.exp() * y.sin()
                + x / (x * x + 1.0).sqrt() / y.tanh()
                + x.signum() * y.powf(1.5)
                + x.tanh();
            let gy = x.exp() * y.cos()
                - (x * x + 1.0).sqrt() * (1.0 - y.tanh().powi(2)) / y.tanh().powi(2)
                + x.abs() * 1.5 * y.sqrt()
                + 1.0 / (y * y);
            assert!((f[0] + gx).abs() < 1e-13 * gx.abs(), "{} vs {}", f[0], -gx);
            assert!((f[1] + gy).abs() < 1e-13 * gy.abs(), "{} vs {}", f[1], -gy);
        }
    }

    #[test]
    fn machine_code_gives_the_interpreters_bits() {
        // Every operation, several times over, in three coordinates: U = Σ of
        // tan(x0)·sinh(x1)/cosh(x2) + sign(x0)|x1|^0.7 + exp(−x2²) log(1 + x0²)
        // + sqrt(1 + x1⁴) cos(x2) sin(x0) − tanh(x0 x1 x2) + (x0 − x2)⁻³.
        let ops = vec![
            Op::Input(0),
            Op::Input(1),
            Op::Input(2),
            Op::Tan(0),
            Op::Sinh(1),
            Op::Cosh(2),
            Op::Mul(3, 4),
            Op::Div(6, 5),
            Op::Sign(0),
            Op::Abs(1),
            Op::Powf(9, 0.7),
            Op::Mul(8, 10),
            Op::Powi(2, 2),
            Op::Neg(12),
            Op::Exp(13),
            Op::Const(1.0),
            Op::Powi(0, 2),
            Op::Add(15, 16),
            Op::Log(17),
            Op::Mul(14, 18),
            Op::Powi(1, 4),
            Op::Add(15, 20),
            Op::Sqrt(21),
            Op::Cos(2),
            Op::Sin(0),
            Op::Mul(22, 23),
            Op::Mul(25, 24),
            Op::Mul(0, 1),
            Op::Mul(27, 2),
            Op::Tanh(28),
            Op::Sub(0, 2),
            Op::Powi(30, -3),
            Op::Add(7, 11),
            Op::Add(32, 19),
            Op::Add(33, 26),
            Op::Sub(34, 29),
            Op::Add(35, 31),
        ];
        let spec = ProgramSpec {
            n_inputs: 3,
            ops,
            output: 36,
        };
        let native = Program::new(&spec, None).unwrap();
        assert!(native.is_native(), "no machine code on this host");
        let plain = native.clone().interpreted();
        let (mut wn, mut wp) = (native.workspace::<f64>(), plain.workspace::<f64>());
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        let mut uniform = || (next() >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0;
        let mut points: Vec<[f64; 3]> = (0..500)
            .map(|_| [uniform(), uniform(), uniform()])
            .collect();
        points.extend([
            [0.0, 0.0, 1.0],
            [1.0, -0.0, 1.0],
            [f64::NAN, 1.0, 2.0],
            [800.0, 1.0, 2.0],
        ]);
        for x in &points {
            for with_value in [true, false] {
                let (mut fn_, mut fp) = ([0.0; 3], [0.0; 3]);
                let un = native.force(x, &mut fn_, with_value, &mut wn).unwrap();
                let up = plain.force(x, &mut fp, with_value, &mut wp).unwrap();
                for i in 0..3 {
                    assert_eq!(fn_[i].to_bits(), fp[i].to_bits(), "force {i} at {x:?}");
                }
                if with_value {
                    assert_eq!(un.to_bits(), up.to_bits(), "U at {x:?}");
                }
            }
            let (vn, vp) = (
                native.value(x, &mut wn).unwrap(),
                plain.value(x, &mut wp).unwrap(),
            );
            assert_eq!(vn.to_bits(), vp.to_bits(), "U alone at {x:?}");
            let mut fs = [Scalar(0.0); 3];
            let xs = x.map(Scalar);
            let us = native
                .force(&xs, &mut fs, true, &mut native.workspace())
                .unwrap();
            assert_eq!(us.0.to_bits(), vp.to_bits());
        }
        // Bundles run machine code over lane pairs: each lane has the interpreter's bits.
        fn bundles<const W: usize>(native: &Program, plain: &Program, points: &[[f64; 3]]) {
            let mut ws = native.workspace::<Lanes<W>>();
            for chunk in points.chunks_exact(W) {
                let x: [Lanes<W>; 3] =
                    std::array::from_fn(|i| Lanes(std::array::from_fn(|b| chunk[b][i])));
                let mut f = [Lanes::<W>::zero(); 3];
                let u = native.force(&x, &mut f, true, &mut ws).unwrap();
                let mut g = [Lanes::<W>::zero(); 3];
                native.force(&x, &mut g, false, &mut ws).unwrap();
                let v = native.value(&x, &mut ws).unwrap();
                for (b, p) in chunk.iter().enumerate() {
                    let mut fp = [0.0; 3];
                    let up = plain
                        .force(p, &mut fp, true, &mut plain.workspace())
                        .unwrap();
                    assert_eq!(u.0[b].to_bits(), up.to_bits(), "U, lane {b} of {W}");
                    assert_eq!(v.0[b].to_bits(), up.to_bits(), "U alone, lane {b} of {W}");
                    for i in 0..3 {
                        assert_eq!(f[i].0[b].to_bits(), fp[i].to_bits(), "force {i}, lane {b}");
                        assert_eq!(g[i].0[b].to_bits(), fp[i].to_bits(), "force {i}, lane {b}");
                    }
                }
            }
        }
        bundles::<2>(&native, &plain, &points);
        bundles::<8>(&native, &plain, &points);
        bundles::<3>(&native, &plain, &points);
        assert!(native.bundle_code(8).is_some() && native.bundle_code(3).is_none());
    }

    #[test]
    fn sin_cos_has_the_bits_of_sin_and_cos() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut xs = vec![
            0.0,
            -0.0,
            1e-300,
            5e-324,
            0.855469,
            2.426265,
            1e22,
            f64::MAX,
        ];
        xs.extend([f64::NAN, f64::INFINITY, f64::NEG_INFINITY]);
        for k in 0..400_000 {
            let r = next();
            let unit = (r >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            // Each of glibc's ranges: |x| < 0.86, < 2.43, < 1.05e8 and beyond (other reductions).
            xs.push(match k % 5 {
                0 => unit * 2.0,
                1 => unit * 6.0,
                2 => unit * 400.0,
                3 => unit * 4e9,
                _ => f64::from_bits(r),
            });
        }
        for x in xs {
            let (s, c) = sin_cos(x);
            assert_eq!(s.to_bits(), x.sin().to_bits(), "sin {x:e}");
            assert_eq!(c.to_bits(), x.cos().to_bits(), "cos {x:e}");
        }
    }

    #[test]
    fn sin_and_cos_of_one_argument_share_a_call_with_unchanged_bits() {
        // U = exp(x) cos(x): U and g need cos x and sin x (one SinCos), U alone only cos x.
        let native = Program::new(&exp_times_cos(), None).unwrap();
        let merged = |c: &Code| c.instrs.iter().any(|i| matches!(i, Instr::SinCos(_)));
        assert!(merged(&native.full) && merged(&native.force_only) && !merged(&native.value_only));
        let plain = native.clone().interpreted();
        for k in 0..2000 {
            let x = (k as f64 - 1000.0) * 0.0137;
            for prog in [&native, &plain] {
                let mut f = [0.0];
                let u = prog
                    .force(&[x], &mut f, true, &mut prog.workspace())
                    .unwrap();
                let alone = prog.value(&[x], &mut prog.workspace()).unwrap();
                assert_eq!(u.to_bits(), alone.to_bits(), "U at {x}");
                assert_eq!(u.to_bits(), (x.exp() * x.cos()).to_bits());
                // −U' = −(eˣ cos x − eˣ sin x) in some order of the same products: to rounding.
                let g = -(x.exp() * x.cos() - x.exp() * x.sin());
                assert!((f[0] - g).abs() <= 4.0 * f64::EPSILON * x.exp(), "g at {x}");
            }
        }
    }

    #[test]
    fn lanes_give_each_trajectory_its_bits() {
        let prog = Program::new(&exp_times_cos(), None).unwrap();
        let xs: [f64; 8] = std::array::from_fn(|b| 0.37 * b as f64 - 1.1);
        let mut f = [Lanes::<8>::zero()];
        let v = prog
            .force(&[Lanes(xs)], &mut f, true, &mut prog.workspace())
            .unwrap();
        for b in 0..8 {
            let mut g = [0.0];
            let u = prog
                .force(&[xs[b]], &mut g, true, &mut prog.workspace())
                .unwrap();
            assert_eq!(
                (v.0[b].to_bits(), f[0].0[b].to_bits()),
                (u.to_bits(), g[0].to_bits())
            );
        }
    }

    #[test]
    fn a_coordinate_map_composes() {
        // U(x) = x0 * x1 with x = T y, T = [[1, 1], [1, -1]]: U = y0² − y1².
        let spec = ProgramSpec {
            n_inputs: 2,
            ops: vec![Op::Input(0), Op::Input(1), Op::Mul(0, 1)],
            output: 2,
        };
        let t =
            LinearMap::from_csr(2, 2, &[0, 2, 4], &[0, 1, 0, 1], &[1.0, 1.0, 1.0, -1.0]).unwrap();
        let prog = Program::new(&spec, Some(&t)).unwrap();
        let mut f = [0.0; 2];
        let v = prog
            .force(&[3.0, 2.0], &mut f, true, &mut prog.workspace())
            .unwrap();
        assert_eq!(v, 5.0);
        assert_eq!(f, [-6.0, 4.0]);
    }

    #[test]
    fn bad_tapes_are_refused() {
        let forward = ProgramSpec {
            n_inputs: 1,
            ops: vec![Op::Add(1, 1), Op::Input(0)],
            output: 0,
        };
        assert!(Program::new(&forward, None).is_err());
        let out_of_range = ProgramSpec {
            n_inputs: 1,
            ops: vec![Op::Input(3)],
            output: 0,
        };
        assert!(Program::new(&out_of_range, None).is_err());
        let nan = ProgramSpec {
            n_inputs: 1,
            ops: vec![Op::Const(f64::NAN)],
            output: 0,
        };
        assert!(Program::new(&nan, None).is_err());
    }
}
