//! Warps from the unit square to directions and points, with their densities.
use glam::Vec3;
use std::f32::consts::PI;

/// The largest f32 below 1, where a uniform number rescaled into [0, 1) stays.
pub const ONE_BELOW: f32 = f32::from_bits(0x3f7f_ffff);

/// A choice between two outcomes drawn with the uniform `u`, the first taken with probability `p`:
/// whether it was, and `u` rescaled to [0, 1) within the part of [0, 1) that chose it, reusable as a
/// fresh uniform number.
pub fn split(u: f32, p: f32) -> (bool, f32) {
    let (first, v) = if u < p { (true, u / p) } else { (false, (u - p) / (1.0 - p)) };
    (first, v.min(ONE_BELOW))
}

/// Cosine-weighted hemisphere around +z; pdf = cos θ / π.
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d[0] * d[0] - d[1] * d[1]).max(0.0).sqrt();
    Vec3::new(d[0], d[1], z)
}

/// Cosine-weighted direction around the unit normal `n` (the one cosine sampler: diffuse BSDFs,
/// emission from area lights); pdf = (wi · n) / π.
pub fn cosine_around(n: Vec3, u: [f32; 2]) -> Vec3 {
    crate::math::Frame::from_normal(n).to_world(cosine_hemisphere(u))
}

/// Shirley–Chiu concentric map from the square to the unit disk.
pub fn concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, theta) = if a.abs() > b.abs() { (a, PI / 4.0 * (b / a)) } else { (b, PI / 2.0 - PI / 4.0 * (a / b)) };
    [r * theta.cos(), r * theta.sin()]
}

/// Uniform direction on the unit sphere; pdf = 1 / 4π.
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone around +z with cos θ ≥ cos_max, given `one_minus_cos_max`
/// = 1 − cos_max (computed stably by the caller: a far, small cone has 1 − cos_max far below f32's
/// epsilon around 1); pdf = 1 / (2π · one_minus_cos_max). sin θ comes from (1 − cos θ)(1 + cos θ),
/// so the directions of a tiny cone keep their spread.
pub fn uniform_cone(u: [f32; 2], one_minus_cos_max: f32) -> Vec3 {
    let one_minus = u[0] * one_minus_cos_max;
    let cos_t = 1.0 - one_minus;
    let sin_t = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Uniform barycentrics on a triangle: returns (b1, b2) for p = (1 − b1 − b2) v0 + b1 v1 + b2 v2.
/// Point `k` of an `n`-point Hammersley set in the unit square (stratified in the first coordinate).
pub fn hammersley(k: usize, n: usize) -> [f32; 2] {
    [(k as f32 + 0.5) / n as f32, (k as u32).reverse_bits() as f32 / 4_294_967_296.0]
}

pub fn uniform_triangle(u: [f32; 2]) -> [f32; 2] {
    let su = u[0].sqrt();
    [1.0 - su, u[1] * su]
}

/// Power heuristic (β = 2) for multiple importance sampling.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a.is_infinite() {
        return if b.is_infinite() { 0.5 } else { 1.0 };
    }
    if a + b == 0.0 || b.is_infinite() {
        0.0
    } else {
        a / (a + b)
    }
}

/// Russian roulette as pbrt-v4 plays it: a path whose throughput (without refraction's radiance scale)
/// has fallen below 1 survives with that throughput as its probability, decided by the uniform `u`;
/// one at 1 or above is never cut (a perfect mirror or a clear glass chain loses nothing, so killing it
/// would only add noise). Returns the survival probability to divide by, or None when the path ends.
/// Camera paths and photons share it, so both sides of a comparison cut paths alike.
pub fn russian_roulette(throughput: f32, u: f32) -> Option<f32> {
    if throughput >= 1.0 {
        return Some(1.0);
    }
    (throughput > 0.0 && u < throughput).then_some(throughput)
}

/// Walker–Vose alias table: draws index i with probability w_i / Σw in O(1), one random access
/// (a binary search over a CDF of a million triangles costs twenty cache misses).
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    prob: Vec<f32>,
    alias: Vec<u32>,
}

impl AliasTable {
    pub fn new(weights: &[f32]) -> AliasTable {
        let n = weights.len();
        let sum: f64 = weights.iter().map(|&w| w.max(0.0) as f64).sum();
        if n == 0 || sum <= 0.0 {
            return AliasTable { prob: vec![1.0; n], alias: (0..n as u32).collect() };
        }
        let mut scaled: Vec<f64> = weights.iter().map(|&w| w.max(0.0) as f64 * n as f64 / sum).collect();
        let mut prob = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            prob[s] = scaled[s] as f32;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        AliasTable { prob, alias }
    }

    /// An index drawn with its weight's probability, from a 32-bit random integer and a uniform coin.
    pub fn sample(&self, bits: u32, coin: f32) -> usize {
        let i = ((bits as u64 * self.prob.len() as u64) >> 32) as usize;
        if coin < self.prob[i] {
            i
        } else {
            self.alias[i] as usize
        }
    }
}

/// Samples an index from a cumulative distribution (last entry = total); returns (index, probability).
pub fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32) {
    let total = *cdf.last().unwrap_or(&0.0);
    let x = u * total;
    let i = cdf.partition_point(|&c| c <= x).min(cdf.len().saturating_sub(1));
    let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
    (i, (cdf[i] - lo) / total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn cosine_hemisphere_integrates_cos_correctly() {
        // E[1/pdf] over the hemisphere must equal its solid angle 2π... estimated with cos-weighted samples:
        // E[cos θ] under pdf cosθ/π equals ∫cos²θ dω / π = 2/3.
        let mut r = Rng::new(3, 0, 0);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| cosine_hemisphere(r.next_2d()).z as f64).sum::<f64>() / n as f64;
        assert!((mean - 2.0 / 3.0).abs() < 0.005, "{mean}");
    }

    #[test]
    fn cone_stays_inside_and_sphere_is_unit() {
        let mut r = Rng::new(4, 0, 0);
        for _ in 0..10_000 {
            let d = uniform_cone(r.next_2d(), 0.1);
            assert!(d.z >= 0.9 - 1e-6 && (d.length() - 1.0).abs() < 1e-5);
            assert!((uniform_sphere(r.next_2d()).length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn alias_table_matches_weights() {
        let w = [1.0, 0.0, 3.0, 4.0, 0.5];
        let t = AliasTable::new(&w);
        let mut counts = [0usize; 5];
        let mut r = Rng::new(6, 0, 0);
        let n = 400_000;
        for _ in 0..n {
            counts[t.sample(r.next_u32(), r.next_f32())] += 1;
        }
        assert_eq!(counts[1], 0);
        for (c, wi) in counts.iter().zip(w) {
            let p = wi / 8.5;
            assert!((*c as f32 / n as f32 - p).abs() < 0.005, "{counts:?}");
        }
    }

    #[test]
    fn cdf_sampling_matches_weights() {
        let cdf = [1.0, 1.0, 4.0, 8.0];
        let mut counts = [0usize; 4];
        let mut r = Rng::new(5, 0, 0);
        for _ in 0..80_000 {
            let (i, p) = sample_cdf(&cdf, r.next_f32());
            counts[i] += 1;
            let expect = [0.125, 0.0, 0.375, 0.5][i];
            assert!((p - expect).abs() < 1e-6);
        }
        assert_eq!(counts[1], 0);
        assert!((counts[3] as f64 / 80_000.0 - 0.5).abs() < 0.01);
    }
}
