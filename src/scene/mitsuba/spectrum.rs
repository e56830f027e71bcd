//! Spectra in a Mitsuba scene, turned into the linear sRGB colour Mitsuba 3's RGB variants render them
//! as (its XML loader's `create_texture_from_spectrum`, whose rules are kept here):
//!
//! - a constant `<spectrum value="c">` is c, except directly inside an `<emitter>`, where it is a flat
//!   (equal-energy) spectrum of height c and becomes c · M·(1, 1, 1), M the XYZ → sRGB matrix: the
//!   slightly purple (1.2048, 0.9483, 0.9089)·c, not grey;
//! - `wavelength:value` pairs (or a `.spd` file of them) are integrated against the CIE 1931 curves
//!   at 1000 points over 360–830 nm, each weighted by the CIE D65 illuminant for a reflectance (so a flat
//!   reflectance of 1 is white) but not for an emitter's radiance, scaled so that a flat spectrum has a
//!   luminance of one, turned into sRGB and clipped: into [0, 1] for a reflectance, at 0 for an
//!   emitter and for the unbounded `eta`, `k`, `int_ior` and `ext_ior`. Outside the pairs' range the
//!   spectrum is zero.
use colorbox::tables::cie_1931_xyz as cie;

/// Mitsuba's `MI_CIE_Y_NORMALIZATION`: 1 over the integral of ȳ over 360–830 nm as it sums it.
const Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Mitsuba's `MI_CIE_D65_NORMALIZATION` for the D65 table below.
const D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;
const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;

/// The CIE standard illuminant D65, relative spectral power at 5 nm steps from 360 to 830 nm (100 at
/// 560 nm), as published by the CIE.
const D65: [f32; 95] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204, 91.486, 92.4589, 93.4318,
    90.057, 86.6823, 95.7736, 104.865, 110.936, 117.008, 117.41, 117.812, 116.336, 114.861, 115.392, 115.923, 112.367,
    108.811, 109.082, 109.354, 108.578, 107.802, 106.296, 104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046,
    102.023, 100.0, 98.1671, 96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026, 89.5991, 88.6489,
    87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.281, 78.2842,
    74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765, 61.604, 65.7448, 69.8856, 72.4863, 75.087, 69.3398,
    63.5927, 55.0054, 46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.304, 61.8779, 59.4519, 55.7054, 51.959,
    54.6998, 57.4406, 58.8765, 60.3125,
];

/// CIE XYZ → linear sRGB (Rec. 709 primaries, D65 white), the matrix Mitsuba uses.
const XYZ_TO_SRGB: [[f64; 3]; 3] =
    [[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556], [0.055648, -0.204043, 1.057311]];

fn xyz_to_srgb(xyz: [f64; 3]) -> [f64; 3] {
    XYZ_TO_SRGB.map(|row| row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2])
}

/// A table at 5 nm steps from 360 nm, linearly interpolated (0 outside).
fn lerp_table(t: &[f32], w: f64) -> f64 {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return 0.0;
    }
    let x = (w - CIE_MIN) / 5.0;
    let i = (x as usize).min(t.len() - 2);
    let f = x - i as f64;
    t[i] as f64 * (1.0 - f) + t[i + 1] as f64 * f
}

/// Property names whose spectra are not reflectances or radiances (no clipping at one).
pub fn is_unbounded(name: &str) -> bool {
    matches!(name, "eta" | "k" | "int_ior" | "ext_ior")
}

/// The colour of a constant spectrum `c` given as property `name`, `in_emitter` if written directly
/// inside an `<emitter>`.
pub fn constant(c: f32, name: &str, in_emitter: bool) -> [f32; 3] {
    if in_emitter && !is_unbounded(name) {
        xyz_to_srgb([1.0; 3]).map(|v| (v * c as f64) as f32)
    } else {
        [c; 3]
    }
}

/// The colour of the spectrum given by `(wavelength in nm, value)` pairs, in increasing order of
/// wavelength (at least two), as property `name`, `in_emitter` if written directly inside an
/// `<emitter>`; with whether it was clipped to sRGB's gamut.
pub fn sampled(pairs: &[(f32, f32)], name: &str, in_emitter: bool) -> ([f32; 3], bool) {
    let unbounded = is_unbounded(name);
    let bounded = !(in_emitter || unbounded);
    let d65 = !in_emitter || unbounded;
    let (first, last) = (pairs[0].0 as f64, pairs[pairs.len() - 1].0 as f64);
    const STEPS: usize = 1000;
    let mut xyz = [0.0f64; 3];
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // The last pair at or below w, and the one after it.
        let k = pairs.partition_point(|p| p.0 as f64 <= w).clamp(1, pairs.len() - 1) - 1;
        let ((w0, v0), (w1, v1)) =
            ((pairs[k].0 as f64, pairs[k].1 as f64), (pairs[k + 1].0 as f64, pairs[k + 1].1 as f64));
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1) * Y_NORMALIZATION;
        let weight = v * if d65 { lerp_table(&D65, w) * D65_NORMALIZATION } else { 1.0 };
        for (acc, t) in xyz.iter_mut().zip([cie::X, cie::Y, cie::Z]) {
            *acc += lerp_table(t, w) * weight;
        }
    }
    let rgb = xyz_to_srgb(xyz.map(|v| v * (CIE_MAX - CIE_MIN) / STEPS as f64));
    let hi = if bounded { 1.0 } else { f64::INFINITY };
    let clipped = rgb.iter().any(|&v| v < 0.0 || v > hi);
    (rgb.map(|v| v.clamp(0.0, hi) as f32), clipped)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol * y.abs().max(1e-3))
    }

    /// Figures Mitsuba 3.9.1 gives for the same properties (`scalar_rgb`, `mi.traverse` of a
    /// `load_string` scene: a diffuse `reflectance` and an area emitter's `radiance`, a conductor's
    /// `eta` and `k`), recorded once; caustica's conversion must give them to 0.01%.
    #[test]
    fn spectra_read_as_mitsuba_3_reads_them() {
        type Case<'a> = (&'a [(f32, f32)], [f32; 3], [f32; 3]);
        let cases: [Case; 4] = [
            (&[(400.0, 1.0), (700.0, 1.0)], [0.995342, 0.999756, 0.994909], [1.19969, 0.94952, 0.903443]),
            (&[(360.0, 1.0), (830.0, 1.0)], [0.998985, 0.998874, 0.998802], [1.20488, 0.948228, 0.909267]),
            (
                &[(400.0, 0.343), (404.0, 0.445), (408.0, 0.551), (412.0, 0.624), (700.0, 0.9)],
                [0.840614, 0.749528, 0.647113],
                [1.00489, 0.712536, 0.584474],
            ),
            // The Cornell box's light: out of gamut as a reflectance (clipped to white), not as radiance.
            (&[(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)], [1.0, 1.0, 1.0], [20.7108, 10.8546, 2.77115]),
        ];
        for (pairs, reflectance, radiance) in cases {
            let (r, _) = sampled(pairs, "reflectance", false);
            assert!(close(r, reflectance, 1e-4), "{pairs:?} as a reflectance: {r:?}, Mitsuba {reflectance:?}");
            let (e, _) = sampled(pairs, "radiance", true);
            assert!(close(e, radiance, 1e-4), "{pairs:?} as radiance: {e:?}, Mitsuba {radiance:?}");
        }
        let (eta, _) = sampled(&[(400.0, 0.2), (700.0, 0.3)], "eta", false);
        let (k, _) = sampled(&[(400.0, 3.0), (700.0, 4.0)], "k", false);
        assert!(close(eta, [0.279483, 0.247597, 0.212586], 5e-4), "eta {eta:?}");
        assert!(close(k, [3.79017, 3.47572, 3.12077], 5e-4), "k {k:?}");
        // A constant: grey, except as an emitter's radiance (Mitsuba: 1.20479, 0.948291, 0.908916).
        assert_eq!(constant(0.5, "reflectance", false), [0.5; 3]);
        assert!(close(constant(1.0, "radiance", true), [1.20479, 0.948291, 0.908916], 1e-5));
        assert!(close(constant(1.0, "intensity", true), [1.20479, 0.948291, 0.908916], 1e-5));
    }

    #[test]
    fn a_saturated_reflectance_is_clipped_into_gamut_and_says_so() {
        // A narrow green band: outside sRGB's gamut (negative red and blue before clipping).
        let (c, clipped) = sampled(&[(500.0, 0.0), (530.0, 1.0), (560.0, 0.0)], "reflectance", false);
        assert!(clipped && c[0] == 0.0 && c[2] == 0.0 && c[1] > 0.0 && c[1] <= 1.0, "{c:?}");
        let (_, clipped) = sampled(&[(400.0, 0.5), (700.0, 0.5)], "reflectance", false);
        assert!(!clipped);
    }
}
