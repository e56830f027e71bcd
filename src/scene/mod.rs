//! The in-memory scene: camera, materials, shapes (triangle meshes and analytic spheres), lights, settings.
pub mod camera;
pub mod contact;
pub mod env;
pub mod file;
pub mod immersed;
pub mod light;
pub mod load;
pub mod material;
pub mod medium;
pub mod mesh;
pub mod mitsuba;
pub mod texture;

pub use medium::Scattering;

use crate::color::Rgb;
use glam::Vec3;
use std::path::PathBuf;

pub use camera::Camera;
pub use file::{RenderSettings, SceneFile};
pub use light::Lights;
pub use load::{load_scene, load_scene_str, load_scene_with};
pub use material::{Blend, BlendWeight, Material, SurfaceMaterial, TransportMode, PRINCIPLED_WEIGHTS};
pub use mesh::TriMesh;
pub use texture::{MeshColors, Texture};

/// Refuses what is not a regular file before it is read: a scene reads each file it names whole, and a
/// device (`/dev/zero` never ends) or a named pipe (it blocks until written to) would take the memory
/// or wait forever. `Err` says why, for a message that names the file.
pub fn regular_file(path: &std::path::Path) -> Result<(), String> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(m) if m.is_dir() => Err("not a regular file (a folder)".into()),
        Ok(_) => Err("not a regular file (a device or a pipe; caustica reads only files)".into()),
        Err(e) => Err(e.to_string()),
    }
}

/// A text file read whole, once `regular_file` allows it; `Err` says why (for a message naming it).
pub fn read_text(path: &std::path::Path) -> Result<String, String> {
    regular_file(path).and_then(|()| std::fs::read_to_string(path).map_err(|e| e.to_string()))
}

/// Everything that can be wrong with a scene; each names the file and, where it applies, the key.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{file}: cannot read: {msg}")]
    Io { file: String, msg: String },
    #[error("{file}: {msg}")]
    Parse { file: String, msg: String },
    #[error("{file}: key `{key}`: {msg}")]
    Invalid { file: String, key: String, msg: String },
    #[error("{file}: file not found")]
    MissingFile { file: String },
    #[error("{file}: {msg}")]
    Mesh { file: String, msg: String },
}

#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriMesh),
    /// A sphere; `frame` (None: the world's axes) turns a world direction into the sphere's own, where
    /// its texture coordinates are Mitsuba's (`sphere_uv`): the rotation (or reflection) a Mitsuba
    /// `to_world` gave it. `inward`: its normals face the centre (Mitsuba's `flip_normals`), so that
    /// its inside is its front: it emits inwards, and a one-sided BSDF scatters only there.
    Sphere {
        center: Vec3,
        radius: f32,
        frame: Option<glam::Mat3>,
        inward: bool,
    },
}

/// A point drawn uniformly by area on one primitive.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit geometric normal (triangle winding, sphere outward unless `inward`); zero for a degenerate
    /// triangle.
    pub n: Vec3,
    /// Area of the primitive the point was drawn on (its area pdf is 1 / area).
    pub area: f32,
    /// Size of the primitive (longest triangle edge, sphere radius), for ray offsets.
    pub size: f32,
    /// The point's barycentric coordinates on its triangle (zero on a sphere, where `n` places it).
    pub bary: [f32; 2],
}

/// The longest edge of triangle abc (one square root: the root of the largest square is the largest root).
fn max_edge(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    (b - a).length_squared().max((c - a).length_squared()).max((c - b).length_squared()).sqrt()
}

impl Geometry {
    /// Axis-aligned bounding box (lo, hi).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Geometry::Mesh(m) => {
                m.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
            }
            Geometry::Sphere { center, radius, .. } => (*center - Vec3::splat(*radius), *center + Vec3::splat(*radius)),
        }
    }

    /// The one point-on-shape sampler: a uniform point on triangle `prim` of a mesh, or on the whole
    /// sphere (`prim` ignored). Lights, caustic targets and the planner all draw through it.
    pub fn point(&self, prim: usize, u: [f32; 2]) -> SurfacePoint {
        match self {
            Geometry::Mesh(m) => {
                let [a, b, c] = m.triangle(prim);
                let bc = crate::math::sampling::uniform_triangle(u);
                let cross = (b - a).cross(c - a);
                // One square root for the normal and the area (normalize_or_zero's own arithmetic;
                // `Mesh::area`'s, so that a light's sampled area and its pdf agree bit for bit).
                let len = crate::math::length_wide(cross);
                let rcp = len.recip();
                SurfacePoint {
                    p: a * (1.0 - bc[0] - bc[1]) + b * bc[0] + c * bc[1],
                    n: if rcp.is_finite() && rcp > 0.0 { cross * rcp } else { Vec3::ZERO },
                    area: 0.5 * len,
                    size: max_edge(a, b, c),
                    bary: bc,
                }
            }
            Geometry::Sphere { center, radius, inward, .. } => {
                let n = crate::math::sampling::uniform_sphere(u);
                SurfacePoint {
                    p: *center + n * *radius,
                    n: if *inward { -n } else { n },
                    area: 4.0 * std::f32::consts::PI * radius * radius,
                    size: *radius,
                    bary: [0.0; 2],
                }
            }
        }
    }
}

#[derive(Clone, Debug)]
pub struct Shape {
    /// Where it came from, e.g. `shapes[2]` or `lights[0]`.
    pub name: String,
    pub geometry: Geometry,
    pub material: u32,
    /// Emitted radiance (front side of triangles, outside of spheres, inside of inward ones); with `emission_texture`, the
    /// factor the texture is multiplied by (1: any non-zero value marks the shape as an emitter).
    pub emission: Rgb,
    /// Index into `Scene::textures`: the radiance at each point, read at its texture coordinates
    /// (Mitsuba's textured `radiance`), times `emission`.
    pub emission_texture: Option<u32>,
    /// A smooth mesh that emits towards the front of its shading normal, on either side of its faces
    /// (`Scene::emits_towards`, `Shape::emits_behind`): Mitsuba's area emitter on a mesh with vertex
    /// normals, whose coarse silhouettes are then dark where the interpolated normal turns away, and
    /// which lets light out behind a face where the interpolated normal leans past it.
    pub emit_by_shading_normal: bool,
}

impl Shape {
    /// Whether the shape may emit behind its faces: a mesh with vertex normals that
    /// `emit_by_shading_normal` emits wherever the direction lies in front of the interpolated normal,
    /// whichever side of the face that is (Mitsuba's area emitter tests its shading frame alone).
    pub fn emits_behind(&self) -> bool {
        self.emit_by_shading_normal && matches!(&self.geometry, Geometry::Mesh(m) if m.normals.is_some())
    }

    pub fn area(&self) -> f32 {
        match &self.geometry {
            Geometry::Mesh(m) => m.total_area(),
            Geometry::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
        }
    }
    /// Texture coordinates of a point `point` drew on primitive `prim`.
    pub fn uv_of(&self, prim: usize, sp: &SurfacePoint) -> glam::Vec2 {
        match &self.geometry {
            Geometry::Mesh(m) => m.uv_at(prim, sp.bary),
            Geometry::Sphere { frame, inward, .. } => sphere_uv_at(*frame, if *inward { -sp.n } else { sp.n }),
        }
    }

    pub fn primitive_count(&self) -> usize {
        match &self.geometry {
            Geometry::Mesh(m) => m.indices.len(),
            Geometry::Sphere { .. } => 1,
        }
    }
}

pub struct Scene {
    pub path: PathBuf,
    pub camera: Camera,
    pub materials: Vec<SurfaceMaterial>,
    pub material_names: Vec<String>,
    /// Images and procedural patterns that materials read their reflectance from.
    pub textures: Vec<Texture>,
    pub shapes: Vec<Shape>,
    pub lights: Lights,
    pub render: RenderSettings,
    /// Bounds of all geometry (and point lights).
    pub bounds: (Vec3, Vec3),
    /// Seconds spent reading files and building meshes.
    pub load_seconds: f64,
    /// Per shape, whether a hit on it can let light straight by (`Scene::see_through_shapes`); empty
    /// when no shape can, so that shadow rays in such scenes stay Embree's plain occlusion test.
    pub see_through: Vec<bool>,
    /// Per shape, the absorption coefficient σ of its inside and of its outside
    /// (`SurfaceMaterial::absorption`, `absorption_outside`); empty when no shape's sides absorb, so
    /// that scenes without coloured glass pay one test per segment.
    pub absorption: Vec<[Rgb; 2]>,
    /// Per shape (beside a non-empty `absorption`), whether it bounds a medium: its material absorbs on
    /// a side. A path changes its medium only where it leaves such a shape (`Scene::sigma_next`).
    pub boundary: Vec<bool>,
    /// Per point, spot or projector light (beside a non-empty `absorption`), in the order `Lights::build`
    /// lists them, the absorption of the medium round its position (`immersed::surrounding_media`).
    pub point_media: Vec<Rgb>,
    /// Per shape (beside `absorption`), what the media inside and outside it scatter
    /// (`SurfaceMaterial::scattering`, `scattering_outside`); empty when no medium scatters, which
    /// every mode but the path tracer's requires (`Scene::check_mode`).
    pub scattering: Vec<[Scattering; 2]>,
    /// Whether a see-through shape (a `null` material) bounds a medium: paths then cross see-through
    /// surfaces one at a time and shadow rays follow the media they cross (`accel::shadow_in_media`),
    /// which only the path tracer does (`Scene::check_mode`).
    pub see_through_media: bool,
    /// What the loader found worth saying about the scene (a shape partly in a medium), each naming
    /// the shape; printed once at load.
    pub warnings: Vec<String>,
}

/// e^(−σ·len) per channel, 1 where σ is 0 (also over an infinite length), out of line.
#[inline(never)]
fn absorb_slow(sigma: Rgb, len: f32) -> Rgb {
    let one = |s: f32| if s > 0.0 { (-s * len).exp() } else { 1.0 };
    Rgb::new(one(sigma.x), one(sigma.y), one(sigma.z))
}

/// What a path does at a surface it meets (`Scene::crossing`).
#[derive(Clone, Copy, Debug)]
pub enum Crossing {
    /// Straight through, as if the surface were not there, the light let through multiplied in.
    Through(Rgb),
    /// Scatters there with this BSDF.
    At(Material),
}

/// Mitsuba's sphere parameterisation (z is the pole, u the longitude from +x), in world axes, of the
/// unit normal `n`.
fn sphere_uv(n: Vec3) -> glam::Vec2 {
    let phi = n.y.atan2(n.x);
    let u = if phi < 0.0 { phi + std::f32::consts::TAU } else { phi } / std::f32::consts::TAU;
    glam::Vec2::new(u, n.z.clamp(-1.0, 1.0).acos() / std::f32::consts::PI)
}

/// A sphere's texture coordinates at its unit normal `n` (world axes), in its own `frame`.
pub fn sphere_uv_at(frame: Option<glam::Mat3>, n: Vec3) -> glam::Vec2 {
    sphere_uv(frame.map_or(n, |f| f * n))
}

/// ∂p/∂u and ∂p/∂v at `p` on a sphere (Mitsuba's: u its longitude over 2π, v its polar angle over π,
/// in its own axes, `frame` turning world directions into them): 2πr along growing longitude and πr
/// down from its north pole, turned into the world's axes; ∂p/∂v zero at the poles, where longitude
/// has no direction.
pub fn sphere_dp_duv(center: Vec3, radius: f32, frame: Option<glam::Mat3>, p: Vec3) -> (Vec3, Vec3) {
    let w = (p - center).normalize_or_zero();
    let q = frame.map_or(w, |f| f * w);
    let rd = (q.x * q.x + q.y * q.y).sqrt();
    let du = Vec3::new(-q.y, q.x, 0.0) * (std::f32::consts::TAU * radius);
    let dv = if rd > 0.0 {
        Vec3::new(q.z * q.x / rd, q.z * q.y / rd, -rd) * (std::f32::consts::PI * radius)
    } else {
        Vec3::ZERO
    };
    let world = |v: Vec3| frame.map_or(v, |f| f.transpose() * v);
    (world(du), world(dv))
}

/// The shading tangent: `dp_du` made orthogonal to the shading normal `ns`, as a unit vector; zero where
/// ∂p/∂u is zero or along the normal.
fn shading_tangent(ns: Vec3, dp_du: Vec3) -> Vec3 {
    (dp_du - ns * ns.dot(dp_du)).normalize_or_zero()
}

/// The normal and the tangent a bump map gives, as Mitsuba 3.9.1's `bumpmap` does, from the geometric
/// normal `ng`, the shading normal `ns`, the shading tangent `s` (∂p/∂u made orthogonal to `ns`),
/// ∂p/∂u, ∂p/∂v and the height's gradient `g` along u and v (times the map's scale): ∂p/∂u and ∂p/∂v
/// with their parts along `ns` replaced by `g`'s, their cross product as the normal, turned to `ng`'s
/// side, and that normal's tangent (`bump_tangent`). `ns` where the cross product vanishes; `s` where it
/// is zero.
pub fn bump_frame(ng: Vec3, ns: Vec3, s: Vec3, dp_du: Vec3, dp_dv: Vec3, g: glam::Vec2) -> (Vec3, Vec3) {
    let du = dp_du + ns * (g.x - ns.dot(dp_du));
    let dv = dp_dv + ns * (g.y - ns.dot(dp_dv));
    let n = du.cross(dv).normalize_or_zero();
    if n == Vec3::ZERO {
        return (ns, s);
    }
    let n = if n.dot(ng) < 0.0 { -n } else { n };
    (n, bump_tangent(ns, s, dp_du, n))
}

/// The tangent Mitsuba 3.9.1's `bumpmap` gives an anisotropic BSDF taken about the bent normal `n`:
/// ∂p/∂u made orthogonal to `n` the way Mitsuba's is, ∂p/∂u's world coordinates taken as coordinates
/// in the shading frame (`s`, `ns` × `s`, `ns`), where the normal is read in that frame (the same as
/// in world axes where that frame is the world's, turned elsewhere; only anisotropic BSDFs see it).
/// `s` where it is zero.
pub fn bump_tangent(ns: Vec3, s: Vec3, dp_du: Vec3, n: Vec3) -> Vec3 {
    if s == Vec3::ZERO {
        return s;
    }
    let t = ns.cross(s);
    let local = Vec3::new(n.dot(s), n.dot(t), n.dot(ns));
    let along = (dp_du - local * local.dot(dp_du)).normalize_or_zero();
    s * along.x + t * along.y + ns * along.z
}

/// A bump-mapped material at a hit: `mapped` with the bent normal (`bump_frame`; `ng` the side it is
/// turned to) and, for an anisotropic nested BSDF, the tangents of the two normals it can be taken
/// about (the nested BSDF's own for the bent normal, `Mapped::flipped_tangent` for its reflection):
/// Mitsuba builds the tangent after it has flipped the normal to the camera's side
/// (`flip_invalid_normals`), from the flipped normal.
pub fn bump_mapped(
    mut mapped: material::Mapped,
    ng: Vec3,
    ns: Vec3,
    s: Vec3,
    (dp_du, dp_dv): (Vec3, Vec3),
    g: glam::Vec2,
) -> Material {
    let tangent;
    (mapped.normal, tangent) = bump_frame(ng, ns, s, dp_du, dp_dv, g);
    let bsdf = Material::Mapped(mapped);
    if !bsdf.anisotropic() {
        return bsdf;
    }
    let flipped = ns * (2.0 * mapped.normal.dot(ns)) - mapped.normal;
    mapped.flipped_tangent = Some(bump_tangent(ns, s, dp_du, flipped.normalize_or_zero()));
    Material::Mapped(mapped).with_tangent(tangent)
}

/// A ray's hit turned into surface data.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    /// Unit geometric normal as stored (triangle winding, sphere outward unless inward).
    pub ng: Vec3,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3,
    pub shape: u32,
    pub prim: u32,
    /// Size of the primitive hit (longest triangle edge, sphere radius), for ray offsets.
    pub scale: f32,
    /// Texture coordinates (the mesh's, else the barycentric ones; spherical on spheres) where the
    /// shape's material reads a texture; zero elsewhere (nothing else reads them).
    pub uv: glam::Vec2,
}

impl SurfaceHit {
    /// A ray leaving the surface in direction `w`, its origin moved off the surface robustly.
    pub fn spawn(&self, w: Vec3) -> crate::math::Ray {
        crate::math::Ray::new(crate::math::offset_ray_origin(self.p, self.ng, w, self.scale), w)
    }

    /// A shadow ray from this surface to `target` (a point already moved off its own surface): it
    /// covers the open segment, so only what lies strictly between the two can block it.
    pub fn spawn_to(&self, target: Vec3) -> crate::math::Ray {
        let o = crate::math::offset_ray_origin(self.p, self.ng, target - self.p, self.scale);
        crate::math::Ray { o, d: target - o, tmin: 0.0, tmax: 1.0 - 1e-4 }
    }

    /// Samples `mat` at this surface for the direction `wo` the path arrived along (pointing away), and
    /// returns the sample with the ray it spawns; None when sampling fails. The sample is the BSDF's about
    /// the shading normal alone, as in Mitsuba 3 and pbrt-v4: a reflection the shading normal sends below
    /// the geometric surface goes on through it (the ray leaves from that side), and a refraction that
    /// does not cross it stays on its side. In `Importance` mode the weight carries Veach's shading-normal
    /// correction |wo·ns||wi·ng| / (|wo·ng||wi·ns|) (thesis §5.3), so photons and light paths see the
    /// adjoint BSDF.
    pub fn scatter(
        &self,
        mat: &Material,
        wo: Vec3,
        rng: &mut crate::math::Rng,
        mode: TransportMode,
    ) -> Option<(material::BsdfSample, crate::math::Ray)> {
        let u = rng.next_2d();
        self.scatter_with(mat, wo, u, rng.next_f32(), mode)
    }

    /// `scatter` with the random numbers given (`u` for the direction, `uc` for the lobe).
    pub fn scatter_with(
        &self,
        mat: &Material,
        wo: Vec3,
        u: [f32; 2],
        uc: f32,
        mode: TransportMode,
    ) -> Option<(material::BsdfSample, crate::math::Ray)> {
        let mut bs = mat.sample(wo, self.ns, u, uc, mode)?;
        if mode == TransportMode::Importance {
            bs.weight *= self.shading_correction(wo, bs.wi);
        }
        Some((bs, self.spawn(bs.wi)))
    }

    /// Whether `mat` here can carry light between `wo` and `wi` (both pointing away), by the shading
    /// normal alone as `scatter_with` samples: a reflection keeps to one side of it, a transmission
    /// (dielectrics only) crosses it. Which side of the geometric surface `wi` lies on does not matter
    /// (a reflection below it reaches what lies behind the surface, as Mitsuba 3's and pbrt-v4's do).
    pub fn can_scatter(&self, mat: &Material, wo: Vec3, wi: Vec3) -> bool {
        let shading = wo.dot(self.ns) * wi.dot(self.ns);
        shading > 0.0 || (shading < 0.0 && mat.transmits())
    }

    /// |wo·ns||wi·ng| / (|wo·ng||wi·ns|): the factor by which the adjoint BSDF differs from the BSDF
    /// under shading normals (1 where they agree).
    pub fn shading_correction(&self, wo: Vec3, wi: Vec3) -> f32 {
        let den = wo.dot(self.ng).abs() * wi.dot(self.ns).abs();
        if den <= 0.0 {
            return 0.0;
        }
        wo.dot(self.ns).abs() * wi.dot(self.ng).abs() / den
    }

    /// The adjoint BSDF of `mat` here scattering light that arrived from `wo` towards `dir`, times
    /// |cos θ| at `dir` (Veach's shading-normal correction included): what a light path carries on
    /// towards `dir`, per unit of its throughput.
    pub fn scatter_light(&self, mat: &Material, wo: Vec3, dir: Vec3) -> Rgb {
        mat.eval(wo, dir, self.ns, TransportMode::Importance)
            * (self.shading_correction(wo, dir) * dir.dot(self.ns).abs())
    }
}

/// Feeds the exact bits of each vector (x, y, z, little-endian) into a content hash.
pub(crate) fn hash_vec3s<'a>(h: &mut sha2::Sha256, v: impl IntoIterator<Item = &'a Vec3>) {
    use sha2::Digest;
    for p in v {
        p.to_array().iter().for_each(|c| h.update(c.to_bits().to_le_bytes()));
    }
}

impl Scene {
    /// SHA-256 (hex) of what the scene is, independent of where its files live: camera, materials,
    /// lights, every shape's geometry (the bits of its vertices, normals, texture coordinates and
    /// colours, its indices) and emission. Render settings are not part of it (they are compared on
    /// their own). Partial renders carry it, so parts of different scenes are never merged.
    pub fn content_hash(&self) -> String {
        use sha2::{Digest, Sha256};
        let mut h = Sha256::new();
        // Debug output of floats round-trips exactly, so equal text means equal values.
        h.update(format!(
            "{:?}|{:?}|{:?}|{:?}|{:?}",
            self.camera, self.materials, self.material_names, self.lights.list, self.lights.power
        ));
        for t in &self.textures {
            t.hash_into(&mut h);
        }
        if let Some((e, _)) = &self.lights.env {
            h.update(format!("env {:?} {:?}", e.scale, e.to_local));
            hash_vec3s(&mut h, e.image.iter().flat_map(|i| &i.texels));
        }
        for s in &self.shapes {
            h.update(format!("|{}|{}|{:?}|{:?}|", s.name, s.material, s.emission, s.emission_texture));
            match &s.geometry {
                Geometry::Mesh(m) => {
                    hash_vec3s(&mut h, &m.positions);
                    for t in &m.indices {
                        t.iter().for_each(|i| h.update(i.to_le_bytes()));
                    }
                    hash_vec3s(&mut h, m.normals.iter().flatten());
                    h.update(format!("colours {:?} {:?}", m.colors.is_some(), m.face_colors.is_some()));
                    hash_vec3s(&mut h, m.colors.iter().flatten());
                    hash_vec3s(&mut h, m.face_colors.iter().flatten());
                    for t in m.uvs.iter().flatten() {
                        t.iter().for_each(|c| h.update(c.to_bits().to_le_bytes()));
                    }
                }
                Geometry::Sphere { center, radius, frame, inward } => {
                    h.update(format!("sphere {center:?} {radius:?}"));
                    if *inward {
                        h.update(" inward");
                    }
                    if let Some(f) = frame {
                        h.update(format!(" frame {f:?}"));
                    }
                }
            }
        }
        h.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }

    pub fn material_of(&self, shape: u32) -> &SurfaceMaterial {
        &self.materials[self.shapes[shape as usize].material as usize]
    }

    /// Whether `f` holds for any material a hit on `material` can be: itself, or either side of a
    /// blend, down nested blends (the loader refuses cycles).
    pub fn any_leaf<F: FnMut(&SurfaceMaterial) -> bool>(&self, material: u32, f: &mut F) -> bool {
        let m = &self.materials[material as usize];
        match m.blend {
            Some(b) => self.any_leaf(b.first, f) || self.any_leaf(b.second, f),
            None => f(m),
        }
    }

    /// Per shape, whether some material a hit on it can be lets light straight through: a thin pane, a
    /// null surface (a pane of index 1), a mask's holes (`Material::thin_reflectance`), on a shape that
    /// does not emit (an emitter stays a surface its light is found on). Empty when there is none: what
    /// `see_through` holds.
    pub fn see_through_shapes(&self) -> Vec<bool> {
        let flags: Vec<bool> = (self.shapes.iter())
            .map(|s| s.emission == Rgb::ZERO && self.any_leaf(s.material, &mut |m| m.bsdf.is_thin()))
            .collect();
        if flags.contains(&true) {
            flags
        } else {
            Vec::new()
        }
    }

    /// Per shape, the absorption of its inside and outside (`absorption`); empty when none absorbs.
    pub fn absorbing_shapes(&self) -> Vec<[Rgb; 2]> {
        let sigma: Vec<[Rgb; 2]> = (self.shapes.iter())
            .map(|s| &self.materials[s.material as usize])
            .map(|m| [m.absorption, m.absorption_outside])
            .collect();
        if sigma.iter().any(|s| *s != [Rgb::ZERO; 2]) {
            sigma
        } else {
            Vec::new()
        }
    }

    /// The absorption coefficient along a segment that leaves `si` in direction `w`: its shape's
    /// inside's when `w` points into the back of the geometric normal (a refraction into the shape, a
    /// reflection inside it), else its outside's (zero for most shapes). This is Mitsuba's rule
    /// (`SurfaceInteraction::target_medium`): the medium a segment runs through is set where it starts.
    #[inline(always)]
    pub fn sigma_leaving(&self, si: &SurfaceHit, w: Vec3) -> Rgb {
        if self.absorption.is_empty() {
            return Rgb::ZERO;
        }
        let [inside, outside] = self.absorption[si.shape as usize];
        if w.dot(si.ng) < 0.0 {
            inside
        } else {
            outside
        }
    }

    /// The absorption along a segment that leaves `si` in direction `w`, the path having arrived there
    /// through a medium of absorption `arrived`: where `si`'s shape bounds a medium, the side `w` points
    /// to (`sigma_leaving`); elsewhere the path keeps the medium it was in. Mitsuba's volpath carries a
    /// path's medium so, past every surface that is not a medium transition: a floor running through a
    /// tank of coloured water is in the water where it is under it and in air elsewhere, and a path
    /// from a camera whose near clipping plane lies inside a medium stays in none (the sensor's) until
    /// it crosses a boundary.
    #[inline(always)]
    pub fn sigma_next(&self, si: &SurfaceHit, w: Vec3, arrived: Rgb) -> Rgb {
        if self.absorption.is_empty() {
            return arrived;
        }
        if self.boundary[si.shape as usize] {
            self.sigma_leaving(si, w)
        } else {
            arrived
        }
    }

    /// What the medium of a segment that leaves `si` in direction `w` scatters, the path having arrived
    /// through one that scatters `arrived`: the side's where `si`'s shape bounds a medium, `arrived`
    /// elsewhere (as `sigma_next` follows the absorption).
    #[inline(always)]
    pub fn scattering_next(&self, si: &SurfaceHit, w: Vec3, arrived: Scattering) -> Scattering {
        if self.scattering.is_empty() || !self.boundary[si.shape as usize] {
            return arrived;
        }
        let [inside, outside] = self.scattering[si.shape as usize];
        if w.dot(si.ng) < 0.0 {
            inside
        } else {
            outside
        }
    }

    /// Per shape, what the media inside and outside it scatter; empty when none does.
    pub fn scattering_shapes(&self) -> Vec<[Scattering; 2]> {
        let sides: Vec<[Scattering; 2]> = (self.shapes.iter())
            .map(|s| &self.materials[s.material as usize])
            .map(|m| [m.scattering, m.scattering_outside])
            .collect();
        if sides.iter().flatten().any(Scattering::scatters) {
            sides
        } else {
            Vec::new()
        }
    }

    /// Whether `mode` renders this scene: a medium that scatters, and one inside a see-through boundary
    /// (a `null` material), are rendered by the path tracer alone (the other modes' photons, light
    /// subpaths and gathers would pass through the first as through coloured glass, and cross the
    /// second's boundary as if it bounded nothing).
    /// A camera in a medium (`camera.medium`) is too: the other modes' light paths would have to know
    /// which medium every point of the scene lies in.
    pub fn check_mode(&self, mode: crate::scene::file::Mode) -> Result<(), String> {
        let camera_medium = self.camera.medium.sigma_t != Rgb::ZERO;
        if (self.scattering.is_empty() && !self.see_through_media && !camera_medium)
            || mode == crate::scene::file::Mode::Path
        {
            return Ok(());
        }
        let file = if self.path.as_os_str().is_empty() { String::new() } else { format!("{}: ", self.path.display()) };
        if camera_medium {
            return Err(format!(
                "{file}the camera sits in a medium (camera.medium; Mitsuba's sensor `medium`), which only the \
                 path tracer renders (--mode path); the photon-mapping and bidirectional modes start camera \
                 paths in vacuum"
            ));
        }
        let name = |shape: usize| &self.material_names[self.shapes[shape].material as usize];
        if let Some(shape) = self.scattering.iter().position(|s| s.iter().any(Scattering::scatters)) {
            return Err(format!(
                "{file}material `{}` holds a medium that scatters light, which only the path tracer renders \
                 (--mode path); the photon-mapping and bidirectional modes read media that only absorb, in glass",
                name(shape)
            ));
        }
        let shape = (0..self.shapes.len()).position(|i| self.is_see_through(i as u32) && self.boundary[i]).unwrap_or(0);
        Err(format!(
            "{file}material `{}` is a see-through surface (null) round a medium, which only the path tracer \
             renders (--mode path); the photon-mapping and bidirectional modes read media in glass",
            name(shape)
        ))
    }

    /// The medium the paths of light `light` (an index in `lights.list`) start in where the scene knows
    /// it: none for the sky and distant lights (outside every shape, as Mitsuba's), the medium round a
    /// point light's position (`point_media`) or round an emitting shape that bounds none. None for an
    /// emitting boundary: its first segment takes the medium its end's side says
    /// (`absorbed_on_light_path`). Not that side for the rest: a light's first hit may be a shape partly
    /// in a medium, whose sides say only the medium round most of it.
    pub fn light_medium(&self, light: usize) -> Option<Rgb> {
        use crate::scene::light::LightKind;
        if self.absorption.is_empty() {
            return Some(Rgb::ZERO);
        }
        match self.lights.list[light] {
            LightKind::Env | LightKind::Distant { .. } => Some(Rgb::ZERO),
            LightKind::Point { .. } => Some(self.point_media[light - self.lights.points.0]),
            LightKind::Triangle { shape, .. } | LightKind::Sphere { shape } if !self.boundary[shape as usize] => {
                Some(self.absorption[shape as usize][0])
            }
            _ => None,
        }
    }

    /// The light let through along `ray`'s segment to its hit at `t` along `ray` (None: it leaves the
    /// scene), the segment having started in a medium of absorption `sigma` (`sigma_leaving`):
    /// e^(−σ·length) per channel. A camera ray starts in none (Mitsuba's sensor without a `medium`:
    /// also where a near clipping plane starts it inside coloured glass).
    #[inline(always)]
    pub fn absorbed_to(&self, sigma: Rgb, ray: &crate::math::Ray, t: Option<f32>) -> Rgb {
        if sigma == Rgb::ZERO {
            return Rgb::ONE;
        }
        absorb_slow(sigma, t.map_or(f32::INFINITY, |t| t * ray.d.length()))
    }

    /// `absorbed_to` for a segment of a light's path (a photon's, a light subpath's) to its hit `si` at
    /// `t` along `ray`, `sigma` being the medium it started in, None on the light's first segment. That
    /// one runs through the inside of an absorbing shape if it arrives at its back (a light inside
    /// coloured glass), through its outside's medium if it arrives at its front: the medium a camera
    /// path from there to the light would start in, so that every mode dims it alike.
    #[inline(always)]
    pub fn absorbed_on_light_path(&self, sigma: Option<Rgb>, ray: &crate::math::Ray, si: &SurfaceHit, t: f32) -> Rgb {
        let sigma = sigma.unwrap_or_else(|| self.sigma_leaving(si, -ray.d));
        self.absorbed_to(sigma, ray, Some(t))
    }

    /// The light let through along a segment of length `len` (infinite: it leaves the scene) through
    /// a medium of absorption `sigma`: e^(−σ·len) per channel, 1 where σ is 0.
    #[inline(always)]
    pub fn absorbed(sigma: Rgb, len: f32) -> Rgb {
        if sigma == Rgb::ZERO {
            return Rgb::ONE;
        }
        absorb_slow(sigma, len)
    }

    /// Whether a hit on `shape` can let light straight through (`see_through`).
    #[inline(always)]
    pub fn is_see_through(&self, shape: u32) -> bool {
        !self.see_through.is_empty() && self.see_through[shape as usize]
    }

    /// What a path arriving along `wo` does at `si`, where it picked `mat`: it goes straight through
    /// (`Crossing::Through`, the light let through) or scatters there (`Crossing::At`, the BSDF to
    /// sample). A see-through surface lets light straight through as no scattering event: it does not
    /// count against `render.max_depth`, and the path's last vertex (its MIS densities, its distance)
    /// stays the one before it. A thin pane also reflects: `u` draws which, reflection with probability
    /// R' (`Material::thin_reflectance`), then a perfect mirror (weight R'/R' = 1), else straight through
    /// with the pane's tint (weight tint·(1 − R')/(1 − R')). Elsewhere `mat` as it is, `u` not drawn.
    #[inline(always)]
    pub fn crossing(&self, si: &SurfaceHit, wo: Vec3, mat: Material, u: impl FnOnce() -> f32) -> Crossing {
        if !self.is_see_through(si.shape) {
            return Crossing::At(mat);
        }
        let (Some(r), Material::ThinDielectric { tint, .. }) = (mat.thin_reflectance(wo.dot(si.ns)), mat) else {
            return Crossing::At(mat);
        };
        if r > 0.0 && u() < r {
            let mirror = Material::conductor(material::Fresnel::Constant(Rgb::ONE), 0.0, material::Microfacet::Ggx);
            Crossing::At(mirror)
        } else {
            Crossing::Through(tint)
        }
    }

    /// The light a see-through surface lets straight through at `si` for a ray along `dir` (of any
    /// length), whatever it picks there: each material it can be, weighed by how often a blend picks
    /// it, its straight transmission where it has one (a thin pane's tint·(1 − R'), all of it for a
    /// null surface) and nothing where it has not. A shadow ray is multiplied by it at each crossing: the
    /// expectation of what a path's own choices there let through, so the strategies' MIS weights,
    /// taken without those choices, still add up to one.
    pub fn transmittance_at(&self, si: &SurfaceHit, dir: Vec3) -> Rgb {
        // A pane's R' reads the cosine to its normal: `dir` (a shadow ray's, target − origin) as a unit.
        self.leaf_transmittance(self.shapes[si.shape as usize].material, si, -dir.normalize())
    }

    fn leaf_transmittance(&self, material: u32, si: &SurfaceHit, wo: Vec3) -> Rgb {
        let m = &self.materials[material as usize];
        match m.blend {
            Some(b) => {
                let w = self.blend_weight(&b, si, wo);
                let first = if w < 1.0 { self.leaf_transmittance(b.first, si, wo) * (1.0 - w) } else { Rgb::ZERO };
                let second = if w > 0.0 { self.leaf_transmittance(b.second, si, wo) * w } else { Rgb::ZERO };
                first + second
            }
            None => self.leaf_bsdf(m, si, wo).straight_transmittance(wo.dot(si.ns)).unwrap_or(Rgb::ZERO),
        }
    }

    /// Whether some material a hit on `shape` can be reflects or bends light other than diffusely (a
    /// mirror, glass, metal, a coat): what caustic photons and VCM's light subpaths are aimed at. The
    /// holes of a see-through surface only let light by, as if the surface were not there; a normal- or
    /// bump-mapped diffuse surface scatters diffusely (`Material::scatters_diffusely`).
    pub fn casts_caustics(&self, shape: u32) -> bool {
        let see_through = self.is_see_through(shape);
        self.any_leaf(self.shapes[shape as usize].material, &mut |m| {
            let lets_by = see_through && m.bsdf.pass_through().is_some();
            !m.bsdf.scatters_diffusely() && !lets_by
        })
    }

    /// Whether every material a hit on `shape` can be scatters diffusely (`Material::scatters_diffusely`:
    /// Lambertian, also about a normal or bump map's normal; no mirror, glass, coat or hole).
    pub fn is_diffuse(&self, shape: u32) -> bool {
        self.material_is_diffuse(self.shapes[shape as usize].material)
    }

    /// `is_diffuse` of a material (an index into `materials`).
    pub fn material_is_diffuse(&self, material: u32) -> bool {
        !self.any_leaf(material, &mut |m| !m.bsdf.scatters_diffusely())
    }

    /// Whether some material a hit on `material` can be is not a delta BSDF: bidirectional light
    /// vertices are kept there (for connections and merging), as light vertices are on any surface
    /// a path can be connected to.
    pub fn material_keeps_light_vertices(&self, material: u32) -> bool {
        self.any_leaf(material, &mut |m| !m.bsdf.is_delta())
    }

    /// Whether some material a hit on `shape` can be mirrors or bends light by a delta lobe
    /// (`Material::has_delta_lobe`).
    pub fn has_delta_lobe(&self, shape: u32) -> bool {
        self.any_leaf(self.shapes[shape as usize].material, &mut |m| m.bsdf.has_delta_lobe())
    }

    /// Whether some material a hit on `shape` can be has a glossy lobe that holds no photons (rough
    /// metal or glass, a principled surface, a rough plastic's coat): where the photon mappers
    /// light-trace the caustics of delta lights to the camera.
    pub fn has_unheld_glossy_lobe(&self, shape: u32) -> bool {
        self.any_leaf(self.shapes[shape as usize].material, &mut |m| m.bsdf.unheld_glossy_lobe().is_some())
    }

    /// Whether any shape can hold photons (`holds_photons`): where caustic photons can be stored at all.
    pub fn any_holds_photons(&self) -> bool {
        (0..self.shapes.len() as u32).any(|s| self.holds_photons(s))
    }

    /// Whether photons can be held on `shape`: some material a hit on it can be holds them.
    pub fn holds_photons(&self, shape: u32) -> bool {
        self.material_holds_photons(self.shapes[shape as usize].material)
    }

    /// `holds_photons` of a material (an index into `materials`).
    pub fn material_holds_photons(&self, material: u32) -> bool {
        self.any_leaf(material, &mut |m| m.bsdf.holds_photons())
    }

    /// Whether `f` holds for the BSDF at `si` seen from `wo` of any material the surface can be there.
    /// Photons are stored (and light vertices kept for merging) by what the surface can be, whatever a
    /// blend picks for the photon's own next bounce: a path gathering there makes its own pick.
    /// A side blend offers only the side `wo` arrives on.
    pub fn any_bsdf_at(&self, si: &SurfaceHit, wo: Vec3, mut f: impl FnMut(&Material) -> bool) -> bool {
        self.any_leaf_at(self.shapes[si.shape as usize].material, si, wo, &mut |m| f(&self.leaf_bsdf(m, si, wo)))
    }

    /// `any_leaf` of the materials a hit at `si` arrived at along `wo` can be: a side blend's side there
    /// alone, either material of another blend.
    fn any_leaf_at<F: FnMut(&SurfaceMaterial) -> bool>(
        &self,
        material: u32,
        si: &SurfaceHit,
        wo: Vec3,
        f: &mut F,
    ) -> bool {
        let m = &self.materials[material as usize];
        match m.blend {
            Some(b) if b.weight == material::BlendWeight::Side => {
                let side = if self.blend_weight(&b, si, wo) > 0.0 { b.second } else { b.first };
                self.any_leaf_at(side, si, wo, f)
            }
            Some(b) => self.any_leaf_at(b.first, si, wo, f) || self.any_leaf_at(b.second, si, wo, f),
            None => f(m),
        }
    }

    /// Whether a material (an index into `materials`) has a glossy lobe no photon is stored for
    /// (`Material::unheld_glossy_lobe`: rough metal or glass, a principled surface, a rough plastic's
    /// coat), on either side of a blend.
    pub fn material_unheld_glossy(&self, material: u32) -> bool {
        self.any_leaf(material, &mut |m| m.bsdf.unheld_glossy_lobe().is_some())
    }

    /// Whether any surface's material has such a lobe (`material_unheld_glossy`).
    pub fn any_unheld_glossy(&self) -> bool {
        self.shapes.iter().any(|s| self.material_unheld_glossy(s.material))
    }

    /// On a blend, whether `f` holds for the BSDF at `si` of any material it can be there (the one picked
    /// or another); false off blends, where the BSDF a caller picked, and has already asked, is the
    /// surface's only one. Keeps photon and light-vertex storing from building that BSDF again at every
    /// mirror and glass hit.
    pub fn blend_offers(&self, si: &SurfaceHit, wo: Vec3, f: impl FnMut(&Material) -> bool) -> bool {
        self.material_of(si.shape).blend.is_some() && self.any_bsdf_at(si, wo, f)
    }

    /// The largest reflectance component a shape's material reaches anywhere (its texture's largest
    /// value; a blend's, the larger of its two).
    pub fn max_albedo(&self, shape: u32) -> f32 {
        let mut best = 0.0f32;
        self.any_leaf(self.shapes[shape as usize].material, &mut |m| {
            let most = |t: Option<u32>| t.map(|t| Rgb::splat(self.textures[t as usize].max_value()));
            best = best.max(match m.texture {
                Some(t) => self.textures[t as usize].max_value(),
                // Each colour at its texture's largest value bounds what the surface reflects.
                None => m
                    .bsdf
                    .with_params(most(m.maps.specular), most(m.maps.tint), None, None, [None; PRINCIPLED_WEIGHTS.len()])
                    .albedo()
                    .max_element(),
            });
            false
        });
        best
    }

    /// Whether a hit on `material` reads texture coordinates (a texture, or a blend's weight).
    fn reads_uv(&self, material: u32) -> bool {
        let m = &self.materials[material as usize];
        match m.blend {
            Some(b) => {
                matches!(b.weight, material::BlendWeight::Texture(_))
                    || self.reads_uv(b.first)
                    || self.reads_uv(b.second)
            }
            None => m.texture.is_some() || m.maps.any() || m.normal_map.is_some(),
        }
    }

    /// The material a hit at `si`, arrived at along `wo`, is. A blend is resolved to one of its two by
    /// its weight there: the number `u` draws (only when a blend's weight there is strictly between 0
    /// and 1, so other scenes' random sequences are unchanged) picks the second below the weight, and
    /// is rescaled to pick again in a nested blend. A weight of 0 or 1 (a side blend's always) picks
    /// without it.
    pub fn pick_material(&self, si: &SurfaceHit, wo: Vec3, u: impl FnOnce() -> f32) -> &SurfaceMaterial {
        let mut m = self.material_of(si.shape);
        let Some(mut b) = m.blend else {
            return m;
        };
        let mut u = Some(u);
        let mut x = 0.0;
        loop {
            let w = self.blend_weight(&b, si, wo);
            let next = if w <= 0.0 {
                b.first
            } else if w >= 1.0 {
                b.second
            } else {
                if let Some(u) = u.take() {
                    x = u();
                }
                let second;
                (second, x) = crate::math::sampling::split(x, w);
                if second {
                    b.second
                } else {
                    b.first
                }
            };
            m = &self.materials[next as usize];
            match m.blend {
                Some(n) => b = n,
                None => return m,
            }
        }
    }

    /// A blend's weight at `si` for a path arriving along `wo`: the chance it is its second material
    /// there, in [0, 1] (NaN reads 0). A side blend's is 1 behind the geometric normal, 0 in front.
    fn blend_weight(&self, b: &material::Blend, si: &SurfaceHit, wo: Vec3) -> f32 {
        let w = match b.weight {
            material::BlendWeight::Value(w) => w,
            material::BlendWeight::Texture(t) => material::mitsuba_luminance(self.texture_at(t, si)),
            material::BlendWeight::Side => return if wo.dot(si.ng) <= 0.0 { 1.0 } else { 0.0 },
        };
        if w.is_nan() {
            0.0
        } else {
            w.clamp(0.0, 1.0)
        }
    }

    /// The BSDF at `si` seen from `wo` (the back of a one-sided material is black; a texture gives the
    /// diffuse reflectance there). On a blend, `u` draws the number that picks one of its materials
    /// (`pick_material`).
    pub fn bsdf(&self, si: &SurfaceHit, wo: Vec3, u: impl FnOnce() -> f32) -> Material {
        self.leaf_bsdf(self.pick_material(si, wo, u), si, wo)
    }

    fn leaf_bsdf(&self, m: &SurfaceMaterial, si: &SurfaceHit, wo: Vec3) -> Material {
        // A one-sided surface is black seen from behind its shading normal, whichever side of the face
        // that is, as Mitsuba's one-sided BSDFs (they test the side in the shading frame alone). Where a
        // smooth mesh's shading normal leans away from `wo`, a BSDF that only asks both directions to
        // lie on one side of it would reflect light from below the shading normal; where it leans past
        // the face towards `wo`, the surface is seen and lit in front of it, from behind the face. The
        // test is the same for the camera's side and the light's, so every mode finds the same light.
        if !m.two_sided && wo.dot(si.ns) <= 0.0 {
            return Material::Diffuse { reflectance: Rgb::ZERO };
        }
        if let (Material::Mapped(mut mapped), Some(map)) = (m.bsdf, m.normal_map) {
            let nested = self.textured_bsdf(m, mapped.nested.material(), si);
            mapped.nested = material::Nested::new(nested).unwrap_or(mapped.nested);
            let (dp_du, dp_dv) = self.dp_duv(si);
            let s = shading_tangent(si.ns, dp_du);
            return match map {
                material::NormalMap::Image(t) => {
                    mapped.normal = self.mapped_normal(t, si, s);
                    let bsdf = Material::Mapped(mapped);
                    if bsdf.anisotropic() {
                        bsdf.with_tangent(s)
                    } else {
                        bsdf
                    }
                }
                material::NormalMap::Bump { height, scale, to_back } => {
                    let g = self.textures[height as usize].gradient(si.uv).unwrap_or(glam::Vec2::ZERO) * scale;
                    bump_mapped(mapped, if to_back { -si.ng } else { si.ng }, si.ns, s, (dp_du, dp_dv), g)
                }
            };
        }
        let bsdf = self.textured_bsdf(m, m.bsdf, si);
        if bsdf.anisotropic() {
            bsdf.with_tangent(self.tangent(si))
        } else {
            bsdf
        }
    }

    /// The shading frame's tangent at `si`, as Mitsuba builds it: ∂p/∂u (a mesh's from its texture
    /// coordinates or, without them, its triangle's first edge; a sphere's along growing longitude) made
    /// orthogonal to the shading normal; zero where ∂p/∂u is zero or along the normal.
    fn tangent(&self, si: &SurfaceHit) -> Vec3 {
        shading_tangent(si.ns, self.dp_duv(si).0)
    }

    /// The normal a normal map (texture `t`) gives at `si`: its colour c as 2c − 1 in the frame of the
    /// tangent `s` (`tangent`), the shading normal × that, and the normal (Mitsuba's `normalmap`), as a
    /// unit vector. The shading normal itself where there is no such frame (`s` zero) or the map reads
    /// zero.
    fn mapped_normal(&self, t: u32, si: &SurfaceHit, s: Vec3) -> Vec3 {
        let ns = si.ns;
        if s == Vec3::ZERO {
            return ns;
        }
        let c = self.texture_at(t, si) * 2.0 - Vec3::ONE;
        // normalize_or_zero gives zero for a zero or non-finite normal too.
        let n = (s * c.x + ns.cross(s) * c.y + ns * c.z).normalize_or_zero();
        if n == Vec3::ZERO {
            ns
        } else {
            n
        }
    }

    /// ∂p/∂u and ∂p/∂v at `si`, as Mitsuba's shapes give them: a mesh triangle's from its texture
    /// coordinates, a sphere's by `sphere_dp_duv`.
    fn dp_duv(&self, si: &SurfaceHit) -> (Vec3, Vec3) {
        match &self.shapes[si.shape as usize].geometry {
            Geometry::Mesh(m) => m.dp_duv(si.prim as usize),
            Geometry::Sphere { center, radius, frame, .. } => sphere_dp_duv(*center, *radius, *frame, si.p),
        }
    }

    /// `bsdf`, material `m`'s BSDF, with its textures read at `si`.
    fn textured_bsdf(&self, m: &SurfaceMaterial, bsdf: Material, si: &SurfaceHit) -> Material {
        let bsdf = match (m.texture, bsdf) {
            (Some(t), Material::Diffuse { .. }) => Material::Diffuse { reflectance: self.texture_at(t, si) },
            (Some(t), Material::Plastic { specular, ior, nonlinear, rough, .. }) => {
                let diffuse = self.texture_at(t, si);
                Material::Plastic { diffuse, specular, ior, nonlinear, rough }
            }
            (Some(t), Material::Principled(mut p)) => {
                p.base = self.texture_at(t, si);
                Material::Principled(p)
            }
            (_, bsdf) => bsdf,
        };
        if !m.maps.any() {
            return bsdf;
        }
        let colour = |t: Option<u32>| t.map(|t| self.texture_at(t, si));
        let number = |t: Option<u32>| colour(t).map(material::mitsuba_luminance);
        let alpha = number(m.maps.alpha);
        // An isotropic textured roughness reads its texture once for both.
        let alpha_v = if m.maps.alpha_v == m.maps.alpha { alpha } else { number(m.maps.alpha_v) };
        bsdf.with_params(colour(m.maps.specular), colour(m.maps.tint), alpha, alpha_v, m.maps.weights.map(number))
    }

    /// Texture `t`'s value at hit `si`: at its uv, or for mesh colours the hit mesh's (its vertices',
    /// interpolated, or its triangle's).
    #[inline]
    pub fn texture_at(&self, t: u32, si: &SurfaceHit) -> Rgb {
        match &self.textures[t as usize] {
            texture::Texture::MeshColor { of, scale } => match &self.shapes[si.shape as usize].geometry {
                Geometry::Mesh(m) => match of {
                    texture::MeshColors::Vertex => m.color_at(si.prim as usize, si.p) * *scale,
                    texture::MeshColors::Face => {
                        m.face_colors.as_ref().map_or(Rgb::ZERO, |c| c[si.prim as usize] * *scale)
                    }
                },
                Geometry::Sphere { .. } => Rgb::ZERO,
            },
            tex => tex.eval(si.uv),
        }
    }

    /// Radiance the surface at `si` emits towards `wo`: the front of its geometric normal; for a shape
    /// that `emit_by_shading_normal`, the front of its shading normal, on either side of the face if it
    /// `emits_behind`.
    pub fn emitted(&self, si: &SurfaceHit, wo: Vec3) -> crate::color::Rgb {
        let s = &self.shapes[si.shape as usize];
        let facing = wo.dot(si.ng) > 0.0 || s.emits_behind();
        if s.emission != crate::color::Rgb::ZERO && facing && self.emits_towards(si.shape, si.prim, si.p, wo) {
            self.radiance_at(si.shape, || si.uv)
        } else {
            crate::color::Rgb::ZERO
        }
    }

    /// Whether point `p` of primitive `prim` of emitter `shape` emits towards `w` as far as its shading
    /// normal says: always, but for a shape that `emit_by_shading_normal`, where `w` must lie in front
    /// of the vertex normals interpolated at `p` (as given in the mesh, not turned towards the face's).
    /// The side of the face is the caller's test (`Shape::emits_behind`).
    pub fn emits_towards(&self, shape: u32, prim: u32, p: Vec3, w: Vec3) -> bool {
        let s = &self.shapes[shape as usize];
        if !s.emit_by_shading_normal {
            return true;
        }
        match &s.geometry {
            Geometry::Mesh(m) => m.interpolated_normal(prim as usize, p).is_none_or(|n| n.dot(w) > 0.0),
            Geometry::Sphere { .. } => true,
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.shapes
            .iter()
            .map(|s| match &s.geometry {
                Geometry::Mesh(m) => m.indices.len(),
                Geometry::Sphere { .. } => 0,
            })
            .sum()
    }

    /// The length of the bounds' diagonal, worked out in f64 (in f32 its square overflows for a scene
    /// wider than about 1e19), at most f32::MAX.
    pub fn diagonal(&self) -> f32 {
        (self.bounds.1.as_dvec3() - self.bounds.0.as_dvec3()).length().min(f32::MAX as f64) as f32
    }

    /// Radiance a shape emits at the point whose texture coordinates `uv` gives (its emission, times
    /// its texture's value there; `uv` is called only on a textured emitter).
    #[inline(always)]
    pub fn radiance_at(&self, shape: u32, uv: impl FnOnce() -> glam::Vec2) -> Rgb {
        let s = &self.shapes[shape as usize];
        match s.emission_texture {
            None => s.emission,
            Some(t) => s.emission * self.textures[t as usize].eval(uv()),
        }
    }

    /// Surface data at a hit (shape, primitive, barycentrics u,v, distance t along `ray`).
    pub fn surface(&self, ray: &crate::math::Ray, shape: u32, prim: u32, u: f32, v: f32, t: f32) -> SurfaceHit {
        // Texture coordinates cost trigonometry on a sphere and three more vertex reads on a mesh: only
        // a textured material reads them.
        let s = &self.shapes[shape as usize];
        let textured = s.emission_texture.is_some() || self.reads_uv(s.material);
        match &s.geometry {
            Geometry::Mesh(m) => {
                let [i0, i1, i2] = m.indices[prim as usize];
                let (a, b, c) = (m.positions[i0 as usize], m.positions[i1 as usize], m.positions[i2 as usize]);
                let p = a * (1.0 - u - v) + b * u + c * v;
                let ng = (b - a).cross(c - a).normalize_or_zero();
                let ng = if ng == Vec3::ZERO { -ray.d.normalize() } else { ng };
                let ns = match &m.normals {
                    Some(ns) => {
                        let n = (ns[i0 as usize] * (1.0 - u - v) + ns[i1 as usize] * u + ns[i2 as usize] * v)
                            .normalize_or_zero();
                        if n == Vec3::ZERO {
                            ng
                        } else if n.dot(ng) < 0.0 {
                            -n
                        } else {
                            n
                        }
                    }
                    None => ng,
                };
                let scale = max_edge(a, b, c);
                let uv = if textured { m.uv_at(prim as usize, [u, v]) } else { glam::Vec2::ZERO };
                SurfaceHit { p, ng, ns, shape, prim, scale, uv }
            }
            Geometry::Sphere { center, radius, frame, inward } => {
                let p = ray.at(t);
                let n = (p - *center).normalize();
                let p = *center + n * *radius;
                let uv = if textured { sphere_uv_at(*frame, n) } else { glam::Vec2::ZERO };
                let n = if *inward { -n } else { n };
                SurfaceHit { p, ng: n, ns: n, shape, prim, scale: *radius, uv }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(got: Vec3, want: [f32; 3]) {
        assert!((got - Vec3::from(want)).abs().max_element() < 2e-4, "{got} against Mitsuba's {want:?}");
    }

    /// Mitsuba 3.9.1's ∂p/∂u and ∂p/∂v on a sphere of radius 2 about (0.5, 0, 0), read off its
    /// `ray_intersect` at the same point: unturned, and turned 40° about (1, 1, 0)/√2 (its to_world's
    /// linear part over the radius is the rotation R; caustica's frame, world to own, is Rᵀ).
    #[test]
    fn sphere_partials_are_mitsubas() {
        let (c, p) = (Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.946647, 0.631098, 1.84451));
        let (du, dv) = sphere_dp_duv(c, 2.0, None, p);
        close(du, [-3.9653, 2.80636, 0.0]);
        close(dv, [3.34754, 4.72997, -2.42896]);
        // R's rows, each the column of Rᵀ.
        let rows = [1.76604, 0.233956, 0.909039, 0.233956, 1.76604, -0.909039, -0.909039, 0.909039, 1.53209];
        let frame = glam::Mat3::from_cols_array(&rows.map(|x| x / 2.0));
        let (du, dv) = sphere_dp_duv(c, 2.0, Some(frame), p);
        close(du, [-8.30521, -3.11781, 3.07786]);
        close(dv, [-2.57394, 5.58525, -1.28771]);
    }

    /// Mitsuba 3.9.1's `bumpmap` over an anisotropic rough conductor (reflectance 1, Beckmann, α 0.05
    /// along the tangent, 0.4 across) on a surface whose geometric normal is +z: its own `eval` at
    /// directions c (the camera's side) and l, from `scripts/peer/bumpmap_flip_cases.py`. In the last
    /// four cases c lies behind the bent normal, which Mitsuba flips about the shading normal before it
    /// builds the tangent from it; with the tangent of the unflipped normal the first of them read
    /// 0.0659 (random scene 3322: a bump-mapped, turned aluminium cube at 0.41 of Mitsuba's mean).
    #[test]
    fn a_bump_maps_tangent_follows_its_flipped_normal() {
        use material::{Fresnel, Mapped, Microfacet, Nested, TransportMode};
        #[allow(clippy::type_complexity)]
        let cases: [([f32; 3], [f32; 3], [f32; 3], [f32; 2], [f32; 3], [f32; 3], f32); 7] = [
            (
                [0.07281852, 0.2312196, 0.9701726],
                [1.663529, -0.2747928, -0.1199002],
                [0.3735534, 0.507898, 0.1927371],
                [0.42, -0.3],
                [-0.7022601, 0.6065322, 0.3727592],
                [0.8040769, 0.5866248, 0.09660045],
                1.7873721e-01,
            ), // c in front of the bent normal
            (
                [0.08297125, -0.1853863, 0.9791566],
                [1.639242, 0.2576907, 0.1327771],
                [-0.05520098, 1.06727, -0.04813744],
                [0.42, -0.3],
                [-0.2155862, 0.6464877, 0.7318308],
                [-0.5008865, 0.1033634, 0.8593188],
                1.127_019e-1,
            ), // c in front of the bent normal
            (
                [0.2184287, 0.04798478, 0.9746724],
                [1.832395, 0.2871179, 0.2215439],
                [-0.4427041, 1.573286, -0.1818115],
                [0.42, -0.3],
                [0.5639943, 0.7993257, 0.2073374],
                [-0.6296337, -0.5638276, 0.5344716],
                1.1156595e+01,
            ), // c in front of the bent normal
            (
                [0.09168946, -0.2412155, 0.9661305],
                [1.493764, 0.07619855, 0.07032259],
                [-0.05301573, 0.8377375, 0.1355263],
                [0.42, -0.3],
                [0.9674332, -0.2510193, 0.03259168],
                [-0.6068694, -0.6245251, 0.4916075],
                1.9180384e+00,
            ), // c behind the bent normal: flipped
            (
                [0.1979937, 0.2334137, 0.9520066],
                [1.703455, 0.1821749, -0.1137405],
                [0.4849171, 1.360489, 0.1915015],
                [0.42, -0.3],
                [0.8390679, -0.5235661, 0.1477957],
                [-0.3511415, 0.07069684, 0.9336496],
                3.4011424e-01,
            ), // c behind the bent normal: flipped
            (
                [-0.1051468, 0.2785201, 0.9546574],
                [0.9731886, 0.2084288, -0.2265009],
                [-0.0447213, 1.70324, 0.2461594],
                [0.42, -0.3],
                [0.8114721, -0.1952034, 0.5508254],
                [-0.7268347, 0.6505305, 0.2202758],
                1.3134892e-01,
            ), // c behind the bent normal: flipped
            (
                [-0.1248267, -0.2431915, 0.9619128],
                [0.8795581, 0.4609022, -0.03434731],
                [-0.2939471, 0.6134493, 0.08753062],
                [0.42, -0.3],
                [0.6577495, -0.6768917, 0.330429],
                [0.8804659, -0.291204, 0.374139],
                6.487_651e-2,
            ), // c behind the bent normal: flipped
        ];
        let nested = Material::Conductor {
            fresnel: Fresnel::Constant(Rgb::ONE),
            alpha: 0.05,
            alpha_v: 0.4,
            tangent: Vec3::ZERO,
            distribution: Microfacet::Beckmann,
        };
        let mapped = Mapped {
            normal: Vec3::ZERO,
            mirror_back: false,
            nested: Nested::new(nested).unwrap(),
            nested_two_sided: false,
            flipped_tangent: None,
        };
        for (ns, dp_du, dp_dv, g, c, l, want) in cases {
            let (ns, dp_du, c, l) = (Vec3::from(ns), Vec3::from(dp_du), Vec3::from(c), Vec3::from(l));
            let s = shading_tangent(ns, dp_du);
            let m = bump_mapped(mapped, Vec3::Z, ns, s, (dp_du, Vec3::from(dp_dv)), glam::Vec2::from(g));
            let got = m.eval(c, l, ns, TransportMode::Radiance).x * l.dot(ns).abs();
            assert!((got - want).abs() < 1e-3 * want, "{c}, {l}: {got} vs Mitsuba's {want}");
            let back = m.eval(l, c, ns, TransportMode::Importance).x * l.dot(ns).abs();
            assert!((back - got).abs() <= 1e-6 * got, "{c}, {l}: light paths read {back}, camera paths {got}");
        }
    }

    /// Mitsuba 3.9.1's `bumpmap` frame, from its own evaluations: a surface with geometric normal +z,
    /// a tilted shading normal, ∂p/∂u (2, 0, 0.3), ∂p/∂v (0.1, 1.5, 0) and a height gradient (1.68,
    /// −1.12). Its BSDF values equal those of its `normalmap` with the normal below (an isotropic rough
    /// conductor, eight pairs of directions, to 1e-6), and over an anisotropic one they equal the
    /// nested BSDF's in the frame of the tangent below, not of the shading tangent made orthogonal to
    /// that normal (what its `normalmap` uses): worked out in numpy from those values.
    #[test]
    fn bump_frame_is_mitsubas() {
        let ns = Vec3::new(0.1, 0.2, 1.0).normalize();
        let dp_du = Vec3::new(2.0, 0.0, 0.3);
        let s = (dp_du - ns * ns.dot(dp_du)).normalize();
        let g = glam::Vec2::new(1.68, -1.12);
        let (n, t) = bump_frame(Vec3::Z, ns, s, dp_du, Vec3::new(0.1, 1.5, 0.0), g);
        close(n, [-0.478212, 0.652470, 0.587874]);
        close(t, [0.876604, 0.313725, 0.364885]);
        // Flat: the shading normal and tangent; seen from the other side of the geometric normal, the
        // bent normal turns to it.
        let (n, t) = bump_frame(Vec3::Z, Vec3::Z, Vec3::X, Vec3::X, Vec3::Y, glam::Vec2::ZERO);
        assert_eq!((n, t), (Vec3::Z, Vec3::X));
        let (n, _) = bump_frame(Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y, Vec3::X, glam::Vec2::new(0.5, 0.0));
        close(n, [0.0, -0.447214, 0.894427]);
        // Degenerate: ∂p/∂u along ∂p/∂v leaves the shading normal.
        let (n, _) = bump_frame(Vec3::Z, Vec3::Z, Vec3::X, Vec3::X, Vec3::X, glam::Vec2::ZERO);
        assert_eq!(n, Vec3::Z);
    }
}
