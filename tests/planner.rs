//! The planner skips what a scene does not need, says why, and skipping changes nothing in the image.
mod common;
use caustica::accel::Accel;
use caustica::pipeline::{plan_for, render_pm_default};
use caustica::scene::load_scene_with;
use std::path::PathBuf;

fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

const SMALL: [&str; 5] = [
    "camera.resolution=[32, 32]",
    "render.pm_spp=2",
    "render.photons.direct=20000",
    "render.photons.indirect=20000",
    "render.photons.caustic=20000",
];

#[test]
fn diffuse_only_scene_skips_the_caustic_pass_and_the_image_is_unchanged() {
    let mut images = Vec::new();
    for forced in [false, true] {
        let mut sets: Vec<String> = SMALL.map(String::from).to_vec();
        sets.push(format!("render.force_all_passes={forced}"));
        sets.push("render.photons.max_shots_factor=5".into());
        let s = load_scene_with(&scene_path("cornell-box.toml"), &sets).unwrap();
        let a = Accel::new(&s).unwrap();
        let plan = plan_for(&s, &a);
        if !forced {
            assert_eq!(plan.photons, [0, 20000, 0], "{:?}", plan.reasons);
            assert!(plan.caustic_targets.is_empty());
            assert_eq!(plan.specular_spp, 0);
            assert!(plan.reasons.iter().any(|r| r.contains("no caustic map")));
        } else {
            assert!(plan.photons.iter().all(|&p| p > 0));
        }
        images.push(render_pm_default(&s, &a, true).unwrap().image);
    }
    // The forced caustic pass finds nothing to store and the direct map goes unused (shadow rays):
    // the two images are the same, bit for bit.
    assert_eq!(images[0], images[1]);
}

/// Where no surface can hold a photon (every one principled, glossy, a mirror or glass), caustic photons
/// would be traced and never stored: the planner shoots none, and forcing every pass changes no pixel.
#[test]
fn without_a_surface_that_holds_photons_no_caustic_photons_are_shot() {
    let text = |forced: bool| {
        format!(
            "[camera]\norigin = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.3, 0.0]\nresolution = [24, 16]\n\
             [materials]\nsatin = {{ type = \"principled\", base_color = [0.7, 0.3, 0.2], sheen = 0.5 }}\n\
             gold = {{ type = \"principled\", base_color = [0.9, 0.6, 0.3], metallic = 1.0, roughness = 0.3 }}\n\
             [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"satin\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.4, 0.0]\nradius = 0.4\nmaterial = \"gold\"\n\
             [[lights]]\ntype = \"point\"\nposition = [1.0, 2.0, 1.0]\npower = [30.0, 30.0, 30.0]\n\
             [render]\npm_spp = 2\nforce_all_passes = {forced}\n\
             [render.photons]\ndirect = 5000\nindirect = 5000\ncaustic = 5000\n"
        )
    };
    let mut images = Vec::new();
    for forced in [false, true] {
        let s = common::scene(&text(forced));
        let a = Accel::new(&s).unwrap();
        let plan = plan_for(&s, &a);
        if !forced {
            assert_eq!(plan.photons, [0, 0, 0], "{:?}", plan.reasons);
            assert!(plan.reasons.iter().any(|r| r.contains("no surface holds photons")), "{:?}", plan.reasons);
        }
        images.push(render_pm_default(&s, &a, true).unwrap().image);
    }
    assert_eq!(images[0], images[1]);
    assert!(images[0].pixels.iter().any(|p| p.x > 0.0), "the eye pass finds the light");
}

/// At `render.max_depth` 1 a photon can only be counted where it first lands (one event: the gather),
/// so no indirect or caustic photon (a bounce before its gather) can ever be stored: the planner shoots
/// none, and forcing every pass changes no pixel. Before, the glass box at max_depth 1 shot its whole
/// budget (50 per requested photon) for two maps that stayed empty, and warned about it.
#[test]
fn at_max_depth_1_no_bounced_photons_are_shot() {
    let mut images = Vec::new();
    for forced in [false, true] {
        let sets = [
            "camera.resolution=[24, 24]".to_string(),
            "render.max_depth=1".into(),
            "render.photons.indirect=2000".into(),
            "render.photons.caustic=2000".into(),
            format!("render.force_all_passes={forced}"),
        ];
        let s = load_scene_with(&scene_path("cornell-glass.toml"), &sets).unwrap();
        let a = Accel::new(&s).unwrap();
        let plan = plan_for(&s, &a);
        if !forced {
            assert_eq!(plan.photons[1..], [0, 0], "{:?}", plan.reasons);
            assert!(plan.reasons.iter().any(|r| r.contains("render.max_depth")), "{:?}", plan.reasons);
        }
        images.push(render_pm_default(&s, &a, true).unwrap().image);
    }
    assert_eq!(images[0], images[1]);
    assert!(images[0].pixels.iter().any(|p| p.x > 0.0), "direct light and the light itself show");
}

#[test]
fn glass_box_targets_both_balls_and_samples_them_more() {
    let s = load_scene_with(&scene_path("cornell-glass.toml"), &SMALL.map(String::from)).unwrap();
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    let names: Vec<&str> = plan.caustic_targets.iter().map(|&i| s.shapes[i as usize].name.as_str()).collect();
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(plan.photons[2] > 0 && plan.specular_spp > 0);
}

#[test]
fn only_a_mirror_every_light_faces_away_from_is_not_a_target() {
    // Occlusion proves nothing (a probe can miss a gap); only geometry does: the quad light faces
    // down, so the mirror ball above it is provably dark and the one below is a target.
    let text = "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nchrome = { type = \"mirror\" }\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 3.0, 0.0]\nradius = 0.2\nmaterial = \"chrome\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.5, 0.0]\nradius = 0.2\nmaterial = \"chrome\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.5, 2.0, -0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\npower = [10.0, 10.0, 10.0]\n";
    let s = common::scene(text);
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    assert_eq!(plan.caustic_targets, vec![1], "{:?}", plan.reasons);
    assert!(plan.reasons.iter().any(|r| r.contains("shapes[0]") && r.contains("faces away")), "{:?}", plan.reasons);
}

/// A spot's cone is a proof of darkness too: a spot straight down (cutoff 20°) from 2 m above the floor
/// misses a mirror ball (radius 0.2) 1.5 m to the side: its centre lies 39.8° from the axis, more than
/// the cutoff plus the ball's angular radius (4.9°); moved to 0.8 m (24.0° against 20° + 5.8°) the cone
/// reaches it and it is a target.
#[test]
fn a_mirror_outside_every_spots_cone_is_not_a_target() {
    let plan_with_ball_at = |x: f32| {
        let text = format!(
            "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
             [materials]\nchrome = {{ type = \"mirror\" }}\nwhite = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
             [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, -3.0]\nedge_u = [0.0, 0.0, 6.0]\nedge_v = [6.0, 0.0, 0.0]\nmaterial = \"white\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [{x}, 0.2, 0.0]\nradius = 0.2\nmaterial = \"chrome\"\n\
             [[lights]]\ntype = \"spot\"\nposition = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [5.0, 5.0, 5.0]\ncutoff_angle = 20.0\n"
        );
        let s = common::scene(&text);
        let a = Accel::new(&s).unwrap();
        plan_for(&s, &a)
    };
    let far = plan_with_ball_at(1.5);
    assert!(far.caustic_targets.is_empty(), "{:?}", far.reasons);
    assert!(far.reasons.iter().any(|r| r.contains("shapes[1]") && r.contains("cone elsewhere")), "{:?}", far.reasons);
    let near = plan_with_ball_at(0.8);
    assert_eq!(near.caustic_targets, vec![1], "{:?}", near.reasons);
}

/// A closed room (inward walls, ρ = 0.6) with a 4 cm × 4 cm hole in its ceiling, a 2 m × 2 m quad light
/// a metre above facing down, a mirror ball under the hole and a camera inside looking at the floor.
/// About one light–ball segment in a thousand passes the hole.
fn room_with_a_gap() -> String {
    let mut t = String::from(
        "[camera]\norigin = [0.0, 1.0, 0.9]\ntarget = [0.0, 0.0, 0.0]\nfov = 70\nresolution = [24, 24]\n\
         [materials]\nwhite = { type = \"diffuse\", reflectance = [0.6, 0.6, 0.6] }\nchrome = { type = \"mirror\" }\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.3, 0.0]\nradius = 0.3\nmaterial = \"chrome\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-1.0, 3.0, -1.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 2.0]\npower = [200.0, 200.0, 200.0]\n",
    );
    // Walls and floor of the box [-1, 1] × [0, 2] × [-1, 1]; the ceiling in four pieces round the hole.
    let quads = [
        ([-1.0, 0.0, -1.0], [0.0, 0.0, 2.0], [2.0, 0.0, 0.0]),
        ([-1.0, 0.0, -1.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        ([-1.0, 0.0, 1.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0]),
        ([-1.0, 0.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
        ([1.0, 0.0, -1.0], [0.0, 0.0, 2.0], [0.0, 2.0, 0.0]),
        ([-1.0, 2.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 0.98]),
        ([-1.0, 2.0, 0.02], [2.0, 0.0, 0.0], [0.0, 0.0, 0.98]),
        ([-1.0, 2.0, -0.02], [0.98, 0.0, 0.0], [0.0, 0.0, 0.04]),
        ([0.02, 2.0, -0.02], [0.98, 0.0, 0.0], [0.0, 0.0, 0.04]),
    ];
    for (c, u, v) in quads {
        t += &format!(
            "[[shapes]]\ntype = \"quad\"\ncorner = {c:?}\nedge_u = {u:?}\nedge_v = {v:?}\nmaterial = \"white\"\n"
        );
    }
    t
}

#[test]
fn a_mirror_lit_through_a_small_gap_keeps_its_caustic() {
    // 256 random light–mirror pairs once decided the mirror was unlit and its caustic vanished.
    let mut s = common::scene(&room_with_a_gap());
    s.render.photons.caustic = 20_000;
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    assert!(plan.caustic_targets.contains(&0), "{:?}", plan.reasons);
    assert!(plan.photons[2] > 0, "{:?}", plan.reasons);
    let (maps, _) = caustica::pipeline::render_pm(&s, &a, &plan, true).unwrap();
    let caustic = maps.maps[2].as_ref().expect("a caustic map");
    assert!(caustic.total_power().x > 0.0 && caustic.len() > 100, "caustic map: {} photons", caustic.len());
}

fn pm_mean(s: &caustica::scene::Scene, a: &Accel) -> f64 {
    mean(&render_pm_default(s, a, true).unwrap().image)
}

fn mean(img: &caustica::film::Image) -> f64 {
    img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64
}

#[test]
fn one_plane_and_a_mirror_ball_keep_the_indirect_map() {
    // Light goes floor → ball → floor (L D S D): the planner once dropped the indirect map because the
    // floor is the only diffuse surface (planned/forced mean 0.970).
    let text = "[camera]\norigin = [0.0, 2.0, 2.5]\ntarget = [0.0, 0.2, 0.0]\nresolution = [32, 32]\n\
         [materials]\nwhite = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\nchrome = { type = \"mirror\" }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.5, 0.0]\nradius = 0.5\nmaterial = \"chrome\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [0.8, 1.5, -0.3]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\npower = [20.0, 20.0, 20.0]\n\
         [render]\npm_spp = 16\nphotons = { indirect = 200000, caustic = 200000 }\n";
    let mut s = common::scene(text);
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    assert!(plan.photons[1] > 0, "{:?}", plan.reasons);
    let planned = pm_mean(&s, &a);
    s.render.force_all_passes = true;
    let forced = pm_mean(&s, &a);
    eprintln!("floor + mirror ball: planned/forced mean {:.4}", planned / forced);
    assert!((planned / forced - 1.0).abs() < 0.01, "planned/forced mean {}", planned / forced);
}

/// Means of the path tracer and the photon mapper with every light sampled and with the planner's
/// next-event selection applied, as `caustica render` does.
fn culled_vs_unculled(text: &str) -> ([f64; 2], [f64; 2], Vec<bool>) {
    let mut s = common::scene(text);
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    let all = [mean(&caustica::pipeline::render_path(&s, &a, 256, true).image), pm_mean(&s, &a)];
    s.lights.restrict_nee(|i| plan.nee_lights[i]);
    let planned = [mean(&caustica::pipeline::render_path(&s, &a, 256, true).image), pm_mean(&s, &a)];
    (all, planned, plan.nee_lights)
}

/// PT and PM each keep their mean (2%) when the planner's light selection is applied.
fn assert_same_means(all: [f64; 2], planned: [f64; 2]) {
    for m in 0..2 {
        assert!(
            all[m] > 0.0 && (planned[m] / all[m] - 1.0).abs() < 0.02,
            "{} planned {} vs {}",
            ["PT", "PM"][m],
            planned[m],
            all[m]
        );
    }
}

#[test]
fn a_point_light_the_camera_sees_only_by_its_bounce_is_not_culled() {
    // A point light shielded from below lights only the ceiling, which the camera does not see; the
    // floor in view is lit by the ceiling alone. Culling it once rendered the image black.
    let text = "[camera]\norigin = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40\nresolution = [16, 16]\n\
         [materials]\nwhite = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 2.0, -2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 4.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-0.2, 1.70, -0.2]\nmax = [0.2, 1.75, 0.2]\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 1.8, 0.0]\npower = [50.0, 50.0, 50.0]\n\
         [render]\npm_spp = 4\nphotons = { indirect = 100000 }\n";
    let (all, planned, keep) = culled_vs_unculled(text);
    eprintln!(
        "ceiling-bounce point light: PT {:.5} vs {:.5}, PM {:.5} vs {:.5}",
        all[0], planned[0], all[1], planned[1]
    );
    assert!(keep.iter().all(|&k| k), "a point light was left out");
    assert_same_means(all, planned);
}

#[test]
fn an_area_light_seen_only_in_a_mirror_keeps_its_light_when_left_out_of_nee() {
    // The camera sees a 45° mirror and, in it, a wall lit by a quad light; no diffuse point in direct
    // view is lit, so the planner leaves the light out of the path tracer's NEE (BSDF sampling with MIS
    // still finds it) and the photon mapper's eye pass, which has no MIS, must still sample it.
    let text = "[camera]\norigin = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, -1.0]\nfov = 20\nresolution = [16, 16]\n\
         [materials]\nwhite = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\nchrome = { type = \"mirror\" }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, -1.0, -3.0]\nedge_u = [2.0, 0.0, 2.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"chrome\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, -2.0, -4.0]\nedge_u = [0.0, 4.0, 0.0]\nedge_v = [0.0, 0.0, 4.0]\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-2.5, 1.5, -2.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\npower = [30.0, 30.0, 30.0]\n\
         [render]\npm_spp = 4\n";
    let (all, planned, keep) = culled_vs_unculled(text);
    eprintln!("light seen via a mirror: PT {:.5} vs {:.5}, PM {:.5} vs {:.5}", all[0], planned[0], all[1], planned[1]);
    assert!(keep.iter().any(|&k| !k), "the planner kept the light: nothing was tested");
    assert_same_means(all, planned);
}

#[test]
fn a_light_shut_in_a_box_is_left_out_of_direct_light_sampling_without_changing_the_image() {
    // One light over the floor, an equally strong one sealed inside a box: NEE samples spent on the
    // second are wasted. The plan leaves it out; the image keeps its mean and loses noise.
    let text = "[camera]\norigin = [0.0, 2.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [24, 24]\n\
        [materials]\nwhite = { type = \"diffuse\", reflectance = [0.6, 0.6, 0.6] }\n\
        [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"white\"\n\
        [[shapes]]\ntype = \"box\"\nmin = [5.0, 0.0, -1.0]\nmax = [7.0, 2.0, 1.0]\nmaterial = \"white\"\n\
        [[lights]]\ntype = \"quad\"\ncorner = [-0.5, 1.5, -0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\npower = [10.0, 10.0, 10.0]\n\
        [[lights]]\ntype = \"sphere\"\ncenter = [6.0, 1.0, 0.0]\nradius = 0.3\npower = [10.0, 10.0, 10.0]\n";
    let mut s = common::scene(text);
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    let sphere =
        s.lights.list.iter().position(|l| matches!(l, caustica::scene::light::LightKind::Sphere { .. })).unwrap();
    assert!(!plan.nee_lights[sphere], "{:?}", plan.reasons);
    assert!(plan.nee_lights.iter().enumerate().all(|(i, &k)| k || i == sphere));
    assert!(plan.reasons.iter().any(|r| r.contains("lights[1]") && r.contains("left out")), "{:?}", plan.reasons);
    let reference = caustica::pipeline::render_path(&s, &a, 2048, true).image;
    let full = caustica::pipeline::render_path(&s, &a, 8, true).image;
    s.lights.restrict_nee(|i| plan.nee_lights[i]);
    let planned = caustica::pipeline::render_path(&s, &a, 8, true).image;
    let (ef, ep) = (
        caustica::metrics::compare(&full, &reference).unwrap(),
        caustica::metrics::compare(&planned, &reference).unwrap(),
    );
    eprintln!(
        "RMSE at 8 spp: all lights sampled {:.5}, planned {:.5}; mean ratios {:.4} {:.4}",
        ef.rmse, ep.rmse, ef.mean_ratio, ep.mean_ratio
    );
    assert!((ep.mean_ratio - 1.0).abs() < 0.02, "planned image mean {}", ep.mean_ratio);
    assert!(ep.rmse < ef.rmse, "planned {} vs all lights {}", ep.rmse, ef.rmse);
}

/// A normal- or bump-mapped diffuse surface scatters as a diffuse one does, about its mapped normal: it
/// holds photons, a photon bounced there is an indirect one and a camera path ends there. It casts no
/// caustic, so it is no caustic target (aimed photons that land on it are wasted: on `bumpmap.xml` fixed
/// PM's caustic pass shot its whole budget, 25M, for 274,626 of 500,000 photons, most of its aim going to
/// the bumped floor), and the camera seeing it takes no extra eye samples (each would gather again where
/// one gather is the estimate).
#[test]
fn a_bump_mapped_diffuse_surface_is_no_caustic_target() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba/bumpmap.xml");
    let s = load_scene_with(&path, &[]).unwrap();
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    // Shapes 0 and 5 (the floor and the card) are bump-mapped diffuse; 2, 3 and 4 a rough gold ball, a
    // brushed silver cube and a plastic tile, each under a bump map too.
    let names = |ids: &[u32]| ids.iter().map(|&i| s.shapes[i as usize].name.clone()).collect::<Vec<_>>();
    assert_eq!(plan.caustic_targets, vec![2, 3, 4], "targets {:?}", names(&plan.caustic_targets));

    // A bumped diffuse floor under a box and a quad light: nothing casts a caustic and nothing the camera
    // sees is specular.
    let height = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba/height.png");
    let text = format!(
        "[camera]\norigin = [0.0, 2.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [24, 24]\n\
         [textures]\nh = {{ type = \"bitmap\", file = \"{}\", raw = true }}\n\
         [materials]\nwhite = {{ type = \"diffuse\", reflectance = [0.6, 0.6, 0.6] }}\n\
         bumped = {{ type = \"bumpmap\", height = \"h\", scale = 0.1, material = \"white\" }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"bumped\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-0.4, 0.0, -0.4]\nmax = [0.4, 0.8, 0.4]\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-0.5, 2.0, -0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\npower = [10.0, 10.0, 10.0]\n",
        height.display()
    );
    let s = common::scene(&text);
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    assert!(plan.caustic_targets.is_empty(), "targets {:?}: {:?}", plan.caustic_targets, plan.reasons);
    assert_eq!(plan.photons[2], 0, "{:?}", plan.reasons);
    assert_eq!(plan.specular_spp, 0, "{:?}", plan.reasons);
    assert!(plan.photons[1] > 0, "the floor and the box light each other: {:?}", plan.reasons);
}
