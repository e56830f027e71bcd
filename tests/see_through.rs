//! See-through surfaces (a `null` surface, the holes of a mask: a blend with `null`) let light by as if
//! they were not there, in every mode: shadow rays cross them, weighed by what they let through
//! (Mitsuba's `volpath` does so; its `path` stops shadow rays at them), and paths cross them as no
//! scattering event, so `render.max_depth` does not count them. Held to closed forms: under a point
//! light a floor in the shadow of a mask of opacity w (a black diffuse sphere with holes) receives
//! (1 − w)² of its light (two crossings), all of it behind a null sphere; at max_depth 1 a floor seen
//! through a null pane is lit as without the pane.
use caustica::accel::Accel;
use caustica::film::Image;
use caustica::pipeline::{plan_for, render_layers};
use caustica::scene::{load_scene_str, Scene};
use glam::Vec3;
use std::path::Path;

/// Every mode with the settings that keep its noise in these small images under the bounds below.
const MODES: [(&str, &[&str]); 6] = [
    ("path", &["render.spp=64"]),
    ("bdpt", &["render.progressive.passes=64"]),
    ("vcm", &["render.progressive.passes=64"]),
    ("sppm", &["render.progressive.passes=32", "render.progressive.photons_per_pass=20000"]),
    ("ppm", &["render.progressive.passes=32", "render.progressive.photons_per_pass=20000"]),
    ("photon_map", &["render.pm_spp=16"]),
];

const SPHERE_CENTER: Vec3 = Vec3::new(0.0, 1.0, 0.0);
const SPHERE_RADIUS: f32 = 0.4;

/// A grey floor under a light (`light`: TOML), seen from low in front, with `extra` (TOML shapes and
/// materials sections appended).
fn floor_scene(light: &str, extra: &str) -> String {
    format!(
        "[camera]\norigin = [0.0, 0.8, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40\nresolution = [32, 24]\n\
         [materials]\ngrey = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         black = {{ type = \"diffuse\", reflectance = [0.0, 0.0, 0.0] }}\n\
         holes = {{ type = \"null\" }}\n\
         half = {{ type = \"blend\", weight = 0.5, first = \"holes\", second = \"black\" }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"grey\"\n\
         {light}{extra}"
    )
}

fn sphere(material: &str) -> String {
    let c = SPHERE_CENTER;
    format!(
        "[[shapes]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {SPHERE_RADIUS}\nmaterial = \"{material}\"\n",
        c.x, c.y, c.z
    )
}

const POINT_LIGHT: &str = "[[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\npower = [20.0, 20.0, 20.0]\n";

fn load(text: &str, mode: &str, sets: &[&str]) -> Scene {
    let mut all = vec![format!("render.mode=\"{mode}\"")];
    all.extend(sets.iter().map(|s| s.to_string()));
    load_scene_str(text, "see-through.toml", Path::new(env!("CARGO_MANIFEST_DIR")), &all)
        .unwrap_or_else(|e| panic!("{e}"))
}

fn render(scene: &Scene) -> Image {
    let accel = Accel::new(scene).unwrap();
    let plan = plan_for(scene, &accel);
    let layers = render_layers(scene, &accel, &plan, &serde_json::json!({}), 0.0, None, true).unwrap();
    layers[0].sums.image()
}

/// Whether the ray from `o` along unit `d` passes within `r` of `c`.
fn passes_near(o: Vec3, d: Vec3, c: Vec3, r: f32) -> bool {
    let t = (c - o).dot(d).max(0.0);
    (o + d * t - c).length() < r
}

/// The pixels whose centre sees the floor at a distance from the light's foot in `range`, without the
/// camera ray passing near the sphere: in the sphere's shadow core (radius 0.87 on the floor) or well
/// outside it.
fn floor_pixels(scene: &Scene, range: std::ops::Range<f32>) -> Vec<bool> {
    let cam = &scene.camera;
    let mut keep = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let ray = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let d = ray.d.normalize();
            let hit = if d.y < 0.0 { Some(ray.o + d * (-ray.o.y / d.y)) } else { None };
            keep.push(hit.is_some_and(|p| {
                let r = (p.x * p.x + p.z * p.z).sqrt();
                range.contains(&r)
                    && p.x.abs() < 1.9
                    && p.z.abs() < 1.9
                    && !passes_near(ray.o, d, SPHERE_CENTER, SPHERE_RADIUS + 0.1)
            }));
        }
    }
    keep
}

fn sum(img: &Image, keep: &[bool]) -> f64 {
    img.pixels.iter().zip(keep).filter(|(_, k)| **k).map(|(p, _)| (p.x + p.y + p.z) as f64).sum()
}

/// Under a point light, a null sphere (w = 0) casts no shadow and a black mask of opacity 0.5 lets a
/// quarter of the light through to its shadow's core (it is crossed twice, on the way in and out).
/// The floor's light is direct only (what it sends up is absorbed by the mask or leaves), so in each
/// mode the core's sum over the plain floor's is (1 − w)², the floor outside the shadow unchanged.
/// Before, shadow rays stopped at any surface: the path tracer's core was black behind both, and so
/// was every photon mapper's behind the mask (their direct light is a shadow ray).
#[test]
fn a_point_lights_shadow_through_null_and_masked_spheres_is_the_closed_form() {
    let mut failures = Vec::new();
    for (mode, sets) in MODES {
        let plain = load(&floor_scene(POINT_LIGHT, ""), mode, sets);
        let core = floor_pixels(&plain, 0.0..0.5);
        let lit = floor_pixels(&plain, 1.1..2.0);
        assert!(core.iter().filter(|k| **k).count() >= 20 && lit.iter().filter(|k| **k).count() >= 50);
        let base = render(&plain);
        for (material, expected) in [("holes", 1.0), ("half", 0.25)] {
            let img = render(&load(&floor_scene(POINT_LIGHT, &sphere(material)), mode, sets));
            let in_core = sum(&img, &core) / sum(&base, &core);
            let outside = sum(&img, &lit) / sum(&base, &lit);
            println!("{mode}, {material}: shadow core {in_core:.4} of the plain floor's (expected {expected}), outside {outside:.4}");
            if (in_core / expected - 1.0).abs() > 0.03 || (outside - 1.0).abs() > 0.03 {
                failures
                    .push(format!("{mode} {material}: core {in_core:.4} (expected {expected}), outside {outside:.4}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A null pane between the camera and the floor is no bounce: at `render.max_depth` 1 (direct light
/// only) the floor seen through it is lit as without it, in every mode. Before, the crossing used up
/// the one scattering event, and the floor behind the pane was black in the path tracer.
#[test]
fn a_null_pane_is_no_bounce_for_max_depth() {
    let pane = "[[shapes]]\ntype = \"quad\"\ncorner = [-3.0, -1.0, 2.2]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 4.0, 0.0]\nmaterial = \"holes\"\n";
    let mut failures = Vec::new();
    for (mode, sets) in MODES {
        let mut sets = sets.to_vec();
        sets.push("render.max_depth=1");
        let plain = load(&floor_scene(POINT_LIGHT, ""), mode, &sets);
        let all = vec![true; (plain.camera.width * plain.camera.height) as usize];
        let base = render(&plain);
        let img = render(&load(&floor_scene(POINT_LIGHT, pane), mode, &sets));
        let ratio = sum(&img, &all) / sum(&base, &all);
        println!("{mode}: max_depth 1 through a null pane: {ratio:.4} of the plain floor's");
        if (ratio - 1.0).abs() > 0.02 {
            failures.push(format!("{mode}: {ratio:.4}"));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Under an area light the light reaching the floor through a see-through surface is found twice, by a
/// light sample whose shadow ray crosses it and by a BSDF sample that crosses it and meets the light:
/// the MIS weights must add up to one with the crossing counted as no vertex. A null sphere leaves the
/// image as it was (an MIS weight of 1 for the BSDF sample, as after a delta bounce, would add the
/// light again), and each mode's mean under a black mask of opacity 0.5 is the path tracer's.
#[test]
fn an_area_light_through_see_through_spheres_is_counted_once() {
    let quad = "[[lights]]\ntype = \"quad\"\ncorner = [-0.5, 2.0, -0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\npower = [20.0, 20.0, 20.0]\n";
    let mut failures = Vec::new();
    let mut pt_half = 0.0;
    for (mode, sets) in MODES {
        let mut sets = sets.to_vec();
        if mode == "path" {
            sets = vec!["render.spp=1024"];
        }
        let plain = load(&floor_scene(quad, ""), mode, &sets);
        let all = vec![true; (plain.camera.width * plain.camera.height) as usize];
        let base = sum(&render(&plain), &all);
        let null = sum(&render(&load(&floor_scene(quad, &sphere("holes")), mode, &sets)), &all) / base;
        let half = sum(&render(&load(&floor_scene(quad, &sphere("half")), mode, &sets)), &all) / base;
        if mode == "path" {
            pt_half = half;
        }
        let of_pt = half / pt_half;
        println!("{mode}: null sphere {null:.4} of the plain scene; mask 0.5 {half:.4} ({of_pt:.4} of PT's)");
        if (null - 1.0).abs() > 0.02 || (of_pt - 1.0).abs() > 0.02 {
            failures.push(format!("{mode}: null {null:.4}, mask {half:.4} ({of_pt:.4} of PT's)"));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}
