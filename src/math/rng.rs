//! Deterministic random numbers keyed by (seed, stream, index): a pixel and sample, or a photon index.
//! The generator is PCG32 seeded through a SplitMix64 hash of the key, so results never depend on threads.

/// SplitMix64 finaliser: a good 64-bit hash used to derive independent streams.
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// PCG32 (O'Neill), 64-bit state.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A generator for one (seed, a, b) key, e.g. (seed, pixel, sample) or (seed, map, photon).
    pub fn new(seed: u64, a: u64, b: u64) -> Rng {
        let h = mix64(seed ^ mix64(a ^ mix64(b.wrapping_add(0x632B_E59B_D9B4_E019))));
        let inc = (mix64(h ^ 0xDA94_2042_E4DD_58B5) << 1) | 1;
        let mut r = Rng { state: 0, inc };
        r.next_u32();
        r.state = r.state.wrapping_add(h);
        r.next_u32();
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

    #[test]
    fn keys_give_different_streams() {
        let a: Vec<u32> = (0..8).map(|_| 0).scan(Rng::new(1, 0, 0), |r, _| Some(r.next_u32())).collect();
        let b: Vec<u32> = (0..8).map(|_| 0).scan(Rng::new(1, 0, 1), |r, _| Some(r.next_u32())).collect();
        let c: Vec<u32> = (0..8).map(|_| 0).scan(Rng::new(1, 0, 0), |r, _| Some(r.next_u32())).collect();
        assert_ne!(a, b);
        assert_eq!(a, c);
    }
}
