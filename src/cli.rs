//! Command-line interface (clap): subcommands, their options, and the examples `--help` shows.
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "caustica",
    version,
    about = "Photon mapping and path tracing side by side, through Embree, measured against each other",
    after_help = "Examples:\n  caustica render scenes/cornell-glass.toml --mode both -o out/glass\n  caustica bench time-vs-error scenes/cornell-glass.toml --budget-s 120\n  caustica compare out/glass-pm.exr out/glass-pt.exr -o out/cmp\n  caustica render scenes/cornell-box.toml --part 0/4 -o out/box   (then 1/4 … 3/4, anywhere)\n  caustica merge out/box-part-*-of-4.part -o out/box\n  caustica bench photons scenes/cornell-glass.toml\n  caustica render scenes/cornell-box.toml --spp 256 --set render.max_depth=8\n  caustica info scenes/dragon.toml\n  caustica bench rays scenes/dragon.toml\n  caustica knn-check --points 1000000 --queries 100000 --k 50 --distribution clustered"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene to EXR (linear), PNG (preview) and JSON (stats).
    Render(RenderArgs),
    /// Print what a scene contains: shapes, triangles, lights, bounds, memory, load and BVH times, and
    /// the plan: which photon maps, why, and how the caustic photons are shared among their targets.
    Info(InfoArgs),
    /// Write a Mitsuba 3 XML scene as caustica's TOML (mesh and image paths rebased to the output's
    /// folder). The TOML is loaded once before it is written, so what is written renders.
    #[command(after_help = "Example:\n  caustica convert tests/mitsuba/showcase.xml -o out/showcase.toml")]
    Convert {
        /// Mitsuba XML scene (<scene version=\"3.x\">; the subset the README lists).
        scene: PathBuf,
        /// TOML file to write (replaced atomically if it exists).
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Throughput benchmarks, each against a baseline measured in the same run.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Build our k-d tree and kiddo's on the same photons; check agreement and compare speed.
    KnnCheck(KnnArgs),
    /// Compare two EXR images (optionally against a reference): labelled side by side, error heat-map
    /// with a colour scale, RMSE / relMSE / MAE / mean-luminance ratio (stdout and JSON).
    Compare {
        /// First image (EXR), the one scored.
        a: PathBuf,
        /// Second image (EXR); the reference for A unless --ref is given.
        b: PathBuf,
        /// Reference image both are scored against (default: B is the reference for A).
        #[arg(long = "ref")]
        reference: Option<PathBuf>,
        /// Output path (a typed .png/.json is dropped): writes OUT.png, OUT-error.png, OUT.json
        /// (default out/compare-A-vs-B, named after the two files; a folder puts that name in it).
        #[arg(short, long, value_parser = out_base)]
        out: Option<PathBuf>,
        /// Exposure (stops) of the side-by-side preview.
        #[arg(long, default_value_t = 0.0)]
        exposure: f32,
    },
    /// Add the N parts of a split render (`render --part i/N`) into OUT.exr, OUT.png and OUT.json (per-part
    /// times and the imbalance in the JSON). Refuses, writing nothing, on a missing, repeated, damaged
    /// or foreign part.
    #[command(
        after_help = "Example:\n  for i in 0 1 2 3; do caustica render scenes/cornell-box.toml --part $i/4 -o out/box; done\n  caustica merge out/box-part-*-of-4.part -o out/box"
    )]
    Merge {
        /// The part files (OUT-part-i-of-N.part), in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output base (a typed .exr/.png/.json is dropped).
        #[arg(short, long, value_parser = out_base)]
        out: PathBuf,
    },
    /// A long reference render in two independent halves (cached in out/ref), with their RMSE as its
    /// noise estimate. --spp for the path tracer; --passes (SPPM) or --photons (fixed PM) for scenes only
    /// photon mapping can render.
    Reference {
        /// Scene file (TOML, or Mitsuba 3 XML).
        scene: PathBuf,
        /// Path-traced reference with this many samples per pixel (split over the two halves).
        #[arg(long, value_parser = clap::value_parser!(u32).range(2..))]
        spp: Option<u32>,
        /// Photon-mapped reference with this many photons (half caustic, a quarter indirect per half).
        /// Biased: the halves share the gather's blur, which their difference does not show.
        #[arg(long)]
        photons: Option<u64>,
        /// SPPM reference with this many passes per half (consistent: for scenes PT cannot render,
        /// such as point-light caustics; check it against a PT or VCM render where one is possible).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        passes: Option<u32>,
        /// Also render (or read) a path-traced reference at this many spp and report whether the two
        /// agree within their noise, pixel by pixel and over 8×8 blocks (exit status 1 if they do not).
        #[arg(long, value_parser = clap::value_parser!(u32).range(2..))]
        against_spp: Option<u32>,
        /// Directory the references are cached in.
        #[arg(long, default_value = "out/ref")]
        dir: PathBuf,
        /// Scene overrides, as for render (part of the cache key).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// No progress bars.
        #[arg(short, long)]
        quiet: bool,
    },
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML, or Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Output path (a typed .exr/.png/.json is dropped): writes OUT.exr, OUT.png, OUT.json
    /// (default out/<scene name>).
    #[arg(short, long, value_parser = out_base)]
    pub out: Option<PathBuf>,
    /// Samples per pixel (path tracer), overrides render.spp.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..4096))]
    pub threads: Option<u32>,
    /// Random seed, overrides render.seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// path | photon_map | both | ppm | sppm | bdpt | vcm, overrides render.mode. ppm: progressive photon
    /// mapping (independent passes with a shrinking radius, averaged); sppm: stochastic progressive
    /// photon mapping (per-pixel radius and flux); bdpt: bidirectional path tracing (every light/camera
    /// subpath pairing, MIS-weighted; light tracing reaches point-light caustics); vcm: bdpt plus photon
    /// merging under one MIS (render.vcm.connect / render.vcm.merge switch either half off; its merge
    /// radius follows the light's density, render.vcm.local_radius). bdpt and vcm aim a share of their
    /// light subpaths at mirrors and glass the lights seldom reach (render.vcm.aim). All four converge
    /// to the right image as passes accumulate. A medium that scatters (a material's albedo) is rendered
    /// by path alone.
    #[arg(long, value_parser = ["path", "photon_map", "both", "ppm", "sppm", "bdpt", "vcm"])]
    pub mode: Option<String>,
    /// Progressive modes: stop after this many passes (overrides render.progressive.passes).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    pub passes: Option<u32>,
    /// Progressive modes: stop once this many seconds were spent (overrides render.progressive.time_s).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_seconds)]
    pub time_s: Option<f64>,
    /// What to show: image (default), photons:direct|indirect|caustic|all, map:direct|indirect|caustic.
    #[arg(long, default_value = "image")]
    pub view: String,
    /// Override any scene key, e.g. --set render.photons.caustic=200000 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Render only share i of N (0 ≤ i < N) and write OUT-part-i-of-N.part (with a .json header
    /// beside it) instead of an image; `caustica merge` adds the N parts into the image one machine
    /// would have made. Path tracing splits every pixel's samples, photon mapping the image rows (every
    /// part builds the same photon maps), PPM the passes; SPPM cannot be split.
    #[arg(long, value_name = "i/N", value_parser = parse_part)]
    pub part: Option<(u32, u32)>,
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
        /// Scene file (TOML, or Mitsuba 3 XML).
        scene: PathBuf,
        /// Scene overrides, e.g. --set camera.resolution=[256,256].
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Rounds of the whole camera-ray set per variant (best round is reported).
        #[arg(long, default_value_t = 5)]
        rounds: u32,
    },
    /// PT at a sweep of spp, PM at sweeps of photon and gather counts, one run each of PPM, SPPM, BDPT
    /// and VCM read after 1, 2, 4, … passes, timed and scored against a cached reference: CSV, log-log
    /// chart (SVG, PNG), the equal-time RMSE ratios to PT and VCM's ratio to the best of PT, PPM, SPPM.
    TimeVsError {
        /// Scene file (TOML, or Mitsuba 3 XML).
        scene: PathBuf,
        /// Seconds split equally over the chosen sweeps among PT, PM photons, PM gather, PPM and SPPM
        /// (all five: a fifth each; `--methods sppm` alone: all of it); BDPT and VCM get the same share on
        /// top.
        #[arg(long, default_value_t = 60.0, allow_negative_numbers = true, value_parser = positive_seconds)]
        budget_s: f64,
        /// Which sweeps to run, comma-separated: pt, pm (photon and gather counts), ppm, sppm, bdpt, vcm.
        #[arg(long, value_delimiter = ',', default_value = "pt,pm,ppm,sppm,bdpt,vcm",
              value_parser = ["pt", "pm", "ppm", "sppm", "bdpt", "vcm"])]
        methods: Vec<String>,
        /// Reference samples per pixel (path tracer).
        #[arg(long)]
        ref_spp: Option<u32>,
        /// Reference by fixed photon mapping with this many photons instead (biased: favours PM).
        #[arg(long)]
        ref_photons: Option<u64>,
        /// Reference by SPPM with this many passes per half instead (consistent; for point-light
        /// caustics and other scenes PT cannot render).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        ref_passes: Option<u32>,
        /// Output path (a typed extension is dropped): OUT.csv, OUT.svg, OUT.png (default out/tve/<scene name>).
        #[arg(short, long, value_parser = out_base)]
        out: Option<PathBuf>,
        /// Scene overrides for every render and the reference, e.g. --set camera.resolution=[128,128].
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Overrides for the timed renders only, scored against the same reference, e.g. --sweep-set
        /// render.final_gather=16 (compare settings without rendering the reference again).
        #[arg(long = "sweep-set", value_name = "KEY=VALUE")]
        sweep_set: Vec<String>,
        /// Overrides for the reference only, e.g. --ref-set render.specular_spp=64 (more samples where
        /// only camera rays find the light); the reference is cached under these too.
        #[arg(long = "ref-set", value_name = "KEY=VALUE")]
        ref_set: Vec<String>,
        /// No progress bars (the table and the files are still written).
        #[arg(short, long)]
        quiet: bool,
    },
    /// Redraw the chart (SVG and PNG) of a time-vs-error CSV, without rendering anything.
    #[command(
        after_help = "Example:\n  caustica bench chart out/tve/cornell-glass.csv   (writes out/tve/cornell-glass.svg and .png)"
    )]
    Chart {
        /// A CSV written by `bench time-vs-error`.
        csv: PathBuf,
        /// Output path (OUT.svg, OUT.png; default: beside the CSV, same name).
        #[arg(short, long, value_parser = out_base)]
        out: Option<PathBuf>,
        /// Chart title (default: the CSV's name).
        #[arg(long)]
        title: Option<String>,
    },
    /// Photon mapping with the planner's choices vs with every pass forced on: time ratio and the
    /// difference between the two images.
    Plan {
        /// Scene file (TOML, or Mitsuba 3 XML).
        scene: PathBuf,
        /// Scene overrides, e.g. --set camera.resolution=[64,64] to run it small.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Photon tracing (segments/s, 1 thread) vs a bare rtcIntersect1 loop over the same rays.
    Photons {
        /// Scene file (TOML, or Mitsuba 3 XML).
        scene: PathBuf,
        /// Photons to store per map for the measurement.
        #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u64).range(1..))]
        photons: u64,
        /// Scene overrides, e.g. --set render.max_depth=4.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
}

#[derive(Args, Debug)]
pub struct KnnArgs {
    /// Photons (points) in the tree.
    #[arg(long, default_value_t = 1_000_000)]
    pub points: usize,
    /// k-NN queries timed (each tree answers the same ones).
    #[arg(long, default_value_t = 100_000)]
    pub queries: usize,
    /// Neighbours per query.
    #[arg(long, default_value_t = 50)]
    pub k: usize,
    /// uniform | clustered | plane
    #[arg(long, default_value = "uniform")]
    pub distribution: String,
    /// Radius cap for the k-NN (default: none).
    #[arg(long)]
    pub radius: Option<f32>,
    /// Seed of the random points and queries.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// A time limit: a finite number of seconds above zero.
fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 => Ok(t),
        _ => Err(format!("`{s}`: expected a number of seconds above 0, e.g. 30 or 2.5")),
    }
}

/// `--part i/N`: 0 ≤ i < N.
fn parse_part(s: &str) -> Result<(u32, u32), String> {
    let (i, n) = s.split_once('/').ok_or_else(|| format!("`{s}`: expected i/N, e.g. 0/4"))?;
    let i: u32 = i.trim().parse().map_err(|_| format!("`{s}`: part index `{i}` is not a number"))?;
    let n: u32 = n.trim().parse().map_err(|_| format!("`{s}`: part count `{n}` is not a number"))?;
    if n == 0 || i >= n {
        return Err(format!("`{s}`: need 0 ≤ i < N (parts are numbered 0 to N−1, as in a Slurm array 0-(N−1))"));
    }
    Ok((i, n))
}

/// `-o` takes an output base; a known extension the user typed (`-o out/a.exr`) is dropped, since the
/// commands append the extensions of the files they write.
fn out_base(s: &str) -> Result<PathBuf, String> {
    if s.is_empty() {
        return Err("the output path is empty".into());
    }
    Ok(crate::output::output_base(std::path::Path::new(s)))
}
