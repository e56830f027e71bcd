//! Vectors (glam), orthonormal frames, robust ray offsets, and the sampling routines every pass shares.
pub mod rng;
pub mod sampling;

pub use glam::{Mat4, Vec3};
pub use rng::Rng;

/// A ray with an origin, a direction (not necessarily normalised) and a parametric range.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray { o, d, tmin: 0.0, tmax: f32::INFINITY }
    }
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// An orthonormal frame around a unit normal `n` (Duff et al., "Building an Orthonormal Basis, Revisited").
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }
    /// The frame about the unit normal `n` whose s is `tangent` made orthogonal to `n` (Gram–Schmidt, as
    /// Mitsuba builds a shading frame from ∂p/∂u), t = n × s; `from_normal` where `tangent` is zero,
    /// along `n` or not finite.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Frame {
        let s = (tangent - n * n.dot(tangent)).normalize_or_zero();
        if s == Vec3::ZERO {
            return Frame::from_normal(n);
        }
        Frame { s, t: n.cross(s), n }
    }
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// Moves `p` off the surface along the geometric normal `ng` by an error-bounded amount, on the side of
/// `w` (Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems 6):
/// a fixed number of float ULPs far from the origin, an absolute epsilon near it. The paper's constants
/// are for primitives of unit size; `scale` (the size of the primitive the point lies on) scales the
/// near-origin ones, so geometry shrunk to 1e-4 or grown to 1e4 behaves like the unit one.
/// The ULP step goes through the float's ordered-integer image, so it crosses zero and subnormals
/// monotonically (adding to the raw bits of ±0.0 would give a NaN) and stops at the largest finite float.
pub fn offset_ray_origin(p: Vec3, ng: Vec3, w: Vec3, scale: f32) -> Vec3 {
    let origin = scale / 32.0;
    let float_scale = scale / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = face_forward(ng, w);
    let pa = p.to_array();
    let na = n.to_array();
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let (x, ulps) = (pa[k], (INT_SCALE * na[k]) as i32);
        out[k] = if x.abs() < origin {
            x + float_scale * na[k]
        } else if (1e-30..1e37).contains(&x.abs()) {
            // At most 256 ulps from a float this far from zero and from f32::MAX: the step cannot
            // cross zero or overflow, so it is the raw bits moved towards the side asked for (the
            // same float `step_ulps` gives, without its ordered-integer detour).
            let step = if x < 0.0 { -ulps } else { ulps };
            f32::from_bits((x.to_bits() as i32).wrapping_add(step) as u32)
        } else {
            step_ulps(x, ulps)
        };
    }
    Vec3::from_array(out)
}

/// `x` moved by `ulps` representable floats (towards +∞ for positive `ulps`), through ±0 and the
/// subnormals without a jump, saturating at ±f32::MAX. NaN stays NaN.
pub fn step_ulps(x: f32, ulps: i32) -> f32 {
    if x.is_nan() {
        return x;
    }
    // Ordered image: negative floats map below zero, −0.0 and +0.0 both to 0, monotone in x.
    let bits = x.to_bits();
    let ord = if bits >> 31 == 1 { -((bits & 0x7FFF_FFFF) as i64) } else { bits as i64 };
    let max = f32::MAX.to_bits() as i64;
    let o = (ord + ulps as i64).clamp(-max, max);
    if o < 0 {
        f32::from_bits((-o) as u32 | 0x8000_0000)
    } else {
        f32::from_bits(o as u32)
    }
}

/// `n` flipped, if needed, to the side of `w` (the one "orient n toward w" of the code base).
pub fn face_forward(n: Vec3, w: Vec3) -> Vec3 {
    if n.dot(w) < 0.0 {
        -n
    } else {
        n
    }
}

/// Nearest positive hit of a ray with a sphere, in f64 (Embree's user geometry, the brute-force twin
/// and light sampling share it): the smallest root t of |o + t·d − c| = r in (tmin, tmax).
#[inline(always)]
pub fn sphere_root(o: [f32; 3], d: [f32; 3], c: [f32; 3], r: f32, tmin: f32, tmax: f32) -> Option<f32> {
    let oc = [o[0] as f64 - c[0] as f64, o[1] as f64 - c[1] as f64, o[2] as f64 - c[2] as f64];
    let dd = [d[0] as f64, d[1] as f64, d[2] as f64];
    let a = dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2];
    let b = oc[0] * dd[0] + oc[1] * dd[1] + oc[2] * dd[2];
    let cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - (r as f64) * (r as f64);
    let disc = b * b - a * cc;
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    let s = disc.sqrt();
    // Numerically stable pair of roots.
    let q = if b > 0.0 { -(b + s) } else { -b + s };
    let (mut t0, mut t1) = (q / a, if q != 0.0 { cc / q } else { q / a });
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    [t0, t1].into_iter().map(|t| t as f32).find(|&t| t > tmin && t < tmax)
}

/// Möller–Trumbore in f64 (the brute-force tracer and the loader's look for the media round a shape
/// share it): the hit of `r`'s line with triangle abc as (t, u, v), p = (1−u−v)·a + u·b + v·c, t
/// unchecked against the ray's range.
pub fn triangle_hit(r: &Ray, [a, b, c]: [Vec3; 3]) -> Option<(f32, f32, f32)> {
    let (o, d) = (r.o.as_dvec3(), r.d.as_dvec3());
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    Some((t as f32, u as f32, v as f32))
}

/// Whether `r` meets the box [lo, hi] within its range (the slab test).
pub fn ray_meets_box(r: &Ray, (lo, hi): (Vec3, Vec3)) -> bool {
    let inv = r.d.recip();
    let (t0, t1) = ((lo - r.o) * inv, (hi - r.o) * inv);
    // NaN (a zero direction component on a slab's plane) counts as meeting it.
    let near = t0.min(t1).max_element().max(r.tmin);
    let far = t0.max(t1).min_element().min(r.tmax);
    near.is_nan() || far.is_nan() || near <= far
}

/// |v|: f32's own `length` wherever its square fits in f32, else worked out in f64 (components beyond
/// about 1e19 square past f32::MAX, and a triangle's area, say, would read infinite).
#[inline]
pub fn length_wide(v: Vec3) -> f32 {
    let l = v.length();
    if l.is_finite() {
        l
    } else {
        v.as_dvec3().length() as f32
    }
}

/// Largest component of a vector.
pub fn max_component(v: Vec3) -> f32 {
    v.x.max(v.y).max(v.z)
}

/// Reflects `wo` (pointing away from the surface) about the normal `n`.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Refracts `wo` (pointing away from the surface, on `n`'s side) through the normal `n` into a medium
/// of relative index `eta` (beyond over this side), given cos θt from `fresnel_dielectric`.
pub fn refract(wo: Vec3, n: Vec3, eta: f32, cos_t: f32) -> Vec3 {
    -wo / eta + (wo.dot(n) / eta - cos_t) * n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        let mut rng = Rng::new(7, 0, 0);
        for _ in 0..1000 {
            let n = sampling::uniform_sphere(rng.next_2d());
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            let v = sampling::uniform_sphere(rng.next_2d());
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn offset_moves_to_the_requested_side_at_all_scales() {
        let n = Vec3::new(0.3, 0.9, -0.2).normalize();
        for scale in [1e-4f32, 1.0, 1e4, 1e5] {
            let p = Vec3::new(0.7, -1.3, 2.1) * scale;
            let up = offset_ray_origin(p, n, n, scale);
            let down = offset_ray_origin(p, n, -n, scale);
            assert!((up - p).dot(n) > 0.0, "scale {scale}");
            assert!((down - p).dot(n) < 0.0, "scale {scale}");
            assert!((up - p).length() < 1e-3 * scale.max(1.0));
        }
    }

    #[test]
    fn offsets_stay_finite_and_on_the_requested_side_for_zero_subnormal_and_huge_coordinates() {
        let specials = [0.0f32, -0.0, 1e-40, -1e-40, f32::MIN_POSITIVE, 1e30, -1e30, 3.0e38, -3.0e38, 0.5];
        let mut rng = Rng::new(11, 0, 0);
        for _ in 0..2000 {
            let n = sampling::uniform_sphere(rng.next_2d());
            let pick = |r: &mut Rng| specials[(r.next_u32() % specials.len() as u32) as usize];
            let p = Vec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng));
            for scale in [0.0f32, 1e-6, 1.0, 1e4] {
                for w in [n, -n] {
                    let q = offset_ray_origin(p, n, w, scale);
                    assert!(q.is_finite(), "p {p:?} n {n:?} scale {scale}: {q:?}");
                    // Each coordinate moves (or stays) towards the side of w.
                    let side = face_forward(n, w);
                    for k in 0..3 {
                        let step = (q[k] as f64 - p[k] as f64) * side[k] as f64;
                        assert!(step >= 0.0, "p {p:?} n {n:?} k {k}: {} -> {}", p[k], q[k]);
                    }
                }
            }
        }
    }

    /// The fast integer step in `offset_ray_origin` is exactly the ordered-integer `step_ulps`
    /// (the definition) for every coordinate it takes: magnitudes from 1e-38 to f32::MAX, both signs,
    /// normals of every direction, primitive sizes from 0 to 1e6.
    #[test]
    fn offset_ray_origin_matches_its_definition() {
        let definition = |p: Vec3, ng: Vec3, w: Vec3, scale: f32| {
            let n = face_forward(ng, w);
            Vec3::from_array(std::array::from_fn(|k| {
                if p[k].abs() < scale / 32.0 {
                    p[k] + scale / 65536.0 * n[k]
                } else {
                    step_ulps(p[k], (256.0 * n[k]) as i32)
                }
            }))
        };
        let mut rng = crate::math::rng::Rng::new(7, 0, 0);
        let coordinate = |rng: &mut crate::math::rng::Rng| {
            let sign = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
            match (rng.next_f32() * 8.0) as u32 {
                0 => 0.0,
                1 => sign * f32::MAX,
                2 => sign * f32::from_bits(1 + (rng.next_u32() >> 9)),
                _ => sign * 10f32.powf(rng.next_f32() * 76.0 - 38.0),
            }
        };
        for _ in 0..200_000 {
            let p = Vec3::new(coordinate(&mut rng), coordinate(&mut rng), coordinate(&mut rng));
            let n = crate::math::sampling::uniform_sphere(rng.next_2d());
            let w = crate::math::sampling::uniform_sphere(rng.next_2d());
            let scale = [0.0, 1e-6, 1.0, 1e6][(rng.next_f32() * 4.0) as usize];
            let (a, b) = (offset_ray_origin(p, n, w, scale), definition(p, n, w, scale));
            for k in 0..3 {
                assert_eq!(a[k].to_bits(), b[k].to_bits(), "p {p:?} n {n:?} w {w:?} scale {scale}: {a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn ulp_steps_cross_zero_monotonically() {
        assert_eq!(step_ulps(0.0, 1), f32::from_bits(1));
        assert_eq!(step_ulps(-0.0, -1), -f32::from_bits(1));
        assert_eq!(step_ulps(f32::from_bits(1), -2), -f32::from_bits(1));
        assert_eq!(step_ulps(1.0, 1), f32::from_bits(1.0f32.to_bits() + 1));
        assert_eq!(step_ulps(-1.0, 1), f32::from_bits((-1.0f32).to_bits() - 1));
        assert_eq!(step_ulps(f32::MAX, 10), f32::MAX);
        assert_eq!(step_ulps(-f32::MAX, -10), -f32::MAX);
    }

    #[test]
    fn sphere_root_is_the_nearest_hit_in_range() {
        let t = sphere_root([0.0, 0.0, -5.0], [0.0, 0.0, 1.0], [0.0; 3], 1.0, 0.0, f32::INFINITY);
        assert!((t.unwrap() - 4.0).abs() < 1e-6);
        let t = sphere_root([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [0.0; 3], 1.0, 0.0, f32::INFINITY);
        assert!((t.unwrap() - 0.5).abs() < 1e-6, "inside: far side");
        assert!(sphere_root([0.0, 0.0, -5.0], [0.0, 0.0, 1.0], [0.0; 3], 1.0, 0.0, 3.9).is_none());
        assert!(sphere_root([0.0, 2.0, -5.0], [0.0, 0.0, 1.0], [0.0; 3], 1.0, 0.0, 100.0).is_none());
    }
}
