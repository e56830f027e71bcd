//! The boundary bias of density estimation: a gather disc that reaches past a wall, an edge or a
//! panel's rim holds photons over only part of its area, so dividing its photons by the whole disc
//! reads dark in a band one radius wide along every edge. Both corrections here probe points of the
//! disc (in the gather point's tangent plane) for a surface that could hold the photons the estimate
//! accepts there: SPPM accumulates the covered fraction over its iterations (`disc_coverage`), while
//! PPM's passes and the fixed photon map's gathers, which must each stand alone, multiply their photons
//! by an unbiased estimate of its inverse (`inverse_coverage`).
use crate::accel::Tracer;
use crate::math::{Frame, Ray, Rng};
use crate::photon::estimate::{DISC_FACING, DISC_SLAB};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

/// Points of each pixel's disc SPPM probes per iteration.
pub const EDGE_PROBES: usize = 2;

/// Most probes `inverse_coverage` draws. Past them it returns this count, which is the inverse of a
/// covered fraction of 1/32; a disc covered less than that (the estimate reads (1 − c)^32 low there,
/// 1.4% at c = 1/8) holds almost no photons anyway.
pub const MAX_TRIALS: u32 = 32;

/// Keys the probes' random numbers apart from every other stream.
pub const EDGE_PROBES_KEY: u64 = 0x4544_4745_5052_4F42;

/// The gather point's side of its surface and the frame of its tangent plane.
fn disc_frame(si: &SurfaceHit, wo: Vec3) -> (Vec3, Frame) {
    let n = crate::math::face_forward(si.ng, wo);
    (n, Frame::from_normal(n))
}

/// Which surfaces hold the photons an estimate reads: `Material::holds_photons` for the photon maps,
/// `Material::unheld_glossy_lobe` for the glossy photons (`super::GlossyGather`), any BSDF not a delta
/// for VCM's light vertices.
pub type Holds = fn(&crate::scene::Material) -> bool;

/// The photon maps' surfaces (`Holds`).
pub fn holds_photons(m: &crate::scene::Material) -> bool {
    m.holds_photons()
}

/// The surfaces VCM keeps light vertices on and merges at: every BSDF but a mirror's or glass's.
pub fn holds_light_vertices(m: &crate::scene::Material) -> bool {
    !m.is_delta()
}

/// The glossy photons' surfaces (`Holds`).
pub fn holds_glossy_photons(m: &crate::scene::Material) -> bool {
    m.unheld_glossy_lobe().is_some()
}

/// Whether a surface that could hold the photons accepted at a gather point of normal `n` (facing the
/// viewer), radius `r`, lies under the point of its disc at polar coordinates (`rho`, `phi`): a ray down
/// through the estimate's slab (±r/4 about the plane, as the photon filter) looks for a surface that
/// `holds` facing the same way within 53°, passing through anything else (glass, a ball's underside,
/// the back of a wall). Returns it with the rays cast.
#[allow(clippy::too_many_arguments)]
fn probe(
    scene: &Scene,
    tracer: &dyn Tracer,
    p: Vec3,
    n: Vec3,
    frame: &Frame,
    r: f32,
    rho: f32,
    phi: f32,
    holds: Holds,
) -> (bool, u64) {
    let h = DISC_SLAB * r;
    let q = p + frame.to_world(Vec3::new(rho * phi.cos(), rho * phi.sin(), 0.0));
    let mut ray = Ray { o: q + n * h, d: -n, tmin: 0.0, tmax: 2.0 * h };
    // A few surfaces at most stand in the slab: pass through the ones that cannot hold photons.
    let mut rays = 0;
    for _ in 0..4 {
        rays += 1;
        let Some(hit) = tracer.intersect(&ray) else {
            break;
        };
        let s = scene.surface(&ray, hit.shape, hit.prim, hit.u, hit.v, hit.t);
        if s.ng.dot(n).abs() >= DISC_FACING && scene.any_bsdf_at(&s, n, holds) {
            return (true, rays);
        }
        ray.tmin = hit.t + 1e-4 * h;
    }
    (false, rays)
}

/// The fraction of the gather disc of radius `r` about `si` under which a surface could hold the
/// photons `flux_within` accepts there, from `EDGE_PROBES` points stratified by area (one per sector,
/// a random rotation). Returns it with the rays cast.
pub fn disc_coverage(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    wo: Vec3,
    r: f32,
    rng: &mut Rng,
) -> (f64, u64) {
    let (n, frame) = disc_frame(si, wo);
    let (turn, mut rays, mut covered) = (rng.next_f32(), 0u64, 0usize);
    for j in 0..EDGE_PROBES {
        let [u, v] = rng.next_2d();
        let phi = 2.0 * std::f32::consts::PI * (turn + (j as f32 + u) / EDGE_PROBES as f32);
        let (hit, k) = probe(scene, tracer, si.p, n, &frame, r, r * v.sqrt(), phi, holds_photons);
        rays += k;
        covered += hit as usize;
    }
    (covered as f64 / EDGE_PROBES as f64, rays)
}

/// An unbiased estimate of 1 / c, c the covered fraction of the gather disc of radius `r` about `si`
/// (as `disc_coverage` defines it), weighted by the estimate's kernel: uniform (a box), or with
/// `cone_k` ≥ 1 the cone filter 1 − ρ/(k r). It is the number of points of the disc, drawn with the
/// kernel's density, probed until one is over a surface (a geometric count, whose mean is 1 / c; at most
/// `MAX_TRIALS`). A disc wholly on its surface costs one probe and returns exactly 1, so only the
/// bands along edges get the count's noise. Multiplying a gather's photons by it, drawn independently
/// of them, makes the estimate read the density over the surface the disc covers (the surfaces that
/// `holds` its photons). Returns it with the rays cast.
#[allow(clippy::too_many_arguments)]
pub fn inverse_coverage(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    wo: Vec3,
    r: f32,
    cone_k: f32,
    rng: &mut Rng,
    holds: Holds,
) -> (f32, u64) {
    let (n, frame) = disc_frame(si, wo);
    let mut rays = 0;
    for trial in 1..=MAX_TRIALS {
        let (rho, phi) = loop {
            let [u, v] = rng.next_2d();
            let rho = r * v.sqrt();
            // The cone's weight by rejection (it is at least 1 − 1/k > 0 where k > 1; k = 1 makes the
            // rim weigh nothing, which rejection handles as well).
            if cone_k < 1.0 || rng.next_f32() < 1.0 - rho / (cone_k * r) {
                break (rho, 2.0 * std::f32::consts::PI * u);
            }
        };
        let (hit, k) = probe(scene, tracer, si.p, n, &frame, r, rho, phi, holds);
        rays += k;
        if hit {
            return (trial as f32, rays);
        }
    }
    (MAX_TRIALS as f32, rays)
}
