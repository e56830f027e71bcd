//! The scene file format: serde structs that mirror the TOML one to one, with defaults.
//! Unknown keys are refused (`deny_unknown_fields`), so a typo is an error, not a silent default.
//!
//! ```toml
//! [camera]
//! origin = [0.0, 1.0, 3.9]
//! target = [0.0, 1.0, 0.0]
//! fov = 39.3                 # degrees, along fov_axis ("x" default, or "y")
//! resolution = [512, 512]
//! # projection = "orthographic" with film_size = [w, h] in scene units instead of fov
//!
//! [materials]
//! white = { type = "diffuse", reflectance = [0.8, 0.8, 0.8] }
//! glass = { type = "dielectric", ior = 1.5 }
//! gold  = { type = "conductor", preset = "Au", roughness = 0.05 }
//!
//! [[shapes]]
//! type = "sphere"
//! center = [0.4, 0.3, 0.2]
//! radius = 0.3
//! material = "glass"
//!
//! [[lights]]
//! type = "quad"
//! corner = [-0.25, 1.98, -0.25]
//! edge_u = [0.5, 0.0, 0.0]
//! edge_v = [0.0, 0.0, 0.5]
//! power = [30.0, 30.0, 30.0]
//! ```
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub type V3 = [f32; 3];

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: CameraSpec,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub textures: BTreeMap<String, TextureSpec>,
    #[serde(default)]
    pub shapes: Vec<ShapeSpec>,
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    #[serde(default)]
    pub render: RenderSettings,
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum FovAxis {
    X,
    Y,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub origin: V3,
    pub target: V3,
    #[serde(default = "default_up")]
    pub up: V3,
    /// `perspective` (the default: a pinhole, or a thin lens with an aperture) or `orthographic`.
    #[serde(default, skip_serializing_if = "Projection::is_perspective")]
    pub projection: Projection,
    /// A perspective camera's field of view in degrees along `fov_axis` (default 40 along x); on an
    /// orthographic camera without `film_size`, the film it spans at the target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov_axis: Option<FovAxis>,
    /// An orthographic camera's film: its width and height in scene units, centred on `origin` (default:
    /// the film `fov` spans at the target when a `fov` is given, so that a perspective scene switched to
    /// orthographic keeps its framing there; else Mitsuba's, 2 wide and as high as the resolution's
    /// aspect makes square pixels).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub film_size: Option<[f32; 2]>,
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 2],
    /// Render only a window of the film: `[x, y, width, height]` in pixels of `resolution`, from its
    /// top-left corner (Mitsuba's film crop). The image is `width` × `height`, each pixel what the same
    /// pixel of the whole film shows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop: Option<[u32; 4]>,
    /// Shifts the film in its plane (a shift lens; Mitsuba's perspective `principal_point_offset_x`,
    /// `_y`): `[x, y]` in film widths and heights, each pixel then seeing what the pixel x film widths to
    /// its right and y film heights below saw. The view axis stays where it was (no keystone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub principal_point_offset: Option<[f32; 2]>,
    /// Pixel reconstruction filter: `{ type = "box" }` (default), `{ type = "tent", radius = 1.0 }` or
    /// `{ type = "gaussian", stddev = 0.5 }` (Mitsuba's film's default).
    #[serde(default, skip_serializing_if = "is_box_filter")]
    pub filter: crate::scene::camera::FilterSpec,
    /// Thin lens (depth of field): the aperture's radius in scene units; 0 (the default) is a pinhole,
    /// everything sharp.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub aperture_radius: f32,
    /// Distance from the lens to the plane in focus, along the view direction (default: the distance
    /// from `origin` to `target`). Read only with an aperture.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focus_distance: Option<f32>,
    /// Clipping planes (Mitsuba's `near_clip` and `far_clip`): the camera sees only what lies between
    /// these depths, measured along the view direction from the lens (default 0 and no far plane).
    /// What is nearer is cut away from the view (a cutaway through a wall) but still casts shadows and
    /// shows in mirrors; where the view reaches the far plane it sees the sky.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near_clip: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub far_clip: Option<f32>,
    /// The image mirrored left to right (default false): what lay on the film's right shows on its left,
    /// as a camera whose `to_world` has a negative determinant sees it (Mitsuba's `<scale x="-1"/>`
    /// before `lookat`, common in converted scenes). Crop windows and the principal point offset are
    /// read on the mirrored film.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub mirror: bool,
    /// The medium the camera sits in (Mitsuba's sensor `medium`): fog round the whole scene, water
    /// round an underwater camera. Camera paths start in it, from the near clipping plane, and carry it
    /// until they cross a shape that bounds a medium (a dielectric's or null material's `absorption` /
    /// `outside_absorption`); a surface without media keeps it on both sides. Rendered by the path
    /// tracer alone (`--mode path`). None (the default): the camera sits in vacuum.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub medium: Option<CameraMediumSpec>,
}

/// `[camera.medium]`: its extinction σ_t per channel and unit of scene length (`absorption`, as a
/// dielectric's), what share of it scatters (`albedo`, each channel in [0, 1]; none: it only absorbs)
/// and the Henyey–Greenstein asymmetry of its phase function (`phase_g` in (−1, 1), 0: isotropic), or
/// its lobes (`phase`).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraMediumSpec {
    pub absorption: V3,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<V3>,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub phase_g: f32,
    /// One or two lobes in place of `phase_g`, as a dielectric's `phase` (`LobeSpec`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase: Option<Vec<LobeSpec>>,
}

fn is_box_filter(f: &crate::scene::camera::FilterSpec) -> bool {
    *f == crate::scene::camera::FilterSpec::Box
}

fn default_up() -> V3 {
    [0.0, 1.0, 0.0]
}
/// The field of view of a perspective camera that does not give one, in degrees along x.
pub const DEFAULT_FOV: f32 = 40.0;

/// How the camera projects the scene onto its film.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Projection {
    /// Rays from the pinhole (or a thin lens's aperture) through the film: a field of view.
    #[default]
    Perspective,
    /// Parallel rays along the view direction, each from its point of a film of `film_size`.
    Orthographic,
}

impl Projection {
    fn is_perspective(&self) -> bool {
        *self == Projection::Perspective
    }
}
fn default_resolution() -> [u32; 2] {
    [512, 512]
}

/// A reflectance: an `[r, g, b]` colour or the name of an entry in `[textures]`.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(untagged, expecting = "an [r, g, b] colour or the name of a [textures] entry")]
pub enum Reflectance {
    Colour(V3),
    Texture(String),
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MaterialSpec {
    /// Lambertian reflector; `two_sided = false` makes its back black (Mitsuba's one-sided BSDFs).
    Diffuse {
        reflectance: Reflectance,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        two_sided: bool,
    },
    /// Perfect (or rough) mirror of a `specular` colour. Here and on the other conductors, the plastic
    /// and the dielectrics, `specular`, `tint` and `roughness` may name a `[textures]` entry instead
    /// (a roughness by the texture's luminance), read at each hit.
    Mirror {
        #[serde(default = "white")]
        specular: Reflectance,
        #[serde(default = "smooth", skip_serializing_if = "is_smooth")]
        roughness: Weight,
        /// Roughness across the surface's tangent (anisotropic; `roughness` then runs along the tangent,
        /// ∂p/∂u of the shape's texture coordinates or, on a mesh without them, its triangles' first edge,
        /// as Mitsuba's `alpha_u` and `alpha_v`): a number > 0 or a texture (read as one number, as
        /// `roughness` may be), with `roughness` not 0.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        roughness_v: Option<Weight>,
        /// Microfacet distribution of a rough mirror: "ggx" (default) or "beckmann".
        #[serde(default, skip_serializing_if = "is_ggx")]
        distribution: crate::scene::material::Microfacet,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        two_sided: bool,
    },
    /// Metal: Schlick Fresnel from a preset ("Au", "Ag", "Cu", "Al", "Cr") or a given F0 colour
    /// (`specular`), or exact Fresnel from a complex index (`eta` and `k`, per channel; `specular` then
    /// scales it).
    Conductor {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        preset: Option<String>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        specular: Option<Reflectance>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        eta: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        k: Option<V3>,
        #[serde(default = "smooth", skip_serializing_if = "is_smooth")]
        roughness: Weight,
        /// Roughness across the surface's tangent (anisotropic; `roughness` then runs along the tangent,
        /// ∂p/∂u of the shape's texture coordinates or, on a mesh without them, its triangles' first edge,
        /// as Mitsuba's `alpha_u` and `alpha_v`): a number > 0 or a texture (read as one number, as
        /// `roughness` may be), with `roughness` not 0.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        roughness_v: Option<Weight>,
        #[serde(default, skip_serializing_if = "is_ggx")]
        distribution: crate::scene::material::Microfacet,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        two_sided: bool,
    },
    /// Plastic: a diffuse base (`reflectance`, a colour or a texture) under a clear coat of index `ior`
    /// (default 1.49, polypropylene) that mirrors F·`specular`; `nonlinear` darkens and saturates the
    /// base as light bouncing inside the coat does (Mitsuba's `plastic`). A coat `roughness` α > 0 makes
    /// its reflection glossy, with the GGX (default) or Beckmann `distribution` (Mitsuba's `roughplastic`).
    Plastic {
        reflectance: Reflectance,
        #[serde(default = "white")]
        specular: Reflectance,
        #[serde(default = "polypropylene")]
        ior: f32,
        #[serde(default = "one")]
        outside_ior: f32,
        #[serde(default, skip_serializing_if = "is_false")]
        nonlinear: bool,
        #[serde(default, skip_serializing_if = "is_zero")]
        roughness: f32,
        #[serde(default, skip_serializing_if = "is_ggx")]
        distribution: crate::scene::material::Microfacet,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        two_sided: bool,
    },
    /// A thin pane of glass (no refraction offset): reflects or lets light through unbent.
    #[serde(rename = "thin_dielectric")]
    ThinDielectric {
        ior: f32,
        #[serde(default = "one")]
        outside_ior: f32,
        #[serde(default = "white")]
        tint: Reflectance,
    },
    /// Glass or water: exact Fresnel, refraction and total internal reflection; smooth, or frosted with
    /// a microfacet `roughness` (α, as a rough conductor's).
    Dielectric {
        ior: f32,
        /// Index of the medium around the object (1 = air; 1.33 for glass under water).
        #[serde(default = "one")]
        outside_ior: f32,
        #[serde(default = "white")]
        tint: Reflectance,
        #[serde(default = "smooth", skip_serializing_if = "is_smooth")]
        roughness: Weight,
        /// Roughness across the surface's tangent (anisotropic; `roughness` then runs along the tangent,
        /// ∂p/∂u of the shape's texture coordinates or, on a mesh without them, its triangles' first edge,
        /// as Mitsuba's `alpha_u` and `alpha_v`): a number > 0 or a texture (read as one number, as
        /// `roughness` may be), with `roughness` not 0.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        roughness_v: Option<Weight>,
        #[serde(default, skip_serializing_if = "is_ggx")]
        distribution: crate::scene::material::Microfacet,
        /// Coloured glass: what the inside of a shape made of this material absorbs, as an absorption
        /// coefficient σ per channel per unit of scene length (≥ 0): light that travels a distance d
        /// inside keeps e^(−σd) of itself (Beer–Lambert; Mitsuba's `homogeneous` interior medium of
        /// albedo 0). σ = 1 keeps 37% over one unit, 2.3 keeps 10%. The shape must be closed, its
        /// normals facing out. Default: none (clear glass).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        absorption: Option<V3>,
        /// What the medium around the object absorbs, likewise, between its surface and the next one
        /// (the glass round a liquid whose surface this material is, beside `outside_ior`; Mitsuba's
        /// `exterior` medium). Default: none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        outside_absorption: Option<V3>,
        /// A medium inside that scatters as well as absorbs (Mitsuba's `homogeneous` medium's
        /// `albedo`): per channel the share of `absorption`, then the medium's extinction σ_t, that
        /// scatters rather than is absorbed, in [0, 1] (milk, jade, fog in a glass). Only the path tracer
        /// renders it (`--mode path`). Default: none (the medium only absorbs).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        albedo: Option<V3>,
        /// The Henyey–Greenstein asymmetry of the inside medium's scattering, in (−1, 1): 0 (the default)
        /// scatters alike in every direction (Mitsuba's `isotropic` phase function), > 0 mostly onwards,
        /// < 0 mostly back (Mitsuba's `hg` and its `g`).
        #[serde(default, skip_serializing_if = "is_zero")]
        phase_g: f32,
        /// `albedo` for the medium outside (with `outside_absorption`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        outside_albedo: Option<V3>,
        /// `phase_g` for the medium outside.
        #[serde(default, skip_serializing_if = "is_zero")]
        outside_phase_g: f32,
        /// The inside medium's phase function as one or two lobes, in place of `phase_g` (`LobeSpec`):
        /// `[{ type = "rayleigh" }]`, or a blend such as `[{ type = "hg", g = 0.8, weight = 0.7 },
        /// { type = "rayleigh", weight = 0.3 }]` (Mitsuba's `rayleigh` and `blendphase`), or a table of
        /// values over the cosine, `[{ type = "table", values = [0.2, 0.3, 1.0, 4.0] }]` (Mitsuba's
        /// `tabphase`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        phase: Option<Vec<LobeSpec>>,
        /// `phase` for the medium outside.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        outside_phase: Option<Vec<LobeSpec>>,
    },
    /// Two of the other `[materials]`, by name, mixed (Mitsuba's `blendbsdf`): at each hit the surface is
    /// `second` with probability `weight` (a number in [0, 1], or the name of a `[textures]` entry,
    /// read as its luminance; default ½) and `first` otherwise. Blends may nest, not contain themselves.
    Blend {
        #[serde(default = "half_weight")]
        weight: Weight,
        first: String,
        second: String,
    },
    /// A surface that is one of the other `[materials]` in front (the side its geometric normal faces)
    /// and another behind (Mitsuba's `twosided` with two BSDFs): `back` is seen from behind as it would
    /// be from its own front, so it must be two-sided, and neither side may let light through.
    Sides { front: String, back: String },
    /// Another of the `[materials]`, by name, under a tangent-space normal map (Mitsuba's `normalmap`):
    /// `normal_map` names a `[textures]` entry whose colour c gives the normal as 2c − 1 in the frame of
    /// ∂p/∂u (along the texture's u) made orthogonal to the shading normal, the normal × that, and the
    /// normal (use `raw = true` for an image of normals). The material is taken about that normal, as
    /// Mitsuba 3 does (its reflection about the shading normal where the viewer is below it, and the
    /// bump-terminator shadowing of Conty Estevez et al. 2019). `two_sided = true` (Mitsuba's `twosided`
    /// around the `normalmap`) shows the mirror image of the front behind the surface, whatever the
    /// material's own sides. Only on a shape's own material (not inside a blend or a side of `sides`),
    /// on meshes with texture coordinates and spheres; over any material but a thin pane or a null
    /// surface. Photons are stored on it where its material holds them (diffuse, a plastic's base) and
    /// gathered about the mapped normal; a mapped diffuse surface scatters diffusely (no caustic target,
    /// no extra eye samples). Over metal or glass the photon mappers follow camera paths across it.
    Normalmap {
        normal_map: String,
        material: String,
        #[serde(default)]
        two_sided: bool,
    },
    /// Another of the `[materials]`, by name, under a bump map (Mitsuba's `bumpmap`): the surface as
    /// if displaced along its shading normal by `scale` (default 1) times the `height` texture's value
    /// (a bitmap, read by luminance; use `raw = true` for heights stored as numbers, not colours), of
    /// which only the gradient along the texture's u and v counts. It bends the normal the material is
    /// taken about, with everything a normal map does (`normalmap`'s reflection, shadowing, `two_sided`
    /// and restrictions); a bump map of a checkerboard is refused (it has no gradient), and one on a
    /// disk (whose triangles do not follow its ∂p/∂v, which shrinks towards the centre).
    Bumpmap {
        height: String,
        #[serde(default = "one")]
        scale: f32,
        material: String,
        #[serde(default)]
        two_sided: bool,
        /// Turn the bent normal to the back of the surface's geometric normal rather than its front, as
        /// Mitsuba's `bumpmap` does on a shape whose `to_world` mirrors (its geometric normal turned
        /// inward there, its shading normal not): the material then lets light only where the bumps
        /// are steep, at grazing angles, and is black elsewhere. The Mitsuba import sets it.
        #[serde(default, skip_serializing_if = "is_false")]
        to_back: bool,
    },
    /// Mitsuba's `principled` BSDF (Burley's "Disney" model as Mitsuba 3 writes it): `base_color` (a
    /// colour or a texture, default ½) and `roughness` (a number or a texture read by luminance,
    /// default ½) and, each a number in [0, 1] defaulting to 0 or a texture read per hit by luminance:
    /// `metallic`, `spec_trans` (transmission), `spec_tint`, `sheen`, `sheen_tint`, `flatness`,
    /// `clearcoat`, `clearcoat_gloss`;
    /// the dielectric index as `eta` (inside over outside) or `specular` (in [0, 1], default ½: η 1.5),
    /// not both. `two_sided` (default: true unless it transmits; a transmitting one cannot be) mirrors
    /// the front onto the back (Mitsuba's `twosided`); one-sided, the back reflects only what its
    /// transmission lobe does. The photon mappers follow camera paths through it, as through rough
    /// metal; only the caustic pass's photons of point, spot and distant lights are kept on it, for
    /// camera paths that see it past a mirror or glass.
    Principled {
        #[serde(default = "grey")]
        base_color: Reflectance,
        #[serde(default = "half_weight")]
        roughness: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        metallic: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        spec_trans: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        spec_tint: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        sheen: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        sheen_tint: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        flatness: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        clearcoat: Weight,
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        clearcoat_gloss: Weight,
        /// The specular and transmission lobes stretched along the surface's tangent (∂p/∂u, as
        /// `roughness_v` takes it), Mitsuba's `anisotropic`: a number in [0, 1] or a texture.
        #[serde(default = "zero_weight", skip_serializing_if = "is_zero_weight")]
        anisotropic: Weight,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        specular: Option<f32>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        eta: Option<f32>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        two_sided: Option<bool>,
    },
    /// No surface: light passes straight through, unbent and undimmed (Mitsuba's `null`). A blend of it
    /// with another material is a cut-out (Mitsuba's `mask`: `weight` is the opacity). A closed shape
    /// of it may bound a medium (smoke in a box; Mitsuba's `null` boundary of a `homogeneous` medium):
    /// `absorption`, `albedo`, `phase_g` and their `outside_` kin as a dielectric's, rendered by the
    /// path tracer alone (`--mode path`).
    Null {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        absorption: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        outside_absorption: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        albedo: Option<V3>,
        #[serde(default, skip_serializing_if = "is_zero")]
        phase_g: f32,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        outside_albedo: Option<V3>,
        #[serde(default, skip_serializing_if = "is_zero")]
        outside_phase_g: f32,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        phase: Option<Vec<LobeSpec>>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        outside_phase: Option<Vec<LobeSpec>>,
    },
}

/// One lobe of a medium's phase function (`phase`): `{ type = "hg", g = 0.8 }` (Henyey–Greenstein,
/// g in (−1, 1)), `{ type = "isotropic" }`, `{ type = "rayleigh" }` (3/(16π)·(1 + cos²θ)) or
/// `{ type = "table", values = [...] }` (Mitsuba's `tabphase`: values at n ≥ 2 cosines evenly spaced
/// from −1, back, to 1, onwards, linear between them, each ≥ 0, scaled to integrate to 1); two lobes
/// blend, each with its `weight` (the two summing to 1), as Mitsuba's `blendphase` does.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LobeSpec {
    #[serde(rename = "type")]
    pub kind: LobeKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub g: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weight: Option<f32>,
    /// A `table` lobe's values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f32>>,
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum LobeKind {
    Hg,
    Isotropic,
    Rayleigh,
    Table,
}

/// One side's medium as a dielectric's or a null material's keys give it: `absorption`, `albedo`,
/// `phase_g` and `phase` for the inside, their `outside_` kin for the outside (`MaterialSpec::media`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MediumKeys {
    pub absorption: Option<V3>,
    pub albedo: Option<V3>,
    pub phase_g: f32,
    pub phase: Option<Vec<LobeSpec>>,
}

/// The pattern that binds the media fields of the materials that hold media (a dielectric, a null
/// surface) to the names given, in the order `absorption`, `outside_absorption`, `albedo`, `phase_g`,
/// `outside_albedo`, `outside_phase_g`, `phase`, `outside_phase` (`MaterialSpec::media`, `set_media`).
macro_rules! media_fields {
    ($a:ident, $oa:ident, $al:ident, $g:ident, $oal:ident, $og:ident, $p:ident, $op:ident) => {
        media_fields!(@in [Dielectric Null] $a, $oa, $al, $g, $oal, $og, $p, $op)
    };
    (@in [$($v:ident)+] $a:ident, $oa:ident, $al:ident, $g:ident, $oal:ident, $og:ident, $p:ident, $op:ident) => {
        $(MaterialSpec::$v {
            absorption: $a,
            outside_absorption: $oa,
            albedo: $al,
            phase_g: $g,
            outside_albedo: $oal,
            outside_phase_g: $og,
            phase: $p,
            outside_phase: $op,
            ..
        })|+
    };
}

impl MaterialSpec {
    /// The media inside and outside a dielectric or a null material; None for any other material.
    pub fn media(&self) -> Option<[MediumKeys; 2]> {
        match self {
            media_fields!(
                absorption,
                outside_absorption,
                albedo,
                phase_g,
                outside_albedo,
                outside_phase_g,
                phase,
                outside_phase
            ) => Some([
                MediumKeys { absorption: *absorption, albedo: *albedo, phase_g: *phase_g, phase: phase.clone() },
                MediumKeys {
                    absorption: *outside_absorption,
                    albedo: *outside_albedo,
                    phase_g: *outside_phase_g,
                    phase: outside_phase.clone(),
                },
            ]),
            _ => None,
        }
    }

    /// Gives a dielectric or a null material these media inside and outside; false (and nothing
    /// changed) for any other material.
    pub fn set_media(&mut self, [inside, outside]: [MediumKeys; 2]) -> bool {
        match self {
            media_fields!(
                absorption,
                outside_absorption,
                albedo,
                phase_g,
                outside_albedo,
                outside_phase_g,
                phase,
                outside_phase
            ) => {
                (*absorption, *albedo, *phase_g, *phase) =
                    (inside.absorption, inside.albedo, inside.phase_g, inside.phase);
                (*outside_absorption, *outside_albedo, *outside_phase_g, *outside_phase) =
                    (outside.absorption, outside.albedo, outside.phase_g, outside.phase);
                true
            }
            _ => false,
        }
    }

    /// A `null` material without media.
    pub fn null() -> MaterialSpec {
        MaterialSpec::Null {
            absorption: None,
            outside_absorption: None,
            albedo: None,
            phase_g: 0.0,
            outside_albedo: None,
            outside_phase_g: 0.0,
            phase: None,
            outside_phase: None,
        }
    }

    /// A principled BSDF's weights that may be textures, in `PRINCIPLED_WEIGHTS`' order (metallic,
    /// spec_trans, spec_tint, sheen, sheen_tint, flatness, clearcoat, clearcoat_gloss, anisotropic);
    /// None for another material.
    pub fn principled_weights(&self) -> Option<[&Weight; 9]> {
        // Each field named once: bound by the pattern and listed in that order.
        macro_rules! weights {
            ($($field:ident),*) => {
                match self {
                    MaterialSpec::Principled { $($field,)* .. } => Some([$($field),*]),
                    _ => None,
                }
            };
        }
        weights!(metallic, spec_trans, spec_tint, sheen, sheen_tint, flatness, clearcoat, clearcoat_gloss, anisotropic)
    }

    /// Whether the material itself (not a blend's sides) names a `[textures]` entry.
    pub fn names_texture(&self) -> bool {
        let t = |r: &Reflectance| matches!(r, Reflectance::Texture(_));
        let w = |r: &Weight| matches!(r, Weight::Texture(_));
        match self {
            MaterialSpec::Diffuse { reflectance, .. } => t(reflectance),
            MaterialSpec::Plastic { reflectance, specular, .. } => t(reflectance) || t(specular),
            MaterialSpec::Mirror { specular, roughness, .. } => t(specular) || w(roughness),
            MaterialSpec::Conductor { specular, roughness, .. } => specular.as_ref().is_some_and(t) || w(roughness),
            MaterialSpec::Dielectric { tint, roughness, .. } => t(tint) || w(roughness),
            MaterialSpec::ThinDielectric { tint, .. } => t(tint),
            MaterialSpec::Principled { base_color, roughness, .. } => {
                t(base_color) || w(roughness) || self.principled_weights().into_iter().flatten().any(w)
            }
            MaterialSpec::Blend { weight, .. } => w(weight),
            MaterialSpec::Sides { .. } | MaterialSpec::Null { .. } => false,
            MaterialSpec::Normalmap { .. } | MaterialSpec::Bumpmap { .. } => true,
        }
    }
}

/// A number in [0, 1] (a blend's weight, a roughness) or the name of an entry in `[textures]` (read
/// as its luminance).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(untagged, expecting = "a number in [0, 1] or the name of a [textures] entry")]
pub enum Weight {
    Value(f32),
    Texture(String),
}

fn zero_weight() -> Weight {
    Weight::Value(0.0)
}

fn is_zero_weight(w: &Weight) -> bool {
    *w == Weight::Value(0.0)
}

fn half_weight() -> Weight {
    Weight::Value(0.5)
}

fn smooth() -> Weight {
    Weight::Value(0.0)
}

fn is_smooth(w: &Weight) -> bool {
    *w == Weight::Value(0.0)
}

fn grey() -> Reflectance {
    Reflectance::Colour([0.5; 3])
}

fn white() -> Reflectance {
    Reflectance::Colour([1.0; 3])
}

fn is_repeat(w: &crate::scene::texture::Wrap) -> bool {
    *w == crate::scene::texture::Wrap::Repeat
}

fn one() -> f32 {
    1.0
}

fn polypropylene() -> f32 {
    1.49
}

fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

fn is_true(b: &bool) -> bool {
    *b
}

fn is_ggx(m: &crate::scene::material::Microfacet) -> bool {
    *m == crate::scene::material::Microfacet::Ggx
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// `[textures]`: named patterns and images a diffuse `reflectance` can name. Texture coordinates are
/// mapped by `uv' = uv · scale + offset`, or by a 2×3 `matrix` (rows [a, b, c], [d, e, f]).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum TextureSpec {
    /// Two colours in squares of ½ × ½ in uv (color0 at the origin). Either may name another
    /// `[textures]` entry (not mesh colours), read at the same uv through its own scale and offset.
    Checkerboard {
        #[serde(default = "checker0")]
        color0: Reflectance,
        #[serde(default = "checker1")]
        color1: Reflectance,
        #[serde(default = "one2")]
        scale: [f32; 2],
        #[serde(default)]
        offset: [f32; 2],
        #[serde(default, skip_serializing_if = "Option::is_none")]
        matrix: Option<[[f32; 3]; 2]>,
    },
    /// An image (`texture::load_image`: PNG, JPEG, BMP, TGA, PPM sRGB-decoded unless `raw`; EXR, Radiance
    /// `.hdr`, PFM linear), relative to the scene file.
    Bitmap {
        file: String,
        #[serde(default, skip_serializing_if = "is_false")]
        raw: bool,
        /// Bilinear (default) or nearest-texel lookup.
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        bilinear: bool,
        /// What is read beyond the image's edges: "repeat" (default), "clamp" (the edge texels) or
        /// "mirror" (the image mirrored at each edge), as Mitsuba's `wrap_mode`.
        #[serde(default, skip_serializing_if = "is_repeat")]
        wrap: crate::scene::texture::Wrap,
        #[serde(default = "one2")]
        scale: [f32; 2],
        #[serde(default)]
        offset: [f32; 2],
        #[serde(default, skip_serializing_if = "Option::is_none")]
        matrix: Option<[[f32; 3]; 2]>,
    },
    /// The colours of the hit mesh's vertices, interpolated across each triangle, times `scale`
    /// (default 1): a PLY's `red`/`green`/`blue` (floats as they are, 8- and 16-bit integers as sRGB
    /// values) or a `.serialized` mesh's colours. Every shape whose material reads it must be such a
    /// mesh, its colours times `scale` within [0, 1].
    #[serde(rename = "vertex_color")]
    VertexColor {
        #[serde(default = "one", skip_serializing_if = "is_one")]
        scale: f32,
    },
    /// The colour of the hit triangle, times `scale` (default 1): a PLY face element's
    /// `red`/`green`/`blue`, read as vertex colours are (a polygon's colour on each of its triangles).
    /// Every shape whose material reads it must be such a mesh, its colours times `scale` within [0, 1].
    #[serde(rename = "face_color")]
    FaceColor {
        #[serde(default = "one", skip_serializing_if = "is_one")]
        scale: f32,
    },
}

fn is_one(x: &f32) -> bool {
    *x == 1.0
}

fn checker0() -> Reflectance {
    Reflectance::Colour([0.4; 3])
}
fn checker1() -> Reflectance {
    Reflectance::Colour([0.2; 3])
}
fn one2() -> [f32; 2] {
    [1.0, 1.0]
}

/// Translate / rotate (degrees, applied x then y then z) / scale, or a full 4×4 row-major matrix.
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TransformSpec {
    #[serde(default)]
    pub translate: Option<V3>,
    #[serde(default)]
    pub rotate_x: Option<f32>,
    #[serde(default)]
    pub rotate_y: Option<f32>,
    #[serde(default)]
    pub rotate_z: Option<f32>,
    #[serde(default)]
    pub scale: Option<Scale>,
    #[serde(default)]
    pub matrix: Option<[[f32; 4]; 4]>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    Axes(V3),
}

/// A shape. Every kind but the height field may emit: `emission` is its radiance, an `[r, g, b]`
/// colour or the name of a `[textures]` entry read at each point's texture coordinates (values ≥ 0,
/// any size: an EXR's), from the front of triangles and the outside of spheres (the inside with
/// `flip_normals`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ShapeSpec {
    /// Triangle mesh from an OBJ (with MTL) or PLY (ASCII or binary, optionally .gz) file.
    Mesh {
        file: String,
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
        /// Smooth shading: the file's vertex normals, or area-weighted ones when it has none.
        /// false (default): flat shading, and normals in the file are not even read.
        #[serde(default)]
        smooth: bool,
        /// Turn the surface inside out (reverse every triangle and normal).
        #[serde(default, skip_serializing_if = "is_false")]
        flip_normals: bool,
        /// Which mesh of a Mitsuba `.serialized` file (0, the first, by default; only for those).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        shape_index: Option<u32>,
        /// The texture coordinates' v read upside down (v → 1 − v), Mitsuba's `flip_tex_coords`: by
        /// default true for an OBJ (whose rows count from the bottom of the image) and false for a PLY;
        /// not for a `.serialized` file.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        flip_tex_coords: Option<bool>,
        /// With `emission` and `smooth`: emit only where the direction is in front of each point's
        /// interpolated vertex normal as well as of its face, as Mitsuba's area emitter does on a mesh
        /// with normals (the import sets it): a coarse smooth mesh's silhouettes are then dark.
        #[serde(default, skip_serializing_if = "is_false")]
        emit_by_shading_normal: bool,
        /// A second placement, after `transform` and after the smooth normals a mesh without any are
        /// computed (as placed by `transform`): they follow it as normals. A Mitsuba `instance`'s
        /// `to_world` (the import sets it): Mitsuba computes those normals in the shape group's space,
        /// which an uneven scale makes differ from normals computed after the whole placement.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        instance_transform: Option<TransformSpec>,
    },
    /// Analytic sphere (exact hits; not tessellated).
    Sphere {
        center: V3,
        radius: f32,
        material: String,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
        /// Normals towards the centre: the inside is the front (it emits inwards; glass reads as a
        /// bubble, its inside the outer medium).
        #[serde(default, skip_serializing_if = "is_false")]
        flip_normals: bool,
    },
    /// Parallelogram `corner + s·edge_u + t·edge_v`, s,t ∈ [0,1]; the front side is edge_u × edge_v.
    Quad {
        corner: V3,
        edge_u: V3,
        edge_v: V3,
        material: String,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
        #[serde(default, skip_serializing_if = "is_false")]
        flip_normals: bool,
    },
    /// Disk of `radius` around `center` facing `normal` (tessellated into `segments` triangles).
    Disk {
        center: V3,
        #[serde(default = "default_normal")]
        normal: V3,
        radius: f32,
        material: String,
        #[serde(default = "default_segments")]
        segments: u32,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
        #[serde(default, skip_serializing_if = "is_false")]
        flip_normals: bool,
    },
    /// Surface of revolution: `profile` points [r, y] revolved about the y axis, listed bottom to top
    /// for outward normals (a closed solid goes up the outside and back down the inside).
    Lathe {
        profile: Vec<[f32; 2]>,
        material: String,
        #[serde(default = "default_lathe_segments")]
        segments: u32,
        /// Area-weighted vertex normals (smooth shading).
        #[serde(default = "yes")]
        smooth: bool,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
    },
    /// Open tube (no caps) of `radius` from `p0` to `p1`, as Mitsuba's `cylinder`: `segments` sides with
    /// smooth radial normals, texture coordinates u around the axis (from the first tangent of the
    /// axis's frame, Mitsuba's) and v from `p0` to `p1`; outward, inward with `flip_normals`.
    Cylinder {
        #[serde(default = "origin")]
        p0: V3,
        #[serde(default = "unit_z")]
        p1: V3,
        #[serde(default = "one")]
        radius: f32,
        material: String,
        #[serde(default = "default_cylinder_segments")]
        segments: u32,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
        #[serde(default, skip_serializing_if = "is_false")]
        flip_normals: bool,
    },
    /// Height field y = height + Σ waves over a `size[0]` × `size[1]` rectangle centred on the origin,
    /// normals up; each wave is amplitude · sin(2π (x·cos a + z·sin a)/wavelength + phase).
    Heightfield {
        size: [f32; 2],
        #[serde(default = "default_hf_resolution")]
        resolution: [u32; 2],
        #[serde(default)]
        height: f32,
        #[serde(default)]
        waves: Vec<Wave>,
        material: String,
        #[serde(default)]
        transform: TransformSpec,
    },
    /// Round curves from a text file, as Mitsuba's `linearcurve` and `bsplinecurve`: a control point a
    /// line (`x y z radius`), a blank line between curves. `basis = "linear"` (default): along each
    /// segment the cone touching the spheres round its two points, and those spheres; `"bspline"`: round
    /// the uniform cubic B-spline of each four consecutive points, the circle of the spline of their
    /// radii across it, open at the ends. Tessellated: `segments` round each ring (default up to 128,
    /// fewer where the file has so many segments that the mesh would pass 8 million triangles).
    /// `transform` places the points and leaves the radii as they are (Mitsuba's);
    /// `instance_transform` places the whole surface after it (a Mitsuba instance's `to_world`). Seen
    /// from outside: their material may not let light through, and they do not emit.
    Curves {
        file: String,
        material: String,
        #[serde(default)]
        basis: CurveBasis,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        segments: Option<u32>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        instance_transform: Option<TransformSpec>,
    },
    /// Axis-aligned box from `min` to `max` (then transformed), outward normals.
    Box {
        min: V3,
        max: V3,
        material: String,
        #[serde(default)]
        transform: TransformSpec,
        #[serde(default)]
        emission: Option<Reflectance>,
        #[serde(default, skip_serializing_if = "is_false")]
        flip_normals: bool,
    },
}

/// How a curve file's control points make its curves (`ShapeSpec::Curves`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CurveBasis {
    /// Straight segments between consecutive points (Mitsuba's `linearcurve`).
    #[default]
    Linear,
    /// A uniform cubic B-spline through each four consecutive points (Mitsuba's `bsplinecurve`).
    Bspline,
}

fn default_lathe_segments() -> u32 {
    128
}
fn default_cylinder_segments() -> u32 {
    256
}
fn origin() -> V3 {
    [0.0; 3]
}
fn unit_z() -> V3 {
    [0.0, 0.0, 1.0]
}
fn default_hf_resolution() -> [u32; 2] {
    [256, 256]
}
fn yes() -> bool {
    true
}

/// One sine wave of a height field; `angle` in degrees from the x axis.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Wave {
    pub amplitude: f32,
    pub wavelength: f32,
    #[serde(default)]
    pub angle: f32,
    #[serde(default)]
    pub phase: f32,
}

fn default_normal() -> V3 {
    [0.0, 1.0, 0.0]
}
fn default_cutoff() -> f32 {
    20.0
}

fn default_segments() -> u32 {
    64
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightSpec {
    /// Isotropic point light of total `power` (W per channel).
    Point { position: V3, power: V3 },
    /// Spot light at `position` shining along `direction` (or towards `target`), as Mitsuba 3's `spot`:
    /// full intensity within `beam_width` degrees of its axis (default ¾ of the cutoff), falling
    /// linearly in angle to zero at `cutoff_angle` degrees (default 20); give `intensity` (W/sr on the
    /// axis) or its total `power` (W).
    Spot {
        position: V3,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        direction: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        target: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        intensity: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        power: Option<V3>,
        #[serde(default = "default_cutoff")]
        cutoff_angle: f32,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        beam_width: Option<f32>,
        /// A texture projected along the spot (the name of a `[textures]` entry; Mitsuba's `texture`):
        /// its square spans the cutoff cone's base, u running along `up` × the axis and v towards `up`;
        /// the light in each direction is the intensity (or `power`'s, the slide left out) times the
        /// texture there. Needs `cutoff_angle` < 90.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        texture: Option<String>,
        /// Where the projected texture's v runs (default [0, 1, 0]; any vector off the axis).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        up: Option<V3>,
    },
    /// A projector at `position` shining along `direction` (or towards `target`), as Mitsuba 3's
    /// `projector`: a pinhole lighting a rectangle that spans `fov` degrees along `fov_axis` ("x", the
    /// default, "y", "diagonal", "smaller" or "larger"; its sides in the texture's proportions, or
    /// square) with its x across `up` × the axis and its y towards `up` (default [0, 1, 0]). A surface
    /// facing it at unit distance on the axis receives `irradiance` (W/m², default 1) times the
    /// `texture` there (a `[textures]` entry, optional), and every point of the plane at that distance
    /// the same: its intensity grows as 1/cos³ of the angle off the axis. The image's left column
    /// lights the projector's +x side, as Mitsuba's. Mitsuba's own `irradiance` texture and `scale`
    /// are this irradiance over π.
    Projector {
        position: V3,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        direction: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        target: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        up: Option<V3>,
        fov: f32,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fov_axis: Option<String>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        irradiance: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        texture: Option<String>,
    },
    /// Spherical area light (visible, emits outward); give `power` or `radiance`.
    Sphere {
        center: V3,
        radius: f32,
        #[serde(default)]
        power: Option<V3>,
        #[serde(default)]
        radiance: Option<V3>,
    },
    /// Parallel light from infinitely far away (the sun): travelling along `direction`, giving
    /// `irradiance` (W/m²) to a surface that faces it.
    Distant { direction: V3, irradiance: V3 },
    /// The same radiance from every direction, infinitely far away (a white sky, a furnace).
    Constant { radiance: V3 },
    /// A lat-long environment image (`texture::load_image`: EXR, HDR, PFM linear; 8/16-bit sRGB) around
    /// the scene, Mitsuba's layout (+y up, u = atan2(x, −z)/2π); `transform` may only rotate it.
    Envmap {
        file: String,
        #[serde(default = "one")]
        scale: f32,
        #[serde(default)]
        transform: TransformSpec,
    },
    /// One-sided quad area light facing edge_u × edge_v; give `power` or `radiance`.
    Quad {
        corner: V3,
        edge_u: V3,
        edge_v: V3,
        #[serde(default)]
        power: Option<V3>,
        #[serde(default)]
        radiance: Option<V3>,
    },
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    Path,
    PhotonMap,
    Both,
    /// Probabilistic progressive photon mapping (Knaus & Zwicker 2011).
    Ppm,
    /// Stochastic progressive photon mapping (Hachisuka & Jensen 2009).
    Sppm,
    /// Bidirectional path tracing with MIS over every (s, t) strategy (`render.vcm` without merging).
    Bdpt,
    /// Vertex connection and merging (Georgiev et al. 2012): BDPT and photon merging under one MIS.
    Vcm,
}

impl Mode {
    /// Modes that render in passes and converge as passes accumulate.
    pub fn is_progressive(self) -> bool {
        matches!(self, Mode::Ppm | Mode::Sppm | Mode::Bdpt | Mode::Vcm)
    }

    /// Modes whose images are made from photon maps (built to the counts of `render.photons`).
    pub fn uses_photon_maps(self) -> bool {
        matches!(self, Mode::PhotonMap | Mode::Both | Mode::Ppm | Mode::Sppm)
    }

    /// The name of the mode's image layer (and of `--mode`).
    pub fn layer_name(self) -> &'static str {
        match self {
            Mode::Path => "pt",
            Mode::PhotonMap => "pm",
            Mode::Both => "both",
            Mode::Ppm => "ppm",
            Mode::Sppm => "sppm",
            Mode::Bdpt => "bdpt",
            Mode::Vcm => "vcm",
        }
    }
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DirectLight {
    ShadowRays,
    PhotonMap,
}

/// `[render]`: every field has a default and can be overridden with `--set render.KEY=VALUE`.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSettings {
    pub mode: Mode,
    /// Samples per pixel (path tracer; photon-map eye pass uses `pm_spp`).
    pub spp: u32,
    /// Maximum path length; the furnace test uses a large value with Russian roulette.
    pub max_depth: u32,
    /// Bounces before Russian roulette starts.
    pub rr_depth: u32,
    pub seed: u64,
    /// Camera samples: `sobol` (Owen-scrambled Sobol per pixel for a sample's first 16 draws, padded
    /// after them; the default), `padded` ((0,2)-sequences
    /// per pixel and draw: less time a sample, more noise at high counts) or `independent`.
    pub sampler: crate::math::rng::Sampler,
    /// Preview exposure in stops (PNG only; the EXR is linear radiance).
    pub exposure: f32,
    /// Eye-pass samples per pixel for photon mapping.
    pub pm_spp: u32,
    /// Extra eye samples for pixels whose first hit is not diffuse (photon mapping).
    pub specular_spp: u32,
    pub direct_light: DirectLight,
    /// Final-gather rays at the first diffuse hit (0 = read the indirect map directly).
    pub final_gather: u32,
    /// Run every pass even where the planner finds it useless (for checking the planner).
    pub force_all_passes: bool,
    /// Leave out the light the camera sees directly (emitters and the sky behind the scene, black
    /// there), keeping everything they light and whatever shows them in a mirror or through glass
    /// (Mitsuba's `hide_emitters`).
    pub hide_emitters: bool,
    pub photons: PhotonSettings,
    pub gather: GatherSettings,
    pub progressive: ProgressiveSettings,
    pub vcm: VcmSettings,
}

/// `[render.vcm]`: which halves of vertex connection and merging `--mode vcm` uses (`--mode bdpt` is
/// vcm with `merge = false`). Iterations, time limit, merge radius r_1 and α come from
/// `[render.progressive]` (r_i = r_1 · i^((α−1)/2)); one light subpath and one camera subpath per pixel
/// per iteration.
///
/// ```toml
/// [render.vcm]
/// connect = true   # light sampling, subpath connections, light tracing (false: a progressive photon mapper)
/// merge = true     # vertex merging (false: bdpt)
/// light_paths = 0  # light subpaths per iteration (0 = one per pixel; never fewer than the pixels)
/// aim = 0.2        # share of light subpaths that head for the specular shapes (aimed as needed; 0 = none)
/// local_radius = true  # merge radius set per region from a pilot's light vertices (false: one radius)
/// merge_primary = "caustics" # what the camera's first hit merges with: the light vertices that came
///                       # through a mirror or glass; "all" (or true) every one, "none" (or false) none
///                       # (light tracing alone there); without connections always "all"
/// ```
#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct VcmSettings {
    pub connect: bool,
    pub merge: bool,
    pub light_paths: u64,
    /// Share of the light subpaths that head for the bounding sphere of a specular shape (the
    /// planner's caustic targets): where the lights' own emission sends fewer there, that many more
    /// are aimed (`integrator::vcm::Aim`); every emission density the MIS weights use is the mixture.
    pub aim: f32,
    /// The merge radius follows the light's density over the scene (`integrator::vcm::RadiusField`),
    /// unless `render.progressive.radius` sets one radius.
    pub local_radius: bool,
    /// Which light vertices the camera's first hit merges with (`MergePrimary`). Ignored without
    /// connections (a progressive photon mapper must merge there).
    pub merge_primary: MergePrimary,
}

impl Default for VcmSettings {
    fn default() -> Self {
        VcmSettings {
            connect: true,
            merge: true,
            light_paths: 0,
            aim: 0.2,
            local_radius: true,
            merge_primary: MergePrimary::Caustics,
        }
    }
}

/// `render.vcm.merge_primary`: the light vertices VCM merges with at the camera's first hit. Where it
/// does not merge, that strategy leaves every MIS sum and light tracing finds the same light there from
/// the same light subpaths: less noise on diffuse light, more on a caustic seen directly. `Caustics`
/// (the default) merges only the light vertices whose last bounce was a delta BSDF (a mirror, smooth
/// glass or water), light that no connection brings to the first hit: at 256² and 12 s (session 37,
/// three runs each, min–max) the Cornell box's RMSE 0.0093–0.0099 with all, 0.0084–0.0085 with none
/// (caustics is none there: no delta BSDF), the glass box 0.0123–0.0134 / 0.0112–0.0120 / caustics
/// 0.0113–0.0124, the cardioid 0.0128–0.0130 with all, 0.0120–0.0122 with caustics (0.0172 with none).
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MergePrimary {
    All,
    Caustics,
    None,
}

impl<'de> Deserialize<'de> for MergePrimary {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(match MergePrimaryRepr::deserialize(d)? {
            MergePrimaryRepr::Flag(true) | MergePrimaryRepr::Name(MergePrimaryName::All) => MergePrimary::All,
            MergePrimaryRepr::Name(MergePrimaryName::Caustics) => MergePrimary::Caustics,
            MergePrimaryRepr::Flag(false) | MergePrimaryRepr::Name(MergePrimaryName::None) => MergePrimary::None,
        })
    }
}

/// What `merge_primary` may be written as: the old switch (true, false) or a name.
#[derive(Deserialize)]
#[serde(untagged, expecting = "true, false, \"all\", \"caustics\" or \"none\"")]
enum MergePrimaryRepr {
    Flag(bool),
    Name(MergePrimaryName),
}

#[derive(Deserialize)]
#[serde(rename_all = "snake_case")]
enum MergePrimaryName {
    All,
    Caustics,
    None,
}

/// `[render.progressive]`: the progressive modes (`ppm`, `sppm`).
///
/// ```toml
/// [render.progressive]
/// passes = 64              # stop after this many passes ...
/// first_pass = 1           # ppm: start at this pass (a share of a render: passes are independent)
/// time_s = 0.0             # ... or after this many seconds (0 = no time limit)
/// photons_per_pass = 100000
/// alpha = 0.6667           # radius shrinkage: r_i² = r_1² Π (k + α)/(k + 1)
/// radius = 0.0             # initial gather radius in scene units (0 = automatic)
/// edge_correction = true   # sppm: divide each pixel's photons by the part of its disc that is surface;
///                          # ppm: multiply each gather's photons by an estimate of 1 / that part
/// ```
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProgressiveSettings {
    pub passes: u32,
    pub first_pass: u32,
    pub time_s: f64,
    pub photons_per_pass: u64,
    pub alpha: f32,
    pub radius: f32,
    /// SPPM: probe how much of each pixel's gather disc lies on a surface that could hold its photons,
    /// and divide by that area instead of the whole disc's (no dark band along walls and edges). PPM:
    /// multiply each gather's photons by an unbiased estimate of 1 / that part (`edges`).
    pub edge_correction: bool,
}

impl Default for ProgressiveSettings {
    fn default() -> Self {
        ProgressiveSettings {
            passes: 64,
            first_pass: 1,
            time_s: 0.0,
            photons_per_pass: 100_000,
            alpha: 2.0 / 3.0,
            radius: 0.0,
            edge_correction: true,
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Mode::Path,
            spp: 16,
            max_depth: 64,
            rr_depth: 4,
            seed: 0,
            sampler: crate::math::rng::Sampler::Sobol,
            exposure: 0.0,
            pm_spp: 4,
            specular_spp: 4,
            direct_light: DirectLight::ShadowRays,
            final_gather: 0,
            force_all_passes: false,
            hide_emitters: false,
            photons: PhotonSettings::default(),
            gather: GatherSettings::default(),
            progressive: ProgressiveSettings::default(),
            vcm: VcmSettings::default(),
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhotonSettings {
    pub direct: u64,
    pub indirect: u64,
    pub caustic: u64,
    /// Give up shooting after this many photons per requested photon (reported, never loops forever).
    pub max_shots_factor: u64,
    /// Aim caustic photons at the parts of specular surfaces the lights reach (probed once; a tenth of
    /// the shots by area alone); false = uniform emission.
    pub caustic_targeting: bool,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings {
            direct: 200_000,
            indirect: 500_000,
            caustic: 500_000,
            max_shots_factor: 50,
            caustic_targeting: true,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct GatherSettings {
    pub direct: u32,
    pub indirect: u32,
    pub caustic: u32,
    /// Cone filter constant k (< 1 disables the filter).
    pub cone_k: f32,
    /// Largest gather radius, as a fraction of the scene's bounding-box diagonal.
    pub max_radius: f32,
    /// Final gather: read indirect and caustic light where gather rays land from radiance precomputed
    /// at every `cache_stride`-th indirect photon (Christensen 1999) instead of two k-NN gathers per
    /// ray; 0 turns the cache off.
    pub cache_stride: u32,
    /// Multiply each gather's photons by an estimate of 1 / (the part of its disc that is surface), so
    /// that a disc reaching past a wall or an edge does not read dark.
    pub edge_correction: bool,
}

impl Default for GatherSettings {
    fn default() -> Self {
        GatherSettings {
            direct: 50,
            indirect: 200,
            caustic: 100,
            cone_k: 1.1,
            max_radius: 0.05,
            cache_stride: 4,
            edge_correction: true,
        }
    }
}
