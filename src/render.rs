//! The render loop: 16×16 tiles over rayon, per-pixel deterministic samplers, a progress bar with
//! Mrays/s, and a guard that counts (and drops) non-finite samples.
use crate::color::Rgb;
use crate::film::Image;
use crate::integrator::Counters;
use crate::math::Rng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

const TILE: u32 = 16;

pub use crate::progress::progress;

pub struct RenderOutput {
    pub image: Image,
    pub counters: Counters,
    pub seconds: f64,
}

/// Renders `spp` samples per pixel with `sample(x, y, rng, counters)` returning one radiance sample for
/// a film position; the sampler for (pixel, sample) is keyed by `seed`, so threads never change the result.
pub fn render<F>(width: u32, height: u32, spp: u32, seed: u64, label: &str, quiet: bool, sample: F) -> RenderOutput
where
    F: Fn(f32, f32, &mut Rng, &mut Counters) -> Rgb + Sync,
{
    let t0 = Instant::now();
    let tiles: Vec<(u32, u32)> =
        (0..height.div_ceil(TILE)).flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx, ty))).collect();
    let pb = progress(tiles.len() as u64, label, quiet);
    let rays = AtomicU64::new(0);
    let results: Vec<(Vec<Rgb>, Counters)> = tiles
        .par_iter()
        .map(|&(tx, ty)| {
            let mut c = Counters::default();
            let mut px = Vec::with_capacity((TILE * TILE) as usize);
            for y in ty * TILE..((ty + 1) * TILE).min(height) {
                for x in tx * TILE..((tx + 1) * TILE).min(width) {
                    let pixel = (y as u64) * width as u64 + x as u64;
                    let mut sum = Rgb::ZERO;
                    for s in 0..spp {
                        let mut rng = Rng::new(seed, pixel, s as u64);
                        let [jx, jy] = rng.next_2d();
                        let v = sample(x as f32 + jx, y as f32 + jy, &mut rng, &mut c);
                        if v.is_finite() {
                            sum += v;
                        } else {
                            c.nonfinite += 1;
                        }
                    }
                    px.push(sum / spp as f32);
                }
            }
            let total = rays.fetch_add(c.rays, Ordering::Relaxed) + c.rays;
            let secs = t0.elapsed().as_secs_f64().max(1e-9);
            pb.set_message(format!("{:.1} Mrays/s", total as f64 / secs / 1e6));
            pb.inc(1);
            (px, c)
        })
        .collect();
    pb.finish_and_clear();
    let mut image = Image::new(width, height);
    let mut counters = Counters::default();
    for (&(tx, ty), (px, c)) in tiles.iter().zip(results) {
        counters += c;
        let mut i = 0;
        for y in ty * TILE..((ty + 1) * TILE).min(height) {
            for x in tx * TILE..((tx + 1) * TILE).min(width) {
                image.set(x, y, px[i]);
                i += 1;
            }
        }
    }
    RenderOutput { image, counters, seconds: t0.elapsed().as_secs_f64() }
}
