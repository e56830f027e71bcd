//! Unidirectional path tracer: next-event estimation with MIS (area and sphere lights), shadow rays for
//! point lights (through see-through surfaces, by their transmittance), delta BSDFs sampled exactly,
//! see-through surfaces crossed as no bounce, Russian roulette after `rr_depth` bounces on the
//! throughput without refraction's 1/η² radiance scale. Segments inside coloured glass are dimmed by its
//! absorption (`Scene::sigma_leaving`).
use super::direct::{emission_seen, estimate_direct_with, DirectStrategy};
use super::{Counters, LineOfSight};
use crate::accel::{Interaction, Tracer};
use crate::color::Rgb;
use crate::math::sampling::russian_roulette;
use crate::math::{max_component, Ray, Rng};
use crate::scene::{Scene, TransportMode};

pub struct PathTracer<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a dyn Tracer,
    pub max_depth: u32,
    pub rr_depth: u32,
}

impl PathTracer<'_> {
    /// Radiance arriving along `ray` (towards its origin).
    pub fn li(&self, mut ray: Ray, rng: &mut Rng, c: &mut Counters) -> Rgb {
        let scene = self.scene;
        let mut l = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        // Product of the refractions' radiance scales (1/η² each): divided out for Russian roulette.
        let mut radiance_scale = 1.0f32;
        let mut specular = true;
        let mut prev_pdf = 0.0f32;
        let mut prev_p = ray.o;
        let mut view = LineOfSight::CAMERA;
        // Absorption of the medium the current segment runs through (`Scene::sigma_next`): none from
        // the camera (Mitsuba's sensor without a medium), set where the path leaves a medium's boundary.
        let mut sigma = Rgb::ZERO;
        for depth in 0.. {
            c.rays += 1;
            let mut found = view.trace(scene, self.tracer, &ray, c);
            // Past see-through surfaces (out of line: most scenes have none), with the BSDF picked where
            // the path scatters.
            let mut picked = None;
            if let Some(f) = found.take_if(|f| scene.is_see_through(f.si.shape)) {
                let (at, tr) = view.cross_from(scene, self.tracer, &ray, f, rng, c);
                beta *= tr;
                found = at.map(|(i, m)| {
                    picked = Some(m);
                    i
                });
            }
            beta *= scene.absorbed_to(sigma, &ray, found.as_ref().map(|f| f.hit.t));
            let (le, w) = emission_seen(scene, found.as_ref(), ray.d, (!specular).then_some((prev_pdf, prev_p)));
            if le != Rgb::ZERO && !view.hides(scene) {
                l += beta * le * w;
            }
            let Some(Interaction { si, wo, .. }) = found else {
                break;
            };
            if depth >= self.max_depth {
                break;
            }
            let mat = picked.unwrap_or_else(|| scene.bsdf(&si, wo, || rng.next_f32()));
            if !mat.is_delta() {
                l += beta * estimate_direct_with(scene, self.tracer, &si, wo, &mat, sigma, rng, c, DirectStrategy::Mis);
            }
            let Some((bs, next)) = si.scatter(&mat, wo, rng, TransportMode::Radiance) else {
                break;
            };
            view = view.after(&mat, bs.transmitted);
            beta *= bs.weight;
            radiance_scale *= bs.radiance_scale;
            specular = bs.delta;
            prev_pdf = bs.pdf;
            prev_p = si.p;
            sigma = scene.sigma_next(&si, next.d, sigma);
            ray = next;
            if depth + 1 >= self.rr_depth {
                let Some(q) = russian_roulette(max_component(beta) / radiance_scale, rng.next_f32()) else {
                    break;
                };
                beta /= q;
            }
        }
        l
    }
}
