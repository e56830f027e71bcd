//! BSDFs: Lambertian diffuse, smooth or GGX-rough mirror/conductor, smooth dielectric (exact Fresnel, TIR).
//! Directions point away from the surface; `n` is the shading normal (any side).
use crate::color::Rgb;
use crate::math::{face_forward, reflect, sampling, Frame};
use glam::Vec3;
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub enum Material {
    Diffuse {
        reflectance: Rgb,
    },
    /// Schlick Fresnel from `f0` (a mirror uses f0 = its colour with `schlick = false`).
    Conductor {
        f0: Rgb,
        alpha: f32,
        schlick: bool,
    },
    Dielectric {
        ior: f32,
        tint: Rgb,
    },
}

/// Which quantity a path carries (pbrt-v4's TransportMode): camera paths carry radiance, light paths
/// and photons carry importance (flux). Refraction scales radiance by 1/η² and leaves flux alone; light
/// paths take Veach's shading-normal correction (`SurfaceHit::scatter` applies it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// The result of sampling a BSDF: the incident direction and f·|cos|/pdf.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: Rgb,
    pub pdf: f32,
    pub delta: bool,
    /// True when the sample crossed the surface (refraction).
    pub transmitted: bool,
    /// Radiance scale of the sample: 1/η² for refraction in radiance mode, 1 otherwise. Russian
    /// roulette divides it out of the throughput (pbrt-v4's etaScale), so the survival probability
    /// inside glass does not drop to 1/η².
    pub radiance_scale: f32,
}

/// Metal F0 colours (linear sRGB) for the `preset` key.
pub fn conductor_preset(name: &str) -> Option<Rgb> {
    Some(match name {
        "Au" => Rgb::new(1.000, 0.766, 0.336),
        "Ag" => Rgb::new(0.972, 0.960, 0.915),
        "Cu" => Rgb::new(0.955, 0.638, 0.538),
        "Al" => Rgb::new(0.913, 0.922, 0.924),
        "Cr" => Rgb::new(0.549, 0.556, 0.554),
        _ => return None,
    })
}

/// Unpolarised Fresnel reflectance of a dielectric interface; `cos_i` ≥ 0 on the incident side,
/// `eta` = n_t / n_i. Returns (F, cos_t); F = 1 on total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32) {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

fn schlick(f0: Rgb, cos: f32) -> Rgb {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m5 = m * m * m * m * m;
    f0 + (Rgb::ONE - f0) * m5
}

fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c = h.z;
    if c <= 0.0 {
        return 0.0;
    }
    let d = c * c * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

fn ggx_g1(w: Vec3, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    if c2 <= 0.0 {
        return 0.0;
    }
    let t2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt())
}

impl Material {
    /// Delta BSDFs (smooth mirror, conductor, dielectric) are sampled, never evaluated.
    pub fn is_delta(&self) -> bool {
        match self {
            Material::Diffuse { .. } => false,
            Material::Conductor { alpha, .. } => *alpha == 0.0,
            Material::Dielectric { .. } => true,
        }
    }

    pub fn is_diffuse(&self) -> bool {
        matches!(self, Material::Diffuse { .. })
    }

    /// Reflectance colour (diffuse reflectance, conductor F0, dielectric tint); its largest component is
    /// the photon's Russian-roulette survival probability at diffuse hits.
    pub fn albedo(&self) -> Rgb {
        match self {
            Material::Diffuse { reflectance } => *reflectance,
            Material::Conductor { f0, .. } => *f0,
            Material::Dielectric { tint, .. } => *tint,
        }
    }

    /// f(wo, wi) for non-delta BSDFs (0 for delta ones).
    pub fn eval(&self, wo: Vec3, wi: Vec3, n: Vec3) -> Rgb {
        match self {
            Material::Diffuse { reflectance } => {
                if wo.dot(n) * wi.dot(n) > 0.0 {
                    *reflectance / PI
                } else {
                    Rgb::ZERO
                }
            }
            Material::Conductor { f0, alpha, schlick: s } if *alpha > 0.0 => {
                let f = Frame::from_normal(face_forward(n, wo));
                let (lo, li) = (f.to_local(wo), f.to_local(wi));
                if lo.z <= 0.0 || li.z <= 0.0 {
                    return Rgb::ZERO;
                }
                let h = (lo + li).normalize();
                let fr = if *s { schlick(*f0, li.dot(h)) } else { *f0 };
                fr * ggx_d(h, *alpha) * ggx_g1(lo, *alpha) * ggx_g1(li, *alpha) / (4.0 * lo.z * li.z)
            }
            _ => Rgb::ZERO,
        }
    }

    /// Solid-angle density of `sample` choosing wi (0 for delta BSDFs).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        match self {
            Material::Diffuse { .. } => wi.dot(face_forward(n, wo)).max(0.0) / PI,
            Material::Conductor { alpha, .. } if *alpha > 0.0 => {
                let f = Frame::from_normal(face_forward(n, wo));
                let (lo, li) = (f.to_local(wo), f.to_local(wi));
                if lo.z <= 0.0 || li.z <= 0.0 {
                    return 0.0;
                }
                let h = (lo + li).normalize();
                ggx_d(h, *alpha) * h.z / (4.0 * lo.dot(h))
            }
            _ => 0.0,
        }
    }

    /// Samples wi given wo; `u` for the direction, `uc` for the discrete (reflect/refract) choice.
    /// In `Radiance` mode (camera paths) refraction scales by 1/η²; photons carry flux (`Importance`),
    /// so a diffuse surface under water seen from air comes out right in both integrators.
    pub fn sample(&self, wo: Vec3, n: Vec3, u: [f32; 2], uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        let side = face_forward(n, wo);
        let sample = |wi, weight, pdf, delta, transmitted, radiance_scale| BsdfSample {
            wi,
            weight,
            pdf,
            delta,
            transmitted,
            radiance_scale,
        };
        match self {
            Material::Diffuse { reflectance } => {
                let wi = sampling::cosine_around(side, u);
                let pdf = wi.dot(side) / PI;
                (pdf > 0.0).then_some(sample(wi, *reflectance, pdf, false, false, 1.0))
            }
            Material::Conductor { f0, alpha, schlick: s } => {
                if *alpha == 0.0 {
                    let wi = reflect(wo, side);
                    let c = wi.dot(side);
                    let fr = if *s { schlick(*f0, c) } else { *f0 };
                    return Some(sample(wi, fr, 1.0, true, false, 1.0));
                }
                let f = Frame::from_normal(side);
                let lo = f.to_local(wo);
                // Sample h ∝ D(h) cos θh.
                let a2 = alpha * alpha;
                let cos2 = (1.0 - u[0]) / (1.0 + (a2 - 1.0) * u[0]);
                let cos_t = cos2.max(0.0).sqrt();
                let sin_t = (1.0 - cos2).max(0.0).sqrt();
                let phi = 2.0 * PI * u[1];
                let h = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
                let li = reflect(lo, h);
                if li.z <= 0.0 || lo.z <= 0.0 {
                    return None;
                }
                let wi = f.to_world(li);
                let pdf = self.pdf(wo, wi, n);
                if pdf <= 0.0 {
                    return None;
                }
                let weight = self.eval(wo, wi, n) * li.z / pdf;
                Some(sample(wi, weight, pdf, false, false, 1.0))
            }
            Material::Dielectric { ior, tint } => {
                let entering = wo.dot(n) > 0.0;
                let eta = if entering { *ior } else { 1.0 / *ior };
                let cos_i = wo.dot(side);
                let (fr, cos_t) = fresnel_dielectric(cos_i, eta);
                if uc < fr {
                    Some(sample(reflect(wo, side), Rgb::ONE, fr, true, false, 1.0))
                } else {
                    let wi = (-wo / eta + (cos_i / eta - cos_t) * side).normalize();
                    let scale = if mode == TransportMode::Radiance { 1.0 / (eta * eta) } else { 1.0 };
                    Some(sample(wi, *tint * scale, 1.0 - fr, true, true, scale))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn fresnel_normal_incidence_and_tir() {
        let (f, _) = fresnel_dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-4);
        // Leaving glass (eta = 1/1.5): critical angle asin(1/1.5) ≈ 41.8°.
        let crit = (1.0f32 / 1.5).asin();
        assert_eq!(fresnel_dielectric((crit + 0.01).cos(), 1.0 / 1.5).0, 1.0);
        assert!(fresnel_dielectric((crit - 0.01).cos(), 1.0 / 1.5).0 < 1.0);
    }

    #[test]
    fn rough_conductor_sampling_matches_eval_and_conserves_energy() {
        let m = Material::Conductor { f0: Rgb::ONE, alpha: 0.3, schlick: false };
        let n = Vec3::Z;
        let wo = Vec3::new(0.3, 0.0, 0.954).normalize();
        let mut r = Rng::new(9, 0, 0);
        let mut albedo = 0.0f64;
        let count = 100_000;
        for _ in 0..count {
            if let Some(s) = m.sample(wo, n, r.next_2d(), r.next_f32(), TransportMode::Radiance) {
                let w = m.eval(wo, s.wi, n) * s.wi.dot(n) / m.pdf(wo, s.wi, n);
                assert!((w - s.weight).length() < 1e-3 * w.length().max(1.0));
                albedo += s.weight.x as f64;
            }
        }
        let albedo = albedo / count as f64;
        assert!(albedo > 0.85 && albedo <= 1.001, "albedo {albedo}");
    }

    #[test]
    fn diffuse_is_reciprocal_and_one_sided_against_transmission() {
        let m = Material::Diffuse { reflectance: Rgb::splat(0.5) };
        let n = Vec3::Y;
        let a = Vec3::new(0.2, 0.9, 0.1).normalize();
        let b = Vec3::new(-0.5, 0.5, 0.3).normalize();
        assert_eq!(m.eval(a, b, n), m.eval(b, a, n));
        assert_eq!(m.eval(a, -b, n), Rgb::ZERO);
    }
}
