//! The one place commands call to render: plan → photon maps → eye pass or path tracing → outputs,
//! one function per mode. Commands (app, bench, tools, timeerror) sit above it and never call each other.
use crate::accel::{Accel, Tracer};
use crate::film::Image;
use crate::film::Sums;
use crate::integrator::path::PathTracer;
use crate::integrator::photon_map::{
    build_maps, splat_photons, MapRequest, PhotonMapper, PhotonMaps, RadianceCache, PHOTON_TINTS,
};
use crate::integrator::Counters;
use crate::math::Ray;
use crate::metrics::compare;
use crate::output::{self, with_suffix};
use crate::photon::trace::{CAUSTIC, DIRECT, INDIRECT};
use crate::plan::{Plan, Probe};
use crate::render::{render_share, render_share_pixels, RenderOutput, Share, ShareOutput};
use crate::scene::file::Mode;
use crate::scene::Scene;
use anyhow::{bail, Result};
use serde_json::json;
use std::path::{Path, PathBuf};

/// One image of a render, still as per-pixel sums: `pt`, `pm`, `ppm` or `sppm`, with the JSON stats of
/// its output and the weight every pixel has once all shares of the render are added (`spp` for the
/// path tracer, the eye samples for photon mapping, the passes for PPM, 1 for SPPM).
pub struct Layer {
    pub name: String,
    pub sums: Sums,
    pub expected_weight: f64,
    /// How the layer splits across parts: `samples`, `rows`, `passes` (or `none`).
    pub split: String,
    pub stats: serde_json::Value,
}

/// Which share of the render to do: `None` for all of it, `Some((i, n))` for part i of n
/// (path tracing splits every pixel's samples, a fixed photon map its rows, PPM its passes).
pub type Part = Option<(u32, u32)>;

/// The render modes of `caustica render`: path tracing, photon mapping, both side by side, PPM or
/// SPPM; writes OUT.exr/.png/.json (OUT-pt and OUT-pm plus a side-by-side OUT.png for both). `base`
/// holds the stats every output's JSON shares.
pub fn render_modes(
    scene: &Scene,
    accel: &Accel,
    plan: &Plan,
    out: &Path,
    base: serde_json::Value,
    bvh_s: f64,
    quiet: bool,
) -> Result<()> {
    let layers = render_layers(scene, accel, plan, &base, bvh_s, None, quiet)?;
    let images: Vec<(String, Image, serde_json::Value)> =
        layers.into_iter().map(|l| (l.name, l.sums.image(), l.stats)).collect();
    write_layers(out, &images, scene.render.exposure)
}

/// The layers the scene's mode makes, or their share `part`.
pub fn render_layers(
    scene: &Scene,
    accel: &Accel,
    plan: &Plan,
    base: &serde_json::Value,
    bvh_s: f64,
    part: Part,
    quiet: bool,
) -> Result<Vec<Layer>> {
    let mode = scene.render.mode;
    scene.check_mode(mode).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (i, n) = part.unwrap_or((0, 1));
    let share = |rows: bool| match part {
        None => Share::All,
        Some(_) if rows => Share::Rows { part: i, parts: n },
        Some(_) => Share::Samples { part: i, parts: n },
    };
    let need = |what: &str, have: u64, key: &str| -> Result<()> {
        if part.is_some() && (n as u64) > have {
            bail!("--part {i}/{n}: {n} parts but only {have} {what} ({key}); every part needs at least one");
        }
        Ok(())
    };
    let mut layers = Vec::new();
    if mode.is_progressive() {
        if part.is_some() {
            if mode == Mode::Sppm {
                bail!("--part: sppm cannot be split (each iteration updates every pixel's radius and flux from the one before); use --mode ppm, bdpt or vcm, whose passes are independent");
            }
            if scene.render.progressive.time_s > 0.0 {
                bail!("--part: a part must do a fixed share of the passes; render.progressive.time_s (--time-s) cannot be split, give --passes instead");
            }
            need("passes", scene.render.progressive.passes as u64, "render.progressive.passes")?;
        }
        let r = render_progressive_share(scene, accel, plan, quiet, &[], (i, n))?;
        let mut stats = base.clone();
        let name = mode.layer_name();
        stats["mode"] = json!(name);
        stats["plan"] = json!(plan);
        stats["passes"] = json!(r.records);
        stats["initial_radius"] = json!(progressive_r1(scene));
        if let Some([caught, aimed]) = r.vcm_aim {
            stats["light_subpaths"] = json!({ "emitted_towards_specular_shapes": caught, "aimed": aimed });
        }
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "render": r.output.seconds });
        add_counters(&mut stats, &r.output.counters, r.output.seconds);
        let expected_weight = if mode == Mode::Sppm { 1.0 } else { scene.render.progressive.passes as f64 };
        let split = if mode == Mode::Sppm { "none" } else { "passes" };
        layers.push(Layer { name: name.into(), sums: r.sums, expected_weight, split: split.into(), stats });
        return Ok(layers);
    }
    if mode != Mode::PhotonMap {
        need("samples per pixel", scene.render.spp as u64, "render.spp")?;
        let r = render_path_share(scene, accel, scene.render.spp, share(false), quiet);
        let mut stats = base.clone();
        stats["mode"] = json!("path");
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "render": r.seconds });
        add_counters(&mut stats, &r.counters, r.seconds);
        let split = if part.is_some() { "samples" } else { "none" };
        let expected_weight = scene.render.spp as f64;
        layers.push(Layer { name: "pt".into(), sums: r.sums, expected_weight, split: split.into(), stats });
    }
    if mode != Mode::Path {
        need("image rows", scene.camera.height as u64, "camera.resolution")?;
        let (maps, r) = render_pm_share(scene, accel, plan, share(true), quiet)?;
        let mut stats = base.clone();
        stats["mode"] = json!("photon_map");
        stats["plan"] = json!(plan);
        stats["photon_maps"] = json!(maps.stats);
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "photon_trace": maps.stats.trace_seconds(), "kdtree_build": maps.stats.build_seconds, "eye_pass": r.seconds });
        add_counters(&mut stats, &r.counters, r.seconds);
        let split = if part.is_some() { "rows" } else { "none" };
        let expected_weight = scene.render.pm_spp as f64;
        layers.push(Layer { name: "pm".into(), sums: r.sums, expected_weight, split: split.into(), stats });
    }
    Ok(layers)
}

/// Writes a render's images: one layer to OUT.exr/.png/.json; PT and PM to OUT-pt.* and OUT-pm.* with
/// a side-by-side OUT.png.
pub fn write_layers(out: &Path, layers: &[(String, Image, serde_json::Value)], exposure: f32) -> Result<()> {
    let both = layers.len() == 2;
    for (name, img, stats) in layers {
        let o = if both { with_suffix(out, &format!("-{name}")) } else { out.to_path_buf() };
        write_outputs(&o, img, exposure, stats)?;
    }
    if both {
        let title = |(name, _, stats): &(String, Image, serde_json::Value)| match name.as_str() {
            "pt" => format!("path tracing {} spp", stats["settings"]["spp"]),
            _ => "photon mapping".to_string(),
        };
        let white = crate::color::Rgb::ONE;
        let panels: Vec<Image> =
            layers.iter().map(|l| crate::font::label_bar(&l.1, &[(title(l).as_str(), white)], exposure)).collect();
        let side = Image::side_by_side(&[&panels[0], &panels[1]], 4);
        let p = with_suffix(out, ".png");
        output::write_png(&p, &side, 0.0)?;
        println!("wrote {} (left: path tracing, right: photon mapping)", p.display());
    }
    Ok(())
}

/// Renders with the path tracer.
pub fn render_path(scene: &Scene, tracer: &dyn Tracer, spp: u32, quiet: bool) -> RenderOutput {
    render_path_share(scene, tracer, spp, Share::All, quiet).finish()
}

/// A share of a path-traced render.
pub fn render_path_share(scene: &Scene, tracer: &dyn Tracer, spp: u32, share: Share, quiet: bool) -> ShareOutput {
    let r = &scene.render;
    let pt = PathTracer { scene, tracer, max_depth: r.max_depth, rr_depth: r.rr_depth };
    let cam = &scene.camera;
    render_share(cam, spp, r.sampler, r.seed, share, "path", quiet, |x, y, rng, c: &mut Counters| {
        pt.li(cam.sample_ray(x, y, rng), rng, c)
    })
}

fn add_counters(stats: &mut serde_json::Value, c: &Counters, seconds: f64) {
    stats["rays"] = json!(c.rays);
    stats["rays_per_s"] = json!(c.rays as f64 / seconds.max(1e-9));
    stats["nonfinite_samples"] = json!(c.nonfinite);
    stats["peak_rss_bytes"] = json!(output::peak_rss_bytes());
}

/// The planner, asking Embree its visibility questions.
pub fn plan_for(scene: &Scene, tracer: &dyn Tracer) -> Plan {
    // Both look past see-through surfaces (null surfaces, masks), as light and camera rays do.
    let visible = |a: glam::Vec3, b: glam::Vec3| {
        let mut r = Ray::new(a, b - a);
        r.tmax = 1.0;
        crate::accel::shadow(scene, tracer, &r, b, &mut 0) != crate::color::Rgb::ZERO
    };
    let first = |r: Ray| {
        crate::accel::first_hit_past(scene, tracer, r, |s| scene.is_see_through(s)).map(|(h, r)| (h.shape, r.at(h.t)))
    };
    crate::plan::plan(scene, &Probe { visible: &visible, first_hit: &first })
}

/// Photon mapping as `plan` says: the maps it asks for, then the eye pass (whose `seconds` it returns).
pub fn render_pm(scene: &Scene, tracer: &dyn Tracer, plan: &Plan, quiet: bool) -> Result<(PhotonMaps, RenderOutput)> {
    let (maps, r) = render_pm_share(scene, tracer, plan, Share::All, quiet)?;
    Ok((maps, r.finish()))
}

/// `render_pm`'s share: every share builds the same (deterministic) maps, then renders its part of
/// the eye pass.
pub fn render_pm_share(
    scene: &Scene,
    tracer: &dyn Tracer,
    plan: &Plan,
    share: Share,
    quiet: bool,
) -> Result<(PhotonMaps, ShareOutput)> {
    scene.check_mode(crate::scene::file::Mode::PhotonMap).map_err(|e| anyhow::anyhow!("{e}"))?;
    let maps = build_maps(scene, tracer, &MapRequest::planned(scene, plan), quiet)?;
    let r = render_photon_map_share(scene, tracer, &maps, plan, None, share, quiet);
    Ok((maps, r))
}

/// Photon mapping with the scene's own settings and the planner's choices; `seconds` covers it all.
pub fn render_pm_default(scene: &Scene, tracer: &dyn Tracer, quiet: bool) -> Result<RenderOutput> {
    let (maps, mut r) = render_pm(scene, tracer, &plan_for(scene, tracer), quiet)?;
    r.seconds += maps.stats.trace_seconds() + maps.stats.build_seconds;
    Ok(r)
}

/// The photon-map eye pass over the whole film; `only` shows a single map's estimate.
pub fn render_photon_map(
    scene: &Scene,
    tracer: &dyn Tracer,
    maps: &PhotonMaps,
    plan: &Plan,
    only: Option<usize>,
    quiet: bool,
) -> RenderOutput {
    render_photon_map_share(scene, tracer, maps, plan, only, Share::All, quiet).finish()
}

/// A share of the photon-map eye pass.
pub fn render_photon_map_share(
    scene: &Scene,
    tracer: &dyn Tracer,
    maps: &PhotonMaps,
    plan: &Plan,
    only: Option<usize>,
    share: Share,
    quiet: bool,
) -> ShareOutput {
    let (extra, probes) = crate::integrator::extra_samples(scene, tracer, plan.specular_spp);
    let mut pm = PhotonMapper::new(scene, tracer, maps, only);
    pm.extra = &extra;
    pm.edges = scene.render.gather.edge_correction;
    if scene.render.final_gather > 0 && only.is_none() {
        let stride = scene.render.gather.cache_stride;
        pm.cache = RadianceCache::build(scene, tracer, maps, &pm.gather, stride, pm.edges);
    }
    let cam = &scene.camera;
    let seed = scene.render.seed;
    let mut out = render_share_pixels(
        cam,
        scene.render.pm_spp,
        scene.render.sampler,
        seed,
        share,
        "eye pass",
        quiet,
        |x, y, s, rng, c: &mut Counters| pm.sample(x, y, s, seed, rng, c),
    );
    out.counters.rays += probes;
    // The caustic pass's light-traced glossy caustics, on the pixels this share renders (weighted as
    // its samples are, so that shares add up).
    if let (Some(g), None | Some(CAUSTIC)) = (&maps.glossy, only) {
        let sums = &mut out.sums;
        for ((sum, &w), v) in sums.sum.iter_mut().zip(&sums.weight).zip(&g.pixels) {
            for k in 0..3 {
                sum[k] += v[k] as f64 * w;
            }
        }
    }
    out
}

fn parse_map(name: &str) -> Result<Vec<usize>> {
    Ok(match name {
        "direct" => vec![DIRECT],
        "indirect" => vec![INDIRECT],
        "caustic" => vec![CAUSTIC],
        "all" => vec![DIRECT, INDIRECT, CAUSTIC],
        _ => bail!("unknown map `{name}` (accepted: direct, indirect, caustic, all)"),
    })
}

/// `--view photons:MAP` (splatted photon positions) and `--view map:MAP` (one map's estimate).
pub fn render_view(
    scene: &Scene,
    accel: &Accel,
    plan: &Plan,
    view: &str,
    out: &Path,
    mut stats: serde_json::Value,
    quiet: bool,
) -> Result<()> {
    let (kind, map) =
        view.split_once(':').ok_or_else(|| anyhow::anyhow!("--view {view}: expected image, photons:MAP or map:MAP"))?;
    let which = parse_map(map)?;
    if kind == "map" && which.len() != 1 {
        bail!("--view map:{map}: choose one of direct, indirect, caustic");
    }
    let ps = &scene.render.photons;
    let mut want = [0u64; 3];
    for &m in &which {
        want[m] = [ps.direct, ps.indirect, ps.caustic][m];
    }
    // A map the plan does not build holds nothing: say so at once instead of shooting photons for a
    // black image.
    let unplanned: Vec<usize> = which.iter().copied().filter(|&m| plan.photons[m] == 0).collect();
    if unplanned.len() == which.len() {
        let names: Vec<&str> = unplanned.iter().map(|&m| crate::photon::trace::MAP_NAMES[m]).collect();
        bail!(
            "--view {view}: this scene has no {} photons to show (the planner builds no such map: {})",
            names.join(" or "),
            if plan.reasons.is_empty() { "nothing reaches it".to_string() } else { plan.reasons.join("; ") }
        );
    }
    for m in unplanned {
        want[m] = 0;
    }
    let maps = build_maps(scene, accel, &MapRequest { want, ..MapRequest::planned(scene, plan) }, quiet)?;
    let img = match kind {
        "photons" => splat_photons(scene, accel, &maps, &which),
        "map" => render_photon_map(scene, accel, &maps, plan, Some(which[0]), quiet).image,
        _ => bail!("--view {view}: expected image, photons:MAP or map:MAP"),
    };
    stats["view"] = json!(view);
    stats["photon_maps"] = json!(maps.stats);
    // The PNG carries a legend (the EXR stays the bare image): each map's name in its own tint, with
    // the photons it stored; a map view names its map.
    let names: Vec<String> = which
        .iter()
        .filter(|&&m| maps.stats.stored[m] > 0)
        .map(|&m| format!("{} {}", crate::photon::trace::MAP_NAMES[m], maps.stats.stored[m]))
        .collect();
    let items: Vec<(&str, crate::color::Rgb)> = match kind {
        "photons" => names
            .iter()
            .zip(which.iter().filter(|&&m| maps.stats.stored[m] > 0))
            .map(|(n, &m)| (n.as_str(), PHOTON_TINTS[m]))
            .collect(),
        _ => names.iter().map(|n| (n.as_str(), crate::color::Rgb::ONE)).collect(),
    };
    let preview = crate::font::label_bar(&img, &items, scene.render.exposure);
    output::write_image_set_with_preview(out, &img, &preview, &stats)?;
    say_written(out, &img, " (with a legend)");
    Ok(())
}

/// Writes OUT.exr, OUT.png and OUT.json together, and says where they went.
fn write_outputs(out: &Path, img: &Image, exposure: f32, stats: &serde_json::Value) -> Result<()> {
    output::write_image_set(out, img, exposure, stats)?;
    say_written(out, img, "");
    Ok(())
}

fn say_written(out: &Path, img: &Image, png_note: &str) {
    println!(
        "wrote {} ({}×{}), {}{png_note} and {}",
        with_suffix(out, ".exr").display(),
        img.width,
        img.height,
        with_suffix(out, ".png").display(),
        with_suffix(out, ".json").display()
    );
}

/// A reference image: the mean of two independent halves, with their RMSE as its noise estimate.
pub struct Reference {
    pub image: Image,
    /// The two independent halves whose mean `image` is (for noise figures on any scale).
    pub halves: [Image; 2],
    /// RMSE between the two halves; the mean's own RMSE is about half of it.
    pub halves_rmse: f64,
    pub path: PathBuf,
    /// Seconds it took to render, or None when it came from the cache.
    pub rendered_s: Option<f64>,
}

/// How a reference is rendered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RefKind {
    /// The path tracer at this many samples per pixel (split over the two halves).
    Spp(u32),
    /// The fixed photon mapper at this many photons (half caustic, a quarter indirect per half). Biased:
    /// its halves share the blur of the gather, which their difference does not show.
    Photons(u64),
    /// SPPM for this many passes per half (a consistent estimator, for scenes PT cannot render: its
    /// halves' difference shows its noise; its bias shrinks with the passes).
    SppmPasses(u32),
}

impl RefKind {
    /// Exactly one of the three command-line options, named in the error otherwise.
    pub fn from_options(spp: Option<u32>, photons: Option<u64>, passes: Option<u32>) -> Result<RefKind> {
        match (spp, photons, passes) {
            (Some(s), None, None) => Ok(RefKind::Spp(s)),
            (None, Some(p), None) => Ok(RefKind::Photons(p)),
            (None, None, Some(n)) => Ok(RefKind::SppmPasses(n)),
            _ => bail!("give exactly one of --spp, --photons or --passes (for a reference)"),
        }
    }

    fn cache_name(self) -> String {
        match self {
            RefKind::Spp(s) => format!("{s}spp"),
            RefKind::Photons(p) => format!("{p}photons"),
            RefKind::SppmPasses(n) => format!("sppm{n}passes"),
        }
    }
}

/// Renders (or loads from the cache in `dir`) a reference of the given kind as two independent halves
/// (different seeds).
pub fn reference(scene_path: &Path, overrides: &[String], kind: RefKind, dir: &Path, quiet: bool) -> Result<Reference> {
    let mut text =
        std::fs::read(scene_path).map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", scene_path.display()))?;
    // The cache key covers the scene text and the overrides.
    for o in overrides {
        text.extend_from_slice(o.as_bytes());
    }
    let key = crate::math::rng::mix64(
        text.iter().fold(0xCBF2_9CE4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x100_0000_01B3)),
    );
    let stem = scene_path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    let what = kind.cache_name();
    let base = dir.join(format!("{stem}-{what}-{key:016x}"));
    let exr = with_suffix(&base, ".exr");
    let js = with_suffix(&base, ".json");
    let half_paths = [with_suffix(&base, "-half0.exr"), with_suffix(&base, "-half1.exr")];
    if exr.exists() && js.exists() && half_paths.iter().all(|p| p.exists()) {
        let meta: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&js)?)?;
        if let Some(n) = meta["halves_rmse"].as_f64() {
            let halves = [output::read_exr(&half_paths[0])?, output::read_exr(&half_paths[1])?];
            let image = output::read_exr(&exr)?;
            return Ok(Reference { image, halves, halves_rmse: n, path: exr, rendered_s: None });
        }
    }
    let t0 = std::time::Instant::now();
    let mut halves = Vec::new();
    for half in 0..2u64 {
        let mut sets = overrides.to_vec();
        sets.push(format!("render.seed={}", 1_000_003 * (half + 1)));
        match kind {
            RefKind::Photons(p) => {
                sets.push(format!("render.photons.caustic={}", p / 2));
                sets.push(format!("render.photons.indirect={}", p / 4));
            }
            RefKind::SppmPasses(n) => {
                sets.push("render.mode=\"sppm\"".to_string());
                sets.push(format!("render.progressive.passes={n}"));
                sets.push("render.progressive.time_s=0.0".to_string());
            }
            RefKind::Spp(_) => {}
        }
        let scene = crate::scene::load_scene_with(scene_path, &sets)?;
        let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
        let img = match kind {
            RefKind::Spp(s) => render_path(&scene, &accel, (s / 2).max(1), quiet).image,
            RefKind::Photons(_) => render_pm_default(&scene, &accel, quiet)?.image,
            RefKind::SppmPasses(_) => {
                let plan = plan_for(&scene, &accel);
                render_progressive(&scene, &accel, &plan, quiet, &[])?.output.image
            }
        };
        halves.push(img);
    }
    let halves_rmse = compare(&halves[0], &halves[1]).map(|e| e.rmse).unwrap_or(f64::NAN);
    let mut image = halves[0].clone();
    for (p, q) in image.pixels.iter_mut().zip(&halves[1].pixels) {
        *p = (*p + *q) * 0.5;
    }
    let mut files = output::Batch::default();
    files.stage(&exr, |t| output::encode_exr(t, &image))?;
    for (p, h) in half_paths.iter().zip(&halves) {
        files.stage(p, |t| output::encode_exr(t, h))?;
    }
    files.stage(&js, |t| {
        output::encode_json(
            t,
            &json!({ "scene": scene_path.display().to_string(), "kind": what, "halves_rmse": halves_rmse,
        "mean_rmse_estimate": halves_rmse / 2.0, "seconds": t0.elapsed().as_secs_f64() }),
        )
    })?;
    files.commit()?;
    let [h0, h1]: [Image; 2] = halves.try_into().map_err(|_| anyhow::anyhow!("two halves expected"))?;
    Ok(Reference { image, halves: [h0, h1], halves_rmse, path: exr, rendered_s: Some(t0.elapsed().as_secs_f64()) })
}

/// A progressive render: the final image (with the total time and counters), a record per pass, and
/// the images after the pass counts asked for as snapshots (with the seconds spent up to each).
pub struct Progressive {
    pub output: RenderOutput,
    /// The image as sums (PPM: pass images summed, weight = passes; SPPM: its image, weight 1).
    pub sums: Sums,
    pub records: Vec<crate::integrator::ppm::PassRecord>,
    pub snapshots: Vec<(u32, f64, Image)>,
    /// bdpt/vcm: the share of the lights' own emission that heads for the specular shapes' bounding
    /// spheres and the share of light subpaths aimed at them (`vcm::Aim`).
    pub vcm_aim: Option<[f32; 2]>,
}

/// `--mode ppm` or `--mode sppm` (the scene's `render.mode`): passes until `render.progressive.passes`
/// or `render.progressive.time_s`, whichever comes first, with a progress line giving the pass, the
/// radius relative to the scene's diagonal and photons per second. `snapshots` lists pass counts after
/// which the current image is kept (time spent making snapshots is not counted).
pub fn render_progressive(
    scene: &Scene,
    tracer: &dyn Tracer,
    plan: &Plan,
    quiet: bool,
    snapshots: &[u32],
) -> Result<Progressive> {
    render_progressive_share(scene, tracer, plan, quiet, snapshots, (0, 1))
}

/// `render_progressive`'s share `part` = (i, n) of the passes: PPM passes first + k with k ≡ i (mod n)
/// (interleaved, so every part gets large and small radii alike). SPPM has only (0, 1).
pub fn render_progressive_share(
    scene: &Scene,
    tracer: &dyn Tracer,
    plan: &Plan,
    quiet: bool,
    snapshots: &[u32],
    part: (u32, u32),
) -> Result<Progressive> {
    use crate::integrator::ppm::{ppm_pass, radius_at};
    use crate::integrator::vcm;
    scene.check_mode(scene.render.mode).map_err(|e| anyhow::anyhow!("{e}"))?;
    let p = &scene.render.progressive;
    let mode = scene.render.mode;
    let sppm_mode = mode == Mode::Sppm;
    let r1 = progressive_r1(scene);
    let mut sums = Sums::new(scene.camera.width, scene.camera.height);
    // Set-up (the caustic targets probed once, SPPM's pixel table, VCM's aim and pilot) counts towards
    // the render's time.
    let t_setup = std::time::Instant::now();
    let photon_passes = matches!(mode, Mode::Ppm | Mode::Sppm);
    let aim = if photon_passes { crate::integrator::photon_map::aim_targets(scene, tracer, plan) } else { None };
    let mut sppm = sppm_mode.then(|| crate::integrator::sppm::Sppm::new(scene, tracer, plan, aim.clone()));
    // PPM's extra eye samples per pixel, chosen once for every pass.
    let (ppm_extra, extra_rays) = if mode == Mode::Ppm {
        crate::integrator::extra_samples(scene, tracer, plan.specular_spp)
    } else {
        (Vec::new(), 0)
    };
    let first = if sppm_mode { 1 } else { p.first_pass };
    let (part, parts) = if sppm_mode { (0, 1) } else { (part.0, part.1.max(1)) };
    let passes: Vec<u32> = (first..first + p.passes).filter(|k| (k - first) % parts == part).collect();
    let pb = crate::progress::progress(passes.len() as u64, mode.layer_name(), quiet);
    let (mut records, mut shots) = (Vec::new(), Vec::new());
    let mut counters = Counters { rays: extra_rays, nonfinite: 0 };
    let vcm_setup = matches!(mode, Mode::Bdpt | Mode::Vcm).then(|| {
        let opts = vcm::VcmOptions::of_scene(scene);
        let setup = vcm::Setup::new(scene, tracer, opts, Some(&plan.caustic_targets));
        if !quiet {
            if setup.aim.targets() > 0 {
                println!("{}", setup.aim.describe());
            }
            let (lo, hi, cells) = setup.radius.spread();
            if cells > 0 {
                let d = scene.diagonal().max(1e-30);
                println!(
                    "merge radius: {:.2e} to {:.2e} of the diagonal over {cells} regions the light reaches (elsewhere {:.2e}), shrinking with passes",
                    lo / d,
                    hi / d,
                    setup.radius.r1() / d
                );
            }
        }
        setup
    });
    if !quiet && r1 > 0.0 {
        if let Some(px) = pixels_across(scene, tracer, r1) {
            // VCM's radius field is at most r1, smaller where the pilot found the light dense.
            let local = vcm_setup.as_ref().is_some_and(|s| s.radius.spread().2 > 0);
            println!(
                "first {} {}{r1:.3e}: about {px:.1} pixel widths where the image's centre looks (shrinking \
                 with passes; render.progressive.radius sets it)",
                if mode == Mode::Vcm { "merge radius" } else { "gather radius" },
                if local { "at most " } else { "" },
            );
        }
    }
    let (mut seconds, mut emitted) = (t_setup.elapsed().as_secs_f64(), 0u64);
    for &i in &passes {
        let record = match (sppm.as_mut(), vcm_setup.as_ref()) {
            (Some(s), _) => s.iterate(i)?,
            (None, Some(setup)) => {
                let opts = setup.opts;
                let t0 = std::time::Instant::now();
                let r = if opts.merge { vcm::radius_at(setup.radius.r1(), p.alpha, i) } else { 0.0 };
                let out = vcm::iterate(scene, tracer, setup, i);
                sums.add_image(&out.image);
                counters += out.counters;
                crate::integrator::ppm::PassRecord {
                    pass: i,
                    seconds: t0.elapsed().as_secs_f64(),
                    radius: r,
                    emitted: [0; 3],
                    stored: out.light_vertices,
                    light_paths: vcm::light_paths(scene, opts) as u64,
                }
            }
            (None, None) => {
                let (img, c, record) =
                    ppm_pass(scene, tracer, plan, &ppm_extra, i, radius_at(r1, p.alpha, i), aim.as_ref())?;
                sums.add_image(&img);
                counters += c;
                record
            }
        };
        seconds += record.seconds;
        emitted += record.emitted.iter().sum::<u64>() + record.light_paths;
        records.push(record);
        pb.set_position(records.len() as u64);
        let (radius_name, what) = match mode {
            Mode::Bdpt => (None, "light paths"),
            Mode::Vcm => (Some("merge radius"), "light paths"),
            _ => (Some("radius"), "photons"),
        };
        let r_rel = records[records.len() - 1].radius / scene.diagonal().max(1e-30);
        let radius = radius_name.map_or(String::new(), |n| format!(", {n} {r_rel:.2e} of the diagonal"));
        pb.set_message(format!("pass {i}{radius}, {:.2} M {what}/s", emitted as f64 / seconds.max(1e-9) / 1e6));
        if snapshots.contains(&i) {
            let img = match &sppm {
                Some(s) => s.image(),
                None => sums.image(),
            };
            shots.push((i, seconds, img));
        }
        if p.time_s > 0.0 && seconds >= p.time_s {
            break;
        }
    }
    pb.finish_and_clear();
    if let Some(s) = &sppm {
        counters += s.counters;
        sums = Sums::from_image(&s.image());
    }
    let image = sums.image();
    let vcm_aim = vcm_setup.map(|s| [s.aim.caught_by_targets(), s.aim.aimed_share()]);
    Ok(Progressive { output: RenderOutput { image, counters, seconds }, sums, records, snapshots: shots, vcm_aim })
}

/// How many pixels a length `r` spans on the surface the camera's centre ray meets, seen face-on (its
/// distance there times the film's width over the field of view; an orthographic film's width); None
/// when that ray meets nothing.
fn pixels_across(scene: &Scene, tracer: &dyn Tracer, r: f32) -> Option<f32> {
    let cam = &scene.camera;
    let ray = cam.ray(0.5 * cam.width as f32, 0.5 * cam.height as f32);
    let t = tracer.intersect(&ray)?.t;
    let pixel = cam.pixel_width_at(t, ray.d);
    (pixel > 0.0 && pixel.is_finite()).then(|| r / pixel)
}

/// The first pass's radius of a progressive mode: the gather radius of ppm/sppm, the merge radius of vcm
/// (0 for bdpt, which does not merge).
pub fn progressive_r1(scene: &Scene) -> f32 {
    match scene.render.mode {
        Mode::Bdpt => 0.0,
        Mode::Vcm => crate::integrator::vcm::initial_radius(scene),
        _ => crate::integrator::ppm::initial_radius(scene),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall 2 in front of a pinhole with a 90° field over 100 pixels: a pixel there is 2 · 2 · tan 45° /
    /// 100 = 0.04 wide, so a radius of 0.1 spans 2.5 of them; with nothing in front, no figure.
    #[test]
    fn a_radius_in_pixels_is_its_length_over_a_pixels_width_where_the_centre_looks() {
        let text = |z: f32| {
            format!(
                "[camera]\norigin = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, -1.0]\nfov = 90\nfov_axis = \"x\"\n\
                 resolution = [100, 60]\n[materials]\nwall = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n\
                 [[shapes]]\ntype = \"quad\"\ncorner = [-5.0, -5.0, {z}]\nedge_u = [10.0, 0.0, 0.0]\n\
                 edge_v = [0.0, 10.0, 0.0]\nmaterial = \"wall\"\nemission = [1.0, 1.0, 1.0]\n"
            )
        };
        let scene = crate::scene::load::load_scene_str(&text(-2.0), "t.toml", std::path::Path::new("."), &[]).unwrap();
        let accel = crate::accel::Accel::new(&scene).unwrap();
        let px = pixels_across(&scene, &accel, 0.1).unwrap();
        assert!((px - 2.5).abs() < 1e-3, "{px}");
        let behind = crate::scene::load::load_scene_str(&text(2.0), "t.toml", std::path::Path::new("."), &[]).unwrap();
        let accel = crate::accel::Accel::new(&behind).unwrap();
        assert_eq!(pixels_across(&behind, &accel, 0.1), None);
    }
}
