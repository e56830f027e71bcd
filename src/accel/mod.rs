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
