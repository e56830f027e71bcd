//! Lights: point and spot lights, emissive shapes (triangles of any mesh, analytic spheres) and an environment,
//! chosen by power. Sampling for next-event estimation (solid-angle pdfs, cone sampling for spheres) and
//! for photon emission.
use crate::color::{luminance, Rgb};
use crate::math::{offset_ray_origin, sampling, sphere_root, Frame, Ray};
use crate::scene::env::EnvLight;
use crate::scene::{Geometry, Scene};
use glam::Vec3;
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub enum LightKind {
    /// A point light: `intensity` in W/sr (on the axis, for a spot), the same in every direction unless
    /// `spot` limits it to a cone.
    Point {
        position: Vec3,
        intensity: Rgb,
        spot: Option<Spot>,
    },
    Triangle {
        shape: u32,
        prim: u32,
    },
    Sphere {
        shape: u32,
    },
    /// The environment (`Lights::env`): light from infinitely far away.
    Env,
    /// A distant (directional) light: parallel rays travelling along `dir` (unit), `irradiance` on a
    /// surface facing them.
    Distant {
        dir: Vec3,
        irradiance: Rgb,
    },
}

/// A spot light's cone, as Mitsuba 3's `spot`: full intensity within `beam` (radians) of the axis,
/// falling linearly in angle to zero at `cutoff`; emission is drawn uniformly over the cutoff cone.
/// Or, with `frustum`, a projector (Mitsuba 3's `projector`): a pinhole lighting the rectangle of
/// half-widths `frustum` (tangents of the half-angles along `frame`) of the plane at unit distance
/// along the axis, its irradiance there the same everywhere (the intensity on the axis times 1/cos³ θ
/// towards an angle θ off it); emission is drawn uniformly over that rectangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spot {
    /// Unit direction the light shines along.
    pub axis: Vec3,
    pub cutoff: f32,
    pub beam: f32,
    /// 1 − cos(cutoff), computed stably for narrow cones: the cone's solid angle over 2π.
    one_minus: f32,
    /// A texture projected along the spot (Mitsuba's `texture`, a slide in front of the bulb): an index
    /// into the scene's textures as the loader gives it, into `Lights::spot_textures` once built.
    pub texture: Option<u32>,
    /// The spot's own x and y axes (unit, across the axis): where the texture's u and v run.
    pub frame: [Vec3; 2],
    /// A projector's half-widths at unit distance, along `frame[0]` and `frame[1]`; None for a cone.
    pub frustum: Option<[f32; 2]>,
}

impl Spot {
    /// A cone around `axis` (any length but zero); `beam` ≤ `cutoff` ≤ π, in radians.
    pub fn new(axis: Vec3, cutoff: f32, beam: f32) -> Spot {
        let half = (0.5 * cutoff).sin();
        Spot {
            axis: axis.normalize(),
            cutoff,
            beam,
            one_minus: 2.0 * half * half,
            texture: None,
            frame: [Vec3::ZERO; 2],
            frustum: None,
        }
    }

    /// A projector shining along `axis` (any length but zero) over the rectangle of half-widths `tan`
    /// (both > 0) at unit distance, its first side across `up` × axis (`up` off the axis), its second
    /// towards `up`, as Mitsuba's `lookat` places a projector's local x and y. Its `cutoff` is the
    /// half-angle of the cone around the rectangle's corners (what the planner reads).
    pub fn projector(axis: Vec3, up: Vec3, tan: [f32; 2]) -> Spot {
        let cutoff = tan[0].hypot(tan[1]).atan();
        let cone = Spot::new(axis, cutoff, cutoff);
        let x = up.cross(cone.axis).normalize();
        Spot { frame: [x, cone.axis.cross(x)], frustum: Some(tan), ..cone }
    }

    /// Direction `w` (any length) where it meets the plane at unit distance along the axis, in the
    /// spot's frame: (x, y), and the cosine of its angle to the axis; None behind the light.
    fn on_plane(&self, w: Vec3) -> Option<(f32, f32, f32)> {
        let z = w.dot(self.axis);
        (z > 0.0).then(|| (w.dot(self.frame[0]) / z, w.dot(self.frame[1]) / z, z / w.length()))
    }

    /// Whether direction `w` (any length) passes through a projector's rectangle, and its cosine to the
    /// axis. The edges are widened by a few ulps, so a direction `sample` draws, once rounded, stays in.
    fn in_frustum(&self, w: Vec3, [tx, ty]: [f32; 2]) -> Option<f32> {
        let (x, y, cos) = self.on_plane(w)?;
        let slack = 1.0 + 4.0 * f32::EPSILON;
        (x.abs() <= tx * slack && y.abs() <= ty * slack).then_some(cos)
    }

    /// This spot with texture `t` projected along it, its v running towards `up` (any vector off the
    /// axis) and its u along up × axis, as Mitsuba's `lookat` places a spot's local x and y.
    pub fn with_texture(self, t: u32, up: Vec3) -> Spot {
        let x = up.cross(self.axis).normalize();
        Spot { texture: Some(t), frame: [x, self.axis.cross(x)], ..self }
    }

    /// The texture coordinates of direction `w` (any length, inside the cone): Mitsuba's, 0.5 + 0.5 ·
    /// (the direction's x and y over its z, in the spot's frame) / tan(cutoff), so that the texture's
    /// square spans the cutoff cone's base.
    /// A projector's runs the other way, as Mitsuba's: 0.5 − 0.5 · x / (z · its half-width) on each side.
    pub fn uv(&self, w: Vec3) -> glam::Vec2 {
        if let Some([tx, ty]) = self.frustum {
            let (x, y, _) = self.on_plane(w).unwrap_or((0.0, 0.0, 1.0));
            return glam::Vec2::new(0.5 - 0.5 * x / tx, 0.5 - 0.5 * y / ty);
        }
        let z = w.dot(self.axis) * self.cutoff.tan();
        glam::Vec2::new(0.5 + 0.5 * w.dot(self.frame[0]) / z, 0.5 + 0.5 * w.dot(self.frame[1]) / z)
    }

    /// Angle between the axis and direction `w` (any length), by atan2: exact for narrow cones, where the f32
    /// cosine of a direction a hundredth of a degree off the axis is 1.
    pub fn angle(&self, w: Vec3) -> f32 {
        self.axis.cross(w).length().atan2(self.axis.dot(w))
    }

    /// Intensity towards unit direction `w` over the intensity on the axis (a projector's 1/cos³ θ
    /// within its rectangle).
    pub fn falloff(&self, w: Vec3) -> f32 {
        if let Some(tan) = self.frustum {
            return self.in_frustum(w, tan).map_or(0.0, |c| 1.0 / (c * c * c));
        }
        let angle = self.angle(w);
        if angle >= self.cutoff {
            0.0
        } else if angle <= self.beam {
            1.0
        } else {
            ((self.cutoff - angle) / (self.cutoff - self.beam)).clamp(0.0, 1.0)
        }
    }

    /// ∫ falloff dω over the sphere: 2π [1 − (sin cutoff − sin beam)/(cutoff − beam)], written as
    /// 2π [1 − cos m · sin h / h] (m, h the mean and half-difference of the angles, in f64 against the
    /// cancellation of narrow cones) so that a hard edge (h → 0) gives the cone's 2π (1 − cos cutoff).
    /// A projector's: the rectangle's area, 4 tan_x tan_y (each unit of it seen through dω = cos³ θ dA).
    pub fn solid_angle(&self) -> f32 {
        if let Some([tx, ty]) = self.frustum {
            return 4.0 * tx * ty;
        }
        let (m, h) = (0.5 * (self.cutoff as f64 + self.beam as f64), 0.5 * (self.cutoff as f64 - self.beam as f64));
        let sinc = if h > 1e-6 { h.sin() / h } else { 1.0 - h * h / 6.0 };
        (2.0 * std::f64::consts::PI * (1.0 - m.cos() * sinc)) as f32
    }

    /// Solid-angle density of an emitted direction `w` (uniform over the cutoff cone; for a projector
    /// uniform over its rectangle: 1 / (4 tan_x tan_y cos³ θ)).
    pub fn pdf(&self, w: Vec3) -> f32 {
        if let Some(tan) = self.frustum {
            return self.in_frustum(w, tan).map_or(0.0, |c| 1.0 / (self.solid_angle() * c * c * c));
        }
        if self.angle(w) < self.cutoff {
            self.cone_density()
        } else {
            0.0
        }
    }

    /// The density of every direction `sample` draws for a cone: one over the cone's solid angle.
    fn cone_density(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus)
    }

    /// A direction uniform over the cutoff cone, or over a projector's rectangle.
    pub fn sample(&self, u: [f32; 2]) -> Vec3 {
        if let Some([tx, ty]) = self.frustum {
            let [x, y] = [tx * (2.0 * u[0] - 1.0), ty * (2.0 * u[1] - 1.0)];
            return (self.frame[0] * x + self.frame[1] * y + self.axis).normalize();
        }
        Frame::from_normal(self.axis).to_world(sampling::uniform_cone(u, self.one_minus)).normalize()
    }

    /// The density of a direction `sample` drew: the cone's (the same everywhere in it, also for a
    /// direction rounded onto its edge), or a projector's `pdf`.
    fn sample_density(&self, w: Vec3) -> f32 {
        match self.frustum {
            Some(_) => self.pdf(w),
            None => self.cone_density(),
        }
    }
}

/// A point light as the loader gives it: position, intensity (W/sr; on the axis for a spot), cone.
#[derive(Clone, Copy, Debug)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Rgb,
    pub spot: Option<Spot>,
}

impl PointLight {
    /// Emitted power: 4π I, or I ∫ falloff dω for a spot.
    pub fn power(&self) -> Rgb {
        self.intensity * self.spot.map_or(4.0 * PI, |s| s.solid_angle())
    }
}

impl LightKind {
    /// An environment or a distant light: light from infinitely far away (`Lights::sample_infinite`).
    pub fn at_infinity(&self) -> bool {
        matches!(self, LightKind::Env | LightKind::Distant { .. })
    }

    /// A point (or spot) or distant light: a delta in position or direction, which no sampled
    /// direction finds.
    pub fn is_delta(&self) -> bool {
        matches!(self, LightKind::Point { .. } | LightKind::Distant { .. })
    }

    /// The emissive shape this light belongs to (None for point lights).
    pub fn shape(&self) -> Option<u32> {
        match self {
            LightKind::Point { .. } | LightKind::Env | LightKind::Distant { .. } => None,
            LightKind::Triangle { shape, .. } | LightKind::Sphere { shape } => Some(*shape),
        }
    }
}

/// The share of triangle `pi`'s emitted directions to draw behind its face, for a mesh that emits in
/// front of its interpolated vertex normals on either side of the face (`Shape::emits_behind`): about
/// the share of its light that leaves behind the face, (1 − cos θ)/2 for the vertex normal θ furthest
/// from the face's (θ²/4 for a small lean, as the cosine-weighted sliver behind a face whose normal leans
/// θ; a half where it lies in the face's plane), kept within [1/64, 63/64] so that either side is drawn
/// (the share only steers sampling: each direction's density carries it).
fn back_share(m: &crate::scene::mesh::TriMesh, pi: usize) -> f32 {
    let [a, b, c] = m.triangle(pi);
    let ng = (b - a).cross(c - a).normalize_or_zero();
    let Some(ns) = &m.normals else { return 0.0 };
    let lowest = m.indices[pi].iter().map(|&v| ns[v as usize].normalize_or_zero().dot(ng)).fold(1.0f32, f32::min);
    (0.5 * (1.0 - lowest)).clamp(1.0f32 / 64.0, 63.0 / 64.0)
}

/// All lights with a power-proportional selection distribution.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub list: Vec<LightKind>,
    /// Emitted power (W per channel) of each light.
    pub power: Vec<Rgb>,
    pub cdf: Vec<f32>,
    /// The distribution next-event estimation draws from: `cdf` with the planner's excluded lights at
    /// zero (MIS weights follow it, so leaving a light out stays unbiased), and the lights at infinity
    /// (sky, suns) weighing together as much as the lights in the scene together (`balance_infinite`).
    pub nee_cdf: Vec<f32>,
    /// For each shape, the index in `list` of its first emitter (triangle `prim` is at offset + prim).
    pub shape_offset: Vec<Option<u32>>,
    /// The environment light and its index in `list`.
    pub env: Option<(EnvLight, usize)>,
    /// Centre and radius of the scene's bounding sphere (where light from infinity enters).
    pub sphere: (Vec3, f32),
    /// Index range [start, end) of the point and spot lights in `list` (`build` lists them together).
    pub(crate) points: (usize, usize),
    /// The textures spots project (`Spot::texture`), copied from the scene's.
    spot_textures: Vec<crate::scene::Texture>,
    /// For each light, the share of its emitted directions drawn behind its face (`side_share`): 0 but
    /// for the triangles of a mesh that `Shape::emits_behind`; empty where no light does.
    back_share: Vec<f32>,
}

/// A point on a light seen from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: Vec3,
    pub dist: f32,
    /// The sampled point on the light, moved off the emitter's surface towards the reference point
    /// (robust offset): a shadow ray ends here and cannot hit the emitter itself.
    pub p: Vec3,
    /// Incident radiance (area lights) or intensity / d² (point lights).
    pub li: Rgb,
    /// Solid-angle pdf including the light choice (for point lights: the choice probability).
    pub pdf: f32,
    pub delta: bool,
    /// For bidirectional MIS: the density with which photon emission (`Lights::emit`) reaches the
    /// reference point, per unit area there, over the density with which this sampler picks the light
    /// point (per unit area of the light; the choice alone for point and distant lights, per solid
    /// angle for the environment), divided by the cosine at the reference point.
    pub emit_ratio: f32,
    /// The light sampled (index in `Lights::list`).
    pub light: usize,
    /// The emitter's unit normal at the sampled point (zero for point lights and lights at infinity).
    pub normal: Vec3,
}

/// A photon leaving a light: origin, direction, and power Φ/(p_choice · pdf) before division by n_emitted,
/// with what bidirectional MIS needs to know about how it was drawn.
#[derive(Clone, Copy, Debug)]
pub struct EmittedRay {
    pub ray: Ray,
    pub phi: Rgb,
    /// `phi` without a spot's projected texture (`Lights::tint`; `phi` itself for every other light):
    /// what a change of direction rescales before the texture is read in the new one.
    pub untinted: Rgb,
    /// The light it left (index in `Lights::list`).
    pub light: usize,
    /// Density of this ray, light choice included: area × solid angle (cosine lobe) for surfaces, solid
    /// angle for point lights, disc area 1/(πR²) × direction density for lights at infinity.
    pub pdf_emit: f32,
    /// Cosine between the emitter's normal and the ray (1 for point lights and lights at infinity).
    pub cos: f32,
    /// The point on the light it left and the light's unit normal there (zero for point lights and
    /// lights at infinity).
    pub origin: Vec3,
    pub normal: Vec3,
    /// Scale of the emitter around `origin`, for offsetting a ray that leaves it in another direction.
    pub size: f32,
}

impl Lights {
    /// Every light of the scene: point and spot lights, distant lights (direction of travel,
    /// irradiance), emissive shapes, and an environment fitted around the scene's bounds.
    pub fn build(scene: &Scene, points: &[PointLight], distant: &[(Vec3, Rgb)], env: Option<EnvLight>) -> Lights {
        let (lo, hi) = scene.bounds;
        let sphere = ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-3));
        let mut l = Lights { shape_offset: vec![None; scene.shapes.len()], sphere, ..Default::default() };
        // Light from infinity: the power that crosses the bounding sphere, πR² ∫L dω or E πR².
        let disc = PI * sphere.1 * sphere.1;
        if let Some(e) = env {
            l.list.push(LightKind::Env);
            l.power.push(e.radiance_integral() * disc);
            l.env = Some((e, 0));
        }
        for &(dir, irradiance) in distant {
            l.list.push(LightKind::Distant { dir: dir.normalize(), irradiance });
            l.power.push(irradiance * disc);
        }
        let first_point = l.list.len();
        for p in points {
            let mut spot = p.spot;
            let mut power = p.power();
            if let Some(s) = &mut spot {
                if let Some(t) = s.texture {
                    // Weighed by the slide's mean (a heuristic for the choice of light: what each photon
                    // and light sample carries is the texture's value in its own direction).
                    let tex = scene.textures[t as usize].clone();
                    power *= tex.mean();
                    s.texture = Some(l.spot_textures.len() as u32);
                    l.spot_textures.push(tex);
                }
            }
            l.list.push(LightKind::Point { position: p.position, intensity: p.intensity, spot });
            l.power.push(power);
        }
        l.points = (first_point, l.list.len());
        for (si, shape) in scene.shapes.iter().enumerate() {
            if shape.emission == Rgb::ZERO {
                continue;
            }
            l.shape_offset[si] = Some(l.list.len() as u32);
            // A textured emitter weighs by its texture's mean (each triangle's own share of it would
            // only steer the choice: the photons and light samples carry the radiance where they land).
            let emission = match shape.emission_texture {
                None => shape.emission,
                Some(t) => shape.emission * scene.textures[t as usize].mean(),
            };
            match &shape.geometry {
                Geometry::Mesh(m) => {
                    if shape.emits_behind() {
                        l.back_share.resize(l.list.len(), 0.0);
                        l.back_share.extend((0..m.indices.len()).map(|pi| back_share(m, pi)));
                    }
                    for pi in 0..m.indices.len() {
                        l.list.push(LightKind::Triangle { shape: si as u32, prim: pi as u32 });
                        l.power.push(emission * PI * m.area(pi));
                    }
                }
                Geometry::Sphere { radius, .. } => {
                    l.list.push(LightKind::Sphere { shape: si as u32 });
                    l.power.push(emission * PI * 4.0 * PI * radius * radius);
                }
            }
        }
        let mut acc = 0.0;
        l.cdf = l
            .power
            .iter()
            .map(|p| {
                acc += luminance(*p).max(0.0);
                acc
            })
            .collect();
        l.nee_cdf = l.cdf.clone();
        l.balance_infinite();
        if !l.back_share.is_empty() {
            l.back_share.resize(l.list.len(), 0.0);
        }
        l
    }

    /// The share of light `i`'s emitted directions drawn on the side of its face that a direction at
    /// cosine `cos` to its normal lies on: 1 in front and 0 behind for every light but the triangles of
    /// a mesh that `Shape::emits_behind`, whose share behind is theirs (`back_share`); 0 along the face.
    pub fn side_share(&self, i: usize, cos: f32) -> f32 {
        let behind = self.back_share.get(i).copied().unwrap_or(0.0);
        if cos > 0.0 {
            1.0 - behind
        } else if cos < 0.0 {
            behind
        } else {
            0.0
        }
    }

    /// Gives next-event estimation's lights at infinity (listed first, before `points`) together the
    /// weight of the scene's own lights together, each keeping its share by power, when there are both.
    /// By power alone a sky weighs its radiance times the disc of the scene's bounding sphere, which
    /// grows with the scene's size and not with what lights a point: under a sky 0.65 around a 6 m
    /// floor, a 0.5 × 0.08 m lamp of radiance 6 got 0.6% of the light samples, and the floor beside it
    /// was lit by BSDF samples that seldom find it. Half and half is what Mitsuba's uniform choice
    /// gives one sky and one lamp, and pbrt-v4's light BVH each infinite light: a light never drops
    /// below half of its power share. The sky's MIS weights and pdfs follow `nee_cdf`, so this is
    /// unbiased; photon emission keeps `cdf`.
    fn balance_infinite(&mut self) {
        let infinite = self.points.0;
        if infinite == 0 || infinite == self.nee_cdf.len() {
            return;
        }
        let at_infinity = self.nee_cdf[infinite - 1];
        let in_scene = self.nee_cdf[self.nee_cdf.len() - 1] - at_infinity;
        if !(at_infinity > 0.0 && in_scene > 0.0) {
            return;
        }
        let scale = in_scene / at_infinity;
        for c in &mut self.nee_cdf[..infinite] {
            *c *= scale;
        }
        for c in &mut self.nee_cdf[infinite..] {
            *c = *c - at_infinity + in_scene;
        }
    }

    /// Leaves the lights for which `keep(i)` is false out of next-event estimation.
    pub fn restrict_nee(&mut self, keep: impl Fn(usize) -> bool) {
        let mut acc = 0.0;
        let mut prev = 0.0;
        self.nee_cdf = self
            .cdf
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                if keep(i) {
                    acc += c - prev;
                }
                prev = c;
                acc
            })
            .collect();
        self.balance_infinite();
    }

    pub fn is_empty(&self) -> bool {
        self.cdf.last().is_none_or(|&t| t <= 0.0)
    }

    /// A direction towards light `i` if it lies at infinity (environment, distant light): the unit
    /// direction towards the light, the radiance (environment) or irradiance (distant) arriving along
    /// it, and its solid-angle pdf (1 for the delta of a distant light).
    pub fn sample_infinite(&self, i: usize, u: [f32; 2]) -> Option<InfiniteSample> {
        match &self.list[i] {
            LightKind::Env => {
                let (wi, li, pdf) = self.env.as_ref()?.0.sample(u)?;
                Some(InfiniteSample { wi, li, pdf, delta: false })
            }
            LightKind::Distant { dir, irradiance } => {
                Some(InfiniteSample { wi: -*dir, li: *irradiance, pdf: 1.0, delta: true })
            }
            _ => None,
        }
    }

    /// Distance from `x` to a point beyond the scene's bounding sphere (where rays from infinity start).
    pub fn beyond_scene(&self, x: Vec3) -> f32 {
        2.0 * (self.sphere.1 + (x - self.sphere.0).length())
    }

    /// How far a shadow ray from `x` towards the sky or a distant light runs: 2·max(R, |x − c|) for the
    /// scene's bounding sphere (c, R), as Mitsuba 3 runs them (its `envmap` and `directional` emitters'
    /// samples lie that far from `x`; pbrt-v4's 2R), which ends it outside the sphere. A medium round
    /// `x` dims the ray along that length: in a medium that fills the space round the scene (a
    /// sensor's, a shape's exterior that nothing encloses) the sky's light reaches a point through that
    /// much of it by light sampling, MIS-weighted against the phase function's or BSDF's sample, which
    /// never gets out of the medium. (That light depends on the light sampling's density, which for an
    /// `envmap` is not Mitsuba's: README, "Not done".)
    pub fn sky_distance(&self, x: Vec3) -> f32 {
        2.0 * self.sphere.1.max((x - self.sphere.0).length())
    }

    /// Radiance of the environment towards `dir` (zero without one).
    pub fn env_radiance(&self, dir: Vec3) -> Rgb {
        self.env.as_ref().map_or(Rgb::ZERO, |(e, _)| e.radiance(dir))
    }

    /// Solid-angle pdf that next-event estimation picks direction `dir` on the environment.
    pub fn env_pdf(&self, dir: Vec3) -> f32 {
        self.env.as_ref().map_or(0.0, |(e, i)| self.choice_pdf(*i) * e.pdf(dir))
    }

    pub fn total_power(&self) -> Rgb {
        self.power.iter().copied().sum()
    }

    /// Probability that next-event estimation chooses light `i`.
    pub fn choice_pdf(&self, i: usize) -> f32 {
        cdf_pdf(&self.nee_cdf, i)
    }

    /// Samples a light point for direct light at `x`: from the next-event distribution (`nee`, with
    /// the planner's left-out lights at zero: only for estimators whose MIS gives those lights to BSDF
    /// sampling) or from every light by power.
    pub fn sample(&self, scene: &Scene, x: Vec3, u_sel: f32, u: [f32; 2], nee: bool) -> Option<LightSample> {
        let cdf = if nee { &self.nee_cdf } else { &self.cdf };
        if cdf.last().is_none_or(|&t| t <= 0.0) {
            return None;
        }
        let (mut i, mut p_sel) = sampling::sample_cdf(cdf, u_sel);
        if (self.points.0..self.points.1).contains(&i) {
            (i, p_sel) = self.pick_point(cdf, x, u_sel)?;
        }
        match &self.list[i] {
            LightKind::Point { position, intensity, .. } => {
                let d = *position - x;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if dist.is_nan() || dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let falloff = self.falloff(i, -wi);
                if falloff <= 0.0 {
                    return None;
                }
                let dir_pdf = self.direction_density(i, Vec3::ZERO, -wi);
                Some(LightSample {
                    wi,
                    dist,
                    p: *position,
                    li: *intensity * self.tint(i, -wi) * (falloff / dist2),
                    pdf: p_sel,
                    delta: true,
                    // Emission picks this light by power, this sampler with p_sel.
                    emit_ratio: dir_pdf / dist2 * (self.power_pdf(i) / p_sel),
                    light: i,
                    normal: Vec3::ZERO,
                })
            }
            LightKind::Sphere { shape } if !self.by_area(scene, i) => {
                let s = &scene.shapes[*shape as usize];
                let Geometry::Sphere { center, radius, frame, .. } = s.geometry else {
                    return None;
                };
                let (wi, one_minus) = towards_sphere(x, center, radius, u)?;
                let dist = near_side(x, wi, center, radius);
                let y = x + wi * dist;
                let p = offset_ray_origin(y, (y - center).normalize_or_zero(), -wi, radius);
                let pdf = p_sel / (2.0 * PI * one_minus);
                // Emission reaches x's surface with p_sel/(4πr²) · cos_y/π · cos_x/d² per unit area; this
                // sampler picks y with pdf · cos_y/d² per unit area of the sphere.
                let cos_light = (-wi.dot((y - center) / radius)).max(0.0);
                let emit_ratio = p_sel / (4.0 * PI * radius * radius) / (PI * pdf);
                let emit_ratio = if cos_light > 0.0 { emit_ratio } else { 0.0 };
                let normal = (y - center) / radius;
                let li = scene.radiance_at(*shape, || crate::scene::sphere_uv_at(frame, normal));
                Some(LightSample { wi, dist, p, li, pdf, delta: false, emit_ratio, light: i, normal })
            }
            // A triangle, or a sphere that emits inward (seen from inside, where no cone is visible):
            // a point drawn by area.
            LightKind::Triangle { .. } | LightKind::Sphere { .. } => {
                let lp = self.sample_point(scene, i, u)?;
                let d = lp.p - x;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                let wi = d / dist;
                // A mesh that emits behind its faces is sampled on both sides (`emits`).
                let cos_l = -wi.dot(lp.n);
                if !lp.pdf_area.is_finite() || !self.emits(scene, i, lp.p, lp.n, -wi) {
                    return None;
                }
                let pdf = p_sel * lp.pdf_area * dist2 / cos_l.abs();
                let p = offset_ray_origin(lp.p, lp.n, -wi, lp.size);
                let emit_ratio = self.direction_density(i, lp.n, -wi) / dist2;
                Some(LightSample { wi, dist, p, li: lp.le, pdf, delta: false, emit_ratio, light: i, normal: lp.n })
            }
            LightKind::Env | LightKind::Distant { .. } => {
                let s = self.sample_infinite(i, u)?;
                // A shadow ray to a point outside the scene's bounding sphere (`sky_distance`).
                let dist = self.sky_distance(x);
                Some(LightSample {
                    wi: s.wi,
                    dist,
                    p: x + s.wi * dist,
                    li: s.li,
                    pdf: p_sel * s.pdf,
                    delta: s.delta,
                    emit_ratio: 1.0 / (PI * self.sphere.1 * self.sphere.1),
                    light: i,
                    normal: Vec3::ZERO,
                })
            }
        }
    }

    /// What point or spot light `j` sends towards `x` unoccluded, by its brightest channel: I·falloff/d².
    fn point_weight(&self, j: usize, x: Vec3) -> f32 {
        let LightKind::Point { position, intensity, .. } = &self.list[j] else { return 0.0 };
        let d = *position - x;
        let d2 = d.length_squared();
        if d2.is_nan() || d2 <= 0.0 {
            return 0.0;
        }
        let w = intensity.max_element() * self.falloff(j, -d / d2.sqrt()) / d2;
        if w.is_finite() {
            w
        } else {
            0.0
        }
    }

    /// The point or spot light `sample` takes at `x` once its draw `u_sel` over `cdf` fell among the
    /// point lights, and the probability of that choice. The point lights keep their share of `cdf`
    /// together (so every other light keeps the probability the MIS weights use), and within it each is
    /// taken in proportion to `point_weight` at x: a spot whose cone misses x, or a far dim light, is
    /// not drawn in place of one that lights x. None: no point light reaches x.
    fn pick_point(&self, cdf: &[f32], x: Vec3, u_sel: f32) -> Option<(usize, f32)> {
        let total = cdf[cdf.len() - 1];
        let (lo, size, sum) = self.point_group(cdf, x);
        let share = size / total;
        if !(share > 0.0 && sum > 0.0 && sum.is_finite()) {
            return None;
        }
        // The draw's place within the group's share, reused to pick within it.
        let u = ((u_sel * total - lo) / size).clamp(0.0, 1.0);
        let target = u * sum;
        let mut acc = 0.0;
        let mut last = None;
        for j in self.points.0..self.points.1 {
            let w = self.point_weight(j, x);
            if w <= 0.0 {
                continue;
            }
            acc += w;
            last = Some((j, w));
            if target < acc {
                break;
            }
        }
        last.map(|(j, w)| (j, share * w / sum))
    }

    /// The point lights' part of `cdf` at x: where their share starts, its size, and the sum of their
    /// `point_weight`s (what `pick_point` draws from and `point_pdf` reports).
    fn point_group(&self, cdf: &[f32], x: Vec3) -> (f32, f32, f32) {
        let (a, b) = self.points;
        let lo = if a == 0 { 0.0 } else { cdf[a - 1] };
        (lo, cdf[b - 1] - lo, (a..b).map(|j| self.point_weight(j, x)).sum())
    }

    /// Probability that `sample` over `cdf` takes point light `j` at x (`pick_point`).
    fn point_pdf(&self, cdf: &[f32], j: usize, x: Vec3) -> f32 {
        let (_, size, sum) = self.point_group(cdf, x);
        if sum > 0.0 && sum.is_finite() {
            size / cdf[cdf.len() - 1] * self.point_weight(j, x) / sum
        } else {
            0.0
        }
    }

    /// Solid-angle pdf that `sample` from `x` produces the point `y` (normal `n`) on the given emitter.
    pub fn pdf(&self, scene: &Scene, shape: u32, prim: u32, x: Vec3, y: Vec3, n: Vec3) -> f32 {
        let Some(off) = self.shape_offset[shape as usize] else {
            return 0.0;
        };
        // The light drawn by area (a triangle, a sphere whose normals face inward: `by_area`), and its area.
        let (i, area) = match &scene.shapes[shape as usize].geometry {
            Geometry::Mesh(m) => ((off + prim) as usize, m.area(prim as usize)),
            Geometry::Sphere { inward: true, .. } => (off as usize, scene.shapes[shape as usize].area()),
            Geometry::Sphere { center, radius, .. } => {
                return visible_cone(*radius, (*center - x).length_squared())
                    .map_or(0.0, |one_minus| self.choice_pdf(off as usize) / (2.0 * PI * one_minus))
            }
        };
        let d = y - x;
        let dist2 = d.length_squared();
        let cos_l = -d.normalize().dot(n);
        if self.side_share(i, cos_l) <= 0.0 || area == 0.0 {
            return 0.0;
        }
        self.choice_pdf(i) * dist2 / (cos_l.abs() * area)
    }

    /// A point on light `i`: position, normal (zero for point lights), area pdf (1 for point lights),
    /// and emitted radiance (area lights) or intensity (point lights; on the axis for a spot: times
    /// `falloff` towards a direction). None for the environment.
    pub fn sample_point(&self, scene: &Scene, i: usize, u: [f32; 2]) -> Option<LightPoint> {
        Some(match &self.list[i] {
            LightKind::Env | LightKind::Distant { .. } => return None,
            LightKind::Point { position, intensity, .. } => {
                LightPoint { p: *position, n: Vec3::ZERO, size: 0.0, pdf_area: 1.0, le: *intensity }
            }
            LightKind::Triangle { shape, prim } => {
                let s = &scene.shapes[*shape as usize];
                let sp = s.geometry.point(*prim as usize, u);
                let le = scene.radiance_at(*shape, || s.uv_of(*prim as usize, &sp));
                LightPoint { p: sp.p, n: sp.n, size: sp.size, pdf_area: 1.0 / sp.area, le }
            }
            LightKind::Sphere { shape } => {
                let s = &scene.shapes[*shape as usize];
                let sp = s.geometry.point(0, u);
                let le = scene.radiance_at(*shape, || s.uv_of(0, &sp));
                LightPoint { p: sp.p, n: sp.n, size: sp.size, pdf_area: 1.0 / sp.area, le }
            }
        })
    }

    /// Whether the point `p` (unit normal `n`) that `sample_point` drew on light `i` emits towards `w`: a
    /// surface on the side of its face that it draws directions on (`side_share`: in front, and behind
    /// too for a mesh that `Shape::emits_behind`), and as far as its shading normal says
    /// (`Scene::emits_towards`: a mesh that `emit_by_shading_normal` emits only in front of its
    /// interpolated normal); point lights and lights at infinity towards every direction.
    pub fn emits(&self, scene: &Scene, i: usize, p: Vec3, n: Vec3, w: Vec3) -> bool {
        match self.list[i] {
            LightKind::Triangle { shape, prim } => {
                self.side_share(i, n.dot(w)) > 0.0 && scene.emits_towards(shape, prim, p, w)
            }
            LightKind::Sphere { .. } => self.side_share(i, n.dot(w)) > 0.0,
            _ => true,
        }
    }

    /// Whether an emitted ray carries light where it leaves (`emits`): `emit` draws its direction over
    /// the face's front, and a caller that turns it (VCM's aim) asks this of the direction it keeps. A ray
    /// that does not counts as a photon shot with no power.
    pub fn leaves(&self, scene: &Scene, e: &EmittedRay) -> bool {
        self.emits(scene, e.light, e.origin, e.normal, e.ray.d)
    }

    /// Emits a photon: light chosen by power, position uniform on it, direction uniform (point; over its
    /// cone for a spot) or cosine. A mesh that `emit_by_shading_normal` may draw a direction its
    /// shading normal turns away from: ask `leaves` of the direction kept.
    /// The returned power is Φ_light / p_choice; divide by the number of photons shot.
    pub fn emit(&self, scene: &Scene, u_sel: f32, u_pos: [f32; 2], u_dir: [f32; 2]) -> Option<EmittedRay> {
        if self.is_empty() {
            return None;
        }
        let (i, p_sel) = sampling::sample_cdf(&self.cdf, u_sel);
        if let Some(s) = self.sample_infinite(i, u_dir) {
            // From a uniform point on the disc of radius R facing the light, 2R out from the centre: each
            // photon carries L πR²/pdf (E πR² for a distant light).
            let (c, r) = self.sphere;
            let f = Frame::from_normal(s.wi);
            let d = sampling::concentric_disk(u_pos);
            let o = c + s.wi * (2.0 * r) + (f.s * d[0] + f.t * d[1]) * r;
            let disc = PI * r * r;
            let phi = s.li * (disc / s.pdf) / p_sel;
            return Some(EmittedRay {
                ray: Ray::new(o, -s.wi),
                phi,
                untinted: phi,
                light: i,
                pdf_emit: p_sel * s.pdf / disc,
                cos: 1.0,
                origin: o,
                normal: Vec3::ZERO,
                size: r,
            });
        }
        if let LightKind::Point { position, intensity, spot: Some(s) } = &self.list[i] {
            // A spot: uniform over its cone (or a projector's rectangle), each photon carrying
            // I·falloff / (pdf · p_choice) (`emission_over_density`, which VCM's aim rescales by). Inside
            // by construction (a direction rounded onto a cone's edge has zero falloff; a projector's
            // edges are widened by a few ulps).
            let d = s.sample(u_dir);
            let pdf = s.sample_density(d);
            let untinted = *intensity * (self.emission_over_density(i, Vec3::ZERO, d) / p_sel);
            return Some(EmittedRay {
                ray: Ray::new(*position, d),
                phi: untinted * self.tint(i, d),
                untinted,
                light: i,
                pdf_emit: p_sel * pdf,
                cos: 1.0,
                origin: *position,
                normal: Vec3::ZERO,
                size: 0.0,
            });
        }
        let lp = self.sample_point(scene, i, u_pos)?;
        // A textured emitter's photon carries the radiance where it leaves: L(x)·π / (pdf_area · p_choice).
        let phi = match self.list[i] {
            LightKind::Triangle { shape, .. } | LightKind::Sphere { shape }
                if scene.shapes[shape as usize].emission_texture.is_some() =>
            {
                lp.le * (PI / (lp.pdf_area * p_sel))
            }
            _ => self.power[i] / p_sel,
        };
        // A point light is no surface: its photons start exactly at it.
        let (ray, pdf_emit, cos, phi) = if lp.n == Vec3::ZERO {
            (Ray::new(lp.p, sampling::uniform_sphere(u_dir)), p_sel / (4.0 * PI), 1.0, phi)
        } else {
            // The cosine lobe in front of the face, or (for a mesh that emits behind its faces, with
            // the triangle's share behind, the first draw reused) the one behind it.
            let (behind, u0) = sampling::split(u_dir[0], self.side_share(i, -1.0));
            let (u_dir, n) = ([u0, u_dir[1]], if behind { -lp.n } else { lp.n });
            let d = sampling::cosine_around(n, u_dir);
            let cos = d.dot(n);
            let share = self.side_share(i, d.dot(lp.n));
            if share <= 0.0 {
                return None;
            }
            let ray = Ray::new(offset_ray_origin(lp.p, lp.n, d, lp.size), d);
            (ray, p_sel * lp.pdf_area * share * cos / PI, cos, phi / share)
        };
        Some(EmittedRay { ray, phi, untinted: phi, light: i, pdf_emit, cos, origin: lp.p, normal: lp.n, size: lp.size })
    }

    /// Probability that a light is chosen by power (photon emission, and next-event estimation over
    /// every light).
    pub fn power_pdf(&self, i: usize) -> f32 {
        cdf_pdf(&self.cdf, i)
    }

    /// Density with which `sample` over every light (`nee = false`) from `x` picks point `y` (unit
    /// normal `n`) of light `i`, per unit area of the light; for point lights the probability that it
    /// takes that light at x (`pick_point`), for distant lights the choice probability alone, for the
    /// environment per unit solid angle of the direction `y − x`.
    pub fn direct_pdf_area(&self, scene: &Scene, i: usize, x: Vec3, y: Vec3, n: Vec3) -> f32 {
        let p_sel = self.power_pdf(i);
        match &self.list[i] {
            LightKind::Point { .. } => self.point_pdf(&self.cdf, i, x),
            LightKind::Distant { .. } => p_sel,
            LightKind::Env => self.env.as_ref().map_or(0.0, |(e, _)| p_sel * e.pdf((y - x).normalize())),
            LightKind::Triangle { .. } => {
                let a = self.area_of(scene, i);
                if a > 0.0 {
                    p_sel / a
                } else {
                    0.0
                }
            }
            LightKind::Sphere { shape } => {
                let Geometry::Sphere { center, radius, inward, .. } = scene.shapes[*shape as usize].geometry else {
                    return 0.0;
                };
                if inward {
                    // Drawn by area (`by_area`).
                    return p_sel / scene.shapes[*shape as usize].area();
                }
                let Some(one_minus) = visible_cone(radius, (center - x).length_squared()) else {
                    return 0.0;
                };
                let d = y - x;
                let cos_y = (-d.normalize().dot(n)).max(0.0);
                p_sel / (2.0 * PI * one_minus) * cos_y / d.length_squared()
            }
        }
    }

    /// Density with which `emit` produces a ray leaving light `i` at cosine `cos` to its normal (area ×
    /// solid angle; for the environment, disc area × solid angle of direction `dir` of travel).
    pub fn emit_pdf(&self, scene: &Scene, i: usize, cos: f32, dir: Vec3) -> f32 {
        let p_sel = self.power_pdf(i);
        let disc = PI * self.sphere.1 * self.sphere.1;
        match &self.list[i] {
            LightKind::Point { .. } => p_sel * self.direction_density(i, Vec3::ZERO, dir),
            LightKind::Distant { .. } => p_sel / disc,
            LightKind::Env => self.env.as_ref().map_or(0.0, |(e, _)| p_sel * e.pdf(-dir) / disc),
            LightKind::Triangle { .. } | LightKind::Sphere { .. } => {
                let a = self.area_of(scene, i);
                if a <= 0.0 {
                    return 0.0;
                }
                p_sel / a * self.side_share(i, cos) * cos.abs() / PI
            }
        }
    }

    /// Light `i`'s own density of emitted direction `w` (unit) from a point of unit normal `n`: uniform
    /// over the sphere for a point light, over the cone for a spot, the cosine lobe for a surface.
    pub fn direction_density(&self, i: usize, n: Vec3, w: Vec3) -> f32 {
        match &self.list[i] {
            LightKind::Point { spot: Some(s), .. } => s.pdf(w),
            LightKind::Point { spot: None, .. } => 1.0 / (4.0 * PI),
            _ => {
                let cos = w.dot(n);
                self.side_share(i, cos) * cos.abs() / PI
            }
        }
    }

    /// Light `i`'s emission towards unit direction `w` over its own density of drawing `w`
    /// (`direction_density`): for a spot its falloff over its cone's uniform density, for a projector
    /// its 1/cos³ over its density, also as 1/cos³ (its rectangle's area within it); for every other
    /// light a constant, 1 (a surface's cosine over the cosine lobe, a point light's uniform over
    /// uniform), as only its ratios between directions matter there, over the share of directions drawn
    /// on `w`'s side of a surface's face (normal `n`, `side_share`); 0 where the light does not emit.
    pub fn emission_over_density(&self, i: usize, n: Vec3, w: Vec3) -> f32 {
        match &self.list[i] {
            LightKind::Point { spot: Some(s), .. } => {
                let pdf = s.pdf(w);
                if pdf > 0.0 {
                    s.falloff(w) / pdf
                } else {
                    0.0
                }
            }
            LightKind::Triangle { .. } | LightKind::Sphere { .. } => {
                let share = self.side_share(i, w.dot(n));
                if share > 0.0 {
                    1.0 / share
                } else {
                    0.0
                }
            }
            _ => 1.0,
        }
    }

    /// The colour a spot's projected texture gives its light towards direction `w` (inside its cone):
    /// the texture at `Spot::uv`; white for every other light.
    pub fn tint(&self, i: usize, w: Vec3) -> Rgb {
        match &self.list[i] {
            LightKind::Point { spot: Some(s @ Spot { texture: Some(t), .. }), .. } => {
                self.spot_textures[*t as usize].eval(s.uv(w))
            }
            _ => Rgb::ONE,
        }
    }

    /// Intensity of light `i` towards unit direction `w` over its intensity on the axis: a spot's
    /// falloff, 1 for every other light (a spot's texture apart: `tint`).
    pub fn falloff(&self, i: usize, w: Vec3) -> f32 {
        match &self.list[i] {
            LightKind::Point { spot: Some(s), .. } => s.falloff(w),
            _ => 1.0,
        }
    }

    /// Area of emitter `i` (a triangle or a whole sphere; 0 for the other lights).
    fn area_of(&self, scene: &Scene, i: usize) -> f32 {
        match &self.list[i] {
            LightKind::Triangle { shape, prim } => match &scene.shapes[*shape as usize].geometry {
                Geometry::Mesh(m) => m.area(*prim as usize),
                Geometry::Sphere { .. } => 0.0,
            },
            LightKind::Sphere { shape } => scene.shapes[*shape as usize].area(),
            _ => 0.0,
        }
    }

    /// Whether `sample` draws light `i`'s points by area: a triangle, or a sphere whose normals face
    /// inward (its light reaches only points inside it, from which no cone of it is visible); the
    /// other spheres are sampled over the cone they fill.
    fn by_area(&self, scene: &Scene, i: usize) -> bool {
        match &self.list[i] {
            LightKind::Triangle { .. } => true,
            LightKind::Sphere { shape } => {
                matches!(scene.shapes[*shape as usize].geometry, Geometry::Sphere { inward: true, .. })
            }
            _ => false,
        }
    }

    /// Index in `list` of the emitter a hit on (`shape`, `prim`) belongs to.
    pub fn index_of(&self, scene: &Scene, shape: u32, prim: u32) -> Option<usize> {
        let off = self.shape_offset[shape as usize]? as usize;
        Some(match scene.shapes[shape as usize].geometry {
            Geometry::Mesh(_) => off + prim as usize,
            Geometry::Sphere { .. } => off,
        })
    }
}

/// A direction towards a light at infinity (`Lights::sample_infinite`).
#[derive(Clone, Copy, Debug)]
pub struct InfiniteSample {
    pub wi: Vec3,
    pub li: Rgb,
    pub pdf: f32,
    pub delta: bool,
}

/// A sampled point on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    pub n: Vec3,
    /// Size of the emitting primitive (0 for point lights), for ray offsets.
    pub size: f32,
    pub pdf_area: f32,
    pub le: Rgb,
}

/// Probability of entry `i` of an unnormalised running sum `cdf` (0 if it sums to nothing).
fn cdf_pdf(cdf: &[f32], i: usize) -> f32 {
    let total = cdf[cdf.len() - 1];
    if total <= 0.0 {
        return 0.0;
    }
    let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
    (cdf[i] - lo) / total
}

/// 1 − cos θmax of the cone a sphere of `radius` subtends from distance² `dc2`, if the point is outside
/// the sphere (with a margin) and the cone is not empty: the cone next-event estimation samples.
pub fn visible_cone(radius: f32, dc2: f32) -> Option<f32> {
    if dc2 <= radius * radius * 1.0001 {
        return None;
    }
    let one_minus = cone_of(radius, dc2);
    (one_minus > 0.0).then_some(one_minus)
}

/// A direction from `x` drawn (from `u`) uniformly in the cone the sphere (`center`, `radius`) subtends,
/// and the cone's 1 − cos θmax (`visible_cone`; the direction's density is 1 / (2π · that)); None from
/// a point on or in the sphere.
pub fn towards_sphere(x: Vec3, center: Vec3, radius: f32, u: [f32; 2]) -> Option<(Vec3, f32)> {
    let d = center - x;
    let dc2 = d.length_squared();
    let one_minus = visible_cone(radius, dc2)?;
    Some((Frame::from_normal(d / dc2.sqrt()).to_world(sampling::uniform_cone(u, one_minus)).normalize(), one_minus))
}

/// The distance from `x` along `w`, a direction of `towards_sphere`'s cone, to the sphere's near side. A
/// direction rounded just past the silhouette still belongs to the cone: then the point of closest
/// approach, which lies on the sphere to rounding.
pub fn near_side(x: Vec3, w: Vec3, center: Vec3, radius: f32) -> f32 {
    sphere_root(x.to_array(), w.to_array(), center.to_array(), radius, 0.0, f32::INFINITY)
        .unwrap_or_else(|| (center - x).dot(w).max(0.0))
}

/// 1 − cos θmax of the cone a sphere of `radius` subtends from distance² `dc2`, computed as
/// s²/(1 + √(1 − s²)) so a far, small sphere keeps its (tiny, positive) solid angle.
fn cone_of(radius: f32, dc2: f32) -> f32 {
    let s2 = (radius * radius / dc2).min(1.0);
    let c = (1.0 - s2).max(0.0).sqrt();
    s2 / (1.0 + c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// The falloff Mitsuba 3.9's `spot` evaluates (`sample_direction` weights at a 20° cutoff and a 10°
    /// beam, read off the installed Mitsuba): linear in angle between the beam and the cutoff.
    #[test]
    fn spot_falloff_is_mitsubas() {
        let s = Spot::new(Vec3::new(0.0, 0.0, 2.0), 20f32.to_radians(), 10f32.to_radians());
        let mitsuba = [(0.0, 1.0), (9.9, 1.0), (11.0, 0.9), (12.5, 0.75), (15.0, 0.5), (17.5, 0.25), (19.0, 0.1)];
        for (deg, want) in mitsuba.into_iter().chain([(19.9f32, 0.01f32), (20.0, 0.0), (21.0, 0.0), (120.0, 0.0)]) {
            let t = f32::to_radians(deg);
            let got = s.falloff(Vec3::new(t.sin(), 0.0, t.cos()));
            assert!((got - want).abs() < 2e-4, "{deg}°: {got} vs {want}");
        }
        // A narrow spot (cutoff 0.05°, beam 0.02°) keeps its linear ramp to 1e-3: the acos of an f32
        // cosine this close to 1 is off by up to 0.01°, a third of the ramp.
        let narrow = Spot::new(Vec3::Z, 0.05f32.to_radians(), 0.02f32.to_radians());
        for k in 0..=30 {
            let deg = 0.02 + 0.001 * k as f32;
            let t = deg.to_radians();
            let got = narrow.falloff(Vec3::new(t.sin(), 0.0, t.cos()));
            let want = ((0.05 - deg) / 0.03).clamp(0.0, 1.0);
            assert!((got - want).abs() < 1e-3, "narrow spot at {deg}°: {got} vs {want}");
        }
    }

    /// A projector as Mitsuba 3.9.1's `projector` reads it: fov 60° along x of a 2:1 image, its frame
    /// that of lookat(0 → +z, up +y). The uv of points Mitsuba's `sample_direction` gave (its `ds.uv`),
    /// and its weight there, π · irradiance / (z² cos θ): the falloff 1/cos³ θ over the squared distance.
    #[test]
    fn projector_uv_and_falloff_are_mitsubas() {
        let t = 30f32.to_radians().tan();
        let p = Spot::projector(Vec3::Z, Vec3::Y, [t, t / 2.0]);
        let cases = [
            ([0.0, 0.0, 1.0], [0.5, 0.5]),
            ([0.5, 0.0, 1.0], [0.0669873, 0.5]),
            ([0.0, 0.2, 1.0], [0.5, 0.15359]),
            ([-0.5, -0.2, 1.0], [0.933013, 0.84641]),
            ([0.5, 0.0, 2.0], [0.283494, 0.5]),
        ];
        for (x, want) in cases {
            let x = Vec3::from(x);
            let uv = p.uv(x);
            assert!((uv - glam::Vec2::from(want)).abs().max_element() < 1e-5, "{x}: uv {uv} against {want:?}");
            let w = x.normalize();
            let (z, cos) = (x.z, w.z);
            let got = p.falloff(w) / x.length_squared();
            let want = 1.0 / (z * z * cos);
            assert!((got / want - 1.0).abs() < 1e-5, "{x}: {got} against {want}");
        }
        // Outside its rectangle (beyond the image's edge along y, and behind it): nothing.
        for x in [Vec3::new(0.0, 0.3, 1.0), Vec3::new(0.0, 0.0, -1.0)] {
            assert_eq!((p.falloff(x.normalize()), p.pdf(x)), (0.0, 0.0), "{x}");
        }
    }

    /// A projector's ∫ falloff dω (its `solid_angle`, the rectangle's area) and ∫ pdf dω (1) by a
    /// midpoint sum over the sphere, and `sample`'s directions against the pdf: the share of draws
    /// through the middle half of the rectangle's width must be the pdf's integral over those
    /// directions (½: uniform over the rectangle, not over the solid angle, which would give more).
    #[test]
    fn projector_integrals_and_sampling_agree() {
        let p = Spot::projector(Vec3::new(0.3, -1.0, 0.2), Vec3::new(1.0, 0.2, 0.0), [0.9, 0.35]);
        let middle = |w: Vec3| (w.dot(p.frame[0]) / w.dot(p.axis)).abs() < 0.45;
        let (n_t, n_p) = (2000, 4000);
        let (mut fall, mut dens, mut dens_mid) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..n_t {
            let th = (i as f64 + 0.5) / n_t as f64 * std::f64::consts::PI;
            for j in 0..n_p {
                let ph = (j as f64 + 0.5) / n_p as f64 * 2.0 * std::f64::consts::PI;
                let local = Vec3::new((th.sin() * ph.cos()) as f32, (th.sin() * ph.sin()) as f32, th.cos() as f32);
                let w = Frame::from_normal(p.axis).to_world(local);
                let dw = th.sin() * (std::f64::consts::PI / n_t as f64) * (2.0 * std::f64::consts::PI / n_p as f64);
                fall += p.falloff(w) as f64 * dw;
                dens += p.pdf(w) as f64 * dw;
                if middle(w) {
                    dens_mid += p.pdf(w) as f64 * dw;
                }
            }
        }
        assert!((fall / p.solid_angle() as f64 - 1.0).abs() < 2e-3, "∫ falloff {fall} against {}", p.solid_angle());
        assert!((dens - 1.0).abs() < 2e-3, "∫ pdf {dens}");
        let mut rng = crate::math::rng::Rng::new(7, 0, 0);
        let (n, mut mid) = (200_000, 0usize);
        for _ in 0..n {
            let d = p.sample(rng.next_2d());
            assert!(p.pdf(d) > 0.0 && p.falloff(d) > 0.0, "{d} drawn outside");
            mid += middle(d) as usize;
        }
        let share = mid as f64 / n as f64;
        let sigma = (0.25 / n as f64).sqrt();
        assert!((share - dens_mid).abs() < 5.0 * sigma + 2e-3, "{share} of the draws, ∫ pdf there {dens_mid}");
        assert!((dens_mid - 0.5).abs() < 2e-3, "∫ pdf over the middle {dens_mid}");
    }

    /// The closed form of ∫ falloff dω against a midpoint sum over θ, for soft, hard, wide (beyond a
    /// hemisphere) and narrow cones; a spot's power and its photons' mean power both follow from it.
    #[test]
    fn spot_solid_angle_is_the_integral_of_its_falloff() {
        for (cutoff, beam) in [(20.0f32, 15.0f32), (30.0, 30.0), (100.0, 60.0), (180.0, 90.0), (0.5, 0.2), (45.0, 0.0)]
        {
            let s = Spot::new(Vec3::Y, cutoff.to_radians(), beam.to_radians());
            let n = 200_000;
            let dt = std::f64::consts::PI / n as f64;
            let sum: f64 = (0..n)
                .map(|k| {
                    let t = (k as f64 + 0.5) * dt;
                    let w = Vec3::new(t.sin() as f32, t.cos() as f32, 0.0);
                    s.falloff(w) as f64 * t.sin() * dt
                })
                .sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            let got = s.solid_angle() as f64;
            assert!((got / sum - 1.0).abs() < 1e-3, "cutoff {cutoff}°, beam {beam}°: {got} vs {sum}");
        }
    }

    /// Next-event estimation takes the point lights together with their share of the power, and among
    /// them each in proportion to what it sends to the point: at a floor point outside one spot's cone
    /// that spot is never taken, the others are taken as often as the probability reported with them
    /// (which `direct_pdf_area` reports too), and the quad light keeps its share of the power.
    #[test]
    fn point_lights_are_taken_by_what_they_send_to_the_point() {
        let text = "[camera]\norigin = [0.0, 2.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n\
            [materials]\nm = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
            [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"m\"\n\
            [[lights]]\ntype = \"spot\"\nposition = [1.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [50.0, 50.0, 50.0]\ncutoff_angle = 10.0\n\
            [[lights]]\ntype = \"spot\"\nposition = [-1.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [5.0, 5.0, 5.0]\ncutoff_angle = 40.0\n\
            [[lights]]\ntype = \"point\"\nposition = [0.0, 3.0, 1.0]\npower = [20.0, 20.0, 20.0]\n\
            [[lights]]\ntype = \"quad\"\ncorner = [-0.2, 1.9, -0.2]\nedge_u = [0.4, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.4]\npower = [10.0, 10.0, 10.0]\n";
        let scene = crate::scene::load::load_scene_str(text, "pick.toml", std::path::Path::new("."), &[]).unwrap();
        let lights = &scene.lights;
        let x = Vec3::new(-0.8, 0.0, 0.1);
        let n = 200_000;
        let mut rng = Rng::new(9, 0, 0);
        let mut count = vec![0u32; lights.list.len()];
        let mut reported = vec![0.0f32; lights.list.len()];
        for _ in 0..n {
            let Some(ls) = lights.sample(&scene, x, rng.next_f32(), rng.next_2d(), false) else { continue };
            let kind = lights.list[ls.light].clone();
            let p = if matches!(kind, LightKind::Point { .. }) { ls.pdf } else { lights.power_pdf(ls.light) };
            count[ls.light] += 1;
            reported[ls.light] = p;
            if matches!(kind, LightKind::Point { .. }) {
                let again = lights.direct_pdf_area(&scene, ls.light, x, ls.p, Vec3::ZERO);
                assert!((again / p - 1.0).abs() < 1e-5, "direct_pdf_area {again} vs {p}");
            }
        }
        let (a, b) = lights.points;
        assert_eq!(count[a], 0, "the narrow spot far from x was taken");
        let share: f32 = (a..b).map(|j| lights.power_pdf(j)).sum();
        let taken: f32 = (a..b).map(|j| reported[j]).sum();
        assert!((taken / share - 1.0).abs() < 1e-5, "point lights' probabilities {taken} vs their share {share}");
        for (j, &c) in count.iter().enumerate().filter(|(_, &c)| c > 0) {
            let expect = reported[j] as f64 * n as f64;
            let sigma = expect.sqrt();
            assert!((c as f64 - expect).abs() < 5.0 * sigma, "light {j}: taken {c} times, expected {expect:.0}");
        }
    }

    /// Next-event estimation under a sky and a sun (6 m of floor: the sky's power is its radiance over
    /// a disc of the scene's size) with a small lamp: the lamp and the lights at infinity get half the
    /// light samples each, the sky and the sun splitting theirs by power (by power alone the lamp got
    /// 0.14%); the samples follow `choice_pdf`, and each sample's pdf is the one MIS weighs BSDF
    /// samples against (`env_pdf`, `pdf`). The planner's restriction keeps the balance among the lights
    /// it keeps; photon emission stays by power; a scene without lights at infinity is untouched.
    #[test]
    fn lights_at_infinity_share_light_samples_with_the_scenes_lights() {
        let head = "[camera]\norigin = [0.0, 2.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n\
            [materials]\nm = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
            [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"m\"\n\
            [[lights]]\ntype = \"quad\"\ncorner = [0.6, 0.5, 0.0]\nedge_u = [0.08, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.5]\nradiance = [6.0, 6.0, 5.0]\n";
        let sky = "[[lights]]\ntype = \"constant\"\nradiance = [0.6, 0.65, 0.7]\n\
            [[lights]]\ntype = \"distant\"\ndirection = [0.3, -1.0, 0.2]\nirradiance = [2.0, 2.0, 2.0]\n";
        let load = |text: &str| {
            crate::scene::load::load_scene_str(text, "balance.toml", std::path::Path::new("."), &[]).unwrap()
        };
        let mut scene = load(&format!("{head}{sky}"));
        let lights = &scene.lights;
        let (sun, lamp) = (1, lights.points.1);
        assert!(matches!(lights.list[0], LightKind::Env) && matches!(lights.list[sun], LightKind::Distant { .. }));
        let lamp_power = lights.power_pdf(lamp) + lights.power_pdf(lamp + 1);
        assert!(lamp_power < 0.002, "by power the lamp has {lamp_power}");
        let at_infinity = lights.choice_pdf(0) + lights.choice_pdf(sun);
        assert!((at_infinity - 0.5).abs() < 1e-6, "the sky and the sun get {at_infinity} of the light samples");
        let by_power = lights.power_pdf(0) / lights.power_pdf(sun);
        assert!((lights.choice_pdf(0) / lights.choice_pdf(sun) / by_power - 1.0).abs() < 1e-4);
        // The samples follow choice_pdf, each with the pdf MIS uses.
        let x = Vec3::new(0.2, 0.0, 0.3);
        let mut count = vec![0u32; lights.list.len()];
        let mut rng = Rng::new(3, 0, 0);
        let n = 100_000;
        for _ in 0..n {
            let Some(ls) = lights.sample(&scene, x, rng.next_f32(), rng.next_2d(), true) else { continue };
            count[ls.light] += 1;
            let mis = match lights.list[ls.light] {
                LightKind::Env => lights.env_pdf(ls.wi),
                LightKind::Distant { .. } => lights.choice_pdf(sun),
                _ => {
                    let d = ls.p - x;
                    let y = x + d.normalize() * ls.dist;
                    lights.pdf(&scene, 1, (ls.light - lamp) as u32, x, y, ls.normal)
                }
            };
            assert!((ls.pdf / mis - 1.0).abs() < 2e-3, "light {}: sampled pdf {} vs MIS pdf {mis}", ls.light, ls.pdf);
        }
        for (j, &c) in count.iter().enumerate() {
            let expect = lights.choice_pdf(j) as f64 * n as f64;
            assert!(
                (c as f64 - expect).abs() < 5.0 * expect.sqrt().max(1.0),
                "light {j}: {c} samples, {expect:.0} expected"
            );
        }
        // Emission stays by power.
        assert!((lights.power_pdf(0) + lights.power_pdf(sun) - (1.0 - lamp_power)).abs() < 1e-5);
        // The planner leaves the sun out: the sky alone weighs as much as the lamp.
        scene.lights.restrict_nee(|i| i != sun);
        let l = &scene.lights;
        assert_eq!(l.choice_pdf(sun), 0.0);
        assert!((l.choice_pdf(0) - 0.5).abs() < 1e-6, "sky alone: {}", l.choice_pdf(0));
        // It leaves the lamp out: the lights at infinity are all there is.
        scene.lights.restrict_nee(|i| i < lamp);
        assert!((scene.lights.choice_pdf(0) + scene.lights.choice_pdf(sun) - 1.0).abs() < 1e-6);
        // Without lights at infinity nothing changes: next-event estimation draws by power.
        let indoor = load(head);
        assert_eq!(indoor.lights.nee_cdf, indoor.lights.cdf);
    }

    /// Photons leaving a spot stay in its cone and carry its power on average (E[φ] = I ∫ falloff dω),
    /// and each one's density is what `emit_pdf` and `direction_density` report.
    #[test]
    fn spot_photons_carry_its_power() {
        let text = "[camera]\norigin = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n\
            [materials]\nm = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
            [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, -2.0]\nradius = 0.5\nmaterial = \"m\"\n\
            [[lights]]\ntype = \"spot\"\nposition = [0.0, 0.0, 0.0]\ndirection = [1.0, -2.0, 0.5]\n\
            intensity = [2.0, 2.0, 2.0]\ncutoff_angle = 35.0\nbeam_width = 20.0\n";
        let scene = crate::scene::load::load_scene_str(text, "spot.toml", std::path::Path::new("."), &[]).unwrap();
        let lights = &scene.lights;
        let LightKind::Point { spot: Some(spot), .. } = lights.list[0] else { panic!("not a spot: {:?}", lights.list) };
        assert!((lights.power[0].x - 2.0 * spot.solid_angle()).abs() < 1e-6);
        let n = 400_000;
        let mut rng = Rng::new(3, 0, 0);
        let mut sum = 0.0f64;
        for _ in 0..n {
            let e = lights.emit(&scene, rng.next_f32(), rng.next_2d(), rng.next_2d()).unwrap();
            assert!(spot.axis.dot(e.ray.d) >= 35f32.to_radians().cos() - 1e-5);
            let pdf = lights.emit_pdf(&scene, 0, 1.0, e.ray.d);
            assert!((pdf / e.pdf_emit - 1.0).abs() < 1e-5 && pdf == lights.direction_density(0, Vec3::ZERO, e.ray.d));
            sum += e.phi.x as f64;
        }
        let (mean, power) = (sum / n as f64, lights.power[0].x as f64);
        assert!((mean / power - 1.0).abs() < 0.005, "mean photon power {mean} vs the spot's power {power}");
    }
}
