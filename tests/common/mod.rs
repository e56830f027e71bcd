//! Helpers shared by the integration tests: scenes built in code or from TOML text.
#![allow(dead_code)]
use caustica::accel::Accel;
use caustica::film::Image;
use caustica::pipeline::{plan_for, render_layers};
use caustica::scene::file::FovAxis;
use caustica::scene::{load_scene_str, Camera, Lights, Scene, Shape, SurfaceHit};
use glam::Vec3;
use std::path::Path;

/// A scene holding just `shapes` (for ray-query tests), with one diffuse material.
pub fn shapes_scene(shapes: Vec<Shape>) -> Scene {
    Scene {
        path: "test".into(),
        camera: Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0, FovAxis::X, [8, 8]),
        materials: vec![caustica::scene::SurfaceMaterial::new(caustica::scene::Material::Diffuse {
            reflectance: Vec3::splat(0.5),
        })],
        material_names: vec!["m".into()],
        textures: Vec::new(),
        shapes,
        lights: Lights::default(),
        render: Default::default(),
        bounds: (Vec3::splat(-1.0), Vec3::splat(1.0)),
        load_seconds: 0.0,
        see_through: Vec::new(),
        absorption: Vec::new(),
        boundary: Vec::new(),
        point_media: Vec::new(),
        scattering: Vec::new(),
        see_through_media: false,
        warnings: Vec::new(),
    }
}

/// The photon mappers' photons in the every-mode test cases: 40,000 a pass (SPPM, PPM) and 200,000 a
/// map (fixed PM), not the defaults' 100,000 and 500,000, for half the time. Over the seventeen scenes
/// of `tests/mitsuba_import.rs`'s `EVERY_MODE` the largest departure from Mitsuba's mean moved from
/// 0.53% to 0.52% (SPPM), 0.46% to 0.47% (PPM) and 0.52% to 0.65% (fixed PM); the bounds, and the errors
/// of 2% and more they catch, are unchanged.
pub const PASS_PHOTONS: &str = "render.progressive.photons_per_pass=40000";
pub const MAP_INDIRECT: &str = "render.photons.indirect=200000";
pub const MAP_CAUSTIC: &str = "render.photons.caustic=200000";

/// Loads a scene from TOML text (paths resolve against the crate root).
pub fn scene(text: &str) -> Scene {
    load_scene_str(text, "test.toml", Path::new(env!("CARGO_MANIFEST_DIR")), &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads a scene from TOML text with `render.mode` set to `mode` and the `key=value` overrides `sets`.
pub fn scene_in_mode(text: &str, mode: &str, sets: &[&str]) -> Scene {
    let mut all = vec![format!("render.mode=\"{mode}\"")];
    all.extend(sets.iter().map(|s| s.to_string()));
    load_scene_str(text, "test.toml", Path::new(env!("CARGO_MANIFEST_DIR")), &all).unwrap_or_else(|e| panic!("{e}"))
}

/// The image a scene renders in its own mode, as `caustica render` plans it.
pub fn render_image(scene: &Scene) -> Image {
    let accel = Accel::new(scene).unwrap();
    let plan = plan_for(scene, &accel);
    let layers = render_layers(scene, &accel, &plan, &serde_json::json!({}), 0.0, None, true).unwrap();
    layers[0].sums.image()
}

/// The error a render of `scene` in its own mode stops with, as `caustica render` plans it (a mode that
/// refuses the scene); panics, naming `what`, if it renders.
pub fn render_error(scene: &Scene, what: &str) -> String {
    let accel = Accel::new(scene).unwrap();
    let plan = plan_for(scene, &accel);
    match render_layers(scene, &accel, &plan, &serde_json::json!({}), 0.0, None, true) {
        Ok(_) => panic!("{what}: rendered"),
        Err(e) => e.to_string(),
    }
}

/// The error loading the TOML `text` (shown as `shown`) stops with; panics, naming `what`, if it loads.
pub fn load_error(text: &str, shown: &str, what: &str) -> String {
    match load_scene_str(text, shown, Path::new("."), &[]) {
        Ok(_) => panic!("{what}: loaded"),
        Err(e) => e.to_string(),
    }
}

/// Six inward-facing quads forming the box [lo, hi]³ (for closed-room tests).
pub fn inward_box(lo: f32, hi: f32, material: &str, emission: Option<f32>) -> String {
    let s = hi - lo;
    let e = emission.map_or(String::new(), |e| format!("emission = [{e}, {e}, {e}]\n"));
    let quads = [
        ([lo, lo, lo], [0.0, 0.0, s], [s, 0.0, 0.0]), // floor, normal +y
        ([lo, hi, lo], [s, 0.0, 0.0], [0.0, 0.0, s]), // ceiling, normal -y
        ([lo, lo, lo], [s, 0.0, 0.0], [0.0, s, 0.0]), // z = lo, normal +z
        ([lo, lo, hi], [0.0, s, 0.0], [s, 0.0, 0.0]), // z = hi, normal -z
        ([lo, lo, lo], [0.0, s, 0.0], [0.0, 0.0, s]), // x = lo, normal +x
        ([hi, lo, lo], [0.0, 0.0, s], [0.0, s, 0.0]), // x = hi, normal -x
    ];
    quads
        .iter()
        .map(|(c, u, v)| format!("[[shapes]]\ntype = \"quad\"\ncorner = {c:?}\nedge_u = {u:?}\nedge_v = {v:?}\nmaterial = \"{material}\"\n{e}\n"))
        .collect()
}

/// A flat-shaded surface point with normal `n` (for querying photon maps directly).
pub fn surface_at(p: Vec3, n: Vec3) -> SurfaceHit {
    SurfaceHit { p, ng: n, ns: n, shape: 0, prim: 0, scale: 1.0, uv: glam::Vec2::ZERO }
}

/// How two EXR files differ: (channel values whose bits differ, largest relative difference among them).
pub fn exr_difference(a: &Path, b: &Path) -> (usize, f64) {
    let (a, b) = (caustica::output::read_exr(a).unwrap(), caustica::output::read_exr(b).unwrap());
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut n = 0;
    let mut worst = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for k in 0..3 {
            if p[k].to_bits() != q[k].to_bits() {
                n += 1;
                let rel = (p[k] as f64 - q[k] as f64).abs() / (p[k].abs().max(q[k].abs()) as f64).max(1e-30);
                worst = worst.max(rel);
            }
        }
    }
    (n, worst)
}

/// Render options of the small split-render tests (tests/parts.rs and tests/slurm.rs): the Cornell box
/// path traced, and the glass box photon mapped.
pub const SMALL_BOX: &[&str] = &["--set", "camera.resolution=[64,48]", "--spp", "16"];
pub const SMALL_GLASS_PM: &[&str] = &[
    "--set",
    "camera.resolution=[64,48]",
    "--mode",
    "photon_map",
    "--set",
    "render.photons.caustic=20000",
    "--set",
    "render.photons.indirect=20000",
];

/// Sums of the image's four quarters (top left, top right, bottom left, bottom right).
pub fn quarters(img: &Image) -> [f64; 4] {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut q = [0.0f64; 4];
    for (i, p) in img.pixels.iter().enumerate() {
        let (x, y) = (i % w, i / w);
        q[2 * (2 * y / h) + 2 * x / w] += (p.x + p.y + p.z) as f64;
    }
    q
}

/// A scene with a perfect mirror (`text`) against the same scene unfolded about the mirror's plane
/// (`unfolded`: every path through the mirror a straight one there), path traced at 1024 spp with
/// light samples alone, its exact reference: each of `cases` (a mode and its overrides) must read the
/// reference's mean within 1.5% and each quarter of the image within 5%.
pub fn assert_matches_unfolded(text: &str, unfolded: &str, cases: &[(&str, &[&str])]) {
    let want = quarters(&render_image(&scene_in_mode(unfolded, "path", &["render.spp=1024"])));
    let want_mean = want.iter().sum::<f64>() / 4.0;
    println!("reference (unfolded, path): quarters {want:.4?}");
    let mut failed = Vec::new();
    for &(mode, sets) in cases {
        let got = quarters(&render_image(&scene_in_mode(text, mode, sets)));
        let mean = got.iter().sum::<f64>() / 4.0;
        let ratios: Vec<f64> = got.iter().zip(&want).map(|(g, w)| g / w).collect();
        println!("{mode}: mean {:.4} of the reference's; quarters {ratios:.4?}", mean / want_mean);
        if (mean / want_mean - 1.0).abs() > 0.015 {
            failed.push(format!("{mode}: mean {:.4} of the reference's", mean / want_mean));
        }
        for (q, r) in ratios.iter().enumerate() {
            if (r - 1.0).abs() > 0.05 {
                failed.push(format!("{mode}: quarter {q} {r:.4} of the reference's"));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// `tests/mitsuba/sky.exr` (64 × 32, PIZ) with its data window's x max raised to 999,999,999: a header
/// that claims 10^9 × 32 texels over the same compressed blocks (the EXR crate refuses 2^30 and more).
pub fn widened_exr() -> Vec<u8> {
    let mut bytes = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba/sky.exr")).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).expect("sky.exr has a data window") + key.len();
    // The attribute's size (16), then x min, y min, x max, y max as little-endian i32.
    assert_eq!(bytes[at..at + 4], 16u32.to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&999_999_999i32.to_le_bytes());
    bytes
}
