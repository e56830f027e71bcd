//! The planner: reads a scene and decides which photon maps, caustic targets and extra pixel samples it
//! needs, and says why. Visibility questions go through a caller-supplied test (the renderer passes
//! Embree's occlusion query), so this module stays below `accel` in the dependency order.
use crate::math::{sampling, Rng};
use crate::scene::file::DirectLight;
use crate::scene::{Geometry, Scene};
use glam::Vec3;
use serde::Serialize;

#[derive(Debug, Clone, Serialize)]
pub struct Plan {
    /// Photons to store per map: direct, indirect, caustic (0 = skip the map).
    pub photons: [u64; 3],
    /// Specular shapes a light can see: the caustic targets.
    pub caustic_targets: Vec<u32>,
    /// Extra eye samples for pixels whose first hit is specular (0 when the camera sees none).
    pub specular_spp: u32,
    /// Per light (`Lights::list` index): sampled for direct light or left out, because nothing it can
    /// reach directly is in view.
    pub nee_lights: Vec<bool>,
    /// One line per decision.
    pub reasons: Vec<String>,
}

/// The two questions the planner asks of the ray tracer.
pub struct Probe<'a> {
    /// Nothing blocks the open segment from a to b.
    pub visible: &'a dyn Fn(Vec3, Vec3) -> bool,
    /// The shape a ray hits first, and where.
    pub first_hit: &'a dyn Fn(crate::math::Ray) -> Option<(u32, Vec3)>,
}

/// A point on shape `s` (uniform over its triangles by count, or over a sphere), and its normal.
fn point_on(scene: &Scene, s: usize, rng: &mut Rng) -> (Vec3, Vec3) {
    match &scene.shapes[s].geometry {
        Geometry::Mesh(m) => {
            let i = (rng.next_u32() as usize) % m.indices.len().max(1);
            let [a, b, c] = m.triangle(i);
            let bc = sampling::uniform_triangle(rng.next_2d());
            (a * (1.0 - bc[0] - bc[1]) + b * bc[0] + c * bc[1], (b - a).cross(c - a).normalize_or_zero())
        }
        Geometry::Sphere { center, radius } => {
            let n = sampling::uniform_sphere(rng.next_2d());
            (*center + n * *radius, n)
        }
    }
}

fn planar(scene: &Scene, s: usize) -> bool {
    match &scene.shapes[s].geometry {
        Geometry::Mesh(m) if !m.indices.is_empty() => {
            let [a, b, c] = m.triangle(0);
            let n = (b - a).cross(c - a).normalize_or_zero();
            m.positions.iter().all(|p| (*p - a).dot(n).abs() <= 1e-5 * (1.0 + p.length()))
        }
        _ => false,
    }
}

/// Whether some light sample sees some point of shape `s` (tries `tries` random pairs).
fn light_sees(scene: &Scene, s: usize, probe: &Probe, tries: u32) -> bool {
    let mut rng = Rng::new(0x91A7, s as u64, 0);
    for _ in 0..tries {
        let (li, _) = sampling::sample_cdf(&scene.lights.cdf, rng.next_f32());
        let Some(lp) = scene.lights.sample_point(scene, li, rng.next_2d()) else {
            continue;
        };
        let (y, n) = point_on(scene, s, &mut rng);
        let d = y - lp.p;
        if lp.n != Vec3::ZERO && lp.n.dot(d) <= 0.0 {
            continue;
        }
        // Offset both ends a hair so neither surface occludes itself.
        let eps = 1e-4 * scene.diagonal().max(1e-6);
        let a = lp.p + d.normalize() * eps;
        let b = y - d.normalize() * eps;
        if n != Vec3::ZERO && (probe.visible)(a, b) {
            return true;
        }
    }
    false
}

pub fn plan(scene: &Scene, probe: &Probe) -> Plan {
    let r = &scene.render;
    let mut reasons = Vec::new();
    let is_diffuse = |s: usize| scene.materials[scene.shapes[s].material as usize].is_diffuse();
    let lit_diffuse: Vec<usize> = (0..scene.shapes.len())
        .filter(|&s| is_diffuse(s) && scene.materials[scene.shapes[s].material as usize].albedo().max_element() > 0.0)
        .collect();
    let specular: Vec<usize> = (0..scene.shapes.len()).filter(|&s| !is_diffuse(s)).collect();

    let mut targets = Vec::new();
    for &s in &specular {
        if light_sees(scene, s, probe, 256) {
            targets.push(s as u32);
        } else {
            reasons.push(format!("{}: specular but no light reaches it: not a caustic target", scene.shapes[s].name));
        }
    }
    let caustic = if r.force_all_passes || !targets.is_empty() {
        reasons.push(format!("caustic map: {} specular shape(s) lit by a light", targets.len()));
        r.photons.caustic
    } else {
        reasons.push("no caustic map: no specular surface that a light can reach".into());
        0
    };
    let bounce_possible = lit_diffuse.len() >= 2 || lit_diffuse.iter().any(|&s| !planar(scene, s));
    let indirect = if r.force_all_passes || bounce_possible {
        reasons.push("indirect map: diffuse surfaces can light each other".into());
        r.photons.indirect
    } else {
        reasons.push("no indirect map: no diffuse surface can light another diffuse surface".into());
        0
    };
    let direct = if r.force_all_passes || r.direct_light == DirectLight::PhotonMap {
        reasons.push("direct map: direct light read from photons (render.direct_light = \"photon_map\")".into());
        r.photons.direct
    } else {
        reasons.push("no direct map: direct light uses shadow rays".into());
        0
    };
    let cam = &scene.camera;
    let (gx, gy) = (48u32, 48u32);
    let mut seen: Vec<(u32, Vec3)> = Vec::new();
    for j in 0..gy {
        for i in 0..gx {
            let ray = cam
                .ray((i as f32 + 0.5) / gx as f32 * cam.width as f32, (j as f32 + 0.5) / gy as f32 * cam.height as f32);
            seen.extend((probe.first_hit)(ray));
        }
    }
    let sees_specular = seen.iter().any(|&(s, _)| !is_diffuse(s as usize));
    let nee_lights = lights_in_view(scene, probe, &seen, &mut reasons);
    let specular_spp = if r.force_all_passes || sees_specular {
        reasons.push(format!("{} extra eye samples where the first hit is specular", r.specular_spp));
        r.specular_spp
    } else {
        reasons.push("no extra eye samples: the camera sees no specular surface".into());
        0
    };
    Plan { photons: [direct, indirect, caustic], caustic_targets: targets, specular_spp, nee_lights, reasons }
}

/// For each light, whether it directly reaches some diffuse point the camera sees (tried against the
/// first hits of a 48×48 grid of camera rays, two light samples each). All triangles of an emissive
/// shape share the answer.
fn lights_in_view(scene: &Scene, probe: &Probe, seen: &[(u32, Vec3)], reasons: &mut Vec<String>) -> Vec<bool> {
    let lights = &scene.lights;
    let eps = 1e-4 * scene.diagonal().max(1e-6);
    let targets: Vec<Vec3> = seen
        .iter()
        .filter(|(s, _)| scene.materials[scene.shapes[*s as usize].material as usize].is_diffuse())
        .map(|&(_, p)| p)
        .collect();
    let mut keep = vec![true; lights.list.len()];
    let mut i = 0;
    while i < lights.list.len() {
        // The group: one point light, or every triangle of one emissive shape.
        let shape = lights.list[i].shape();
        let mut end = i + 1;
        while shape.is_some() && end < lights.list.len() && lights.list[end].shape() == shape {
            end += 1;
        }
        let mut rng = Rng::new(0x11_6475, i as u64, 0);
        let reaches = targets.iter().any(|&p| {
            (0..2).any(|_| {
                let li = i + (rng.next_u32() as usize) % (end - i);
                let Some(lp) = lights.sample_point(scene, li, rng.next_2d()) else { return false };
                let d = p - lp.p;
                if d.length() <= 2.0 * eps || (lp.n != Vec3::ZERO && lp.n.dot(d) <= 0.0) {
                    return false;
                }
                let dir = d.normalize();
                (probe.visible)(lp.p + dir * eps, p - dir * eps)
            })
        });
        if !reaches {
            let name = shape.map_or_else(|| format!("point light {i}"), |s| scene.shapes[s as usize].name.clone());
            reasons
                .push(format!("{name}: reaches nothing the camera sees directly: left out of direct-light sampling"));
            keep[i..end].iter_mut().for_each(|k| *k = false);
        }
        i = end;
    }
    keep
}
