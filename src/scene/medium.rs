//! Media that scatter (Mitsuba's `homogeneous` medium of albedo > 0): where a path running through one
//! scatters (free flight by a hero channel, with spectral MIS over the path) and the Henyey–Greenstein phase function
//! it scatters by. The path tracer alone renders them (`Scene::check_mode`).
use crate::color::Rgb;
use crate::math::Frame;
use glam::Vec3;
use std::f32::consts::PI;

/// What a medium scatters: its extinction σ_t is the absorption its side holds (`Scene::absorption`),
/// of which σ_s scatters, by its phase function.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Scattering {
    /// The scattering coefficient σ_s per channel, per unit of scene length (Mitsuba's albedo × σ_t);
    /// zero where the medium only absorbs.
    pub sigma_s: Rgb,
    /// The phase function it scatters by (isotropic by default).
    pub phase: Phase,
}

/// One lobe of a phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lobe {
    /// Henyey–Greenstein's of asymmetry g in (−1, 1): 0 scatters alike in every direction (Mitsuba's
    /// `isotropic`), > 0 mostly onwards, < 0 mostly back (Mitsuba's `hg`).
    Hg(f32),
    /// Rayleigh's, 3/(16π)·(1 + cos²θ): small particles, as much back as onwards (Mitsuba's `rayleigh`).
    Rayleigh,
    /// A table of values over the cosine (Mitsuba's `tabphase`).
    Table(&'static Table),
}

/// A phase function tabulated over the cosine between the directions light travels in and out (1:
/// onwards): values at n ≥ 2 cosines evenly spaced from −1 to 1, linear between them, scaled to
/// integrate to 1 over the sphere (Mitsuba's `tabphase`, whose `ContinuousDistribution` reads them
/// so).
#[derive(Debug, PartialEq)]
pub struct Table {
    /// The values as given.
    values: Vec<f32>,
    /// The values' integral over the cosine from −1 up to each knot (trapezoids; 0 first, their whole
    /// integral last), in f64: values near f32::MAX sum beyond it.
    cdf: Vec<f64>,
}

impl Table {
    /// The table of `values`, refused (with why) unless there are at least two, each finite and ≥ 0,
    /// not all 0.
    pub fn new(values: &[f32]) -> Result<Table, String> {
        if values.len() < 2 {
            return Err(format!("{} value(s): a table needs at least two (at cosines −1 and 1)", values.len()));
        }
        if let Some(v) = values.iter().find(|v| !v.is_finite() || **v < 0.0) {
            return Err(format!("{v}: each value must be finite and ≥ 0"));
        }
        let h = 2.0 / (values.len() - 1) as f64;
        let mut cdf = vec![0.0f64];
        for w in values.windows(2) {
            cdf.push(cdf.last().unwrap() + 0.5 * (w[0] as f64 + w[1] as f64) * h);
        }
        if *cdf.last().unwrap() <= 0.0 {
            return Err("every value is 0: the table has no scattering to spread".to_string());
        }
        Ok(Table { values: values.to_vec(), cdf })
    }

    /// The table of `values` (as `new`), one copy per distinct table for the life of the process: a
    /// lobe refers to it, and lobes are copied along every path.
    pub fn interned(values: &[f32]) -> Result<&'static Table, String> {
        static TABLES: std::sync::Mutex<Vec<&'static Table>> = std::sync::Mutex::new(Vec::new());
        let mut tables = TABLES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = tables.iter().find(|t| t.values == values) {
            return Ok(t);
        }
        let t: &'static Table = Box::leak(Box::new(Table::new(values)?));
        tables.push(t);
        Ok(t)
    }

    /// The values as given.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    fn step(&self) -> f64 {
        2.0 / (self.values.len() - 1) as f64
    }

    /// The values' whole integral over the cosine.
    fn total(&self) -> f64 {
        *self.cdf.last().unwrap()
    }

    /// Density per steradian at the cosine `cos`: the values interpolated, over their integral and 2π.
    fn density(&self, cos: f32) -> f32 {
        let last = self.values.len() - 1;
        let x = ((cos.clamp(-1.0, 1.0) as f64 + 1.0) / self.step()).min(last as f64);
        let i = (x as usize).min(last - 1);
        let t = x - i as f64;
        let v = self.values[i] as f64 * (1.0 - t) + self.values[i + 1] as f64 * t;
        (v / (self.total() * 2.0 * std::f64::consts::PI)) as f32
    }

    /// A cosine drawn by the table's density from `u` in [0, 1): the interval by the integral, then
    /// the point inside it by the linear density's quadratic integral, inverted.
    fn sample_cos(&self, u: f32) -> f32 {
        let last = self.values.len() - 1;
        let target = u as f64 * self.total();
        // The last knot whose integral is ≤ the target, below the last.
        let i = self.cdf.partition_point(|c| *c <= target).clamp(1, last) - 1;
        let h = self.step();
        let (a, b) = (self.values[i] as f64, self.values[i + 1] as f64);
        // The share t of the interval with a·t·h + (b − a)·t²·h/2 = r, in the form without cancellation.
        let r = (target - self.cdf[i]).max(0.0) / h;
        let root = a + (a * a + 2.0 * (b - a) * r).max(0.0).sqrt();
        let t = if root > 0.0 { (2.0 * r / root).clamp(0.0, 1.0) } else { 0.0 };
        (-1.0 + (i as f64 + t) * h).clamp(-1.0, 1.0) as f32
    }
}

impl Default for Lobe {
    fn default() -> Lobe {
        Lobe::Hg(0.0)
    }
}

impl Lobe {
    /// The lobe's density at the cosine `cos` between the directions light travels in and out.
    fn density(self, cos: f32) -> f32 {
        match self {
            Lobe::Hg(g) => henyey_greenstein(g, cos),
            Lobe::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + cos * cos),
            Lobe::Table(t) => t.density(cos),
        }
    }

    /// A cosine drawn by the lobe's density from `u` in [0, 1).
    fn sample_cos(self, u: f32) -> f32 {
        match self {
            Lobe::Hg(g) if g.abs() < 1e-3 => 1.0 - 2.0 * u,
            Lobe::Hg(g) => {
                let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
                ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
            }
            // The CDF 1/2 + 3/8·(c + c³/3) inverted in closed form (Cardano's root of c³ + 3c = z).
            Lobe::Rayleigh => {
                let z = 4.0 * (2.0 * u - 1.0);
                let r = (z * z / 4.0 + 1.0).sqrt();
                ((z / 2.0 + r).cbrt() + (z / 2.0 - r).cbrt()).clamp(-1.0, 1.0)
            }
            Lobe::Table(t) => t.sample_cos(u),
        }
    }
}

/// A phase function: (1 − `weight`)·`first` + `weight`·`second` (Mitsuba's `blendphase` of two lobes;
/// `weight` 0 for one lobe).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Phase {
    pub first: Lobe,
    pub second: Lobe,
    pub weight: f32,
}

impl Phase {
    /// Henyey–Greenstein's of asymmetry `g` alone.
    pub fn hg(g: f32) -> Phase {
        Phase { first: Lobe::Hg(g), ..Default::default() }
    }

    /// The density at the cosine `cos` between the directions light travels in and out.
    pub fn density(&self, cos: f32) -> f32 {
        match self.weight {
            0.0 => self.first.density(cos),
            w => (1.0 - w) * self.first.density(cos) + w * self.second.density(cos),
        }
    }
}

impl Scattering {
    /// Whether the medium scatters at all.
    pub fn scatters(&self) -> bool {
        self.sigma_s != Rgb::ZERO
    }

    /// The phase function's density (per steradian, integrating to 1 over the sphere) of going on along
    /// `out` having come along `inc` (both the directions light travels, unit).
    pub fn phase(&self, inc: Vec3, out: Vec3) -> f32 {
        self.phase.density(inc.dot(out))
    }

    /// A direction to go on along having come along `inc` (unit), drawn by the phase function itself (a
    /// lobe picked by its weight with `u[0]`, then drawn by it): the phase over its density is 1.
    /// Returns the direction and that density.
    pub fn sample_phase(&self, inc: Vec3, u: [f32; 2]) -> (Vec3, f32) {
        let w = self.phase.weight;
        let cos = match w {
            0.0 => self.phase.first.sample_cos(u[0]),
            _ if u[0] < w => self.phase.second.sample_cos((u[0] / w).min(ONE_BELOW)),
            _ => self.phase.first.sample_cos(((u[0] - w) / (1.0 - w)).min(ONE_BELOW)),
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u[1];
        let out = Frame::from_normal(inc).to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)).normalize();
        (out, self.phase.density(cos))
    }
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// A homogeneous medium a path runs through: its extinction σ_t per channel and what of it scatters
/// (the default: vacuum).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Medium {
    pub sigma_t: Rgb,
    pub scattering: Scattering,
}

/// Henyey–Greenstein's density at the cosine `cos` between the incoming and outgoing directions of
/// travel: (1 − g²) / (4π (1 + g² − 2g cos)^{3/2}), Mitsuba's `hg` (its g > 0 scatters forwards).
pub fn henyey_greenstein(g: f32, cos: f32) -> f32 {
    let d = (1.0 + g * g - 2.0 * g * cos).max(1e-12);
    (1.0 - g * g) / (4.0 * PI * d * d.sqrt())
}

/// Where a path through a medium of extinction `sigma_t` goes along a segment of length `len`
/// (infinite: it leaves the scene): `fly`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// It meets the medium at distance `dist`, which each channel's free flight reaches with density
    /// `pdf` (σ_t e^(−σ_t dist) per channel), through the transmittance `tr` (e^(−σ_t dist); 1 in a
    /// channel of σ_t 0).
    Scatter { dist: f32, pdf: Rgb, tr: Rgb },
    /// It reaches the segment's end, which each channel's free flight passes with probability `prob`
    /// (e^(−σ_t len) per channel: the transmittance).
    Through { prob: Rgb },
}

/// Free flight through a homogeneous medium by channel `hero`'s extinction (`u`: uniform in [0, 1)),
/// with what every channel's free flight would give the same outcome, for spectral MIS over the whole
/// path: a path tracer draws one hero channel per path (uniformly) and keeps each channel's path density
/// over their mean, r (1 at the start); at each flight, with p the channels' densities (or
/// probabilities) of its outcome and m the mean of r·p, its throughput takes the transmittance over m
/// and r becomes r·p / m. What it gathers is then its contribution over the mean of the channels' path
/// densities: the balance heuristic over the three (Wilkie et al. 2014; pbrt-v4's rescaled path
/// probabilities), unbiased, and never more than three times a channel's own estimator's weight, where
/// mixing the channels flight by flight lets the weight of a path that scatters a hundred times grow
/// without bound in a channel whose σ_t differs. A channel of σ_t 0 never stops the path.
pub fn fly(sigma_t: Rgb, len: f32, hero: usize, u: f32) -> Flight {
    let s = sigma_t[hero];
    let dist = if s > 0.0 { -(1.0 - u).ln() / s } else { f32::INFINITY };
    let tr = |d: f32| {
        let one = |s: f32| if s > 0.0 { (-s * d).exp() } else { 1.0 };
        Rgb::new(one(sigma_t.x), one(sigma_t.y), one(sigma_t.z))
    };
    if dist < len {
        let tr = tr(dist);
        Flight::Scatter { dist, pdf: sigma_t * tr, tr }
    } else {
        Flight::Through { prob: tr(len) }
    }
}

/// The mean of a colour's channels (`fly`'s m).
#[inline]
pub fn mean_ratio(r: Rgb) -> f32 {
    (r.x + r.y + r.z) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// Each phase function integrates to 1 over the sphere, and its samples fall by its own density:
    /// their cosines' histogram (20 bins) matches the density's integral over each bin within 0.002 of
    /// the samples (about four standard deviations), each sample's density is the function's own, and
    /// their mean cosine is the closed form (g for Henyey–Greenstein, 0 for Rayleigh, whose mean squared
    /// cosine is 2/5; the weighted sum for a blend). A Rayleigh lobe sampled as isotropic would miss its
    /// outermost bins by 0.021.
    #[test]
    fn phase_functions_are_normalised_and_sampled_by_their_density() {
        let mut rng = Rng::new(7, 0, 0);
        let mean_cos = |l: Lobe| match l {
            Lobe::Hg(g) => g as f64,
            Lobe::Rayleigh => 0.0,
            // ∫ c·v(c) dc over ∫ v(c) dc, interval by interval in closed form (v linear on each).
            Lobe::Table(t) => {
                let v = t.values();
                let h = 2.0 / (v.len() - 1) as f64;
                let (mut num, mut den) = (0.0, 0.0);
                for (i, w) in v.windows(2).enumerate() {
                    let (a, b, c0) = (w[0] as f64, w[1] as f64, -1.0 + i as f64 * h);
                    num += h * (c0 * a + c0 * (b - a) / 2.0 + h * a / 2.0 + h * (b - a) / 3.0);
                    den += h * (a + b) / 2.0;
                }
                num / den
            }
        };
        let mut phases: Vec<Phase> = [-0.7f32, -0.2, 0.0, 0.0005, 0.3, 0.8, 0.95].map(Phase::hg).to_vec();
        phases.push(Phase { first: Lobe::Rayleigh, ..Default::default() });
        phases.push(Phase { first: Lobe::Hg(0.8), second: Lobe::Rayleigh, weight: 0.3 });
        phases.push(Phase { first: Lobe::Hg(0.9), second: Lobe::Hg(-0.5), weight: 0.25 });
        let table = |v: &[f32]| Lobe::Table(Table::interned(v).unwrap());
        for v in [&[0.0f32, 1.0][..], &[0.1, 0.1, 0.2, 0.5, 3.0, 10.0], &[1.0, 0.0, 0.0, 2.0], &[0.0, 5.0, 0.0]] {
            phases.push(Phase { first: table(v), ..Default::default() });
        }
        phases.push(Phase { first: Lobe::Hg(-0.3), second: table(&[0.2, 0.0, 0.3, 4.0]), weight: 0.6 });
        for phase in phases {
            let n = 200_000;
            let integral: f64 = (0..n)
                .map(|k| {
                    let cos = 1.0 - 2.0 * (k as f32 + 0.5) / n as f32;
                    phase.density(cos) as f64 * 4.0 * std::f64::consts::PI / n as f64
                })
                .sum();
            assert!((integral - 1.0).abs() < 2e-3, "{phase:?}: integral {integral}");
            let sc = Scattering { sigma_s: Rgb::ONE, phase };
            let inc = Vec3::new(0.3, -0.5, 0.8).normalize();
            let (mut mean, mut mean2) = (0.0f64, 0.0f64);
            let bins = 20;
            let mut hist = vec![0.0f64; bins];
            for _ in 0..n {
                let (out, pdf) = sc.sample_phase(inc, rng.next_2d());
                assert!((out.length() - 1.0).abs() < 1e-4);
                let want = sc.phase(inc, out);
                assert!((pdf - want).abs() <= 2e-3 * want.max(1.0), "{phase:?}: density {pdf} against {want}");
                let c = inc.dot(out).clamp(-1.0, 1.0) as f64;
                mean += c / n as f64;
                mean2 += c * c / n as f64;
                hist[(((c + 1.0) / 2.0 * bins as f64) as usize).min(bins - 1)] += 1.0 / n as f64;
            }
            for (b, got) in hist.iter().enumerate() {
                let steps = 4000;
                let want: f64 = (0..steps)
                    .map(|k| {
                        let c = -1.0 + 2.0 * (b as f64 + (k as f64 + 0.5) / steps as f64) / bins as f64;
                        phase.density(c as f32) as f64 * 2.0 * std::f64::consts::PI * 2.0 / (bins * steps) as f64
                    })
                    .sum();
                assert!((got - want).abs() < 0.002, "{phase:?}: bin {b} holds {got}, density {want}");
            }
            let w = phase.weight as f64;
            let want = (1.0 - w) * mean_cos(phase.first) + w * mean_cos(phase.second);
            assert!((mean - want).abs() < 0.006, "{phase:?}: mean cosine {mean} against {want}");
            if phase.first == Lobe::Rayleigh && w == 0.0 {
                assert!((mean2 - 0.4).abs() < 0.004, "Rayleigh: mean squared cosine {mean2}");
            }
        }
    }

    /// A table's density is its values interpolated over their integral and 2π: equal values are the
    /// isotropic lobe (also values near f32::MAX, whose sum passes it), values 0 and 1 the ramp (1 + cos)/(4π); equal tables are one copy; a table of
    /// fewer than two values, a negative or non-finite value, or only zeros is refused.
    #[test]
    fn tabulated_phase_functions_read_as_their_closed_forms() {
        let flat = Table::interned(&[2.0, 2.0]).unwrap();
        let ramp = Table::interned(&[0.0, 1.0]).unwrap();
        // Values whose sum passes f32::MAX.
        let huge = Table::interned(&[3e38, 3e38, 3e38]).unwrap();
        for k in 0..=40 {
            let cos = -1.0 + k as f32 / 20.0;
            assert!((Lobe::Table(flat).density(cos) - 1.0 / (4.0 * PI)).abs() < 1e-6, "flat at {cos}");
            assert!((Lobe::Table(huge).density(cos) - 1.0 / (4.0 * PI)).abs() < 1e-6, "huge at {cos}");
            let want = (1.0 + cos) / (4.0 * PI);
            assert!((Lobe::Table(ramp).density(cos) - want).abs() < 1e-6, "ramp at {cos}");
        }
        assert!(std::ptr::eq(ramp, Table::interned(&[0.0, 1.0]).unwrap()));
        for bad in [&[][..], &[1.0], &[1.0, -0.5], &[1.0, f32::NAN], &[0.0, 0.0, 0.0]] {
            assert!(Table::new(bad).is_err(), "{bad:?} read");
        }
    }

    /// Over many flights along a segment of length L, each by a hero channel drawn uniformly, the
    /// weights of those that pass (the transmittance over the mean of the channels' probabilities),
    /// summed and divided by the flights, are the transmittance e^(−σ_t L); and those that stop in
    /// [a, b] (σ_t times the transmittance over the mean density) give ∫ σ_t e^(−σ_t t) dt over [a, b]
    /// per channel (the closed form), for a medium whose channels differ a hundredfold and one with a
    /// channel of σ_t 0. The transmittance a stop reports is `Scene::absorbed`'s, bit for bit.
    #[test]
    fn free_flight_weights_are_the_transmittance_and_its_density() {
        let mut rng = Rng::new(11, 0, 0);
        for sigma in [Rgb::new(0.05, 0.5, 5.0), Rgb::new(0.0, 1.0, 2.0)] {
            let len = 1.3f32;
            let (a, b) = (0.2f32, 0.7f32);
            let n = 400_000;
            let (mut through, mut inside) = (Rgb::ZERO, Rgb::ZERO);
            for _ in 0..n {
                let hero = ((rng.next_f32() * 3.0) as usize).min(2);
                match fly(sigma, len, hero, rng.next_f32()) {
                    Flight::Through { prob } => through += prob / mean_ratio(prob) / n as f32,
                    Flight::Scatter { dist, pdf, tr } => {
                        assert_eq!(tr, crate::scene::Scene::absorbed(sigma, dist));
                        assert!(dist < len);
                        if (a..b).contains(&dist) {
                            inside += pdf / mean_ratio(pdf) / n as f32;
                        }
                    }
                }
            }
            for c in 0..3 {
                let s = sigma[c];
                let want_through = (-s * len).exp();
                let want_inside = (-s * a).exp() - (-s * b).exp();
                assert!(
                    (through[c] - want_through).abs() < 0.01,
                    "σ {sigma}: through {through} against {want_through}"
                );
                assert!(
                    (inside[c] - want_inside).abs() < 0.01,
                    "σ {sigma}: stopping in [a, b] {inside} against {want_inside}"
                );
            }
        }
        // Leaving the scene: only a channel of σ_t 0 gets through.
        assert_eq!(
            fly(Rgb::new(0.0, 1.0, 2.0), f32::INFINITY, 0, 0.5),
            Flight::Through { prob: Rgb::new(1.0, 0.0, 0.0) }
        );
        assert!(matches!(fly(Rgb::new(0.0, 1.0, 2.0), f32::INFINITY, 1, 0.5), Flight::Scatter { .. }));
    }
}
