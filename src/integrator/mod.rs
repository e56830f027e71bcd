//! Integrators: the path tracer (reference) and the photon-map eye pass, sharing light sampling.
pub mod direct;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod sppm;

/// Per-thread counters, summed after a render.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    pub rays: u64,
    pub nonfinite: u64,
}

impl std::ops::AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        self.rays += o.rays;
        self.nonfinite += o.nonfinite;
    }
}
