//! The planner skips what a scene does not need, says why, and skipping changes nothing in the image.
mod common;
use caustica::accel::Accel;
use caustica::app::{plan_for, render_pm_default};
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
fn a_mirror_no_light_can_reach_is_not_a_target_and_one_plane_has_no_indirect_map() {
    // A mirror ball shut in a box with no light inside; the light is outside above a single plane.
    let text = "[camera]\norigin = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nwhite = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\nchrome = { type = \"mirror\" }\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-2.5, 0.5, 0.0]\nradius = 0.2\nmaterial = \"chrome\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-3.0, 0.0, -0.5]\nmax = [-2.0, 1.0, 0.5]\nmaterial = \"chrome\"\n\
         [[lights]]\ntype = \"point\"\nposition = [1.0, 2.0, 0.0]\npower = [10.0, 10.0, 10.0]\n";
    // The box itself is specular and lit; the ball inside it is not reachable.
    let s = common::scene(text);
    let a = Accel::new(&s).unwrap();
    let plan = plan_for(&s, &a);
    assert_eq!(plan.caustic_targets, vec![1], "{:?}", plan.reasons);
    assert!(plan.reasons.iter().any(|r| r.contains("shapes[0]") && r.contains("no light reaches it")));
    let plane = common::scene(&format!(
        "{}[[shapes]]\ntype = \"quad\"\ncorner = [-5.0, 0.0, -5.0]\nedge_u = [0.0, 0.0, 10.0]\nedge_v = [10.0, 0.0, 0.0]\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"point\"\nposition = [1.0, 2.0, 0.0]\npower = [10.0, 10.0, 10.0]\n",
        text.split("[[shapes]]").next().unwrap()
    ));
    let a = Accel::new(&plane).unwrap();
    let plan = plan_for(&plane, &a);
    assert_eq!(plan.photons[1], 0, "{:?}", plan.reasons);
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
    let reference = caustica::app::render_path(&s, &a, 2048, true).image;
    let full = caustica::app::render_path(&s, &a, 8, true).image;
    s.lights.restrict_nee(|i| plan.nee_lights[i]);
    let planned = caustica::app::render_path(&s, &a, 8, true).image;
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
