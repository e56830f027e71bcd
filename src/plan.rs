//! The planner: reads a scene and decides which photon maps, caustic targets and extra pixel samples it
//! needs, and says why. Visibility questions go through a caller-supplied test (the renderer passes
//! Embree's occlusion query), so this module stays below `accel` in the dependency order.
use crate::math::Rng;
use crate::scene::file::DirectLight;
use crate::scene::light::LightKind;
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
    /// Maps the scene's light needs that `render.photons` asks 0 photons of: the light each would carry
    /// is left out of the photon mappers' images (one line each, for a warning).
    pub left_out: Vec<String>,
}

/// The two questions the planner asks of the ray tracer.
pub struct Probe<'a> {
    /// Nothing blocks the open segment from a to b.
    pub visible: &'a dyn Fn(Vec3, Vec3) -> bool,
    /// The shape a ray hits first, and where.
    pub first_hit: &'a dyn Fn(crate::math::Ray) -> Option<(u32, Vec3)>,
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

/// Corners of the bounding box of shape `s`.
fn box_corners(scene: &Scene, s: usize) -> [Vec3; 8] {
    let (lo, hi) = scene.shapes[s].geometry.bounds();
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Whether light can possibly arrive at shape `s` straight from an emitter. The only proof of
/// darkness used is geometric and exact: every emitting triangle faces away from the shape's whole
/// bounding box (triangles emit from their front only), and every spot's cone misses the sphere around
/// that box. Point and sphere lights shine everywhere, and occlusion is never used as a proof: a mirror
/// lit through a gap a random probe misses stays a target.
fn may_be_lit(scene: &Scene, s: usize) -> bool {
    let corners = box_corners(scene, s);
    let (lo, hi) = scene.shapes[s].geometry.bounds();
    let (centre, radius) = (0.5 * (lo + hi), 0.5 * (hi - lo).length());
    scene.lights.list.iter().enumerate().any(|(i, light)| {
        if scene.lights.power[i].max_element() <= 0.0 {
            return false;
        }
        match light {
            LightKind::Triangle { shape, prim } => {
                // A mesh that emits behind its faces lights both sides.
                let s = &scene.shapes[*shape as usize];
                if s.emits_behind() {
                    return true;
                }
                let Geometry::Mesh(m) = &s.geometry else { return true };
                let [a, b, c] = m.triangle(*prim as usize);
                let n = (b - a).cross(c - a);
                corners.iter().any(|&q| (q - a).dot(n) > 0.0)
            }
            LightKind::Point { position, spot: Some(spot), .. } => {
                // The cone reaches the sphere iff the angle from its axis to the centre is at most the
                // cutoff plus the sphere's angular radius (or the apex is inside the sphere).
                let v = centre - *position;
                let d = v.length();
                if d.is_nan() || d <= radius * (1.0 + 1e-4) {
                    return true;
                }
                let angle = spot.angle(v);
                // Anything not a number is no proof of darkness.
                angle.is_nan() || angle <= spot.cutoff + (radius / d).min(1.0).asin() + 1e-4
            }
            LightKind::Point { .. } | LightKind::Sphere { .. } | LightKind::Env | LightKind::Distant { .. } => true,
        }
    })
}

pub fn plan(scene: &Scene, probe: &Probe) -> Plan {
    let r = &scene.render;
    let mut reasons = Vec::new();
    let mut left_out = Vec::new();
    // A map this scene's light needs, asked for `count` photons: none asked, its light is left out.
    let mut wanted = |key: &str, count: u64, light: &str| {
        if count == 0 {
            left_out.push(format!(
                "render.photons.{key} = 0: the {key} map is not built, so {light} is left out of the photon mappers' \
                 images (path tracing, BDPT and VCM keep it)"
            ));
        }
        count
    };
    // A plastic is both: its base holds photons, its coat is a mirror.
    let is_diffuse = |s: usize| scene.is_diffuse(s as u32);
    let holds = |s: usize| scene.holds_photons(s as u32);
    let lit_diffuse: Vec<usize> =
        (0..scene.shapes.len()).filter(|&s| holds(s) && scene.max_albedo(s as u32) > 0.0).collect();
    // What can cast a caustic: a see-through surface's holes only let light by.
    let specular: Vec<usize> = (0..scene.shapes.len()).filter(|&s| scene.casts_caustics(s as u32)).collect();

    let mut targets = Vec::new();
    for &s in &specular {
        if may_be_lit(scene, s) {
            targets.push(s as u32);
        } else {
            reasons.push(format!(
                "{}: specular but every light faces away from it (or points its cone elsewhere): not a caustic target",
                scene.shapes[s].name
            ));
        }
    }
    // Caustic photons are stored only where a surface holds photons (diffuse, a plastic's base). The
    // targets stay: VCM's light subpaths aim at them too. A point, spot or distant light's caustics on a
    // glossy surface (rough metal or glass, a principled surface, a rough plastic's coat) are traced by
    // the caustic pass too, to the camera: nothing else finds them.
    let any_holder = scene.any_holds_photons();
    let delta_light = scene.lights.list.iter().any(|l| l.is_delta());
    let glossy = (0..scene.shapes.len()).any(|s| scene.has_unheld_glossy_lobe(s as u32));
    let glossy_caustics = delta_light && glossy && targets.iter().any(|&t| scene.has_delta_lobe(t));
    // A caustic or indirect photon bounced before it landed: its path and its gather are at least two
    // scattering events, which `render.max_depth` 1 never counts (the photons would be traced, never
    // stored, until the shot budget ran out).
    let bounced_fit = r.max_depth >= 2;
    let too_shallow = || format!("render.max_depth {}: no path with a bounce before its gather fits", r.max_depth);
    let caustic = if !r.force_all_passes && !bounced_fit {
        reasons.push(format!("no caustic map: {}", too_shallow()));
        0
    } else if r.force_all_passes || (!targets.is_empty() && any_holder) {
        let glossy = if glossy_caustics {
            "; their caustics from point, spot or distant lights on glossy surfaces are traced to the camera"
        } else {
            ""
        };
        reasons.push(format!("caustic map: {} specular shape(s) lit by a light{glossy}", targets.len()));
        wanted("caustic", r.photons.caustic, "light that reaches diffuse surfaces through mirrors and glass")
    } else if glossy_caustics {
        reasons.push(format!(
            "caustic photons, no map: {} specular shape(s) lit by a point, spot or distant light, whose caustics \
             on glossy surfaces are traced to the camera (no surface holds photons)",
            targets.len()
        ));
        wanted("caustic", r.photons.caustic, "the caustics of point, spot and distant lights on glossy surfaces")
    } else if !targets.is_empty() {
        reasons.push(
            "no caustic map: no surface holds photons (every one is specular or glossy, and no mirror or glass \
             lit by a point, spot or distant light: the eye pass's own paths find the light)"
                .into(),
        );
        0
    } else {
        reasons.push("no caustic map: no specular surface that a light can reach".into());
        0
    };
    // Light reflected by one diffuse surface reaches a diffuse surface again through a second diffuse
    // surface, through a curved one lighting itself, or through a mirror or glass (L D S⁺ D).
    let via_specular = !lit_diffuse.is_empty() && !specular.is_empty();
    let bounce_possible = lit_diffuse.len() >= 2 || lit_diffuse.iter().any(|&s| !planar(scene, s)) || via_specular;
    let indirect = if !r.force_all_passes && !bounced_fit {
        reasons.push(format!("no indirect map: {}", too_shallow()));
        0
    } else if r.force_all_passes || bounce_possible {
        reasons.push(if via_specular && lit_diffuse.len() < 2 {
            "indirect map: a diffuse surface lights itself through a specular one".into()
        } else {
            "indirect map: diffuse surfaces can light each other".into()
        });
        wanted("indirect", r.photons.indirect, "light that bounced off a diffuse surface before")
    } else {
        reasons.push("no indirect map: no diffuse surface can light another, or itself via a mirror".into());
        0
    };
    let direct = if r.force_all_passes || r.direct_light == DirectLight::PhotonMap {
        reasons.push("direct map: direct light read from photons (render.direct_light = \"photon_map\")".into());
        wanted("direct", r.photons.direct, "direct light")
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
    Plan { photons: [direct, indirect, caustic], caustic_targets: targets, specular_spp, nee_lights, reasons, left_out }
}

/// For each light, whether the path tracer's next-event estimation should sample it. Only area lights
/// (triangles, spheres) can be left out: BSDF sampling hits them, and the path tracer's MIS weights
/// follow the reduced distribution, so leaving one out changes noise, never the expectation, whatever
/// this heuristic concludes. Point lights have no other strategy and are always kept; estimators
/// without MIS (the photon-map eye pass) sample every light. An area light is left out when it reaches
/// no diffuse point among the first hits of a 48×48 grid of camera rays (two light samples each).
/// All triangles of an emissive shape share the answer. In a scene with a medium that scatters (also
/// round the camera) every light is kept: the light a medium scatters to the camera is not lit at the diffuse points the probes
/// look at (a light inside a fog ball lights the fog).
fn lights_in_view(scene: &Scene, probe: &Probe, seen: &[(u32, Vec3)], reasons: &mut Vec<String>) -> Vec<bool> {
    let lights = &scene.lights;
    if !scene.scattering.is_empty() || scene.camera.medium.scattering.scatters() {
        return vec![true; lights.list.len()];
    }
    let eps = 1e-4 * scene.diagonal().max(1e-6);
    let targets: Vec<Vec3> = seen.iter().filter(|(s, _)| scene.holds_photons(*s)).map(|&(_, p)| p).collect();
    let mut keep = vec![true; lights.list.len()];
    let mut i = 0;
    while i < lights.list.len() {
        // The group: one point light, or every triangle of one emissive shape.
        let shape = lights.list[i].shape();
        let mut end = i + 1;
        while shape.is_some() && end < lights.list.len() && lights.list[end].shape() == shape {
            end += 1;
        }
        if shape.is_none() {
            i = end;
            continue;
        }
        let mut rng = Rng::new(0x11_6475, i as u64, 0);
        let reaches = targets.iter().any(|&p| {
            (0..2).any(|_| {
                let li = i + (rng.next_u32() as usize) % (end - i);
                let Some(lp) = lights.sample_point(scene, li, rng.next_2d()) else { return false };
                let d = p - lp.p;
                if d.length() <= 2.0 * eps || (lp.n != Vec3::ZERO && lights.side_share(li, lp.n.dot(d)) <= 0.0) {
                    return false;
                }
                let dir = d.normalize();
                (probe.visible)(lp.p + dir * eps, p - dir * eps)
            })
        });
        if !reaches {
            let name = shape.map_or_else(|| format!("point light {i}"), |s| scene.shapes[s as usize].name.clone());
            reasons.push(format!(
                "{name}: reaches nothing the camera sees directly: left out of the path tracer's light \
                 sampling (BSDF sampling with MIS still finds it)"
            ));
            keep[i..end].iter_mut().for_each(|k| *k = false);
        }
        i = end;
    }
    keep
}
