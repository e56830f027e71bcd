//! Malformed scenes: each must end with a non-zero exit, no panic, and a message naming the file and
//! the key (or line) that is wrong. A failed run must not touch existing outputs.
mod common;
use common::widened_exr;
use std::path::{Path, PathBuf};
use std::process::Command;

const GOOD: &str = r#"
[camera]
origin = [0.0, 1.0, 3.0]
target = [0.0, 1.0, 0.0]
fov = 40
resolution = [8, 8]

[materials]
white = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }

[[shapes]]
type = "quad"
corner = [-1.0, 0.0, -1.0]
edge_u = [0.0, 0.0, 2.0]
edge_v = [2.0, 0.0, 0.0]
material = "white"

[[lights]]
type = "point"
position = [0.0, 1.5, 0.0]
power = [10.0, 10.0, 10.0]
"#;

/// `GOOD` with its one material, `white`, replaced by `line` (a whole `white = …` line).
fn with_white(line: &str) -> String {
    GOOD.replace("white = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }", line)
}

/// `GOOD` with its quad emitting the radiance the image `file` holds (a texture named `glow`).
fn glowing(file: &str) -> String {
    with_textures(
        GOOD.replace("material = \"white\"", "material = \"white\"\nemission = \"glow\""),
        &format!("glow = {{ type = \"bitmap\", file = \"{file}\" }}"),
    )
}

/// `scene` with a `[textures]` table of `lines` (whole `name = { … }` lines) before its materials.
fn with_textures(scene: String, lines: &str) -> String {
    scene.replace("[materials]", &format!("[textures]\n{lines}\n\n[materials]"))
}

/// `GOOD` with its material `white` a normal map (a checkerboard of normals, `saw`) over a material `d`
/// that `rest` (whole lines) defines; `extra` ends white's table (`, key = value`).
fn normal_mapped(extra: &str, rest: &str) -> String {
    with_textures(
        with_white(&format!(
            "white = {{ type = \"normalmap\", normal_map = \"saw\", material = \"d\"{extra} }}\n{rest}"
        )),
        "saw = { type = \"checkerboard\" }",
    )
}

/// `GOOD` with its quad's type and geometry (the lines before its material) replaced by `shape`.
fn with_shape(shape: &str) -> String {
    GOOD.replace(
        "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]",
        shape,
    )
}

/// `GOOD` with its material `white` a bump map of the `[textures]` entry `h` (defined by `texture`, an
/// inline table) over a diffuse `d`; `extra` ends white's table (`, key = value`).
fn bump_mapped(extra: &str, texture: &str) -> String {
    with_textures(
        with_white(&format!(
            "white = {{ type = \"bumpmap\", height = \"h\", material = \"d\"{extra} }}\nd = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}"
        )),
        &format!("h = {texture}"),
    )
}

/// `GOOD` with the camera's pixel filter `filter` (an inline table).
fn with_filter(filter: &str) -> String {
    with_camera(&format!("filter = {filter}"))
}

/// `white` as the top of a chain of `n` blends, each of a diffuse surface and the next.
fn deep_blends(n: usize) -> String {
    let mut lines = vec!["white = { type = \"blend\", first = \"d\", second = \"m1\" }".to_string()];
    lines.push("d = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }".into());
    for i in 1..n {
        lines.push(format!("m{i} = {{ type = \"blend\", first = \"d\", second = \"m{}\" }}", i + 1));
    }
    lines.push(format!("m{n} = {{ type = \"null\" }}"));
    lines.join("\n")
}

/// GOOD with `lines` added to its `[camera]`.
fn with_camera(lines: &str) -> String {
    GOOD.replace("resolution = [8, 8]", &format!("resolution = [8, 8]\n{lines}"))
}

/// `GOOD` with its point light a spot straight down, `lines` (`\n`-separated) added to it.
fn with_spot(lines: &str) -> String {
    GOOD.replace(
        "type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]",
        &format!("type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\npower = [10.0, 10.0, 10.0]\n{lines}"),
    )
}

/// `GOOD` with an orthographic camera (no `fov`) and `lines` added to it.
fn orthographic(lines: &str) -> String {
    with_camera(&format!("projection = \"orthographic\"\n{lines}")).replace("fov = 40\n", "")
}

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-bad-input-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(scene_path: &Path, extra: &[&str]) -> (i32, String) {
    let out = dir().join("out/img");
    let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene_path.to_str().unwrap(), "-q", "-o", out.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap();
    (o.status.code().unwrap_or(-1), String::from_utf8_lossy(&o.stderr).to_string())
}

fn check(name: &str, text: &str, extra: &[&str], expect: &[&str]) {
    let p = dir().join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    let (code, err) = run(&p, extra);
    assert_ne!(code, 0, "{name}: expected failure, got success");
    assert!(!err.contains("panicked"), "{name}: panicked: {err}");
    assert!(err.contains(&format!("{name}.toml")), "{name}: message does not name the file: {err}");
    for e in expect {
        assert!(err.contains(e), "{name}: message lacks `{e}`: {err}");
    }
}

#[test]
fn the_good_scene_renders() {
    let p = dir().join("good.toml");
    std::fs::write(&p, GOOD).unwrap();
    let (code, err) = run(&p, &[]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn each_malformed_scene_gets_its_own_message() {
    let d = dir();
    std::fs::write(d.join("nan.obj"), "v 0 0 0\nv 1 0 nan\nv 0 1 0\nv inf 1 1\nf 1 2 3\nf 1 3 4\n").unwrap();
    std::fs::write(d.join("nomtl.obj"), "mtllib gone.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    // MTL diffuse maps out of [0, 1]: a negative texel, and one of 1e32 (a surface adding light).
    for (name, map) in [("negmap", "negative.exr"), ("hotmap", "blinding.exr")] {
        let obj =
            format!("mtllib {name}.mtl\nusemtl m\nvt 0 0\nvt 1 0\nvt 0 1\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n");
        std::fs::write(d.join(format!("{name}.obj")), obj).unwrap();
        std::fs::write(d.join(format!("{name}.mtl")), format!("newmtl m\nmap_Kd {map}\n")).unwrap();
    }
    std::fs::write(d.join("text.serialized"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(d.join("short.ply"), "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n").unwrap();
    let mut negative = caustica::film::Image::new(2, 1);
    negative.pixels[1] = glam::Vec3::new(1.0, -0.5, 1.0);
    caustica::output::write_exr(&d.join("negative.exr"), &negative).unwrap();
    // Negative in one texel, positive on average (a spot projecting it still has positive power).
    negative.pixels[0] = glam::Vec3::ONE;
    caustica::output::write_exr(&d.join("dip.exr"), &negative).unwrap();
    let mut blinding = caustica::film::Image::new(2, 1);
    blinding.pixels[0] = glam::Vec3::splat(1e32);
    caustica::output::write_exr(&d.join("blinding.exr"), &blinding).unwrap();
    std::fs::write(d.join("far.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 1e15\nf 1 2 3\n").unwrap();
    // Found by fuzz seed 11: a damaged PIZ-compressed sky whose data window claims 10^9 columns. The EXR
    // crate sized one block's buffer by the window (192 GB; the fuzz's, 238 GB) and the allocation aborted the process.
    std::fs::write(d.join("wide.exr"), widened_exr()).unwrap();
    // A PFM whose header claims more pixels than the file holds, and one claiming 10^10 texels.
    std::fs::write(d.join("short.pfm"), [&b"PF\n64 32\n-1.0\n"[..], &[0u8; 100]].concat()).unwrap();
    std::fs::write(d.join("vast.pfm"), [&b"Pf 100000 100000 1 "[..], &[0u8; 100]].concat()).unwrap();
    std::fs::write(d.join("nouv.obj"), "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 3 2\n").unwrap();
    let ply = |props: &str, rows: &str| {
        format!("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n{props}element face 1\nproperty list uchar int vertex_indices\nend_header\n{rows}3 0 2 1\n")
    };
    let rgb = "property float r\nproperty float g\nproperty float b\n";
    std::fs::write(d.join("bright.ply"), ply(rgb, "-1 0 -1 0.5 0.5 0.5\n1 0 -1 0.5 1.5 0.5\n0 0 1 0 0 0\n")).unwrap();
    std::fs::write(d.join("red.ply"), ply("property uchar red\n", "-1 0 -1 9\n1 0 -1 9\n0 0 1 9\n")).unwrap();
    let faces = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nproperty float r\nproperty float g\nproperty float b\nend_header\n-1 0 -1\n1 0 -1\n0 0 1\n0 1 0\n3 0 2 1 0.5 0.5 0.5\n3 0 1 3 0.2 0.2 1.25\n";
    std::fs::write(d.join("bright-faces.ply"), faces).unwrap();
    let mixed = faces
        .replace("property float b", "property uchar b")
        .replace("0.5 0.5 0.5\n", "0.5 0.5 128\n")
        .replace("1.25\n", "255\n");
    std::fs::write(d.join("mixed-faces.ply"), mixed).unwrap();
    let cases: Vec<(&str, String, Vec<&str>, Vec<&str>)> = vec![
        ("syntax", GOOD.replace("fov = 40", "fov = = 40"), vec![], vec!["line 5"]),
        ("unknown_key", GOOD.replace("fov = 40", "fovv = 40"), vec![], vec!["unknown field `fovv`", "line 5"]),
        ("wrong_type", GOOD.replace("fov = 40", "fov = \"wide\""), vec![], vec!["invalid type", "line 5"]),
        (
            "unknown_material",
            GOOD.replace("material = \"white\"", "material = \"gold\""),
            vec![],
            vec!["shapes[0].material", "unknown material `gold`"],
        ),
        (
            "missing_mesh",
            with_shape("type = \"mesh\"\nfile = \"nowhere.ply\""),
            vec![],
            vec!["nowhere.ply", "not found"],
        ),
        ("not_finite", GOOD.replace("fov = 40", "fov = nan"), vec![], vec!["camera.fov", "not finite"]),
        (
            // The mesh's colour was to come from an MTL file that is missing: say which.
            "missing_mtl",
            GOOD.replace(
                "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"white\"",
                "type = \"mesh\"\nfile = \"nomtl.obj\"",
            ),
            vec![],
            vec!["shapes[0].material", "no MTL colour", "gone.mtl"],
        ),
        (
            // No photon gathered: the map's light would be silently left out (the Cornell box's mean
            // read 0.78 with `gather.indirect = 0`).
            "gather_nothing",
            format!("{GOOD}\n[render.gather]\nindirect = 0\n"),
            vec![],
            vec!["render.gather.indirect", "≥ 1"],
        ),
        (
            "vcm_does_nothing",
            format!("{GOOD}\n[render]\nmode = \"vcm\"\n[render.vcm]\nconnect = false\nmerge = false\n"),
            vec![],
            vec!["render.vcm", "both false"],
        ),
        (
            "degenerate_transform",
            GOOD.replace("material = \"white\"", "material = \"white\"\ntransform = { scale = [1.0, 0.0, 1.0] }"),
            vec![],
            vec!["shapes[0].transform", "degenerate"],
        ),
        (
            "zero_area_light",
            GOOD.replace(
                "type = \"point\"\nposition = [0.0, 1.5, 0.0]",
                "type = \"quad\"\ncorner = [0.0, 1.9, 0.0]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [2.0, 0.0, 0.0]",
            ),
            vec![],
            vec!["lights[0]", "zero area"],
        ),
        (
            "spot_two_directions",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nintensity = [1.0, 1.0, 1.0]"),
            vec![],
            vec!["lights[0]", "exactly one of `direction` or `target`"],
        ),
        (
            "spot_no_direction",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\nintensity = [1.0, 1.0, 1.0]"),
            vec![],
            vec!["lights[0]", "exactly one of `direction` or `target`"],
        ),
        (
            "spot_at_its_target",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ntarget = [0.0, 1.5, 0.0]\nintensity = [1.0, 1.0, 1.0]"),
            vec![],
            vec!["lights[0].target", "no direction"],
        ),
        // Anisotropic roughness (session 43; textures since session 44): across the tangent a number > 0 or
        // a texture, with a roughness along it that is not 0.
        (
            "anisotropic_unknown_texture",
            with_textures(with_white("white = { type = \"mirror\", roughness = \"saw\", roughness_v = \"grain\" }"), "saw = { type = \"checkerboard\" }"),
            vec![],
            vec!["materials.white.roughness_v", "`grain`"],
        ),
        (
            "anisotropic_texture_on_smooth",
            with_textures(with_white("white = { type = \"conductor\", preset = \"Au\", roughness_v = \"saw\" }"), "saw = { type = \"checkerboard\" }"),
            vec![],
            vec!["materials.white.roughness_v", "needs both `roughness` and `roughness_v` > 0"],
        ),
        (
            "anisotropic_roughness_range",
            with_white("white = { type = \"conductor\", preset = \"Au\", roughness = 0.1, roughness_v = 1.5 }"),
            vec![],
            vec!["materials.white.roughness_v", "[0, 1]", "got 1.5"],
        ),
        (
            "anisotropic_smooth",
            with_white("white = { type = \"dielectric\", ior = 1.5, roughness_v = 0.2 }"),
            vec![],
            vec!["materials.white.roughness_v", "both `roughness` and `roughness_v` > 0 (got 0 and 0.2)"],
        ),
        (
            "principled_anisotropic_range",
            with_white("white = { type = \"principled\", anisotropic = 1.5 }"),
            vec![],
            vec!["materials.white.anisotropic", "[0, 1]", "got 1.5"],
        ),
        // Cylinders (session 43).
        (
            "cylinder_radius",
            with_shape("type = \"cylinder\"\nradius = 0.0"),
            vec![],
            vec!["shapes[0].radius", "finite radius > 0, got 0"],
        ),
        (
            "cylinder_axis",
            with_shape("type = \"cylinder\"\np0 = [0.0, 1.0, 0.0]\np1 = [0.0, 1.0, 0.0]"),
            vec![],
            vec!["shapes[0].p1", "must differ from p0"],
        ),
        (
            "glass_roughness",
            with_white("white = { type = \"dielectric\", ior = 1.5, roughness = 1.5 }"),
            vec![],
            vec!["materials.white.roughness", "[0, 1]", "got 1.5"],
        ),
        (
            "plastic_ior",
            with_white("white = { type = \"plastic\", reflectance = [0.5, 0.5, 0.5], ior = 0.1 }"),
            vec![],
            vec!["materials.white.ior", "[0.25, 4]", "got 0.1"],
        ),
        (
            "plastic_reflectance",
            with_white("white = { type = \"plastic\", reflectance = [0.5, 1.5, 0.5] }"),
            vec![],
            vec!["materials.white.reflectance"],
        ),
        (
            "plastic_texture",
            with_white("white = { type = \"plastic\", reflectance = \"wood\" }"),
            vec![],
            vec!["materials.white.reflectance", "unknown texture `wood`"],
        ),
        (
            "filter_stddev",
            with_filter("{ type = \"gaussian\", stddev = 5.0 }"),
            vec![],
            vec!["camera.filter.stddev", "[0.1, 1]", "got 5"],
        ),
        (
            "filter_kind",
            with_filter("{ type = \"sinc\" }"),
            vec![],
            vec!["line 7", "sinc", "box", "tent", "gaussian", "mitchell", "catmullrom", "lanczos"],
        ),
        (
            "filter_mitchell_c",
            with_filter("{ type = \"mitchell\", c = 3.0 }"),
            vec![],
            vec!["camera.filter.c", "[0, 1]", "got 3"],
        ),
        (
            "filter_lanczos_lobes",
            with_filter("{ type = \"lanczos\", lobes = 40 }"),
            vec![],
            vec!["camera.filter.lobes", "[1, 8]", "got 40"],
        ),
        (
            "negative_aperture",
            with_camera("aperture_radius = -0.1"),
            vec![],
            vec!["camera.aperture_radius", "≥ 0", "got -0.1"],
        ),
        (
            "focus_at_the_lens",
            with_camera("aperture_radius = 0.1\nfocus_distance = 0.0"),
            vec![],
            vec!["camera.focus_distance", "> 0", "got 0"],
        ),
        (
            // Finite, but its rim is not: rays would leave from infinity.
            "lens_beyond_f32",
            with_camera("aperture_radius = 3.3e38")
                .replace("origin = [0.0, 1.0, 3.0]\ntarget = [0.0, 1.0, 0.0]", "origin = [1e38, 1.0, 3.0]\ntarget = [1e38, 1.0, 0.0]"),
            vec![],
            vec!["camera.aperture_radius", "3.3e38 puts the lens beyond f32's range"],
        ),
        (
            "negative_near_clip",
            with_camera("near_clip = -1.0"),
            vec![],
            vec!["camera.near_clip", "≥ 0", "got -1"],
        ),
        (
            "far_clip_before_near",
            with_camera("near_clip = 2.0\nfar_clip = 1.0"),
            vec![],
            vec!["camera.far_clip", "beyond near_clip (2)", "got 1"],
        ),
        (
            "orthographic_fov_and_film",
            with_camera("projection = \"orthographic\"\nfilm_size = [2.0, 2.0]"),
            vec![],
            vec!["camera.fov", "takes `film_size` or `fov`", "not both"],
        ),
        (
            "orthographic_lens",
            orthographic("aperture_radius = 0.1"),
            vec![],
            vec!["camera.aperture_radius", "an orthographic camera has no lens"],
        ),
        (
            "orthographic_film",
            orthographic("film_size = [2.0, -1.0]"),
            vec![],
            vec!["camera.film_size", "> 0", "got [2.0, -1.0]"],
        ),
        (
            // Each side finite, a pixel's area not: the density of a ray's origin would be 0.
            "orthographic_film_beyond_f32",
            orthographic("film_size = [3e38, 3e38]"),
            vec![],
            vec!["camera.film_size", "beyond f32's range", "got [3e38, 3e38]"],
        ),
        (
            "crop_off_the_film",
            with_camera("crop = [2, 0, 7, 8]"),
            vec![],
            vec!["camera.crop", "[2, 0, 7, 8]", "inside the 8×8 film", "x + width ≤ 8"],
        ),
        (
            "principal_point_offset_far",
            with_camera("principal_point_offset = [2000.0, 0.0]"),
            vec![],
            vec!["camera.principal_point_offset", "within ±1000", "[2000.0, 0.0]"],
        ),
        (
            "crop_empty",
            with_camera("crop = [0, 0, 0, 8]"),
            vec![],
            vec!["camera.crop", "at least one pixel"],
        ),
        (
            "perspective_film_size",
            with_camera("film_size = [2.0, 2.0]"),
            vec![],
            vec!["camera.film_size", "only with projection = \"orthographic\""],
        ),
        (
            "projection_kind",
            with_camera("projection = \"fisheye\""),
            vec![],
            vec!["projection = \"fisheye\"", "unknown variant `fisheye`", "orthographic"],
        ),
        (
            "spot_texture_unknown",
            with_spot("texture = \"slide\""),
            vec![],
            vec!["lights[0].texture", "`slide`"],
        ),
        (
            "spot_texture_wide",
            with_textures(with_spot("texture = \"slide\"\ncutoff_angle = 90"), "slide = { type = \"checkerboard\" }"),
            vec![],
            vec!["lights[0].cutoff_angle", "< 90 degrees, got 90"],
        ),
        (
            "spot_up_along_axis",
            with_textures(with_spot("texture = \"slide\""), "slide = { type = \"checkerboard\" }"),
            vec![],
            vec!["lights[0].up", "along the spot's axis"],
        ),
        (
            "spot_up_without_texture",
            with_spot("up = [1.0, 0.0, 0.0]"),
            vec![],
            vec!["lights[0].up", "this spot has none"],
        ),
        (
            "blend_of_itself",
            with_white(
                "white = { type = \"blend\", first = \"a\", second = \"b\" }\n\
                 a = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
                 b = { type = \"blend\", weight = 0.3, first = \"a\", second = \"white\" }",
            ),
            vec![],
            vec!["materials.b", "a blend that contains itself", "b → white → b"],
        ),
        (
            // Coloured glass (session 61): σ must be a finite number ≥ 0 per channel, an absorbing glass
            // belongs to a shape alone (a blend has no one inside), and a thin pane has no inside.
            "absorption_negative",
            with_white("white = { type = \"dielectric\", ior = 1.5, absorption = [0.5, -1.0, 0.0] }"),
            vec![],
            vec!["materials.white.absorption", "negative component"],
        ),
        (
            "absorption_not_finite",
            with_white("white = { type = \"dielectric\", ior = 1.5, absorption = [0.5, nan, 0.0] }"),
            vec![],
            vec!["materials.white.absorption", "not finite"],
        ),
        (
            "absorption_infinite",
            with_white("white = { type = \"dielectric\", ior = 1.5, absorption = [inf, 1.0, 1.0] }"),
            vec![],
            vec!["materials.white.absorption", "not finite"],
        ),
        (
            "absorbing_glass_in_a_blend",
            with_white(
                "white = { type = \"blend\", first = \"a\", second = \"amber\" }\n\
                 a = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
                 amber = { type = \"dielectric\", ior = 1.5, absorption = [0.2, 1.0, 3.0] }",
            ),
            vec![],
            vec!["materials.white.second", "`amber` absorbs inside"],
        ),
        (
            "absorption_on_thin_glass",
            with_white("white = { type = \"thin_dielectric\", ior = 1.5, absorption = [0.5, 1.0, 1.0] }"),
            vec![],
            vec!["line 9", "unknown field `absorption`"],
        ),
        (
            "blend_unknown_material",
            with_white("white = { type = \"blend\", first = \"white\", second = \"chalk\" }"),
            vec![],
            vec!["materials.white.second", "unknown material `chalk`"],
        ),
        (
            "sides_one_sided_back",
            with_white(
                "white = { type = \"sides\", front = \"d\", back = \"b\" }\nd = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\nb = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5], two_sided = false }",
            ),
            vec![],
            vec!["materials.white.back", "`b` is one-sided"],
        ),
        (
            "sides_unknown_material",
            with_white("white = { type = \"sides\", front = \"white\", back = \"chalk\" }"),
            vec![],
            vec!["materials.white.back", "unknown material `chalk`"],
        ),
        (
            "normalmap_unknown_texture",
            with_white("white = { type = \"normalmap\", normal_map = \"bumps\", material = \"d\" }\nd = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }"),
            vec![],
            vec!["materials.white.normal_map", "unknown texture `bumps`"],
        ),
        (
            "normalmap_over_blend",
            normal_mapped("", "d = { type = \"blend\", first = \"e\", second = \"e\" }\ne = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }"),
            vec![],
            vec!["materials.white.material", "`d` is a blend"],
        ),
        (
            "normalmap_over_pane",
            normal_mapped("", "d = { type = \"thin_dielectric\", ior = 1.5 }"),
            vec![],
            vec!["materials.white.material", "`d` is a thin pane"],
        ),
        (
            "normalmap_twice",
            normal_mapped("", "d = { type = \"normalmap\", normal_map = \"saw\", material = \"e\" }\ne = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }"),
            vec![],
            vec!["materials.white.material", "`d` has a normal map already"],
        ),
        (
            "normalmap_in_blend",
            with_textures(with_white("white = { type = \"blend\", first = \"m\", second = \"d\" }\nm = { type = \"normalmap\", normal_map = \"saw\", material = \"d\" }\nd = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }"), "saw = { type = \"checkerboard\" }"),
            vec![],
            vec!["materials.white.first", "`m` has a normal map"],
        ),
        (
            "normalmap_mirrored_glass",
            normal_mapped(", two_sided = true", "d = { type = \"dielectric\", ior = 1.5 }"),
            vec![],
            vec!["materials.white.two_sided", "`d` lets light through"],
        ),
        (
            "normalmap_without_uv",
            normal_mapped("", "d = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }").replace(
                "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]",
                "type = \"mesh\"\nfile = \"nouv.obj\"",
            ),
            vec![],
            vec!["shapes[0].material", "`white` has a normal map, which needs texture coordinates"],
        ),
        (
            "bumpmap_of_checkerboard",
            bump_mapped("", "{ type = \"checkerboard\" }"),
            vec![],
            vec!["materials.white.height", "`h` has no gradient"],
        ),
        (
            "bumpmap_infinite_scale",
            bump_mapped(", scale = inf", "{ type = \"bitmap\", file = \"negative.exr\" }"),
            vec![],
            vec!["materials.white.scale", "number inf is not finite"],
        ),
        (
            "bumpmap_without_uv",
            bump_mapped("", "{ type = \"bitmap\", file = \"negative.exr\" }").replace(
                "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]",
                "type = \"mesh\"\nfile = \"nouv.obj\"",
            ),
            vec![],
            vec!["shapes[0].material", "`white` has a bump map, which needs texture coordinates"],
        ),
        (
            "bumpmap_on_disk",
            bump_mapped("", "{ type = \"bitmap\", file = \"negative.exr\" }").replace(
                "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]",
                "type = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nradius = 1.0",
            ),
            vec![],
            vec!["shapes[0].material", "`white` has a bump map, not supported on a disk"],
        ),
        (
            "emission_unknown_texture",
            GOOD.replace("material = \"white\"", "material = \"white\"\nemission = \"glow\""),
            vec![],
            vec!["shapes[0].emission", "unknown texture `glow`"],
        ),
        (
            "emit_by_shading_normal_flat",
            with_shape("type = \"mesh\"\nfile = \"bright.ply\"\nemission = [1.0, 1.0, 1.0]\nemit_by_shading_normal = true"),
            vec![],
            vec!["shapes[0].emit_by_shading_normal", "is for an emitting mesh with smooth normals"],
        ),
        (
            "checkerboard_contains_itself",
            with_textures(
                with_white("white = { type = \"diffuse\", reflectance = \"a\" }"),
                "a = { type = \"checkerboard\", color1 = \"b\" }\nb = { type = \"checkerboard\", color0 = \"a\" }",
            ),
            vec![],
            vec!["textures.b.color0", "texture `a` contains itself (a → b → a)"],
        ),
        (
            "checkerboard_unknown_square",
            with_textures(
                with_white("white = { type = \"diffuse\", reflectance = \"a\" }"),
                "a = { type = \"checkerboard\", color1 = \"wood\" }",
            ),
            vec![],
            vec!["textures.a.color1", "unknown texture `wood`"],
        ),
        (
            "checkerboard_of_vertex_colours",
            with_textures(
                with_white("white = { type = \"diffuse\", reflectance = \"a\" }"),
                "a = { type = \"checkerboard\", color0 = \"vc\" }\nvc = { type = \"vertex_color\" }",
            ),
            vec![],
            vec!["textures.a.color0", "`vc` is a vertex_color texture, which a checkerboard's squares cannot show"],
        ),
        (
            "checkerboard_square_too_bright",
            with_textures(
                with_white("white = { type = \"diffuse\", reflectance = \"a\" }"),
                "a = { type = \"checkerboard\", color0 = \"b\" }\nb = { type = \"checkerboard\", color1 = [0.5, 1.5, 0.5] }",
            ),
            vec![],
            vec!["materials.white.reflectance", "texture `a` reaches 1.5"],
        ),
        (
            "vertex_colors_none",
            with_textures(with_white("white = { type = \"diffuse\", reflectance = \"vc\" }"), "vc = { type = \"vertex_color\" }"),
            vec![],
            vec!["shapes[0].material", "`white` reads vertex colours", "this shape has none"],
        ),
        (
            "vertex_colors_bright",
            with_textures(
                with_shape("type = \"mesh\"\nfile = \"bright.ply\"")
                    .replace("reflectance = [0.5, 0.5, 0.5]", "reflectance = \"vc\""),
                "vc = { type = \"vertex_color\" }",
            ),
            vec![],
            vec!["shapes[0]", "vertex 1's colour [0.5, 1.5, 0.5]", "leaves [0, 1]"],
        ),
        (
            "face_colors_none",
            with_textures(
                with_shape("type = \"mesh\"\nfile = \"bright.ply\"")
                    .replace("reflectance = [0.5, 0.5, 0.5]", "reflectance = \"fc\""),
                "fc = { type = \"face_color\" }",
            ),
            vec![],
            vec!["shapes[0].material", "`white` reads face colours (a face_color texture)", "this shape has none"],
        ),
        (
            "face_colors_bright",
            with_textures(
                with_shape("type = \"mesh\"\nfile = \"bright-faces.ply\"")
                    .replace("reflectance = [0.5, 0.5, 0.5]", "reflectance = \"fc\""),
                "fc = { type = \"face_color\", scale = 0.9 }",
            ),
            vec![],
            vec!["shapes[0]", "triangle 1's colour [0.2, 0.2, 1.25]", "face_color texture's scale 0.9", "leaves [0, 1]"],
        ),
        (
            "face_colors_mixed_types",
            with_shape("type = \"mesh\"\nfile = \"mixed-faces.ply\""),
            vec![],
            vec!["mixed-faces.ply", "PLY face colours", "not all of one type"],
        ),
        (
            "face_colors_emitted",
            with_textures(GOOD.replace("material = \"white\"", "material = \"white\"\nemission = \"fc\""), "fc = { type = \"face_color\" }"),
            vec![],
            vec!["shapes[0].emission", "`fc` is a face_color texture", "not as an emitter's radiance"],
        ),
        (
            "vertex_colors_red_only",
            with_shape("type = \"mesh\"\nfile = \"red.ply\""),
            vec![],
            vec!["red.ply", "has `red` but no `green`"],
        ),
        (
            "vertex_colors_emitted",
            with_textures(GOOD.replace("material = \"white\"", "material = \"white\"\nemission = \"vc\""), "vc = { type = \"vertex_color\" }"),
            vec![],
            vec!["shapes[0].emission", "`vc` is a vertex_color texture", "not as an emitter's radiance"],
        ),
        (
            "emission_negative_texture",
            glowing("negative.exr"),
            vec![],
            vec!["shapes[0].emission", "texture `glow` (negative.exr) reaches -0.5", "≥ 0"],
        ),
        (
            // Found by the damaged-file fuzz: a damaged sky.exr read as an emitter's radiance emitted
            // 6e32 W, and the error named the scene and the shape but not the file to look at.
            "emission_texture_beyond_f32",
            glowing("blinding.exr"),
            vec![],
            vec!["shapes[0]", "at most 1e30 W", "blinding.exr"],
        ),
        (
            "exr_window_beyond_any_image",
            glowing("wide.exr"),
            vec![],
            vec!["textures.glow.file", "wide.exr", "1000000000×32", "larger than"],
        ),
        (
            // Found by fuzz seed 16 through a damaged PFM: a reflectance texture's texels were held to at
            // most 1 but not to at least 0, and a negative one made samples NaN.
            "reflectance_texture_below_zero",
            with_textures(
                with_white("white = { type = \"diffuse\", reflectance = \"neg\" }"),
                "neg = { type = \"bitmap\", file = \"negative.exr\" }",
            ),
            vec![],
            vec!["materials.white.reflectance", "texture `neg` (negative.exr) reaches -0.5", "[0, 1]"],
        ),
        (
            "spot_texture_below_zero",
            with_textures(
                with_spot("texture = \"slide\"\nup = [1.0, 0.0, 0.0]"),
                "slide = { type = \"bitmap\", file = \"dip.exr\" }",
            ),
            vec![],
            vec!["lights[0].texture", "texture `slide` (dip.exr) reaches -0.5", "≥ 0"],
        ),
        (
            "mtl_map_below_zero",
            GOOD.replace(
                "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"white\"",
                "type = \"mesh\"\nfile = \"negmap.obj\"",
            ),
            vec![],
            vec!["shapes[0].file", "negative.exr", "reaches -0.5", "[0, 1]"],
        ),
        (
            "mtl_map_above_one",
            GOOD.replace(
                "type = \"quad\"\ncorner = [-1.0, 0.0, -1.0]\nedge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"white\"",
                "type = \"mesh\"\nfile = \"hotmap.obj\"",
            ),
            vec![],
            vec!["shapes[0].file", "blinding.exr reaches 1000000000", "[0, 1]"],
        ),
        (
            "pfm_shorter_than_its_header",
            glowing("short.pfm"),
            vec![],
            vec!["textures.glow.file", "short.pfm", "64×32", "needs 24576 bytes", "has 100", "truncated"],
        ),
        (
            "pfm_beyond_any_image",
            glowing("vast.pfm"),
            vec![],
            vec!["textures.glow.file", "vast.pfm", "100000×100000", "larger than"],
        ),
        (
            "blend_weight_range",
            with_white(
                "white = { type = \"blend\", weight = 1.5, first = \"n\", second = \"n\" }\nn = { type = \"null\" }",
            ),
            vec![],
            vec!["materials.white.weight", "[0, 1]", "got 1.5"],
        ),
        (
            "roughness_unknown_texture",
            with_white("white = { type = \"conductor\", eta = [0.2, 0.9, 1.1], k = [3.9, 2.4, 2.2], roughness = \"bumps\" }"),
            vec![],
            vec!["materials.white.roughness", "unknown texture `bumps`"],
        ),
        (
            "principled_weight_above_one",
            with_white("white = { type = \"principled\", metallic = 1.5 }"),
            vec![],
            vec!["materials.white.metallic", "[0, 1]", "got 1.5"],
        ),
        (
            "principled_metallic_unknown_texture",
            with_white("white = { type = \"principled\", metallic = \"shiny\" }"),
            vec![],
            vec!["materials.white.metallic", "unknown texture `shiny`"],
        ),
        (
            "principled_anisotropic_unknown_texture",
            with_white("white = { type = \"principled\", anisotropic = \"brushed\" }"),
            vec![],
            vec!["materials.white.anisotropic", "unknown texture `brushed`"],
        ),
        (
            "principled_metallic_wrong_type",
            with_white("white = { type = \"principled\", metallic = [0.5, 0.5, 0.5] }"),
            vec![],
            vec!["a number in [0, 1] or the name of a [textures] entry"],
        ),
        (
            "principled_eta_and_specular",
            with_white("white = { type = \"principled\", eta = 1.5, specular = 0.5 }"),
            vec![],
            vec!["materials.white", "`eta` or `specular`, not both"],
        ),
        (
            "principled_eta_zero",
            with_white("white = { type = \"principled\", eta = 0.0, spec_trans = 1.0 }"),
            vec![],
            vec!["materials.white.eta", "[0.25, 4]", "got 0"],
        ),
        (
            "principled_two_sided_transmitter",
            with_white("white = { type = \"principled\", spec_trans = 0.5, two_sided = true }"),
            vec![],
            vec!["materials.white.two_sided", "transmitting", "cannot be two-sided"],
        ),
        (
            "principled_unknown_roughness_texture",
            with_white("white = { type = \"principled\", roughness = \"bumps\" }"),
            vec![],
            vec!["materials.white.roughness", "unknown texture `bumps`"],
        ),
        (
            "tint_unknown_texture",
            with_white("white = { type = \"dielectric\", ior = 1.5, tint = \"stain\" }"),
            vec![],
            vec!["materials.white.tint", "unknown texture `stain`"],
        ),
        (
            "specular_texture_above_one",
            with_white(
                "white = { type = \"mirror\", specular = \"hot\" }\n\n[textures]\nhot = { type = \"checkerboard\", color0 = [2.0, 2.0, 2.0] }",
            ),
            vec![],
            vec!["materials.white.specular", "texture `hot` reaches 2", "a specular must be in [0, 1]"],
        ),
        (
            "blend_weight_texture",
            with_white("white = { type = \"blend\", weight = \"mask\", first = \"n\", second = \"n\" }\nn = { type = \"null\" }"),
            vec![],
            vec!["materials.white.weight", "unknown texture `mask`"],
        ),
        (
            // A chain of blends beyond any real scene (each would be walked at every hit).
            "blend_too_deep",
            with_white(&deep_blends(70)),
            vec![],
            vec!["blends nested deeper than 64"],
        ),
        (
            "rough_plastic_roughness",
            with_white("white = { type = \"plastic\", reflectance = [0.5, 0.5, 0.5], roughness = 2.0 }"),
            vec![],
            vec!["materials.white.roughness", "[0, 1]", "got 2"],
        ),
        (
            "rough_plastic_distribution",
            with_white("white = { type = \"plastic\", reflectance = [0.5, 0.5, 0.5], roughness = 0.2, distribution = \"blinn\" }"),
            vec![],
            vec!["line 9", "blinn", "ggx", "beckmann"],
        ),
        (
            "glass_distribution",
            with_white("white = { type = \"dielectric\", ior = 1.5, roughness = 0.2, distribution = \"phong\" }"),
            vec![],
            vec!["line 9", "phong", "ggx", "beckmann"],
        ),
        (
            "spot_cutoff",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\ncutoff_angle = 0.0"),
            vec![],
            vec!["lights[0].cutoff_angle", "(0, 180]", "got 0"],
        ),
        (
            "spot_beam_past_cutoff",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\ncutoff_angle = 20.0\nbeam_width = 25.0"),
            vec![],
            vec!["lights[0].beam_width", "[0, 20]", "got 25"],
        ),
        (
            "spot_intensity_and_power",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\npower = [1.0, 1.0, 1.0]"),
            vec![],
            vec!["lights[0]", "exactly one of `intensity` or `power`"],
        ),
        (
            "spot_negative",
            GOOD.replace("type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [1.0, -1.0, 1.0]"),
            vec![],
            vec!["lights[0].intensity", "negative"],
        ),
        (
            // Found by fuzz seed 16: a damaged Radiance sky whose texels reach 1e33 emitted beyond the
            // bound, and the error named the light but not its image.
            "sky_image_too_bright",
            GOOD.replace(
                "type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]",
                "type = \"envmap\"\nfile = \"blinding.exr\"",
            ),
            vec![],
            vec!["lights[0].file", "emits", "read from blinding.exr", "bounding disc", "texels"],
        ),
        (
            // A sky emits its radiance times the area of the scene's bounding disc: with a shape 1e30 away
            // that overflowed f32 and a quarter of the samples were NaN (found by the XML fuzz).
            "sky_around_a_huge_scene",
            GOOD.replace(
                "type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]",
                "type = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n[[shapes]]\ntype = \"sphere\"\ncenter = [1e30, 0.0, 0.0]\nradius = 1.0\nmaterial = \"white\"",
            ),
            vec![],
            vec!["lights[0]", "emits inf W", "bounding disc", "radius 5.000e29", "reached by shapes[1]"],
        ),
        (
            // The same with a mesh one of whose vertices (a damaged file's) lies 1e15 away: the message
            // names the mesh and its file, the real culprit, not the sky alone (found by the XML fuzz,
            // seed 7: a damaged PLY's vertex at 8e14 under a sky).
            "sky_around_a_mesh_with_a_far_vertex",
            GOOD.replace(
                "type = \"point\"\nposition = [0.0, 1.5, 0.0]\npower = [10.0, 10.0, 10.0]",
                "type = \"constant\"\nradiance = [1.0, 1.0, 1.0]\n[[shapes]]\ntype = \"mesh\"\nfile = \"far.obj\"\nmaterial = \"white\"",
            ),
            vec![],
            vec!["lights[0]", "emits", "bounding disc", "reached by shapes[1] (far.obj)"],
        ),
        (
            "lights_beyond_f32",
            GOOD.replace("power = [10.0, 10.0, 10.0]", "power = [3e38, 3e38, 3e38]\n[[lights]]\ntype = \"point\"\nposition = [0.5, 1.5, 0.0]\npower = [3e38, 3e38, 3e38]"),
            vec![],
            vec!["lights[", "emits 3.000e38 W", "at most 1e30 W"],
        ),
        (
            "negative_reflectance",
            GOOD.replace("[0.5, 0.5, 0.5]", "[0.5, -0.5, 0.5]"),
            vec![],
            vec!["materials.white.reflectance", "negative"],
        ),
        (
            "reflectance_above_one",
            GOOD.replace("[0.5, 0.5, 0.5]", "[0.5, 1.5, 0.5]"),
            vec![],
            vec!["materials.white.reflectance", "exceeds"],
        ),
        (
            "no_light",
            GOOD.replace("power = [10.0, 10.0, 10.0]", "power = [0.0, 0.0, 0.0]"),
            vec![],
            vec!["lights", "no light"],
        ),
        (
            "camera_degenerate",
            GOOD.replace("target = [0.0, 1.0, 0.0]", "target = [0.0, 1.0, 3.0]"),
            vec![],
            vec!["camera.target", "equals camera.origin"],
        ),
        (
            "nan_mesh",
            with_shape("type = \"mesh\"\nfile = \"nan.obj\""),
            vec![],
            vec!["nan.obj", "2 vertices have NaN or infinite"],
        ),
        (
            "truncated_ply",
            with_shape("type = \"mesh\"\nfile = \"short.ply\""),
            vec![],
            vec!["short.ply", "header says 3"],
        ),
        (
            "serialized_index",
            with_shape("type = \"mesh\"\nfile = \"nan.obj\"\nshape_index = 1"),
            vec![],
            vec!["shapes[0].file", "nan.obj", "shape_index is for a Mitsuba `.serialized` file"],
        ),
        (
            "serialized_flip_tex_coords",
            with_shape("type = \"mesh\"\nfile = \"text.serialized\"\nflip_tex_coords = true"),
            vec![],
            vec!["shapes[0].flip_tex_coords", "is read only for an OBJ or PLY file"],
        ),
        (
            "serialized_garbage",
            with_shape("type = \"mesh\"\nfile = \"text.serialized\""),
            vec![],
            vec!["text.serialized", "not a Mitsuba serialized mesh"],
        ),
        (
            "unknown_preset",
            with_white("white = { type = \"conductor\", preset = \"Unobtainium\" }"),
            vec![],
            vec!["materials.white.preset", "unknown metal"],
        ),
        (
            "huge_resolution",
            GOOD.replace("resolution = [8, 8]", "resolution = [100000, 100000]"),
            vec![],
            vec!["camera.resolution", "MiB"],
        ),
        (
            "unknown_shape",
            GOOD.replace("type = \"quad\"", "type = \"teapot\""),
            vec![],
            vec!["unknown variant `teapot`"],
        ),
        (
            "sphere_radius",
            with_shape("type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.0"),
            vec![],
            vec!["shapes[0].radius", "must be > 0"],
        ),
        ("bad_override", GOOD.to_string(), vec!["--set", "render.sppp=4"], vec!["unknown field `sppp`"]),
        (
            "too_many_photons",
            GOOD.to_string(),
            vec!["--set", "render.photons.caustic=100000000000"],
            vec!["render.photons", "GiB"],
        ),
        ("vcm_aim", GOOD.to_string(), vec!["--set", "render.vcm.aim=1.0"], vec!["render.vcm.aim", "[0, 1)"]),
        ("vcm_aim_nan", GOOD.to_string(), vec!["--set", "render.vcm.aim=nan"], vec!["render.vcm.aim"]),
        (
            "vcm_merge_primary",
            format!("{GOOD}\n[render.vcm]\nmerge_primary = \"caustic\"\n"),
            vec![],
            vec!["merge_primary", "line 24", "\"all\", \"caustics\" or \"none\""],
        ),
        (
            "vcm_merge_primary_set",
            GOOD.to_string(),
            vec!["--set", "render.vcm.merge_primary=3"],
            vec!["render.vcm.merge_primary", "\"caustics\""],
        ),
    ];
    assert!(cases.len() >= 12);
    for (name, text, extra, expect) in &cases {
        check(name, text, extra, expect);
    }
}

#[test]
fn missing_scene_file_is_named() {
    let (code, err) = run(Path::new("/definitely/not/here.toml"), &[]);
    assert_ne!(code, 0);
    assert!(err.contains("/definitely/not/here.toml") && err.contains("cannot read"), "{err}");
}

#[test]
fn a_failed_run_leaves_existing_outputs_alone() {
    let d = dir().join("keep");
    std::fs::create_dir_all(&d).unwrap();
    let img = d.join("img.png");
    std::fs::write(&img, b"precious").unwrap();
    let p = dir().join("broken.toml");
    std::fs::write(&p, GOOD.replace("fov = 40", "fov = 400")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", p.to_str().unwrap(), "-q", "-o", d.join("img").to_str().unwrap()])
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(std::fs::read(&img).unwrap(), b"precious");
    assert!(std::fs::read_dir(&d).unwrap().count() == 1, "a temporary file was left behind");
}

#[test]
fn a_run_that_fails_after_rendering_leaves_existing_outputs_intact() {
    // The scene is fine and renders; then the JSON's place is taken by a folder. The EXR and PNG of the
    // earlier run must survive untouched (all three files are renamed into place only once all are
    // written and nothing is in the way), and no temporary file may be left behind.
    let d = dir().join("after-render");
    std::fs::create_dir_all(d.join("img.json")).unwrap();
    std::fs::write(d.join("img.exr"), b"old exr").unwrap();
    std::fs::write(d.join("img.png"), b"old png").unwrap();
    let p = dir().join("fine.toml");
    std::fs::write(&p, GOOD).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", p.to_str().unwrap(), "-q", "--spp", "1", "-o", d.join("img").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("img.json") && !err.contains("panicked"), "{err}");
    assert_eq!(std::fs::read(d.join("img.exr")).unwrap(), b"old exr");
    assert_eq!(std::fs::read(d.join("img.png")).unwrap(), b"old png");
    let names: Vec<String> =
        std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().to_string()).collect();
    assert_eq!(names.len(), 3, "left behind: {names:?}");
}

#[test]
fn a_typed_extension_on_the_output_names_the_file_written() {
    let d = dir().join("ext");
    let p = dir().join("fine-ext.toml");
    std::fs::write(&p, GOOD).unwrap();
    for typed in ["img.exr", "img.png", "img.json", "img"] {
        let _ = std::fs::remove_dir_all(&d);
        let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .args(["render", p.to_str().unwrap(), "-q", "--spp", "1", "-o", d.join(typed).to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let mut names: Vec<String> =
            std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().to_string()).collect();
        names.sort();
        assert_eq!(names, ["img.exr", "img.json", "img.png"], "-o {typed}");
    }
}

#[test]
fn a_closed_pipe_ends_a_command_quietly() {
    // `caustica info scene | head -1`: the reader goes away before we print. No panic, no message,
    // exit 0 or 141 (SIGPIPE's), for the scene summary and for --help alike.
    let p = dir().join("fine-pipe.toml");
    std::fs::write(&p, GOOD).unwrap();
    for args in [vec!["info", p.to_str().unwrap()], vec!["--help"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(matches!(o.status.code(), Some(0) | Some(141)), "{args:?}: exit {:?}: {err}", o.status.code());
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
    }
}

/// Runs `caustica render PATH` for at most 30 s (killed after that) in 8 GB of address space; its exit
/// code (None: killed) and stderr.
fn run_for_at_most_30s(scene_path: &Path) -> (Option<i32>, String) {
    let out = dir().join("out/endless");
    run_args_for_at_most_30s(&["render", scene_path.to_str().unwrap(), "-q", "-o", out.to_str().unwrap()])
}

/// `caustica ARGS` for at most 30 s in 8 GB of address space: its exit code (None: killed) and stderr.
fn run_args_for_at_most_30s(args: &[&str]) -> (Option<i32>, String) {
    use std::io::Read;
    // At most 8 GB of address space: reading an endless file must not take the machine's memory.
    let mut child = Command::new("sh")
        .args(["-c", "ulimit -v 8000000; exec \"$@\"", "sh", env!("CARGO_BIN_EXE_caustica")])
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if start.elapsed().as_secs() >= 30 {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (code, err)
}

/// A file a scene names that never ends (`/dev/zero`) or blocks until someone writes to it (a named
/// pipe) is refused at once, named, as not a regular file: the scene itself, a mesh, a texture, a sky,
/// an XML `<include>` and a spectrum file (an OBJ's optional MTL is left out, with a warning). Before,
/// each read until memory ran out, aborted or waited forever.
#[test]
fn endless_and_blocking_files_are_refused_not_read() {
    let d = dir().join("endless");
    std::fs::create_dir_all(&d).unwrap();
    let fifo = d.join("pipe.png");
    let _ = std::fs::remove_file(&fifo);
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let sky_fifo = d.join("sky.exr");
    let _ = std::fs::remove_file(&sky_fifo);
    assert!(Command::new("mkfifo").arg(&sky_fifo).status().unwrap().success());
    let zero_ply = d.join("zero.ply");
    let _ = std::fs::remove_file(&zero_ply);
    std::os::unix::fs::symlink("/dev/zero", &zero_ply).unwrap();
    let toml = |name: &str, text: String| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let xml = |name: &str, inner: &str| {
        let p = d.join(name);
        std::fs::write(
            &p,
            format!(
                r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>{inner}</scene>"#
            ),
        )
        .unwrap();
        p
    };
    let cases: Vec<(PathBuf, &str)> = vec![
        (PathBuf::from("/dev/zero"), "/dev/zero"),
        (toml("mesh.toml", with_shape("type = \"mesh\"\nfile = \"zero.ply\"")), "zero.ply"),
        (
            toml(
                "texture.toml",
                with_white(
                    "white = { type = \"diffuse\", reflectance = \"pipe\" }\n\n[textures]\npipe = { type = \"bitmap\", file = \"pipe.png\" }",
                ),
            ),
            "pipe.png",
        ),
        (
            toml("sky.toml", format!("{GOOD}\n[[lights]]\ntype = \"envmap\"\nfile = \"sky.exr\"\n")),
            "sky.exr",
        ),
        (xml("include.xml", r#"<include filename="/dev/zero"/>"#), "/dev/zero"),
        (
            xml(
                "spd.xml",
                r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="/dev/zero"/></bsdf></shape>"#,
            ),
            "/dev/zero",
        ),
    ];
    // An OBJ's `mtllib` is optional where the scene gives the material: one that is `/dev/zero` or a
    // pipe is left out and the mesh renders; where the scene gives none, the error about the missing
    // material names the MTL as not a regular file. Before, the first aborted the process ("memory
    // allocation of 8589934592 bytes failed") and the second blocked forever.
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::fs::write(d.join("zero-mtl.obj"), format!("mtllib /dev/zero\n{tri}")).unwrap();
    std::fs::write(d.join("pipe-mtl.obj"), format!("mtllib pipe.png\n{tri}")).unwrap();
    // An MTL colour of two numbers panicked inside tobj (session 82): now the MTL's error, naming its line.
    std::fs::write(d.join("short.mtl"), "newmtl x\nKd 1 0\n").unwrap();
    std::fs::write(d.join("short-mtl.obj"), format!("mtllib short.mtl\nusemtl x\n{tri}")).unwrap();
    for obj in ["zero-mtl.obj", "pipe-mtl.obj", "short-mtl.obj"] {
        let path = toml(&format!("{obj}.toml"), with_shape(&format!("type = \"mesh\"\nfile = \"{obj}\"")));
        let (code, err) = run_for_at_most_30s(&path);
        assert_eq!(code, Some(0), "{obj}: {err}");
        let bare = toml(&format!("{obj}-bare.toml"), with_shape(&format!("type = \"mesh\"\nfile = \"{obj}\"")))
            .to_string_lossy()
            .to_string();
        let text = std::fs::read_to_string(&bare).unwrap().replace("material = \"white\"\n", "");
        std::fs::write(&bare, text).unwrap();
        let (code, err) = run_for_at_most_30s(Path::new(&bare));
        assert_eq!(code, Some(1), "{obj} without a material: {err}");
        assert!(!err.contains("panicked"), "{obj}: {err}");
        let (mtl, why) = match obj {
            "zero-mtl.obj" => ("/dev/zero", "not a regular file"),
            "pipe-mtl.obj" => ("pipe.png", "not a regular file"),
            _ => ("short.mtl", "line 2: `Kd 1 0`: needs three numbers"),
        };
        assert!(err.contains(mtl) && err.contains(why), "{obj}: {err}");
    }
    // The command line's own files too: a chart's CSV, images to compare.
    let pipe = fifo.to_str().unwrap();
    for args in [vec!["bench", "chart", pipe], vec!["compare", pipe, "/dev/zero"]] {
        let (code, err) = run_args_for_at_most_30s(&args);
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert!(err.contains(pipe) && err.contains("not a regular file"), "{args:?}: {err}");
    }
    for (path, named) in cases {
        let (code, err) = run_for_at_most_30s(&path);
        let shown = path.display().to_string();
        assert!(code.is_some(), "{shown}: still reading after 30 s (killed)");
        assert_ne!(code, Some(0), "{shown}: rendered");
        assert!(!err.contains("panicked"), "{shown}: panicked: {err}");
        assert!(err.contains(named) && err.contains("not a regular file"), "{shown}: {err}");
    }
}
