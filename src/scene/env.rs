//! Environment light: constant radiance from every direction, or a lat-long image read as Mitsuba 3's
//! `envmap` reads it (u = atan2(x, −z)/2π, v = acos(y)/π in the light's own frame; bilinear, texel
//! columns centred at (i + ½)/W and wrapping, rows at v = j/(H − 1) from pole to pole), importance-sampled
//! on a W × H grid by luminance × sin θ. `Lights` places it around the scene's bounding sphere (photons
//! from a disc of that radius, facing the sampled direction, each carrying L·πR²/pdf).
//!
//! ```toml
//! [[lights]]
//! type = "envmap"
//! file = "assets/sky.exr"
//! scale = 1.0
//! transform = { rotate_y = 90.0 }
//!
//! [[lights]]
//! type = "constant"
//! radiance = [0.5, 0.5, 0.5]
//! ```
use crate::color::{luminance, Rgb};
use crate::math::sampling;
use glam::{Mat3, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub struct EnvLight {
    /// Radiance of a constant environment, or the image's multiplier.
    pub scale: Rgb,
    pub image: Option<EnvImage>,
    /// World → light frame (a rotation).
    pub to_local: Mat3,
}

#[derive(Clone, Debug)]
pub struct EnvImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Rgb>,
    /// Sampling weights per grid cell (row-major, cell (i, j) = u ∈ [i, i+1)/W, v ∈ [j, j+1)/H): the
    /// largest luminance of the texels within one of it (so the bilinear lookup never shows light where
    /// the pdf is zero) times sin θ at its centre.
    rows: Vec<f32>,
    row_cdf: Vec<f32>,
    col_cdf: Vec<Vec<f32>>,
}

impl EnvImage {
    pub fn new(width: u32, height: u32, texels: Vec<Rgb>) -> EnvImage {
        let (w, h) = (width as usize, height as usize);
        let lum = |x: i64, y: i64| {
            let y = y.clamp(0, h as i64 - 1) as usize;
            luminance(texels[y * w + x.rem_euclid(w as i64) as usize]).max(0.0)
        };
        let mut col_cdf = Vec::with_capacity(h);
        let mut rows = Vec::with_capacity(h);
        for y in 0..h {
            let sin = ((y as f32 + 0.5) / h as f32 * PI).sin();
            let mut acc = 0.0;
            let cdf: Vec<f32> = (0..w as i64)
                .map(|x| {
                    let m = (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)));
                    acc += m.map(|(dx, dy)| lum(x + dx, y as i64 + dy)).fold(0.0, f32::max) * sin;
                    acc
                })
                .collect();
            rows.push(acc);
            col_cdf.push(cdf);
        }
        let mut acc = 0.0;
        let row_cdf = rows
            .iter()
            .map(|r| {
                acc += r;
                acc
            })
            .collect();
        EnvImage { width, height, texels, rows, row_cdf, col_cdf }
    }

    fn lookup(&self, u: f32, v: f32) -> Rgb {
        let (w, h) = (self.width as i64, self.height as i64);
        let at = |x: i64, y: i64| self.texels[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize];
        crate::scene::texture::bilinear(u * w as f32 - 0.5, v.clamp(0.0, 1.0) * (h - 1) as f32, at)
    }

    /// Density of (u, v) over the unit square.
    fn pdf_uv(&self, u: f32, v: f32) -> f32 {
        let total = *self.row_cdf.last().unwrap_or(&0.0);
        if total <= 0.0 {
            return 0.0;
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let x = ((u * w as f32) as usize).min(w - 1);
        let y = ((v * h as f32) as usize).min(h - 1);
        let cdf = &self.col_cdf[y];
        let cell = cdf[x] - if x == 0 { 0.0 } else { cdf[x - 1] };
        cell * (w * h) as f32 / total
    }
}

/// Direction in the light's frame for lat-long coordinates (u, v).
fn direction(u: f32, v: f32) -> Vec3 {
    let (phi, theta) = (u * 2.0 * PI, v * PI);
    Vec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin())
}

fn lat_long(d: Vec3) -> (f32, f32) {
    let u = d.x.atan2(-d.z) / (2.0 * PI);
    (u - u.floor(), d.y.clamp(-1.0, 1.0).acos() / PI)
}

impl EnvLight {
    /// Radiance arriving from world direction `dir` (pointing away from the scene).
    pub fn radiance(&self, dir: Vec3) -> Rgb {
        match &self.image {
            None => self.scale,
            Some(img) => {
                let (u, v) = lat_long(self.to_local * dir.normalize());
                img.lookup(u, v) * self.scale
            }
        }
    }

    /// Solid-angle density with which `sample` picks world direction `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match &self.image {
            None => 1.0 / (4.0 * PI),
            Some(img) => {
                let (u, v) = lat_long(self.to_local * dir.normalize());
                // At the poles sin θ rounds to 0: keep the density finite there (sample and pdf agree).
                let sin = (v * PI).sin().max(1e-7);
                img.pdf_uv(u, v) / (2.0 * PI * PI * sin)
            }
        }
    }

    /// A world direction towards the environment with its radiance and solid-angle pdf.
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, Rgb, f32)> {
        let Some(img) = &self.image else {
            return Some((sampling::uniform_sphere(u), self.scale, 1.0 / (4.0 * PI)));
        };
        if img.rows.is_empty() || *img.row_cdf.last()? <= 0.0 {
            return None;
        }
        let (y, _) = sampling::sample_cdf(&img.row_cdf, u[0]);
        let (x, _) = sampling::sample_cdf(&img.col_cdf[y], u[1]);
        // Uniform within the texel: reuse the fractional parts of the two choices.
        let frac = |cdf: &[f32], i: usize, uu: f32| {
            let total = *cdf.last().unwrap_or(&1.0);
            let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
            ((uu * total - lo) / (cdf[i] - lo)).clamp(0.0, 0.999_999)
        };
        let uu = (x as f32 + frac(&img.col_cdf[y], x, u[1])) / img.width as f32;
        let vv = (y as f32 + frac(&img.row_cdf, y, u[0])) / img.height as f32;
        let local = direction(uu, vv);
        let dir = self.to_local.transpose() * local;
        let pdf = self.pdf(dir);
        (pdf > 0.0).then(|| (dir, self.radiance(dir), pdf))
    }

    /// ∫ L dω over the sphere (per channel).
    pub fn radiance_integral(&self) -> Rgb {
        match &self.image {
            None => self.scale * 4.0 * PI,
            Some(img) => {
                // Midpoint rule on a grid k times finer than the image.
                let (w, h) = (img.width as usize, img.height as usize);
                let k = if w * h > 1 << 20 { 1 } else { 4 };
                let (nu, nv) = (w * k, h * k);
                let mut sum = glam::DVec3::ZERO;
                for j in 0..nv {
                    let v = (j as f32 + 0.5) / nv as f32;
                    let d_omega = (2.0 * PI / nu as f32) * (PI / nv as f32) * (v * PI).sin();
                    let row: Rgb = (0..nu).map(|i| img.lookup((i as f32 + 0.5) / nu as f32, v)).sum();
                    sum += (row * d_omega).as_dvec3();
                }
                sum.as_vec3() * self.scale
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(texels: Vec<Rgb>, w: u32, h: u32) -> EnvLight {
        EnvLight { scale: Rgb::ONE, image: Some(EnvImage::new(w, h, texels)), to_local: Mat3::IDENTITY }
    }

    #[test]
    fn lat_long_round_trips_and_sampling_matches_the_pdf() {
        for (u, v) in [(0.1f32, 0.3f32), (0.6, 0.8), (0.95, 0.5)] {
            let (u2, v2) = lat_long(direction(u, v));
            assert!((u - u2).abs() < 1e-5 && (v - v2).abs() < 1e-5);
        }
        // A sky brighter towards +y with a hot texel: E[L/pdf] must equal ∫L dω, and the pdf integrates to 1.
        let (w, h) = (16u32, 8u32);
        let texels: Vec<Rgb> =
            (0..w * h).map(|i| if i == 21 { Rgb::splat(50.0) } else { Rgb::splat(1.0 + (h - i / w) as f32) }).collect();
        let e = env(texels, w, h);
        let mut rng = crate::math::Rng::new(1, 2, 3);
        let (n, mut est, mut pdf_int) = (400_000, 0.0f64, 0.0f64);
        for _ in 0..n {
            let (d, l, pdf) = e.sample(rng.next_2d()).unwrap();
            assert!((pdf - e.pdf(d)).abs() <= 1e-3 * pdf, "{pdf} vs {}", e.pdf(d));
            est += (l.x / pdf) as f64 / n as f64;
            let du = sampling::uniform_sphere(rng.next_2d());
            pdf_int += (e.pdf(du) * 4.0 * PI) as f64 / n as f64;
        }
        let want = e.radiance_integral().x as f64;
        assert!((est / want - 1.0).abs() < 0.01, "{est} vs {want}");
        assert!((pdf_int - 1.0).abs() < 0.01, "{pdf_int}");
    }
}
