//! The render loop: 16×16 tiles over rayon, per-pixel deterministic samplers, a progress bar with
//! Mrays/s, and a guard that counts (and drops) non-finite samples. A render can be a share of the
//! whole (`Share`): a range of every pixel's sample indices, or an interleaved set of rows.
use crate::color::Rgb;
use crate::film::{Image, Sums};
use crate::integrator::Counters;
use crate::math::rng::Sampler;
use crate::math::Rng;
use crate::scene::Camera;
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

/// Which part of a render to do: everything, share `part` of `parts` of every pixel's sample indices
/// (a contiguous range, so the shares take equal time), or the rows y ≡ part (mod parts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Share {
    All,
    Samples { part: u32, parts: u32 },
    Rows { part: u32, parts: u32 },
}

impl Share {
    /// The sample indices this share takes of `spp`.
    pub fn samples(self, spp: u32) -> std::ops::Range<u32> {
        match self {
            Share::Samples { part, parts } => {
                let at = |i: u32| ((spp as u64 * i as u64) / parts.max(1) as u64) as u32;
                at(part)..at(part + 1)
            }
            _ => 0..spp,
        }
    }

    pub fn has_row(self, y: u32) -> bool {
        match self {
            Share::Rows { part, parts } => y % parts.max(1) == part,
            _ => true,
        }
    }
}

/// A share of a render, as per-pixel sums of samples in f64 (weight = samples taken; 0 for pixels the
/// share skips).
pub struct ShareOutput {
    pub sums: Sums,
    pub counters: Counters,
    pub seconds: f64,
}

impl ShareOutput {
    /// The finished render: each pixel's sum divided by its weight.
    pub fn finish(self) -> RenderOutput {
        RenderOutput { image: self.sums.image(), counters: self.counters, seconds: self.seconds }
    }
}

/// Renders `spp` samples per pixel with `sample(x, y, rng, counters)` returning one radiance sample for
/// a film position (drawn by the camera's pixel filter, `Camera::film_position`); the sampler for
/// (pixel, sample) is keyed by `seed`, so threads never change the result.
#[allow(clippy::too_many_arguments)]
pub fn render<F>(
    cam: &Camera,
    spp: u32,
    sampler: Sampler,
    seed: u64,
    label: &str,
    quiet: bool,
    sample: F,
) -> RenderOutput
where
    F: Fn(f32, f32, &mut Rng, &mut Counters) -> Rgb + Sync,
{
    render_share(cam, spp, sampler, seed, Share::All, label, quiet, sample).finish()
}

/// `render`'s share `share`: each pixel's samples are summed in f64 in sample order, so the sums of
/// sample-index shares add up to the whole render's sums (to f64 rounding).
#[allow(clippy::too_many_arguments)]
pub fn render_share<F>(
    cam: &Camera,
    spp: u32,
    sampler: Sampler,
    seed: u64,
    share: Share,
    label: &str,
    quiet: bool,
    sample: F,
) -> ShareOutput
where
    F: Fn(f32, f32, &mut Rng, &mut Counters) -> Rgb + Sync,
{
    render_share_pixels(cam, spp, sampler, seed, share, label, quiet, |x, y, _, rng, c| {
        let (fx, fy, weight) = cam.film_position(x, y, rng.next_2d());
        sample(fx, fy, rng, c) * weight
    })
}

/// As `render_share`, with `sample(x, y, s, rng, counters)` taking pixel (x, y)'s sample `s` whole: it
/// draws its own film positions (with `rng`, the (pixel, s) sampler, for the first) and returns the
/// filter-weighted radiance (an eye pass that takes extra samples of a pixel's area).
#[allow(clippy::too_many_arguments)]
pub fn render_share_pixels<F>(
    cam: &Camera,
    spp: u32,
    sampler: Sampler,
    seed: u64,
    share: Share,
    label: &str,
    quiet: bool,
    sample: F,
) -> ShareOutput
where
    F: Fn(u32, u32, u32, &mut Rng, &mut Counters) -> Rgb + Sync,
{
    let (width, height) = (cam.width, cam.height);
    let t0 = Instant::now();
    let tiles: Vec<(u32, u32)> =
        (0..height.div_ceil(TILE)).flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx, ty))).collect();
    let pb = progress(tiles.len() as u64, label, quiet);
    let rays = AtomicU64::new(0);
    let range = share.samples(spp);
    let taken = range.len() as f64;
    let results: Vec<(Vec<[f64; 3]>, Counters)> = tiles
        .par_iter()
        .map(|&(tx, ty)| {
            let mut c = Counters::default();
            let mut px = Vec::with_capacity((TILE * TILE) as usize);
            for y in (ty * TILE..((ty + 1) * TILE).min(height)).filter(|&y| share.has_row(y)) {
                for x in tx * TILE..((tx + 1) * TILE).min(width) {
                    let pixel = (y as u64) * width as u64 + x as u64;
                    let mut sum = [0.0f64; 3];
                    for s in range.clone() {
                        let mut rng = Rng::camera(sampler, seed, pixel, s as u64);
                        let v = sample(x, y, s, &mut rng, &mut c);
                        if v.is_finite() {
                            for k in 0..3 {
                                sum[k] += v[k] as f64;
                            }
                        } else {
                            c.nonfinite += 1;
                        }
                    }
                    px.push(sum);
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
    let mut sums = Sums::new(width, height);
    let mut counters = Counters::default();
    for (&(tx, ty), (px, c)) in tiles.iter().zip(results) {
        counters += c;
        let mut vals = px.into_iter();
        for y in (ty * TILE..((ty + 1) * TILE).min(height)).filter(|&y| share.has_row(y)) {
            for x in tx * TILE..((tx + 1) * TILE).min(width) {
                let i = (y * width + x) as usize;
                sums.sum[i] = vals.next().unwrap_or_default();
                sums.weight[i] = taken;
            }
        }
    }
    ShareOutput { sums, counters, seconds: t0.elapsed().as_secs_f64() }
}
