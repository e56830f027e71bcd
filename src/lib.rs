//! caustica: photon mapping and path tracing side by side, through Embree, measured against each other.
//! Modules are listed in dependency order: none uses a module listed after it.
#![deny(unsafe_code)]

pub mod accel;
pub mod color;
pub mod cpu;
pub mod film;
pub mod integrator;
pub mod math;
pub mod metrics;
pub mod output;
pub mod parts;
pub mod photon;
pub mod pipeline;
pub mod plan;
pub mod progress;
pub mod render;
pub mod scene;

pub mod app;
pub mod bench;
pub mod cli;
pub mod font;
pub mod timeerror;
pub mod tools;
