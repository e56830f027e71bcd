//! The one place commands call to render: plan → photon maps → eye pass or path tracing → outputs,
//! one function per mode. Commands (app, bench, tools, timeerror) sit above it and never call each other.
use crate::accel::{Accel, Tracer};
use crate::film::Image;
use crate::integrator::path::PathTracer;
use crate::integrator::photon_map::{build_maps, splat_photons, MapRequest, PhotonMapper, PhotonMaps};
use crate::integrator::Counters;
use crate::math::Ray;
use crate::metrics::compare;
use crate::output::{self, with_suffix};
use crate::photon::trace::{CAUSTIC, DIRECT, INDIRECT};
use crate::plan::{Plan, Probe};
use crate::render::{render, RenderOutput};
use crate::scene::file::Mode;
use crate::scene::Scene;
use anyhow::{bail, Result};
use serde_json::json;
use std::path::{Path, PathBuf};

/// The render modes of `caustica render`: path tracing, photon mapping, or both side by side; writes
/// OUT.exr/.png/.json (OUT-pt and OUT-pm plus a side-by-side OUT.png for both). `base` holds the stats
/// every output's JSON shares.
pub fn render_modes(
    scene: &Scene,
    accel: &Accel,
    plan: &Plan,
    out: &Path,
    base: serde_json::Value,
    bvh_s: f64,
    quiet: bool,
) -> Result<()> {
    let mode = scene.render.mode;
    if matches!(mode, Mode::Ppm | Mode::Sppm) {
        let r = render_progressive(scene, accel, plan, quiet, &[])?;
        let mut stats = base;
        stats["mode"] = json!(if mode == Mode::Ppm { "ppm" } else { "sppm" });
        stats["plan"] = json!(plan);
        stats["passes"] = json!(r.records);
        stats["initial_radius"] = json!(crate::integrator::ppm::initial_radius(scene));
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "render": r.output.seconds });
        add_counters(&mut stats, &r.output);
        write_outputs(out, &r.output.image, scene.render.exposure, &stats)?;
        return Ok(());
    }
    let mut images = Vec::new();
    if mode != Mode::PhotonMap {
        let r = render_path(scene, accel, scene.render.spp, quiet);
        let mut stats = base.clone();
        stats["mode"] = json!("path");
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "render": r.seconds });
        add_counters(&mut stats, &r);
        let o = if mode == Mode::Both { with_suffix(out, "-pt") } else { out.to_path_buf() };
        write_outputs(&o, &r.image, scene.render.exposure, &stats)?;
        images.push(r.image);
    }
    if mode != Mode::Path {
        let (maps, r) = render_pm(scene, accel, plan, quiet)?;
        let mut stats = base.clone();
        stats["mode"] = json!("photon_map");
        stats["plan"] = json!(plan);
        stats["photon_maps"] = json!(maps.stats);
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "photon_trace": maps.stats.trace_seconds(), "kdtree_build": maps.stats.build_seconds, "eye_pass": r.seconds });
        add_counters(&mut stats, &r);
        let o = if mode == Mode::Both { with_suffix(out, "-pm") } else { out.to_path_buf() };
        write_outputs(&o, &r.image, scene.render.exposure, &stats)?;
        images.push(r.image);
    }
    if images.len() == 2 {
        let side = Image::side_by_side(&[&images[0], &images[1]], 4);
        let p = with_suffix(out, ".png");
        output::write_png(&p, &side, scene.render.exposure)?;
        println!("wrote {} (left: path tracing, right: photon mapping)", p.display());
    }
    Ok(())
}

/// Renders with the path tracer.
pub fn render_path(scene: &Scene, tracer: &dyn Tracer, spp: u32, quiet: bool) -> RenderOutput {
    let r = &scene.render;
    let pt = PathTracer { scene, tracer, max_depth: r.max_depth, rr_depth: r.rr_depth };
    let cam = &scene.camera;
    render(cam.width, cam.height, spp, r.seed, "path", quiet, |x, y, rng, c: &mut Counters| {
        pt.li(cam.ray(x, y), rng, c)
    })
}

fn add_counters(stats: &mut serde_json::Value, r: &RenderOutput) {
    stats["rays"] = json!(r.counters.rays);
    stats["rays_per_s"] = json!(r.counters.rays as f64 / r.seconds.max(1e-9));
    stats["nonfinite_samples"] = json!(r.counters.nonfinite);
    stats["peak_rss_bytes"] = json!(output::peak_rss_bytes());
}

/// The planner, asking Embree its visibility questions.
pub fn plan_for(scene: &Scene, tracer: &dyn Tracer) -> Plan {
    let visible = |a: glam::Vec3, b: glam::Vec3| {
        let mut r = Ray::new(a, b - a);
        r.tmax = 1.0;
        !tracer.occluded(&r)
    };
    let first = |r: Ray| tracer.intersect(&r).map(|h| (h.shape, r.at(h.t)));
    crate::plan::plan(scene, &Probe { visible: &visible, first_hit: &first })
}

/// Photon mapping as `plan` says: the maps it asks for, then the eye pass (whose `seconds` it returns).
pub fn render_pm(scene: &Scene, tracer: &dyn Tracer, plan: &Plan, quiet: bool) -> Result<(PhotonMaps, RenderOutput)> {
    let req = MapRequest::planned(scene, plan);
    let maps = build_maps(scene, tracer, &req, quiet)?;
    let r = render_photon_map(scene, tracer, &maps, plan, None, quiet);
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
    let mut pm = PhotonMapper::new(scene, tracer, maps, only);
    pm.specular_spp = plan.specular_spp;
    let cam = &scene.camera;
    render(
        cam.width,
        cam.height,
        scene.render.pm_spp,
        scene.render.seed,
        "eye pass",
        quiet,
        |x, y, rng, c: &mut Counters| pm.li(cam.ray(x, y), rng, c),
    )
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
    let maps = build_maps(scene, accel, &MapRequest { want, ..MapRequest::planned(scene, plan) }, quiet)?;
    let img = match kind {
        "photons" => splat_photons(scene, accel, &maps, &which),
        "map" => render_photon_map(scene, accel, &maps, plan, Some(which[0]), quiet).image,
        _ => bail!("--view {view}: expected image, photons:MAP or map:MAP"),
    };
    stats["view"] = json!(view);
    stats["photon_maps"] = json!(maps.stats);
    write_outputs(out, &img, scene.render.exposure, &stats)?;
    Ok(())
}

/// Writes OUT.exr, OUT.png and OUT.json together, and says where they went.
fn write_outputs(out: &Path, img: &Image, exposure: f32, stats: &serde_json::Value) -> Result<()> {
    output::write_image_set(out, img, exposure, stats)?;
    println!(
        "wrote {} ({}×{}), {} and {}",
        with_suffix(out, ".exr").display(),
        img.width,
        img.height,
        with_suffix(out, ".png").display(),
        with_suffix(out, ".json").display()
    );
    Ok(())
}

/// A reference image: the mean of two independent halves, with their RMSE as its noise estimate.
pub struct Reference {
    pub image: Image,
    /// The two independent halves whose mean `image` is (for noise figures on any scale).
    pub halves: [Image; 2],
    /// RMSE between the two halves; the mean's own RMSE is about half of it.
    pub halves_rmse: f64,
    pub path: PathBuf,
}

/// Renders (or loads from the cache in `dir`) a path-traced reference at `spp`, or with `photons`
/// (photon mapping at that many caustic and indirect photons, for scenes only PM can render).
pub fn reference(
    scene_path: &Path,
    overrides: &[String],
    spp: Option<u32>,
    photons: Option<u64>,
    dir: &Path,
    quiet: bool,
) -> Result<Reference> {
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
    let what = match (spp, photons) {
        (Some(s), None) => format!("{s}spp"),
        (None, Some(p)) => format!("{p}photons"),
        _ => bail!("give exactly one of --spp or --photons"),
    };
    let base = dir.join(format!("{stem}-{what}-{key:016x}"));
    let exr = with_suffix(&base, ".exr");
    let js = with_suffix(&base, ".json");
    let half_paths = [with_suffix(&base, "-half0.exr"), with_suffix(&base, "-half1.exr")];
    if exr.exists() && js.exists() && half_paths.iter().all(|p| p.exists()) {
        let meta: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&js)?)?;
        if let Some(n) = meta["halves_rmse"].as_f64() {
            let halves = [output::read_exr(&half_paths[0])?, output::read_exr(&half_paths[1])?];
            return Ok(Reference { image: output::read_exr(&exr)?, halves, halves_rmse: n, path: exr });
        }
    }
    let t0 = std::time::Instant::now();
    let mut halves = Vec::new();
    for half in 0..2u64 {
        let mut sets = overrides.to_vec();
        sets.push(format!("render.seed={}", 1_000_003 * (half + 1)));
        if let Some(p) = photons {
            sets.push(format!("render.photons.caustic={}", p / 2));
            sets.push(format!("render.photons.indirect={}", p / 4));
        }
        let scene = crate::scene::load_scene_with(scene_path, &sets)?;
        let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
        let img = match spp {
            Some(s) => render_path(&scene, &accel, (s / 2).max(1), quiet).image,
            None => render_pm_default(&scene, &accel, quiet)?.image,
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
    Ok(Reference { image, halves: [h0, h1], halves_rmse, path: exr })
}

/// A progressive render: the final image (with the total time and counters), a record per pass, and
/// the images after the pass counts asked for as snapshots (with the seconds spent up to each).
pub struct Progressive {
    pub output: RenderOutput,
    pub records: Vec<crate::integrator::ppm::PassRecord>,
    pub snapshots: Vec<(u32, f64, Image)>,
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
    use crate::integrator::ppm::{initial_radius, ppm_pass, radius_at};
    let p = &scene.render.progressive;
    let sppm_mode = scene.render.mode == Mode::Sppm;
    let r1 = initial_radius(scene);
    let pixels = scene.camera.width as usize * scene.camera.height as usize;
    let mut sum = vec![[0.0f64; 3]; pixels];
    let mut sppm = sppm_mode.then(|| crate::integrator::sppm::Sppm::new(scene, tracer, plan));
    let pb = crate::progress::progress(p.passes as u64, if sppm_mode { "sppm" } else { "ppm" }, quiet);
    let (mut records, mut shots) = (Vec::new(), Vec::new());
    let mut counters = Counters::default();
    let (mut seconds, mut emitted) = (0.0f64, 0u64);
    let mean = |sum: &[[f64; 3]], n: u32| {
        let mut img = Image::new(scene.camera.width, scene.camera.height);
        for (o, s) in img.pixels.iter_mut().zip(sum) {
            *o = glam::Vec3::new((s[0] / n as f64) as f32, (s[1] / n as f64) as f32, (s[2] / n as f64) as f32);
        }
        img
    };
    let first = if sppm_mode { 1 } else { p.first_pass };
    for i in first..first + p.passes {
        let record = match sppm.as_mut() {
            Some(s) => s.iterate(i)?,
            None => {
                let (img, c, record) = ppm_pass(scene, tracer, plan, i, radius_at(r1, p.alpha, i))?;
                for (acc, px) in sum.iter_mut().zip(&img.pixels) {
                    for k in 0..3 {
                        acc[k] += px[k] as f64;
                    }
                }
                counters += c;
                record
            }
        };
        seconds += record.seconds;
        emitted += record.emitted.iter().sum::<u64>();
        pb.set_position((i - first + 1) as u64);
        pb.set_message(format!(
            "pass {i}, radius {:.2e} of the diagonal, {:.2} M photons/s",
            record.radius / scene.diagonal().max(1e-30),
            emitted as f64 / seconds.max(1e-9) / 1e6
        ));
        records.push(record);
        if snapshots.contains(&i) {
            let img = match &sppm {
                Some(s) => s.image(),
                None => mean(&sum, records.len() as u32),
            };
            shots.push((i, seconds, img));
        }
        if p.time_s > 0.0 && seconds >= p.time_s {
            break;
        }
    }
    pb.finish_and_clear();
    let n = records.len() as u32;
    let image = match &sppm {
        Some(s) => {
            counters += s.counters;
            s.image()
        }
        None => mean(&sum, n),
    };
    Ok(Progressive { output: RenderOutput { image, counters, seconds }, records, snapshots: shots })
}
