//! Command-line interface (clap): subcommands, their options, and the examples `--help` shows.
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "caustica",
    version,
    about = "Photon mapping and path tracing side by side, through Embree, measured against each other",
    after_help = "Examples:\n  caustica render scenes/cornell-glass.toml --mode both -o out/glass\n  caustica bench photons scenes/cornell-glass.toml\n  caustica render scenes/cornell-box.toml --spp 256 --set render.max_depth=8\n  caustica info scenes/dragon.toml\n  caustica bench rays scenes/dragon.toml\n  caustica knn-check --points 1000000 --queries 100000 --k 50 --distribution clustered"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene to EXR (linear), PNG (preview) and JSON (stats).
    Render(RenderArgs),
    /// Print what a scene contains: shapes, triangles, lights, bounds, memory, load and BVH times.
    Info(InfoArgs),
    /// Throughput benchmarks, each against a baseline measured in the same run.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Build our k-d tree and kiddo's on the same photons; check agreement and compare speed.
    KnnCheck(KnnArgs),
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Output path without extension: writes OUT.exr, OUT.png, OUT.json (default out/<scene name>).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Samples per pixel (path tracer), overrides render.spp.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Random seed, overrides render.seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// path | photon_map | both, overrides render.mode.
    #[arg(long)]
    pub mode: Option<String>,
    /// What to show: image (default), photons:direct|indirect|caustic|all, map:direct|indirect|caustic.
    #[arg(long, default_value = "image")]
    pub view: String,
    /// Override any scene key, e.g. --set render.photons.caustic=200000 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct InfoArgs {
    pub scene: PathBuf,
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Camera rays through the renderer's accel layer (16-ray packets and single rays) vs a bare
    /// rtcIntersect16 loop on the same rays, one thread.
    Rays {
        scene: PathBuf,
        /// Rounds of the whole camera-ray set per variant (best round is reported).
        #[arg(long, default_value_t = 5)]
        rounds: u32,
    },
    /// Photon tracing (segments/s, 1 thread) vs a bare rtcIntersect1 loop over as many incoherent rays.
    Photons {
        scene: PathBuf,
        /// Photons to store per map for the measurement.
        #[arg(long, default_value_t = 100_000)]
        photons: u64,
    },
}

#[derive(Args, Debug)]
pub struct KnnArgs {
    #[arg(long, default_value_t = 1_000_000)]
    pub points: usize,
    #[arg(long, default_value_t = 100_000)]
    pub queries: usize,
    #[arg(long, default_value_t = 50)]
    pub k: usize,
    /// uniform | clustered | plane
    #[arg(long, default_value = "uniform")]
    pub distribution: String,
    /// Radius cap for the k-NN (default: none).
    #[arg(long)]
    pub radius: Option<f32>,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}
