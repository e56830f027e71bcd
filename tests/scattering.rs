//! Media that scatter (a dielectric's `albedo` and `phase_g` beside its `absorption`, Mitsuba's
//! `homogeneous` medium of albedo > 0), rendered by the path tracer: held to closed forms and to
//! themselves here, and to Mitsuba's volpath in `tests/mitsuba_import.rs` (`scatter.xml`).
mod common;
use caustica::film::Image;

/// A ball of glass under a white sky of radiance 1, filled with a medium that scatters all it meets
/// (albedo 1) and absorbs nothing: a white furnace, whose every pixel reads 1 whatever the medium's
/// extinction, the glass's index or roughness and the phase function. The extinction differs a
/// hundredfold between red and blue, so a path that scatters a hundred times in blue would, drawn by
/// red's free flights and weighted channel by channel at each flight, carry weights without bound; the
/// whole path's spectral MIS keeps them within three times a channel's own. Seen: weighting each flight
/// alone read 0.85 in blue, with pixels up to 9.4; the scattering's σ_s left out reads far below 1.
/// Rayleigh's phase function, tables over the cosine and blends of two lobes read 1 too (a phase
/// function whose samples' density is not its own, or that does not integrate to 1, reads otherwise).
#[test]
fn a_white_medium_in_a_white_furnace_reads_one() {
    // (Since session 77 also Rayleigh's phase function and blends of two lobes, `phase`.)
    let rayleigh = "0.0, phase = [{ type = \"rayleigh\" }]";
    let blend = "0.0, phase = [{ type = \"hg\", g = 0.8, weight = 0.6 }, { type = \"rayleigh\", weight = 0.4 }]";
    let two_hg = "0.0, phase = [{ type = \"hg\", g = 0.9, weight = 0.7 }, { type = \"hg\", g = -0.6, weight = 0.3 }]";
    // (Since session 81 tables over the cosine, Mitsuba's `tabphase`, alone and blended.)
    let table = "0.0, phase = [{ type = \"table\", values = [0.8, 0.3, 0.1, 0.05, 0.1, 0.4, 1.5, 6.0] }]";
    let table_hg =
        "0.0, phase = [{ type = \"table\", values = [2.0, 0.0, 0.0, 3.0], weight = 0.4 }, { type = \"hg\", g = -0.4, weight = 0.6 }]";
    for (glass, g) in [
        ("ior = 1.0", "0.0"),
        ("ior = 1.5", "0.7"),
        ("ior = 1.33", "-0.5"),
        ("ior = 1.0", rayleigh),
        ("ior = 1.5", blend),
        ("ior = 1.0", two_hg),
        ("ior = 1.5", table),
        ("ior = 1.0", table_hg),
    ] {
        let text = format!(
            "[camera]\nfov = 30\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\n\
             resolution = [16, 16]\n\
             [materials]\nfog = {{ type = \"dielectric\", {glass}, absorption = [0.1, 1.0, 10.0], \
             albedo = [1.0, 1.0, 1.0], phase_g = {g} }}\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"fog\"\n\
             [[lights]]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n\
             [render]\nmax_depth = 100000\nspp = 1024\n"
        );
        assert_reads_one(&common::render_image(&common::scene(&text)), &format!("{glass}, g = {g}"));
    }
}

/// Every channel of a furnace's image reads 1: its mean within 0.004 and every 4 × 4 block within 3%.
fn assert_reads_one(img: &Image, what: &str) {
    let n = img.pixels.len() as f64;
    for k in 0..3 {
        let mean = img.pixels.iter().map(|p| p[k] as f64).sum::<f64>() / n;
        let blocks = channel_blocks(img, k);
        let (lo, hi) = blocks.iter().fold((f64::MAX, f64::MIN), |(lo, hi), b| (lo.min(*b), hi.max(*b)));
        println!("{what}, channel {k}: mean {mean:.5}, 4 × 4 blocks {lo:.4} to {hi:.4}");
        assert!((mean - 1.0).abs() < 0.004, "{what}, channel {k}: mean {mean}");
        assert!(lo > 0.97 && hi < 1.03, "{what}, channel {k}: blocks {lo} to {hi}");
    }
}

/// RGB rendering keeps its channels apart: a coloured medium's image in each channel is the image of
/// the same scene whose medium is grey, of that channel's extinction and albedo. A ball of water
/// (index 1.33) holding a fog whose extinction differs a hundredfold between red and blue, with a
/// sphere light inside it (light sampled from the fog, and met by its phase samples, MIS-weighted) and
/// a quad light above a floor; each channel's mean within 0.5% of the grey scene's and each 4 × 4 block
/// within 5% of the grey's block or of its mean if that is larger (the caustics under the ball are
/// noisy where the image is dark). The other modes refuse the scene, naming the material.
#[test]
fn each_channel_of_a_coloured_medium_reads_as_a_grey_medium_of_its_own() {
    let sigma = [0.05f32, 0.5, 5.0];
    let albedo = [0.95f32, 0.8, 0.6];
    let text = |s: [f32; 3], a: [f32; 3]| {
        format!(
            "[camera]\nfov = 40\norigin = [0.0, 1.2, 4.0]\ntarget = [0.0, 0.6, 0.0]\nup = [0.0, 1.0, 0.0]\n\
             resolution = [24, 24]\n\
             [materials]\nfloor = {{ type = \"diffuse\", reflectance = [0.6, 0.6, 0.6] }}\n\
             fog = {{ type = \"dielectric\", ior = 1.33, absorption = [{}, {}, {}], albedo = [{}, {}, {}], \
             phase_g = 0.4 }}\n\
             [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\n\
             material = \"floor\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.8, 0.0]\nradius = 0.8\nmaterial = \"fog\"\n\
             [[lights]]\ntype = \"sphere\"\ncenter = [0.2, 0.9, 0.1]\nradius = 0.08\nradiance = [20.0, 20.0, 20.0]\n\
             [[lights]]\ntype = \"quad\"\ncorner = [-0.5, 3.0, -0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\n\
             radiance = [10.0, 10.0, 10.0]\n\
             [render]\nmax_depth = 64\nspp = 8192\n",
            s[0], s[1], s[2], a[0], a[1], a[2]
        )
    };
    let coloured = text(sigma, albedo);
    let img = common::render_image(&common::scene(&coloured));
    for k in 0..3 {
        let grey = common::render_image(&common::scene(&text([sigma[k]; 3], [albedo[k]; 3])));
        let (mine, theirs) = (channel_blocks(&img, k), channel_blocks(&grey, k));
        let mean = |b: &[f64]| b.iter().sum::<f64>() / b.len() as f64;
        let ratio = mean(&mine) / mean(&theirs);
        let m = mean(&theirs);
        let worst = mine.iter().zip(&theirs).map(|(a, b)| (a - b).abs() / b.max(m)).fold(0.0, f64::max);
        println!(
            "channel {k}: mean {ratio:.4} of the grey medium's, worst 4 × 4 block off by {:.1}% of itself or the mean",
            worst * 100.0
        );
        assert!((ratio - 1.0).abs() < 0.005, "channel {k}: mean {ratio} of the grey medium's");
        assert!(worst < 0.05, "channel {k}: a block off by {worst} of itself or the mean");
    }
    for mode in ["bdpt", "vcm", "sppm", "ppm", "photon_map", "both"] {
        let msg = common::render_error(&common::scene_in_mode(&coloured, mode, &[]), mode);
        assert!(msg.contains("`fog`") && msg.contains("--mode path"), "{mode}: {msg}");
    }
}

/// Each 4 × 4 block's mean of channel `k`.
fn channel_blocks(img: &Image, k: usize) -> Vec<f64> {
    let mut out = Vec::new();
    for by in (0..img.height).step_by(4) {
        for bx in (0..img.width).step_by(4) {
            let mut sum = 0.0;
            for y in by..by + 4 {
                for x in bx..bx + 4 {
                    sum += img.pixels[(y * img.width + x) as usize][k] as f64;
                }
            }
            out.push(sum / 16.0);
        }
    }
    out
}

/// Bad scattering settings are refused naming the key: an albedo above 1 or below 0, an albedo without
/// an absorption (the extinction it is a share of), a `phase_g` of 1 or without an albedo; a `phase`
/// beside a `phase_g`, without an albedo, of three lobes, of two whose weights miss or do not sum to 1,
/// a `hg` lobe without its g or with a g of 1, a g on another lobe, an unknown lobe, a table without
/// its values or with bad ones, values on another lobe; and a null surface
/// round a medium that emits, naming the shape.
#[test]
fn bad_scattering_settings_are_refused_naming_the_key() {
    for (fields, key) in [
        ("absorption = [1.0, 1.0, 1.0], albedo = [1.2, 0.5, 0.5]", "materials.fog.albedo"),
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, -0.1, 0.5]", "materials.fog.albedo"),
        ("albedo = [0.5, 0.5, 0.5]", "materials.fog.albedo"),
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase_g = 1.0", "materials.fog.phase_g"),
        ("absorption = [1.0, 1.0, 1.0], phase_g = 0.3", "materials.fog.phase_g"),
        (
            "outside_absorption = [1.0, 1.0, 1.0], outside_albedo = [0.5, 0.5, 0.5], outside_phase_g = -1.5",
            "materials.fog.outside_phase_g",
        ),
        // Phase functions as lobes (`phase`, since session 77).
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase_g = 0.3, phase = [{ type = \"rayleigh\" }]", "materials.fog.phase"),
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"hg\" }]", "materials.fog.phase[0]"),
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"rayleigh\", g = 0.3 }]", "materials.fog.phase[0].g"),
        (
            "absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"hg\", g = 0.5, weight = 0.5 }, { type = \"rayleigh\", weight = 0.6 }]",
            "materials.fog.phase",
        ),
        (
            "absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"hg\", g = 0.5, weight = 0.5 }, { type = \"rayleigh\" }]",
            "materials.fog.phase[1].weight",
        ),
        (
            "absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"rayleigh\" }, { type = \"rayleigh\" }, { type = \"isotropic\" }]",
            "materials.fog.phase",
        ),
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"mie\" }]", "mie"),
        ("absorption = [1.0, 1.0, 1.0], phase = [{ type = \"rayleigh\" }]", "materials.fog.phase"),
        (
            "outside_absorption = [1.0, 1.0, 1.0], outside_albedo = [0.5, 0.5, 0.5], outside_phase = [{ type = \"hg\", g = 1.0 }]",
            "materials.fog.outside_phase[0].g",
        ),
        // Tables over the cosine (since session 81): without values, values on another lobe, one
        // value, a negative one, only zeros.
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"table\" }]", "materials.fog.phase[0]"),
        (
            "absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"rayleigh\", values = [1.0, 2.0] }]",
            "materials.fog.phase[0].values",
        ),
        (
            "absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"table\", values = [1.0] }]",
            "materials.fog.phase[0].values",
        ),
        (
            "absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase = [{ type = \"table\", values = [1.0, -0.5, 2.0] }]",
            "materials.fog.phase[0].values",
        ),
        (
            "outside_absorption = [1.0, 1.0, 1.0], outside_albedo = [0.5, 0.5, 0.5], outside_phase = [{ type = \"table\", values = [0.0, 0.0] }]",
            "materials.fog.outside_phase[0].values",
        ),
    ] {
        let text = format!(
            "[camera]\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
             [materials]\nfog = {{ type = \"dielectric\", ior = 1.5, {fields} }}\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"fog\"\n\
             [[lights]]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n"
        );
        let err = common::load_error(&text, "fog.toml", fields);
        assert!(err.contains("fog.toml") && err.contains(key), "{fields}: {err}");
    }
    // A null surface round a medium that emits: an emitter is no see-through surface.
    let text = "[camera]\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
                [materials]\nsmoke = { type = \"null\", absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5] }\n\
                [[shapes]]\ntype = \"box\"\nmin = [-1.0, -1.0, -1.0]\nmax = [1.0, 1.0, 1.0]\nmaterial = \"smoke\"\n\
                emission = [1.0, 1.0, 1.0]\n";
    let err = common::load_error(text, "smoke.toml", "an emitting null surface round a medium");
    assert!(
        err.contains("smoke.toml") && err.contains("shapes[0]") && err.contains("null surface round a medium"),
        "{err}"
    );
}

/// A box of ink inside a `null` boundary (no surface, a medium that only absorbs σ; Mitsuba's null
/// boundary of a `homogeneous` medium), 0.5 thick, between a point light 2 above a white floor and the
/// floor, seen straight down by an orthographic camera: every pixel reads ρ/π · I cos θ / d² ·
/// e^(−σ·0.5 / cos θ) · e^(−σ·0.5), the shadow ray and the camera ray each dimmed by the ink they cross
/// (θ the light's angle at the floor point), within 0.2% (`max_depth` 1: crossing the boundary is no
/// bounce). Shadow rays that crossed it undimmed would read e^(σ·0.5) too much. The other modes refuse
/// the scene (their photons and light subpaths would cross the boundary as if it bounded nothing).
#[test]
fn ink_inside_a_null_boundary_dims_camera_and_shadow_rays() {
    let sigma = [0.4f32, 1.0, 2.5];
    let text = format!(
        "[camera]\nprojection = \"orthographic\"\nfilm_size = [0.2, 0.2]\norigin = [0.0, 3.0, 0.0]\n\
         target = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nresolution = [8, 8]\n\
         [materials]\nfloor = {{ type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }}\n\
         ink = {{ type = \"null\", absorption = [{}, {}, {}] }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-3.0, 0.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\n\
         material = \"floor\"\n\
         [[shapes]]\ntype = \"box\"\nmin = [-3.0, 0.5, -3.0]\nmax = [3.0, 1.0, 3.0]\nmaterial = \"ink\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\npower = [10.0, 10.0, 10.0]\n\
         [render]\nmax_depth = 1\nspp = 4\n",
        sigma[0], sigma[1], sigma[2]
    );
    let scene = common::scene(&text);
    assert!(scene.see_through_media);
    let img = common::render_image(&scene);
    let intensity = 10.0 / (4.0 * std::f64::consts::PI);
    for y in 0..8u32 {
        for x in 0..8u32 {
            // The pixel's centre on the floor (x across, z down the film: up is −z).
            let (px, pz) = ((x as f64 + 0.5) / 8.0 * 0.2 - 0.1, (y as f64 + 0.5) / 8.0 * 0.2 - 0.1);
            let d2 = px * px + pz * pz + 4.0;
            let cos = 2.0 / d2.sqrt();
            for (k, s) in sigma.iter().map(|s| *s as f64).enumerate() {
                let want =
                    0.8 / std::f64::consts::PI * intensity * cos / d2 * (-s * 0.5 / cos).exp() * (-s * 0.5).exp();
                let got = img.pixels[(y * 8 + x) as usize][k] as f64;
                assert!((got / want - 1.0).abs() < 2e-3, "pixel ({x}, {y}) channel {k}: {got} where {want} is due");
            }
        }
    }
    // The other modes refuse it, naming the material.
    let msg = common::render_error(&common::scene_in_mode(&text, "sppm", &[]), "sppm, ink in a null box");
    assert!(msg.contains("`ink`") && msg.contains("--mode path"), "{msg}");
}

/// A camera in a medium that only absorbs (`camera.medium`, Mitsuba's sensor `medium`), looking
/// straight (orthographic) at a quad light of radiance 1 at distance 4: every pixel reads e^(−σ·4),
/// and with a near clipping plane at 1.5 e^(−σ·2.5), the medium starting at the plane as Mitsuba's
/// camera rays start there (σ differing per channel); past a mirror that bounds no medium to a light
/// 6 behind it, e^(−σ·10) (seen: e^(−σ·4) where the path lost the medium at the mirror in a scene
/// without boundaries). With nothing but a white sky, infinitely far
/// beyond the medium, a channel of σ 0 sees the sky and the others nothing, with and without a far
/// clipping plane (past which the view leaves through the rest of the medium). Every other mode
/// refuses a camera in a medium, naming `camera.medium` and `--mode path`. Refused before (an unknown
/// key): seen failing.
#[test]
fn a_camera_in_an_absorbing_medium_sees_from_its_near_plane() {
    let sigma = [0.1f32, 0.5, 1.0];
    let text = |clip: &str| {
        format!(
            "[camera]\nprojection = \"orthographic\"\nfilm_size = [2.0, 2.0]\norigin = [0.0, 0.0, 4.0]\n\
             target = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n{clip}\n\
             [camera.medium]\nabsorption = [{}, {}, {}]\n\
             [[lights]]\ntype = \"quad\"\ncorner = [-5.0, -5.0, 0.0]\nedge_u = [10.0, 0.0, 0.0]\n\
             edge_v = [0.0, 10.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\n\
             [render]\nspp = 4\n",
            sigma[0], sigma[1], sigma[2]
        )
    };
    for (clip, len) in [("", 4.0f32), ("near_clip = 1.5", 2.5)] {
        let img = common::render_image(&common::scene(&text(clip)));
        for p in &img.pixels {
            for k in 0..3 {
                let want = (-sigma[k] * len).exp();
                assert!((p[k] / want - 1.0).abs() < 1e-3, "{clip:?}: channel {k} reads {} for {want}", p[k]);
            }
        }
    }
    // Past a mirror at z = 0 back up to a quad light at z = 6 facing it, behind the camera: the path
    // keeps the camera's medium where it reflects (the mirror bounds none), e^(−σ·(4 + 6)).
    let mirror = format!(
        "[camera]\nprojection = \"orthographic\"\nfilm_size = [2.0, 2.0]\norigin = [0.0, 0.0, 4.0]\n\
         target = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
         [camera.medium]\nabsorption = [{}, {}, {}]\n\
         [materials]\nmirror = {{ type = \"mirror\" }}\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-5.0, -5.0, 0.0]\nedge_u = [10.0, 0.0, 0.0]\n\
         edge_v = [0.0, 10.0, 0.0]\nmaterial = \"mirror\"\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-5.0, -5.0, 6.0]\nedge_u = [0.0, 10.0, 0.0]\n\
         edge_v = [10.0, 0.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\n\
         [render]\nspp = 4\n",
        sigma[0], sigma[1], sigma[2]
    );
    let img = common::render_image(&common::scene(&mirror));
    for p in &img.pixels {
        for k in 0..3 {
            let want = (-sigma[k] * 10.0).exp();
            assert!((p[k] / want - 1.0).abs() < 1e-3, "past a mirror: channel {k} reads {} for {want}", p[k]);
        }
    }
    for clip in ["", "far_clip = 3.0"] {
        let sky = format!(
            "[camera]\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n{clip}\n\
             [camera.medium]\nabsorption = [0.0, 0.5, 1.0]\n\
             [[lights]]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n[render]\nspp = 4\n"
        );
        let img = common::render_image(&common::scene(&sky));
        for p in &img.pixels {
            assert!((p[0] - 1.0).abs() < 1e-4 && p[1] == 0.0 && p[2] == 0.0, "{clip:?}: {p:?}");
        }
    }
    for mode in ["bdpt", "vcm", "sppm", "ppm", "photon_map", "both"] {
        let msg = common::render_error(&common::scene_in_mode(&text(""), mode, &[]), mode);
        assert!(msg.contains("camera.medium") && msg.contains("--mode path"), "{mode}: {msg}");
    }
}

/// A camera in a white medium (albedo 1, no absorption; extinction differing a hundredfold between
/// red and blue, Henyey–Greenstein g 0.6) inside a sphere that emits radiance ½ inwards and reflects
/// half the light it meets (diffuse): a furnace whose radiance L = ½ + ½L is 1 everywhere, so every
/// pixel reads 1. A path that started in vacuum, lost the medium where it bounced off the sphere (which
/// bounds none; seen: the path kept none in a scene without boundaries, 0.93 in red and 0.73 in blue),
/// or left its σ_s out, reads otherwise.
#[test]
fn a_camera_in_a_white_medium_in_a_white_furnace_reads_one() {
    let text = "[camera]\nfov = 60\norigin = [0.0, 0.0, 0.5]\ntarget = [0.0, 0.0, 0.0]\nresolution = [16, 16]\n\
                [camera.medium]\nabsorption = [0.1, 1.0, 10.0]\nalbedo = [1.0, 1.0, 1.0]\nphase_g = 0.6\n\
                [materials]\ngrey = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
                [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 2.0\nmaterial = \"grey\"\n\
                flip_normals = true\nemission = [0.5, 0.5, 0.5]\n\
                [render]\nmax_depth = 100000\nspp = 1024\n";
    assert_reads_one(&common::render_image(&common::scene(text)), "a camera in a white medium");
}

/// Bad camera media are refused naming the file and the key: a negative or non-finite absorption, an
/// albedo above 1 or without absorption, a phase_g of 1, an unknown key.
#[test]
fn bad_camera_media_are_refused_naming_the_key() {
    for (fields, key) in [
        ("absorption = [-1.0, 1.0, 1.0]", "camera.medium.absorption"),
        ("absorption = [1.0, 1.0, 1.0], albedo = [1.5, 0.5, 0.5]", "camera.medium.albedo"),
        ("absorption = [0.0, 0.0, 0.0], albedo = [0.5, 0.5, 0.5]", "camera.medium.albedo"),
        ("absorption = [1.0, 1.0, 1.0], albedo = [0.5, 0.5, 0.5], phase_g = 1.0", "camera.medium.phase_g"),
        ("absorption = [1.0, 1.0, 1.0], phase_g = 0.5", "camera.medium.phase_g"),
        ("absorption = [1.0, 1.0, 1.0], sigma_s = [0.5, 0.5, 0.5]", "sigma_s"),
        ("albedo = [0.5, 0.5, 0.5]", "absorption"),
        ("absorption = [inf, 1.0, 1.0]", "camera.medium.absorption"),
    ] {
        let text = format!(
            "[camera]\norigin = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
             medium = {{ {fields} }}\n\
             [[lights]]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n"
        );
        let err = common::load_error(&text, "fogcam.toml", fields);
        assert!(err.contains("fogcam.toml") && err.contains(key), "{fields}: {err}");
    }
}
