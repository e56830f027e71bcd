//! Unidirectional path tracer: next-event estimation with MIS (area and sphere lights), shadow rays for
//! point lights, delta BSDFs sampled exactly, Russian roulette after `rr_depth` bounces.
use super::direct::estimate_direct;
use super::Counters;
use crate::accel::{interact, Interaction, Tracer};
use crate::color::Rgb;
use crate::math::{max_component, sampling::power_heuristic, Ray, Rng};
use crate::scene::Scene;

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
        let mut specular = true;
        let mut prev_pdf = 0.0f32;
        let mut prev_p = ray.o;
        for depth in 0.. {
            c.rays += 1;
            let Some(Interaction { hit, si, wo }) = interact(scene, self.tracer, &ray) else {
                break;
            };
            let le = scene.emitted(&si, wo);
            if le != Rgb::ZERO {
                let w = if specular {
                    1.0
                } else {
                    power_heuristic(prev_pdf, scene.lights.pdf(scene, hit.shape, hit.prim, prev_p, si.p, si.ng))
                };
                l += beta * le * w;
            }
            if depth >= self.max_depth {
                break;
            }
            let mat = scene.material_of(hit.shape);
            if !mat.is_delta() {
                l += beta * estimate_direct(scene, self.tracer, &si, wo, rng, c, true);
            }
            let Some((bs, next)) = si.scatter(mat, wo, rng, true) else {
                break;
            };
            beta *= bs.weight;
            specular = bs.delta;
            prev_pdf = bs.pdf;
            prev_p = si.p;
            ray = next;
            if depth + 1 >= self.rr_depth {
                let q = max_component(beta).min(0.95);
                if q <= 0.0 || rng.next_f32() >= q {
                    break;
                }
                beta /= q;
            }
        }
        l
    }
}
