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

/// Un-normalised per-pixel sums and weights (samples or passes) in f64: what a render accumulates
/// before dividing, and what a partial render (`--part i/N`) stores so that parts merge exactly.
#[derive(Clone, Debug, PartialEq)]
pub struct Sums {
    pub width: u32,
    pub height: u32,
    pub sum: Vec<[f64; 3]>,
    pub weight: Vec<f64>,
}

impl Sums {
    pub fn new(width: u32, height: u32) -> Sums {
        let n = width as usize * height as usize;
        Sums { width, height, sum: vec![[0.0; 3]; n], weight: vec![0.0; n] }
    }

    /// An image taken as it is, weight 1 per pixel (for estimators that keep their own state, SPPM).
    pub fn from_image(img: &Image) -> Sums {
        let sum = img.pixels.iter().map(|p| [p.x as f64, p.y as f64, p.z as f64]).collect();
        Sums { width: img.width, height: img.height, sum, weight: vec![1.0; img.pixels.len()] }
    }

    /// Adds one pass's image: every pixel gains its value and weight 1.
    pub fn add_image(&mut self, img: &Image) {
        for ((acc, w), p) in self.sum.iter_mut().zip(&mut self.weight).zip(&img.pixels) {
            for k in 0..3 {
                acc[k] += p[k] as f64;
            }
            *w += 1.0;
        }
    }

    /// Adds another share of the same film (same size).
    pub fn add(&mut self, other: &Sums) {
        for i in 0..self.sum.len() {
            for k in 0..3 {
                self.sum[i][k] += other.sum[i][k];
            }
            self.weight[i] += other.weight[i];
        }
    }

    /// The mean per pixel (sum / weight, in f64, rounded once to f32); black where nothing was added.
    pub fn image(&self) -> Image {
        let mut img = Image::new(self.width, self.height);
        for ((o, s), &w) in img.pixels.iter_mut().zip(&self.sum).zip(&self.weight) {
            if w > 0.0 {
                *o = Rgb::new((s[0] / w) as f32, (s[1] / w) as f32, (s[2] / w) as f32);
            }
        }
        img
    }
}
