//! Direct light: one light sample with a shadow ray, MIS-weighted against BSDF sampling where the
//! caller's estimator also counts lights its BSDF samples hit.
use super::Counters;
use crate::accel::Tracer;
use crate::color::Rgb;
use crate::math::{sampling::power_heuristic, Rng};
use crate::scene::light::LightSample;
use crate::scene::{Material, Scene, SurfaceHit};
use glam::Vec3;

/// How the caller combines this estimate with light found by BSDF sampling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectStrategy {
    /// The path tracer: lights drawn from the next-event distribution (the planner may leave area
    /// lights out of it) and MIS-weighted against BSDF sampling, which finds those lights too.
    Mis,
    /// Estimators that never count emission found by BSDF sampling (the photon-map eye pass): every
    /// light by power, unweighted.
    LightOnly,
    /// Estimators that follow no path past the point (the photon mappers' eye passes under a sky): a
    /// light sample as in `Mis` and a BSDF sample, each MIS-weighted against the other, the BSDF sample
    /// counting only a light it meets first (or the sky it escapes to). One ray more than `LightOnly`;
    /// worth it under a sky, whose smooth part a BSDF sample finds at low variance where a light sample
    /// drawn by the sky's brightness mostly heads for its sun.
    LightAndBsdf,
}

impl DirectStrategy {
    /// What the photon mappers' eye passes (fixed PM at its visible points, SPPM) use: the BSDF sample
    /// too where the scene has a sky, the light sample alone elsewhere.
    pub fn eye_pass(scene: &Scene) -> DirectStrategy {
        if scene.lights.env.is_some() {
            DirectStrategy::LightAndBsdf
        } else {
            DirectStrategy::LightOnly
        }
    }
}

/// Direct light reflected towards `wo` at a non-delta surface.
pub fn estimate_direct(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    wo: Vec3,
    rng: &mut Rng,
    c: &mut Counters,
    strategy: DirectStrategy,
) -> Rgb {
    let mat = scene.bsdf(si, wo, || rng.next_f32());
    // The medium the path arrived in, as the surface's side towards it says (a shape that bounds none
    // has the medium round it on both sides).
    let arrived = scene.sigma_leaving(si, wo);
    estimate_direct_with(scene, tracer, si, wo, &mat, arrived, rng, c, strategy)
}

/// `estimate_direct` with a given BSDF in place of the surface's own (the radiance cache's unit-albedo
/// Lambertian), the path having arrived at `si` through a medium of absorption `arrived`
/// (`Scene::sigma_next`).
#[allow(clippy::too_many_arguments)]
pub fn estimate_direct_with(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    wo: Vec3,
    mat: &Material,
    arrived: Rgb,
    rng: &mut Rng,
    c: &mut Counters,
    strategy: DirectStrategy,
) -> Rgb {
    let mis = strategy != DirectStrategy::LightOnly;
    let light = match sample_light(scene, si, wo, mat, rng, mis) {
        Some((ls, f)) => {
            let tr = shadow(scene, tracer, si, arrived, &ls, c);
            if tr == Rgb::ZERO {
                Rgb::ZERO
            } else {
                let w = if ls.delta || !mis {
                    1.0
                } else {
                    power_heuristic(ls.pdf, mat.pdf(wo, ls.wi, si.ns, crate::scene::TransportMode::Radiance))
                };
                f * ls.li * tr * (w / ls.pdf)
            }
        }
        None => Rgb::ZERO,
    };
    if strategy != DirectStrategy::LightAndBsdf {
        return light;
    }
    // A BSDF sample: the emission of the light it meets first, or of the sky it escapes to, weighted
    // against the light sample.
    let Some((bs, ray)) = si.scatter(mat, wo, rng, crate::scene::TransportMode::Radiance) else {
        return light;
    };
    if bs.delta {
        return light;
    }
    c.rays += 1;
    let (found, tr) = super::LineOfSight::NOT.trace_through(scene, tracer, &ray, rng, c);
    let (le, w) = emission_seen(scene, found.as_ref().map(|f| &f.0), ray.d, Some((bs.pdf, si.p)));
    if le == Rgb::ZERO {
        return light;
    }
    let sigma = scene.sigma_next(si, ray.d, arrived);
    let absorbed = scene.absorbed_to(sigma, &ray, found.as_ref().map(|f| f.0.hit.t));
    light + bs.weight * tr * absorbed * (le * w)
}

/// The light a ray meets, with its MIS weight: the emission of the surface it hits (`found`), or of
/// the sky it escapes to along `dir`; weighted against the light sample taken where the ray left if it
/// was BSDF-sampled there (`sampled`: its density and that point), in full after a delta bounce or from
/// the camera (`sampled` None). (ZERO, 0) when it meets no light. The path tracer, the photon mappers'
/// specular chains and `LightAndBsdf` all count emission through this.
pub fn emission_seen(
    scene: &Scene,
    found: Option<&crate::accel::Interaction>,
    dir: Vec3,
    sampled: Option<(f32, Vec3)>,
) -> (Rgb, f32) {
    let le = match found {
        None => scene.lights.env_radiance(dir),
        Some(i) => scene.emitted(&i.si, i.wo),
    };
    if le == Rgb::ZERO {
        return (le, 0.0);
    }
    let Some((pdf, from)) = sampled else {
        return (le, 1.0);
    };
    let pdf_light = match found {
        None => scene.lights.env_pdf(dir),
        Some(i) => scene.lights.pdf(scene, i.hit.shape, i.hit.prim, from, i.si.p, i.si.ng),
    };
    (le, power_heuristic(pdf, pdf_light))
}

/// A light point for direct light at `si` (seen along `wo`, BSDF `mat`), drawn from the next-event
/// distribution (`nee`) or from every light by power, with f·|cos θ| towards it; None when no light can
/// arrive that way (no sample, no radiance, the light behind the surface, a zero BSDF). No shadow ray.
pub fn sample_light(
    scene: &Scene,
    si: &SurfaceHit,
    wo: Vec3,
    mat: &Material,
    rng: &mut Rng,
    nee: bool,
) -> Option<(LightSample, Rgb)> {
    let u_sel = rng.next_f32();
    let u = rng.next_2d();
    let ls = scene.lights.sample(scene, si.p, u_sel, u, nee)?;
    if ls.pdf <= 0.0 || ls.li == Rgb::ZERO {
        return None;
    }
    // Light must be on a side the BSDF can scatter into (the geometric test avoids light leaks).
    if !si.can_scatter(mat, wo, ls.wi) {
        return None;
    }
    let f = mat.eval(wo, ls.wi, si.ns, crate::scene::TransportMode::Radiance) * ls.wi.dot(si.ns).abs();
    (f != Rgb::ZERO).then_some((ls, f))
}

/// Traces the shadow ray from `si` to the sampled light point (its rays counted in `c`): the light let
/// through, `Rgb::ONE` when nothing lies between, the see-through surfaces' transmittance where only
/// they do (`accel::transmittance`), zero when anything else does; times the absorption along it
/// where it leaves `si` into coloured glass (a light inside it), or through the medium the path arrived
/// in (`arrived`) where `si`'s shape bounds none (`Scene::sigma_next`).
pub fn shadow(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    arrived: Rgb,
    ls: &LightSample,
    c: &mut Counters,
) -> Rgb {
    c.rays += 1;
    let ray = si.spawn_to(ls.p);
    let sigma = scene.sigma_next(si, ray.d, arrived);
    if scene.see_through_media {
        return crate::accel::shadow_in_media(scene, tracer, &ray, ls.p, sigma, &mut c.rays);
    }
    let tr = crate::accel::shadow(scene, tracer, &ray, ls.p, &mut c.rays);
    tr * Scene::absorbed(sigma, ray.d.length())
}
