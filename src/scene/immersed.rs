//! The medium round a shape that bounds none. A shape whose material absorbs on a side (coloured glass,
//! a coloured liquid: `SurfaceMaterial::absorption`, `absorption_outside`) is a boundary between media;
//! every other shape is not, and a path that scatters on it stays in the medium it was in. That is
//! Mitsuba's rule too (its volumetric path tracer changes a path's medium only where it crosses a
//! shape with media), so a diffuse ball inside coloured glass, a light in coloured water or a clear
//! glass ball in it all lie in that medium, on both of their sides. A segment's medium being set where
//! it starts (`Scene::sigma_leaving`), such a shape gets the medium round it as both of its sides'.
//!
//! Which medium that is, is found once at load: from points spread over the shape by area, rays in six
//! fixed directions meet the boundaries (and nothing else); the first one met says the medium (its
//! inside's if met from behind, its outside's if met in front; none if no boundary is met). Each point
//! takes its rays' majority, the shape its points' majority. A shape whose bounds touch no boundary's
//! bounds lies in none without a ray. A shape whose points disagree lies partly in a medium: it gets
//! its points' majority, and the loader warns, naming it (one medium per shape is all a segment's
//! start can say). A boundary is looked at the same way, past itself: where the medium it claims on
//! its outer side is not the one round it, the medium is open (nothing encloses it) and the loader
//! warns, Mitsuba following a path in it further than caustica does.
use crate::color::Rgb;
use crate::math::{offset_ray_origin, ray_meets_box, sphere_root, triangle_hit, Frame, Ray};
use crate::scene::{Geometry, Scene};
use glam::Vec3;
use rayon::prelude::*;

/// Points per shape and rays per point.
const POINTS: usize = 16;

/// The six directions each point's rays take: a frame's axes both ways, turned off the world's so
/// that axis-aligned walls and edges are not met edge-on.
fn directions() -> [Vec3; 6] {
    let f = Frame::from_normal(Vec3::new(0.267, 0.802, 0.535).normalize());
    [f.s, -f.s, f.t, -f.t, f.n, -f.n]
}

/// The boundaries (shapes whose material absorbs on a side): shape index and bounds.
fn boundaries(scene: &Scene) -> Vec<(usize, (Vec3, Vec3))> {
    (scene.absorption.iter().enumerate())
        .filter(|(_, s)| **s != [Rgb::ZERO; 2])
        .map(|(i, _)| (i, scene.shapes[i].geometry.bounds()))
        .collect()
}

/// The absorption σ of the medium `ray` starts in, by the first boundary it meets (zero if none).
fn medium_along(scene: &Scene, bounds: &[(usize, (Vec3, Vec3))], ray: &Ray) -> Rgb {
    let mut best: Option<(f32, usize, bool)> = None;
    for &(i, b) in bounds {
        let tmax = best.map_or(ray.tmax, |(t, ..)| t);
        if !ray_meets_box(&Ray { tmax, ..*ray }, b) {
            continue;
        }
        match &scene.shapes[i].geometry {
            Geometry::Mesh(m) => {
                for k in 0..m.indices.len() {
                    let tri = m.triangle(k);
                    if let Some((t, ..)) = triangle_hit(ray, tri) {
                        if t > ray.tmin && t < best.map_or(ray.tmax, |(t, ..)| t) {
                            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                            best = Some((t, i, ray.d.dot(n) > 0.0));
                        }
                    }
                }
            }
            Geometry::Sphere { center, radius, inward, .. } => {
                let o = ray.o.to_array();
                if let Some(t) = sphere_root(o, ray.d.to_array(), center.to_array(), *radius, ray.tmin, tmax) {
                    let outward = ray.at(t) - *center;
                    let n = if *inward { -outward } else { outward };
                    best = Some((t, i, ray.d.dot(n) > 0.0));
                }
            }
        }
    }
    // Met from behind: the boundary's inside; in front: its outside.
    best.map_or(Rgb::ZERO, |(_, i, behind)| scene.absorption[i][if behind { 0 } else { 1 }])
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
/// every boundary), and the warnings: a shape that lies partly in a medium, and a boundary whose medium
/// on its outer side is not the one round it (a sphere with `flip_normals` whose inside medium is then
/// all the space outside it, an exterior medium that nothing encloses): Mitsuba carries a path that
/// leaves it into that medium past every other surface, caustica to the next one. Empty when the scene
/// has no boundary (`Scene::absorption` empty).
pub fn surrounding_media(scene: &Scene) -> (Vec<Rgb>, Vec<String>) {
    if scene.absorption.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let all = boundaries(scene);
    let dirs = directions();
    let slack = Vec3::splat(scene.diagonal() * 1e-6);
    // (σ round the shape, points that disagree), from the boundaries other than the shape itself.
    let found: Vec<(Rgb, usize)> = (0..scene.shapes.len())
        .into_par_iter()
        .map(|i| {
            let (lo, hi) = scene.shapes[i].geometry.bounds();
            let others: Vec<(usize, (Vec3, Vec3))> = (all.iter().copied())
                .filter(|&(j, (blo, bhi))| j != i && (lo - slack).cmple(bhi).all() && (hi + slack).cmpge(blo).all())
                .collect();
            if others.is_empty() {
                return (Rgb::ZERO, 0);
            }
            let votes: Vec<Rgb> = spread_points(&scene.shapes[i].geometry)
                .iter()
                .map(|&(p, n, size)| {
                    let rays: Vec<Rgb> = dirs
                        .iter()
                        .map(|&d| medium_along(scene, &others, &Ray::new(offset_ray_origin(p, n, d, size), d)))
                        .collect();
                    majority(&rays).0
                })
                .collect();
            let (sigma, agree) = majority(&votes);
            (sigma, votes.len() - agree)
        })
        .collect();
    let mut warnings = Vec::new();
    let mut round = Vec::with_capacity(found.len());
    for (i, (sigma, disagree)) in found.into_iter().enumerate() {
        let name = &scene.shapes[i].name;
        let sides = scene.absorption[i];
        if sides == [Rgb::ZERO; 2] {
            if disagree > 0 {
                warnings.push(format!(
                    "{name} lies partly inside a medium that absorbs (of {POINTS} points spread over it, \
                     {disagree} lie in another medium than the rest): caustica gives a shape that bounds no \
                     medium one medium round it, here σ {:?}, where Mitsuba follows each path's own; split the \
                     shape where it crosses the medium's boundary",
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
                     (σ {:?}): Mitsuba carries a path that leaves the shape there in that medium past every \
                     other surface until it crosses a boundary again, caustica only to the next surface, so \
                     the two differ; enclose the medium in a shape of its own",
                    sides[outer].to_array(),
                    if outer == 0 { ", its inside: its normals face inward" } else { "" },
                    sigma.to_array()
                ));
            }
        }
    }
    (round, warnings)
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

/// `POINTS` points spread over a shape by area (stratified draws of its one point-on-shape sampler):
/// position, geometric normal and the primitive's size (for the ray offset).
fn spread_points(g: &Geometry) -> Vec<(Vec3, Vec3, f32)> {
    let areas: Vec<f32> = match g {
        Geometry::Mesh(m) => (0..m.indices.len()).map(|k| m.area(k)).collect(),
        Geometry::Sphere { .. } => vec![1.0],
    };
    let total: f64 = areas.iter().map(|&a| a as f64).sum();
    let mut out = Vec::with_capacity(POINTS);
    let (mut k, mut acc) = (0usize, 0.0f64);
    for j in 0..POINTS {
        // The (j + ½)/POINTS-th quantile of the area, and a stratified point within its primitive.
        let target = (j as f64 + 0.5) / POINTS as f64 * total;
        while k + 1 < areas.len() && acc + areas[k] as f64 <= target {
            acc += areas[k] as f64;
            k += 1;
        }
        let u = crate::math::sampling::hammersley(j, POINTS);
        let sp = g.point(k, u);
        out.push((sp.p, sp.n, sp.size));
    }
    out
}
