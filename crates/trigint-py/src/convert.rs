//! Typed inputs: what the Python layer (`trigint._native`) hands over, checked and converted
//! into core types. Errors name the field and say what was expected.

use numpy::{
    PyArrayDescrMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::conversion::FromPyObjectOwned;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyString, PyTuple};
use trigint_core::description::Value;
use trigint_core::energy::PairForms;
use trigint_core::{Form, Layout, MethodCoefficients, Record};

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
    // {"a", "b", "weights", "axes"}: the pair form of a wave equation's momentum (optional;
    // without "axes", the weights per pair)
    let pair_forms = match d.get_item("pair_forms")? {
        Some(f) if !f.is_none() => {
            let f = f.cast::<PyDict>()?;
            let (a, b): (Vec<usize>, Vec<usize>) = (item(f, "a")?, item(f, "b")?);
            let weights = vec1(item(f, "weights")?);
            let axes = match f.get_item("axes")? {
                Some(x) => x.extract::<usize>()?,
                None => weights.len().checked_div(a.len()).unwrap_or(0),
            };
            Some(
                PairForms::new(a, b, weights, axes, omega2.len())
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

/// A description as plain data ([`Value`]), converted the same way for every kind: dicts with
/// string keys, lists and tuples, 1-d NumPy arrays (integer ones as integers, float ones as
/// floats), numbers (NumPy's scalars too), strings, bools and None.
pub fn description(obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    value_at(obj, "description")
}

/// [`description`] of the value at `path` (named in errors, e.g. `description["terms"][3]`).
fn value_at(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<Value> {
    let unsupported = |what: String| {
        PyTypeError::new_err(format!(
            "{path}: {what}; a description holds dicts, lists, tuples, 1-d numeric arrays, \
             numbers, strings, bools and None"
        ))
    };
    if obj.is_none() {
        return Ok(Value::None);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::Str(s.to_str()?.to_owned()));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        return d
            .iter()
            .map(|(k, v)| {
                let key: String = k
                    .extract()
                    .map_err(|_| unsupported(format!("the key {k} is not a string")))?;
                let inner = value_at(&v, &format!("{path}[{key:?}]"))?;
                Ok((key, inner))
            })
            .collect::<PyResult<_>>()
            .map(Value::Dict);
    }
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        if a.ndim() != 1 {
            return Err(unsupported(format!("a {}-d array", a.ndim())));
        }
        return match a.dtype().kind() {
            b'f' => {
                let a = obj.call_method1("astype", ("float64",))?;
                Ok(Value::Floats(
                    a.extract::<PyReadonlyArray1<f64>>()?.as_array().to_vec(),
                ))
            }
            b'i' | b'u' => {
                let a = obj.call_method1("astype", ("int64",))?;
                Ok(Value::Ints(
                    a.extract::<PyReadonlyArray1<i64>>()?.as_array().to_vec(),
                ))
            }
            _ => Err(unsupported(format!("an array of dtype {}", a.dtype()))),
        };
    }
    let items = |it: &mut dyn Iterator<Item = Bound<'_, PyAny>>| {
        it.enumerate()
            .map(|(i, x)| value_at(&x, &format!("{path}[{i}]")))
            .collect::<PyResult<_>>()
            .map(Value::List)
    };
    if let Ok(l) = obj.cast::<PyList>() {
        return items(&mut l.iter());
    }
    if let Ok(t) = obj.cast::<PyTuple>() {
        return items(&mut t.iter());
    }
    if let Ok(i) = obj.extract::<i64>() {
        return Ok(Value::Int(i));
    }
    if let Ok(x) = obj.extract::<f64>() {
        return Ok(Value::Float(x));
    }
    Err(unsupported(format!(
        "a value of type {}",
        obj.get_type().name()?
    )))
}
