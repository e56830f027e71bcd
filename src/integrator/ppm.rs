//! Probabilistic progressive photon mapping (Knaus & Zwicker 2011, "Progressive photon mapping: a
//! probabilistic approach"). Pass i is an ordinary photon-map render with its own photons and eye
//! samples (both keyed by i) and every map read with one fixed radius r_i,
//! r_i² = r_1² Π_{k=1}^{i−1} (k + α)/(k + 1); the image is the mean of the passes, so bias and variance
//! both vanish as passes accumulate. A pass is a pure function of (scene, seed, i): passes can run in
//! any order or in separate processes and be averaged.
use super::photon_map::{build_maps, MapRequest, PhotonMapper};
use super::Counters;
use crate::film::Image;
use crate::photon::trace::Targets;
use crate::plan::Plan;
use crate::render::{render_share_pixels, Share};
use crate::scene::Scene;
use serde::Serialize;
use std::sync::Arc;

/// What one progressive pass did (recorded in the JSON stats).
#[derive(Clone, Debug, Serialize)]
pub struct PassRecord {
    pub pass: u32,
    pub seconds: f64,
    /// Gather radius of the pass (scene units).
    pub radius: f32,
    /// Photons shot for the direct, indirect and caustic maps (0 = map not built).
    pub emitted: [u64; 3],
    /// Photons stored (bdpt, vcm: light vertices stored).
    pub stored: u64,
    /// bdpt, vcm: light subpaths traced (0 for the photon mappers).
    #[serde(skip_serializing_if = "is_zero")]
    pub light_paths: u64,
}

fn is_zero(x: &u64) -> bool {
    *x == 0
}

/// r_i for pass `i` (1-based): r_i² = r_1² Π_{k=1}^{i−1} (k + α)/(k + 1).
pub fn radius_at(r1: f32, alpha: f32, i: u32) -> f32 {
    let mut r2 = (r1 as f64) * (r1 as f64);
    for k in 1..i.max(1) {
        r2 *= (k as f64 + alpha as f64) / (k as f64 + 1.0);
    }
    r2.sqrt() as f32
}

/// The first pass's radius: `render.progressive.radius` if set, else the radius of a disc that would
/// hold about 30 photons if one pass's photons covered the scene's diffuse surfaces evenly, capped at
/// `render.gather.max_radius` of the scene diagonal.
pub fn initial_radius(scene: &Scene) -> f32 {
    let p = &scene.render.progressive;
    if p.radius > 0.0 {
        return p.radius;
    }
    radius_for_density(scene, 30.0, p.photons_per_pass as f64, |m| scene.material_holds_photons(m))
}

/// The first pass's radius for the glossy photons (`super::GlossyGather`): `render.progressive.radius`
/// if set, else as `initial_radius` over the surfaces with a glossy lobe no photon is stored for (30
/// photons in a disc if one pass's shots all landed evenly on them), with the same cap.
pub fn glossy_initial_radius(scene: &Scene) -> f32 {
    let p = &scene.render.progressive;
    if p.radius > 0.0 {
        return p.radius;
    }
    radius_for_density(scene, 30.0, p.photons_per_pass as f64, |m| scene.material_unheld_glossy(m))
}

/// The most π r² × points a radius may make: VCM's η (π r² times its light subpaths) and the MIS sums
/// it enters stay finite in f32 (a scene stretched over 1e30 units made η infinite and VCM's samples NaN).
const MAX_DISC_POINTS_AREA: f64 = 1e30;

/// The radius of a disc holding about `k` of `points` points spread evenly over the surfaces whose
/// material `holds` (those the points are stored on: photons on the surfaces that hold them, VCM's
/// light vertices on every surface that is not a delta BSDF), capped at `render.gather.max_radius` of
/// the scene diagonal, and so that π r² × `points` stays within `MAX_DISC_POINTS_AREA`.
pub fn radius_for_density(scene: &Scene, k: f64, points: f64, holds: impl Fn(u32) -> bool) -> f32 {
    let area: f64 = scene.shapes.iter().filter(|s| holds(s.material)).map(|s| s.area() as f64).sum();
    let r = (k * area / (std::f64::consts::PI * points)).sqrt();
    let cap = scene.render.gather.max_radius as f64 * scene.diagonal() as f64;
    let r = if r.is_finite() && r > 0.0 { r.min(cap) } else { cap };
    r.min((MAX_DISC_POINTS_AREA / (std::f64::consts::PI * points.max(1.0))).sqrt()) as f32
}

/// Seed of pass `i`'s eye samples: every pass of every seed draws its own pixel samples (the seed is
/// hashed before the pass index joins it, so no two (seed, pass) pairs share a stream).
pub fn pass_seed(seed: u64, i: u32) -> u64 {
    use crate::math::rng::mix64;
    mix64(mix64(seed ^ (0x5050_u64 << 32)) ^ i as u64)
}

/// The maps a progressive pass builds: those the plan wants, each from exactly `photons_per_pass` shots,
/// caustic photons aimed at `aim` (the render's targets, probed once: `aim_targets`).
pub fn pass_request(scene: &Scene, plan: &Plan, i: u32, aim: Option<&Arc<Targets>>) -> MapRequest {
    MapRequest {
        shots: Some(scene.render.progressive.photons_per_pass),
        key: i as u64,
        aim: aim.cloned(),
        ..MapRequest::planned(scene, plan)
    }
}

/// Pass `i` of probabilistic PPM at radius `r`: its image (one eye sample per pixel, and `extra[k]` more
/// for pixel k, `super::extra_samples` of the plan's `specular_spp`), counters and record.
pub fn ppm_pass(
    scene: &Scene,
    tracer: &dyn crate::accel::Tracer,
    plan: &Plan,
    extra: &[u32],
    i: u32,
    r: f32,
    aim: Option<&Arc<Targets>>,
) -> anyhow::Result<(Image, Counters, PassRecord)> {
    let t0 = std::time::Instant::now();
    let maps = build_maps(scene, tracer, &pass_request(scene, plan, i, aim), true)?;
    let mut pm = PhotonMapper::new(scene, tracer, &maps, None);
    pm.extra = extra;
    pm.radius = Some(r);
    pm.glossy_radius = Some(radius_at(glossy_initial_radius(scene), scene.render.progressive.alpha, i));
    pm.edges = scene.render.progressive.edge_correction;
    let cam = &scene.camera;
    // Each pass is one eye sample per pixel with its own scramble (passes must stay independent).
    let (sampler, seed) = (scene.render.sampler, pass_seed(scene.render.seed, i));
    let mut out = render_share_pixels(cam, 1, sampler, seed, Share::All, "eye pass", true, |x, y, s, rng, c| {
        pm.sample(x, y, s, seed, rng, c)
    })
    .finish();
    if let Some(g) = &maps.glossy {
        for (o, v) in out.image.pixels.iter_mut().zip(&g.pixels) {
            *o += *v;
        }
    }
    let record = PassRecord {
        pass: i,
        seconds: t0.elapsed().as_secs_f64(),
        radius: r,
        emitted: maps.stats.n_emitted,
        stored: maps.stats.stored.iter().sum(),
        light_paths: 0,
    };
    Ok((out.image, out.counters, record))
}

#[cfg(test)]
mod tests {
    use super::{pass_seed, radius_at};

    /// Renders with different seeds draw different eye samples in every pass: no (seed, pass) pair
    /// shares another's stream. (Seeds XORed with the pass index did: seed 1's pass 2 was seed 2's pass
    /// 1, so runs with neighbouring seeds were mostly the same samples.)
    #[test]
    fn pass_seeds_of_different_seeds_never_coincide() {
        let mut seen = std::collections::HashMap::new();
        for seed in 0..64u64 {
            for i in 1..=2000u32 {
                if let Some(prev) = seen.insert(pass_seed(seed, i), (seed, i)) {
                    panic!("seed {seed} pass {i} draws the eye samples of seed {} pass {}", prev.0, prev.1);
                }
            }
        }
    }

    #[test]
    fn radius_schedule_follows_knaus_zwicker() {
        let r1 = 0.1f32;
        assert_eq!(radius_at(r1, 2.0 / 3.0, 1), r1);
        // r_2² = r_1² (1 + α)/2, r_3² = r_2² (2 + α)/3.
        let a = 2.0f64 / 3.0;
        let r3 = 0.1f64 * ((1.0 + a) / 2.0 * (2.0 + a) / 3.0).sqrt();
        assert!((radius_at(r1, 2.0 / 3.0, 3) as f64 - r3).abs() < 1e-7);
        // r_i² falls like i^(α−1): r_1000² / r_100² ≈ 10^(α−1).
        let ratio = (radius_at(r1, 2.0 / 3.0, 1000) / radius_at(r1, 2.0 / 3.0, 100)).powi(2) as f64;
        assert!((ratio / 10f64.powf(a - 1.0) - 1.0).abs() < 0.01, "{ratio}");
    }
}
