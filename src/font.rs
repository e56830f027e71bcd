//! Text on images and charts, drawn with a TrueType font (Hack, MIT/Bitstream Vera licence, bundled by
//! the `epaint_default_fonts` crate) through `ab_glyph`: no system fonts needed.
use crate::color::Rgb;
use crate::film::Image;
use ab_glyph::{Font, FontRef, ScaleFont};

/// The font's bytes (also registered with plotters for the charts).
pub const FONT: &[u8] = epaint_default_fonts::HACK_REGULAR;

/// Pixel height of text at scale 1.
const PX: f32 = 13.0;

fn font() -> FontRef<'static> {
    FontRef::try_from_slice(FONT).expect("the bundled font parses")
}

/// Width in pixels of `text` at integer `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    let f = font();
    let sf = f.as_scaled(PX * scale as f32);
    let mut w = 0.0;
    let mut prev = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = prev {
            w += sf.kern(p, id);
        }
        w += sf.h_advance(id);
        prev = Some(id);
    }
    w.ceil() as u32
}

/// Draws `text` with its top-left corner at (x, y) (the line's ascent below y), antialiased, clipped.
pub fn draw_text(img: &mut Image, x: i32, y: i32, text: &str, scale: u32, colour: Rgb) {
    let f = font();
    let sf = f.as_scaled(PX * scale as f32);
    let baseline = y as f32 + sf.ascent();
    let mut pen = x as f32;
    let mut prev = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = prev {
            pen += sf.kern(p, id);
        }
        let glyph = id.with_scale_and_position(sf.scale(), ab_glyph::point(pen, baseline));
        pen += sf.h_advance(id);
        prev = Some(id);
        let Some(outline) = f.outline_glyph(glyph) else { continue };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, a| {
            let (px, py) = (b.min.x as i32 + gx as i32, b.min.y as i32 + gy as i32);
            if px >= 0 && py >= 0 && (px as u32) < img.width && (py as u32) < img.height {
                let bg = img.get(px as u32, py as u32);
                img.set(px as u32, py as u32, bg + (colour - bg) * a.clamp(0.0, 1.0));
            }
        });
    }
}

/// `img` scaled by 2^`exposure` under an 18-pixel black bar carrying `items` left to right, each text in
/// its own colour (labels for previews, a legend for the photon views).
pub fn label_bar(img: &Image, items: &[(&str, Rgb)], exposure: f32) -> Image {
    let bar = 18;
    let mut out = Image::new(img.width, img.height + bar);
    let k = 2f32.powf(exposure);
    for y in 0..img.height {
        for x in 0..img.width {
            out.set(x, y + bar, img.get(x, y) * k);
        }
    }
    let mut x = 4;
    for (text, colour) in items {
        draw_text(&mut out, x, 5, text, 1, *colour);
        x += text_width(text, 1) as i32 + 12;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn text_lands_where_asked_and_is_clipped() {
        let mut img = Image::new(40, 20);
        draw_text(&mut img, 1, 1, "I", 1, Rgb::ONE);
        // Ink inside the glyph's box to the right of and below (1, 1), none elsewhere.
        let ink: Vec<(u32, u32)> =
            (0..20).flat_map(|y| (0..40).map(move |x| (x, y))).filter(|&(x, y)| img.get(x, y).x > 0.5).collect();
        assert!(!ink.is_empty());
        assert!(ink.iter().all(|&(x, y)| (1..1 + text_width("I", 1)).contains(&x) && (1..17).contains(&y)), "{ink:?}");
        draw_text(&mut img, 35, 5, "WWW", 2, Rgb::ONE); // runs off the edge without panicking
                                                        // A monospaced font: twice the scale, twice the width; two letters, twice one.
        assert!(text_width("AB", 2).abs_diff(2 * text_width("AB", 1)) <= 1);
        assert!(text_width("AB", 1).abs_diff(2 * text_width("A", 1)) <= 1);
    }
}
