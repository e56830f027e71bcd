//! What each subcommand does: load, build, render, write, report.
use crate::accel::{Accel, Tracer};
use crate::cli::{BenchCommand, Cli, Command, InfoArgs, RenderArgs};
use crate::film::Image;
use crate::integrator::path::PathTracer;
use crate::integrator::photon_map::{build_maps, splat_photons, MapRequest, PhotonMapper, PhotonMaps};
use crate::integrator::Counters;
use crate::math::Ray;
use crate::output::{self, with_suffix};
use crate::photon::trace::{CAUSTIC, DIRECT, INDIRECT};
use crate::plan::{Plan, Probe};
use crate::render::{render, RenderOutput};
use crate::scene::file::Mode;
use crate::scene::{load_scene_with, Geometry, Scene};
use anyhow::{bail, Context, Result};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::Info(a) => cmd_info(a),
        Command::Bench(BenchCommand::Rays { scene, rounds }) => crate::bench::rays(&scene, rounds),
        Command::Bench(BenchCommand::Photons { scene, photons }) => crate::bench::photons(&scene, photons),
        Command::Bench(BenchCommand::Plan { scene }) => crate::bench::plan(&scene),
        Command::KnnCheck(a) => crate::bench::knn_check(&a),
        Command::Compare { a, b, reference, out, exposure } => {
            crate::tools::compare_cmd(&a, &b, reference.as_deref(), &out, exposure)
        }
        Command::Reference { scene, spp, photons, set, quiet } => {
            let r = crate::tools::reference(&scene, &set, spp, photons, Path::new("out/ref"), quiet)?;
            println!(
                "reference {} (two halves differ by RMSE {:.6}; the mean's own RMSE is about half)",
                r.path.display(),
                r.halves_rmse
            );
            Ok(())
        }
        Command::Bench(BenchCommand::TimeVsError { scene, budget_s, ref_spp, ref_photons, out, set, quiet }) => {
            let out = out.unwrap_or_else(|| PathBuf::from("out/tve").join(scene.file_stem().unwrap_or_default()));
            let ref_spp = if ref_photons.is_none() { Some(ref_spp.unwrap_or(1024)) } else { ref_spp };
            crate::timeerror::run(&crate::timeerror::Options {
                scene: &scene,
                budget_s,
                ref_spp,
                ref_photons,
                out: &out,
                quiet,
                sets: &set,
            })
        }
    }
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

fn overrides(a: &RenderArgs) -> Vec<String> {
    let mut v = a.set.clone();
    if let Some(s) = a.spp {
        v.push(format!("render.spp={s}"));
    }
    if let Some(s) = a.seed {
        v.push(format!("render.seed={s}"));
    }
    if let Some(m) = &a.mode {
        v.push(format!("render.mode=\"{m}\""));
    }
    v
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    if let Some(n) = a.threads {
        if n == 0 {
            bail!("--threads must be ≥ 1");
        }
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot set up the thread pool")?;
    }
    let mut scene = load_scene_with(&a.scene, &overrides(&a))?;
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("out").join(a.scene.file_stem().unwrap_or_default()));
    let t0 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t0.elapsed().as_secs_f64();
    // Lights that reach nothing in view are left out of next-event estimation (unbiased: MIS follows).
    let plan = plan_for(&scene, &accel);
    scene.lights.restrict_nee(|i| plan.nee_lights[i]);
    if !a.quiet {
        eprintln!(
            "{}: {} shapes, {} triangles, loaded in {:.2} s, BVH in {:.2} s",
            a.scene.display(),
            scene.shapes.len(),
            scene.triangle_count(),
            scene.load_seconds,
            bvh_s
        );
    }
    let base = json!({
        "scene": a.scene.display().to_string(),
        "settings": scene.render,
        "resolution": [scene.camera.width, scene.camera.height],
    });
    if a.view != "image" {
        return render_view(&scene, &accel, &plan, &a.view, &out, base, a.quiet);
    }
    let mode = scene.render.mode;
    let mut images = Vec::new();
    if mode != Mode::PhotonMap {
        let r = render_path(&scene, &accel, scene.render.spp, a.quiet);
        let mut stats = base.clone();
        stats["mode"] = json!("path");
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "render": r.seconds });
        add_counters(&mut stats, &r);
        let o = if mode == Mode::Both { with_suffix(&out, "-pt") } else { out.clone() };
        write_outputs(&o, &r.image, scene.render.exposure, &stats)?;
        println!("{}", describe(&o, &r.image));
        images.push(r.image);
    }
    if mode != Mode::Path {
        let (maps, r) = render_pm(&scene, &accel, &plan, a.quiet)?;
        let mut stats = base.clone();
        stats["mode"] = json!("photon_map");
        stats["plan"] = json!(plan);
        stats["photon_maps"] = json!(maps.stats);
        stats["times_s"] = json!({ "load": scene.load_seconds, "bvh": bvh_s, "photon_trace": maps.stats.trace_seconds(), "kdtree_build": maps.stats.build_seconds, "eye_pass": r.seconds });
        add_counters(&mut stats, &r);
        let o = if mode == Mode::Both { with_suffix(&out, "-pm") } else { out.clone() };
        write_outputs(&o, &r.image, scene.render.exposure, &stats)?;
        println!("{}", describe(&o, &r.image));
        images.push(r.image);
    }
    if images.len() == 2 {
        let side = Image::side_by_side(&[&images[0], &images[1]], 4);
        let p = with_suffix(&out, ".png");
        output::write_png(&p, &side, scene.render.exposure)?;
        println!("wrote {} (left: path tracing, right: photon mapping)", p.display());
    }
    Ok(())
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
    let req = MapRequest {
        want: plan.photons,
        targeted: scene.render.photons.caustic_targeting,
        targets: Some(plan.caustic_targets.clone()),
    };
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
fn render_view(
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
    let maps = build_maps(
        scene,
        accel,
        &MapRequest { want, targeted: ps.caustic_targeting, targets: Some(plan.caustic_targets.clone()) },
        quiet,
    )?;
    let img = match kind {
        "photons" => splat_photons(scene, accel, &maps, &which),
        "map" => render_photon_map(scene, accel, &maps, plan, Some(which[0]), quiet).image,
        _ => bail!("--view {view}: expected image, photons:MAP or map:MAP"),
    };
    stats["view"] = json!(view);
    stats["photon_maps"] = json!(maps.stats);
    write_outputs(out, &img, scene.render.exposure, &stats)?;
    println!("{}", describe(out, &img));
    Ok(())
}

/// Writes OUT.exr, OUT.png and OUT.json.
pub fn write_outputs(out: &Path, img: &Image, exposure: f32, stats: &serde_json::Value) -> Result<()> {
    output::write_image_set(out, img, exposure, stats)
}

pub fn describe(out: &Path, img: &Image) -> String {
    format!(
        "wrote {} ({}×{}), {} and {}",
        with_suffix(out, ".exr").display(),
        img.width,
        img.height,
        with_suffix(out, ".png").display(),
        with_suffix(out, ".json").display()
    )
}

fn cmd_info(a: InfoArgs) -> Result<()> {
    let scene = load_scene_with(&a.scene, &a.set)?;
    let t0 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t0.elapsed().as_secs_f64();
    let plan = plan_for(&scene, &accel);
    drop(accel);
    let tris = scene.triangle_count();
    let spheres = scene.shapes.iter().filter(|s| matches!(s.geometry, Geometry::Sphere { .. })).count();
    let mesh_bytes: usize =
        scene.shapes.iter().map(|s| if let Geometry::Mesh(m) = &s.geometry { m.bytes() } else { 0 }).sum();
    println!("scene       {}", a.scene.display());
    println!("camera      {}×{}", scene.camera.width, scene.camera.height);
    println!("shapes      {} ({} triangles, {} analytic spheres)", scene.shapes.len(), tris, spheres);
    for s in &scene.shapes {
        let kind = match &s.geometry {
            Geometry::Mesh(m) => format!("mesh, {} triangles", m.indices.len()),
            Geometry::Sphere { radius, .. } => format!("sphere r={radius}"),
        };
        println!(
            "  {:<12} {:<28} material {:<10} area {:.4}{}",
            s.name,
            kind,
            scene.material_names[s.material as usize],
            s.area(),
            if s.emission != glam::Vec3::ZERO { " (emissive)" } else { "" }
        );
    }
    let n_points =
        scene.lights.list.iter().filter(|l| matches!(l, crate::scene::light::LightKind::Point { .. })).count();
    println!(
        "lights      {} point, {} emissive primitives, total power {:?} W",
        n_points,
        scene.lights.list.len() - n_points,
        scene.lights.total_power().to_array()
    );
    println!("bounds      {:?} .. {:?}", scene.bounds.0.to_array(), scene.bounds.1.to_array());
    println!(
        "memory      meshes {:.1} MiB, BVH about {:.1} MiB (estimate: 64 B per triangle)",
        mesh_bytes as f64 / 1048576.0,
        tris as f64 * 64.0 / 1048576.0
    );
    println!("times       load {:.3} s, BVH build {:.3} s", scene.load_seconds, bvh_s);
    println!(
        "plan        photons: direct {}, indirect {}, caustic {}; caustic targets {:?}; extra eye samples {}",
        plan.photons[0],
        plan.photons[1],
        plan.photons[2],
        plan.caustic_targets.iter().map(|&i| scene.shapes[i as usize].name.as_str()).collect::<Vec<_>>(),
        plan.specular_spp
    );
    for r in &plan.reasons {
        println!("  - {r}");
    }
    Ok(())
}
