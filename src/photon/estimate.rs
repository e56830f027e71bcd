//! Photon maps and the radiance estimate: k nearest photons within a maximum radius,
//! L ≈ C/(π r²) Σ f_r ΔΦ_p w_p with the cone filter w_p = max(0, 1 − d_p/(k r)), C = 1/(1 − 2/(3k))
//! (k < 1 disables it), counting only photons that arrived from the viewer's side of the surface, landed
//! on a surface facing the same way and lie on its tangent disc (so light does not leak through thin walls or around corners).
use crate::color::Rgb;
use crate::math::face_forward;
use crate::photon::kdtree::{KdError, KdTree, KnnResult};
use crate::photon::photon::{Photon, PhotonPayload};
use crate::photon::trace::MapPhotons;
use crate::scene::SurfaceHit;
use glam::Vec3;

pub struct PhotonMap {
    pub tree: KdTree<PhotonPayload>,
    pub n_emitted: u64,
    pub complete: bool,
}

/// Gather parameters of one map.
#[derive(Clone, Copy, Debug)]
pub struct Gather {
    pub k: usize,
    pub max_r2: f32,
    pub cone_k: f32,
}

impl PhotonMap {
    pub fn build(m: MapPhotons) -> Result<PhotonMap, KdError> {
        let pts = m.photons.iter().map(|p: &Photon| (p.p.to_array(), p.payload())).collect();
        Ok(PhotonMap { tree: KdTree::build(pts)?, n_emitted: m.n_emitted, complete: m.complete })
    }

    pub fn len(&self) -> usize {
        self.tree.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// Sum of stored photon powers (W), for conservation checks.
    pub fn total_power(&self) -> Rgb {
        (0..self.tree.len() as u32).map(|i| self.tree.item(i).phi()).sum()
    }

    /// Reflected radiance towards `wo` at the surface point `si` of a Lambertian surface with reflectance
    /// `rho`, estimated from this map. Photons carry flux per unit of geometric area; each is scaled by
    /// |wi·ns| / |wi·ng| so the estimate integrates the cosine about the shading normal, as the path
    /// tracer does (the last factor of the shading-normal adjoint; 1 on flat-shaded surfaces).
    pub fn radiance(&self, si: &SurfaceHit, wo: Vec3, rho: Rgb, g: Gather, res: &mut KnnResult) -> Rgb {
        if self.is_empty() || g.k == 0 {
            return Rgb::ZERO;
        }
        let (p, n) = (si.p, si.ng);
        let smooth = si.ns != si.ng;
        let r2 = self.tree.knn(p.to_array(), g.k, g.max_r2, res);
        if r2.is_nan() || r2 <= 0.0 || !r2.is_finite() {
            return Rgb::ZERO;
        }
        let r = r2.sqrt();
        let n_side = face_forward(n, wo);
        let ns_side = face_forward(si.ns, wo);
        let cone = g.cone_k >= 1.0;
        // When k photons were found, r is the k-th one's distance and that photon sits on the boundary:
        // given r, the other k − 1 are spread over the disc, so (k − 1)/(π r²) is the unbiased density,
        // and counting the boundary photon too would add k/(k − 1) (3.4% at k = 30). It is left out.
        let boundary = (res.items().len() >= g.k)
            .then(|| res.items().iter().enumerate().max_by(|a, b| a.1 .0.total_cmp(&b.1 .0)).map(|(j, _)| j))
            .flatten();
        let mut sum = Rgb::ZERO;
        for (j, &(d2, i)) in res.items().iter().enumerate() {
            if Some(j) == boundary {
                continue;
            }
            let item = self.tree.item(i);
            // Arrived from the viewer's side (travelled against the normal), on a surface facing the same
            // way (not the other side of a thin wall, not the next wall round a corner).
            if item.wi().dot(n_side) >= 0.0 || item.n().dot(n_side) < 0.6 {
                continue;
            }
            // On this surface's tangent disc, not on a nearby surface facing elsewhere.
            let q = Vec3::from_array(self.tree.position(i));
            if (q - p).dot(n_side).abs() > 0.25 * r {
                continue;
            }
            let mut w = if cone { (1.0 - d2.sqrt() / (g.cone_k * r)).max(0.0) } else { 1.0 };
            if smooth {
                // The Lambertian BSDF about the shading normal is zero for light arriving from below it.
                let wi = item.wi();
                w *= (-wi).dot(ns_side).max(0.0) / wi.dot(n).abs().max(1e-6);
            }
            sum += item.phi() * w;
        }
        let norm = if cone { 1.0 - 2.0 / (3.0 * g.cone_k) } else { 1.0 };
        sum * rho / (std::f32::consts::PI * std::f32::consts::PI * r2 * norm)
    }
}
