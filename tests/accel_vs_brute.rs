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
            emit_by_shading_normal: false,
        });
    }
    for i in 0..spheres {
        let c = v();
        let rad = 0.02 + 0.2 * (i as f32 / spheres as f32);
        shapes.push(Shape {
            name: format!("sphere{i}"),
            geometry: Geometry::Sphere { center: c, radius: rad, frame: None, inward: false },
            material: 0,
            emission: Vec3::ZERO,
            emission_texture: None,
            emit_by_shading_normal: false,
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
        geometry: Geometry::Sphere { center: Vec3::new(0.3, -0.2, 0.1), radius: 0.7, frame: None, inward: false },
        material: 0,
        emission: Vec3::ZERO,
        emission_texture: None,
        emit_by_shading_normal: false,
    }]);
    let a = Accel::new(&scene).unwrap();
    let mut r = Rng::new(3, 0, 0);
    for _ in 0..10_000 {
        let d = uniform_sphere(r.next_2d());
        let h = a.intersect(&Ray::new(Vec3::new(0.3, -0.2, 0.1), d)).expect("must hit from inside");
        assert!((h.t - 0.7).abs() < 1e-5, "t = {}", h.t);
    }
}

/// Debian's Embree keeps its assertions, and one of them (`ray.valid()`) aborted the process on a ray
/// whose origin and direction both had a subnormal component: a spot light placed at y = 1e-40 over a
/// floor (found by `hostile_input`'s fuzz). Such components are zero to any geometry; rays carrying them,
/// or NaN, infinite and huge values, must get the brute-force tracer's answer (or none), never an abort.
#[test]
fn rays_with_subnormal_or_huge_components_get_answers_not_an_abort() {
    let floor = TriMesh {
        positions: vec![
            Vec3::new(-5.0, 0.0, -5.0),
            Vec3::new(5.0, 0.0, -5.0),
            Vec3::new(5.0, 0.0, 5.0),
            Vec3::new(-5.0, 0.0, 5.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..TriMesh::default()
    };
    let shape = |name: &str, geometry| Shape {
        name: name.into(),
        geometry,
        material: 0,
        emission: Vec3::ZERO,
        emission_texture: None,
        emit_by_shading_normal: false,
    };
    let scene = common::shapes_scene(vec![
        shape("floor", Geometry::Mesh(floor)),
        shape("ball", Geometry::Sphere { center: Vec3::new(0.0, 0.7, 0.0), radius: 0.3, frame: None, inward: false }),
    ]);
    let (fast, slow) = (Accel::new(&scene).unwrap(), Brute::new(&scene));
    let tiny = [1e-40f32, -2.8e-41, f32::MIN_POSITIVE / 2.0, -1e-45];
    // Rays lying in the floor's plane, or leaving it, to within a subnormal (the fuzz's ray first):
    // whether they meet it is beyond float precision, so any answer will do, as long as there is one.
    let mut grazing = Vec::new();
    // Rays with subnormal components that cross the floor or the ball plainly: the brute force's answer.
    let mut plain = Vec::new();
    for (i, &a) in tiny.iter().enumerate() {
        let b = tiny[(i + 1) % tiny.len()];
        grazing.push(Ray::new(Vec3::new(0.0, a, -0.4), Vec3::new(0.4488477, b, 0.89360833)));
        grazing.push(Ray::new(Vec3::new(a, b, a), Vec3::new(a, b, 1.0)));
        grazing.push(Ray::new(Vec3::new(0.0, a, -0.4), Vec3::new(b, 1.0, 0.0)));
        plain.push(Ray::new(Vec3::new(a, 1.0, b), Vec3::new(b, -1.0, a)));
        plain.push(Ray::new(Vec3::new(0.0, 0.7, -2.0), Vec3::new(a, b, 1.0)));
        let mut r = Ray::new(Vec3::new(0.1, 2.0, 0.1), Vec3::new(b, -1.0, a));
        r.tmin = a.abs();
        plain.push(r);
    }
    for ray in &plain {
        let (a, b) = (fast.intersect(ray), slow.intersect(ray));
        assert_eq!(a.map(|h| (h.shape, h.prim)), b.map(|h| (h.shape, h.prim)), "{ray:?}");
        if let (Some(a), Some(b)) = (a, b) {
            assert!((a.t - b.t).abs() <= 1e-5 * b.t.max(1.0), "{ray:?}: t {} against {}", a.t, b.t);
        }
        assert_eq!(fast.occluded(ray), slow.occluded(ray), "{ray:?}");
    }
    for ray in &grazing {
        assert!(fast.intersect(ray).is_none_or(|h| h.shape == 0), "{ray:?}");
        fast.occluded(ray);
    }
    // NaN, infinite and huge values: no hit.
    let mut bad = Vec::new();
    for v in [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -3e18] {
        bad.push(Ray::new(Vec3::new(v, 1.0, 0.0), Vec3::new(0.0, -1.0, 0.0)));
        bad.push(Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, v, 0.0)));
    }
    for ray in &bad {
        assert_eq!(fast.intersect(ray), None, "{ray:?}");
        assert!(!fast.occluded(ray), "{ray:?}");
    }
    let rays: Vec<Ray> = [plain, grazing, bad].concat();
    for chunk in rays.chunks(16).chain(rays.chunks(8)) {
        let mut out = vec![None; chunk.len()];
        fast.intersect_packet(chunk, &mut out);
        for (p, o) in chunk.iter().zip(out) {
            assert_eq!(o, fast.intersect(p), "packet and single-ray answers differ for {p:?}");
        }
    }
}
