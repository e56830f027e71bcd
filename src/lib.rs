//! caustica: photon mapping and path tracing side by side, through Embree, measured against each other.
#![deny(unsafe_code)]

pub mod accel;
pub mod color;
pub mod math;
pub mod photon;
pub mod plan;
pub mod scene;

pub mod app;
pub mod bench;
pub mod cli;
pub mod film;
pub mod font;
pub mod integrator;
pub mod metrics;
pub mod output;
pub mod render;
pub mod timeerror;
pub mod tools;
