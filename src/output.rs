//! Writing results: linear EXR, sRGB PNG preview with exposure, JSON stats; every write goes to a
//! temporary file in the same folder and is renamed into place, so a failed run never clobbers a file.
use crate::color::{srgb_encode, Rgb};
use crate::film::Image;
use anyhow::{anyhow, Context, Result};
use std::path::{Path, PathBuf};

/// `out` with `suffix` appended to its file name: `with_suffix("out/glass-egg-1.1", ".png")` keeps the
/// dots that `Path::with_extension` would cut, and `"-pt"` makes a sibling name.
pub fn with_suffix(out: &Path, suffix: &str) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// The output base a user meant by `-o`: `out/glass.exr`, `out/glass.png` and `out/glass.json` all mean
/// `out/glass` (the commands append the extensions they write), so `-o x.exr` writes `x.exr`, not
/// `x.exr.exr`. Other dots are kept (`glass-egg-1.1` stays as it is).
pub fn output_base(out: &Path) -> PathBuf {
    let known = [".exr", ".png", ".json", ".svg", ".csv"];
    let name = out.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    let lower = name.to_ascii_lowercase();
    match known.iter().find(|e| lower.ends_with(*e) && lower.len() > e.len()) {
        Some(e) => out.with_file_name(&name[..name.len() - e.len()]),
        None => out.to_path_buf(),
    }
}

/// `-o` as a folder: `out/` (trailing slash) or an existing folder gets `name` inside it, so outputs never
/// become hidden files like `out/.exr`; anything else is the output base itself.
pub fn in_folder(out: PathBuf, name: &str) -> PathBuf {
    let s = out.as_os_str().to_string_lossy();
    if s.ends_with('/') || s.ends_with(std::path::MAIN_SEPARATOR) || out.is_dir() {
        out.join(name)
    } else {
        out
    }
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Files written together: each goes to a temporary file beside its destination first; only when all
/// are written, and no destination is a folder in the way, are they renamed into place. A run that
/// fails while writing leaves every earlier file as it was, and no temporary file behind.
#[derive(Default)]
pub struct Batch {
    staged: Vec<(PathBuf, PathBuf)>,
}

impl Batch {
    /// Writes `path`'s content through `write` into its temporary file.
    pub fn stage(&mut self, path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("cannot create folder {}", dir.display()))?;
        }
        let tmp = temp_path(path);
        // Registered before writing, so a failed write's partial file is removed with the rest.
        self.staged.push((tmp.clone(), path.to_path_buf()));
        write(&tmp)
    }

    /// Renames every staged file into place.
    pub fn commit(mut self) -> Result<()> {
        for (_, dest) in &self.staged {
            if dest.is_dir() {
                return Err(anyhow!(
                    "{}: a folder is in the way of the output file; nothing was written",
                    dest.display()
                ));
            }
        }
        for (tmp, dest) in std::mem::take(&mut self.staged) {
            if let Err(e) = std::fs::rename(&tmp, &dest) {
                let _ = std::fs::remove_file(&tmp);
                return Err(e).with_context(|| format!("cannot rename onto {}", dest.display()));
            }
        }
        Ok(())
    }
}

impl Drop for Batch {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Writes via `write` into a temporary file, then renames it over `path`.
pub fn atomic_write(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let mut b = Batch::default();
    b.stage(path, write)?;
    b.commit()
}

pub fn write_exr(path: &Path, img: &Image) -> Result<()> {
    atomic_write(path, |tmp| encode_exr(tmp, img))
}

/// Writes `img` as a linear RGB EXR at `file`. Chunks are compressed in order on one thread, so the
/// same image always gives the same bytes (the parallel writer stores chunks in the order they finish).
pub fn encode_exr(file: &Path, img: &Image) -> Result<()> {
    use exr::prelude::{SpecificChannels, Vec2, WritableImage};
    let w = img.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let c = img.pixels[y * w + x];
        (c.x, c.y, c.z)
    });
    exr::prelude::Image::from_channels((w, img.height as usize), channels)
        .write()
        .non_parallel()
        .to_file(file)
        .map_err(|e| anyhow!("{}: EXR write failed: {e}", file.display()))
}

/// Refuses an EXR whose header claims a layer of more than `MAX_TEXELS` texels (or of more than 16
/// bytes a texel over that many), before any of its pixels is decoded: the EXR crate sizes each
/// block's buffer by the header, and a damaged one claiming 10^9 columns made it allocate hundreds of
/// GB, which aborts the process (no error to catch). Returns the first layer's width and height.
fn check_exr_header(path: &Path) -> std::result::Result<(usize, usize), String> {
    use crate::scene::texture::MAX_TEXELS;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| format!("cannot read EXR: {e}"))?;
    for (i, h) in meta.headers.iter().enumerate() {
        let (w, ht) = (h.layer_size.width(), h.layer_size.height());
        let texels = w as u64 * ht as u64;
        if texels > MAX_TEXELS || texels.saturating_mul(h.channels.bytes_per_pixel as u64) > 16 * MAX_TEXELS {
            let layer = if meta.headers.len() > 1 { format!("layer {i} of ") } else { String::new() };
            return Err(format!(
                "the EXR's header claims {layer}{w}×{ht} texels of {} bytes, larger than this reader takes ({MAX_TEXELS} texels of at most 16 bytes): damaged?",
                h.channels.bytes_per_pixel
            ));
        }
    }
    let first = meta.headers.first().ok_or("cannot read EXR: no layer")?;
    Ok((first.layer_size.width(), first.layer_size.height()))
}

/// The first RGB(A) layer of an EXR (or else its first grey `Y` layer, as three equal channels) as
/// (width, height, pixels, row 0 first), its header checked first
/// (`check_exr_header`). Images under 2^20 texels are decoded on this thread: a thread pool for a
/// small texture costs more than it saves.
pub fn read_exr_pixels(path: &Path) -> std::result::Result<(usize, usize, Vec<Rgb>), String> {
    let (w, h) = check_exr_header(path)?;
    // The header check bounds every layer's size. Zeroed arrays of floats come from the allocator
    // untouched, so a damaged header's claim of a large image costs nothing until its pixels are read.
    let create = |res: exr::prelude::Vec2<usize>, _: &_| (res.width(), res.height(), vec![[0.0f32; 3]; res.area()]);
    let set = |img: &mut (usize, usize, Vec<[f32; 3]>),
               pos: exr::prelude::Vec2<usize>,
               (r, g, b, _a): (f32, f32, f32, f32)| {
        if let Some(t) = img.2.get_mut(pos.y() * img.0 + pos.x()) {
            *t = [r, g, b];
        }
    };
    use exr::prelude::{ReadChannels, ReadLayers, ReadSpecificChannel};
    let small = (w as u64 * h as u64) < 1 << 20;
    let reader = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(create, set)
        .first_valid_layer()
        .all_attributes();
    let read = if small { reader.non_parallel().from_file(path) } else { reader.from_file(path) };
    let (w, h, pixels) = match read {
        Ok(img) => img.layer_data.channel_data.pixels,
        Err(rgb_error) => {
            // A grey image (a luminance channel `Y`, with or without alpha, as Mitsuba writes a
            // one-channel bitmap): each texel its Y in all three channels, as Mitsuba reads it.
            let set_grey = |img: &mut (usize, usize, Vec<[f32; 3]>), pos: exr::prelude::Vec2<usize>, (y,): (f32,)| {
                if let Some(t) = img.2.get_mut(pos.y() * img.0 + pos.x()) {
                    *t = [y; 3];
                }
            };
            let grey = exr::prelude::read()
                .no_deep_data()
                .largest_resolution_level()
                .specific_channels()
                .required("Y")
                .collect_pixels(
                    |res: exr::prelude::Vec2<usize>, _: &_| (res.width(), res.height(), vec![[0.0f32; 3]; res.area()]),
                    set_grey,
                )
                .first_valid_layer()
                .all_attributes();
            let read = if small { grey.non_parallel().from_file(path) } else { grey.from_file(path) };
            read.map_err(|_| format!("cannot read EXR: {rgb_error} (neither R, G, B nor a grey Y channel)"))?
                .layer_data
                .channel_data
                .pixels
        }
    };
    if pixels.is_empty() {
        return Err(format!("{w}×{h} EXR is empty"));
    }
    Ok((w, h, pixels.into_iter().map(Rgb::from_array).collect()))
}

pub fn read_exr(path: &Path) -> Result<Image> {
    crate::scene::regular_file(path).map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
    let (w, h, pixels) = read_exr_pixels(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(Image { width: w as u32, height: h as u32, pixels })
}

/// 8-bit sRGB encoding of an image scaled by 2^exposure.
pub fn to_srgb8(img: &Image, exposure: f32) -> Vec<u8> {
    let k = 2f32.powf(exposure);
    img.pixels.iter().flat_map(|c| [srgb_encode(c.x * k), srgb_encode(c.y * k), srgb_encode(c.z * k)]).collect()
}

pub fn write_png_rgb8(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<()> {
    atomic_write(path, |tmp| encode_png_rgb8(tmp, width, height, data))
}

/// Writes 8-bit sRGB pixels as a PNG at `file`.
pub fn encode_png_rgb8(file: &Path, width: u32, height: u32, data: &[u8]) -> Result<()> {
    let f = std::fs::File::create(file).with_context(|| format!("cannot create {}", file.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(f), width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    enc.set_compression(png::Compression::Best);
    enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let mut w = enc.write_header()?;
    w.write_image_data(data)?;
    w.finish()?;
    Ok(())
}

pub fn write_png(path: &Path, img: &Image, exposure: f32) -> Result<()> {
    write_png_rgb8(path, img.width, img.height, &to_srgb8(img, exposure))
}

pub fn write_json(path: &Path, v: &serde_json::Value) -> Result<()> {
    atomic_write(path, |tmp| encode_json(tmp, v))
}

/// Writes `v` as pretty JSON at `file`.
pub fn encode_json(file: &Path, v: &serde_json::Value) -> Result<()> {
    std::fs::write(file, serde_json::to_string_pretty(v)? + "\n")
        .with_context(|| format!("cannot write {}", file.display()))
}

/// Writes OUT.exr (linear), OUT.png (preview at `exposure`) and OUT.json as one batch: all three or none.
pub fn write_image_set(out: &Path, img: &Image, exposure: f32, stats: &serde_json::Value) -> Result<()> {
    write_set(out, img, (img.width, img.height, to_srgb8(img, exposure)), stats)
}

/// Like `write_image_set`, with the PNG drawn from `preview` (already exposed: labels, legends).
pub fn write_image_set_with_preview(out: &Path, img: &Image, preview: &Image, stats: &serde_json::Value) -> Result<()> {
    write_set(out, img, (preview.width, preview.height, to_srgb8(preview, 0.0)), stats)
}

fn write_set(out: &Path, img: &Image, png: (u32, u32, Vec<u8>), stats: &serde_json::Value) -> Result<()> {
    let mut b = Batch::default();
    b.stage(&with_suffix(out, ".exr"), |t| encode_exr(t, img))?;
    b.stage(&with_suffix(out, ".png"), |t| encode_png_rgb8(t, png.0, png.1, &png.2))?;
    b.stage(&with_suffix(out, ".json"), |t| encode_json(t, stats))?;
    b.commit()
}

/// Resident set size of this process in bytes (Linux), for the stats file.
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    #[test]
    fn output_base_strips_only_known_extensions() {
        use super::output_base;
        use std::path::Path;
        assert_eq!(output_base(Path::new("out/a.exr")), Path::new("out/a"));
        assert_eq!(output_base(Path::new("out/a.PNG")), Path::new("out/a"));
        assert_eq!(output_base(Path::new("a.json")), Path::new("a"));
        assert_eq!(output_base(Path::new("out/glass-egg-1.1")), Path::new("out/glass-egg-1.1"));
        assert_eq!(output_base(Path::new("out/.exr")), Path::new("out/.exr"));
        assert_eq!(output_base(Path::new("out/x.tar")), Path::new("out/x.tar"));
    }

    /// A grey EXR (one `Y` channel, with or without alpha, as Mitsuba writes a one-channel bitmap) reads
    /// as three equal channels, row 0 first; one with neither R, G, B nor Y is refused, naming both.
    #[test]
    fn a_grey_exr_reads_as_grey() {
        use exr::prelude::*;
        let dir = std::env::temp_dir().join(format!("caustica-grey-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let value = |x: usize, y: usize| (y * 3 + x) as f32 * 0.25;
        let y_only = dir.join("y.exr");
        let channel =
            |name: &str| AnyChannel::new(name, FlatSamples::F32((0..6).map(|i| value(i % 3, i / 3)).collect()));
        let write = |path: &std::path::Path, names: &[&str]| {
            let channels = AnyChannels::sort(names.iter().map(|n| channel(n)).collect());
            Image::from_channels((3, 2), channels).write().to_file(path).unwrap();
        };
        write(&y_only, &["Y"]);
        let ya = dir.join("ya.exr");
        write(&ya, &["Y", "A"]);
        for path in [&y_only, &ya] {
            let (w, h, pixels) = super::read_exr_pixels(path).unwrap();
            assert_eq!((w, h), (3, 2));
            for (i, p) in pixels.iter().enumerate() {
                assert_eq!(p.to_array(), [value(i % 3, i / 3); 3], "{} texel {i}", path.display());
            }
        }
        let z = dir.join("z.exr");
        write(&z, &["Z"]);
        let err = super::read_exr_pixels(&z).unwrap_err();
        assert!(err.contains("neither R, G, B nor a grey Y channel"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
