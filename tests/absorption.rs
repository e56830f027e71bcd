//! Coloured glass: a dielectric whose inside absorbs (`absorption`, σ per unit length; Mitsuba's
//! `homogeneous` interior medium of albedo 0), checked against Beer–Lambert's closed form and against
//! itself across modes. `tests/mitsuba_import.rs` (`absorb.xml`) holds it to Mitsuba's volpath.
mod common;
use caustica::film::Image;

const SIGMA: [f32; 3] = [0.2, 1.0, 3.0];

/// An orthographic camera looks straight down through a slab of glass of index 1 (no refraction, no
/// reflection), 0.5 thick, at a panel emitting radiance 1, 1 below it: every ray crosses exactly 0.5 of
/// the glass, so every pixel reads e^(−0.5σ) in each channel, in every mode (the camera's chains and
/// subpaths reach the panel through the glass; nothing else lights the film). Without the absorption
/// the pixels read 1; a segment measured along an unnormalised direction, or counted on the way in and
/// out, reads something else. With a near clipping plane in the middle of the slab the camera's rays
/// start inside the glass, in no medium (Mitsuba's sensor without one), and the pixels read 1: Mitsuba
/// renders random scene 2406 so, whose near plane cuts into an absorbing ball (its camera segment dimmed
/// there, caustica read 0.72 of Mitsuba's mean). A clear slab whose `outside_absorption` is σ (Mitsuba's
/// `exterior` medium): the segment from its underside to the panel, 1 long, starts outside it (and the
/// panel's light arrives at its outside), e^(−σ); the camera's segment above stays in none.
#[test]
fn a_slab_of_coloured_glass_lets_through_e_to_the_minus_sigma_d_in_every_mode() {
    let [r, g, b] = SIGMA;
    let text = |sides: &str| {
        format!(
            "[camera]\nprojection = \"orthographic\"\nfov = 30\norigin = [0.0, 3.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
             up = [0.0, 0.0, -1.0]\nresolution = [8, 8]\n\
             [materials]\nslab = {{ type = \"dielectric\", ior = 1.0, {sides} = [{r}, {g}, {b}] }}\n\
             [[shapes]]\ntype = \"box\"\nmin = [-3.0, 1.0, -3.0]\nmax = [3.0, 1.5, 3.0]\nmaterial = \"slab\"\n\
             [[lights]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\n\
             radiance = [1.0, 1.0, 1.0]\n\
             [render]\nmax_depth = 4\n"
        )
    };
    let through = SIGMA.map(|s| (-0.5 * s).exp());
    let below = SIGMA.map(|s| (-s).exp());
    for (sides, near, want) in [
        ("absorption", None, through),
        ("absorption", Some("camera.near_clip=1.75"), [1.0; 3]),
        ("outside_absorption", None, below),
    ] {
        every_mode_reads(&text(sides), near, want, &format!("{sides}, {near:?}"));
    }
}

/// Every mode (4 samples or passes; fixed PM without a caustic map, as nothing holds photons past the
/// glass) renders `text`, with the setting `extra` if any, as `want` in every pixel and channel within
/// 0.2%.
fn every_mode_reads(text: &str, extra: Option<&str>, want: [f32; 3], label: &str) {
    every_mode_reads_at(text, extra, label, |_| Some(want));
}

/// `every_mode_reads` with each pixel's due value `want(i)` (pixel i, row by row; None: not checked).
fn every_mode_reads_at(text: &str, extra: Option<&str>, label: &str, want: impl Fn(usize) -> Option<[f32; 3]>) {
    for (mode, sets) in [
        ("path", &["render.spp=4"][..]),
        ("bdpt", &["render.progressive.passes=4"][..]),
        ("vcm", &["render.progressive.passes=4"][..]),
        ("sppm", &["render.progressive.passes=4"][..]),
        ("ppm", &["render.progressive.passes=4"][..]),
        ("photon_map", &["render.pm_spp=4", "render.photons.caustic=0"][..]),
    ] {
        let sets: Vec<&str> = sets.iter().copied().chain(extra).collect();
        let img = common::render_image(&common::scene_in_mode(text, mode, &sets));
        for (i, p) in img.pixels.iter().enumerate() {
            let Some(want) = want(i) else { continue };
            for k in 0..3 {
                assert!(
                    (p[k] / want[k] - 1.0).abs() < 2e-3,
                    "{mode}, {label}: pixel {i} channel {k}: {} where {} is due",
                    p[k],
                    want[k]
                );
            }
        }
    }
}

/// A light inside coloured glass: a sphere light at the centre of an absorbing glass ball (index 1.5)
/// over a floor before a wall. Camera paths reach the light through the glass from outside, light
/// subpaths and photons start inside it; a light's first segment takes its medium from where it ends
/// (`Scene::absorbed_on_light_path`), the medium a camera path from there would start in, so every mode
/// must agree with the path tracer in every channel. With every segment's medium set at its start
/// alone, the light's first segment went undimmed for light tracing and photons: BDPT then read +6%,
/// +30%, +90% over PT (seen).
#[test]
fn a_light_inside_coloured_glass_reads_the_same_in_every_mode() {
    let text = "[camera]\norigin = [0.0, 1.6, 2.6]\ntarget = [0.0, 0.35, 0.0]\nfov = 45\nresolution = [32, 24]\n\
         [materials]\nfloor = { type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }\n\
         wall = { type = \"diffuse\", reflectance = [0.5, 0.6, 0.7] }\n\
         amber = { type = \"dielectric\", ior = 1.5, absorption = [0.5, 2.0, 4.0] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -2.0]\nedge_u = [0.0, 0.0, 4.0]\nedge_v = [4.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, -1.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"wall\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.45, 0.0]\nradius = 0.4\nmaterial = \"amber\"\n\
         [[lights]]\ntype = \"sphere\"\ncenter = [0.0, 0.45, 0.0]\nradius = 0.12\nradiance = [20.0, 20.0, 20.0]\n\
         [render]\nmax_depth = 8\n";
    let mean = |img: &Image| {
        let mut m = [0.0f64; 3];
        for p in &img.pixels {
            for k in 0..3 {
                m[k] += p[k] as f64 / img.pixels.len() as f64;
            }
        }
        m
    };
    let pt = mean(&common::render_image(&common::scene_in_mode(text, "path", &["render.spp=2048"])));
    for (mode, sets) in [
        ("bdpt", &["render.progressive.passes=256"][..]),
        ("vcm", &["render.progressive.passes=256"][..]),
        ("sppm", &["render.progressive.passes=128"][..]),
        ("photon_map", &["render.pm_spp=32"][..]),
    ] {
        let m = mean(&common::render_image(&common::scene_in_mode(text, mode, sets)));
        let ratio: Vec<f64> = (0..3).map(|k| m[k] / pt[k]).collect();
        println!("{mode}: {ratio:.4?} of PT's means");
        for (k, r) in ratio.iter().enumerate() {
            assert!((r - 1.0).abs() < 0.015, "{mode}: channel {k} mean {r:.4} of PT's");
        }
    }
}

/// A mirror inside coloured glass (`immersed`): an orthographic camera looks straight down into a box of
/// glass of index 1 whose inside absorbs σ, at a mirror tilted 45° within it (the plane y = 1 + x),
/// which sends every ray out through the box's side to a panel emitting radiance 1 beside it. Each ray
/// travels 1 − x down and then 1 + x across inside the glass: 2 in all, so every pixel reads e^(−2σ), in
/// every mode. The mirror bounds no medium and lies in the glass's: the segment that leaves it runs
/// through that medium too (Mitsuba's volpath carries a path's medium past such a surface). With the
/// medium set by the mirror's own sides (none), the pixels read e^(−σ(1 − x)) (the first pixel 0.759 in
/// red where 0.670 is due: seen failing). The loader says nothing: the mirror lies wholly in the glass.
#[test]
fn a_mirror_inside_coloured_glass_lies_in_its_medium_in_every_mode() {
    let text = mirror_in_glass(1.0);
    let scene = common::scene(&text);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    every_mode_reads(&text, None, SIGMA.map(|s| (-2.0 * s).exp()), "a mirror in the glass");
}

/// The scene of the two mirror tests: an orthographic camera looking straight down at a mirror in the
/// plane y = 1 + x (|x|, |z| ≤ 0.6) that sends every ray across to a panel of radiance 1 at x = −1.5,
/// in a box of glass of index 1 absorbing `SIGMA` over x ∈ [−1, `max_x`].
fn mirror_in_glass(max_x: f32) -> String {
    let [r, g, b] = SIGMA;
    format!(
        "[camera]\nprojection = \"orthographic\"\nfov = 10\norigin = [0.0, 5.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
         up = [0.0, 0.0, -1.0]\nresolution = [8, 8]\n\
         [materials]\nglass = {{ type = \"dielectric\", ior = 1.0, absorption = [{r}, {g}, {b}] }}\n\
         mirror = {{ type = \"mirror\" }}\n\
         [[shapes]]\ntype = \"box\"\nmin = [-1.0, 0.0, -1.0]\nmax = [{max_x:?}, 2.0, 1.0]\nmaterial = \"glass\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-0.6, 0.4, 0.6]\nedge_u = [1.2, 1.2, 0.0]\nedge_v = [0.0, 0.0, -1.2]\n\
         material = \"mirror\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-1.5, -2.0, -3.0]\nedge_u = [0.0, 6.0, 0.0]\nedge_v = [0.0, 0.0, 6.0]\n\
         radiance = [1.0, 1.0, 1.0]\n\
         [render]\nmax_depth = 6\n"
    )
}

/// A mirror half inside coloured glass: the box of glass of the test above filled only for x < 0, the
/// same mirror running out of it through its side at x = 0. A ray that meets the mirror inside the glass
/// (x < 0) travels 1 − x down and 1 + x across in it, 2 in all: e^(−2σ). One that meets it outside
/// (x > 0) reaches the mirror through air and the glass only on its way across, from x = 0 to x = −1:
/// e^(−σ). A path carries its medium past a surface that bounds none (Mitsuba's volpath), so the
/// mirror's two halves lie in different media; with one medium per shape (the one round most of it)
/// one half read the other's (the first pixel 0.759 in red where 0.670 is due: seen failing). Every
/// mode, the three columns of pixels on each side away from the line where the mirror leaves the glass
/// (a sample that meets the mirror within a ray offset of the glass's face starts its next segment past
/// that face, and one such sample in SPPM's four passes read a pixel there 1.1% high).
#[test]
fn a_mirror_half_inside_coloured_glass_lies_in_each_medium_in_every_mode() {
    let text = mirror_in_glass(0.0);
    let inside = SIGMA.map(|s| (-2.0 * s).exp());
    let outside = SIGMA.map(|s| (-s).exp());
    // Columns 0–2 meet the mirror in the glass, 5–7 outside it; 3 and 4 lie along the line between.
    let due = |i: usize| match i % 8 {
        0..=2 => Some(inside),
        5..=7 => Some(outside),
        _ => None,
    };
    every_mode_reads_at(&text, None, "a mirror half in the glass", due);
}

/// A floor that runs out of a tank of coloured water (glass of index 1 whose inside absorbs σ) over
/// more than half of it, under a point light above its dry part, beside a wall. Over the dry part every
/// mode must agree with the path tracer. The wet part is lit through the water's surface, light that
/// only merging finds (a point light's light through glass onto a surface seen through glass): there
/// VCM and fixed PM must agree with SPPM. Camera paths carry their medium past the floor
/// (`Scene::sigma_next`); light paths start in the medium round the light (`Scene::light_medium`: none
/// here). Taken from the side of the light's first hit instead, light that reached the dry floor
/// straight from the light started in the water round most of the floor.
#[test]
fn light_on_a_floor_partly_under_coloured_water_reads_the_same_in_every_mode() {
    let text = "[camera]\norigin = [0.0, 2.2, 2.6]\ntarget = [0.0, 0.0, 0.0]\nfov = 45\nresolution = [32, 24]\n\
         [materials]\nfloor = { type = \"diffuse\", reflectance = [0.7, 0.7, 0.7] }\n\
         wall = { type = \"diffuse\", reflectance = [0.5, 0.6, 0.7] }\n\
         water = { type = \"dielectric\", ior = 1.0, absorption = [0.5, 1.5, 3.0] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 1.5, 0.0]\nmaterial = \"wall\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-1.2, -0.1, -0.9]\nmax = [0.3, 0.5, 1.2]\nmaterial = \"water\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.65, 1.2, 0.3]\npower = [40.0, 40.0, 40.0]\n\
         [render]\nmax_depth = 6\n";
    // Each channel's sum over the film's columns left (the wet part) and right of column 20.
    let halves = |img: &Image| {
        let mut m = [[0.0f64; 3]; 2];
        for (i, p) in img.pixels.iter().enumerate() {
            let side = ((i as u32 % img.width) >= 20) as usize;
            for k in 0..3 {
                m[side][k] += p[k] as f64;
            }
        }
        m
    };
    let render = |mode: &str, sets: &[&str]| halves(&common::render_image(&common::scene_in_mode(text, mode, sets)));
    let pt = render("path", &["render.spp=1024"]);
    let sppm = render("sppm", &["render.progressive.passes=64"]);
    for (mode, m) in [
        ("bdpt", render("bdpt", &["render.progressive.passes=256"])),
        ("vcm", render("vcm", &["render.progressive.passes=256"])),
        ("sppm", sppm),
        ("photon_map", render("photon_map", &["render.pm_spp=16"])),
    ] {
        for (side, label, reference, by) in [(1, "dry", pt, "PT"), (0, "wet", sppm, "SPPM")] {
            if side == 0 && !matches!(mode, "vcm" | "photon_map") {
                continue;
            }
            let ratio: Vec<f64> = (0..3).map(|k| m[side][k] / reference[side][k]).collect();
            println!("{mode}, {label} part: {ratio:.4?} of {by}'s");
            for (k, r) in ratio.iter().enumerate() {
                assert!((r - 1.0).abs() < 0.02, "{mode}, {label} part: channel {k} {r:.4} of {by}'s");
            }
        }
    }
}
