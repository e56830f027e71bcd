//! Progress bars on stderr for long work (photon tracing, rendering, sweeps).
use indicatif::{ProgressBar, ProgressStyle};

/// Progress bar on stderr (hidden when `quiet` or when stderr is not a terminal).
pub fn progress(len: u64, label: &str, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>12} [{bar:30}] {percent:>3}% {msg} ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(label.to_string());
    pb
}
