//! Glass resting flat on another surface, or an area light set into a ceiling: faces of a dielectric
//! or an emitting mesh that lie in the plane of another shape's faces and overlap them. Where two
//! surfaces coincide, which one a ray meets first is decided by rounding, so whether light leaves the
//! glass (or the light is seen) there differs between a camera ray and a photon: the path tracer and
//! the photon mappers then disagree (the glass foot of the bundled snifter read 0.8 of the path tracer
//! in SPPM, VCM and PM before the scene lifted it by 0.5 mm), and so do other renderers. The loader
//! warns, naming both shapes; a gap (or a modelled contact) makes the scene well posed. Coplanar means
//! within 1e-5 of the scene's size, a proxy for what the ray offsets can resolve.
use crate::scene::material::Material;
use crate::scene::{Geometry, Scene, TriMesh};
use glam::{Vec2, Vec3};

/// Pairs of triangles compared at most per pair of shapes (after the bounding-box cull); beyond it the
/// pair is not checked (two huge meshes pressed together).
const MAX_PAIR_TESTS: u64 = 20_000_000;

/// One message per pair of shapes in flat contact, the glass (dielectric or thin dielectric) or the
/// light first. An area light lying in a ceiling's plane is as ill-posed as glass on a table: the
/// ceiling hides it from some rays and not from others.
pub fn coplanar_contacts(scene: &Scene) -> Vec<String> {
    let (lo, hi) = scene.bounds;
    let extent = (hi - lo).max_element();
    if !(extent.is_finite() && extent > 0.0) {
        return Vec::new();
    }
    // Far below any gap a scene means (0.5 mm on a 6 m table is 8e-5 of it), far above rounding.
    let eps = extent * 1e-5;
    // What a shape is checked as: glass (dielectric or thin dielectric), an area light, or neither.
    let glass = |m: &crate::scene::SurfaceMaterial| {
        matches!(m.bsdf, Material::Dielectric { .. } | Material::ThinDielectric { .. })
    };
    let kind = |s: &crate::scene::Shape| {
        if scene.any_leaf(s.material, &mut |m| glass(m)) {
            Some("glass")
        } else if s.emission.max_element() > 0.0 {
            Some("light")
        } else {
            None
        }
    };
    let boxes: Vec<(Vec3, Vec3)> = scene.shapes.iter().map(|s| s.geometry.bounds()).collect();
    let mut out = Vec::new();
    for (i, a) in scene.shapes.iter().enumerate() {
        let (Some(what), Geometry::Mesh(ma)) = (kind(a), &a.geometry) else { continue };
        for (j, b) in scene.shapes.iter().enumerate() {
            let Geometry::Mesh(mb) = &b.geometry else { continue };
            // A shape with itself never; a pair of lights or of glasses once.
            if i == j || (j < i && kind(b).is_some()) {
                continue;
            }
            if let Some(n) = touching_faces((ma, boxes[i]), (mb, boxes[j]), eps) {
                out.push(format!(
                    "{} ({what}) lies flat on {} ({n} face{} in the same plane): which surface a ray meets \
                     there is decided by rounding, so the path tracer and the photon mappers see different \
                     light there; leave a gap (e.g. move the {what} by {:.2e}) or model the shared face once",
                    a.name,
                    b.name,
                    if n == 1 { "" } else { "s" },
                    extent * 1e-4
                ));
            }
        }
    }
    out
}

struct Tri {
    v: [Vec3; 3],
    n: Vec3,
    lo: Vec3,
    hi: Vec3,
}

fn tris(m: &TriMesh, within: (Vec3, Vec3), eps: f32) -> Vec<Tri> {
    (0..m.indices.len())
        .filter_map(|k| {
            let v = m.triangle(k);
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            let lo = v[0].min(v[1]).min(v[2]);
            let hi = v[0].max(v[1]).max(v[2]);
            let overlaps = lo.cmple(within.1 + eps).all() && hi.cmpge(within.0 - eps).all();
            (n != Vec3::ZERO && overlaps).then_some(Tri { v, n, lo, hi })
        })
        .collect()
}

/// How many of `a`'s faces lie in the plane of one of `b`'s and overlap it (None: none, or too many
/// pairs to check); each mesh comes with its bounding box.
fn touching_faces((a, abox): (&TriMesh, (Vec3, Vec3)), (b, bbox): (&TriMesh, (Vec3, Vec3)), eps: f32) -> Option<usize> {
    if abox.0.cmpgt(bbox.1 + eps).any() || bbox.0.cmpgt(abox.1 + eps).any() {
        return None;
    }
    let ta = tris(a, bbox, eps);
    let tb = tris(b, abox, eps);
    if ta.is_empty() || tb.is_empty() || ta.len() as u64 * tb.len() as u64 > MAX_PAIR_TESTS {
        return None;
    }
    let n = ta.iter().filter(|x| tb.iter().any(|y| coplanar_overlap(x, y, eps))).count();
    (n > 0).then_some(n)
}

/// Same plane (parallel normals, every corner of each within `eps` of the other's plane) and an
/// overlap of positive area (separating axes in the plane, shrunk by `eps` so that faces meeting
/// only along an edge do not count).
fn coplanar_overlap(x: &Tri, y: &Tri, eps: f32) -> bool {
    if x.lo.cmpgt(y.hi + eps).any() || y.lo.cmpgt(x.hi + eps).any() || x.n.dot(y.n).abs() < 1.0 - 1e-4 {
        return false;
    }
    let off = |t: &Tri, p: Vec3| (p - t.v[0]).dot(t.n).abs();
    if x.v.iter().any(|&p| off(y, p) > eps) || y.v.iter().any(|&p| off(x, p) > eps) {
        return false;
    }
    let f = crate::math::Frame::from_normal(x.n);
    let (s, t) = (f.s, f.t);
    let flat = |tri: &Tri| tri.v.map(|p| Vec2::new(p.dot(s), p.dot(t)));
    let (p, q) = (flat(x), flat(y));
    for poly in [&p, &q] {
        for k in 0..3 {
            let e = poly[(k + 1) % 3] - poly[k];
            let axis = Vec2::new(-e.y, e.x).normalize_or_zero();
            if axis == Vec2::ZERO {
                return false;
            }
            let span = |v: &[Vec2; 3]| {
                v.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), w| {
                    let d = w.dot(axis);
                    (lo.min(d), hi.max(d))
                })
            };
            let (p0, p1) = span(&p);
            let (q0, q1) = span(&q);
            if p1 <= q0 + eps || q1 <= p0 + eps {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use crate::scene::load::load_scene_str;
    use std::path::Path;

    fn scene(glass_y: f32, glass: &str) -> String {
        format!(
            r#"
[camera]
origin = [0.0, 1.0, 4.0]
target = [0.0, 0.3, 0.0]
fov = 40
resolution = [8, 8]
[materials]
floor = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
glass = {glass}
[[shapes]]
type = "quad"
corner = [-2.0, 0.0, -2.0]
edge_u = [0.0, 0.0, 4.0]
edge_v = [4.0, 0.0, 0.0]
material = "floor"
[[shapes]]
type = "box"
min = [-0.3, {glass_y}, -0.3]
max = [0.3, 0.6, 0.3]
material = "glass"
[[lights]]
type = "point"
position = [0.0, 2.0, 0.0]
power = [10.0, 10.0, 10.0]
"#
        )
    }

    const GLASS: &str = r#"{ type = "dielectric", ior = 1.5 }"#;

    #[test]
    fn glass_flat_on_the_floor_is_reported_lifted_it_is_not() {
        let s = load_scene_str(&scene(0.0, GLASS), "t.toml", Path::new("."), &[]).unwrap();
        let w = super::coplanar_contacts(&s);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("shapes[1]") && w[0].contains("shapes[0]") && w[0].contains("2 faces"), "{w:?}");
        for y in [0.0005, -0.0005] {
            let s = load_scene_str(&scene(y, GLASS), "t.toml", Path::new("."), &[]).unwrap();
            assert!(super::coplanar_contacts(&s).is_empty(), "glass at y = {y}");
        }
        // Opaque boxes on the floor are well posed (no ray can pass between the two faces).
        let diffuse = r#"{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }"#;
        let s = load_scene_str(&scene(0.0, diffuse), "t.toml", Path::new("."), &[]).unwrap();
        assert!(super::coplanar_contacts(&s).is_empty());
    }

    #[test]
    fn a_light_in_the_ceiling_plane_is_reported_below_it_is_not() {
        let diffuse = r#"{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }"#;
        let light = |y: f32| {
            format!(
                "[[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 2.0, -2.0]\nedge_u = [4.0, 0.0, 0.0]\n\
                 edge_v = [0.0, 0.0, 4.0]\nmaterial = \"floor\"\n[[lights]]\ntype = \"quad\"\n\
                 corner = [-0.2, {y}, -0.2]\nedge_u = [0.4, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.4]\n\
                 power = [5.0, 5.0, 5.0]\n"
            )
        };
        let s = load_scene_str(&(scene(0.1, diffuse) + &light(2.0)), "t.toml", Path::new("."), &[]).unwrap();
        let w = super::coplanar_contacts(&s);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("(light) lies flat on shapes[2]"), "{w:?}");
        let s = load_scene_str(&(scene(0.1, diffuse) + &light(1.999)), "t.toml", Path::new("."), &[]).unwrap();
        assert!(super::coplanar_contacts(&s).is_empty());
    }
}
