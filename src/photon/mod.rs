//! Photons: the compact record, the hand-written k-d tree, tracing from the lights, radiance estimates.
pub mod distributions;
pub mod estimate;
pub mod kdtree;
#[allow(clippy::module_inception)]
pub mod photon;
pub mod trace;
