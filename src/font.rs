//! A 5×7 bitmap font for labels on images and charts (no system fonts needed).
use crate::color::Rgb;
use crate::film::Image;

/// Glyph rows, top to bottom, 5 bits each (bit 4 = leftmost column).
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        '0' => [14, 17, 19, 21, 25, 17, 14],
        '1' => [4, 12, 4, 4, 4, 4, 14],
        '2' => [14, 17, 1, 2, 4, 8, 31],
        '3' => [31, 2, 4, 2, 1, 17, 14],
        '4' => [2, 6, 10, 18, 31, 2, 2],
        '5' => [31, 16, 30, 1, 1, 17, 14],
        '6' => [6, 8, 16, 30, 17, 17, 14],
        '7' => [31, 1, 2, 4, 8, 8, 8],
        '8' => [14, 17, 17, 14, 17, 17, 14],
        '9' => [14, 17, 17, 15, 1, 2, 12],
        'A' => [14, 17, 17, 31, 17, 17, 17],
        'B' => [30, 17, 17, 30, 17, 17, 30],
        'C' => [14, 17, 16, 16, 16, 17, 14],
        'D' => [28, 18, 17, 17, 17, 18, 28],
        'E' => [31, 16, 16, 30, 16, 16, 31],
        'F' => [31, 16, 16, 30, 16, 16, 16],
        'G' => [14, 17, 16, 23, 17, 17, 15],
        'H' => [17, 17, 17, 31, 17, 17, 17],
        'I' => [14, 4, 4, 4, 4, 4, 14],
        'J' => [7, 2, 2, 2, 2, 18, 12],
        'K' => [17, 18, 20, 24, 20, 18, 17],
        'L' => [16, 16, 16, 16, 16, 16, 31],
        'M' => [17, 27, 21, 21, 17, 17, 17],
        'N' => [17, 17, 25, 21, 19, 17, 17],
        'O' => [14, 17, 17, 17, 17, 17, 14],
        'P' => [30, 17, 17, 30, 16, 16, 16],
        'Q' => [14, 17, 17, 17, 21, 18, 13],
        'R' => [30, 17, 17, 30, 20, 18, 17],
        'S' => [15, 16, 16, 14, 1, 1, 30],
        'T' => [31, 4, 4, 4, 4, 4, 4],
        'U' => [17, 17, 17, 17, 17, 17, 14],
        'V' => [17, 17, 17, 17, 17, 10, 4],
        'W' => [17, 17, 17, 21, 21, 21, 10],
        'X' => [17, 17, 10, 4, 10, 17, 17],
        'Y' => [17, 17, 17, 10, 4, 4, 4],
        'Z' => [31, 1, 2, 4, 8, 16, 31],
        '.' => [0, 0, 0, 0, 0, 12, 12],
        ',' => [0, 0, 0, 0, 12, 4, 8],
        ':' => [0, 12, 12, 0, 12, 12, 0],
        '-' => [0, 0, 0, 31, 0, 0, 0],
        '+' => [0, 4, 4, 31, 4, 4, 0],
        '=' => [0, 0, 31, 0, 31, 0, 0],
        '/' => [0, 1, 2, 4, 8, 16, 0],
        '(' => [2, 4, 8, 8, 8, 4, 2],
        ')' => [8, 4, 2, 2, 2, 4, 8],
        '%' => [24, 25, 2, 4, 8, 19, 3],
        '_' => [0, 0, 0, 0, 0, 0, 31],
        '×' => [0, 17, 10, 4, 10, 17, 0],
        _ => [0; 7],
    }
}

/// Width in pixels of `text` at integer `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * 6 * scale
}

/// Draws `text` with its top-left corner at (x, y), clipped to the image.
pub fn draw_text(img: &mut Image, x: i32, y: i32, text: &str, scale: u32, colour: Rgb) {
    for (i, c) in text.chars().enumerate() {
        let g = glyph(c);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (16 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let px = x + ((i as u32 * 6 + col) * scale + dx) as i32;
                        let py = y + (row as u32 * scale + dy) as i32;
                        if px >= 0 && py >= 0 && (px as u32) < img.width && (py as u32) < img.height {
                            img.set(px as u32, py as u32, colour);
                        }
                    }
                }
            }
        }
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
        let mut img = Image::new(40, 10);
        draw_text(&mut img, 1, 1, "1", 1, Rgb::ONE);
        // '1' has its stem in column 2: pixel (3, 2) is set, (0, 0) is not.
        assert_eq!(img.get(3, 2), Rgb::ONE);
        assert_eq!(img.get(0, 0), Rgb::ZERO);
        draw_text(&mut img, 35, 5, "WWW", 2, Rgb::ONE); // runs off the edge without panicking
        assert_eq!(text_width("AB", 2), 24);
    }
}
