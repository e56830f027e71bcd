//! Writing results: linear EXR, sRGB PNG preview with exposure, JSON stats; every write goes to a
//! temporary file in the same folder and is renamed into place, so a failed run never clobbers a file.
use crate::color::srgb_encode;
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

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Writes via `write` into a temporary file, then renames it over `path`.
pub fn atomic_write(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create folder {}", dir.display()))?;
    }
    let tmp = temp_path(path);
    let r = write(&tmp)
        .and_then(|_| std::fs::rename(&tmp, path).with_context(|| format!("cannot rename onto {}", path.display())));
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}

pub fn write_exr(path: &Path, img: &Image) -> Result<()> {
    atomic_write(path, |tmp| {
        let w = img.width as usize;
        exr::prelude::write_rgb_file(tmp, w, img.height as usize, |x, y| {
            let c = img.pixels[y * w + x];
            (c.x, c.y, c.z)
        })
        .map_err(|e| anyhow!("{}: EXR write failed: {e}", path.display()))
    })
}

pub fn read_exr(path: &Path) -> Result<Image> {
    let img = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| Image::new(res.width() as u32, res.height() as u32),
        |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            img.set(pos.x() as u32, pos.y() as u32, glam::Vec3::new(r, g, b))
        },
    )
    .map_err(|e| anyhow!("{}: cannot read EXR: {e}", path.display()))?;
    Ok(img.layer_data.channel_data.pixels)
}

/// 8-bit sRGB encoding of an image scaled by 2^exposure.
pub fn to_srgb8(img: &Image, exposure: f32) -> Vec<u8> {
    let k = 2f32.powf(exposure);
    img.pixels.iter().flat_map(|c| [srgb_encode(c.x * k), srgb_encode(c.y * k), srgb_encode(c.z * k)]).collect()
}

pub fn write_png_rgb8(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<()> {
    atomic_write(path, |tmp| {
        let f = std::fs::File::create(tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
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
    })
}

pub fn write_png(path: &Path, img: &Image, exposure: f32) -> Result<()> {
    write_png_rgb8(path, img.width, img.height, &to_srgb8(img, exposure))
}

pub fn write_json(path: &Path, v: &serde_json::Value) -> Result<()> {
    atomic_write(path, |tmp| {
        std::fs::write(tmp, serde_json::to_string_pretty(v)? + "\n")
            .with_context(|| format!("cannot write {}", tmp.display()))
    })
}

/// Resident set size of this process in bytes (Linux), for the stats file.
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
