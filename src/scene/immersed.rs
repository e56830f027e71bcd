//! The medium round a shape that bounds none, and round a point light. A shape whose material absorbs on
//! a side (coloured glass, a coloured liquid: `SurfaceMaterial::absorption`, `absorption_outside`) is a
//! boundary between media; every other shape is not, and a path that scatters on it stays in the
//! medium it was in (`Scene::sigma_next`, since session 72: each path carries its medium, as Mitsuba's
//! volumetric path tracer does, changing it only where it crosses a shape with media). So a diffuse
//! ball inside coloured glass, a light in coloured water or a clear glass ball in it all lie in that
//! medium, and a floor that runs through a tank of it lies in it only where it is under the water.
//!
//! What a path cannot carry is where light starts: a light's own medium (`Scene::light_medium`). That
//! is found once at load: from points spread over the shape by area (a point light's position), rays in
//! six fixed directions meet the boundaries (and nothing else); the first one met says the medium (its
//! inside's if met from behind, its outside's if met in front; none if no boundary is met). Each point
//! takes its rays' majority, the shape its points' majority (16 points). A shape whose bounds touch no
//! boundary's bounds lies in none without a ray. An emitting shape whose points disagree lies partly in
//! a medium: its light starts in its points' majority, and the loader warns, naming it. A boundary is
//! looked at the same way, past itself: where the medium it claims on its outer side is not the one
//! round it, the medium is open (nothing encloses it), light that starts in it has no one medium, and
//! the loader warns. So it does for a near clipping plane inside a medium (`near_plane_in_medium`),
//! where camera paths start in none (Mitsuba's sensor's) but light in the medium is absorbed.
use crate::color::Rgb;
use crate::math::{offset_ray_origin, ray_meets_box, sphere_root, triangle_hit, Frame, Ray};
use crate::scene::{Geometry, Scene};
use glam::Vec3;
use rayon::prelude::*;

/// Points per shape (rays per point: six).
const POINTS: usize = 16;

/// The six directions each point's rays take: a frame's axes both ways, turned off the world's so
/// that axis-aligned walls and edges are not met edge-on.
fn directions() -> [Vec3; 6] {
    let f = Frame::from_normal(Vec3::new(0.267, 0.802, 0.535).normalize());
    [f.s, -f.s, f.t, -f.t, f.n, -f.n]
}

/// A node of `Boundaries`' hierarchy: its bounds, and its triangles `first..first + count` (a leaf) or
/// its two children (`count` 0).
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    first: u32,
    count: u32,
    left: u32,
    right: u32,
}

/// The boundaries' surfaces, for the first one a ray meets: their triangles (corners and shape) under a
/// bounding-volume hierarchy split at the median of the longest axis (a glass dragon's 871k triangles
/// take some 20 box tests a ray, where a scan of them all took seconds for a few hundred shapes), and
/// their spheres (centre, radius, normals inward, shape), scanned; and each boundary's bounds.
struct Boundaries {
    boxes: Vec<(usize, (Vec3, Vec3))>,
    tris: Vec<([Vec3; 3], u32)>,
    nodes: Vec<Node>,
    spheres: Vec<(Vec3, f32, bool, u32)>,
}

/// Triangles per leaf, at most.
const LEAF: usize = 4;

impl Boundaries {
    fn new(scene: &Scene) -> Boundaries {
        let (mut boxes, mut tris, mut spheres) = (Vec::new(), Vec::new(), Vec::new());
        for (i, _) in scene.boundary.iter().enumerate().filter(|(_, b)| **b) {
            boxes.push((i, scene.shapes[i].geometry.bounds()));
            match &scene.shapes[i].geometry {
                Geometry::Mesh(m) => tris.extend((0..m.indices.len()).map(|k| (m.triangle(k), i as u32))),
                Geometry::Sphere { center, radius, inward, .. } => spheres.push((*center, *radius, *inward, i as u32)),
            }
        }
        let mut nodes = Vec::new();
        if !tris.is_empty() {
            Self::build(&mut nodes, &mut tris, 0);
        }
        Boundaries { boxes, tris, nodes, spheres }
    }

    /// Builds the node over `tris` (which start at `first` in the whole list) and its subtree; returns
    /// its index.
    fn build(nodes: &mut Vec<Node>, tris: &mut [([Vec3; 3], u32)], first: usize) -> u32 {
        let (lo, hi) = (tris.iter().flat_map(|(c, _)| c.iter()))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let me = nodes.len();
        nodes.push(Node { lo, hi, first: first as u32, count: tris.len() as u32, left: 0, right: 0 });
        if tris.len() <= LEAF {
            return me as u32;
        }
        let centre = |t: &([Vec3; 3], u32)| t.0[0] + t.0[1] + t.0[2];
        let (clo, chi) =
            tris.iter().map(centre).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)));
        let extent = chi - clo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = tris.len() / 2;
        tris.select_nth_unstable_by(mid, |a, b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        let (l, r) = tris.split_at_mut(mid);
        let left = Self::build(nodes, l, first);
        let right = Self::build(nodes, r, first + mid);
        nodes[me] = Node { count: 0, left, right, ..nodes[me] };
        me as u32
    }

    /// The first boundary surface `ray` meets past `tmin`, not counting shape `skip`'s: its distance,
    /// shape, and whether it is met from behind (against its normal).
    fn first_hit(&self, ray: &Ray, skip: u32) -> Option<(f32, u32, bool)> {
        let mut best: Option<(f32, u32, bool)> = None;
        let mut tmax = ray.tmax;
        let mut stack: Vec<u32> = if self.nodes.is_empty() { Vec::new() } else { vec![0] };
        while let Some(k) = stack.pop() {
            let n = self.nodes[k as usize];
            if !ray_meets_box(&Ray { tmax, ..*ray }, (n.lo, n.hi)) {
                continue;
            }
            if n.count == 0 {
                stack.extend([n.left, n.right]);
                continue;
            }
            for (c, shape) in &self.tris[n.first as usize..(n.first + n.count) as usize] {
                if *shape == skip {
                    continue;
                }
                if let Some((t, ..)) = triangle_hit(ray, *c) {
                    if t > ray.tmin && t < tmax {
                        tmax = t;
                        best = Some((t, *shape, ray.d.dot((c[1] - c[0]).cross(c[2] - c[0])) > 0.0));
                    }
                }
            }
        }
        for &(centre, radius, inward, shape) in &self.spheres {
            if shape == skip {
                continue;
            }
            if let Some(t) = sphere_root(ray.o.to_array(), ray.d.to_array(), centre.to_array(), radius, ray.tmin, tmax)
            {
                tmax = t;
                let outward = ray.at(t) - centre;
                best = Some((t, shape, ray.d.dot(if inward { -outward } else { outward }) > 0.0));
            }
        }
        best
    }
}

/// The absorption σ of the medium `ray` starts in, by the first boundary other than `skip` it meets:
/// its inside's if met from behind, its outside's in front (if none, the camera's: zero unless it sits
/// in a medium, which then fills the space no boundary encloses).
fn medium_along(scene: &Scene, boundaries: &Boundaries, ray: &Ray, skip: u32) -> Rgb {
    (boundaries.first_hit(ray, skip))
        .map_or(scene.camera.medium.sigma_t, |(_, i, behind)| scene.absorption[i as usize][if behind { 0 } else { 1 }])
}

/// The medium a point lies in: the majority of what `rays` from it (one per direction of
/// `directions`) say by `medium_along`, `skip` being the shape the point lies on.
fn medium_of_rays(scene: &Scene, boundaries: &Boundaries, rays: &[Ray; 6], skip: u32) -> Rgb {
    majority(&rays.map(|ray| medium_along(scene, boundaries, &ray, skip))).0
}

/// The medium round point `p` that lies on no shape (a point light's position, a point of the near
/// clipping plane): `medium_of_rays` from `p` itself.
fn medium_at(scene: &Scene, boundaries: &Boundaries, dirs: &[Vec3; 6], p: Vec3) -> Rgb {
    medium_of_rays(scene, boundaries, &dirs.map(|d| Ray::new(p, d)), u32::MAX)
}

/// The most common of `votes` (the first among equals) and how many cast it.
fn majority(votes: &[Rgb]) -> (Rgb, usize) {
    let mut best = (Rgb::ZERO, 0);
    for v in votes {
        let n = votes.iter().filter(|w| *w == v).count();
        if n > best.1 {
            best = (*v, n);
        }
    }
    best
}

/// Per shape, the absorption σ of the medium round it when it bounds none (zero where none is, and for
/// every boundary); per point light (its position in `lamps`), the medium round it; and the warnings: an emitting shape that lies partly in a medium, and a boundary
/// whose medium on its outer side is not the one round it (a sphere with `flip_normals` whose inside
/// medium is then all the space outside it, an exterior medium that nothing encloses), where light that
/// starts out has no one medium. Empty when the scene has no boundary (`Scene::absorption` empty).
pub fn surrounding_media(scene: &Scene, lamps: &[Vec3]) -> (Vec<Rgb>, Vec<Rgb>, Vec<String>) {
    if scene.absorption.is_empty() {
        return (Vec::new(), Vec::new(), Vec::new());
    }
    let boundaries = Boundaries::new(scene);
    let dirs = directions();
    let lamp_media = lamps.iter().map(|&p| medium_at(scene, &boundaries, &dirs, p)).collect();
    let slack = Vec3::splat(scene.diagonal() * 1e-6);
    // (σ round the shape, points that disagree, points looked from), past the shape itself.
    let found: Vec<(Rgb, usize, usize)> = (0..scene.shapes.len())
        .into_par_iter()
        .map(|i| {
            let (lo, hi) = scene.shapes[i].geometry.bounds();
            let near = |&(j, (blo, bhi)): &(usize, (Vec3, Vec3))| {
                j != i && (lo - slack).cmple(bhi).all() && (hi + slack).cmpge(blo).all()
            };
            if !boundaries.boxes.iter().any(near) {
                return (scene.camera.medium.sigma_t, 0, 0);
            }
            let votes: Vec<Rgb> = spread_points(&scene.shapes[i].geometry, POINTS)
                .iter()
                .map(|&(p, n, size)| {
                    let rays = dirs.map(|d| Ray::new(offset_ray_origin(p, n, d, size), d));
                    medium_of_rays(scene, &boundaries, &rays, i as u32)
                })
                .collect();
            let (sigma, agree) = majority(&votes);
            (sigma, votes.len() - agree, votes.len())
        })
        .collect();
    let mut warnings = Vec::new();
    let mut round = Vec::with_capacity(found.len());
    for (i, (sigma, disagree, looked)) in found.into_iter().enumerate() {
        let name = &scene.shapes[i].name;
        let sides = scene.absorption[i];
        if sides == [Rgb::ZERO; 2] {
            // Paths carry their medium past it (`Scene::sigma_next`); only the light an emitting shape
            // sends out starts in the one medium round it.
            if disagree > 0 && scene.shapes[i].emission != Rgb::ZERO {
                warnings.push(format!(
                    "{name} emits and lies partly inside a medium that absorbs (of {looked} points spread over \
                     it, {disagree} {} in another medium than the rest): the light it sends out starts in the \
                     medium round most of it, here σ {:?}, in the photon and bidirectional modes, where a path \
                     that reaches it carries its own; split the shape where it crosses the medium's boundary",
                    if disagree == 1 { "lies" } else { "lie" },
                    sigma.to_array()
                ));
            }
            round.push(sigma);
            continue;
        }
        round.push(Rgb::ZERO);
        if let Some(outer) = outer_side(&scene.shapes[i].geometry) {
            if sides[outer] != sigma {
                warnings.push(format!(
                    "{name} bounds a medium on its outer side (σ {:?}{}) that is not the medium round it \
                     (σ {:?}): a path that leaves the shape there carries that medium past every other \
                     surface until it crosses a boundary again, as in Mitsuba, but light that starts out there \
                     (a light, and in caustica's photon and bidirectional modes a photon) has no one medium, \
                     so those modes may differ from the path tracer; enclose the medium in a shape of its own",
                    sides[outer].to_array(),
                    if outer == 0 { ", its inside: its normals face inward" } else { "" },
                    sigma.to_array()
                ));
            }
        }
    }
    warnings.extend(near_plane_in_medium(scene, &boundaries, &dirs));
    (round, lamp_media, warnings)
}

/// Film points per side of the grid at which `near_plane_in_medium` looks at the near clipping plane.
const NEAR_GRID: u32 = 8;

/// The warning for a near clipping plane that starts camera rays inside a medium that absorbs (found
/// at an 8 × 8 grid of film points, where the pinhole's ray through each meets the plane, as a shape's
/// points are). Camera paths start in none and carry it until they cross a boundary, in both renderers
/// (since session 72 in caustica; before, whatever scattered inside the medium, a shape in it or the
/// boundary's inside, gave the path that medium: random scene 2406 of `--more --area-lights`, a diffuse
/// ball in absorbing rough glass cut by the plane, read 0.917 / 0.862 / 1.019 of Mitsuba's means). The
/// light of the medium's own lights and photons is absorbed in it, so the modes differ there.
fn near_plane_in_medium(scene: &Scene, boundaries: &Boundaries, dirs: &[Vec3; 6]) -> Option<String> {
    let cam = &scene.camera;
    if cam.clip[0] <= 0.0 {
        return None;
    }
    let inside: Vec<Rgb> = (0..NEAR_GRID * NEAR_GRID)
        .filter_map(|k| {
            let at = |i: u32, size: u32| (i as f32 + 0.5) / NEAR_GRID as f32 * size as f32;
            let ray = cam.ray(at(k % NEAR_GRID, cam.width), at(k / NEAR_GRID, cam.height));
            let p = ray.at(ray.tmin);
            let sigma = medium_at(scene, boundaries, dirs, p);
            Some(sigma).filter(|sigma| *sigma != cam.medium.sigma_t)
        })
        .collect();
    let (sigma, _) = majority(&inside);
    (!inside.is_empty()).then(|| {
        format!(
            "the camera's near clipping plane lies inside a medium that absorbs (σ {:?}, at {} of {} points \
             of the plane the film sees): camera paths start in the sensor's medium (σ {:?}) and carry it \
             until they cross the medium's boundary, as in Mitsuba, while light from the medium's own \
             lights and photons is absorbed in it: caustica's photon and bidirectional modes differ from \
             its path tracer there. Move the plane out of the medium",
            sigma.to_array(),
            inside.len(),
            NEAR_GRID * NEAR_GRID,
            cam.medium.sigma_t.to_array()
        )
    })
}

/// Which of a closed shape's sides (0: the back of its normals, 1: their front) faces away from it:
/// a sphere's front unless its normals face inward, a mesh's by the sign of its enclosed volume; None
/// for a mesh that encloses none (an open sheet, whose sides are both outer).
fn outer_side(g: &Geometry) -> Option<usize> {
    match g {
        Geometry::Sphere { inward, .. } => Some(if *inward { 0 } else { 1 }),
        Geometry::Mesh(m) => {
            let (lo, hi) = g.bounds();
            let c = 0.5 * (lo + hi);
            let six_v: f64 = (0..m.indices.len())
                .map(|k| {
                    let [a, b, d] = m.triangle(k).map(|p| (p - c).as_dvec3());
                    a.dot(b.cross(d))
                })
                .sum();
            let scale = (hi - lo).as_dvec3();
            // Below a millionth of the box's volume: no volume to speak of.
            (six_v.abs() > 6e-6 * scale.x * scale.y * scale.z).then_some(if six_v > 0.0 { 1 } else { 0 })
        }
    }
}

/// `n` points spread over a shape by area (stratified draws of its one point-on-shape sampler):
/// position, geometric normal and the primitive's size (for the ray offset); none on a mesh without
/// triangles.
fn spread_points(g: &Geometry, n: usize) -> Vec<(Vec3, Vec3, f32)> {
    let cdf: Vec<f32> = match g {
        Geometry::Mesh(m) => (0..m.indices.len())
            .scan(0.0f32, |acc, k| {
                *acc += m.area(k);
                Some(*acc)
            })
            .collect(),
        Geometry::Sphere { .. } => vec![1.0],
    };
    if cdf.is_empty() {
        return Vec::new();
    }
    (0..n)
        .map(|j| {
            // The primitive at the (j + ½)/n-th quantile of the area, and a stratified point within it.
            let (k, _) = crate::math::sampling::sample_cdf(&cdf, (j as f32 + 0.5) / n as f32);
            let sp = g.point(k, crate::math::sampling::hammersley(j, n));
            (sp.p, sp.n, sp.size)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// The hierarchy finds the first boundary surface a ray meets as a scan of every triangle does (its
    /// brute-force twin): 3,000 random triangles of three shapes, 2,000 random rays from inside and
    /// outside their box, one shape skipped for a third of them; the same shape, side and distance.
    #[test]
    fn the_hierarchy_meets_what_a_scan_of_every_triangle_meets() {
        let mut rng = Rng::new(7, 0, 0);
        let mut point = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - Vec3::splat(2.0);
        let mut tris = Vec::new();
        for k in 0..3000u32 {
            let a = point();
            let (b, c) = (a + (point() * 0.1), a + (point() * 0.1));
            tris.push(([a, b, c], k % 3));
        }
        let mut nodes = Vec::new();
        let mut built = tris.clone();
        Boundaries::build(&mut nodes, &mut built, 0);
        let b = Boundaries { boxes: Vec::new(), tris: built, nodes, spheres: Vec::new() };
        let mut hits = 0;
        for k in 0..2000u32 {
            let o = point() * 1.5;
            let d = (point() - o).normalize();
            let ray = Ray::new(o, d);
            let skip = if k % 3 == 0 { k % 3 + (k / 3) % 3 } else { u32::MAX };
            let mut want: Option<(f32, u32, bool)> = None;
            for (c, shape) in &tris {
                if *shape == skip {
                    continue;
                }
                if let Some((t, ..)) = triangle_hit(&ray, *c) {
                    if t > 0.0 && want.is_none_or(|w| t < w.0) {
                        want = Some((t, *shape, d.dot((c[1] - c[0]).cross(c[2] - c[0])) > 0.0));
                    }
                }
            }
            assert_eq!(b.first_hit(&ray, skip), want, "ray {k}");
            hits += want.is_some() as u32;
        }
        assert!(hits > 1000, "only {hits} rays met a triangle");
    }
}
