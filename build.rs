//! Build script: stop early, with one clear line, when Embree 3 is not installed.
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    let header = match std::env::var_os("EMBREE_DIR") {
        Some(dir) => PathBuf::from(dir).join("include/embree3/rtcore.h"),
        None => PathBuf::from("/usr/include/embree3/rtcore.h"),
    };
    if !header.exists() {
        eprintln!(
            "error: Embree 3 not found ({} is missing). Install it with `apt-get install -y libembree-dev` or set EMBREE_DIR to an Embree 3.13 install.",
            header.display()
        );
        std::process::exit(1);
    }
}
