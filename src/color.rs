//! RGB radiometric quantities (linear), luminance, and the sRGB transfer curve for previews.
pub use glam::Vec3 as Rgb;

/// Rec. 709 luminance of a linear RGB value.
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Linear → sRGB-encoded 8-bit value, clamped.
pub fn srgb_encode(x: f32) -> u8 {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    let s = if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// sRGB-encoded value in [0, 1] → linear (the inverse of the transfer curve `srgb_encode` applies).
pub fn srgb_decode(x: f32) -> f32 {
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb_encode(0.0), 0);
        assert_eq!(srgb_encode(1.0), 255);
        assert_eq!(srgb_encode(0.214_041_14), 128);
        assert_eq!(srgb_encode(f32::NAN), 0);
        for v in [0u8, 10, 128, 255] {
            assert_eq!(srgb_encode(srgb_decode(v as f32 / 255.0)), v);
        }
        assert!((luminance(Rgb::ONE) - 1.0).abs() < 1e-6);
    }
}
