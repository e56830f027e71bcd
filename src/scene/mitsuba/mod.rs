//! Mitsuba 3 XML scenes (a documented subset; 0.6 where the syntax is the same) turned into caustica's
//! scene file, keeping Mitsuba's meaning: BSDFs are one-sided unless wrapped in `twosided`, an area
//! emitter emits from the front of its shape and the shape keeps its BSDF, a point light's `intensity`
//! is W/sr. Anything outside the subset is refused, naming the element, its line and what is read.
//!
//! `caustica render scene.xml` reads it directly; `caustica convert scene.xml -o scene.toml` writes the
//! TOML equivalent.
mod props;
mod spectrum;
pub mod xml;

use crate::scene::file::*;
use crate::scene::{SceneError, PRINCIPLED_WEIGHTS};
use glam::{Mat4, Vec3};
use props::{ColourProp, Props};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use xml::Node;

/// A converted scene, with what it could only approximate.
pub struct Converted {
    pub file: SceneFile,
    /// Differences from Mitsuba that change the image a little (e.g. the reconstruction filter).
    pub warnings: Vec<String>,
}

/// A colour property's value, or the texture it names (with the name it gets in `[textures]` unless
/// the texture has an id).
enum Valued<'a> {
    Rgb([f32; 3]),
    Texture(&'a Node, String),
}

const SHAPES: &str =
    "obj, ply, serialized, rectangle, cube, disk, sphere, cylinder, linearcurve, bsplinecurve, shapegroup, instance, merge";
const BSDFS: &str = "diffuse, plastic, roughplastic, dielectric, roughdielectric, thindielectric, conductor, \
                     roughconductor (ggx, beckmann), principled, twosided, blendbsdf, mask, null, normalmap, bumpmap";
const EMITTERS: &str = "area (inside a shape), point, spot, projector, directional, constant, envmap";
/// Mitsuba's `max_depth = -1` (no limit): a bound Russian roulette never reaches in practice.
const UNLIMITED_DEPTH: u32 = 1000;
/// The `max_depth` Mitsuba 3's path replay integrators (`prb`, `prb_basic`, `prb_projective`,
/// `prbvolpath`) stop at when none is given (Mitsuba's depth: 6 segments).
const PRB_MAX_DEPTH: i64 = 6;

/// Reads a projective sampling integrator's settings (`prb_projective`, `direct_projective`): how many
/// samples and what guiding its gradients take. A forward render does not use them.
fn projective_sampling(p: &Props) -> Result<(), SceneError> {
    for key in ["sppc", "sppp", "sppi", "guiding_rounds"] {
        p.int(key)?;
    }
    p.string("guiding")?;
    p.boolean("guiding_proj")?;
    Ok(())
}

/// The integrator whose image Mitsuba writes as R, G, B: `n`, or under the `aov` and `moment` wrappers
/// (which add channels of their own) their first nested integrator's.
fn rendering_integrator(n: &Node) -> &Node {
    match n.attr("type") {
        Some("aov" | "moment") => n.children.iter().find(|c| c.tag == "integrator").map_or(n, rendering_integrator),
        _ => n,
    }
}

/// Reads a Mitsuba XML scene. File names in the result (meshes, images) are as Mitsuba resolves them,
/// relative to the scene file's folder when they lie inside it, absolute otherwise.
pub fn convert(path: &Path) -> Result<Converted, SceneError> {
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    props::begin(&base);
    let mut warnings = Vec::new();
    let root = xml::read_scene(path, &mut warnings)?;
    let mut cx = Cx {
        base,
        warnings,
        ids: HashMap::new(),
        file: empty_file(),
        done: HashMap::new(),
        blends: Vec::new(),
        textures: Vec::new(),
        in_sides: false,
        legacy: root.attr("version").is_some_and(|v| v.starts_with("0.")),
        direct_without: None,
        // Mitsuba renders a scene that names no integrator with `path`.
        opaque_see_through: (!root.children.iter().any(|c| c.tag == "integrator"))
            .then(|| ("path".to_string(), format!("{}: line {}", root.file.display(), root.line), false)),
        media: root.children.iter().any(|c| {
            c.tag == "integrator"
                && matches!(rendering_integrator(c).attr("type"), Some("volpath" | "volpathmis" | "prbvolpath"))
        }),
    };
    for c in &root.children {
        if let Some(id) = c.attr("id").filter(|_| c.tag != "alias") {
            cx.ids.insert(id.to_string(), c);
        }
    }
    // `<alias id="a" as="b"/>`: `b` names what `a` names, in the order written.
    for c in root.children.iter().filter(|c| c.tag == "alias") {
        let (Some(id), Some(alias)) = (c.attr("id"), c.attr("as")) else {
            return Err(c.error("an alias needs `id` (an element's) and `as` (its other name)"));
        };
        let target = cx.lookup(c, id)?;
        if cx.ids.contains_key(alias) {
            return Err(c.error(format!("the id `{alias}` is taken already")));
        }
        cx.ids.insert(alias.to_string(), target);
    }
    let mut sensor = None;
    for c in &root.children {
        match c.tag.as_str() {
            "default" | "alias" => {}
            "sensor" if sensor.is_some() => return Err(c.error("a second sensor (caustica renders one view)")),
            "sensor" => sensor = Some(c),
            "integrator" => cx.integrator(c)?,
            "bsdf" | "texture" | "medium" => {
                if c.attr("id").is_none() {
                    return Err(c.error("a top-level BSDF, texture or medium needs an `id` to be used"));
                }
            }
            "shape" => cx.shape(c)?,
            "emitter" => cx.emitter(c)?,
            _ => {
                return Err(c.error(format!(
                    "not supported at scene level (read: sensor, integrator, bsdf, texture, medium, shape \
                     ({SHAPES}), emitter ({EMITTERS}), default, include, alias)"
                )))
            }
        }
    }
    let sensor = sensor.ok_or_else(|| root.error("has no <sensor> (perspective or thinlens)"))?;
    cx.sensor(sensor)?;
    // A particle tracer or 0.6's bidirectional path tracer renders as caustica's BDPT: one pass a sample.
    if cx.file.render.mode == Mode::Bdpt {
        cx.file.render.progressive.passes = cx.file.render.spp;
    }
    if let Some(w) = cx.direct_without_warning() {
        cx.warnings.push(w);
    }
    if let Some(w) = cx.see_through_warning() {
        cx.warnings.push(w);
    }
    cx.warnings.extend(props::take_notes());
    Ok(Converted { file: cx.file, warnings: cx.warnings })
}

/// A `homogeneous` medium: its extinction σ_t (`sigma_t` × `scale`), what share of it scatters
/// (`albedo`, Mitsuba's default 0.75; None where it is 0 and the medium only absorbs, coloured glass)
/// and its phase function: Henyey–Greenstein's asymmetry `g` (`isotropic`: 0, `hg`: its `g`, 0.8 by
/// default), or for `rayleigh`, `tabphase` and a `blendphase` its lobes (TOML `phase`).
struct Medium {
    sigma: [f32; 3],
    albedo: Option<[f32; 3]>,
    g: f32,
    lobes: Option<Vec<LobeSpec>>,
}

impl Medium {
    /// The TOML keys of the medium (its phase only where it scatters).
    fn keys(&self) -> MediumKeys {
        let scatters = self.albedo.is_some();
        MediumKeys {
            absorption: Some(self.sigma),
            albedo: self.albedo,
            phase_g: if scatters { self.g } else { 0.0 },
            phase: self.lobes.clone().filter(|_| scatters),
        }
    }
}

fn homogeneous_medium(m: &Node) -> Result<Medium, SceneError> {
    if m.attr("type") != Some("homogeneous") {
        return Err(m.error("medium type not read (read: homogeneous)"));
    }
    let p = Props::new(m);
    let sigma_t = p.rgb("sigma_t")?.unwrap_or([1.0; 3]);
    let albedo = p.rgb("albedo")?.unwrap_or([0.75; 3]);
    let scale = p.float("scale")?.unwrap_or(1.0);
    p.boolean("sample_emitters")?;
    p.boolean("has_spectral_extinction")?;
    let phases = p.children_where(|c| c.tag == "phase");
    p.finish("sigma_t, albedo, scale, sample_emitters, has_spectral_extinction, a phase function (isotropic, hg, rayleigh, tabphase, blendphase)")?;
    let sigma = sigma_t.map(|x| x * scale);
    if sigma.iter().any(|x| !x.is_finite() || *x < 0.0) {
        return Err(m.error(format!("sigma_t × scale = {sigma:?} must be finite and ≥ 0")));
    }
    if albedo.iter().any(|a| !(0.0..=1.0).contains(a)) {
        return Err(m.error(format!("albedo {albedo:?} must lie in [0, 1] (the share of sigma_t that scatters)")));
    }
    let lobes = match phases.as_slice() {
        [] => vec![(1.0, LobeSpec { kind: LobeKind::Isotropic, g: None, weight: None, values: None })],
        [ph] => phase_lobes(ph)?,
        [_, second, ..] => return Err(second.error("a second phase function")),
    };
    let (g, lobes) = match lobes.as_slice() {
        [(_, LobeSpec { kind: LobeKind::Isotropic, .. })] => (0.0, None),
        [(_, LobeSpec { kind: LobeKind::Hg, g: Some(g), .. })] => (*g, None),
        _ => (0.0, Some(lobes.into_iter().map(|(w, l)| LobeSpec { weight: Some(w), ..l }).collect())),
    };
    let albedo = (albedo != [0.0; 3]).then_some(albedo);
    Ok(Medium { sigma, albedo, g, lobes })
}

/// A `<phase>`'s lobes with their weights: `isotropic`, `hg` (its `g`, 0.8 by default, strictly between
/// −1 and 1), `rayleigh`, `tabphase` (its `values`, a string of numbers), or a `blendphase` of two
/// nested phase functions, (1 − `weight`)·first + `weight`·second, itself read into at most two lobes
/// in all (more are refused naming the line).
fn phase_lobes(ph: &Node) -> Result<Vec<(f32, LobeSpec)>, SceneError> {
    let pp = Props::new(ph);
    let one = |kind, g| Ok(vec![(1.0, LobeSpec { kind, g, weight: None, values: None })]);
    let lobes = match ph.attr("type") {
        Some("isotropic") => {
            pp.finish("no property")?;
            one(LobeKind::Isotropic, None)
        }
        Some("rayleigh") => {
            pp.finish("no property")?;
            one(LobeKind::Rayleigh, None)
        }
        Some("hg") => {
            let g = pp.float("g")?.unwrap_or(0.8);
            pp.finish("g")?;
            if !(g > -1.0 && g < 1.0) {
                return Err(ph.error(format!("g = {g} must lie strictly between -1 and 1")));
            }
            one(LobeKind::Hg, Some(g))
        }
        Some("tabphase") => {
            let text = pp.string("values")?.ok_or_else(|| ph.error("a `tabphase` needs its `values`"))?;
            pp.finish("values")?;
            let values = Props::numbers(ph, &text)?;
            crate::scene::medium::Table::new(&values).map_err(|e| ph.error(format!("`values`: {e}")))?;
            Ok(vec![(1.0, LobeSpec { kind: LobeKind::Table, g: None, weight: None, values: Some(values) })])
        }
        Some("blendphase") => {
            let w = pp.float("weight")?.ok_or_else(|| ph.error("a `blendphase` needs its `weight`"))?;
            let nested = pp.children_where(|c| c.tag == "phase");
            pp.finish("weight, two phase functions")?;
            if !(0.0..=1.0).contains(&w) {
                return Err(ph.error(format!("weight = {w} must lie in [0, 1]")));
            }
            let [a, b] = nested[..] else {
                return Err(ph.error(format!("a `blendphase` blends two phase functions, not {}", nested.len())));
            };
            let scaled = |lobes: Vec<(f32, LobeSpec)>, by: f32| lobes.into_iter().map(move |(x, l)| (x * by, l));
            let lobes: Vec<(f32, LobeSpec)> =
                scaled(phase_lobes(a)?, 1.0 - w).chain(scaled(phase_lobes(b)?, w)).filter(|(x, _)| *x > 0.0).collect();
            if lobes.len() > 2 {
                return Err(ph.error("a blend of more than two lobes in all is not read (caustica blends two)"));
            }
            Ok(lobes)
        }
        _ => Err(ph.error("phase function type not read (read: isotropic, hg, rayleigh, tabphase, blendphase)")),
    }?;
    Ok(lobes)
}

fn empty_file() -> SceneFile {
    let camera = CameraSpec {
        origin: [0.0; 3],
        target: [0.0, 0.0, 1.0],
        up: [0.0, 1.0, 0.0],
        projection: Projection::Perspective,
        fov: Some(40.0),
        fov_axis: Some(FovAxis::X),
        film_size: None,
        resolution: [768, 576],
        crop: None,
        principal_point_offset: None,
        // Mitsuba's film's default; replaced by what the film says.
        filter: crate::scene::camera::FilterSpec::Gaussian { stddev: crate::scene::camera::GAUSSIAN_STDDEV },
        aperture_radius: 0.0,
        focus_distance: None,
        near_clip: None,
        far_clip: None,
        mirror: false,
        medium: None,
    };
    let mut render = RenderSettings { max_depth: UNLIMITED_DEPTH, ..Default::default() };
    render.spp = 4;
    SceneFile {
        camera,
        materials: BTreeMap::new(),
        textures: BTreeMap::new(),
        shapes: Vec::new(),
        lights: Vec::new(),
        render,
    }
}

/// Mitsuba's clipping planes unless a sensor gives its own: `near_clip`, `far_clip`.
const MITSUBA_CLIP: [f32; 2] = [1e-2, 1e4];

struct Cx<'a> {
    base: PathBuf,
    warnings: Vec<String>,
    /// Top-level objects by id, for `<ref id>`.
    ids: HashMap<String, &'a Node>,
    file: SceneFile,
    /// Materials and textures already converted, by the address of their element.
    done: HashMap<*const Node, String>,
    /// The blends being converted, outermost first (a blend that refers to itself is refused).
    blends: Vec<*const Node>,
    /// The textures being converted, outermost first (a checkerboard whose square refers to itself, or
    /// textures nested deeper than the loader takes, are refused).
    textures: Vec<*const Node>,
    /// Whether a `twosided` of two BSDFs is being converted (no normal map may sit inside it).
    in_sides: bool,
    /// Whether the integrator renders media (`volpath`, `volpathmis`, `prbvolpath`, also inside an `aov`
    /// or `moment`); Mitsuba's others ignore them.
    media: bool,
    /// A Mitsuba 0.5/0.6 file (`<scene version="0.x">`): its own settings are read too (`ldrfilm`,
    /// `strictNormals`, a conductor's `extEta`, MIP-mapped texture filters).
    legacy: bool,
    /// A `direct` integrator that takes no samples of one of its two kinds: which kind (the emitters'
    /// or the BSDFs'), and where it says so (warned of once the scene's lights and materials are read).
    direct_without: Option<(&'static str, String)>,
    /// An integrator of Mitsuba's that stops shadow rays at see-through surfaces (`path`, `direct`,
    /// their path replay kin, `ptracer`): its kind and where it is named, or the `<scene>` element where it names
    /// none (Mitsuba's default is `path`) (`see_through_warning`).
    opaque_see_through: Option<(String, String, bool)>,
}

impl<'a> Cx<'a> {
    /// The `direct` integrator's sample counts, as Mitsuba 3 reads them: `shading_samples` (default 1)
    /// sets both `emitter_samples` and `bsdf_samples`, and may not be given beside either; none is
    /// negative, and not both are 0. caustica's direct light takes both kinds of samples, weighed by
    /// MIS: how many of each changes only the noise, except where one kind is 0. Mitsuba then misses
    /// what only the other finds (without BSDF samples, light reflected or let through by smooth
    /// surfaces: mirrors, glass, a plastic's coat, a null surface; without emitter samples, point,
    /// spot, projector and directional lights), which caustica renders; the import warns of it where the
    /// scene has such surfaces or lights (`direct_without_warning`).
    fn direct_samples(&mut self, n: &Node, p: &Props) -> Result<(), SceneError> {
        let count = |name: &str, v: Option<i64>| match v {
            Some(c) if c < 0 => Err(n.error(format!("`{name}` is {c}: a count of samples, not negative"))),
            _ => Ok(v),
        };
        let shading = count("shading_samples", p.int("shading_samples")?)?;
        let emitter = count("emitter_samples", p.int("emitter_samples")?)?;
        let bsdf = count("bsdf_samples", p.int("bsdf_samples")?)?;
        if shading.is_some() && (emitter.is_some() || bsdf.is_some()) {
            return Err(n.error(
                "`shading_samples` sets both `emitter_samples` and `bsdf_samples`: give it or them, not both \
                 (Mitsuba refuses both)",
            ));
        }
        let (emitter, bsdf) = (emitter.or(shading).unwrap_or(1), bsdf.or(shading).unwrap_or(1));
        let at = format!("{}: line {}", n.file.display(), n.line);
        self.direct_without = match (emitter, bsdf) {
            (0, 0) => {
                return Err(n.error(
                    "`emitter_samples` and `bsdf_samples` are both 0: no sample finds any light (Mitsuba \
                     refuses it)",
                ))
            }
            (0, _) => Some(("emitter", at)),
            (_, 0) => Some(("BSDF", at)),
            _ => None,
        };
        Ok(())
    }

    /// Whether the scene has a point, spot, projector or directional light, which no BSDF sample finds.
    fn has_delta_light(&self) -> bool {
        self.file.lights.iter().any(|l| {
            matches!(
                l,
                LightSpec::Point { .. }
                    | LightSpec::Spot { .. }
                    | LightSpec::Projector { .. }
                    | LightSpec::Distant { .. }
            )
        })
    }

    /// The warning for a `direct` integrator without emitter or BSDF samples (`direct_samples`), where
    /// the scene has what Mitsuba's image then lacks.
    fn direct_without_warning(&self) -> Option<String> {
        let (kind, at) = self.direct_without.as_ref()?;
        let smooth = |w: &Weight| *w == Weight::Value(0.0);
        let missed = if *kind == "emitter" {
            self.has_delta_light()
        } else {
            self.file.materials.values().any(|m| match m {
                MaterialSpec::Mirror { roughness, .. }
                | MaterialSpec::Conductor { roughness, .. }
                | MaterialSpec::Dielectric { roughness, .. } => smooth(roughness),
                MaterialSpec::Plastic { roughness, .. } => *roughness == 0.0,
                MaterialSpec::ThinDielectric { .. } | MaterialSpec::Null { .. } => true,
                _ => false,
            })
        };
        let lacks = if *kind == "emitter" {
            "the light of the scene's point, spot, projector and directional emitters, which only emitter \
             samples find"
        } else {
            "the light its smooth mirrors, glass, plastic coats or null surfaces reflect or let through, \
             which only BSDF samples find"
        };
        missed.then(|| {
            format!(
                "{at}: the `direct` integrator takes no {kind} samples: Mitsuba's image then lacks {lacks}; \
                 caustica renders it (its direct light takes both kinds of samples, weighed by MIS)"
            )
        })
    }

    /// caustica lets light straight through a `null` surface, a mask's holes and a thin pane, by their
    /// transmittance and without counting a bounce, in every mode, as Mitsuba's `volpath` does
    /// (README "See-through surfaces"). Mitsuba's `path` (and its path replay kin) stops shadow rays
    /// there and counts a crossing as a bounce: area lights and the sky still reach past them by BSDF
    /// samples (an unbiased image, noisier), but point, spot, projector and directional light does not
    /// (under a thin pane lit by a point light Mitsuba's `path` read 1/1.32 of its `volpath`'s mean,
    /// black in the pane's shadow). Mitsuba's `direct` stops there for every light (a pane under an
    /// area light: caustica's `direct` read 1.45 of its mean, and 1.0000 of its `volpath` at depth 2).
    /// Mitsuba's `ptracer` links its light paths to the camera by rays that stop there too, so what is
    /// seen through them is black (the same pane: its `volpath` read 1.07 of its `ptracer`'s mean, blocks
    /// seen through the pane 5.9). Where the scene has such a surface (and, under `path`, such a light),
    /// the import warns.
    fn see_through_warning(&self) -> Option<String> {
        let (kind, at, named) = self.opaque_see_through.as_ref()?;
        let has = |f: fn(&MaterialSpec) -> bool| self.file.materials.values().any(f);
        let mut which = Vec::new();
        if has(|m| matches!(m, MaterialSpec::Null { .. })) {
            which.push("null surfaces or a mask's holes");
        }
        if has(|m| matches!(m, MaterialSpec::ThinDielectric { .. })) {
            which.push("thin panes (`thindielectric`)");
        }
        // A mask: a blend with a null surface on one side (`blend` reads `mask` so).
        let null = |name: &String| matches!(self.file.materials.get(name), Some(MaterialSpec::Null { .. }));
        let masks = (self.file.materials.values())
            .any(|m| matches!(m, MaterialSpec::Blend { first, second, .. } if null(first) || null(second)));
        let lost = if kind.starts_with("direct") {
            "every light's shadow rays stop at them and what is seen through them is black but for emitters"
        } else if kind == "ptracer" {
            "its light paths' links to the camera stop at them, so what is seen through them is black"
        } else if self.has_delta_light() {
            "the light of its point, spot, projector and directional emitters does not pass them (area lights \
             and the sky pass by BSDF samples alone), and crossing one counts as a bounce"
        } else if masks {
            // Measured with Mitsuba 3.9.1: a sphere of `mask` (over `diffuse`) above a floor under an area
            // light alone, its `path` against its `volpath`: the sphere's top 0.75 at opacity 0.5, 0.98 at
            // 0.9; a null sphere and a thin pane there read 1.003 and 1.002 (no warning for them).
            which = vec!["masks (`mask`)"];
            "part of the light that passes a mask's holes is lost even from area lights and the sky (a sphere \
             of opacity 0.5 under an area light: its top read 0.75 of Mitsuba's `volpath`)"
        } else {
            return None;
        };
        let depth = if kind.starts_with("direct") { " with `max_depth` 2" } else { "" };
        let named = if *named { "" } else { " (its integrator where the scene names none)" };
        (!which.is_empty()).then(|| {
            format!(
                "{at}: the scene has {}, which caustica lets light straight through by their transmittance, \
                 without counting a bounce, as Mitsuba's `volpath` does; under Mitsuba's `{kind}`{named} {lost}, so \
                 its image is darker behind them (Mitsuba's `volpath`{depth} renders what caustica renders)",
                which.join(" and "),
            )
        })
    }

    fn lookup(&self, n: &Node, id: &str) -> Result<&'a Node, SceneError> {
        self.ids.get(id).copied().ok_or_else(|| n.error(format!("refers to id `{id}`, which no top-level element has")))
    }

    /// A file name as Mitsuba resolves it: next to the file that names it, else next to the scene.
    fn resolve(&self, n: &Node, name: &str) -> String {
        let own = n.dir().join(name);
        let path = if own.exists() { own } else { self.base.join(name) };
        match path.strip_prefix(&self.base) {
            Ok(rel) => rel.display().to_string(),
            Err(_) => path.display().to_string(),
        }
    }

    fn sensor(&mut self, s: &'a Node) -> Result<(), SceneError> {
        let thin_lens = match s.attr("type") {
            Some("perspective") => false,
            Some("thinlens") => true,
            Some("orthographic") => return self.orthographic(s),
            _ => return Err(s.error("sensor type not read (read: perspective, thinlens, orthographic)")),
        };
        let p = Props::new(s);
        if thin_lens {
            // Mitsuba requires the radius (and renders 0 as a pinhole, its epsilon); the plane of focus
            // defaults to the far clipping plane.
            let radius = p.float("aperture_radius")?.ok_or_else(|| s.error("a `thinlens` needs `aperture_radius`"))?;
            let far = p.float("far_clip")?.unwrap_or(MITSUBA_CLIP[1]);
            let focus = p.float("focus_distance")?.unwrap_or(far);
            (self.file.camera.aperture_radius, self.file.camera.focus_distance) = (radius, Some(focus));
        }
        let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
        if [x, y, z].iter().any(|a| (a.length() - 1.0).abs() > 1e-3) {
            return Err(
                s.error("the camera's to_world scales (Mitsuba refuses this too); use lookat, rotate, translate")
            );
        }
        self.place_camera(m.w_axis.truncate(), x, y, z);
        let (fov, fov_axis) = (p.float("fov")?, p.string("fov_axis")?);
        let focal = p.string("focal_length")?;
        if !thin_lens {
            // Mitsuba's thin lens does not read a principal point (it refuses the property).
            let shift = [p.float("principal_point_offset_x")?, p.float("principal_point_offset_y")?];
            if shift.iter().any(Option::is_some) {
                self.file.camera.principal_point_offset = Some(shift.map(|v| v.unwrap_or(0.0)));
            }
        }
        self.sensor_common(s, &p)?;
        p.finish("to_world, fov, fov_axis, focal_length, near_clip, far_clip, shutter_open, shutter_close, film, sampler, medium (for perspective principal_point_offset_x, principal_point_offset_y; for thinlens aperture_radius, focus_distance)")?;
        let [w, h] = self.file.camera.resolution.map(|v| v as f32);
        let (deg, axis) = field_of_view(s, fov, fov_axis, focal)?;
        let half = (deg.to_radians() * 0.5).tan();
        let cam = &mut self.file.camera;
        let (fov, axis) = match axis.as_str() {
            "x" => (deg, FovAxis::X),
            "y" => (deg, FovAxis::Y),
            "smaller" => (deg, if w <= h { FovAxis::X } else { FovAxis::Y }),
            "larger" => (deg, if w >= h { FovAxis::X } else { FovAxis::Y }),
            "diagonal" => ((half * w / w.hypot(h)).atan().to_degrees() * 2.0, FovAxis::X),
            a => return Err(s.error(format!("fov_axis `{a}` (read: x, y, diagonal, smaller, larger)"))),
        };
        (cam.fov, cam.fov_axis) = (Some(fov), Some(axis));
        Ok(())
    }

    /// The camera's place: `origin` (a sensor's `to_world` translation), the view direction `z` and up
    /// `y` (its local axes, unit vectors). Mitsuba's film runs along −x, its local left: where `x`
    /// is not `y × z` (`to_world` mirrors: a negative scale, as converted scenes often put before
    /// `lookat`) the image is mirrored left to right, as Mitsuba renders it.
    ///
    /// The target is put along `z` as far from `origin` as `origin` is from the world's centre (at least
    /// 1): a unit step from an origin at 1.5e6 rounds to the floats there (0.125 apart) and turned the
    /// view by degrees, where Mitsuba, which keeps the matrix, renders the same image at any size.
    fn place_camera(&mut self, origin: Vec3, x: Vec3, y: Vec3, z: Vec3) {
        let cam = &mut self.file.camera;
        let reach = origin.abs().max_element().max(1.0);
        (cam.origin, cam.target, cam.up) = (origin.to_array(), (origin + z * reach).to_array(), y.to_array());
        cam.mirror = x.dot(y.cross(z)) < 0.0;
    }

    /// What every sensor may hold besides its projection: the clipping planes (Mitsuba's defaults 0.01
    /// and 10⁴, which Mitsuba requires to be positive and in order), the film and the sampler.
    fn sensor_common(&mut self, s: &Node, p: &Props<'a>) -> Result<(), SceneError> {
        let near = p.float("near_clip")?.unwrap_or(MITSUBA_CLIP[0]);
        let far = p.float("far_clip")?.unwrap_or(MITSUBA_CLIP[1]);
        if !(near.is_finite() && near > 0.0 && far.is_finite() && far > near) {
            return Err(s.error(format!(
                "near_clip ({near}) and far_clip ({far}) must be finite depths, 0 < near_clip < far_clip"
            )));
        }
        (self.file.camera.near_clip, self.file.camera.far_clip) = (Some(near), Some(far));
        self.sensor_medium(p)?;
        // When the shutter opens and closes: nothing in a Mitsuba XML scene moves, so the image is the same.
        p.float("shutter_open")?;
        p.float("shutter_close")?;
        for film in p.objects("film") {
            self.film(film)?;
        }
        for sampler in p.objects("sampler") {
            let sp = Props::new(sampler);
            if let Some(n) = sp.int("sample_count")? {
                self.file.render.spp = u32::try_from(n)
                    .ok()
                    .filter(|&n| n > 0)
                    .ok_or_else(|| sampler.error(format!("sample_count must be in [1, {}], got {n}", u32::MAX)))?;
            }
            if let Some(seed) = sp.int("seed")? {
                self.file.render.seed = seed as u64;
            }
            sp.boolean("jitter")?;
            sp.int("scramble_seed")?;
            // The orthogonal array's strength.
            sp.int("strength")?;
            sp.finish("sample_count, seed (the sampler type only changes the noise)")?;
        }
        Ok(())
    }

    /// The medium an endpoint (a sensor or an emitter) names: a nested `<medium>`, or a `<ref>` to one,
    /// unnamed or named `medium`; a second is refused naming its line.
    fn endpoint_medium(&self, p: &Props<'a>) -> Result<Option<&'a Node>, SceneError> {
        let ids = &self.ids;
        let media = p.children_where(|c| match c.tag.as_str() {
            "medium" => true,
            "ref" => {
                matches!(c.attr("name"), None | Some("medium"))
                    && c.attr("id").and_then(|id| ids.get(id)).is_some_and(|t| t.tag == "medium")
            }
            _ => false,
        });
        match media[..] {
            [] => Ok(None),
            [m] if m.tag == "ref" => Ok(Some(self.lookup(m, m.attr("id").unwrap_or_default())?)),
            [m] => Ok(Some(m)),
            [_, second, ..] => Err(second.error("a second medium (an endpoint sits in one)")),
        }
    }

    /// The medium a sensor sits in (`endpoint_medium`), read under `volpath` into `camera.medium`, and
    /// ignored with a warning under Mitsuba's other integrators, which ignore it. A medium of σ_t 0 is
    /// vacuum.
    fn sensor_medium(&mut self, p: &Props<'a>) -> Result<(), SceneError> {
        let Some(node) = self.endpoint_medium(p)? else { return Ok(()) };
        let medium = homogeneous_medium(node)?;
        if !self.media {
            self.warnings.push(format!(
                "{}: line {}: the sensor's medium is ignored, as Mitsuba's integrator here ignores it (only \
                 volpath and volpathmis render media)",
                p.node.file.display(),
                p.node.line
            ));
            return Ok(());
        }
        let keys = medium.keys();
        self.file.camera.medium = (medium.sigma != [0.0; 3]).then_some(CameraMediumSpec {
            absorption: medium.sigma,
            albedo: keys.albedo,
            phase_g: keys.phase_g,
            phase: keys.phase,
        });
        Ok(())
    }

    /// Mitsuba's `orthographic` sensor: its film spans local x in [−1, 1] and y in [−1/aspect,
    /// 1/aspect], scaled by `to_world` (which may scale x and y, to size the view, but not shear or
    /// mirror), every ray along local z.
    fn orthographic(&mut self, s: &'a Node) -> Result<(), SceneError> {
        let p = Props::new(s);
        let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
        let (sx, sy, sz) = (x.length(), y.length(), z.length());
        if ![sx, sy, sz].iter().all(|l| l.is_finite() && *l > 0.0) {
            return Err(s.error("the camera's to_world collapses an axis (a zero scale)"));
        }
        let (xn, yn, zn) = (x / sx, y / sy, z / sz);
        if xn.dot(yn).abs() > 1e-3 || xn.dot(zn).abs() > 1e-3 || yn.dot(zn).abs() > 1e-3 {
            return Err(s.error("the camera's to_world shears the film (its axes are not at right angles)"));
        }
        self.place_camera(m.w_axis.truncate(), xn, yn, zn);
        self.sensor_common(s, &p)?;
        // The planes are read as depths in scene units, which a z scale of to_world would make ambiguous
        // (local or scaled units): refused rather than guessed.
        let clips = [self.file.camera.near_clip, self.file.camera.far_clip] != MITSUBA_CLIP.map(Some);
        if clips && (sz - 1.0).abs() > 1e-3 {
            return Err(s.error("an orthographic camera whose to_world scales z may not set near_clip or far_clip"));
        }
        p.finish("to_world, near_clip, far_clip, shutter_open, shutter_close, film, sampler, medium")?;
        let [w, h] = self.file.camera.resolution.map(|v| v as f32);
        let cam = &mut self.file.camera;
        cam.projection = Projection::Orthographic;
        (cam.fov, cam.fov_axis) = (None, None);
        cam.film_size = Some([2.0 * sx, 2.0 * sy * h / w]);
        Ok(())
    }

    fn film(&mut self, f: &Node) -> Result<(), SceneError> {
        let p = Props::new(f);
        match f.attr("type") {
            Some("hdrfilm") => {}
            Some("ldrfilm") if self.legacy => {
                // 0.5/0.6's tone-mapped film: its size, crop and filter as an HDR film's. caustica writes
                // the linear EXR and an sRGB PNG, so the tone mapping is left to the user.
                for key in ["gamma", "exposure", "key", "burn"] {
                    p.float(key)?;
                }
                p.string("tonemap_method")?;
                self.warnings.push(format!(
                    "{}: line {}: 0.6's ldrfilm is read as an HDR film (size, crop, filter): caustica writes the \
                     linear EXR and an sRGB PNG, without its tone mapping (gamma, exposure)",
                    f.file.display(),
                    f.line
                ));
            }
            _ => return Err(f.error("only `hdrfilm` is read (and 0.5/0.6's `ldrfilm` in files of those versions)")),
        }
        if self.legacy {
            p.boolean("attach_log")?;
        }
        let dim = |v: Option<i64>, d: u32| {
            v.map_or(Ok(d), |v| {
                u32::try_from(v)
                    .ok()
                    .filter(|&v| v > 0)
                    .ok_or_else(|| f.error(format!("width and height must be in [1, {}], got {v}", u32::MAX)))
            })
        };
        let [w, h] = [dim(p.int("width")?, 768)?, dim(p.int("height")?, 576)?];
        self.file.camera.resolution = [w, h];
        // A crop window: its size defaults to the whole film, its offset to 0; Mitsuba refuses one that
        // leaves the film, and so does caustica (it also refuses an empty one, which Mitsuba renders as
        // an image of no pixels).
        let keys = ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"];
        let given = keys.iter().map(|k| p.int(k)).collect::<Result<Vec<_>, _>>()?;
        if given.iter().any(Option::is_some) {
            let defaults = [0, 0, w as i64, h as i64];
            let mut window = [0u32; 4];
            for (i, key) in keys.iter().enumerate() {
                let v = given[i].unwrap_or(defaults[i]);
                window[i] =
                    u32::try_from(v).map_err(|_| f.error(format!("{key} must be in [0, {}], got {v}", u32::MAX)))?;
            }
            let [x, y, cw, ch] = window;
            if !crate::scene::camera::Camera::window_fits(window, [w, h]) {
                return Err(f.error(format!(
                    "the crop window (crop_offset_x {x}, crop_offset_y {y}, crop_width {cw}, crop_height {ch}) \
                     must hold at least one pixel and lie on the {w}×{h} film"
                )));
            }
            self.file.camera.crop = Some(window);
        }
        // How Mitsuba stores its image, checked as Mitsuba 3 checks an `hdrfilm`'s (in any case; a 0.x
        // `ldrfilm` writes PNG and JPEG, read as they are); caustica writes RGB (and its other files)
        // whatever they say, the same radiance.
        let hdr = f.attr("type") == Some("hdrfilm");
        for (key, known) in [
            ("pixel_format", &["rgb", "rgba", "luminance", "luminance_alpha", "xyz", "xyza"][..]),
            ("component_format", &["float16", "float32", "uint32"][..]),
            ("file_format", &["openexr", "exr", "rgbe", "pfm"][..]),
        ] {
            let Some(v) = p.string(key)?.filter(|_| hdr) else { continue };
            let lower = v.to_lowercase();
            if !known.contains(&lower.as_str()) {
                return Err(f.error(format!("{key} `{v}` is not one Mitsuba knows ({})", known.join(", "))));
            }
            if key == "pixel_format" && !lower.starts_with("rgb") {
                self.warnings.push(format!(
                    "{}: line {}: the film's pixel_format `{v}`: Mitsuba writes its image so, caustica writes RGB \
                     (of the same radiance)",
                    f.file.display(),
                    f.line
                ));
            }
        }
        p.boolean("banner")?;
        p.boolean("high_quality_edges")?;
        // Removed from Mitsuba 3, which reads and ignores it (Kahan summation of the film).
        p.boolean("compensate")?;
        if p.boolean("sample_border")? == Some(true) {
            // Only the edge pixels of a filter wider than a pixel differ.
            self.warnings.push(format!(
                "{}: film `sample_border` is ignored (the film's edge pixels are filtered from samples on the film)",
                f.file.display()
            ));
        }
        // Mitsuba's film filters with a Gaussian unless told otherwise.
        use crate::scene::camera::{
            FilterSpec, GAUSSIAN_STDDEV, LANCZOS_LOBES, LANCZOS_LOBES_RANGE, MITCHELL_BC, TENT_RADIUS,
        };
        let filters = p.objects("rfilter");
        self.file.camera.filter = match filters.first() {
            None => FilterSpec::Gaussian { stddev: GAUSSIAN_STDDEV },
            Some(r) => {
                let rp = Props::new(r);
                let spec = match r.attr("type").unwrap_or("") {
                    "box" => FilterSpec::Box,
                    "tent" => FilterSpec::Tent { radius: rp.float("radius")?.unwrap_or(TENT_RADIUS) },
                    "gaussian" => FilterSpec::Gaussian { stddev: rp.float("stddev")?.unwrap_or(GAUSSIAN_STDDEV) },
                    "mitchell" => FilterSpec::Mitchell {
                        b: rp.float("B")?.unwrap_or(MITCHELL_BC),
                        c: rp.float("C")?.unwrap_or(MITCHELL_BC),
                    },
                    "catmullrom" => FilterSpec::CatmullRom,
                    "lanczos" => {
                        let lobes = rp.int("lobes")?.unwrap_or(LANCZOS_LOBES as i64);
                        let range = LANCZOS_LOBES_RANGE;
                        if !(*range.start() as i64..=*range.end() as i64).contains(&lobes) {
                            let (lo, hi) = (range.start(), range.end());
                            return Err(r.error(format!("lobes must be {lo} to {hi}, got {lobes}")));
                        }
                        FilterSpec::Lanczos { lobes: lobes as u32 }
                    }
                    kind => {
                        return Err(r.error(format!(
                            "reconstruction filter `{kind}` not read (read: box, tent, gaussian, mitchell, \
                             catmullrom, lanczos)"
                        )))
                    }
                };
                rp.finish("radius (tent), stddev (gaussian), B and C (mitchell), lobes (lanczos)")?;
                spec
            }
        };
        p.finish("width, height, crop_offset_x, crop_offset_y, crop_width, crop_height, rfilter, pixel_format, component_format, file_format")
    }

    fn integrator(&mut self, n: &Node) -> Result<(), SceneError> {
        if let Some(kind @ ("aov" | "moment")) = n.attr("type") {
            // Wrappers that add channels (arbitrary outputs, or the second moments of the nested
            // integrators' images) to the R, G, B image of their first nested integrator.
            let p = Props::new(n);
            let aovs = if kind == "aov" { p.string("aovs")? } else { None };
            let nested = p.objects("integrator");
            p.finish("aovs (aov), nested integrators")?;
            let Some(first) = nested.first() else {
                return Err(n.error(format!(
                    "an `{kind}` integrator without a nested integrator makes no image of light (caustica \
                     renders the nested integrator's image)"
                )));
            };
            let extra = match aovs {
                Some(a) => format!("the outputs `{a}`"),
                None if kind == "aov" => "no outputs".to_string(),
                None => "the second moments".to_string(),
            };
            let others = if nested.len() > 1 { " and the other nested integrators' images" } else { "" };
            self.warnings.push(format!(
                "{}: line {}: the `{kind}` integrator's extra channels ({extra}{others}) are not written: \
                 caustica renders the image of its first nested integrator (line {}), Mitsuba's R, G, B",
                n.file.display(),
                n.line,
                first.line
            ));
            return self.integrator(first);
        }
        if let Some(
            kind @ ("path" | "prb" | "prb_basic" | "prb_projective" | "direct" | "direct_projective" | "ptracer"),
        ) = n.attr("type")
        {
            self.opaque_see_through = Some((kind.to_string(), format!("{}: line {}", n.file.display(), n.line), true));
        }
        let p = Props::new(n);
        let r = &mut self.file.render;
        let depth = |d: i64| {
            if d < 0 {
                Ok(UNLIMITED_DEPTH)
            } else {
                u32::try_from(d - 1).map_err(|_| n.error("max_depth must be ≥ 1 or -1"))
            }
        };
        match n.attr("type") {
            Some(
                kind @ ("path" | "volpath" | "volpathmis" | "ptracer" | "bdpt" | "prb" | "prb_basic" | "prb_projective"
                | "prbvolpath"),
            ) => {
                // Mitsuba 3's particle tracer (light paths joined to the camera, and emitters seen
                // directly) and 0.6's BDPT estimate what `path` does, with other noise: caustica renders
                // them with its BDPT, whose strategies include light tracing.
                let light_paths = matches!(kind, "ptracer" | "bdpt");
                r.mode = if light_paths { Mode::Bdpt } else { Mode::Path };
                // Mitsuba 3's path replay integrators (for differentiable rendering) render what `path`
                // and `volpath` render, but stop at a max_depth of 6 unless told otherwise.
                if kind.starts_with("prb") {
                    r.max_depth = depth(PRB_MAX_DEPTH)?;
                }
                if kind == "prb_projective" {
                    projective_sampling(&p)?;
                }
                if let Some(d) = p.int("max_depth")? {
                    r.max_depth = depth(d)?;
                }
                if let Some(d) = p.int("rr_depth")? {
                    r.rr_depth = (d.max(1) - 1) as u32;
                }
                r.hide_emitters = p.boolean("hide_emitters")?.unwrap_or(false);
                if self.legacy {
                    // 0.6's option to stop paths where a shading normal and the geometric one put the
                    // direction on different sides (README: read, not applied).
                    p.boolean("strict_normals")?;
                }
                // How many samples a pass takes (deprecated in Mitsuba 3, which warns): the image is the same.
                p.int("samples_per_pass")?;
                if light_paths {
                    p.boolean("light_image")?;
                    p.boolean("sample_direct")?;
                }
            }
            Some(kind @ ("direct" | "direct_projective")) => {
                r.mode = Mode::Path;
                r.max_depth = 1;
                r.hide_emitters = p.boolean("hide_emitters")?.unwrap_or(false);
                if kind == "direct" {
                    self.direct_samples(n, &p)?;
                } else {
                    // Mitsuba's projective direct integrator reads these and keeps its depth of 2.
                    p.int("max_depth")?;
                    p.int("rr_depth")?;
                    projective_sampling(&p)?;
                }
            }
            Some(kind @ ("photonmapper" | "sppm")) => {
                r.mode = if kind == "sppm" { Mode::Sppm } else { Mode::PhotonMap };
                if let Some(d) = p.int("max_depth")? {
                    r.max_depth = depth(d)?;
                }
                if let Some(c) = p.int("photon_count")? {
                    r.progressive.photons_per_pass = c.max(1) as u64;
                }
                if let Some(c) = p.int("max_passes")? {
                    r.progressive.passes = c.max(1) as u32;
                }
                if let Some(a) = p.float("alpha")? {
                    r.progressive.alpha = a;
                }
                if let Some(c) = p.int("global_photons")? {
                    r.photons.indirect = c.max(0) as u64;
                }
                if let Some(c) = p.int("caustic_photons")? {
                    r.photons.caustic = c.max(0) as u64;
                }
            }
            _ => {
                return Err(n.error(
                    "not read (read: path, volpath (media: absorbing glass), direct, ptracer, prb, prb_basic, \
                     prb_projective, prbvolpath, direct_projective, aov and moment around one of these; 0.6's \
                     photonmapper, sppm, bdpt)",
                ))
            }
        }
        p.finish(match n.attr("type") {
            Some("direct") => "hide_emitters, emitter_samples, bsdf_samples, shading_samples",
            Some("direct_projective") => {
                "hide_emitters, max_depth, rr_depth, sppc, sppp, sppi, guiding, guiding_proj, guiding_rounds"
            }
            Some("prb_projective") => {
                "max_depth, rr_depth, hide_emitters, sppc, sppp, sppi, guiding, guiding_proj, guiding_rounds"
            }
            Some("photonmapper" | "sppm") => {
                "max_depth, photon_count, max_passes, alpha, global_photons, caustic_photons"
            }
            Some("ptracer" | "bdpt") => {
                "max_depth, rr_depth, hide_emitters, samples_per_pass, light_image, sample_direct"
            }
            _ => "max_depth, rr_depth, hide_emitters, samples_per_pass",
        })
    }

    fn shape(&mut self, n: &'a Node) -> Result<(), SceneError> {
        match n.attr("type") {
            // A group is drawn only where an instance places it.
            Some("shapegroup") => self.shapegroup(n).map(|_| ()),
            Some("instance") => self.instance(n),
            Some("merge") => {
                for c in self.merge_parts(n)? {
                    match c.tag.as_str() {
                        "shape" => self.shape(c)?,
                        _ => self.emitter(c)?,
                    }
                }
                Ok(())
            }
            _ => self.placed_shape(n, None),
        }
    }

    /// A `merge`'s parts, its shapes and emitters in the order written. Mitsuba joins the meshes in it
    /// that share a BSDF, media and emitter into one mesh, which renders as its parts did, and passes
    /// everything else (spheres, instances, emitters, nested merges) to the scene as it is: so its parts
    /// are read as if they stood where it stands. A BSDF, texture or medium in it applies to none of
    /// them (warned of); the merge itself takes no setting (`to_world` refused, as Mitsuba refuses it).
    fn merge_parts(&mut self, n: &'a Node) -> Result<Vec<&'a Node>, SceneError> {
        let p = Props::new(n);
        let parts = p.objects_of(&["shape", "emitter"]);
        let unused = p.objects_of(&["bsdf", "texture", "medium", "ref"]);
        p.finish("shapes and emitters (a merge takes no setting, as in Mitsuba)")?;
        // A <ref> to a top-level shape adds nothing: that shape is drawn where it stands (Mitsuba draws it
        // twice, on itself).
        let target = |u: &Node| u.attr("id").and_then(|id| self.ids.get(id)).map(|t| t.tag.as_str());
        let unused: Vec<&Node> = unused.into_iter().filter(|u| u.tag != "ref" || target(u) != Some("shape")).collect();
        for u in unused {
            let w = format!(
                "{}: line {}: a <{}> inside a merge applies to none of its shapes (Mitsuba passes it to the \
                 scene, which ignores it); put it in each shape, or refer to it from there",
                u.file.display(),
                u.line,
                u.tag
            );
            if !self.warnings.contains(&w) {
                self.warnings.push(w);
            }
        }
        Ok(parts)
    }

    /// A `shapegroup`'s shapes, checked: an `id`, shapes only, none of them emitting or a group itself
    /// (Mitsuba instances neither emitters nor groups); a merge's parts as the group's own.
    fn shapegroup(&mut self, g: &'a Node) -> Result<Vec<&'a Node>, SceneError> {
        if g.attr("id").is_none() {
            return Err(g.error("a shapegroup needs an `id` for instances to refer to"));
        }
        let p = Props::new(g);
        let mut todo = p.objects("shape");
        p.finish("shapes")?;
        todo.reverse();
        let mut shapes = Vec::new();
        while let Some(c) = todo.pop() {
            let merge = c.tag == "shape" && c.attr("type") == Some("merge");
            if merge {
                todo.extend(self.merge_parts(c)?.into_iter().rev());
                continue;
            }
            if c.tag == "emitter" || c.children.iter().any(|e| e.tag == "emitter") {
                return Err(c.error("an emitter inside a shapegroup (Mitsuba does not instance emitters either)"));
            }
            if matches!(c.attr("type"), Some("shapegroup" | "instance")) {
                return Err(c.error("a shapegroup inside a shapegroup (Mitsuba does not nest instancing either)"));
            }
            shapes.push(c);
        }
        Ok(shapes)
    }

    /// An `instance`: its group's shapes, each placed by the instance's `to_world` after its own (as
    /// copies: caustica flattens instances).
    fn instance(&mut self, n: &'a Node) -> Result<(), SceneError> {
        let p = Props::new(n);
        let outer = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let refs = p.objects("ref");
        p.finish("to_world, a <ref> to a shapegroup")?;
        let [r] = refs[..] else {
            return Err(n.error("an instance needs exactly one <ref id> to a shapegroup"));
        };
        let id = r.attr("id").ok_or_else(|| r.error("needs an `id`"))?;
        let group = self.lookup(r, id)?;
        if group.tag != "shape" || group.attr("type") != Some("shapegroup") {
            return Err(r.error(format!("`{id}` is not a <shape type=\"shapegroup\">")));
        }
        for c in self.shapegroup(group)? {
            self.placed_shape(c, Some(outer))?;
        }
        Ok(())
    }

    /// One shape, placed by its `to_world` and then by `outer` (an instance's) when there is one.
    fn placed_shape(&mut self, n: &'a Node, outer: Option<Mat4>) -> Result<(), SceneError> {
        let index = self.file.shapes.len();
        let p = Props::new(n);
        let own = p.transform("to_world")?;
        let to_world = match outer {
            None => own,
            Some(m) => Some(m * own.unwrap_or(Mat4::IDENTITY)),
        };
        let transform = transform_spec(to_world);
        let flip_normals = p.boolean("flip_normals")?.unwrap_or(false);
        let mut emission = None;
        for e in p.objects("emitter") {
            if e.attr("type") != Some("area") {
                return Err(e.error("only an `area` emitter can sit inside a shape"));
            }
            let ep = Props::new(e);
            // A colour, or a texture read at each point (its `id`, else named after the shape).
            let radiance = self.colour_prop(&ep, "radiance", &format!("shapes[{index}]-emitter"))?;
            emission = Some(radiance.unwrap_or(Reflectance::Colour([1.0; 3])));
            // How often Mitsuba's light samples pick this emitter: it changes the noise, not the image.
            ep.float("sampling_weight")?;
            // Its medium, left out (`emitter`).
            self.endpoint_medium(&ep)?;
            ep.finish("radiance, sampling_weight, medium")?;
        }
        // The shape's own to_world mirrors (an instance's does not turn its shapes in Mitsuba either).
        let mirrors = own.is_some_and(|m| glam::Mat3::from_mat4(m).determinant() < 0.0);
        let material = self.shape_material(n, &p, index, emission.is_some())?;
        let material = self.shape_media(n, &p, index, material, mirrors)?;
        // Set where the import turns a mirrored mesh inside out as Mitsuba renders it (no warning then).
        let mut inside_out = false;
        let mut spec = match n.attr("type").unwrap_or("") {
            kind @ ("obj" | "ply" | "serialized") => {
                let file = p.string("filename")?.ok_or_else(|| n.error("needs a `filename`"))?;
                let face_normals = p.boolean("face_normals")?.unwrap_or(false);
                // Mitsuba flips an OBJ's texture rows by default and a PLY's not; a `serialized` mesh
                // does not read it (refused as Mitsuba refuses it).
                let flip_tex_coords = if kind == "serialized" { None } else { p.boolean("flip_tex_coords")? };
                let shape_index = match p.int("shape_index")? {
                    Some(i) if kind == "serialized" => {
                        Some(u32::try_from(i).map_err(|_| n.error(format!("shape_index must be ≥ 0, got {i}")))?)
                    }
                    Some(_) => return Err(n.error("shape_index is only read on a `serialized` shape")),
                    None => None,
                };
                if kind == "serialized" && !file.to_lowercase().ends_with(".serialized") {
                    return Err(n.error(format!("a `serialized` shape's file must end in .serialized, got `{file}`")));
                }
                let file = self.resolve(n, &file);
                // The check below reads the mesh file, only where it is needed (None where it is not, and
                // where the file does not load: the check then keeps its default).
                let smooth_emitter = emission.is_some() && !face_normals;
                let mirror_check = mirrors && !face_normals;
                let meshes = mirror_check.then(|| self.load_file_meshes(&file, shape_index)).flatten();
                // Mitsuba keeps a mirrored mesh's winding, so its faces' normals turn inward, and so
                // do the vertex normals it computes for a mesh without any: it renders that mesh
                // inside out, as the mesh turned inside out before its transform (caustica's
                // `flip_normals`) renders here. Vertex normals from the file stay outward (transformed
                // as normals), the shading Mitsuba gives them too, only its media swapping sides.
                inside_out = mirrors && (face_normals || !file_has_normals(meshes.as_deref()));
                // Mitsuba's area emitter emits towards the front of each point's shading normal, on
                // either side of the face (`emit_by_shading_normal`; a mesh turned inward, random scenes
                // 2455 and 2832, lets its light out past its faces where that normal leans outward).
                // Mitsuba computes a mesh's missing vertex normals in its shape group's space, and an
                // instance transforms them as normals: placed by the shape's own to_world first, by the
                // instance's after them.
                ShapeSpec::Mesh {
                    file,
                    material: Some(material),
                    transform: transform_spec(own),
                    emission,
                    smooth: !face_normals,
                    flip_normals: flip_normals ^ inside_out,
                    shape_index,
                    flip_tex_coords,
                    emit_by_shading_normal: smooth_emitter,
                    instance_transform: outer.map(|m| transform_spec(Some(m))),
                }
            }
            "rectangle" => ShapeSpec::Quad {
                corner: [-1.0, -1.0, 0.0],
                edge_u: [2.0, 0.0, 0.0],
                edge_v: [0.0, 2.0, 0.0],
                material,
                transform,
                emission,
                flip_normals,
            },
            "cube" => ShapeSpec::Box { min: [-1.0; 3], max: [1.0; 3], material, transform, emission, flip_normals },
            "disk" => ShapeSpec::Disk {
                center: [0.0; 3],
                normal: [0.0, 0.0, 1.0],
                radius: 1.0,
                material,
                segments: 256,
                transform,
                emission,
                flip_normals,
            },
            "sphere" => {
                // Mitsuba warns of a sphere whose own to_world scales unevenly and renders a sphere
                // (of one of its scales), not the ellipsoid it describes; placed by an instance that
                // scales unevenly it renders the ellipsoid, as caustica does.
                if own.is_some_and(|m| !crate::scene::load::is_similarity(&m)) {
                    return Err(n.error(
                        "a sphere's own to_world scales it unevenly or shears it: Mitsuba renders a sphere there \
                         (it warns that to_world should not scale unevenly), not the ellipsoid it describes; \
                         place it by an instance of a shapegroup that scales it (an ellipsoid in both \
                         renderers), or scale it uniformly",
                    ));
                }
                let center = p.point("center")?.unwrap_or([0.0; 3]);
                let radius = p.float("radius")?.unwrap_or(1.0);
                // Mitsuba turns a sphere's normals inward under its own mirroring to_world, as
                // `flip_normals` does (and a mirror undoes a `flip_normals`).
                inside_out = mirrors;
                ShapeSpec::Sphere {
                    center,
                    radius,
                    material,
                    transform,
                    emission,
                    flip_normals: flip_normals ^ mirrors,
                }
            }
            "cylinder" => cylinder(n, &p, to_world, material, emission, flip_normals)?,
            kind @ ("linearcurve" | "bsplinecurve") => {
                if emission.is_some() {
                    return Err(n.error(
                        "an emitter on curves: Mitsuba cannot sample points on curves, and its render fails \
                         (\"pdf_position(): not implemented\")",
                    ));
                }
                if flip_normals {
                    return Err(n.error("flip_normals on curves (their outside is always the front)"));
                }
                let file = p.string("filename")?.ok_or_else(|| n.error("needs a `filename`"))?;
                // Its points are placed by its own to_world (a mirror included: the surface is built
                // round them, facing out), its radii left as they are; an instance places the whole.
                inside_out = mirrors;
                ShapeSpec::Curves {
                    file: self.resolve(n, &file),
                    material,
                    basis: if kind == "bsplinecurve" {
                        crate::scene::file::CurveBasis::Bspline
                    } else {
                        crate::scene::file::CurveBasis::Linear
                    },
                    transform: transform_spec(own),
                    segments: None,
                    instance_transform: outer.map(|m| transform_spec(Some(m))),
                }
            }
            _ => return Err(n.error(format!("shape type not read (read: {SHAPES})"))),
        };
        if mirrors && !inside_out {
            self.mirrored_bump(n, &mut spec);
            self.mirror_warning(n);
        }
        p.finish(
            "to_world, filename, face_normals, flip_normals, flip_tex_coords (obj, ply), shape_index, center, radius, p0, p1, a bsdf or <ref>, an area emitter",
        )?;
        self.file.shapes.push(spec);
        Ok(())
    }

    /// The meshes of a file the import's checks read (`placed_shape`), or None where it does not load:
    /// that is reported when the scene loads, with the file and what is wrong.
    fn load_file_meshes(&self, file: &str, shape_index: Option<u32>) -> Option<Vec<crate::scene::mesh::LoadedMesh>> {
        crate::scene::mesh::load_mesh_file(&self.base.join(file), file, true, shape_index, None).ok()
    }

    /// A bump map on a shape whose own `to_world` mirrors and whose geometric normal Mitsuba 3.9.1 turns
    /// inward while its shading normal stays out (a rectangle, a cube, a mesh with vertex normals: the
    /// mirrored frame's or the kept winding's cross product). Its `bumpmap` turns the bumped normal to
    /// that geometric normal, against the shading normal, and lets light only in directions on the same
    /// side of both: the surface is black from both sides but where its bumps are steep, at grazing
    /// angles. The import gives the shape a copy of the material with the bent normal turned to the back
    /// (`to_back`), which renders it so, and says so, naming the line.
    fn mirrored_bump(&mut self, n: &Node, spec: &mut ShapeSpec) {
        let material = match spec {
            ShapeSpec::Mesh { material: Some(m), .. }
            | ShapeSpec::Quad { material: m, .. }
            | ShapeSpec::Box { material: m, .. } => m,
            _ => return,
        };
        let Some(mut copy @ MaterialSpec::Bumpmap { .. }) = self.file.materials.get(material.as_str()).cloned() else {
            return;
        };
        self.warnings.push(format!(
            "{}: line {}: a bump map on a shape whose to_world mirrors: Mitsuba turns the bumped normal to the \
             geometric normal, which its mirror turns inward while the shading normal stays out, so the surface \
             is black from both sides but where its bumps are steep; caustica renders it so too",
            n.file.display(),
            n.line
        ));
        if let MaterialSpec::Bumpmap { to_back, .. } = &mut copy {
            *to_back = true;
        }
        *material = format!("{material}+mirrored");
        self.file.materials.insert(material.clone(), copy);
    }

    /// Warns of a shape whose own `to_world` mirrors where Mitsuba 3.9.1 turns the surface and caustica
    /// does not (caustica keeps a mirrored surface's normals transformed as normals; measured in README
    /// "Not done"): a cylinder rebuilds its frame without the mirror. Rectangles and disks turn their
    /// normals as caustica does; meshes Mitsuba renders inside out, and spheres, whose normals Mitsuba
    /// turns inward, are turned here too (`placed_shape`); a mesh with vertex normals, or a cube, whose
    /// faces Mitsuba turns inward has its media swapped (`media_turned`).
    fn mirror_warning(&mut self, n: &Node) {
        if n.attr("type") != Some("cylinder") {
            return;
        }
        let what = "Mitsuba's cylinder rebuilds its frame without the mirror and shades differently";
        self.warnings.push(format!(
            "{}: line {}: a mirroring to_world (negative determinant): {what}; caustica mirrors the surface \
             and keeps its outside facing out, so the two images differ",
            n.file.display(),
            n.line
        ));
    }

    /// A shape's media (`<medium name="interior|exterior">`, nested or a `<ref>`), read into its material
    /// (named `material`): under `volpath` `homogeneous` media inside and outside a dielectric (bare or
    /// under a normal or bump map) or a `null` surface are a copy of the material with its `absorption`
    /// and `outside_absorption` (σ_t = `sigma_t` × `scale`), and for a medium that scatters its `albedo`
    /// and `phase_g` (coloured glass, the coloured liquid or glass round it, milk in glass, smoke in a
    /// null box); anything else is refused. Mitsuba's other integrators ignore media, and so does the import then, with a warning.
    ///
    /// Mitsuba gives a segment the medium by the side of the face's geometric normal, from its winding
    /// (`target_medium`), where caustica's faces may be turned from the file's (`media_turned`): the
    /// media then swap sides in the copy, named with `+turned`.
    fn shape_media(
        &mut self,
        n: &'a Node,
        p: &Props<'a>,
        index: usize,
        material: String,
        mirrors: bool,
    ) -> Result<String, SceneError> {
        let media = p.children_where(|c| {
            matches!(c.tag.as_str(), "medium" | "ref") && matches!(c.attr("name"), Some("interior" | "exterior"))
        });
        if media.is_empty() {
            return Ok(material);
        }
        if !self.media {
            self.warnings.push(format!(
                "{}: line {}: the shape's media are ignored, as Mitsuba's integrator here ignores them (only \
                 volpath and volpathmis render media)",
                n.file.display(),
                n.line
            ));
            return Ok(material);
        }
        // Interior, exterior: σ and the name each gives the material's copy.
        let mut sides: [Option<(Medium, String)>; 2] = [None, None];
        for m in &media {
            let side = m.attr("name") == Some("exterior");
            let which = ["interior", "exterior"][side as usize];
            if sides[side as usize].is_some() {
                return Err(m.error(format!("a second {which} medium")));
            }
            let (node, label) = match m.tag.as_str() {
                "ref" => {
                    let id = m.attr("id").ok_or_else(|| m.error("needs an `id`"))?;
                    let target = self.lookup(m, id)?;
                    if target.tag != "medium" {
                        return Err(m.error(format!("`{id}` is a <{}>, not a <medium>", target.tag)));
                    }
                    (target, id.to_string())
                }
                _ => (*m, format!("shapes[{index}]-{which}")),
            };
            sides[side as usize] = Some((homogeneous_medium(node)?, label));
        }
        let turned = self.media_turned(n, p, mirrors)?;
        let label = sides.iter().filter_map(|s| s.as_ref().map(|(_, l)| l.as_str())).collect::<Vec<_>>();
        let suffix = label.join("+") + if turned { "+turned" } else { "" };
        if turned {
            sides.swap(0, 1);
        }
        let [inside, outside] = sides;
        let refuse = || {
            media[0].error(
                "a medium on a shape whose BSDF is not a `dielectric`, `roughdielectric` (or a `normalmap` or \
                 `bumpmap` over one) or `null` is not read (caustica reads media in and around glass, and \
                 inside null boundaries)",
            )
        };
        // A copy of a dielectric's or null material's spec with the media (None for any other material).
        let keys = |side: &Option<(Medium, String)>| side.as_ref().map_or(MediumKeys::default(), |(m, _)| m.keys());
        let media = [keys(&inside), keys(&outside)];
        let with_media = |spec: Option<&MaterialSpec>| {
            let mut copy = spec?.clone();
            copy.set_media(media.clone()).then_some(copy)
        };
        let mut spec = self.file.materials.get(&material).cloned();
        match &mut spec {
            // Glass under a normal or bump map: the map over a copy of the glass with the media.
            Some(MaterialSpec::Normalmap { material: glass, .. } | MaterialSpec::Bumpmap { material: glass, .. }) => {
                let copy = with_media(self.file.materials.get(glass.as_str())).ok_or_else(refuse)?;
                *glass = format!("{glass}+{suffix}");
                self.file.materials.insert(glass.clone(), copy);
            }
            _ => spec = Some(with_media(spec.as_ref()).ok_or_else(refuse)?),
        }
        let name = format!("{material}+{suffix}");
        self.file.materials.insert(name.clone(), spec.expect("a material, or refused above"));
        Ok(name)
    }

    /// Whether caustica's faces of shape `n` are all turned from the winding Mitsuba keeps, which sets
    /// the side of its media (`shape_media`). A mirroring `to_world` turns a cube's faces and a mesh's
    /// with vertex normals in its file here (their normals transformed as normals, the outside kept out)
    /// while Mitsuba keeps their winding; the load turns each triangle whose vertex normals point behind
    /// its face (`TriMesh::face_vertex_normals`), which Mitsuba keeps too. A mesh turned on some of its
    /// triangles but not all has its media on the two sides of those in Mitsuba: warned of, naming the
    /// line. A file that does not load says so when the scene loads.
    fn media_turned(&mut self, n: &Node, p: &Props<'a>, mirrors: bool) -> Result<bool, SceneError> {
        let kind = n.attr("type").unwrap_or("");
        if kind == "cube" {
            return Ok(mirrors);
        }
        if !matches!(kind, "obj" | "ply" | "serialized") || p.boolean("face_normals")?.unwrap_or(false) {
            return Ok(false);
        }
        let Some(file) = p.string("filename")? else { return Ok(false) };
        let shape_index = p.int("shape_index")?.and_then(|i| u32::try_from(i).ok());
        let file = self.resolve(n, &file);
        let Some(meshes) = self.load_file_meshes(&file, shape_index) else { return Ok(false) };
        // Without vertex normals in the file a mirrored mesh is turned inside out as Mitsuba renders it.
        let Some(against) = meshes.iter().map(|m| m.mesh.against_vertex_normals()).collect::<Option<Vec<_>>>() else {
            return Ok(false);
        };
        let (count, total) =
            (against.iter().flatten().filter(|a| **a).count(), against.iter().map(Vec::len).sum::<usize>());
        if count > 0 && count < total {
            self.warnings.push(format!(
                "{}: line {}: the vertex normals of `{file}` point behind {count} of its {total} triangles: caustica \
                 turns those to face their normals, as Mitsuba shades them, but Mitsuba gives the media by each \
                 triangle's winding, so the media differ across those triangles",
                n.file.display(),
                n.line
            ));
        }
        Ok(mirrors != (count == total && total > 0))
    }

    /// The material a shape names (nested `<bsdf>` or `<ref>`), or Mitsuba's default: one-sided diffuse
    /// 0.5, black on an emitter.
    fn shape_material(&mut self, n: &'a Node, p: &Props<'a>, index: usize, emits: bool) -> Result<String, SceneError> {
        let mut bsdfs: Vec<&Node> = p.objects("bsdf");
        for r in p.objects("ref") {
            let id = r.attr("id").ok_or_else(|| r.error("needs an `id`"))?;
            let target = self.lookup(r, id)?;
            if target.tag != "bsdf" {
                return Err(r.error(format!("`{id}` is a <{}>, not a <bsdf>", target.tag)));
            }
            bsdfs.push(target);
        }
        match bsdfs[..] {
            [] => {
                let (name, albedo) = if emits { ("default-emitter", 0.0) } else { ("default", 0.5) };
                self.file.materials.entry(name.to_string()).or_insert(MaterialSpec::Diffuse {
                    reflectance: Reflectance::Colour([albedo; 3]),
                    two_sided: false,
                });
                Ok(name.to_string())
            }
            [b] => self.material(b, &format!("shapes[{index}]")),
            _ => Err(n.error("has more than one BSDF")),
        }
    }

    /// Converts a `<bsdf>` once (by id, else named after its shape) and returns its material name.
    fn material(&mut self, b: &'a Node, fallback: &str) -> Result<String, SceneError> {
        if let Some(name) = self.done.get(&(b as *const Node)) {
            return Ok(name.clone());
        }
        let name = b.attr("id").map_or_else(|| fallback.to_string(), str::to_string);
        let spec = self.bsdf(b, false, &name)?;
        self.file.materials.insert(name.clone(), spec);
        self.done.insert(b as *const Node, name.clone());
        Ok(name)
    }

    /// One BSDF as a material spec; `name` is the material's (inline textures are named after it).
    fn bsdf(&mut self, b: &'a Node, two_sided: bool, name: &str) -> Result<MaterialSpec, SceneError> {
        let p = Props::new(b);
        let kind = b.attr("type").unwrap_or("");
        let spec = match kind {
            "twosided" => {
                let mut inner: Vec<&Node> = p.objects("bsdf");
                for r in p.objects("ref") {
                    inner.push(self.lookup(r, r.attr("id").unwrap_or(""))?);
                }
                for one in &inner {
                    if matches!(
                        one.attr("type"),
                        Some("dielectric" | "roughdielectric" | "thindielectric" | "twosided")
                    ) {
                        return Err(one.error("cannot be wrapped in twosided (it is two-sided already)"));
                    }
                    if matches!(one.attr("type"), Some("null" | "mask")) {
                        return Err(
                            one.error("cannot be wrapped in twosided (it lets light through; Mitsuba refuses it too)")
                        );
                    }
                }
                match inner[..] {
                    [one] => self.bsdf(one, true, name)?,
                    // The first on the front, the second on the back, seen as from its own front.
                    [front, back] => {
                        self.in_sides = true;
                        let sides = (
                            self.nested_material(front, false, &format!("{name}-front")),
                            self.nested_material(back, true, &format!("{name}-back")),
                        );
                        self.in_sides = false;
                        MaterialSpec::Sides { front: sides.0?, back: sides.1? }
                    }
                    _ => return Err(b.error(format!("needs one or two nested BSDFs (found {})", inner.len()))),
                }
            }
            "diffuse" => MaterialSpec::Diffuse { reflectance: self.reflectance(&p, "reflectance", name)?, two_sided },
            "plastic" | "roughplastic" => {
                let ior = p.float_or_name("int_ior", named_ior)?.unwrap_or(1.49);
                let outside_ior = p.float_or_name("ext_ior", named_ior)?.unwrap_or(1.000277);
                // Mitsuba's roughplastic reads one isotropic `alpha` (default 0.1), Beckmann by default.
                // (Its α is one number, not a texture: Mitsuba precomputes the coat's tables for it.)
                let (roughness, distribution) = if kind == "roughplastic" {
                    let distribution = microfacet_distribution(b, &p)?;
                    (p.float("alpha")?.unwrap_or(0.1), distribution)
                } else {
                    (0.0, Default::default())
                };
                MaterialSpec::Plastic {
                    roughness,
                    distribution,
                    reflectance: self.reflectance(&p, "diffuse_reflectance", name)?,
                    specular: self.colour_or_texture(&p, "specular_reflectance", name, 1.0)?,
                    ior,
                    outside_ior,
                    nonlinear: p.boolean("nonlinear")?.unwrap_or(false),
                    two_sided,
                }
            }
            "dielectric" | "thindielectric" | "roughdielectric" => {
                let int = p.float_or_name("int_ior", named_ior)?.unwrap_or(1.5046);
                let ext = p.float_or_name("ext_ior", named_ior)?.unwrap_or(1.000277);
                if p.rgb("specular_reflectance")?.is_some_and(|c| c != [1.0; 3]) {
                    return Err(b.error("specular_reflectance other than 1 is not supported"));
                }
                let tint = self.colour_or_texture(&p, "specular_transmittance", name, 1.0)?;
                match kind {
                    "thindielectric" => MaterialSpec::ThinDielectric { ior: int, outside_ior: ext, tint },
                    "dielectric" => MaterialSpec::Dielectric {
                        ior: int,
                        outside_ior: ext,
                        tint,
                        roughness: Weight::Value(0.0),
                        roughness_v: None,
                        distribution: Default::default(),
                        absorption: None,
                        outside_absorption: None,
                        albedo: None,
                        phase_g: 0.0,
                        outside_albedo: None,
                        outside_phase_g: 0.0,
                        phase: None,
                        outside_phase: None,
                    },
                    _ => {
                        let (roughness, roughness_v, distribution) = self.microfacet(b, &p, name)?;
                        MaterialSpec::Dielectric {
                            ior: int,
                            outside_ior: ext,
                            tint,
                            roughness,
                            roughness_v,
                            distribution,
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
                }
            }
            "conductor" | "roughconductor" => self.conductor(b, &p, two_sided, name)?,
            "principled" => self.principled(b, &p, two_sided, name)?,
            "blendbsdf" | "mask" => self.blend(b, &p, two_sided, name)?,
            "null" => MaterialSpec::null(),
            "normalmap" | "bumpmap" => self.normal_map(b, &p, two_sided, name)?,
            _ => return Err(b.error(format!("BSDF type not read (read: {BSDFS})"))),
        };
        p.finish(
            "the parameters of diffuse, plastic, roughplastic, dielectric, roughdielectric, thindielectric, conductor, \
             roughconductor, principled, twosided, blendbsdf (weight), mask (opacity), normalmap (normalmap, \
             flip_invalid_normals and use_shadowing_function, both true) and bumpmap (its texture, scale, the same \
             flags)",
        )?;
        Ok(spec)
    }

    /// `blendbsdf` (its `weight`, default ½, and two nested BSDFs in the order written) or `mask` (its
    /// `opacity`, default ½, over one nested BSDF, the rest a `null` surface), as a blend of materials
    /// converted for it; inside `twosided` both are two-sided.
    fn blend(&mut self, b: &'a Node, p: &Props<'a>, two_sided: bool, name: &str) -> Result<MaterialSpec, SceneError> {
        let mask = b.attr("type") == Some("mask");
        let key = if mask { "opacity" } else { "weight" };
        let weight = match self.colour_or_node(p, key, name)? {
            None => Weight::Value(0.5),
            // A colour counts by its luminance, as Mitsuba's `eval_1` reads it (a grey, exactly).
            Some(Valued::Rgb([r, g, bb])) if r == g && g == bb => Weight::Value(r),
            Some(Valued::Rgb(c)) => {
                Weight::Value(crate::scene::material::mitsuba_luminance(Vec3::from_array(c)).clamp(0.0, 1.0))
            }
            Some(Valued::Texture(t, fallback)) => Weight::Texture(self.scalar_texture(t, &fallback)?),
        };
        let nested = self.nested_bsdfs(p)?;
        if self.blends.contains(&(b as *const Node)) {
            return Err(b.error("contains itself (through <ref>s)"));
        }
        if self.blends.len() >= crate::scene::load::MAX_BLEND_DEPTH {
            return Err(b.error(format!("blends nested deeper than {}", crate::scene::load::MAX_BLEND_DEPTH)));
        }
        self.blends.push(b as *const Node);
        let sides = self.blend_sides(b, mask, &nested, two_sided, name);
        self.blends.pop();
        let (first, second) = sides?;
        Ok(MaterialSpec::Blend { weight, first, second })
    }

    /// `normalmap` (its `normalmap` texture) or `bumpmap` (its one texture, whatever its name, a
    /// bitmap: the height whose gradient bends the normal, times `scale`) over its one nested BSDF
    /// (converted as a material of its own). Inside `twosided` the back shows the front's mirror image;
    /// a `twosided` inside it makes the nested BSDF two-sided about the bent normal. Not inside a blend
    /// or a `twosided` of two BSDFs (the normal is perturbed for the whole surface, before a blend
    /// picks), nor over one.
    fn normal_map(
        &mut self,
        b: &'a Node,
        p: &Props<'a>,
        two_sided: bool,
        name: &str,
    ) -> Result<MaterialSpec, SceneError> {
        let kind = b.attr("type").unwrap_or("normalmap");
        if !self.blends.is_empty() || self.in_sides {
            return Err(b.error(format!(
                "a {kind} inside a blendbsdf, mask or two-BSDF twosided is not supported (put it around them)"
            )));
        }
        let bump = kind == "bumpmap";
        let texture = if bump {
            self.bump_height(b, p, name)?
        } else {
            match self.colour_or_node(p, "normalmap", name)? {
                Some(Valued::Texture(t, fallback)) => self.texture(t, &fallback)?,
                _ => return Err(b.error("needs a `normalmap` texture")),
            }
        };
        let scale = if bump { p.float("scale")?.unwrap_or(1.0) } else { 1.0 };
        for flag in ["flip_invalid_normals", "use_shadowing_function"] {
            if p.boolean(flag)? == Some(false) {
                return Err(
                    b.error(format!("`{flag}` false is not supported (caustica's normal map is Mitsuba's default)"))
                );
            }
        }
        let nested = self.nested_bsdfs(p)?;
        let [one] = nested[..] else {
            return Err(b.error(format!("needs exactly one nested BSDF (found {})", nested.len())));
        };
        if let Some(t @ ("blendbsdf" | "mask" | "null" | "thindielectric" | "normalmap" | "bumpmap")) = one.attr("type")
        {
            return Err(one.error(format!("a `{t}` under a {kind} is not supported (put the {kind}s inside it)")));
        }
        let material = self.nested_material(one, two_sided, &format!("{name}-mapped"))?;
        if let Some(MaterialSpec::Blend { .. } | MaterialSpec::Sides { .. }) = self.file.materials.get(&material) {
            return Err(
                one.error(format!("a twosided of two BSDFs under a {kind} is not supported (put a {kind} in each)"))
            );
        }
        // Inside `twosided`, the back is the front's mirror image, normal map and all.
        Ok(if bump {
            MaterialSpec::Bumpmap { height: texture, scale, material, two_sided, to_back: false }
        } else {
            MaterialSpec::Normalmap { normal_map: texture, material, two_sided }
        })
    }

    /// A `bumpmap`'s height: its one texture (whatever its name, or a `<ref>` to one), which must be a
    /// bitmap, converted; warned of where its `to_uv` turns or shears (Mitsuba 3.9.1's gradient is then
    /// not the derivative on a non-square image; caustica's is).
    fn bump_height(&mut self, b: &'a Node, p: &Props<'a>, name: &str) -> Result<String, SceneError> {
        let is_texture = |c: &Node| {
            c.tag == "texture"
                || (c.tag == "ref" && c.attr("id").and_then(|id| self.ids.get(id)).is_some_and(|t| t.tag == "texture"))
        };
        let found = p.children_where(is_texture);
        let [t] = found[..] else {
            return Err(b.error(format!("needs exactly one texture, its height (found {})", found.len())));
        };
        let t = match t.attr("id") {
            Some(id) if t.tag == "ref" => self.lookup(t, id)?,
            _ => t,
        };
        match t.attr("type") {
            Some("bitmap") => {}
            other => {
                return Err(t.error(format!(
                    "a bumpmap's height must be a bitmap, whose gradient bends the normal (a {} has none, in \
                     Mitsuba 3.9 too)",
                    other.unwrap_or("texture without a type")
                )))
            }
        }
        let height = self.texture(t, &format!("{name}-height"))?;
        if let Some(TextureSpec::Bitmap { matrix: Some(m), .. }) = self.file.textures.get(&height) {
            if m[0][1] != 0.0 || m[1][0] != 0.0 {
                self.warnings.push(format!(
                    "{}: line {}: the bumpmap's height turns or shears its texture coordinates (`to_uv`): \
                     Mitsuba 3.9.1's gradient there is not its texture's derivative unless the image is square \
                     (it scales by the image's size after turning); caustica bends by the derivative",
                    t.file.display(),
                    t.line
                ));
            }
        }
        Ok(height)
    }

    /// The two materials a blend mixes (a mask's first is a `null` surface).
    fn blend_sides(
        &mut self,
        b: &'a Node,
        mask: bool,
        nested: &[&'a Node],
        two_sided: bool,
        name: &str,
    ) -> Result<(String, String), SceneError> {
        Ok(match (mask, nested) {
            (true, [one]) => {
                let null = self.fresh_material_name("null");
                self.file.materials.insert(null.clone(), MaterialSpec::null());
                (null, self.nested_material(one, two_sided, &format!("{name}-masked"))?)
            }
            (false, [one, two]) => (
                self.nested_material(one, two_sided, &format!("{name}-first"))?,
                self.nested_material(two, two_sided, &format!("{name}-second"))?,
            ),
            (true, _) => return Err(b.error(format!("needs exactly one nested BSDF (found {})", nested.len()))),
            (false, _) => return Err(b.error(format!("needs exactly two nested BSDFs (found {})", nested.len()))),
        })
    }

    /// The `<bsdf>` children of a node and the BSDFs its `<ref>`s name, in the order written.
    fn nested_bsdfs(&mut self, p: &Props<'a>) -> Result<Vec<&'a Node>, SceneError> {
        let mut out = Vec::new();
        for c in p.objects_of(&["bsdf", "ref"]) {
            if c.tag == "bsdf" {
                out.push(c);
                continue;
            }
            let id = c.attr("id").ok_or_else(|| c.error("needs an `id`"))?;
            let target = self.lookup(c, id)?;
            if target.tag != "bsdf" {
                return Err(c.error(format!("`{id}` is a <{}>, not a <bsdf>", target.tag)));
            }
            out.push(target);
        }
        Ok(out)
    }

    /// A BSDF nested in a blend as a material of its own: converted once by id where it is one-sided
    /// (shared with its other uses), afresh under `fallback` inside `twosided`.
    fn nested_material(&mut self, b: &'a Node, two_sided: bool, fallback: &str) -> Result<String, SceneError> {
        if !two_sided {
            return self.material(b, fallback);
        }
        let name = self.fresh_material_name(fallback);
        let spec = self.bsdf(b, true, &name)?;
        self.file.materials.insert(name.clone(), spec);
        Ok(name)
    }

    /// `base`, or `base-2`, `base-3`, … whichever no material has yet.
    fn fresh_material_name(&self, base: &str) -> String {
        let mut name = base.to_string();
        let mut i = 2;
        while self.file.materials.contains_key(&name) {
            name = format!("{base}-{i}");
            i += 1;
        }
        name
    }

    /// A reflectance property (Mitsuba's default 0.5): a colour, or a texture nested or referenced.
    fn reflectance(&mut self, p: &Props<'a>, key: &str, name: &str) -> Result<Reflectance, SceneError> {
        self.colour_or_texture(p, key, name, 0.5)
    }

    /// A colour property (`default` grey when absent): a colour, or a texture nested or referenced.
    fn colour_or_texture(
        &mut self,
        p: &Props<'a>,
        key: &str,
        name: &str,
        default: f32,
    ) -> Result<Reflectance, SceneError> {
        Ok(self.colour_prop(p, key, name)?.unwrap_or(Reflectance::Colour([default; 3])))
    }

    /// A colour property if given: a colour, or a texture nested or referenced (converted once).
    fn colour_prop(&mut self, p: &Props<'a>, key: &str, name: &str) -> Result<Option<Reflectance>, SceneError> {
        Ok(Some(match self.colour_or_node(p, key, name)? {
            None => return Ok(None),
            Some(Valued::Rgb(c)) => Reflectance::Colour(c),
            Some(Valued::Texture(t, fallback)) => Reflectance::Texture(self.texture(t, &fallback)?),
        }))
    }

    /// A property that is a colour or a texture, if given: the colour, or the `<texture>` (nested, or
    /// the one a `<ref>` names) with the name it gets in `[textures]` unless it has an id of its own.
    fn colour_or_node(&self, p: &Props<'a>, key: &str, name: &str) -> Result<Option<Valued<'a>>, SceneError> {
        Ok(Some(match p.colour(key)? {
            None => return Ok(None),
            Some(ColourProp::Rgb(c)) => Valued::Rgb(c),
            Some(ColourProp::Texture(t)) => Valued::Texture(t, format!("{name}-{key}")),
            Some(ColourProp::Ref(r, id)) => match self.lookup(r, &id)? {
                t if t.tag == "texture" && t.attr("type") == Some("srgb") => Valued::Rgb(props::srgb_texture(t)?),
                t => Valued::Texture(t, id),
            },
        }))
    }

    fn conductor(
        &mut self,
        b: &'a Node,
        p: &Props<'a>,
        two_sided: bool,
        name: &str,
    ) -> Result<MaterialSpec, SceneError> {
        use crate::scene::material::Microfacet;
        let (roughness, roughness_v, distribution) = if b.attr("type") == Some("roughconductor") {
            self.microfacet(b, p, name)?
        } else {
            (Weight::Value(0.0), None, Microfacet::Ggx)
        };
        let specular = self.colour_prop(p, "specular_reflectance", name)?;
        let (eta, k) = (p.rgb("eta")?, p.rgb("k")?);
        let material = p.string("material")?;
        // 0.6's index of refraction of the medium outside a conductor (Mitsuba 3 has it as 1): the
        // Fresnel term reads η and k relative to it.
        let outside = if self.legacy { p.float_or_name("ext_eta", named_ior)? } else { None };
        let (eta, k) = match (material.as_deref(), eta, k) {
            (None | Some("none"), None, None) => {
                let specular = specular.unwrap_or(Reflectance::Colour([1.0; 3]));
                return Ok(MaterialSpec::Mirror { specular, roughness, roughness_v, distribution, two_sided });
            }
            (Some(m), None, None) => {
                let (e, k) = crate::scene::material::complex_ior(m).ok_or_else(|| {
                    b.error(format!(
                        "conductor material `{m}` is not one Mitsuba names (a-C, Ag, Al, AlAs, AlSb, Au, Be, Cr, CsI, \
                         Cu, Cu2O, CuO, d-C, Hg, HgTe, Ir, K, Li, MgO, Mo, Na_palik, Nb, Ni_palik, Rh, Se, Se-e, SiC, \
                         SnTe, Ta, Te, Te-e, ThF4, TiC, TiN, TiO2, TiO2-e, V_palik, VC, VN, W, none; most also with \
                         `_palik`; names are case-sensitive)"
                    ))
                })?;
                (e.to_array(), k.to_array())
            }
            (None, Some(e), Some(k)) => (e, k),
            (None, Some(e), None) => (e, [0.0; 3]),
            _ => return Err(b.error("give `material`, or `eta` and `k`, not both")),
        };
        let (eta, k) = match outside {
            Some(o) if o > 0.0 => (eta.map(|x| x / o), k.map(|x| x / o)),
            Some(o) => return Err(b.error(format!("ext_eta must be > 0, got {o}"))),
            None => (eta, k),
        };
        Ok(MaterialSpec::Conductor {
            preset: None,
            specular,
            eta: Some(eta),
            k: Some(k),
            roughness,
            roughness_v,
            distribution,
            two_sided,
        })
    }

    /// A rough conductor's or dielectric's roughness α (`alpha`, Mitsuba's default 0.1; a number or a
    /// texture read as one number), or `alpha_u` and `alpha_v` (each a number or a texture; anisotropic
    /// where they differ: α along the surface's ∂p/∂u and the roughness across it), and microfacet
    /// distribution (Mitsuba's default Beckmann).
    fn microfacet(
        &mut self,
        b: &'a Node,
        p: &Props<'a>,
        name: &str,
    ) -> Result<(Weight, Option<Weight>, crate::scene::material::Microfacet), SceneError> {
        let distribution = microfacet_distribution(b, p)?;
        let alpha = self.scalar_prop(b, p, "alpha", name)?;
        let u = self.scalar_prop(b, p, "alpha_u", name)?;
        let v = self.scalar_prop(b, p, "alpha_v", name)?;
        let (alpha, across) = match (alpha, u, v) {
            (Some(a), None, None) => (a, None),
            (Some(_), _, _) => return Err(b.error("give `alpha`, or `alpha_u` and `alpha_v`, not both")),
            (None, None, None) => (Weight::Value(0.1), None),
            (None, Some(u), Some(v)) if u == v => (u, None),
            (None, Some(u), Some(v)) => {
                let positive = |w: &Weight| match w {
                    Weight::Value(x) => *x > 0.0,
                    Weight::Texture(_) => true,
                };
                if !(positive(&u) && positive(&v)) {
                    let show = |w: &Weight| match w {
                        Weight::Value(x) => x.to_string(),
                        Weight::Texture(_) => "a texture".into(),
                    };
                    let msg = format!("`alpha_u` and `alpha_v` must both be > 0 (got {} and {})", show(&u), show(&v));
                    return Err(b.error(msg));
                }
                (u, Some(v))
            }
            (None, _, _) => return Err(b.error("give both `alpha_u` and `alpha_v` (or one `alpha`)")),
        };
        Ok((alpha, across, distribution))
    }

    /// A property Mitsuba reads as one number (its `eval_1`), if given: a number, a grey colour, or a
    /// texture nested or referenced (`scalar_texture`).
    fn scalar_prop(&mut self, b: &Node, p: &Props<'a>, key: &str, name: &str) -> Result<Option<Weight>, SceneError> {
        Ok(Some(match self.colour_or_node(p, key, name)? {
            None => return Ok(None),
            Some(Valued::Rgb([a, g, bb])) if a == g && g == bb => Weight::Value(a),
            Some(Valued::Rgb(_)) => return Err(b.error(format!("`{key}` must be one number or a texture"))),
            Some(Valued::Texture(t, fallback)) => Weight::Texture(self.scalar_texture(t, &fallback)?),
        }))
    }

    /// Mitsuba's `principled`: its weights (`anisotropic` among them) numbers or textures, each read
    /// as one number; the sampling rates change only the noise and are read and left.
    fn principled(
        &mut self,
        b: &'a Node,
        p: &Props<'a>,
        two_sided: bool,
        name: &str,
    ) -> Result<MaterialSpec, SceneError> {
        for rate in ["main_specular_sampling_rate", "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate"] {
            p.float(rate)?;
        }
        let weight = |key: &str| -> Result<Weight, SceneError> {
            Ok(self.scalar_prop(b, p, key, name)?.unwrap_or(Weight::Value(0.0)))
        };
        let [metallic, spec_trans, spec_tint, sheen, sheen_tint, flatness, clearcoat, clearcoat_gloss, anisotropic] =
            PRINCIPLED_WEIGHTS.map(weight);
        let spec_trans = spec_trans?;
        // Mitsuba's twosided refuses a principled BSDF that can transmit (a textured spec_trans can).
        if two_sided && spec_trans != Weight::Value(0.0) {
            return Err(
                b.error("a principled BSDF with spec_trans cannot be wrapped in twosided (Mitsuba refuses it too)")
            );
        }
        Ok(MaterialSpec::Principled {
            base_color: self.colour_or_texture(p, "base_color", name, 0.5)?,
            roughness: self.scalar_prop(b, p, "roughness", name)?.unwrap_or(Weight::Value(0.5)),
            metallic: metallic?,
            spec_trans,
            spec_tint: spec_tint?,
            sheen: sheen?,
            sheen_tint: sheen_tint?,
            flatness: flatness?,
            clearcoat: clearcoat?,
            clearcoat_gloss: clearcoat_gloss?,
            anisotropic: anisotropic?,
            specular: p.float("specular")?,
            eta: p.float("eta")?,
            two_sided: Some(two_sided),
        })
    }

    /// A texture read as one number (a blend's weight, a mask's opacity) as Mitsuba 3.9 reads it (its
    /// `eval_1`): a colour by its luminance, which caustica's blend weight takes, and a checkerboard with
    /// its two colours the other way round (Mitsuba's `eval_1` puts `color1` where its `eval` puts
    /// `color0`), so a second checkerboard with them swapped.
    fn scalar_texture(&mut self, t: &'a Node, fallback: &str) -> Result<String, SceneError> {
        let name = self.texture(t, fallback)?;
        Ok(self.as_weight(name))
    }

    /// `[textures]` entry `name` as Mitsuba's `eval_1` reads it: a checkerboard with its squares swapped,
    /// and each square that is a texture read so too (a textured square's `eval_1`); others as they are.
    fn as_weight(&mut self, name: String) -> String {
        let Some(TextureSpec::Checkerboard { color0, color1, scale, offset, matrix }) = self.file.textures.get(&name)
        else {
            return name;
        };
        let scalar = format!("{name}-as-weight");
        if self.file.textures.contains_key(&scalar) {
            return scalar;
        }
        let (color0, color1, scale, offset, matrix) = (color0.clone(), color1.clone(), *scale, *offset, *matrix);
        // `texture` refuses boards nested deeper than `MAX_TEXTURE_DEPTH` or containing themselves: this walk ends.
        let mut square = |c: Reflectance| match c {
            Reflectance::Texture(n) => Reflectance::Texture(self.as_weight(n)),
            c => c,
        };
        let swapped =
            TextureSpec::Checkerboard { color0: square(color1), color1: square(color0), scale, offset, matrix };
        self.file.textures.insert(scalar.clone(), swapped);
        scalar
    }

    /// Converts a `<texture>` once and returns its name in `[textures]`.
    fn texture(&mut self, t: &'a Node, fallback: &str) -> Result<String, SceneError> {
        if let Some(name) = self.done.get(&(t as *const Node)) {
            return Ok(name.clone());
        }
        let mut name = t.attr("id").map_or_else(|| fallback.to_string(), str::to_string);
        while self.file.textures.contains_key(&name) {
            name += "'";
        }
        if self.textures.contains(&(t as *const Node)) {
            return Err(t.error("a checkerboard's square refers to the texture it is part of"));
        }
        if self.textures.len() >= crate::scene::load::MAX_TEXTURE_DEPTH {
            let msg = format!("textures nested deeper than {} in checkerboards", crate::scene::load::MAX_TEXTURE_DEPTH);
            return Err(t.error(msg));
        }
        let p = Props::new(t);
        // Mitsuba keeps the 2-D part of the 4×4: [m00 m01 m03; m10 m11 m13].
        let matrix = p.transform("to_uv")?.map(|m| {
            let c = |r: usize, col: usize| m.col(col)[r];
            [[c(0, 0), c(0, 1), c(0, 3)], [c(1, 0), c(1, 1), c(1, 3)]]
        });
        // 0.5/0.6 placed a texture by `uscale`, `vscale`, `uoffset` and `voffset` (uv · scale + offset).
        let (scale, offset) = if self.legacy {
            let scale = [p.float("uscale")?.unwrap_or(1.0), p.float("vscale")?.unwrap_or(1.0)];
            let offset = [p.float("uoffset")?.unwrap_or(0.0), p.float("voffset")?.unwrap_or(0.0)];
            if matrix.is_some() && (scale != [1.0; 2] || offset != [0.0; 2]) {
                return Err(t.error("give `to_uv`, or uscale, vscale, uoffset and voffset, not both"));
            }
            (scale, offset)
        } else {
            ([1.0; 2], [0.0; 2])
        };
        let spec = match t.attr("type") {
            Some("checkerboard") => {
                // A square may be another texture, read at the same uv through its own `to_uv`.
                self.textures.push(t);
                let color0 = self.colour_prop(&p, "color0", &name)?.unwrap_or(Reflectance::Colour([0.4; 3]));
                let color1 = self.colour_prop(&p, "color1", &name)?.unwrap_or(Reflectance::Colour([0.2; 3]));
                self.textures.pop();
                TextureSpec::Checkerboard { color0, color1, scale, offset, matrix }
            }
            Some("bitmap") => {
                let file = p.string("filename")?.ok_or_else(|| t.error("needs a `filename`"))?;
                let bilinear = match p.string("filter_type")?.as_deref() {
                    None | Some("bilinear") => true,
                    Some("nearest") => false,
                    // 0.6's MIP-mapped filters prefilter what a pixel covers; many samples a pixel of
                    // the bilinear image average the same texels (README: a blur apart where minified).
                    Some("trilinear" | "ewa") if self.legacy => true,
                    Some(f) => return Err(t.error(format!("filter_type `{f}` (read: bilinear, nearest)"))),
                };
                // 0.6's override of the image's encoding: 1 linear, −1 sRGB.
                let legacy_raw = match self.legacy.then(|| p.float("gamma")).transpose()?.flatten() {
                    None => None,
                    Some(1.0) => Some(true),
                    Some(-1.0) => Some(false),
                    Some(g) => return Err(t.error(format!("gamma {g} (read: 1, linear, and -1, sRGB)"))),
                };
                if self.legacy {
                    p.float("max_anisotropy")?;
                    p.boolean("cache")?;
                }
                use crate::scene::texture::Wrap;
                let wrap = match p.string("wrap_mode")?.as_deref() {
                    None | Some("repeat") => Wrap::Repeat,
                    Some("clamp") => Wrap::Clamp,
                    Some("mirror") => Wrap::Mirror,
                    Some(w) => return Err(t.error(format!("wrap_mode `{w}` (read: repeat, clamp, mirror)"))),
                };
                // How Mitsuba stores the texels (half floats for 8- and 16-bit images by default) and
                // whether a GPU reads them through its texture units: precision only.
                p.boolean("accel")?;
                if let Some(f) = p.string("format")?.filter(|f| !["auto", "variant", "fp16"].contains(&f.as_str())) {
                    return Err(t.error(format!("format `{f}` (read: auto, variant, fp16)")));
                }
                let raw = p.boolean("raw")?.or(legacy_raw).unwrap_or(false);
                TextureSpec::Bitmap { file: self.resolve(t, &file), raw, bilinear, wrap, scale, offset, matrix }
            }
            Some("mesh_attribute") => {
                // The hit mesh's attribute, times `scale`: caustica reads the vertex colours
                // (interpolated) and the face colours.
                let attr = p.string("name")?.ok_or_else(|| t.error("a `mesh_attribute` needs a `name`"))?;
                if matrix.is_some() {
                    return Err(t.error("a `mesh_attribute` texture has no `to_uv` (Mitsuba refuses it too)"));
                }
                let scale = p.float("scale")?.unwrap_or(1.0);
                match attr.as_str() {
                    "vertex_color" => TextureSpec::VertexColor { scale },
                    "face_color" => TextureSpec::FaceColor { scale },
                    _ => {
                        let msg = format!("mesh attribute `{attr}` is not read (read: vertex_color, face_color)");
                        return Err(t.error(msg));
                    }
                }
            }
            _ => return Err(t.error("texture type not read (read: bitmap, checkerboard, mesh_attribute, srgb)")),
        };
        p.finish(
            "filename, filter_type, wrap_mode, raw, to_uv, accel, format (bitmap); color0, color1, to_uv (checkerboard); \
             name = vertex_color or face_color, scale (mesh_attribute); in 0.5/0.6 files uscale, vscale, uoffset, voffset, \
             and gamma, max_anisotropy, cache (bitmap)",
        )?;
        self.file.textures.insert(name.clone(), spec);
        self.done.insert(t as *const Node, name.clone());
        Ok(name)
    }

    fn emitter(&mut self, e: &'a Node) -> Result<(), SceneError> {
        let p = Props::new(e);
        // How often Mitsuba's light samples pick this emitter: it changes the noise, not the image.
        p.float("sampling_weight")?;
        // The medium it sits in, which Mitsuba's path tracers do not read (a path carries its own, and a
        // light sample is dimmed by the medium of the point it lights): read and left out.
        self.endpoint_medium(&p)?;
        match e.attr("type") {
            Some("point") => {
                let intensity = p.rgb("intensity")?.unwrap_or([1.0; 3]);
                let at = p.point("position")?;
                let m = p.transform("to_world")?;
                let position = match (at, m) {
                    (Some(_), Some(_)) => return Err(e.error("give `position` or `to_world`, not both")),
                    (Some(x), None) => x,
                    (None, m) => m.unwrap_or(Mat4::IDENTITY).transform_point3(Vec3::ZERO).to_array(),
                };
                // Mitsuba's intensity is W/sr; caustica's point light takes its total power, 4π I.
                let power = intensity.map(|i| i * 4.0 * std::f32::consts::PI);
                self.file.lights.push(LightSpec::Point { position, power });
            }
            Some("spot") => {
                // Mitsuba's spot sits at to_world's origin and shines along its +z; a beam wider than
                // the cutoff is a hard edge at the cutoff there, as here with the two equal.
                let intensity = p.rgb("intensity")?.unwrap_or([1.0; 3]);
                let cutoff_angle = p.float("cutoff_angle")?.unwrap_or(20.0);
                let beam_width = p.float("beam_width")?.unwrap_or(0.75 * cutoff_angle).min(cutoff_angle);
                let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                // A projected texture (Mitsuba's `texture`, a bitmap or another varying texture) runs
                // along the spot's local x and y: its `up` is to_world's y, which must not scale or shear.
                let (texture, up) =
                    match self.colour_or_node(&p, "texture", &format!("lights[{}]", self.file.lights.len()))? {
                        None => (None, None),
                        Some(Valued::Rgb(_)) => {
                            return Err(e.error(
                                "a spot's `texture` must be a texture that varies (Mitsuba refuses a constant too)",
                            ))
                        }
                        Some(Valued::Texture(t, fallback)) => {
                            if !rotates_and_translates(&m) {
                                return Err(e.error(
                                    "a spot with a `texture` needs a to_world that only rotates and translates",
                                ));
                            }
                            (Some(self.texture(t, &fallback)?), Some(m.y_axis.truncate().to_array()))
                        }
                    };
                self.file.lights.push(LightSpec::Spot {
                    position: m.transform_point3(Vec3::ZERO).to_array(),
                    direction: Some(m.transform_vector3(Vec3::Z).to_array()),
                    target: None,
                    intensity: Some(intensity),
                    power: None,
                    cutoff_angle,
                    beam_width: Some(beam_width),
                    texture,
                    up,
                });
            }
            Some("projector") => {
                // Mitsuba's projector sits at to_world's origin and shines along its +z, its image's x
                // across its local x; it lights with π × scale × its `irradiance` (a texture or a colour)
                // where caustica's `irradiance` is what a surface facing it at unit distance receives.
                let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                if !rotates_and_translates(&m) {
                    return Err(e.error("a projector needs a to_world that only rotates and translates"));
                }
                let (y, z) = (m.y_axis.truncate(), m.z_axis.truncate());
                let scale = p.float("scale")?.unwrap_or(1.0) * std::f32::consts::PI;
                let name = format!("lights[{}]", self.file.lights.len());
                let (irradiance, texture) = match self.colour_or_node(&p, "irradiance", &name)? {
                    None => return Err(e.error("a projector needs an `irradiance` (Mitsuba refuses one without)")),
                    Some(Valued::Rgb(c)) => (c.map(|v| v * scale), None),
                    Some(Valued::Texture(t, fallback)) => ([scale; 3], Some(self.texture(t, &fallback)?)),
                };
                let (fov, fov_axis) =
                    field_of_view(e, p.float("fov")?, p.string("fov_axis")?, p.string("focal_length")?)?;
                self.file.lights.push(LightSpec::Projector {
                    position: m.transform_point3(Vec3::ZERO).to_array(),
                    direction: Some(z.to_array()),
                    target: None,
                    up: Some(y.to_array()),
                    fov,
                    fov_axis: Some(fov_axis),
                    irradiance: Some(irradiance),
                    texture,
                });
            }
            Some("constant") => {
                let radiance = p.rgb("radiance")?.unwrap_or([1.0; 3]);
                self.file.lights.push(LightSpec::Constant { radiance });
            }
            Some("envmap") => {
                let file = p.string("filename")?.ok_or_else(|| e.error("needs a `filename`"))?;
                let scale = p.float("scale")?.unwrap_or(1.0);
                let to_world = p.transform("to_world")?;
                // Mitsuba 3.9.1 renders another sky under a to_world that scales (a uniform scale of 2:
                // 1.31 of the unscaled sky's mean, 1, 3, 1: 1.62), which caustica does not copy; and
                // caustica's sky only turns (the loader refuses a mirror too, naming only its key).
                if to_world.is_some_and(|m| !rotates_and_translates(&m)) {
                    return Err(e.error(
                        "an envmap's to_world that scales or shears it (Mitsuba renders another sky then: a \
                         uniform scale of 2 read 1.31 of the unscaled sky's mean) or mirrors it; rotate it only",
                    ));
                }
                let transform = transform_spec(to_world);
                // How Mitsuba draws directions from the sky (sharpened for MIS): the image is the same.
                p.boolean("mis_compensation")?;
                self.file.lights.push(LightSpec::Envmap { file: self.resolve(e, &file), scale, transform });
            }
            Some("directional") => {
                let irradiance = p.rgb("irradiance")?.unwrap_or([1.0; 3]);
                let (d, m) = (p.point("direction")?, p.transform("to_world")?);
                let direction = match (d, m) {
                    (Some(_), Some(_)) => return Err(e.error("give `direction` or `to_world`, not both")),
                    (Some(d), None) => d,
                    (None, m) => m.unwrap_or(Mat4::IDENTITY).transform_vector3(Vec3::Z).to_array(),
                };
                self.file.lights.push(LightSpec::Distant { direction, irradiance });
            }
            Some("area") => return Err(e.error("an area emitter must sit inside the <shape> that emits")),
            _ => return Err(e.error(format!("emitter type not read (read: {EMITTERS})"))),
        }
        p.finish(
            "intensity, position, to_world (point); intensity, cutoff_angle, beam_width, texture, to_world (spot); irradiance, scale, fov, fov_axis, focal_length, to_world (projector); irradiance, direction, to_world (directional); radiance \
             (constant); filename, scale, to_world, mis_compensation (envmap); sampling_weight, medium (every emitter)",
        )
    }
}

/// Whether `m` only rotates and translates (its axes unit, at right angles and right-handed, within
/// 1e-3): what a light projecting an image through its frame needs, as Mitsuba maps points through the
/// inverse of that frame and caustica through an orthonormal one.
fn rotates_and_translates(m: &Mat4) -> bool {
    let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    [x, y, z].iter().all(|a| (a.length() - 1.0).abs() < 1e-3)
        && [x.dot(y), x.dot(z), y.dot(z)].iter().all(|d| d.abs() < 1e-3)
        && x.cross(y).dot(z) > 0.0
}

/// Mitsuba's field of view of a camera or projector `n`: its `fov` degrees along `fov_axis` (default x),
/// or its 35 mm film equivalent `focal_length` (default 50 mm) along the diagonal.
fn field_of_view(
    n: &Node,
    fov: Option<f32>,
    fov_axis: Option<String>,
    focal: Option<String>,
) -> Result<(f32, String), SceneError> {
    Ok(match (fov, focal) {
        (Some(_), Some(_)) => return Err(n.error("give `fov` or `focal_length`, not both")),
        (Some(f), None) => (f, fov_axis.unwrap_or_else(|| "x".into())),
        (None, f) => {
            let f = f.unwrap_or_else(|| "50mm".into());
            let mm: f32 =
                f.trim_end_matches("mm").trim().parse().map_err(|_| n.error(format!("focal_length `{f}`")))?;
            ((36f32.hypot(24.0) / (2.0 * mm)).atan().to_degrees() * 2.0, "diagonal".into())
        }
    })
}

/// Rewrites the file names of a converted scene (meshes, bitmaps), given relative to `from`, to be
/// relative to `to` (both folders must exist), so the TOML can be written somewhere else.
pub fn rebase(file: &mut SceneFile, from: &Path, to: &Path) -> Result<(), String> {
    let canon = |p: &Path| p.canonicalize().map_err(|e| format!("{}: {e}", p.display()));
    let (from, to) = (canon(if from.as_os_str().is_empty() { Path::new(".") } else { from })?, canon(to)?);
    let fix = |name: &mut String| -> Result<(), String> {
        let target = canon(&from.join(&*name))?;
        *name = relative_path(&to, &target).display().to_string();
        Ok(())
    };
    for s in &mut file.shapes {
        if let ShapeSpec::Mesh { file, .. } | ShapeSpec::Curves { file, .. } = s {
            fix(file)?;
        }
    }
    for l in &mut file.lights {
        if let LightSpec::Envmap { file, .. } = l {
            fix(file)?;
        }
    }
    for t in file.textures.values_mut() {
        if let TextureSpec::Bitmap { file, .. } = t {
            fix(file)?;
        }
    }
    Ok(())
}

/// Mitsuba's `cylinder`: the open tube (no caps) of `radius` from `p0` to `p1` under `to_world`, with
/// its texture coordinates (so textures, normal maps and anisotropic BSDFs follow them), as a 256-sided
/// tube with smooth radial normals (its silhouette within 7.6e-5 radii of the circle); normals outward,
/// inward with `flip_normals`.
fn cylinder(
    n: &Node,
    p: &Props,
    to_world: Option<Mat4>,
    material: String,
    emission: Option<Reflectance>,
    flip_normals: bool,
) -> Result<ShapeSpec, SceneError> {
    let p0 = Vec3::from_array(p.point("p0")?.unwrap_or([0.0; 3]));
    let p1 = Vec3::from_array(p.point("p1")?.unwrap_or([0.0, 0.0, 1.0]));
    let radius = p.float("radius")?.unwrap_or(1.0);
    let axis = p1 - p0;
    let fine = radius > 0.0 && radius.is_finite() && axis.length() > 0.0 && axis.is_finite() && p0.is_finite();
    if !fine {
        return Err(n.error(format!("needs a radius > 0 and p0 ≠ p1 (got radius {radius}, p0 {p0}, p1 {p1})")));
    }
    Ok(ShapeSpec::Cylinder {
        p0: p0.to_array(),
        p1: p1.to_array(),
        radius,
        material,
        segments: 256,
        transform: transform_spec(to_world),
        emission,
        flip_normals,
    })
}

/// A microfacet BSDF's `distribution` (Mitsuba's default Beckmann) and `sample_visible` (read and
/// ignored: it only changes how Mitsuba samples).
fn microfacet_distribution(b: &Node, p: &Props) -> Result<crate::scene::material::Microfacet, SceneError> {
    use crate::scene::material::Microfacet;
    let distribution = match p.string("distribution")?.as_deref() {
        Some("ggx") => Microfacet::Ggx,
        None | Some("beckmann") => Microfacet::Beckmann,
        Some(d) => return Err(b.error(format!("microfacet distribution `{d}` (read: beckmann, ggx)"))),
    };
    p.boolean("sample_visible")?;
    Ok(distribution)
}

/// `target` as seen from folder `base` (both absolute): `../x/y` where needed.
fn relative_path(base: &Path, target: &Path) -> PathBuf {
    let (b, t): (Vec<_>, Vec<_>) = (base.components().collect(), target.components().collect());
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
}

/// A Mitsuba `to_world` as the TOML's row-major `matrix` (identity when absent).
fn transform_spec(m: Option<Mat4>) -> TransformSpec {
    m.map(|m| TransformSpec { matrix: Some(m.transpose().to_cols_array_2d()), ..Default::default() })
        .unwrap_or_default()
}

/// Mitsuba's named indices of refraction.
pub fn named_ior(name: &str) -> Option<f32> {
    Some(match name {
        "vacuum" => 1.0,
        "helium" => 1.000036,
        "hydrogen" => 1.000132,
        "air" => 1.000277,
        "carbon dioxide" => 1.00045,
        "water" => 1.333,
        "acetone" => 1.36,
        "ethanol" => 1.361,
        "carbon tetrachloride" => 1.461,
        "glycerol" => 1.4729,
        "benzene" => 1.501,
        "silicone oil" => 1.52045,
        "bromine" => 1.661,
        "water ice" => 1.31,
        "fused quartz" => 1.458,
        "pyrex" => 1.47,
        "acrylic glass" => 1.49,
        "polypropylene" => 1.49,
        "bk7" => 1.5046,
        "sodium chloride" => 1.544,
        "amber" => 1.55,
        "pet" => 1.575,
        "diamond" => 2.419,
        _ => return None,
    })
}

/// Whether a mesh file carries vertex normals (each mesh in it): Mitsuba renders a mirrored mesh inside
/// out unless it does and `face_normals` is off (`placed_shape`). A file that did not load (None) turns
/// nothing.
fn file_has_normals(meshes: Option<&[crate::scene::mesh::LoadedMesh]>) -> bool {
    meshes.is_none_or(|meshes| meshes.iter().all(|m| m.mesh.normals.is_some()))
}
