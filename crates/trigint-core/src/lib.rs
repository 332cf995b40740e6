//! trigint-core: the numerical core of trigint.
//!
//! Long-time integration of q'' + Ω²q = −∇U(q) by trigonometric and modified trigonometric
//! integrators (Cohen, Gauckler, Hairer, Lubich, BIT 2015). Methods arrive as per-coordinate
//! coefficient arrays ([`MethodCoefficients`]); one recursion ([`recursion`]), written once over
//! a lane-generic number type ([`Real`]), steps every method, for one trajectory or for bundles
//! of them ([`run`]).

// Loops over lanes and coordinates index several arrays of equal, validated length in lockstep;
// written with indices they are what the vectorizer handles best (see docs/design.md).
#![allow(clippy::needless_range_loop)]

pub mod basis;
pub mod channels;
pub mod coefficients;
pub mod coordinates;
pub mod cpu;
pub mod description;
pub mod energy;
pub mod error;
#[doc(hidden)]
pub mod fixtures;
pub mod isa;
pub mod krylov;
pub mod output;
pub mod plan;
pub mod potential;
pub mod prepared;
pub mod real;
pub mod recursion;
pub mod recycle;
pub mod resident;
pub mod run;
pub mod shape;
pub mod spectral;
pub mod sum;

pub use channels::{channel_count, channel_names, Channel, CHANNELS};
pub use coefficients::MethodCoefficients;
pub use energy::Samples;
pub use error::{CoreError, CoreResult};
pub use output::{Form, Record, Status, TrajectoryOutput};
pub use potential::{
    Chain, ChainTerm, Fpu, LinearMap, Native, Op, Potential, Program, ProgramSpec, Scratch, Wave,
};
pub use prepared::{PreparedLayout, PreparedMethod};
pub use real::{LaneSet, Lanes, Real, Scalar, MAX_LANES};
pub use run::tangent::tangent;
pub use run::Control;
pub use run::{integrate, integrate_batch, integrate_prepared, tangent_batch};
pub use run::{TangentOutput, TangentRequest};
pub use shape::Layout;

/// Trajectories per bundle of the batched kernel: one AVX-512 register of f64.
pub type BatchLanes = Lanes<8>;
