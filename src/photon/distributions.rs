//! Synthetic photon sets for the k-d tree's checks and benchmarks: uniform in a cube, clustered,
//! all on one plane, and caustic-like (most photons in a small disc on a floor).
use crate::math::Rng;
use std::str::FromStr;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    Uniform,
    Clustered,
    Plane,
    Caustic,
}

impl FromStr for Distribution {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "uniform" => Distribution::Uniform,
            "clustered" => Distribution::Clustered,
            "plane" => Distribution::Plane,
            "caustic" => Distribution::Caustic,
            _ => return Err(format!("unknown distribution `{s}` (accepted: uniform, clustered, plane, caustic)")),
        })
    }
}

const CLUSTERS: u64 = 64;

fn cluster_center(seed: u64, c: u64) -> [f32; 3] {
    let mut r = Rng::new(seed, 0xC1u64, c);
    [r.next_f32(), r.next_f32(), r.next_f32()]
}

fn point(d: Distribution, seed: u64, stream: u64, i: u64, query: bool) -> [f32; 3] {
    let mut r = Rng::new(seed, stream, i);
    match d {
        Distribution::Uniform => [r.next_f32(), r.next_f32(), r.next_f32()],
        Distribution::Clustered => {
            let c = cluster_center(seed, (r.next_u32() as u64) % CLUSTERS);
            // Sum of three uniforms: a bell of width ≈ 0.02 around the centre.
            let g = |r: &mut Rng| (r.next_f32() + r.next_f32() + r.next_f32() - 1.5) * 0.03;
            [c[0] + g(&mut r), c[1] + g(&mut r), c[2] + g(&mut r)]
        }
        Distribution::Plane => [r.next_f32(), 0.25, r.next_f32()],
        Distribution::Caustic => {
            if query || r.next_f32() < 0.8 {
                let rad = 0.05 * r.next_f32().sqrt();
                let phi = std::f32::consts::TAU * r.next_f32();
                [0.5 + rad * phi.cos(), 0.0, 0.5 + rad * phi.sin()]
            } else {
                [r.next_f32(), 0.0, r.next_f32()]
            }
        }
    }
}

/// `n` photon positions.
pub fn points(d: Distribution, n: usize, seed: u64) -> Vec<[f32; 3]> {
    (0..n as u64).map(|i| point(d, seed, 1, i, false)).collect()
}

/// `m` query positions drawn where a photon map would be queried for this distribution.
pub fn queries(d: Distribution, m: usize, seed: u64) -> Vec<[f32; 3]> {
    (0..m as u64).map(|i| point(d, seed, 2, i, true)).collect()
}
