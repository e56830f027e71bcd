//! Same image bits whatever the thread count: path tracing, and photon mapping (maps and eye pass).
use caustica::accel::Accel;
use caustica::pipeline::{plan_for, render_path, render_pm};
use caustica::scene::load_scene_with;
use std::path::Path;

fn scene() -> caustica::scene::Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glass.toml");
    let sets = [
        "camera.resolution=[48, 48]",
        "render.spp=4",
        "render.pm_spp=2",
        "render.photons.indirect=20000",
        "render.photons.caustic=20000",
        "render.photons.direct=20000",
        "render.direct_light=\"photon_map\"",
    ];
    load_scene_with(&p, &sets.map(String::from)).unwrap()
}

fn with_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(f)
}

#[test]
fn path_tracer_is_bit_identical_for_1_and_2_threads() {
    let s = scene();
    let a = Accel::new(&s).unwrap();
    let one = with_threads(1, || render_path(&s, &a, 4, true).image);
    let two = with_threads(2, || render_path(&s, &a, 4, true).image);
    assert!(one.pixels.iter().any(|p| p.x > 0.0));
    assert!(one
        .pixels
        .iter()
        .zip(&two.pixels)
        .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)));
}

#[test]
fn photon_mapper_is_bit_identical_for_1_and_2_threads() {
    let s = scene();
    let a = Accel::new(&s).unwrap();
    let run = || {
        let (maps, r) = render_pm(&s, &a, &plan_for(&s, &a), true).unwrap();
        (maps.stats.stored, maps.stats.n_emitted, r.image)
    };
    let one = with_threads(1, run);
    let two = with_threads(2, run);
    assert_eq!(one.0, two.0);
    assert_eq!(one.1, two.1);
    assert!(one
        .2
        .pixels
        .iter()
        .zip(&two.2.pixels)
        .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)));
}

/// The caustic pass's light-traced glossy caustics (`scenes/brushed-metal.toml`: a spot's caustic
/// through a glass ball on rough aluminium) are summed in photon order: the same bits on 1 and 2
/// threads, and the splats are there (the caustic region is lit).
#[test]
fn glossy_caustic_splats_are_bit_identical_for_1_and_2_threads() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/brushed-metal.toml");
    let sets = ["camera.resolution=[40, 30]", "render.pm_spp=1", "render.photons.caustic=30000"];
    let s = load_scene_with(&p, &sets.map(String::from)).unwrap();
    let a = Accel::new(&s).unwrap();
    let run = || {
        let (maps, r) = render_pm(&s, &a, &plan_for(&s, &a), true).unwrap();
        (maps.glossy.expect("glossy caustic splats").pixels, r.image)
    };
    let one = with_threads(1, run);
    let two = with_threads(2, run);
    assert!(one.0.iter().filter(|p| p.x > 0.0).count() > 10);
    let bits = |v: &[caustica::color::Rgb]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&one.0), bits(&two.0));
    assert_eq!(bits(&one.1.pixels), bits(&two.1.pixels));
}
