//! What each subcommand does: load, build, render, write, report.
use crate::accel::{Accel, Tracer};
use crate::cli::{BenchCommand, Cli, Command, InfoArgs, RenderArgs};
use crate::film::Image;
use crate::integrator::path::PathTracer;
use crate::integrator::Counters;
use crate::output;
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
        Command::KnnCheck(a) => crate::bench::knn_check(&a),
    }
}

/// Renders with the path tracer.
pub fn render_path(scene: &Scene, tracer: &dyn Tracer, spp: u32, quiet: bool) -> RenderOutput {
    let r = &scene.render;
    let pt = PathTracer {
        scene,
        tracer,
        max_depth: r.max_depth,
        rr_depth: r.rr_depth,
    };
    let cam = &scene.camera;
    render(
        cam.width,
        cam.height,
        spp,
        r.seed,
        "path",
        quiet,
        |x, y, rng, c: &mut Counters| pt.li(cam.ray(x, y), rng, c),
    )
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
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot set up the thread pool")?;
    }
    let scene = load_scene_with(&a.scene, &overrides(&a))?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(a.scene.file_stem().unwrap_or_default()));
    let t0 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t0.elapsed().as_secs_f64();
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
    let mode = scene.render.mode;
    if a.view != "image" || mode != Mode::Path {
        return crate::integrator_app::render_photon_modes(&scene, &accel, &a, &out, bvh_s);
    }
    let r = render_path(&scene, &accel, scene.render.spp, a.quiet);
    let stats = json!({
        "scene": a.scene.display().to_string(),
        "mode": "path",
        "settings": scene.render,
        "resolution": [scene.camera.width, scene.camera.height],
        "times_s": { "load": scene.load_seconds, "bvh": bvh_s, "render": r.seconds },
        "rays": r.counters.rays,
        "rays_per_s": r.counters.rays as f64 / r.seconds.max(1e-9),
        "nonfinite_samples": r.counters.nonfinite,
        "peak_rss_bytes": output::peak_rss_bytes(),
    });
    write_outputs(&out, &r.image, scene.render.exposure, &stats)?;
    println!("{}", describe(&out, &r.image));
    Ok(())
}

/// Writes OUT.exr, OUT.png and OUT.json.
pub fn write_outputs(
    out: &Path,
    img: &Image,
    exposure: f32,
    stats: &serde_json::Value,
) -> Result<()> {
    output::write_exr(&out.with_extension("exr"), img)?;
    output::write_png(&out.with_extension("png"), img, exposure)?;
    output::write_json(&out.with_extension("json"), stats)?;
    Ok(())
}

pub fn describe(out: &Path, img: &Image) -> String {
    format!(
        "wrote {} ({}×{}), {} and {}",
        out.with_extension("exr").display(),
        img.width,
        img.height,
        out.with_extension("png").display(),
        out.with_extension("json").display()
    )
}

fn cmd_info(a: InfoArgs) -> Result<()> {
    let scene = load_scene_with(&a.scene, &a.set)?;
    let t0 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t0.elapsed().as_secs_f64();
    drop(accel);
    let tris = scene.triangle_count();
    let spheres = scene
        .shapes
        .iter()
        .filter(|s| matches!(s.geometry, Geometry::Sphere { .. }))
        .count();
    let mesh_bytes: usize = scene
        .shapes
        .iter()
        .map(|s| {
            if let Geometry::Mesh(m) = &s.geometry {
                m.bytes()
            } else {
                0
            }
        })
        .sum();
    println!("scene       {}", a.scene.display());
    println!("camera      {}×{}", scene.camera.width, scene.camera.height);
    println!(
        "shapes      {} ({} triangles, {} analytic spheres)",
        scene.shapes.len(),
        tris,
        spheres
    );
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
            if s.emission != glam::Vec3::ZERO {
                " (emissive)"
            } else {
                ""
            }
        );
    }
    let n_points = scene
        .lights
        .list
        .iter()
        .filter(|l| matches!(l, crate::scene::light::LightKind::Point { .. }))
        .count();
    println!(
        "lights      {} point, {} emissive primitives, total power {:?} W",
        n_points,
        scene.lights.list.len() - n_points,
        scene.lights.total_power().to_array()
    );
    println!(
        "bounds      {:?} .. {:?}",
        scene.bounds.0.to_array(),
        scene.bounds.1.to_array()
    );
    println!(
        "memory      meshes {:.1} MiB, BVH about {:.1} MiB (estimate: 64 B per triangle)",
        mesh_bytes as f64 / 1048576.0,
        tris as f64 * 64.0 / 1048576.0
    );
    println!(
        "times       load {:.3} s, BVH build {:.3} s",
        scene.load_seconds, bvh_s
    );
    Ok(())
}
