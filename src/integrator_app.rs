//! Photon-map render modes (placeholder until the photon mapper lands).
use crate::accel::Accel;
use crate::cli::RenderArgs;
use crate::scene::Scene;
use anyhow::Result;
use std::path::Path;

pub fn render_photon_modes(
    _scene: &Scene,
    _accel: &Accel,
    _a: &RenderArgs,
    _out: &Path,
    _bvh_s: f64,
) -> Result<()> {
    anyhow::bail!("photon mapping is not available yet")
}
