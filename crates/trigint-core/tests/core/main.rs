//! The core's integration tests, through its public interface alone. One test crate, so that
//! the kernels the three files share are compiled and linked once (three crates built them
//! three times: a fifth of the Rust tests' build).

mod batch;
mod kernel;
mod wave;
