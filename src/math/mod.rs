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
pub fn offset_ray_origin(p: Vec3, ng: Vec3, w: Vec3, scale: f32) -> Vec3 {
    let origin = scale / 32.0;
    let float_scale = scale / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if ng.dot(w) < 0.0 { -ng } else { ng };
    let of_i = [(INT_SCALE * n.x) as i32, (INT_SCALE * n.y) as i32, (INT_SCALE * n.z) as i32];
    let pa = p.to_array();
    let na = n.to_array();
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let bits = pa[k].to_bits() as i32;
        let delta = if pa[k] < 0.0 { -of_i[k] } else { of_i[k] };
        let p_i = f32::from_bits(bits.wrapping_add(delta) as u32);
        out[k] = if pa[k].abs() < origin { pa[k] + float_scale * na[k] } else { p_i };
    }
    Vec3::from_array(out)
}

/// Largest component of a vector.
pub fn max_component(v: Vec3) -> f32 {
    v.x.max(v.y).max(v.z)
}

/// Reflects `wo` (pointing away from the surface) about the normal `n`.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
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
}
