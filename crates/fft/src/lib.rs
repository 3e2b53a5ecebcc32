//! rubscan's real FFT plans in double precision, behind functions that are not generic.
//!
//! realfft's and rustfft's planners are generic over the float type, so each crate that plans
//! an FFT compiles every algorithm the planner may pick: all the butterflies, for each SIMD
//! path (AVX, SSE, scalar). In rubscan that was 18 % of the library's LLVM IR
//! (`cargo llvm-lines`), compiled twice per test build (the library and its unit tests).
//! Planned here, that code is compiled once, with the dependencies, and rubscan calls two
//! plain functions. The plans are realfft's, unchanged: the numbers are the same.

use std::sync::Arc;

pub use realfft::num_complex::{Complex, Complex64};
pub use realfft::{ComplexToReal, RealToComplex};

/// A planner of real FFTs of f64 (realfft's), which reuses the plans it has made for a length.
pub struct RealFftPlanner64(realfft::RealFftPlanner<f64>);

impl RealFftPlanner64 {
    /// A planner with no plans yet.
    pub fn new() -> Self {
        Self(realfft::RealFftPlanner::new())
    }

    /// The forward transform of `n` real samples into `n / 2 + 1` complex ones.
    pub fn plan_fft_forward(&mut self, n: usize) -> Arc<dyn RealToComplex<f64>> {
        self.0.plan_fft_forward(n)
    }

    /// The inverse transform of `n / 2 + 1` complex samples into `n` real ones (unnormalised,
    /// as rustfft's: forward then inverse scales by `n`).
    pub fn plan_fft_inverse(&mut self, n: usize) -> Arc<dyn ComplexToReal<f64>> {
        self.0.plan_fft_inverse(n)
    }
}

impl Default for RealFftPlanner64 {
    fn default() -> Self {
        Self::new()
    }
}
