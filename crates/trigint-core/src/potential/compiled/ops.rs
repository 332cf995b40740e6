//! A tape's operations as the Python layer hands them over, and the functions they name.

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
    pub(super) fn scalar(self, a: f64, b: f64) -> f64 {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
        }
    }
}
