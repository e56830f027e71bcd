//! Typed reading of a Mitsuba element's properties (`<float name=…>`, `<rgb>`, `<transform>` …), with
//! every child that no reader asked for reported as unsupported, so nothing is silently ignored.
use super::spectrum;
use super::xml::Node;
use crate::scene::SceneError;
use glam::{Mat4, Vec3};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

thread_local! {
    /// What reading this thread's scene found worth a warning (spectra clipped into sRGB's gamut).
    static NOTES: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) };
    /// The folder of the scene this thread is reading, where a file name not found beside the file that
    /// names it is looked for (as Mitsuba's file resolver does).
    static BASE: RefCell<PathBuf> = const { RefCell::new(PathBuf::new()) };
}

/// Starts reading a scene in `base`: clears the warnings of any earlier one.
pub fn begin(base: &Path) {
    BASE.with(|b| *b.borrow_mut() = base.to_path_buf());
    take_notes();
}

/// Takes the warnings gathered since `begin` or the last call (see `NOTES`).
pub fn take_notes() -> Vec<String> {
    NOTES.with(|w| std::mem::take(&mut *w.borrow_mut()))
}

/// A colour-valued property: a constant, an inline `<texture>`, or `<ref id>` to one.
pub enum ColourProp<'a> {
    Rgb([f32; 3]),
    Texture(&'a Node),
    Ref(&'a Node, String),
}

pub struct Props<'a> {
    pub node: &'a Node,
    used: RefCell<Vec<bool>>,
}

impl<'a> Props<'a> {
    pub fn new(node: &'a Node) -> Self {
        Props { node, used: RefCell::new(vec![false; node.children.len()]) }
    }

    fn take(&self, name: &str) -> Option<&'a Node> {
        let i = self.node.children.iter().position(|c| c.attr("name") == Some(name) && c.tag != "default")?;
        self.used.borrow_mut()[i] = true;
        Some(&self.node.children[i])
    }

    /// Nested objects of a kind (`bsdf`, `emitter`, `film`, `ref` …) that are not named properties.
    pub fn objects(&self, tag: &str) -> Vec<&'a Node> {
        self.objects_of(&[tag])
    }

    /// The children with any of `tags` that are objects, not named properties, in the order written.
    /// A nested `<bsdf>`, `<emitter>`, `<shape>`, `<film>`, `<sampler>` or `<rfilter>` is one whatever
    /// its `name`: Mitsuba gathers nested objects by kind and the name only labels them, and exporters
    /// write one (Blender's: `<bsdf type="principled" name="bsdf">`, `<film name="film">`). A `<ref>`
    /// is one unnamed or named `bsdf`; under other names it is a property (a texture's, a medium's).
    pub fn objects_of(&self, tags: &[&str]) -> Vec<&'a Node> {
        let mut used = self.used.borrow_mut();
        let mut out = Vec::new();
        for (i, c) in self.node.children.iter().enumerate() {
            let object = match c.tag.as_str() {
                "ref" => c.attr("name").is_none() || c.attr("name") == Some("bsdf"),
                _ => true,
            };
            if tags.contains(&c.tag.as_str()) && !used[i] && object {
                used[i] = true;
                out.push(c);
            }
        }
        out
    }

    /// The children not read yet, named or not, for which `f` holds, in the order written (a
    /// `bumpmap`'s texture, whatever its name).
    pub fn children_where(&self, f: impl Fn(&'a Node) -> bool) -> Vec<&'a Node> {
        let mut used = self.used.borrow_mut();
        let mut out = Vec::new();
        for (i, c) in self.node.children.iter().enumerate() {
            if !used[i] && c.tag != "default" && f(c) {
                used[i] = true;
                out.push(c);
            }
        }
        out
    }

    fn value(n: &Node) -> Result<&str, SceneError> {
        n.attr("value").ok_or_else(|| n.error("needs a `value` attribute"))
    }

    pub fn numbers(n: &Node, s: &str) -> Result<Vec<f32>, SceneError> {
        s.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| match t.parse::<f32>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(n.error(format!("`{t}` is not a finite number"))),
            })
            .collect()
    }

    pub fn float(&self, name: &str) -> Result<Option<f32>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        if n.tag != "float" && n.tag != "integer" {
            return Err(n.error(format!("`{name}` must be a <float>")));
        }
        match Self::numbers(n, Self::value(n)?)?[..] {
            [x] => Ok(Some(x)),
            _ => Err(n.error("expected one number")),
        }
    }

    pub fn int(&self, name: &str) -> Result<Option<i64>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        let v = Self::value(n)?;
        if n.tag != "integer" {
            return Err(n.error(format!("`{name}` must be an <integer>")));
        }
        v.trim().parse().map(Some).map_err(|_| n.error(format!("`{v}` is not an integer")))
    }

    pub fn boolean(&self, name: &str) -> Result<Option<bool>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        // Mitsuba reads the two words in any case ("True", as Python writers put it), nothing else.
        match (n.tag.as_str(), Self::value(n)?.trim().to_ascii_lowercase().as_str()) {
            ("boolean", "true") => Ok(Some(true)),
            ("boolean", "false") => Ok(Some(false)),
            _ => Err(n.error(format!("`{name}` must be <boolean value=\"true\"> or \"false\""))),
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<String>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        if n.tag != "string" {
            return Err(n.error(format!("`{name}` must be a <string>")));
        }
        Ok(Some(Self::value(n)?.to_string()))
    }

    /// A float or a named constant (e.g. `int_ior` as 1.5 or "bk7").
    pub fn float_or_name(&self, name: &str, named: impl Fn(&str) -> Option<f32>) -> Result<Option<f32>, SceneError> {
        let Some(n) = self.node.children.iter().find(|c| c.attr("name") == Some(name)) else { return Ok(None) };
        if n.tag == "string" {
            let s = self.string(name)?.unwrap_or_default();
            return named(&s).map(Some).ok_or_else(|| n.error(format!("unknown name `{s}`")));
        }
        self.float(name)
    }

    pub fn point(&self, name: &str) -> Result<Option<[f32; 3]>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        if n.tag != "point" && n.tag != "vector" {
            return Err(n.error(format!("`{name}` must be a <point>")));
        }
        Ok(Some(xyz(n, 0.0)?))
    }

    /// A colour: `<rgb>`, `<spectrum>` with one value, `<float>`, 0.6's `<srgb>`, or a texture.
    pub fn colour(&self, name: &str) -> Result<Option<ColourProp<'a>>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        let rgb = |v: Vec<f32>| match v[..] {
            [x] => Ok([x, x, x]),
            [r, g, b] => Ok([r, g, b]),
            _ => Err(n.error("expected one or three numbers")),
        };
        Ok(Some(match n.tag.as_str() {
            "rgb" | "float" => ColourProp::Rgb(rgb(Self::numbers(n, Self::value(n)?)?)?),
            "spectrum" => ColourProp::Rgb(self.spectrum(n, name)?),
            "srgb" => ColourProp::Rgb(srgb(n, Self::value(n)?)?),
            "texture" if n.attr("type") == Some("srgb") => ColourProp::Rgb(srgb_texture(n)?),
            "texture" => ColourProp::Texture(n),
            "ref" => ColourProp::Ref(n, n.attr("id").ok_or_else(|| n.error("needs an `id`"))?.to_string()),
            // A medium's constant volume (Mitsuba's `constvolume`): its `value`, one number or a colour.
            "volume" if self.node.tag == "medium" && n.attr("type") == Some("constvolume") => {
                let inner = Props::new(n);
                let value = inner.colour("value")?.ok_or_else(|| n.error("a `constvolume` needs its `value`"))?;
                inner.finish("value")?;
                match value {
                    ColourProp::Rgb(c) => ColourProp::Rgb(c),
                    ColourProp::Texture(t) | ColourProp::Ref(t, _) => {
                        return Err(t.error("a constvolume's `value` must be <rgb>, <spectrum> or <float>"))
                    }
                }
            }
            "volume" if self.node.tag == "medium" => {
                return Err(n.error(format!(
                    "volume type `{}` is not read (read: constvolume; a medium that varies in space, \
                     `gridvolume`, is not rendered)",
                    n.attr("type").unwrap_or("")
                )))
            }
            _ => return Err(n.error(format!("`{name}` must be <rgb>, <spectrum>, <float> or a <texture>"))),
        }))
    }

    /// A `<spectrum>` as the colour Mitsuba 3's RGB variants give it (see `spectrum`): one value,
    /// `wavelength:value` pairs, a `.spd` file of them (`filename`, beside the file that names it or
    /// else the scene), or the plugins `d65` (its `color`, times `scale`), `srgb` (`color`) and
    /// `uniform` (`value`).
    fn spectrum(&self, n: &Node, name: &str) -> Result<[f32; 3], SceneError> {
        let in_emitter = self.node.tag == "emitter";
        if let Some(kind) = n.attr("type") {
            return spectrum_plugin(n, kind);
        }
        let (pairs, from) = match (n.attr("value"), n.attr("filename")) {
            (Some(v), None) => {
                let tokens: Vec<&str> =
                    v.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect();
                if let [one] = tokens[..] {
                    if !one.contains(':') {
                        return Ok(spectrum::constant(Self::numbers(n, one)?[0], name, in_emitter));
                    }
                }
                let pairs = tokens
                    .iter()
                    .map(|t| match t.split_once(':') {
                        Some((w, x)) => Ok((Self::numbers(n, w)?, Self::numbers(n, x)?)),
                        None => Err(n.error(format!("`{t}`: expected one value or wavelength:value pairs"))),
                    })
                    .map(|r| match r? {
                        (w, x) if w.len() == 1 && x.len() == 1 => Ok((w[0], x[0])),
                        _ => Err(n.error("expected one value or wavelength:value pairs")),
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                (pairs, String::new())
            }
            (None, Some(f)) => {
                let own = n.dir().join(f);
                let path = if own.exists() { own } else { BASE.with(|b| b.borrow().join(f)) };
                (read_spd(n, &path)?, format!(" in {}", path.display()))
            }
            _ => return Err(n.error("needs one of `value` and `filename`")),
        };
        if pairs.len() < 2 {
            return Err(n.error(format!("a sampled spectrum needs at least two wavelength:value pairs{from}")));
        }
        if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
            return Err(n.error(format!("wavelengths must increase ({} nm after {} nm{from})", w[1].0, w[0].0)));
        }
        let (c, clipped) = spectrum::sampled(&pairs, name, in_emitter);
        if clipped {
            let msg = format!("out of sRGB's gamut, clipped to ({}, {}, {}) as Mitsuba clips it", c[0], c[1], c[2]);
            NOTES.with(|w| w.borrow_mut().push(n.error(msg).to_string()));
        }
        Ok(c)
    }

    /// A constant colour: as `colour`, but a texture here is refused (parameters that take one use `colour`).
    pub fn rgb(&self, name: &str) -> Result<Option<[f32; 3]>, SceneError> {
        match self.colour(name)? {
            None => Ok(None),
            Some(ColourProp::Rgb(c)) => Ok(Some(c)),
            Some(ColourProp::Texture(n) | ColourProp::Ref(n, _)) => Err(n.error(format!(
                "a textured `{name}` is not supported (textures are read on a reflectance, a conductor's \
                     specular_reflectance, a dielectric's specular_transmittance, a rough conductor's or \
                     dielectric's alpha, a blend's weight and a mask's opacity)"
            ))),
        }
    }

    /// A `<transform name=…>` as one matrix (each operation applied after the ones before it).
    pub fn transform(&self, name: &str) -> Result<Option<Mat4>, SceneError> {
        let Some(n) = self.take(name) else { return Ok(None) };
        if n.tag != "transform" {
            return Err(n.error(format!("`{name}` must be a <transform>")));
        }
        let mut m = Mat4::IDENTITY;
        for op in &n.children {
            m = op_matrix(op)? * m;
        }
        if !m.is_finite() || crate::scene::load::degenerate(&m) {
            return Err(n.error("is degenerate (zero scale or not finite)"));
        }
        Ok(Some(m))
    }

    /// Refuses every child no reader took, naming it and what `supported` lists.
    pub fn finish(&self, supported: &str) -> Result<(), SceneError> {
        let used = self.used.borrow();
        match self.node.children.iter().enumerate().find(|(i, _)| !used[*i]) {
            None => Ok(()),
            Some((_, c)) => Err(c.error(format!(
                "not supported inside {} (line {}); supported here: {supported}",
                self.node.describe(),
                self.node.line
            ))),
        }
    }
}

/// `<texture type="srgb">`: Mitsuba 3's constant colour (`color`, what an `<rgb>` becomes), within
/// [0, 1] unless `unbounded`, as Mitsuba checks it.
pub fn srgb_texture(n: &Node) -> Result<[f32; 3], SceneError> {
    let p = Props::new(n);
    let c = p.rgb("color")?.ok_or_else(|| n.error("<texture type=\"srgb\"> needs a `color`"))?;
    let unbounded = p.boolean("unbounded")?.unwrap_or(false);
    p.finish("color, unbounded")?;
    if !unbounded && c.iter().any(|v| !(0.0..=1.0).contains(v)) {
        return Err(
            n.error(format!("color {c:?} must lie in [0, 1] (Mitsuba refuses it too) unless `unbounded` is true"))
        );
    }
    Ok(c)
}

/// `<spectrum type="…">`: the plugins that have a colour in Mitsuba 3's RGB variants.
fn spectrum_plugin(n: &Node, kind: &str) -> Result<[f32; 3], SceneError> {
    let p = Props::new(n);
    let c = match kind {
        "uniform" => [p.float("value")?.unwrap_or(1.0); 3],
        "d65" | "srgb" => {
            let c = match p.rgb("color")? {
                Some(c) => c,
                None if kind == "d65" => [1.0; 3],
                None => return Err(n.error("<spectrum type=\"srgb\"> needs a `color`")),
            };
            let scale = if kind == "d65" { p.float("scale")?.unwrap_or(1.0) } else { 1.0 };
            c.map(|v| v * scale)
        }
        "blackbody" => {
            return Err(n.error("a blackbody spectrum is not read (Mitsuba 3 reads it only in its spectral variants)"))
        }
        _ => return Err(n.error(format!("spectrum type `{kind}` is not read (read: d65, srgb, uniform)"))),
    };
    p.finish(if kind == "uniform" {
        "value"
    } else if kind == "d65" {
        "color, scale"
    } else {
        "color"
    })?;
    if c.iter().any(|v| *v < 0.0) {
        return Err(n.error("is negative"));
    }
    Ok(c)
}

/// A `.spd` file: one `wavelength value` pair a line, `#` comments; named relative to the element's file.
fn read_spd(n: &Node, path: &Path) -> Result<Vec<(f32, f32)>, SceneError> {
    let text = crate::scene::read_text(path)
        .map_err(|e| n.error(format!("cannot read spectrum file {}: {e}", path.display())))?;
    let mut pairs = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or_default();
        let at = |msg: &str| n.error(format!("{}: line {}: {msg}", path.display(), i + 1));
        let nums: Vec<f32> = line
            .split_whitespace()
            .map(|t| {
                t.parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| at(&format!("`{t}` is not a finite number")))
            })
            .collect::<Result<_, _>>()?;
        match nums[..] {
            [] => {}
            [w, v] => pairs.push((w, v)),
            _ => return Err(at("expected `wavelength value`")),
        }
    }
    Ok(pairs)
}

fn srgb(n: &Node, v: &str) -> Result<[f32; 3], SceneError> {
    let enc = if let Some(hex) = v.trim().strip_prefix('#') {
        let c = u32::from_str_radix(hex, 16).ok().filter(|_| hex.len() == 6).ok_or_else(|| n.error("bad #rrggbb"))?;
        [(c >> 16) as f32 / 255.0, ((c >> 8) & 255) as f32 / 255.0, (c & 255) as f32 / 255.0]
    } else {
        match Props::numbers(n, v)?[..] {
            [r, g, b] => [r, g, b],
            [x] => [x; 3],
            _ => return Err(n.error("expected #rrggbb or three numbers")),
        }
    };
    Ok(enc.map(crate::color::srgb_decode))
}

/// `x`, `y`, `z` attributes (missing ones `default`) or one `value="x, y, z"` (one number: all three).
fn xyz(n: &Node, default: f32) -> Result<[f32; 3], SceneError> {
    if let Some(v) = n.attr("value") {
        return match Props::numbers(n, v)?[..] {
            [x] => Ok([x; 3]),
            [x, y, z] => Ok([x, y, z]),
            _ => Err(n.error("expected one or three numbers")),
        };
    }
    let get = |k: &str| {
        n.attr(k).map_or(Ok(default), |s| Props::numbers(n, s).map(|v| v.first().copied().unwrap_or(default)))
    };
    Ok([get("x")?, get("y")?, get("z")?])
}

fn vec_attr(n: &Node, key: &str) -> Result<Vec3, SceneError> {
    let s = n.attr(key).ok_or_else(|| n.error(format!("needs `{key}`")))?;
    match Props::numbers(n, s)?[..] {
        [x, y, z] => Ok(Vec3::new(x, y, z)),
        _ => Err(n.error(format!("`{key}` needs three numbers"))),
    }
}

/// The first axis of Mitsuba's `coordinate_system(n)` for the unit `n` of `d` (Duff et al. 2017, "Building
/// an orthonormal basis, revisited"): what a `lookat` without `up` takes as its up.
fn basis_up(d: glam::DVec3) -> Vec3 {
    let n = d.normalize_or_zero();
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    glam::DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x).as_vec3()
}

fn op_matrix(op: &Node) -> Result<Mat4, SceneError> {
    Ok(match op.tag.as_str() {
        "translate" => Mat4::from_translation(Vec3::from_array(xyz(op, 0.0)?)),
        "scale" => Mat4::from_scale(Vec3::from_array(xyz(op, 1.0)?)),
        "rotate" => {
            let axis = match op.attr("axis").or(op.attr("value")) {
                Some(_) => vec_attr(op, if op.attr("axis").is_some() { "axis" } else { "value" })?,
                None => Vec3::from_array(xyz(op, 0.0)?),
            };
            let angle: f32 = op
                .attr("angle")
                .and_then(|a| a.trim().parse().ok())
                .ok_or_else(|| op.error("needs a numeric `angle` (degrees)"))?;
            if axis.length() == 0.0 {
                return Err(op.error("the rotation axis is zero"));
            }
            Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
        }
        "matrix" => {
            let v = Props::numbers(op, op.attr("value").ok_or_else(|| op.error("needs `value`"))?)?;
            match v.len() {
                16 => Mat4::from_cols_slice(&v).transpose(),
                9 => Mat4::from_mat3(glam::Mat3::from_cols_slice(&v).transpose()),
                n => return Err(op.error(format!("needs 16 (or 9) numbers, got {n}"))),
            }
        }
        "lookat" => {
            let (o, t) = (vec_attr(op, "origin")?, vec_attr(op, "target")?);
            let dir = (t - o).normalize_or_zero();
            // Without `up`, Mitsuba's: the first axis of its `coordinate_system` of the view direction
            // (Duff et al.'s orthonormal basis, in f64 as Mitsuba's parser takes it), not +y.
            let up = if op.attr("up").is_some() { vec_attr(op, "up")? } else { basis_up((t - o).as_dvec3()) };
            let left = up.cross(dir).normalize_or_zero();
            if dir == Vec3::ZERO || left == Vec3::ZERO {
                return Err(op.error("origin equals target, or up is parallel to the view"));
            }
            let new_up = dir.cross(left);
            Mat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), o.extend(1.0))
        }
        _ => return Err(op.error("not a transform operation (translate, rotate, scale, matrix, lookat)")),
    })
}
