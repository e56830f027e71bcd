//! Split renders on a real Slurm (`scripts/cluster-render`, a job array and a merge job). These tests
//! need a running Slurm: `scripts/test` starts one with `scripts/local-slurm start`, runs them with
//! `--ignored`, and stops it. Run by hand:
//!
//! ```text
//! eval "$(scripts/local-slurm start)"
//! cargo test --release --test slurm -- --ignored --test-threads 1
//! scripts/local-slurm stop
//! ```
//!
//! Without a Slurm they fail (they are never skipped silently once asked for).
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-slurm-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn require_slurm() {
    let conf = std::env::var("SLURM_CONF").unwrap_or_default();
    let ok = Command::new("sinfo").arg("-h").output().map(|o| o.status.success()).unwrap_or(false);
    assert!(ok, "no Slurm to talk to (SLURM_CONF={conf:?}): start one with `eval \"$(scripts/local-slurm start)\"`");
}

fn sh(cmd: &mut Command) -> String {
    let o = cmd.output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{cmd:?} failed:\n{text}");
    text
}

fn cluster_render(scene: &str, out: &Path, flags: &[&str], render: &[&str]) -> (bool, String) {
    let o = Command::new(root().join("scripts/cluster-render"))
        .arg(root().join("scenes").join(scene))
        .args(["--parts", "4", "--out", out.to_str().unwrap()])
        .args(flags)
        .arg("--")
        .args(render)
        .env("CAUSTICA_BIN", env!("CARGO_BIN_EXE_caustica"))
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    (o.status.success(), text)
}

fn single(scene: &str, out: &Path, render: &[&str]) {
    let scene = root().join("scenes").join(scene);
    sh(Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene.to_str().unwrap(), "-q", "-o", out.to_str().unwrap()])
        .args(render));
}

fn job_ids(text: &str) -> (String, String) {
    let line = text.lines().find(|l| l.starts_with("ARRAY_JOB=")).unwrap_or_else(|| panic!("no job ids in:\n{text}"));
    let mut ids = line.split_whitespace().map(|kv| kv.split_once('=').unwrap().1.to_string());
    (ids.next().unwrap(), ids.next().unwrap())
}

fn array_and_merge_equal_one_machine(name: &str, scene: &str, render: &[&str], bit_identical: bool) {
    require_slurm();
    let d = dir(name);
    single(scene, &d.join("single"), render);
    let (ok, text) = cluster_render(scene, &d.join("cluster"), &["--wait"], render);
    assert!(ok, "cluster render failed:\n{text}");
    let (n, worst) = common::exr_difference(&d.join("single.exr"), &d.join("cluster.exr"));
    println!("{name}: Slurm 4-task array + merge vs one machine: {n} values differ, worst relative {worst:.3e}");
    if bit_identical {
        assert_eq!(n, 0);
    }
    assert!(worst <= 1e-6);
}

/// Path tracing, 4 array tasks, each a quarter of every pixel's samples.
#[test]
#[ignore = "needs a running Slurm (scripts/local-slurm start); scripts/test runs it"]
fn slurm_array_path_tracing_merges_to_the_single_render() {
    array_and_merge_equal_one_machine("pt", "cornell-box.toml", common::SMALL_BOX, false);
}

/// Photon mapping, 4 array tasks, each a quarter of the rows over the same (deterministic) maps.
#[test]
#[ignore = "needs a running Slurm (scripts/local-slurm start); scripts/test runs it"]
fn slurm_array_photon_mapping_merges_bit_identically() {
    array_and_merge_equal_one_machine("pm", "cornell-glass.toml", common::SMALL_GLASS_PM, true);
}

/// A cancelled task: the merge job never runs, `merge` by hand refuses naming the missing part and
/// writes nothing; resubmitting only that task gives the image of a complete run.
#[test]
#[ignore = "needs a running Slurm (scripts/local-slurm start); scripts/test runs it"]
fn slurm_cancelled_task_is_named_and_resubmitting_it_completes_the_image() {
    require_slurm();
    let render = common::SMALL_BOX;
    let d = dir("cancel");
    let full = d.join("full");
    let (ok, text) = cluster_render("cornell-box.toml", &full, &["--wait"], render);
    assert!(ok, "complete run failed:\n{text}");

    let out = d.join("box");
    let (ok, text) = cluster_render("cornell-box.toml", &out, &["--hold"], render);
    assert!(ok, "submission failed:\n{text}");
    let (array, merge) = job_ids(&text);
    sh(Command::new("scancel").arg(format!("{array}_2")));
    sh(Command::new("scontrol").args(["release", &array]));
    let t0 = std::time::Instant::now();
    while !String::from_utf8_lossy(
        &Command::new("squeue").args(["-h", "-j", &format!("{array},{merge}")]).output().unwrap().stdout,
    )
    .trim()
    .is_empty()
    {
        assert!(t0.elapsed().as_secs() < 300, "jobs {array}, {merge} still queued after 300 s");
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
    let merge_state = sh(Command::new("scontrol").args(["show", "job", &merge]));
    assert!(!merge_state.contains("JobState=COMPLETED"), "merge ran although part 2 was cancelled:\n{merge_state}");
    assert!(!caustica::output::with_suffix(&out, ".exr").exists(), "an image was written without part 2");

    let parts: Vec<String> = (0..4)
        .map(|i| caustica::parts::part_path(&out, i, 4))
        .filter(|p| p.exists())
        .map(|p| p.display().to_string())
        .collect();
    assert_eq!(parts.len(), 3, "expected parts 0, 1 and 3 on disk: {parts:?}");
    let o = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .arg("merge")
        .args(&parts)
        .args(["-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "merge accepted three parts of four");
    assert!(err.contains("missing part 2 of 4") && err.contains("box-part-2-of-4.part"), "{err}");
    for ext in [".exr", ".png", ".json"] {
        assert!(!caustica::output::with_suffix(&out, ext).exists(), "merge wrote {ext} although it refused");
    }

    let (ok, text) = cluster_render("cornell-box.toml", &out, &["--only", "2", "--wait"], render);
    assert!(ok, "resubmitting part 2 failed:\n{text}");
    let (n, worst) = common::exr_difference(&full.with_extension("exr"), &out.with_extension("exr"));
    println!("resubmitted part 2: {n} values differ from the complete run (worst {worst:e})");
    assert_eq!(n, 0, "the resubmitted run differs from the complete run");
}
