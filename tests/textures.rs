//! Textures reach the BSDF at the right place: a checkerboard through a quad's texture coordinates and
//! a uv scale, and an MTL `map_Kd` image on an OBJ with texture coordinates (OBJ's v runs bottom-up, the
//! image's rows top-down), read back through real ray hits.
mod common;

use caustica::accel::{interact, Accel};
use caustica::math::Ray;
use glam::Vec3;

/// The reflectance seen by a ray straight down the −z axis through (x, y).
fn reflectance_at(scene: &caustica::scene::Scene, accel: &Accel, x: f32, y: f32) -> Vec3 {
    let ray = Ray::new(Vec3::new(x, y, 5.0), -Vec3::Z);
    let i = interact(scene, accel, &ray).expect("hit");
    scene.bsdf(&i.si, i.wo, || panic!("no blend here")).albedo()
}

#[test]
fn checkerboard_and_mtl_image_land_where_their_coordinates_say() {
    let scene = common::scene(
        "[camera]\norigin = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [textures]\nchecks = { type = \"checkerboard\", color0 = [0.9, 0.9, 0.9], color1 = [0.1, 0.2, 0.3], scale = [2.0, 2.0] }\n\
         [materials]\nfloor = { type = \"diffuse\", reflectance = \"checks\" }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [1.0, -1.0, 0.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"tests/mitsuba/tile-mtl.obj\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 3.0]\npower = [1.0, 1.0, 1.0]\n",
    );
    let accel = Accel::new(&scene).unwrap();
    // Quad over x ∈ [1, 3]: uv = ((x − 1)/2, (y + 1)/2), scaled by 2 → squares of ½ in uv' are ½ wide.
    let (c0, c1) = (Vec3::splat(0.9), Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(reflectance_at(&scene, &accel, 1.2, -0.8), c0);
    assert_eq!(reflectance_at(&scene, &accel, 1.7, -0.8), c1);
    assert_eq!(reflectance_at(&scene, &accel, 1.7, -0.3), c0);
    assert_eq!(reflectance_at(&scene, &accel, 2.2, -0.8), c0);
    // The tile: the centre of the image's top-left texel (white) is near its top-left corner; its top
    // half shows the red band, its bottom half green (left) and blue (right), sRGB-decoded, bilinear.
    let srgb = |v: f32| ((v / 255.0 + 0.055) / 1.055).powf(2.4);
    let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-3;
    assert!(near(reflectance_at(&scene, &accel, -0.4375, 0.375), Vec3::ONE));
    let red = Vec3::new(srgb(200.0), srgb(40.0), srgb(40.0));
    assert!(near(reflectance_at(&scene, &accel, 0.1, 0.3), red), "{}", reflectance_at(&scene, &accel, 0.1, 0.3));
    assert!(near(reflectance_at(&scene, &accel, -0.3, -0.3), Vec3::new(srgb(40.0), srgb(180.0), srgb(40.0))));
    assert!(near(reflectance_at(&scene, &accel, 0.3, -0.3), Vec3::new(srgb(40.0), srgb(40.0), srgb(200.0))));
}

#[test]
fn bad_textures_are_refused_naming_the_key() {
    let base = "[camera]\norigin = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\n\
                [[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 3.0]\npower = [1.0, 1.0, 1.0]\n";
    let cases = [
        ("[materials]\nm = { type = \"diffuse\", reflectance = \"nope\" }\n", "unknown texture `nope`"),
        ("[textures]\nt = { type = \"bitmap\", file = \"missing.png\" }\n", "textures.t.file"),
        ("[textures]\nt = { type = \"bitmap\", file = \"Cargo.toml\" }\n", "textures.t.file"),
        (
            "[textures]\nt = { type = \"checkerboard\", color0 = [2.0, 2.0, 2.0] }\n[materials]\nm = { type = \"diffuse\", reflectance = \"t\" }\n",
            "reflectance must be in [0, 1]",
        ),
        ("[materials]\nm = { type = \"diffuse\", reflectance = 0.5 }\n", "an [r, g, b] colour or the name of a [textures] entry"),
    ];
    for (extra, want) in cases {
        let text = format!("{base}{extra}");
        let msg = match caustica::scene::load_scene_str(
            &text,
            "t.toml",
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")),
            &[],
        ) {
            Ok(_) => panic!("accepted: {extra}"),
            Err(e) => e.to_string(),
        };
        assert!(msg.contains(want), "`{want}` not in: {msg}");
    }
}

/// Radiance HDR, BMP and TGA are read as Mitsuba's `Bitmap` reads them. `sky.hdr` is `sky.exr` written
/// out by Mitsuba 3.9.1's own RGBE writer: it must read as the EXR's linear values to RGBE's precision
/// (one 8-bit exponent a texel: within 1/128 of the texel's largest channel), not sRGB-decoded (which
/// would take 0.5 to 0.21), also when `raw`. `label.png` saved again as BMP and TGA (the `image`
/// crate's encoders) must read back texel for texel as the PNG does, sRGB-decoded unless `raw`.
#[test]
fn hdr_bmp_and_tga_images_read_as_mitsuba_reads_them() {
    use caustica::color::srgb_decode;
    use caustica::scene::texture::load_image;
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba");
    let (w, h, exr) = load_image(&src.join("sky.exr"), false).unwrap();
    for raw in [false, true] {
        let (w2, h2, hdr) = load_image(&src.join("sky.hdr"), raw).unwrap();
        assert_eq!((w2, h2), (w, h));
        let mut worst = 0.0f32;
        for (i, (a, b)) in exr.iter().zip(&hdr).enumerate() {
            let off = (*a - *b).abs().max_element() / a.max_element().max(1e-6);
            assert!(off <= 1.0 / 128.0, "sky.hdr (raw {raw}) texel {i}: {b} against the EXR's {a}");
            worst = worst.max(off);
        }
        assert!(worst > 0.0, "sky.hdr read exactly as the EXR: is it the EXR?");
    }
    let dir = std::env::temp_dir().join(format!("caustica-formats-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let label = image::open(src.join("label.png")).unwrap();
    for raw in [false, true] {
        let png = load_image(&src.join("label.png"), raw).unwrap();
        for ext in ["bmp", "tga"] {
            let file = dir.join(format!("label.{ext}"));
            label.save(&file).unwrap();
            assert_eq!(load_image(&file, raw).unwrap(), png, "label.{ext}, raw {raw}");
        }
    }
    // Unless raw, each texel is the sRGB decoding of its raw value (8-bit 128 reads 0.2158, not 0.502).
    let (decoded, raw) =
        (load_image(&src.join("label.png"), false).unwrap(), load_image(&src.join("label.png"), true).unwrap());
    let decode = |c: Vec3| Vec3::new(srgb_decode(c.x), srgb_decode(c.y), srgb_decode(c.z));
    assert!(decoded.2.iter().zip(&raw.2).all(|(d, r)| (*d - decode(*r)).abs().max_element() < 1e-6));
    assert!(
        decoded.2.iter().zip(&raw.2).any(|(d, r)| (*d - *r).abs().max_element() > 0.1),
        "label.png has no mid-tone"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// PFM and PPM are read as Mitsuba's `Bitmap` reads them. `label.pfm` is `label.png` converted to linear
/// 32-bit floats and written by Mitsuba 3.9.1 (`Bitmap.convert(RGB, Float32, False).write`); `label.ppm`
/// is `label.png` written by it as it is (8-bit P6). The PFM must read as the PNG's sRGB-decoded texels,
/// also when `raw` (floats are linear); the PPM texel for texel as the PNG, sRGB-decoded unless `raw`.
/// PFM rows run from the bottom up (the label's rows differ, so a flip is seen). Hand-made PFMs: a
/// positive scale means big-endian floats times the scale, a negative one little-endian times its
/// magnitude (Mitsuba multiplies too: 2.0 big-endian reads 0.5 as 1.0, −4.0 reads 0.5 as 2.0), `Pf` is
/// grey; and damaged ones are refused before their pixels are read.
#[test]
fn pfm_and_ppm_images_read_as_mitsuba_reads_them() {
    use caustica::scene::texture::load_image;
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba");
    let png = load_image(&src.join("label.png"), false).unwrap();
    let (w, h) = (png.0 as usize, png.1 as usize);
    assert!((0..h / 2).any(|y| png.2[y * w..][..w] != png.2[(h - 1 - y) * w..][..w]), "label.png is symmetric");
    for raw in [false, true] {
        let pfm = load_image(&src.join("label.pfm"), raw).unwrap();
        assert_eq!((pfm.0, pfm.1), (png.0, png.1));
        for (i, (a, b)) in png.2.iter().zip(&pfm.2).enumerate() {
            assert!((*a - *b).abs().max_element() < 1e-6, "label.pfm (raw {raw}) texel {i}: {b} against the PNG's {a}");
        }
        assert_eq!(load_image(&src.join("label.ppm"), raw).unwrap(), load_image(&src.join("label.png"), raw).unwrap());
    }
    let dir = std::env::temp_dir().join(format!("caustica-pfm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, head: &str, values: &[f32], big: bool| {
        let mut bytes = head.as_bytes().to_vec();
        for v in values {
            bytes.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
        let file = dir.join(name);
        std::fs::write(&file, bytes).unwrap();
        file
    };
    // Two rows of two: the file's first row is the image's bottom one.
    let rgb = [0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0];
    let v = |a: f32, b: f32, c: f32| Vec3::new(a, b, c);
    let want = |k: f32| vec![v(6.0, 7.0, 8.0) * k, v(9.0, 10.0, 11.0) * k, v(0.5, 1.0, 2.0) * k, v(3.0, 4.0, 5.0) * k];
    assert_eq!(load_image(&write("le.pfm", "PF\n2 2\n-1.0\n", &rgb, false), false).unwrap(), (2, 2, want(1.0)));
    assert_eq!(load_image(&write("be.pfm", "PF\n2 2\n2.0\n", &rgb, true), false).unwrap(), (2, 2, want(2.0)));
    assert_eq!(load_image(&write("sc.pfm", "PF 2 2 -4 ", &rgb, false), true).unwrap(), (2, 2, want(4.0)));
    let grey = load_image(&write("g.pfm", "Pf\n3 1\n-1\n", &[0.25, 1.0, 7.0], false), false).unwrap();
    assert_eq!(grey, (3, 1, vec![Vec3::splat(0.25), Vec3::splat(1.0), Vec3::splat(7.0)]));
    let refused = [
        (write("short.pfm", "PF\n2 2\n-1\n", &rgb[..11], false), "truncated"),
        (write("huge.pfm", "PF\n100000 100000\n-1\n", &rgb, false), "larger than"),
        (write("nan.pfm", "PF\n2 2\n-1\n", &[f32::NAN; 12], false), "texel (0, 0) is not finite"),
        (write("zero.pfm", "PF\n2 0\n-1\n", &rgb, false), "height `0`"),
        (write("scale.pfm", "PF\n2 2\n0\n", &rgb, false), "scale `0`"),
        (write("cut.pfm", "PF\n2 2", &[], false), "incomplete"),
    ];
    for (file, want) in refused {
        let msg = load_image(&file, false).unwrap_err();
        assert!(msg.contains(want), "{}: `{want}` not in: {msg}", file.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
