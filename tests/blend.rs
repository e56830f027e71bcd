//! Blended and cut-out materials (`type = "blend"`, `type = "null"`; Mitsuba's `blendbsdf` and `mask`)
//! against closed forms: nested blends pick each material as often as their weights say, and a blend
//! of a diffuse surface with a black mirror reflects exactly what a darker diffuse surface does, in
//! every mode (the pick, the photons stored whatever a photon's own pick, the merges of VCM).
mod common;

use caustica::scene::{load_scene_str, SurfaceHit};
use common::{MAP_CAUSTIC, MAP_INDIRECT, PASS_PHOTONS};
use glam::{Vec2, Vec3};

const BOX: &str = include_str!("../scenes/cornell-box.toml");

/// A hit on `shape` at `uv` with its normal along +z, and a direction in front of it.
fn hit(shape: u32, uv: Vec2) -> (SurfaceHit, Vec3) {
    let si = SurfaceHit { p: Vec3::ZERO, ng: Vec3::Z, ns: Vec3::Z, shape, prim: 0, scale: 1.0, uv };
    (si, Vec3::new(0.3, 0.0, 0.9).normalize())
}

/// The Cornell box with its white material replaced by `white` (TOML lines for `[materials]`).
fn cornell_with(white: &str) -> String {
    let plain = r#"white = { type = "diffuse", reflectance = [0.73, 0.73, 0.73] }"#;
    assert!(BOX.contains(plain));
    BOX.replace(plain, white)
}

#[test]
fn nested_blends_pick_each_material_by_its_weights() {
    let toml = r#"
[camera]
origin = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [8, 8]
[textures]
half = { type = "checkerboard", color0 = [0.0, 0.0, 0.0], color1 = [1.0, 1.0, 1.0] }
[materials]
a = { type = "diffuse", reflectance = [0.1, 0.1, 0.1] }
b = { type = "diffuse", reflectance = [0.2, 0.2, 0.2] }
c = { type = "mirror" }
inner = { type = "blend", weight = 0.25, first = "b", second = "c" }
outer = { type = "blend", weight = 0.5, first = "a", second = "inner" }
by_uv = { type = "blend", weight = "half", first = "a", second = "c" }
[[shapes]]
type = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "outer"
[[shapes]]
type = "sphere"
center = [3.0, 0.0, 0.0]
radius = 1.0
material = "by_uv"
[[lights]]
type = "point"
position = [0.0, 3.0, 3.0]
power = [10.0, 10.0, 10.0]
"#;
    let scene = load_scene_str(toml, "blend.toml", std::path::Path::new("."), &[]).unwrap_or_else(|e| panic!("{e}"));
    let index = |name: &str| scene.material_names.iter().position(|n| n == name).unwrap();
    let (a, b, c) = (index("a"), index("b"), index("c"));
    // Stratified numbers: each leaf's share of them is its probability, to within 1/n.
    let n = 4000;
    let mut counts = [0usize; 3];
    for i in 0..n {
        let u = (i as f32 + 0.5) / n as f32;
        let (si, wo) = hit(0, Vec2::ZERO);
        let m = scene.pick_material(&si, wo, || u);
        let leaf = [a, b, c].iter().position(|&l| std::ptr::eq(m, &scene.materials[l])).expect("a leaf");
        counts[leaf] += 1;
    }
    let shares = counts.map(|k| k as f64 / n as f64);
    println!("picks a, b, c: {shares:?} (want 0.5, 0.375, 0.125)");
    for (got, want) in shares.iter().zip([0.5, 0.375, 0.125]) {
        assert!((got - want).abs() <= 1.0 / n as f64, "{shares:?}");
    }
    // A texture weight picks by place: the checkerboard's 0 squares are `a`, its 1 squares `c`.
    let at = |uv: Vec2| {
        let (si, wo) = hit(1, uv);
        scene.pick_material(&si, wo, || 0.5) as *const _
    };
    assert_eq!(at(Vec2::new(0.25, 0.25)), &scene.materials[a] as *const _);
    assert_eq!(at(Vec2::new(0.75, 0.25)), &scene.materials[c] as *const _);
    // A plain material draws no number.
    let plain = load_scene_str(
        &cornell_with(r#"white = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }"#),
        "box.toml",
        std::path::Path::new("."),
        &[],
    )
    .unwrap();
    let (si, wo) = hit(0, Vec2::ZERO);
    plain.pick_material(&si, wo, || panic!("a number drawn for a plain material"));
}

/// Mean of the image `mode` renders of `toml` (48 × 48 pixels, with `sets`): r + g + b.
fn mean_in_mode(toml: &str, mode: &str, sets: &[&str]) -> f64 {
    channel_means_in_mode(toml, mode, sets).iter().sum()
}

/// Per-channel means of the image `mode` renders of `toml` (48 × 48 pixels, with `sets`).
fn channel_means_in_mode(toml: &str, mode: &str, sets: &[&str]) -> [f64; 3] {
    let mut all = vec!["camera.resolution=[48, 48]"];
    all.extend(sets);
    let img = common::render_image(&common::scene_in_mode(toml, mode, &all));
    let n = img.pixels.len() as f64;
    [0, 1, 2].map(|k| img.pixels.iter().map(|p| p[k] as f64).sum::<f64>() / n)
}

/// A blend that is a black mirror 40% of the time reflects 60% of what its diffuse side does:
/// (1 − w)·ρ/π. Every mode renders the Cornell box with it as with a diffuse white of 0.6 × 0.73.
/// Picking the mirror kills the path (PT's light samples, BDPT's connections) or the photon (which
/// was stored first: SPPM and PM gather it wherever a camera path picks the diffuse side).
#[test]
fn a_blend_with_a_black_mirror_is_a_darker_diffuse_surface_in_every_mode() {
    let blend = cornell_with(
        r#"white = { type = "blend", weight = 0.4, first = "white_d", second = "void" }
white_d = { type = "diffuse", reflectance = [0.73, 0.73, 0.73] }
void = { type = "mirror", specular = [0.0, 0.0, 0.0] }"#,
    );
    let darker = cornell_with(r#"white = { type = "diffuse", reflectance = [0.438, 0.438, 0.438] }"#);
    let cases: [(&str, &[&str], f64); 6] = [
        ("path", &["render.spp=256"], 0.01),
        ("bdpt", &["render.progressive.passes=64"], 0.01),
        ("vcm", &["render.progressive.passes=64"], 0.01),
        ("sppm", &["render.progressive.passes=64", PASS_PHOTONS], 0.015),
        ("ppm", &["render.progressive.passes=64", PASS_PHOTONS], 0.02),
        ("photon_map", &["render.pm_spp=16", MAP_INDIRECT, MAP_CAUSTIC], 0.015),
    ];
    for (mode, sets, tol) in cases {
        let (m_blend, m_plain) = (mean_in_mode(&blend, mode, sets), mean_in_mode(&darker, mode, sets));
        let rel = m_blend / m_plain - 1.0;
        println!("{mode}: blend {m_blend:.5}, diffuse {m_plain:.5} ({:+.2}%)", rel * 100.0);
        assert!(rel.abs() < tol, "{mode}: the blend's mean {m_blend} against the diffuse surface's {m_plain}");
    }
}

/// A side blend (`type = "sides"`, Mitsuba's `twosided` with two BSDFs) is its front where a path
/// arrives in front of the geometric normal and its back behind it, and draws no number for it.
#[test]
fn a_side_blend_is_its_front_in_front_and_its_back_behind() {
    let toml = |back: &str| {
        format!(
            r#"
[camera]
origin = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [8, 8]
[materials]
f = {{ type = "diffuse", reflectance = [0.1, 0.2, 0.3] }}
one_sided = {{ type = "diffuse", reflectance = [0.3, 0.2, 0.1], two_sided = false }}
glass = {{ type = "dielectric", ior = 1.5 }}
b = {{ type = "mirror" }}
inner = {{ type = "blend", weight = 0.5, first = "b", second = "f" }}
card = {{ type = "sides", front = "f", back = "{back}" }}
[[shapes]]
type = "quad"
corner = [-1.0, -1.0, 0.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 2.0, 0.0]
material = "card"
[[lights]]
type = "point"
position = [0.0, 3.0, 3.0]
power = [10.0, 10.0, 10.0]
"#
        )
    };
    let scene =
        load_scene_str(&toml("b"), "sides.toml", std::path::Path::new("."), &[]).unwrap_or_else(|e| panic!("{e}"));
    let index = |name: &str| scene.material_names.iter().position(|n| n == name).unwrap();
    let (si, wo) = hit(0, Vec2::ZERO);
    let no_draw = || -> f32 { panic!("a number drawn for a side blend") };
    assert!(std::ptr::eq(scene.pick_material(&si, wo, no_draw), &scene.materials[index("f")]));
    assert!(std::ptr::eq(scene.pick_material(&si, -wo, no_draw), &scene.materials[index("b")]));
    // Seen from behind, the back is its material seen from its own front: a perfect mirror.
    let back = scene.bsdf(&si, -wo, no_draw);
    assert!(back.is_delta(), "{back:?}");
    // Photons are kept by the side they arrive on: the front holds them, the mirror behind does not.
    assert!(scene.any_bsdf_at(&si, wo, |m| m.holds_photons()));
    assert!(!scene.any_bsdf_at(&si, -wo, |m| m.holds_photons()));
    // A back that is a blend of two-sided materials is read; one that would be black from behind, or a
    // side that lets light through, is refused by key.
    let load = |back: &str| load_scene_str(&toml(back), "sides.toml", std::path::Path::new("."), &[]);
    load("inner").unwrap_or_else(|e| panic!("back `inner`: {e}"));
    for (back, words) in [("one_sided", "`one_sided` is one-sided"), ("glass", "`glass` lets light through")] {
        let msg = load(back).err().unwrap_or_else(|| panic!("back `{back}` was accepted")).to_string();
        assert!(msg.contains("materials.card.back") && msg.contains(words), "{msg}");
    }
}

/// A panel in the Cornell box with blue diffuse on one side and a mirror on the other renders the same
/// in every mode as the panel turned over (its normal the other way) with its sides swapped: each
/// side's material is found by the side a path or photon arrives on, wherever the light comes from.
/// The light falls mostly on the mirror side (its caustic lands on the back wall), the camera sees the
/// blue side (a surface always its back moves the red channel's mean by 5%).
#[test]
fn a_panel_turned_over_with_its_sides_swapped_renders_the_same_in_every_mode() {
    let panel = |u: &str, v: &str, sides: &str| {
        let materials = format!(
            r#"white = {{ type = "diffuse", reflectance = [0.73, 0.73, 0.73] }}
blue = {{ type = "diffuse", reflectance = [0.05, 0.1, 0.7] }}
shiny = {{ type = "mirror", specular = [0.9, 0.9, 0.9] }}
panel = {{ type = "sides", {sides} }}"#
        );
        let shape = format!("\n[[shapes]]\ntype = \"quad\"\ncorner = [-0.8, 0.0, 0.5]\nedge_u = {u}\nedge_v = {v}\nmaterial = \"panel\"\n");
        cornell_with(&materials) + &shape
    };
    let (u, v) = ("[0.6, 0.0, 0.3]", "[0.0, 1.0, 0.0]");
    let a = panel(u, v, r#"front = "blue", back = "shiny""#);
    let b = panel(v, u, r#"front = "shiny", back = "blue""#);
    let cases: [(&str, &[&str], f64); 6] = [
        ("path", &["render.spp=256"], 0.01),
        ("bdpt", &["render.progressive.passes=64"], 0.01),
        ("vcm", &["render.progressive.passes=64"], 0.01),
        ("sppm", &["render.progressive.passes=64", PASS_PHOTONS], 0.01),
        ("ppm", &["render.progressive.passes=64", PASS_PHOTONS], 0.01),
        ("photon_map", &["render.pm_spp=16", MAP_INDIRECT, MAP_CAUSTIC], 0.01),
    ];
    for (mode, sets, tol) in cases {
        let (ma, mb) = (channel_means_in_mode(&a, mode, sets), channel_means_in_mode(&b, mode, sets));
        println!("{mode}: panel {ma:.5?}, turned over {mb:.5?}");
        for k in 0..3 {
            let rel = ma[k] / mb[k] - 1.0;
            assert!(rel.abs() < tol, "{mode}: channel {k}: {} against {} ({:+.2}%)", ma[k], mb[k], rel * 100.0);
        }
    }
}
