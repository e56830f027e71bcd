//! `caustica compare` on synthetic EXRs whose RMSE is known, and its refusal of mismatched sizes.
mod common;
use caustica::film::Image;
use caustica::output::write_exr;
use glam::Vec3;
use std::process::Command;

fn dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-compare-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn compare_reports_the_known_rmse_and_writes_its_images() {
    let d = dir();
    let mut a = Image::new(8, 4);
    let mut b = Image::new(8, 4);
    for (i, p) in a.pixels.iter_mut().enumerate() {
        *p = Vec3::splat(0.25 + 0.01 * i as f32);
    }
    // B = A + 0.1 on every channel of the first 8 pixels: RMSE = sqrt(8·3·0.01 / 96) = 0.05.
    for (i, (q, p)) in b.pixels.iter_mut().zip(&a.pixels).enumerate() {
        *q = if i < 8 { *p + Vec3::splat(0.1) } else { *p };
    }
    write_exr(&d.join("a.exr"), &a).unwrap();
    write_exr(&d.join("b.exr"), &b).unwrap();
    let out = d.join("cmp");
    let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args([
            "compare",
            d.join("a.exr").to_str().unwrap(),
            d.join("b.exr").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("RMSE 0.050000"), "{stdout}");
    let js: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("cmp.json")).unwrap()).unwrap();
    let rmse = js["a_errors"]["rmse"].as_f64().unwrap();
    assert!((rmse - 0.05).abs() < 1e-6, "{rmse}");
    assert!(d.join("cmp.png").exists() && d.join("cmp-error.png").exists());
}

#[test]
fn compare_refuses_images_of_different_sizes_and_unreadable_files() {
    let d = dir();
    write_exr(&d.join("s1.exr"), &Image::new(4, 4)).unwrap();
    write_exr(&d.join("s2.exr"), &Image::new(5, 4)).unwrap();
    std::fs::write(d.join("junk.exr"), b"not an exr").unwrap();
    // A header claiming 10^9 × 32 pixels over a 64 × 32 image's blocks: sizing the image by it aborted.
    std::fs::write(d.join("wide.exr"), common::widened_exr()).unwrap();
    for (other, expect) in [("s2.exr", "same size"), ("junk.exr", "cannot read EXR"), ("wide.exr", "larger than")] {
        let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .args([
                "compare",
                d.join("s1.exr").to_str().unwrap(),
                d.join(other).to_str().unwrap(),
                "-o",
                d.join("x").to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(expect) && err.contains(other) && !err.contains("panicked"),
            "{err}"
        );
    }
}
