//! The hash-consed expression graph: every node once, exact rewrites only (constant folding,
//! signs), reverse-mode adjoints, and integer powers lowered to multiplication chains.

use std::collections::HashMap;

use super::ops::{Binary, Unary};

/// A node of the graph; constants are keyed by their bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Node {
    Input(u32),
    Const(u64),
    Bin(Binary, u32, u32),
    Un(Unary, u32),
    Powi(u32, i32),
    Powf(u32, u64),
}

/// A hash-consed expression graph: every node once, operands before the nodes that use them.
#[derive(Default)]
pub(super) struct Graph {
    pub(super) nodes: Vec<Node>,
    index: HashMap<Node, u32>,
}

impl Graph {
    pub(super) fn node(&self, id: u32) -> Node {
        self.nodes[id as usize]
    }

    pub(super) fn constant_of(&self, id: u32) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    pub(super) fn intern(&mut self, node: Node) -> u32 {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    pub(super) fn constant(&mut self, c: f64) -> u32 {
        self.intern(Node::Const(c.to_bits()))
    }

    pub(super) fn input(&mut self, i: usize) -> u32 {
        self.intern(Node::Input(i as u32))
    }

    pub(super) fn neg_of(&self, id: u32) -> Option<u32> {
        match self.node(id) {
            Node::Un(Unary::Neg, a) => Some(a),
            _ => None,
        }
    }

    pub(super) fn unary(&mut self, op: Unary, a: u32) -> u32 {
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

    pub(super) fn binary(&mut self, op: Binary, a: u32, b: u32) -> u32 {
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

    pub(super) fn add(&mut self, a: u32, b: u32) -> u32 {
        self.binary(Binary::Add, a, b)
    }

    pub(super) fn mul(&mut self, a: u32, b: u32) -> u32 {
        self.binary(Binary::Mul, a, b)
    }

    pub(super) fn powi(&mut self, a: u32, k: i32) -> u32 {
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

    pub(super) fn powf(&mut self, a: u32, c: f64) -> u32 {
        if c == 1.0 {
            return a;
        }
        if let Some(x) = self.constant_of(a) {
            return self.constant(x.powf(c));
        }
        self.intern(Node::Powf(a, c.to_bits()))
    }

    /// a^k by repeated squaring: a³ = (a·a)·a, a⁴ = (a·a)·(a·a); the squares are shared.
    pub(super) fn power_chain(&mut self, a: u32, k: i32) -> u32 {
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
    pub(super) fn adjoints(&mut self, out: u32, n_inputs: usize, seed: f64) -> Vec<Option<u32>> {
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
    pub(super) fn lower_powers(&self, roots: &[u32]) -> (Graph, Vec<u32>) {
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
