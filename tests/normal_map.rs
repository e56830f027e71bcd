//! Normal maps (`type = "normalmap"`, Mitsuba's `normalmap`) in every mode. The BSDF under a normal
//! map is not symmetric: the normal it is taken about depends on the camera's side of the path (the
//! map's, or its reflection about the shading normal where the viewer is below it), and the shadowing
//! term on the light's side. Camera paths know their side; light paths and photons arrive from the
//! light's and must draw the camera's about either normal. Every mode must light the scene as the path
//! tracer does.
mod common;
use caustica::film::Image;

/// A floor of a bumped mirror (checkerboard normals tilted ±35° across x: a sawtooth of facets), a back
/// wall of bumped white diffuse (±40° across its own u), a ball of smooth blue plastic under the same
/// map as the wall, and a card turned away from the camera in bumped diffuse red with `two_sided`, lit
/// on its back by a second, low panel. A small square light hangs above; the camera looks down at the
/// floor and the wall, where the mirror's facets throw the light.
const SCENE: &str = r#"
[camera]
origin = [0.0, 1.6, 3.2]
target = [0.0, 0.6, 0.0]
fov = 50.0
resolution = [48, 48]
[textures]
saw = { type = "checkerboard", color0 = [0.7868, 0.5, 0.9096], color1 = [0.2132, 0.5, 0.9096], scale = [4.0, 4.0] }
steep = { type = "checkerboard", color0 = [0.8214, 0.5, 0.8830], color1 = [0.1786, 0.5, 0.8830], scale = [6.0, 3.0] }
[materials]
chrome = { type = "mirror", specular = [0.9, 0.9, 0.9] }
white = { type = "diffuse", reflectance = [0.7, 0.7, 0.7] }
blue = { type = "plastic", reflectance = [0.15, 0.25, 0.6], ior = 1.5 }
red = { type = "diffuse", reflectance = [0.7, 0.25, 0.2], two_sided = false }
floor = { type = "normalmap", normal_map = "saw", material = "chrome" }
wall = { type = "normalmap", normal_map = "steep", material = "white" }
ball = { type = "normalmap", normal_map = "steep", material = "blue" }
card = { type = "normalmap", normal_map = "steep", material = "red", two_sided = true }
dark = { type = "diffuse", reflectance = [0.0, 0.0, 0.0] }
[[shapes]]
type = "quad"
corner = [-2.0, 0.0, 2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -4.0]
material = "floor"
[[shapes]]
type = "quad"
corner = [-2.0, 0.0, -1.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 2.5, 0.0]
material = "wall"
[[shapes]]
type = "sphere"
center = [-0.7, 0.35, 0.4]
radius = 0.35
material = "ball"
[[shapes]]
type = "quad"
corner = [0.9, 0.1, 0.9]
edge_u = [0.0, 0.8, 0.0]
edge_v = [-0.6, 0.0, -0.5]
material = "card"
[[shapes]]
type = "quad"
corner = [-0.3, 2.2, -0.3]
edge_u = [0.6, 0.0, 0.0]
edge_v = [0.0, 0.0, 0.6]
material = "dark"
emission = [12.0, 12.0, 11.0]
[[shapes]]
type = "quad"
corner = [1.9, 0.2, 1.6]
edge_u = [0.0, 0.0, -0.5]
edge_v = [0.0, 0.5, 0.0]
material = "dark"
emission = [6.0, 5.0, 4.0]
"#;

/// Mean of r + g + b over each of the 4 × 4 blocks of the image, row by row.
fn blocks(img: &Image) -> Vec<f64> {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut sum = [0.0f64; 16];
    for y in 0..h {
        for x in 0..w {
            let p = img.pixels[y * w + x];
            sum[4 * (4 * y / h) + 4 * x / w] += (p.x + p.y + p.z) as f64;
        }
    }
    sum.iter().map(|s| s / (w * h / 16) as f64).collect()
}

#[test]
fn a_normal_mapped_scene_renders_alike_in_every_mode() {
    let pt = blocks(&common::render_image(&common::scene_in_mode(SCENE, "path", &["render.spp=1024"])));
    println!("path: {pt:.4?}");
    let pt_mean = pt.iter().sum::<f64>() / 16.0;
    let cases: [(&str, &[&str], f64, f64); 5] = [
        ("bdpt", &["render.progressive.passes=256"], 0.01, 0.06),
        ("vcm", &["render.progressive.passes=256"], 0.015, 0.08),
        // The photon mappers at 128 passes of 40,000 photons, fixed PM's maps at 200,000 photons and 64
        // eye samples: a quarter of the time of 256 passes and the default photons, where blocks brighter
        // than 0.05 read within 2.6% of PT's (within 1.8% here).
        ("sppm", &["render.progressive.passes=128", common::PASS_PHOTONS], 0.015, 0.08),
        ("ppm", &["render.progressive.passes=128", common::PASS_PHOTONS], 0.02, 0.10),
        ("photon_map", &["render.pm_spp=64", common::MAP_INDIRECT, common::MAP_CAUSTIC], 0.015, 0.08),
    ];
    let mut failed = Vec::new();
    for (mode, sets, mean_tol, block_tol) in cases {
        let b = blocks(&common::render_image(&common::scene_in_mode(SCENE, mode, sets)));
        let mean = b.iter().sum::<f64>() / 16.0;
        println!("{mode}: mean {:.4} of PT's; blocks {b:.4?}", mean / pt_mean);
        if (mean / pt_mean - 1.0).abs() > mean_tol {
            failed.push(format!("{mode}: mean {:.4} of PT's", mean / pt_mean));
        }
        for (i, (a, p)) in b.iter().zip(&pt).enumerate() {
            // Blocks the light barely reaches are held to an absolute bound.
            let off = if *p > 0.05 { (a / p - 1.0).abs() > block_tol } else { (a - p).abs() > 0.05 * block_tol };
            if off {
                failed.push(format!("{mode}: block {i} {a:.4} against PT's {p:.4}"));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// Normal-mapped diffuse and plastic walls on a perfect mirror floor under a point light
/// (`scenes/mapped-mirror.toml`), their light as the mirror shows it compared with an exact reference
/// without a mirror: a point light's light that reaches a normal-mapped surface by a mirror and is seen
/// in the mirror (camera, mirror, wall, mirror, light) is found by no camera path and by no light
/// path's link to the camera; only photons stored on the mapped surface reach it. The reference
/// (`scenes/mapped-mirror-unfolded.toml`) unfolds the scene about the mirror's plane (perfect and wide
/// enough for every path here): the walls' mirror images below the plane (their normal maps mirrored
/// with them: the quads' v edges point down), the light's image, no floor; the path tracer renders that
/// one with light samples alone. Every photon mode's mean and each quarter of the image must be the
/// reference's. Before, the photon mappers stored no photon on normal- or bump-mapped surfaces, and the
/// three read 19% dark.
#[test]
fn a_point_lights_light_via_a_mirror_on_normal_mapped_walls_seen_in_the_mirror() {
    common::assert_matches_unfolded(
        include_str!("scenes/mapped-mirror.toml"),
        include_str!("scenes/mapped-mirror-unfolded.toml"),
        &[
            ("sppm", &["render.progressive.passes=128"]),
            ("ppm", &["render.progressive.passes=128"]),
            ("photon_map", &["render.photons.caustic=200000", "render.photons.indirect=20000"]),
            ("vcm", &["render.progressive.passes=128"]),
        ],
    );
}
