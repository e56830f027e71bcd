//! The camera: `origin`, `target`, `up`, `resolution` and the pixel reconstruction filter; a pinhole
//! (or thin lens) of field of view `fov` (degrees) along `fov_axis`, or an orthographic projection whose
//! film is a rectangle of the scene (every ray parallel to the view direction).
use crate::math::Ray;
use crate::scene::file::FovAxis;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// A pixel reconstruction filter as written in a scene (Mitsuba's `rfilter`): `box` (caustica's
/// default: each pixel averages the light over its own square), `tent` of a `radius` in pixels (Mitsuba's
/// default 1) or `gaussian` of a standard deviation `stddev` (Mitsuba's default 0.5, cut at 4 stddev
/// with the value there subtracted, as Mitsuba's is; Mitsuba's film's default filter); and three with
/// negative lobes, which sharpen: `mitchell` (Mitchell & Netravali's cubic, parameters `b` and `c`,
/// 1/3 each by default, reach 2 pixels), `catmullrom` (the same cubic with b = 0, c = 1/2) and
/// `lanczos` (sinc windowed by a wider sinc, `lobes` pixels of reach, 3 by default).
#[derive(Clone, Copy, Debug, PartialEq, Default, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum FilterSpec {
    #[default]
    Box,
    Tent {
        #[serde(default = "tent_radius")]
        radius: f32,
    },
    Gaussian {
        #[serde(default = "gaussian_stddev")]
        stddev: f32,
    },
    Mitchell {
        #[serde(default = "mitchell_bc")]
        b: f32,
        #[serde(default = "mitchell_bc")]
        c: f32,
    },
    CatmullRom,
    Lanczos {
        #[serde(default = "lanczos_lobes")]
        lobes: u32,
    },
}

/// Mitsuba's default `radius` of a `tent` filter, `stddev` of a `gaussian` one (its film's default),
/// `B` and `C` of a `mitchell` one and `lobes` of a `lanczos` one.
pub const TENT_RADIUS: f32 = 1.0;
pub const GAUSSIAN_STDDEV: f32 = 0.5;
pub const MITCHELL_BC: f32 = 1.0 / 3.0;
pub const LANCZOS_LOBES: u32 = 3;
/// The Lanczos lobes a scene may ask for (a splat reaches (2 · lobes)² pixels).
pub const LANCZOS_LOBES_RANGE: std::ops::RangeInclusive<u32> = 1..=8;

fn tent_radius() -> f32 {
    TENT_RADIUS
}

fn gaussian_stddev() -> f32 {
    GAUSSIAN_STDDEV
}

fn mitchell_bc() -> f32 {
    MITCHELL_BC
}

fn lanczos_lobes() -> u32 {
    LANCZOS_LOBES
}

/// Mitchell & Netravali's cubic of parameters `b` and `c` at |x| (reach 2).
fn mitchell(x: f32, b: f32, c: f32) -> f32 {
    let x = x.abs();
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else if x < 2.0 {
        (-b - 6.0 * c) * x3 + (6.0 * b + 30.0 * c) * x2 + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c)
    } else {
        0.0
    };
    v / 6.0
}

impl FilterSpec {
    /// The filter's reach in pixels from a pixel's centre.
    pub fn radius(&self) -> f32 {
        match *self {
            FilterSpec::Box => 0.5,
            FilterSpec::Tent { radius } => radius,
            FilterSpec::Gaussian { stddev } => 4.0 * stddev,
            FilterSpec::Mitchell { .. } | FilterSpec::CatmullRom => 2.0,
            FilterSpec::Lanczos { lobes } => lobes as f32,
        }
    }

    /// The filter's value at an offset of `t` pixels along one axis (it is separable).
    fn eval(&self, t: f32) -> f32 {
        let r = self.radius();
        match *self {
            FilterSpec::Box => (t.abs() <= 0.5) as u8 as f32,
            FilterSpec::Tent { radius } => (1.0 - t.abs() / radius).max(0.0),
            FilterSpec::Gaussian { stddev } => {
                let a = -1.0 / (2.0 * stddev * stddev);
                ((t * t * a).exp() - (r * r * a).exp()).max(0.0)
            }
            FilterSpec::Mitchell { b, c } => mitchell(t, b, c),
            FilterSpec::CatmullRom => mitchell(t, 0.0, 0.5),
            FilterSpec::Lanczos { .. } => {
                let x = std::f32::consts::PI * t.abs();
                if t.abs() > r {
                    0.0
                } else if x < 1e-6 {
                    1.0
                } else {
                    x.sin() * (x / r).sin() / (x * x / r)
                }
            }
        }
    }
}

/// Bins of a filter's tabulated distribution over [−radius, radius].
const FILTER_BINS: usize = 512;

/// A reconstruction filter ready to draw with. Box: a pixel's samples are uniform over its square.
/// Otherwise each sample's film position is drawn from the filter's magnitude |f| around the pixel's
/// centre (tabulated in `FILTER_BINS` steps, the step function being the filter rendered), cut to the
/// film, as Mitsuba's film (without `sample_border`) only samples inside it, and weighs
/// sign(f) · ∫|f| / ∫f, both over the film: 1 for a filter without negative lobes. A pixel then converges
/// to ∫ f(x − c) L(x) dx / ∫ f, both over the film, the weighted average Mitsuba's film accumulates.
/// Light tracing's splats (`splat`) give each pixel in reach f / ∫f there, the same in expectation.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelFilter {
    pub spec: FilterSpec,
    radius: f32,
    /// The cumulative distribution of |f| at the bins' edges (FILTER_BINS + 1 entries, 0 to 1); empty
    /// for the box.
    cdf: Vec<f32>,
    /// The cumulative sum of f itself on the same scale, for a filter with a negative bin; else empty
    /// (it would equal `cdf`).
    signed: Vec<f32>,
}

impl PixelFilter {
    pub fn new(spec: FilterSpec) -> PixelFilter {
        let radius = spec.radius();
        if spec == FilterSpec::Box {
            return PixelFilter { spec, radius, cdf: Vec::new(), signed: Vec::new() };
        }
        let width = 2.0 * radius as f64 / FILTER_BINS as f64;
        // Each bin's value: the filter averaged over the bin (16 midpoints), in f64.
        let (mut cdf, mut signed) = (vec![0.0f64; FILTER_BINS + 1], vec![0.0f64; FILTER_BINS + 1]);
        for k in 0..FILTER_BINS {
            let bin: f64 = (0..16)
                .map(|j| spec.eval((-radius as f64 + (k as f64 + (j as f64 + 0.5) / 16.0) * width) as f32) as f64)
                .sum();
            cdf[k + 1] = cdf[k] + bin.abs();
            signed[k + 1] = signed[k] + bin;
        }
        let total = cdf[FILTER_BINS];
        let scale = |v: &[f64]| v.iter().map(|c| (c / total) as f32).collect::<Vec<f32>>();
        let signed = if signed == cdf { Vec::new() } else { scale(&signed) };
        PixelFilter { spec, radius, cdf: scale(&cdf), signed }
    }

    /// The offsets from pixel `i`'s centre (of `n` along this axis) that stay on the film and in reach.
    fn bounds(&self, i: u32, n: u32) -> (f32, f32) {
        let c = i as f32 + 0.5;
        ((-self.radius).max(-c), self.radius.min(n as f32 - c))
    }

    /// The bin holding offset `t` ∈ [−radius, radius], and how far into it `t` lies (in bins).
    fn bin(&self, t: f32) -> (usize, f32) {
        let s = ((t + self.radius) / (2.0 * self.radius) * FILTER_BINS as f32).clamp(0.0, FILTER_BINS as f32);
        let k = (s as usize).min(FILTER_BINS - 1);
        (k, s - k as f32)
    }

    /// A cumulative table (`cdf` or `signed`) at offset `t` ∈ [−radius, radius] (linear within a bin).
    fn table_at(&self, table: &[f32], t: f32) -> f32 {
        let (k, frac) = self.bin(t);
        table[k] + (table[k + 1] - table[k]) * frac
    }

    /// The cumulative distribution of |f| at offset `t`.
    fn cdf_at(&self, t: f32) -> f32 {
        self.table_at(&self.cdf, t)
    }

    /// The cumulative table of f itself: `signed`, or `cdf` where the two are equal.
    fn f_table(&self) -> &[f32] {
        if self.signed.is_empty() {
            &self.cdf
        } else {
            &self.signed
        }
    }

    /// The filter's integral over [`lo`, `hi`] on the scale of the tables (of |f| over its whole reach = 1).
    fn signed_mass(&self, lo: f32, hi: f32) -> f32 {
        let table = self.f_table();
        self.table_at(table, hi) - self.table_at(table, lo)
    }

    /// A film coordinate for pixel `i` of `n` along one axis from a uniform `u`, and its weight along
    /// this axis (1 unless the filter has negative lobes).
    fn sample_axis(&self, i: u32, n: u32, u: f32) -> (f32, f32) {
        let (lo, hi) = self.bounds(i, n);
        let (a, b) = (self.cdf_at(lo), self.cdf_at(hi));
        let v = a + u * (b - a);
        // The bin holding v: the last edge at or below it.
        let k = (self.cdf.partition_point(|&c| c <= v).max(1) - 1).min(FILTER_BINS - 1);
        let span = self.cdf[k + 1] - self.cdf[k];
        let frac = if span > 0.0 { ((v - self.cdf[k]) / span).clamp(0.0, 1.0) } else { 0.5 };
        let t = -self.radius + (k as f32 + frac) * (2.0 * self.radius / FILTER_BINS as f32);
        let x = i as f32 + 0.5 + t.clamp(lo, hi);
        if self.signed.is_empty() {
            return (x, 1.0);
        }
        // Drawn from |f| over [lo, hi]: weighs sign(f) · ∫|f| / ∫f there.
        let negative = self.signed[k + 1] < self.signed[k];
        let w = (b - a) / self.signed_mass(lo, hi);
        (x, if negative { -w } else { w })
    }

    /// Pixel `i`'s (of `n`) splat weight along one axis at film coordinate `x`: f / ∫f over the film
    /// (0 out of reach), which for a filter without negative lobes is the density of its draws.
    fn weight_axis(&self, i: u32, n: u32, x: f32) -> f32 {
        let (lo, hi) = self.bounds(i, n);
        let t = x - (i as f32 + 0.5);
        if !(t >= lo && t < hi) {
            return 0.0;
        }
        let (k, _) = self.bin(t);
        let table = self.f_table();
        let (value, mass) = (table[k + 1] - table[k], self.signed_mass(lo, hi));
        if mass > 0.0 {
            value * FILTER_BINS as f32 / (2.0 * self.radius) / mass
        } else {
            0.0
        }
    }
}

impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter::new(FilterSpec::Box)
    }
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub origin: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub tan_half: [f32; 2],
    pub width: u32,
    pub height: u32,
    pub filter: PixelFilter,
    /// Radius of the thin lens's aperture (0: a pinhole). Rays leave from a point of the disc of this
    /// radius around `origin` (in the film's plane) and pass through the point that the pinhole ray
    /// of their film position meets on the plane of focus.
    pub lens_radius: f32,
    /// Distance from the lens to the plane in focus, along `forward`.
    pub focus_distance: f32,
    /// An orthographic projection: half the film's width and height in scene units, the film centred on
    /// `origin` in the plane facing `forward`, each ray leaving its film point along `forward` (None: the
    /// pinhole or thin lens). Its rays' direction is a delta, so light tracing joins a surface point to
    /// the film point in front of it, as to a distant light.
    pub ortho: Option<[f32; 2]>,
    /// Where the film's centre lies off the view axis, in the units of `tan_half` (or of `ortho`): the
    /// film is a crop window of a larger one centred on the axis (`crop`); [0, 0] without a crop.
    pub centre: [f32; 2],
    /// For a crop window: its offset on the whole film and that film's size, in pixels (for reports).
    pub window: Option<([u32; 2], [u32; 2])>,
    /// The clipping planes (Mitsuba's sensor `near_clip` and `far_clip`): the camera sees only what lies
    /// between these depths along `forward` from the lens's plane, [0, ∞) by default. Whatever is nearer
    /// is not there for the camera's line of sight (a cutaway), though it still casts shadows and
    /// reflects; whatever is farther is not seen either, the sky shows instead. Only the segment from the
    /// camera is clipped, as in Mitsuba (a reflection shows everything).
    pub clip: [f32; 2],
    /// The medium the camera sits in (Mitsuba's sensor `medium`; vacuum by default): camera paths start
    /// in it at the near clipping plane (`PathTracer::li`).
    pub medium: crate::scene::medium::Medium,
}

/// Where light leaving a surface point reaches the camera (`Camera::link`).
#[derive(Clone, Copy, Debug)]
pub struct CameraLink {
    /// Film position, in pixels.
    pub film: (f32, f32),
    /// The point the light reaches: the lens point, or for an orthographic camera the film point in
    /// front of the surface point.
    pub to: Vec3,
    /// Unit direction from the surface point to `to`.
    pub dir: Vec3,
    /// The camera's importance per unit area at the surface point, before the surface's cosine (per
    /// pixel of film), is `pdf / dist2`: a pinhole's `pixel_pdf_dir(-dir)` over the squared distance,
    /// an orthographic camera's 1 / (a pixel's area in the scene) over 1. Times |cos θ| at the surface it
    /// is the density with which a camera path reaches that point, per unit area.
    pub pdf: f32,
    pub dist2: f32,
    /// Where the segment from the surface point towards `to` meets the near clipping plane (`to` itself
    /// without one): what lies beyond it, nearer the camera, the camera sees through, so a shadow ray
    /// to the camera stops there.
    pub clear: Vec3,
    /// The point lies beyond the far clipping plane. Only the segment from the camera is clipped: the
    /// camera sees such a point only through a surface its line of sight goes straight on through (a
    /// thin pane, a null surface, a hidden emitter) that lies within the plane (`camera_sees`).
    pub beyond_far: bool,
}

impl Camera {
    pub fn new(origin: Vec3, target: Vec3, up: Vec3, fov_deg: f32, axis: FovAxis, res: [u32; 2]) -> Camera {
        let forward = (target - origin).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let t = (fov_deg.to_radians() * 0.5).tan();
        let aspect = res[0] as f32 / res[1] as f32;
        let tan_half = match axis {
            FovAxis::X => [t, t / aspect],
            FovAxis::Y => [t * aspect, t],
        };
        Camera {
            origin,
            right,
            up,
            forward,
            tan_half,
            width: res[0],
            height: res[1],
            filter: PixelFilter::default(),
            lens_radius: 0.0,
            focus_distance: (target - origin).length(),
            ortho: None,
            centre: [0.0, 0.0],
            window: None,
            clip: [0.0, f32::INFINITY],
            medium: Default::default(),
        }
    }

    /// Depth of world point `p` along the view direction from the lens's plane.
    pub fn depth(&self, p: Vec3) -> f32 {
        (p - self.origin).dot(self.forward)
    }

    /// Ray `r` leaving the lens's plane, limited to the clipping planes: t from near to far over the
    /// cosine of its direction with the view direction (`r.d` need not be a unit vector).
    fn clipped(&self, mut r: Ray) -> Ray {
        let [near, far] = self.clip;
        if near > 0.0 || far < f32::INFINITY {
            let c = r.d.dot(self.forward);
            (r.tmin, r.tmax) = (near / c, far / c);
        }
        r
    }

    /// An orthographic camera at `origin` looking at `target`, its film `size` (width, height) in scene
    /// units.
    pub fn orthographic(origin: Vec3, target: Vec3, up: Vec3, size: [f32; 2], res: [u32; 2]) -> Camera {
        Camera { ortho: Some([0.5 * size[0], 0.5 * size[1]]), ..Camera::new(origin, target, up, 40.0, FovAxis::X, res) }
    }

    /// The same camera with its film shifted in its plane by `[x, y]` film widths and heights (right and
    /// down): each pixel sees what the pixel that far from it saw (Mitsuba's principal point offset).
    pub fn shift(self, [x, y]: [f32; 2]) -> Camera {
        let half = self.ortho.unwrap_or(self.tan_half);
        let centre = [self.centre[0] + 2.0 * x * half[0], self.centre[1] - 2.0 * y * half[1]];
        Camera { centre, ..self }
    }

    /// Whether the crop window `[x, y, width, height]` holds at least one pixel and lies on a film of
    /// `film` pixels (what `crop` needs).
    pub fn window_fits([x, y, w, h]: [u32; 4], film: [u32; 2]) -> bool {
        w > 0 && h > 0 && x as u64 + w as u64 <= film[0] as u64 && y as u64 + h as u64 <= film[1] as u64
    }

    /// The same camera rendering only the window of `size` pixels at `offset` (from the top-left corner)
    /// of its film: each pixel of the new film sees exactly what the same pixel of the window saw, so the
    /// image is that window of the whole one (Mitsuba's film crop). The caller checks that the window
    /// lies on the film (`window_fits`).
    pub fn crop(self, offset: [u32; 2], size: [u32; 2]) -> Camera {
        let (full, new) = ([self.width as f32, self.height as f32], [size[0] as f32, size[1] as f32]);
        let half = self.ortho.unwrap_or(self.tan_half);
        let half_new = [half[0] * new[0] / full[0], half[1] * new[1] / full[1]];
        // The window's centre on the film, from −1 to 1 across it (y up).
        let mid =
            [(2.0 * offset[0] as f32 + new[0]) / full[0] - 1.0, 1.0 - (2.0 * offset[1] as f32 + new[1]) / full[1]];
        let centre = [self.centre[0] + mid[0] * half[0], self.centre[1] + mid[1] * half[1]];
        let (tan_half, ortho) = match self.ortho {
            Some(_) => (self.tan_half, Some(half_new)),
            None => (half_new, None),
        };
        let whole = match self.window {
            Some((at, film)) => ([at[0] + offset[0], at[1] + offset[1]], film),
            None => (offset, [self.width, self.height]),
        };
        Camera { tan_half, ortho, centre, width: size[0], height: size[1], window: Some(whole), ..self }
    }

    /// A pixel's area in the scene on an orthographic camera's film.
    fn ortho_pixel_area(&self, half: [f32; 2]) -> f32 {
        (2.0 * half[0] / self.width as f32) * (2.0 * half[1] / self.height as f32)
    }

    /// Where light leaving world point `p` reaches the camera through lens point `lens` (the pinhole, or
    /// ignored for an orthographic camera), if `p` is in front of the camera and lands on the film.
    /// Nearer than the near clipping plane the camera does not see `p`; beyond the far one, only through
    /// what its line of sight crosses (`CameraLink::beyond_far`).
    pub fn link(&self, lens: Vec3, p: Vec3) -> Option<CameraLink> {
        let [near, far] = self.clip;
        let z = self.depth(p);
        if z < near {
            return None;
        }
        let beyond_far = z > far;
        // The point where the segment from p to the lens's plane crosses the near plane.
        let clear = |to: Vec3| if near > 0.0 { p + (to - p) * ((z - near) / z) } else { to };
        if self.ortho.is_some() {
            let film = self.project(p)?;
            let to = p - self.forward * z;
            let pdf = self.pixel_pdf_dir(self.forward);
            return Some(CameraLink { film, to, dir: -self.forward, pdf, dist2: 1.0, clear: clear(to), beyond_far });
        }
        let film = self.film_position_from(lens, p)?;
        let to_cam = lens - p;
        let dist2 = to_cam.length_squared();
        let dir = to_cam / dist2.sqrt();
        Some(CameraLink { film, to: lens, dir, pdf: self.pixel_pdf_dir(-dir), dist2, clear: clear(lens), beyond_far })
    }

    /// The width in the scene of one pixel at distance `t` along camera ray direction `d`, seen face on.
    pub fn pixel_width_at(&self, t: f32, d: Vec3) -> f32 {
        match self.ortho {
            Some(half) => 2.0 * half[0] / self.width as f32,
            None => 2.0 * t * d.dot(self.forward) * self.tan_half[0] / self.width as f32,
        }
    }

    /// The point of the aperture that the uniform pair `u` picks (uniform over the disc; `origin` for a
    /// pinhole). Every lens point has the same density, 1 / (π r²), so it cancels wherever a light
    /// path is joined to the camera: only the point itself matters.
    pub fn lens_point(&self, u: [f32; 2]) -> Vec3 {
        if self.lens_radius <= 0.0 {
            return self.origin;
        }
        let [a, b] = crate::math::sampling::concentric_disk(u);
        self.origin + self.lens_radius * (a * self.right + b * self.up)
    }

    /// A lens point drawn from `rng` (its next two numbers, taken only when there is an aperture;
    /// `origin` for a pinhole).
    pub fn sample_lens(&self, rng: &mut crate::math::Rng) -> Vec3 {
        if self.lens_radius <= 0.0 {
            return self.origin;
        }
        self.lens_point(rng.next_2d())
    }

    /// A camera ray through film position (x, y): the pinhole's `ray`, or, with a lens, from a lens
    /// point drawn from `rng` (`sample_lens`) towards where that pinhole ray meets the plane of focus.
    pub fn sample_ray(&self, x: f32, y: f32, rng: &mut crate::math::Rng) -> Ray {
        self.ray_from(self.sample_lens(rng), x, y)
    }

    /// The ray from lens point `lens` through film position (x, y): towards where the pinhole's ray
    /// of (x, y) meets the plane of focus (the pinhole's ray itself without an aperture).
    pub fn ray_from(&self, lens: Vec3, x: f32, y: f32) -> Ray {
        let pinhole = self.ray(x, y);
        if self.lens_radius <= 0.0 {
            return pinhole;
        }
        let focus = self.origin + pinhole.d * (self.focus_distance / pinhole.d.dot(self.forward));
        self.clipped(Ray::new(lens, (focus - lens).normalize()))
    }

    /// Film position at which light leaving world point `p` towards lens point `lens` lands (the
    /// pinhole projection of where that line crosses the plane of focus), if it is on the film and `p`
    /// is in front of the lens.
    pub fn film_position_from(&self, lens: Vec3, p: Vec3) -> Option<(f32, f32)> {
        if self.lens_radius <= 0.0 {
            return self.project(p);
        }
        let d = p - lens;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        self.project(lens + d * (self.focus_distance / z))
    }

    /// The film position of a sample of pixel (`x`, `y`) from the uniform pair `u`, and the weight its
    /// radiance counts with: within the pixel for the box filter (x + u exactly), else drawn from the
    /// filter around its centre (`PixelFilter`); the weight is 1 unless the filter has negative lobes,
    /// where it is ± a constant of the pixel (negative where the filter is).
    #[inline]
    pub fn film_position(&self, x: u32, y: u32, u: [f32; 2]) -> (f32, f32, f32) {
        let f = &self.filter;
        if f.cdf.is_empty() {
            return (x as f32 + u[0], y as f32 + u[1], 1.0);
        }
        let ((fx, wx), (fy, wy)) = (f.sample_axis(x, self.width, u[0]), f.sample_axis(y, self.height, u[1]));
        (fx, fy, wx * wy)
    }

    /// Light landing at film position (`x`, `y`) (on the film): `add(pixel index, weight)` for each
    /// pixel it counts in, with the weight a sample of that pixel would give it: the pixel under it,
    /// weight 1, for the box filter; every pixel whose filter reaches it otherwise, each weighted by
    /// that pixel's filter there over its integral on the film (so each pixel's share integrates to
    /// one; for a filter without negative lobes, the density of that pixel's film positions there).
    pub fn splat(&self, x: f32, y: f32, mut add: impl FnMut(u32, f32)) {
        let (w, h) = (self.width, self.height);
        let f = &self.filter;
        if f.cdf.is_empty() {
            add((y as u32).min(h - 1) * w + (x as u32).min(w - 1), 1.0);
            return;
        }
        let reach = |c: f32, n: u32| {
            let lo = (c - 0.5 - f.radius).floor().max(0.0) as u32;
            let hi = ((c - 0.5 + f.radius).ceil().max(0.0) as u32).min(n - 1);
            lo..=hi
        };
        for py in reach(y, h) {
            let wy = f.weight_axis(py, h, y);
            if wy == 0.0 {
                continue;
            }
            for px in reach(x, w) {
                let wx = f.weight_axis(px, w, x);
                if wx != 0.0 {
                    add(py * w + px, wx * wy);
                }
            }
        }
    }

    /// The pinhole's ray through film position (x, y) in pixels, (0,0) = top-left corner (from the
    /// lens's centre when there is a lens: for aiming, not for rendering; see `sample_ray`); an
    /// orthographic camera's ray from that film point.
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let sx = 2.0 * x / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * y / self.height as f32;
        let [cx, cy] = self.centre;
        if let Some([hx, hy]) = self.ortho {
            let o = self.origin + (sx * hx + cx) * self.right + (sy * hy + cy) * self.up;
            return self.clipped(Ray::new(o, self.forward));
        }
        let (sx, sy) = (sx * self.tan_half[0] + cx, sy * self.tan_half[1] + cy);
        self.clipped(Ray::new(self.origin, (self.forward + sx * self.right + sy * self.up).normalize()))
    }

    /// Distance from the pinhole to the plane on which one pixel has unit area.
    pub fn pixel_plane_distance(&self) -> f32 {
        self.width as f32 / (2.0 * self.tan_half[0])
    }

    /// Solid-angle density of a primary ray along unit direction `d` when the film position is uniform
    /// over one pixel (D²/cos³θ with D the unit-pixel plane's distance), 0 behind the camera. It is also
    /// the pixel's importance times cos θ: light tracing divides by it to land on the film. With a lens
    /// it is the same function of the ray's direction from whichever lens point it leaves (the film
    /// maps linearly onto the plane of focus, seen from that point). For an orthographic camera (whose
    /// rays all run along `forward`) it is the density of the ray's origin per unit area of the film
    /// plane: 1 / (a pixel's area in the scene).
    pub fn pixel_pdf_dir(&self, d: Vec3) -> f32 {
        let c = d.dot(self.forward);
        if c <= 0.0 {
            return 0.0;
        }
        if let Some(half) = self.ortho {
            return 1.0 / self.ortho_pixel_area(half);
        }
        let dd = self.pixel_plane_distance();
        dd * dd / (c * c * c)
    }

    /// Film position of a world point, if it is in front of the camera and on the film.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.origin;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let [cx, cy] = self.centre;
        let (sx, sy) = match self.ortho {
            Some([hx, hy]) => ((d.dot(self.right) - cx) / hx, (d.dot(self.up) - cy) / hy),
            None => ((d.dot(self.right) / z - cx) / self.tan_half[0], (d.dot(self.up) / z - cy) / self.tan_half[1]),
        };
        let x = (sx + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - sy) * 0.5 * self.height as f32;
        (x >= 0.0 && y >= 0.0 && x < self.width as f32 && y < self.height as f32).then_some((x, y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pixel's film positions follow its filter, cut to the film: a histogram of 400,000 draws per
    /// axis, each counted with its weight (±, for a filter with negative lobes), equals the filter's
    /// values over the pixels it reaches (normalised over the film), within 2% of the largest bin; light
    /// landing anywhere gives each pixel the same weight there (`splat`), so each pixel's weights
    /// integrate to 1 over the film, at its edge too.
    #[test]
    fn filters_draw_and_splat_alike() {
        let specs = [
            FilterSpec::Gaussian { stddev: 0.5 },
            FilterSpec::Tent { radius: 1.5 },
            FilterSpec::Box,
            FilterSpec::Mitchell { b: MITCHELL_BC, c: MITCHELL_BC },
            FilterSpec::CatmullRom,
            FilterSpec::Lanczos { lobes: 3 },
        ];
        for spec in specs {
            let mut cam = Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, FovAxis::X, [9, 7]);
            cam.filter = PixelFilter::new(spec);
            let mut r = crate::math::Rng::new(5, 0, 0);
            for (px, py) in [(4u32, 3u32), (0, 0), (8, 6), (1, 5)] {
                // Draws: histogram in 1/8-pixel bins over the film.
                let (bins_x, bins_y) = (9 * 8, 7 * 8);
                let (mut hx, mut hy) = (vec![0.0f64; bins_x], vec![0.0f64; bins_y]);
                let n = 400_000;
                for _ in 0..n {
                    let (x, y, weight) = cam.film_position(px, py, r.next_2d());
                    assert!((0.0..=9.0).contains(&x) && (0.0..=7.0).contains(&y), "{spec:?}: ({x}, {y}) off the film");
                    hx[((x * 8.0) as usize).min(bins_x - 1)] += weight as f64 / n as f64;
                    hy[((y * 8.0) as usize).min(bins_y - 1)] += weight as f64 / n as f64;
                }
                // The splat weights of this pixel over the same bins (16 points per bin), and their integral.
                let (mut wx, mut wy) = (vec![0.0f64; bins_x], vec![0.0f64; bins_y]);
                let step = 1.0 / 128.0;
                for iy in 0..7 * 128 {
                    for ix in 0..9 * 128 {
                        let (x, y) = ((ix as f32 + 0.5) * step, (iy as f32 + 0.5) * step);
                        cam.splat(x, y, |pixel, w| {
                            if pixel == py * 9 + px {
                                let a = (w * step * step) as f64;
                                wx[ix / 16] += a;
                                wy[iy / 16] += a;
                            }
                        });
                    }
                }
                // The weights' integral over the film. They are separable, so it is the product of their
                // integrals along the row and the column through the pixel's centre over the value there;
                // each line is summed at 64 points per bin of the filter's table (a grid on which the table's
                // steps do not alias).
                let at = |x: f64, y: f64| {
                    let mut v = 0.0f64;
                    cam.splat(x as f32, y as f32, |pixel, w| {
                        if pixel == py * 9 + px {
                            v = w as f64;
                        }
                    });
                    v
                };
                let (cx, cy) = (px as f64 + 0.5, py as f64 + 0.5);
                let r = cam.filter.radius as f64;
                let points = FILTER_BINS * 64;
                let dt = 2.0 * r / points as f64;
                let line = |dx: f64, dy: f64| -> f64 {
                    (0..points)
                        .map(|k| -r + (k as f64 + 0.5) * dt)
                        .map(|t| (cx + t * dx, cy + t * dy))
                        .filter(|&(x, y)| (0.0..9.0).contains(&x) && (0.0..7.0).contains(&y))
                        .map(|(x, y)| at(x, y) * dt)
                        .sum()
                };
                let total = line(1.0, 0.0) * line(0.0, 1.0) / at(cx, cy);
                assert!((total - 1.0).abs() < 1e-3, "{spec:?} pixel ({px}, {py}): splat weights integrate to {total}");
                for (h, w) in [(&hx, &wx), (&hy, &wy)] {
                    let peak = w.iter().cloned().fold(0.0, f64::max);
                    for (k, (a, b)) in h.iter().zip(w.iter()).enumerate() {
                        assert!(
                            (a - b).abs() < 0.02 * peak,
                            "{spec:?} pixel ({px}, {py}) bin {k}: drawn {a} vs splat {b}"
                        );
                    }
                }
            }
            // The box draws x + u exactly.
            if spec == FilterSpec::Box {
                assert_eq!(cam.film_position(3, 2, [0.25, 0.75]), (3.25, 2.75, 1.0));
            }
        }
    }

    /// The Gaussian is Mitsuba's (stddev 0.5, cut at 2 pixels with its value there subtracted): its
    /// tabulated distribution's mass within half a pixel of the centre equals the closed form.
    #[test]
    fn gaussian_is_mitsubas() {
        let f = PixelFilter::new(FilterSpec::Gaussian { stddev: 0.5 });
        // ∫_{-a}^{a} (e^{-2t²} − e^{-8}) dt / ∫_{-2}^{2} (…): erf by its series, in f64.
        let erf = |x: f64| {
            let mut sum = 0.0;
            let mut term = x;
            for k in 0..60 {
                sum += term / (2 * k + 1) as f64;
                term *= -x * x / (k + 1) as f64;
            }
            2.0 / std::f64::consts::PI.sqrt() * sum
        };
        let mass = |a: f64| (std::f64::consts::PI / 2.0).sqrt() * erf(2f64.sqrt() * a) - 2.0 * a * (-8f64).exp();
        let expected = mass(0.5) / mass(2.0);
        let got = (f.cdf_at(0.5) - f.cdf_at(-0.5)) as f64;
        assert!((got - expected).abs() < 1e-4, "mass within half a pixel {got} vs {expected}");
    }
    /// The filters with negative lobes are Mitsuba's: Mitchell & Netravali's cubic is a partition of unity
    /// for any B and C (its copies one pixel apart sum to 1), is 1 − B/3 at 0 (its 6 − 2B over 6) and
    /// has its negative lobe where the closed form puts it; Catmull-Rom is the cubic with B = 0, C = ½
    /// (1 at 0, 0 at the integers); Lanczos is 1 at 0, 0 at every integer, sinc(x) sinc(x/lobes) between.
    #[test]
    fn negative_lobed_filters_are_mitsubas() {
        for (b, c) in [(1.0 / 3.0, 1.0 / 3.0), (0.0, 0.5), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            let f = FilterSpec::Mitchell { b, c };
            for x in [0.0f32, 0.13, 0.5, 0.77] {
                let sum: f32 = (-3..=3).map(|k| f.eval(x - k as f32)).sum();
                assert!((sum - 1.0).abs() < 1e-5, "Mitchell B {b} C {c}: copies sum to {sum} at {x}");
            }
            assert!((f.eval(0.0) - (1.0 - b / 3.0)).abs() < 1e-6);
            assert_eq!(f.eval(2.0), 0.0);
        }
        // B = C = 1/3 at 1.5: (−7/3 · 3.375 + 12 · 2.25 − 20 · 1.5 + 32/3) / 6 = −0.0347…
        let m = FilterSpec::Mitchell { b: MITCHELL_BC, c: MITCHELL_BC };
        assert!((m.eval(1.5) - (-7.0 / 3.0 * 3.375 + 27.0 - 30.0 + 32.0 / 3.0) / 6.0).abs() < 1e-6);
        assert!(m.eval(1.5) < 0.0);
        let cr = FilterSpec::CatmullRom;
        for x in [0.0f32, 0.3, 1.0, 1.4, 2.0] {
            assert_eq!(cr.eval(x), FilterSpec::Mitchell { b: 0.0, c: 0.5 }.eval(x));
        }
        assert!((cr.eval(0.0) - 1.0).abs() < 1e-6 && cr.eval(1.0).abs() < 1e-6);
        for lobes in [1u32, 2, 3, 5] {
            let l = FilterSpec::Lanczos { lobes };
            assert_eq!(l.radius(), lobes as f32);
            assert!((l.eval(0.0) - 1.0).abs() < 1e-6);
            for k in 1..=lobes {
                assert!(l.eval(k as f32).abs() < 1e-5, "Lanczos {lobes}: {} at {k}", l.eval(k as f32));
            }
            let x = 0.6f64;
            let pi = std::f64::consts::PI;
            let want = (pi * x).sin() / (pi * x) * (pi * x / lobes as f64).sin() / (pi * x / lobes as f64);
            assert!((l.eval(x as f32) as f64 - want).abs() < 1e-5);
            assert_eq!(l.eval(lobes as f32 + 0.1), 0.0);
        }
    }

    /// Over the parameters a scene may give (B and C in [0, 1], 1 to 8 lobes), a pixel's filter keeps a
    /// clearly positive integral however the film cuts it (a pixel at the film's edge, on a film one
    /// pixel wide), so its samples' weights sign(f) · ∫|f| / ∫f stay bounded; they are exactly 1 for
    /// filters without negative lobes.
    #[test]
    fn cut_filters_keep_a_positive_integral() {
        let mut specs = vec![FilterSpec::CatmullRom];
        for b in [0.0, 0.5, 1.0] {
            for c in [0.0, 0.5, 1.0] {
                specs.push(FilterSpec::Mitchell { b, c });
            }
        }
        specs.extend(LANCZOS_LOBES_RANGE.map(|lobes| FilterSpec::Lanczos { lobes }));
        for spec in specs {
            let f = PixelFilter::new(spec);
            // Mitchell's cubic is B (2 − x)³ / 6 between 1 and 2 when C = 0, negative there otherwise;
            // Lanczos of one lobe is sinc², its main lobe alone.
            let positive = matches!(spec, FilterSpec::Mitchell { c: 0.0, .. } | FilterSpec::Lanczos { lobes: 1 });
            assert_eq!(f.signed.is_empty(), positive, "{spec:?}: has negative lobes {}", !positive);
            if positive {
                continue;
            }
            for n in [1u32, 2, 40] {
                for i in [0, n / 2, n - 1] {
                    let (lo, hi) = f.bounds(i, n);
                    let ratio = (f.cdf_at(hi) - f.cdf_at(lo)) / f.signed_mass(lo, hi);
                    assert!((0.9999..2.5).contains(&ratio), "{spec:?} pixel {i} of {n}: ∫|f| / ∫f = {ratio}");
                }
            }
        }
        for spec in [FilterSpec::Gaussian { stddev: 0.1 }, FilterSpec::Tent { radius: 4.0 }] {
            let cam = Camera {
                filter: PixelFilter::new(spec),
                ..Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, FovAxis::X, [3, 2])
            };
            assert!(cam.filter.signed.is_empty());
            assert_eq!(cam.film_position(0, 1, [0.9, 0.1]).2, 1.0);
        }
    }

    /// A shifted film cropped: each pixel's ray as Mitsuba 3.9.1's `sample_ray` gives it (a 60° field of
    /// view along x on a 200 × 100 film, `principal_point_offset_x` 0.1, the window of the right half:
    /// its left edge, centre and right edge look 0.1155, 0.4041 and 0.6928 to the right per unit ahead,
    /// read off Mitsuba), and `project` takes each point back to its pixel.
    #[test]
    fn a_shifted_cropped_film_looks_where_mitsubas_does() {
        let c = Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, FovAxis::X, [200, 100])
            .shift([0.1, 0.0])
            .crop([100, 0], [100, 100]);
        for (x, want) in [(0.0, 0.1155), (50.0, 0.4041), (100.0, 0.6928)] {
            let r = c.ray(x, 50.0);
            let got = r.d.dot(c.right) / r.d.dot(c.forward);
            assert!((got - want).abs() < 2e-4, "film x {x}: {got} vs Mitsuba's {want}");
            assert!(r.d.dot(c.up).abs() < 1e-6);
            if x < 100.0 {
                let (px, py) = c.project(r.at(2.0)).expect("on the film");
                assert!((px - x).abs() < 1e-3 && (py - 50.0).abs() < 1e-3, "({px}, {py}) for ({x}, 50)");
            }
        }
        // Mitsuba's principal_point_offset_y 0.1 lowers the view: the centre looks 0.0577 down.
        let c = Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, FovAxis::X, [200, 100]).shift([0.0, 0.1]);
        let r = c.ray(100.0, 50.0);
        assert!((r.d.dot(c.up) / r.d.dot(c.forward) + 0.0577).abs() < 2e-4);
    }

    #[test]
    fn project_inverts_ray() {
        let c = Camera::new(Vec3::new(0.0, 1.0, 4.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 40.0, FovAxis::X, [320, 200]);
        for (x, y) in [(10.5, 20.5), (160.0, 100.0), (300.2, 190.9)] {
            let r = c.ray(x, y);
            let (px, py) = c.project(r.at(3.0)).unwrap();
            assert!((px - x).abs() < 1e-3 && (py - y).abs() < 1e-3);
        }
    }

    /// An orthographic camera: every ray runs along the view direction from its point of a film of the
    /// given size centred on the origin ((0, 0) the top-left corner: up and to the left of the view),
    /// `project` inverts `ray` at any depth, `link` joins a point to the film point straight in front
    /// of it, and the density of a ray's origin over one pixel is 1 / (the pixel's area in the scene).
    #[test]
    fn orthographic_rays_are_parallel_and_project_back() {
        let (o, t) = (Vec3::new(1.0, 2.0, 5.0), Vec3::new(1.0, 2.0, 0.0));
        let c = Camera::orthographic(o, t, Vec3::Y, [4.0, 1.5], [40, 20]);
        let corner = c.ray(0.0, 0.0);
        assert!((corner.o - Vec3::new(-1.0, 2.75, 5.0)).length() < 1e-5, "{:?}", corner.o);
        assert!((c.ray(40.0, 20.0).o - Vec3::new(3.0, 1.25, 5.0)).length() < 1e-5);
        for (x, y) in [(0.5, 0.5), (20.0, 10.0), (37.3, 18.9)] {
            let r = c.ray(x, y);
            assert_eq!(r.d, c.forward);
            for depth in [0.5, 3.0, 40.0] {
                let (px, py) = c.project(r.at(depth)).unwrap();
                assert!((px - x).abs() < 1e-3 && (py - y).abs() < 1e-3, "({x}, {y}) at {depth}: ({px}, {py})");
                let l = c.link(Vec3::ZERO, r.at(depth)).unwrap();
                assert!((l.to - r.o).length() < 1e-4 && l.dir == -c.forward && l.dist2 == 1.0);
                assert!((l.pdf * (4.0 / 40.0) * (1.5 / 20.0) - 1.0).abs() < 1e-5);
            }
        }
        assert!(c.project(o - c.forward).is_none(), "behind the film");
        assert!(c.project(o + 3.0 * c.forward + 2.01 * c.right).is_none(), "beside the film");
        assert_eq!(c.pixel_width_at(123.0, c.forward), 0.1);
    }

    /// A thin lens: every ray of a film position, whichever lens point it leaves, passes through the
    /// pinhole ray's point on the plane of focus, and light from any point on it lands back on that film
    /// position (`film_position_from` inverts `ray_from`); lens points fill the aperture's disc
    /// uniformly (mean r² = R²/2, none outside, a quarter in each quadrant). A pinhole's `sample_ray`
    /// is its `ray` and draws no random number.
    #[test]
    fn thin_lens_rays_meet_on_the_plane_of_focus() {
        use crate::math::Rng;
        let mut c =
            Camera::new(Vec3::new(0.3, 1.0, 4.0), Vec3::new(0.0, 0.8, 0.0), Vec3::Y, 50.0, FovAxis::X, [320, 200]);
        let mut rng = Rng::new(5, 6, 7);
        let before = rng.clone().next_f32();
        assert_eq!(c.sample_ray(10.5, 20.5, &mut rng).d, c.ray(10.5, 20.5).d);
        assert_eq!(rng.next_f32(), before, "a pinhole drew random numbers");
        (c.lens_radius, c.focus_distance) = (0.25, 3.0);
        for (x, y) in [(10.5, 20.5), (160.0, 100.0), (300.2, 190.9)] {
            let p = c.ray(x, y);
            let focus = p.at(3.0 / p.d.dot(c.forward));
            for _ in 0..50 {
                let r = c.sample_ray(x, y, &mut rng);
                assert!((r.o - c.origin).dot(c.forward).abs() < 1e-5, "lens point off the lens's plane");
                let t = (focus - r.o).dot(r.d);
                assert!((r.at(t) - focus).length() < 1e-4, "a ray of ({x}, {y}) misses the focus point");
                for along in [0.5, 2.0, 7.0] {
                    let (px, py) = c.film_position_from(r.o, r.at(along)).unwrap();
                    assert!((px - x).abs() < 2e-3 && (py - y).abs() < 2e-3, "({x}, {y}) came back as ({px}, {py})");
                }
            }
        }
        let n = 100_000;
        let (mut r2, mut quadrant) = (0.0f64, [0u32; 4]);
        for _ in 0..n {
            let l = c.lens_point(rng.next_2d()) - c.origin;
            let (a, b) = (l.dot(c.right), l.dot(c.up));
            assert!(a.hypot(b) <= c.lens_radius * 1.0001);
            r2 += (a * a + b * b) as f64;
            quadrant[(a > 0.0) as usize + 2 * (b > 0.0) as usize] += 1;
        }
        let mean_r2 = r2 / n as f64 / (0.25f64 * 0.25);
        assert!((mean_r2 - 0.5).abs() < 0.005, "mean r² / R² = {mean_r2}");
        assert!(quadrant.iter().all(|&q| (q as f64 / n as f64 - 0.25).abs() < 0.006), "{quadrant:?}");
    }
}
