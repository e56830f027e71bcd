//! Unidirectional path tracer: next-event estimation with MIS (area and sphere lights), shadow rays for
//! point lights (through see-through surfaces, by their transmittance), delta BSDFs sampled exactly,
//! see-through surfaces crossed as no bounce, Russian roulette after `rr_depth` bounces on the
//! throughput without refraction's 1/η² radiance scale. Segments inside coloured glass are dimmed by its
//! absorption (`Scene::sigma_leaving`).
use super::direct::{emission_seen, estimate_direct_with, DirectStrategy};
use super::{Counters, LineOfSight};
use crate::accel::{Interaction, Tracer};
use crate::color::Rgb;
use crate::math::sampling::power_heuristic;
use crate::math::sampling::russian_roulette;
use crate::math::{max_component, Ray, Rng};
use crate::scene::medium::{fly, mean_ratio, Flight};
use crate::scene::{Crossing, Scattering, Scene, TransportMode};
use glam::Vec3;

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
        // Absorption (extinction) of the medium the current segment runs through (`Scene::sigma_next`):
        // the camera's (none unless `camera.medium`: Mitsuba's sensor `medium`), set where the path
        // leaves a medium's boundary.
        let mut sigma = scene.camera.medium.sigma_t;
        // What that medium scatters (`Scene::scattering_next`): nothing in most scenes.
        let mut scat = scene.camera.medium.scattering;
        if sigma != Rgb::ZERO && ray.tmin > 0.0 {
            // The camera's medium starts at the near clipping plane, as Mitsuba's camera rays do (their
            // origin on it): what lies nearer is cut away, the medium too.
            ray = Ray { o: ray.at(ray.tmin), tmin: 0.0, tmax: ray.tmax - ray.tmin, ..ray };
        }
        // Spectral MIS through media that scatter (`medium::fly`): the channel whose free flights the
        // path draws (chosen at its first such medium), and each channel's path density so far over
        // their mean (`beta` then holds the path's contribution over that mean: the balance heuristic).
        let mut hero = None;
        let mut ratio = Rgb::ONE;
        let mut depth = 0;
        // See-through surfaces crossed in a row inside a medium that scatters (as `cross_from` bounds
        // them).
        let mut crossed = 0;
        loop {
            c.rays += 1;
            // With `hide_emitters` the camera's line of sight passes hidden emitters, but not inside a
            // medium, where Mitsuba's volpath meets them (their light hidden, their BSDF scattering) as
            // it does any surface: a camera in fog sees only the fog before a hidden light.
            let mut found = match sigma != Rgb::ZERO {
                true => crate::accel::interact(scene, self.tracer, &ray),
                false => view.trace(scene, self.tracer, &ray, c),
            };
            // Past see-through surfaces (out of line: most scenes have none), with the BSDF picked where
            // the path scatters.
            let mut picked = None;
            if scat.scatters() || scene.see_through_media {
                // A medium that scatters: the path may scatter in it before it reaches `found`. (Also
                // where see-through surfaces bound media, which it then crosses one at a time.)
                // To the hit, else to the ray's end (a camera ray's far clipping plane, where Mitsuba's
                // free flights stop too; infinite elsewhere).
                let len = found.as_ref().map_or(ray.tmax, |f| f.hit.t) * ray.d.length();
                let flight = if scat.scatters() {
                    let h = *hero.get_or_insert_with(|| ((rng.next_f32() * 3.0) as usize).min(2));
                    fly(sigma, len, h, rng.next_f32())
                } else {
                    // A medium that only absorbs (past a see-through boundary): its transmittance.
                    beta *= Scene::absorbed(sigma, len);
                    Flight::Through { prob: Rgb::ONE }
                };
                match flight {
                    Flight::Scatter { dist, pdf, tr } => {
                        // The scattering event is the path's next (`max_depth` counts these too, as
                        // Mitsuba's volpath does).
                        if depth >= self.max_depth {
                            break;
                        }
                        let m = mean_ratio(ratio * pdf);
                        if m <= 0.0 {
                            break;
                        }
                        beta *= tr / m;
                        ratio *= pdf / m;
                        let inc = ray.d.normalize();
                        let p = ray.o + inc * dist;
                        l += beta * in_medium_direct(scene, self.tracer, p, inc, scat, sigma, rng, c);
                        // The phase sample's weight (phase over density) is 1.
                        beta *= scat.sigma_s;
                        let (out, pdf) = scat.sample_phase(inc, rng.next_2d());
                        view = LineOfSight::NOT;
                        specular = false;
                        prev_pdf = pdf;
                        prev_p = p;
                        ray = Ray::new(p, out);
                        depth += 1;
                        crossed = 0;
                        if depth >= self.rr_depth {
                            let Some(q) = russian_roulette(max_component(beta) / radiance_scale, rng.next_f32()) else {
                                break;
                            };
                            beta /= q;
                        }
                        continue;
                    }
                    Flight::Through { prob } if prob != Rgb::ONE => {
                        let m = mean_ratio(ratio * prob);
                        if m <= 0.0 {
                            break;
                        }
                        beta *= prob / m;
                        ratio *= prob / m;
                    }
                    Flight::Through { .. } => {}
                }
                if found.is_none() && len < f32::INFINITY {
                    // Past the far clipping plane the ray leaves the scene through the rest of the
                    // medium: only channels it does not dim see the sky (Mitsuba's escaping flight).
                    beta *= Scene::absorbed(sigma, f32::INFINITY);
                }
                // A see-through surface is crossed as its own segment's end: the medium goes on beyond
                // it (or changes, where it bounds one), where the path may scatter again.
                if let Some(f) = found.take_if(|f| scene.is_see_through(f.si.shape)) {
                    let mat = scene.bsdf(&f.si, f.wo, || rng.next_f32());
                    match scene.crossing(&f.si, f.wo, mat, || rng.next_f32()) {
                        Crossing::Through(t) => {
                            beta *= t;
                            crossed += 1;
                            if beta == Rgb::ZERO || crossed > crate::accel::MAX_CROSSINGS {
                                break;
                            }
                            sigma = scene.sigma_next(&f.si, ray.d, sigma);
                            scat = scene.scattering_next(&f.si, ray.d, scat);
                            ray = f.si.spawn(ray.d);
                            continue;
                        }
                        Crossing::At(m) => {
                            picked = Some(m);
                            found = Some(f);
                        }
                    }
                }
            } else {
                if let Some(f) = found.take_if(|f| scene.is_see_through(f.si.shape)) {
                    let (at, tr) = view.cross_from(scene, self.tracer, &ray, f, rng, c);
                    beta *= tr;
                    found = at.map(|(i, m)| {
                        picked = Some(m);
                        i
                    });
                }
                beta *= scene.absorbed_to(sigma, &ray, found.as_ref().map(|f| f.hit.t));
            }
            crossed = 0;
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
            scat = scene.scattering_next(&si, next.d, scat);
            ray = next;
            depth += 1;
            if depth >= self.rr_depth {
                let Some(q) = russian_roulette(max_component(beta) / radiance_scale, rng.next_f32()) else {
                    break;
                };
                beta /= q;
            }
        }
        l
    }
}

/// Direct light scattered at `p` in a medium towards where the path came from (it arrived travelling
/// along `inc`): one light sample, its shadow ray dimmed by the medium's extinction `sigma` (a ray in a
/// medium bounded by glass meets the glass and is blocked, as in Mitsuba's `volpath`), times the phase
/// function and σ_s, MIS-weighted against the phase sample that goes on from `p` (which counts the
/// lights it meets with `emission_seen`).
#[allow(clippy::too_many_arguments)]
fn in_medium_direct(
    scene: &Scene,
    tracer: &dyn Tracer,
    p: Vec3,
    inc: Vec3,
    scat: Scattering,
    sigma: Rgb,
    rng: &mut Rng,
    c: &mut Counters,
) -> Rgb {
    let u_sel = rng.next_f32();
    let u = rng.next_2d();
    let Some(ls) = scene.lights.sample(scene, p, u_sel, u, true) else {
        return Rgb::ZERO;
    };
    if ls.pdf <= 0.0 || ls.li == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let phase = scat.phase(inc, ls.wi);
    c.rays += 1;
    let ray = Ray { o: p, d: ls.p - p, tmin: 0.0, tmax: 1.0 - 1e-4 };
    let tr = if scene.see_through_media {
        crate::accel::shadow_in_media(scene, tracer, &ray, ls.p, sigma, &mut c.rays)
    } else {
        crate::accel::shadow(scene, tracer, &ray, ls.p, &mut c.rays) * Scene::absorbed(sigma, ray.d.length())
    };
    if tr == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, phase) };
    scat.sigma_s * ls.li * tr * (phase * w / ls.pdf)
}
