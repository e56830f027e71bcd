//! See-through surfaces (a `null` surface, the holes of a mask: a blend with `null`, a thin pane's
//! straight transmission) let light straight through in every mode: shadow rays cross them, weighed by
//! what they let through (Mitsuba's `volpath` does so; its `path` stops shadow rays at them), and paths
//! cross them as no scattering event, so `render.max_depth` does not count them. Held to closed forms:
//! under a point light a floor in the shadow of a mask of opacity w (a black diffuse sphere with
//! holes) receives (1 − w)² of its light (two crossings), all of it behind a null sphere, (1 − R')²
//! behind thin glass; at max_depth 1 a floor seen through a pane is lit as without it, times what the
//! pane lets through.
mod common;
use caustica::film::Image;
use caustica::scene::Scene;
use common::{render_image as render, scene_in_mode as load};
use glam::Vec3;

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
         pane = {{ type = \"thin_dielectric\", ior = 1.5 }}\n\
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
            keep.push(floor_point(scene, x, y).is_some_and(|p| {
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

/// A thin pane's reflectance (both faces, every bounce between: 2R/(1 + R)) for unpolarised light at
/// cosine `cos` to its normal, index 1.5.
fn pane_reflectance(cos: f64) -> f64 {
    let eta = 1.5f64;
    let cos_t = (1.0 - (1.0 - cos * cos) / (eta * eta)).sqrt();
    let rs = (cos - eta * cos_t) / (cos + eta * cos_t);
    let rp = (eta * cos - cos_t) / (eta * cos + cos_t);
    let r = 0.5 * (rs * rs + rp * rp);
    2.0 * r / (1.0 + r)
}

/// What the see-through shape `case` lets through from the light at `light` to floor point `p`:
/// crossing the null sphere 1, the mask sphere (1 − 0.5)² (twice), a square of thin glass 1 − R' at
/// the segment's angle to it (once), 1 where the segment misses the shape.
fn expected_transmittance(case: &str, p: Vec3, light: Vec3) -> f64 {
    let d = (light - p).normalize();
    if let Some((c, u, v)) = pane_frame(case) {
        let n = u.cross(v);
        let q = p + d * (n.dot(c - p) / n.dot(d));
        let inside = (q - c).dot(u).abs() < 0.5 && (q - c).dot(v).abs() < 0.5;
        return if inside { 1.0 - pane_reflectance(n.dot(d).abs() as f64) } else { 1.0 };
    }
    let t = (SPHERE_CENTER - p).dot(d);
    if (p + d * t - SPHERE_CENTER).length() >= SPHERE_RADIUS {
        return 1.0;
    }
    match case {
        "holes" => 1.0,
        "half" => 0.25,
        _ => unreachable!(),
    }
}

/// A unit square of thin glass between the light and the floor's centre: its centre and unit edges.
/// `pane` lies flat (the light's segments cross it near its normal), `tilted` is turned 60° about z
/// (they cross it at about 60° from its normal, where R' is twice what it is straight on).
fn pane_frame(case: &str) -> Option<(Vec3, Vec3, Vec3)> {
    let c = Vec3::new(0.0, 1.0, 0.0);
    let a = 60f32.to_radians();
    match case {
        "pane" => Some((c, Vec3::X, Vec3::Z)),
        "tilted" => Some((c, Vec3::new(a.cos(), -a.sin(), 0.0), Vec3::Z)),
        _ => None,
    }
}

/// The see-through shape of each closed-form case: a null sphere, a black mask sphere of opacity 0.5,
/// a flat or a tilted square of thin glass (index 1.5).
fn see_through_shape(case: &str) -> String {
    match pane_frame(case) {
        Some((c, u, v)) => {
            let corner = c - 0.5 * u - 0.5 * v;
            format!(
                "[[shapes]]\ntype = \"quad\"\ncorner = [{}, {}, {}]\nedge_u = [{}, {}, {}]\nedge_v = [{}, {}, {}]\n\
                 material = \"pane\"\n",
                corner.x, corner.y, corner.z, u.x, u.y, u.z, v.x, v.y, v.z
            )
        }
        None => sphere(case),
    }
}

/// The floor point pixel (x, y) of `scene`'s camera sees at its centre (where its ray meets y = 0).
fn floor_point(scene: &Scene, x: u32, y: u32) -> Option<Vec3> {
    let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
    let d = ray.d.normalize();
    (d.y < 0.0).then(|| ray.o + d * (-ray.o.y / d.y))
}

fn sum(img: &Image, keep: &[bool]) -> f64 {
    img.pixels.iter().zip(keep).filter(|(_, k)| **k).map(|(p, _)| (p.x + p.y + p.z) as f64).sum()
}

/// Under a point light, a null sphere (w = 0) casts no shadow, a black mask of opacity 0.5 lets a
/// quarter of the light through to its shadow's core (it is crossed twice, on the way in and out), and
/// a horizontal square of thin glass lets 1 − R' through at each segment's angle (0.923 straight down),
/// as Mitsuba's `volpath` renders them. The floor's light is direct only (what it sends up is absorbed
/// by the mask, leaves, or comes back off the glass: under 1%), so in each mode the core's sum over
/// the plain floor's is the closed form's (per pixel, at its centre), and the floor outside the
/// spheres' shadows is unchanged. Before, shadow rays stopped at any surface: the path tracer's core
/// was black behind all three, the photon mappers' behind the mask (their direct light is a shadow
/// ray).
#[test]
fn a_point_lights_shadow_through_see_through_surfaces_is_the_closed_form() {
    let light = Vec3::new(0.0, 2.0, 0.0);
    let mut failures = Vec::new();
    for (mode, sets) in MODES {
        let plain = load(&floor_scene(POINT_LIGHT, ""), mode, sets);
        let w = plain.camera.width;
        let core = floor_pixels(&plain, 0.0..0.5);
        let lit = floor_pixels(&plain, 1.1..2.0);
        assert!(core.iter().filter(|k| **k).count() >= 20 && lit.iter().filter(|k| **k).count() >= 50);
        let base = render(&plain);
        for case in ["holes", "half", "pane", "tilted"] {
            let mut expected = 0.0;
            for (i, _) in core.iter().enumerate().filter(|(_, k)| **k) {
                let p = floor_point(&plain, i as u32 % w, i as u32 / w).unwrap();
                let px = base.pixels[i];
                expected += (px.x + px.y + px.z) as f64 * expected_transmittance(case, p, light);
            }
            expected /= sum(&base, &core);
            let img = render(&load(&floor_scene(POINT_LIGHT, &see_through_shape(case)), mode, sets));
            let in_core = sum(&img, &core) / sum(&base, &core);
            let outside = sum(&img, &lit) / sum(&base, &lit);
            println!(
                "{mode}, {case}: core {in_core:.4} of the plain floor's (expected {expected:.4}), outside {outside:.4}"
            );
            // The squares' shadows reach into the ring `lit`: only their core is held.
            let outside_off = pane_frame(case).is_none() && (outside - 1.0).abs() > 0.03;
            if (in_core / expected - 1.0).abs() > 0.03 || outside_off {
                failures
                    .push(format!("{mode} {case}: core {in_core:.4} (expected {expected:.4}), outside {outside:.4}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A thin glass sphere under a point light: light crosses its near face straight, and part of it is
/// mirrored around inside (at the same angle at every hit, R' growing towards grazing) before it
/// leaves, some of it onto the floor below, a caustic a path tracer cannot find from a point light
/// (its core reads the straight transmission, 0.848 of the plain floor's). Light tracing finds it: an
/// independent ray simulation of the sphere (internal mirror bounces summed) gives 0.965 for the
/// disc of radius 0.5, BDPT 0.970 at 2,048 passes and 0.964 at 64. The photon mappers' caustic
/// photons are aimed at the sphere; each must count the light whose first interaction is its aimed
/// point, so one aimed at the far face is dropped when it meets the near face first, as at opaque
/// targets. Before (aimed photons crossed the near face to their point), the light behind the near
/// face was counted twice: SPPM 1.094, PPM 1.081, fixed PM 1.083 of the plain floor's core.
#[test]
fn a_thin_glass_spheres_caustic_is_counted_once() {
    let mut cores = Vec::new();
    for (mode, sets) in MODES.iter().skip(1) {
        let plain = load(&floor_scene(POINT_LIGHT, ""), mode, sets);
        let core = floor_pixels(&plain, 0.0..0.5);
        let base = render(&plain);
        let img = render(&load(&floor_scene(POINT_LIGHT, &sphere("pane")), mode, sets));
        let in_core = sum(&img, &core) / sum(&base, &core);
        println!("{mode}: thin glass sphere, core {in_core:.4} of the plain floor's");
        cores.push((mode, in_core));
    }
    let bdpt = cores[0].1;
    assert!((bdpt - 0.965).abs() < 0.02, "BDPT's core {bdpt:.4} against the simulation's 0.965");
    let off: Vec<_> = cores.iter().filter(|(_, c)| (c / bdpt - 1.0).abs() > 0.03).collect();
    assert!(off.is_empty(), "modes off BDPT's {bdpt:.4}: {off:?}");
}

/// A null pane or a thin glass pane between the camera and the floor is no bounce where it lets light
/// straight through: at `render.max_depth` 1 (direct light only) the floor seen through it is lit as
/// without it, times what the pane lets through at the camera ray's angle (1, or 1 − R' for the glass,
/// whose reflection shows only the dark behind the camera), in every mode. Before, the crossing used
/// up the one scattering event, and the floor behind either pane was black in the path tracer.
#[test]
fn a_pane_crossed_straight_is_no_bounce_for_max_depth() {
    let mut failures = Vec::new();
    for (mode, sets) in MODES {
        let mut sets = sets.to_vec();
        sets.push("render.max_depth=1");
        let plain = load(&floor_scene(POINT_LIGHT, ""), mode, &sets);
        let w = plain.camera.width;
        let all = vec![true; base_len(&plain)];
        let base = render(&plain);
        for material in ["holes", "pane"] {
            let pane = format!(
                "[[shapes]]\ntype = \"quad\"\ncorner = [-3.0, -1.0, 2.2]\nedge_u = [6.0, 0.0, 0.0]\n\
                 edge_v = [0.0, 4.0, 0.0]\nmaterial = \"{material}\"\n"
            );
            // Each pixel's light through the pane, at its centre ray's angle to the pane's normal (z).
            let mut expected = 0.0;
            for (i, px) in base.pixels.iter().enumerate() {
                let d = plain.camera.ray((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5).d.normalize();
                let t = if material == "pane" { 1.0 - pane_reflectance(d.z.abs() as f64) } else { 1.0 };
                expected += (px.x + px.y + px.z) as f64 * t;
            }
            expected /= sum(&base, &all);
            let img = render(&load(&floor_scene(POINT_LIGHT, &pane), mode, &sets));
            let ratio = sum(&img, &all) / sum(&base, &all);
            println!("{mode}: max_depth 1 through a {material} pane: {ratio:.4} of the plain floor's (expected {expected:.4})");
            if (ratio / expected - 1.0).abs() > 0.02 {
                failures.push(format!("{mode} {material}: {ratio:.4} (expected {expected:.4})"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

fn base_len(scene: &Scene) -> usize {
    (scene.camera.width * scene.camera.height) as usize
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
        let all = vec![true; base_len(&plain)];
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
