//! Blended and cut-out materials (`type = "blend"`, `type = "null"`; Mitsuba's `blendbsdf` and `mask`)
//! against closed forms: nested blends pick each material as often as their weights say, and a blend
//! of a diffuse surface with a black mirror reflects exactly what a darker diffuse surface does, in
//! every mode (the pick, the photons stored whatever a photon's own pick, the merges of VCM).
use caustica::accel::Accel;
use caustica::pipeline::{plan_for, render_layers};
use caustica::scene::{load_scene_str, load_scene_with};
use glam::Vec2;
use std::path::PathBuf;

const BOX: &str = include_str!("../scenes/cornell-box.toml");

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
        let m = scene.pick_material(0, Vec2::ZERO, || u);
        let leaf = [a, b, c].iter().position(|&l| std::ptr::eq(m, &scene.materials[l])).expect("a leaf");
        counts[leaf] += 1;
    }
    let shares = counts.map(|k| k as f64 / n as f64);
    println!("picks a, b, c: {shares:?} (want 0.5, 0.375, 0.125)");
    for (got, want) in shares.iter().zip([0.5, 0.375, 0.125]) {
        assert!((got - want).abs() <= 1.0 / n as f64, "{shares:?}");
    }
    // A texture weight picks by place: the checkerboard's 0 squares are `a`, its 1 squares `c`.
    let at = |uv: Vec2| scene.pick_material(1, uv, || 0.5) as *const _;
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
    plain.pick_material(0, Vec2::ZERO, || panic!("a number drawn for a plain material"));
}

/// Mean of the image `mode` renders of `toml` (written to a file, rendered with `sets`).
fn mean_in_mode(toml: &str, name: &str, mode: &str, sets: &[&str]) -> f64 {
    let dir: PathBuf = std::env::temp_dir().join(format!("caustica-blend-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, toml).unwrap();
    let mut all = vec![format!("render.mode=\"{mode}\""), "camera.resolution=[48, 48]".to_string()];
    all.extend(sets.iter().map(|s| s.to_string()));
    let scene = load_scene_with(&path, &all).unwrap_or_else(|e| panic!("{e}"));
    let accel = Accel::new(&scene).unwrap();
    let plan = plan_for(&scene, &accel);
    let layers = render_layers(&scene, &accel, &plan, &serde_json::json!({}), 0.0, None, true).unwrap();
    let img = layers[0].sums.image();
    img.pixels.iter().map(|p| (p.x + p.y + p.z) as f64).sum::<f64>() / img.pixels.len() as f64
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
        ("sppm", &["render.progressive.passes=64"], 0.015),
        ("ppm", &["render.progressive.passes=64"], 0.02),
        ("photon_map", &["render.pm_spp=16"], 0.015),
    ];
    for (mode, sets, tol) in cases {
        let (m_blend, m_plain) =
            (mean_in_mode(&blend, "blend", mode, sets), mean_in_mode(&darker, "darker", mode, sets));
        let rel = m_blend / m_plain - 1.0;
        println!("{mode}: blend {m_blend:.5}, diffuse {m_plain:.5} ({:+.2}%)", rel * 100.0);
        assert!(rel.abs() < tol, "{mode}: the blend's mean {m_blend} against the diffuse surface's {m_plain}");
    }
}
