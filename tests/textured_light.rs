//! Emitters whose radiance is a texture (`emission = "texture"` in TOML, a textured `radiance` in
//! Mitsuba XML): every strategy must carry the radiance of the point it leaves or finds. A panel whose
//! quadrants are bright and dark hangs low over a floor; the floor beside it is brighter by its bright
//! quadrants. Every mode must light the floor's quadrants as the path tracer does (which finds the
//! panel both by light samples and by BSDF samples), and the path tracer must see the pattern at all.
mod common;
use caustica::film::Image;

/// A 2 × 2 panel 0.3 above a diffuse floor (a wall of it behind, lit by the floor: light the photon
/// maps carry), its quadrants (checkerboard in uv) [5, 5, 5] and
/// [0.2, 0.2, 0.2] facing down; a camera beside it looks down at the floor along one edge, where the
/// light from the quadrants nearest that edge falls.
const SCENE: &str = r#"
[camera]
origin = [3.0, 1.2, 0.0]
target = [1.2, 0.0, 0.0]
fov = 50.0
resolution = [48, 48]
[textures]
quarters = { type = "checkerboard", color0 = [5.0, 5.0, 5.0], color1 = [0.2, 0.2, 0.2] }
[materials]
floor = { type = "diffuse", reflectance = [0.7, 0.7, 0.7] }
black = { type = "diffuse", reflectance = [0.0, 0.0, 0.0] }
[[shapes]]
type = "quad"
corner = [-3.0, 0.0, -3.0]
edge_u = [0.0, 0.0, 6.0]
edge_v = [6.0, 0.0, 0.0]
material = "floor"
[[shapes]]
type = "quad"
corner = [-1.6, 0.0, -3.0]
edge_u = [0.0, 3.0, 0.0]
edge_v = [0.0, 0.0, 6.0]
material = "floor"
[[shapes]]
type = "quad"
corner = [-1.0, 0.3, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
material = "black"
emission = "quarters"
"#;

/// Mean of r + g + b over each quarter of the image (top left, top right, bottom left, bottom right).
fn quarters(img: &Image) -> [f64; 4] {
    let mut sum = [0.0f64; 4];
    let (w, h) = (img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            let p = img.pixels[(y * w + x) as usize];
            sum[(2 * (y >= h / 2) as usize) + (x >= w / 2) as usize] += (p.x + p.y + p.z) as f64;
        }
    }
    sum.map(|s| s / (w * h / 4) as f64)
}

#[test]
fn a_textured_emitter_lights_by_its_texture_in_every_mode() {
    let pt = quarters(&common::render_image(&common::scene_in_mode(SCENE, "path", &["render.spp=512"])));
    println!("path: {pt:.4?}");
    // The pattern is there: the floor beside the panel's bright quadrant (the image's left half) is
    // far brighter than beside its dark one.
    assert!(pt[0] + pt[2] > 2.0 * (pt[1] + pt[3]), "{pt:?}");
    let cases: [(&str, &[&str], f64); 5] = [
        ("bdpt", &["render.progressive.passes=64"], 0.02),
        ("vcm", &["render.progressive.passes=64"], 0.03),
        ("sppm", &["render.progressive.passes=64"], 0.03),
        // Its radius's blur of the bright strip by the panel: +4.4% and −6.4% in the top quarters at
        // 64 passes, +1.8% and −2.1% at 512.
        ("ppm", &["render.progressive.passes=512"], 0.04),
        ("photon_map", &["render.pm_spp=64"], 0.03),
    ];
    for (mode, sets, tol) in cases {
        let q = quarters(&common::render_image(&common::scene_in_mode(SCENE, mode, sets)));
        println!("{mode}: {q:.4?}");
        for k in 0..4 {
            let rel = q[k] / pt[k] - 1.0;
            assert!(
                rel.abs() < tol,
                "{mode}: quarter {k} {} against the path tracer's {} ({:+.2}%)",
                q[k],
                pt[k],
                rel * 100.0
            );
        }
    }
}
