//! Images: linear RGB float pixels, row-major from the top-left, plus side-by-side composition.
use crate::color::Rgb;

#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Rgb>,
}

impl Image {
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, pixels: vec![Rgb::ZERO; width as usize * height as usize] }
    }

    pub fn get(&self, x: u32, y: u32) -> Rgb {
        self.pixels[(y * self.width + x) as usize]
    }

    pub fn set(&mut self, x: u32, y: u32, c: Rgb) {
        self.pixels[(y * self.width + x) as usize] = c;
    }

    /// Images placed left to right with a `gap`-pixel black separator (heights must match).
    pub fn side_by_side(images: &[&Image], gap: u32) -> Image {
        let h = images.iter().map(|i| i.height).max().unwrap_or(0);
        let w = images.iter().map(|i| i.width).sum::<u32>() + gap * images.len().saturating_sub(1) as u32;
        let mut out = Image::new(w, h);
        let mut x0 = 0;
        for img in images {
            for y in 0..img.height {
                for x in 0..img.width {
                    out.set(x0 + x, y, img.get(x, y));
                }
            }
            x0 += img.width + gap;
        }
        out
    }

    pub fn mean(&self) -> Rgb {
        self.pixels.iter().copied().sum::<Rgb>() / self.pixels.len().max(1) as f32
    }
}
