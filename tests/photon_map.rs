//! Photon-mapping claims: energy conservation of the maps, no light through thin walls, the ball
//! lens focus, unbiased caustic targeting, and convergence to the path-traced reference.
mod common;
use caustica::accel::{Accel, Tracer};

use caustica::app::{plan_for, render_path, render_photon_map};
use caustica::color::Rgb;
use caustica::integrator::photon_map::{build_maps, MapRequest, PhotonMaps};
use caustica::math::Ray;
use caustica::metrics::{compare_masked, light_free_pixels};
use caustica::photon::kdtree::KnnResult;
use caustica::photon::trace::{CAUSTIC, DIRECT, INDIRECT};
use caustica::scene::Scene;
use glam::Vec3;

fn maps(scene: &Scene, accel: &Accel, want: [u64; 3], targeted: bool) -> PhotonMaps {
    build_maps(scene, accel, &MapRequest { want, targeted, targets: None }, true).unwrap()
}

#[test]
fn closed_box_maps_hold_the_light_power_and_its_interreflections() {
    let a = 0.5f32;
    let text = format!(
        "[camera]\norigin = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, -1.0]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [{a}, {a}, {a}] }}\n\
         [[lights]]\ntype = \"point\"\nposition = [0.1, 0.2, 0.3]\npower = [20.0, 20.0, 20.0]\n\
         [render.photons]\nmax_bounces = 1000\n{}",
        common::inward_box(-1.0, 1.0, "wall", None)
    );
    let scene = common::scene(&text);
    let accel = Accel::new(&scene).unwrap();
    let m = maps(&scene, &accel, [100_000, 200_000, 0], false);
    let direct = m.maps[DIRECT].as_ref().unwrap().total_power();
    let indirect = m.maps[INDIRECT].as_ref().unwrap().total_power();
    // Every photon lands on a wall once (direct), then a fraction a keeps bouncing: a + a² + … = a/(1−a).
    assert!((direct.x - 20.0).abs() < 0.01 * 20.0, "direct map holds {direct}");
    let expect = 20.0 * a / (1.0 - a);
    assert!((indirect.x - expect).abs() < 0.02 * expect, "indirect map holds {indirect}, expected {expect}");
    // What the walls absorb, (1 − a)·(all arriving power), is what the light emitted.
    assert!(((1.0 - a) * (direct.x + indirect.x) - 20.0).abs() < 0.02 * 20.0);
}

#[test]
fn no_light_leaks_through_a_thin_wall() {
    // Room A (x < 0) holds the light and a mirror ball; room B (x > 0) is sealed from it by a
    // zero-thickness wall. Every map, gathered on the wall's dark face (corners included), reads zero;
    // the same points seen from the lit face are bright.
    let text = format!(
        "[camera]\norigin = [0.9, 0.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }}\nchrome = {{ type = \"mirror\" }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [0.0, -1.0, -1.0]\nedge_u = [0.0, 2.0, 0.0]\nedge_v = [0.0, 0.0, 2.0]\nmaterial = \"wall\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-0.5, -0.6, 0.3]\nradius = 0.3\nmaterial = \"chrome\"\n\
         [[lights]]\ntype = \"point\"\nposition = [-0.1, 0.2, 0.0]\npower = [50.0, 50.0, 50.0]\n{}",
        common::inward_box(-1.0, 1.0, "wall", None)
    );
    let scene = common::scene(&text);
    let accel = Accel::new(&scene).unwrap();
    let m = maps(&scene, &accel, [100_000, 100_000, 100_000], true);
    let mut res = KnnResult::new();
    let g = caustica::photon::estimate::Gather { k: 100, max_r2: 0.09, cone_k: 1.1 };
    let (mut dark, mut bright) = (0usize, 0usize);
    for (mi, map) in m.maps.iter().enumerate() {
        let map = map.as_ref().unwrap();
        assert!(map.len() > 10_000, "map {mi} has {} photons", map.len());
        for j in 0..=20 {
            for k in 0..=20 {
                let p = Vec3::new(0.0, -1.0 + j as f32 * 0.1, -1.0 + k as f32 * 0.1);
                let b = map.radiance(p, Vec3::X, Vec3::X, Rgb::splat(0.7), g, &mut res);
                dark += (b.max_element() > 0.0) as usize;
                let a = map.radiance(p, Vec3::X, -Vec3::X, Rgb::splat(0.7), g, &mut res);
                bright += (a.max_element() > 0.0) as usize;
            }
        }
    }
    assert_eq!(dark, 0, "{dark} points on the dark face received light");
    // Direct and indirect light reach the whole lit face; the mirror ball's caustic only part of it.
    assert!(bright > 2 * 441, "only {bright} of 3 × 441 points on the lit face are lit");
}

/// Caustic irradiance (up to a constant) on the sphere's axis, on a floor at `depth` below the centre.
fn axis_caustic(depth: f32, n: f32, r: f32) -> f32 {
    let text = format!(
        "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nglass = {{ type = \"dielectric\", ior = {n} }}\nfloor = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = {r}\nmaterial = \"glass\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, -{depth}, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 1000.0, 0.0]\npower = [1.0e7, 1.0e7, 1.0e7]\n"
    );
    let scene = common::scene(&text);
    let accel = Accel::new(&scene).unwrap();
    let m = maps(&scene, &accel, [0, 0, 200_000], true);
    let map = m.maps[CAUSTIC].as_ref().unwrap();
    let mut res = KnnResult::new();
    let g = caustica::photon::estimate::Gather { k: 400, max_r2: f32::INFINITY, cone_k: 0.0 };
    map.radiance(Vec3::new(0.0, -depth, 0.0), Vec3::Y, Vec3::Y, Rgb::ONE, g, &mut res).x
}

#[test]
fn ball_lens_focuses_near_the_paraxial_focus() {
    let (n, r) = (1.5f32, 0.5f32);
    let focus = r * n / (2.0 * (n - 1.0)); // from the centre: 1.5 R
                                           // Paraxial rays, traced exactly: they cross the axis at the paraxial focus.
    let scene = common::scene(&format!(
        "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n[materials]\nglass = {{ type = \"dielectric\", ior = {n} }}\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = {r}\nmaterial = \"glass\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 10.0, 0.0]\npower = [1.0, 1.0, 1.0]\n"
    ));
    let accel = Accel::new(&scene).unwrap();
    let glass = &scene.materials[0];
    let h = 0.01 * r;
    let mut ray = Ray::new(Vec3::new(h, 2.0, 0.0), -Vec3::Y);
    for _ in 0..2 {
        let hit = accel.intersect(&ray).unwrap();
        let si = scene.surface(&ray, hit.shape, hit.prim, hit.u, hit.v, hit.t);
        // uc = 1: always refract (Fresnel reflection is not the path being checked).
        let s = glass.sample(-ray.d, si.ns, [0.0, 0.0], 0.999_999, false).unwrap();
        assert!(s.transmitted);
        ray = si.spawn(s.wi);
    }
    let crossing = ray.o.y - ray.o.x * ray.d.y / ray.d.x;
    assert!((-crossing - focus).abs() < 0.01 * focus, "paraxial crossing at {}, focus {focus}", -crossing);
    // The photon-map caustic on the axis peaks near there (spherical aberration pulls the peak in a little).
    let depths: Vec<f32> = (0..12).map(|i| 1.05 * r + i as f32 * 0.1 * r).collect();
    let vals: Vec<f32> = depths.iter().map(|&d| axis_caustic(d, n, r)).collect();
    let (best, _) = vals.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
    let peak = depths[best];
    eprintln!("caustic on axis by depth: {:?}", depths.iter().zip(&vals).collect::<Vec<_>>());
    assert!((peak - focus).abs() <= 0.2 * focus, "brightest at {peak}, paraxial focus {focus}");
    assert!(vals[best] > 5.0 * vals[0], "no focusing: {vals:?}");
}

/// Total power in the caustic map (an unbiased estimate of the caustic flux on diffuse surfaces) and
/// the photons shot. `shots` = Some(n): uniform emission with exactly n photons shot (equal work).
fn caustic_flux(want: u64, shots: Option<u64>, seed: u64) -> (f64, u64) {
    let mut s = common::scene(
        &std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glass.toml"))
            .unwrap(),
    );
    s.render.seed = seed;
    let accel = Accel::new(&s).unwrap();
    let m = match shots {
        None => maps(&s, &accel, [0, 0, want], true),
        Some(n) => {
            s.render.photons.max_shots_factor = 1;
            maps(&s, &accel, [0, 0, n], false)
        }
    };
    let map = m.maps[CAUSTIC].as_ref().unwrap();
    (map.total_power().x as f64, map.n_emitted)
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt())
}

#[test]
fn targeted_caustics_match_uniform_emission_with_less_noise() {
    let runs = 8;
    let targeted: Vec<(f64, u64)> = (0..runs).map(|i| caustic_flux(20_000, None, 10 + i)).collect();
    let shots = targeted[0].1;
    let uniform: Vec<f64> = (0..runs).map(|i| caustic_flux(0, Some(shots), 100 + i).0).collect();
    let (mt, st) = mean_std(&targeted.iter().map(|t| t.0).collect::<Vec<_>>());
    let (mu, su) = mean_std(&uniform);
    // Uniform emission at 16× the work: the expectation both must share.
    let (reference, _) = caustic_flux(0, Some(16 * shots), 7);
    eprintln!("{shots} shots: targeted {mt:.5} ± {st:.5}, uniform {mu:.5} ± {su:.5}, uniform×16 {reference:.5}");
    let sigma = (st * st / runs as f64 + su * su / 16.0).sqrt();
    assert!((mt - reference).abs() < 4.0 * sigma, "targeted mean {mt} vs uniform {reference} (σ {sigma})");
    assert!(st < 0.5 * su, "targeted spread {st} vs uniform {su} at equal shots");
}

#[test]
fn photon_mapping_converges_to_the_path_traced_reference() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
    let base = ["camera.resolution=[40, 40]", "render.pm_spp=64", "render.direct_light=\"shadow_rays\""];
    let (reference, keep) = {
        let s = caustica::scene::load_scene_with(&p, &base.map(String::from)).unwrap();
        let a = Accel::new(&s).unwrap();
        (render_path(&s, &a, 4096, true).image, light_free_pixels(&s, &a, 8))
    };
    let mut errors = Vec::new();
    for photons in [5_000u64, 20_000, 80_000, 320_000] {
        let mut sets: Vec<String> = base.map(String::from).to_vec();
        sets.push(format!("render.photons.indirect={photons}"));
        let s = caustica::scene::load_scene_with(&p, &sets).unwrap();
        let a = Accel::new(&s).unwrap();
        let plan = plan_for(&s, &a);
        let m = build_maps(
            &s,
            &a,
            &MapRequest { want: plan.photons, targeted: true, targets: Some(plan.caustic_targets.clone()) },
            true,
        )
        .unwrap();
        let img = render_photon_map(&s, &a, &m, &plan, None, true).image;
        errors.push(compare_masked(&img, &reference, &keep).unwrap().rmse);
    }
    eprintln!("RMSE against the path-traced reference by indirect photons: {errors:?}");
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "RMSE does not fall: {errors:?}");
    // The box's mean radiance is about 0.3; the remaining error is mostly the eye pass's own
    // shadow-ray noise (64 samples per pixel against the reference's 4096).
    assert!(errors[3] < 0.04, "final RMSE {} too large", errors[3]);
}
