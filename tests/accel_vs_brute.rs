//! Embree (through `accel::Accel`) against the O(n) brute-force twin on random triangle soups and
//! spheres: same closest primitive, same distance (1e-4 relative), same occlusion answers.
mod common;
use caustica::accel::{Accel, Brute, Tracer};
use caustica::math::{sampling::uniform_sphere, Ray, Rng};
use caustica::scene::{Geometry, Shape, TriMesh};
use glam::Vec3;

fn random_scene(seed: u64, tris: usize, spheres: usize) -> caustica::scene::Scene {
    let mut r = Rng::new(seed, 0, 0);
    let mut v = || Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 2.0 - Vec3::ONE;
    let mut shapes = Vec::new();
    for chunk in 0..4 {
        let mut m = TriMesh::default();
        for i in 0..tris / 4 {
            let c = v();
            let size = if i % 7 == 0 { 0.5 } else { 0.1 };
            m.positions.extend([c, c + v() * size, c + v() * size]);
            let b = m.positions.len() as u32 - 3;
            m.indices.push([b, b + 1, b + 2]);
        }
        shapes.push(Shape {
            name: format!("soup{chunk}"),
            geometry: Geometry::Mesh(m),
            material: 0,
            emission: Vec3::ZERO,
            emission_texture: None,
        });
    }
    for i in 0..spheres {
        let c = v();
        let rad = 0.02 + 0.2 * (i as f32 / spheres as f32);
        shapes.push(Shape {
            name: format!("sphere{i}"),
            geometry: Geometry::Sphere { center: c, radius: rad, frame: None },
            material: 0,
            emission: Vec3::ZERO,
            emission_texture: None,
        });
    }
    common::shapes_scene(shapes)
}

#[test]
fn embree_matches_brute_force_on_random_soups_and_spheres() {
    let (mut rays, mut hits, mut mismatched, mut occl_mismatch) = (0usize, 0usize, 0usize, 0usize);
    let mut checked_packets = 0usize;
    for seed in 0..5u64 {
        let scene = random_scene(seed, 400, 40);
        let (fast, slow) = (Accel::new(&scene).unwrap(), Brute::new(&scene));
        let mut r = Rng::new(seed, 1, 0);
        let mut packet = Vec::new();
        let mut packets = 0usize;
        for i in 0..20_000 {
            let o = Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 3.0 - Vec3::splat(1.5);
            let mut ray = Ray::new(o, uniform_sphere(r.next_2d()) * (0.5 + r.next_f32()));
            if i % 3 == 0 {
                ray.tmax = r.next_f32() * 2.0;
            }
            rays += 1;
            let (a, b) = (fast.intersect(&ray), slow.intersect(&ray));
            match (a, b) {
                (Some(a), Some(b)) => {
                    hits += 1;
                    let same_prim = a.shape == b.shape && a.prim == b.prim;
                    let close_t = (a.t - b.t).abs() <= 1e-4 * b.t.abs().max(1e-3);
                    if !(same_prim && close_t) {
                        mismatched += 1;
                    }
                }
                (None, None) => {}
                _ => mismatched += 1,
            }
            if fast.occluded(&ray) != slow.occluded(&ray) {
                occl_mismatch += 1;
            }
            packet.push(ray);
            // Alternate 16- and 8-ray packets (Embree's two packet widths here).
            if packet.len() == if packets.is_multiple_of(2) { 16 } else { 8 } {
                packets += 1;
                let mut out = vec![None; packet.len()];
                fast.intersect_packet(&packet, &mut out);
                for (p, o) in packet.iter().zip(out) {
                    assert_eq!(o, fast.intersect(p), "packet and single-ray answers differ");
                }
                checked_packets += 1;
                packet.clear();
            }
        }
    }
    assert!(rays >= 100_000);
    assert!(checked_packets > 8_000, "only {checked_packets} packets compared");
    assert!(hits > rays / 10, "too few hits ({hits}) for a meaningful test");
    // Rays grazing a shared edge within float precision may legitimately pick either side; allow 1e-4.
    assert!(mismatched as f64 <= 1e-4 * rays as f64, "{mismatched} of {rays} closest hits differ");
    assert!(occl_mismatch as f64 <= 1e-4 * rays as f64, "{occl_mismatch} of {rays} occlusion answers differ");
    eprintln!("{rays} rays, {hits} hits, {mismatched} closest-hit and {occl_mismatch} occlusion differences");
}

#[test]
fn rays_from_inside_a_sphere_hit_its_far_side_exactly() {
    let scene = common::shapes_scene(vec![Shape {
        name: "s".into(),
        geometry: Geometry::Sphere { center: Vec3::new(0.3, -0.2, 0.1), radius: 0.7, frame: None },
        material: 0,
        emission: Vec3::ZERO,
        emission_texture: None,
    }]);
    let a = Accel::new(&scene).unwrap();
    let mut r = Rng::new(3, 0, 0);
    for _ in 0..10_000 {
        let d = uniform_sphere(r.next_2d());
        let h = a.intersect(&Ray::new(Vec3::new(0.3, -0.2, 0.1), d)).expect("must hit from inside");
        assert!((h.t - 0.7).abs() < 1e-5, "t = {}", h.t);
    }
}
