//! Deterministic random numbers keyed by (seed, stream, index): a pixel and sample, or a photon index.
//! The generator is PCG32 seeded through a SplitMix64 hash of the key, so results never depend on threads.
//!
//! Camera samples can instead draw from an Owen-scrambled Sobol sequence (`Rng::sobol`, the
//! `sobol_burley` crate: Burley's hash-based scrambling, Kuo et al.'s direction numbers): the i-th
//! `next_f32` of sample s in pixel p is dimension i of point s of a sequence scrambled per pixel, so
//! the samples of one pixel are stratified in every dimension and in 2-D projections of consecutive
//! pairs. Only the first 16 draws come from it: the pixel's position, a lens, the first vertex's light
//! and BSDF samples, which it stratifies jointly. The draws after those come from padded
//! (0,2)-sequences (below), which stratify each draw alone at a hash and a few table reads a draw,
//! where four Sobol dimensions cost a matrix product: on long paths that product cost a seventh of the
//! time (`tests/mitsuba/phase.xml`, a fog of up to 24 bounces, 128 spp, interleaved runs: 4.19 s median
//! user time against 4.86 s with 256 Sobol draws, the same variance). Past 2^16 samples the whole
//! sample draws from the padded sequences.
//!
//! Or from padded (0,2)-sequences (`Rng::padded`, pbrt-v4's PaddedSobol, the kind of
//! sampler Mitsuba's `ldsampler` is): each draw, a `next_f32` or a `next_2d`, takes the first one or two
//! dimensions of the Sobol sequence with the samples' order shuffled by an Owen scramble of the index
//! (Burley 2020, "Practical hash-based Owen scrambling") and the values randomly shifted (XOR), keyed
//! per draw. Every 1-D draw is stratified, every 2-D draw a (0, m, 2)-net over the first 2^m samples,
//! with no limit on the number of draws; draws are not stratified against one another. It costs a
//! hash and a few table reads a draw, where each four dimensions of the Sobol stream cost a matrix
//! product. Measured in session 78: on Mitsuba's Cornell box it needs 8–14% less time than Sobol for
//! about the same error (RMSE² × time 7–12% lower from 16 to 256 spp), but at 1024 spp on
//! `tests/mitsuba/filter-catmullrom.xml` its variance is 1.38× Sobol's, whose draws are stratified
//! jointly (the pixel's position with the first light sample): Sobol stays the default.

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
    /// Owen-scrambled Sobol points per pixel (low discrepancy) for a sample's first 16 draws, padded
    /// (0,2)-sequences for the rest.
    #[default]
    Sobol,
    /// PCG32 streams keyed by (seed, pixel, sample).
    Independent,
    /// (0,2)-sequences per pixel, one per 1-D or 2-D draw, shuffled apart (pbrt-v4's PaddedSobol, the
    /// kind of sampler Mitsuba's `ldsampler` is): cheaper than `Sobol` a sample, noisier at high counts.
    Padded,
}

/// PCG32 (O'Neill), 64-bit state, optionally fronted by a scrambled Sobol sequence.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
    /// The low-discrepancy stream of a camera sample, when drawing from one.
    lds: Option<Lds>,
}

/// A camera sample's low-discrepancy stream.
#[derive(Clone, Debug)]
enum Lds {
    Sobol(SobolStream),
    Padded(PaddedStream),
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

/// Sample `index` of a pixel's padded (0,2)-sequences: draw `slot` is keyed by (`seed`, `slot`).
#[derive(Clone, Debug)]
struct PaddedStream {
    /// The sample's index with its bits reversed (the form the shuffle works on).
    reversed: u32,
    seed: u32,
    /// The slot of the draw after `ready`.
    slot: u32,
    /// The next draw's point, computed ahead: a draw's hashes are a long chain of dependent
    /// multiplications, and with the point ready the work that uses it does not wait for them (a 1-D
    /// draw takes its first coordinate, which is what a 1-D draw of that slot is). `tests/mitsuba/phase.xml`
    /// at 512 spp: 8.15–8.37 s computed ahead, 8.77–8.89 s computed when drawn (three runs each).
    ready: [f32; 2],
}

/// A 32-bit integer hash (Wellons' lowbias32): every input bit reaches every output bit.
fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// Burley's Laine–Karras-style hash: output bit k depends only on input bits 0..=k and the seed, so on
/// bit-reversed values it is a random nested uniform (Owen) scramble in base 2.
fn lk_hash(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^ x.wrapping_mul(0x53a2_2864)
}

/// Sobol's second dimension as a function of the point's index with its bits reversed, as four tables
/// of a byte each: entry j of table b is the XOR of the columns v_k for the bits of j (bit i of byte b
/// is bit 31 − 8b − i of the index, which selects k = 32 − 8b − i), where v₁ = 2³¹,
/// v_k = v_{k−1} ⊕ (v_{k−1} >> 1) (the polynomial x + 1: Pascal's triangle mod 2).
const SOBOL_1: [[u32; 256]; 4] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut j = 0;
        while j < 256 {
            let mut x = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if j >> bit & 1 == 1 {
                    x ^= v[31 - 8 * b - bit];
                }
                bit += 1;
            }
            t[b][j] = x;
            j += 1;
        }
        b += 1;
    }
    t
};

/// Sobol's second dimension (0.32 fixed point) of the point whose index reversed is `u`.
fn sobol_1(u: u32) -> u32 {
    let b = u.to_le_bytes();
    let t = &SOBOL_1;
    t[0][b[0] as usize] ^ t[1][b[1] as usize] ^ t[2][b[2] as usize] ^ t[3][b[3] as usize]
}

/// 0.32 fixed point to a float in [0, 1) (its top 24 bits, exactly representable).
fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

impl PaddedStream {
    fn new(index: u32, seed: u32) -> PaddedStream {
        let mut p = PaddedStream { reversed: index.reverse_bits(), seed, slot: 0, ready: [0.0; 2] };
        p.ready = p.compute();
        p
    }

    /// The point of draw `slot`, which then moves on. Its keys: a shuffle of the samples' order and a
    /// random digital shift per dimension. The shuffle Owen-scrambles the sample's index (a nonlinear
    /// hash of its reversed bits, so no two draws pair their samples alike), which maps each aligned
    /// block of 2^m indices onto one, so the first 2^m samples (any aligned block of them) stay a net.
    /// The shuffled index reversed, `u`, is Sobol's first dimension of that point; the shifts (XOR)
    /// keep the net.
    fn compute(&mut self) -> [f32; 2] {
        let h = mix64(((self.seed as u64) << 32) | self.slot as u64);
        self.slot = self.slot.wrapping_add(1);
        let (shuffle, x) = (h as u32, (h >> 32) as u32);
        let u = lk_hash(self.reversed, shuffle);
        [unit(u ^ x), unit(sobol_1(u) ^ hash32(x))]
    }

    fn next_2d(&mut self) -> [f32; 2] {
        let v = self.ready;
        self.ready = self.compute();
        v
    }
}

/// The draws a camera sample takes from Sobol's dimensions (`sobol_burley` provides 256), before it
/// continues with padded sequences: enough for the pixel, a lens and the first vertex's light pick,
/// light point, BSDF lobe and direction and its Russian roulette. Joint stratification matters there:
/// at 1024 spp on `tests/mitsuba/filter-catmullrom.xml` (a fine checkerboard under a direct light) the
/// variance with 4 Sobol draws is 1.16× that with 8 or more, with none (all padded) 1.40×; on
/// `tests/mitsuba/thinlens.xml` all padded is 2.8× (the lens against the pixel).
const SOBOL_DIMS: u32 = 16;
/// Samples `sobol_burley` provides.
const SOBOL_SAMPLES: u64 = 1 << 16;

impl Rng {
    /// A generator for one (seed, a, b) key, e.g. (seed, pixel, sample) or (seed, map, photon).
    pub fn new(seed: u64, a: u64, b: u64) -> Rng {
        let h = mix64(seed ^ mix64(a ^ mix64(b.wrapping_add(0x632B_E59B_D9B4_E019))));
        let inc = (mix64(h ^ 0xDA94_2042_E4DD_58B5) << 1) | 1;
        let mut r = Rng { state: 0, inc, lds: None };
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
            Sampler::Padded => Rng::padded(seed, pixel, index),
        }
    }

    /// A camera sample: sample `index` of `pixel`, its first `SOBOL_DIMS` draws (a `next_2d` is two) taken
    /// from an Owen-scrambled Sobol sequence scrambled per (seed, pixel), the rest from padded (0,2)-sequences
    /// keyed by (seed, pixel, draw); beyond 2^16 samples all from the padded sequences.
    pub fn sobol(seed: u64, pixel: u64, index: u64) -> Rng {
        if index >= SOBOL_SAMPLES {
            return Rng::padded(seed, pixel, index);
        }
        let mut r = Rng::new(seed, pixel, index);
        let scramble = mix64(seed ^ mix64(pixel ^ 0x50B0_1A5E_ED00_0000)) as u32;
        r.lds = Some(Lds::Sobol(SobolStream { index: index as u32, seed: scramble, dim: 0, four: [0.0; 4] }));
        r
    }

    /// A camera sample: sample `index` of `pixel`, each `next_f32` or `next_2d` from a padded
    /// (0,2)-sequence keyed by (seed, pixel, draw); beyond 2^32 samples, the keyed PCG32 stream.
    pub fn padded(seed: u64, pixel: u64, index: u64) -> Rng {
        let mut r = Rng::new(seed, pixel, index);
        if let Ok(index) = u32::try_from(index) {
            let key = mix64(seed ^ mix64(pixel ^ 0x9add_ed50_b010_0000)) as u32;
            r.lds = Some(Lds::Padded(PaddedStream::new(index, key)));
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
        match &mut self.lds {
            Some(Lds::Sobol(s)) => {
                if s.dim % 4 == 0 {
                    s.four = sobol_burley::sample_4d(s.index, s.dim / 4, s.seed);
                }
                let v = s.four[(s.dim % 4) as usize];
                s.dim += 1;
                if s.dim == SOBOL_DIMS {
                    // Its Sobol draws used up, the sample goes on with its padded sequences, keyed apart
                    // from the scramble (and from the padded sampler's own keys).
                    let p = PaddedStream::new(s.index, hash32(s.seed ^ 0xA5B3_0F1D));
                    self.lds = Some(Lds::Padded(p));
                }
                return v;
            }
            Some(Lds::Padded(p)) => return p.next_2d()[0],
            None => {}
        }
        unit(self.next_u32())
    }

    /// Two numbers in [0, 1) meant as one 2-D sample (a point on a pixel, a lens, a light, a direction):
    /// the padded sampler stratifies them jointly.
    pub fn next_2d(&mut self) -> [f32; 2] {
        if let Some(Lds::Padded(p)) = &mut self.lds {
            return p.next_2d();
        }
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
        let Some(Lds::Sobol(SobolStream { seed, .. })) = r.lds else { panic!("not a Sobol stream") };
        for d in 0..SOBOL_DIMS {
            assert_eq!(r.next_f32().to_bits(), sobol_burley::sample(9, d, seed).to_bits(), "dimension {d}");
        }
    }

    /// Each 2-D draw of the padded sampler is a (0, m, 2)-net: over the first 2^m samples of a pixel,
    /// and over any aligned block of 2^m, every elementary interval of area 2^−m (2^j by 2^(m−j) cells,
    /// all j) holds exactly one point, whatever 1-D and 2-D draws came before it; each 1-D draw puts one
    /// sample in each of 2^m equal bins.
    #[test]
    fn padded_draws_are_nets() {
        for pixel in [0u64, 9, 77_777] {
            for start in [0u64, 1024, 5 * 1024] {
                let n = 1024usize;
                let draws: Vec<Vec<[f32; 2]>> = (start..start + n as u64)
                    .map(|s| {
                        let mut r = Rng::padded(3, pixel, s);
                        vec![r.next_2d(), [r.next_f32(), 0.5], r.next_2d(), [r.next_f32(), r.next_f32()], r.next_2d()]
                    })
                    .collect();
                for m in 0..=10u32 {
                    let block = &draws[..1 << m];
                    for d in [0usize, 2, 4] {
                        for j in 0..=m {
                            let (nx, ny) = (1usize << j, 1usize << (m - j));
                            let mut cells = vec![0u32; 1 << m];
                            for v in block {
                                let [x, y] = v[d];
                                cells[(x * nx as f32) as usize * ny + (y * ny as f32) as usize] += 1;
                            }
                            assert!(
                                cells.iter().all(|&c| c == 1),
                                "pixel {pixel}, start {start}, draw {d}, 2^{j} × 2^{}",
                                m - j
                            );
                        }
                    }
                    for d in [1usize, 3] {
                        let mut bins = vec![0u32; 1 << m];
                        block.iter().for_each(|v| bins[(v[d][0] * (1 << m) as f32) as usize] += 1);
                        assert!(bins.iter().all(|&b| b == 1), "pixel {pixel}, 1-D draw {d}, 2^{m} bins");
                    }
                }
            }
        }
    }

    /// The padded sampler's draws are shuffled apart: consecutive draws of 4096 samples are uncorrelated
    /// (|r| < 0.06, about four standard errors; one shuffle shared by all draws gives |r| ≈ 0.75), and pixels
    /// get different points.
    #[test]
    fn padded_draws_are_independent_of_one_another() {
        for pixel in [1u64, 2, 3] {
            let v: Vec<[f32; 4]> = (0..4096)
                .map(|s| {
                    let mut r = Rng::padded(11, pixel, s);
                    let ([a, b], c) = (r.next_2d(), r.next_f32());
                    [a, b, c, r.next_2d()[1]]
                })
                .collect();
            for (i, j) in [(0, 2), (1, 2), (2, 3), (0, 3), (1, 3)] {
                let n = v.len() as f64;
                let (mi, mj) = (0.5, 0.5);
                let cov = v.iter().map(|x| (x[i] as f64 - mi) * (x[j] as f64 - mj)).sum::<f64>() / n;
                let r = cov * 12.0;
                assert!(r.abs() < 0.06, "pixel {pixel}: draws {i} and {j} correlate, r = {r:.3}");
            }
        }
        let a: Vec<[f32; 2]> = (0..4).map(|s| Rng::padded(1, 0, s).next_2d()).collect();
        let b: Vec<[f32; 2]> = (0..4).map(|s| Rng::padded(1, 1, s).next_2d()).collect();
        assert_ne!(a, b);
    }

    /// Different pixels get different scrambles, and the draws past the Sobol dimensions, and every draw
    /// of a sample past 2^16, stay stratified draw by draw (they come from padded sequences): over any
    /// aligned block of 256 samples of a pixel, a 1-D draw puts one in each of 256 bins and a 2-D draw
    /// one in each cell of a 16×16 grid, both at the first draw after the Sobol ones and 300 draws in.
    /// (Before, a draw past the 256th and every draw past 2^16 samples were PCG32's, which leaves bins
    /// empty.)
    #[test]
    fn sobol_pixels_differ_and_later_draws_stay_stratified() {
        let a: Vec<f32> = (0..4).scan(Rng::sobol(1, 0, 3), |r, _| Some(r.next_f32())).collect();
        let b: Vec<f32> = (0..4).scan(Rng::sobol(1, 1, 3), |r, _| Some(r.next_f32())).collect();
        assert_ne!(a, b);
        for pixel in [0u64, 31, 4_000_000] {
            for start in [0u64, 256, SOBOL_SAMPLES, 3 * SOBOL_SAMPLES + 512] {
                let draws: Vec<[f32; 6]> = (start..start + 256)
                    .map(|s| {
                        let mut r = Rng::sobol(8, pixel, s);
                        let sobol: Vec<f32> = (0..SOBOL_DIMS).map(|_| r.next_f32()).collect();
                        let (first, pair) = (r.next_f32(), r.next_2d());
                        (0..300).for_each(|_| _ = r.next_f32());
                        let (late, late_pair) = (r.next_f32(), r.next_2d());
                        assert!(sobol.iter().chain(&[first, late]).all(|x| (0.0..1.0).contains(x)));
                        [first, late, pair[0], pair[1], late_pair[0], late_pair[1]]
                    })
                    .collect();
                for (d, what) in [(0, "first 1-D draw past Sobol's"), (1, "a 1-D draw 300 further")] {
                    let mut bins = [0u32; 256];
                    draws.iter().for_each(|v| bins[(v[d] * 256.0) as usize] += 1);
                    assert!(bins.iter().all(|&n| n == 1), "pixel {pixel}, samples from {start}: {what}: {bins:?}");
                }
                for (d, what) in [(2, "first 2-D draw past Sobol's"), (4, "a 2-D draw 300 further")] {
                    let mut cells = [0u32; 256];
                    draws.iter().for_each(|v| cells[(v[d] * 16.0) as usize * 16 + (v[d + 1] * 16.0) as usize] += 1);
                    assert!(cells.iter().all(|&c| c == 1), "pixel {pixel}, samples from {start}: {what}");
                }
            }
        }
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
