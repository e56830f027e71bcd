//! Textured BSDF parameters (a conductor's `specular`, a rough surface's `roughness`, a dielectric's
//! `tint`) against renders of the same scene with each texel's value as a constant: every pixel that
//! sees only one square of a checkerboard must equal the render with that square's values everywhere,
//! as both draw the same random numbers (textures draw none). A texture read in the wrong place, not
//! read at all, or with its squares the wrong way round fails.
use caustica::accel::Accel;
use caustica::pipeline::{plan_for, render_layers};
use caustica::scene::load_scene_with;
use std::path::PathBuf;

/// A floor seen straight from above, filling the frame, under a quad light, a point light and a dim
/// sky: nothing else is there, so each pixel's light depends only on the floor where its camera ray
/// lands (the floor cannot see itself). `floor` is the floor's material line, `pane` that of a pane
/// filling the frame above it (`null` for none).
fn scene(floor: &str, pane: &str) -> String {
    format!(
        r#"
[camera]
origin = [0.1, 3.0, 0.13]
target = [0.1, 0.0, 0.13]
up = [0.0, 0.0, -1.0]
fov = 40.0
resolution = [48, 48]
[textures]
rough = {{ type = "checkerboard", color0 = [0.05, 0.05, 0.05], color1 = [0.4, 0.4, 0.4], scale = [3.0, 3.0] }}
colour = {{ type = "checkerboard", color0 = [1.0, 1.0, 1.0], color1 = [0.4, 0.7, 1.0], scale = [3.0, 3.0] }}
stain = {{ type = "checkerboard", color0 = [0.9, 0.3, 0.2], color1 = [0.2, 0.9, 0.4], scale = [3.0, 3.0] }}
[materials]
{floor}
{pane}
[[shapes]]
type = "quad"
corner = [-2.0, 0.0, -2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 4.0]
material = "floor"
[[shapes]]
type = "quad"
corner = [-2.0, 0.5, -2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 4.0]
material = "pane"
[[lights]]
type = "quad"
corner = [-0.3, 2.5, 0.6]
edge_u = [0.6, 0.0, 0.0]
edge_v = [0.0, 0.0, 0.4]
power = [20.0, 20.0, 20.0]
[[lights]]
type = "point"
position = [-1.0, 1.5, -0.5]
power = [30.0, 30.0, 30.0]
[[lights]]
type = "constant"
radiance = [0.1, 0.1, 0.1]
"#
    )
}

fn render(toml: &str, name: &str, mode: &str, sets: &[&str]) -> Vec<f64> {
    let dir: PathBuf = std::env::temp_dir().join(format!("caustica-textured-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Tests run in parallel: each render gets a file of its own.
    static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let path = dir.join(format!("{name}-{}.toml", NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)));
    std::fs::write(&path, toml).unwrap();
    let mut all = vec![format!("render.mode=\"{mode}\"")];
    all.extend(sets.iter().map(|s| s.to_string()));
    let scene = load_scene_with(&path, &all).unwrap_or_else(|e| panic!("{e}"));
    let accel = Accel::new(&scene).unwrap();
    let plan = plan_for(&scene, &accel);
    let layers = render_layers(&scene, &accel, &plan, &serde_json::json!({}), 0.0, None, true).unwrap();
    layers[0].sums.image().pixels.iter().map(|p| (p.x + p.y + p.z) as f64).collect()
}

/// Renders the textured scene and the two constant ones in `mode`; each pixel of the textured image
/// must match one of them, and both squares' values must be seen.
fn squares_match(textured: (&str, &str), first: (&str, &str), second: (&str, &str), mode: &str, sets: &[&str]) {
    let t = render(&scene(textured.0, textured.1), "textured", mode, sets);
    let a = render(&scene(first.0, first.1), "first", mode, sets);
    let b = render(&scene(second.0, second.1), "second", mode, sets);
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-3 * y.abs().max(1e-3);
    let (mut on_a, mut on_b, mut differ) = (0, 0, 0);
    for ((t, a), b) in t.iter().zip(&a).zip(&b) {
        if close(*a, *b) {
            continue; // the two constants agree here: nothing to tell
        }
        match (close(*t, *a), close(*t, *b)) {
            (true, _) => on_a += 1,
            (_, true) => on_b += 1,
            _ => differ += 1,
        }
    }
    // The frame's centre looks straight down at (0.1, 0.13), two pixels inside a square of color0 (uv
    // (0.525, 0.533), 3× that is (1.58, 1.60)): there the textured image is the first constant's.
    let centre = 24 * 48 + 24;
    assert!(!close(a[centre], b[centre]) && close(t[centre], a[centre]), "{mode}: the squares are swapped");
    let n = t.len() as f64;
    println!(
        "{mode}: pixels equal to the first constant {on_a}, to the second {on_b}, to neither {differ} (of {})",
        t.len()
    );
    // A 48-pixel frame over 6 × 4.4 squares: a pixel straddles an edge in about a quarter of the rows
    // and columns; the rest see one square.
    assert!(differ as f64 <= 0.35 * n, "{mode}: {differ} pixels match neither constant");
    assert!(on_a as f64 >= 0.2 * n && on_b as f64 >= 0.2 * n, "{mode}: {on_a} and {on_b} pixels by square");
}

/// Rough gold whose roughness and colour are checkerboards, against the gold at each square's values.
#[test]
fn textured_roughness_and_colour_equal_their_constants_square_by_square() {
    let none = "pane = { type = \"null\" }";
    let gold = |spec: &str, rough: &str| {
        format!(
            "floor = {{ type = \"conductor\", eta = [0.143, 0.374, 1.442], k = [3.983, 2.385, 1.603], specular = {spec}, roughness = {rough} }}"
        )
    };
    let textured = gold("\"colour\"", "\"rough\"");
    let first = gold("[1.0, 1.0, 1.0]", "0.05");
    let second = gold("[0.4, 0.7, 1.0]", "0.4");
    for (mode, sets) in [("path", &["render.spp=16"][..]), ("bdpt", &["render.progressive.passes=4"][..])] {
        squares_match((&textured, none), (&first, none), (&second, none), mode, sets);
    }
}

/// A rough mirror whose roughness alone is textured, and a thin pane whose transmittance is a
/// checkerboard with nothing under it but the sky (the floor made `null`): a camera ray then meets one
/// square of the pane and leaves it for the lights or the sky.
#[test]
fn textured_mirror_roughness_and_pane_tint_equal_their_constants_square_by_square() {
    let none = "pane = { type = \"null\" }";
    let mirror = |r: &str| format!("floor = {{ type = \"mirror\", roughness = {r} }}");
    let (textured, first, second) = (mirror("\"rough\""), mirror("0.05"), mirror("0.4"));
    squares_match((&textured, none), (&first, none), (&second, none), "path", &["render.spp=16"]);
    let gone = "floor = { type = \"null\" }";
    let pane = |t: &str| format!("pane = {{ type = \"thin_dielectric\", ior = 1.5, tint = {t} }}");
    let (textured, first, second) = (pane("\"stain\""), pane("[0.9, 0.3, 0.2]"), pane("[0.2, 0.9, 0.4]"));
    squares_match((gone, &textured), (gone, &first), (gone, &second), "path", &["render.spp=16"]);
}
