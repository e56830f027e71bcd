//! The stored photon: position (f32×3, kept by the k-d tree in structure-of-arrays form), power in
//! shared-exponent RGBE (4 bytes), incoming direction octahedral-encoded (2 bytes), and the normal of
//! the surface it landed on, facing where it came from, in one byte (4+4-bit octahedral, within 20°).
//! 19 bytes per photon plus the tree's split planes (≈ 0.3 byte per photon) and the boxes of its upper
//! nodes (≈ 0.1 byte), no per-node pointers.
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

/// Largest path length a stored photon position records exactly; longer paths are stored as this.
pub const EVENTS_CAP: u32 = 7;

/// `p` with a photon path's scattering events (those before it landed plus the gather at its landing
/// point: 1 for a photon straight from a light) recorded in the lowest mantissa bit of each coordinate,
/// capped at `EVENTS_CAP`; 0 records nothing (photons built by hand). Moves the point by at most one
/// unit in the last place per coordinate, and costs the 20-byte photon nothing. A zero (or subnormal)
/// coordinate becomes ±`f32::MIN_POSITIVE` first (1.2e-38 away): a photon on the plane y = 0 would
/// otherwise carry a subnormal coordinate, and arithmetic on subnormals is many times slower (the eye
/// pass of `cornell-glass`, whose floor is at y = 0, took 15% longer).
pub fn with_events(p: [f32; 3], events: u32) -> [f32; 3] {
    let v = events.min(EVENTS_CAP);
    [0, 1, 2].map(|a| {
        let b = p[a].to_bits();
        let b = if b & 0x7fff_ffff < f32::MIN_POSITIVE.to_bits() {
            (b & 0x8000_0000) | f32::MIN_POSITIVE.to_bits()
        } else {
            b
        };
        f32::from_bits((b & !1) | ((v >> a) & 1))
    })
}

/// The scattering events `with_events` recorded in a stored position (0: none recorded).
#[inline(always)]
pub fn events(p: [f32; 3]) -> u32 {
    (p[0].to_bits() & 1) | (p[1].to_bits() & 1) << 1 | (p[2].to_bits() & 1) << 2
}

/// Whether a photon whose position records `events` may be gathered at a point where `budget`
/// scattering events remain of `render.max_depth` (the path tracer's limit on the whole path: the eye
/// side's bounces to the gather point and the photon's own). Exact below `EVENTS_CAP`; a capped record
/// (7 or more) is accepted when 7 remain, which overcounts only photons of more than `budget` ≥ 7
/// events.
#[inline(always)]
pub fn within_depth(events: u32, budget: u32) -> bool {
    events == 0 || events.min(EVENTS_CAP) <= budget
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
    let f = pow2(e[3] as i32 - (128 + 8));
    Rgb::new((e[0] as f32 + 0.5) * f, (e[1] as f32 + 0.5) * f, (e[2] as f32 + 0.5) * f)
}

/// 2^x exactly (subnormal, zero or infinite where it must be), built from the float's bits. `powi`,
/// which this replaces, is a library call and a measurable share of a photon gather; even kept for
/// the rare cases only, the compiler hoisted the call and made it on every decode.
fn pow2(x: i32) -> f32 {
    if x > 127 {
        f32::INFINITY
    } else if x >= -126 {
        f32::from_bits(((x + 127) as u32) << 23)
    } else if x >= -149 {
        f32::from_bits(1u32 << (x + 149))
    } else {
        0.0
    }
}

/// x = mant · 2^exp with mant in [0.5, 1), for finite x > 0, exactly: split by the float's bits (no
/// `log2` call), a subnormal one first scaled by 2^64. (The `log2` and `powi` it replaced returned a
/// zero or infinite mantissa above 2^127 and below 2^-126.) Zero, NaN and infinities come back as
/// (x, 0).
fn frexp(x: f32) -> (f32, i32) {
    if !x.is_normal() {
        if x == 0.0 || !x.is_finite() {
            return (x, 0);
        }
        let (m, e) = frexp(x * pow2(64));
        return (m, e - 64);
    }
    let b = x.to_bits();
    (f32::from_bits((b & 0x807f_ffff) | (126 << 23)), ((b >> 23) & 0xff) as i32 - 126)
}

/// Octahedral encoding in one byte (4 bits per coordinate): enough to tell surfaces apart.
pub fn oct_encode_coarse(v: Vec3) -> u8 {
    let (x, y) = oct_square(v);
    // 15 levels (0..=14) so that −1, 0 and 1 are exact: axis-aligned walls keep exact normals.
    let q = |t: f32| (((t * 0.5 + 0.5) * 14.0).round()).clamp(0.0, 14.0) as u8;
    q(x) << 4 | q(y)
}

/// The unit normal of a one-byte code: read from a table of all 256, made once.
pub fn oct_decode_coarse(e: u8) -> Vec3 {
    static TABLE: std::sync::LazyLock<[Vec3; 256]> =
        std::sync::LazyLock::new(|| std::array::from_fn(|e| oct_decode_coarse_direct(e as u8)));
    TABLE[e as usize]
}

fn oct_decode_coarse_direct(e: u8) -> Vec3 {
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
    fn events_ride_in_the_lowest_mantissa_bits() {
        let mut r = Rng::new(9, 0, 0);
        for _ in 0..10_000 {
            let p = [r.next_f32() * 8.0 - 4.0, -r.next_f32() * 1e6, r.next_f32() * 1e-30];
            for e in 0..12u32 {
                let q = with_events(p, e);
                assert_eq!(events(q), e.min(EVENTS_CAP));
                for a in 0..3 {
                    let ulp = (p[a].to_bits() as i64 - q[a].to_bits() as i64).abs();
                    assert!(ulp <= 1 && q[a].signum() == p[a].signum(), "{p:?} -> {q:?}");
                }
            }
        }
        // Zeros and subnormals become normal numbers (never a subnormal coordinate), with their sign.
        for p in [[0.0, -0.0, 1.0], [1e-40, -1e-42, f32::MIN_POSITIVE], [0.0, 0.0, 0.0]] {
            for e in 0..8u32 {
                let q = with_events(p, e);
                assert_eq!(events(q), e);
                for a in 0..3 {
                    assert!(q[a].is_normal() && q[a].is_sign_negative() == p[a].is_sign_negative(), "{p:?} -> {q:?}");
                    assert!(
                        (q[a] - p[a]).abs() <= (2.0 * f32::MIN_POSITIVE).max(p[a].abs() * f32::EPSILON),
                        "{p:?} -> {q:?}"
                    );
                }
            }
        }
        // A path of e events fits a budget of b iff e <= b (exact below the cap; none recorded: always).
        for b in 0..20 {
            for e in 1..EVENTS_CAP {
                assert_eq!(within_depth(e, b), e <= b);
            }
            assert_eq!(within_depth(EVENTS_CAP, b), b >= EVENTS_CAP);
            assert!(within_depth(0, b));
        }
    }

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
    fn frexp_splits_exactly() {
        let mut r = Rng::new(5, 0, 0);
        for _ in 0..100_000 {
            let x = f32::from_bits(r.next_u32() & 0x7fff_ffff);
            if !(x.is_finite() && x > 0.0) {
                continue;
            }
            let (m, e) = frexp(x);
            assert!((0.5..1.0).contains(&m), "{x}: mantissa {m}");
            assert_eq!((m as f64) * 2f64.powi(e), x as f64, "{x} = {m} · 2^{e}");
        }
    }

    #[test]
    fn fast_decodes_equal_the_direct_ones_bit_for_bit() {
        for x in -200..200 {
            assert_eq!(pow2(x).to_bits(), (2f64.powi(x) as f32).to_bits(), "2^{x}");
        }
        for e in 1..=255u8 {
            let c = rgbe_decode([255, 128, 1, e]);
            let f = 2f64.powi(e as i32 - 136) as f32;
            assert_eq!(c, Rgb::new(255.5 * f, 128.5 * f, 1.5 * f), "exponent byte {e}");
        }
        for e in 0..=255u8 {
            assert_eq!(oct_decode_coarse(e), oct_decode_coarse_direct(e), "code {e}");
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
