//! Textures a diffuse reflectance can read per hit: a procedural checkerboard and bitmaps (`load_image`:
//! 8/16-bit formats decoded from sRGB, float ones linear), both through a 2-D affine `to_uv` map. A
//! checkerboard's squares may be other textures, read at the hit's own uv (through their own maps), as
//! Mitsuba reads a `<texture>` nested in a checkerboard.
//!
//! ```toml
//! [textures]
//! checks = { type = "checkerboard", color0 = [0.8, 0.8, 0.8], color1 = [0.1, 0.1, 0.1], scale = [8.0, 8.0] }
//! wood   = { type = "bitmap", file = "assets/wood.jpg" }
//! inlay  = { type = "checkerboard", color0 = "wood", color1 = [0.1, 0.1, 0.1], scale = [4.0, 4.0] }
//!
//! [materials]
//! floor = { type = "diffuse", reflectance = "checks" }
//! ```
use crate::color::Rgb;
use glam::Vec2;
use std::path::Path;
use std::sync::Arc;

/// Largest bitmap accepted (texels), so a hostile header cannot ask for unbounded memory.
pub const MAX_TEXELS: u64 = 1 << 28;

#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// color0 where both of frac(u), frac(v) are on the same side of ½ (Mitsuba's convention), else color1.
    Checkerboard { color0: Patch, color1: Patch, to_uv: UvMap },
    /// Linear RGB texels, row 0 at v = 0; bilinear (or nearest) lookup with texel centres at (i + ½)/size,
    /// texels beyond the edges read as `wrap` says.
    Bitmap { file: String, width: u32, height: u32, texels: Vec<Rgb>, to_uv: UvMap, bilinear: bool, wrap: Wrap },
    /// The hit mesh's vertex colours, interpolated, or its triangle's colour, times `scale` (Mitsuba's
    /// `mesh_attribute` `vertex_color` and `face_color`). It needs the hit, not its uv: the scene reads
    /// it (`Scene::texture_at`); `eval` alone gives `scale` (white), and the loader checks the colours of
    /// every mesh that reads it lie in [0, 1], the bounds `min_value` and `max_value` give.
    MeshColor { of: MeshColors, scale: f32 },
}

/// What a checkerboard's squares of one kind show: a colour, or another texture read at the same uv
/// (never mesh colours: the loader refuses them there, as `eval` has no hit to read them at).
#[derive(Clone, Debug, PartialEq)]
pub enum Patch {
    Colour(Rgb),
    Texture(Arc<Texture>),
}

impl From<Rgb> for Patch {
    fn from(c: Rgb) -> Patch {
        Patch::Colour(c)
    }
}

impl Patch {
    fn eval(&self, uv: Vec2) -> Rgb {
        match self {
            Patch::Colour(c) => *c,
            Patch::Texture(t) => t.eval(uv),
        }
    }

    fn mean(&self) -> Rgb {
        match self {
            Patch::Colour(c) => *c,
            Patch::Texture(t) => t.mean(),
        }
    }

    fn min_value(&self) -> f32 {
        match self {
            Patch::Colour(c) => c.min_element(),
            Patch::Texture(t) => t.min_value(),
        }
    }

    fn max_value(&self) -> f32 {
        match self {
            Patch::Colour(c) => c.max_element(),
            Patch::Texture(t) => t.max_value(),
        }
    }

    fn hash_into(&self, h: &mut sha2::Sha256) {
        use sha2::Digest;
        match self {
            Patch::Colour(c) => h.update(format!("colour {c:?}")),
            Patch::Texture(t) => {
                h.update("texture");
                t.hash_into(h);
            }
        }
    }
}

/// Which colours of a mesh a `MeshColor` texture reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshColors {
    /// Its vertices', interpolated across each triangle.
    Vertex,
    /// Its triangles' own, one each.
    Face,
}

impl MeshColors {
    /// The texture's name in a scene file (and Mitsuba's attribute name).
    pub fn name(self) -> &'static str {
        match self {
            MeshColors::Vertex => "vertex_color",
            MeshColors::Face => "face_color",
        }
    }
}

/// Which texel an index beyond a bitmap's edge reads (Mitsuba's `wrap_mode`): the image repeated,
/// its edge texels stretched out, or the image mirrored at each edge (period twice its size).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Wrap {
    #[default]
    Repeat,
    Clamp,
    Mirror,
}

impl Wrap {
    /// Texel index `i` of a row or column of `n` texels, brought into [0, n).
    pub fn index(self, i: i64, n: i64) -> i64 {
        match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }
    }
}

/// uv' = (a·u + b·v + c, d·u + e·v + f).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMap(pub [f32; 6]);

impl Default for UvMap {
    fn default() -> Self {
        UvMap([1.0, 0.0, 0.0, 0.0, 1.0, 0.0])
    }
}

impl UvMap {
    /// Scale, then offset: uv' = uv · scale + offset.
    pub fn scale_offset(scale: [f32; 2], offset: [f32; 2]) -> Self {
        UvMap([scale[0], 0.0, offset[0], 0.0, scale[1], offset[1]])
    }
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let m = &self.0;
        Vec2::new(m[0] * uv.x + m[1] * uv.y + m[2], m[3] * uv.x + m[4] * uv.y + m[5])
    }
}

impl Texture {
    pub fn eval(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Checkerboard { color0, color1, to_uv } => {
                let t = to_uv.apply(uv);
                let (fu, fv) = (t.x - t.x.floor(), t.y - t.y.floor());
                if (fu > 0.5) == (fv > 0.5) {
                    color0.eval(uv)
                } else {
                    color1.eval(uv)
                }
            }
            Texture::Bitmap { width, height, texels, to_uv, bilinear, wrap, .. } => {
                let t = to_uv.apply(uv);
                let at = wrapped(texels, *width, *height, *wrap);
                let (x, y) = (t.x * *width as f32, t.y * *height as f32);
                if !(x.is_finite() && y.is_finite()) {
                    return Rgb::ZERO;
                }
                if !*bilinear {
                    return at(x.floor() as i64, y.floor() as i64);
                }
                self::bilinear(x - 0.5, y - 0.5, at)
            }
            Texture::MeshColor { scale, .. } => Rgb::splat(*scale),
        }
    }

    /// The gradient (∂/∂u, ∂/∂v) of the texture's value read as one number (its luminance, Mitsuba's
    /// `eval_1`) at `uv`, as Mitsuba's `eval_1_grad` gives it to a bump map: a bilinear bitmap's
    /// interpolant differentiated within the texel cell `uv` falls in, through `to_uv`; zero for nearest
    /// lookup (a step function's gradient almost everywhere). None for a checkerboard or mesh colours,
    /// which Mitsuba 3.9 cannot differentiate either. (Mitsuba 3.9.1 scales by the image's size after
    /// `to_uv`'s transposed matrix, not before: the same for a square image or a `to_uv` without rotation
    /// or shear, another number otherwise; caustica's is the derivative of what it evaluates.)
    pub fn gradient(&self, uv: Vec2) -> Option<Vec2> {
        let Texture::Bitmap { width, height, texels, to_uv, bilinear, wrap, .. } = self else { return None };
        let t = to_uv.apply(uv);
        let (w, h) = (*width as f32, *height as f32);
        let (x, y) = (t.x * w - 0.5, t.y * h - 0.5);
        if !(*bilinear && x.is_finite() && y.is_finite()) {
            return Some(Vec2::ZERO);
        }
        let texel = wrapped(texels, *width, *height, *wrap);
        let at = |x: i64, y: i64| crate::scene::material::mitsuba_luminance(texel(x, y));
        let ((x0, y0), (fx, fy)) = cell(x, y);
        let [f00, f10, f01, f11] = [at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1)];
        // Per unit of the texture's own coordinates (a texel is 1/width of u).
        let gx = ((f10 - f00) * (1.0 - fy) + (f11 - f01) * fy) * w;
        let gy = ((f01 - f00) * (1.0 - fx) + (f11 - f10) * fx) * h;
        let m = &to_uv.0;
        Some(Vec2::new(m[0] * gx + m[3] * gy, m[1] * gx + m[4] * gy))
    }

    /// Feeds what the texture is into a scene's content hash.
    pub fn hash_into(&self, h: &mut sha2::Sha256) {
        use sha2::Digest;
        match self {
            Texture::Checkerboard { color0, color1, to_uv } => {
                h.update(format!("checkerboard {to_uv:?}"));
                color0.hash_into(h);
                color1.hash_into(h);
            }
            Texture::MeshColor { .. } => h.update(format!("{self:?}")),
            Texture::Bitmap { width, height, texels, to_uv, bilinear, wrap, .. } => {
                h.update(format!("bitmap {width} {height} {to_uv:?} {bilinear} {wrap:?}"));
                crate::scene::hash_vec3s(h, texels);
            }
        }
    }

    /// Mean value over the texture (a checkerboard's two colours equally, as Mitsuba's `mean` has it, also
    /// where they are textures; a bitmap's texels), in double precision.
    pub fn mean(&self) -> Rgb {
        match self {
            Texture::Checkerboard { color0, color1, .. } => (color0.mean() + color1.mean()) * 0.5,
            Texture::Bitmap { texels, .. } => {
                let sum =
                    texels.iter().fold([0.0f64; 3], |a, t| [a[0] + t.x as f64, a[1] + t.y as f64, a[2] + t.z as f64]);
                let n = texels.len().max(1) as f64;
                Rgb::new((sum[0] / n) as f32, (sum[1] / n) as f32, (sum[2] / n) as f32)
            }
            // Not read on emitters (refused there); the middle of its range.
            Texture::MeshColor { scale, .. } => Rgb::splat(0.5 * scale),
        }
    }

    /// Smallest value any channel of the texture takes (an emitter's must stay ≥ 0).
    pub fn min_value(&self) -> f32 {
        match self {
            Texture::Checkerboard { color0, color1, .. } => color0.min_value().min(color1.min_value()),
            Texture::Bitmap { texels, .. } => texels.iter().map(|t| t.min_element()).fold(f32::INFINITY, f32::min),
            Texture::MeshColor { scale, .. } => scale.min(0.0),
        }
    }

    /// Largest value the texture takes (a reflectance must stay ≤ 1).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Checkerboard { color0, color1, .. } => color0.max_value().max(color1.max_value()),
            Texture::Bitmap { texels, .. } => texels.iter().map(|t| t.max_element()).fold(0.0, f32::max),
            Texture::MeshColor { scale, .. } => scale.max(0.0),
        }
    }
}

/// Bilinear interpolation at continuous texel coordinates (x, y), texel (i, j) sitting at (i, j); `at`
/// reads a texel and decides how indices outside the image wrap or clamp.
pub fn bilinear(x: f32, y: f32, at: impl Fn(i64, i64) -> Rgb) -> Rgb {
    let ((x0, y0), (fx, fy)) = cell(x, y);
    (at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx) * (1.0 - fy)
        + (at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx) * fy
}

/// The texel cell continuous texel coordinates (x, y) fall in (texel (i, j) sitting at (i, j)): its
/// lower corner and the fractions of the way across it.
fn cell(x: f32, y: f32) -> ((i64, i64), (f32, f32)) {
    let (x0, y0) = (x.floor(), y.floor());
    ((x0 as i64, y0 as i64), (x - x0, y - y0))
}

/// A bitmap's texel reader: texel (x, y) of `width` × `height` `texels` (row 0 first), indices beyond
/// the edges brought onto the image as `wrap` says.
fn wrapped(texels: &[Rgb], width: u32, height: u32, wrap: Wrap) -> impl Fn(i64, i64) -> Rgb + '_ {
    let (w, h) = (width as i64, height as i64);
    move |x, y| texels[(wrap.index(y, h) * w + wrap.index(x, w)) as usize]
}

/// Reads an image as linear RGB, row 0 first, as Mitsuba's `Bitmap` reads it: EXR, Radiance RGBE
/// (`.hdr`) and PFM as stored (float formats are linear; a PFM's values times its scale's magnitude);
/// PNG, JPEG, BMP, TGA and PNM (PPM, PGM) decoded from sRGB unless `raw` (then 8/16-bit values are
/// divided by their maximum and kept). Returns (width, height, texels).
pub fn load_image(path: &Path, raw: bool) -> Result<(u32, u32, Vec<Rgb>), String> {
    let name = path.to_string_lossy().to_lowercase();
    if !path.exists() {
        return Err("file not found".into());
    }
    crate::scene::regular_file(path)?;
    let mut head = Vec::with_capacity(6);
    std::fs::File::open(path)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 6), &mut head))
        .map_err(|e| format!("cannot read image: {e}"))?;
    let pfm = head.len() == 6 && matches!(&head[..2], b"PF" | b"Pf") && head[2].is_ascii_whitespace();
    if name.ends_with(".exr") || pfm {
        let (w, h, texels) = if pfm {
            read_pfm(path)?
        } else {
            let (w, h, texels) = crate::output::read_exr_pixels(path)?;
            (w as u32, h as u32, texels)
        };
        if let Some(i) = texels.iter().position(|t| !t.is_finite()) {
            return Err(format!("texel ({}, {}) is not finite", i % w as usize, i / w as usize));
        }
        return Ok((w, h, texels));
    }
    // Radiance files open with `#?RADIANCE` or, from other writers (Mitsuba's among them), `#?RGBE`,
    // which the decoder does not know: such a file is read into memory (RGBE takes about 4 bytes a
    // texel) and its first line made `#?RADIANCE`. Anything else is read from the file as it decodes.
    let rgbe = head == b"#?RGBE";
    let img = if rgbe {
        let len = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
        if len > 5 * MAX_TEXELS {
            return Err(format!("a Radiance file of {len} bytes is larger than any image of {MAX_TEXELS} texels"));
        }
        let mut bytes = std::fs::read(path).map_err(|e| format!("cannot read image: {e}"))?;
        bytes.splice(..6, *b"#?RADIANCE");
        decode_image(path, || Ok(std::io::Cursor::new(&bytes[..])))?
    } else {
        decode_image(path, || std::fs::File::open(path).map(std::io::BufReader::new).map_err(|e| e.to_string()))?
    };
    let (w, h) = (img.width(), img.height());
    // Radiance's RGBE decodes to floats, which are linear light (Mitsuba keeps them as they are).
    let linear = raw || matches!(img, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_));
    let img = img.into_rgb32f();
    let decode = |x: f32| if linear { x } else { crate::color::srgb_decode(x) };
    let texels = img.pixels().map(|p| Rgb::new(decode(p[0]), decode(p[1]), decode(p[2]))).collect();
    Ok((w, h, texels))
}

/// Reads a Portable Float Map as Mitsuba (and pbrt) read one: `PF` (RGB) or `Pf` (grey, read into all
/// three channels), width, height and a scale, separated by white space, one white-space byte, then
/// 32-bit floats row by row from the bottom row up, little-endian if the scale is negative, big-endian
/// otherwise, each multiplied by the scale's magnitude. The header is checked against the file's length
/// before any pixel is read.
fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<Rgb>), String> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| format!("cannot read image: {e}"))?;
    let len = file.metadata().map_err(|e| format!("cannot read image: {e}"))?.len();
    let mut r = std::io::BufReader::new(file);
    let (mut tokens, mut token, mut header_len) = (Vec::<String>::new(), Vec::new(), 0u64);
    while tokens.len() < 4 {
        let mut byte = [0u8];
        if header_len == 256 || r.read_exact(&mut byte).is_err() {
            return Err("PFM header (PF or Pf, width, height, scale) is damaged or incomplete".into());
        }
        header_len += 1;
        if !byte[0].is_ascii_whitespace() {
            token.push(byte[0]);
        } else if !token.is_empty() {
            tokens.push(String::from_utf8_lossy(&std::mem::take(&mut token)).into_owned());
        }
    }
    let channels = if tokens[0] == "PF" { 3 } else { 1 };
    let size = |t: &str, what: &str| match t.parse::<u32>() {
        Ok(v) if v > 0 => Ok(v),
        _ => Err(format!("PFM header's {what} `{t}` is not a positive whole number")),
    };
    let (w, h) = (size(&tokens[1], "width")?, size(&tokens[2], "height")?);
    let scale = match tokens[3].parse::<f32>() {
        Ok(s) if s.is_finite() && s != 0.0 => s,
        _ => return Err(format!("PFM header's scale `{}` is not a finite number other than 0", tokens[3])),
    };
    let texels = w as u64 * h as u64;
    if texels > MAX_TEXELS {
        return Err(format!("{w}×{h} image is larger than {MAX_TEXELS} texels"));
    }
    let bytes = texels * channels * 4;
    if len - header_len < bytes {
        return Err(format!(
            "PFM of {w}×{h} texels needs {bytes} bytes of pixels after its header, the file has {}: truncated?",
            len - header_len
        ));
    }
    let mut data = vec![0u8; bytes as usize];
    r.read_exact(&mut data).map_err(|e| format!("cannot read image: {e}"))?;
    let value = |c: &[u8]| {
        let b = [c[0], c[1], c[2], c[3]];
        scale.abs() * if scale < 0.0 { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) }
    };
    let (w_us, h_us, n) = (w as usize, h as usize, channels as usize);
    let mut out = Vec::with_capacity(texels as usize);
    for row in data.chunks_exact(w_us * n * 4).rev() {
        out.extend(row.chunks_exact(n * 4).map(|t| match n {
            3 => Rgb::new(value(&t[0..4]), value(&t[4..8]), value(&t[8..12])),
            _ => Rgb::splat(value(t)),
        }));
    }
    debug_assert_eq!(out.len(), w_us * h_us);
    Ok((w, h, out))
}

/// Decodes the image `open` reads (by its content, or by `path`'s extension for formats without a
/// signature, TGA), refusing one of more than `MAX_TEXELS` texels before its pixels are decoded.
fn decode_image<R: std::io::BufRead + std::io::Seek>(
    path: &Path,
    open: impl Fn() -> Result<R, String>,
) -> Result<image::DynamicImage, String> {
    const ACCEPTED: &str = "EXR, HDR, PFM, PNG, JPEG, BMP, TGA or PPM accepted";
    let reader = || {
        let mut r = image::ImageReader::new(open()?);
        if let Ok(f) = image::ImageFormat::from_path(path) {
            r.set_format(f);
        }
        r.with_guessed_format().map_err(|e| e.to_string())
    };
    let (w, h) = reader()?.into_dimensions().map_err(|e| format!("cannot read image ({ACCEPTED}): {e}"))?;
    if w as u64 * h as u64 > MAX_TEXELS || w == 0 || h == 0 {
        return Err(format!("{w}×{h} image is empty or larger than {MAX_TEXELS} texels"));
    }
    reader()?.decode().map_err(|e| format!("cannot decode image ({ACCEPTED}): {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_follows_mitsuba_halves_and_scale() {
        let t = Texture::Checkerboard {
            color0: Rgb::ONE.into(),
            color1: Rgb::ZERO.into(),
            to_uv: UvMap::scale_offset([2.0, 2.0], [0.0, 0.0]),
        };
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)), Rgb::ONE);
        assert_eq!(t.eval(Vec2::new(0.3, 0.1)), Rgb::ZERO);
        assert_eq!(t.eval(Vec2::new(0.3, 0.3)), Rgb::ONE);
        // Wraps: negative coordinates keep the pattern.
        assert_eq!(t.eval(Vec2::new(-0.1, 0.1)), Rgb::ZERO);
    }

    /// A square that is a texture is read at the hit's own uv through that texture's map, not the
    /// board's; the board's mean, least and largest values take the nested texture's.
    #[test]
    fn a_nested_square_reads_its_own_uv() {
        let inner = Texture::Bitmap {
            file: "g".into(),
            width: 2,
            height: 1,
            texels: vec![Rgb::new(0.2, 0.2, 0.2), Rgb::new(0.6, 0.0, 0.9)],
            to_uv: UvMap::scale_offset([1.0, 1.0], [0.5, 0.0]),
            bilinear: false,
            wrap: Wrap::Repeat,
        };
        let t = Texture::Checkerboard {
            color0: Patch::Texture(Arc::new(inner)),
            color1: Rgb::splat(0.05).into(),
            to_uv: UvMap::scale_offset([2.0, 2.0], [0.0, 0.0]),
        };
        // (0.1, 0.1): the board's color0; the image at u + 0.5 = 0.6 (texel 1), not at 2u + 0.5 = 0.7.
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)), Rgb::new(0.6, 0.0, 0.9));
        // (0.3, 0.3): color0 again; the image at 0.8 (texel 1). (0.8, 0.3): at 1.3, texel 0.
        assert_eq!(t.eval(Vec2::new(0.3, 0.3)), Rgb::new(0.6, 0.0, 0.9));
        assert_eq!(t.eval(Vec2::new(0.8, 0.3)), Rgb::splat(0.2));
        assert_eq!(t.eval(Vec2::new(0.3, 0.1)), Rgb::splat(0.05));
        assert!((t.mean() - Rgb::new(0.225, 0.075, 0.3)).abs().max_element() < 1e-6, "{:?}", t.mean());
        assert_eq!((t.min_value(), t.max_value()), (0.0, 0.9));
    }

    /// Mitsuba 3.9.1's `eval_1_grad` of a 7 × 5 raw EXR (texel (x, y) = ((3x + 5y) mod 7)/7,
    /// ((x² + 2y) mod 5)/5, 0.1xy/3), read off it at four uv, one beyond [0, 1] (it wraps), without and
    /// with a `to_uv` of scale (2, 3) then translate (0.25, −0.5); and the gradient against central
    /// differences of `eval` (away from the texel centres, where the interpolant has kinks).
    #[test]
    fn bitmap_gradient_is_mitsubas_and_evals_derivative() {
        let (w, h) = (7u32, 5u32);
        let texels = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x as f32, y as f32)))
            .map(|(x, y)| {
                Rgb::new(((3.0 * x + 5.0 * y) % 7.0) / 7.0, ((x * x + 2.0 * y) % 5.0) / 5.0, 0.1 * x * y / 3.0)
            })
            .collect::<Vec<_>>();
        let bitmap = |to_uv| Texture::Bitmap {
            file: "g".into(),
            width: w,
            height: h,
            texels: texels.clone(),
            to_uv,
            bilinear: true,
            wrap: Wrap::Repeat,
        };
        let plain = bitmap(UvMap::default());
        let mapped = bitmap(UvMap([2.0, 0.0, 0.25, 0.0, 3.0, -0.5]));
        let cases = [
            (&plain, [0.31, 0.73], [-2.576783, 1.859039]),
            (&plain, [0.57, 0.12], [-1.863363, -0.655175]),
            (&plain, [0.02, 0.95], [-1.038495, -2.778043]),
            (&plain, [-0.4, 1.33], [1.685603, -1.013045]),
            (&mapped, [0.31, 0.73], [2.728349, 1.065132]),
            (&mapped, [0.57, 0.12], [-0.977909, 5.916333]),
            (&mapped, [0.02, 0.95], [-0.928060, -0.107825]),
            (&mapped, [-0.4, 1.33], [1.192832, 5.54868]),
        ];
        let lum = crate::scene::material::mitsuba_luminance;
        for (t, [u, v], want) in cases {
            let g = t.gradient(Vec2::new(u, v)).unwrap();
            assert!((g - Vec2::from(want)).abs().max_element() < 1e-4, "at ({u}, {v}): {g} against Mitsuba's {want:?}");
            let e = 1e-3;
            let du = (lum(t.eval(Vec2::new(u + e, v))) - lum(t.eval(Vec2::new(u - e, v)))) / (2.0 * e);
            let dv = (lum(t.eval(Vec2::new(u, v + e))) - lum(t.eval(Vec2::new(u, v - e)))) / (2.0 * e);
            assert!((g - Vec2::new(du, dv)).abs().max_element() < 2e-2, "at ({u}, {v}): {g} against ({du}, {dv})");
        }
        // Nearest lookup: flat within each texel. A checkerboard has none.
        let nearest = Texture::Bitmap {
            file: "g".into(),
            width: w,
            height: h,
            texels,
            to_uv: UvMap::default(),
            bilinear: false,
            wrap: Wrap::Repeat,
        };
        assert_eq!(nearest.gradient(Vec2::new(0.31, 0.73)), Some(Vec2::ZERO));
        let checks =
            Texture::Checkerboard { color0: Rgb::ONE.into(), color1: Rgb::ZERO.into(), to_uv: UvMap::default() };
        assert_eq!(checks.gradient(Vec2::new(0.3, 0.3)), None);
    }

    /// Mitsuba 3.9.1's `wrap_mode` clamp and mirror on a 5 × 4 one-channel bitmap (texel (x, y) = 10x +
    /// y), bilinear and nearest: `eval_1` and `eval_1_grad` read off it at uv beyond each edge, two
    /// periods out and inside.
    #[test]
    fn clamp_and_mirror_wrap_as_mitsuba() {
        let texels = (0..4).flat_map(|y| (0..5).map(move |x| Rgb::splat((10 * x + y) as f32))).collect::<Vec<_>>();
        let uvs = [[-0.3, 0.5], [1.25, 0.5], [0.5, -0.6], [0.5, 1.9], [2.3, 0.4], [-1.3, 0.4], [0.05, 0.05]];
        type Case = (Wrap, bool, [f32; 7], [[f32; 2]; 7]);
        let cases: [Case; 4] = [
            (
                Wrap::Clamp,
                true,
                [1.5, 41.5, 20.0, 23.0, 41.1, 1.1, 0.0],
                [[0.0, 4.0], [0.0, 4.0], [50.0, 0.0], [50.0, 0.0], [0.0, 4.0], [0.0, 4.0], [0.0, 0.0]],
            ),
            (Wrap::Clamp, false, [2.0, 42.0, 20.0, 23.0, 41.0, 1.0, 0.0], [[0.0; 2]; 7]),
            (
                Wrap::Mirror,
                true,
                [11.5, 34.0, 21.9, 20.0, 11.1, 31.1, 0.0],
                [[-50.0, 4.0], [-50.0, 4.0], [50.0, -4.0], [50.0, 0.0], [50.0, 4.0], [50.0, 4.0], [0.0, 0.0]],
            ),
            (Wrap::Mirror, false, [12.0, 32.0, 22.0, 20.0, 11.0, 31.0, 0.0], [[0.0; 2]; 7]),
        ];
        for (wrap, bilinear, values, grads) in cases {
            let t = Texture::Bitmap {
                file: "w".into(),
                width: 5,
                height: 4,
                texels: texels.clone(),
                to_uv: UvMap::default(),
                bilinear,
                wrap,
            };
            for ((uv, v), g) in uvs.iter().zip(values).zip(grads) {
                let uv = Vec2::from(*uv);
                let got = t.eval(uv).x;
                assert!((got - v).abs() < 1e-3, "{wrap:?} bilinear {bilinear} at {uv}: {got} against Mitsuba's {v}");
                let got = t.gradient(uv).unwrap();
                assert!(
                    (got - Vec2::from(g)).abs().max_element() < 1e-3,
                    "{wrap:?} {bilinear} at {uv}: gradient {got}, Mitsuba's {g:?}"
                );
            }
        }
    }

    #[test]
    fn bitmap_bilinear_hits_texel_centres_and_wraps() {
        let texels = vec![Rgb::splat(0.0), Rgb::splat(1.0), Rgb::splat(0.5), Rgb::splat(0.25)];
        let t = Texture::Bitmap {
            file: "t".into(),
            width: 2,
            height: 2,
            texels,
            to_uv: UvMap::default(),
            bilinear: true,
            wrap: Wrap::Repeat,
        };
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Rgb::splat(0.0));
        assert_eq!(t.eval(Vec2::new(0.75, 0.25)), Rgb::splat(1.0));
        assert_eq!(t.eval(Vec2::new(0.25, 0.75)), Rgb::splat(0.5));
        // Halfway between the two texels of the top row, and across the wrap at u = 0.
        assert!((t.eval(Vec2::new(0.5, 0.25)).x - 0.5).abs() < 1e-6);
        assert!((t.eval(Vec2::new(0.0, 0.25)).x - 0.5).abs() < 1e-6);
    }
}
