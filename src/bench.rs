//! `caustica bench ...` and `caustica knn-check`: throughput measured against a baseline in the same run.
use crate::accel::{embree::RawPackets, Accel, Hit, Tracer};
use crate::cli::KnnArgs;
use crate::math::Ray;
use crate::scene::load_scene;
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

pub fn rays(path: &Path, rounds: u32) -> Result<()> {
    let t0 = Instant::now();
    let scene = load_scene(path)?;
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
        hits_one = packets
            .iter()
            .flat_map(|p| p.iter())
            .filter(|r| accel.intersect(r).is_some())
            .count();
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
    println!(
        "{} camera rays, {} hits, 1 thread, best of {} rounds",
        n_rays as u64, hits_raw, rounds
    );
    println!(
        "bare rtcIntersect16 loop   {:8.2} Mrays/s  (baseline)",
        n_rays / best_raw / 1e6
    );
    println!(
        "accel packet path (16)     {:8.2} Mrays/s  ratio {:.3}",
        n_rays / best_pkt / 1e6,
        best_raw / best_pkt
    );
    println!(
        "accel single rays          {:8.2} Mrays/s  ratio {:.3}",
        n_rays / best_one / 1e6,
        best_raw / best_one
    );
    Ok(())
}

pub fn knn_check(_a: &KnnArgs) -> Result<()> {
    anyhow::bail!("knn-check needs the photon k-d tree")
}
