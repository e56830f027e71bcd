//! Bidirectional path tracing and vertex connection and merging (Georgiev, Křivánek, Davidovič &
//! Slusallek 2012), with the recursive MIS quantities of Georgiev's "Implementing Vertex Connection and
//! Merging" (dVCM, dVC, dVM carried along each subpath).
//!
//! One iteration i traces one light subpath per pixel (the photon tracer's emission, `Lights::emit`),
//! connects each of its non-delta vertices to the camera (light tracing, splatted onto the film),
//! stores them in the project's k-d tree, then traces one camera subpath per pixel that, at every
//! non-delta vertex, takes a light sample (s = 1), connects to every vertex of "its" light subpath
//! (s ≥ 2) and merges with the stored light vertices within r_i = r_1 · i^((α−1)/2) (vertex merging);
//! emission found by the camera subpath (s = 0) is weighted as well. Without merging this is BDPT;
//! without connections a progressive photon mapper (merging at every camera vertex).
//!
//! MIS pdfs use geometric normals for the area ↔ solid-angle conversions (true densities), Russian
//! roulette is left out of them (every strategy ignores it alike, so the weights still sum to one).
//! An iteration is a pure function of (scene, seed, i): iterations can be averaged in any grouping,
//! and light-tracing splats are summed in a fixed order (per chunk of light paths, chunks in order),
//! so images are the same bits on any thread count.
use super::direct::{sample_light, unoccluded};
use super::Counters;
use crate::accel::{interact, Interaction, Tracer};
use crate::color::Rgb;
use crate::film::Image;
use crate::math::sampling::russian_roulette;
use crate::math::{max_component, offset_ray_origin, Ray, Rng};
use crate::photon::kdtree::{KdTree, KnnResult};
use crate::scene::light::LightKind;
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
    d_vcm: f32,
    d_vc: f32,
    d_vm: f32,
    /// Product of the refractions' 1/η² (camera subpaths), divided out for Russian roulette.
    radiance_scale: f32,
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
    d_vm: f32,
}

impl LightVertex {
    /// The adjoint BSDF at the vertex scattering the arriving light towards `dir`, times |cos θ| there
    /// (Veach's shading-normal correction included).
    fn f_to(&self, dir: Vec3) -> Rgb {
        self.mat.eval(self.wo, dir, self.si.ns) * (self.si.shading_correction(self.wo, dir) * dir.dot(self.si.ns).abs())
    }
}

/// What merging reads of a light vertex, stored in the k-d tree in tree order (spatially coherent, a
/// fraction of a `LightVertex`'s size).
#[derive(Clone, Copy, Debug, Default)]
struct MergeVertex {
    wo: Vec3,
    beta: Rgb,
    len: u32,
    d_vcm: f32,
    d_vm: f32,
}

/// Constants of one iteration.
struct Iteration {
    max_len: u32,
    n_paths: f32,
    mis_vm: f32,
    mis_vc: f32,
    vm_norm: f32,
    r2: f32,
    opts: VcmOptions,
}

impl Iteration {
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
/// scene's diffuse surfaces, capped at `render.gather.max_radius` of the diagonal.
pub fn initial_radius(scene: &Scene) -> f32 {
    let p = &scene.render.progressive;
    if p.radius > 0.0 {
        return p.radius;
    }
    super::ppm::radius_for_density(scene, 4.0, light_paths(scene, VcmOptions::of_scene(scene)) as f64)
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

/// Iteration `i` (1-based) of BDPT/VCM at merge radius `r`.
pub fn iterate(scene: &Scene, tracer: &dyn Tracer, opts: VcmOptions, i: u32, r: f32) -> IterationOutput {
    let cam = &scene.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let pixels = w * h;
    let n = light_paths(scene, opts);
    let r = r.max(1e-7);
    let eta = PI * r * r * n as f32;
    let it = Iteration {
        max_len: scene.render.max_depth.saturating_add(1),
        n_paths: n as f32,
        mis_vm: if opts.merge { eta } else { 0.0 },
        mis_vc: if opts.connect { 1.0 / eta } else { 0.0 },
        vm_norm: 1.0 / eta,
        r2: r * r,
        opts,
    };
    let v = Vcm { scene, tracer, it };
    let (sampler, seed) = (scene.render.sampler, scene.render.seed);
    // Light subpaths, in fixed chunks.
    let chunks: Vec<LightChunk> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|ci| {
            let (mut verts, mut ends, mut splats, mut c) = (Vec::new(), Vec::new(), Vec::new(), Counters::default());
            for k in ci * CHUNK..((ci + 1) * CHUNK).min(n) {
                let mut rng = Rng::camera(sampler, seed ^ 0x7C3A_0000_0000_0000, k as u64, (i - 1) as u64);
                v.light_path(&mut rng, &mut verts, &mut splats, &mut c);
                ends.push(verts.len() as u32);
            }
            (verts, ends, splats, c)
        })
        .collect();
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
    let tree = if opts.merge && !verts.is_empty() {
        let pts: Vec<([f32; 3], MergeVertex)> = verts
            .iter()
            .map(|lv| {
                let m = MergeVertex { wo: lv.wo, beta: lv.beta, len: lv.len, d_vcm: lv.d_vcm, d_vm: lv.d_vm };
                (lv.si.p.to_array(), m)
            })
            .collect();
        KdTree::build(pts).ok()
    } else {
        None
    };
    let light = LightPaths { verts: &verts, ends: &ends, tree: tree.as_ref() };
    let camera: Vec<(Rgb, Counters)> = (0..pixels)
        .into_par_iter()
        .map(|k| {
            let mut rng = Rng::camera(sampler, seed, k as u64, (i - 1) as u64);
            let mut c = Counters::default();
            let [u, uv] = rng.next_2d();
            let l = v.camera_path(((k % w) as f32 + u, (k / w) as f32 + uv), k, &light, &mut rng, &mut c);
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
    tree: Option<&'a KdTree<MergeVertex>>,
}

struct Vcm<'a> {
    scene: &'a Scene,
    tracer: &'a dyn Tracer,
    it: Iteration,
}

/// Cosine of `w` to the geometric normal (the area ↔ solid-angle conversions of the MIS pdfs).
fn cos_g(si: &SurfaceHit, w: Vec3) -> f32 {
    w.dot(si.ng).abs()
}

impl Vcm<'_> {
    /// Traces one light subpath: stores its non-delta vertices (when connecting or merging) and
    /// connects each to the camera (light tracing).
    fn light_path(&self, rng: &mut Rng, verts: &mut Vec<LightVertex>, splats: &mut Vec<(u32, Rgb)>, c: &mut Counters) {
        let scene = self.scene;
        let lights = &scene.lights;
        let it = &self.it;
        let Some(e) = lights.emit(scene, rng.next_f32(), rng.next_2d(), rng.next_2d()) else {
            return;
        };
        if e.pdf_emit <= 0.0 || e.phi == Rgb::ZERO {
            return;
        }
        let kind = &lights.list[e.light];
        let finite = !kind.at_infinity();
        let delta = matches!(kind, LightKind::Point { .. } | LightKind::Distant { .. });
        // dVCM = p_direct / p_emit [tech. rep. (31)]; for lights at finite distance the direct density
        // (per unit area of the light) depends on the first hit (cone sampling of spheres), so it is
        // taken there.
        let d_vcm = if finite {
            0.0
        } else {
            lights.direct_pdf_area(scene, e.light, e.origin + e.ray.d, e.origin, Vec3::ZERO) / e.pdf_emit
        };
        let d_vc = if delta { 0.0 } else { (if finite { e.cos } else { 1.0 }) / e.pdf_emit };
        let mut sp =
            SubPath { beta: e.phi, len: 1, specular: true, d_vcm, d_vc, d_vm: d_vc * it.mis_vc, radiance_scale: 1.0 };
        let beta0 = max_component(e.phi).max(1e-30);
        let mut ray = e.ray;
        loop {
            c.rays += 1;
            let Some(Interaction { hit, si, wo }) = interact(scene, self.tracer, &ray) else {
                break;
            };
            let dist2 = (hit.t * ray.d.length()).powi(2);
            if sp.len == 1 && finite {
                sp.d_vcm = lights.direct_pdf_area(scene, e.light, si.p, e.origin, e.normal) / e.pdf_emit;
            }
            if sp.len > 1 || finite {
                sp.d_vcm *= dist2;
            }
            let cos_in = cos_g(&si, wo);
            if cos_in <= 0.0 {
                break;
            }
            sp.d_vcm /= cos_in;
            sp.d_vc /= cos_in;
            sp.d_vm /= cos_in;
            let mat = scene.bsdf(&si, wo);
            if !mat.is_delta() {
                let lv = LightVertex {
                    si,
                    wo,
                    mat,
                    beta: sp.beta,
                    len: sp.len,
                    d_vcm: sp.d_vcm,
                    d_vc: sp.d_vc,
                    d_vm: sp.d_vm,
                };
                if it.opts.connect || it.opts.strategy.is_some() {
                    self.connect_to_camera(&lv, splats, c);
                }
                if it.opts.connect || it.opts.merge {
                    verts.push(lv);
                }
            }
            if sp.len + 2 > it.max_len {
                break;
            }
            let Some(next) = self.scatter(&mut sp, &si, wo, &mat, rng, TransportMode::Importance, beta0) else {
                break;
            };
            ray = next;
            sp.len += 1;
        }
    }

    /// Samples the BSDF at the subpath's end and updates its throughput and MIS quantities [tech. rep.
    /// (34)-(36), (53)-(55)]; Russian roulette after `render.rr_depth` edges. None ends the subpath.
    #[allow(clippy::too_many_arguments)]
    fn scatter(
        &self,
        sp: &mut SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
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
            sp.d_vm *= cos_out;
        } else {
            let rev = mat.pdf(bs.wi, wo, si.ns);
            let f = cos_out / bs.pdf;
            sp.d_vc = f * (sp.d_vc * rev + sp.d_vcm + it.mis_vm);
            sp.d_vm = f * (sp.d_vm * rev + sp.d_vcm * it.mis_vc + 1.0);
            sp.d_vcm = 1.0 / bs.pdf;
            sp.specular = false;
        }
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

    /// Light tracing (t = 1): the light vertex seen by the camera, splatted where it lands on the film.
    fn connect_to_camera(&self, lv: &LightVertex, splats: &mut Vec<(u32, Rgb)>, c: &mut Counters) {
        let it = &self.it;
        let (s, t) = (lv.len + 1, 1);
        if lv.len + 1 > it.max_len {
            return;
        }
        let cam = &self.scene.camera;
        let Some((px, py)) = cam.project(lv.si.p) else {
            return;
        };
        let to_cam = cam.origin - lv.si.p;
        let dist2 = to_cam.length_squared();
        let dir = to_cam / dist2.sqrt();
        if dir.dot(lv.si.ng) * lv.wo.dot(lv.si.ng) <= 0.0 {
            return;
        }
        let f = lv.f_to(dir);
        if f == Rgb::ZERO {
            return;
        }
        // Density (per unit area at the vertex) with which a camera subpath reaches it.
        let pdf_dir = cam.pixel_pdf_dir(-dir);
        let camera_pdf_a = pdf_dir * cos_g(&lv.si, dir) / dist2;
        let w = it.weight(s, t, || {
            let rev = lv.mat.pdf(dir, lv.wo, lv.si.ns);
            let w_light = camera_pdf_a / it.n_paths * (it.mis_vm + lv.d_vcm + lv.d_vc * rev);
            1.0 / (w_light + 1.0)
        });
        if w == 0.0 {
            return;
        }
        let val = lv.beta * f * (w * pdf_dir / dist2 / it.n_paths);
        c.rays += 1;
        if self.tracer.occluded(&lv.si.spawn_to(cam.origin)) {
            return;
        }
        let pixel = (py as u32).min(cam.height - 1) * cam.width + (px as u32).min(cam.width - 1);
        splats.push((pixel, val));
    }

    /// One camera subpath through film position `film`, paired with light subpath `k`.
    fn camera_path(&self, film: (f32, f32), k: usize, light: &LightPaths, rng: &mut Rng, c: &mut Counters) -> Rgb {
        let scene = self.scene;
        let it = &self.it;
        let cam = &scene.camera;
        let mut ray = cam.ray(film.0, film.1);
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
            d_vm: 0.0,
            radiance_scale: 1.0,
        };
        let mut prev = cam.origin;
        let mut l = Rgb::ZERO;
        let lv_range = light.ends[k] as usize..light.ends[k + 1] as usize;
        loop {
            c.rays += 1;
            let Some(Interaction { hit, si, wo }) = interact(scene, self.tracer, &ray) else {
                l += sp.beta * self.env_hit(&sp, ray.d);
                break;
            };
            let dist2 = (hit.t * ray.d.length()).powi(2);
            let cos_in = cos_g(&si, wo);
            if cos_in <= 0.0 {
                break;
            }
            sp.d_vcm *= dist2 / cos_in;
            sp.d_vc /= cos_in;
            sp.d_vm /= cos_in;
            let le = scene.emitted(&si, wo);
            if le != Rgb::ZERO {
                l += sp.beta * le * self.emitter_hit(&sp, &si, wo, prev);
            }
            if sp.len >= it.max_len {
                break;
            }
            let mat = scene.bsdf(&si, wo);
            if !mat.is_delta() {
                if it.opts.connect || it.opts.strategy.is_some() {
                    l += sp.beta * self.light_sample(&sp, &si, wo, &mat, rng, c);
                    for lv in &light.verts[lv_range.clone()] {
                        if lv.len + 1 + sp.len > it.max_len {
                            break;
                        }
                        l += sp.beta * lv.beta * self.connect(&sp, &si, wo, &mat, lv, c);
                    }
                }
                if let Some(tree) = light.tree {
                    l += sp.beta * self.merge(&sp, &si, wo, &mat, tree);
                }
            }
            prev = si.p;
            let Some(next) = self.scatter(&mut sp, &si, wo, &mat, rng, TransportMode::Radiance, 1.0) else {
                break;
            };
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
            Some((direct_a, lights.emit_pdf(self.scene, i, wo.dot(si.ng), -wo)))
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

    /// Next-event estimation (s = 1) at a non-delta camera vertex [tech. rep. (44)-(45)].
    fn light_sample(
        &self,
        sp: &SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
        rng: &mut Rng,
        c: &mut Counters,
    ) -> Rgb {
        let it = &self.it;
        let Some((ls, f)) = sample_light(self.scene, si, wo, mat, rng, false) else {
            return Rgb::ZERO;
        };
        let w = it.weight(1, sp.len + 1, || {
            let dir_pdf = if ls.delta { 0.0 } else { mat.pdf(wo, ls.wi, si.ns) };
            let rev_pdf = mat.pdf(ls.wi, wo, si.ns);
            let w_light = dir_pdf / ls.pdf;
            let w_camera = ls.emit_ratio * cos_g(si, ls.wi) * (it.mis_vm + sp.d_vcm + sp.d_vc * rev_pdf);
            1.0 / (w_light + 1.0 + w_camera)
        });
        if w == 0.0 || !unoccluded(self.tracer, si, &ls, c) {
            return Rgb::ZERO;
        }
        f * ls.li * (w / ls.pdf)
    }

    /// Connects a camera vertex to a light vertex (s ≥ 2, t ≥ 2) [tech. rep. (40)-(41)]; the result is
    /// to be multiplied by both subpaths' throughputs.
    fn connect(
        &self,
        sp: &SubPath,
        si: &SurfaceHit,
        wo: Vec3,
        mat: &Material,
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
        // Both ends reflect: the connection must leave each on the side it was reached from.
        if dir.dot(si.ng) * wo.dot(si.ng) <= 0.0 || (-dir).dot(lv.si.ng) * lv.wo.dot(lv.si.ng) <= 0.0 {
            return Rgb::ZERO;
        }
        let f_cam = mat.eval(wo, dir, si.ns) * dir.dot(si.ns).abs();
        if f_cam == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let f_light = lv.f_to(-dir);
        if f_light == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let w = it.weight(lv.len + 1, sp.len + 1, || {
            let cam_dir_a = mat.pdf(wo, dir, si.ns) * cos_g(&lv.si, dir) / dist2;
            let cam_rev = mat.pdf(dir, wo, si.ns);
            let light_dir_a = lv.mat.pdf(lv.wo, -dir, lv.si.ns) * cos_g(si, dir) / dist2;
            let light_rev = lv.mat.pdf(-dir, lv.wo, lv.si.ns);
            let w_light = cam_dir_a * (it.mis_vm + lv.d_vcm + lv.d_vc * light_rev);
            let w_camera = light_dir_a * (it.mis_vm + sp.d_vcm + sp.d_vc * cam_rev);
            1.0 / (w_light + 1.0 + w_camera)
        });
        if w == 0.0 {
            return Rgb::ZERO;
        }
        c.rays += 1;
        let target = offset_ray_origin(lv.si.p, lv.si.ng, -dir, lv.si.scale);
        if self.tracer.occluded(&si.spawn_to(target)) {
            return Rgb::ZERO;
        }
        f_cam * f_light * (w / dist2)
    }

    /// Vertex merging at a non-delta camera vertex [tech. rep. (37)-(39)]: the light vertices within
    /// the iteration's radius, as a density estimate over the disc; to be multiplied by the camera
    /// throughput.
    fn merge(&self, sp: &SubPath, si: &SurfaceHit, wo: Vec3, mat: &Material, tree: &KdTree<MergeVertex>) -> Rgb {
        let it = &self.it;
        if it.opts.strategy.is_some() {
            return Rgb::ZERO;
        }
        let mut sum = Rgb::ZERO;
        SCRATCH.with(|s| {
            let mut s = s.borrow_mut();
            tree.within_res(si.p.to_array(), it.r2, &mut s);
            for &(_, ti) in s.items() {
                let lv = tree.item(ti);
                if lv.len + sp.len > it.max_len || lv.wo.dot(si.ng) * wo.dot(si.ng) <= 0.0 {
                    continue;
                }
                let f = mat.eval(wo, lv.wo, si.ns);
                if f == Rgb::ZERO {
                    continue;
                }
                let w_light = lv.d_vcm * it.mis_vc + lv.d_vm * mat.pdf(wo, lv.wo, si.ns);
                let w_camera = sp.d_vcm * it.mis_vc + sp.d_vm * mat.pdf(lv.wo, wo, si.ns);
                sum += f * lv.beta * (1.0 / (w_light + 1.0 + w_camera));
            }
        });
        sum * it.vm_norm
    }
}
