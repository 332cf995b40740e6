//! A potential's description as plain data: what a potential's `describe()` returns in Python
//! (numbers, strings, numeric arrays, lists and named fields), converted as it is by the binding.
//! Each native kind reads its own description (see `potential::Native`), so the binding has no
//! code per kind.
//!
//! ```
//! use trigint_core::description::Value;
//! let d = Value::dict([("kind", Value::from("fpu")), ("m", Value::Int(3))]);
//! assert_eq!(d.field("m").unwrap().to_usize("m").unwrap(), 3);
//! assert!(d.field("map").is_err() && d.optional("map").is_none());
//! ```

use crate::error::{CoreError, CoreResult};

/// One value of a description.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    None,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    /// A one-dimensional array of floats.
    Floats(Vec<f64>),
    /// A one-dimensional array of integers.
    Ints(Vec<i64>),
    List(Vec<Value>),
    /// Named fields, in the order given.
    Dict(Vec<(String, Value)>),
}

impl From<&str> for Value {
    fn from(s: &str) -> Self {
        Value::Str(s.to_owned())
    }
}

impl Value {
    /// Named fields from pairs.
    pub fn dict<'a>(fields: impl IntoIterator<Item = (&'a str, Value)>) -> Self {
        Value::Dict(fields.into_iter().map(|(k, v)| (k.to_owned(), v)).collect())
    }

    fn kind(&self) -> &'static str {
        match self {
            Value::None => "None",
            Value::Bool(_) => "a bool",
            Value::Int(_) => "an integer",
            Value::Float(_) => "a float",
            Value::Str(_) => "a string",
            Value::Floats(_) => "an array of floats",
            Value::Ints(_) => "an array of integers",
            Value::List(_) => "a list",
            Value::Dict(_) => "a dict",
        }
    }

    fn wrong(&self, name: &'static str, expected: &str) -> CoreError {
        CoreError::invalid(name, format!("expected {expected}, got {}", self.kind()))
    }

    /// The field `key` of a dict (an error naming the key if it is missing or this is no dict).
    pub fn field(&self, key: &'static str) -> CoreResult<&Value> {
        match self {
            Value::Dict(fields) => fields
                .iter()
                .find(|(k, _)| k == key)
                .map(|(_, v)| v)
                .ok_or_else(|| CoreError::invalid(key, "missing from the description")),
            other => Err(other.wrong(key, "a dict holding it")),
        }
    }

    /// This value, which must be a dict (`name`: the field that holds it, for the error).
    pub fn to_dict(&self, name: &'static str) -> CoreResult<&Value> {
        match self {
            Value::Dict(_) => Ok(self),
            other => Err(other.wrong(name, "a dict")),
        }
    }

    /// The field `key`, or None where it is missing or None.
    pub fn optional(&self, key: &'static str) -> Option<&Value> {
        match self.field(key) {
            Ok(Value::None) | Err(_) => None,
            Ok(v) => Some(v),
        }
    }

    pub fn to_str(&self, name: &'static str) -> CoreResult<&str> {
        match self {
            Value::Str(s) => Ok(s),
            other => Err(other.wrong(name, "a string")),
        }
    }

    pub fn to_usize(&self, name: &'static str) -> CoreResult<usize> {
        match self {
            Value::Int(i) if *i >= 0 => Ok(*i as usize),
            Value::Int(i) => Err(CoreError::invalid(
                name,
                format!("expected a non-negative integer, got {i}"),
            )),
            other => Err(other.wrong(name, "an integer")),
        }
    }

    pub fn to_i32(&self, name: &'static str) -> CoreResult<i32> {
        match self {
            Value::Int(i) => i32::try_from(*i)
                .map_err(|_| CoreError::invalid(name, format!("{i} is out of range"))),
            other => Err(other.wrong(name, "an integer")),
        }
    }

    pub fn to_f64(&self, name: &'static str) -> CoreResult<f64> {
        match self {
            Value::Float(x) => Ok(*x),
            Value::Int(i) => Ok(*i as f64),
            other => Err(other.wrong(name, "a number")),
        }
    }

    pub fn to_list(&self, name: &'static str) -> CoreResult<&[Value]> {
        match self {
            Value::List(items) => Ok(items),
            other => Err(other.wrong(name, "a list")),
        }
    }

    /// Numbers: an array, or a list of numbers.
    pub fn to_f64s(&self, name: &'static str) -> CoreResult<Vec<f64>> {
        match self {
            Value::Floats(v) => Ok(v.clone()),
            Value::Ints(v) => Ok(v.iter().map(|&i| i as f64).collect()),
            Value::List(items) => items.iter().map(|x| x.to_f64(name)).collect(),
            other => Err(other.wrong(name, "numbers")),
        }
    }

    /// Indices: an array of integers, or a list of them.
    pub fn to_usizes(&self, name: &'static str) -> CoreResult<Vec<usize>> {
        match self {
            Value::Floats(v) if v.is_empty() => Ok(Vec::new()),
            Value::Ints(v) => v.iter().map(|&i| Value::Int(i).to_usize(name)).collect(),
            Value::List(items) => items.iter().map(|x| x.to_usize(name)).collect(),
            other => Err(other.wrong(name, "indices")),
        }
    }
}

/// What is read from a description: a native potential kind (see `potential::Native`) or a
/// part of one (a tape, a linear map).
pub trait FromDescription: Sized {
    fn from_description(d: &Value) -> CoreResult<Self>;
}

impl<T: FromDescription> FromDescription for Box<T> {
    fn from_description(d: &Value) -> CoreResult<Self> {
        T::from_description(d).map(Box::new)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_read_with_errors_that_name_them() {
        let d = Value::dict([
            ("n", Value::Int(-1)),
            ("xs", Value::List(vec![Value::Int(1), Value::Float(0.5)])),
            ("idx", Value::Ints(vec![0, 2])),
        ]);
        assert_eq!(d.field("xs").unwrap().to_f64s("xs").unwrap(), [1.0, 0.5]);
        assert_eq!(d.field("idx").unwrap().to_usizes("idx").unwrap(), [0, 2]);
        let e = d.field("n").unwrap().to_usize("n").unwrap_err().to_string();
        assert!(e.contains("`n`") && e.contains("non-negative"), "{e}");
        let e = d
            .field("xs")
            .unwrap()
            .to_usizes("xs")
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected an integer, got a float"), "{e}");
        let e = d.field("kind").unwrap_err().to_string();
        assert!(e.contains("`kind`") && e.contains("missing"), "{e}");
        assert_eq!(
            Value::Int(1).field("a").unwrap_err().to_string(),
            "invalid argument `a`: expected a dict holding it, got an integer"
        );
    }
}
