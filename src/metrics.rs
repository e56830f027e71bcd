//! Image error metrics against a reference: RMSE, relative MSE, MAE, mean-luminance ratio.
use crate::accel::Tracer;
use crate::color::luminance;
use crate::film::Image;
use crate::scene::Scene;
use serde::Serialize;

#[derive(Clone, Copy, Debug, Serialize)]
pub struct Errors {
    pub rmse: f64,
    pub rel_mse: f64,
    pub mae: f64,
    pub mean_ratio: f64,
}

/// Errors of `a` against reference `r` over all channels; None if sizes differ.
pub fn compare(a: &Image, r: &Image) -> Option<Errors> {
    compare_masked(a, r, &vec![true; r.pixels.len()])
}

/// Pixels in which no camera ray (of a `sub`×`sub` grid over the pixel's filter: the pixel itself for
/// the box; from the lens's centre and eight points of its rim when it has an aperture) sees an emitter
/// directly. Error metrics leave the others out: a light's edge pixels measure only anti-aliasing noise
/// and swamp every other error.
pub fn light_free_pixels(scene: &Scene, tracer: &dyn Tracer, sub: u32) -> Vec<bool> {
    let cam = &scene.camera;
    // The grid spans the filter's reach: 1 pixel for the box, 2 × radius otherwise.
    let span = 2.0 * cam.filter.spec.radius();
    // Square points the disc map sends to the lens's centre and around its rim.
    let rim =
        [[0.5, 0.5], [0.0, 0.5], [1.0, 0.5], [0.5, 0.0], [0.5, 1.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    let lens: Vec<glam::Vec3> =
        rim[..if cam.lens_radius > 0.0 { rim.len() } else { 1 }].iter().map(|&u| cam.lens_point(u)).collect();
    let mut keep = Vec::with_capacity((cam.width * cam.height) as usize);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let sees_light = (0..sub * sub).any(|i| {
                let (fx, fy) = ((i % sub) as f32 + 0.5, (i / sub) as f32 + 0.5);
                let at = |p: u32, f: f32| p as f32 + 0.5 + (f / sub as f32 - 0.5) * span;
                lens.iter().any(|&l| {
                    let ray = cam.ray_from(l, at(x, fx), at(y, fy));
                    tracer.intersect(&ray).is_some_and(|h| scene.shapes[h.shape as usize].emission != glam::Vec3::ZERO)
                })
            });
            keep.push(!sees_light);
        }
    }
    keep
}

/// As `compare`, over the pixels where `keep` is true.
pub fn compare_masked(a: &Image, r: &Image, keep: &[bool]) -> Option<Errors> {
    if a.width != r.width || a.height != r.height || keep.len() != r.pixels.len() {
        return None;
    }
    let n = (keep.iter().filter(|k| **k).count().max(1) * 3) as f64;
    let (mut se, mut rel, mut ae, mut la, mut lr) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for ((p, q), _) in a.pixels.iter().zip(&r.pixels).zip(keep.iter()).filter(|(_, k)| **k) {
        for k in 0..3 {
            let d = (p[k] - q[k]) as f64;
            se += d * d;
            ae += d.abs();
            rel += d * d / ((q[k] as f64) * (q[k] as f64) + 1e-2);
        }
        la += luminance(*p) as f64;
        lr += luminance(*q) as f64;
    }
    Some(Errors {
        rmse: (se / n).sqrt(),
        rel_mse: rel / n,
        mae: ae / n,
        mean_ratio: if lr > 0.0 { la / lr } else { f64::NAN },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn known_rmse_on_synthetic_images() {
        let mut a = Image::new(4, 2);
        let b = Image::new(4, 2);
        // One channel of one pixel off by 2.4 → RMSE = sqrt(2.4² / 24).
        a.set(1, 1, Vec3::new(0.0, 2.4, 0.0));
        let e = compare(&a, &b).unwrap();
        assert!((e.rmse - (2.4f64 * 2.4 / 24.0).sqrt()).abs() < 1e-6);
        assert!((e.mae - 2.4 / 24.0).abs() < 1e-6);
        assert!(compare(&a, &Image::new(3, 2)).is_none());
        // Leaving out the bright pixel leaves nothing to differ.
        let mut r = Image::new(4, 2);
        r.set(1, 1, Vec3::splat(10.0));
        a.set(1, 1, Vec3::splat(12.0));
        assert!((compare(&a, &r).unwrap().rmse - 0.5f64.sqrt()).abs() < 1e-6);
        let mut keep = vec![true; 8];
        keep[5] = false;
        assert_eq!(compare_masked(&a, &r, &keep).unwrap().rmse, 0.0);
    }
}
