//! `caustica bench ...` and `caustica knn-check`: throughput measured against a baseline in the same run.
use crate::accel::{embree::RawPackets, Accel, Hit, Tracer};
use crate::cli::KnnArgs;
use crate::math::Ray;
use crate::scene::load_scene_with;
use anyhow::Result;
use std::path::Path;
use std::time::Instant;

/// Camera rays at one sample per pixel, grouped into 4×4-pixel packets of 16.
fn camera_packets(scene: &crate::scene::Scene) -> Vec<[Ray; 16]> {
    let cam = &scene.camera;
    let mut packets = Vec::new();
    for by in (0..cam.height).step_by(4) {
        for bx in (0..cam.width).step_by(4) {
            let mut p = [Ray::new(cam.origin, cam.forward); 16];
            for (i, r) in p.iter_mut().enumerate() {
                let x = (bx + (i as u32 % 4)).min(cam.width - 1);
                let y = (by + (i as u32 / 4)).min(cam.height - 1);
                *r = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            }
            packets.push(p);
        }
    }
    packets
}

pub fn rays(path: &Path, rounds: u32, sets: &[String]) -> Result<()> {
    let t0 = Instant::now();
    let scene = load_scene_with(path, sets)?;
    let load_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let bvh_s = t1.elapsed().as_secs_f64();
    let packets = camera_packets(&scene);
    let raw = RawPackets::new(&packets);
    let n_rays = packets.len() as f64 * 16.0;
    let (mut best_raw, mut best_pkt, mut best_one) = (f64::MAX, f64::MAX, f64::MAX);
    let (mut hits_raw, mut hits_pkt, mut hits_one) = (0, 0, 0);
    let mut out = [None::<Hit>; 16];
    for _ in 0..rounds.max(1) {
        let t = Instant::now();
        hits_raw = accel.raw_intersect16(&raw);
        best_raw = best_raw.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        hits_pkt = 0;
        for p in &packets {
            accel.intersect_packet(p, &mut out);
            hits_pkt += out.iter().filter(|h| h.is_some()).count();
        }
        best_pkt = best_pkt.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        hits_one = packets.iter().flat_map(|p| p.iter()).filter(|r| accel.intersect(r).is_some()).count();
        best_one = best_one.min(t.elapsed().as_secs_f64());
    }
    if hits_raw != hits_pkt || hits_raw != hits_one {
        anyhow::bail!("hit counts differ: raw {hits_raw}, packet {hits_pkt}, single {hits_one}");
    }
    println!(
        "scene {}: {} triangles; load {:.3} s, BVH build {:.3} s (total {:.3} s)",
        path.display(),
        scene.triangle_count(),
        load_s,
        bvh_s,
        load_s + bvh_s
    );
    println!("{} camera rays, {} hits, 1 thread, best of {} rounds", n_rays as u64, hits_raw, rounds);
    println!("bare rtcIntersect16 loop   {:8.2} Mrays/s  (baseline)", n_rays / best_raw / 1e6);
    println!("accel packet path (16)     {:8.2} Mrays/s  ratio {:.3}", n_rays / best_pkt / 1e6, best_raw / best_pkt);
    println!("accel single rays          {:8.2} Mrays/s  ratio {:.3}", n_rays / best_one / 1e6, best_raw / best_one);
    Ok(())
}

/// The planner's savings: photon mapping as planned vs with every pass forced on, same seed.
pub fn plan(path: &Path, user_sets: &[String]) -> Result<()> {
    let mut out = Vec::new();
    for forced in [false, true] {
        let mut sets = user_sets.to_vec();
        sets.push(format!("render.force_all_passes={forced}"));
        let scene = crate::scene::load_scene_with(path, &sets)?;
        let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
        let t = Instant::now();
        let r = crate::pipeline::render_pm_default(&scene, &accel, true)?;
        out.push((t.elapsed().as_secs_f64(), r.image));
    }
    let plan = {
        let scene = load_scene_with(path, user_sets)?;
        let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
        crate::pipeline::plan_for(&scene, &accel)
    };
    let e = crate::metrics::compare(&out[0].1, &out[1].1).ok_or_else(|| anyhow::anyhow!("image sizes differ"))?;
    println!("scene {}: plan {:?}", path.display(), plan.reasons);
    println!("planned      {:8.3} s", out[0].0);
    println!("all forced   {:8.3} s  (baseline)", out[1].0);
    println!(
        "time ratio planned/forced {:.3}; images differ by RMSE {:.2e} (mean ratio {:.5})",
        out[0].0 / out[1].0,
        e.rmse,
        e.mean_ratio
    );
    Ok(())
}

/// Wraps a tracer and keeps every ray it is asked to intersect (to replay them through bare Embree).
struct Recorder<'a> {
    inner: &'a Accel,
    rays: std::sync::Mutex<Vec<Ray>>,
    /// Shadow-ray queries (`occluded`), counted, not replayed.
    occluded: std::sync::atomic::AtomicU64,
}

impl Tracer for Recorder<'_> {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if let Ok(mut v) = self.rays.lock() {
            v.push(*ray);
        }
        self.inner.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.occluded(ray)
    }
}

/// Photon tracing throughput against a bare `rtcIntersect1` loop over the very same rays (recorded in a
/// second, identical run), both on one thread: the ratio is what the photon pipeline costs beyond Embree.
pub fn photons(path: &Path, photons: u64, sets: &[String]) -> Result<()> {
    use crate::integrator::photon_map::{build_maps, MapRequest};
    let scene = load_scene_with(path, sets)?;
    let accel = Accel::new(&scene).map_err(anyhow::Error::msg)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let req = MapRequest {
        want: [photons, photons, photons],
        targeted: scene.render.photons.caustic_targeting,
        targets: None,
        ..Default::default()
    };
    let maps = pool.install(|| build_maps(&scene, &accel, &req, true))?;
    let passes = [maps.stats.global_pass, maps.stats.caustic_pass];
    // Every ray the pipeline traced: photon path segments and the probes that aim caustic photons.
    let segments: u64 = passes.iter().flatten().map(|p| p.segments).sum::<u64>() + maps.stats.aim_rays;
    let trace_s = maps.stats.trace_seconds();
    // The glossy caustics' links to the camera are shadow rays (through see-through surfaces, closest
    // hits): counted apart, not replayed, and not credited to photon tracing's rays per second.
    let camera_rays: u64 = passes.iter().flatten().map(|p| p.camera_rays).sum();
    let rec = Recorder { inner: &accel, rays: std::sync::Mutex::new(Vec::new()), occluded: Default::default() };
    pool.install(|| build_maps(&scene, &rec, &req, true))?;
    let occluded = rec.occluded.load(std::sync::atomic::Ordering::Relaxed);
    let rays = rec.rays.into_inner().map_err(|_| anyhow::anyhow!("recorder poisoned"))?;
    // The two runs are the same deterministic work: the rays we count are the rays the baseline replays.
    if rays.len() as u64 + occluded != segments + camera_rays {
        anyhow::bail!(
            "photon tracing counted {segments} rays and {camera_rays} rays linking glossy caustics to the camera but \
             traced {} closest hits and {occluded} shadow rays (accounting bug)",
            rays.len()
        );
    }
    // Both sides count the same closest-hit rays: the photons' segments, the aiming probes and the
    // links' walks past see-through surfaces; the links' `occluded` queries are uncredited extra work.
    let prepared = Accel::prepare_single(&rays);
    let t = Instant::now();
    let hits = accel.raw_intersect1(&prepared);
    let raw_s = t.elapsed().as_secs_f64();
    let ours = rays.len() as f64 / trace_s;
    let bare = rays.len() as f64 / raw_s;
    println!(
        "scene {}: {} photons stored, {} shot, {} rays traced (segments and aiming probes) in {:.3} s (1 thread)",
        path.display(),
        maps.stats.stored.iter().sum::<u64>(),
        passes.iter().flatten().map(|p| p.shot).sum::<u64>(),
        segments,
        trace_s
    );
    println!("photon tracing                   {:8.2} M rays/s    ", ours / 1e6);
    println!(
        "bare rtcIntersect1, same rays    {:8.2} M rays/s ({} rays, {} hits)  (baseline)",
        bare / 1e6,
        rays.len(),
        hits
    );
    println!("ratio                            {:8.3}", ours / bare);
    Ok(())
}

/// Queries per block of `knn-check`'s alternating timing (ours, then kiddo's, then ours …).
#[cfg(feature = "oracle")]
const KNN_BLOCK: usize = 5_000;

/// kiddo's k nearest, capped by a squared radius when it is finite.
#[cfg(feature = "oracle")]
macro_rules! kiddo_knn {
    ($tree:expr, $q:expr, $k:expr, $r2:expr) => {
        if $r2.is_finite() {
            $tree.query($q).nearest_n::<kiddo::SquaredEuclidean<f32>>($k).within($r2).execute()
        } else {
            $tree.query($q).nearest_n::<kiddo::SquaredEuclidean<f32>>($k).execute()
        }
    };
}

/// kiddo's mutable tree on the same points, for reference: (build s, query s), or why its bulk build
/// refused the input (it does for some, with UnsplittableBucket).
#[cfg(feature = "oracle")]
fn kiddo_mutable(
    pts: &[[f32; 3]],
    qs: &[[f32; 3]],
    k: std::num::NonZeroUsize,
    r2: f32,
) -> std::result::Result<(f64, f64), String> {
    let t = Instant::now();
    let m = kiddo::MutableKdTree::<f32, 3>::new_from_slice(pts).map_err(|e| format!("{e:?}"))?;
    let build = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for q in qs {
        std::hint::black_box(kiddo_knn!(m, q, k, r2));
    }
    Ok((build, t.elapsed().as_secs_f64()))
}

/// Queries whose sorted squared distances differ between our tree and kiddo's.
#[cfg(feature = "oracle")]
fn disagreements(
    ours: &crate::photon::kdtree::KdTree<u32>,
    theirs: &kiddo::ImmutableKdTree<f32, 3>,
    qs: &[[f32; 3]],
    k: std::num::NonZeroUsize,
    r2: f32,
) -> usize {
    let mut res = crate::photon::kdtree::KnnResult::new();
    qs.iter()
        .filter(|q| {
            ours.knn(**q, k.get(), r2, &mut res);
            let mut d: Vec<f32> = kiddo_knn!(theirs, q, k, r2).iter().map(|r| r.distance).collect();
            d.sort_by(f32::total_cmp);
            d != res.sorted_d2()
        })
        .count()
}

/// Builds our tree and kiddo's on the same photons, checks that every query's sorted squared distances
/// agree, and prints the build and query speed ratios (single-threaded queries).
#[cfg(feature = "oracle")]
pub fn knn_check(a: &KnnArgs) -> Result<()> {
    use crate::photon::distributions::{points, queries, Distribution};
    use crate::photon::kdtree::{KdTree, KnnResult};
    use kiddo::ImmutableKdTree;
    use std::num::NonZeroUsize;
    let dist: Distribution = a.distribution.parse().map_err(anyhow::Error::msg)?;
    let k = NonZeroUsize::new(a.k).ok_or_else(|| anyhow::anyhow!("--k must be ≥ 1"))?;
    if a.points == 0 || a.queries == 0 {
        anyhow::bail!("--points and --queries must be ≥ 1");
    }
    // Both trees, the points and the build's scratch: refuse before allocating what cannot fit.
    const BYTES_PER_POINT: u128 = 80;
    let need = a.points as u128 * BYTES_PER_POINT;
    let limit = crate::scene::load::MAX_BYTES;
    if need > limit as u128 {
        anyhow::bail!(
            "--points {} needs about {} GiB (some {BYTES_PER_POINT} bytes per point for both trees); the limit is {} GiB",
            a.points,
            need >> 30,
            limit >> 30
        );
    }
    if let Some(r) = a.radius.filter(|r| !(r.is_finite() && *r >= 0.0)) {
        anyhow::bail!("--radius must be a finite distance ≥ 0, got {r}");
    }
    let r2 = a.radius.map_or(f32::INFINITY, |r| r * r);
    let pts = points(dist, a.points, a.seed);
    let qs = queries(dist, a.queries, a.seed);
    let t = Instant::now();
    let ours =
        KdTree::build(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect()).map_err(anyhow::Error::msg)?;
    let our_build = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let theirs: ImmutableKdTree<f32, 3> =
        ImmutableKdTree::new_from_slice_parallel(&pts).map_err(|e| anyhow::anyhow!("kiddo: {e:?}"))?;
    let their_build = t.elapsed().as_secs_f64();
    let mutable = kiddo_mutable(&pts, &qs, k, r2);
    let mut res = KnnResult::new();
    let (mut bad, mut sum_ours, mut sum_theirs) = (0usize, 0f64, 0f64);
    // The two trees answer the same queries in alternating blocks, so that a shared machine's slow
    // spells fall on both (timed one after the other, the ratio moved by ±15% between runs).
    let (mut our_q, mut their_q) = (0f64, 0f64);
    for block in qs.chunks(KNN_BLOCK) {
        let t = Instant::now();
        for q in block {
            ours.knn(*q, a.k, r2, &mut res);
            sum_ours += res.len() as f64;
        }
        our_q += t.elapsed().as_secs_f64();
        let t = Instant::now();
        for q in block {
            let found = kiddo_knn!(theirs, q, k, r2);
            sum_theirs += found.len() as f64;
        }
        their_q += t.elapsed().as_secs_f64();
    }
    bad += disagreements(&ours, &theirs, &qs[..qs.len().min(20_000)], k, r2);
    println!(
        "{} photons ({:?}), {} queries, k = {}, radius cap {}",
        a.points,
        dist,
        a.queries,
        a.k,
        a.radius.map_or("none".into(), |r| r.to_string())
    );
    println!(
        "agreement (first {} queries, sorted squared distances): {}",
        qs.len().min(20_000),
        if bad == 0 { "all equal".to_string() } else { format!("{bad} DIFFER") }
    );
    println!(
        "mean neighbours found: ours {:.1}, kiddo {:.1}",
        sum_ours / qs.len().max(1) as f64,
        sum_theirs / qs.len().max(1) as f64
    );
    println!(
        "vs kiddo ImmutableKdTree:\nbuild ({} threads): ours {:.3} s, kiddo {:.3} s, ratio ours/kiddo {:.2}",
        rayon::current_num_threads(),
        our_build,
        their_build,
        our_build / their_build
    );
    println!(
        "queries (1 thread, alternating blocks of {KNN_BLOCK}): ours {:.0}/s, kiddo {:.0}/s, speed-up {:.2}x",
        qs.len() as f64 / our_q,
        qs.len() as f64 / their_q,
        their_q / our_q
    );
    match mutable {
        Ok((mutable_build, mutable_q)) => println!(
            "vs kiddo MutableKdTree: build {:.3} s (ratio {:.2}), queries {:.0}/s, speed-up {:.2}x",
            mutable_build,
            our_build / mutable_build,
            qs.len() as f64 / mutable_q,
            mutable_q / our_q
        ),
        Err(e) => println!("vs kiddo MutableKdTree: its bulk build refused these points ({e})"),
    }
    let paths = res.paths();
    let pct = |n: u64| 100.0 * n as f64 / qs.len().max(1) as f64;
    println!(
        "our search paths: {:.1}% no guessed radius (k ≤ a bucket or ≥ the points, or the guess reached the cap), {:.1}% within the \
         guessed radius, {:.1}% widened once, {:.1}% searched again from an open bound",
        pct(paths[0]),
        pct(paths[1]),
        pct(paths[2]),
        pct(paths[3])
    );
    println!(
        "memory: {:.1} bytes per photon in our tree (positions, item, split planes, node boxes)",
        ours.bytes_per_point()
    );
    if bad > 0 {
        anyhow::bail!("{bad} queries disagree with kiddo");
    }
    Ok(())
}

#[cfg(not(feature = "oracle"))]
pub fn knn_check(_a: &KnnArgs) -> Result<()> {
    anyhow::bail!("knn-check compares against kiddo, which this binary was built without; rebuild with `cargo build --release --features oracle`")
}
