//! Environment lights: a constant sky is a furnace for a convex diffuse object (every point sees the
//! whole sky over its hemisphere, so L = ρ·L_env); the photons it sends carry the flux that crosses
//! the object (E = π L_env on every surface element); photons aimed at glass from the sky keep the
//! caustic map's power equal to uniform emission's.
mod common;

use caustica::accel::Accel;
use caustica::integrator::photon_map::{build_maps, MapRequest};
use caustica::photon::trace::{CAUSTIC, DIRECT};
use caustica::pipeline::render_path;

const SKY: &str = "[camera]\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\nresolution = [32, 32]\n\
                   [[lights]]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n";

#[test]
fn a_diffuse_sphere_under_a_constant_sky_has_radiance_albedo_times_sky() {
    let scene = common::scene(&format!(
        "{SKY}[materials]\nm = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.6\nmaterial = \"m\"\n"
    ));
    let accel = Accel::new(&scene).unwrap();
    let img = render_path(&scene, &accel, 256, true).image;
    let (w, h) = (img.width as i32, img.height as i32);
    let (mut on, mut n_on) = (0.0f64, 0);
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x - w / 2, y - h / 2);
            let p = img.pixels[(y * w + x) as usize].x as f64;
            if dx * dx + dy * dy <= 25 {
                on += p;
                n_on += 1;
            } else if dx * dx + dy * dy >= 15 * 15 {
                assert!((p - 1.0).abs() < 1e-6, "background pixel ({x}, {y}) = {p}, want the sky's 1");
            }
        }
    }
    let on = on / n_on as f64;
    assert!((on - 0.5).abs() < 0.005, "sphere radiance {on}, want 0.5");
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
