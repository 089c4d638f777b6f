//! Random numbers and the warps that turn them into directions and points.

pub mod distribution;
pub mod sampler;
pub mod sobol;
pub mod warp;

#[cfg(test)]
pub mod chi2;

pub use distribution::Distribution1D;
pub use sampler::PixelSampler;
