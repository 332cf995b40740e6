//! The native kinds by name: a potential built from its description (`describe()` in Python,
//! see [`description`](crate::description)), and the one dispatch from it to the generic entry
//! points. A new kind is its own file (implementing [`Potential`](super::Potential) and
//! [`FromDescription`]) plus its `mod` line in `potential/mod.rs` and two lines here (its entry
//! in `native_kinds!` and its arm in `with_native!`): the binding and the entry points need
//! nothing new.

use super::{Chain, Fpu, Program, Wave};
use crate::description::{FromDescription, Value};
use crate::error::{CoreError, CoreResult};

/// The kinds, written once: each `"name" => Variant(Type)` gives the variant of [`Native`], its
/// entry in [`Native::KINDS`] and its case in [`Native::from_description`].
macro_rules! native_kinds {
    ($($name:literal => $variant:ident($ty:ty)),* $(,)?) => {
        /// A potential of one of the native kinds.
        #[derive(Debug)]
        pub enum Native {
            $($variant($ty)),*
        }

        impl Native {
            /// The kinds' names, as a description's `"kind"` gives them.
            pub const KINDS: &'static [&'static str] = &[$($name),*];

            /// The potential of a description `{"kind": …, …}`.
            pub fn from_description(d: &Value) -> CoreResult<Self> {
                Ok(match d.field("kind")?.to_str("kind")? {
                    $($name => Self::$variant(FromDescription::from_description(d)?),)*
                    other => {
                        return Err(CoreError::invalid(
                            "kind",
                            format!(
                                "unknown potential kind {other:?}; expected one of {}",
                                Self::KINDS.join(", ")
                            ),
                        ))
                    }
                })
            }
        }
    };
}

native_kinds! {
    "fpu" => Fpu(Fpu),
    "program" => Program(Program),
    "chain" => Chain(Chain),
    "wave" => Wave(Box<Wave>),
}

impl Native {
    /// Instructions of the force-only code of a compiled program (None for other kinds).
    pub fn instructions(&self) -> Option<usize> {
        match self {
            Self::Program(p) => Some(p.force_instructions()),
            _ => None,
        }
    }
}

/// Runs `$body` with `$p` bound to the concrete potential of a `&Native`: the one dispatch from
/// a built potential to the generic entry points.
#[macro_export]
macro_rules! with_native {
    ($pot:expr, |$p:ident| $body:expr) => {
        match $pot {
            $crate::potential::Native::Fpu($p) => $body,
            $crate::potential::Native::Program($p) => $body,
            $crate::potential::Native::Chain($p) => $body,
            $crate::potential::Native::Wave($p) => {
                let $p: &$crate::potential::Wave = $p;
                $body
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tape(n: i64) -> Vec<(&'static str, Value)> {
        // U = x0⁴/4 as a tape: input, powi, const, mul
        let op = |items: Vec<Value>| Value::List(items);
        vec![
            ("n", Value::Int(n)),
            (
                "ops",
                Value::List(vec![
                    op(vec!["input".into(), Value::Int(0)]),
                    op(vec!["powi".into(), Value::Int(0), Value::Int(4)]),
                    op(vec!["const".into(), Value::Float(0.25)]),
                    op(vec!["mul".into(), Value::Int(1), Value::Int(2)]),
                ]),
            ),
            ("output", Value::Int(3)),
        ]
    }

    #[test]
    fn each_kind_is_built_from_its_description() {
        use crate::Potential;
        let fpu =
            Native::from_description(&Value::dict([("kind", "fpu".into()), ("m", Value::Int(3))]))
                .unwrap();
        assert!(matches!(&fpu, Native::Fpu(f) if f.m == 3 && f.map.is_none()));
        let mut program = tape(1);
        program.push(("kind", "program".into()));
        let program = Native::from_description(&Value::dict(program)).unwrap();
        let x = [2.0];
        let mut g = [0.0];
        with_native!(&program, |p| {
            let mut ws = p.workspace::<f64>();
            let u = p.force(&x, &mut g, true, &mut ws).unwrap();
            assert_eq!((u, g[0]), (4.0, -8.0));
        });
        assert_eq!(program.instructions().map(|k| k > 0), Some(true));
        let map = Value::dict([
            ("rows", Value::Int(1)),
            ("cols", Value::Int(2)),
            ("ptr", Value::Ints(vec![0, 2])),
            ("idx", Value::List(vec![Value::Int(0), Value::Int(1)])),
            ("vals", Value::Floats(vec![1.0, -1.0])),
        ]);
        let chain = Native::from_description(&Value::dict([
            ("kind", "chain".into()),
            ("n", Value::Int(2)),
            (
                "terms",
                Value::List(vec![Value::dict([
                    ("v", Value::dict(tape(1))),
                    ("map", map),
                ])]),
            ),
        ]))
        .unwrap();
        with_native!(&chain, |p| {
            let mut ws = p.workspace::<f64>();
            let mut g = [0.0; 2];
            // U = (x0 − x1)⁴/4 at (3, 1): 4, g = (−8, 8)
            assert_eq!(p.force(&[3.0, 1.0], &mut g, true, &mut ws).unwrap(), 4.0);
            assert_eq!(g, [-8.0, 8.0]);
        });
    }

    #[test]
    fn every_kind_is_dispatched_by_its_name() {
        for kind in Native::KINDS {
            let e = Native::from_description(&Value::dict([("kind", (*kind).into())]));
            let e = e.unwrap_err().to_string();
            assert!(e.contains("missing from the description"), "{kind}: {e}");
        }
    }

    #[test]
    fn a_bad_description_says_what_is_wrong() {
        let err = |d: Value| Native::from_description(&d).unwrap_err().to_string();
        let e = err(Value::dict([("kind", "spline".into())]));
        assert!(
            e.contains("unknown potential kind \"spline\"")
                && e.contains("fpu, program, chain, wave"),
            "{e}"
        );
        let e = err(Value::dict([("kind", "fpu".into())]));
        assert!(e.contains("`m`") && e.contains("missing"), "{e}");
        let mut bad = tape(1);
        bad[1].1 = Value::List(vec![Value::List(vec!["cbrt".into(), Value::Int(0)])]);
        bad.push(("kind", "program".into()));
        let e = err(Value::dict(bad));
        assert!(
            e.contains("program operation 0 (\"cbrt\"): unknown operation"),
            "{e}"
        );
        let e = err(Value::dict([
            ("kind", "chain".into()),
            ("n", Value::Int(2)),
            (
                "terms",
                Value::List(vec![Value::dict([("v", Value::dict(tape(1)))])]),
            ),
        ]));
        assert!(
            e.contains("term 0: invalid argument `map`: a chain term needs its map"),
            "{e}"
        );
        let e = err(Value::dict([
            ("kind", "fpu".into()),
            ("m", Value::Int(2)),
            ("map", Value::List(vec![])),
        ]));
        assert!(e.contains("`map`: expected a dict, got a list"), "{e}");
    }
}
