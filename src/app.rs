//! What each subcommand does: load, build, render, write, report.
use crate::accel::Accel;
use crate::cli::{BenchCommand, Cli, Command, InfoArgs, RenderArgs};
use crate::scene::{load_scene_with, Geometry};
use anyhow::{bail, Context, Result};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::Info(a) => cmd_info(a),
        Command::Convert { scene, out } => cmd_convert(&scene, &out),
        Command::Bench(BenchCommand::Rays { scene, set, rounds }) => crate::bench::rays(&scene, rounds, &set),
        Command::Bench(BenchCommand::Photons { scene, photons, set }) => crate::bench::photons(&scene, photons, &set),
        Command::Bench(BenchCommand::Plan { scene, set }) => crate::bench::plan(&scene, &set),
        Command::Bench(BenchCommand::Chart { csv, out, title }) => {
            let out = out.unwrap_or_else(|| csv.with_extension(""));
            let title =
                title.unwrap_or_else(|| csv.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default());
            crate::timeerror::redraw(&csv, &out, &title)
        }
        Command::KnnCheck(a) => crate::bench::knn_check(&a),
        Command::Merge { parts, out } => cmd_merge(&parts, &out),
        Command::Compare { a, b, reference, out, exposure } => {
            let stem = |p: &Path| p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
            let name = format!("compare-{}-vs-{}", stem(&a), stem(&b));
            let out = crate::output::in_folder(out.unwrap_or_else(|| PathBuf::from("out/")), &name);
            crate::tools::compare_cmd(&a, &b, reference.as_deref(), &out, exposure)
        }
        Command::Reference { scene, spp, photons, passes, against_spp, dir, set, quiet } => {
            let kind = crate::pipeline::RefKind::from_options(spp, photons, passes)?;
            let r = crate::pipeline::reference(&scene, &set, kind, &dir, quiet)?;
            let how = match r.rendered_s {
                Some(s) => format!("rendered in {s:.1} s"),
                None => "from the cache; delete it to render again".to_string(),
            };
            println!(
                "reference {} ({how}; two halves differ by RMSE {:.6}; the mean's own RMSE is about half)",
                r.path.display(),
                r.halves_rmse
            );
            let Some(n) = against_spp else { return Ok(()) };
            let pt = crate::pipeline::reference(&scene, &set, crate::pipeline::RefKind::Spp(n), &dir, quiet)?;
            let a = crate::timeerror::reference_agreement(&scene, &set, [&r, &pt])?;
            println!(
                "against a {n}-spp path-traced reference (clamped to [0, 1], lights masked, as time-vs-error scores):"
            );
            for (i, s) in a.scales.iter().enumerate() {
                println!(
                    "  {:<12} RMSE between the two {:.5}; their noise alone {:.5}; beyond the noise {:.5} (noise alone makes up to {:.5} plausible{})",
                    s.name,
                    s.rmse,
                    s.noise,
                    s.excess,
                    s.allowed,
                    if i == 0 { "" } else { " if it were the same everywhere; for information" }
                );
            }
            let t = &a.local;
            println!(
                "  {:<12} difference² over the local noise variance (3×3 blocks around each), mean {:.3}; noise alone gives {:.3}, up to {:.3} plausible over {} blocks",
                format!("{0}×{0} blocks", crate::timeerror::BLOCK),
                t.chi2,
                t.expected,
                t.allowed,
                t.blocks
            );
            let [r, g, b] = a.mean_ratio;
            println!("  means, this / path traced (R, G, B): {r:.4}, {g:.4}, {b:.4}");
            if a.agrees() {
                println!("agree within their noise");
                Ok(())
            } else {
                anyhow::bail!("{}: the references differ beyond their noise", scene.display())
            }
        }
        Command::Bench(BenchCommand::TimeVsError {
            scene,
            budget_s,
            methods,
            ref_spp,
            ref_photons,
            ref_passes,
            out,
            set,
            sweep_set,
            ref_set,
            quiet,
        }) => {
            let stem = scene.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
            let out = crate::output::in_folder(out.unwrap_or_else(|| PathBuf::from("out/tve/")), &stem);
            let ref_spp =
                if ref_photons.is_none() && ref_passes.is_none() { Some(ref_spp.unwrap_or(1024)) } else { ref_spp };
            let reference = crate::pipeline::RefKind::from_options(ref_spp, ref_photons, ref_passes)?;
            crate::timeerror::run(&crate::timeerror::Options {
                scene: &scene,
                budget_s,
                methods: &methods,
                reference,
                out: &out,
                quiet,
                sets: &set,
                sweep_sets: &sweep_set,
                ref_sets: &ref_set,
            })
        }
    }
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
    if let Some(n) = a.passes {
        v.push(format!("render.progressive.passes={n}"));
    }
    if let Some(t) = a.time_s {
        v.push(format!("render.progressive.time_s={t:?}"));
    }
    v
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    let started = Instant::now();
    if let Some(n) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build_global()
            .context("cannot set up the thread pool")?;
    }
    let mut scene = load_scene_with(&a.scene, &overrides(&a))?;
    let stem = a.scene.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    let out = crate::output::in_folder(a.out.clone().unwrap_or_else(|| PathBuf::from("out/")), &stem);
    let t0 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t0.elapsed().as_secs_f64();
    // Lights that reach nothing in view are left out of next-event estimation (unbiased: MIS follows).
    let plan = crate::pipeline::plan_for(&scene, &accel);
    scene.lights.restrict_nee(|i| plan.nee_lights[i]);
    if scene.render.mode.uses_photon_maps() {
        for w in &plan.left_out {
            eprintln!("warning: {}: {w}", a.scene.display());
        }
    }
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
        if a.part.is_some() {
            bail!("--part renders a share of the image; it does not combine with --view {}", a.view);
        }
        return crate::pipeline::render_view(&scene, &accel, &plan, &a.view, &out, base, a.quiet);
    }
    let Some((i, n)) = a.part else {
        return crate::pipeline::render_modes(&scene, &accel, &plan, &out, base, bvh_s, a.quiet);
    };
    let layers = crate::pipeline::render_layers(&scene, &accel, &plan, &base, bvh_s, a.part, a.quiet)?;
    let header = crate::parts::PartHeader {
        format: "caustica-part".into(),
        version: 1,
        scene: a.scene.display().to_string(),
        scene_hash: scene.content_hash(),
        settings: serde_json::to_value(&scene.render)?,
        mode: layers.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join("+"),
        seed: scene.render.seed,
        part: i,
        parts: n,
        width: scene.camera.width,
        height: scene.camera.height,
        host: crate::parts::host_name(),
        seconds: started.elapsed().as_secs_f64(),
        layers: layers
            .iter()
            .map(|l| crate::parts::LayerHeader {
                name: l.name.clone(),
                split: l.split.clone(),
                expected_weight: l.expected_weight,
                stats: l.stats.clone(),
            })
            .collect(),
    };
    let sums: Vec<&crate::film::Sums> = layers.iter().map(|l| &l.sums).collect();
    let path = crate::parts::write_partial(&out, &header, &sums)?;
    println!(
        "wrote {} (part {i} of {n}, {:.2} s); merge all {n} with: caustica merge {} -o {}",
        path.display(),
        header.seconds,
        crate::parts::part_path(&out, 0, n).display().to_string().replace("-part-0-of-", "-part-*-of-"),
        out.display()
    );
    Ok(())
}

fn cmd_merge(parts: &[PathBuf], out: &Path) -> Result<()> {
    let merged = crate::parts::merge(parts)?;
    let name = parts[0].file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    let out = crate::output::in_folder(out.to_path_buf(), name.split("-part-").next().unwrap_or("merged"));
    crate::pipeline::write_layers(&out, &merged.images, merged.exposure)
}

fn cmd_convert(scene: &Path, out: &Path) -> Result<()> {
    use crate::scene::{load, mitsuba};
    if !load::is_mitsuba(scene) {
        bail!("{}: convert reads Mitsuba XML scenes (.xml); caustica's own TOML needs no converting", scene.display());
    }
    if load::is_mitsuba(out) || out.extension().is_none_or(|e| e != "toml") {
        bail!("{}: the output must be a .toml file", out.display());
    }
    let mut conv = mitsuba::convert(scene)?;
    for w in &conv.warnings {
        eprintln!("warning: {w}");
    }
    let from = scene.parent().unwrap_or(Path::new(""));
    let to = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(to).with_context(|| format!("cannot create {}", to.display()))?;
    mitsuba::rebase(&mut conv.file, from, to).map_err(anyhow::Error::msg)?;
    let shown = out.display().to_string();
    let text = format!(
        "# Converted from {} by `caustica convert` (Mitsuba's one-sided BSDFs are `two_sided = false`).\n{}",
        scene.display(),
        load::scene_file_toml(&conv.file, &shown)?
    );
    load::load_scene_str(&text, &shown, to, &[]).context("the converted scene does not load; nothing was written")?;
    crate::output::atomic_write(out, |tmp| {
        std::fs::write(tmp, &text).with_context(|| format!("cannot write {}", tmp.display()))
    })?;
    println!(
        "wrote {} ({} shapes, {} materials, {} lights)",
        out.display(),
        conv.file.shapes.len(),
        conv.file.materials.len(),
        conv.file.lights.len()
    );
    Ok(())
}

/// A medium of extinction `sigma` that scatters `sc` of it, for `caustica info`: a medium that
/// scatters by its σ_t, albedo and phase; one that only absorbs by its σ.
fn medium_text(sigma: glam::Vec3, sc: &crate::scene::Scattering) -> String {
    use crate::scene::medium::Lobe;
    let lobe = |l: Lobe| match l {
        Lobe::Hg(g) => format!("g {g}"),
        Lobe::Rayleigh => "Rayleigh".to_string(),
        Lobe::Table(t) => format!("a table of {} values", t.values().len()),
    };
    let p = sc.phase;
    let phase = match p.weight {
        0.0 => lobe(p.first),
        w => format!("{} × {} + {w} × {}", 1.0 - w, lobe(p.first), lobe(p.second)),
    };
    match sc.scatters() {
        true => format!(
            "σ_t {:?} per unit, albedo {:?}, phase {phase}",
            sigma.to_array(),
            (sc.sigma_s / sigma).to_array().map(|a| if a.is_finite() { a } else { 0.0 }),
        ),
        false => format!("σ {:?} per unit", sigma.to_array()),
    }
}

fn cmd_info(a: InfoArgs) -> Result<()> {
    let scene = load_scene_with(&a.scene, &a.set)?;
    let t0 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t0.elapsed().as_secs_f64();
    let plan = crate::pipeline::plan_for(&scene, &accel);
    let aim = crate::integrator::photon_map::aim_targets(&scene, &accel, &plan);
    drop(accel);
    let tris = scene.triangle_count();
    let spheres = scene.shapes.iter().filter(|s| matches!(s.geometry, Geometry::Sphere { .. })).count();
    let mesh_bytes: usize =
        scene.shapes.iter().map(|s| if let Geometry::Mesh(m) = &s.geometry { m.bytes() } else { 0 }).sum();
    println!("scene       {}", a.scene.display());
    let window = match scene.camera.window {
        Some((at, film)) => format!(", the window at ({}, {}) of a {}×{} film", at[0], at[1], film[0], film[1]),
        None => String::new(),
    };
    let medium = scene.camera.medium;
    let medium = match medium.sigma_t != glam::Vec3::ZERO {
        true => format!(", in a medium ({})", medium_text(medium.sigma_t, &medium.scattering)),
        false => String::new(),
    };
    println!("camera      {}×{}{window}{medium}", scene.camera.width, scene.camera.height);
    println!("shapes      {} ({} triangles, {} analytic spheres)", scene.shapes.len(), tris, spheres);
    for (i, s) in scene.shapes.iter().enumerate() {
        let kind = match &s.geometry {
            Geometry::Mesh(m) => {
                let colours = match (m.colors.is_some(), m.face_colors.is_some()) {
                    (true, true) => ", vertex and face colours",
                    (true, false) => ", vertex colours",
                    (false, true) => ", face colours",
                    (false, false) => "",
                };
                // Triangles the load turned on their own to face their vertex normals (`face_vertex_normals`).
                let alone = m.turned_alone.iter().filter(|t| **t).count();
                let turned = if alone > 0 { format!(", {alone} turned to their normals") } else { String::new() };
                format!("mesh, {} triangles{colours}{turned}", m.indices.len())
            }
            Geometry::Sphere { radius, inward: false, .. } => format!("sphere r={radius}"),
            Geometry::Sphere { radius, inward: true, .. } => format!("sphere r={radius}, normals inward"),
        };
        let m = &scene.materials[s.material as usize];
        let sides: Vec<String> =
            [("inside", m.absorption, m.scattering), ("outside", m.absorption_outside, m.scattering_outside)]
                .iter()
                .filter(|(_, sigma, _)| *sigma != glam::Vec3::ZERO)
                .map(|(side, sigma, sc)| format!("{side}: {}", medium_text(*sigma, sc)))
                .collect();
        // A shape that bounds no medium but lies in one (`scene::immersed`).
        let round = scene.absorption.get(i).map_or(glam::Vec3::ZERO, |s| s[0]);
        let scatters = m.scattering.scatters() || m.scattering_outside.scatters();
        let absorbs = if scatters {
            format!(" (a medium that scatters; {})", sides.join("; "))
        } else if !sides.is_empty() {
            format!(" (absorbs {})", sides.join(", "))
        } else if round != glam::Vec3::ZERO {
            format!(" (lies in a medium: σ {:?} per unit round it)", round.to_array())
        } else {
            String::new()
        };
        println!(
            "  {:<12} {:<36} material {:<10} area {:.4}{}{}",
            s.name,
            kind,
            scene.material_names[s.material as usize],
            s.area(),
            if s.emission != glam::Vec3::ZERO { " (emissive)" } else { "" },
            absorbs
        );
    }
    use crate::scene::light::LightKind;
    let n_points = scene.lights.list.iter().filter(|l| matches!(l, LightKind::Point { .. })).count();
    let n_spots = scene.lights.list.iter().filter(|l| matches!(l, LightKind::Point { spot: Some(_), .. })).count();
    let n_projectors = scene
        .lights
        .list
        .iter()
        .filter(|l| matches!(l, LightKind::Point { spot: Some(s), .. } if s.frustum.is_some()))
        .count();
    let env = match &scene.lights.env {
        Some((e, i)) => {
            let kind = match &e.image {
                Some(i) => format!("an environment map {}×{}", i.width, i.height),
                None => format!("a constant environment {:?}", e.scale.to_array()),
            };
            format!(", {kind} (power through the scene's sphere {:?} W)", scene.lights.power[*i].to_array())
        }
        None => String::new(),
    };
    let n_env = usize::from(scene.lights.env.is_some());
    let n_distant = scene.lights.list.iter().filter(|l| matches!(l, LightKind::Distant { .. })).count();
    println!(
        "lights      {} point, {} spot, {n_projectors} projector, {n_distant} distant, {} emissive primitives{env}, total power {:?} W",
        n_points - n_spots,
        n_spots - n_projectors,
        scene.lights.list.len() - n_points - n_env - n_distant,
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
    for w in &plan.left_out {
        println!("  ! {w}");
    }
    if let Some(t) = aim.filter(|t| !t.is_empty()) {
        let parts: Vec<String> = (t.shares().iter().enumerate())
            .map(|(i, &(shape, share))| {
                let name = &scene.shapes[shape as usize].name;
                match &t.yields {
                    Some(y) => format!("{name} {:.1}% (pilot yield {:.4})", 100.0 * share, y[i]),
                    None => format!("{name} {:.1}%", 100.0 * share),
                }
            })
            .collect();
        println!("aim         caustic shots by target: {}", parts.join(", "));
        println!(
            "            (by where the lights reach{}; a tenth by area)",
            if t.yields.is_some() { " and by the share of each target's photons a caustic pass stores" } else { "" }
        );
    }
    Ok(())
}
