//! O(n) reference tracer: every triangle and sphere tested for every ray. Slow and obviously right.
use super::{sphere_root, Hit, Tracer};
use crate::math::triangle_hit as tri_hit;
use crate::math::Ray;
use crate::scene::{Geometry, Scene};
use glam::Vec3;

pub struct Brute {
    /// Each triangle, its shape and index, and whether its back is culled (`TriMesh::cull_back`).
    tris: Vec<([Vec3; 3], u32, u32, bool)>,
    spheres: Vec<(Vec3, f32, u32)>,
}

impl Brute {
    pub fn new(scene: &Scene) -> Brute {
        let mut tris = Vec::new();
        let mut spheres = Vec::new();
        for (si, s) in scene.shapes.iter().enumerate() {
            match &s.geometry {
                Geometry::Mesh(m) => {
                    for pi in 0..m.indices.len() {
                        tris.push((m.triangle(pi), si as u32, pi as u32, m.cull_back));
                    }
                }
                Geometry::Sphere { center, radius, .. } => spheres.push((*center, *radius, si as u32)),
            }
        }
        Brute { tris, spheres }
    }
}

/// Whether `r` meets the back of `tri` (its winding facing away from the ray) where backs are culled.
fn culled(r: &Ray, tri: &[Vec3; 3], cull: bool) -> bool {
    cull && (tri[1] - tri[0]).cross(tri[2] - tri[0]).dot(r.d) > 0.0
}

impl Tracer for Brute {
    fn intersect(&self, r: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut tmax = r.tmax;
        for (tri, s, p, cull) in &self.tris {
            if culled(r, tri, *cull) {
                continue;
            }
            if let Some((t, u, v)) = tri_hit(r, *tri) {
                if t > r.tmin && t < tmax {
                    tmax = t;
                    best = Some(Hit { t, u, v, shape: *s, prim: *p });
                }
            }
        }
        for (c, rad, s) in &self.spheres {
            if let Some(t) = sphere_root(r.o.to_array(), r.d.to_array(), c.to_array(), *rad, r.tmin, tmax) {
                tmax = t;
                best = Some(Hit { t, u: 0.0, v: 0.0, shape: *s, prim: 0 });
            }
        }
        best
    }

    fn occluded(&self, r: &Ray) -> bool {
        (self.tris.iter())
            .filter(|(tri, _, _, cull)| !culled(r, tri, *cull))
            .any(|(tri, _, _, _)| tri_hit(r, *tri).is_some_and(|(t, _, _)| t > r.tmin && t < r.tmax))
            || self.spheres.iter().any(|(c, rad, _)| {
                sphere_root(r.o.to_array(), r.d.to_array(), c.to_array(), *rad, r.tmin, r.tmax).is_some()
            })
    }
}
