//! Split renders: `render --part i/N` then `merge` must give the image one `render` gives with the same
//! seed, and `merge` must refuse (non-zero exit, a message naming the file, no output written) every
//! set of parts that is not exactly the N parts of one render.
mod common;

use caustica::parts::{read_partial, write_partial};
use std::path::{Path, PathBuf};
use std::process::Command;

use common::{SMALL_BOX as BOX, SMALL_GLASS_PM as GLASS_PM};

const GLASS_PPM: &[&str] = &[
    "--set",
    "camera.resolution=[48,36]",
    "--mode",
    "ppm",
    "--passes",
    "8",
    "--set",
    "render.progressive.photons_per_pass=10000",
];

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-parts-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn caustica(args: &[&str]) -> (i32, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!err.contains("panicked"), "caustica {args:?} panicked: {err}");
    (o.status.code().unwrap_or(-1), err)
}

fn render(scene: &str, extra: &[&str], out: &Path, part: Option<(u32, u32)>) {
    let scene = format!("{}/scenes/{scene}", env!("CARGO_MANIFEST_DIR"));
    let mut args = vec!["render", scene.as_str(), "-q", "-o", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let p = part.map(|(i, n)| format!("{i}/{n}"));
    if let Some(p) = &p {
        args.extend_from_slice(&["--part", p.as_str()]);
    }
    let (code, err) = caustica(&args);
    assert_eq!(code, 0, "render {args:?} failed: {err}");
}

fn part(out: &Path, i: u32, n: u32) -> PathBuf {
    caustica::parts::part_path(out, i, n)
}

fn merge(parts: &[PathBuf], out: &Path) -> (i32, String) {
    let mut args: Vec<String> = vec!["merge".into()];
    args.extend(parts.iter().map(|p| p.display().to_string()));
    args.extend(["-o".into(), out.display().to_string()]);
    caustica(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

const GLASS_VCM: &[&str] = &["--set", "camera.resolution=[48,36]", "--mode", "vcm", "--passes", "8"];

fn split_equals_single(name: &str, scene: &str, extra: &[&str], n: u32, must_be_identical: bool) {
    let d = dir(name);
    let single = d.join("single");
    render(scene, extra, &single, None);
    // Parts rendered out of order: each is a pure function of (scene, settings, i, N).
    for i in (0..n).rev() {
        render(scene, extra, &d.join("split"), Some((i, n)));
    }
    let parts: Vec<PathBuf> = (0..n).map(|i| part(&d.join("split"), i, n)).collect();
    let (code, err) = merge(&parts, &d.join("merged"));
    assert_eq!(code, 0, "merge failed: {err}");
    let (differ, worst) = common::exr_difference(&d.join("single.exr"), &d.join("merged.exr"));
    println!(
        "{name}: {n} parts vs one render: {differ} channel values differ, largest relative difference {worst:.3e}"
    );
    if must_be_identical {
        assert_eq!(differ, 0, "{name}: merged image is not bit-identical (worst {worst:e})");
    }
    assert!(worst <= 1e-6, "{name}: merged differs from the single render by {worst:e} relative");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("merged.json")).unwrap()).unwrap();
    assert_eq!(stats["merged"]["parts"].as_array().map(|a| a.len()), Some(n as usize));
    assert!(stats["merged"]["imbalance_max_over_mean"].as_f64().unwrap() >= 1.0);
}

/// Path tracing splits every pixel's sample indices; sums are f64 in sample order, so the merged sum
/// equals the single one unless f64 rounding differs between the two groupings (≤ 1e-6 relative).
#[test]
fn path_traced_parts_merge_to_the_single_render() {
    split_equals_single("pt", "cornell-box.toml", BOX, 4, false);
}

/// A fixed photon map splits rows: every part builds the same maps and each pixel comes from exactly
/// one part, so the merge is bit-identical by construction.
#[test]
fn photon_map_parts_merge_bit_identically() {
    split_equals_single("pm", "cornell-glass.toml", GLASS_PM, 4, true);
}

/// PPM splits its passes (interleaved); 8 passes in 3 uneven parts.
#[test]
fn ppm_parts_merge_to_the_single_render() {
    split_equals_single("ppm", "cornell-glass.toml", GLASS_PPM, 3, false);
}

/// VCM's iterations are independent too (light tracing splats included): 8 in 3 parts.
#[test]
fn vcm_parts_merge_to_the_single_render() {
    split_equals_single("vcm", "cornell-glass.toml", GLASS_VCM, 3, false);
}

fn refused(name: &str, parts: &[PathBuf], out: &Path, expect: &[&str]) {
    let (code, err) = merge(parts, out);
    assert_ne!(code, 0, "{name}: merge accepted bad parts");
    for e in expect {
        assert!(err.contains(e), "{name}: message lacks `{e}`: {err}");
    }
    let leftovers: Vec<_> = std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|f| f.starts_with(&out.file_name().unwrap().to_string_lossy().to_string()))
        .collect();
    assert!(leftovers.is_empty(), "{name}: merge left {leftovers:?} behind");
}

#[test]
fn merge_refuses_bad_sets_of_parts_and_writes_nothing() {
    let d = dir("bad");
    let a = d.join("a");
    for i in 0..4 {
        render("cornell-box.toml", BOX, &a, Some((i, 4)));
    }
    let good: Vec<PathBuf> = (0..4).map(|i| part(&a, i, 4)).collect();
    let out = d.join("result/merged");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();

    // A missing part: named by index and by the file expected.
    refused(
        "missing",
        &[good[0].clone(), good[1].clone(), good[3].clone()],
        &out,
        &["missing part 2 of 4", "a-part-2-of-4.part", "--part 2/4"],
    );
    // The same part twice.
    refused(
        "duplicate",
        &[good[0].clone(), good[1].clone(), good[1].clone(), good[3].clone()],
        &out,
        &["part 1/4 given twice"],
    );
    // Truncated.
    let bytes = std::fs::read(&good[2]).unwrap();
    let cut = d.join("cut.part");
    std::fs::write(&cut, &bytes[..bytes.len() - 1000]).unwrap();
    refused(
        "truncated",
        &[good[0].clone(), good[1].clone(), cut.clone(), good[3].clone()],
        &out,
        &["cut.part", "truncated"],
    );
    // Extra bytes.
    let long = d.join("long.part");
    std::fs::write(&long, [bytes.as_slice(), &[0u8; 64]].concat()).unwrap();
    refused(
        "wrong size",
        &[good[0].clone(), good[1].clone(), long, good[3].clone()],
        &out,
        &["long.part", "wrong size"],
    );
    // One flipped byte in the pixel data.
    let mut flipped = bytes.clone();
    let at = flipped.len() - 100;
    flipped[at] ^= 0x10;
    let bad = d.join("flipped.part");
    std::fs::write(&bad, &flipped).unwrap();
    refused("damaged", &[good[0].clone(), good[1].clone(), bad, good[3].clone()], &out, &["flipped.part", "checksum"]);
    // Not a part file at all.
    let junk = d.join("junk.part");
    std::fs::write(&junk, b"P6 not a part").unwrap();
    refused("junk", &[junk], &out, &["junk.part", "not a caustica part file"]);

    // Headers rewritten through the library (valid checksums) so only the one field is wrong.
    let rewrite = |from: &Path, to: &str, edit: &dyn Fn(&mut caustica::parts::PartHeader)| -> PathBuf {
        let p = read_partial(from).unwrap();
        let mut h = p.header.clone();
        edit(&mut h);
        let layers: Vec<&caustica::film::Sums> = p.layers.iter().collect();
        write_partial(&d.join(to), &h, &layers).unwrap()
    };
    let out_of_range = rewrite(&good[2], "range", &|h| h.part = 7);
    refused("index out of range", &[good[0].clone(), out_of_range], &out, &["range-part-7-of-4.part", "out of range"]);
    let n_mismatch = rewrite(&good[2], "eight", &|h| h.parts = 8);
    refused(
        "N mismatch",
        &[good[0].clone(), good[1].clone(), n_mismatch, good[3].clone()],
        &out,
        &["eight-part-2-of-8.part", "part 2 of 8"],
    );
    // A part of a smaller film.
    let sized = d.join("sized");
    render("cornell-box.toml", &["--set", "camera.resolution=[32,24]", "--spp", "16"], &sized, Some((2, 4)));
    refused(
        "different size",
        &[good[0].clone(), good[1].clone(), part(&sized, 2, 4), good[3].clone()],
        &out,
        &["sized-part-2-of-4.part", "32×24", "64×48"],
    );

    // Parts of another render: same scene, different seed.
    let b = d.join("b");
    let mut seeded = BOX.to_vec();
    seeded.extend_from_slice(&["--seed", "99"]);
    render("cornell-box.toml", &seeded, &b, Some((2, 4)));
    refused(
        "mixed settings",
        &[good[0].clone(), good[1].clone(), part(&b, 2, 4), good[3].clone()],
        &out,
        &["b-part-2-of-4.part", "render.seed"],
    );
    // Parts of another scene (same settings, different content).
    let c = d.join("c");
    render(
        "cornell-box.toml",
        &[BOX, &["--set", "materials.red.reflectance=[0.5,0.1,0.1]"]].concat(),
        &c,
        Some((2, 4)),
    );
    refused(
        "mixed scenes",
        &[good[0].clone(), good[1].clone(), part(&c, 2, 4), good[3].clone()],
        &out,
        &["c-part-2-of-4.part", "different scene"],
    );

    // And the good set still merges, after all that.
    let (code, err) = merge(&good, &out);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn parts_that_cannot_be_split_are_refused_before_rendering() {
    let d = dir("refuse");
    let scene = format!("{}/scenes/cornell-glass.toml", env!("CARGO_MANIFEST_DIR"));
    let o = d.join("x");
    let o = o.to_str().unwrap();
    for (args, expect) in [
        (vec!["--mode", "sppm"], "sppm cannot be split"),
        (vec!["--mode", "ppm", "--time-s", "5"], "--passes"),
        (vec!["--spp", "2"], "only 2 samples per pixel"),
        (vec!["--view", "photons:caustic"], "--view"),
    ] {
        let mut all =
            vec!["render", scene.as_str(), "-q", "-o", o, "--part", "1/4", "--set", "camera.resolution=[16,16]"];
        all.extend(args);
        let (code, err) = caustica(&all);
        assert_ne!(code, 0, "{all:?} was accepted");
        assert!(err.contains(expect), "{all:?}: message lacks `{expect}`: {err}");
    }
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0, "a refused part left files behind");
}
