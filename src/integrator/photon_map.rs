//! Photon mapping: trace and build the three maps, then the eye pass. Camera rays follow mirrors and
//! glass by sampling until a diffuse hit, where direct light (shadow rays or the direct map), caustics
//! (caustic map) and indirect light (indirect map, or a final gather that reads the maps one bounce
//! further) are added. The caustic pass also keeps the photons of point, spot and distant lights that
//! land on glossy surfaces past a mirror or glass, which a camera ray's first glossy hit past a mirror
//! or glass reads (`super::GlossyGather`). Also the map views: photon splats and single-map estimates
//! (which leave the glossy photons out).
use super::direct::{estimate_direct_with, DirectStrategy};
use super::edges::{holds_photons, inverse_coverage, Holds, EDGE_PROBES_KEY};
use super::{ChainLight, Counters, GlossyGather};
use crate::accel::Tracer;
use crate::color::{luminance, Rgb};
use crate::film::Image;
use crate::math::{Ray, Rng};
use crate::photon::estimate::{Gather, PhotonMap, Reach};
use crate::photon::kdtree::{KdTree, KnnResult};
use crate::photon::photon::EVENTS_CAP;
use crate::photon::trace::{run_pass, PassSettings, PassStats, Targets, CAUSTIC, DIRECT, INDIRECT, MAP_NAMES};
use crate::scene::file::DirectLight;
use crate::scene::material::DiffuseLobe;
use crate::scene::{Scene, SurfaceHit, TransportMode};
use serde::Serialize;
use std::cell::RefCell;

/// The built maps (None = not built) and what it took.
pub struct PhotonMaps {
    pub maps: [Option<PhotonMap>; 3],
    /// The caustic pass's light-traced caustics of delta lights on glossy surfaces, per pixel (radiance,
    /// to be added to the eye pass's estimate: `PassSettings::glossy_splats`); None without a caustic
    /// pass or without any such light reaching the film.
    pub glossy: Option<Image>,
    /// The caustic pass's photons of delta lights on glossy lobes, past a mirror or glass first (the
    /// light the glossy splats carry), for camera chains that meet a glossy surface past a mirror or
    /// glass (`super::GlossyGather`); None when none was stored.
    pub glossy_photons: Option<PhotonMap>,
    pub stats: MapsStats,
}

impl PhotonMaps {
    /// Whether direct light is read from the direct map (built, and `render.direct_light` asks for it)
    /// rather than traced with shadow rays: the eye pass and the radiance cache decide alike.
    pub fn direct_from_map(&self, scene: &Scene) -> bool {
        self.maps[DIRECT].is_some() && scene.render.direct_light == DirectLight::PhotonMap
    }
}

#[derive(Debug, Default, Clone, Serialize)]
pub struct MapsStats {
    pub global_pass: Option<PassStats>,
    pub caustic_pass: Option<PassStats>,
    pub caustic_targeted: bool,
    /// Seconds spent probing what the lights see of the caustic targets, and the rays it took (0 when
    /// they came probed).
    pub aim_seconds: f64,
    pub aim_rays: u64,
    pub stored: [u64; 3],
    /// Photons kept on glossy lobes (`PhotonMaps::glossy_photons`).
    pub glossy_stored: u64,
    pub n_emitted: [u64; 3],
    pub complete: [bool; 3],
    pub bytes_per_photon: [f64; 3],
    pub build_seconds: f64,
    pub photons_per_second: f64,
}

impl MapsStats {
    /// Seconds spent tracing photons, over both passes, and aiming the caustic ones.
    pub fn trace_seconds(&self) -> f64 {
        self.aim_seconds + [self.global_pass, self.caustic_pass].iter().flatten().map(|p| p.seconds).sum::<f64>()
    }
}

/// What to trace: photons wanted per map, and whether caustic photons are aimed at specular shapes.
#[derive(Default)]
pub struct MapRequest {
    pub want: [u64; 3],
    pub targeted: bool,
    /// Restrict caustic targets to these shapes (the planner's list); None = every specular shape.
    pub targets: Option<Vec<u32>>,
    /// Progressive passes: shoot exactly this many photons in each tracing pass and keep every photon
    /// stored (maps with a nonzero `want` are built); None = trace until each map holds `want`.
    pub shots: Option<u64>,
    /// Distinguishes the random streams of progressive passes (0 for the fixed photon map).
    pub key: u64,
    /// The caustic targets with their probed shares, built once for all the passes of a progressive
    /// render (`aim_targets`); None: built here when the caustic map is aimed.
    pub aim: Option<std::sync::Arc<Targets>>,
}

/// The caustic targets `planned` requests aim at, probed once (a ray per target triangle), for a
/// render whose passes all trace caustic photons; None when no caustic photons are aimed.
pub fn aim_targets(scene: &Scene, tracer: &dyn Tracer, plan: &crate::plan::Plan) -> Option<std::sync::Arc<Targets>> {
    let aimed = plan.photons[CAUSTIC] > 0 && scene.render.photons.caustic_targeting;
    aimed.then(|| std::sync::Arc::new(Targets::new(scene, tracer, Some(&plan.caustic_targets))))
}

impl MapRequest {
    /// The maps `plan` asks for, with the scene's targeting setting and the plan's caustic targets.
    pub fn planned(scene: &Scene, plan: &crate::plan::Plan) -> MapRequest {
        MapRequest {
            want: plan.photons,
            targeted: scene.render.photons.caustic_targeting,
            targets: Some(plan.caustic_targets.clone()),
            ..Default::default()
        }
    }
}

/// What a user is told of map `i` left with `stored` of its `want[i]` photons after `shot` photons,
/// the pass's budget `factor` × its largest request: the share of shots that stored one, that the
/// estimate stays right (normalised by every shot, from fewer photons over a wider gather), and the
/// factor that would about fill it at that share, or the smaller request.
fn unfilled(i: usize, stored: u64, shot: u64, want: [u64; 3], factor: u64) -> String {
    let name = MAP_NAMES[i];
    let head = format!(
        "the {name} map got {stored} photons of {} requested before the shot budget ran out ({shot} shot",
        want[i]
    );
    // The budget of the pass that traces this map: the global pass shoots for its larger request.
    let pass_want = if i == CAUSTIC { want[CAUSTIC] } else { want[DIRECT].max(want[INDIRECT]) };
    if stored == 0 {
        return format!(
            "{head}, none of them stored one): light seldom or never reaches a surface that keeps {name} \
             photons. render.photons.max_shots_factor (now {factor}) shoots more; render.photons.{name} = 0 leaves \
             the map and its light out"
        );
    }
    let needed = (want[i] as f64 * shot as f64 / stored as f64 / pass_want.max(1) as f64).ceil() as u64;
    format!(
        "{head}, {:.2}% of them stored one); its estimate is right, from fewer photons over a wider gather. \
         render.photons.max_shots_factor = {} (now {factor}) would about fill it, or ask for fewer \
         (render.photons.{name})",
        100.0 * stored as f64 / shot.max(1) as f64,
        needed.max(factor + 1)
    )
}

pub fn build_maps(scene: &Scene, tracer: &dyn Tracer, req: &MapRequest, quiet: bool) -> anyhow::Result<PhotonMaps> {
    let ps = &scene.render.photons;
    // One bar per photon pass, named, each running to 100% (progressive passes have their own line).
    let bar = |len: u64, label: &str| crate::progress::progress(len, label, quiet || req.shots.is_some());
    let mut stats = MapsStats::default();
    let mut maps: [Option<PhotonMap>; 3] = Default::default();
    let t0 = std::time::Instant::now();
    let mut collected: [Option<crate::photon::trace::MapPhotons>; 3] = Default::default();
    let mut glossy_collected = None;
    let holds = scene.any_holds_photons();
    if req.want[DIRECT] + req.want[INDIRECT] > 0 {
        let want = [req.want[DIRECT], req.want[INDIRECT], 0, 0];
        let s = PassSettings {
            want: req.shots.map_or(want, |_| want.map(|w| if w > 0 { u64::MAX } else { 0 })),
            max_depth: scene.render.max_depth,
            rr_depth: scene.render.rr_depth,
            max_shots: req
                .shots
                .unwrap_or_else(|| want.iter().max().copied().unwrap_or(0).saturating_mul(ps.max_shots_factor)),
            seed: scene.render.seed,
            pass: 1 + 2 * req.key,
            glossy_splats: false,
        };
        let pb = bar(want[DIRECT].saturating_add(want[INDIRECT]), "photons: direct+indirect");
        let (m, st) = run_pass(scene, tracer, &s, None, &pb);
        pb.finish_and_clear();
        let [d, i, _, _] = m;
        collected[DIRECT] = (want[DIRECT] > 0).then_some(d);
        collected[INDIRECT] = (want[INDIRECT] > 0).then_some(i);
        stats.global_pass = Some(st);
    }
    if req.want[CAUSTIC] > 0 {
        let built;
        let targets: &Targets = match &req.aim {
            Some(t) => t,
            None => {
                let t_aim = std::time::Instant::now();
                built =
                    if req.targeted { Targets::new(scene, tracer, req.targets.as_deref()) } else { Targets::none() };
                stats.aim_seconds = t_aim.elapsed().as_secs_f64();
                stats.aim_rays = built.probe_rays;
                &built
            }
        };
        let targeted = req.targeted && !targets.is_empty();
        // With no surface to hold them, caustic photons are traced for their glossy caustics alone: as
        // many shots as photons asked for (a count of stored photons would never be reached).
        let shots = req.shots.or((!holds).then_some(req.want[CAUSTIC]));
        let count = if shots.is_some() { u64::MAX } else { req.want[CAUSTIC] };
        // Photons on glossy lobes, as many as caustic photons at most, where a delta light's light can
        // reach one past a mirror or glass.
        let glossy =
            if scene.lights.list.iter().any(|l| l.is_delta()) && scene.any_unheld_glossy() { count } else { 0 };
        let s = PassSettings {
            want: [0, 0, count, glossy],
            max_depth: scene.render.max_depth,
            rr_depth: scene.render.rr_depth,
            max_shots: shots.unwrap_or_else(|| req.want[CAUSTIC].saturating_mul(ps.max_shots_factor)),
            seed: scene.render.seed,
            pass: 2 + 2 * req.key,
            glossy_splats: true,
        };
        let pb = bar(req.want[CAUSTIC], if holds { "photons: caustic" } else { "photons: caustic (shots)" });
        let (m, st) = run_pass(scene, tracer, &s, targeted.then_some(targets), &pb);
        pb.finish_and_clear();
        let [_, _, c, g] = m;
        collected[CAUSTIC] = Some(c);
        glossy_collected = Some(g).filter(|g| !g.photons.is_empty());
        stats.caustic_pass = Some(st);
        stats.caustic_targeted = targeted;
    }
    let trace_s = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let mut glossy = None;
    for (i, c) in collected.into_iter().enumerate() {
        if let Some(mut c) = c {
            if !c.splats.is_empty() {
                glossy = Some(splat_image(scene, &std::mem::take(&mut c.splats), c.n_emitted));
            }
            // (A caustic pass with nothing to hold its photons shoots a count, not to a count.)
            if !c.complete && req.shots.is_none() && (i != CAUSTIC || holds) {
                eprintln!(
                    "warning: {}",
                    unfilled(i, c.photons.len() as u64, c.n_emitted, req.want, ps.max_shots_factor)
                );
            }
            let m = PhotonMap::build(c).map_err(|e| anyhow::anyhow!("{} map: {e}", MAP_NAMES[i]))?;
            stats.stored[i] = m.len() as u64;
            stats.n_emitted[i] = m.n_emitted;
            stats.complete[i] = m.complete;
            stats.bytes_per_photon[i] = m.tree.bytes_per_point();
            maps[i] = Some(m);
        }
    }
    let glossy_photons = match glossy_collected {
        Some(g) => Some(PhotonMap::build(g).map_err(|e| anyhow::anyhow!("glossy photons: {e}"))?),
        None => None,
    };
    stats.glossy_stored = glossy_photons.as_ref().map_or(0, |m| m.len() as u64);
    stats.build_seconds = t1.elapsed().as_secs_f64();
    stats.photons_per_second = stats.stored.iter().sum::<u64>() as f64 / trace_s.max(1e-9);
    Ok(PhotonMaps { maps, glossy, glossy_photons, stats })
}

/// Light-tracing splats of `n_emitted` photons, summed per pixel, as a radiance image.
fn splat_image(scene: &Scene, sum: &[[f64; 3]], n_emitted: u64) -> Image {
    let cam = &scene.camera;
    let mut img = Image::new(cam.width, cam.height);
    let n = n_emitted.max(1) as f64;
    for (o, s) in img.pixels.iter_mut().zip(sum) {
        *o = Rgb::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32);
    }
    img
}

thread_local! {
    static SCRATCH: RefCell<KnnResult> = RefCell::new(KnnResult::new());
}

/// An estimate of 1 / (the part of the gather disc of radius `r` about `si` that is surface, weighed by
/// the kernel), from its own random stream keyed by two draws of `rng`'s generator (which leaves a
/// camera sample's Sobol dimensions as they were): `edges::inverse_coverage` over the surfaces that
/// `holds` the estimate's photons. Its rays go to `c`.
#[allow(clippy::too_many_arguments)]
pub(super) fn edge_factor(
    scene: &Scene,
    tracer: &dyn Tracer,
    si: &SurfaceHit,
    wo: glam::Vec3,
    r: f32,
    cone_k: f32,
    rng: &mut Rng,
    c: &mut Counters,
    holds: Holds,
) -> f32 {
    let mut probes = Rng::new(EDGE_PROBES_KEY, rng.next_u32() as u64, rng.next_u32() as u64);
    let (inv, rays) = inverse_coverage(scene, tracer, si, wo, r, cone_k, &mut probes, holds);
    c.rays += rays;
    inv
}

/// `map`'s k-NN estimate at `si` (`PhotonMap::radiance`), times `edge_factor` at the radius it gathered
/// over (with its cone filter) when `edges` is set and it found photons.
#[allow(clippy::too_many_arguments)]
fn knn_radiance(
    scene: &Scene,
    tracer: &dyn Tracer,
    map: &PhotonMap,
    si: &SurfaceHit,
    wo: glam::Vec3,
    lobe: DiffuseLobe,
    g: Gather,
    budget: u32,
    edges: bool,
    rng: &mut Rng,
    c: &mut Counters,
) -> Rgb {
    let (l, r) = SCRATCH.with(|s| map.radiance(si, wo, lobe, g, budget, &mut s.borrow_mut()));
    if edges && l != Rgb::ZERO {
        l * edge_factor(scene, tracer, si, wo, r, g.cone_k, rng, c, holds_photons)
    } else {
        l
    }
}

/// Radiance per unit albedo (indirect + caustic maps) precomputed at a point of a surface.
#[derive(Clone, Copy, Debug, Default)]
pub struct CachedRadiance {
    l: [f32; 3],
    normal: u8,
}

/// Shadow rays per cached point for its direct light (when direct light is not read from the map).
const CACHE_DIRECT_SAMPLES: u32 = 4;
/// The random stream of the cache's direct-light samples (keyed apart from photons and pixels).
const CACHE_STREAM: u64 = 0xCAC4_E000_0000_0001;

/// Radiance per unit albedo (direct, caustic and indirect) precomputed at every `stride`-th photon of
/// the indirect map (Christensen 1999, "Faster photon map global illumination"): a final-gather ray then
/// reads the nearest cached point on the same surface instead of gathering 200 + 100 photons and
/// tracing a shadow ray. Each point's exact surface normal is found by a short ray down the photon's
/// (coarse) normal, so the estimate there uses the same filters as an eye-pass gather; its direct light
/// is the direct map's estimate when direct light comes from the map, else the mean of
/// `CACHE_DIRECT_SAMPLES` shadow rays.
pub struct RadianceCache {
    tree: KdTree<CachedRadiance>,
    /// Farthest a lookup may go (squared): the indirect map's largest gather radius.
    max_r2: f32,
}

impl RadianceCache {
    pub fn build(
        scene: &Scene,
        tracer: &dyn Tracer,
        maps: &PhotonMaps,
        gather: &[Gather; 3],
        stride: u32,
        edges: bool,
    ) -> Option<RadianceCache> {
        use rayon::prelude::*;
        let ind = maps.maps[INDIRECT].as_ref()?;
        if stride == 0 || ind.is_empty() {
            return None;
        }
        let delta = 1e-4 * scene.diagonal().max(1e-30);
        // Gather rays land one bounce into the path (their ends at two or more bounces, after glass,
        // read the cache only where the depth left is past what photons record: `diffuse_radiance`).
        let budget = scene.render.max_depth.saturating_sub(1);
        let ids: Vec<u32> = (0..ind.len() as u32).step_by(stride as usize).collect();
        let points: Vec<([f32; 3], CachedRadiance)> = ids
            .par_iter()
            .filter_map(|&i| {
                let p = glam::Vec3::from_array(ind.tree.position(i));
                let nc = ind.tree.item(i).n();
                let mut probe = Ray::new(p + nc * delta, -nc);
                probe.tmax = 2.0 * delta;
                let h = tracer.intersect(&probe)?;
                let si = scene.surface(&probe, h.shape, h.prim, h.u, h.v, h.t);
                let wo = crate::math::face_forward(si.ng, nc);
                // The edge correction's probes draw from a stream of their own.
                let mut edge_rng = Rng::new(scene.render.seed ^ EDGE_PROBES_KEY, CACHE_STREAM, i as u64);
                let mut from_maps = |which: &[usize]| {
                    let (unit, mut c) = (DiffuseLobe::lambert(Rgb::ONE), Counters::default());
                    which
                        .iter()
                        .filter_map(|&m| Some((m, maps.maps[m].as_ref()?)))
                        .map(|(m, map)| {
                            knn_radiance(
                                scene,
                                tracer,
                                map,
                                &si,
                                wo,
                                unit,
                                gather[m],
                                budget,
                                edges,
                                &mut edge_rng,
                                &mut c,
                            )
                        })
                        .sum::<Rgb>()
                };
                let direct = if maps.direct_from_map(scene) {
                    from_maps(&[DIRECT])
                } else {
                    let unit = crate::scene::Material::Diffuse { reflectance: Rgb::ONE };
                    let mut rng = Rng::new(scene.render.seed, CACHE_STREAM, i as u64);
                    let mut c = Counters::default();
                    // A photon's path carried no medium to its record: the side it faces says it.
                    let arrived = scene.sigma_leaving(&si, wo);
                    let sum = (0..CACHE_DIRECT_SAMPLES).fold(Rgb::ZERO, |acc, _| {
                        acc + estimate_direct_with(
                            scene,
                            tracer,
                            &si,
                            wo,
                            &unit,
                            arrived,
                            &mut rng,
                            &mut c,
                            DirectStrategy::LightOnly,
                        )
                    });
                    sum / CACHE_DIRECT_SAMPLES as f32
                };
                let l = direct + from_maps(&[INDIRECT, CAUSTIC]);
                let normal = crate::photon::photon::oct_encode_coarse(crate::math::face_forward(si.ns, wo));
                Some((si.p.to_array(), CachedRadiance { l: l.to_array(), normal }))
            })
            .collect();
        if points.is_empty() {
            return None;
        }
        // Lookups reach as far as the indirect gather does.
        let max_r2 = gather[INDIRECT].max_r2;
        KdTree::build(points).ok().map(|tree| RadianceCache { tree, max_r2 })
    }

    /// Radiance per unit albedo at `si` seen from `wo`: the nearest cached point (within the indirect
    /// gather's reach) whose surface faces the same way and lies near the tangent plane, or None.
    fn lookup(&self, si: &SurfaceHit, wo: glam::Vec3, res: &mut KnnResult) -> Option<Rgb> {
        let side = crate::math::face_forward(si.ns, wo);
        let same_surface = |i: u32, d2: f32| {
            let off = (glam::Vec3::from_array(self.tree.position(i)) - si.p).dot(side);
            off * off <= 0.0625 * d2.max(1e-30)
                && crate::photon::photon::oct_decode_coarse(self.tree.item(i).normal).dot(side) >= 0.8
        };
        let (i, _) = self.tree.nearest_where(si.p.to_array(), self.max_r2, res, same_surface)?;
        Some(Rgb::from_array(self.tree.item(i).l))
    }
}

/// The eye pass.
pub struct PhotonMapper<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a dyn Tracer,
    pub maps: &'a PhotonMaps,
    pub gather: [Gather; 3],
    /// Show one map's estimate alone (the `map:` views).
    pub only: Option<usize>,
    /// Extra eye samples per sample of each pixel (row-major, `super::extra_samples`): none unless set.
    pub extra: &'a [u32],
    /// Progressive passes: every map is read with this fixed gather radius (box kernel, all photons
    /// within it) instead of its k nearest photons.
    pub radius: Option<f32>,
    /// Progressive passes: the glossy photons (`super::GlossyGather`) are read with this fixed radius
    /// (box kernel) instead of the caustic map's k nearest.
    pub glossy_radius: Option<f32>,
    /// Final gather's precomputed radiance, read by gather rays when set (the fixed photon mapper's
    /// eye pass sets it when `render.final_gather` > 0; progressive passes do not).
    pub cache: Option<RadianceCache>,
    /// Multiply each gather's photons by an estimate of 1 / (the part of its disc that is surface), so
    /// that discs reaching past an edge do not read dark (`edges::inverse_coverage`).
    pub edges: bool,
}

impl<'a> PhotonMapper<'a> {
    pub fn new(
        scene: &'a Scene,
        tracer: &'a dyn Tracer,
        maps: &'a PhotonMaps,
        only: Option<usize>,
    ) -> PhotonMapper<'a> {
        let g = &scene.render.gather;
        let max_r = g.max_radius * scene.diagonal();
        let mk = |k: u32| Gather { k: k as usize, max_r2: max_r * max_r, cone_k: g.cone_k };
        PhotonMapper {
            scene,
            tracer,
            maps,
            gather: [mk(g.direct), mk(g.indirect), mk(g.caustic)],
            only,
            extra: &[],
            radius: None,
            glossy_radius: None,
            cache: None,
            edges: false,
        }
    }

    /// Map `m`'s estimate at `si`, times an unbiased estimate of 1 / (the part of its gather disc that
    /// is surface) when `edges` is set (`edges::inverse_coverage`, drawn only where photons were found).
    /// With a fixed radius every map's disc is the same, so the first map's draw is kept in `shared`
    /// for the others of the same gather point.
    #[allow(clippy::too_many_arguments)]
    fn map_radiance(
        &self,
        m: usize,
        si: &SurfaceHit,
        wo: glam::Vec3,
        lobe: DiffuseLobe,
        budget: u32,
        rng: &mut Rng,
        c: &mut Counters,
        shared: &mut Option<f32>,
    ) -> Rgb {
        let Some(map) = &self.maps.maps[m] else {
            return Rgb::ZERO;
        };
        let Some(r) = self.radius else {
            let (scene, tracer, g) = (self.scene, self.tracer, self.gather[m]);
            return knn_radiance(scene, tracer, map, si, wo, lobe, g, budget, self.edges, rng, c);
        };
        let (flux, _) = SCRATCH.with(|s| map.flux_within(si, wo, r, budget, lobe, &mut s.borrow_mut()));
        let l = flux * lobe.rho / (std::f32::consts::PI * std::f32::consts::PI * r * r);
        if !self.edges || l == Rgb::ZERO {
            return l;
        }
        // Progressive passes gather with a box kernel.
        let (scene, tracer) = (self.scene, self.tracer);
        l * *shared.get_or_insert_with(|| edge_factor(scene, tracer, si, wo, r, 0.0, rng, c, holds_photons))
    }

    /// Radiance leaving a diffuse point (or a plastic's base) by its diffuse lobe: direct + caustic +
    /// indirect (`fg` final-gather rays, 0 = map), from light paths of at most `budget` scattering events
    /// from here on (`ChainEnd::budget`).
    #[allow(clippy::too_many_arguments)]
    fn diffuse_radiance(
        &self,
        end: &super::ChainEnd,
        rng: &mut Rng,
        c: &mut Counters,
        fg: u32,
        in_gather: bool,
        budget: u32,
    ) -> Rgb {
        if budget == 0 {
            // The path tracer counts only emission here (the chain did).
            return Rgb::ZERO;
        }
        let (si, wo, mat) = (&end.si, end.wo, &end.mat);
        let Some(lobe) = mat.diffuse_lobe(wo, si.ns) else {
            return Rgb::ZERO;
        };
        let mut shared = None;
        if let Some(m) = self.only {
            return self.map_radiance(m, si, wo, lobe, budget, rng, c, &mut shared);
        }
        // The cache holds direct light too: a gather ray that finds it traces no shadow ray. It was
        // filled for a gather ray's end one bounce into the path; past glass, where less depth is left,
        // it is read only when the photons' records could not tell the difference anyway. It holds a
        // Lambertian surface's light (per unit albedo): a plastic's coat and a normal map weigh each direction, so
        // such a surface gathers for itself.
        let cache_fits = budget + 1 >= self.scene.render.max_depth || budget >= EVENTS_CAP;
        if in_gather && cache_fits && lobe.coat.is_none() && lobe.map.is_none() {
            if let Some(l) =
                self.cache.as_ref().and_then(|cache| SCRATCH.with(|r| cache.lookup(si, wo, &mut r.borrow_mut())))
            {
                return l * lobe.rho;
            }
        }
        let direct = if self.maps.direct_from_map(self.scene) {
            self.map_radiance(DIRECT, si, wo, lobe, budget, rng, c, &mut shared)
        } else {
            // Final-gather ends keep the light sample alone (a BSDF sample there is not worth its ray).
            let strategy = if in_gather { DirectStrategy::LightOnly } else { DirectStrategy::eye_pass(self.scene) };
            estimate_direct_with(self.scene, self.tracer, si, wo, &mat.base_only(), end.sigma, rng, c, strategy)
        };
        let caustic = self.map_radiance(CAUSTIC, si, wo, lobe, budget, rng, c, &mut shared);
        if fg > 0 {
            return direct + caustic + self.final_gather(si, wo, mat, end.sigma, rng, c, fg, budget);
        }
        direct + caustic + self.map_radiance(INDIRECT, si, wo, lobe, budget, rng, c, &mut shared)
    }

    /// Indirect light by `n` rays sampled from the surface's BSDF (cosine about the shading normal, as
    /// direct light and the path tracer use it) that read the maps where they land, `budget` scattering
    /// events left here (this one's included); the path arrived here through a medium of absorption
    /// `arrived`.
    #[allow(clippy::too_many_arguments)]
    fn final_gather(
        &self,
        si: &SurfaceHit,
        wo: glam::Vec3,
        mat: &crate::scene::Material,
        arrived: Rgb,
        rng: &mut Rng,
        c: &mut Counters,
        n: u32,
        budget: u32,
    ) -> Rgb {
        if budget <= 1 {
            return Rgb::ZERO;
        }
        // A rough plastic's coat lobe is the chain's to follow: only its base gathers.
        let mat = mat.base_only();
        // The gather rays' first hits are one bounce further into the path than this point.
        let first = self.scene.render.max_depth - budget + 1;
        let mut sum = Rgb::ZERO;
        for _ in 0..n {
            let Some((bs, ray)) = si.scatter(&mat, wo, rng, TransportMode::Radiance) else {
                continue;
            };
            // A plastic's mirror lobe is the chain's to follow (`specular_chain`): here it counts 0,
            // which leaves the diffuse lobe's share in expectation.
            if bs.delta {
                continue;
            }
            // Emission seen by gather rays is direct light or a caustic, already counted: skip it.
            sum += self.follow(ray, self.scene.sigma_next(si, ray.d, arrived), bs.weight, rng, c, false, 0, first);
        }
        sum / n as f32
    }

    /// Follows a ray whose first hit is `first` bounces into its path through specular surfaces to a
    /// diffuse one; `emission` adds lights seen on the way.
    #[allow(clippy::too_many_arguments)]
    fn follow(
        &self,
        ray: Ray,
        sigma: Rgb,
        beta: Rgb,
        rng: &mut Rng,
        c: &mut Counters,
        emission: bool,
        fg: u32,
        first: u32,
    ) -> Rgb {
        let count_emission = emission && self.only.is_none();
        let light = if count_emission { ChainLight::CountSplitFirst } else { ChainLight::Skip };
        // Camera chains (the ones that count emission) gather the glossy photons past a mirror or glass.
        let glossy = self.maps.glossy_photons.as_ref().filter(|_| count_emission && first == 0).map(|map| {
            let reach = match self.glossy_radius {
                Some(r) => Reach::Radius(r),
                None => Reach::Knn(self.gather[CAUSTIC]),
            };
            GlossyGather { map, reach, edges: self.edges }
        });
        let (mut l, end) =
            super::specular_chain(self.scene, self.tracer, ray, sigma, beta, rng, c, light, glossy.as_ref());
        if let Some(e) = end {
            // Final-gather rays are the ones that do not count emission.
            l += e.beta * self.diffuse_radiance(&e, rng, c, fg, !emission, e.budget(self.scene, first));
        }
        l
    }

    /// Camera sample `s` of pixel (x, y), filter-weighted, with the pixel's extra samples (keyed by
    /// `seed`, the eye pass's), `rng` the pixel's sampler for sample `s`.
    pub fn sample(&self, x: u32, y: u32, s: u32, seed: u64, rng: &mut Rng, c: &mut Counters) -> Rgb {
        let fg = self.scene.render.final_gather;
        let k = y as usize * self.scene.camera.width as usize + x as usize;
        let extra = self.extra.get(k).copied().unwrap_or(0);
        super::eye_sample(self.scene, x, y, s as u64, extra, seed, rng, |ray, rng| {
            self.follow(ray, Rgb::ZERO, Rgb::ONE, rng, c, true, fg, 0)
        })
    }
}

/// The colours of the direct, indirect and caustic photons in `--view photons:…` (and its legend).
pub const PHOTON_TINTS: [Rgb; 3] = [Rgb::new(1.0, 0.9, 0.6), Rgb::new(0.5, 0.7, 1.0), Rgb::new(1.0, 0.4, 0.9)];

/// Photon positions splatted onto the film (visible ones only), coloured by normalised power.
pub fn splat_photons(scene: &Scene, tracer: &dyn Tracer, maps: &PhotonMaps, which: &[usize]) -> Image {
    let cam = &scene.camera;
    let mut img = Image::new(cam.width, cam.height);
    let total: usize = which.iter().filter_map(|&m| maps.maps[m].as_ref()).map(|m| m.len()).sum();
    // Dots stay distinguishable whatever the photon count: about two photons' worth saturates a pixel.
    let weight = (2.0 * img.pixels.len() as f32 / total.max(1) as f32).clamp(0.02, 0.5);
    for &m in which {
        let Some(map) = &maps.maps[m] else { continue };
        let tint = PHOTON_TINTS[m];
        for i in 0..map.len() as u32 {
            let p = glam::Vec3::from_array(map.tree.position(i));
            let Some(link) = cam.link(cam.origin, p).filter(|l| !l.beyond_far) else {
                continue;
            };
            let (x, y) = link.film;
            let mut r = Ray::new(link.clear, p - link.clear);
            r.tmax = 1.0 - 1e-3;
            if tracer.occluded(&r) {
                continue;
            }
            let phi = map.phi(i);
            let lum = luminance(phi).max(1e-30);
            let px = img.get(x as u32, y as u32);
            img.set(x as u32, y as u32, px + tint * (phi / lum).min(glam::Vec3::splat(4.0)) * weight);
        }
    }
    img
}
