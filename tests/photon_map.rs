//! Photon-mapping claims: energy conservation of the maps, no light through thin walls, the ball
//! lens focus, unbiased caustic targeting, and convergence to the path-traced reference.
mod common;
use caustica::accel::{Accel, Tracer};
use caustica::scene::material::DiffuseLobe;

use caustica::color::Rgb;
use caustica::integrator::photon_map::{build_maps, MapRequest, PhotonMaps};
use caustica::math::Ray;
use caustica::metrics::compare_masked;
use caustica::photon::kdtree::KnnResult;
use caustica::photon::trace::{CAUSTIC, DIRECT, INDIRECT};
use caustica::pipeline::{plan_for, render_path, render_photon_map};
use caustica::scene::{Scene, TransportMode};
use glam::Vec3;

fn maps(scene: &Scene, accel: &Accel, want: [u64; 3], targeted: bool) -> PhotonMaps {
    build_maps(scene, accel, &MapRequest { want, targeted, targets: None, ..Default::default() }, true).unwrap()
}

#[test]
fn closed_box_maps_hold_the_light_power_and_its_interreflections() {
    let a = 0.5f32;
    let text = format!(
        "[camera]\norigin = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, -1.0]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [{a}, {a}, {a}] }}\n\
         [[lights]]\ntype = \"point\"\nposition = [0.1, 0.2, 0.3]\npower = [20.0, 20.0, 20.0]\n\
         [render]\nmax_depth = 1000\n{}",
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
                let b = map
                    .radiance(
                        &common::surface_at(p, Vec3::X),
                        Vec3::X,
                        DiffuseLobe::lambert(Rgb::splat(0.7)),
                        g,
                        u32::MAX,
                        &mut res,
                    )
                    .0;
                dark += (b.max_element() > 0.0) as usize;
                let a = map
                    .radiance(
                        &common::surface_at(p, Vec3::X),
                        -Vec3::X,
                        DiffuseLobe::lambert(Rgb::splat(0.7)),
                        g,
                        u32::MAX,
                        &mut res,
                    )
                    .0;
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
    map.radiance(
        &common::surface_at(Vec3::new(0.0, -depth, 0.0), Vec3::Y),
        Vec3::Y,
        DiffuseLobe::lambert(Rgb::ONE),
        g,
        u32::MAX,
        &mut res,
    )
    .0
    .x
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
        let s = glass.bsdf.sample(-ray.d, si.ns, [0.0, 0.0], 0.999_999, TransportMode::Importance).unwrap();
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

/// Total power in `s`'s caustic map (an unbiased estimate of the caustic flux on diffuse surfaces), the
/// photons shot and the photons stored. `shots` = Some(n): uniform emission with exactly n photons shot
/// (equal work); None: aimed emission until `want` are stored.
fn caustic_of(mut s: Scene, want: u64, shots: Option<u64>, seed: u64) -> (f64, u64, u64) {
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
    (map.total_power().x as f64, map.n_emitted, map.len() as u64)
}

/// The glass box's caustic flux and photons shot (see `caustic_of`).
fn caustic_flux(want: u64, shots: Option<u64>, seed: u64) -> (f64, u64) {
    let s = common::scene(
        &std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glass.toml"))
            .unwrap(),
    );
    let (flux, shot, _) = caustic_of(s, want, shots, seed);
    (flux, shot)
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

/// A glass block under a small area light, half of its top in the shadow of a board: the light sees
/// a quarter of the block's area (the top; the sides and bottom face away), less the shadow, which cuts
/// both top triangles, so the probes misjudge them. Caustic flux and photons stored per shot.
fn shaded_block_caustic(want: u64, shots: Option<u64>, seed: u64) -> (f64, u64, u64) {
    let s = common::scene(
        "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [16, 16]\n\
         [materials]\nglass = { type = \"dielectric\", ior = 1.5 }\nwhite = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-0.5, 0.3, -0.5]\nmax = [0.5, 0.8, 0.5]\nmaterial = \"glass\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.6, 1.5, -0.6]\nedge_u = [0.0, 0.0, 1.2]\nedge_v = [0.6, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.2, 3.0, -0.2]\nedge_u = [0.4, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.4]\n\
         material = \"white\"\nemission = [10.0, 10.0, 10.0]\n",
    );
    caustic_of(s, want, shots, seed)
}

/// Aiming only where the light arrives (probed once per triangle, with a share of the shots still by
/// area) keeps the caustic flux of uniform emission, and most aimed photons now arrive: aimed by area
/// alone, three in four hit the block elsewhere first (or the board) and were dropped.
#[test]
fn aimed_photons_go_where_the_light_arrives_and_keep_the_caustic_flux() {
    let runs = 8;
    let aimed: Vec<(f64, u64, u64)> = (0..runs).map(|i| shaded_block_caustic(20_000, None, 10 + i)).collect();
    let shots = aimed[0].1;
    let (ma, sa) = mean_std(&aimed.iter().map(|t| t.0).collect::<Vec<_>>());
    let (reference, _, _) = shaded_block_caustic(0, Some(40 * shots), 7);
    let uniform: Vec<f64> = (0..4).map(|i| shaded_block_caustic(0, Some(10 * shots), 100 + i).0).collect();
    let (_, su) = mean_std(&uniform);
    // The 40× run's spread is half that of the 10× runs.
    let sigma = (sa * sa / runs as f64 + su * su / 4.0).sqrt();
    let stored_per_shot = aimed.iter().map(|t| t.2 as f64 / t.1 as f64).sum::<f64>() / runs as f64;
    eprintln!(
        "aimed {ma:.5} ± {sa:.5} ({shots} shots, {stored_per_shot:.3} stored per shot), uniform×40 {reference:.5}"
    );
    assert!((ma - reference).abs() < 4.0 * sigma, "aimed mean {ma} vs uniform {reference} (σ {sigma})");
    assert!(stored_per_shot > 0.45, "{stored_per_shot:.3} caustic photons stored per aimed shot");
}

/// A spot (cutoff 30°, beam 20°) above a glass ball that subtends 14.5° from it, its axis tilted 25°
/// from the ball's centre: part of the ball lies outside the cone, so photons aimed at it must carry the spot's falloff towards where
/// they were aimed (and none outside its cone), or the caustic flux is several times too high.
fn spot_caustic(want: u64, shots: Option<u64>, seed: u64) -> (f64, u64, u64) {
    let s = common::scene(
        "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [16, 16]\n\
         [materials]\nglass = { type = \"dielectric\", ior = 1.5 }\nwhite = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.7, 0.0]\nradius = 0.4\nmaterial = \"glass\"\n\
         [[lights]]\ntype = \"spot\"\nposition = [0.0, 2.3, 0.0]\ntarget = [1.0725, 0.0, 0.0]\n\
         intensity = [30.0, 30.0, 30.0]\ncutoff_angle = 30.0\nbeam_width = 20.0\n",
    );
    caustic_of(s, want, shots, seed)
}

#[test]
fn photons_aimed_at_glass_under_a_spot_keep_the_caustic_flux() {
    let runs = 8;
    let aimed: Vec<(f64, u64, u64)> = (0..runs).map(|i| spot_caustic(20_000, None, 10 + i)).collect();
    let shots = aimed[0].1;
    let (ma, sa) = mean_std(&aimed.iter().map(|t| t.0).collect::<Vec<_>>());
    let uniform: Vec<f64> = (0..4).map(|i| spot_caustic(0, Some(shots), 100 + i).0).collect();
    let (mu, su) = mean_std(&uniform);
    let sigma = (sa * sa / runs as f64 + su * su / 4.0).sqrt();
    eprintln!("spot: aimed {ma:.5} ± {sa:.5} ({shots} shots), uniform {mu:.5} ± {su:.5}");
    assert!((ma - mu).abs() < 4.0 * sigma + 1e-3 * mu, "aimed mean {ma} vs uniform {mu} (σ {sigma})");
}

/// A glass ball over a wide rough plastic floor (4 × 4, the ball of radius 0.3) under a point light.
/// Both are caustic targets: the floor's coat reflects light that can make a caustic, but most of what
/// arrives there the base scatters, which a caustic pass does not keep. Aimed by area and by what the
/// light sees, the floor took ~96% of the shots and fixed PM's caustic pass stored 1.1% of its shots
/// (220,903 photons of 400,000 in its whole 20M budget); now a pilot measures each target's yield. And
/// the ball, drawn uniformly over its surface, had three shots in five land on its far side, which the
/// light reaches only through its near side (dropped); now it is drawn where the light sees it.
fn plastic_floor_caustic(want: u64, shots: Option<u64>, seed: u64) -> (f64, u64, u64) {
    let s = common::scene(
        "[camera]\norigin = [0.0, 2.5, 2.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [16, 16]\n\
         [materials]\nglass = { type = \"dielectric\", ior = 1.5 }\n\
         coat = { type = \"plastic\", reflectance = [0.3, 0.3, 0.3], ior = 1.5, roughness = 0.2 }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"coat\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.8, 0.0]\nradius = 0.3\nmaterial = \"glass\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\npower = [30.0, 30.0, 30.0]\n",
    );
    caustic_of(s, want, shots, seed)
}

/// Caustic photons are aimed at each target in proportion to its yield, the share of the photons aimed
/// at it that a caustic pass stores (measured by a pilot): the caustic flux stays uniform emission's,
/// and the shots go where caustics come from (0.011 stored per shot at first, 0.29 with the pilot, 0.80
/// with the ball drawn where the light sees it).
#[test]
fn a_plastic_floor_does_not_take_the_glass_balls_caustic_photons() {
    let runs = 6;
    let aimed: Vec<(f64, u64, u64)> = (0..runs).map(|i| plastic_floor_caustic(10_000, None, 10 + i)).collect();
    let shots = aimed[0].1;
    let (ma, sa) = mean_std(&aimed.iter().map(|t| t.0).collect::<Vec<_>>());
    let uniform: Vec<f64> = (0..4).map(|i| plastic_floor_caustic(0, Some(16 * shots), 100 + i).0).collect();
    let (mu, su) = mean_std(&uniform);
    let sigma = (sa * sa / runs as f64 + su * su / 4.0).sqrt();
    let stored_per_shot = aimed.iter().map(|t| t.2 as f64 / t.1 as f64).sum::<f64>() / runs as f64;
    eprintln!(
        "plastic floor: aimed {ma:.5} ± {sa:.5} ({shots} shots, {stored_per_shot:.4} stored per shot), \
         uniform×16 {mu:.5} ± {su:.5}"
    );
    assert!((ma - mu).abs() < 4.0 * sigma, "aimed mean {ma} vs uniform {mu} (σ {sigma})");
    assert!(stored_per_shot > 0.6, "{stored_per_shot:.4} caustic photons stored per aimed shot");
}

/// A flat water surface (a 256 × 256 heightfield, 131,072 triangles: one probe each) in full view of a
/// small sphere light:
/// every triangle is lit, so aiming where the light arrives must spread the shots by area as plain
/// aiming does, and the photons through the flat surface carry nearly equal power. (Probes from
/// random points of the light's surface once marked half the triangles unseen, the far side of the
/// sphere facing away: their photons were 19 times heavier than their neighbours'.)
#[test]
fn a_fully_lit_surface_is_aimed_at_evenly() {
    let s = common::scene(
        "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [16, 16]\n\
         [materials]\nwater = { type = \"dielectric\", ior = 1.33 }\nwhite = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"heightfield\"\nsize = [2.0, 2.0]\nresolution = [256, 256]\nheight = 0.5\nmaterial = \"water\"\n\
         [[lights]]\ntype = \"sphere\"\ncenter = [0.2, 3.0, 0.1]\nradius = 0.05\npower = [10.0, 10.0, 10.0]\n",
    );
    let accel = Accel::new(&s).unwrap();
    let m = maps(&s, &accel, [0, 0, 20_000], true);
    let map = m.maps[CAUSTIC].as_ref().unwrap();
    let mut powers: Vec<f32> = (0..map.len() as u32).map(|i| map.phi(i).x).collect();
    powers.sort_by(f32::total_cmp);
    // The 99th percentile against the median: cos θ, distance and Fresnel transmission vary over the
    // surface, and Russian roulette raises a few (2.2 measured on 2048 triangles).
    let ratio = powers[powers.len() * 99 / 100] / powers[powers.len() / 2];
    eprintln!("fully lit water: {} caustic photons, 99th percentile / median power {ratio:.3}", powers.len());
    assert!(ratio < 4.0, "uneven aiming: 99th percentile photon {ratio} times the median");
}

/// A mirror made of a single triangle (an OBJ with one face) over a floor, under a point light: aimed
/// photons reach it and carry the caustic flux of uniform emission.
#[test]
fn a_one_triangle_mirror_is_aimed_at_like_any_mesh() {
    let dir = std::env::temp_dir().join(format!("caustica-tri-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("mirror.obj");
    // Upright in the plane x = −1, facing +x: it throws the light back down onto the floor.
    std::fs::write(&obj, "v -1 0.2 -0.6\nv -1 0.2 0.6\nv -1 1.2 0\nf 1 3 2\n").unwrap();
    let text = format!(
        "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [16, 16]\n\
         [materials]\nmirror = {{ type = \"conductor\", preset = \"Ag\", roughness = 0.0 }}\n\
         white = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 3.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"{}\"\nmaterial = \"mirror\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.5, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]\n",
        obj.display()
    );
    let runs = 6;
    let aimed: Vec<(f64, u64, u64)> =
        (0..runs).map(|i| caustic_of(common::scene(&text), 5_000, None, 10 + i)).collect();
    let shots = aimed[0].1;
    let (ma, sa) = mean_std(&aimed.iter().map(|t| t.0).collect::<Vec<_>>());
    let uniform: Vec<f64> = (0..4).map(|i| caustic_of(common::scene(&text), 0, Some(50 * shots), 100 + i).0).collect();
    let (mu, su) = mean_std(&uniform);
    std::fs::remove_dir_all(&dir).ok();
    let sigma = (sa * sa / runs as f64 + su * su / 4.0).sqrt();
    eprintln!("one-triangle mirror: aimed {ma:.5} ± {sa:.5} ({shots} shots), uniform ×50 {mu:.5} ± {su:.5}");
    assert!(ma > 0.0 && (ma - mu).abs() < 4.0 * sigma, "aimed {ma} vs uniform {mu} (σ {sigma})");
}

#[test]
fn indirect_photon_map_converges_to_the_path_traced_indirect_light() {
    // The indirect part alone: PT(all bounces) − PT(max_depth = 1) with the same seeds is exactly the
    // path tracer's light after two or more bounces (the first hit's NEE and MIS draws are the same in
    // both); PM's is the indirect map's estimate at the first diffuse hit (`map:indirect`). Shadow-ray
    // direct light, which dominates the image, cannot hide an error here.
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
    let base = ["camera.resolution=[40, 40]", "render.pm_spp=16"];
    let reference = {
        let mut s = caustica::scene::load_scene_with(&p, &base.map(String::from)).unwrap();
        let a = Accel::new(&s).unwrap();
        let full = render_path(&s, &a, 4096, true).image;
        s.render.max_depth = 1;
        let direct = render_path(&s, &a, 4096, true).image;
        let mut ind = full.clone();
        for (o, d) in ind.pixels.iter_mut().zip(&direct.pixels) {
            *o -= *d;
        }
        ind
    };
    let keep = vec![true; reference.pixels.len()];
    let mut errors = Vec::new();
    let mut ratio = 0.0;
    for photons in [5_000u64, 20_000, 80_000, 320_000] {
        let mut sets: Vec<String> = base.map(String::from).to_vec();
        sets.push(format!("render.photons.indirect={photons}"));
        let s = caustica::scene::load_scene_with(&p, &sets).unwrap();
        let a = Accel::new(&s).unwrap();
        let plan = plan_for(&s, &a);
        let m = build_maps(
            &s,
            &a,
            &MapRequest { want: [0, photons, 0], targeted: false, targets: None, ..Default::default() },
            true,
        )
        .unwrap();
        let img = render_photon_map(&s, &a, &m, &plan, Some(INDIRECT), true).image;
        let c = compare_masked(&img, &reference, &keep).unwrap();
        errors.push(c.rmse);
        ratio = c.mean_ratio;
    }
    let mean = reference.pixels.iter().map(|p| p.x as f64).sum::<f64>() / reference.pixels.len() as f64;
    eprintln!("indirect light (mean {mean:.4}): RMSE by indirect photons {errors:?}, final mean ratio {ratio:.4}");
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "RMSE does not fall: {errors:?}");
    // PM's own bias here is the boundary bias at the box's edges (gather discs reaching past a wall's
    // edge find no photons there): 0.963 at 320k photons. A 10% error in the indirect estimate fails.
    assert!((ratio - 1.0).abs() < 0.05, "indirect map's mean is {ratio} of the path tracer's");
    assert!(errors[3] < 0.15 * mean, "final RMSE {} against a mean of {mean}", errors[3]);
}

#[test]
fn a_point_light_at_the_origin_fills_the_direct_map_with_its_power() {
    // Spawn offsets once turned a photon leaving (0, 0, 0) into NaN: it counted as emitted, was lost.
    let text = format!(
        "[camera]\norigin = [0.0, 0.0, 0.5]\ntarget = [0.0, 0.0, -1.0]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\npower = [20.0, 20.0, 20.0]\n{}",
        common::inward_box(-1.0, 1.0, "wall", None)
    );
    let scene = common::scene(&text);
    let accel = Accel::new(&scene).unwrap();
    let m = maps(&scene, &accel, [100_000, 0, 0], false);
    let direct = m.maps[DIRECT].as_ref().unwrap().total_power();
    assert!((direct.x - 20.0).abs() < 0.01 * 20.0, "direct map holds {direct} of 20 W");
}

#[test]
fn photons_follow_the_path_tracers_depth_through_a_long_mirror_tube() {
    // A point light near the top of a narrow tube of perfect mirrors whose floor absorbs: every photon
    // ends on the floor, most after dozens of reflections. With render.max_depth = 1000 (the depth the
    // path tracer would use) the direct and caustic maps together must hold all of Φ but the few
    // photons so near horizontal that they need more than 1000 reflections (≈3%); photons once stopped after 16 bounces whatever
    // max_depth said. Perfect mirrors keep the throughput at 1, so Russian roulette never cuts a chain.
    let (w, h) = (0.1f32, 4.0f32);
    let mut text = String::from(
        "[camera]\norigin = [0.0, 2.0, 0.05]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nchrome = { type = \"mirror\" }\nfloor = { type = \"diffuse\", reflectance = [0.0, 0.0, 0.0] }\n\
         [render]\nmax_depth = 1000\n\
         [[lights]]\ntype = \"point\"\nposition = [0.013, 3.9, 0.021]\npower = [10.0, 10.0, 10.0]\n",
    );
    let quads = [
        ([-w, 0.0, -w], [0.0, 0.0, 2.0 * w], [2.0 * w, 0.0, 0.0], "floor"),
        ([-w, h, -w], [2.0 * w, 0.0, 0.0], [0.0, 0.0, 2.0 * w], "chrome"),
        ([-w, 0.0, -w], [2.0 * w, 0.0, 0.0], [0.0, h, 0.0], "chrome"),
        ([-w, 0.0, w], [0.0, h, 0.0], [2.0 * w, 0.0, 0.0], "chrome"),
        ([-w, 0.0, -w], [0.0, h, 0.0], [0.0, 0.0, 2.0 * w], "chrome"),
        ([w, 0.0, -w], [0.0, 0.0, 2.0 * w], [0.0, h, 0.0], "chrome"),
    ];
    for (c, u, v, m) in quads {
        text += &format!(
            "[[shapes]]\ntype = \"quad\"\ncorner = {c:?}\nedge_u = {u:?}\nedge_v = {v:?}\nmaterial = \"{m}\"\n"
        );
    }
    let scene = common::scene(&text);
    let accel = Accel::new(&scene).unwrap();
    let m = maps(&scene, &accel, [20_000, 0, 200_000], false);
    let direct = m.maps[DIRECT].as_ref().unwrap().total_power().x;
    let caustic = m.maps[CAUSTIC].as_ref().unwrap().total_power().x;
    eprintln!("floor receives {direct:.4} W directly and {caustic:.4} W via the mirrors (of 10 W)");
    let got = direct + caustic;
    assert!(got > 0.96 * 10.0 && got < 1.005 * 10.0, "floor receives {got} of 10 W");
}

/// n × n photons of total flux `phi` on a jittered grid over the 2 × 2 square of the plane y = 0
/// (random stream `seed`), landed on its side `side`, each travelling along `wi(a, b)` of its jitter.
fn photons_on_square(
    n: usize,
    phi: f32,
    seed: u64,
    side: Vec3,
    wi: impl Fn(f32, f32) -> Vec3,
) -> caustica::photon::estimate::PhotonMap {
    use caustica::photon::photon::Photon;
    let mut rng = caustica::math::Rng::new(seed, 0, 0);
    let mut photons = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let [a, b] = rng.next_2d();
            let p = Vec3::new(-1.0 + 2.0 * (i as f32 + a) / n as f32, 0.0, -1.0 + 2.0 * (j as f32 + b) / n as f32);
            photons.push(Photon { p, wi: wi(a, b), phi: Rgb::splat(phi / (n * n) as f32), n: side });
        }
    }
    let m = caustica::photon::trace::MapPhotons::from_photons(&photons, 1);
    caustica::photon::estimate::PhotonMap::build(m).unwrap()
}

#[test]
fn uniform_photon_density_gives_the_lambertian_radiance_with_and_without_the_cone_filter() {
    // Photons on a jittered grid over a 2×2 plane, total flux Φ: irradiance E = Φ/4, L = ρE/π.
    use caustica::photon::estimate::Gather;
    let (n, phi, rho) = (1000usize, 8.0f32, 0.6f32);
    let map =
        photons_on_square(n, phi, 21, Vec3::Y, |a, b| Vec3::new(0.3 * (a - 0.5), -1.0, 0.3 * (b - 0.5)).normalize());
    let expect = rho * (phi / 4.0) / std::f32::consts::PI;
    let mut res = KnnResult::new();
    for cone_k in [0.0f32, 1.1, 2.0] {
        let g = Gather { k: 800, max_r2: f32::INFINITY, cone_k };
        let mut mean = 0.0f64;
        for q in 0..40 {
            let x = Vec3::new(-0.6 + 0.03 * q as f32, 0.0, 0.5 - 0.025 * q as f32);
            mean += map
                .radiance(
                    &common::surface_at(x, Vec3::Y),
                    Vec3::Y,
                    DiffuseLobe::lambert(Rgb::splat(rho)),
                    g,
                    u32::MAX,
                    &mut res,
                )
                .0
                .x as f64
                / 40.0;
        }
        eprintln!("cone_k {cone_k}: L = {mean:.5}, ρE/π = {expect:.5}");
        assert!((mean / expect as f64 - 1.0).abs() < 0.01, "cone_k {cone_k}: L = {mean}, expected {expect}");
    }
}

/// The glossy photons' estimate (`PhotonMap::glossy_radiance`): photons of flux Φ spread evenly over a
/// 2 × 2 plane, all arriving from one direction l, give the radiance f(wo, l)·Φ/A through the glossy
/// BSDF f for any viewing direction wo (photons carry flux per unit of geometric area; the cosine is
/// theirs already), with the k-NN reach (with and without the cone filter) and with a fixed radius. A
/// rough metal sees nothing of photons that arrived from below; a rough glass lets them through, by
/// its transmission lobe. Holds the normalisation (π r², the cone's), the direction a photon is read
/// along (as its record holds it) and the side tests to 1.5%.
#[test]
fn uniform_photon_density_gives_the_glossy_radiance_for_each_direction() {
    use caustica::photon::estimate::{Gather, Reach};
    use caustica::photon::photon::Photon;
    use caustica::scene::material::{Fresnel, Material, Microfacet};
    let (n, phi) = (700usize, 8.0f32);
    let map_from = |l: Vec3| photons_on_square(n, phi, 22, if l.y > 0.0 { Vec3::Y } else { -Vec3::Y }, |_, _| -l);
    let metal = Material::conductor(Fresnel::Schlick(Rgb::new(0.9, 0.7, 0.4)), 0.3, Microfacet::Ggx);
    let glass = Material::Dielectric {
        ior: 1.5,
        tint: Rgb::ONE,
        alpha: 0.3,
        alpha_v: 0.3,
        tangent: Vec3::ZERO,
        distribution: Microfacet::Ggx,
    };
    let above = Vec3::new(0.5, 0.8, -0.2).normalize();
    let below = Vec3::new(0.25, -0.93, -0.2).normalize();
    let reaches = [
        Reach::Knn(Gather { k: 600, max_r2: f32::INFINITY, cone_k: 0.0 }),
        Reach::Knn(Gather { k: 600, max_r2: f32::INFINITY, cone_k: 1.1 }),
        Reach::Radius(0.03),
    ];
    let mut res = KnnResult::new();
    let mut failed = Vec::new();
    // A smooth-shaded surface's shading normal, 12° off the geometric one: each photon counts
    // f(wo, l; ns)·|l·ns| / |l·ng| (the path tracer integrates the cosine about the shading normal).
    let tilted = Vec3::new(0.2, 1.0, 0.05).normalize();
    let cases = [
        ("metal", metal, above, Vec3::Y),
        ("metal from below", metal, below, Vec3::Y),
        ("glass from below", glass, below, Vec3::Y),
        ("metal, shading normal tilted", metal, above, tilted),
    ];
    for (name, mat, l, ns) in cases {
        let map = map_from(l);
        for wo in [Vec3::new(-0.4, 0.85, 0.3).normalize(), Vec3::new(0.1, 0.6, 0.8).normalize()] {
            // The direction as the photon's record holds it (8 bits per octahedral coordinate: near a
            // sharp transmission peak a degree's rounding moves f by several percent).
            let held = -Photon { p: Vec3::ZERO, wi: -l, phi: Rgb::ONE, n: Vec3::Y }.payload().wi();
            let f = mat.eval(wo, held, ns, TransportMode::Radiance) * (held.dot(ns).abs() / held.y.abs());
            let expect = f.y as f64 * (phi / 4.0) as f64;
            for reach in reaches {
                let mut mean = 0.0f64;
                for q in 0..40 {
                    let x = Vec3::new(-0.6 + 0.03 * q as f32, 0.0, 0.5 - 0.025 * q as f32);
                    let si = caustica::scene::SurfaceHit { ns, ..common::surface_at(x, Vec3::Y) };
                    mean += map.glossy_radiance(&si, wo, &mat, reach, u32::MAX, &mut res).0.y as f64 / 40.0;
                }
                eprintln!("{name}, wo {wo:?}, {reach:?}: L = {mean:.5}, f·Φ/A = {expect:.5}");
                let off = if expect > 0.0 { (mean / expect - 1.0).abs() > 0.015 } else { mean != 0.0 };
                if off {
                    failed.push(format!("{name}, wo {wo:?}, {reach:?}: {mean} against {expect}"));
                }
            }
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// A coarse, smooth-shaded diffuse lathe ball (8 profile points, 12 segments: shading normals differ
/// from the facets' by up to ~15°) under a point light.
fn smooth_ball() -> String {
    let profile: Vec<String> = (0..=8)
        .map(|i| {
            let t = std::f32::consts::PI * i as f32 / 8.0;
            format!("[{:.5}, {:.5}]", 0.5 * t.sin(), 0.5 - 0.5 * t.cos())
        })
        .collect();
    format!(
        "[camera]\norigin = [0.0, 0.5, 1.6]\ntarget = [0.0, 0.5, 0.0]\nfov = 40\nresolution = [48, 48]\n\
         [materials]\nwhite = {{ type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }}\n\
         [[shapes]]\ntype = \"lathe\"\nprofile = [{}]\nsegments = 12\nsmooth = true\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.9, 1.4, 1.1]\npower = [30.0, 30.0, 30.0]\n",
        profile.join(", "),
    )
}

#[test]
fn photons_see_shading_normals_as_the_path_tracer_does() {
    // A lone convex ball only receives direct light: PT (shadow rays, cosine about the shading normal)
    // and the direct photon map (flux per facet area, scaled by |wi·ns|/|wi·ng|) must agree.
    let mut s = common::scene(&smooth_ball());
    s.render.direct_light = caustica::scene::file::DirectLight::PhotonMap;
    // 64 eye samples: with 4, the eye pass alone moves this mean by ±1% from seed to seed (the
    // estimate is spiky at the silhouette's grazing facets), as much as the bound.
    s.render.pm_spp = 64;
    // Few photons per estimate and many photons: the blur bias of a faceted ball (a 3D ball around a
    // fold holds more than πr² of surface) stays well below the 1.3% the normal correction makes.
    s.render.gather.direct = 10;
    let a = Accel::new(&s).unwrap();
    let pt = render_path(&s, &a, 256, true).image;
    let plan = plan_for(&s, &a);
    let m = maps(&s, &a, [4_000_000, 0, 0], false);
    let pm = render_photon_map(&s, &a, &m, &plan, None, true).image;
    let keep = vec![true; pt.pixels.len()];
    let c = compare_masked(&pm, &pt, &keep).unwrap();
    eprintln!("smooth lathe ball, direct light from photons: PM/PT mean {:.4}", c.mean_ratio);
    assert!((c.mean_ratio - 1.0).abs() < 0.01, "PM/PT mean {}", c.mean_ratio);
}

/// A room lit mostly by one bright wall (x = +2, ρ = 0.9; the rest ρ = 0.1), its floor a mesh whose
/// shading normals lean 30° towards that wall; a shielded point light shines on the bright wall only.
fn tilted_floor_room() -> String {
    let dir = std::env::temp_dir().join(format!("caustica-fg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("tilted.obj");
    std::fs::write(
        &obj,
        "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nvn 0.5 0.8660254 0\nf 1//1 4//1 3//1\nf 1//1 3//1 2//1\n",
    )
    .unwrap();
    let walls: String = common::inward_box(-2.0, 2.0, "dark", None)
        .split("\n\n")
        .enumerate()
        .filter(|(i, _)| *i > 0)
        .map(|(i, q)| if i == 5 { q.replace("\"dark\"", "\"bright\"") } else { q.to_string() })
        .collect::<Vec<_>>()
        .join("\n\n");
    format!(
        "[camera]\norigin = [-1.5, 1.5, 1.5]\ntarget = [0.5, 0.0, 0.0]\nfov = 50\nresolution = [32, 32]\n\
         [materials]\nfloor = {{ type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }}\n\
         dark = {{ type = \"diffuse\", reflectance = [0.1, 0.1, 0.1] }}\nbright = {{ type = \"diffuse\", reflectance = [0.9, 0.9, 0.9] }}\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"{}\"\nsmooth = true\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [1.3, 0.5, -0.6]\nmax = [1.4, 2.0, 0.6]\nmaterial = \"dark\"\n\
         [[lights]]\ntype = \"point\"\nposition = [1.6, 1.2, 0.0]\npower = [40.0, 40.0, 40.0]\n{walls}",
        obj.display()
    )
}

#[test]
fn final_gather_samples_about_the_shading_normal() {
    // Indirect light on the floor comes mostly from one side, and the floor's shading normals lean
    // towards it: gathering with cosines about the facet normal instead of the shading normal (as direct
    // light and the path tracer use) weights that light wrongly.
    let mut s = common::scene(&tilted_floor_room());
    s.render.final_gather = 32;
    s.render.pm_spp = 4;
    let a = Accel::new(&s).unwrap();
    let pt = render_path(&s, &a, 1024, true).image;
    let plan = plan_for(&s, &a);
    let m = maps(&s, &a, [0, 400_000, 0], false);
    let pm = render_photon_map(&s, &a, &m, &plan, None, true).image;
    // Score the floor only: pixels whose first hit is the tilted mesh (shape 0).
    let keep: Vec<bool> = (0..pt.pixels.len())
        .map(|i| {
            let (x, y) = ((i % 32) as f32 + 0.5, (i / 32) as f32 + 0.5);
            a.intersect(&s.camera.ray(x, y)).is_some_and(|h| h.shape == 0)
        })
        .collect();
    assert!(keep.iter().filter(|k| **k).count() > 300);
    let c = compare_masked(&pm, &pt, &keep).unwrap();
    eprintln!("tilted shading normals, final gather: PM/PT mean on the floor {:.4}", c.mean_ratio);
    // Measured: 1.001 with the shading normal, 0.970 with the facet normal (2.2 at a 45° lean). Since
    // the camera streams were re-keyed (and with Sobol samples) the same maps give 0.985–0.990: the eye
    // pass's own noise on this mean is about ±1%; the radiance cache moves it by 0.001.
    assert!((c.mean_ratio - 1.0).abs() < 0.02, "PM/PT mean on the floor {}", c.mean_ratio);
}

/// The final gather's radiance cache (indirect + caustic radiance precomputed at every 4th indirect
/// photon) must change the image by much less than its own noise: on the glass box, cached and
/// uncached final gathers with the same seed differ by under a third of the RMSE between two seeds of
/// the uncached one, and their means agree within 1%.
#[test]
fn final_gather_through_the_radiance_cache_matches_full_gathers() {
    // The cache holds direct light as well (shadow rays at each cached point, or the direct map when
    // direct light comes from it), so gather rays that read it trace no shadow ray: the same seed then
    // draws different numbers after the first gather ray, and the cached render is compared with the
    // full gathers' seed-to-seed noise and mean.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glass.toml");
    for direct in ["shadow_rays", "photon_map"] {
        let load = |stride: u32, seed: u64| {
            let sets = [
                "camera.resolution=[48,48]".to_string(),
                "render.final_gather=16".to_string(),
                "render.pm_spp=2".to_string(),
                format!("render.direct_light=\"{direct}\""),
                format!("render.gather.cache_stride={stride}"),
                format!("render.seed={seed}"),
            ];
            caustica::scene::load_scene_with(&path, &sets).unwrap()
        };
        let s = load(0, 1);
        let a = Accel::new(&s).unwrap();
        let plan = plan_for(&s, &a);
        let m = build_maps(&s, &a, &MapRequest::planned(&s, &plan), true).unwrap();
        let render = |stride, seed| render_photon_map(&load(stride, seed), &a, &m, &plan, None, true).image;
        let (full1, full2, cached1) = (render(0, 1), render(0, 2), render(4, 1));
        let keep = vec![true; full1.pixels.len()];
        let noise = compare_masked(&full2, &full1, &keep).unwrap();
        let cache = compare_masked(&cached1, &full1, &keep).unwrap();
        eprintln!(
            "direct light by {direct}: cached vs full (same seed): RMSE {:.5}, mean ratio {:.4}; full, two seeds: RMSE {:.5}, mean ratio {:.4}",
            cache.rmse, cache.mean_ratio, noise.rmse, noise.mean_ratio
        );
        assert!((cache.mean_ratio - 1.0).abs() < 0.01, "{direct}: mean ratio {}", cache.mean_ratio);
        assert!(cache.rmse < noise.rmse / 3.0, "{direct}: cache error {} vs noise {}", cache.rmse, noise.rmse);
    }
}

/// Per-channel means of an image.
fn channel_means(img: &caustica::film::Image) -> [f64; 3] {
    let n = img.pixels.len() as f64;
    [0, 1, 2].map(|k| img.pixels.iter().map(|p| p[k] as f64).sum::<f64>() / n)
}

/// Rough metal reflects delta lights too. The photon-mapping eye passes follow a camera ray through
/// rough metal by sampling its BSDF, and a sampled direction never finds a point light or a distant
/// light; the light they send straight into the camera off a rough surface has to come from a light
/// sample there (next-event estimation, MIS-weighted against the BSDF samples that find area lights).
/// A rough gold floor under a point light, a spot, a sun and a small quad light, with a white ball on it: fixed
/// PM, PPM and SPPM have the path tracer's mean in every channel.
#[test]
fn photon_mappers_see_delta_lights_in_rough_metal() {
    let text = "[camera]\norigin = [0.0, 1.6, 3.0]\ntarget = [0.0, 0.0, -0.3]\nfov = 50\nresolution = [32, 24]\n\
         [materials]\ngold = { type = \"conductor\", preset = \"Au\", roughness = 0.25 }\n\
         white = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"gold\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-0.6, 0.3, -0.4]\nradius = 0.3\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.2, 1.0, -0.8]\npower = [30.0, 30.0, 30.0]\n\
         [[lights]]\ntype = \"distant\"\ndirection = [0.1, -0.5, 1.0]\nirradiance = [1.5, 1.2, 0.9]\n\
         [[lights]]\ntype = \"spot\"\nposition = [-1.2, 1.5, -1.2]\ntarget = [-0.3, 0.0, 0.2]\nintensity = [8.0, 6.0, 4.0]\ncutoff_angle = 30.0\n\
         [[lights]]\ntype = \"quad\"\ncorner = [0.6, 1.2, -1.0]\nedge_u = [0.3, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.3]\npower = [6.0, 6.0, 6.0]\n\
         [render]\nmax_depth = 6\n";
    photon_modes_match_pt("rough metal", text);
}

/// Fixed PM, PPM and SPPM (32 passes of 50,000 photons) have the path tracer's mean (2048 spp) in
/// every channel, within 3%.
fn photon_modes_match_pt(label: &str, text: &str) {
    photon_modes_match_pt_within(label, text, 0.03);
}

fn photon_modes_match_pt_within(label: &str, text: &str, tol: f64) {
    let mut s = common::scene(text);
    let a = Accel::new(&s).unwrap();
    let pt = channel_means(&render_path(&s, &a, 2048, true).image);
    let plan = plan_for(&s, &a);
    let m = build_maps(&s, &a, &MapRequest::planned(&s, &plan), true).unwrap();
    let mut got = vec![("photon_map", channel_means(&render_photon_map(&s, &a, &m, &plan, None, true).image))];
    for (name, mode) in [("ppm", caustica::scene::file::Mode::Ppm), ("sppm", caustica::scene::file::Mode::Sppm)] {
        s.render.mode = mode;
        s.render.progressive.passes = 32;
        s.render.progressive.photons_per_pass = 50_000;
        let img = caustica::pipeline::render_progressive(&s, &a, &plan, true, &[]).unwrap().output.image;
        got.push((name, channel_means(&img)));
    }
    for (name, mean) in got {
        let ratio = [0, 1, 2].map(|k| mean[k] / pt[k]);
        eprintln!("{label}, {name}: mean / PT's {ratio:.4?} (PT {pt:.4?})");
        assert!(ratio.iter().all(|r| (r - 1.0).abs() < tol), "{label}, {name}: means {mean:?} against PT's {pt:?}");
    }
}

/// Rough glass in the photon mappers: photons cross it with the adjoint BSDF and land as caustic
/// photons; camera rays go through it by sampling its BSDF, with a light sample at each crossing. A
/// rough glass ball (Beckmann, α 0.4) on a diffuse floor and a rough glass slab (GGX, α 0.3, tinted)
/// standing on its edge, under a quad light, a point light and a spot, with a point light inside a
/// second rough ball (light that crosses glass once, where an adjoint off by η² would not cancel):
/// the path tracer finds every one of these paths by next-event estimation at the glass. A point
/// light seen through rough glass is a spiky glint, heavy-tailed in few eye samples: with the ball at
/// α 0.2 and the slab at 0.1, fixed PM read 1.10 of PT's mean at 4 eye samples and PPM 0.967–0.973 at
/// 32 passes (0.985 at 256) though their expectations are right; rougher glass and 64 eye samples keep
/// this test's noise under its 3%.
#[test]
fn photon_mappers_render_rough_glass() {
    let text = "[camera]\norigin = [0.0, 1.4, 3.0]\ntarget = [0.0, 0.3, -0.2]\nfov = 50\nresolution = [32, 24]\n\
         [materials]\nwhite = { type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }\n\
         frosted = { type = \"dielectric\", ior = 1.5, roughness = 0.4, distribution = \"beckmann\" }\n\
         pane = { type = \"dielectric\", ior = 1.5, roughness = 0.3, tint = [0.9, 0.7, 0.5] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -1.5]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-0.6, 0.31, 0.0]\nradius = 0.3\nmaterial = \"frosted\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.9, 0.5, -0.6]\nradius = 0.25\nmaterial = \"frosted\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [0.1, 0.01, -0.2]\nmax = [0.5, 0.6, -0.1]\nmaterial = \"pane\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.4, 1.2, 0.6]\npower = [20.0, 20.0, 20.0]\n\
         [[lights]]\ntype = \"point\"\nposition = [0.9, 0.5, -0.6]\npower = [3.0, 3.0, 3.0]\n\
         [[lights]]\ntype = \"spot\"\nposition = [-1.2, 1.5, 0.8]\ntarget = [-0.6, 0.3, 0.0]\nintensity = [6.0, 5.0, 4.0]\ncutoff_angle = 25.0\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.3, 1.8, -0.8]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.4]\npower = [8.0, 8.0, 8.0]\n\
         [render]\nmax_depth = 8\npm_spp = 64\n";
    photon_modes_match_pt("rough glass", text);
}

/// Plastic in the photon mappers: photons are stored on its base and go on by either lobe (its coat a
/// mirror, its base diffuse); a camera ray that meets it ends there by the base's share (gathering
/// photons, each weighed by the share its own direction gets through the coat) or follows the coat's
/// mirror. A room whose walls are red plastic, with a textured plastic floor, a nonlinear plastic ball
/// and a diffuse one, under a quad light: most of what the camera sees is plastic, much of it lit by
/// light that bounced (indirect photons) or was mirrored by a coat (caustic photons), which the path
/// tracer finds by sampling the same BSDF.
#[test]
fn photon_mappers_render_plastic() {
    photon_modes_match_pt_within("plastic", &plastic_room(["", "", ""], ""), 0.015);
}

/// The room of the plastic tests: red plastic walls and ceiling, a textured plastic floor of index 1.6
/// with a dimmed coat, a nonlinear plastic ball and a diffuse one, under a quad light. `coats` adds keys
/// to the walls', the floor's and the ball's materials; `lights` adds lights.
fn plastic_room(coats: [&str; 3], lights: &str) -> String {
    let [wall, floor, ball] = coats;
    format!(
        "[camera]\norigin = [0.3, 0.2, 0.95]\ntarget = [-0.2, -0.5, -0.5]\nfov = 70\nresolution = [32, 24]\n\
         [textures]\nchecks = {{ type = \"checkerboard\", color0 = [0.8, 0.8, 0.7], color1 = [0.1, 0.2, 0.3], scale = [4.0, 4.0] }}\n\
         [materials]\nwall = {{ type = \"plastic\", reflectance = [0.75, 0.3, 0.25], ior = 1.5{wall} }}\n\
         floor = {{ type = \"plastic\", reflectance = \"checks\", ior = 1.6, specular = [0.8, 0.8, 0.8]{floor} }}\n\
         ball = {{ type = \"plastic\", reflectance = [0.2, 0.8, 0.3], nonlinear = true{ball} }}\n\
         white = {{ type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, -1.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-0.4, -0.65, -0.3]\nradius = 0.35\nmaterial = \"ball\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.45, -0.75, -0.5]\nradius = 0.25\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.3, 0.98, -0.3]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\npower = [10.0, 10.0, 10.0]\n\
         {lights}[render]\nmax_depth = 6\npm_spp = 16\n{}",
        // The box's walls and ceiling (its floor is the textured quad above).
        common::inward_box(-1.0, 1.0, "wall", None).split("\n\n").skip(1).collect::<Vec<_>>().join("\n\n")
    )
}

/// Rough plastic (Mitsuba's `roughplastic`) in the photon mappers: photons are stored on the base and
/// go on by either lobe, the coat's glossy reflection counting as a specular bounce; camera chains that
/// meet it follow the glossy lobe by its share (with a light sample there, as at rough metal) or end at
/// the base, where each photon is weighed by the coat's transmittance table in its own direction and
/// light samples and final gather see the base alone. A room of rough red plastic walls (GGX, α 0.3), a
/// textured rough floor (Beckmann, α 0.15, IOR 1.6), a nonlinear ball with a barely rough coat (GGX,
/// α 0.05) and a diffuse ball, under a quad light and a point light whose glossy highlights and their
/// reflections on the diffuse surfaces the path tracer finds by light samples at the coats.
#[test]
fn photon_mappers_render_rough_plastic() {
    let coats = [", roughness = 0.3", ", roughness = 0.15, distribution = \"beckmann\"", ", roughness = 0.05"];
    let point = "[[lights]]\ntype = \"point\"\nposition = [0.5, 0.3, 0.2]\npower = [3.0, 3.0, 3.0]\n";
    photon_modes_match_pt_within("rough plastic", &plastic_room(coats, point), 0.015);
}

/// `render.max_depth` limits the whole path in the path tracer: the camera's bounces through glass
/// plus what the light did before. Photon maps must cut the same paths: a photon gathered where the
/// camera ray arrived after k bounces counts only if its own path (the gather included) has at most
/// max_depth − k scattering events. A room seen through a glass slab that fills the view (every camera
/// ray is refracted twice before it meets the back wall): at max_depth 3 the path tracer has only the
/// wall's direct light (no photon fits), at 4 also one diffuse bounce; fixed PM, PPM and SPPM must have
/// its mean at both. (Before the photon paths' depths were recorded, the photon mappers added every
/// photon there, whatever its path.)
#[test]
fn photon_mappers_cut_paths_at_the_path_tracers_depth() {
    let text = format!(
        "[camera]\norigin = [0.0, 0.0, 0.9]\ntarget = [0.0, 0.0, -1.0]\nfov = 30\nresolution = [16, 16]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }}\n\
         glass = {{ type = \"dielectric\", ior = 1.5 }}\n\
         [[shapes]]\ntype = \"box\"\nmin = [-0.99, -0.99, 0.5]\nmax = [0.99, 0.99, 0.7]\nmaterial = \"glass\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.3, 0.99, -0.5]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\npower = [10.0, 10.0, 10.0]\n\
         {}",
        common::inward_box(-1.0, 1.0, "wall", None)
    );
    for depth in [3u32, 4] {
        let mut s = common::scene(&text);
        s.render.max_depth = depth;
        let a = Accel::new(&s).unwrap();
        let pt = channel_means(&render_path(&s, &a, 1024, true).image)[1];
        let plan = plan_for(&s, &a);
        let m = build_maps(&s, &a, &MapRequest::planned(&s, &plan), true).unwrap();
        let mut got = vec![("photon_map", channel_means(&render_photon_map(&s, &a, &m, &plan, None, true).image)[1])];
        for (name, mode) in [("ppm", caustica::scene::file::Mode::Ppm), ("sppm", caustica::scene::file::Mode::Sppm)] {
            s.render.mode = mode;
            s.render.progressive.passes = 16;
            s.render.progressive.photons_per_pass = 50_000;
            let img = caustica::pipeline::render_progressive(&s, &a, &plan, true, &[]).unwrap().output.image;
            got.push((name, channel_means(&img)[1]));
        }
        for (name, mean) in got {
            eprintln!("max_depth {depth}, {name}: mean / PT's {:.4} (PT {pt:.4})", mean / pt);
            assert!((mean / pt - 1.0).abs() < 0.03, "max_depth {depth}, {name}: mean {mean} against PT's {pt}");
        }
    }
}

/// The eye passes' split at a first glass hit (both lobes followed, `ChainLight::CountSplitFirst`) keeps
/// to `render.max_depth`: the lobe not sampled starts one bounce in, not at the camera. A glass ball
/// filling most of the view under a constant sky, over a dark floor (a random scene's, found by
/// comparing every mode with the others): at max_depth 1 only the sky mirrored in the ball reaches the
/// camera, at 2 also what crosses the ball once. Before, the split-off lobe's chain counted its
/// bounces from zero, so the sky seen through the ball (two refractions) showed at max_depth 1:
/// fixed PM read 1.4934 and SPPM 1.4973 of the path tracer's mean (at 2, 1.0055 and 1.0047, where the
/// extra bounce adds little); now 0.9986 and 1.0004 (1.0014 and 1.0004 at 2). PPM splits nothing.
#[test]
fn the_split_first_glass_lobe_keeps_the_depth_limit() {
    for depth in [1u32, 2] {
        let text = format!(
            "[camera]\norigin = [0.0, 0.55, 1.3]\ntarget = [0.0, 0.45, 0.0]\nfov = 30\nresolution = [24, 24]\n\
             [materials]\ndark = {{ type = \"diffuse\", reflectance = [0.1, 0.1, 0.1] }}\n\
             glass = {{ type = \"dielectric\", ior = 1.5 }}\n\
             [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\nmaterial = \"dark\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.45, 0.0]\nradius = 0.4\nmaterial = \"glass\"\n\
             [[lights]]\ntype = \"constant\"\nradiance = [0.8, 0.9, 1.0]\n\
             [render]\nmax_depth = {depth}\npm_spp = 16\n"
        );
        let label = format!("max_depth {depth}");
        photon_modes_match_pt_within(&label, &text, 0.02);
    }
}

/// A light's edge mirrored across a pixel: a camera looks at a mirror (its first hit specular) that
/// shows a quad light covering x < x0, with x0 placed so the light's reflection covers `f` = 0.3 of the
/// width of column 4 of an 8 × 8 image (box filter). Columns 0–3 see the light over their whole area,
/// column 4 over 30% of it, columns 5–7 not at all.
fn mirrored_edge(mode: &str, sets: &[&str]) -> Scene {
    // A camera ray through film coordinate t (tangent plane, x) hits the mirror at z = −1 and, reflected,
    // reaches the light's plane z = 0.5 at x = 2.5 t. Column 4 spans t ∈ [0, w], w = 2 tan(10°) / 8.
    let w = 2.0 * 10f32.to_radians().tan() / 8.0;
    let x0 = 2.5 * 0.3 * w;
    let text = format!(
        "[camera]\norigin = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, -1.0]\nfov = 20\nresolution = [8, 8]\n\
         [materials]\nmirror = {{ type = \"mirror\" }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, -2.0, -1.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 4.0, 0.0]\n\
         material = \"mirror\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [{x0}, -3.0, 0.5]\nedge_u = [-6.0, 0.0, 0.0]\nedge_v = [0.0, 6.0, 0.0]\n\
         radiance = [1.0, 1.0, 1.0]\n"
    );
    common::scene_in_mode(&text, mode, sets)
}

/// The extra eye samples of pixels whose first hit is specular (`render.specular_spp`) sample the
/// pixel's area: a light's reflection covering 30% of a pixel is found by 1 − 0.7⁵ of five-sample
/// estimates, and one pass's value at that pixel varies by at most 0.3 · 0.7 / 5 (independent positions;
/// less when stratified), against 0.3 · 0.7 for a single position, for every mode with an eye pass of
/// photon mapping: one SPPM iteration, one PPM pass, a fixed photon map's single eye sample. The mean
/// stays the light's share of the pixel, 0.3, and the lit and dark columns read exactly 1 and 0.
#[test]
fn extra_eye_samples_behind_a_mirror_sample_the_pixel_area() {
    let f = 0.3f64;
    for (mode, sets) in [
        ("sppm", &["render.progressive.passes=1", "render.progressive.photons_per_pass=1000"][..]),
        ("ppm", &["render.progressive.passes=1", "render.progressive.photons_per_pass=1000"][..]),
        ("photon_map", &["render.pm_spp=1", "render.photons.caustic=1000", "render.photons.indirect=1000"][..]),
    ] {
        let mut edge = Vec::new();
        for seed in 0..64u64 {
            let mut s = mirrored_edge(mode, sets);
            s.render.seed = seed;
            let img = common::render_image(&s);
            for y in 0..8 {
                for x in [0u32, 3, 5, 7] {
                    let want = if x < 4 { 1.0 } else { 0.0 };
                    let v = img.get(x, y).x;
                    assert!((v - want).abs() < 1e-4, "{mode}: pixel ({x}, {y}) reads {v}, expected {want}");
                }
                edge.push(img.get(4, y).x as f64);
            }
        }
        let (mean, sd) = mean_std(&edge);
        let var = sd * sd;
        let se = (f * (1.0 - f) / edge.len() as f64).sqrt();
        eprintln!(
            "{mode}: the edge pixel reads {mean:.4} ± {se:.4} (expected {f}), variance {var:.4} \
             (one area sample {:.4}, five {:.4})",
            f * (1.0 - f),
            f * (1.0 - f) / 5.0
        );
        assert!((mean - f).abs() < 4.0 * se, "{mode}: the edge pixel reads {mean}, expected {f} ± {se}");
        assert!(
            var < 0.4 * f * (1.0 - f),
            "{mode}: the edge pixel's variance {var:.4} is that of one area sample ({:.4}), not five",
            f * (1.0 - f)
        );
    }
}
