//! Integrators: the path tracer (reference), the photon-map eye pass and the progressive photon
//! mappers, bidirectional path tracing and vertex connection and merging, sharing light sampling and the walk of a camera ray through mirrors and glass.
pub mod direct;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod sppm;
pub mod vcm;

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

/// Where a camera ray's chain of non-diffuse bounces (mirrors, glass, rough metal, each sampled) first
/// meets a diffuse surface, and the chain's throughput there.
#[derive(Clone, Copy, Debug)]
pub struct ChainEnd {
    pub si: crate::scene::SurfaceHit,
    pub wo: glam::Vec3,
    pub beta: crate::color::Rgb,
}

/// Follows `ray` (throughput `beta`) through non-diffuse surfaces, at most `render.max_depth + 1`
/// hits, to the first diffuse one. Returns the emission seen on the way, weighted by the throughput
/// (the diffuse hit's own included), and the diffuse hit, if the chain reached one.
pub fn specular_chain(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    mut ray: crate::math::Ray,
    mut beta: crate::color::Rgb,
    rng: &mut crate::math::Rng,
    c: &mut Counters,
) -> (crate::color::Rgb, Option<ChainEnd>) {
    use crate::color::Rgb;
    let mut emitted = Rgb::ZERO;
    for _ in 0..=scene.render.max_depth {
        c.rays += 1;
        let Some(crate::accel::Interaction { si, wo, .. }) = crate::accel::interact(scene, tracer, &ray) else {
            emitted += beta * scene.lights.env_radiance(ray.d);
            break;
        };
        emitted += beta * scene.emitted(&si, wo);
        let mat = scene.bsdf(&si, wo);
        if mat.is_diffuse() {
            return (emitted, Some(ChainEnd { si, wo, beta }));
        }
        let Some((bs, next)) = si.scatter(&mat, wo, rng, crate::scene::TransportMode::Radiance) else {
            break;
        };
        beta *= bs.weight;
        if beta == Rgb::ZERO {
            break;
        }
        ray = next;
    }
    (emitted, None)
}
