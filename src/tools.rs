//! `caustica compare` (side-by-side with labels, error heat-map with a colour scale, metrics) and
//! `caustica reference` (a long render in two independent halves, cached, with its own noise figure).
use crate::color::{luminance, Rgb};
use crate::film::Image;
use crate::font::{draw_text, text_width};
use crate::metrics::{compare, Errors};
use crate::output::{self, read_exr, to_srgb8, with_suffix, write_png_rgb8};
use anyhow::{bail, Result};
use serde_json::json;
use std::path::Path;

/// Heat-map colours from black through purple, red and yellow to white, for t in [0, 1].
pub fn heat(t: f32) -> Rgb {
    let stops = [
        Rgb::new(0.0, 0.0, 0.0),
        Rgb::new(0.3, 0.0, 0.5),
        Rgb::new(0.85, 0.1, 0.2),
        Rgb::new(1.0, 0.75, 0.0),
        Rgb::new(1.0, 1.0, 1.0),
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 1.0 } * (stops.len() - 1) as f32;
    let i = (t as usize).min(stops.len() - 2);
    stops[i].lerp(stops[i + 1], t - i as f32)
}

/// A tone-mapped copy (linear values already in display range) with a label bar on top.
fn labelled(img: &Image, label: &str, exposure: f32) -> Image {
    crate::font::label_bar(img, &[(label, Rgb::ONE)], exposure)
}

/// Per-pixel absolute luminance error as a heat map scaled to `max`, with a colour bar and its scale.
fn heat_map(a: &Image, r: &Image, max: f32, label: &str) -> Image {
    let bar = 18;
    let scale_h = 26;
    let mut out = Image::new(a.width, a.height + bar + scale_h);
    for y in 0..a.height {
        for x in 0..a.width {
            let e = (luminance(a.get(x, y)) - luminance(r.get(x, y))).abs();
            out.set(x, y + bar, heat(e / max));
        }
    }
    draw_text(&mut out, 4, 5, label, 1, Rgb::ONE);
    let y0 = a.height + bar + 4;
    for x in 0..a.width {
        let c = heat(x as f32 / (a.width.max(2) - 1) as f32);
        for y in y0..y0 + 8 {
            out.set(x, y, c);
        }
    }
    draw_text(&mut out, 2, (y0 + 11) as i32, "0", 1, Rgb::ONE);
    let m = format!("{max:.3}");
    draw_text(&mut out, a.width as i32 - text_width(&m, 1) as i32 - 2, (y0 + 11) as i32, &m, 1, Rgb::ONE);
    out
}

/// Writes OUT.png (labelled side by side), OUT-error.png (heat maps), OUT.json (metrics).
pub fn compare_cmd(a_path: &Path, b_path: &Path, reference: Option<&Path>, out: &Path, exposure: f32) -> Result<()> {
    let a = read_exr(a_path)?;
    let b = read_exr(b_path)?;
    let r = reference.map(read_exr).transpose()?;
    for (p, img) in [(b_path, &b)].into_iter().chain(reference.iter().map(|p| (*p, r.as_ref().unwrap()))) {
        if (img.width, img.height) != (a.width, a.height) {
            bail!(
                "{} is {}×{} but {} is {}×{}: images must have the same size",
                p.display(),
                img.width,
                img.height,
                a_path.display(),
                a.width,
                a.height
            );
        }
    }
    let name = |p: &Path| p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    // Against the reference when given; otherwise B is the reference for A.
    let (ea, eb): (Errors, Option<Errors>) = match &r {
        Some(r) => (compare(&a, r).unwrap(), Some(compare(&b, r).unwrap())),
        None => (compare(&a, &b).unwrap(), None),
    };
    let mut panels = vec![labelled(&a, &name(a_path), exposure), labelled(&b, &name(b_path), exposure)];
    if let Some(r) = &r {
        panels.push(labelled(r, &format!("reference {}", name(reference.unwrap())), exposure));
    }
    let refs: Vec<&Image> = panels.iter().collect();
    let side = Image::side_by_side(&refs, 4);
    let png = with_suffix(out, ".png");
    write_png_rgb8(&png, side.width, side.height, &to_srgb8(&side, 0.0))?;
    let target = r.as_ref().unwrap_or(&b);
    let mut errs: Vec<f32> =
        a.pixels.iter().zip(&target.pixels).map(|(p, q)| (luminance(*p) - luminance(*q)).abs()).collect();
    if r.is_some() {
        errs.extend(b.pixels.iter().zip(&target.pixels).map(|(p, q)| (luminance(*p) - luminance(*q)).abs()));
    }
    errs.sort_by(f32::total_cmp);
    let max = errs.get(errs.len() * 99 / 100).copied().unwrap_or(1.0).max(1e-6);
    let mut maps = vec![heat_map(
        &a,
        target,
        max,
        &format!("|{} - {}|", name(a_path), if r.is_some() { "ref".into() } else { name(b_path) }),
    )];
    if r.is_some() {
        maps.push(heat_map(&b, target, max, &format!("|{} - ref|", name(b_path))));
    }
    let refs: Vec<&Image> = maps.iter().collect();
    let hm = Image::side_by_side(&refs, 4);
    let err_png = with_suffix(out, "-error.png");
    write_png_rgb8(&err_png, hm.width, hm.height, &to_srgb8(&hm, 0.0))?;
    let stats = json!({ "a": a_path.display().to_string(), "b": b_path.display().to_string(),
        "reference": reference.map(|p| p.display().to_string()), "a_errors": ea, "b_errors": eb, "heat_map_max": max });
    output::write_json(&with_suffix(out, ".json"), &stats)?;
    let show = |n: &str, e: &Errors| {
        println!(
            "{n:<24} RMSE {:.6}  relMSE {:.6}  MAE {:.6}  mean-luminance ratio {:.4}",
            e.rmse, e.rel_mse, e.mae, e.mean_ratio
        )
    };
    match &eb {
        Some(eb) => {
            show(&name(a_path), &ea);
            show(&name(b_path), eb);
        }
        None => show(&format!("{} vs {}", name(a_path), name(b_path)), &ea),
    }
    println!("wrote {}, {} and {}", png.display(), err_png.display(), with_suffix(out, ".json").display());
    Ok(())
}
