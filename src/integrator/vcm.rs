//! Bidirectional path tracing and vertex connection and merging (Georgiev, Křivánek, Davidovič &
//! Slusallek 2012), with the recursive MIS quantities of Georgiev's "Implementing Vertex Connection and
//! Merging" (dVCM, dVC, dVM carried along each subpath).
//!
//! One iteration i traces one light subpath per pixel (the photon tracer's emission, `Lights::emit`),
//! connects each of its non-delta vertices to the camera (light tracing, splatted onto the film),
//! stores them in the project's k-d tree, then traces one camera subpath per pixel that, at every
//! non-delta vertex, takes a light sample (s = 1), connects to every vertex of "its" light subpath
//! (s ≥ 2) and merges with the stored light vertices within r_i = r_1 · i^((α−1)/2) (vertex merging;
//! r_1 varies over the scene with the light's density, `RadiusField`, and aimed emission, `Aim`); at its
//! first hit with the light vertices `render.vcm.merge_primary` names (`Primary`); emission found by
//! the camera subpath (s = 0) is weighted as well. Without merging this is BDPT;
//! without connections a progressive photon mapper (merging at every camera vertex).
//!
//! MIS pdfs use geometric normals for the area ↔ solid-angle conversions (true densities), Russian
//! roulette is left out of them (every strategy ignores it alike, so the weights still sum to one).
//! An iteration is a pure function of (scene, seed, i): iterations can be averaged in any grouping,
//! and light-tracing splats are summed in a fixed order (per chunk of light paths, chunks in order),
//! so images are the same bits on any thread count.
use super::direct::{sample_light, shadow};
use super::edges::holds_light_vertices;
use super::photon_map::edge_factor;
use super::{Counters, LineOfSight};
use crate::accel::{interact, Interaction, Tracer};
use crate::color::Rgb;
use crate::film::Image;
use crate::math::sampling::russian_roulette;
use crate::math::sampling::uniform_sphere;
use crate::math::{max_component, offset_ray_origin, Ray, Rng};
use crate::photon::estimate::{in_disc_slab, DISC_FACING};
use crate::photon::kdtree::{KdTree, KnnResult};
use crate::scene::file::MergePrimary as Primary;
use crate::scene::light::{towards_sphere, visible_cone, EmittedRay, Lights};
use crate::scene::Geometry;
use crate::scene::{Material, Scene, SurfaceHit, TransportMode};
use glam::Vec3;
use rayon::prelude::*;
use std::cell::RefCell;
use std::f32::consts::PI;

/// Light subpaths per parallel work item (fixed, so splats are summed in the same order on any thread
/// count).
const CHUNK: usize = 512;

thread_local! {
    static SCRATCH: RefCell<KnnResult> = RefCell::new(KnnResult::new());
}

/// What an iteration does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VcmOptions {
    /// Vertex connection: light sampling, connections between subpaths, light tracing.
    pub connect: bool,
    /// Vertex merging with the light vertices of the iteration.
    pub merge: bool,
    /// Light subpaths per iteration (raised to one per pixel: each camera subpath connects to its own).
    pub light_paths: usize,
    /// Debugging and tests: only the (s, t) strategy (s light vertices, t camera vertices, the camera
    /// itself counted) contributes, with weight 1.
    pub strategy: Option<(u32, u32)>,
}

impl VcmOptions {
    pub fn bdpt() -> VcmOptions {
        VcmOptions { connect: true, merge: false, light_paths: 0, strategy: None }
    }
    pub fn vcm() -> VcmOptions {
        VcmOptions { connect: true, merge: true, light_paths: 0, strategy: None }
    }
    /// The scene's `render.vcm` settings (`merge` forced off for `bdpt`).
    pub fn of_scene(scene: &Scene) -> VcmOptions {
        let v = &scene.render.vcm;
        let bdpt = scene.render.mode == crate::scene::file::Mode::Bdpt;
        VcmOptions {
            connect: v.connect || bdpt,
            merge: v.merge && !bdpt,
            light_paths: v.light_paths as usize,
            strategy: None,
        }
    }
}

/// The MIS state of a subpath at its current end.
#[derive(Clone, Copy, Debug)]
struct SubPath {
    beta: Rgb,
    /// Edges from the subpath's origin to its current end.
    len: u32,
    /// Every scattering so far was a delta BSDF.
    specular: bool,
    /// The last scattering was a delta BSDF (false at the first hit).
    after_delta: bool,
    d_vcm: f32,
    d_vc: f32,
    /// dVM times η of the vertex merged at (η varies over the scene with the merge radius): divided
    /// by the merge vertex's η when merging.
    s_vm: f32,
    /// Product of the refractions' 1/η² (camera subpaths), divided out for Russian roulette.
    radiance_scale: f32,
    /// Camera subpaths that merge at their first hit only with light that came through a delta BSDF:
    /// that strategy's share of dVC and dVM (both alike) since the first hit, held back until the second
    /// vertex shows whether the path could be merged there (it goes in if that vertex is a delta BSDF).
    held_vm: f32,
}

/// A stored light vertex (never on a delta BSDF).
#[derive(Clone, Copy, Debug)]
struct LightVertex {
    si: SurfaceHit,
    /// Unit direction back along the light subpath (where the light came from).
    wo: Vec3,
    mat: Material,
    beta: Rgb,
    len: u32,
    d_vcm: f32,
    d_vc: f32,
    s_vm: f32,
    /// The merge strategy's weight at this vertex in a MIS sum: η here, 0 without merging.
    vm: f32,
    /// The light arrived through a delta BSDF (a caustic): merged at a camera's first hit by `Caustics`.
    after_delta: bool,
    /// The absorption of the medium the light arrived in (`Scene::sigma_next`).
    sigma: Rgb,
}

impl LightVertex {
    /// The adjoint BSDF at the vertex scattering the arriving light towards `dir`, times |cos θ| there
    /// (Veach's shading-normal correction included).
    fn f_to(&self, dir: Vec3) -> Rgb {
        self.si.scatter_light(&self.mat, self.wo, dir)
    }
}

/// What merging reads of a light vertex, stored in the k-d tree in tree order (spatially coherent, a
/// fraction of a `LightVertex`'s size).
#[derive(Clone, Copy, Debug, Default)]
struct MergeVertex {
    wo: Vec3,
    /// The geometric normal where the light landed: a merge reads only the surface it is on.
    ng: Vec3,
    beta: Rgb,
    len: u32,
    d_vcm: f32,
    s_vm: f32,
}

/// Constants of one iteration.
struct Iteration<'a> {
    max_len: u32,
    n_paths: f32,
    /// 1 when connecting (the connection strategies' share of the MIS sums), else 0.
    vc: f32,
    merge: bool,
    /// What the camera subpath merges with at its first hit (`render.vcm.merge_primary`; everything
    /// without connections, nothing without merging).
    primary: Primary,
    /// The first iteration's merge radius over the scene, scaled by `shrink` for this iteration.
    radius: &'a RadiusField,
    shrink: f32,
    opts: VcmOptions,
}

impl<'a> Iteration<'a> {
    /// An iteration of `opts` with merge radius `radius` × `shrink`.
    fn new(scene: &Scene, opts: VcmOptions, radius: &'a RadiusField, shrink: f32) -> Iteration<'a> {
        Iteration {
            max_len: scene.render.max_depth.saturating_add(1),
            n_paths: light_paths(scene, opts) as f32,
            vc: if opts.connect { 1.0 } else { 0.0 },
            merge: opts.merge,
            primary: if !opts.merge {
                Primary::None
            } else if !opts.connect {
                Primary::All
            } else {
                scene.render.vcm.merge_primary
            },
            radius,
            shrink,
            opts,
        }
    }

    /// This iteration's merge radius at `p`.
    fn r(&self, p: Vec3) -> f32 {
        (self.radius.at(p) * self.shrink).max(1e-7)
    }

    /// η at `p`: merging's density over a connection's, π r(p)² times the light subpaths.
    fn eta(&self, p: Vec3) -> f32 {
        let r = self.r(p);
        PI * r * r * self.n_paths
    }

    /// The merge strategy at `p` in a MIS sum (η there; 0 without merging).
    fn vm_at(&self, p: Vec3) -> f32 {
        if self.merge {
            self.eta(p)
        } else {
            0.0
        }
    }

    /// The merge strategy at a light vertex that is the camera's first hit (light tracing's MIS sum).
    fn vm_as_first_hit(&self, lv: &LightVertex) -> f32 {
        match self.primary {
            Primary::All => lv.vm,
            Primary::Caustics if lv.after_delta => lv.vm,
            _ => 0.0,
        }
    }

    /// Whether strategy (s, t) contributes, and its weight given the MIS weight `w` of the full
    /// estimator.
    fn weight(&self, s: u32, t: u32, w: impl FnOnce() -> f32) -> f32 {
        match self.opts.strategy {
            Some(st) => (st == (s, t)) as u32 as f32,
            None => w(),
        }
    }
}

/// The merge radius of iteration `i` (1-based): r_1 · i^((α−1)/2).
pub fn radius_at(r1: f32, alpha: f32, i: u32) -> f32 {
    r1 * (i.max(1) as f32).powf(0.5 * (alpha - 1.0))
}

/// The first iteration's merge radius: `render.progressive.radius` if set, else the radius of a disc
/// that would hold about 4 light vertices if one iteration's light subpaths spread evenly over the
/// surfaces light vertices are kept on (every one that is not a delta BSDF: rough metal and glass
/// too, not only those that hold photons), capped at `render.gather.max_radius` of the diagonal.
pub fn initial_radius(scene: &Scene) -> f32 {
    let p = &scene.render.progressive;
    if p.radius > 0.0 {
        return p.radius;
    }
    let paths = light_paths(scene, VcmOptions::of_scene(scene)) as f64;
    super::ppm::radius_for_density(scene, 4.0, paths, |m| scene.material_keeps_light_vertices(m))
}

/// Light subpaths aimed at the specular shapes (the planner's caustic targets), where the lights' own
/// emission seldom reaches them (a point light far from a small mirror). From a point on a light at
/// finite distance, a subpath is aimed with probability `frac`: it leaves uniformly into the cone of
/// one target's bounding sphere (the target drawn uniformly; any direction when the point is inside
/// the sphere); otherwise it leaves as the light emits (`Lights::emit`: cosine lobe, or uniform for a
/// point light). The emission density of a direction is the mixture (1 − frac) · p_light(ω) + frac ·
/// p_cone(ω): the subpath's power is divided by the mixture over p_light, and every emission density
/// the MIS weights use (the light subpath's own, a camera subpath hitting an emitter, next-event
/// estimation's ratio) is multiplied by it, so each strategy's weight stays a function of the path
/// alone. The density is positive wherever the light emits, so light that misses the targets is still
/// carried, by the unaimed share. `frac` makes `render.vcm.aim` of all subpaths head for the spheres,
/// counting those the lights' own emission already sends there (measured once from `AIM_PROBES`
/// emitted rays): nothing is aimed where the targets already catch that share. Lights at infinity are
/// not aimed.
pub struct Aim {
    /// Probability that a subpath is aimed.
    frac: f32,
    /// Share of the unaimed emission that already heads into a target's sphere.
    caught: f32,
    /// Specular shapes aimed at (their spheres may be merged into one).
    shapes: usize,
    /// Centre and radius of each target's bounding sphere.
    spheres: Vec<(Vec3, f32)>,
}

/// Emitted rays that estimate how much of the lights' own emission heads for the targets.
const AIM_PROBES: u64 = 4096;

/// Most targets aimed at one by one; beyond this, one sphere around them all.
const AIM_MAX_TARGETS: usize = 16;

impl Aim {
    /// Aiming at the non-diffuse shapes of the scene, or at those of `only` (the planner's caustic
    /// targets), so that `render.vcm.aim` of the light subpaths head for them.
    pub fn new(scene: &Scene, only: Option<&[u32]>) -> Aim {
        let share = scene.render.vcm.aim;
        let targets: Vec<&crate::scene::Shape> = (scene.shapes.iter().enumerate())
            .filter(|&(i, sh)| {
                only.is_none_or(|o| o.contains(&(i as u32))) && scene.casts_caustics(i as u32) && sh.area() > 0.0
            })
            .map(|(_, sh)| sh)
            .collect();
        let spheres = if targets.len() > AIM_MAX_TARGETS {
            let (lo, hi) = targets
                .iter()
                .map(|sh| sh.geometry.bounds())
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), (l, h)| (a.min(l), b.max(h)));
            vec![(0.5 * (lo + hi), 0.5 * (hi - lo).length() * (1.0 + 1e-4))]
        } else {
            targets
                .iter()
                .map(|sh| match &sh.geometry {
                    Geometry::Sphere { center, radius, .. } => (*center, *radius),
                    Geometry::Mesh(m) => {
                        let (lo, hi) = sh.geometry.bounds();
                        let c = 0.5 * (lo + hi);
                        let r = m.positions.iter().map(|p| p.distance_squared(c)).fold(0.0f32, f32::max).sqrt();
                        (c, r * (1.0 + 1e-4) + 1e-6 * scene.diagonal())
                    }
                })
                .collect()
        };
        let mut aim = Aim { frac: 0.0, shapes: targets.len(), spheres, caught: 0.0 };
        if aim.spheres.is_empty() {
            return aim;
        }
        aim.caught = aim.caught_share(scene);
        aim.frac = if aim.caught >= share { 0.0 } else { (share - aim.caught) / (1.0 - aim.caught) };
        aim
    }

    /// Share of the lights' own emission (lights at finite distance, by power) that leaves towards a
    /// target's bounding sphere, estimated from `AIM_PROBES` emitted rays (fixed random numbers).
    fn caught_share(&self, scene: &Scene) -> f32 {
        let lights = &scene.lights;
        let (mut caught, mut finite) = (0u32, 0u32);
        for k in 0..AIM_PROBES {
            let mut rng = Rng::new(0xA1A1_0000_0000_0001, k, 0);
            let Some(e) = lights.emit(scene, rng.next_f32(), rng.next_2d(), rng.next_2d()) else {
                continue;
            };
            if lights.list[e.light].at_infinity() {
                continue;
            }
            finite += 1;
            caught += (self.cone_pdf(e.origin, e.ray.d) > 0.0) as u32;
        }
        if finite == 0 {
            1.0
        } else {
            caught as f32 / finite as f32
        }
    }

    /// Probability that a light subpath is aimed.
    pub fn aimed_share(&self) -> f32 {
        self.frac
    }

    /// Share of the lights' own emission (at finite distance) that heads for a target's sphere.
    pub fn caught_by_targets(&self) -> f32 {
        self.caught
    }

    /// How many specular shapes subpaths are aimed at.
    pub fn targets(&self) -> usize {
        self.shapes
    }

    /// One line for the user: how much of the light heads for the specular shapes, how much is aimed.
    pub fn describe(&self) -> String {
        let sent = format!(
            "light subpaths: the lights' own emission sends {:.1}% towards the bounding spheres of {} specular shape(s)",
            100.0 * self.caught,
            self.shapes
        );
        if self.frac > 0.0 {
            format!("{sent}; {:.1}% are aimed there, so that render.vcm.aim of them go there", 100.0 * self.frac)
        } else {
            format!("{sent}; none aimed (render.vcm.aim of them already go there)")
        }
    }

    /// Whether any subpath is aimed.
    pub fn is_active(&self) -> bool {
        self.frac > 0.0
    }

    /// Solid-angle density of the aimed share's direction `w` (unit) from point `x`.
    fn cone_pdf(&self, x: Vec3, w: Vec3) -> f32 {
        let mut p = 0.0;
        for &(c, r) in &self.spheres {
            let d = c - x;
            match visible_cone(r, d.length_squared()) {
                None => p += 1.0 / (4.0 * PI),
                Some(one_minus) => {
                    let t = d.dot(w);
                    // Inside the cone: the line x + t·w passes within r of the centre, ahead of x.
                    if t > 0.0 && (d - w * t).length_squared() <= r * r {
                        p += 1.0 / (2.0 * PI * one_minus);
                    }
                }
            }
        }
        p / self.spheres.len() as f32
    }

    /// A direction of the aimed share from `x`: target `u_pick` ∈ [0, 1) of the list, `u` in its cone.
    fn sample(&self, x: Vec3, u_pick: f32, u: [f32; 2]) -> Vec3 {
        let k = ((u_pick * self.spheres.len() as f32) as usize).min(self.spheres.len() - 1);
        let (c, r) = self.spheres[k];
        towards_sphere(x, c, r, u).map_or_else(|| uniform_sphere(u), |(w, _)| w)
    }

    /// The mixture's density of direction `w` from light point `x` over the light's own density
    /// `base` of it: the factor aiming puts on every emission density (1 without aiming).
    fn ratio(&self, x: Vec3, w: Vec3, base: f32) -> f32 {
        if !self.is_active() || base <= 0.0 {
            return 1.0;
        }
        (1.0 - self.frac) + self.frac * self.cone_pdf(x, w) / base
    }

    /// Aims an emitted ray (light at finite distance) with probability `frac`, given the uniform
    /// `u_aim` and the direction numbers `u_dir` the emission used; corrects its power and density.
    /// None: the aimed direction leaves the emitter's back or a spot's cone (it emits nothing there).
    fn apply(&self, lights: &Lights, mut e: EmittedRay, u_aim: f32, u_dir: [f32; 2]) -> Option<EmittedRay> {
        let old = lights.direction_density(e.light, e.normal, e.ray.d);
        let old_carried = lights.emission_over_density(e.light, e.normal, e.ray.d);
        if u_aim < self.frac {
            let w = self.sample(e.origin, u_aim / self.frac, u_dir);
            if e.normal == Vec3::ZERO {
                e.ray = Ray::new(e.origin, w);
            } else {
                // Behind the face only for a mesh that emits there (`Lights::side_share`).
                let cos = w.dot(e.normal);
                if lights.side_share(e.light, cos) <= 0.0 {
                    return None;
                }
                e.cos = cos.abs();
                e.ray = Ray::new(offset_ray_origin(e.origin, e.normal, w, e.size), w);
            }
        }
        let new = lights.direction_density(e.light, e.normal, e.ray.d);
        if new <= 0.0 || old <= 0.0 || old_carried <= 0.0 {
            return None;
        }
        // The power is the light's emission towards the direction over the density of drawing it: the
        // light's own emission over its own density (`emission_over_density`) in the new direction
        // over that in the old, and the mixture divides by `ratio`.
        let ratio = self.ratio(e.origin, e.ray.d, new);
        e.untinted *= lights.emission_over_density(e.light, e.normal, e.ray.d) / old_carried / ratio;
        // A spot's projected texture, read in the direction it now leaves along.
        e.phi = e.untinted * lights.tint(e.light, e.ray.d);
        e.pdf_emit = e.pdf_emit / old * new * ratio;
        Some(e)
    }
}

/// Light subpaths per iteration: the setting, at least one per pixel.
pub fn light_paths(scene: &Scene, opts: VcmOptions) -> usize {
    (scene.camera.width as usize * scene.camera.height as usize).max(opts.light_paths)
}

/// What one iteration produced.
pub struct IterationOutput {
    pub image: Image,
    pub counters: Counters,
    pub light_vertices: u64,
}

/// What a render sets up once for all its iterations: the options it was made for, the aimed emission
/// of light subpaths and the first iteration's merge radius over the scene.
pub struct Setup {
    pub opts: VcmOptions,
    pub aim: Aim,
    pub radius: RadiusField,
}

impl Setup {
    /// The scene's settings: aiming at `targets` (None: every non-diffuse shape), the merge radius
    /// `render.progressive.radius` everywhere if set, else (`render.vcm.local_radius`) set per region
    /// by a pilot iteration's light vertices, or `initial_radius` everywhere.
    pub fn new(scene: &Scene, tracer: &dyn Tracer, opts: VcmOptions, targets: Option<&[u32]>) -> Setup {
        let aim = Aim::new(scene, targets);
        let r1 = initial_radius(scene);
        let local = opts.merge && scene.render.vcm.local_radius && scene.render.progressive.radius <= 0.0;
        let radius = if local { RadiusField::local(scene, tracer, opts, &aim, r1) } else { RadiusField::uniform(r1) };
        Setup { opts, aim, radius }
    }
}

/// The first iteration's merge radius over the scene (iteration i scales it by i^((α−1)/2)): one
/// radius everywhere, or one per cell of a grid over the scene's bounds, set so that a merge disc
/// there holds about `MERGE_COUNT` of an iteration's light vertices, as a pilot iteration's light
/// vertices fall (their `PILOT_K`-th nearest neighbour distance, averaged per cell as r²), never above
/// the scene-wide radius `initial_radius` nor below 1/16 of it. Where light is dense (a caustic) the
/// radius shrinks and blurs less; cells the pilot did not reach keep the scene-wide radius. The MIS
/// weights take η = π r² n at each vertex (merging at that vertex), so they stay exact for a radius
/// that varies over the scene: the dVM quantity is carried as η·dVM and divided by the merge vertex's
/// own η.
pub struct RadiusField {
    r1: f32,
    /// Base radius per cell, x fastest (empty: `r1` everywhere).
    grid: Vec<f32>,
    lo: Vec3,
    inv_cell: f32,
    dims: [usize; 3],
    /// Smallest and largest base radius over the cells the pilot reached, and how many it reached.
    summary: (f32, f32, usize),
}

/// Light vertices a merge disc holds at the first iteration (as `initial_radius` assumes).
const MERGE_COUNT: f32 = 4.0;
/// Neighbours whose distance measures the pilot's local density.
const PILOT_K: usize = 16;
/// Most pilot vertices whose density is measured.
const PILOT_QUERIES: usize = 1 << 16;
/// Most cells of the radius grid.
const RADIUS_CELLS: usize = 1 << 22;

impl RadiusField {
    pub fn uniform(r1: f32) -> RadiusField {
        RadiusField { r1, grid: Vec::new(), lo: Vec3::ZERO, inv_cell: 0.0, dims: [0; 3], summary: (r1, r1, 0) }
    }

    /// The scene-wide radius.
    pub fn r1(&self) -> f32 {
        self.r1
    }

    /// The base radius at `p`.
    fn at(&self, p: Vec3) -> f32 {
        if self.grid.is_empty() {
            return self.r1;
        }
        self.grid[self.index(p)]
    }

    /// Range of the base radii over the cells the pilot reached: (smallest, largest, cells).
    pub fn spread(&self) -> (f32, f32, usize) {
        self.summary
    }

    /// From a pilot iteration's light subpaths (its own random numbers, not part of the image).
    fn local(scene: &Scene, tracer: &dyn Tracer, opts: VcmOptions, aim: &Aim, r1: f32) -> RadiusField {
        let uniform = RadiusField::uniform(r1);
        let pilot = VcmOptions { connect: false, merge: true, light_paths: opts.light_paths, strategy: None };
        let v = Vcm { scene, tracer, it: Iteration::new(scene, pilot, &uniform, 1.0), aim };
        let seed = scene.render.seed ^ 0x9170_7000_0000_0000;
        let pts: Vec<([f32; 3], ())> = v
            .light_chunks(light_paths(scene, pilot), |k| Rng::new(seed, k as u64, 0))
            .iter()
            .flat_map(|chunk| chunk.0.iter().map(|lv| (lv.si.p.to_array(), ())))
            .collect();
        if pts.len() <= PILOT_K {
            return uniform;
        }
        let Ok(tree) = KdTree::build(pts) else {
            return uniform;
        };
        let (lo, hi) = scene.bounds;
        let extent = (hi - lo).max(Vec3::splat(1e-6 * scene.diagonal().max(1e-30)));
        // Cells of 4 r1, larger if the grid would get too big.
        let mut cell = 4.0 * r1;
        let dims = loop {
            let d = (extent / cell).ceil().max(Vec3::ONE);
            if (d.x as f64) * (d.y as f64) * (d.z as f64) <= RADIUS_CELLS as f64 {
                break [d.x as usize, d.y as usize, d.z as usize];
            }
            cell *= 1.5;
        };
        let mut field = RadiusField {
            r1,
            grid: vec![r1; dims[0] * dims[1] * dims[2]],
            lo,
            inv_cell: 1.0 / cell,
            dims,
            summary: (f32::INFINITY, 0.0, 0),
        };
        let step = tree.len().div_ceil(PILOT_QUERIES);
        let measured: Vec<(usize, f32)> = (0..tree.len())
            .step_by(step)
            .collect::<Vec<_>>()
            .into_par_iter()
            .filter_map(|i| {
                let q = tree.position(i as u32);
                let d2 = SCRATCH.with(|s| tree.knn(q, PILOT_K, f32::INFINITY, &mut s.borrow_mut()));
                let r2 = d2 * (MERGE_COUNT / PILOT_K as f32);
                (r2.is_finite() && r2 > 0.0).then(|| (field.index(Vec3::from_array(q)), r2))
            })
            .collect();
        let mut sums = vec![(0.0f64, 0u32); field.grid.len()];
        for (c, r2) in measured {
            sums[c].0 += r2 as f64;
            sums[c].1 += 1;
        }
        // Only ever smaller than the scene-wide radius (larger ones blurred more than they saved in
        // noise on every scene tried), and at most 16 times smaller.
        for (g, (sum, count)) in field.grid.iter_mut().zip(sums) {
            if count > 0 {
                *g = ((sum / count as f64).sqrt() as f32).clamp(r1 / 16.0, r1);
                let (lo, hi, n) = field.summary;
                field.summary = (lo.min(*g), hi.max(*g), n + 1);
            }
        }
        if field.summary.2 == 0 {
            field.summary = (r1, r1, 0);
        }
        field
    }

    /// The grid cell holding `p`.
    fn index(&self, p: Vec3) -> usize {
        let q = (p - self.lo) * self.inv_cell;
        let c = |v: f32, d: usize| (v.max(0.0) as usize).min(d - 1);
        let [nx, ny, nz] = self.dims;
        (c(q.z, nz) * ny + c(q.y, ny)) * nx + c(q.x, nx)
    }
}

/// Iteration `i` (1-based) of BDPT/VCM: merge radius `setup.radius` × i^((α−1)/2).
pub fn iterate(scene: &Scene, tracer: &dyn Tracer, setup: &Setup, i: u32) -> IterationOutput {
    let opts = setup.opts;
    let cam = &scene.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let pixels = w * h;
    let n = light_paths(scene, opts);
    let shrink = radius_at(1.0, scene.render.progressive.alpha, i);
    let v = Vcm { scene, tracer, it: Iteration::new(scene, opts, &setup.radius, shrink), aim: &setup.aim };
    let (sampler, seed) = (scene.render.sampler, scene.render.seed);
    let chunks = v.light_chunks(n, |k| Rng::camera(sampler, seed ^ 0x7C3A_0000_0000_0000, k as u64, (i - 1) as u64));
    let mut verts = Vec::new();
    let mut ends = Vec::with_capacity(n + 1);
    ends.push(0u32);
    let mut splat = vec![[0.0f64; 3]; pixels];
    let mut counters = Counters::default();
    for (cv, ce, cs, c) in chunks {
        let base = verts.len() as u32;
        ends.extend(ce.iter().map(|e| e + base));
        verts.extend(cv);
        for (px, val) in cs {
            for k in 0..3 {
                splat[px as usize][k] += val[k] as f64;
            }
        }
        counters += c;
    }
    // The light vertices to merge with: all of them, and (merging only caustics at the camera's first
    // hit) a tree of those that came through a delta BSDF, searched there.
    let build = |keep: fn(&LightVertex) -> bool| {
        let pts: Vec<([f32; 3], MergeVertex)> = verts
            .iter()
            .filter(|lv| keep(lv))
            .map(|lv| {
                let m =
                    MergeVertex { wo: lv.wo, ng: lv.si.ng, beta: lv.beta, len: lv.len, d_vcm: lv.d_vcm, s_vm: lv.s_vm };
                (lv.si.p.to_array(), m)
            })
            .collect();
        if pts.is_empty() {
            None
        } else {
            KdTree::build(pts).ok()
        }
    };
    let tree = if opts.merge { build(|_| true) } else { None };
    let caustic_tree = if v.it.primary == Primary::Caustics { build(|lv| lv.after_delta) } else { None };
    let first_hit_tree = match v.it.primary {
        Primary::All => tree.as_ref(),
        Primary::Caustics => caustic_tree.as_ref(),
        Primary::None => None,
    };
    let light = LightPaths { verts: &verts, ends: &ends, tree: tree.as_ref(), first_hit_tree };
    let camera: Vec<(Rgb, Counters)> = (0..pixels)
        .into_par_iter()
        .map(|k| {
            let mut rng = Rng::camera(sampler, seed, k as u64, (i - 1) as u64);
            let mut c = Counters::default();
            let (fx, fy, weight) = cam.film_position((k % w) as u32, (k / w) as u32, rng.next_2d());
            let l = v.camera_path((fx, fy), k, &light, &mut rng, &mut c) * weight;
            (l, c)
        })
        .collect();
    let mut image = Image::new(cam.width, cam.height);
    for (k, (l, c)) in camera.into_iter().enumerate() {
        counters += c;
        let s = splat[k];
        let val = Rgb::new((l.x as f64 + s[0]) as f32, (l.y as f64 + s[1]) as f32, (l.z as f64 + s[2]) as f32);
        if val.is_finite() {
            image.pixels[k] = val;
        } else {
            counters.nonfinite += 1;
        }
    }
    IterationOutput { image, counters, light_vertices: verts.len() as u64 }
}

/// One chunk of light subpaths: their vertices, where each path's vertices end, the light-tracing
/// splats (pixel, value) in the order made, and counters.
type LightChunk = (Vec<LightVertex>, Vec<u32>, Vec<(u32, Rgb)>, Counters);

struct LightPaths<'a> {
    verts: &'a [LightVertex],
    /// Light path k's vertices are verts[ends[k]..ends[k + 1]].
    ends: &'a [u32],
    /// The light vertices merged with past the camera's first hit, and at the first hit (None where no
    /// merging happens: without merging, or at the first hit with `merge_primary = "none"`).
    tree: Option<&'a KdTree<MergeVertex>>,
    first_hit_tree: Option<&'a KdTree<MergeVertex>>,
}

struct Vcm<'a> {
    scene: &'a Scene,
    tracer: &'a dyn Tracer,
    it: Iteration<'a>,
    aim: &'a Aim,
}

/// Cosine of `w` to the geometric normal (the area ↔ solid-angle conversions of the MIS pdfs).
fn cos_g(si: &SurfaceHit, w: Vec3) -> f32 {
    w.dot(si.ng).abs()
}

impl Vcm<'_> {
    /// `n` light subpaths in fixed chunks (the same chunks on any thread count), subpath k drawing
    /// from `rng(k)`.
    fn light_chunks(&self, n: usize, rng: impl Fn(usize) -> Rng + Sync) -> Vec<LightChunk> {
        (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|ci| {
                let (mut verts, mut ends, mut splats, mut c) =
                    (Vec::new(), Vec::new(), Vec::new(), Counters::default());
                for k in ci * CHUNK..((ci + 1) * CHUNK).min(n) {
                    self.light_path(&mut rng(k), &mut verts, &mut splats, &mut c);
                    ends.push(verts.len() as u32);
                }
                (verts, ends, splats, c)
            })
            .collect()
    }

    /// Traces one light subpath: stores its non-delta vertices (when connecting or merging) and
    /// connects each to the camera (light tracing).
    fn light_path(&self, rng: &mut Rng, verts: &mut Vec<LightVertex>, splats: &mut Vec<(u32, Rgb)>, c: &mut Counters) {
        let scene = self.scene;
        let lights = &scene.lights;
        let it = &self.it;
        let (u_sel, u_pos, u_dir) = (rng.next_f32(), rng.next_2d(), rng.next_2d());
        let Some(mut e) = lights.emit(scene, u_sel, u_pos, u_dir) else {
            return;
        };
        let kind = &lights.list[e.light];
        let finite = !kind.at_infinity();
        if finite && self.aim.is_active() {
            let Some(aimed) = self.aim.apply(lights, e, rng.next_f32(), u_dir) else {
                return;
            };
            e = aimed;
        }
        if e.pdf_emit <= 0.0 || e.phi == Rgb::ZERO || !lights.leaves(scene, &e) {
            return;
        }
        let delta = kind.is_delta();
        // dVCM = p_direct / p_emit [tech. rep. (31)]; for lights at finite distance the direct density
        // (per unit area of the light) depends on the first hit (cone sampling of spheres), so it is
        // taken there.
        let d_vcm = if finite {
            0.0
        } else {
            lights.direct_pdf_area(scene, e.light, e.origin + e.ray.d, e.origin, Vec3::ZERO) / e.pdf_emit
        };
        let d_vc = if delta { 0.0 } else { (if finite { e.cos } else { 1.0 }) / e.pdf_emit };
        let mut sp = SubPath {
            beta: e.phi,
            len: 1,
            specular: true,
            after_delta: false,
            d_vcm,
            d_vc,
            s_vm: d_vc * it.vc,
            radiance_scale: 1.0,
            held_vm: 0.0,
        };
        let beta0 = max_component(e.phi).max(1e-30);
        let mut ray = e.ray;
        // Distance from the subpath's last vertex to `ray`'s origin: see-through surfaces crossed since
        // are no vertices (`Scene::crossing`).
        let (mut travelled, mut crossings) = (0.0f32, 0u32);
        // Absorption of the medium the subpath's segment runs through (`Scene::sigma_next`), from the
        // light's own (`Scene::light_medium`); None where that is the first segment's end's to say
        // (`Scene::absorbed_on_light_path`).
        let mut sigma = scene.light_medium(e.light);
        loop {
            c.rays += 1;
            let Some(Interaction { hit, si, wo }) = interact(scene, self.tracer, &ray) else {
                break;
            };
            sp.beta *= scene.absorbed_on_light_path(sigma, &ray, &si, hit.t);
            // The medium the light arrived in (on its first segment the one this end's side says).
            let arrived = sigma.unwrap_or_else(|| scene.sigma_leaving(&si, wo));
            let picked = scene.bsdf(&si, wo, || rng.next_f32());
            let crossing = scene.crossing(&si, wo, picked, || rng.next_f32());
            let mat = match crossing {
                crate::scene::Crossing::At(mat) => mat,
                crate::scene::Crossing::Through(_) => picked,
            };
            // The MIS state on arrival here; a crossing leaves the subpath's own as it was.
            let mut here = sp;
            let dist = travelled + hit.t * ray.d.length();
            if here.len == 1 && finite {
                here.d_vcm = lights.direct_pdf_area(scene, e.light, si.p, e.origin, e.normal) / e.pdf_emit;
            }
            if here.len > 1 || finite {
                here.d_vcm *= dist * dist;
            }
            let cos_in = cos_g(&si, wo);
            if cos_in <= 0.0 {
                break;
            }
            here.d_vcm /= cos_in;
            here.d_vc /= cos_in;
            here.s_vm /= cos_in;
            let vm = if mat.is_delta() { 0.0 } else { it.vm_at(si.p) };
            let lv = LightVertex {
                si,
                wo,
                mat,
                beta: here.beta,
                len: here.len,
                d_vcm: here.d_vcm,
                d_vc: here.d_vc,
                s_vm: here.s_vm,
                vm,
                after_delta: here.after_delta,
                sigma: arrived,
            };
            if let crate::scene::Crossing::Through(t) = crossing {
                // Let by: no vertex. The light that arrived is still there for a camera subpath whose own
                // pick there can merge with it, as at a blend's mirror (below).
                if it.opts.merge && scene.blend_offers(&si, wo, |m| !m.is_delta()) {
                    verts.push(lv);
                }
                sp.beta *= t;
                crossings += 1;
                if sp.beta == Rgb::ZERO || crossings > crate::accel::MAX_CROSSINGS {
                    break;
                }
                travelled = dist;
                ray = si.spawn(ray.d);
                continue;
            }
            sp = here;
            travelled = 0.0;
            if mat.is_delta() {
                // A blend that picked a mirror or glass here for the light's next bounce: the light that
                // arrived is still there for a camera subpath whose own pick can merge with it (this
                // vertex connects to nothing: its BSDF is a delta).
                if it.opts.merge && scene.blend_offers(&si, wo, |m| !m.is_delta()) {
                    verts.push(lv);
                }
            } else {
                if it.opts.connect || it.opts.strategy.is_some() {
                    // A lens point of its own for each connection.
                    let lens = scene.camera.sample_lens(rng);
                    self.connect_to_camera(&lv, lens, splats, c);
                }
                if it.opts.connect || it.opts.merge {
                    verts.push(lv);
                }
            }
            if sp.len + 2 > it.max_len {
                break;
            }
            let Some(next) = self.scatter(&mut sp, &si, wo, &mat, vm, 0.0, rng, TransportMode::Importance, beta0)
            else {
                break;
            };
            sigma = Some(scene.sigma_next(&si, next.d, arrived));
            ray = next;
            sp.len += 1;
        }
    }

    /// Samples the BSDF at the subpath's end and updates its throughput and MIS quantities [tech. rep.
    /// (34)-(36), (53)-(55)], `vm` being the merge strategy at the vertex (`Iteration::vm_at`) and `held`
    /// its share held back (`SubPath::held_vm`); Russian roulette after `render.rr_depth` edges. None ends
    /// the subpath.
    #[allow(clippy::too_many_arguments)]
    fn scatter(
        &self,
        sp: &mut SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
        vm: f32,
        held: f32,
        rng: &mut Rng,
        mode: TransportMode,
        beta0: f32,
    ) -> Option<Ray> {
        let it = &self.it;
        let (bs, next) = si.scatter(mat, wo, rng, mode)?;
        if bs.pdf <= 0.0 {
            return None;
        }
        let cos_out = cos_g(si, bs.wi);
        if bs.delta {
            // The forward and reverse choice probabilities of a delta lobe are equal and cancel.
            sp.d_vcm = 0.0;
            sp.d_vc *= cos_out;
            sp.s_vm *= cos_out;
            sp.held_vm = 0.0;
        } else {
            // The reverse density: wo drawn from bs.wi's side, in the other subpath's mode.
            let other =
                if mode == TransportMode::Radiance { TransportMode::Importance } else { TransportMode::Radiance };
            let rev = mat.pdf(bs.wi, wo, si.ns, other);
            let f = cos_out / bs.pdf;
            sp.d_vc = f * (sp.d_vc * rev + sp.d_vcm + vm);
            sp.s_vm = f * (sp.s_vm * rev + sp.d_vcm * it.vc + vm);
            sp.held_vm = f * held;
            sp.d_vcm = 1.0 / bs.pdf;
            sp.specular = false;
        }
        sp.after_delta = bs.delta;
        sp.beta *= bs.weight;
        sp.radiance_scale *= bs.radiance_scale;
        if sp.beta == Rgb::ZERO {
            return None;
        }
        if sp.len >= self.scene.render.rr_depth {
            let q = russian_roulette(max_component(sp.beta) / beta0 / sp.radiance_scale, rng.next_f32())?;
            sp.beta /= q;
        }
        Some(next)
    }

    /// Light tracing (t = 1): the light vertex seen from lens point `lens` (the pinhole for a pinhole
    /// camera), splatted where it lands on the film (`link_to_camera`).
    fn connect_to_camera(&self, lv: &LightVertex, lens: Vec3, splats: &mut Vec<(u32, Rgb)>, c: &mut Counters) {
        let it = &self.it;
        let (s, t) = (lv.len + 1, 1);
        if lv.len + 1 > it.max_len {
            return;
        }
        let weight = |dir: Vec3, camera_pdf_a: f32| {
            it.weight(s, t, || {
                let rev = lv.mat.pdf(dir, lv.wo, lv.si.ns, TransportMode::Radiance);
                // The light vertex is the camera's first hit here: merging there is a strategy as
                // `merge_primary` says.
                let vm = it.vm_as_first_hit(lv);
                let w_light = camera_pdf_a / it.n_paths * (vm + lv.d_vcm + lv.d_vc * rev);
                1.0 / (w_light + 1.0)
            })
        };
        let add = |pixel, val| splats.push((pixel, val));
        super::link_to_camera(
            self.scene,
            self.tracer,
            &lv.si,
            lv.wo,
            &lv.mat,
            lv.beta,
            lens,
            it.n_paths,
            c,
            weight,
            add,
        );
    }

    /// One camera subpath through film position `film`, paired with light subpath `k`.
    fn camera_path(&self, film: (f32, f32), k: usize, light: &LightPaths, rng: &mut Rng, c: &mut Counters) -> Rgb {
        let scene = self.scene;
        let it = &self.it;
        let cam = &scene.camera;
        let mut ray = cam.sample_ray(film.0, film.1, rng);
        let pdf_dir = cam.pixel_pdf_dir(ray.d);
        if pdf_dir <= 0.0 {
            return Rgb::ZERO;
        }
        let mut sp = SubPath {
            beta: Rgb::ONE,
            len: 1,
            specular: true,
            d_vcm: it.n_paths / pdf_dir,
            d_vc: 0.0,
            s_vm: 0.0,
            radiance_scale: 1.0,
            after_delta: false,
            held_vm: 0.0,
        };
        let mut prev = ray.o;
        let mut l = Rgb::ZERO;
        let lv_range = light.ends[k] as usize..light.ends[k + 1] as usize;
        let mut view = LineOfSight::CAMERA;
        let mut sigma = Rgb::ZERO;
        loop {
            c.rays += 1;
            // Only the camera sees light along its line of sight (s = 0): hidden, it is hidden for all.
            let hidden = view.hides(scene);
            let (found, tr) = view.trace_through(scene, self.tracer, &ray, rng, c);
            sp.beta *= tr * scene.absorbed_to(sigma, &ray, found.as_ref().map(|f| f.0.hit.t));
            let Some((Interaction { hit, si, wo }, mat)) = found else {
                if !hidden {
                    l += sp.beta * self.env_hit(&sp, ray.d);
                }
                break;
            };
            let dist2 = (hit.t * ray.d.length()).powi(2);
            let cos_in = cos_g(&si, wo);
            if cos_in <= 0.0 {
                break;
            }
            // Per unit area at this vertex. An orthographic camera's rays do not spread: its density
            // (per unit area of film) converts at the first hit without a distance.
            if sp.len == 1 && cam.ortho.is_some() {
                sp.d_vcm /= cos_in;
            } else {
                sp.d_vcm *= dist2 / cos_in;
            }
            sp.d_vc /= cos_in;
            sp.s_vm /= cos_in;
            // Emission here ends the path at the light: the first hit's caustic merge (held back) is no
            // strategy for it.
            let le = if hidden { Rgb::ZERO } else { scene.emitted(&si, wo) };
            if le != Rgb::ZERO {
                l += sp.beta * le * self.emitter_hit(&sp, &si, wo, prev);
            }
            if sp.len >= it.max_len {
                break;
            }
            if sp.held_vm != 0.0 {
                // The second vertex: light scattered by a delta BSDF here could have been merged at the
                // first hit, for every path that goes on from here.
                if mat.is_delta() {
                    let held = sp.held_vm / cos_in;
                    sp.d_vc += held;
                    sp.s_vm += held;
                }
                sp.held_vm = 0.0;
            }
            // η here (merging's radius), the merge strategy's share of MIS sums here and what it merges
            // with (at the first hit as `merge_primary` says: only caustics' light vertices, whose MIS
            // share is held back until the next vertex, or none).
            let first = sp.len == 1;
            let merges_here = if first { it.primary != Primary::None } else { it.merge };
            let only_caustics = first && it.primary == Primary::Caustics;
            let merge_tree = if first { light.first_hit_tree } else { light.tree };
            let (eta, vm, held) = if mat.is_delta() || !merges_here {
                (0.0, 0.0, 0.0)
            } else {
                let eta = it.eta(si.p);
                if only_caustics {
                    (eta, 0.0, eta)
                } else {
                    (eta, eta, 0.0)
                }
            };
            if !mat.is_delta() {
                if it.opts.connect || it.opts.strategy.is_some() {
                    l += sp.beta * self.light_sample(&sp, &si, wo, &mat, sigma, vm, rng, c);
                    for lv in &light.verts[lv_range.clone()] {
                        if lv.len + 1 + sp.len > it.max_len {
                            break;
                        }
                        l += sp.beta * lv.beta * self.connect(&sp, &si, wo, &mat, sigma, vm, lv, c);
                    }
                }
                if let Some(tree) = merge_tree {
                    l += sp.beta * self.merge(&sp, &si, wo, &mat, eta, tree, rng, c);
                }
            }
            prev = si.p;
            let Some(next) = self.scatter(&mut sp, &si, wo, &mat, vm, held, rng, TransportMode::Radiance, 1.0) else {
                break;
            };
            // `scatter` keeps the sample to itself; a thin pane's transmission is the one lobe that goes on
            // along the incoming direction.
            view = view.after(&mat, next.d.normalize().dot(-wo) > 1.0 - 1e-5);
            sigma = scene.sigma_next(&si, next.d, sigma);
            ray = next;
            sp.len += 1;
        }
        l
    }

    /// Weight of emission found by the camera subpath (s = 0) on a surface [tech. rep. (42)-(43)].
    fn emitter_hit(&self, sp: &SubPath, si: &SurfaceHit, wo: Vec3, prev: Vec3) -> f32 {
        let lights = &self.scene.lights;
        self.s0_weight(sp, || {
            let i = lights.index_of(self.scene, si.shape, si.prim)?;
            let direct_a = lights.direct_pdf_area(self.scene, i, prev, si.p, si.ng);
            let cos = wo.dot(si.ng);
            let aim = self.aim.ratio(si.p, wo, lights.direction_density(i, si.ng, wo));
            Some((direct_a, lights.emit_pdf(self.scene, i, cos, -wo) * aim))
        })
    }

    /// Environment radiance met by the camera subpath leaving the scene along `dir` (s = 0), weighted.
    fn env_hit(&self, sp: &SubPath, dir: Vec3) -> Rgb {
        let lights = &self.scene.lights;
        let Some((env, i)) = &lights.env else {
            return Rgb::ZERO;
        };
        let le = env.radiance(dir);
        if le == Rgb::ZERO {
            return le;
        }
        le * self
            .s0_weight(sp, || Some((lights.power_pdf(*i) * env.pdf(dir), lights.emit_pdf(self.scene, *i, 1.0, -dir))))
    }

    /// The weight of emission the camera subpath finds (s = 0): 1 seen straight from the camera; without
    /// connections, 1 along a purely specular chain and 0 otherwise (merging has the rest); else the MIS
    /// weight from `pdfs`: next-event estimation's density of the emitting point (per area, per solid
    /// angle for the sky) and emission's density of the ray (None: not a light next-event estimation
    /// knows, weight 1).
    fn s0_weight(&self, sp: &SubPath, pdfs: impl FnOnce() -> Option<(f32, f32)>) -> f32 {
        let it = &self.it;
        it.weight(0, sp.len + 1, || {
            if sp.len == 1 {
                return 1.0;
            }
            if !it.opts.connect {
                return sp.specular as u32 as f32;
            }
            pdfs().map_or(1.0, |(direct, emit)| 1.0 / (1.0 + direct * sp.d_vcm + emit * sp.d_vc))
        })
    }

    /// Next-event estimation (s = 1) at a non-delta camera vertex [tech. rep. (44)-(45)], reached through
    /// a medium of absorption `arrived`; `vm`: the merge strategy there.
    #[allow(clippy::too_many_arguments)]
    fn light_sample(
        &self,
        sp: &SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
        arrived: Rgb,
        vm: f32,
        rng: &mut Rng,
        c: &mut Counters,
    ) -> Rgb {
        let it = &self.it;
        let Some((ls, f)) = sample_light(self.scene, si, wo, mat, rng, false) else {
            return Rgb::ZERO;
        };
        let w = it.weight(1, sp.len + 1, || {
            let dir_pdf = if ls.delta { 0.0 } else { mat.pdf(wo, ls.wi, si.ns, TransportMode::Radiance) };
            let rev_pdf = mat.pdf(ls.wi, wo, si.ns, TransportMode::Importance);
            let w_light = dir_pdf / ls.pdf;
            let aim = if self.scene.lights.list[ls.light].at_infinity() {
                1.0
            } else {
                self.aim.ratio(ls.p, -ls.wi, self.scene.lights.direction_density(ls.light, ls.normal, -ls.wi))
            };
            let w_camera = ls.emit_ratio * aim * cos_g(si, ls.wi) * (vm + sp.d_vcm + sp.d_vc * rev_pdf);
            1.0 / (w_light + 1.0 + w_camera)
        });
        if w == 0.0 {
            return Rgb::ZERO;
        }
        let tr = shadow(self.scene, self.tracer, si, arrived, &ls, c);
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        f * ls.li * tr * (w / ls.pdf)
    }

    /// Connects a camera vertex to a light vertex (s ≥ 2, t ≥ 2) [tech. rep. (40)-(41)]; the result is
    /// to be multiplied by both subpaths' throughputs; `arrived`: the medium the camera subpath reached
    /// its vertex in; `vm`: the merge strategy at the camera vertex.
    #[allow(clippy::too_many_arguments)]
    fn connect(
        &self,
        sp: &SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
        arrived: Rgb,
        vm: f32,
        lv: &LightVertex,
        c: &mut Counters,
    ) -> Rgb {
        let it = &self.it;
        let d = lv.si.p - si.p;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return Rgb::ZERO;
        }
        let dir = d / dist2.sqrt();
        // The connection must leave each end on a side its BSDF scatters to.
        if !si.can_scatter(mat, wo, dir) || !lv.si.can_scatter(&lv.mat, lv.wo, -dir) {
            return Rgb::ZERO;
        }
        let f_cam = mat.eval(wo, dir, si.ns, TransportMode::Radiance) * dir.dot(si.ns).abs();
        if f_cam == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let f_light = lv.f_to(-dir);
        if f_light == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let w = it.weight(lv.len + 1, sp.len + 1, || {
            let cam_dir_a = mat.pdf(wo, dir, si.ns, TransportMode::Radiance) * cos_g(&lv.si, dir) / dist2;
            let cam_rev = mat.pdf(dir, wo, si.ns, TransportMode::Importance);
            let light_dir_a = lv.mat.pdf(lv.wo, -dir, lv.si.ns, TransportMode::Importance) * cos_g(si, dir) / dist2;
            let light_rev = lv.mat.pdf(-dir, lv.wo, lv.si.ns, TransportMode::Radiance);
            let w_light = cam_dir_a * (lv.vm + lv.d_vcm + lv.d_vc * light_rev);
            let w_camera = light_dir_a * (vm + sp.d_vcm + sp.d_vc * cam_rev);
            1.0 / (w_light + 1.0 + w_camera)
        });
        if w == 0.0 {
            return Rgb::ZERO;
        }
        c.rays += 1;
        let target = offset_ray_origin(lv.si.p, lv.si.ng, -dir, lv.si.scale);
        let tr = crate::accel::shadow(self.scene, self.tracer, &si.spawn_to(target), target, &mut c.rays);
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        // Inside coloured glass, by either end's medium (`Scene::sigma_next`: a boundary's side, or the
        // medium each subpath carried there).
        let sigma = match self.scene.sigma_next(si, dir, arrived) {
            s if s == Rgb::ZERO => self.scene.sigma_next(&lv.si, -dir, lv.sigma),
            s => s,
        };
        f_cam * f_light * tr * Scene::absorbed(sigma, dist2.sqrt()) * (w / dist2)
    }

    /// Vertex merging at a non-delta camera vertex [tech. rep. (37)-(39)]: the light vertices of `tree`
    /// within the iteration's radius, as a density estimate over the disc; to be multiplied by the
    /// camera throughput. As the photon maps' gathers: only light vertices on the disc (within a quarter
    /// of the radius of the tangent plane, on a surface facing within 53° of it) count, and the sum is
    /// divided by the part of the disc that is surface (`edges::inverse_coverage` over the surfaces that
    /// hold light vertices). The search's ball, counted whole, reads a point by a concave edge with the
    /// light vertices of the wall across it, and its disc, counted whole, reads dark by a convex one.
    #[allow(clippy::too_many_arguments)]
    fn merge(
        &self,
        sp: &SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
        eta: f32,
        tree: &KdTree<MergeVertex>,
        rng: &mut Rng,
        c: &mut Counters,
    ) -> Rgb {
        let it = &self.it;
        if it.opts.strategy.is_some() {
            return Rgb::ZERO;
        }
        let mut sum = Rgb::ZERO;
        let r = (eta / (PI * it.n_paths)).sqrt();
        SCRATCH.with(|s| {
            let mut s = s.borrow_mut();
            tree.within_res(si.p.to_array(), r * r, &mut s);
            for &(_, ti) in s.items() {
                let lv = tree.item(ti);
                if lv.len + sp.len > it.max_len || !si.can_scatter(mat, wo, lv.wo) {
                    continue;
                }
                if !in_disc_slab(si.p, si.ng, r, tree.position(ti)) || lv.ng.dot(si.ng).abs() < DISC_FACING {
                    continue;
                }
                let f = mat.eval(wo, lv.wo, si.ns, TransportMode::Radiance);
                if f == Rgb::ZERO {
                    continue;
                }
                let w_light = (lv.d_vcm * it.vc + lv.s_vm * mat.pdf(wo, lv.wo, si.ns, TransportMode::Radiance)) / eta;
                let w_camera =
                    (sp.d_vcm * it.vc + sp.s_vm * mat.pdf(lv.wo, wo, si.ns, TransportMode::Importance)) / eta;
                sum += f * lv.beta * (1.0 / (w_light + 1.0 + w_camera));
            }
        });
        if sum == Rgb::ZERO {
            return sum;
        }
        let edge = edge_factor(self.scene, self.tracer, si, wo, r, 0.0, rng, c, holds_light_vertices);
        sum * (edge / eta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::uniform_sphere;

    /// The aimed share's direction density is a density: it integrates to one over the sphere of
    /// directions, from points outside two targets, between them and inside one; and a direction the
    /// sampler draws has positive density, even in the cone of a tiny sphere 1000 units away.
    #[test]
    fn the_aimed_direction_density_integrates_to_one() {
        let aim = |spheres: Vec<(Vec3, f32)>| Aim { frac: 0.5, caught: 0.0, shapes: spheres.len(), spheres };
        let near = aim(vec![(Vec3::new(3.0, 0.0, 0.0), 0.5), (Vec3::new(0.0, 0.0, -6.0), 0.3)]);
        let far = aim(vec![(Vec3::new(0.0, 0.0, -1000.0), 0.01)]);
        let n = 1_000_000;
        for x in [Vec3::new(-1.0, 0.2, 0.0), Vec3::new(3.2, 0.1, 0.0), Vec3::new(1.5, 0.0, -3.0)] {
            let mut rng = Rng::new(7, 0, 0);
            let total: f64 = (0..n).map(|_| near.cone_pdf(x, uniform_sphere(rng.next_2d())) as f64).sum::<f64>();
            let integral = total / n as f64 * 4.0 * std::f64::consts::PI;
            assert!((integral - 1.0).abs() < 0.05, "from {x}: ∫ p = {integral}");
            for a in [&near, &far] {
                for k in 0..2000 {
                    let w = a.sample(x, (k as f32 + 0.5) / 2000.0, rng.next_2d());
                    assert!(a.cone_pdf(x, w) > 0.0, "from {x}: sampled {w} has density 0");
                }
            }
        }
    }

    /// Aiming moves a light's emission between directions but keeps what it carries: over emitted rays,
    /// aimed half of the time at a ball off to the side, the mean power and the mean power heading into
    /// the ball equal those of the light's own emission, for a point light, a spot with a soft edge, a
    /// projector and a quad light. A projector's intensity and its density of directions both grow as
    /// 1/cos³ off its axis; aimed rays took the intensity's change alone, so those heading into the ball
    /// (off its axis) carried 1.95 times their power in all, and the modes that aim light subpaths
    /// (BDPT, VCM) read a glossy disk's reflection of a projector 3–5% dark (random scene 2075).
    #[test]
    fn aiming_keeps_the_power_each_light_emits() {
        let lights = [
            "type = \"point\"\nposition = [0.0, 1.0, 0.0]\npower = [1.0, 1.0, 1.0]",
            "type = \"spot\"\nposition = [0.0, 1.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n\
             cutoff_angle = 60\nbeam_width = 20",
            "type = \"projector\"\nposition = [0.0, 1.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 110",
            "type = \"quad\"\ncorner = [-0.2, 1.0, -0.2]\nedge_u = [0.4, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.4]\n\
             power = [1.0, 1.0, 1.0]",
        ];
        let (ball, radius) = (Vec3::new(1.0, 0.0, 0.9), 0.3);
        let aim = Aim { frac: 0.5, caught: 0.0, shapes: 1, spheres: vec![(ball, radius)] };
        for light in lights {
            let text = format!(
                "[camera]\norigin = [0.0, 1.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
                 [materials]\nm = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
                 [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, -1.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\nmaterial = \"m\"\n\
                 [[lights]]\n{light}\n"
            );
            let s = crate::scene::load::load_scene_str(&text, "aim.toml", std::path::Path::new("."), &[]).unwrap();
            // Mean power, and mean power heading into the ball, with its standard error, over `n` rays.
            let carried = |aimed: bool, seed: u64| {
                let (n, mut rng) = (400_000, Rng::new(seed, 0, 0));
                let [mut all, mut into, mut into2] = [0.0f64; 3];
                for _ in 0..n {
                    let (u_sel, u_pos, u_dir) = (rng.next_f32(), rng.next_2d(), rng.next_2d());
                    let Some(e) = s.lights.emit(&s, u_sel, u_pos, u_dir) else { continue };
                    let e = if aimed { aim.apply(&s.lights, e, rng.next_f32(), u_dir) } else { Some(e) };
                    let Some(e) = e else { continue };
                    let phi = e.phi.y as f64;
                    all += phi;
                    if aim.cone_pdf(e.origin, e.ray.d) > 0.0 {
                        into += phi;
                        into2 += phi * phi;
                    }
                }
                let n = n as f64;
                (all / n, into / n, ((into2 / n - (into / n).powi(2)) / n).sqrt())
            };
            let (all, into, err) = carried(false, 1);
            let (all_aimed, into_aimed, err_aimed) = carried(true, 2);
            let sigma = err.hypot(err_aimed);
            assert!(into > 20.0 * sigma, "{light}: the ball must catch light ({into} ± {sigma})");
            assert!(
                (into_aimed - into).abs() < 4.0 * sigma,
                "{light}: {into_aimed} heads into the ball aimed, {into} unaimed (σ {sigma})"
            );
            assert!((all_aimed / all - 1.0).abs() < 0.01, "{light}: power {all_aimed} aimed, {all} unaimed");
        }
    }

    /// Aiming brings the share of subpaths heading for the targets to `render.vcm.aim`, counting those
    /// the light sends there anyway, and aims none when the light already sends more.
    #[test]
    fn aiming_makes_the_set_share_head_for_the_targets() {
        let text = |aim: f32| {
            format!(
                "[camera]\norigin = [0.0, 1.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
                 [materials]\nm = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
                 chrome = {{ type = \"mirror\" }}\n\
                 [[shapes]]\ntype = \"sphere\"\ncenter = [2.0, 0.0, 0.0]\nradius = 0.5\nmaterial = \"chrome\"\n\
                 [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, -1.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\nmaterial = \"m\"\n\
                 [[lights]]\ntype = \"point\"\nposition = [-2.0, 0.0, 0.0]\npower = [1.0, 1.0, 1.0]\n\
                 [render.vcm]\naim = {aim}\n"
            )
        };
        for share in [0.2f32, 0.6, 0.0] {
            let s =
                crate::scene::load::load_scene_str(&text(share), "aim.toml", std::path::Path::new("."), &[]).unwrap();
            let aim = Aim::new(&s, None);
            // A sphere of radius 0.5 seen from 4: 1 − cos θ = 1 − √(1 − 1/64), half of which is the share.
            let caught = 0.5 * (1.0 - (1.0f32 - 1.0 / 64.0).sqrt());
            assert!((aim.caught_by_targets() - caught).abs() < 0.003, "caught {}", aim.caught_by_targets());
            let mut rng = Rng::new(3, 0, 0);
            let n = 100_000;
            let heading = (0..n)
                .filter(|_| {
                    let u_dir = rng.next_2d();
                    let e = s.lights.emit(&s, 0.5, [0.5, 0.5], u_dir).unwrap();
                    let e = if aim.is_active() { aim.apply(&s.lights, e, rng.next_f32(), u_dir).unwrap() } else { e };
                    aim.cone_pdf(e.origin, e.ray.d) > 0.0
                })
                .count() as f32
                / n as f32;
            let expected = share.max(caught);
            assert!(
                (heading - expected).abs() < 0.01,
                "aim {share}: {heading} head for the target, expected {expected}"
            );
        }
    }
}

#[cfg(test)]
mod radius_tests {
    use super::*;
    use crate::accel::Accel;

    /// The first merge radius spreads one iteration's light vertices over every surface they are kept
    /// on: a diffuse quad (area 1) and a rough gold one (area 4), not the mirror or the thin pane
    /// (delta BSDFs, area 4 each). Counting only the surfaces that hold photons (the diffuse quad) gave
    /// a radius √5 too small here, and, in a scene with no diffuse surface, the cap (a twentieth of the
    /// diagonal) where a handful of light vertices were meant: merging then blurred rough glass seen in
    /// a mirror by 10% in an 8×8 block (a random scene's, against PT).
    #[test]
    fn the_first_merge_radius_counts_every_surface_light_vertices_are_kept_on() {
        let quad = |x: f32, y: f32, side: f32, m: &str| {
            format!(
                "[[shapes]]\ntype = \"quad\"\ncorner = [{x}, {y}, 0.0]\nedge_u = [{side}, 0.0, 0.0]\n\
                 edge_v = [0.0, {side}, 0.0]\nmaterial = \"{m}\"\n"
            )
        };
        let text = format!(
            "[camera]\norigin = [0.0, 0.0, 6.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [32, 32]\n\
             [materials]\nwhite = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
             gold = {{ type = \"conductor\", preset = \"Au\", roughness = 0.3 }}\n\
             chrome = {{ type = \"mirror\" }}\npane = {{ type = \"thin_dielectric\", ior = 1.5 }}\n\
             {}{}{}{}[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 3.0]\npower = [1.0, 1.0, 1.0]\n",
            quad(-3.0, -3.0, 1.0, "white"),
            quad(-2.0, 0.5, 2.0, "gold"),
            quad(0.5, -2.5, 2.0, "chrome"),
            quad(0.5, 0.5, 2.0, "pane"),
        );
        let s = crate::scene::load::load_scene_str(&text, "r1.toml", std::path::Path::new("."), &[]).unwrap();
        let expected = (4.0 * 5.0 / (PI * 1024.0)).sqrt();
        let r1 = initial_radius(&s);
        assert!(expected < 0.05 * s.diagonal(), "the cap must not decide this test");
        assert!((r1 / expected - 1.0).abs() < 1e-4, "r1 {r1}, expected {expected}");
    }

    /// The merge radius follows the light's density: under a small light 0.5 above a dark floor the
    /// light vertices at 1.0 off-centre are 25 times sparser than below it (irradiance ∝ cos⁴), so the
    /// radius for the same count of them is about 5 times larger there (4.3 once the centre's cell,
    /// 0.28 wide, averages over its falling density; 3.98 measured; 3.5× to 6.5× required, a radius
    /// set as for points in a volume would give 25^⅓ = 2.9×); it never exceeds the scene-wide radius.
    #[test]
    fn the_merge_radius_shrinks_where_light_is_dense() {
        let text = "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [128, 128]\n\
                    [materials]\nblack = { type = \"diffuse\", reflectance = [0.0, 0.0, 0.0] }\n\
                    [[shapes]]\ntype = \"quad\"\ncorner = [-4.0, 0.0, 4.0]\nedge_u = [8.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -8.0]\nmaterial = \"black\"\n\
                    [[shapes]]\ntype = \"quad\"\ncorner = [-0.02, 0.5, -0.02]\nedge_u = [0.04, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.04]\n\
                    material = \"black\"\nemission = [100.0, 100.0, 100.0]\n";
        let s = crate::scene::load::load_scene_str(text, "radius.toml", std::path::Path::new("."), &[]).unwrap();
        let a = Accel::new(&s).unwrap();
        let setup = Setup::new(&s, &a, VcmOptions::vcm(), None);
        let r1 = setup.radius.r1();
        let (centre, off) = (setup.radius.at(Vec3::new(0.01, 0.0, 0.01)), setup.radius.at(Vec3::new(1.0, 0.0, 0.0)));
        let ratio = off / centre;
        assert!((3.5..6.5).contains(&ratio), "radius {centre} below the light, {off} at 1.0 ({ratio}×), r1 {r1}");
        assert!(off <= r1 && centre <= r1, "{centre}, {off} above r1 {r1}");
    }
}
