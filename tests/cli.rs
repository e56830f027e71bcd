//! The command line as a new user meets it: output names, argument errors blamed on the argument (exit
//! 2, clap's convention), work refused up front when the plan says it would produce nothing.
use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn scene(name: &str) -> String {
    format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn caustica(args: &[&str], cwd: &Path) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).current_dir(cwd).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!err.contains("panicked"), "caustica {args:?} panicked: {err}");
    (o.status.code().unwrap_or(-1), String::from_utf8_lossy(&o.stdout).to_string(), err)
}

fn files(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

#[test]
fn a_folder_as_output_gets_the_scene_name_not_hidden_files() {
    let d = dir("folder");
    let box_ = scene("cornell-box.toml");
    let small = ["--set", "camera.resolution=[16,16]", "--spp", "1", "--mode", "path", "-q"];
    let out = format!("{}/", d.join("out").display());
    let (code, _, err) = caustica(&[&["render", box_.as_str(), "-o", out.as_str()], &small[..]].concat(), &d);
    assert_eq!(code, 0, "{err}");
    assert_eq!(files(&d.join("out")), ["cornell-box.exr", "cornell-box.json", "cornell-box.png"]);
    // An existing folder without the slash means the same.
    std::fs::create_dir_all(d.join("existing")).unwrap();
    let out = d.join("existing").display().to_string();
    let (code, _, err) = caustica(&[&["render", box_.as_str(), "-o", out.as_str()], &small[..]].concat(), &d);
    assert_eq!(code, 0, "{err}");
    assert_eq!(files(&d.join("existing")), ["cornell-box.exr", "cornell-box.json", "cornell-box.png"]);
}

#[test]
fn compare_names_its_output_after_its_inputs() {
    let d = dir("compare");
    let box_ = scene("cornell-box.toml");
    for seed in ["1", "2", "3"] {
        let out = d.join(format!("s{seed}")).display().to_string();
        let args = [
            "render",
            box_.as_str(),
            "-o",
            out.as_str(),
            "--seed",
            seed,
            "--set",
            "camera.resolution=[16,16]",
            "--spp",
            "1",
            "--mode",
            "path",
            "-q",
        ];
        assert_eq!(caustica(&args, &d).0, 0);
    }
    assert_eq!(caustica(&["compare", "s1.exr", "s2.exr"], &d).0, 0);
    assert_eq!(caustica(&["compare", "s1.exr", "s3.exr"], &d).0, 0);
    let out = files(&d.join("out"));
    assert!(
        out.contains(&"compare-s1-vs-s2.json".to_string()) && out.contains(&"compare-s1-vs-s3.json".to_string()),
        "{out:?}"
    );
}

#[test]
fn argument_errors_name_the_argument_and_exit_2() {
    let d = dir("args");
    let box_ = scene("cornell-box.toml");
    for (args, expect) in [
        (vec!["--spp", "0"], "--spp"),
        (vec!["--spp", "-1"], "--spp"),
        (vec!["--mode", "foo"], "photon_map"),
        (vec!["--passes", "0"], "--passes"),
        (vec!["--time-s", "-3"], "seconds above 0"),
        (vec!["--threads", "0"], "--threads"),
    ] {
        let mut all = vec!["render", box_.as_str(), "-q"];
        all.extend(&args);
        let (code, _, err) = caustica(&all, &d);
        assert_eq!(code, 2, "{args:?}: exit {code}: {err}");
        assert!(err.contains(expect), "{args:?}: message lacks `{expect}`: {err}");
        assert!(!err.contains("cornell-box.toml"), "{args:?}: blamed on the scene file: {err}");
        assert!(!err.contains("-- -1"), "{args:?}: suggests `-- -1`: {err}");
    }
    // The benchmarks too: a budget of NaN seconds used to run every sweep to its end, 0 photons to
    // report NaN rays per second.
    for (args, expect) in [
        (vec!["bench", "time-vs-error", box_.as_str(), "--budget-s", "nan"], "seconds above 0"),
        (vec!["bench", "time-vs-error", box_.as_str(), "--budget-s", "-5"], "seconds above 0"),
        (vec!["bench", "photons", box_.as_str(), "--photons", "0"], "--photons"),
    ] {
        let (code, _, err) = caustica(&args, &d);
        assert_eq!(code, 2, "{args:?}: exit {code}: {err}");
        assert!(err.contains(expect), "{args:?}: message lacks `{expect}`: {err}");
    }
    // knn-check (built with the oracle): 3e9 points aborted on a 36 GB allocation, a NaN radius was
    // reported as "queries disagree with kiddo".
    if cfg!(feature = "oracle") {
        for (args, expect) in [
            (vec!["knn-check", "--points", "3000000000"], "the limit is 16 GiB"),
            (vec!["knn-check", "--radius", "nan"], "--radius"),
            (vec!["knn-check", "--radius=-1"], "--radius"),
            (vec!["knn-check", "--points", "0"], "--points"),
        ] {
            let (code, _, err) = caustica(&args, &d);
            assert_eq!(code, 1, "{args:?}: exit {code}: {err}");
            assert!(err.contains(expect), "{args:?}: message lacks `{expect}`: {err}");
        }
    }
    assert!(files(&d).is_empty());
}

/// The plain Cornell box has no specular surface: no caustic map is planned, so a view of it is refused
/// at once with the planner's reason, even under -q, instead of shooting photons for a black image.
#[test]
fn a_view_of_a_map_the_plan_does_not_build_is_refused_with_the_reason() {
    let d = dir("view");
    let box_ = scene("cornell-box.toml");
    for view in ["map:caustic", "photons:caustic"] {
        let t0 = std::time::Instant::now();
        let (code, _, err) = caustica(&["render", box_.as_str(), "-q", "--view", view, "-o", "v"], &d);
        assert_ne!(code, 0, "{view} accepted");
        assert!(err.contains("no caustic photons") && err.contains("planner"), "{view}: {err}");
        assert!(t0.elapsed().as_secs_f64() < 20.0, "{view}: refused only after {:?}", t0.elapsed());
    }
    assert!(files(&d).is_empty(), "{:?}", files(&d));
    // A view the plan does build still works, with a legend on its PNG only (the EXR is the bare image).
    let glass = scene("cornell-glass.toml");
    let args = [
        "render",
        glass.as_str(),
        "-q",
        "--view",
        "photons:all",
        "-o",
        "p",
        "--set",
        "camera.resolution=[32,24]",
        "--set",
        "render.photons.caustic=2000",
        "--set",
        "render.photons.indirect=2000",
        "--set",
        "render.photons.direct=2000",
    ];
    let (code, out, err) = caustica(&args, &d);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("legend"), "{out}");
    let png = png_size(&d.join("p.png"));
    assert_eq!(png, (32, 24 + 18), "the PNG should carry an 18-pixel legend bar above the image");
}

fn png_size(p: &Path) -> (u32, u32) {
    let bytes = std::fs::read(p).unwrap();
    // IHDR: width and height are the big-endian u32s at bytes 16..24.
    (u32::from_be_bytes(bytes[16..20].try_into().unwrap()), u32::from_be_bytes(bytes[20..24].try_into().unwrap()))
}

#[test]
fn a_cached_reference_says_it_came_from_the_cache() {
    let d = dir("reference");
    let box_ = scene("cornell-box.toml");
    let args = ["reference", box_.as_str(), "--spp", "2", "--set", "camera.resolution=[8,8]", "-q"];
    let (code, first, err) = caustica(&args, &d);
    assert_eq!(code, 0, "{err}");
    assert!(first.contains("rendered in"), "{first}");
    let (code, second, err) = caustica(&args, &d);
    assert_eq!(code, 0, "{err}");
    assert!(second.contains("from the cache"), "{second}");
}

#[test]
fn bench_commands_take_scene_overrides() {
    let d = dir("bench");
    let box_ = scene("cornell-box.toml");
    let (code, out, err) = caustica(
        &[
            "bench",
            "plan",
            box_.as_str(),
            "--set",
            "camera.resolution=[16,16]",
            "--set",
            "render.photons.indirect=2000",
            "--set",
            "render.photons.direct=2000",
        ],
        &d,
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("time ratio planned/forced"), "{out}");
}

#[test]
fn bench_chart_redraws_a_csv_and_refuses_a_bad_one_naming_the_line() {
    let d = dir("chart");
    let csv = "series,spp,photons,gather,seconds,rmse,rmse_raw,rel_mse\n\
               PT,1,0,0,0.1,0.1,0.1,0.2\nPT,4,0,0,0.4,0.05,0.05,0.1\nSPPM,4,400000,0,0.5,0.03,0.03,0.05\n";
    std::fs::write(d.join("run.csv"), csv).unwrap();
    let (code, out, err) = caustica(&["bench", "chart", "run.csv"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert_eq!(png_size(&d.join("run.png")), (900, 600));
    assert!(std::fs::read_to_string(d.join("run.svg")).unwrap().contains("SPPM"));
    std::fs::write(d.join("bad.csv"), csv.replace("0.4,0.05", "oops,0.05")).unwrap();
    let (code, _, err) = caustica(&["bench", "chart", "bad.csv"], &d);
    assert_ne!(code, 0);
    assert!(err.contains("bad.csv: line 3") && err.contains("seconds"), "{err}");
    assert!(!d.join("bad.png").exists());
}

/// `reference --against-spp` accepts a reference that converges to the same image (PT at fewer samples)
/// and refuses a biased one (a fixed photon map with few photons and a wide gather),
/// with exit status 1.
#[test]
fn reference_agreement_tells_a_biased_reference_from_a_noisy_one() {
    let d = dir("reference-agreement");
    let box_ = scene("cornell-box.toml");
    let run = |kind: &[&str]| {
        let mut args = vec!["reference", box_.as_str()];
        args.extend_from_slice(kind);
        args.extend_from_slice(&["--against-spp", "512", "--set", "camera.resolution=[32,32]", "-q"]);
        caustica(&args, &d)
    };
    let (code, out, err) = run(&["--spp", "64"]);
    assert_eq!(code, 0, "PT 64 spp against PT 512 spp: {out}{err}");
    assert!(out.contains("agree within their noise"), "{out}");
    let (code, out, err) = run(&["--photons", "20000"]);
    assert_eq!(code, 1, "a 20,000-photon map against PT should differ beyond the noise: {out}{err}");
    assert!(err.contains("differ beyond their noise"), "{err}");
}

#[test]
fn time_vs_error_sweep_and_reference_overrides_reach_only_their_side() {
    let d = dir("tve-sets");
    let box_ = scene("cornell-box.toml");
    let out = d.join("tve").join("box").display().to_string();
    let base = [
        "bench",
        "time-vs-error",
        box_.as_str(),
        "--methods",
        "pt",
        "--budget-s",
        "0.05",
        "--ref-spp",
        "4",
        "-q",
        "-o",
        out.as_str(),
        "--set",
        "camera.resolution=[16,16]",
    ];
    let run = |extra: &[&str]| caustica(&[&base[..], extra].concat(), &d);
    let (code, table, err) = run(&["--sweep-set", "render.max_depth=2"]);
    assert_eq!(code, 0, "{err}");
    assert!(table.contains("PT"), "{table}");
    let refs = files(&d.join("tve").join("ref"));
    assert_eq!(refs.len(), 4, "one reference (mean, two halves, JSON): {refs:?}");
    // The sweep's overrides are not part of the reference: without them the same reference is reused.
    let (code, _, err) = run(&[]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(files(&d.join("tve").join("ref")), refs);
    // A sweep override reaches the timed renders and not the reference (so the sizes differ) …
    let (code, _, err) = run(&["--sweep-set", "camera.resolution=[8,8]"]);
    assert_ne!(code, 0);
    assert!(err.contains("reference size differs"), "{err}");
    // … and a reference override the reference alone, which is cached under its own key.
    let (code, _, err) = run(&["--ref-set", "camera.resolution=[8,8]"]);
    assert_ne!(code, 0);
    assert!(err.contains("reference size differs"), "{err}");
    assert_eq!(files(&d.join("tve").join("ref")).len(), 8, "a second reference for the --ref-set");
}

/// `bench photons` replays every ray photon tracing traced, and refuses to report when the two counts
/// differ. On `spotlight` (spot lights, which face away from some of the points the caustic aim
/// probes, and a rough gold ring that the caustic pass light-traces the spot's caustic from) it
/// refused: the aim counted a probe ray for every probe, also those whose light samples all faced away
/// and traced none (20,897 rays too many, at any photon count). Both sides now count the rays traced,
/// the links to the camera apart.
#[test]
fn bench_photons_counts_the_rays_it_traces() {
    let d = dir("bench-photons");
    let spot = scene("spotlight.toml");
    let (code, out, err) = caustica(&["bench", "photons", spot.as_str(), "--photons", "20000"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("ratio"), "{out}");
}

/// `caustica info` says how the caustic shots are shared among the targets: on the glass box both balls,
/// their shares summing to 100%, each with the pilot's yield; on the diffuse box, with no caustic map,
/// no aim line.
#[test]
fn info_shows_how_the_caustic_shots_are_aimed() {
    let d = dir("info-aim");
    let (code, out, err) = caustica(&["info", scene("cornell-glass.toml").as_str()], &d);
    assert_eq!(code, 0, "{err}");
    let line = out.lines().find(|l| l.starts_with("aim ")).unwrap_or_else(|| panic!("no aim line: {out}"));
    let shares: Vec<f64> =
        line.split('%').filter_map(|part| part.rsplit(' ').next().and_then(|n| n.parse().ok())).collect();
    assert_eq!(shares.len(), 2, "{line}");
    assert!((shares.iter().sum::<f64>() - 100.0).abs() < 0.2, "{line}");
    assert_eq!(line.matches("pilot yield").count(), 2, "{line}");
    let (code, out, err) = caustica(&["info", scene("cornell-box.toml").as_str()], &d);
    assert_eq!(code, 0, "{err}");
    assert!(!out.lines().any(|l| l.starts_with("aim ")), "{out}");
}

/// A map the shot budget cannot fill says what to do about it: an open floor whose light comes back to
/// it only by a small mirror ball keeps few indirect photons per shot, and the warning names the share
/// stored, the setting that would fill the map (`render.photons.max_shots_factor`, with a value that
/// would), and that the estimate stays right from fewer photons. Raised to that value, the map fills.
#[test]
fn an_unfilled_map_says_which_setting_would_fill_it() {
    let d = dir("budget");
    let text = "[camera]\norigin = [0.0, 2.5, 2.0]\ntarget = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
         [materials]\nchrome = { type = \"mirror\" }\nwhite = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\
         [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.3, 0.5, 0.0]\nradius = 0.3\nmaterial = \"chrome\"\n\
         [[lights]]\ntype = \"point\"\nposition = [-0.5, 1.5, 0.2]\npower = [30.0, 30.0, 30.0]\n\
         [render]\npm_spp = 1\nphotons = { indirect = 2000, caustic = 2000, max_shots_factor = 20 }\n";
    std::fs::write(d.join("open.toml"), text).unwrap();
    let render = |extra: &[&str]| {
        let args = [&["render", "open.toml", "--mode", "photon_map", "-q", "-o", "out"][..], extra].concat();
        let (code, _, err) = caustica(&args, &d);
        assert_eq!(code, 0, "{err}");
        err
    };
    let err = render(&[]);
    let line = err.lines().find(|l| l.contains("indirect map got")).unwrap_or_else(|| panic!("no warning: {err}"));
    assert!(line.contains("stored") && line.contains("render.photons.indirect"), "{line}");
    let factor: u64 = line
        .split("render.photons.max_shots_factor = ")
        .nth(1)
        .and_then(|rest| rest.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no factor suggested: {line}"));
    assert!(factor > 20, "{line}");
    let set = format!("render.photons.max_shots_factor={}", factor * 3 / 2);
    let err = render(&["--set", &set]);
    assert!(!err.contains("indirect map got"), "with {set}: {err}");
}

/// A map the scene's light needs, asked for no photons (`render.photons.caustic = 0` on the glass box):
/// the photon mappers render without that light (the glass box's mean 0.972 of its full image), and
/// say so naming the key; the path tracer, which does not use the maps, does not; nor does the default.
/// A gather of no photons (`render.gather.indirect = 0`, which read the box at 0.78 of its mean) is
/// refused (`bad_input.rs`).
#[test]
fn a_map_asked_for_no_photons_is_warned_of() {
    let d = dir("no-photons");
    let glass = scene("cornell-glass.toml");
    let render = |extra: &[&str]| {
        let base = ["render", glass.as_str(), "-q", "-o", "out", "--set", "camera.resolution=[8,8]", "--spp", "1"];
        let (code, _, err) = caustica(&[&base[..], extra].concat(), &d);
        assert_eq!(code, 0, "{err}");
        err
    };
    let pm = ["--mode", "photon_map", "--set", "render.pm_spp=1", "--set", "render.photons.indirect=1000"];
    let err = render(&[&pm[..], &["--set", "render.photons.caustic=0"]].concat());
    assert!(err.contains("warning") && err.contains("render.photons.caustic = 0"), "{err}");
    let err = render(&["--mode", "path", "--set", "render.photons.caustic=0"]);
    assert!(!err.contains("render.photons.caustic = 0"), "{err}");
    let err = render(&[&pm[..], &["--set", "render.photons.caustic=1000"]].concat());
    assert!(!err.contains("= 0:"), "{err}");
}
