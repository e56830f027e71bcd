//! Progressive photon mapping (`ppm`) and stochastic progressive photon mapping (`sppm`): they converge
//! to the right answer as passes accumulate, PPM passes can be split across runs, SPPM is deterministic.
//! Point-light caustics converge with `bdpt` and `vcm` too.
mod common;
use caustica::accel::Accel;
use caustica::film::Image;
use caustica::metrics::{compare_masked, light_free_pixels};
use caustica::pipeline::{plan_for, render_path, render_progressive, Progressive};
use caustica::scene::file::Mode;
use caustica::scene::{load_scene_with, Scene};
use std::path::PathBuf;

fn run(s: &Scene, a: &Accel, snapshots: &[u32]) -> Progressive {
    render_progressive(s, a, &plan_for(s, a), true, snapshots).unwrap()
}

fn furnace(mode: Mode) -> Scene {
    // Looking at the middle of one wall of a closed box whose walls all emit Le and reflect a: every
    // point sees Le/(1 − a). The view stays 0.6 from the wall's edges, beyond every gather radius used.
    let (le, a) = (1.0f32, 0.5f32);
    let mut s = common::scene(&format!(
        "[camera]\norigin = [0.0, 0.0, 0.5]\ntarget = [0.0, 0.0, -1.0]\nfov = 30\nresolution = [6, 6]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [{a}, {a}, {a}] }}\n\
         [render]\nmax_depth = 10000\n{}",
        common::inward_box(-1.0, 1.0, "wall", Some(le))
    ));
    s.render.mode = mode;
    s.render.progressive.passes = 24;
    s.render.progressive.photons_per_pass = 100_000;
    s
}

#[test]
fn the_furnace_converges_to_le_over_one_minus_albedo_in_both_modes() {
    for mode in [Mode::Ppm, Mode::Sppm] {
        let s = furnace(mode);
        let a = Accel::new(&s).unwrap();
        let img = run(&s, &a, &[]).output.image;
        let mean = img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64;
        eprintln!("{mode:?} furnace: {mean:.5} (expected 2)");
        assert!((mean / 2.0 - 1.0).abs() < 0.01, "{mode:?}: furnace reads {mean}, expected 2");
    }
}

/// The furnace seen from close to one of its corners (`mode`, 64 passes, direct light from photons
/// too), with a mask of the pixels that see within 0.03 of an edge.
fn furnace_corner(mode: Mode) -> (Scene, Accel, Vec<bool>) {
    let mut s = furnace(mode);
    s.camera = caustica::scene::Camera::new(
        glam::Vec3::new(-0.6, -0.55, -0.5),
        glam::Vec3::splat(-1.0),
        glam::Vec3::Y,
        50.0,
        caustica::scene::file::FovAxis::X,
        [24, 24],
    );
    s.render.progressive.passes = 64;
    s.render.direct_light = caustica::scene::file::DirectLight::PhotonMap;
    let a = Accel::new(&s).unwrap();
    let near_edge: Vec<bool> = (0..24 * 24)
        .map(|k| {
            let ray = s.camera.ray((k % 24) as f32 + 0.5, (k / 24) as f32 + 0.5);
            let hit = caustica::accel::Tracer::intersect(&a, &ray).expect("a closed box");
            ray.at(hit.t).to_array().iter().filter(|c| c.abs() > 0.97).count() >= 2
        })
        .collect();
    (s, a, near_edge)
}

/// Mean of the pixels `near_edge` marks, and of the others.
fn edge_and_rest(img: &Image, near_edge: &[bool]) -> (f64, f64) {
    let edge_pixels = near_edge.iter().filter(|&&e| e).count();
    assert!(edge_pixels >= 30, "only {edge_pixels} pixels see an edge");
    let (mut edge, mut rest) = (0.0f64, 0.0f64);
    for (p, &e) in img.pixels.iter().zip(near_edge) {
        *(if e { &mut edge } else { &mut rest }) += p.x as f64;
    }
    (edge / edge_pixels as f64, rest / (img.pixels.len() - edge_pixels) as f64)
}

#[test]
fn progressive_modes_read_the_furnace_right_up_to_its_edges_and_corners() {
    // The furnace seen from close to one of its corners: every point of every wall reads
    // Le/(1 − a) = 2, the reflected half of it from photons (direct light too, so no shadow-ray noise).
    // A gather disc that reaches past an edge holds photons over only part of its area; divided by the
    // whole disc it reads 1 + c (c the part covered: about 1.5 at an edge, 1.25 in the corner). Checked
    // on the pixels that see within 0.03 of an edge (about one radius), with and without the edge
    // correction (the same photons and visible points: only the correction differs). SPPM divides by
    // the covered area it accumulates; PPM's passes, which share one radius, multiply each gather by an
    // unbiased estimate of 1 / (the part covered).
    for mode in [Mode::Sppm, Mode::Ppm] {
        let (mut s, a, near_edge) = furnace_corner(mode);
        let (edge, rest) = edge_and_rest(&run(&s, &a, &[]).output.image, &near_edge);
        s.render.progressive.edge_correction = false;
        let (plain_edge, plain_rest) = edge_and_rest(&run(&s, &a, &[]).output.image, &near_edge);
        eprintln!(
            "{mode:?} furnace corner: edge pixels corrected {edge:.4} (elsewhere {rest:.4}), \
             plain {plain_edge:.4} (elsewhere {plain_rest:.4}); expected 2"
        );
        assert!((edge / 2.0 - 1.0).abs() < 0.015, "{mode:?}: edge pixels read {edge} with the correction");
        assert!((rest / 2.0 - 1.0).abs() < 0.015, "{mode:?}: other pixels read {rest} with the correction");
        assert!(plain_edge < 1.95, "{mode:?}: without the correction the edge pixels read {plain_edge}, not dark");
    }
}

#[test]
fn fixed_photon_map_reads_the_furnace_right_up_to_its_edges_and_corners() {
    // The fixed photon map gathers its k nearest photons (cone filter): at an edge the k spread over the
    // part of the disc that is surface, and dividing by the whole disc read 1.73-1.78 instead of 2 on
    // the edge pixels. Each gather multiplies by an estimate of 1 / (the cone-weighted part covered).
    // The map's noise is low-frequency (one set of photons per render), so three seeds are averaged.
    let (mut s, a, near_edge) = furnace_corner(Mode::PhotonMap);
    let mut read = |edges: bool| {
        s.render.gather.edge_correction = edges;
        let (mut edge, mut rest) = (0.0, 0.0);
        for seed in 1..=3 {
            s.render.seed = seed;
            let img = caustica::pipeline::render_pm(&s, &a, &plan_for(&s, &a), true).unwrap().1.image;
            let (e, r) = edge_and_rest(&img, &near_edge);
            (edge, rest) = (edge + e / 3.0, rest + r / 3.0);
        }
        (edge, rest)
    };
    let (edge, rest) = read(true);
    let (plain_edge, plain_rest) = read(false);
    eprintln!(
        "fixed PM furnace corner: edge pixels corrected {edge:.4} (elsewhere {rest:.4}), \
         plain {plain_edge:.4} (elsewhere {plain_rest:.4}); expected 2"
    );
    assert!((edge / 2.0 - 1.0).abs() < 0.02, "edge pixels read {edge} with the correction, expected 2");
    assert!((rest / 2.0 - 1.0).abs() < 0.02, "other pixels read {rest} with the correction, expected 2");
    assert!(plain_edge < 1.9, "without the correction the edge pixels should read dark, not {plain_edge}");
}

fn glass(mode: Mode) -> (Scene, Accel) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glass.toml");
    let mut s = load_scene_with(&p, &["camera.resolution=[48, 48]".to_string()]).unwrap();
    s.render.mode = mode;
    s.render.progressive.photons_per_pass = 20_000;
    let a = Accel::new(&s).unwrap();
    (s, a)
}

fn clamped(img: &Image) -> Image {
    Image { pixels: img.pixels.iter().map(|p| p.clamp(glam::Vec3::ZERO, glam::Vec3::ONE)).collect(), ..img.clone() }
}

#[test]
fn error_on_the_glass_box_keeps_falling_with_passes() {
    // A consistent estimator: against a long path-traced reference, RMSE at 64 passes is at most half
    // of RMSE at 4 passes (fixed photon mapping's error stops falling at its bias).
    let (s, a) = glass(Mode::Path);
    let reference = clamped(&render_path(&s, &a, 8192, true).image);
    let keep = light_free_pixels(&s, &a, 4);
    for mode in [Mode::Ppm, Mode::Sppm] {
        let (mut s, a) = glass(mode);
        s.render.progressive.passes = 64;
        let p = run(&s, &a, &[4, 64]);
        let e: Vec<f64> = p
            .snapshots
            .iter()
            .map(|(_, _, img)| compare_masked(&clamped(img), &reference, &keep).unwrap().rmse)
            .collect();
        eprintln!("{mode:?} glass box: RMSE at 4 passes {:.5}, at 64 passes {:.5}", e[0], e[1]);
        assert!(e[1] <= 0.5 * e[0], "{mode:?}: RMSE {} at 64 passes vs {} at 4", e[1], e[0]);
    }
}

#[test]
fn ppm_passes_split_across_two_runs_average_to_the_single_run() {
    let (mut s, a) = glass(Mode::Ppm);
    s.render.progressive.passes = 8;
    let whole = run(&s, &a, &[]).output.image;
    s.render.progressive.passes = 4;
    let first = run(&s, &a, &[]).output.image;
    s.render.progressive.first_pass = 5;
    let second = run(&s, &a, &[]).output.image;
    let mut worst = 0.0f32;
    for ((w, f), g) in whole.pixels.iter().zip(&first.pixels).zip(&second.pixels) {
        let avg = (*f + *g) * 0.5;
        for k in 0..3 {
            worst = worst.max((avg[k] - w[k]).abs() / w[k].abs().max(1e-3));
        }
    }
    assert!(worst <= 1e-6, "largest relative difference {worst}");
}

#[test]
fn sppm_is_bit_identical_on_one_and_two_threads() {
    let (mut s, a) = glass(Mode::Sppm);
    s.render.progressive.passes = 4;
    let images: Vec<Image> = [1, 2]
        .iter()
        .map(|&n| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
            pool.install(|| run(&s, &a, &[]).output.image)
        })
        .collect();
    assert!(images[0].pixels == images[1].pixels, "1 and 2 threads differ");
}

#[test]
fn point_light_caustics_converge_where_the_path_tracer_sees_nothing() {
    // The cardioid: a ring mirror lit by a point light; PT never finds the caustic. Each mode (PPM,
    // SPPM, and BDPT by light tracing, VCM by light tracing and merging) must approach its own long run
    // (256 passes, another seed: smaller radius, independent noise) — RMSE at 64 passes at most 0.6 ×
    // at 4 — the long runs, different estimators of the same limit, must agree in the mean with PPM's
    // (3%), and the caustic must add light PT's image lacks.
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cardioid.toml");
    let sets = [
        "camera.resolution=[48, 48]".to_string(),
        "render.progressive.photons_per_pass=50000".to_string(),
        "render.vcm.light_paths=50000".to_string(),
    ];
    let load = |mode: Mode, passes: u32, seed: u64| {
        let mut s = load_scene_with(&p, &sets).unwrap();
        s.render.mode = mode;
        s.render.progressive.passes = passes;
        s.render.seed = seed;
        s
    };
    let s = load(Mode::Ppm, 1, 0);
    let a = Accel::new(&s).unwrap();
    let keep = vec![true; 48 * 48];
    let pt = render_path(&s, &a, 64, true).image;
    let lit = |img: &Image| img.pixels.iter().map(|p| p.x as f64).sum::<f64>();
    let mut long_runs = Vec::new();
    for mode in [Mode::Ppm, Mode::Sppm, Mode::Bdpt, Mode::Vcm] {
        let long = run(&load(mode, 256, 99), &a, &[]).output.image;
        let reference = clamped(&long);
        let snaps = run(&load(mode, 64, 0), &a, &[4, 64]).snapshots;
        let e: Vec<f64> =
            snaps.iter().map(|(_, _, img)| compare_masked(&clamped(img), &reference, &keep).unwrap().rmse).collect();
        eprintln!(
            "{mode:?} cardioid: RMSE against 256 passes {:.5} at 4 passes, {:.5} at 64; image sums PT {:.1}, {mode:?} {:.1}",
            e[0],
            e[1],
            lit(&pt),
            lit(&snaps[1].2)
        );
        assert!(e[1] <= 0.6 * e[0], "{mode:?}: RMSE {} at 64 passes vs {} at 4", e[1], e[0]);
        assert!(lit(&snaps[1].2) > 1.05 * lit(&pt), "{mode:?}: the caustic adds no light over PT's image");
        // Means unclamped: clamping would cut the rare bright light-tracing samples and bias the mean.
        long_runs.push(long);
    }
    // BDPT cannot make the caustic's reflection in the ring (point light → mirror → floor → mirror →
    // camera: no strategy connects at a mirror or hits a point light), so it may only fall short.
    for (k, name) in [(1, "SPPM"), (2, "BDPT"), (3, "VCM")] {
        let agree = compare_masked(&long_runs[k], &long_runs[0], &keep).unwrap();
        eprintln!("cardioid, 256 passes: {name}/PPM mean {:.4}", agree.mean_ratio);
        let low = if name == "BDPT" { 0.9 } else { 0.97 };
        assert!(agree.mean_ratio > low && agree.mean_ratio < 1.03, "{name}/PPM mean {}", agree.mean_ratio);
    }
}

/// A spot's caustic: a spot (cutoff 30°, beam 20°) above a glass ball that subtends 14.5° from it,
/// its axis tilted 25° from the ball's centre, so that part of the ball lies outside its cone. VCM's light subpaths aimed at the ball
/// (`render.vcm.aim = 0.9`) must carry the spot's falloff towards where they were aimed and die outside
/// its cone, or the caustic under the ball comes out several times too bright: the aimed run must
/// have the unaimed run's mean (aim 0) within 3%. (The photon mappers' aimed caustic photons:
/// tests/photon_map.rs.)
#[test]
fn vcm_aimed_at_glass_under_a_spot_keeps_the_caustic() {
    let text = "[camera]\norigin = [0.0, 1.3, 2.0]\ntarget = [0.0, 0.2, 0.0]\nfov = 40\nresolution = [32, 32]\n\
        [materials]\nfloor = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\nglass = { type = \"dielectric\", ior = 1.5 }\n\
        [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\nmaterial = \"floor\"\n\
        [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.7, 0.0]\nradius = 0.4\nmaterial = \"glass\"\n\
        [[lights]]\ntype = \"spot\"\nposition = [0.0, 2.3, 0.0]\ndirection = [0.4226, -0.9063, 0.0]\n\
        intensity = [30.0, 30.0, 30.0]\ncutoff_angle = 30.0\nbeam_width = 20.0\n\
        [render]\nmode = \"vcm\"\n[render.progressive]\npasses = 96\n[render.vcm]\nlight_paths = 50000\n";
    let base = common::scene(text);
    let a = Accel::new(&base).unwrap();
    let mean = |aim: f32| {
        let mut s = common::scene(text);
        s.render.vcm.aim = aim;
        let img = run(&s, &a, &[]).output.image;
        img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64
    };
    let (aimed, unaimed) = (mean(0.9), mean(0.0));
    eprintln!("VCM under a spot: aimed {aimed:.5}, unaimed {unaimed:.5}, ratio {:.4}", aimed / unaimed);
    assert!(unaimed > 0.0 && (aimed / unaimed - 1.0).abs() < 0.03, "aimed {aimed} vs unaimed {unaimed}");
}
