//! Lights at infinity: a constant sky is a furnace for a convex diffuse object (every point sees the
//! whole sky over its hemisphere, so L = ρ·L_env, in PT and PM); one bright texel lights a plane like a
//! distant light, and a `distant` light follows Lambert's law (1e-3); the photons a sky or a distant
//! light sends carry the flux that crosses the object (E = π L_env, or E cos θ, on every element);
//! photons aimed at glass keep the caustic power of uniform emission.
mod common;

use caustica::accel::Accel;
use caustica::integrator::photon_map::{build_maps, MapRequest};
use caustica::photon::trace::{CAUSTIC, DIRECT};
use caustica::pipeline::{plan_for, render_path, render_pm};

const SKY: &str = "[camera]\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\nresolution = [32, 32]\n\
                   [[lights]]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n";

/// Every pixel whose centre sees the sphere (a disc well inside its silhouette) and every pixel of
/// pure sky, as (on sphere, value).
fn sphere_and_sky(img: &caustica::film::Image) -> Vec<(bool, f32)> {
    let (w, h) = (img.width as i32, img.height as i32);
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x - w / 2, y - h / 2);
            let p = img.pixels[(y * w + x) as usize].x;
            if dx * dx + dy * dy <= 25 {
                out.push((true, p));
            } else if dx * dx + dy * dy >= 15 * 15 {
                out.push((false, p));
            }
        }
    }
    out
}

#[test]
fn a_diffuse_sphere_under_a_constant_sky_has_radiance_albedo_times_sky_in_pt_and_pm() {
    // Convex: every point of the sphere sees the sky over its whole hemisphere and nothing else.
    let scene = common::scene(&format!(
        "{SKY}[materials]\nm = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.6\nmaterial = \"m\"\n\
         [render]\npm_spp = 512\nspecular_spp = 0\n[render.photons]\ndirect = 0\ncaustic = 0\nindirect = 1000\n"
    ));
    let accel = Accel::new(&scene).unwrap();
    let pt = render_path(&scene, &accel, 1024, true).image;
    let pm = render_pm(&scene, &accel, &plan_for(&scene, &accel), true).unwrap().1.image;
    for (name, img) in [("PT", &pt), ("PM", &pm)] {
        let px = sphere_and_sky(img);
        let worst = px.iter().filter(|p| p.0).map(|p| (p.1 - 0.5).abs()).fold(0.0, f32::max);
        eprintln!("{name}: worst sphere pixel off 0.5 by {worst}");
        assert!(worst < 0.005, "{name}: a sphere pixel is {worst} off 0.5 (1% allowed)");
        assert!(px.iter().filter(|p| !p.0).all(|p| (p.1 - 1.0).abs() < 1e-6), "{name}: sky pixels are not 1");
    }
}

#[test]
fn one_bright_texel_lights_a_plane_like_a_distant_light() {
    // A black 64×32 sky with one texel of radiance V: it covers ΔΩ = (2π/W)(π/(H − 1)) sin θ (Mitsuba's
    // rows run pole to pole) and lights an upward plane like a distant light of irradiance V ΔΩ cos θ.
    let (w, h, tx, ty, v) = (64usize, 32usize, 20usize, 9usize, 500.0f32);
    let dir = std::env::temp_dir().join(format!("caustica-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sky = dir.join("one-texel.exr");
    let mut img = caustica::film::Image::new(w as u32, h as u32);
    img.set(tx as u32, ty as u32, glam::Vec3::splat(v));
    caustica::output::write_exr(&sky, &img).unwrap();
    let theta = ty as f32 / (h - 1) as f32 * std::f32::consts::PI;
    let e = v
        * (2.0 * std::f32::consts::PI / w as f32)
        * (std::f32::consts::PI / (h - 1) as f32)
        * theta.sin()
        * theta.cos();
    let want = 0.5 / std::f32::consts::PI * e;
    let scene = caustica::scene::load_scene_str(
        &format!(
            "[camera]\norigin = [0.0, 3.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 20.0\nresolution = [16, 16]\n\
             [materials]\nm = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
             [[shapes]]\ntype = \"quad\"\ncorner = [-50.0, 0.0, 50.0]\nedge_u = [100.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -100.0]\nmaterial = \"m\"\n\
             [[lights]]\ntype = \"envmap\"\nfile = \"{}\"\n",
            sky.display()
        ),
        "one-texel.toml",
        &dir,
        &[],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let accel = Accel::new(&scene).unwrap();
    let out = render_path(&scene, &accel, 256, true).image;
    let mean = out.pixels.iter().map(|p| p.x as f64).sum::<f64>() / out.pixels.len() as f64;
    eprintln!("plane under one texel: {mean} (distant light: {want})");
    assert!((mean as f32 / want - 1.0).abs() < 0.02, "{mean} vs {want}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn sky_photons_carry_the_flux_that_crosses_the_object_and_targeting_keeps_it() {
    // A sphere of radius r under a sky of radiance 1 receives E = π on every element: Φ = 4π² r².
    let r = 0.6f32;
    let sphere = format!(
        "{SKY}[materials]\nm = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         glass = {{ type = \"dielectric\", ior = 1.5 }}\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = {r}\nmaterial = \"m\"\n"
    );
    let req = |targeted| MapRequest { want: [200_000, 0, 100_000], targeted, targets: None, ..Default::default() };
    let scene = common::scene(&sphere);
    let accel = Accel::new(&scene).unwrap();
    let direct = build_maps(&scene, &accel, &req(false), true).unwrap().maps[DIRECT].as_ref().unwrap().total_power().x;
    let want = 4.0 * std::f32::consts::PI.powi(2) * r * r;
    eprintln!("sky flux onto the sphere: {direct} of {want}");
    assert!((direct / want - 1.0).abs() < 0.01, "{direct} of {want}");
    // A glass ball above it focuses sky light onto it: aimed and uniform emission agree on that caustic.
    let scene = common::scene(&format!(
        "{sphere}[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 0.3\nmaterial = \"glass\"\n"
    ));
    let accel = Accel::new(&scene).unwrap();
    let caustic =
        |t| build_maps(&scene, &accel, &req(t), true).unwrap().maps[CAUSTIC].as_ref().unwrap().total_power().x;
    let (uniform, aimed) = (caustic(false), caustic(true));
    eprintln!("sky caustic through the glass ball: uniform {uniform}, aimed {aimed}");
    assert!((aimed / uniform - 1.0).abs() < 0.03, "caustic power aimed {aimed} vs uniform {uniform}");
}

#[test]
fn a_distant_light_follows_lamberts_law_and_its_photons_carry_e_cos_area() {
    // A 2 × 2 diffuse plane, ρ = 0.5, under parallel light of irradiance 3 at 60° from its normal:
    // L = ρ/π · E cos 60° everywhere, and the plane receives E cos 60° · 4 of flux.
    let scene = common::scene(
        "[camera]\norigin = [0.0, 3.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 20.0\nresolution = [16, 16]\n\
         [materials]\nm = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
         glass = { type = \"dielectric\", ior = 1.5 }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, 0.0, 1.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -2.0]\nmaterial = \"m\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.6, 0.5, 0.6]\nradius = 0.2\nmaterial = \"glass\"\n\
         [[lights]]\ntype = \"distant\"\ndirection = [0.8660254, -0.5, 0.0]\nirradiance = [3.0, 3.0, 3.0]\n",
    );
    let accel = Accel::new(&scene).unwrap();
    let img = render_path(&scene, &accel, 16, true).image;
    let want = 0.5 / std::f32::consts::PI * 3.0 * 0.5;
    // The camera looks straight down at the middle of the plane, away from the glass ball's shadow.
    let centre = img.pixels[(8 * img.width + 8) as usize].x;
    eprintln!("distant light: centre pixel {centre}, Lambert {want}");
    assert!((centre / want - 1.0).abs() < 1e-3, "{centre} vs {want}");
    let req = |targeted| MapRequest { want: [200_000, 0, 50_000], targeted, targets: None, ..Default::default() };
    let uniform = build_maps(&scene, &accel, &req(false), true).unwrap();
    let direct = uniform.maps[DIRECT].as_ref().unwrap().total_power().x;
    let caustic = uniform.maps[CAUSTIC].as_ref().unwrap().total_power().x;
    let aimed = build_maps(&scene, &accel, &req(true), true).unwrap().maps[CAUSTIC].as_ref().unwrap().total_power().x;
    eprintln!("distant light flux: direct {direct} + caustic {caustic} of about 6 (the ball shades a little); aimed caustic {aimed}");
    assert!(direct + caustic > 0.97 * 6.0 && direct + caustic < 1.02 * 6.0, "{direct} + {caustic}");
    assert!((aimed / caustic - 1.0).abs() < 0.03, "aimed {aimed} vs uniform {caustic}");
}

/// The photon mappers' direct light under a sky (`DirectStrategy::LightAndBsdf`: a light sample and a BSDF
/// sample, MIS-weighted) against a light sample alone (`LightOnly`, what they used before), at one
/// point of a floor under tests/mitsuba/sky.exr (a small bright sun over a smooth sky) and a quad
/// light: the same mean (within 4σ) and under half the variance. A BSDF half left unweighted (or
/// weighted twice) moves the mean; one that never finds the sky leaves the variance where it was.
#[test]
fn direct_light_under_a_sky_takes_a_bsdf_sample_too() {
    use caustica::integrator::direct::{estimate_direct, DirectStrategy};
    use caustica::integrator::Counters;
    use caustica::math::Rng;
    use glam::Vec3;
    let scene = common::scene(
        "[camera]\norigin = [0.0, 2.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [materials]\nm = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-20.0, 0.0, 20.0]\nedge_u = [40.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -40.0]\nmaterial = \"m\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [0.5, 1.5, -0.5]\nedge_u = [0.5, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.5]\npower = [4.0, 4.0, 4.0]\n\
         [[lights]]\ntype = \"envmap\"\nfile = \"tests/mitsuba/sky.exr\"\n",
    );
    let accel = Accel::new(&scene).unwrap();
    let si = common::surface_at(Vec3::ZERO, Vec3::Y);
    let n = 400_000u64;
    let stats = |both: bool| {
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let mut rng = Rng::new(5, both as u64, i);
            let mut c = Counters::default();
            let strategy = if both { DirectStrategy::LightAndBsdf } else { DirectStrategy::LightOnly };
            let l = estimate_direct(&scene, &accel, &si, Vec3::Y, &mut rng, &mut c, strategy);
            let v = caustica::color::luminance(l) as f64;
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        (mean, s2 / n as f64 - mean * mean)
    };
    let (m_light, v_light) = stats(false);
    let (m_both, v_both) = stats(true);
    let sigma = ((v_light + v_both) / n as f64).sqrt();
    eprintln!(
        "light sample alone: mean {m_light:.5}, variance {v_light:.5}; with a BSDF sample: {m_both:.5}, {v_both:.5}"
    );
    assert!((m_both - m_light).abs() < 4.0 * sigma, "means {m_both} vs {m_light} (σ {sigma})");
    assert!(v_both < 0.5 * v_light, "variance {v_both} against {v_light}");
}

/// A square pane (z = 0, facets facing +z) filling the view of a camera on the z axis, under a constant
/// sky of radiance 1, its vertex normals tilted `tilt` degrees towards +x (the facets stay flat).
fn tilted_pane_under_sky(tilt: f32, material: &str, dir: &std::path::Path) -> String {
    let (s, c) = tilt.to_radians().sin_cos();
    let obj = dir.join(format!("pane-{tilt}.obj"));
    std::fs::write(
        &obj,
        format!("v -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0\nvn {s} 0 {c}\nf 1//1 2//1 3//1\nf 1//1 3//1 4//1\n"),
    )
    .unwrap();
    format!(
        "{SKY}[materials]\nm = {material}\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"{}\"\nsmooth = true\nmaterial = \"m\"\n",
        obj.display()
    )
}

#[test]
fn a_reflection_the_shading_normal_sends_below_the_facet_carries_the_sky_in_every_mode() {
    // Mitsuba 3 and pbrt-v4 take a BSDF sample by the shading normal alone: a reflection that leaves
    // below the facet goes on through it. A lone pane under a sky of radiance 1 then reads ρ (diffuse,
    // every direction sees the sky), 1 (a white mirror) and R + T = 1 (a thin pane) whatever the tilt.
    // Ending those samples instead loses (1 − cos 30°)/2 = 6.7% of the diffuse pane's cosine lobe, and
    // all of the mirror tilted 50° (its reflection of the view along the normal leaves 10° below).
    let dir = std::env::temp_dir().join(format!("caustica-pane-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        ("diffuse", 30.0, "{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }", 0.5),
        ("one-sided diffuse", 30.0, "{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5], two_sided = false }", 0.5),
        ("mirror", 50.0, "{ type = \"mirror\" }", 1.0),
        ("thin glass", 50.0, "{ type = \"thin_dielectric\", ior = 1.5 }", 1.0),
    ];
    let modes: [(&str, &[&str]); 7] = [
        ("path", &["render.spp=64"]),
        ("photon_map", &["render.pm_spp=64", "render.specular_spp=0"]),
        // Direct light from a million photons: the weights |l·ns|/|l·ng| of grazing photons have a long
        // tail, and at the default 200,000 this image's mean strays 1% from seed to seed.
        (
            "photon_map",
            &[
                "render.pm_spp=64",
                "render.specular_spp=0",
                "render.direct_light=\"photon_map\"",
                "render.photons.direct=1000000",
            ],
        ),
        ("sppm", &["render.progressive.passes=16"]),
        ("ppm", &["render.progressive.passes=16"]),
        ("bdpt", &["render.progressive.passes=32"]),
        ("vcm", &["render.progressive.passes=32"]),
    ];
    let mut failed = Vec::new();
    for (name, tilt, material, want) in cases {
        let text = tilted_pane_under_sky(tilt, material, &dir);
        for (mode, sets) in modes {
            let img = common::render_image(&common::scene_in_mode(&text, mode, sets));
            let mean = img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64;
            eprintln!("{name} pane tilted {tilt}°, {mode} {sets:?}: mean {mean:.4} (want {want})");
            if (mean / want - 1.0).abs() > 0.01 {
                failed.push(format!("{name}, {mode} {sets:?}: {mean:.4} against {want}"));
            }
        }
    }
    let _ = std::fs::remove_dir_all(dir);
    assert!(failed.is_empty(), "{failed:#?}");
}
