//! Photon tracing: emission from the lights (uniform, or aimed at specular surfaces for caustics),
//! bounces through Embree, storage into the direct / indirect / caustic maps. Bounces go through the
//! same BSDF sampling as camera paths, in importance mode (no 1/η², shading-normal adjoint). Depth
//! follows the path tracer: a photon path plus the surface it is gathered at has at most
//! `render.max_depth` scattering events; Russian roulette at diffuse hits by reflectance (a plastic's base:
//! by the sample's weight), and at specular hits (a plastic's coat among them) past `render.rr_depth` on
//! the throughput, as the path tracer does. Photon i's random
//! numbers are keyed by (seed, pass, i), and batches are merged in index order, so the maps are
//! identical for any thread count. Each map counts its own `n_emitted`: the
//! number of photons shot up to the batch in which it reached its requested size.
use crate::accel::Tracer;
use crate::color::Rgb;
use crate::math::sampling::hammersley;
use crate::math::{face_forward, max_component, offset_ray_origin, sampling, Ray, Rng};
use crate::photon::photon::{with_events, Photon};
use crate::scene::{Geometry, Scene, TransportMode};
use glam::Vec3;
use rayon::prelude::*;

/// Map indices.
pub const DIRECT: usize = 0;
pub const INDIRECT: usize = 1;
pub const CAUSTIC: usize = 2;
/// The caustic pass's photons on glossy lobes (`PassSettings::want`'s last entry; not one of the three
/// maps of `MAP_NAMES`).
pub const GLOSSY: usize = 3;
pub const MAP_NAMES: [&str; 3] = ["direct", "indirect", "caustic"];

const BATCH: u64 = 4096;

/// Photons gathered for one map, before the tree is built.
#[derive(Debug, Default, Clone)]
pub struct MapPhotons {
    /// Positions (recording the path's scattering events: `with_events`) and compact payloads (20
    /// bytes a photon), power not yet divided by `n_emitted` (`PhotonMap` applies 1/n_emitted when it
    /// reads a photon).
    pub photons: Vec<Stored>,
    /// Photons shot (stored or not) that this map's estimate is normalised by.
    pub n_emitted: u64,
    /// False when the shot budget ran out before the requested count was reached.
    pub complete: bool,
    /// Light-tracing splats of the photons shot for this map, summed per pixel in the order shot (power
    /// not yet divided by `n_emitted`; empty until the first): the caustic pass's glossy caustics
    /// (`PassSettings::glossy_splats`). Summed as they come, so their memory is the film's, not a
    /// record per splat.
    pub splats: Vec<[f64; 3]>,
}

/// A photon as the tracer keeps it: position and compact payload (what the k-d tree stores).
pub type Stored = ([f32; 3], crate::photon::photon::PhotonPayload);

impl MapPhotons {
    /// A map's photons from full records whose power is already per emitted photon (`n_emitted` = 1
    /// keeps it so), e.g. photons built by hand in tests.
    pub fn from_photons(photons: &[Photon], n_emitted: u64) -> MapPhotons {
        MapPhotons {
            photons: photons.iter().map(|p| (with_events(p.p.to_array(), 0), p.payload())).collect(),
            n_emitted,
            complete: true,
            splats: Vec::new(),
        }
    }
}

/// What a tracing pass did.
#[derive(Debug, Default, Clone, Copy, serde::Serialize)]
pub struct PassStats {
    pub shot: u64,
    /// Rays traced, also those of batches traced past the point where the maps filled up.
    pub segments: u64,
    /// Rays of the glossy caustics' links to the camera (`PassSettings::glossy_splats`; shadow rays,
    /// not in `segments`).
    pub camera_rays: u64,
    pub seconds: f64,
    pub budget_exhausted: bool,
}

/// Share of the caustic shots aimed by area alone, whatever the probes saw (the defensive part of the
/// mixture): every point of a target keeps at least this share of the by-area density, so a triangle
/// the probes misjudged as hidden is still aimed at, its photons at most 1/`AIM_BY_AREA` times heavier
/// than by area alone. The estimate is unbiased for any value in (0, 1].
const AIM_BY_AREA: f32 = 0.1;
/// Most probes a target triangle (or sphere) gets.
const AIM_PROBES: usize = 64;
/// Light samples a probe draws before it gives up finding a light point that faces its target point.
const AIM_LIGHT_TRIES: usize = 8;
/// Probe rays the targets' triangles share: each gets this many over the number of triangles, at least
/// one (the glass dragon's 871k triangles: one each) and at most `AIM_PROBES` (a 12-triangle glass
/// block: 64 each, at stratified points of the triangle).
const AIM_PROBE_RAYS: usize = 1 << 16;

/// Photons of the pilot that measures each target's yield (`Targets::pilot_yields`).
const AIM_PILOT: u64 = 1 << 14;
/// Shots' worth of the mean yield each target's pilot count starts from (a target few pilot photons
/// were aimed at keeps about the mean).
const AIM_PILOT_PRIOR: f64 = 16.0;
/// Fewest stored pilot photons that say anything about the targets' yields.
const AIM_PILOT_MIN_STORED: f64 = 64.0;

/// Specular surfaces that caustic photons are aimed at. A point is drawn in two steps (a target shape,
/// then one of its triangles, each by precomputed shares), with density over the targets' area
///
///   p(y) = (1 − a) · c(T)·v(T)/V + a / A,   a = `AIM_BY_AREA`,
///
/// for y on triangle T: A the targets' total area, v(T) the fraction of probes for which a photon aimed
/// at a point of T, from a light point drawn as direct lighting draws it there (facing that point: the
/// far side of a sphere light would say nothing about T), arrives first (what `trace_one` checks of
/// every aimed photon), c(T) the yield of T's shape: the share of the photons aimed at it (by the
/// density with c = 1) that a caustic pass stores, measured by a pilot of `AIM_PILOT` photons where
/// there are two target shapes or more (`pilot_yields`), V = Σ area(T)·c(T)·v(T). A closed glass mesh
/// shows a light at most half its area, and its folds hide more (the glass dragon: three aimed photons
/// in four hit the dragon elsewhere first and were dropped); with the probes most shots arrive. A
/// plastic floor beside a glass ball would take most shots by its area, though a caustic pass keeps
/// nothing of the light its base scatters and its coat sends most of the rest out of the scene; with
/// the pilot most go to the ball. A sphere is one element (uniform on it), probed at `AIM_PROBES`
/// points.
pub struct Targets {
    shapes: Vec<u32>,
    /// Running sum of each target shape's share of the shots.
    cdf: Vec<f32>,
    /// Per target shape: its triangles drawn by their shares (meshes only).
    tri_pick: Vec<sampling::AliasTable>,
    /// Per target shape: 1 / p(y) on each triangle (one entry for a sphere).
    inv_density: Vec<Vec<f32>>,
    /// Rays the probes traced.
    pub probe_rays: u64,
    /// Per target shape, the pilot's yield c(T) (None where no pilot ran: one target, or too few
    /// photons stored to tell).
    pub yields: Option<Vec<f64>>,
}

impl Targets {
    /// Every shape that casts caustics (`Scene::casts_caustics`) is a target, or those of `only` (the
    /// planner's list); mesh triangles probed for what the lights see of them through `tracer`.
    pub fn new(scene: &Scene, tracer: &dyn Tracer, only: Option<&[u32]>) -> Targets {
        // The probes' rays, counted as traced (a probe whose light samples all face away traces none;
        // one past see-through surfaces traces several).
        let tracer = &CountingTracer { inner: tracer, rays: Default::default() };
        let mut shapes = Vec::new();
        for (i, s) in scene.shapes.iter().enumerate() {
            let excluded = only.is_some_and(|o| !o.contains(&(i as u32)));
            if !scene.casts_caustics(i as u32) || excluded || s.area() <= 0.0 {
                continue;
            }
            shapes.push(i as u32);
        }
        let probing = !scene.lights.is_empty();
        let triangles: usize = shapes
            .iter()
            .map(|&s| match &scene.shapes[s as usize].geometry {
                Geometry::Mesh(m) => m.indices.len(),
                Geometry::Sphere { .. } => 0,
            })
            .sum();
        let per_triangle = (AIM_PROBE_RAYS / triangles.max(1)).clamp(1, AIM_PROBES);
        // Per target shape, per element (triangle, or the whole sphere): (area, fraction seen).
        let elements: Vec<Vec<(f32, f32)>> = shapes
            .iter()
            .map(|&shape| match &scene.shapes[shape as usize].geometry {
                Geometry::Mesh(m) if probing => (0..m.indices.len())
                    .into_par_iter()
                    .map(|j| {
                        let [a, b, c] = m.triangle(j);
                        let seen = (0..per_triangle)
                            .filter(|&k| {
                                let [bu, bv] = sampling::uniform_triangle(hammersley(k, per_triangle));
                                let y = a * (1.0 - bu - bv) + b * bu + c * bv;
                                let mut rng = Rng::new(0xA1A1_5EED, shape as u64, (j * per_triangle + k) as u64);
                                Self::lit(scene, tracer, shape, y, &mut rng)
                            })
                            .count();
                        (m.area(j), seen as f32 / per_triangle as f32)
                    })
                    .collect(),
                Geometry::Mesh(m) => (0..m.indices.len()).map(|j| (m.area(j), 1.0)).collect(),
                Geometry::Sphere { center, radius, .. } => {
                    // A sphere is one element, probed at AIM_PROBES stratified points of its surface.
                    let seen = if probing {
                        (0..AIM_PROBES)
                            .into_par_iter()
                            .filter(|&k| {
                                let y = *center + sampling::uniform_sphere(hammersley(k, AIM_PROBES)) * *radius;
                                let mut rng = Rng::new(0xA1A1_5EED, shape as u64, k as u64);
                                Self::lit(scene, tracer, shape, y, &mut rng)
                            })
                            .count() as f32
                            / AIM_PROBES as f32
                    } else {
                        1.0
                    };
                    vec![(scene.shapes[shape as usize].area(), seen)]
                }
            })
            .collect();
        let probe_rays = tracer.rays.load(std::sync::atomic::Ordering::Relaxed);
        let by_sight = Targets::weighed(scene, shapes.clone(), &elements, None, probe_rays);
        // With more than one target, a pilot of aimed photons measures each one's yield: what share of
        // the photons aimed at it a caustic pass stores (its photons may also miss it, be scattered
        // by a plastic's base, which a caustic pass does not keep, or leave the scene).
        if by_sight.shapes.len() < 2 || !probing {
            return by_sight;
        }
        let Some(yields) = by_sight.pilot_yields(scene, tracer) else {
            return by_sight;
        };
        let probe_rays = tracer.rays.load(std::sync::atomic::Ordering::Relaxed);
        Targets::weighed(scene, shapes, &elements, Some(&yields), probe_rays)
    }

    /// The targets `shapes` with their elements' (area, fraction seen) and, if measured, each shape's
    /// yield c(T) (else 1): the density of `Targets`.
    fn weighed(
        scene: &Scene,
        shapes: Vec<u32>,
        elements: &[Vec<(f32, f32)>],
        yields: Option<&[f64]>,
        probe_rays: u64,
    ) -> Targets {
        let c = |i: usize| yields.map_or(1.0, |y| y[i]);
        let area: f64 = elements.iter().flatten().map(|e| e.0 as f64).sum();
        let seen: f64 = (elements.iter().enumerate())
            .map(|(i, els)| c(i) * els.iter().map(|e| e.0 as f64 * e.1 as f64).sum::<f64>())
            .sum();
        let a = if seen > 0.0 { AIM_BY_AREA as f64 } else { 1.0 };
        let density = |cv: f64| (1.0 - a) * cv / seen.max(f64::MIN_POSITIVE) + a / area;
        let mut t = Targets { shapes, probe_rays, yields: yields.map(<[f64]>::to_vec), ..Targets::none() };
        let mut total = 0.0f64;
        for (i, els) in elements.iter().enumerate() {
            let shares: Vec<f32> = els.iter().map(|&(ar, v)| (ar as f64 * density(c(i) * v as f64)) as f32).collect();
            total += shares.iter().map(|&x| x as f64).sum::<f64>();
            t.cdf.push(total as f32);
            t.tri_pick.push(match scene.shapes[t.shapes[i] as usize].geometry {
                Geometry::Mesh(_) => sampling::AliasTable::new(&shares),
                Geometry::Sphere { .. } => Default::default(),
            });
            t.inv_density.push(els.iter().map(|&(_, v)| (1.0 / density(c(i) * v as f64)) as f32).collect());
        }
        t
    }

    /// Per target shape, the share of the photons aimed at it that a caustic pass stores, from
    /// `AIM_PILOT` photons aimed as `self` aims them (their rays counted by `tracer`; the photons are
    /// not kept), each shape's count pulled towards the mean by `AIM_PILOT_PRIOR` shots' worth. None
    /// when too few are stored to tell (no surface holds caustic photons: the pass is traced for its
    /// glossy caustics alone).
    fn pilot_yields(&self, scene: &Scene, tracer: &dyn Tracer) -> Option<Vec<f64>> {
        let s = PassSettings {
            want: [0, 0, 1, 0],
            max_depth: scene.render.max_depth,
            rr_depth: scene.render.rr_depth,
            max_shots: AIM_PILOT,
            seed: 0xA1A1_5EED,
            pass: u64::MAX,
            glossy_splats: false,
        };
        let n = self.shapes.len();
        let batches = AIM_PILOT.div_ceil(BATCH);
        let counts: Vec<(Vec<u64>, Vec<u64>)> = (0..batches)
            .into_par_iter()
            .map(|b| {
                let (mut shots, mut stored) = (vec![0u64; n], vec![0u64; n]);
                let mut out: [Vec<Stored>; 4] = Default::default();
                let (mut splats, mut segs, mut camera_rays) = (Vec::new(), 0u64, 0u64);
                for i in b * BATCH..((b + 1) * BATCH).min(AIM_PILOT) {
                    let mut rng = Rng::new(s.seed, s.pass, i);
                    let Some(l) = launch_targeted(scene, self, &mut rng) else {
                        continue;
                    };
                    let Some(k) = l.aim.and_then(|(shape, _)| self.shapes.iter().position(|&t| t == shape)) else {
                        continue;
                    };
                    let before = out[CAUSTIC].len();
                    trace_one(scene, tracer, l, &mut rng, &s, &mut out, &mut splats, &mut segs, &mut camera_rays);
                    shots[k] += 1;
                    stored[k] += (out[CAUSTIC].len() - before) as u64;
                    out[CAUSTIC].clear();
                }
                (shots, stored)
            })
            .collect();
        let shots: Vec<f64> = (0..n).map(|k| counts.iter().map(|c| c.0[k] as f64).sum()).collect();
        let stored: Vec<f64> = (0..n).map(|k| counts.iter().map(|c| c.1[k] as f64).sum()).collect();
        let total = stored.iter().sum::<f64>();
        if total < AIM_PILOT_MIN_STORED {
            return None;
        }
        let mean = total / shots.iter().sum::<f64>();
        Some((0..n).map(|k| (stored[k] + AIM_PILOT_PRIOR * mean) / (shots[k] + AIM_PILOT_PRIOR)).collect())
    }

    /// Whether a photon aimed at point `y` of target `shape` from a light point drawn as direct lighting
    /// draws it from `y` (by power; the first of `AIM_LIGHT_TRIES` that faces `y`) gets there first: the
    /// test `trace_one` applies to every aimed photon.
    fn lit(scene: &Scene, tracer: &dyn Tracer, shape: u32, y: Vec3, rng: &mut Rng) -> bool {
        for _ in 0..AIM_LIGHT_TRIES {
            let Some(ls) = scene.lights.sample(scene, y, rng.next_f32(), rng.next_2d(), false) else {
                continue;
            };
            let d = y - ls.p;
            let dist = d.length();
            if dist.is_nan() || dist <= 0.0 {
                return false;
            }
            // Past see-through surfaces that cast no caustic, as `trace_one` lets aimed photons pass them
            // (a target casts caustics: the walk stops there).
            let passes = |s: u32| scene.is_see_through(s) && !scene.casts_caustics(s);
            let first = crate::accel::first_hit_past(scene, tracer, Ray::new(ls.p, d / dist), passes);
            return first.is_some_and(|(h, r)| h.shape == shape && (r.o - ls.p).length() + h.t >= dist * (1.0 - 1e-3));
        }
        false
    }

    /// No targets (emission is not aimed).
    pub fn none() -> Targets {
        Targets {
            shapes: Vec::new(),
            cdf: Vec::new(),
            tri_pick: Vec::new(),
            inv_density: Vec::new(),
            probe_rays: 0,
            yields: None,
        }
    }

    /// Each target shape with its share of the aimed shots.
    pub fn shares(&self) -> Vec<(u32, f64)> {
        let total = self.cdf.last().copied().unwrap_or(0.0) as f64;
        let mut before = 0.0f64;
        (self.shapes.iter().zip(&self.cdf))
            .map(|(&shape, &c)| {
                let share = (c as f64 - before) / total.max(f64::MIN_POSITIVE);
                before = c as f64;
                (shape, share)
            })
            .collect()
    }

    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// A target point for light from `from`: (shape, position, unit normal, 1 / its density over the
    /// targets' area). A sphere (unless see-through) is drawn where `from` sees it, by solid angle from
    /// a light point (uniform in the cone it subtends, the first hit of that direction) or by projected
    /// area across a direction from infinity: light reaches no other point of it first, so this density
    /// covers all the sphere's points that light can reach first, and no shot is aimed at its far side
    /// (uniform on the sphere, a point light 4 radii away had three shots in five land there and dropped).
    /// The shape is chosen by its share either way.
    fn sample(
        &self,
        scene: &Scene,
        from: AimFrom,
        u_sel: f32,
        (bits, coin): (u32, f32),
        u: [f32; 2],
    ) -> (u32, Vec3, Vec3, f32) {
        let (i, p_shape) = sampling::sample_cdf(&self.cdf, u_sel);
        let shape = self.shapes[i];
        let geometry = &scene.shapes[shape as usize].geometry;
        if let Geometry::Sphere { center, radius, .. } = *geometry {
            if !scene.is_see_through(shape) {
                if let Some((y, n, p_in)) = sphere_seen_from(center, radius, from, u) {
                    let inv_p = if p_in > 0.0 && p_shape > 0.0 { 1.0 / (p_shape * p_in) } else { 0.0 };
                    return (shape, y, n, inv_p);
                }
            }
        }
        let prim = match geometry {
            Geometry::Mesh(_) => self.tri_pick[i].sample(bits, coin),
            Geometry::Sphere { .. } => 0,
        };
        let sp = geometry.point(prim, u);
        (shape, sp.p, sp.n, self.inv_density[i][prim])
    }
}

/// Where an aimed photon's light comes from: a point (on a light), or a direction of travel (from a light
/// at infinity).
#[derive(Clone, Copy)]
enum AimFrom {
    Point(Vec3),
    Direction(Vec3),
}

/// A point of the sphere (`center`, `radius`) that light from `from` reaches first, drawn from `u`: its
/// position, outward normal and density over the sphere's area. From a point, uniform in the cone of
/// directions the sphere subtends (density cos θy / (d² · the cone's solid angle)); from a direction,
/// uniform over the sphere's disc across it (density |n·ω| / πr²). None from a point on or in the
/// sphere (then it is drawn uniformly).
fn sphere_seen_from(center: Vec3, radius: f32, from: AimFrom, u: [f32; 2]) -> Option<(Vec3, Vec3, f32)> {
    let (o, w) = match from {
        AimFrom::Point(x) => {
            let (w, one_minus) = crate::scene::light::towards_sphere(x, center, radius, u)?;
            let t = crate::scene::light::near_side(x, w, center, radius);
            let y = x + w * t;
            let n = ((y - center) / radius).normalize_or_zero();
            let p = n.dot(w).abs() / (t * t * 2.0 * std::f32::consts::PI * one_minus);
            return Some((y, n, p));
        }
        AimFrom::Direction(w) => {
            let [dx, dy] = sampling::concentric_disk(u);
            let f = crate::math::Frame::from_normal(w);
            (center + f.to_world(Vec3::new(dx, dy, 0.0)) * radius - w * (2.0 * radius), w)
        }
    };
    let t = crate::math::sphere_root(o.to_array(), w.to_array(), center.to_array(), radius, 0.0, f32::INFINITY)
        .unwrap_or(2.0 * radius);
    let y = o + w * t;
    let n = ((y - center) / radius).normalize_or_zero();
    Some((y, n, n.dot(w).abs() / (std::f32::consts::PI * radius * radius)))
}

/// A tracer that counts the rays it is asked to trace.
struct CountingTracer<'a> {
    inner: &'a dyn Tracer,
    rays: std::sync::atomic::AtomicU64,
}

impl Tracer for CountingTracer<'_> {
    fn intersect(&self, ray: &Ray) -> Option<crate::accel::Hit> {
        self.rays.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.rays.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.occluded(ray)
    }
}

/// Settings of one tracing pass.
pub struct PassSettings {
    /// Requested stored photons per map (0 = map not built in this pass): direct, indirect, caustic,
    /// and (`GLOSSY`) the photons of delta lights on glossy lobes, past a mirror or glass first (the
    /// photons the glossy splats are made from, kept for camera chains that reach a glossy surface
    /// through a mirror or glass: `integrator::GlossyGather`). The glossy count never keeps a pass
    /// going: it stops collecting at its count, or when the other maps are done.
    pub want: [u64; 4],
    /// Scattering events a photon path may have, counting the one at the gather point (render.max_depth).
    pub max_depth: u32,
    /// Specular bounces past which Russian roulette applies (render.rr_depth).
    pub rr_depth: u32,
    /// Give up after this many photons shot.
    pub max_shots: u64,
    pub seed: u64,
    /// Distinguishes the random streams of different passes.
    pub pass: u64,
    /// Light-trace the caustics of point, spot and distant lights on glossy surfaces to the camera
    /// (the caustic pass): a photon from such a light whose first bounce was a mirror or glass, with no
    /// diffuse bounce since, that meets a glossy lobe no photon is stored for (rough metal, rough glass,
    /// a principled surface, a rough plastic's coat) is splatted onto the film from there. Nothing else
    /// finds that light where the camera sees the glossy surface directly: a camera chain through
    /// glossy lobes takes a light sample at each (light that came straight from the light to one of
    /// them), its BSDF samples never reach a point light, and the glossy photons (`want[GLOSSY]`) are
    /// read only where the camera sees the surface past a mirror or glass.
    pub glossy_splats: bool,
}

/// One photon's flight: where it starts, with what power, and (targeted emission) which surface it was
/// aimed at, at what distance; if it hits anything else first it is dropped.
struct Launch {
    ray: Ray,
    phi: Rgb,
    aim: Option<(u32, f32)>,
    /// From a point, spot or distant light (a delta light: no camera path's BSDF sample finds it).
    delta: bool,
    /// The light it left (index in `Lights::list`).
    light: usize,
}

#[allow(clippy::too_many_arguments)]
fn trace_one(
    scene: &Scene,
    tracer: &dyn Tracer,
    l: Launch,
    rng: &mut Rng,
    s: &PassSettings,
    out: &mut [Vec<Stored>; 4],
    splats: &mut Vec<(u32, Rgb)>,
    segs: &mut u64,
    camera_rays: &mut u64,
) {
    let (mut ray, mut phi) = (l.ray, l.phi);
    let phi_launch = max_component(l.phi);
    let mut diffuse_bounces = 0u32;
    let mut specular_bounces = 0u32;
    // From a delta light, first bounced by a delta lobe (mirror, glass, a smooth coat), and no diffuse
    // bounce since: light no camera chain finds (`PassSettings::glossy_splats`).
    let mut delta_first = l.delta;
    // An aimed photon must arrive at its target (shape, distance left) first, see-through surfaces
    // whose pick lets it by apart.
    let mut aim = l.aim;
    let mut crossings = 0u32;
    // Absorption of the medium the photon flies through (`Scene::sigma_next`), from the light's own
    // (`Scene::light_medium`); None where that is the first segment's end's to say
    // (`Scene::absorbed_on_light_path`).
    let mut sigma = scene.light_medium(l.light);
    // Hit `depth` follows `depth` scattering events; gathering there adds one more.
    for depth in 0..s.max_depth {
        let (si, wo, mat) = loop {
            *segs += 1;
            let Some(hit) = tracer.intersect(&ray) else {
                return;
            };
            let on_target = match aim {
                Some((shape, dist)) if hit.shape == shape && hit.t >= dist * (1.0 - 1e-3) => {
                    aim = None;
                    true
                }
                _ => false,
            };
            // Aimed photons count the light whose first interaction is at a target point: one that meets
            // a surface before its point is dropped, unless the surface lets it straight through and
            // casts no caustic (a null surface, a mask's holes over a diffuse or black surface). A
            // target crossed on the way (its near side, another thin pane) is the first interaction of
            // the photons aimed at it, which already count the light that goes on from there.
            if aim.is_some() && !on_target && (!scene.is_see_through(hit.shape) || scene.casts_caustics(hit.shape)) {
                return;
            }
            let si = scene.surface(&ray, hit.shape, hit.prim, hit.u, hit.v, hit.t);
            phi *= scene.absorbed_on_light_path(sigma, &ray, &si, hit.t);
            let wo = -ray.d.normalize();
            let picked = scene.bsdf(&si, wo, || rng.next_f32());
            // A see-through surface that lets the photon straight through: no scattering event, not a
            // bounce. Where the surface can also hold photons (a mask's opaque part) the photon is stored
            // there first, as a blend's photons are whatever the photon's own pick (below).
            let t = match scene.crossing(&si, wo, picked, || rng.next_f32()) {
                crate::scene::Crossing::Through(t) => t,
                crate::scene::Crossing::At(mat) => {
                    if aim.is_some() && !on_target {
                        return;
                    }
                    break (si, wo, mat);
                }
            };
            if scene.blend_offers(&si, wo, |m| m.holds_photons()) {
                store(s, out, &si, wo, phi, depth, diffuse_bounces, specular_bounces);
            }
            phi *= t;
            crossings += 1;
            if phi == Rgb::ZERO || crossings > crate::accel::MAX_CROSSINGS {
                return;
            }
            if let Some((_, dist)) = &mut aim {
                *dist -= hit.t * ray.d.length();
            }
            ray = si.spawn(ray.d);
        };
        // The medium the photon arrived in (on the light's first segment the one its end's side says).
        let arrived = sigma.unwrap_or_else(|| scene.sigma_leaving(&si, wo));
        let last = depth + 1 >= s.max_depth;
        if delta_first && specular_bounces > 0 {
            let glossy = mat.unheld_glossy_lobe();
            // Kept whatever this photon's own pick at a blend: the gather weighs the camera's.
            if s.want[GLOSSY] > 0
                && (glossy.is_some() || scene.blend_offers(&si, wo, |m| m.unheld_glossy_lobe().is_some()))
            {
                out[GLOSSY].push(record(&si, wo, phi, depth));
            }
            if let Some(lobe) = glossy.filter(|_| s.glossy_splats) {
                let lens = scene.camera.sample_lens(rng);
                let mut c = crate::integrator::Counters::default();
                let add = |pixel, val| splats.push((pixel, val));
                crate::integrator::link_to_camera(
                    scene,
                    tracer,
                    &si,
                    wo,
                    &lobe,
                    phi,
                    lens,
                    1.0,
                    &mut c,
                    |_, _| 1.0,
                    add,
                );
                *camera_rays += c.rays;
            }
        }
        // Stored where the surface can hold photons, also where a blend picked a mirror or glass for
        // this photon's next bounce.
        if mat.holds_photons() || scene.blend_offers(&si, wo, |m| m.holds_photons()) {
            store(s, out, &si, wo, phi, depth, diffuse_bounces, specular_bounces);
        }
        if last {
            return;
        }
        if mat.is_diffuse() {
            // Nothing this pass wants can follow (a caustic-only pass stops at the first diffuse hit).
            if s.want[INDIRECT] == 0 {
                return;
            }
            let p = max_component(mat.albedo());
            if p <= 0.0 || rng.next_f32() >= p {
                return;
            }
            let Some((bs, next)) = si.scatter(&mat, wo, rng, TransportMode::Importance) else {
                return;
            };
            phi *= bs.weight / p;
            diffuse_bounces += 1;
            delta_first = false;
            sigma = Some(scene.sigma_next(&si, next.d, arrived));
            ray = next;
            continue;
        }
        // A rough plastic: its glossy coat (a specular bounce) or its base (a diffuse one), each chosen
        // by its share and weighed by 1 / that share.
        let (mat, lobe_p) = match mat.coat_lobe() {
            Some(coat) => {
                let share = mat.coat_share(wo, si.ns);
                if rng.next_f32() < share {
                    (coat, share)
                } else {
                    (mat.base_only(), 1.0 - share)
                }
            }
            None => (mat, 1.0),
        };
        let Some((mut bs, next)) = si.scatter(&mat, wo, rng, TransportMode::Importance) else {
            return;
        };
        bs.weight /= lobe_p;
        if !bs.delta && mat.holds_photons() {
            // A plastic's base: a diffuse bounce, with Russian roulette on the sample's weight.
            if s.want[INDIRECT] == 0 {
                return;
            }
            let q = max_component(bs.weight).min(1.0);
            if q <= 0.0 || rng.next_f32() >= q {
                return;
            }
            phi *= bs.weight / q;
            diffuse_bounces += 1;
            delta_first = false;
            sigma = Some(scene.sigma_next(&si, next.d, arrived));
            ray = next;
            continue;
        }
        phi *= bs.weight;
        specular_bounces += 1;
        if specular_bounces == 1 {
            delta_first &= bs.delta;
        }
        if specular_bounces >= s.rr_depth {
            let Some(q) = sampling::russian_roulette(max_component(phi) / phi_launch, rng.next_f32()) else {
                return;
            };
            phi /= q;
        }
        sigma = Some(scene.sigma_next(&si, next.d, arrived));
        ray = next;
    }
}

/// Stores a photon of power `phi` arriving at `si` (from `wo`) after `depth` scattering events, in the
/// map its bounces so far say (indirect after a diffuse one, caustic after specular ones only, else
/// direct), if the pass wants that map.
#[allow(clippy::too_many_arguments)]
fn store(
    s: &PassSettings,
    out: &mut [Vec<Stored>; 4],
    si: &crate::scene::SurfaceHit,
    wo: Vec3,
    phi: Rgb,
    depth: u32,
    diffuse_bounces: u32,
    specular_bounces: u32,
) {
    let map = if diffuse_bounces > 0 {
        INDIRECT
    } else if specular_bounces > 0 {
        CAUSTIC
    } else {
        DIRECT
    };
    if s.want[map] > 0 {
        out[map].push(record(si, wo, phi, depth));
    }
}

/// A photon of power `phi` arriving at `si` from `wo` after `depth` scattering events, as stored. The
/// position records the path's scattering events, the gather's included (`with_events`), so that a
/// gather seen through glass can leave out paths the path tracer's depth would cut.
fn record(si: &crate::scene::SurfaceHit, wo: Vec3, phi: Rgb, depth: u32) -> Stored {
    let p = with_events(si.p.to_array(), depth + 1);
    (p, Photon { p: si.p, wi: -wo, phi, n: face_forward(si.ng, wo) }.payload())
}

/// Uniform emission from the lights (power-weighted choice, then position and direction on the light).
fn launch_uniform(scene: &Scene, rng: &mut Rng) -> Option<Launch> {
    let e = scene
        .lights
        .emit(scene, rng.next_f32(), rng.next_2d(), rng.next_2d())
        .filter(|e| scene.lights.leaves(scene, e))?;
    Some(Launch { ray: e.ray, phi: e.phi, aim: None, delta: scene.lights.list[e.light].is_delta(), light: e.light })
}

/// Emission aimed at a point drawn on the specular targets (by `Targets`' density). The power is the
/// flux that reaches that surface element, L·cosθx·cosθy/d² (I·cosθy/d² for point lights, times the
/// falloff towards it for a spot), divided by
/// the densities of the light choice, the light point and the target point, so the caustic estimate
/// has the same expectation as with uniform emission.
fn launch_targeted(scene: &Scene, targets: &Targets, rng: &mut Rng) -> Option<Launch> {
    let lights = &scene.lights;
    let (li, p_sel) = sampling::sample_cdf(&lights.cdf, rng.next_f32());
    if lights.list[li].at_infinity() {
        let s = lights.sample_infinite(li, rng.next_2d())?;
        // From infinity (environment or distant light): a direction ω by its distribution, the target
        // point y by area; the flux reaching y's surface element from ω is L(ω)|n·ω| dω dA (E|n·ω| dA).
        let (u_sel, u_tri, u) = (rng.next_f32(), (rng.next_u32(), rng.next_f32()), rng.next_2d());
        let (shape, y, ny, inv_p) = targets.sample(scene, AimFrom::Direction(-s.wi), u_sel, u_tri, u);
        let far = lights.beyond_scene(y);
        let phi = s.li * (ny.dot(s.wi).abs() * inv_p / (s.pdf * p_sel));
        let delta = lights.list[li].is_delta();
        return Some(Launch { ray: Ray::new(y + s.wi * far, -s.wi), phi, aim: Some((shape, far)), delta, light: li });
    }
    let lp = lights.sample_point(scene, li, rng.next_2d())?;
    let (u_sel, u_tri, u) = (rng.next_f32(), (rng.next_u32(), rng.next_f32()), rng.next_2d());
    let (shape, y, ny, inv_p) = targets.sample(scene, AimFrom::Point(lp.p), u_sel, u_tri, u);
    let d = y - lp.p;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 {
        return None;
    }
    let dist = dist2.sqrt();
    let w = d / dist;
    // A surface emits in front of its face (and behind it, for a mesh that `Shape::emits_behind`).
    if !lights.emits(scene, li, lp.p, lp.n, w) {
        return None;
    }
    let cos_x = if lp.n == Vec3::ZERO { 1.0 } else { lp.n.dot(w).abs() };
    let cos_y = ny.dot(w).abs();
    let falloff = lights.falloff(li, w);
    if falloff <= 0.0 {
        return None;
    }
    let phi = lp.le * lights.tint(li, w) * (falloff * cos_x * cos_y / dist2 * inv_p / (lp.pdf_area * p_sel));
    let o = if lp.n == Vec3::ZERO { lp.p } else { offset_ray_origin(lp.p, lp.n, w, lp.size) };
    let travelled = (o - lp.p).length();
    let delta = lights.list[li].is_delta();
    Some(Launch { ray: Ray::new(o, w), phi, aim: Some((shape, dist - travelled)), delta, light: li })
}

/// What a batch of photons left: each map's photons, the glossy caustics' splats, where the batch
/// ended, and its rays (photon segments, links to the camera).
type BatchOut = ([Vec<Stored>; 4], Vec<(u32, Rgb)>, u64, [u64; 2]);

/// Runs one pass until every wanted map (of the first three) has its photons or `max_shots` photons
/// were shot.
pub fn run_pass(
    scene: &Scene,
    tracer: &dyn Tracer,
    s: &PassSettings,
    targets: Option<&Targets>,
    progress: &indicatif::ProgressBar,
) -> ([MapPhotons; 4], PassStats) {
    let t0 = std::time::Instant::now();
    let mut maps: [MapPhotons; 4] = Default::default();
    // A map asked for a count gets its whole vector up front (the want, plus one round of batches of
    // overshoot): untouched capacity costs no memory, and no doubling ever copies the photons or
    // leaves spare capacity resident. Progressive passes (no count, a shot budget) just grow.
    let round = rayon::current_num_threads() as u64 * 4 * BATCH * 4;
    for (m, &w) in maps.iter_mut().zip(&s.want) {
        if w > 0 && w < (1 << 34) {
            m.photons = Vec::with_capacity((w + round) as usize);
        }
    }
    let mut done = s.want.map(|w| w == 0);
    // The glossy photons never keep the pass going.
    let going = |done: &[bool; 4]| done[..GLOSSY].iter().any(|d| !d);
    let mut stats = PassStats::default();
    let threads = rayon::current_num_threads() as u64;
    let mut next = 0u64;
    while going(&done) && next < s.max_shots {
        let batches = (threads * 4).max(1);
        let results: Vec<BatchOut> = (0..batches)
            .into_par_iter()
            .map(|b| {
                let start = (next + b * BATCH).min(s.max_shots);
                let end = (start + BATCH).min(s.max_shots);
                let mut out: [Vec<Stored>; 4] = Default::default();
                let mut splats = Vec::new();
                let (mut segs, mut camera_rays) = (0u64, 0u64);
                for i in start..end {
                    let mut rng = Rng::new(s.seed, s.pass, i);
                    let launch = match targets {
                        Some(t) => launch_targeted(scene, t, &mut rng),
                        None => launch_uniform(scene, &mut rng),
                    };
                    if let Some(l) = launch {
                        trace_one(scene, tracer, l, &mut rng, s, &mut out, &mut splats, &mut segs, &mut camera_rays);
                    }
                }
                (out, splats, end, [segs, camera_rays])
            })
            .collect();
        // Every batch was traced, also those past the point where the maps filled up (their photons
        // are dropped so that the maps do not depend on the thread count): all their rays count.
        stats.segments += results.iter().map(|r| r.3[0]).sum::<u64>();
        stats.camera_rays += results.iter().map(|r| r.3[1]).sum::<u64>();
        for (out, splats, end, _) in results {
            if end <= next {
                continue;
            }
            // The splats belong to the caustic map's shots (the only pass that makes them).
            if !done[CAUSTIC] && !splats.is_empty() {
                let sum = &mut maps[CAUSTIC].splats;
                if sum.is_empty() {
                    *sum = vec![[0.0; 3]; (scene.camera.width * scene.camera.height) as usize];
                }
                for (px, v) in splats {
                    for k in 0..3 {
                        sum[px as usize][k] += v[k] as f64;
                    }
                }
            }
            for (m, photons) in out.into_iter().enumerate() {
                if done[m] {
                    continue;
                }
                maps[m].photons.extend_from_slice(&photons);
                maps[m].n_emitted = end;
                if maps[m].photons.len() as u64 >= s.want[m] {
                    done[m] = true;
                    maps[m].complete = true;
                }
            }
            next = end;
            if !going(&done) {
                break;
            }
        }
        // Each map counts up to what it wants, so the bar reaches 100% exactly when the pass is done.
        // (A pass that shoots a count instead, every map unbounded, counts its shots.)
        let counted = maps[..GLOSSY].iter().zip(s.want);
        let stored: u64 = counted.map(|(m, w)| (m.photons.len() as u64).min(w)).sum();
        let shooting = s.want[..GLOSSY].iter().all(|&w| w == 0 || w == u64::MAX);
        progress.set_position(if shooting { next } else { stored }.min(progress.length().unwrap_or(u64::MAX)));
    }
    stats.shot = next;
    stats.budget_exhausted = going(&done);
    stats.seconds = t0.elapsed().as_secs_f64();
    (maps, stats)
}
