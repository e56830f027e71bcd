//! The stored photon: position (f32×3, kept by the k-d tree in structure-of-arrays form), power in
//! shared-exponent RGBE (4 bytes), incoming direction octahedral-encoded (2 bytes), and the normal of
//! the surface it landed on, facing where it came from, in one byte (4+4-bit octahedral, within 20°).
//! 19 bytes per photon plus the tree's split planes (≈ 0.3 byte per photon), no per-node pointers.
use crate::color::Rgb;
use glam::Vec3;

/// What the photon map stores beside each position.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct PhotonPayload {
    pub power: [u8; 4],
    pub dir: [u8; 2],
    pub normal: u8,
}

/// A photon before it goes into a tree.
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    pub p: Vec3,
    /// Direction of travel (towards the surface), unit length.
    pub wi: Vec3,
    pub phi: Rgb,
    /// Unit normal of the surface it landed on, on the side it arrived from.
    pub n: Vec3,
}

impl Photon {
    pub fn payload(&self) -> PhotonPayload {
        PhotonPayload { power: rgbe_encode(self.phi), dir: oct_encode(self.wi), normal: oct_encode_coarse(self.n) }
    }
}

impl PhotonPayload {
    pub fn phi(&self) -> Rgb {
        rgbe_decode(self.power)
    }
    pub fn wi(&self) -> Vec3 {
        oct_decode(self.dir)
    }
    pub fn n(&self) -> Vec3 {
        oct_decode_coarse(self.normal)
    }
}

/// Ward's RGBE: three 8-bit mantissas sharing one exponent (relative error below 1% of the largest channel).
pub fn rgbe_encode(c: Rgb) -> [u8; 4] {
    let m = c.max_element();
    if m.is_nan() || m <= 1e-32 || !m.is_finite() {
        return [0; 4];
    }
    let (mant, exp) = frexp(m);
    let scale = mant * 256.0 / m;
    let q = |x: f32| ((x.max(0.0) * scale) as u32).min(255) as u8;
    [q(c.x), q(c.y), q(c.z), (exp + 128).clamp(0, 255) as u8]
}

pub fn rgbe_decode(e: [u8; 4]) -> Rgb {
    if e[3] == 0 {
        return Rgb::ZERO;
    }
    let f = 2f32.powi(e[3] as i32 - (128 + 8));
    Rgb::new((e[0] as f32 + 0.5) * f, (e[1] as f32 + 0.5) * f, (e[2] as f32 + 0.5) * f)
}

/// x = mant · 2^exp with mant in [0.5, 1).
fn frexp(x: f32) -> (f32, i32) {
    let exp = x.log2().floor() as i32 + 1;
    let mut mant = x / 2f32.powi(exp);
    let mut exp = exp;
    if mant >= 1.0 {
        mant /= 2.0;
        exp += 1;
    } else if mant < 0.5 {
        mant *= 2.0;
        exp -= 1;
    }
    (mant, exp)
}

/// Octahedral encoding in one byte (4 bits per coordinate): enough to tell surfaces apart.
pub fn oct_encode_coarse(v: Vec3) -> u8 {
    let (x, y) = oct_square(v);
    // 15 levels (0..=14) so that −1, 0 and 1 are exact: axis-aligned walls keep exact normals.
    let q = |t: f32| (((t * 0.5 + 0.5) * 14.0).round()).clamp(0.0, 14.0) as u8;
    q(x) << 4 | q(y)
}

pub fn oct_decode_coarse(e: u8) -> Vec3 {
    oct_unsquare((e >> 4) as f32 / 14.0 * 2.0 - 1.0, (e & 15) as f32 / 14.0 * 2.0 - 1.0)
}

/// The unit vector folded onto the octahedral square [−1, 1]².
fn oct_square(v: Vec3) -> (f32, f32) {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    if l1 == 0.0 || !l1.is_finite() {
        return (0.0, 0.0);
    }
    let (x, y) = (v.x / l1, v.y / l1);
    if v.z < 0.0 {
        ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum())
    } else {
        (x, y)
    }
}

fn oct_unsquare(x: f32, y: f32) -> Vec3 {
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 { ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum()) } else { (x, y) };
    Vec3::new(x, y, z).normalize()
}

/// Octahedral encoding of a unit vector in two bytes.
pub fn oct_encode(v: Vec3) -> [u8; 2] {
    let (x, y) = oct_square(v);
    let q = |t: f32| (((t * 0.5 + 0.5) * 255.0).round()).clamp(0.0, 255.0) as u8;
    [q(x), q(y)]
}

pub fn oct_decode(e: [u8; 2]) -> Vec3 {
    oct_unsquare(e[0] as f32 / 255.0 * 2.0 - 1.0, e[1] as f32 / 255.0 * 2.0 - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{sampling::uniform_sphere, Rng};

    #[test]
    fn payload_is_seven_bytes() {
        assert_eq!(std::mem::size_of::<PhotonPayload>(), 7);
    }

    #[test]
    fn rgbe_round_trip_within_one_percent_of_max() {
        let mut r = Rng::new(1, 0, 0);
        for _ in 0..10_000 {
            let s = 10f32.powf(r.next_f32() * 40.0 - 20.0);
            let c = Rgb::new(r.next_f32(), r.next_f32(), r.next_f32()) * s;
            let d = rgbe_decode(rgbe_encode(c));
            assert!((d - c).abs().max_element() <= 0.01 * c.max_element(), "{c} -> {d}");
        }
        assert_eq!(rgbe_decode(rgbe_encode(Rgb::ZERO)), Rgb::ZERO);
    }

    #[test]
    fn coarse_normal_round_trip_within_twenty_degrees() {
        let mut r = Rng::new(3, 0, 0);
        for _ in 0..10_000 {
            let v = uniform_sphere(r.next_2d());
            let d = oct_decode_coarse(oct_encode_coarse(v));
            assert!(v.dot(d) > 20f32.to_radians().cos(), "{v} -> {d}");
        }
        for v in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            assert!(oct_decode_coarse(oct_encode_coarse(v)).dot(v) > 0.999);
        }
    }

    #[test]
    fn octahedral_round_trip_within_one_degree() {
        let mut r = Rng::new(2, 0, 0);
        for _ in 0..10_000 {
            let v = uniform_sphere(r.next_2d());
            let d = oct_decode(oct_encode(v));
            assert!(v.dot(d) > 1.0f32.to_radians().cos(), "{v} -> {d}");
        }
    }
}
