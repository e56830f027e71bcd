//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009), as pbrt-v4's SPPMIntegrator. Each
//! iteration: a photon pass traces this iteration's photons (the shared photon tracer, into the
//! project's k-d trees); a camera pass finds every pixel's visible point (the first diffuse hit after
//! the specular chain, with the chain's throughput) and adds what is seen along the way (emission,
//! direct light by shadow rays, and at the first glossy hit past a mirror or glass the glossy photons,
//! `super::GlossyGather`, read with one radius per iteration as `ppm` reads its maps); then each pixel
//! gathers the photons within its own radius and updates its photon count N, radius r and flux τ:
//! N' = N + αM, r'² = r² N'/(N + M), τ' = (τ + Φ) r'²/r².
//! Unless the scene fixes the radius, each pixel starts at the distance of the 30th nearest photon of
//! the densest map at its first visible point (capped by the scene-wide initial radius).
//! Pixels whose centre looks into a mirror, glass or water take `specular_spp` extra camera samples per
//! iteration for the light seen along the chain and at its end (emission, direct light): a small
//! light's glint through a wavy surface covers a sliver of a pixel, and it is found only by sampling the
//! pixel's area. The visible point comes from the first sample only.
//! A gather disc that reaches past a wall or an edge holds photons over only part of its area, so the
//! plain estimate darkens a band one radius wide along every corner of a room. Each iteration probes
//! `EDGE_PROBES` points of the disc (stratified by area) for a surface that could hold its photons and
//! accumulates the covered fraction; the estimate divides the flux by that accumulated area instead of
//! n discs (a ratio of sums: consistent, and exact where the disc is whole).
//! Every pixel updates only its own state, in parallel: no shared sums, the same bits on any thread
//! count.
use super::direct::{estimate_direct_with, DirectStrategy};
use super::edges::{disc_coverage, EDGE_PROBES_KEY};
use super::photon_map::build_maps;
use super::ppm::{glossy_initial_radius, initial_radius, pass_request, radius_at, PassRecord};
use super::{specular_chain, ChainEnd, ChainLight, Counters, GlossyGather};
use crate::accel::Tracer;
use crate::color::Rgb;
use crate::film::Image;
use crate::math::Rng;
use crate::photon::estimate::Reach;
use crate::photon::kdtree::KnnResult;
use crate::plan::Plan;
use crate::scene::file::DirectLight;
use crate::scene::material::DiffuseLobe;
use crate::scene::Scene;
use rayon::prelude::*;
use std::cell::RefCell;

/// Photons a pixel's first radius is chosen to hold (in the densest map), when the scene sets none.
const INITIAL_K: usize = 30;

thread_local! {
    static SCRATCH: RefCell<KnnResult> = RefCell::new(KnnResult::new());
}

/// One pixel's running estimate.
#[derive(Clone, Copy, Debug)]
struct PixelState {
    /// Sum over iterations of the light found by the camera pass (emission, direct light).
    ld: [f64; 3],
    n: f32,
    r: f32,
    tau: Rgb,
    /// Sum over iterations of the fraction of the disc that is surface (1 for an iteration without a
    /// visible point, or without edge correction): the number of whole discs τ is divided by.
    discs: f64,
}

pub struct Sppm<'a> {
    scene: &'a Scene,
    tracer: &'a dyn Tracer,
    plan: &'a Plan,
    pixels: Vec<PixelState>,
    /// Extra camera samples per iteration, per pixel: `plan.specular_spp` where the ray through the
    /// pixel's centre first meets a non-diffuse surface, else 0. A fixed function of the pixel (not of
    /// the samples it weighs), so the average over the samples stays unbiased.
    extra: Vec<u32>,
    /// The caustic targets, probed once for every iteration's photons.
    aim: Option<std::sync::Arc<crate::photon::trace::Targets>>,
    iterations: u32,
    pub counters: Counters,
}

impl<'a> Sppm<'a> {
    /// `aim`: the render's caustic targets, probed once (`photon_map::aim_targets`).
    pub fn new(
        scene: &'a Scene,
        tracer: &'a dyn Tracer,
        plan: &'a Plan,
        aim: Option<std::sync::Arc<crate::photon::trace::Targets>>,
    ) -> Sppm<'a> {
        let r = initial_radius(scene);
        let px = PixelState { ld: [0.0; 3], n: 0.0, r, tau: Rgb::ZERO, discs: 0.0 };
        let count = scene.camera.width as usize * scene.camera.height as usize;
        let (extra, rays) = super::extra_samples(scene, tracer, plan.specular_spp);
        let counters = Counters { rays, nonfinite: 0 };
        Sppm { scene, tracer, plan, pixels: vec![px; count], extra, aim, iterations: 0, counters }
    }

    /// Runs iteration `i` (1-based; the photons and eye samples of iteration i are keyed by i).
    pub fn iterate(&mut self, i: u32) -> anyhow::Result<PassRecord> {
        let t0 = std::time::Instant::now();
        let (sampler, base_seed) = (self.scene.render.sampler, self.scene.render.seed);
        let width = self.scene.camera.width as usize;
        let maps =
            build_maps(self.scene, self.tracer, &pass_request(self.scene, self.plan, i, self.aim.as_ref()), true)?;
        let alpha = self.scene.render.progressive.alpha;
        // The glossy photons are gathered as probabilistic PPM gathers them (`ppm`): one radius per
        // iteration, shrinking by its schedule; each iteration's estimate joins the light the camera
        // pass found.
        let glossy = maps.glossy_photons.as_ref().map(|map| GlossyGather {
            map,
            reach: Reach::Radius(radius_at(glossy_initial_radius(self.scene), alpha, i)),
            edges: self.scene.render.progressive.edge_correction,
        });
        let camera: Vec<(Rgb, Option<ChainEnd>, Counters)> = (0..self.pixels.len())
            .into_par_iter()
            .map(|k| {
                // Iteration i is camera sample i − 1 of each pixel: stratified across iterations.
                let mut rng = Rng::camera(sampler, base_seed, k as u64, (i - 1) as u64);
                let mut c = Counters::default();
                let (x, y) = ((k % width) as u32, (k / width) as u32);
                let (mut l, vp) = self.camera_path(x, y, &mut rng, &mut c, glossy.as_ref());
                let extra = self.extra[k] as u64;
                for j in 0..extra {
                    let index = (i - 1) as u64 * extra + j;
                    let mut rng = Rng::camera(sampler, base_seed ^ super::EXTRA_SAMPLES_KEY, k as u64, index);
                    l += self.camera_path(x, y, &mut rng, &mut c, glossy.as_ref()).0;
                }
                l /= (extra + 1) as f32;
                (l, vp, c)
            })
            .collect();
        let scene = self.scene;
        // Unless the scene fixes it, a pixel's radius starts where its first visible point finds
        // INITIAL_K photons in the densest map of the first iteration: small inside a caustic, large
        // where photons are sparse (capped by the scene-wide initial radius).
        let adapt = i == 1 && scene.render.progressive.radius <= 0.0;
        let edges = scene.render.progressive.edge_correction;
        let probes: Vec<u64> = self
            .pixels
            .par_iter_mut()
            .zip(&camera)
            .enumerate()
            .map(|(k, (px, (l, vp, _)))| {
                // The iteration's light-traced glossy caustics count as light its camera path found.
                let glossy = maps.glossy.as_ref().map_or(Rgb::ZERO, |g| g.pixels[k]);
                for c in 0..3 {
                    px.ld[c] += l[c] as f64 + glossy[c] as f64;
                }
                let Some(vp) = vp else {
                    px.discs += 1.0;
                    return 0;
                };
                if adapt {
                    let g = crate::photon::estimate::Gather { k: INITIAL_K, max_r2: px.r * px.r, cone_k: 0.0 };
                    SCRATCH.with(|s| {
                        let mut s = s.borrow_mut();
                        for map in maps.maps.iter().flatten() {
                            let r2 = map.tree.knn(vp.si.p.to_array(), g.k, g.max_r2, &mut s);
                            if s.len() >= g.k && r2 > 0.0 {
                                px.r = px.r.min(r2.sqrt());
                            }
                        }
                    });
                }
                let (mut flux, mut m) = (Rgb::ZERO, 0u32);
                let budget = vp.budget(scene, 0);
                let lobe = vp.mat.diffuse_lobe(vp.wo, vp.si.ns).unwrap_or(DiffuseLobe::lambert(Rgb::ZERO));
                SCRATCH.with(|s| {
                    for map in maps.maps.iter().flatten() {
                        let (f, c) = map.flux_within(&vp.si, vp.wo, px.r, budget, lobe, &mut s.borrow_mut());
                        flux += f;
                        m += c;
                    }
                });
                let (covered, rays) = if edges {
                    let mut rng = Rng::new(base_seed ^ EDGE_PROBES_KEY, k as u64, i as u64);
                    disc_coverage(scene, self.tracer, &vp.si, vp.wo, px.r, &mut rng)
                } else {
                    (1.0, 0)
                };
                px.discs += covered;
                if m > 0 {
                    let phi = vp.beta * lobe.rho / std::f32::consts::PI * flux;
                    let n_new = px.n + alpha * m as f32;
                    let r_new = px.r * (n_new / (px.n + m as f32)).sqrt();
                    px.tau = (px.tau + phi) * ((r_new * r_new) / (px.r * px.r));
                    px.n = n_new;
                    px.r = r_new;
                }
                rays
            })
            .collect();
        for (_, _, c) in &camera {
            self.counters += *c;
        }
        self.counters.rays += probes.iter().sum::<u64>();
        self.iterations = i;
        let mean_r = self.pixels.iter().map(|p| p.r as f64).sum::<f64>() / self.pixels.len().max(1) as f64;
        Ok(PassRecord {
            pass: i,
            seconds: t0.elapsed().as_secs_f64(),
            radius: mean_r as f32,
            emitted: maps.stats.n_emitted,
            stored: maps.stats.stored.iter().sum(),
            light_paths: 0,
        })
    }

    /// A camera sample through pixel (x, y): the light it finds before (and at) its first diffuse hit,
    /// and that hit as a visible point. Direct light there comes from shadow rays, unless the scene reads
    /// it from photons (`render.direct_light = "photon_map"`, gathered like the rest).
    fn camera_path(
        &self,
        x: u32,
        y: u32,
        rng: &mut Rng,
        c: &mut Counters,
        glossy: Option<&GlossyGather>,
    ) -> (Rgb, Option<ChainEnd>) {
        let scene = self.scene;
        // The filter's weight (±, for a filter with negative lobes) rides in the throughput, so the
        // visible point's photons count with it too.
        let (fx, fy, weight) = scene.camera.film_position(x, y, rng.next_2d());
        let ray = scene.camera.sample_ray(fx, fy, rng);
        let beta = Rgb::splat(weight);
        let (mut l, end) =
            specular_chain(scene, self.tracer, ray, Rgb::ZERO, beta, rng, c, ChainLight::CountSplitFirst, glossy);
        if let (Some(e), DirectLight::ShadowRays) = (&end, scene.render.direct_light) {
            // No light sample where the path tracer's depth leaves none (`ChainEnd::budget`).
            if e.budget(scene, 0) == 0 {
                return (l, end);
            }
            let strategy = DirectStrategy::eye_pass(scene);
            let base = e.mat.base_only();
            l += e.beta * estimate_direct_with(scene, self.tracer, &e.si, e.wo, &base, e.sigma, rng, c, strategy);
        }
        (l, end)
    }

    /// The current estimate: L = Ld / n + τ / (D π r²) after n iterations, D the number of whole discs
    /// the flux was gathered over (n without edge correction; never taken below n/4, a quarter disc
    /// per iteration, so a few unlucky probes early on cannot blow a pixel up).
    pub fn image(&self) -> Image {
        let cam = &self.scene.camera;
        let mut img = Image::new(cam.width, cam.height);
        let n = self.iterations.max(1) as f64;
        for (o, px) in img.pixels.iter_mut().zip(&self.pixels) {
            let area = std::f64::consts::PI * (px.r as f64) * (px.r as f64);
            let discs = px.discs.max(0.25 * n);
            for k in 0..3 {
                o[k] = (px.ld[k] / n + px.tau[k] as f64 / (discs * area)) as f32;
            }
        }
        img
    }
}
