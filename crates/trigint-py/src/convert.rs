//! Typed inputs: what the Python layer (`trigint._native`) hands over, checked and converted
//! into core types. Errors name the field and say what was expected.

use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::conversion::FromPyObjectOwned;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use trigint_core::energy::PairForms;
use trigint_core::{Form, Layout, LinearMap, MethodCoefficients, Op, ProgramSpec, Record};

/// `d[key]`, or a TypeError naming the key.
pub fn item<'py, T: FromPyObjectOwned<'py>>(d: &Bound<'py, PyDict>, key: &str) -> PyResult<T> {
    let value = d
        .get_item(key)?
        .ok_or_else(|| PyTypeError::new_err(format!("missing field {key:?}")))?;
    value.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        PyTypeError::new_err(format!("field {key:?}: {e}"))
    })
}

pub fn vec1(a: PyReadonlyArray1<f64>) -> Vec<f64> {
    a.as_array().to_vec()
}

/// The problem's arrangement: `{"omega2", "n_slow", "block_ends"}`.
pub fn layout(d: &Bound<'_, PyDict>) -> PyResult<Layout> {
    let omega2 = vec1(item(d, "omega2")?);
    // {"a", "b", "weights"}: the pair form of a wave equation's momentum (optional)
    let pair_forms = match d.get_item("pair_forms")? {
        Some(f) if !f.is_none() => {
            let f = f.cast::<PyDict>()?;
            Some(
                PairForms::new(
                    item(f, "a")?,
                    item(f, "b")?,
                    vec1(item(f, "weights")?),
                    omega2.len(),
                )
                .map_err(|e| PyValueError::new_err(e.to_string()))?,
            )
        }
        _ => None,
    };
    Ok(Layout {
        omega2,
        n_slow: item(d, "n_slow")?,
        block_ends: item(d, "block_ends")?,
        pair_forms,
    })
}

/// One method: `{"h": float, <row>: 1-d array, …}`, the rows named as in
/// [`MethodCoefficients::ROWS`].
pub fn method(d: &Bound<'_, PyDict>) -> PyResult<MethodCoefficients> {
    MethodCoefficients::from_rows(item(d, "h")?, |k| {
        item::<PyReadonlyArray1<f64>>(d, k).map(vec1)
    })
}

/// One method per trajectory: `{"h": 1-d array (B,), <row>: 2-d array (B, n), …}`.
pub fn methods(d: &Bound<'_, PyDict>) -> PyResult<Vec<MethodCoefficients>> {
    let h = vec1(item(d, "h")?);
    let mut tables = Vec::with_capacity(MethodCoefficients::ROWS.len());
    for &k in MethodCoefficients::ROWS {
        let t = item::<PyReadonlyArray2<f64>>(d, k)?;
        if t.shape()[0] != h.len() {
            return Err(PyValueError::new_err(format!(
                "{k}: {} rows for {} trajectories",
                t.shape()[0],
                h.len()
            )));
        }
        tables.push((k, t));
    }
    let table = |k: &str| {
        &tables
            .iter()
            .find(|(name, _)| *name == k)
            .expect("every row")
            .1
    };
    (0..h.len())
        .map(|b| {
            MethodCoefficients::from_rows(h[b], |k| {
                Ok::<_, PyErr>(table(k).as_array().row(b).to_vec())
            })
        })
        .collect()
}

pub fn form(name: &str) -> PyResult<Form> {
    match name {
        "two-step" => Ok(Form::TwoStep),
        "one-step" => Ok(Form::OneStep),
        other => Err(PyValueError::new_err(format!(
            "form must be 'two-step' or 'one-step', got {other:?}"
        ))),
    }
}

pub fn record(save_every: Option<u64>, track: bool) -> Record {
    Record { save_every, track }
}

/// A sparse matrix in compressed rows: `{"rows", "cols", "ptr", "idx", "vals"}`.
pub fn linear_map(d: &Bound<'_, PyDict>) -> PyResult<LinearMap> {
    let ptr: Vec<usize> = item(d, "ptr")?;
    let idx: Vec<usize> = item(d, "idx")?;
    let vals = vec1(item(d, "vals")?);
    LinearMap::from_csr(item(d, "rows")?, item(d, "cols")?, &ptr, &idx, &vals)
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// A tape: `{"n": int, "ops": [(name, a, b?) …], "output": int}`, with the operations named
/// as in [`Op`] ("input", "const", "add", "sub", "mul", "div", "neg", "powi", "powf", "sqrt",
/// "exp", "log", "sin", "cos", "tan", "sinh", "cosh", "tanh", "abs", "sign").
pub fn program(d: &Bound<'_, PyDict>) -> PyResult<ProgramSpec> {
    let raw: Vec<Bound<'_, PyTuple>> = item(d, "ops")?;
    let mut ops = Vec::with_capacity(raw.len());
    for (k, t) in raw.iter().enumerate() {
        let name: String = t.get_item(0)?.extract()?;
        let bad =
            |what: &str| PyValueError::new_err(format!("program operation {k} ({name:?}): {what}"));
        let arg = |j: usize| -> PyResult<usize> {
            t.get_item(j)
                .and_then(|x| x.extract())
                .map_err(|_| bad("expected an operand index"))
        };
        let num = |j: usize| -> PyResult<f64> {
            t.get_item(j)
                .and_then(|x| x.extract())
                .map_err(|_| bad("expected a number"))
        };
        let op = match name.as_str() {
            "input" => Op::Input(arg(1)?),
            "const" => Op::Const(num(1)?),
            "add" => Op::Add(arg(1)?, arg(2)?),
            "sub" => Op::Sub(arg(1)?, arg(2)?),
            "mul" => Op::Mul(arg(1)?, arg(2)?),
            "div" => Op::Div(arg(1)?, arg(2)?),
            "neg" => Op::Neg(arg(1)?),
            "powi" => Op::Powi(
                arg(1)?,
                t.get_item(2)
                    .and_then(|x| x.extract())
                    .map_err(|_| bad("expected an integer exponent"))?,
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
        };
        ops.push(op);
    }
    Ok(ProgramSpec {
        n_inputs: item(d, "n")?,
        ops,
        output: item(d, "output")?,
    })
}
