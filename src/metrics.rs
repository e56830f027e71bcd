//! Image error metrics against a reference: RMSE, relative MSE, MAE, mean-luminance ratio.
use crate::color::luminance;
use crate::film::Image;
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
    if a.width != r.width || a.height != r.height {
        return None;
    }
    let n = (a.pixels.len() * 3) as f64;
    let (mut se, mut rel, mut ae, mut la, mut lr) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (p, q) in a.pixels.iter().zip(&r.pixels) {
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
    }
}
