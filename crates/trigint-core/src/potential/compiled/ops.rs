//! A tape's operations as the Python layer hands them over, and the functions they name.

use crate::description::{FromDescription, Value};
use crate::error::{CoreError, CoreResult};

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

impl FromDescription for ProgramSpec {
    /// A tape: `{"n": int, "ops": [(name, a, b?) …], "output": int}`, the operations named as
    /// in [`Op`] in lower case ("input", "const", "add", "sub", "mul", "div", "neg", "powi",
    /// "powf", "sqrt", "exp", "log", "sin", "cos", "tan", "sinh", "cosh", "tanh", "abs", "sign").
    fn from_description(d: &Value) -> CoreResult<Self> {
        let raw = d.field("ops")?.to_list("ops")?;
        let ops = raw
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let t = t.to_list("ops").map_err(|e| {
                    CoreError::invalid("ops", format!("program operation {k}: {e}"))
                })?;
                let name = t
                    .first()
                    .and_then(|x| x.to_str("ops").ok())
                    .ok_or_else(|| {
                        CoreError::invalid("ops", format!("program operation {k}: no name first"))
                    })?;
                let bad = |what: &str| {
                    CoreError::invalid("ops", format!("program operation {k} ({name:?}): {what}"))
                };
                let operand = |j: usize| t.get(j).and_then(|x| x.to_usize("ops").ok());
                let arg = |j: usize| operand(j).ok_or_else(|| bad("expected an operand index"));
                let num = |j: usize| {
                    t.get(j)
                        .and_then(|x| x.to_f64("ops").ok())
                        .ok_or_else(|| bad("expected a number"))
                };
                Ok(match name {
                    "input" => Op::Input(arg(1)?),
                    "const" => Op::Const(num(1)?),
                    "add" => Op::Add(arg(1)?, arg(2)?),
                    "sub" => Op::Sub(arg(1)?, arg(2)?),
                    "mul" => Op::Mul(arg(1)?, arg(2)?),
                    "div" => Op::Div(arg(1)?, arg(2)?),
                    "neg" => Op::Neg(arg(1)?),
                    "powi" => Op::Powi(
                        arg(1)?,
                        t.get(2)
                            .and_then(|x| x.to_i32("ops").ok())
                            .ok_or_else(|| bad("expected an integer exponent"))?,
                    ),
                    "powf" => Op::Powf(arg(1)?, num(2)?),
                    "sqrt" => Op::Sqrt(arg(1)?),
                    "exp" => Op::Exp(arg(1)?),
                    "log" => Op::Log(arg(1)?),
                    "sin" => Op::Sin(arg(1)?),
                    "cos" => Op::Cos(arg(1)?),
                    "tan" => Op::Tan(arg(1)?),
                    "sinh" => Op::Sinh(arg(1)?),
                    "cosh" => Op::Cosh(arg(1)?),
                    "tanh" => Op::Tanh(arg(1)?),
                    "abs" => Op::Abs(arg(1)?),
                    "sign" => Op::Sign(arg(1)?),
                    _ => return Err(bad("unknown operation")),
                })
            })
            .collect::<CoreResult<Vec<_>>>()?;
        Ok(ProgramSpec {
            n_inputs: d.field("n")?.to_usize("n")?,
            ops,
            output: d.field("output")?.to_usize("output")?,
        })
    }
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
