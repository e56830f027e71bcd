//! Deterministic random numbers keyed by (seed, stream, index): a pixel and sample, or a photon index.
//! The generator is PCG32 seeded through a SplitMix64 hash of the key, so results never depend on threads.
//!
//! Camera samples can instead draw from an Owen-scrambled Sobol sequence (`Rng::sobol`, the
//! `sobol_burley` crate: Burley's hash-based scrambling, Kuo et al.'s direction numbers): the i-th
//! `next_f32` of sample s in pixel p is dimension i of point s of a sequence scrambled per pixel, so
//! the samples of one pixel are stratified in every dimension and in 2-D projections of consecutive
//! pairs. Past the sequence's 256 dimensions or 2^16 samples it continues with the keyed PCG32 stream.

/// SplitMix64 finaliser: a good 64-bit hash used to derive independent streams.
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Where camera samples come from (`render.sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sampler {
    /// Owen-scrambled Sobol points per pixel (low discrepancy), then PCG32.
    #[default]
    Sobol,
    /// PCG32 streams keyed by (seed, pixel, sample).
    Independent,
}

/// PCG32 (O'Neill), 64-bit state, optionally fronted by a scrambled Sobol sequence.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
    /// The Sobol stream of a camera sample, when drawing from it.
    sobol: Option<SobolStream>,
}

/// Sample `index` of a Sobol sequence scrambled by `seed`, read one dimension at a time; dimensions are
/// computed four at a time (`sobol_burley::sample_4d`, the same values as `sample` gives one by one).
#[derive(Clone, Debug)]
struct SobolStream {
    index: u32,
    seed: u32,
    dim: u32,
    four: [f32; 4],
}

/// Dimensions and samples `sobol_burley` provides.
const SOBOL_DIMS: u32 = 256;
const SOBOL_SAMPLES: u64 = 1 << 16;

impl Rng {
    /// A generator for one (seed, a, b) key, e.g. (seed, pixel, sample) or (seed, map, photon).
    pub fn new(seed: u64, a: u64, b: u64) -> Rng {
        let h = mix64(seed ^ mix64(a ^ mix64(b.wrapping_add(0x632B_E59B_D9B4_E019))));
        let inc = (mix64(h ^ 0xDA94_2042_E4DD_58B5) << 1) | 1;
        let mut r = Rng { state: 0, inc, sobol: None };
        r.next_u32();
        r.state = r.state.wrapping_add(h);
        r.next_u32();
        r
    }

    /// The generator for camera sample `index` of `pixel` under `sampler`.
    /// Camera streams are keyed apart from photon streams (which use (seed, pass, photon)), so pixel p's
    /// sample s never replays photon s of pass p.
    pub fn camera(sampler: Sampler, seed: u64, pixel: u64, index: u64) -> Rng {
        let seed = mix64(seed ^ 0xCA3E_3A00_0000_0001);
        match sampler {
            Sampler::Sobol => Rng::sobol(seed, pixel, index),
            Sampler::Independent => Rng::new(seed, pixel, index),
        }
    }

    /// A camera sample: sample `index` of `pixel`, its `next_f32`/`next_2d` draws taken from an Owen-scrambled
    /// Sobol sequence scrambled per (seed, pixel); beyond 2^16 samples or 256 draws, the keyed PCG32 stream.
    pub fn sobol(seed: u64, pixel: u64, index: u64) -> Rng {
        let mut r = Rng::new(seed, pixel, index);
        if index < SOBOL_SAMPLES {
            let scramble = mix64(seed ^ mix64(pixel ^ 0x50B0_1A5E_ED00_0000)) as u32;
            r.sobol = Some(SobolStream { index: index as u32, seed: scramble, dim: 0, four: [0.0; 4] });
        }
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        if let Some(s) = &mut self.sobol {
            if s.dim < SOBOL_DIMS {
                if s.dim % 4 == 0 {
                    s.four = sobol_burley::sample_4d(s.index, s.dim / 4, s.seed);
                }
                let v = s.four[(s.dim % 4) as usize];
                s.dim += 1;
                return v;
            }
        }
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_mean_and_variance() {
        let mut r = Rng::new(1, 2, 3);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = r.next_f32() as f64;
            assert!((0.0..1.0).contains(&x));
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
        assert!((var - 1.0 / 12.0).abs() < 0.002, "{var}");
    }

    /// The Sobol draws of one pixel are stratified: 256 samples put exactly one point in each of 256
    /// equal bins of every dimension tried, and one in each cell of a 16×16 grid of the first pair;
    /// independent draws leave bins empty.
    #[test]
    fn sobol_samples_of_a_pixel_are_stratified() {
        for pixel in [0u64, 7, 123_456] {
            let draws: Vec<Vec<f32>> = (0..256)
                .map(|s| {
                    let mut r = Rng::sobol(42, pixel, s);
                    (0..8).map(|_| r.next_f32()).collect()
                })
                .collect();
            for d in 0..8 {
                let mut bins = [0u32; 256];
                draws.iter().for_each(|v| bins[(v[d] * 256.0) as usize] += 1);
                assert!(bins.iter().all(|&b| b == 1), "pixel {pixel}, dimension {d}: {bins:?}");
            }
            let mut cells = [0u32; 256];
            draws.iter().for_each(|v| cells[(v[0] * 16.0) as usize * 16 + (v[1] * 16.0) as usize] += 1);
            assert!(cells.iter().all(|&c| c == 1), "pixel {pixel}: first pair not stratified");
        }
        let mut bins = [0u32; 256];
        (0..256).for_each(|s| bins[(Rng::new(42, 0, s).next_f32() * 256.0) as usize] += 1);
        assert!(bins.contains(&0), "independent draws stratified by chance?");
    }

    /// Drawing four dimensions at a time gives exactly the values of `sobol_burley::sample`.
    #[test]
    fn sobol_draws_match_the_crate_one_dimension_at_a_time() {
        let mut r = Rng::sobol(5, 77, 9);
        let seed = r.sobol.as_ref().map(|s| s.seed).unwrap();
        for d in 0..SOBOL_DIMS {
            assert_eq!(r.next_f32().to_bits(), sobol_burley::sample(9, d, seed).to_bits(), "dimension {d}");
        }
    }

    /// Different pixels get different scrambles, and draws past the Sobol dimensions still vary.
    #[test]
    fn sobol_pixels_differ_and_high_dimensions_fall_back() {
        let a: Vec<f32> = (0..4).scan(Rng::sobol(1, 0, 3), |r, _| Some(r.next_f32())).collect();
        let b: Vec<f32> = (0..4).scan(Rng::sobol(1, 1, 3), |r, _| Some(r.next_f32())).collect();
        assert_ne!(a, b);
        let mut r = Rng::sobol(1, 0, 3);
        let tail: Vec<f32> = (0..300).map(|_| r.next_f32()).skip(256).collect();
        assert!(tail.iter().all(|x| (0.0..1.0).contains(x)));
        assert!(tail.windows(2).any(|w| w[0] != w[1]));
    }

    #[test]
    fn keys_give_different_streams() {
        let a: Vec<u32> = (0..8).map(|_| 0).scan(Rng::new(1, 0, 0), |r, _| Some(r.next_u32())).collect();
        let b: Vec<u32> = (0..8).map(|_| 0).scan(Rng::new(1, 0, 1), |r, _| Some(r.next_u32())).collect();
        let c: Vec<u32> = (0..8).map(|_| 0).scan(Rng::new(1, 0, 0), |r, _| Some(r.next_u32())).collect();
        assert_ne!(a, b);
        assert_eq!(a, c);
    }
}
