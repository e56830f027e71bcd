//! Scene file → `Scene`: TOML parsing, `--set` overrides, and every check a user's mistake needs,
//! each error naming the file and the key (TOML syntax and type errors also give the line).
use crate::color::Rgb;
use crate::scene::camera::{FilterSpec, PixelFilter, LANCZOS_LOBES_RANGE};
use crate::scene::env::{EnvImage, EnvLight};
use crate::scene::file::*;
use crate::scene::light::{LightKind, Lights, PointLight, Spot};
use crate::scene::material::{
    conductor_preset, BlendWeight, Fresnel, Mapped, Material, Nested, NormalMap, ParamMaps, Principled, RoughCoat,
    SurfaceMaterial, MIN_ALPHA, PRINCIPLED_WEIGHTS,
};
use crate::scene::mesh::{self, TriMesh};
use crate::scene::texture::{load_image, MeshColors, Patch, Texture, UvMap};
use crate::scene::{Camera, Geometry, Scene, SceneError, Shape};
use glam::{Mat3, Mat4, Vec3};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Largest image we agree to allocate (pixels); beyond it the run is refused up front.
pub const MAX_PIXELS: u64 = 64 * 1024 * 1024;
/// The most memory a request may plan to allocate (photon maps, `knn-check`'s trees): refused above.
pub const MAX_BYTES: u64 = 16 << 30;

pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_with(path, &[])
}

/// Loads a scene and applies `key=value` overrides (TOML values; bare words are strings).
pub fn load_scene_with(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    let t0 = std::time::Instant::now();
    let shown = path.display().to_string();
    let text = if is_mitsuba(path) {
        let converted = crate::scene::mitsuba::convert(path)?;
        for w in &converted.warnings {
            eprintln!("warning: {w}");
        }
        scene_file_toml(&converted.file, &shown)?
    } else {
        crate::scene::read_text(path).map_err(|msg| SceneError::Io { file: shown.clone(), msg })?
    };
    let file = parse_scene_text(&text, &shown, overrides)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut scene = build(file, &shown, &dir)?;
    for w in scene.warnings.iter().cloned().chain(crate::scene::contact::coplanar_contacts(&scene)) {
        eprintln!("warning: {shown}: {w}");
    }
    scene.path = path.to_path_buf();
    scene.load_seconds = t0.elapsed().as_secs_f64();
    Ok(scene)
}

/// True for a Mitsuba XML scene (by its extension).
pub fn is_mitsuba(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// The scene file as TOML text (what `caustica convert` writes, and how XML scenes take `--set`).
pub fn scene_file_toml(file: &SceneFile, shown: &str) -> Result<String, SceneError> {
    let err = |e: String| SceneError::Parse { file: shown.into(), msg: format!("cannot write as TOML: {e}") };
    let mut value = toml::Value::try_from(file).map_err(|e| err(e.to_string()))?;
    shortest_floats(&mut value);
    toml::to_string(&value).map_err(|e| err(e.to_string()))
}

/// Every number was an f32: write the shortest decimal that reads back as the same f32 (0.3, not
/// 0.30000001192092896).
fn shortest_floats(v: &mut toml::Value) {
    match v {
        toml::Value::Float(x) => *x = format!("{}", *x as f32).parse().unwrap_or(*x),
        toml::Value::Array(a) => a.iter_mut().for_each(shortest_floats),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| shortest_floats(v)),
        _ => {}
    }
}

/// Loads a scene from TOML text; relative mesh paths resolve against `dir`; errors name `shown`.
pub fn load_scene_str(text: &str, shown: &str, dir: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    let t0 = std::time::Instant::now();
    let file = parse_scene_text(text, shown, overrides)?;
    let mut scene = build(file, shown, dir)?;
    scene.path = PathBuf::from(shown);
    scene.load_seconds = t0.elapsed().as_secs_f64();
    Ok(scene)
}

/// Parses and type-checks the TOML text, applying overrides; returns the effective settings.
pub fn parse_scene_text(text: &str, shown: &str, overrides: &[String]) -> Result<SceneFile, SceneError> {
    let perr = |msg: String| SceneError::Parse { file: shown.to_string(), msg };
    let mut value: toml::Table = toml::from_str(text).map_err(|e| perr(e.to_string().trim_end().to_string()))?;
    // Type-check against the original text first so errors carry line numbers.
    toml::from_str::<SceneFile>(text).map_err(|e| perr(e.to_string().trim_end().to_string()))?;
    for ov in overrides {
        apply_override(&mut value, ov).map_err(|msg| SceneError::Invalid {
            file: shown.into(),
            key: ov.clone(),
            msg,
        })?;
    }
    check_finite(&toml::Value::Table(value.clone()), "", shown)?;
    let file: SceneFile = toml::Value::Table(value)
        .try_into()
        .map_err(|e: toml::de::Error| perr(format!("after --set overrides: {}", e.to_string().trim_end())))?;
    Ok(file)
}

fn apply_override(root: &mut toml::Table, ov: &str) -> Result<(), String> {
    let (key, val) = ov.split_once('=').ok_or("expected KEY=VALUE, e.g. render.spp=64")?;
    let val: toml::Value = match toml::from_str::<toml::Table>(&format!("v = {val}")) {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(val.into())),
        Err(_) => toml::Value::String(val.trim().to_string()),
    };
    let parts: Vec<&str> = key.trim().split('.').collect();
    let mut cur = root;
    for (i, part) in parts.iter().enumerate() {
        if i + 1 == parts.len() {
            cur.insert(part.to_string(), val);
            return Ok(());
        }
        let entry = cur.entry(part.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = match entry {
            toml::Value::Table(t) => t,
            _ => return Err(format!("`{part}` is not a table")),
        };
    }
    Err("empty key".into())
}

fn check_finite(v: &toml::Value, key: &str, shown: &str) -> Result<(), SceneError> {
    match v {
        toml::Value::Float(f) if !f.is_finite() || f.abs() > f32::MAX as f64 => Err(SceneError::Invalid {
            file: shown.into(),
            key: key.into(),
            msg: format!("number {f} is not finite (or does not fit in f32)"),
        }),
        toml::Value::Table(t) => t.iter().try_for_each(|(k, v)| {
            check_finite(v, &if key.is_empty() { k.clone() } else { format!("{key}.{k}") }, shown)
        }),
        toml::Value::Array(a) => {
            a.iter().enumerate().try_for_each(|(i, v)| check_finite(v, &format!("{key}[{i}]"), shown))
        }
        _ => Ok(()),
    }
}

struct Ctx<'a> {
    shown: &'a str,
}

impl Ctx<'_> {
    fn err(&self, key: &str, msg: impl Into<String>) -> SceneError {
        SceneError::Invalid { file: self.shown.into(), key: key.into(), msg: msg.into() }
    }
    fn colour(&self, key: &str, c: V3, max: Option<f32>) -> Result<Rgb, SceneError> {
        let v = Vec3::from_array(c);
        if v.min_element() < 0.0 {
            return Err(self.err(key, format!("{c:?} has a negative component")));
        }
        if let Some(m) = max {
            if v.max_element() > m {
                return Err(self.err(key, format!("{c:?} exceeds {m} (reflectance must be in [0, 1])")));
            }
        }
        Ok(v)
    }
    fn positive(&self, key: &str, x: f32) -> Result<f32, SceneError> {
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(key, format!("must be > 0, got {x}")))
        }
    }
}

/// A dielectric's `absorption` (σ per unit length, per channel): finite and ≥ 0. A σ so large that
/// e^(−σ·d) is 0 over any distance the scene's floats tell apart is allowed (glass as dark as ink).
fn absorption_of(cx: &Ctx, key: &str, a: V3) -> Result<Rgb, SceneError> {
    if a.iter().any(|x| !x.is_finite()) {
        return Err(cx.err(key, format!("{a:?} is not finite (an absorption coefficient per unit length, ≥ 0)")));
    }
    cx.colour(key, a, None)
}

/// `base` with the media inside and outside it that a dielectric's or a null material's keys give
/// (`absorption`, `albedo`, `phase_g`, `phase` and their `outside_` kin).
fn with_media(
    cx: &Ctx,
    key: &str,
    [inside, outside]: [MediumKeys; 2],
    base: SurfaceMaterial,
) -> Result<SurfaceMaterial, SceneError> {
    let sigma = |name: &str, a: &Option<V3>| match a {
        Some(a) => absorption_of(cx, &format!("{key}.{name}"), *a),
        None => Ok(Rgb::ZERO),
    };
    let sigma_in = sigma("absorption", &inside.absorption)?;
    let sigma_out = sigma("outside_absorption", &outside.absorption)?;
    Ok(SurfaceMaterial {
        absorption: sigma_in,
        absorption_outside: sigma_out,
        scattering: scattering_of(cx, key, "", sigma_in, &inside)?,
        scattering_outside: scattering_of(cx, key, "outside_", sigma_out, &outside)?,
        ..base
    })
}

/// A medium's scattering from its keys (`albedo`, `phase_g`, `phase`, each named with `prefix` under
/// `key`, beside the absorption's): an albedo in [0, 1] of a medium whose absorption, its extinction
/// σ_t, is not zero; a g strictly between −1 and 1, or the lobes of `phase` (`phase_of`), only beside
/// an albedo.
fn scattering_of(
    cx: &Ctx,
    key: &str,
    prefix: &str,
    sigma_t: Rgb,
    m: &MediumKeys,
) -> Result<crate::scene::Scattering, SceneError> {
    let [sigma_key, albedo_key, g_key, phase_key] =
        ["absorption", "albedo", "phase_g", "phase"].map(|k| format!("{prefix}{k}"));
    let g = m.phase_g;
    let Some(a) = &m.albedo else {
        if g != 0.0 || m.phase.is_some() {
            let (k, what) = if g != 0.0 { (&g_key, g.to_string()) } else { (&phase_key, "a phase".into()) };
            return Err(cx.err(
                &format!("{key}.{k}"),
                format!("{what} without `{albedo_key}`: a medium that only absorbs has no phase function"),
            ));
        }
        return Ok(Default::default());
    };
    let albedo_key = format!("{key}.{albedo_key}");
    if a.iter().any(|x| !(0.0..=1.0).contains(x)) {
        return Err(cx.err(
            &albedo_key,
            format!("{a:?}: each channel must lie in [0, 1] (the share of `{sigma_key}` that scatters)"),
        ));
    }
    if sigma_t == Rgb::ZERO && *a != [0.0; 3] {
        return Err(cx.err(&albedo_key, format!("{a:?} without `{sigma_key}`: the medium's extinction σ_t, of which the albedo scatters a share, is needed")));
    }
    if !(g > -1.0 && g < 1.0) {
        return Err(cx.err(&format!("{key}.{g_key}"), format!("{g} must lie strictly between -1 and 1")));
    }
    let phase = match &m.phase {
        None => crate::scene::medium::Phase::hg(g),
        Some(_) if g != 0.0 => {
            return Err(cx.err(&format!("{key}.{phase_key}"), format!("give `{g_key}` or `{phase_key}`, not both")))
        }
        Some(lobes) => phase_of(cx, &format!("{key}.{phase_key}"), lobes)?,
    };
    Ok(crate::scene::Scattering { sigma_s: sigma_t * Rgb::from(*a), phase })
}

/// A phase function from one lobe (its `weight`, if given, 1) or two (their weights, each in [0, 1],
/// summing to 1); a Henyey–Greenstein lobe needs its g, strictly between −1 and 1, and no other has one;
/// a table its `values` (`medium::Table::new`), and no other has them.
fn phase_of(cx: &Ctx, key: &str, lobes: &[LobeSpec]) -> Result<crate::scene::medium::Phase, SceneError> {
    use crate::scene::medium::{Lobe, Phase};
    let lobe = |i: usize, l: &LobeSpec| -> Result<Lobe, SceneError> {
        let k = format!("{key}[{i}]");
        if l.values.is_some() != (l.kind == LobeKind::Table) {
            return Err(match l.kind {
                LobeKind::Table => cx.err(&k, "a `table` lobe needs its `values`"),
                _ => cx.err(&format!("{k}.values"), "only a `table` lobe has `values`"),
            });
        }
        match (l.kind, l.g) {
            (LobeKind::Table, None) => {
                let values = l.values.as_deref().unwrap_or_default();
                crate::scene::medium::Table::interned(values)
                    .map(Lobe::Table)
                    .map_err(|e| cx.err(&format!("{k}.values"), e))
            }
            (LobeKind::Hg, Some(g)) if g > -1.0 && g < 1.0 => Ok(Lobe::Hg(g)),
            (LobeKind::Hg, Some(g)) => {
                Err(cx.err(&format!("{k}.g"), format!("{g} must lie strictly between -1 and 1")))
            }
            (LobeKind::Hg, None) => Err(cx.err(&k, "a `hg` lobe needs its asymmetry `g`")),
            (_, Some(_)) => Err(cx.err(&format!("{k}.g"), "only a `hg` lobe has an asymmetry `g`")),
            (LobeKind::Isotropic, None) => Ok(Lobe::Hg(0.0)),
            (LobeKind::Rayleigh, None) => Ok(Lobe::Rayleigh),
        }
    };
    let weight = |i: usize, l: &LobeSpec, default: Option<f32>| -> Result<f32, SceneError> {
        match l.weight.or(default) {
            Some(w) if (0.0..=1.0).contains(&w) => Ok(w),
            Some(w) => Err(cx.err(&format!("{key}[{i}].weight"), format!("{w} must lie in [0, 1]"))),
            None => Err(cx.err(&format!("{key}[{i}].weight"), "each of two blended lobes needs its `weight`")),
        }
    };
    match lobes {
        [one] => {
            if weight(0, one, Some(1.0))? != 1.0 {
                return Err(cx.err(&format!("{key}[0].weight"), "a lone lobe's weight is 1"));
            }
            Ok(Phase { first: lobe(0, one)?, ..Default::default() })
        }
        [a, b] => {
            let (wa, wb) = (weight(0, a, None)?, weight(1, b, None)?);
            if (wa + wb - 1.0).abs() > 1e-4 {
                return Err(cx.err(key, format!("the lobes' weights {wa} and {wb} must sum to 1")));
            }
            Ok(Phase { first: lobe(0, a)?, second: lobe(1, b)?, weight: wb })
        }
        _ => Err(cx.err(key, format!("{} lobes: give one, or two to blend", lobes.len()))),
    }
}

fn build(file: SceneFile, shown: &str, dir: &Path) -> Result<Scene, SceneError> {
    let cx = Ctx { shown };
    let camera = build_camera(&cx, &file.camera)?;
    check_render(&cx, &file.render)?;

    let mut textures = Textures { list: Vec::new(), index: HashMap::new(), files: HashMap::new() };
    let mut built = HashMap::new();
    let mut order = Vec::new();
    for name in file.textures.keys() {
        order.push((name, resolve_texture(&cx, &file.textures, name, dir, &mut built, &mut Vec::new())?));
    }
    drop(built);
    for (name, t) in order {
        // Moved out, unless a checkerboard shows it too (then copied: such an image is kept twice).
        textures.index.insert(name.clone(), textures.list.len() as u32);
        textures.list.push(Arc::try_unwrap(t).unwrap_or_else(|shared| (*shared).clone()));
    }
    let mut materials = Vec::new();
    let mut names = Vec::new();
    // Numbered first: a blend names the materials it mixes.
    let index: HashMap<String, u32> = file.materials.keys().enumerate().map(|(i, n)| (n.clone(), i as u32)).collect();
    for (name, spec) in &file.materials {
        materials.push(build_material(&cx, &format!("materials.{name}"), spec, &textures, &index)?);
        names.push(name.clone());
    }
    apply_normal_maps(&cx, &file, &index, &textures, &mut materials)?;
    refuse_blend_cycles(&cx, &materials, &names)?;
    check_sides(&cx, &materials, &names)?;
    let mut shapes = Vec::new();
    let mut out = Built { materials: &mut materials, names: &mut names, shapes: &mut shapes, textures: &mut textures };
    for (i, spec) in file.shapes.iter().enumerate() {
        build_shape(&cx, &format!("shapes[{i}]"), spec, dir, &index, &mut out)?;
    }
    let black = materials.len() as u32;
    materials.push(SurfaceMaterial::new(Material::Diffuse { reflectance: Rgb::ZERO }));
    names.push("(light)".into());
    let mut points = Vec::new();
    let mut distant = Vec::new();
    let mut env = None;
    // The keys of the lights in the order `Lights::build` lists them: environment, distant, point.
    let (mut env_key, mut distant_keys, mut point_keys) = (None, Vec::new(), Vec::new());
    for (i, spec) in file.lights.iter().enumerate() {
        let key = format!("lights[{i}]");
        match spec {
            LightSpec::Constant { .. } | LightSpec::Envmap { .. } => {
                if env.is_some() {
                    return Err(cx.err(&key, "a second environment light (a scene has at most one)"));
                }
                env = Some(build_env(&cx, &key, spec, dir)?);
                env_key = Some(key);
            }
            LightSpec::Distant { direction, irradiance } => {
                let d = Vec3::from_array(*direction);
                if d.length() == 0.0 {
                    return Err(cx.err(&format!("{key}.direction"), "is the zero vector"));
                }
                distant.push((d, cx.colour(&format!("{key}.irradiance"), *irradiance, None)?));
                distant_keys.push(key);
            }
            LightSpec::Point { .. } | LightSpec::Spot { .. } | LightSpec::Projector { .. } => {
                build_light(&cx, &key, spec, black, &textures, &mut shapes, &mut points)?;
                point_keys.push(key);
            }
            _ => build_light(&cx, &key, spec, black, &textures, &mut shapes, &mut points)?,
        }
    }
    let bounds = scene_bounds(&shapes, &points);
    let mut scene = Scene {
        path: PathBuf::new(),
        camera,
        materials,
        material_names: names,
        textures: textures.list,
        shapes,
        lights: Lights::default(),
        render: file.render,
        bounds,
        load_seconds: 0.0,
        see_through: Vec::new(),
        absorption: Vec::new(),
        boundary: Vec::new(),
        point_media: Vec::new(),
        scattering: Vec::new(),
        see_through_media: false,
        warnings: Vec::new(),
    };
    scene.see_through = scene.see_through_shapes();
    scene.absorption = scene.absorbing_shapes();
    scene.boundary = scene.absorption.iter().map(|sides| *sides != [Rgb::ZERO; 2]).collect();
    scene.scattering = scene.scattering_shapes();
    scene.see_through_media =
        (0..scene.shapes.len()).any(|i| scene.is_see_through(i as u32) && scene.boundary.get(i) == Some(&true));
    // An emitter is never see-through (its light is met where a path crosses it), so a null surface
    // round a medium may not emit: paths and shadow rays would stop at it.
    for (i, shape) in scene.shapes.iter().enumerate() {
        let m = &scene.materials[shape.material as usize];
        // (Named by the shape's name, its place in the file.)
        if shape.emission != Rgb::ZERO && scene.boundary.get(i) == Some(&true) && m.bsdf.is_thin() {
            let msg = "emits, and its material is a null surface round a medium, which caustica does not \
                       render (give the light a shape of its own)";
            return Err(cx.err(&shape.name, msg));
        }
    }
    // A shape that bounds no medium lies in the one round it, on both of its sides (`immersed`).
    let lamps: Vec<Vec3> = points.iter().map(|p| p.position).collect();
    let (round, point_media, warnings) = crate::scene::immersed::surrounding_media(&scene, &lamps);
    for (sides, sigma) in scene.absorption.iter_mut().zip(round) {
        if sigma != Rgb::ZERO {
            *sides = [sigma; 2];
        }
    }
    scene.point_media = point_media;
    scene.warnings = warnings;
    // B-spline curves are open at their ends and cull their backs, as Mitsuba's are: light that passes
    // into an end and out through the wall cannot pass back the other way.
    for (i, spec) in file.shapes.iter().enumerate() {
        if let ShapeSpec::Curves { basis: CurveBasis::Bspline, .. } = spec {
            scene.warnings.push(format!(
                "shapes[{i}] (B-spline curves) is open at its curves' ends and culls its inside, as Mitsuba's: \
                 light that passes into an end and out through the wall cannot pass back the other way, which \
                 paths from the lights and from the camera do not see alike, so near the open ends the photon \
                 and bidirectional modes may differ from the path tracer (which renders what Mitsuba's does)"
            ));
        }
    }
    scene.lights = Lights::build(&scene, &points, &distant, env);
    let keys: Vec<String> = env_key.into_iter().chain(distant_keys).chain(point_keys).collect();
    let env_file = file.lights.iter().find_map(|l| match l {
        LightSpec::Envmap { file, .. } => Some(file.as_str()),
        _ => None,
    });
    check_power(&cx, &scene, &keys, &file.shapes, env_file)?;
    if scene.lights.is_empty() {
        return Err(
            cx.err("lights", "the scene has no light with positive power (add [[lights]] or an emissive shape)")
        );
    }
    Ok(scene)
}

fn build_camera(cx: &Ctx, c: &CameraSpec) -> Result<Camera, SceneError> {
    let (o, t, up) = (Vec3::from_array(c.origin), Vec3::from_array(c.target), Vec3::from_array(c.up));
    if (t - o).length() == 0.0 {
        return Err(cx.err("camera.target", "equals camera.origin"));
    }
    if up.length() == 0.0 || (t - o).normalize().cross(up.normalize()).length() < 1e-6 {
        return Err(cx.err("camera.up", "is zero or parallel to the view direction"));
    }
    let [w, h] = c.resolution;
    if w == 0 || h == 0 {
        return Err(cx.err("camera.resolution", "width and height must be ≥ 1"));
    }
    let ortho = c.projection == Projection::Orthographic;
    if ortho {
        if c.film_size.is_some() {
            for (key, given) in [("camera.fov", c.fov.is_some()), ("camera.fov_axis", c.fov_axis.is_some())] {
                if given {
                    let msg = "an orthographic camera takes `film_size` or `fov` (the film that field of view spans \
                               at the target), not both";
                    return Err(cx.err(key, msg));
                }
            }
        }
        if c.aperture_radius != 0.0 || c.focus_distance.is_some() {
            let key = if c.aperture_radius != 0.0 { "camera.aperture_radius" } else { "camera.focus_distance" };
            return Err(cx.err(key, "an orthographic camera has no lens (depth of field needs a perspective camera)"));
        }
    } else if c.film_size.is_some() {
        return Err(cx.err(
            "camera.film_size",
            "is read only with projection = \"orthographic\" (a perspective camera has fov)",
        ));
    }
    let fov = c.fov.unwrap_or(DEFAULT_FOV);
    if !(fov > 0.0 && fov < 180.0) {
        return Err(cx.err("camera.fov", format!("must be in (0, 180) degrees, got {fov}")));
    }
    // The film holds the crop window's pixels only.
    let [fw, fh] = c.crop.map_or([w, h], |[_, _, cw, ch]| [cw, ch]);
    let px = fw as u64 * fh as u64;
    if px > MAX_PIXELS {
        return Err(cx.err(
            "camera.resolution",
            format!("{fw}×{fh} needs about {} MiB of film; the limit is {MAX_PIXELS} pixels", px * 40 / (1 << 20)),
        ));
    }
    let mut camera = if ortho {
        // `film_size`; else the film a perspective camera's field of view spans at the target, when one
        // is given (a perspective scene made orthographic keeps its framing there); else Mitsuba's
        // default film, 2 wide with square pixels.
        let size = match (c.film_size, c.fov) {
            (Some(size), _) => size,
            (None, Some(_)) => {
                let pinhole = Camera::new(o, t, up, fov, c.fov_axis.unwrap_or(FovAxis::X), c.resolution);
                pinhole.tan_half.map(|th| 2.0 * (t - o).length() * th)
            }
            (None, None) => [2.0, 2.0 * h as f32 / w as f32],
        };
        let bad = |why: &str| cx.err("camera.film_size", format!("{why}, got {size:?}"));
        if !size.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(bad("must be a width and a height > 0 in scene units"));
        }
        let camera = Camera::orthographic(o, t, up, size, c.resolution);
        // Film points and a pixel's area (the density of a ray's origin) must be f32 numbers.
        let corner = camera.ray(0.0, 0.0).o;
        if !camera.pixel_pdf_dir(camera.forward).is_normal() || !corner.is_finite() {
            return Err(bad("puts a pixel's area or the film's corners beyond f32's range"));
        }
        camera
    } else {
        Camera::new(o, t, up, fov, c.fov_axis.unwrap_or(FovAxis::X), c.resolution)
    };
    if c.mirror {
        // The film's x axis turned round: rays, projections (light tracing's splats), the lens's disc,
        // the shift and the crop all go through `right`, so they all follow.
        camera.right = -camera.right;
    }
    // Each parameter's bounds: a reach a film sample can afford, and for the filters with negative lobes
    // a clearly positive integral however the film cuts them (`PixelFilter`'s weights stay bounded).
    let bounded: &[(&str, f32, std::ops::RangeInclusive<f32>, &str)] = match c.filter {
        FilterSpec::Box | FilterSpec::CatmullRom => &[],
        FilterSpec::Tent { radius } => &[("camera.filter.radius", radius, 0.5..=4.0, " pixels")],
        FilterSpec::Gaussian { stddev } => &[("camera.filter.stddev", stddev, 0.1..=1.0, " pixels")],
        FilterSpec::Mitchell { b, c } => {
            &[("camera.filter.b", b, 0.0..=1.0, ""), ("camera.filter.c", c, 0.0..=1.0, "")]
        }
        FilterSpec::Lanczos { lobes } => {
            let (lo, hi) = (*LANCZOS_LOBES_RANGE.start() as f32, *LANCZOS_LOBES_RANGE.end() as f32);
            &[("camera.filter.lobes", lobes as f32, lo..=hi, "")]
        }
    };
    if let Some((key, value, range, unit)) = bounded.iter().find(|(_, v, range, _)| !range.contains(v)) {
        let (lo, hi) = (range.start(), range.end());
        return Err(cx.err(key, format!("must be in [{lo}, {hi}]{unit}, got {value}")));
    }
    if let Some(shift) = c.principal_point_offset {
        if !shift.iter().all(|v| v.is_finite() && v.abs() <= 1e3) {
            return Err(cx.err(
                "camera.principal_point_offset",
                format!("must be two numbers within ±1000 film widths and heights, got {shift:?}"),
            ));
        }
        camera = camera.shift(shift);
    }
    if let Some([x, y, cw, ch]) = c.crop {
        if !Camera::window_fits([x, y, cw, ch], [w, h]) {
            return Err(cx.err(
                "camera.crop",
                format!(
                    "[x, y, width, height] = [{x}, {y}, {cw}, {ch}] must be a window of at least one pixel \
                     inside the {w}×{h} film (x + width ≤ {w}, y + height ≤ {h})"
                ),
            ));
        }
        camera = camera.crop([x, y], [cw, ch]);
    }
    camera.filter = PixelFilter::new(c.filter);
    if !(c.aperture_radius.is_finite() && c.aperture_radius >= 0.0) {
        return Err(cx.err(
            "camera.aperture_radius",
            format!("must be a finite radius ≥ 0 (0: a pinhole), got {}", c.aperture_radius),
        ));
    }
    camera.lens_radius = c.aperture_radius;
    if let Some(f) = c.focus_distance {
        if !(f.is_finite() && f > 0.0) {
            return Err(cx.err("camera.focus_distance", format!("must be a finite distance > 0, got {f}")));
        }
        camera.focus_distance = f;
    }
    let near = c.near_clip.unwrap_or(0.0);
    if !(near.is_finite() && near >= 0.0) {
        return Err(cx.err("camera.near_clip", format!("must be a finite depth ≥ 0, got {near}")));
    }
    let far = c.far_clip.unwrap_or(f32::INFINITY);
    if far.is_nan() || far <= near {
        return Err(cx.err("camera.far_clip", format!("must be a depth beyond near_clip ({near}), got {far}")));
    }
    camera.clip = [near, far];
    if let Some(m) = &c.medium {
        let sigma_t = absorption_of(cx, "camera.medium.absorption", m.absorption)?;
        let keys =
            MediumKeys { absorption: Some(m.absorption), albedo: m.albedo, phase_g: m.phase_g, phase: m.phase.clone() };
        let scattering = scattering_of(cx, "camera.medium", "", sigma_t, &keys)?;
        camera.medium = crate::scene::medium::Medium { sigma_t, scattering };
    }
    // Rays leave the lens's rim and aim at the corners of the plane of focus: both must be f32 points.
    let rim = camera.origin + camera.lens_radius * (camera.right + camera.up);
    if !rim.is_finite() {
        return Err(
            cx.err("camera.aperture_radius", format!("{:e} puts the lens beyond f32's range", c.aperture_radius))
        );
    }
    let reach = [0, 1].map(|i| camera.tan_half[i] + camera.centre[i].abs());
    let corner = camera.forward + reach[0] * camera.right + reach[1] * camera.up;
    if camera.lens_radius > 0.0 && !(camera.origin + corner * camera.focus_distance).is_finite() {
        let f = camera.focus_distance;
        return Err(cx.err("camera.focus_distance", format!("{f:e} puts the plane of focus beyond f32's range")));
    }
    Ok(camera)
}

fn check_render(cx: &Ctx, r: &RenderSettings) -> Result<(), SceneError> {
    if r.spp == 0 {
        return Err(cx.err("render.spp", "must be ≥ 1"));
    }
    let pr = &r.progressive;
    if pr.passes == 0 {
        return Err(cx.err("render.progressive.passes", "must be ≥ 1"));
    }
    if pr.first_pass == 0 || pr.first_pass.checked_add(pr.passes).is_none() {
        return Err(cx.err("render.progressive.first_pass", "must be ≥ 1, and first_pass + passes must fit in 32 bits"));
    }
    if pr.first_pass != 1 && r.mode == crate::scene::file::Mode::Sppm {
        return Err(cx.err(
            "render.progressive.first_pass",
            "sppm iterations build on each other and must start at 1 (ppm passes are independent)",
        ));
    }
    if r.mode == crate::scene::file::Mode::Vcm && !r.vcm.connect && !r.vcm.merge {
        return Err(cx.err("render.vcm", "connect and merge are both false: vcm would render nothing"));
    }
    if !(pr.time_s.is_finite() && pr.time_s >= 0.0) {
        return Err(cx.err("render.progressive.time_s", "must be ≥ 0 seconds (0 = no time limit)"));
    }
    if !(r.vcm.aim >= 0.0 && r.vcm.aim < 1.0) {
        return Err(cx.err(
            "render.vcm.aim",
            "must be in [0, 1): the share of light subpaths that head for specular shapes (0 = never aimed)",
        ));
    }
    if r.vcm.light_paths > 100_000_000 {
        return Err(cx.err("render.vcm.light_paths", "must be at most 100000000 (0 = one per pixel)"));
    }
    if pr.photons_per_pass == 0 || pr.photons_per_pass > 100_000_000 {
        return Err(cx.err("render.progressive.photons_per_pass", "must be in [1, 100000000]"));
    }
    if !(pr.alpha > 0.0 && pr.alpha < 1.0) {
        return Err(cx.err("render.progressive.alpha", "must be in (0, 1); 2/3 is the usual choice"));
    }
    if !(pr.radius.is_finite() && pr.radius >= 0.0) {
        return Err(cx.err("render.progressive.radius", "must be ≥ 0 (0 = chosen from the scene)"));
    }
    if r.pm_spp == 0 {
        return Err(cx.err("render.pm_spp", "must be ≥ 1"));
    }
    // (key, value, the most it accepts, whether it counts the photons a gather reads: 0 would read
    // nothing and leave the map's light out of the image unsaid).
    for (key, v, max, gather) in [
        ("render.final_gather", r.final_gather, 4096, false),
        ("render.specular_spp", r.specular_spp, 4096, false),
        ("render.gather.direct", r.gather.direct, 100_000, true),
        ("render.gather.indirect", r.gather.indirect, 100_000, true),
        ("render.gather.caustic", r.gather.caustic, 100_000, true),
    ] {
        if v > max {
            return Err(cx.err(key, format!("{v} is more than the {max} this setting accepts")));
        }
        if gather && v == 0 {
            return Err(cx.err(
                key,
                "must be ≥ 1: the photons each estimate gathers (0 would leave the map's light out of the image)",
            ));
        }
    }
    if !(r.gather.cone_k.is_finite() && r.gather.cone_k >= 0.0) {
        return Err(cx.err("render.gather.cone_k", "must be ≥ 0 (values below 1 disable the cone filter)"));
    }
    if !r.exposure.is_finite() || r.exposure.abs() > 64.0 {
        return Err(cx.err("render.exposure", "must be within ±64 stops"));
    }
    // 20 bytes per stored photon plus about as much again while tracing and building.
    let total = r.photons.direct.checked_add(r.photons.indirect).and_then(|t| t.checked_add(r.photons.caustic));
    match total.and_then(|t| t.checked_mul(48)) {
        Some(bytes) if bytes <= MAX_BYTES => {}
        Some(bytes) => {
            let total = total.unwrap_or(u64::MAX);
            let msg = format!("{total} photons need about {} GiB; the limit is {} GiB", bytes >> 30, MAX_BYTES >> 30);
            return Err(cx.err("render.photons", msg));
        }
        None => {
            let msg = format!("the photon counts add up to more than {} GiB can hold", MAX_BYTES >> 30);
            return Err(cx.err("render.photons", msg));
        }
    }
    if r.photons.max_shots_factor == 0 {
        return Err(cx.err("render.photons.max_shots_factor", "must be ≥ 1"));
    }
    if r.gather.max_radius.is_nan() || r.gather.max_radius <= 0.0 {
        return Err(cx.err("render.gather.max_radius", "must be > 0"));
    }
    Ok(())
}

/// Textures built so far: by name (`[textures]`) and by image file (MTL `map_Kd`, loaded once each).
struct Textures {
    list: Vec<Texture>,
    index: HashMap<String, u32>,
    files: HashMap<PathBuf, u32>,
}

/// What building the shapes adds to: materials (MTL colours and textures), their names, the shapes.
struct Built<'a> {
    materials: &'a mut Vec<SurfaceMaterial>,
    names: &'a mut Vec<String>,
    shapes: &'a mut Vec<Shape>,
    textures: &'a mut Textures,
}

fn uv_map(
    cx: &Ctx,
    key: &str,
    scale: [f32; 2],
    offset: [f32; 2],
    matrix: Option<[[f32; 3]; 2]>,
) -> Result<UvMap, SceneError> {
    match matrix {
        Some(_) if scale != [1.0, 1.0] || offset != [0.0, 0.0] => {
            Err(cx.err(&format!("{key}.matrix"), "give either `matrix` or scale/offset, not both"))
        }
        Some([[a, b, c], [d, e, f]]) => Ok(UvMap([a, b, c, d, e, f])),
        None => Ok(UvMap::scale_offset(scale, offset)),
    }
}

/// Deepest nesting of textures in checkerboards accepted (a real scene nests one or two).
pub const MAX_TEXTURE_DEPTH: usize = 16;

/// The `[textures]` entry `name`, built once (`built`) with the textures its checkerboard squares name
/// (`chain`: the entries being built that lead to it, for a clear refusal of one that contains itself).
fn resolve_texture<'s>(
    cx: &Ctx,
    specs: &'s BTreeMap<String, TextureSpec>,
    name: &'s str,
    dir: &Path,
    built: &mut HashMap<&'s str, Arc<Texture>>,
    chain: &mut Vec<&'s str>,
) -> Result<Arc<Texture>, SceneError> {
    if let Some(t) = built.get(name) {
        return Ok(t.clone());
    }
    let key = format!("textures.{name}");
    chain.push(name);
    let t = match &specs[name] {
        TextureSpec::Checkerboard { color0, color1, scale, offset, matrix } => Texture::Checkerboard {
            color0: patch(cx, specs, &format!("{key}.color0"), color0, dir, built, chain)?,
            color1: patch(cx, specs, &format!("{key}.color1"), color1, dir, built, chain)?,
            to_uv: uv_map(cx, &key, *scale, *offset, *matrix)?,
        },
        TextureSpec::Bitmap { file, raw, bilinear, wrap, scale, offset, matrix } => {
            let path = dir.join(file);
            let (width, height, texels) = load_image(&path, *raw)
                .map_err(|e| cx.err(&format!("{key}.file"), format!("{}: {e}", path.display())))?;
            let to_uv = uv_map(cx, &key, *scale, *offset, *matrix)?;
            Texture::Bitmap { file: file.clone(), width, height, texels, to_uv, bilinear: *bilinear, wrap: *wrap }
        }
        spec @ (TextureSpec::VertexColor { scale } | TextureSpec::FaceColor { scale }) => {
            if !(scale.is_finite() && *scale >= 0.0) {
                return Err(cx.err(&format!("{key}.scale"), format!("must be a finite number ≥ 0, got {scale}")));
            }
            let of = if let TextureSpec::FaceColor { .. } = spec { MeshColors::Face } else { MeshColors::Vertex };
            Texture::MeshColor { of, scale: *scale }
        }
    };
    chain.pop();
    let t = Arc::new(t);
    built.insert(name, t.clone());
    Ok(t)
}

/// A checkerboard's squares (field `key`): a colour, or the texture an entry of `specs` is.
fn patch<'s>(
    cx: &Ctx,
    specs: &'s BTreeMap<String, TextureSpec>,
    key: &str,
    value: &'s Reflectance,
    dir: &Path,
    built: &mut HashMap<&'s str, Arc<Texture>>,
    chain: &mut Vec<&'s str>,
) -> Result<Patch, SceneError> {
    let name = match value {
        Reflectance::Colour(c) => return Ok(Patch::Colour(cx.colour(key, *c, None)?)),
        Reflectance::Texture(name) => name,
    };
    let Some((name, _)) = specs.get_key_value(name.as_str()) else {
        let known: Vec<&String> = specs.keys().collect();
        return Err(cx.err(key, format!("unknown texture `{name}` (defined: {known:?})")));
    };
    if let Some(from) = chain.iter().position(|c| *c == name.as_str()) {
        let cycle: Vec<&str> = chain[from..].iter().copied().chain([name.as_str()]).collect();
        return Err(cx.err(key, format!("texture `{name}` contains itself ({})", cycle.join(" → "))));
    }
    if chain.len() >= MAX_TEXTURE_DEPTH {
        return Err(cx.err(key, format!("textures nested deeper than {MAX_TEXTURE_DEPTH} ({})", chain.join(" → "))));
    }
    let t = resolve_texture(cx, specs, name, dir, built, chain)?;
    if let Texture::MeshColor { of, .. } = *t {
        let msg = format!("`{name}` is a {} texture, which a checkerboard's squares cannot show", of.name());
        return Err(cx.err(key, msg));
    }
    Ok(Patch::Texture(t))
}

/// Deepest nesting of blends accepted (real scenes nest one or two; this bounds every walk down them).
pub const MAX_BLEND_DEPTH: usize = 64;

/// A blend that contains itself (directly or through other blends) would pick forever, and one nested
/// deeper than `MAX_BLEND_DEPTH` is no real scene: both refused, naming the chain.
fn refuse_blend_cycles(cx: &Ctx, materials: &[SurfaceMaterial], names: &[String]) -> Result<(), SceneError> {
    // 0: not seen, 1: on the current chain, 2: done. Returns the offending chain.
    fn visit(m: usize, materials: &[SurfaceMaterial], state: &mut [u8], chain: &mut Vec<usize>) -> Option<Vec<usize>> {
        if state[m] == 2 {
            return None;
        }
        if state[m] == 1 || chain.len() >= MAX_BLEND_DEPTH {
            let from = chain.iter().position(|&c| c == m).unwrap_or(0);
            let mut bad = chain[from..].to_vec();
            bad.push(m);
            return Some(bad);
        }
        state[m] = 1;
        chain.push(m);
        if let Some(b) = materials[m].blend {
            for next in [b.first, b.second] {
                if let Some(bad) = visit(next as usize, materials, state, chain) {
                    return Some(bad);
                }
            }
        }
        chain.pop();
        state[m] = 2;
        None
    }
    let mut state = vec![0u8; materials.len()];
    for m in 0..materials.len() {
        if let Some(bad) = visit(m, materials, &mut state, &mut Vec::new()) {
            let path: Vec<&str> = bad.iter().map(|&i| names[i].as_str()).collect();
            let msg = if bad.first() == bad.last() && bad.len() > 1 {
                format!("a blend that contains itself ({})", path.join(" → "))
            } else {
                format!("blends nested deeper than {MAX_BLEND_DEPTH} ({} → …)", path[..3.min(path.len())].join(" → "))
            };
            return Err(cx.err(&format!("materials.{}", names[bad[0]]), msg));
        }
    }
    Ok(())
}

fn build_material(
    cx: &Ctx,
    key: &str,
    spec: &MaterialSpec,
    textures: &Textures,
    index: &HashMap<String, u32>,
) -> Result<SurfaceMaterial, SceneError> {
    // Another material, by name.
    let named = |field: &str, name: &str| material_named(cx, &format!("{key}.{field}"), name, index);
    // A number field that must lie in [0, 1] (a roughness, a weight).
    let unit = |field: &str, x: f32| -> Result<f32, SceneError> {
        if (0.0..=1.0).contains(&x) {
            Ok(x)
        } else {
            Err(cx.err(&format!("{key}.{field}"), format!("must be in [0, 1], got {x}")))
        }
    };
    let rough = |r: f32| unit("roughness", r);
    // A colour field as its colour, or as its texture (the material's own colour then the texture's
    // largest value, which bounds what the surface reflects).
    let colour = |field: &str, r: &Reflectance| -> Result<(Rgb, Option<u32>), SceneError> {
        let key = format!("{key}.{field}");
        match r {
            Reflectance::Colour(c) => Ok((cx.colour(&key, *c, Some(1.0))?, None)),
            Reflectance::Texture(name) => {
                let t = texture_index(cx, &key, name, textures, &format!("a {field}"))?;
                Ok((Rgb::splat(textures.list[t as usize].max_value()), Some(t)))
            }
        }
    };
    // A diffuse reflectance or a base colour, or its texture (which replaces it at every hit: the
    // material's own is 0).
    let reflectance = |field: &str, r: &Reflectance| -> Result<(Rgb, Option<u32>), SceneError> {
        Ok(match colour(field, r)? {
            (_, Some(t)) => (Rgb::ZERO, Some(t)),
            plain => plain,
        })
    };
    // A roughness, or its texture (then rough everywhere: at least MIN_ALPHA, as Mitsuba keeps α).
    let roughness = |w: &Weight| -> Result<(f32, Option<u32>), SceneError> {
        match w {
            Weight::Value(r) => Ok((rough(*r)?, None)),
            Weight::Texture(name) => {
                let t = texture_index(cx, &format!("{key}.roughness"), name, textures, "a roughness")?;
                Ok((textures.list[t as usize].max_value().max(MIN_ALPHA), Some(t)))
            }
        }
    };
    // The roughness across the tangent and its texture: `roughness`'s again unless `roughness_v` is given
    // (anisotropic: a number > 0 or a texture, with `roughness` not 0).
    let across = |alpha: f32, map: Option<u32>, v: &Option<Weight>| -> Result<(f32, Option<u32>), SceneError> {
        let Some(v) = v else {
            return Ok((alpha, map));
        };
        let vkey = format!("{key}.roughness_v");
        let (v, v_map) = match v {
            Weight::Value(v) => (unit("roughness_v", *v)?, None),
            Weight::Texture(name) => {
                let t = texture_index(cx, &vkey, name, textures, "a roughness")?;
                (textures.list[t as usize].max_value().max(MIN_ALPHA), Some(t))
            }
        };
        if alpha == 0.0 || v == 0.0 {
            let msg =
                format!("an anisotropic roughness needs both `roughness` and `roughness_v` > 0 (got {alpha} and {v})");
            return Err(cx.err(&vkey, msg));
        }
        Ok((v, v_map))
    };
    let sided = |bsdf: Material, two_sided: bool, maps: ParamMaps| SurfaceMaterial {
        two_sided,
        maps,
        ..SurfaceMaterial::new(bsdf)
    };
    Ok(match spec {
        MaterialSpec::Diffuse { reflectance: r, two_sided } => {
            let (reflectance, texture) = reflectance("reflectance", r)?;
            SurfaceMaterial {
                two_sided: *two_sided,
                texture,
                ..SurfaceMaterial::new(Material::Diffuse { reflectance })
            }
        }
        MaterialSpec::Plastic {
            reflectance: r,
            specular,
            ior,
            outside_ior,
            nonlinear,
            roughness,
            distribution,
            two_sided,
        } => {
            let ior = relative_ior(cx, key, *ior, *outside_ior)?;
            let (diffuse, texture) = reflectance("reflectance", r)?;
            let (specular, specular_map) = colour("specular", specular)?;
            let alpha = rough(*roughness)?;
            let rough = (alpha > 0.0).then(|| RoughCoat::get(alpha, *distribution, ior));
            let bsdf = Material::Plastic { diffuse, specular, ior, nonlinear: *nonlinear, rough };
            let maps = ParamMaps { specular: specular_map, ..Default::default() };
            SurfaceMaterial { two_sided: *two_sided, texture, maps, ..SurfaceMaterial::new(bsdf) }
        }
        MaterialSpec::Mirror { specular, roughness: r, roughness_v, distribution, two_sided } => {
            let (c, specular) = colour("specular", specular)?;
            let (alpha, alpha_map) = roughness(r)?;
            let (alpha_v, alpha_v_map) = across(alpha, alpha_map, roughness_v)?;
            let fresnel = Fresnel::Constant(c);
            let bsdf =
                Material::Conductor { fresnel, alpha, alpha_v, tangent: Vec3::ZERO, distribution: *distribution };
            sided(
                bsdf,
                *two_sided,
                ParamMaps { specular, alpha: alpha_map, alpha_v: alpha_v_map, ..Default::default() },
            )
        }
        MaterialSpec::Conductor { preset, specular, eta, k, roughness: r, roughness_v, distribution, two_sided } => {
            let (fresnel, specular) = match (preset, specular, eta, k) {
                (Some(p), None, None, None) => (
                    Fresnel::Schlick(conductor_preset(p).ok_or_else(|| {
                        cx.err(&format!("{key}.preset"), format!("unknown metal `{p}` (accepted: Au, Ag, Cu, Al, Cr)"))
                    })?),
                    None,
                ),
                (None, Some(s), None, None) => {
                    let (f0, map) = colour("specular", s)?;
                    (Fresnel::Schlick(f0), map)
                }
                (None, s, Some(e), Some(kk)) => {
                    let (scale, map) = colour("specular", s.as_ref().unwrap_or(&Reflectance::Colour([1.0; 3])))?;
                    let eta = cx.colour(&format!("{key}.eta"), *e, None)?;
                    (Fresnel::Complex { eta, k: cx.colour(&format!("{key}.k"), *kk, None)?, scale }, map)
                }
                _ => {
                    let msg =
                        "a conductor needs `preset`, or `specular`, or `eta` and `k` (with an optional `specular`)";
                    return Err(cx.err(key, msg));
                }
            };
            let (alpha, alpha_map) = roughness(r)?;
            let (alpha_v, alpha_v_map) = across(alpha, alpha_map, roughness_v)?;
            let bsdf =
                Material::Conductor { fresnel, alpha, alpha_v, tangent: Vec3::ZERO, distribution: *distribution };
            sided(
                bsdf,
                *two_sided,
                ParamMaps { specular, alpha: alpha_map, alpha_v: alpha_v_map, ..Default::default() },
            )
        }
        MaterialSpec::Dielectric { ior, outside_ior, tint, .. }
        | MaterialSpec::ThinDielectric { ior, outside_ior, tint } => {
            let ior = relative_ior(cx, key, *ior, *outside_ior)?;
            let (tint, tint_map) = colour("tint", tint)?;
            if let MaterialSpec::Dielectric { roughness: r, roughness_v, distribution, .. } = spec {
                let (alpha, alpha_map) = roughness(r)?;
                let (alpha_v, alpha_v_map) = across(alpha, alpha_map, roughness_v)?;
                let distribution = *distribution;
                let bsdf = Material::Dielectric { ior, tint, alpha, alpha_v, tangent: Vec3::ZERO, distribution };
                let base = sided(
                    bsdf,
                    true,
                    ParamMaps { tint: tint_map, alpha: alpha_map, alpha_v: alpha_v_map, ..Default::default() },
                );
                with_media(cx, key, spec.media().unwrap_or_default(), base)?
            } else {
                sided(Material::ThinDielectric { ior, tint }, true, ParamMaps { tint: tint_map, ..Default::default() })
            }
        }
        MaterialSpec::Principled { base_color, roughness: r, specular, eta, two_sided, .. } => {
            let mut p = Principled::new(Rgb::ZERO);
            // A textured weight is read per hit; the material's own number is the texture's least for
            // `metallic` and its most for the others (where the surface is most able to transmit,
            // which `transmits` asks, and the sides are chosen by; an `anisotropic` texture that is
            // anywhere above 0 makes the material one whose hits get a tangent).
            let given = spec.principled_weights().expect("a principled BSDF's weights");
            let mut weights = [None; PRINCIPLED_WEIGHTS.len()];
            for (k, (w, name)) in given.into_iter().zip(PRINCIPLED_WEIGHTS).enumerate() {
                *p.weight_mut(k) = match w {
                    Weight::Value(x) => unit(name, *x)?,
                    Weight::Texture(t) => {
                        let what = format!("a principled {name} weight");
                        let t = texture_index(cx, &format!("{key}.{name}"), t, textures, &what)?;
                        weights[k] = Some(t);
                        let tex = &textures.list[t as usize];
                        if name == "metallic" { tex.min_value() } else { tex.max_value() }.clamp(0.0, 1.0)
                    }
                };
            }
            // Mitsuba's own guards: a transmitting surface of index 1 (or specular 0) is made 1.001 (1e-3).
            let transmits = p.spec_trans > 0.0;
            p.eta = match (eta, specular) {
                (Some(_), Some(_)) => return Err(cx.err(key, "give `eta` or `specular`, not both")),
                (Some(e), None) if (0.25..=4.0).contains(e) => {
                    if transmits && *e == 1.0 {
                        1.001
                    } else {
                        *e
                    }
                }
                (Some(e), None) => return Err(cx.err(&format!("{key}.eta"), format!("must be in [0.25, 4], got {e}"))),
                (None, s) => {
                    let s = unit("specular", s.unwrap_or(0.5))?;
                    Principled::eta_from_specular(if transmits && s == 0.0 { 1e-3 } else { s })
                }
            };
            p.two_sided = match two_sided {
                Some(true) if transmits => {
                    let msg = "a transmitting principled (spec_trans > 0) cannot be two-sided (Mitsuba's twosided refuses it too)";
                    return Err(cx.err(&format!("{key}.two_sided"), msg));
                }
                Some(t) => *t,
                None => !transmits,
            };
            let (base, texture) = reflectance("base_color", base_color)?;
            p.base = base;
            let alpha = match r {
                Weight::Value(x) => {
                    p.roughness = rough(*x)?;
                    None
                }
                Weight::Texture(name) => {
                    let t = texture_index(cx, &format!("{key}.roughness"), name, textures, "a roughness")?;
                    p.roughness = textures.list[t as usize].max_value();
                    Some(t)
                }
            };
            // The BSDF minds its own sides (`Principled::two_sided`).
            let maps = ParamMaps { alpha, weights, ..Default::default() };
            SurfaceMaterial { texture, maps, ..SurfaceMaterial::new(Material::Principled(p)) }
        }
        MaterialSpec::Null { .. } => with_media(cx, key, spec.media().unwrap_or_default(), SurfaceMaterial::null())?,
        MaterialSpec::Blend { weight, first, second } => {
            let weight = match weight {
                Weight::Value(w) => BlendWeight::Value(unit("weight", *w)?),
                Weight::Texture(name) => {
                    BlendWeight::Texture(texture_index(cx, &format!("{key}.weight"), name, textures, "a weight")?)
                }
            };
            SurfaceMaterial::blend(weight, named("first", first)?, named("second", second)?)
        }
        MaterialSpec::Sides { front, back } => {
            SurfaceMaterial::blend(BlendWeight::Side, named("front", front)?, named("back", back)?)
        }
        // Filled in by `apply_normal_maps` once every material is built.
        MaterialSpec::Normalmap { .. } | MaterialSpec::Bumpmap { .. } => {
            SurfaceMaterial::new(Material::Diffuse { reflectance: Rgb::ZERO })
        }
    })
}

/// Each `normalmap` or `bumpmap` material becomes the material it names with the normal map or bump
/// map added (built after every material, as it may name one listed later). A normal map of a normal
/// map, and one on a blend's or a side material's own materials (the normal is perturbed before a
/// blend picks), are refused; so is a bump map whose height has no gradient.
fn apply_normal_maps(
    cx: &Ctx,
    file: &SceneFile,
    index: &HashMap<String, u32>,
    textures: &Textures,
    materials: &mut [SurfaceMaterial],
) -> Result<(), SceneError> {
    let mapped: Vec<bool> = file
        .materials
        .values()
        .map(|m| matches!(m, MaterialSpec::Normalmap { .. } | MaterialSpec::Bumpmap { .. }))
        .collect();
    for (i, (name, spec)) in file.materials.iter().enumerate() {
        let key = format!("materials.{name}");
        let (map, material, two_sided) = match spec {
            MaterialSpec::Normalmap { normal_map, material, two_sided } => (
                NormalMap::Image(texture_named(cx, &format!("{key}.normal_map"), normal_map, textures)?),
                material,
                two_sided,
            ),
            MaterialSpec::Bumpmap { height, scale, material, two_sided, to_back } => {
                let t = texture_named(cx, &format!("{key}.height"), height, textures)?;
                if textures.list[t as usize].gradient(glam::Vec2::ZERO).is_none() {
                    let msg =
                        format!("`{height}` has no gradient to bend the normal by (a bump map's height is a bitmap)");
                    return Err(cx.err(&format!("{key}.height"), msg));
                }
                (NormalMap::Bump { height: t, scale: *scale, to_back: *to_back }, material, two_sided)
            }
            _ => continue,
        };
        let j = material_named(cx, &format!("{key}.material"), material, index)?;
        if mapped[j as usize] {
            return Err(cx.err(&format!("{key}.material"), format!("`{material}` has a normal map already")));
        }
        let inner = &materials[j as usize];
        if inner.blend.is_some() {
            let msg =
                format!("`{material}` is a blend; a normal map goes over one material (put it on each of the blend's)");
            return Err(cx.err(&format!("{key}.material"), msg));
        }
        let Some(nested) = Nested::new(inner.bsdf) else {
            let msg = format!("`{material}` is a thin pane or a null surface, which a normal map cannot bend");
            return Err(cx.err(&format!("{key}.material"), msg));
        };
        if *two_sided && inner.bsdf.transmits() {
            let msg = format!("`{material}` lets light through; its back cannot be its front's mirror image");
            return Err(cx.err(&format!("{key}.two_sided"), msg));
        }
        let nested_two_sided = inner.two_sided;
        let bsdf = Material::Mapped(Mapped {
            normal: Vec3::ZERO,
            mirror_back: *two_sided,
            nested,
            nested_two_sided,
            flipped_tangent: None,
        });
        let two_sided = *two_sided || inner.two_sided;
        materials[i] = SurfaceMaterial { bsdf, two_sided, normal_map: Some(map), ..inner.clone() };
    }
    for (name, spec) in &file.materials {
        let fields = match spec {
            MaterialSpec::Blend { first, second, .. } => [("first", first), ("second", second)],
            MaterialSpec::Sides { front, back } => [("front", front), ("back", back)],
            _ => continue,
        };
        for (field, other) in fields {
            if index.get(other).is_some_and(|&j| materials[j as usize].normal_map.is_some()) {
                let msg = format!("`{other}` has a normal map; a blend's or a side material's materials cannot (put the normal map around `{name}` instead)");
                return Err(cx.err(&format!("materials.{name}.{field}"), msg));
            }
        }
    }
    Ok(())
}

/// The first leaf under material `m` (itself, or a blend's parts, first then second; cycles are refused
/// before anything walks them) for which `f` holds.
fn find_leaf(m: u32, materials: &[SurfaceMaterial], f: &dyn Fn(&SurfaceMaterial) -> bool) -> Option<u32> {
    match materials[m as usize].blend {
        Some(b) => find_leaf(b.first, materials, f).or_else(|| find_leaf(b.second, materials, f)),
        None => f(&materials[m as usize]).then_some(m),
    }
}

/// Whether a material absorbs inside or around it (`absorption`, `outside_absorption`: a medium).
fn absorbs(m: &SurfaceMaterial) -> bool {
    m.absorption != Rgb::ZERO || m.absorption_outside != Rgb::ZERO
}

/// A side blend's back is seen from behind as from its own front, so each material it can be must be
/// two-sided (a one-sided one would be black there); and neither side may let light through (a path
/// through the surface would meet the other side's material: Mitsuba's `twosided` refuses it too).
fn check_sides(cx: &Ctx, materials: &[SurfaceMaterial], names: &[String]) -> Result<(), SceneError> {
    for (i, m) in materials.iter().enumerate() {
        let Some(b) = m.blend else { continue };
        for (field, part) in [("first", b.first), ("second", b.second)] {
            if let Some(l) = find_leaf(part, materials, &absorbs) {
                let field =
                    if b.weight == BlendWeight::Side { ["front", "back"][(field == "second") as usize] } else { field };
                let msg = format!(
                    "`{}` absorbs inside or around it (`absorption`, `outside_absorption`), which only a shape \
                     made of it alone can have, not a blend or a side of a surface",
                    names[l as usize]
                );
                return Err(cx.err(&format!("materials.{}.{field}", names[i]), msg));
            }
        }
        let Some(b) = m.blend.filter(|b| b.weight == BlendWeight::Side) else { continue };
        let key = format!("materials.{}", names[i]);
        let one_sided = |l: &SurfaceMaterial| !l.two_sided || matches!(l.bsdf, Material::Principled(p) if !p.two_sided);
        if let Some(l) = find_leaf(b.second, materials, &one_sided) {
            let msg = format!(
                "`{}` is one-sided: seen from behind it would be black (make it two_sided = true)",
                names[l as usize]
            );
            return Err(cx.err(&format!("{key}.back"), msg));
        }
        for (field, side) in [("front", b.first), ("back", b.second)] {
            if let Some(l) = find_leaf(side, materials, &|l: &SurfaceMaterial| l.bsdf.transmits()) {
                let msg = format!(
                    "`{}` lets light through; a surface with a material on each side cannot",
                    names[l as usize]
                );
                return Err(cx.err(&format!("{key}.{field}"), msg));
            }
        }
    }
    Ok(())
}

/// An interface's index inside over outside, both checked to lie in [0.25, 4]: only the ratio matters
/// at an interface (glass, 1.5, in water, 1.33, bends light by 1.5/1.33).
fn relative_ior(cx: &Ctx, key: &str, ior: f32, outside_ior: f32) -> Result<f32, SceneError> {
    for (k, v) in [("ior", ior), ("outside_ior", outside_ior)] {
        if !(0.25..=4.0).contains(&v) {
            return Err(cx.err(&format!("{key}.{k}"), format!("must be in [0.25, 4], got {v}")));
        }
    }
    Ok(ior / outside_ior)
}

/// The axis of a spot or projector at `position`: its `direction`, or towards its `target` (exactly
/// one of them), refused if it gives no direction.
fn light_axis(
    cx: &Ctx,
    key: &str,
    position: Vec3,
    direction: &Option<V3>,
    target: &Option<V3>,
) -> Result<Vec3, SceneError> {
    let axis = match (direction, target) {
        (Some(d), None) => Vec3::from_array(*d),
        (None, Some(t)) => Vec3::from_array(*t) - position,
        _ => return Err(cx.err(key, "give exactly one of `direction` or `target`")),
    };
    if !(axis.length() > 0.0 && axis.length().is_finite()) {
        let what = if direction.is_some() { "direction" } else { "target" };
        return Err(cx.err(&format!("{key}.{what}"), "gives no direction (zero vector, or the light's own position)"));
    }
    Ok(axis)
}

/// The `up` of a light projecting an image (default +y), refused if zero or along `axis`; `whose`
/// names the light in the message ("the spot's").
fn light_up(cx: &Ctx, key: &str, up: &Option<V3>, axis: Vec3, whose: &str) -> Result<Vec3, SceneError> {
    let up = Vec3::from_array(up.unwrap_or([0.0, 1.0, 0.0]));
    let off_axis = up.cross(axis.normalize()).length();
    if !up.is_finite() || off_axis.is_nan() || off_axis <= 1e-6 {
        return Err(cx.err(&format!("{key}.up"), format!("is zero or along {whose} axis")));
    }
    Ok(up)
}

/// The texture a spot or projector (`whose`: "a spot's") of light `key` projects, refused if it is
/// mesh colours or below 0 anywhere.
fn projected_texture(cx: &Ctx, key: &str, name: &str, textures: &Textures, whose: &str) -> Result<u32, SceneError> {
    let field = format!("{key}.texture");
    let t = texture_named(cx, &field, name, textures)?;
    not_mesh_colors(cx, &field, name, textures, t, &format!("{whose} projected texture"))?;
    let low = textures.list[t as usize].min_value();
    if low.is_nan() || low < 0.0 {
        let label = texture_label(name, &textures.list[t as usize]);
        return Err(cx.err(&field, format!("texture {label} reaches {low}; {whose} projected texture must be ≥ 0")));
    }
    Ok(t)
}

/// The `[textures]` entry `name` that the material field `key` names (a reflectance, a blend's weight);
/// refused if unknown or outside [0, 1] anywhere, as `what` must stay in [0, 1].
fn texture_index(cx: &Ctx, key: &str, name: &str, textures: &Textures, what: &str) -> Result<u32, SceneError> {
    let t = texture_named(cx, key, name, textures)?;
    let tex = &textures.list[t as usize];
    unit_range(tex).map_err(|reach| {
        cx.err(key, format!("texture {} reaches {reach}; {what} must be in [0, 1]", texture_label(name, tex)))
    })?;
    Ok(t)
}

/// Ok if every value of the texture lies in [0, 1]; else the value beyond the range it reaches.
fn unit_range(tex: &Texture) -> Result<(), f32> {
    let (low, high) = (tex.min_value(), tex.max_value());
    if low.is_nan() || low < 0.0 {
        Err(low)
    } else if high > 1.0 {
        Err(high)
    } else {
        Ok(())
    }
}

/// The `[materials]` entry `name` that the field `key` names; refused if there is none.
fn material_named(cx: &Ctx, key: &str, name: &str, index: &HashMap<String, u32>) -> Result<u32, SceneError> {
    index.get(name).copied().ok_or_else(|| {
        let known: Vec<&String> = index.keys().collect();
        cx.err(key, format!("unknown material `{name}` (defined: {known:?})"))
    })
}

/// The `[textures]` entry `name` that the field `key` names; refused if there is none.
fn texture_named(cx: &Ctx, key: &str, name: &str, textures: &Textures) -> Result<u32, SceneError> {
    textures.index.get(name).copied().ok_or_else(|| {
        let known: Vec<&String> = textures.index.keys().collect();
        cx.err(key, format!("unknown texture `{name}` (defined: {known:?})"))
    })
}

/// Refuses mesh colours (texture `t`, named `name`, for the field `key`) where `what` has no mesh hit
/// to read them at.
fn not_mesh_colors(cx: &Ctx, key: &str, name: &str, textures: &Textures, t: u32, what: &str) -> Result<(), SceneError> {
    if let Texture::MeshColor { of, .. } = textures.list[t as usize] {
        let msg = format!("`{name}` is a {} texture, read on materials only, not as {what}", of.name());
        return Err(cx.err(key, msg));
    }
    Ok(())
}

/// The largest scale of the mesh-colour textures of kind `of` material `m` reads (through its blends,
/// depth-bounded), if it reads any.
fn mesh_color_scale(
    materials: &[SurfaceMaterial],
    textures: &[Texture],
    of: MeshColors,
    m: u32,
    depth: usize,
) -> Option<f32> {
    let mat = &materials[m as usize];
    let maps = &mat.maps;
    let weight = mat.blend.and_then(|b| match b.weight {
        crate::scene::material::BlendWeight::Texture(t) => Some(t),
        _ => None,
    });
    let normal = mat.normal_map.map(NormalMap::texture);
    let own = [mat.texture, maps.specular, maps.tint, maps.alpha, maps.alpha_v, normal, weight];
    let mut most =
        own.into_iter().chain(maps.weights).flatten().fold(None, |most: Option<f32>, t| match textures[t as usize] {
            Texture::MeshColor { of: kind, scale } if kind == of => Some(most.map_or(scale, |m| m.max(scale))),
            _ => most,
        });
    if let Some(b) = mat.blend.filter(|_| depth < MAX_BLEND_DEPTH) {
        for next in [b.first, b.second] {
            if let Some(scale) = mesh_color_scale(materials, textures, of, next, depth + 1) {
                most = Some(most.map_or(scale, |m| m.max(scale)));
            }
        }
    }
    most
}

/// A texture as an error names it: `name`, and the image file it was read from.
fn texture_label(name: &str, t: &Texture) -> String {
    match t {
        Texture::Bitmap { file, .. } => format!("`{name}` ({file})"),
        Texture::Checkerboard { .. } | Texture::MeshColor { .. } => format!("`{name}`"),
    }
}

/// Transform to a matrix; refuses degenerate or non-finite ones.
pub fn transform_matrix(cx_key: &str, t: &TransformSpec, shown: &str) -> Result<Mat4, SceneError> {
    transform_matrix_at(&format!("{cx_key}.transform"), t, shown)
}

/// Whether `m`'s linear part flattens space: its determinant below 1e-12 of the product of its columns'
/// lengths (what a zero scale gives, or columns along one another). Relative, so that a scene keeps
/// loading at any size: an absolute bound refused every transform of a scene scaled to 1e-5 (a floor
/// of side 8e-5 has determinant 6.4e-14) while Mitsuba reads it.
pub(crate) fn degenerate(m: &Mat4) -> bool {
    let (a, b, c) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let volume = a.length() * b.length() * c.length();
    let d = m.determinant().abs();
    d.is_nan() || d <= 1e-12 * volume
}

/// `transform_matrix` for the transform at `key` (its whole name, errors naming it).
fn transform_matrix_at(key: &str, t: &TransformSpec, shown: &str) -> Result<Mat4, SceneError> {
    let err = |msg: String| SceneError::Invalid { file: shown.into(), key: key.into(), msg };
    let m = if let Some(rows) = t.matrix {
        if t.translate.is_some()
            || t.scale.is_some()
            || t.rotate_x.is_some()
            || t.rotate_y.is_some()
            || t.rotate_z.is_some()
        {
            return Err(err("give either `matrix` or translate/rotate/scale, not both".into()));
        }
        Mat4::from_cols_array_2d(&rows).transpose()
    } else {
        let s = match &t.scale {
            None => Vec3::ONE,
            Some(Scale::Uniform(s)) => Vec3::splat(*s),
            Some(Scale::Axes(a)) => Vec3::from_array(*a),
        };
        Mat4::from_translation(Vec3::from_array(t.translate.unwrap_or([0.0; 3])))
            * Mat4::from_rotation_z(t.rotate_z.unwrap_or(0.0).to_radians())
            * Mat4::from_rotation_y(t.rotate_y.unwrap_or(0.0).to_radians())
            * Mat4::from_rotation_x(t.rotate_x.unwrap_or(0.0).to_radians())
            * Mat4::from_scale(s)
    };
    let det = m.determinant();
    if !det.is_finite() || !m.is_finite() || degenerate(&m) {
        return Err(err(format!("is degenerate (determinant {det})")));
    }
    Ok(m)
}

fn build_shape(
    cx: &Ctx,
    key: &str,
    spec: &ShapeSpec,
    dir: &Path,
    index: &HashMap<String, u32>,
    out: &mut Built,
) -> Result<(), SceneError> {
    let first = out.shapes.len();
    let lookup = |name: &str| material_named(cx, &format!("{key}.material"), name, index);
    // Emitted radiance: a colour, or a texture (of values ≥ 0) times 1.
    let emission = |e: &Option<Reflectance>, textures: &Textures| -> Result<(Rgb, Option<u32>), SceneError> {
        let field = format!("{key}.emission");
        match e {
            None => Ok((Rgb::ZERO, None)),
            Some(Reflectance::Colour(c)) => Ok((cx.colour(&field, *c, None)?, None)),
            Some(Reflectance::Texture(name)) => {
                let t = texture_named(cx, &field, name, textures)?;
                not_mesh_colors(cx, &field, name, textures, t, "an emitter's radiance")?;
                let low = textures.list[t as usize].min_value();
                if low.is_nan() || low < 0.0 {
                    let label = texture_label(name, &textures.list[t as usize]);
                    return Err(cx.err(&field, format!("texture {label} reaches {low}; radiance must be ≥ 0")));
                }
                Ok((Rgb::ONE, Some(t)))
            }
        }
    };
    // A mesh turned inside out if asked, then transformed, becomes the shape; smooth normals it lacks
    // (`smooth` with none in the file) are computed as placed, before an instance's placement (`after`),
    // which they follow as normals.
    let push = |shapes: &mut Vec<Shape>,
                mut mesh: TriMesh,
                flip: bool,
                (transform, after): (&TransformSpec, Option<&TransformSpec>),
                material: u32,
                (emission, emission_texture): (Rgb, Option<u32>),
                smooth: bool,
                emit_by_shading_normal: bool| {
        if flip {
            mesh.flip();
        }
        mesh.transform(&transform_matrix(key, transform, cx.shown)?);
        if smooth && mesh.normals.is_none() {
            mesh.compute_smooth_normals();
        }
        if let Some(after) = after {
            mesh.place_as_instance(&transform_matrix_at(&format!("{key}.instance_transform"), after, cx.shown)?);
        }
        mesh.face_vertex_normals();
        let geometry = Geometry::Mesh(mesh);
        shapes.push(Shape { name: key.into(), geometry, material, emission, emission_texture, emit_by_shading_normal });
        Ok::<(), SceneError>(())
    };
    match spec {
        ShapeSpec::Mesh {
            file,
            material,
            transform,
            emission: e,
            smooth,
            flip_normals,
            shape_index,
            flip_tex_coords,
            emit_by_shading_normal,
            instance_transform,
        } => {
            if *emit_by_shading_normal && !(*smooth && e.is_some()) {
                let msg = "is for an emitting mesh with smooth normals (`emission` and `smooth = true`)";
                return Err(cx.err(&format!("{key}.emit_by_shading_normal"), msg));
            }
            let path = dir.join(file);
            let shown_mesh = path.display().to_string();
            let in_scene = |e: SceneError| cx.err(&format!("{key}.file"), e.to_string());
            let textured = matches!(mesh::MeshFormat::of(file), Some(mesh::MeshFormat::Obj | mesh::MeshFormat::Ply));
            if flip_tex_coords.is_some() && !textured {
                return Err(cx.err(&format!("{key}.flip_tex_coords"), "is read only for an OBJ or PLY file"));
            }
            let loaded =
                mesh::load_mesh_file(&path, &shown_mesh, *smooth, *shape_index, *flip_tex_coords).map_err(in_scene)?;
            for lm in loaded {
                lm.mesh.validate(&shown_mesh).map_err(in_scene)?;
                let mat = match (material, lm.mtl_diffuse, &lm.mtl_texture) {
                    (Some(m), _, _) => lookup(m)?,
                    (None, _, Some(tex)) => mtl_texture_material(cx, key, &path, tex, file, out)?,
                    (None, Some(kd), None) => {
                        let reflectance = Vec3::from_array(kd).clamp(Vec3::ZERO, Vec3::ONE);
                        out.materials.push(SurfaceMaterial::new(Material::Diffuse { reflectance }));
                        out.names.push(format!("{file} (MTL)"));
                        out.materials.len() as u32 - 1
                    }
                    (None, None, None) => {
                        let why = lm.mtl_error.as_ref().map_or(String::new(), |e| format!(" (its MTL file: {e})"));
                        return Err(
                            cx.err(&format!("{key}.material"), format!("missing, and the mesh has no MTL colour{why}"))
                        );
                    }
                };
                let emits = emission(e, out.textures)?;
                let placed = (transform, instance_transform.as_ref());
                push(out.shapes, lm.mesh, *flip_normals, placed, mat, emits, *smooth, *emit_by_shading_normal)?;
            }
        }
        ShapeSpec::Sphere { center, radius, material, transform, emission: e, flip_normals } => {
            cx.positive(&format!("{key}.radius"), *radius)?;
            let m = transform_matrix(key, transform, cx.shown)?;
            if is_similarity(&m) {
                let geometry = sphere_geometry(*center, *radius, &m, *flip_normals);
                let (emission, emission_texture) = emission(e, out.textures)?;
                let material = lookup(material)?;
                let emit_by_shading_normal = false;
                out.shapes.push(Shape {
                    name: key.into(),
                    geometry,
                    material,
                    emission,
                    emission_texture,
                    emit_by_shading_normal,
                });
            } else if e.is_some() {
                let msg = "an emitting sphere accepts only uniform scale, rotation and translation (only one that \
                           does not emit may be stretched into an ellipsoid, which is tessellated)";
                return Err(cx.err(&format!("{key}.transform"), msg));
            } else {
                // An uneven scale or a shear makes an ellipsoid (Mitsuba's sphere placed by an instance
                // that scales unevenly): tessellated finely, its normals exact at the vertices.
                let mut mesh = mesh::uv_sphere(ELLIPSOID_ROWS, 2 * ELLIPSOID_ROWS);
                mesh.transform(
                    &(Mat4::from_translation(Vec3::from_array(*center)) * Mat4::from_scale(Vec3::splat(*radius))),
                );
                let mat = lookup(material)?;
                push(out.shapes, mesh, *flip_normals, (transform, None), mat, (Rgb::ZERO, None), true, false)?;
            }
        }
        ShapeSpec::Curves { file, material, basis, transform, segments, instance_transform } => {
            let path = dir.join(file);
            let shown_file = path.display().to_string();
            let in_scene = |e: SceneError| cx.err(&format!("{key}.file"), e.to_string());
            let least = if *basis == CurveBasis::Bspline { 4 } else { 2 };
            let mut curves = mesh::read_curves(&path, &shown_file, least).map_err(in_scene)?;
            // The points placed, the radii as they are (Mitsuba's).
            let m = transform_matrix(key, transform, cx.shown)?;
            for (p, _) in curves.iter_mut().flatten() {
                *p = m.transform_point3(*p);
            }
            let around = curve_segments(cx, key, &curves, *basis, *segments)?;
            let mat = lookup(material)?;
            if let Some(why) = unfit_for_curves(out.materials, mat) {
                let msg = format!("`{material}` {why}: curves cull their backs, as Mitsuba's do");
                return Err(cx.err(&format!("{key}.material"), msg));
            }
            let mesh = match basis {
                CurveBasis::Linear => mesh::round_linear_curves(&curves, around),
                CurveBasis::Bspline => mesh::round_bspline_curves(&curves, around, bspline_steps(around)),
            };
            mesh.validate(&shown_file).map_err(in_scene)?;
            let placed = (&TransformSpec::default(), instance_transform.as_ref());
            push(out.shapes, mesh, false, placed, mat, (Rgb::ZERO, None), true, false)?;
        }
        ShapeSpec::Heightfield { material, transform, .. } => {
            let mesh = generated_mesh(cx, key, spec)?;
            push(out.shapes, mesh, false, (transform, None), lookup(material)?, (Rgb::ZERO, None), false, false)?;
        }
        ShapeSpec::Quad { material, transform, emission: e, flip_normals: flip, .. }
        | ShapeSpec::Disk { material, transform, emission: e, flip_normals: flip, .. }
        | ShapeSpec::Cylinder { material, transform, emission: e, flip_normals: flip, .. }
        | ShapeSpec::Box { material, transform, emission: e, flip_normals: flip, .. } => {
            let mesh = generated_mesh(cx, key, spec)?;
            let (mat, emits) = (lookup(material)?, emission(e, out.textures)?);
            push(out.shapes, mesh, *flip, (transform, None), mat, emits, false, false)?;
        }
        ShapeSpec::Lathe { material, transform, emission: e, .. } => {
            let mesh = generated_mesh(cx, key, spec)?;
            let (mat, emits) = (lookup(material)?, emission(e, out.textures)?);
            push(out.shapes, mesh, false, (transform, None), mat, emits, false, false)?;
        }
    }
    // Mesh colours are read off the hit mesh: it must have them, each within [0, 1] times the
    // texture's scale (a reflectance, a weight, a roughness).
    for s in &out.shapes[first..] {
        for of in [MeshColors::Vertex, MeshColors::Face] {
            let Some(scale) = mesh_color_scale(out.materials, &out.textures.list, of, s.material, 0) else { continue };
            let name = &out.names[s.material as usize];
            let (colors, what) = match (&s.geometry, of) {
                (Geometry::Mesh(m), MeshColors::Vertex) => (m.colors.as_ref(), "vertex"),
                (Geometry::Mesh(m), MeshColors::Face) => (m.face_colors.as_ref(), "triangle"),
                (Geometry::Sphere { .. }, _) => (None, ""),
            };
            let Some(colors) = colors else {
                let msg = match of {
                    MeshColors::Vertex => "vertex colours (a vertex_color texture)",
                    MeshColors::Face => "face colours (a face_color texture)",
                };
                return Err(
                    cx.err(&format!("{key}.material"), format!("`{name}` reads {msg}, and this shape has none"))
                );
            };
            if let Some((i, c)) = colors
                .iter()
                .enumerate()
                .find(|(_, c)| !(c.is_finite() && c.min_element() >= 0.0 && c.max_element() * scale <= 1.0))
            {
                let from = match spec {
                    ShapeSpec::Mesh { file, .. } => format!("{file}: "),
                    _ => String::new(),
                };
                let msg = format!(
                    "{from}{what} {i}'s colour {:?} times the {} texture's scale {scale} leaves [0, 1] (`{name}` reads it)",
                    c.to_array(),
                    of.name()
                );
                return Err(cx.err(key, msg));
            }
        }
    }
    // A normal map is read along the texture's u, a bump map's gradient along u and v: a mesh without
    // texture coordinates has none.
    for s in &out.shapes[first..] {
        let map = out.materials[s.material as usize].normal_map;
        if map.is_some() && matches!(&s.geometry, Geometry::Mesh(m) if m.uvs.is_none()) {
            let name = &out.names[s.material as usize];
            let kind = if let Some(NormalMap::Bump { .. }) = map { "a bump map" } else { "a normal map" };
            let msg = format!("`{name}` has {kind}, which needs texture coordinates, and this mesh has none");
            return Err(cx.err(&format!("{key}.material"), msg));
        }
        // A disk's ∂p/∂v (along its angle) shrinks towards its centre (Mitsuba's disk: 2πr); each of
        // its triangles keeps the rim's, which only a normal map (read along ∂p/∂u) does not see.
        if let (Some(NormalMap::Bump { .. }), ShapeSpec::Disk { .. }) = (map, spec) {
            let name = &out.names[s.material as usize];
            let msg = format!(
                "`{name}` has a bump map, not supported on a disk (its triangles would bend it by the rim's ∂p/∂v \
                 everywhere; a rectangle or a mesh with texture coordinates can carry it)"
            );
            return Err(cx.err(&format!("{key}.material"), msg));
        }
    }
    Ok(())
}

/// A diffuse material reading the MTL's `map_Kd` image (path relative to the OBJ), one per image file.
fn mtl_texture_material(
    cx: &Ctx,
    key: &str,
    obj: &Path,
    tex: &str,
    file: &str,
    out: &mut Built,
) -> Result<u32, SceneError> {
    let path = obj.parent().map(Path::to_path_buf).unwrap_or_default().join(tex.replace('\\', "/"));
    let t = match out.textures.files.get(&path) {
        Some(&t) => t,
        None => {
            let (width, height, texels) = load_image(&path, false)
                .map_err(|e| cx.err(&format!("{key}.file"), format!("MTL map_Kd {}: {e}", path.display())))?;
            let t = out.textures.list.len() as u32;
            let bitmap = Texture::Bitmap {
                file: tex.into(),
                width,
                height,
                texels,
                to_uv: UvMap::default(),
                bilinear: true,
                wrap: Default::default(),
            };
            unit_range(&bitmap).map_err(|reach| {
                let msg = format!("MTL map_Kd {} reaches {reach}; a reflectance must be in [0, 1]", path.display());
                cx.err(&format!("{key}.file"), msg)
            })?;
            out.textures.list.push(bitmap);
            out.textures.files.insert(path.clone(), t);
            t
        }
    };
    out.materials.push(SurfaceMaterial {
        texture: Some(t),
        ..SurfaceMaterial::new(Material::Diffuse { reflectance: Rgb::ZERO })
    });
    out.names.push(format!("{file} (MTL {tex})"));
    Ok(out.materials.len() as u32 - 1)
}

/// Rows of polar angle of a sphere stretched into an ellipsoid (`mesh::uv_sphere`, twice as many columns):
/// its silhouette within 7.6e-5 of its longest radius of the true one.
const ELLIPSOID_ROWS: u32 = 128;

/// Most triangles the automatic tessellation of a curve file makes (`curve_segments`).
const CURVE_TRIANGLES: usize = 8_000_000;

/// Steps along each segment of a B-spline curve's mesh for `around` steps round it.
fn bspline_steps(around: u32) -> u32 {
    (around / 8).max(4)
}

/// Steps round each ring of a curve file's mesh: `asked` (3 to 1024), or 128, fewer (down to 6) where
/// the mesh would pass `CURVE_TRIANGLES`. Refused: more than 200 million triangles.
fn curve_segments(
    cx: &Ctx,
    key: &str,
    curves: &[mesh::Curve],
    basis: CurveBasis,
    asked: Option<u32>,
) -> Result<u32, SceneError> {
    let least = if basis == CurveBasis::Bspline { 3 } else { 1 };
    let segments: usize = curves.iter().map(|c| c.len() - least).sum();
    let triangles = |around: u32| {
        let (a, rings) = (around as usize, (around / 4).max(2) as usize);
        match basis {
            // Each segment's cone and end cap, each curve's start cap (`round_linear_curves`).
            CurveBasis::Linear => segments * (2 * a + 2 * a * rings) + curves.len() * 2 * a * rings,
            CurveBasis::Bspline => segments * 2 * a * bspline_steps(around) as usize,
        }
    };
    let around = match asked {
        Some(a) if (3..=1024).contains(&a) => a,
        Some(a) => return Err(cx.err(&format!("{key}.segments"), format!("must be in [3, 1024], got {a}"))),
        None => (6..=128).rev().find(|&a| triangles(a) <= CURVE_TRIANGLES).unwrap_or(6),
    };
    if triangles(around) > 200_000_000 {
        let msg = format!(
            "{segments} curve segments at {around} steps round make {} triangles, more than 200 million",
            triangles(around)
        );
        return Err(cx.err(&format!("{key}.file"), msg));
    }
    Ok(around)
}

/// Why a curve may not have `material`, if some material a hit on it can be holds a medium or refracts:
/// curves cull their backs (as Mitsuba's do), so light that enters one meets no wall from inside. (A
/// blend holds no medium: `check_sides` refuses one.)
fn unfit_for_curves(materials: &[SurfaceMaterial], material: u32) -> Option<&'static str> {
    if find_leaf(material, materials, &absorbs).is_some() {
        return Some("holds a medium, which a path that enters a curve could never leave");
    }
    let refracts = |m: &SurfaceMaterial| m.bsdf.transmits() && !m.bsdf.is_thin();
    find_leaf(material, materials, &refracts).map(|_| {
        "refracts, and light that enters a curve leaves it unbent (as in Mitsuba), which paths from the \
         lights (BDPT, VCM, photons) and from the camera do not see alike"
    })
}

/// Whether `m` only rotates (or reflects), translates and scales uniformly, to 1e-4: a sphere stays a
/// sphere under it.
pub fn is_similarity(m: &Mat4) -> bool {
    let (sx, sy, sz) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let s = sx.length();
    (sy.length() - s).abs() < 1e-4 * s
        && (sz.length() - s).abs() < 1e-4 * s
        && sx.dot(sy).abs() < 1e-4 * s * s
        && sx.dot(sz).abs() < 1e-4 * s * s
        && sy.dot(sz).abs() < 1e-4 * s * s
}

/// An analytic sphere after its transform `m`, which only rotates (or reflects: the sphere stays a
/// sphere, its normals facing as `inward` says), translates and scales uniformly (`is_similarity`).
fn sphere_geometry(center: V3, radius: f32, m: &Mat4, inward: bool) -> Geometry {
    let (sx, sy, sz) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let s = sx.length();
    // The sphere's own axes, for its texture coordinates: to_world's rotation (or reflection) undone.
    let turn = glam::Mat3::from_cols(sx / s, sy / s, sz / s);
    let frame = (!turn.abs_diff_eq(glam::Mat3::IDENTITY, 1e-6)).then(|| turn.transpose());
    Geometry::Sphere { center: m.transform_point3(Vec3::from_array(center)), radius: radius * s, frame, inward }
}

/// The triangle mesh of a generated shape (quad, disk, lathe, cylinder, height field, box), its parameters
/// checked.
fn generated_mesh(cx: &Ctx, key: &str, spec: &ShapeSpec) -> Result<TriMesh, SceneError> {
    let bad = |field: &str, msg: String| cx.err(&format!("{key}.{field}"), msg);
    Ok(match spec {
        ShapeSpec::Quad { corner, edge_u, edge_v, .. } => {
            let (eu, ev) = (Vec3::from_array(*edge_u), Vec3::from_array(*edge_v));
            if eu.cross(ev).length() == 0.0 {
                return Err(bad("edge_u", "edge_u and edge_v span zero area".into()));
            }
            mesh::quad(Vec3::from_array(*corner), eu, ev)
        }
        ShapeSpec::Disk { center, normal, radius, segments, .. } => {
            cx.positive(&format!("{key}.radius"), *radius)?;
            if *segments < 3 || *segments > 1 << 20 {
                return Err(bad("segments", "must be in [3, 1048576]".into()));
            }
            let n = Vec3::from_array(*normal);
            if n.length() == 0.0 {
                return Err(bad("normal", "is the zero vector".into()));
            }
            mesh::disk(Vec3::from_array(*center), n, *radius, *segments)
        }
        ShapeSpec::Lathe { profile, segments, smooth, .. } => lathe_mesh(cx, key, profile, *segments, *smooth)?,
        ShapeSpec::Cylinder { p0, p1, radius, segments, .. } => {
            let (p0, p1) = (Vec3::from_array(*p0), Vec3::from_array(*p1));
            let axis = p1 - p0;
            if !(radius.is_finite() && *radius > 0.0) {
                return Err(bad("radius", format!("must be a finite radius > 0, got {radius}")));
            }
            if !(p0.is_finite() && axis.is_finite() && axis.length() > 0.0) {
                return Err(bad("p1", format!("must differ from p0, both finite (got p0 {p0}, p1 {p1})")));
            }
            if !(3..=1 << 20).contains(segments) {
                return Err(bad("segments", "must be in [3, 1048576]".into()));
            }
            // Mitsuba's placement: its unit tube's x and y along the axis frame's tangents (scaled by
            // the radius), its z along p0 → p1.
            let f = crate::math::Frame::from_normal(axis.normalize());
            let local = Mat4::from_cols(
                (f.s * *radius).extend(0.0),
                (f.t * *radius).extend(0.0),
                axis.extend(0.0),
                p0.extend(1.0),
            );
            let mut m = mesh::cylinder(*segments);
            m.transform(&local);
            m
        }
        ShapeSpec::Heightfield { size, resolution, height, waves, .. } => {
            if size[0] <= 0.0 || size[1] <= 0.0 {
                return Err(bad("size", "both sides must be > 0".into()));
            }
            if resolution[0] == 0 || resolution[1] == 0 || resolution[0] as u64 * resolution[1] as u64 > 1 << 22 {
                return Err(bad("resolution", "must be ≥ 1 and at most 4M cells".into()));
            }
            if let Some(w) = waves.iter().find(|w| w.wavelength <= 0.0) {
                return Err(bad("waves", format!("wavelength {} must be > 0", w.wavelength)));
            }
            let f = |x: f32, z: f32| {
                let wave = |w: &crate::scene::file::Wave| {
                    let a = w.angle.to_radians();
                    w.amplitude * (std::f32::consts::TAU * (x * a.cos() + z * a.sin()) / w.wavelength + w.phase).sin()
                };
                height + waves.iter().map(wave).sum::<f32>()
            };
            let mut m = mesh::heightfield(*size, *resolution, f);
            m.compute_smooth_normals();
            m
        }
        ShapeSpec::Box { min, max, .. } => {
            let (a, b) = (Vec3::from_array(*min), Vec3::from_array(*max));
            if (b - a).min_element() <= 0.0 {
                return Err(bad("max", "must exceed `min` on every axis".into()));
            }
            mesh::cuboid(a, b)
        }
        ShapeSpec::Mesh { .. } | ShapeSpec::Sphere { .. } | ShapeSpec::Curves { .. } => {
            unreachable!("not a generated mesh")
        }
    })
}

fn lathe_mesh(cx: &Ctx, key: &str, profile: &[[f32; 2]], segments: u32, smooth: bool) -> Result<TriMesh, SceneError> {
    let bad = |msg: String| cx.err(&format!("{key}.profile"), msg);
    if profile.len() < 2 {
        return Err(bad("needs at least two [r, y] points".into()));
    }
    if let Some(p) = profile.iter().find(|p| p[0] < 0.0) {
        return Err(bad(format!("radius {} is negative", p[0])));
    }
    if !(3..=1 << 16).contains(&segments) {
        return Err(cx.err(&format!("{key}.segments"), "must be in [3, 65536]"));
    }
    if profile.len() as u64 * segments as u64 > 1 << 24 {
        return Err(bad("profile points × segments exceeds 16M vertices".into()));
    }
    let mut m = mesh::lathe(profile, segments);
    if m.indices.is_empty() {
        return Err(bad("the profile sweeps no area".into()));
    }
    if smooth {
        m.compute_smooth_normals();
    }
    Ok(m)
}

fn radiance_of(cx: &Ctx, key: &str, power: &Option<V3>, radiance: &Option<V3>, area: f32) -> Result<Rgb, SceneError> {
    let l = match (power, radiance) {
        (Some(p), None) => cx.colour(&format!("{key}.power"), *p, None)? / (std::f32::consts::PI * area),
        (None, Some(r)) => cx.colour(&format!("{key}.radiance"), *r, None)?,
        _ => return Err(cx.err(key, "give exactly one of `power` or `radiance`")),
    };
    if !l.is_finite() {
        return Err(cx.err(key, "radiance overflows f32 (power too large for this area)"));
    }
    Ok(l)
}

fn build_light(
    cx: &Ctx,
    key: &str,
    spec: &LightSpec,
    black: u32,
    textures: &Textures,
    shapes: &mut Vec<Shape>,
    points: &mut Vec<PointLight>,
) -> Result<(), SceneError> {
    // A sphere or quad light: a shape of the black material emitting `emission`.
    let light_shape = |geometry, emission| Shape {
        name: key.into(),
        geometry,
        material: black,
        emission,
        emission_texture: None,
        emit_by_shading_normal: false,
    };
    match spec {
        LightSpec::Point { position, power } => {
            let power = cx.colour(&format!("{key}.power"), *power, None)?;
            let intensity = power / (4.0 * std::f32::consts::PI);
            points.push(PointLight { position: Vec3::from_array(*position), intensity, spot: None });
        }
        LightSpec::Spot { position, direction, target, intensity, power, cutoff_angle, beam_width, texture, up } => {
            let position = Vec3::from_array(*position);
            let axis = light_axis(cx, key, position, direction, target)?;
            let angle = |name: &str, deg: f32, (min, max): (f32, f32), open: &str| {
                if deg >= min && deg <= max && (deg > 0.0 || open == "[") {
                    Ok(deg.to_radians())
                } else {
                    Err(cx.err(&format!("{key}.{name}"), format!("must be in {open}0, {max}] degrees, got {deg}")))
                }
            };
            let cutoff = angle("cutoff_angle", *cutoff_angle, (0.0, 180.0), "(")?;
            let beam = angle("beam_width", beam_width.unwrap_or(0.75 * cutoff_angle), (0.0, *cutoff_angle), "[")?;
            let mut spot = Spot::new(axis, cutoff, beam);
            match texture {
                Some(name) => {
                    let t = projected_texture(cx, key, name, textures, "a spot's")?;
                    if *cutoff_angle >= 90.0 {
                        let msg = format!("a projected texture needs cutoff_angle < 90 degrees, got {cutoff_angle}");
                        return Err(cx.err(&format!("{key}.cutoff_angle"), msg));
                    }
                    spot = spot.with_texture(t, light_up(cx, key, up, axis, "the spot's")?);
                }
                None if up.is_some() => {
                    return Err(cx.err(&format!("{key}.up"), "orients a projected texture; this spot has none"));
                }
                None => {}
            }
            let intensity = match (intensity, power) {
                (Some(i), None) => cx.colour(&format!("{key}.intensity"), *i, None)?,
                (None, Some(p)) => cx.colour(&format!("{key}.power"), *p, None)? / spot.solid_angle(),
                _ => return Err(cx.err(key, "give exactly one of `intensity` or `power`")),
            };
            if !intensity.is_finite() {
                return Err(cx.err(key, "intensity overflows f32 (power too large for this cone)"));
            }
            points.push(PointLight { position, intensity, spot: Some(spot) });
        }
        LightSpec::Projector { position, direction, target, up, fov, fov_axis, irradiance, texture } => {
            let position = Vec3::from_array(*position);
            let axis = light_axis(cx, key, position, direction, target)?;
            let up = light_up(cx, key, up, axis, "the projector's")?;
            let t =
                texture.as_ref().map(|name| projected_texture(cx, key, name, textures, "a projector's")).transpose()?;
            // The rectangle's proportions: the texture's, or square.
            let aspect = match t.map(|t| &textures.list[t as usize]) {
                Some(Texture::Bitmap { width, height, .. }) => *width as f32 / *height as f32,
                _ => 1.0,
            };
            if !(*fov > 0.0 && *fov < 180.0) {
                return Err(cx.err(&format!("{key}.fov"), format!("must be in (0, 180) degrees, got {fov}")));
            }
            let half = (0.5 * fov.to_radians()).tan();
            let tx = match fov_axis.as_deref().unwrap_or("x") {
                "x" => half,
                "y" => half * aspect,
                "smaller" => half * aspect.max(1.0),
                "larger" => half * aspect.min(1.0),
                "diagonal" => half * aspect / aspect.hypot(1.0),
                a => {
                    let msg = format!("`{a}` is not an axis (read: x, y, diagonal, smaller, larger)");
                    return Err(cx.err(&format!("{key}.fov_axis"), msg));
                }
            };
            let tan = [tx, tx / aspect];
            if !tan.iter().all(|t| t.is_finite() && *t > 0.0 && *t < 1e6) {
                let msg = format!("with this texture's proportions ({aspect}) the rectangle's half-widths are {tan:?}");
                return Err(cx.err(&format!("{key}.fov"), msg));
            }
            let mut spot = Spot::projector(axis, up, tan);
            spot.texture = t;
            let intensity = cx.colour(&format!("{key}.irradiance"), irradiance.unwrap_or([1.0; 3]), None)?;
            points.push(PointLight { position, intensity, spot: Some(spot) });
        }
        LightSpec::Sphere { center, radius, power, radiance } => {
            let r = cx.positive(&format!("{key}.radius"), *radius)?;
            let area = 4.0 * std::f32::consts::PI * r * r;
            let emission = radiance_of(cx, key, power, radiance, area)?;
            let geometry =
                Geometry::Sphere { center: Vec3::from_array(*center), radius: r, frame: None, inward: false };
            shapes.push(light_shape(geometry, emission));
        }
        LightSpec::Quad { corner, edge_u, edge_v, power, radiance } => {
            let (eu, ev) = (Vec3::from_array(*edge_u), Vec3::from_array(*edge_v));
            let area = eu.cross(ev).length();
            if area == 0.0 {
                return Err(cx.err(&format!("{key}.edge_u"), "the quad light has zero area"));
            }
            let emission = radiance_of(cx, key, power, radiance, area)?;
            let geometry = Geometry::Mesh(mesh::quad(Vec3::from_array(*corner), eu, ev));
            shapes.push(light_shape(geometry, emission));
        }
        LightSpec::Constant { .. } | LightSpec::Envmap { .. } | LightSpec::Distant { .. } => {
            unreachable!("built in build()")
        }
    }
    Ok(())
}

/// Most power (W, any channel) a scene's lights may emit in all: photon powers, flux sums and pixel
/// values are f32, and a light brighter than this leaves no headroom for them.
const MAX_POWER: f64 = 1e30;

/// Refuses lights whose power overflows f32 or whose total exceeds `MAX_POWER`, naming the brightest:
/// two point lights of 3e38 W each, or a sky around a scene stretched over 1e20 units (a light at
/// infinity emits its radiance times the area of the scene's bounding disc), would turn into NaN.
/// `keys`: the file's key of each light at infinity and point light, in `Lights` order; `specs` the
/// file's shapes (to name the mesh file of the shape that stretches the scene); `env_file`, the
/// environment's image, if it has one.
fn check_power(
    cx: &Ctx,
    scene: &Scene,
    keys: &[String],
    specs: &[ShapeSpec],
    env_file: Option<&str>,
) -> Result<(), SceneError> {
    let lights = &scene.lights;
    let total: f64 = lights.power.iter().map(|p| p.max_element() as f64).sum();
    if total <= MAX_POWER {
        return Ok(());
    }
    let (i, p) =
        lights.power.iter().enumerate().max_by(|a, b| a.1.max_element().total_cmp(&b.1.max_element())).unwrap();
    let mut key =
        keys.get(i).cloned().or_else(|| lights.list[i].shape().map(|s| scene.shapes[s as usize].name.clone()));
    // An environment's image: its texels are the likelier culprit (a damaged file), so it is named.
    let env_image = env_file.filter(|_| matches!(lights.list[i], LightKind::Env));
    if env_image.is_some() {
        key = key.map(|k| format!("{k}.file"));
    }
    let texture = lights.list[i].shape().and_then(|s| scene.shapes[s as usize].emission_texture);
    let why = if let Some(crate::scene::texture::Texture::Bitmap { file, .. }) =
        texture.map(|t| &scene.textures[t as usize])
    {
        format!(" (its radiance is read from {file}: are its texels right?)")
    } else if lights.list[i].at_infinity() {
        let reach = farthest_shape(scene).map_or(String::new(), |k| {
            let name = &scene.shapes[k].name;
            let index = name.strip_prefix("shapes[").and_then(|r| r.strip_suffix(']')?.parse::<usize>().ok());
            match index.and_then(|i| specs.get(i)) {
                Some(ShapeSpec::Mesh { file, .. }) => format!(", reached by {name} ({file})"),
                _ => format!(", reached by {name}"),
            }
        });
        let radius = 0.5 * (scene.bounds.1.as_dvec3() - scene.bounds.0.as_dvec3()).length();
        match env_image {
            Some(file) => format!(
                " (its radiance is read from {file}, and a light at infinity emits it times the area of the \
                 scene's bounding disc, here of radius {radius:.3e}{reach}: are the image's texels right, and \
                 the shapes within about 1e12 of one another?)"
            ),
            None => format!(
                " (a light at infinity emits its radiance times the area of the scene's bounding disc, here of \
                 radius {radius:.3e}{reach}: keep the shapes within about 1e12 of one another)"
            ),
        }
    } else {
        String::new()
    };
    Err(cx.err(
        &key.unwrap_or_else(|| "lights".into()),
        format!("emits {:.3e} W{why}; the lights may emit at most {MAX_POWER:e} W in all", p.max_element()),
    ))
}

/// The shape reaching farthest from the camera (where the scene's content is): the one to name when a
/// scene is stretched too far.
fn farthest_shape(scene: &Scene) -> Option<usize> {
    let eye = scene.camera.origin.as_dvec3();
    let reach = |shape: &Shape| {
        let (lo, hi) = shape.geometry.bounds();
        (lo.as_dvec3() - eye).abs().max((hi.as_dvec3() - eye).abs()).max_element()
    };
    let reaches = scene.shapes.iter().map(reach).enumerate().filter(|(_, r)| r.is_finite());
    reaches.max_by(|a, b| a.1.total_cmp(&b.1)).map(|(k, _)| k)
}

/// An environment light (`Lights::build` places it around the scene).
fn build_env(cx: &Ctx, key: &str, spec: &LightSpec, dir: &Path) -> Result<EnvLight, SceneError> {
    let (scale, image, to_local) = match spec {
        LightSpec::Constant { radiance } => {
            (cx.colour(&format!("{key}.radiance"), *radiance, None)?, None, Mat3::IDENTITY)
        }
        LightSpec::Envmap { file, scale, transform } => {
            if !(scale.is_finite() && *scale >= 0.0) {
                return Err(cx.err(&format!("{key}.scale"), format!("must be ≥ 0, got {scale}")));
            }
            let m = Mat3::from_mat4(transform_matrix(key, transform, cx.shown)?);
            if (m * m.transpose() - Mat3::IDENTITY).to_cols_array().iter().any(|v| v.abs() > 1e-3)
                || m.determinant() < 0.0
            {
                return Err(cx.err(&format!("{key}.transform"), "an environment may only be rotated"));
            }
            let path = dir.join(file);
            let (w, h, texels) = load_image(&path, false)
                .map_err(|e| cx.err(&format!("{key}.file"), format!("{}: {e}", path.display())))?;
            if texels.iter().any(|t| t.min_element() < 0.0) {
                return Err(cx.err(&format!("{key}.file"), format!("{}: has negative texels", path.display())));
            }
            (Rgb::splat(*scale), Some(EnvImage::new(w, h, texels)), m.transpose())
        }
        _ => unreachable!("not an environment light"),
    };
    Ok(EnvLight { scale, image, to_local })
}

fn scene_bounds(shapes: &[Shape], points: &[PointLight]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for s in shapes {
        match &s.geometry {
            Geometry::Mesh(m) => {
                for p in &m.positions {
                    lo = lo.min(*p);
                    hi = hi.max(*p);
                }
            }
            Geometry::Sphere { center, radius, .. } => {
                lo = lo.min(*center - Vec3::splat(*radius));
                hi = hi.max(*center + Vec3::splat(*radius));
            }
        }
    }
    for p in points {
        lo = lo.min(p.position);
        hi = hi.max(p.position);
    }
    if lo.x > hi.x {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (lo, hi)
    }
}
