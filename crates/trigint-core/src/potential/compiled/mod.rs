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
//! same codes as machine code ([`jit`]), with the same bits.
//!
//! The pieces, each depending only on those listed before it:
//! - [`ops`]: the tape as Python hands it over ([`Op`], [`ProgramSpec`]) and the operations;
//! - [`libm`]: the libm shim (sin and cos of one argument in one call);
//! - [`graph`]: the hash-consed graph, its exact rewrites, adjoints and power lowering;
//! - [`code`]: straight-line codes scheduled from the graph, and their interpreter;
//! - [`jit`]: the codes as machine code (depends on `code`, `ops` and `libm` only);
//! - [`program`]: the [`Program`] potential: three codes, their machine code, the walks.

pub mod code;
pub mod graph;
pub mod jit;
pub mod libm;
pub mod ops;
pub mod program;
#[cfg(test)]
mod tests;

pub use ops::{Op, ProgramSpec};
pub use program::Program;
