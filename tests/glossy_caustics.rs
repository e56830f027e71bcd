//! Caustics of point, spot and distant lights on glossy surfaces. Photons are stored on diffuse
//! surfaces (and a plastic's base) only; the photon mappers' eye passes follow a camera ray through a
//! glossy lobe (rough metal or glass, a principled surface, a rough plastic's coat) by sampling, with a
//! light sample there. A point light's light that reaches the glossy surface through glass reaches
//! neither: the light sample is blocked by the glass and a sampled direction never finds a point. The
//! caustic pass therefore light-traces such photons to the camera from the glossy surface they land
//! on (when every bounce before was a mirror or glass); BDPT's light tracing is the reference. Where
//! the camera sees the glossy surface past a mirror or glass, light tracing cannot link it to the
//! camera (nor can BDPT): the caustic pass keeps those photons, and the camera chain's first glossy hit
//! past a mirror or glass gathers them; an unfolded scene without the mirror is the reference.
mod common;
use caustica::film::Image;
use caustica::scene::Scene;
use common::{render_image as render, scene_in_mode as load};

/// A 1.5 glass ball 0.8 above a floor of material `floor` (a 4 × 4 square), under `light` (TOML),
/// seen from above and in front, where a glossy floor sends the caustic below the ball towards the
/// camera; `extra` is appended (TOML).
fn scene(floor: &str, light: &str, ball: &str, extra: &str) -> String {
    format!(
        "[camera]\norigin = [0.0, 2.5, 2.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40\nresolution = [32, 24]\n\
         [materials]\nglass = {{ type = \"dielectric\", ior = 1.5 }}\n\
         metal = {{ type = \"conductor\", eta = [0.2, 0.9, 1.1], k = [3.9, 2.4, 2.2], roughness = 0.35, distribution = \"ggx\" }}\n\
         coat = {{ type = \"plastic\", reflectance = [0.3, 0.3, 0.3], ior = 1.5, roughness = 0.2 }}\n\
         grey = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"{floor}\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.8, 0.0]\nradius = 0.3\nmaterial = \"{ball}\"\n\
         {light}{extra}"
    )
}

const POINT: &str = "[[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\npower = [30.0, 30.0, 30.0]\n";

/// Sum over the pixels whose centre sees the floor within `r` of the point below the ball (the
/// caustic), and over the whole image.
fn sums(scene: &Scene, img: &Image, r: f32) -> (f64, f64) {
    let cam = &scene.camera;
    let (mut near, mut all) = (0.0, 0.0);
    for (i, p) in img.pixels.iter().enumerate() {
        let v = (p.x + p.y + p.z) as f64;
        all += v;
        let ray = cam.ray((i as u32 % cam.width) as f32 + 0.5, (i as u32 / cam.width) as f32 + 0.5);
        let d = ray.d.normalize();
        if d.y < 0.0 {
            let q = ray.o + d * (-ray.o.y / d.y);
            if (q.x * q.x + q.z * q.z).sqrt() < r {
                near += v;
            }
        }
    }
    (near, all)
}

/// The caustic region's radius on the floor: the focused spot below the ball (about 0.1 across) with
/// what fixed PM's k nearest photons blur of it into the base of the plastic floor.
const REGION: f32 = 0.4;

const PHOTON_MODES: [(&str, &[&str]); 4] = [
    ("sppm", &["render.progressive.passes=64", "render.progressive.photons_per_pass=20000"]),
    ("ppm", &["render.progressive.passes=64", "render.progressive.photons_per_pass=20000"]),
    ("photon_map", &["render.pm_spp=32", "render.photons.caustic=400000"]),
    ("vcm", &["render.progressive.passes=256"]),
];

/// A glass ball's caustic under a point light on a rough metal floor (no surface in the scene holds
/// photons: before, the planner traced no caustic photons at all) and on a rough plastic floor (its
/// base holds the caustic photons, its coat reflects the caustic too): every photon mode's sum over
/// the caustic region and over the image is BDPT's. Before, the photon mappers left the caustic out
/// of both floors' glossy reflection.
#[test]
fn a_point_lights_caustic_on_a_glossy_floor_is_in_every_mode() {
    let mut failures = Vec::new();
    for floor in ["metal", "coat"] {
        let text = scene(floor, POINT, "glass", "");
        let bdpt_scene = load(&text, "bdpt", &["render.progressive.passes=1024"]);
        let (ref_near, ref_all) = sums(&bdpt_scene, &render(&bdpt_scene), REGION);
        let plain = load(&scene(floor, POINT, "grey", ""), "bdpt", &["render.progressive.passes=256"]);
        let (plain_near, _) = sums(&plain, &render(&plain), REGION);
        println!("{floor}: BDPT caustic region {ref_near:.3} (a grey ball there instead: {plain_near:.3})");
        assert!(ref_near > 2.0 * plain_near, "no caustic to speak of on the {floor} floor");
        for (mode, sets) in PHOTON_MODES {
            let s = load(&text, mode, sets);
            let (near, all) = sums(&s, &render(&s), REGION);
            let (a, b) = (near / ref_near, all / ref_all);
            println!("{floor}, {mode}: caustic region {a:.4} of BDPT's, image {b:.4}");
            if (a - 1.0).abs() > 0.05 || (b - 1.0).abs() > 0.03 {
                failures.push(format!("{floor} {mode}: caustic {a:.4}, image {b:.4} of BDPT's"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Light tracing must add only what the eye passes cannot find. Under a small area light a camera ray
/// leaving the rough floor finds the light through the ball by sampling (the path tracer renders the
/// caustic), and under the point light a rough metal ball's light on the floor is found by a light
/// sample at the ball: in both every photon mode's image is the path tracer's (a splat after a glossy
/// bounce, or of an area light's photons, would count that light twice).
#[test]
fn glossy_caustics_the_eye_passes_find_are_counted_once() {
    let quad = "[[lights]]\ntype = \"quad\"\ncorner = [-0.15, 2.0, -0.15]\nedge_u = [0.3, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.3]\npower = [30.0, 30.0, 30.0]\n";
    let mut failures = Vec::new();
    for (case, text) in [
        ("area light, glass ball", scene("metal", quad, "glass", "")),
        ("point light, metal ball", scene("metal", POINT, "metal", "")),
    ] {
        let pt = load(&text, "path", &["render.spp=4096"]);
        let (_, ref_all) = sums(&pt, &render(&pt), REGION);
        for (mode, sets) in PHOTON_MODES {
            let s = load(&text, mode, sets);
            let (_, all) = sums(&s, &render(&s), REGION);
            println!("{case}, {mode}: image {:.4} of PT's", all / ref_all);
            if (all / ref_all - 1.0).abs() > 0.03 {
                failures.push(format!("{case} {mode}: {:.4} of PT's", all / ref_all));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// The caustic on the rough metal floor lights a rough metal wall behind the ball, which the camera
/// sees (L S G G E): a camera chain from the wall reaches the floor by sampling, but its light sample
/// there meets the glass, so the photons first bounced by the glass are light-traced from every glossy
/// surface they reach until a diffuse bounce, not only from the first. Every photon mode's sum over the
/// wall is BDPT's within 1.5%: light-traced from the first glossy surface only (this session's first
/// version), the wall read 0.977 / 0.972 / 0.978 of BDPT's in SPPM, PPM and fixed PM (then 1.0005 /
/// 0.9952 / 0.9980; since session 51, the wall seen through the ball left out of the sum, 1.0045 /
/// 1.0050 / 0.9980, VCM 1.0009: with it, VCM read 1.0111 of BDPT's, which misses the light there).
#[test]
fn a_glossy_surface_lit_by_a_glossy_caustic_is_in_every_mode() {
    let wall = "[[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -0.8]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"satin\"\n";
    let text = |ball: &str| {
        scene("metal", POINT, ball, wall).replacen(
            "[[shapes]]",
            "satin = { type = \"conductor\", preset = \"Al\", roughness = 0.6 }\n[[shapes]]",
            1,
        )
    };
    // Pixels whose centre sees the ball are left out: there the camera sees the wall through the
    // glass, and the caustic's light on it (camera, glass, wall, glass, light) is what BDPT cannot find
    // (the photon mappers gather it since session 51: `a_point_lights_light_via_a_mirror_on_glossy_walls_seen_in_the_mirror`).
    let on_wall = |s: &Scene, img: &Image| {
        let cam = &s.camera;
        let mut sum = 0.0;
        for (i, p) in img.pixels.iter().enumerate() {
            let ray = cam.ray((i as u32 % cam.width) as f32 + 0.5, (i as u32 / cam.width) as f32 + 0.5);
            let d = ray.d.normalize();
            let oc = ray.o - glam::Vec3::new(0.0, 0.8, 0.0);
            let b = oc.dot(d);
            if b * b - (oc.length_squared() - 0.3 * 0.3) > 0.0 {
                continue;
            }
            let t = (-0.8 - ray.o.z) / d.z;
            let q = ray.o + d * t;
            if t > 0.0 && q.y > 0.05 && q.y < 2.0 && q.x.abs() < 2.0 {
                sum += (p.x + p.y + p.z) as f64;
            }
        }
        sum
    };
    let bdpt = load(&text("glass"), "bdpt", &["render.progressive.passes=1024"]);
    let reference = on_wall(&bdpt, &render(&bdpt));
    let mut failures = Vec::new();
    for (mode, sets) in PHOTON_MODES {
        let s = load(&text("glass"), mode, sets);
        let ratio = on_wall(&s, &render(&s)) / reference;
        println!("wall, {mode}: {ratio:.4} of BDPT's");
        if (ratio - 1.0).abs() > 0.015 {
            failures.push(format!("{mode}: {ratio:.4} of BDPT's"));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A rough gold mirror wall and a blue principled wall on a perfect mirror floor under a point light
/// (`scenes/glossy-mirror.toml`), their light as the mirror shows it compared with an exact reference
/// without a mirror, as `normal_map.rs` does for mapped walls: the point light's light that reaches a
/// glossy wall by the mirror and is seen in the mirror (camera, mirror, wall, mirror, light) is found by
/// no camera path's samples, by no light sample and by no light path's link to the camera (the camera
/// sees the wall only in the mirror); only photons kept on the glossy walls and gathered at the first
/// glossy hit of a camera chain past a mirror reach it. The reference
/// (`scenes/glossy-mirror-unfolded.toml`) unfolds the scene about the mirror's plane: the walls' images
/// below the plane, the light's image, no floor; the path tracer renders it with light samples alone.
/// Every photon mode's mean and each quarter of the image must be the reference's (BDPT cannot find
/// that light, VCM merges it).
#[test]
fn a_point_lights_light_via_a_mirror_on_glossy_walls_seen_in_the_mirror() {
    common::assert_matches_unfolded(
        include_str!("scenes/glossy-mirror.toml"),
        include_str!("scenes/glossy-mirror-unfolded.toml"),
        &[
            ("sppm", &["render.progressive.passes=128"]),
            ("ppm", &["render.progressive.passes=128"]),
            ("photon_map", &["render.photons.caustic=200000", "render.pm_spp=64"]),
            ("vcm", &["render.progressive.passes=128"]),
        ],
    );
}
