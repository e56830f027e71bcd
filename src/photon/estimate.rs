//! Photon maps and the radiance estimate: k nearest photons within a maximum radius,
//! L ≈ C/(π r²) Σ f_r ΔΦ_p w_p with the cone filter w_p = max(0, 1 − d_p/(k r)), C = 1/(1 − 2/(3k))
//! (k < 1 disables it), counting only photons that arrived from the viewer's side of the surface (of the
//! normal its BSDF is taken about, on smooth-shaded or mapped surfaces), landed on a surface facing the
//! same way (either way on those) and lie on its tangent disc (so light does not leak through thin walls
//! or around corners), and whose paths fit in the scattering events `render.max_depth` leaves after the
//! eye side's bounces.
use crate::color::Rgb;
use crate::math::face_forward;
use crate::photon::kdtree::{KdError, KdTree, KnnResult};
use crate::photon::photon::{events, within_depth, PhotonPayload, EVENTS_CAP};
use crate::photon::trace::MapPhotons;
use crate::scene::material::{Coat, DiffuseLobe, MappedFrame};
use crate::scene::{Material, SurfaceHit, TransportMode};
use glam::Vec3;

pub struct PhotonMap {
    /// Photons with their power as traced; `phi` divides it by `n_emitted`.
    pub tree: KdTree<PhotonPayload>,
    pub n_emitted: u64,
    pub complete: bool,
    power_scale: f32,
}

/// Gather parameters of one map.
#[derive(Clone, Copy, Debug)]
pub struct Gather {
    pub k: usize,
    pub max_r2: f32,
    pub cone_k: f32,
}

impl PhotonMap {
    /// Builds the tree over the traced photons, consuming them (their memory is released as the tree
    /// fills).
    pub fn build(m: MapPhotons) -> Result<PhotonMap, KdError> {
        let power_scale = 1.0 / m.n_emitted.max(1) as f32;
        Ok(PhotonMap { tree: KdTree::build(m.photons)?, n_emitted: m.n_emitted, complete: m.complete, power_scale })
    }

    /// Power of the photon at tree index `i` per emitted photon (W).
    pub fn phi(&self, i: u32) -> Rgb {
        self.tree.item(i).phi() * self.power_scale
    }

    pub fn len(&self) -> usize {
        self.tree.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// Sum of stored photon powers (W), for conservation checks.
    pub fn total_power(&self) -> Rgb {
        (0..self.tree.len() as u32).map(|i| self.phi(i)).sum()
    }

    /// Reflected radiance towards `wo` at the surface point `si` by its diffuse `lobe` (a Lambertian
    /// reflectance, or a plastic's base under its coat), estimated from the k nearest photons (cone
    /// filter if `g.cone_k` ≥ 1), counting the photons whose paths fit in `budget` scattering events
    /// (`within_depth`; `render.max_depth` less the eye side's bounces before `si`). Returns it with the
    /// radius of the disc it gathered over (0 when it found nothing).
    pub fn radiance(
        &self,
        si: &SurfaceHit,
        wo: Vec3,
        lobe: DiffuseLobe,
        g: Gather,
        budget: u32,
        res: &mut KnnResult,
    ) -> (Rgb, f32) {
        if self.is_empty() || g.k == 0 {
            return (Rgb::ZERO, 0.0);
        }
        let r2 = self.tree.knn(si.p.to_array(), g.k, g.max_r2, res);
        if r2.is_nan() || r2 <= 0.0 || !r2.is_finite() {
            return (Rgb::ZERO, 0.0);
        }
        let r = r2.sqrt();
        let f = PhotonFilter::new(si, wo, r, budget, lobe);
        let cone = Cone { k: g.cone_k, r };
        let boundary = boundary_photon(res, g.k);
        let mut sum = Rgb::ZERO;
        for (j, &(d2, i)) in res.items().iter().enumerate() {
            if Some(j) == boundary {
                continue;
            }
            let Some(w) = f.weight(self.tree.item(i), self.tree.position(i)) else {
                continue;
            };
            sum += self.phi(i) * (w * cone.weight(d2));
        }
        (sum * lobe.rho / (std::f32::consts::PI * std::f32::consts::PI * r2 * cone.norm()), r)
    }

    /// Flux-weighted sum Σ w_p ΔΦ_p over the photons within radius `r` of `si` that pass the surface
    /// tests (box kernel) and whose paths fit in `budget` scattering events (as in `radiance`): divided
    /// by π r² it is the irradiance the progressive estimators accumulate. Under a plastic's coat each
    /// photon also counts the share its coat lets through (`Coat::transmission`), under a normal map the
    /// map's factor (`MappedFrame::factor`): `lobe` says which. Returns (sum, photons counted).
    pub fn flux_within(
        &self,
        si: &SurfaceHit,
        wo: Vec3,
        r: f32,
        budget: u32,
        lobe: DiffuseLobe,
        res: &mut KnnResult,
    ) -> (Rgb, u32) {
        if self.is_empty() || r.is_nan() || r <= 0.0 {
            return (Rgb::ZERO, 0);
        }
        self.tree.within_res(si.p.to_array(), r * r, res);
        let f = PhotonFilter::new(si, wo, r, budget, lobe);
        let mut sum = Rgb::ZERO;
        let mut count = 0u32;
        for &(_, i) in res.items() {
            if let Some(w) = f.weight(self.tree.item(i), self.tree.position(i)) {
                sum += self.phi(i) * w;
                count += 1;
            }
        }
        (sum, count)
    }
}

/// How far a glossy estimate reaches: the k nearest photons (the fixed photon map's gather: radius from
/// the k-th, cone filter), or every photon within a fixed radius (progressive passes, box kernel).
#[derive(Clone, Copy, Debug)]
pub enum Reach {
    Knn(Gather),
    Radius(f32),
}

impl PhotonMap {
    /// Radiance towards `wo` that the glossy BSDF `lobe` (a rough metal, rough glass, principled surface,
    /// rough plastic's coat) scatters at `si` from the photons around it, each counted through the BSDF
    /// for its own direction l: Σ f(wo, l)·|l·ns|/|l·ng|·ΔΦ / (π r²) (photons carry flux per unit of
    /// geometric area), over the photons on the surface's tangent disc that landed on a surface of the
    /// same orientation (from either side: a rough glass lets light through), whose paths fit in `budget`
    /// scattering events, and for which `lobe` can carry light from l to `wo` (`SurfaceHit::can_scatter`).
    /// The k-NN reach leaves out the boundary photon and applies the cone filter, as `radiance` does.
    /// Returns it with the radius of the disc it gathered over (0 when it found nothing).
    pub fn glossy_radiance(
        &self,
        si: &SurfaceHit,
        wo: Vec3,
        lobe: &Material,
        reach: Reach,
        budget: u32,
        res: &mut KnnResult,
    ) -> (Rgb, f32) {
        if self.is_empty() {
            return (Rgb::ZERO, 0.0);
        }
        let (r2, cone_k) = match reach {
            Reach::Knn(g) if g.k > 0 => (self.tree.knn(si.p.to_array(), g.k, g.max_r2, res), g.cone_k),
            Reach::Radius(r) if r > 0.0 => {
                self.tree.within_res(si.p.to_array(), r * r, res);
                (r * r, 0.0)
            }
            _ => return (Rgb::ZERO, 0.0),
        };
        if r2.is_nan() || r2 <= 0.0 || !r2.is_finite() {
            return (Rgb::ZERO, 0.0);
        }
        let r = r2.sqrt();
        let boundary = match reach {
            Reach::Knn(g) => boundary_photon(res, g.k),
            Reach::Radius(_) => None,
        };
        let cone = Cone { k: cone_k, r };
        let mut sum = Rgb::ZERO;
        for (j, &(d2, i)) in res.items().iter().enumerate() {
            let (item, pos) = (self.tree.item(i), self.tree.position(i));
            if Some(j) == boundary || !on_disc(si.p, si.ng, r, budget, pos) || item.n().dot(si.ng).abs() < DISC_FACING {
                continue;
            }
            let l = -item.wi();
            let cos_g = l.dot(si.ng).abs();
            if cos_g <= 1e-6 || !si.can_scatter(lobe, wo, l) {
                continue;
            }
            let f = lobe.eval(wo, l, si.ns, TransportMode::Radiance) * (l.dot(si.ns).abs() / cos_g);
            sum += f * self.phi(i) * cone.weight(d2);
        }
        (sum / (std::f32::consts::PI * r2 * cone.norm()), r)
    }
}

/// Where a k-NN gather found k photons, the one on the boundary (its index in `res`): r is its
/// distance, so given r the other k − 1 are spread over the disc and (k − 1)/(π r²) is the unbiased
/// density; counting the boundary photon too would add k/(k − 1) (3.4% at k = 30). It is left out.
fn boundary_photon(res: &KnnResult, k: usize) -> Option<usize> {
    (res.items().len() >= k)
        .then(|| res.items().iter().enumerate().max_by(|a, b| a.1 .0.total_cmp(&b.1 .0)).map(|(j, _)| j))
        .flatten()
}

/// The cone filter of a gather over radius `r`: weight max(0, 1 − d/(k r)) for a photon at distance d
/// and normalisation 1 − 2/(3k), with k ≥ 1; a box (weight and normalisation 1) otherwise.
#[derive(Clone, Copy)]
struct Cone {
    k: f32,
    r: f32,
}

impl Cone {
    #[inline(always)]
    fn weight(self, d2: f32) -> f32 {
        if self.k >= 1.0 {
            (1.0 - d2.sqrt() / (self.k * self.r)).max(0.0)
        } else {
            1.0
        }
    }

    fn norm(self) -> f32 {
        if self.k >= 1.0 {
            1.0 - 2.0 / (3.0 * self.k)
        } else {
            1.0
        }
    }
}

/// The gather disc's thickness: what lies within this fraction of the radius of a gather point's
/// tangent plane counts as on its disc. Every estimate's filter and the edge correction's probes
/// (`integrator::edges`) use it, so that the probes measure the part of the disc the filter accepts.
pub const DISC_SLAB: f32 = 0.25;

/// The least |cos| between the normals of a gather point and a surface its disc counts (53°): a
/// nearby surface facing elsewhere (the next wall round a corner) is not the disc's.
pub const DISC_FACING: f32 = 0.6;

/// Whether `pos` lies in the slab of the gather disc of radius `r` at `p`, normal `n` (`DISC_SLAB`).
#[inline(always)]
pub fn in_disc_slab(p: Vec3, n: Vec3, r: f32, pos: [f32; 3]) -> bool {
    (Vec3::from_array(pos) - p).dot(n).abs() <= DISC_SLAB * r
}

/// Whether a photon at `pos` (its record of scattering events included) lies on the tangent disc of
/// radius `r` at `p` (`in_disc_slab`: not on a nearby surface facing elsewhere) and its path fits in
/// `budget` scattering events (with 7 or more left every record fits: no test). The position's test
/// first: it is at hand.
#[inline(always)]
fn on_disc(p: Vec3, n: Vec3, r: f32, budget: u32, pos: [f32; 3]) -> bool {
    in_disc_slab(p, n, r, pos) && (budget >= EVENTS_CAP || within_depth(events(pos), budget))
}

/// The per-photon tests and weight shared by every estimate at one surface point.
struct PhotonFilter {
    p: Vec3,
    n: Vec3,
    n_side: Vec3,
    ns_side: Vec3,
    smooth: bool,
    /// The normal the BSDF is taken about differs from the facet's (smooth shading or a map): light
    /// from behind the facet can reach the viewer's side of that normal.
    bent: bool,
    r: f32,
    budget: u32,
    /// A plastic's coat (smooth or rough): each photon counts the share it lets through.
    coat: Option<Coat>,
    /// A normal or bump map's frame: each photon counts the map's factor.
    map: Option<MappedFrame>,
}

impl PhotonFilter {
    fn new(si: &SurfaceHit, wo: Vec3, r: f32, budget: u32, lobe: DiffuseLobe) -> PhotonFilter {
        PhotonFilter {
            p: si.p,
            n: si.ng,
            n_side: face_forward(si.ng, wo),
            ns_side: face_forward(si.ns, wo),
            smooth: si.ns != si.ng,
            bent: si.ns != si.ng || lobe.map.is_some(),
            r,
            budget,
            coat: lobe.coat,
            map: lobe.map,
        }
    }

    /// None when the photon does not belong to this surface point or its path is longer than the
    /// remaining depth allows; else its weight: 1, or on
    /// smooth-shaded surfaces |wi·ns| / |wi·ng| (photons carry flux per unit of geometric area, the path
    /// tracer integrates the cosine about the shading normal: the last factor of the shading-normal
    /// adjoint), zero for light arriving from below the shading normal; under a normal map the map's
    /// factor / |wi·ng| (the cosine about the mapped normal and the shadowing term). Under a coat, times
    /// the share the coat lets through, at the normal the lobe is taken about. On such bent normals a
    /// photon that landed on the back of the facet counts too where it arrived from the viewer's side
    /// of the shading normal: the path tracer's reflections below the facet go through it and find
    /// that light (`SurfaceHit::scatter_with`).
    /// Inlined: called once per gathered photon (a profile put a third of a photon-mapped render's
    /// samples on its first use of the photon's position; inlining alone did not change the time).
    #[inline(always)]
    fn weight(&self, item: &PhotonPayload, pos: [f32; 3]) -> Option<f32> {
        if !on_disc(self.p, self.n, self.r, self.budget, pos) {
            return None;
        }
        // Landed on a surface facing the same way (not the other side of a thin wall, not the next wall
        // round a corner), and arrived from the viewer's side (travelled against the normal).
        let wi = item.wi();
        if self.bent {
            // Either side of the facet: the weight below is zero unless the light came from the
            // viewer's side of the normal the BSDF is taken about.
            if item.n().dot(self.n_side).abs() < DISC_FACING {
                return None;
            }
        } else if item.n().dot(self.n_side) < DISC_FACING || wi.dot(self.n_side) >= 0.0 {
            return None;
        }
        let (w, about) = match &self.map {
            None if self.smooth => ((-wi).dot(self.ns_side).max(0.0) / wi.dot(self.n).abs().max(1e-6), self.ns_side),
            None => (1.0, self.ns_side),
            Some(m) => (m.factor(-wi) / wi.dot(self.n).abs().max(1e-6), m.n),
        };
        match self.coat {
            None => Some(w),
            // Mitsuba's plastic takes the coat's factor at the shading normal (the mapped one under a map).
            Some(coat) => Some(w * coat.transmission((-wi).dot(about))),
        }
    }
}
