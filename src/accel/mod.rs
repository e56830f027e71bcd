//! Ray queries over a scene: `Accel` (Embree, the only unsafe code) and `Brute` (O(n) twin for tests).
//! Both answer the same questions: closest hit, any hit (occlusion), and 16-ray packets.
pub mod brute;
pub mod embree;

use crate::math::Ray;
pub use brute::Brute;
pub use embree::Accel;

/// The closest hit along a ray: distance, barycentrics (triangles: p = (1−u−v)·v0 + u·v1 + v·v2),
/// shape index and primitive index within the shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub shape: u32,
    pub prim: u32,
}

/// A ray's closest hit turned into surface data, with the direction back along the ray.
pub struct Interaction {
    pub hit: Hit,
    pub si: crate::scene::SurfaceHit,
    /// Unit direction from the surface back towards the ray's origin.
    pub wo: glam::Vec3,
}

/// Traces `ray` and describes what it hits (None: it leaves the scene).
pub fn interact(scene: &crate::scene::Scene, tracer: &dyn Tracer, ray: &Ray) -> Option<Interaction> {
    let hit = tracer.intersect(ray)?;
    let si = scene.surface(ray, hit.shape, hit.prim, hit.u, hit.v, hit.t);
    Some(Interaction { hit, si, wo: -ray.d.normalize() })
}

/// Most see-through surfaces one ray crosses (a guard against a ray that keeps meeting the surface it
/// left); a ray that would cross more is taken as blocked.
pub const MAX_CROSSINGS: u32 = 64;

/// The light let through along a shadow ray from its origin to `end` (`ray` being
/// `SurfaceHit::spawn_to(end)` or a segment like it): `Rgb::ONE` when nothing lies between, zero when
/// something does that a ray cannot cross, and the product of their transmittances
/// (`Scene::transmittance_at`) where only see-through surfaces lie between (null surfaces, masks).
/// `hidden(shape)`: surfaces crossed as if absent (`render.hide_emitters`' emitters on the way to the
/// camera). Rays traced past the first are added to `rays`.
#[cold]
#[inline(never)]
pub fn transmittance(
    scene: &crate::scene::Scene,
    tracer: &dyn Tracer,
    ray: &Ray,
    end: glam::Vec3,
    hidden: impl Fn(u32) -> bool,
    rays: &mut u64,
) -> crate::color::Rgb {
    use crate::color::Rgb;
    let mut ray = *ray;
    let mut tr = Rgb::ONE;
    for _ in 0..MAX_CROSSINGS {
        let Some(hit) = tracer.intersect(&ray) else {
            return tr;
        };
        let skip = hidden(hit.shape);
        if !skip && !scene.is_see_through(hit.shape) {
            return Rgb::ZERO;
        }
        let si = scene.surface(&ray, hit.shape, hit.prim, hit.u, hit.v, hit.t);
        if !skip {
            tr *= scene.transmittance_at(&si, ray.d);
            if tr == Rgb::ZERO {
                return tr;
            }
        }
        ray = si.spawn_to(end);
        *rays += 1;
    }
    Rgb::ZERO
}

/// `shadow` in a scene whose see-through surfaces may bound media (`Scene::see_through_media`): the
/// light let through along the shadow ray, which starts in a medium of extinction `sigma`, each stretch
/// dimmed by the medium it runs through (e^(−σ·length)) and each see-through surface crossed by its
/// transmittance, the medium changing where the ray leaves a boundary (`Scene::sigma_next`), as
/// Mitsuba's volpath follows its shadow rays through null interfaces. Zero at anything else.
pub fn shadow_in_media(
    scene: &crate::scene::Scene,
    tracer: &dyn Tracer,
    ray: &Ray,
    end: glam::Vec3,
    mut sigma: crate::color::Rgb,
    rays: &mut u64,
) -> crate::color::Rgb {
    use crate::color::Rgb;
    let mut ray = *ray;
    let mut tr = Rgb::ONE;
    for _ in 0..MAX_CROSSINGS {
        let Some(hit) = tracer.intersect(&ray) else {
            return tr * crate::scene::Scene::absorbed(sigma, (end - ray.o).length());
        };
        if !scene.is_see_through(hit.shape) {
            return Rgb::ZERO;
        }
        let si = scene.surface(&ray, hit.shape, hit.prim, hit.u, hit.v, hit.t);
        tr *= crate::scene::Scene::absorbed(sigma, (si.p - ray.o).length()) * scene.transmittance_at(&si, ray.d);
        if tr == Rgb::ZERO {
            return tr;
        }
        sigma = scene.sigma_next(&si, ray.d, sigma);
        ray = si.spawn_to(end);
        *rays += 1;
    }
    Rgb::ZERO
}

/// The first hit along `ray` on a shape that `passes` does not walk past, going straight on through
/// those it does (at most `MAX_CROSSINGS`), with the ray it was found on (its `t` is along that ray).
/// The probes' view past see-through surfaces: the planner's camera rays, the caustic aim's light rays.
pub fn first_hit_past(
    scene: &crate::scene::Scene,
    tracer: &dyn Tracer,
    mut ray: Ray,
    passes: impl Fn(u32) -> bool,
) -> Option<(Hit, Ray)> {
    for _ in 0..MAX_CROSSINGS {
        let h = tracer.intersect(&ray)?;
        if !passes(h.shape) {
            return Some((h, ray));
        }
        ray = scene.surface(&ray, h.shape, h.prim, h.u, h.v, h.t).spawn(ray.d);
    }
    None
}

/// Whether a shadow ray (as `transmittance` takes it) lets any light through; Embree's occlusion test
/// alone where no shape is see-through.
#[inline(always)]
pub fn shadow(
    scene: &crate::scene::Scene,
    tracer: &dyn Tracer,
    ray: &Ray,
    end: glam::Vec3,
    rays: &mut u64,
) -> crate::color::Rgb {
    if scene.see_through.is_empty() {
        return if tracer.occluded(ray) { crate::color::Rgb::ZERO } else { crate::color::Rgb::ONE };
    }
    transmittance(scene, tracer, ray, end, |_| false, rays)
}

/// What the integrators need from a ray tracer.
pub trait Tracer: Sync + Send {
    /// Closest hit with t in (ray.tmin, ray.tmax).
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything lies on the ray with t in (ray.tmin, ray.tmax).
    fn occluded(&self, ray: &Ray) -> bool;
    /// Closest hits for up to 16 rays at once (`out.len() == rays.len()`); Embree uses an 8-wide
    /// packet for up to 8 rays and a 16-wide one beyond.
    fn intersect_packet(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.intersect(r);
        }
    }
}

pub use crate::math::sphere_root;
