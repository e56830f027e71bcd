//! Bidirectional path tracing (`bdpt`) and vertex connection and merging (`vcm`) against closed forms
//! and the path tracer: the furnace, the means of two Cornell boxes, every single (s, t) strategy on its
//! own (the test that catches a wrong pdf: an unweighted strategy has PT's mean only if its sampling
//! densities are right), every kind of light, and the same bits on 1 and 2 threads. Point-light
//! caustics converging: tests/progressive.rs, beside PPM and SPPM.
mod common;
use caustica::accel::Accel;
use caustica::film::Image;
use caustica::integrator::vcm::{iterate, Setup, VcmOptions};
use caustica::pipeline::render_path;
use caustica::scene::{load_scene_with, Scene};
use std::path::PathBuf;

fn mean(img: &Image) -> f64 {
    img.pixels.iter().map(|p| (p.x + p.y + p.z) as f64 / 3.0).sum::<f64>() / img.pixels.len() as f64
}

/// Mean of the image over `passes` iterations and the standard error of that mean, set up as a render
/// would (aimed light subpaths, the merge radius following the light's density). The iterations are
/// made independent for this (the default Sobol sampler stratifies them, which would make the spread of
/// their means overstate the error).
fn bidir_mean(s: &mut Scene, a: &Accel, opts: VcmOptions, passes: u32) -> (f64, f64) {
    let sampler = std::mem::replace(&mut s.render.sampler, caustica::math::rng::Sampler::Independent);
    let setup = Setup::new(s, a, opts, None);
    let m: Vec<f64> = (1..=passes).map(|i| mean(&iterate(s, a, &setup, i).image)).collect();
    s.render.sampler = sampler;
    mean_and_error(&m)
}

fn mean_and_error(m: &[f64]) -> (f64, f64) {
    let n = m.len() as f64;
    let mu = m.iter().sum::<f64>() / n;
    let var = m.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (n - 1.0);
    (mu, (var / n).sqrt())
}

/// The path tracer's mean and standard error from `chunks` independent renders of `spp` samples.
fn pt_mean(s: &mut Scene, a: &Accel, spp: u32, chunks: u64) -> (f64, f64) {
    let seed = s.render.seed;
    let m: Vec<f64> = (0..chunks)
        .map(|k| {
            s.render.seed = 1000 + k;
            mean(&render_path(s, a, spp, true).image)
        })
        .collect();
    s.render.seed = seed;
    mean_and_error(&m)
}

fn furnace() -> Scene {
    // Looking at the middle of one wall of a closed box whose walls all emit Le and reflect a: every
    // point sees Le/(1 − a).
    let (le, a) = (1.0f32, 0.5f32);
    common::scene(&format!(
        "[camera]\norigin = [0.0, 0.0, 0.5]\ntarget = [0.0, 0.0, -1.0]\nfov = 30\nresolution = [16, 16]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [{a}, {a}, {a}] }}\n\
         [render]\nmax_depth = 10000\n[render.progressive]\nradius = 0.05\n{}",
        common::inward_box(-1.0, 1.0, "wall", Some(le))
    ))
}

#[test]
fn the_furnace_reads_le_over_one_minus_albedo() {
    let mut s = furnace();
    let a = Accel::new(&s).unwrap();
    for (name, opts) in [("bdpt", VcmOptions::bdpt()), ("vcm", VcmOptions::vcm())] {
        let (m, e) = bidir_mean(&mut s, &a, opts, 64);
        eprintln!("{name} furnace: {m:.5} ± {e:.5} (expected 2)");
        assert!((m / 2.0 - 1.0).abs() < 0.01, "{name}: furnace reads {m}, expected 2");
    }
}

/// The furnace seen from its middle towards a corner (three walls and their edges fill the view), with
/// a merge radius of 0.6 (the walls are 2 wide) that hardly shrinks: merging alone (a progressive photon
/// mapper) and VCM must read `Le/(1 − a)` = 2, the mean within 0.5% and every 4 × 4 block within 3%, along
/// the edges and at the corner too. A merge that counts, at a point by an edge, the light vertices of the wall across it (the
/// search's ball, not the disc on the surface) misreads bands one radius wide along every edge; a disc
/// counted whole where part of it is off the wall reads dark there.
#[test]
fn merging_reads_the_furnace_right_at_its_edges_and_corners() {
    let (le, a) = (1.0f32, 0.5f32);
    let s = common::scene(&format!(
        "[camera]\norigin = [0.3, 0.3, 0.3]\ntarget = [-1.0, -1.0, -1.0]\nfov = 100\nresolution = [32, 32]\n\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [{a}, {a}, {a}] }}\n\
         [render]\nmax_depth = 10000\n[render.progressive]\nradius = 0.6\nalpha = 0.99\n{}",
        common::inward_box(-1.0, 1.0, "wall", Some(le))
    ));
    let a = Accel::new(&s).unwrap();
    let merging = VcmOptions { connect: false, ..VcmOptions::vcm() };
    let read: Vec<(&str, f64, f64)> = [("merging", merging), ("vcm", VcmOptions::vcm())]
        .into_iter()
        .map(|(name, opts)| {
            let blocks = bidir_blocks(&s, &a, opts, 48, 4);
            let mean = blocks.iter().sum::<f64>() / blocks.len() as f64;
            let worst = blocks.iter().map(|b| (b / 2.0 - 1.0).abs()).fold(0.0, f64::max);
            eprintln!("{name} furnace towards a corner: mean {mean:.5}, worst 4 × 4 block {worst:.4} off 2");
            (name, mean, worst)
        })
        .collect();
    for (name, mean, worst) in read {
        assert!((mean / 2.0 - 1.0).abs() < 0.005, "{name}: the furnace reads {mean} towards a corner, expected 2");
        assert!(worst < 0.03, "{name}: a block of the furnace reads {worst} off 2");
    }
}

fn small(name: &str, res: u32) -> (Scene, Accel) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let s = load_scene_with(&p, &[format!("camera.resolution=[{res}, {res}]")]).unwrap();
    let a = Accel::new(&s).unwrap();
    (s, a)
}

#[test]
fn bdpt_and_vcm_means_equal_the_path_tracers_on_both_cornell_boxes() {
    for scene in ["cornell-box.toml", "cornell-glass.toml"] {
        let (mut s, a) = small(scene, 32);
        means_match_pt(scene, &mut s, &a, 64, 256);
    }
}

/// BDPT's and VCM's means over `passes` iterations equal PT's (16 renders of `pt_spp`) within 3σ.
fn means_match_pt(label: &str, s: &mut Scene, a: &Accel, pt_spp: u32, passes: u32) {
    let (pt, pt_e) = pt_mean(s, a, pt_spp, 16);
    for (name, opts) in [("bdpt", VcmOptions::bdpt()), ("vcm", VcmOptions::vcm())] {
        let (m, e) = bidir_mean(s, a, opts, passes);
        let sigma = (e * e + pt_e * pt_e).sqrt();
        eprintln!("{label} {name}: {m:.5} ± {e:.5}, PT {pt:.5} ± {pt_e:.5}: {:+.2}σ", (m - pt) / sigma);
        assert!((m - pt).abs() < 3.0 * sigma, "{label} {name}: mean {m} vs PT {pt} (σ {sigma})");
    }
}

/// A small open room for the strategy test: a floor, a back wall and a side wall that do not touch
/// (an unweighted connection's 1/d² has infinite variance where two surfaces meet, which would make
/// its mean unmeasurable), a floating rough (GGX) gold block, a quad light under the ceiling's place
/// and a sphere light (area and cone sampling); no delta BSDF, so every strategy can make every path.
fn strategy_room() -> Scene {
    strategy_room_seen_by("fov = 60\n")
}

/// `strategy_room` seen by a camera that `camera` (whole lines) describes beside its place.
fn strategy_room_seen_by(camera: &str) -> Scene {
    common::scene(&format!(
        "[camera]\norigin = [0.0, 0.0, 0.9]\ntarget = [0.0, -0.2, 0.0]\nresolution = [12, 12]\n{camera}\
         [materials]\nwall = {{ type = \"diffuse\", reflectance = [0.7, 0.6, 0.5] }}\n\
         gold = {{ type = \"conductor\", preset = \"Au\", roughness = 0.3 }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, -1.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"wall\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, -0.7, -1.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 1.7, 0.0]\nmaterial = \"wall\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, -0.7, -0.7]\nedge_u = [0.0, 1.7, 0.0]\nedge_v = [0.0, 0.0, 1.7]\nmaterial = \"wall\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-0.5, -0.6, -0.5]\nmax = [0.0, -0.2, 0.0]\nmaterial = \"gold\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.3, 0.98, -0.3]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\n\
         material = \"wall\"\nemission = [4.0, 4.0, 4.0]\n\
         [[lights]]\ntype = \"sphere\"\ncenter = [0.6, -0.6, -0.5]\nradius = 0.15\nradiance = [3.0, 3.0, 3.0]\n",
    ))
}

#[test]
fn every_strategy_alone_has_the_path_tracers_mean_for_its_path_length() {
    every_strategy_alone_matches_pt(&strategy_room, 4);
}

/// The strategy test through an orthographic camera: its rays' direction is a delta, so a camera
/// subpath's first vertex has a density per unit area of film (not per solid angle) and light tracing
/// (t = 1) joins a vertex to the film point straight in front of it. Paths of 2 and 3 edges.
#[test]
fn every_strategy_alone_has_the_path_tracers_mean_through_an_orthographic_camera() {
    let ortho = || strategy_room_seen_by("projection = \"orthographic\"\nfilm_size = [1.6, 1.6]\n");
    assert_eq!(ortho().camera.ortho, Some([0.8, 0.8]));
    every_strategy_alone_matches_pt(&ortho, 3);
}

/// A floor seen through a thin pane of glass past the camera's far clipping plane: only the segment
/// from the camera is clipped, so camera rays that cross the pane within the plane go on past it and
/// see the floor beyond, as Mitsuba's do (random scene 1925: its thin-glass cylinder stood at the far
/// plane). Light tracing (t = 1) must see the same points through the same pane; it left out every
/// point beyond the plane: the unweighted (2, 1) strategy read 0.0236 against PT's 0.0330 here (−75σ;
/// BDPT's image 0.62 of PT's by the pane in scene 1925). With `hide_emitters` the camera's line of
/// sight passes emitting surfaces as well, and the link to the camera by the same rule: the pane made
/// a hidden emitter instead.
fn pane_at_the_far_plane(pane: &str) -> Scene {
    common::scene(&format!(
        "[camera]\norigin = [0.0, 0.6, 1.6]\ntarget = [0.0, 0.2, 0.0]\nfov = 50\nresolution = [16, 12]\nfar_clip = 1.9\n\
         [materials]\nfloor = {{ type = \"diffuse\", reflectance = [0.7, 0.6, 0.5] }}\n\
         glass = {{ type = \"thin_dielectric\", ior = 1.5 }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -5.0]\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.3, 1.5, -0.8]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\n\
         material = \"floor\"\nemission = [4.0, 4.0, 4.0]\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.4, 0.0, 0.0]\nedge_u = [0.8, 0.0, 0.0]\nedge_v = [0.0, 0.6, 0.0]\n{pane}",
    ))
}

#[test]
fn light_tracing_sees_past_the_far_plane_through_a_pane_as_camera_rays_do() {
    let glass = "material = \"glass\"\n";
    assert_eq!(pane_at_the_far_plane(glass).camera.clip, [0.0, 1.9]);
    // Two-edge paths only: longer ones reflect off the pane (a delta), which some strategies cannot make.
    every_strategy_alone_matches_pt(&|| pane_at_the_far_plane(glass), 2);
    let hidden = "material = \"floor\"\nemission = [0.5, 0.5, 0.5]\n[render]\nhide_emitters = true\n";
    every_strategy_alone_matches_pt(&|| pane_at_the_far_plane(hidden), 2);
}

/// Paths of exactly k edges (2 ≤ k ≤ `max_k`) in the scene `room` makes: PT with max_depth k − 1 minus
/// PT with max_depth k − 2, both from the same seed (the two share every random number up to the last
/// bounce, so the difference is precise); each (s, t) with s + t − 1 = k, unweighted, must have the
/// same mean.
fn every_strategy_alone_matches_pt(room: &dyn Fn() -> Scene, max_k: u32) {
    let base = room();
    let a = Accel::new(&base).unwrap();
    let pt_upto = |depth: u32, seed: u64| {
        let mut s = room();
        s.render.max_depth = depth;
        s.render.seed = seed;
        mean(&render_path(&s, &a, 4096, true).image)
    };
    for k in 2..=max_k {
        let diffs: Vec<f64> = (0..8).map(|seed| pt_upto(k - 1, seed) - pt_upto(k - 2, seed)).collect();
        let (pt, pt_e) = mean_and_error(&diffs);
        let mut s = room();
        s.render.max_depth = k - 1;
        for sv in 0..=k {
            let t = k + 1 - sv;
            let opts = VcmOptions { strategy: Some((sv, t)), ..VcmOptions::bdpt() };
            let (m, e) = bidir_mean(&mut s, &a, opts, 1500);
            let sigma = (e * e + pt_e * pt_e).sqrt();
            eprintln!("k={k} (s,t)=({sv},{t}): {m:.5} ± {e:.5}; PT {pt:.5} ± {pt_e:.5}: {:+.2}σ", (m - pt) / sigma);
            assert!((m - pt).abs() < 4.0 * sigma + 2e-3 * pt, "k={k} (s,t)=({sv},{t}): {m} vs PT {pt} (σ {sigma})");
        }
    }
}

/// A fine black-and-white checkerboard under a quad light, seen from above (direct light only): the
/// scene in which light tracing must land on the film where camera samples see it.
fn checkerboard_from_above(camera_extra: &str) -> Scene {
    checkerboard_seen_by(&format!("fov = 50\n{camera_extra}"))
}

/// `checkerboard_from_above` seen by a camera that `camera` (whole lines) describes beside its place.
fn checkerboard_seen_by(camera: &str) -> Scene {
    let mut s = common::scene(&format!(
        "[camera]\norigin = [0.0, 1.2, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nresolution = [20, 20]\n{camera}\
         [textures]\nchecks = {{ type = \"checkerboard\", color0 = [0.9, 0.9, 0.9], color1 = [0.02, 0.02, 0.02], scale = [7.0, 7.0] }}\n\
         [materials]\nfloor = {{ type = \"diffuse\", reflectance = \"checks\" }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, 0.0, 1.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -2.0]\nmaterial = \"floor\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.5, 1.5, -0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\npower = [20.0, 20.0, 20.0]\n\
         [render]\nmax_depth = 1\n"
    ));
    // Independent samples, so that two halves' difference measures the noise (Sobol's stratify across
    // iterations).
    s.render.sampler = caustica::math::rng::Sampler::Independent;
    s
}

/// The unweighted light-tracing strategy (s = 2, t = 1) against the path tracer's image of the same
/// scene, pixel by pixel: their difference must hold less than a tenth of the difference between PT's
/// image and `wrong` (what a mistake would render; projected on it), and its mean square must be within
/// 1.5× of their two noises' variances (each measured from two independent renders), where `wrong`
/// differs from PT's image by several times that noise.
fn light_tracing_matches_pt(label: &str, s: &mut Scene, a: &Accel, wrong: &Image) {
    let sq = |x: &Image, y: &Image| {
        let sum: f64 = x.pixels.iter().zip(&y.pixels).map(|(p, q)| (*p - *q).length_squared() as f64).sum();
        sum / (x.pixels.len() * 3) as f64
    };
    let average = |imgs: &[Image]| {
        let mut out = imgs[0].clone();
        for (k, p) in out.pixels.iter_mut().enumerate() {
            *p = imgs.iter().map(|i| i.pixels[k]).sum::<caustica::color::Rgb>() / imgs.len() as f32;
        }
        out
    };
    let (pt1, pt2) = (pt_image(s, a, 1), pt_image(s, a, 2));
    s.render.seed = 3;
    let setup = Setup::new(s, a, VcmOptions { strategy: Some((2, 1)), ..VcmOptions::bdpt() }, None);
    let lt: Vec<Image> = (1..=2400).map(|i| iterate(s, a, &setup, i).image).collect();
    let (half1, half2) = (average(&lt[..1200]), average(&lt[1200..]));
    let lt = average(&lt);
    // Variances of one PT render and of the whole light-tracing average.
    let (var_pt, var_lt) = (sq(&pt1, &pt2) / 2.0, sq(&half1, &half2) / 4.0);
    let (got, wrong_off) = (sq(&lt, &pt1), sq(wrong, &pt1));
    // How much of the mistake's difference the light-traced image has: its difference from PT's image
    // projected on the mistake's (0: as PT sees it; 1: as the mistake renders it).
    let dot = |x: &Image, y: &Image, z: &Image| -> f64 {
        x.pixels.iter().zip(&y.pixels).zip(&z.pixels).map(|((p, q), r)| (*p - *q).dot(*r - *q) as f64).sum()
    };
    let beta = dot(&lt, &pt1, wrong) / dot(wrong, &pt1, wrong);
    eprintln!(
        "{label}: light tracing vs PT MSE {got:.3e}, their noise {:.3e}; the mistake vs PT {wrong_off:.3e}; \
         share of the mistake's difference {beta:+.3}",
        var_pt + var_lt
    );
    assert!(beta.abs() < 0.1, "{label}: the light-traced image has {beta} of the mistake's difference");
    assert!(got < 1.5 * (var_pt + var_lt), "{label}: MSE {got} against noise {}", var_pt + var_lt);
    assert!(wrong_off > 3.0 * (var_pt + var_lt), "{label}: the mistake should show: {wrong_off}");
}

/// The path tracer's image at 8192 spp with seed `seed`.
fn pt_image(s: &mut Scene, a: &Accel, seed: u64) -> Image {
    s.render.seed = seed;
    render_path(s, a, 8192, true).image
}

/// Glass (a caustic) and a rough gold panel on a floor under a quad light, seen from (0, 0.9, 2.2) by a
/// camera that `camera` (whole lines) describes beside its place.
fn glass_and_gold_seen_by(camera: &str) -> Scene {
    common::scene(&format!(
        "[camera]\norigin = [0.0, 0.9, 2.2]\ntarget = [0.0, 0.2, 0.0]\n{camera}\
         [materials]\nm = {{ type = \"diffuse\", reflectance = [0.6, 0.6, 0.6] }}\n\
         glass = {{ type = \"dielectric\", ior = 1.5 }}\n\
         gold = {{ type = \"conductor\", preset = \"Au\", roughness = 0.15 }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.5, 0.0, 1.5]\nedge_u = [3.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -3.0]\nmaterial = \"m\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.3, 0.25, 0.6]\nradius = 0.25\nmaterial = \"glass\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.8, 0.05, -0.4]\nedge_u = [0.8, 0.0, 0.0]\nedge_v = [0.0, 0.5, -0.3]\nmaterial = \"gold\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.4, 1.2, -0.4]\nedge_u = [0.8, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.8]\npower = [20.0, 20.0, 20.0]\n\
         [render]\nmax_depth = 5\n[render.progressive]\nradius = 0.02\n",
    ))
}

/// BDPT's and VCM's means equal the path tracer's through a thin lens, every strategy weighted: camera
/// subpaths start at a lens point, light tracing joins a lens point of its own, glass (a caustic) and a
/// rough gold panel in and out of focus.
#[test]
fn bidirectional_means_hold_through_a_thin_lens() {
    let mut s =
        glass_and_gold_seen_by("fov = 40\nresolution = [20, 20]\naperture_radius = 0.15\nfocus_distance = 1.6\n");
    assert_eq!(s.camera.lens_radius, 0.15);
    let a = Accel::new(&s).unwrap();
    means_match_pt("thin lens", &mut s, &a, 256, 1024);
}

/// BDPT's and VCM's means equal the path tracer's through an orthographic camera, every strategy
/// weighted: camera subpaths start on the film with a density per unit area, light tracing joins each
/// light vertex to the film point in front of it; glass (a caustic) and a rough gold panel.
#[test]
fn bidirectional_means_hold_through_an_orthographic_camera() {
    let mut s =
        glass_and_gold_seen_by("projection = \"orthographic\"\nfilm_size = [2.4, 1.8]\nresolution = [20, 15]\n");
    assert_eq!(s.camera.ortho, Some([1.2, 0.9]));
    let a = Accel::new(&s).unwrap();
    means_match_pt("orthographic", &mut s, &a, 256, 1024);
}

/// Light tracing through an orthographic camera lands each light vertex where the parallel ray that
/// sees it starts: the checkerboard it makes must be the path tracer's, where the image of a film 10%
/// wider (a light vertex landing 10% off the film's centre) differs by many times the noise. (A
/// perspective camera's image of the same place would not do: the floor is parallel to the film.)
#[test]
fn light_tracing_lands_where_an_orthographic_camera_looks() {
    let mut s = checkerboard_seen_by("projection = \"orthographic\"\nfilm_size = [1.3, 1.3]\n");
    let a = Accel::new(&s).unwrap();
    let mut wider = checkerboard_seen_by("projection = \"orthographic\"\nfilm_size = [1.43, 1.43]\n");
    let wrong = pt_image(&mut wider, &a, 1);
    light_tracing_matches_pt("orthographic", &mut s, &a, &wrong);
}

/// A crop window of the film (TOML `camera.crop`, Mitsuba's film crop) through a pinhole, a thin lens
/// and an orthographic camera: the path tracer's crop must show what the same pixels of the whole film
/// show (held pixel by pixel to the window of a whole-film render, within 1.5× their noise, where the
/// window one pixel to the right differs by more than 3× it), and light tracing must land in the crop
/// where its camera samples look (`light_tracing_matches_pt`, against the crop one pixel to the right).
#[test]
fn a_crop_window_shows_the_whole_films_pixels_and_light_tracing_lands_in_it() {
    let cameras = [
        ("pinhole", "fov = 50\n"),
        ("thin lens", "fov = 50\naperture_radius = 0.05\nfocus_distance = 1.1\n"),
        ("orthographic", "projection = \"orthographic\"\nfilm_size = [1.3, 1.3]\n"),
    ];
    let window = |img: &Image, [x0, y0, w, h]: [u32; 4]| {
        let mut out = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                out.set(x, y, img.get(x0 + x, y0 + y));
            }
        }
        out
    };
    let sq = |x: &Image, y: &Image| {
        let sum: f64 = x.pixels.iter().zip(&y.pixels).map(|(p, q)| (*p - *q).length_squared() as f64).sum();
        sum / (x.pixels.len() * 3) as f64
    };
    let crop = [5, 3, 12, 14];
    for (label, camera) in cameras {
        let mut whole = checkerboard_seen_by(camera);
        let a = Accel::new(&whole).unwrap();
        let mut cropped = checkerboard_seen_by(&format!("{camera}crop = {crop:?}\n"));
        assert_eq!((cropped.camera.width, cropped.camera.height), (12, 14));
        let (w1, w2) = (pt_image(&mut whole, &a, 1), pt_image(&mut whole, &a, 2));
        let (c1, c2) = (pt_image(&mut cropped, &a, 3), pt_image(&mut cropped, &a, 4));
        let noise = sq(&window(&w1, crop), &window(&w2, crop)) / 2.0 + sq(&c1, &c2) / 2.0;
        let got = sq(&c1, &window(&w1, crop));
        let shifted = sq(&c1, &window(&w1, [crop[0] + 1, crop[1], crop[2], crop[3]]));
        eprintln!("crop, {label}: PT vs the whole film's window MSE {got:.3e}, noise {noise:.3e}; one pixel off {shifted:.3e}");
        assert!(got < 1.5 * noise, "crop, {label}: MSE {got} against the whole film's window, noise {noise}");
        assert!(shifted > 3.0 * noise, "crop, {label}: the shifted window should differ: {shifted}");
        let mut off = checkerboard_seen_by(&format!("{camera}crop = [6, 3, 12, 14]\n"));
        let wrong = pt_image(&mut off, &a, 1);
        light_tracing_matches_pt(&format!("crop, {label}"), &mut cropped, &a, &wrong);
    }
}

/// Light tracing splats through the pixel filter as camera samples are drawn through it: with a
/// Gaussian, a tent and a Mitchell filter (negative lobes) it matches the path tracer's image with the
/// same filter, where splatting as a box would render the box-filtered image.
#[test]
fn light_tracing_splats_through_the_pixel_filter() {
    use caustica::scene::camera::{FilterSpec, PixelFilter};
    let mut s = checkerboard_from_above("");
    let a = Accel::new(&s).unwrap();
    let boxed = pt_image(&mut s, &a, 1);
    for spec in [
        FilterSpec::Gaussian { stddev: 0.5 },
        FilterSpec::Tent { radius: 1.0 },
        FilterSpec::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 },
    ] {
        s.camera.filter = PixelFilter::new(spec);
        light_tracing_matches_pt(&format!("{spec:?}"), &mut s, &a, &boxed);
    }
}

/// Light tracing through a thin lens: each light vertex is joined to a point drawn on the aperture and
/// lands where the line from it through that point crosses the plane of focus. With the floor twice as
/// far as the plane of focus, the blurred checkerboard light tracing makes must be the path tracer's,
/// where the pinhole's sharp image (light joined to the lens's centre) differs by many times the noise.
#[test]
fn light_tracing_sees_through_a_thin_lens() {
    let mut s = checkerboard_from_above("aperture_radius = 0.04\nfocus_distance = 0.6\n");
    let a = Accel::new(&s).unwrap();
    assert_eq!((s.camera.lens_radius, s.camera.focus_distance), (0.04, 0.6));
    s.camera.lens_radius = 0.0;
    let pinhole = pt_image(&mut s, &a, 1);
    s.camera.lens_radius = 0.04;
    light_tracing_matches_pt("thin lens", &mut s, &a, &pinhole);
}

/// Mean luminance of each `b`×`b` block of the average of `passes` iterations.
fn bidir_blocks(s: &Scene, a: &Accel, opts: VcmOptions, passes: u32, b: usize) -> Vec<f64> {
    let setup = Setup::new(s, a, opts, None);
    let (w, h) = (s.camera.width as usize, s.camera.height as usize);
    let mut sum = vec![0.0f64; (w / b) * (h / b)];
    for i in 1..=passes {
        let img = iterate(s, a, &setup, i).image;
        for y in 0..h / b * b {
            for x in 0..w / b * b {
                sum[(y / b) * (w / b) + x / b] += caustica::color::luminance(img.pixels[y * w + x]) as f64;
            }
        }
    }
    sum.iter().map(|v| v / (passes as usize * b * b) as f64).collect()
}

/// A scene with no diffuse surface (a random scene's, found by comparing every mode with the others):
/// a mirror floor, a rough glass block standing on it and seen in it, a rough gold panel, under a
/// constant sky and a point light. Light vertices are kept on the rough glass and gold only; VCM's
/// first merge radius used to spread them over the surfaces that hold photons, of which there are
/// none, and fell back to its cap (0.58 here, against the block's 0.4), so merging blurred the block
/// and its reflection: the worst 8×8 block read 6.1% off BDPT's after 128 iterations (the random
/// scene's, 9.9% above PT's). Every 8×8 block of VCM's image must be BDPT's within 3%.
#[test]
fn vcm_matches_bdpt_where_light_vertices_land_only_on_rough_metal_and_glass() {
    let s = common::scene(
        "[camera]\norigin = [-0.8, 1.2, 4.3]\ntarget = [0.0, 0.4, 0.0]\nfov = 30\nresolution = [48, 32]\n\
         [materials]\nchrome = { type = \"mirror\", specular = [0.9, 0.8, 0.6] }\n\
         frost = { type = \"dielectric\", ior = 1.3, roughness = 0.35 }\n\
         gold = { type = \"conductor\", preset = \"Au\", roughness = 0.2 }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-4.0, 0.0, 4.0]\nedge_u = [8.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -8.0]\nmaterial = \"chrome\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-0.6, 0.3, -0.3]\nmax = [-0.2, 1.0, 0.1]\nmaterial = \"frost\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [0.5, 0.2, -0.4]\nedge_u = [0.5, 0.0, 0.5]\nedge_v = [0.0, 0.8, 0.0]\nmaterial = \"gold\"\n\
         [[lights]]\ntype = \"constant\"\nradiance = [0.33, 0.69, 0.6]\n\
         [[lights]]\ntype = \"point\"\nposition = [-1.0, 2.2, -0.9]\npower = [90.0, 79.0, 50.0]\n\
         [render]\nmax_depth = 3\n",
    );
    let a = Accel::new(&s).unwrap();
    let bdpt = bidir_blocks(&s, &a, VcmOptions::bdpt(), 128, 8);
    let vcm = bidir_blocks(&s, &a, VcmOptions::vcm(), 128, 8);
    let worst = bdpt.iter().zip(&vcm).map(|(b, v)| (v / b - 1.0).abs()).fold(0.0f64, f64::max);
    eprintln!("VCM over BDPT, 8×8 blocks: worst {worst:.4}");
    assert!(worst < 0.03, "a block of VCM's image is {worst} off BDPT's");
}

/// The sun's light reflected by a gold mirror floor onto a small rough glass panel, seen by the camera
/// (another random scene's): only light subpaths find it (light tracing and merging on the panel), and
/// VCM's mean must be BDPT's. With the merge radius at its cap (the panel was the only non-delta
/// surface, and none holds photons) merge discs much wider than the panel read 0.81 of BDPT's mean
/// here over 2048 iterations (7σ; 0.68 in the random scene at 64 × 48 and 128 iterations).
#[test]
fn vcm_keeps_bdpts_mean_on_a_small_rough_panel_lit_through_a_mirror() {
    let mut s = common::scene(
        "[camera]\norigin = [0.7434, 2.027, 3.564]\ntarget = [0.0, 0.4, 0.0]\nfov = 40.35\nresolution = [32, 24]\n\
         [materials]\ngold = { type = \"conductor\", preset = \"Au\" }\n\
         frost = { type = \"dielectric\", ior = 1.45, roughness = 0.28 }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-4.0, 0.0, 4.0]\nedge_u = [8.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -8.0]\nmaterial = \"gold\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, -1.0, 0.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"frost\"\n\
         transform = { matrix = [[0.1768, 0.1612, 0.2880, 0.4854], [-0.0360, 0.3777, -0.1590, 0.767], \
         [-0.2488, 0.0599, 0.2277, 0.6645], [0.0, 0.0, 0.0, 1.0]] }\n\
         [[lights]]\ntype = \"distant\"\ndirection = [-0.75, -1.0, 0.75]\nirradiance = [1.6, 0.9, 1.8]\n\
         [render]\nmax_depth = 8\n",
    );
    let a = Accel::new(&s).unwrap();
    let (b, be) = bidir_mean(&mut s, &a, VcmOptions::bdpt(), 2048);
    let (v, ve) = bidir_mean(&mut s, &a, VcmOptions::vcm(), 2048);
    let sigma = (be * be + ve * ve).sqrt();
    eprintln!("VCM {v:.6} ± {ve:.6}, BDPT {b:.6} ± {be:.6}: {:+.2}σ, ratio {:.4}", (v - b) / sigma, v / b);
    assert!(b > 0.0 && (v - b).abs() < 3.0 * sigma, "VCM {v} against BDPT {b} (σ {sigma})");
}
