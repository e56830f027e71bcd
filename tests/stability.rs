//! Numerical stability: robust ray offsets at any scene scale (the dragon scaled by 1e-4 … 1e4 and moved
//! by 1e5), grazing rays, total internal reflection, glass under water, thin sheets, lights touching
//! surfaces, a camera inside glass, degenerate triangles, extreme light powers, and a NaN/Inf guard
//! over every bundled scene in both modes.
mod common;
use caustica::accel::{Accel, Tracer};
use caustica::film::Image;
use caustica::math::{sampling, Frame, Rng};
use caustica::metrics::compare;
use caustica::pipeline::{render_path, render_pm_default};
use caustica::scene::light::{LightKind, PointLight};
use caustica::scene::{load_scene_with, Geometry, Lights, Scene};
use glam::Vec3;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn dragon_available() -> bool {
    let p = root().join("assets/dragon_vrip.ply.gz");
    assert!(p.exists(), "the Stanford Dragon is missing: run scripts/fetch-dragon (scripts/test does)");
    true
}

/// The same scene with every position mapped p → s·p + t (lights keep their look: point-light power ×s²).
fn transformed(mut scene: Scene, s: f32, t: Vec3) -> Scene {
    for sh in &mut scene.shapes {
        match &mut sh.geometry {
            Geometry::Mesh(m) => m.positions.iter_mut().for_each(|p| *p = *p * s + t),
            Geometry::Sphere { center, radius, .. } => {
                *center = *center * s + t;
                *radius *= s;
            }
        }
    }
    let points: Vec<PointLight> = scene
        .lights
        .list
        .iter()
        .filter_map(|l| match l {
            LightKind::Point { position, intensity, spot } => {
                Some(PointLight { position: *position * s + t, intensity: *intensity * s * s, spot: *spot })
            }
            _ => None,
        })
        .collect();
    scene.camera.origin = scene.camera.origin * s + t;
    scene.bounds = (scene.bounds.0 * s + t, scene.bounds.1 * s + t);
    scene.lights = Lights::build(&scene, &points, &[], None);
    scene
}

fn render(scene: &Scene, spp: u32, seed: u64) -> Image {
    let mut s = Scene { render: scene.render.clone(), ..clone_scene(scene) };
    s.render.seed = seed;
    let a = Accel::new(&s).unwrap();
    let out = render_path(&s, &a, spp, true);
    assert_eq!(out.counters.nonfinite, 0);
    out.image
}

fn clone_scene(s: &Scene) -> Scene {
    Scene {
        path: s.path.clone(),
        camera: s.camera.clone(),
        materials: s.materials.clone(),
        material_names: s.material_names.clone(),
        textures: s.textures.clone(),
        shapes: s.shapes.clone(),
        lights: s.lights.clone(),
        render: s.render.clone(),
        bounds: s.bounds,
        load_seconds: 0.0,
        see_through: s.see_through.clone(),
        absorption: s.absorption.clone(),
        boundary: s.boundary.clone(),
        point_media: s.point_media.clone(),
        scattering: s.scattering.clone(),
        see_through_media: s.see_through_media,
        warnings: s.warnings.clone(),
    }
}

/// Fraction of rays leaving sampled dragon points (both sides) that hit their own triangle again.
fn self_hit_rate(scene: &Scene, accel: &Accel, shape: usize) -> f64 {
    let Geometry::Mesh(m) = &scene.shapes[shape].geometry else { panic!("not a mesh") };
    let mut rng = Rng::new(4, 0, 0);
    let n = 50_000;
    let mut bad = 0;
    for i in 0..n {
        let prim = (rng.next_u32() as usize) % m.indices.len();
        let [a, b, c] = m.triangle(prim);
        let bc = sampling::uniform_triangle(rng.next_2d());
        let p = a * (1.0 - bc[0] - bc[1]) + b * bc[0] + c * bc[1];
        let ng = (b - a).cross(c - a).normalize_or_zero();
        if ng == Vec3::ZERO {
            continue;
        }
        let side = if i % 2 == 0 { ng } else { -ng };
        let w = Frame::from_normal(side).to_world(sampling::cosine_hemisphere(rng.next_2d()));
        let si = caustica::scene::SurfaceHit {
            p,
            ng,
            ns: ng,
            shape: shape as u32,
            prim: prim as u32,
            scale: (b - a).length().max((c - a).length()),
            uv: glam::Vec2::ZERO,
        };
        if let Some(h) = accel.intersect(&si.spawn(w)) {
            bad += (h.shape == shape as u32 && h.prim == prim as u32) as usize;
        }
    }
    bad as f64 / n as f64
}

#[test]
fn dragon_renders_the_same_at_every_scale_and_offset() {
    assert!(dragon_available());
    let sets = ["camera.resolution=[40, 40]"].map(String::from);
    let unit = load_scene_with(&root().join("scenes/dragon.toml"), &sets).unwrap();
    let dragon = unit.shapes.iter().position(|s| s.primitive_count() > 1000).unwrap();
    let spp = 64;
    let a = render(&unit, spp, 1);
    let b = render(&unit, spp, 2);
    // Clamped to the display range: fireflies in the glass would otherwise swamp every difference.
    let clamp =
        |i: &Image| Image { pixels: i.pixels.iter().map(|p| p.clamp(Vec3::ZERO, Vec3::ONE)).collect(), ..i.clone() };
    let (a, b) = (clamp(&a), clamp(&b));
    let noise = compare(&a, &b).unwrap().rmse;
    for (s, t) in [(1e-4f32, Vec3::ZERO), (1.0, Vec3::ZERO), (1e4, Vec3::ZERO), (1e4, Vec3::splat(1e5))] {
        let scene = transformed(clone_scene(&unit), s, t);
        let accel = Accel::new(&scene).unwrap();
        let rate = self_hit_rate(&scene, &accel, dragon);
        let img = clamp(&render(&scene, spp, 2));
        // Against the unit render with other random numbers: as far apart as two unit renders are.
        let e = compare(&img, &a).unwrap();
        // Against the unit render with the same random numbers: only rounding makes paths diverge.
        let same = compare(&img, &b).unwrap();
        eprintln!(
            "scale {s:e}, offset {}: self-intersections {rate:.2e}, RMSE vs unit {:.5} (noise {noise:.5}); same seed: RMSE {:.5}, mean ratio {:.4}",
            t.x, e.rmse, same.rmse, same.mean_ratio
        );
        assert!(rate <= 1e-4, "scale {s}: {rate} of spawned rays hit their own triangle");
        assert!(e.rmse <= 1.2 * noise, "scale {s}, offset {t}: RMSE {} against unit-scale noise {noise}", e.rmse);
        // Same random numbers: closer to the unit render than an independent render is.
        assert!(same.rmse < noise, "scale {s}: same-seed RMSE {} not below the noise {noise}", same.rmse);
        // …and as bright: lost or doubled light (offsets too large or too small) shifts the mean.
        assert!(
            (same.mean_ratio - 1.0).abs() < 0.05,
            "scale {s}: mean ratio {} against the unit render",
            same.mean_ratio
        );
    }
}

fn scene_text(body: &str) -> String {
    format!("[camera]\norigin = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.3, 0.0]\nfov = 50\nresolution = [24, 24]\n[materials]\nwhite = {{ type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }}\nglass = {{ type = \"dielectric\", ior = 1.5 }}\nmirror = {{ type = \"mirror\" }}\n[render]\nspp = 8\npm_spp = 2\n[render.photons]\ndirect = 5000\nindirect = 5000\ncaustic = 5000\n{body}")
}

/// Renders a scene both ways; every pixel finite and non-negative, no non-finite sample; returns the means.
fn both_finite(text: &str) -> (Vec3, Vec3) {
    let scene = common::scene(text);
    let accel = Accel::new(&scene).unwrap();
    let pt = render_path(&scene, &accel, scene.render.spp, true);
    let pm = render_pm_default(&scene, &accel, true).unwrap();
    for (name, out) in [("path", &pt), ("photon map", &pm)] {
        assert_eq!(out.counters.nonfinite, 0, "{name}: non-finite samples");
        assert!(out.image.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0), "{name}: bad pixel");
    }
    (pt.image.mean(), pm.image.mean())
}

const FLOOR: &str = "[[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"white\"\n";
const LIGHT: &str = "[[lights]]\ntype = \"quad\"\ncorner = [-0.3, 1.8, -0.3]\nedge_u = [0.6, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\npower = [20.0, 20.0, 20.0]\n";

#[test]
fn hostile_geometry_and_lights_stay_finite() {
    let cases = [
        // Grazing: the camera looks along the floor.
        format!("{FLOOR}{LIGHT}").replace("origin = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.3, 0.0]", "origin = [0.0, 1e-6, 3.0]\ntarget = [0.0, 0.0, -3.0]"),
        // Thin glass sheet (1e-5 thick) over the floor.
        format!("{FLOOR}{LIGHT}[[shapes]]\ntype = \"box\"\nmin = [-0.5, 0.5, -0.5]\nmax = [0.5, 0.50001, 0.5]\nmaterial = \"glass\"\n"),
        // A sphere light resting on the floor, and a quad light lying on it.
        format!("{FLOOR}[[lights]]\ntype = \"sphere\"\ncenter = [0.0, 0.2, 0.0]\nradius = 0.2\npower = [10.0, 10.0, 10.0]\n[[lights]]\ntype = \"quad\"\ncorner = [0.5, 0.0, 0.5]\nedge_u = [0.2, 0.0, 0.0]\nedge_v = [0.0, 0.0, -0.2]\npower = [5.0, 5.0, 5.0]\n"),
        // The camera inside a glass ball.
        format!("{FLOOR}{LIGHT}[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 3.0]\nradius = 0.5\nmaterial = \"glass\"\n"),
        // Glass ball under water (relative index 1.5/1.33).
        format!("{FLOOR}{LIGHT}[materials.inwater]\ntype = \"dielectric\"\nior = 1.5\noutside_ior = 1.33\n[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.3, 0.0]\nradius = 0.3\nmaterial = \"inwater\"\n").replace("[render]", "[render.x]").replace("[render.x]", "[render]"),
        // Mirror box around everything but the camera: long specular chains.
        format!("{FLOOR}{LIGHT}[[shapes]]\ntype = \"sphere\"\ncenter = [0.6, 0.3, 0.0]\nradius = 0.3\nmaterial = \"mirror\"\n[[shapes]]\ntype = \"sphere\"\ncenter = [-0.6, 0.3, 0.0]\nradius = 0.3\nmaterial = \"mirror\"\n"),
    ];
    for c in &cases {
        both_finite(&scene_text(c));
    }
}

#[test]
fn degenerate_triangles_and_duplicate_vertices_are_harmless() {
    let dir = std::env::temp_dir().join(format!("caustica-stab-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A zero-area triangle, a sliver, a duplicated vertex, and one good triangle.
    let obj = "v 0 0.2 0\nv 1 0.2 0\nv 2 0.2 0\nv 0 0.2 0\nv 0 0.2 1\nv 1 0.2 1e-9\nv 0 0.2 0\nf 1 2 3\nf 1 2 6\nf 1 4 5\nf 7 2 5\n";
    std::fs::write(dir.join("bad.obj"), obj).unwrap();
    let text = scene_text(&format!(
        "{FLOOR}{LIGHT}[[shapes]]\ntype = \"mesh\"\nfile = \"{}\"\nmaterial = \"glass\"\n",
        dir.join("bad.obj").display()
    ));
    both_finite(&text);
}

#[test]
fn light_power_from_1e_minus_20_to_1e20_scales_linearly() {
    let mut base = None;
    for e in [-20i32, -10, 0, 10, 20] {
        let p = 10f32.powi(e);
        let text = scene_text(&format!("{FLOOR}[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.3, 0.0]\nradius = 0.3\nmaterial = \"glass\"\n[[lights]]\ntype = \"point\"\nposition = [0.3, 1.5, 0.2]\npower = [{p:e}, {p:e}, {p:e}]\n"));
        let (pt, pm) = both_finite(&text);
        let ratio = (pt.x / p, pm.x / p);
        let b = *base.get_or_insert(ratio);
        // Same random numbers at every power: the images must scale exactly with it (to float rounding).
        assert!(
            (ratio.0 / b.0 - 1.0).abs() < 1e-3 && (ratio.1 / b.1 - 1.0).abs() < 2e-2,
            "power 1e{e}: {ratio:?} vs {b:?}"
        );
    }
}

#[test]
fn snell_with_relative_index_under_water() {
    let text = scene_text(&format!(
        "{FLOOR}{LIGHT}[materials.inwater]\ntype = \"dielectric\"\nior = 1.5\noutside_ior = 1.33\n"
    ));
    let scene = common::scene(&text);
    let m = &scene.materials[scene.material_names.iter().position(|n| n == "inwater").unwrap()];
    let theta = 40f32.to_radians();
    let wo = Vec3::new(-theta.sin(), theta.cos(), 0.0);
    let s = m.bsdf.sample(wo, Vec3::Y, [0.0, 0.0], 0.999_999, caustica::scene::TransportMode::Importance).unwrap();
    assert!(s.transmitted);
    let sin_t = s.wi.x.abs();
    assert!((sin_t - 1.33 / 1.5 * theta.sin()).abs() < 1e-5, "sin θt = {sin_t}");
}

#[test]
fn every_bundled_scene_renders_finite_in_both_modes() {
    assert!(dragon_available());
    let mut names: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 10, "{names:?}");
    let sets = [
        "camera.resolution=[24, 16]",
        "render.spp=2",
        "render.pm_spp=1",
        "render.specular_spp=1",
        "render.photons.direct=3000",
        "render.photons.indirect=3000",
        "render.photons.caustic=3000",
    ]
    .map(String::from);
    for p in &names {
        let scene = load_scene_with(Path::new(p), &sets).unwrap_or_else(|e| panic!("{e}"));
        // No glass of ours lies flat on another surface (ill-posed: cognac-glass's foot did, and read 0.8
        // of the path tracer in the photon mappers until the scene lifted it).
        let contacts = caustica::scene::contact::coplanar_contacts(&scene);
        assert!(contacts.is_empty(), "{}: {contacts:?}", p.display());
        let accel = Accel::new(&scene).unwrap();
        let pt = render_path(&scene, &accel, 2, true);
        let pm = render_pm_default(&scene, &accel, true).unwrap();
        assert_eq!(pt.counters.nonfinite + pm.counters.nonfinite, 0, "{}: non-finite samples", p.display());
        assert!(pt.image.pixels.iter().chain(&pm.image.pixels).all(|c| c.is_finite()), "{}", p.display());
    }
}

/// A small Mitsuba scene (a floor, a turned box, a panel light, a point light) with every length times
/// `s` and the point light's intensity times s².
fn scene_at_size(s: f32) -> String {
    let v = |x: f32| format!("{}", x * s);
    format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="6"/></integrator>
<sensor type="perspective"><float name="fov" value="45"/><float name="near_clip" value="{near}"/>
<float name="far_clip" value="{far}"/>
<transform name="to_world"><lookat origin="0, {cy}, {cz}" target="0, {ty}, 0" up="0, 1, 0"/></transform>
<film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="36"/></film></sensor>
<shape type="rectangle"><transform name="to_world"><scale value="{floor}"/><rotate x="1" angle="-90"/></transform>
<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf></shape>
<shape type="cube"><transform name="to_world"><scale value="{half}"/><rotate y="1" angle="30"/>
<translate x="{bx}" y="{half}" z="0"/></transform><bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf></shape>
<shape type="rectangle"><transform name="to_world"><scale value="{panel}"/><rotate x="1" angle="90"/>
<translate y="{py}"/></transform><emitter type="area"><rgb name="radiance" value="8, 8, 8"/></emitter></shape>
<emitter type="point"><point name="position" x="{lx}" y="{ly}" z="{lz}"/><rgb name="intensity" value="{i}, {i}, {i}"/></emitter>
</scene>"#,
        near = v(0.01),
        far = v(1000.0),
        cy = v(1.5),
        cz = v(4.0),
        ty = v(0.4),
        floor = v(4.0),
        half = v(0.4),
        bx = v(-0.5),
        panel = v(0.5),
        py = v(2.5),
        lx = v(1.0),
        ly = v(2.0),
        lz = v(1.5),
        i = 3.0 * s * s,
    )
}

/// The same scene written at sizes from 1e-5 to 1e6 loads and, with the same random numbers, renders the
/// image it renders at unit size: ray offsets, the lights' sampling and the loader's checks are all
/// relative to the scene. Before session 73 the loader refused the 1e-5 scene (a floor of side 8e-5 has
/// determinant 6.4e-14, below its absolute bound of 1e-12), and the import's camera looked a unit step
/// from its origin, which rounds far from the world's centre: the view turned, 0.9984 of the unit
/// scene's mean at 1e5 and 0.898 at 1e6 (Mitsuba's own image the same at every size).
#[test]
fn a_scene_written_at_any_size_renders_the_same() {
    let dir = std::env::temp_dir().join(format!("caustica-size-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let load = |s: f32| {
        let path = dir.join(format!("size-{s:e}.xml"));
        std::fs::write(&path, scene_at_size(s)).unwrap();
        load_scene_with(&path, &[]).unwrap_or_else(|e| panic!("size {s:e}: {e}"))
    };
    let unit = load(1.0);
    let spp = 32;
    let a = render(&unit, spp, 1);
    let noise = compare(&a, &render(&unit, spp, 2)).unwrap().rmse;
    for s in [1e-5f32, 1e-3, 1e3, 1e5, 1e6] {
        let img = render(&load(s), spp, 1);
        let e = compare(&img, &a).unwrap();
        let mean = |i: &Image| i.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>();
        let ratio = mean(&img) / mean(&a);
        eprintln!("size {s:e}: same-seed RMSE {:.5} (two seeds' {noise:.5}), mean ratio {ratio:.5}", e.rmse);
        assert!(e.rmse < 0.02 * noise, "size {s:e}: same-seed RMSE {} against two seeds' {noise}", e.rmse);
        assert!((ratio - 1.0).abs() < 2e-4, "size {s:e}: mean {ratio} of the unit scene's");
    }
    std::fs::remove_dir_all(&dir).ok();
}
