//! Photon maps and the radiance estimate: k nearest photons within a maximum radius,
//! L ≈ C/(π r²) Σ f_r ΔΦ_p w_p with the cone filter w_p = max(0, 1 − d_p/(k r)), C = 1/(1 − 2/(3k))
//! (k < 1 disables it), counting only photons that arrived from the viewer's side of the surface, landed
//! on a surface facing the same way and lie on its tangent disc (so light does not leak through thin walls or around corners).
use crate::color::Rgb;
use crate::photon::kdtree::{KdError, KdTree, KnnResult};
use crate::photon::photon::{Photon, PhotonPayload};
use crate::photon::trace::MapPhotons;
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

    /// Reflected radiance towards `wo` at `p` (normal `n`, geometric) of a Lambertian surface with
    /// reflectance `rho`, estimated from this map.
    pub fn radiance(&self, p: Vec3, n: Vec3, wo: Vec3, rho: Rgb, g: Gather, res: &mut KnnResult) -> Rgb {
        if self.is_empty() || g.k == 0 {
            return Rgb::ZERO;
        }
        let r2 = self.tree.knn(p.to_array(), g.k, g.max_r2, res);
        if r2.is_nan() || r2 <= 0.0 || !r2.is_finite() {
            return Rgb::ZERO;
        }
        let r = r2.sqrt();
        let n_side = if wo.dot(n) < 0.0 { -n } else { n };
        let cone = g.cone_k >= 1.0;
        let mut sum = Rgb::ZERO;
        for &(d2, i) in res.items() {
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
            let w = if cone { (1.0 - d2.sqrt() / (g.cone_k * r)).max(0.0) } else { 1.0 };
            sum += item.phi() * w;
        }
        let norm = if cone { 1.0 - 2.0 / (3.0 * g.cone_k) } else { 1.0 };
        sum * rho / (std::f32::consts::PI * std::f32::consts::PI * r2 * norm)
    }
}
