//! Next-event estimation: one light sample with a shadow ray, MIS-weighted against BSDF sampling.
use super::Counters;
use crate::accel::Tracer;
use crate::color::Rgb;
use crate::math::{sampling::power_heuristic, Rng};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

/// Direct light reflected towards `wo` at a non-delta surface (MIS weight applied when `mis`).
pub fn estimate_direct(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    wo: Vec3,
    rng: &mut Rng,
    c: &mut Counters,
    mis: bool,
) -> Rgb {
    let mat = scene.material_of(si.shape);
    let u_sel = rng.next_f32();
    let u = rng.next_2d();
    let Some(ls) = scene.lights.sample(scene, si.p, u_sel, u) else {
        return Rgb::ZERO;
    };
    if ls.pdf <= 0.0 || ls.li == Rgb::ZERO {
        return Rgb::ZERO;
    }
    // Light must be on the side the BSDF can scatter into (geometric test avoids light leaks).
    if ls.wi.dot(si.ng) * wo.dot(si.ng) <= 0.0 {
        return Rgb::ZERO;
    }
    let f = mat.eval(wo, ls.wi, si.ns) * ls.wi.dot(si.ns).abs();
    if f == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let mut shadow = si.spawn(ls.wi);
    let o = shadow.o;
    shadow.tmax = (ls.dist - (o - si.p).length()) * (1.0 - 1e-4);
    c.rays += 1;
    if tracer.occluded(&shadow) {
        return Rgb::ZERO;
    }
    let w = if ls.delta || !mis { 1.0 } else { power_heuristic(ls.pdf, mat.pdf(wo, ls.wi, si.ns)) };
    f * ls.li * (w / ls.pdf)
}
