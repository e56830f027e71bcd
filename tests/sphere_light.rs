//! Sphere lights against their closed form. A diffuse floor (ρ) lit by a sphere of radiance L and
//! radius r whose centre is at distance d, wholly above the horizon, has irradiance E = π L sin²α cos θ
//! (sin α = r/d, θ the centre's angle from the normal), so L_o = ρ L sin²α cos θ. The path tracer
//! (NEE + MIS) must match it within 1% for small, large, near and far lights; the direct photon map
//! within its blur.
mod common;
use caustica::accel::Accel;
use caustica::integrator::path::PathTracer;
use caustica::integrator::photon_map::{build_maps, MapRequest};
use caustica::integrator::Counters;
use caustica::math::{Ray, Rng};
use caustica::photon::estimate::Gather;
use caustica::photon::kdtree::KnnResult;
use caustica::photon::trace::DIRECT;
use caustica::scene::Scene;
use glam::Vec3;

const RHO: f32 = 0.8;

fn floor_scene(center: Vec3, radius: f32, radiance: f32, half: f32) -> Scene {
    common::scene(&format!(
        "[camera]\norigin = [0.0, 5.0, 0.1]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nm = {{ type = \"diffuse\", reflectance = [{RHO}, {RHO}, {RHO}] }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [{lo}, 0.0, {lo}]\nedge_u = [0.0, 0.0, {s}]\nedge_v = [{s}, 0.0, 0.0]\nmaterial = \"m\"\n\
         [[lights]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {radius}\nradiance = [{radiance}, {radiance}, {radiance}]\n",
        center.x,
        center.y,
        center.z,
        lo = -half,
        s = 2.0 * half,
    ))
}

fn closed_form(x: Vec3, center: Vec3, radius: f32, radiance: f32) -> f32 {
    let d = center - x;
    RHO * radiance * radius * radius / d.length_squared() * d.normalize().y
}

/// (centre, radius, radiance, floor half-size): the review's case, its large-radius twin, a light right
/// above the point, a far small one, and a large one close to the floor.
const CASES: [([f32; 3], f32, f32, f32); 6] = [
    ([-1.9, 2.1, -0.5], 0.05, 3000.0, 2.0),
    ([-1.9, 2.1, -0.5], 0.5, 30.0, 2.0),
    ([-1.9, 2.1, -0.5], 0.05, 3000.0, 50.0),
    ([0.5, 1.0, 0.5], 0.2, 100.0, 2.0),
    ([8.0, 6.0, -3.0], 0.1, 20000.0, 2.0),
    ([1.5, 0.9, 0.5], 0.8, 5.0, 2.0),
];

#[test]
fn path_tracer_matches_the_sphere_light_closed_form_within_one_percent() {
    let x = Vec3::new(0.5, 0.0, 0.5);
    for (c, radius, radiance, half) in CASES {
        let center = Vec3::from_array(c);
        let scene = floor_scene(center, radius, radiance, half);
        let accel = Accel::new(&scene).unwrap();
        let pt = PathTracer { scene: &scene, tracer: &accel, max_depth: 1, rr_depth: 100 };
        let n = 200_000;
        let mut sum = 0.0f64;
        let mut rng = Rng::new(3, 0, 0);
        for _ in 0..n {
            let ray = Ray::new(x + 0.01 * Vec3::Y, -Vec3::Y);
            sum += pt.li(ray, &mut rng, &mut Counters::default()).x as f64;
        }
        let got = sum / n as f64;
        let expect = closed_form(x, center, radius, radiance) as f64;
        eprintln!("sphere {c:?} r={radius} floor ±{half}: PT {got:.5} closed form {expect:.5} ({:.4})", got / expect);
        assert!((got / expect - 1.0).abs() < 0.01, "sphere {c:?} r={radius}: PT {got} vs closed form {expect}");
    }
}

#[test]
fn direct_photon_map_matches_the_sphere_light_closed_form_within_its_blur() {
    for (c, radius, radiance, half) in [CASES[0], CASES[1], CASES[3]] {
        let center = Vec3::from_array(c);
        let mut scene = floor_scene(center, radius, radiance, half);
        scene.render.photons.max_shots_factor = 20;
        let accel = Accel::new(&scene).unwrap();
        let m = build_maps(
            &scene,
            &accel,
            &MapRequest { want: [400_000, 0, 0], targeted: false, targets: None, ..Default::default() },
            true,
        )
        .unwrap();
        let map = m.maps[DIRECT].as_ref().unwrap();
        let g = Gather { k: 500, max_r2: f32::INFINITY, cone_k: 0.0 };
        let mut res = KnnResult::new();
        // 25 query points 0.4 apart: their gather discs do not overlap, so the errors average down.
        let mut ratio = 0.0f64;
        for j in 0..5 {
            for i in 0..5 {
                let x = Vec3::new(-0.8 + 0.4 * i as f32, 0.0, -0.8 + 0.4 * j as f32);
                let l = map
                    .radiance(
                        &common::surface_at(x, Vec3::Y),
                        Vec3::Y,
                        caustica::scene::material::DiffuseLobe::lambert(Vec3::splat(RHO)),
                        g,
                        u32::MAX,
                        &mut res,
                    )
                    .0
                    .x;
                ratio += (l / closed_form(x, center, radius, radiance)) as f64 / 25.0;
            }
        }
        eprintln!("sphere {c:?} r={radius}: direct map / closed form = {ratio:.4}");
        assert!((ratio - 1.0).abs() < 0.03, "sphere {c:?} r={radius}: direct map reads {ratio} of the closed form");
    }
}

#[test]
fn a_far_tiny_sphere_light_samples_its_whole_cone_with_the_pdf_mis_uses() {
    // Radius 1e-3 at distance 10 (1e4 radii): 1 − cos θmax = 5e-9, far below f32's spacing near 1, so
    // a cone sampler that forms 1 − cos θ from cos θ returns the axis only. The sampled directions must
    // fill the cone uniformly in solid angle (u = (1 − cos θ)/(1 − cos θmax) uniform on [0, 1]; 20 bins,
    // each within 5σ) and carry the pdf that `Lights::pdf` gives the same point (the MIS weight).
    let center = Vec3::new(3.0, 9.0, 4.0);
    let x = Vec3::new(0.5, 0.0, 0.5);
    let radius = 1e-3f32 * (center - x).length() / 10.0;
    let scene = floor_scene(center, radius, 1.0, 2.0);
    let axis = (center - x).as_dvec3().normalize();
    let dist = (center - x).as_dvec3().length();
    let s2 = (radius as f64 / dist).powi(2);
    let one_minus_max = s2 / (1.0 + (1.0 - s2).sqrt());
    let n = 200_000;
    let mut bins = [0usize; 20];
    let mut rng = Rng::new(9, 0, 0);
    for _ in 0..n {
        let ls = scene.lights.sample(&scene, x, rng.next_f32(), rng.next_2d(), true).expect("a sample");
        let w = ls.wi.as_dvec3();
        let theta = w.cross(axis).length().atan2(w.dot(axis));
        let u = (2.0 * (theta / 2.0).sin().powi(2)) / one_minus_max;
        assert!(u < 1.0 + 1e-3, "direction outside the cone: u = {u}");
        bins[((u * 20.0) as usize).min(19)] += 1;
        let y = x + ls.wi * ls.dist;
        let n_y = (y - center).normalize();
        let pdf = scene.lights.pdf(&scene, 1, 0, x, y, n_y);
        assert!((pdf / ls.pdf - 1.0).abs() < 1e-3, "sample pdf {} vs MIS pdf {pdf}", ls.pdf);
    }
    let expect = n as f64 / 20.0;
    let sigma = (expect * (1.0 - 1.0 / 20.0)).sqrt();
    for (b, &c) in bins.iter().enumerate() {
        assert!((c as f64 - expect).abs() < 5.0 * sigma, "bin {b}: {c} samples, expected {expect:.0}: {bins:?}");
    }
}
