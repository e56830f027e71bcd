//! Integrators: the path tracer (reference), the photon-map eye pass and the progressive photon
//! mappers, bidirectional path tracing and vertex connection and merging, sharing light sampling and the walk of a camera ray through mirrors and glass.
pub mod direct;
pub mod edges;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod sppm;
pub mod vcm;

/// Per-thread counters, summed after a render.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    pub rays: u64,
    pub nonfinite: u64,
}

impl std::ops::AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        self.rays += o.rays;
        self.nonfinite += o.nonfinite;
    }
}

/// Where a camera ray's chain of non-diffuse bounces (mirrors, glass, rough metal, a plastic's coat, each
/// sampled) first meets a diffuse surface (or a plastic's base), and the chain's throughput there.
#[derive(Clone, Copy, Debug)]
pub struct ChainEnd {
    pub si: crate::scene::SurfaceHit,
    pub wo: glam::Vec3,
    pub beta: crate::color::Rgb,
    /// Bounces before this hit along the chain (0: the ray's first hit).
    pub depth: u32,
    /// The BSDF there: on a blend, the material the chain picked (light gathered here uses it).
    pub mat: crate::scene::Material,
    /// The absorption of the medium the chain arrived here in (`Scene::sigma_next`).
    pub sigma: crate::color::Rgb,
}

impl ChainEnd {
    /// Scattering events `render.max_depth` leaves for light gathered here, if the chain began `first`
    /// bounces into its path (0 for a camera ray): this hit's own scattering and the photon's path, or
    /// the light sample. 0 when the path tracer would count only emission here.
    pub fn budget(&self, scene: &crate::scene::Scene, first: u32) -> u32 {
        scene.render.max_depth.saturating_sub(first + self.depth)
    }
}

/// Whether `ray` first meets a non-diffuse surface (mirror, glass, metal): where the photon-mapping eye
/// passes take their extra samples.
fn first_hit_specular(scene: &crate::scene::Scene, tracer: &dyn crate::accel::Tracer, ray: &crate::math::Ray) -> bool {
    tracer.intersect(ray).is_some_and(|h| !scene.is_diffuse(h.shape))
}

/// Keys the extra camera samples of pixels behind specular surfaces apart from the pixels' own.
pub const EXTRA_SAMPLES_KEY: u64 = 0x5350_504D_4558_5452;

/// The extra eye samples each pixel of the photon-mapping eye passes takes per sample of its own
/// (row-major): `spp` where the ray through the pixel's centre first meets a mirror, glass or metal, else
/// 0. Decided once per pixel, not per sample: a count that followed each sample's own ray would weigh
/// the samples landing on the specular part of a pixel less than the others. Also returns the rays
/// traced (one per pixel, none when `spp` is 0).
pub fn extra_samples(scene: &crate::scene::Scene, tracer: &dyn crate::accel::Tracer, spp: u32) -> (Vec<u32>, u64) {
    use rayon::prelude::*;
    let cam = &scene.camera;
    let (width, count) = (cam.width as usize, cam.width as usize * cam.height as usize);
    if spp == 0 {
        return (vec![0; count], 0);
    }
    let extra = (0..count)
        .into_par_iter()
        .map(|k| {
            let ray = cam.ray((k % width) as f32 + 0.5, (k / width) as f32 + 0.5);
            if first_hit_specular(scene, tracer, &ray) {
                spp
            } else {
                0
            }
        })
        .collect();
    (extra, count as u64)
}

/// Camera sample `s` of pixel (x, y) for a photon-mapping eye pass, filter-weighted: `li(ray, rng)` for
/// a film position drawn with `rng` (the pixel's own sampler for sample `s`), averaged with `extra`
/// more, each at a film position of its own, drawn from sampler `seed ^ EXTRA_SAMPLES_KEY`'s samples
/// s·extra … s·extra + extra − 1 of the pixel: a light's glint in a mirror that covers a sliver of the
/// pixel is found by any of them, not by the first position alone.
#[allow(clippy::too_many_arguments)]
pub fn eye_sample(
    scene: &crate::scene::Scene,
    x: u32,
    y: u32,
    s: u64,
    extra: u32,
    seed: u64,
    rng: &mut crate::math::Rng,
    mut li: impl FnMut(crate::math::Ray, &mut crate::math::Rng) -> crate::color::Rgb,
) -> crate::color::Rgb {
    let cam = &scene.camera;
    let (fx, fy, weight) = cam.film_position(x, y, rng.next_2d());
    let mut l = li(cam.sample_ray(fx, fy, rng), rng) * weight;
    let pixel = y as u64 * cam.width as u64 + x as u64;
    for j in 0..extra as u64 {
        let mut rng =
            crate::math::Rng::camera(scene.render.sampler, seed ^ EXTRA_SAMPLES_KEY, pixel, s * extra as u64 + j);
        let (fx, fy, weight) = cam.film_position(x, y, rng.next_2d());
        l += li(cam.sample_ray(fx, fy, &mut rng), &mut rng) * weight;
    }
    l / (extra + 1) as f32
}

/// Most emitting surfaces one camera ray passes when they are hidden (a guard against a ray that keeps
/// meeting the surface it left).
const HIDDEN_PASSES: u32 = 64;

/// Whether shape `shape` emits light (an area light, a sphere light, an emitting mesh).
fn emits(scene: &crate::scene::Scene, shape: u32) -> bool {
    scene.shapes[shape as usize].emission != crate::color::Rgb::ZERO
}

/// Whether a path is still the camera's own line of sight: its first segment, and on straight through
/// null surfaces and thin panes (their transmission), as Mitsuba's null events. With
/// `render.hide_emitters` the camera sees no emitter and no sky along it (`trace`, `hides`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineOfSight(bool);

impl LineOfSight {
    /// A camera ray's first segment.
    pub const CAMERA: LineOfSight = LineOfSight(true);
    /// Any other segment.
    pub const NOT: LineOfSight = LineOfSight(false);

    /// The first surface along `ray`: `camera_view` on the line of sight, else the plain hit.
    pub fn trace(
        self,
        scene: &crate::scene::Scene,
        tracer: &dyn crate::accel::Tracer,
        ray: &crate::math::Ray,
        c: &mut Counters,
    ) -> Option<crate::accel::Interaction> {
        if self.0 {
            camera_view(scene, tracer, ray, c)
        } else {
            crate::accel::interact(scene, tracer, ray)
        }
    }

    /// The first surface along `ray` that the path scatters at, with the BSDF it scatters by there, and
    /// the light let through on the way: see-through surfaces that let the path straight through (a
    /// null surface, a mask's holes, a thin pane's transmission: `Scene::crossing`) are crossed, each
    /// multiplying in what it lets through, as no scattering event (the segment stays one, from the
    /// ray's origin: the hit's `t` is along `ray`). None with the light let through when the ray leaves
    /// the scene; zero light when it crosses more than `accel::MAX_CROSSINGS` surfaces.
    #[inline(always)]
    pub fn trace_through(
        self,
        scene: &crate::scene::Scene,
        tracer: &dyn crate::accel::Tracer,
        ray: &crate::math::Ray,
        rng: &mut crate::math::Rng,
        c: &mut Counters,
    ) -> (Option<(crate::accel::Interaction, crate::scene::Material)>, crate::color::Rgb) {
        let Some(found) = self.trace(scene, tracer, ray, c) else {
            return (None, crate::color::Rgb::ONE);
        };
        if scene.is_see_through(found.si.shape) {
            return self.cross_from(scene, tracer, ray, found, rng, c);
        }
        let mat = scene.bsdf(&found.si, found.wo, || rng.next_f32());
        (Some((found, mat)), crate::color::Rgb::ONE)
    }

    /// `trace_through` from `ray`'s first hit, `found`, on a see-through surface (`Scene::see_through`).
    /// Out of line, so that the paths of scenes without one stay as short as they were.
    #[cold]
    #[inline(never)]
    pub fn cross_from(
        self,
        scene: &crate::scene::Scene,
        tracer: &dyn crate::accel::Tracer,
        ray: &crate::math::Ray,
        mut found: crate::accel::Interaction,
        rng: &mut crate::math::Rng,
        c: &mut Counters,
    ) -> (Option<(crate::accel::Interaction, crate::scene::Material)>, crate::color::Rgb) {
        let mut picked = scene.bsdf(&found.si, found.wo, || rng.next_f32());
        let mut tr = crate::color::Rgb::ONE;
        for crossed in 0..crate::accel::MAX_CROSSINGS {
            let t = match scene.crossing(&found.si, found.wo, picked, || rng.next_f32()) {
                crate::scene::Crossing::Through(t) => t,
                crate::scene::Crossing::At(mat) => {
                    if crossed > 0 {
                        found.hit.t = (found.si.p - ray.o).dot(ray.d) / ray.d.length_squared();
                    }
                    return (Some((found, mat)), tr);
                }
            };
            tr *= t;
            if tr == crate::color::Rgb::ZERO {
                return (None, tr);
            }
            c.rays += 1;
            let Some(next) = self.trace(scene, tracer, &found.si.spawn(ray.d), c) else {
                return (None, tr);
            };
            found = next;
            picked = scene.bsdf(&found.si, found.wo, || rng.next_f32());
        }
        (None, crate::color::Rgb::ZERO)
    }

    /// Whether emission (or the sky) met along this segment is left out.
    pub fn hides(self, scene: &crate::scene::Scene) -> bool {
        self.0 && scene.render.hide_emitters
    }

    /// The next segment, after a bounce off `mat` that `transmitted` through it or not: still the line
    /// of sight only straight through a thin pane (a null surface is one).
    pub fn after(self, mat: &crate::scene::Material, transmitted: bool) -> LineOfSight {
        LineOfSight(self.0 && mat.is_thin() && transmitted)
    }
}

/// What the camera sees along `ray` (its own line of sight, `LineOfSight`). With
/// `render.hide_emitters` the camera does not see emitting surfaces at all, as in Mitsuba 3.9: the view
/// passes through them to what lies behind, without a bounce, while their light, their shadows and
/// their images in mirrors and glass stay. The hit's `t` is along `ray`.
fn camera_view(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    ray: &crate::math::Ray,
    c: &mut Counters,
) -> Option<crate::accel::Interaction> {
    let mut found = crate::accel::interact(scene, tracer, ray)?;
    if !scene.render.hide_emitters {
        return Some(found);
    }
    let mut t = 0.0;
    for _ in 0..HIDDEN_PASSES {
        if !emits(scene, found.si.shape) {
            found.hit.t += t;
            return Some(found);
        }
        t += found.hit.t;
        let next = found.si.spawn(ray.d);
        c.rays += 1;
        found = crate::accel::interact(scene, tracer, &next)?;
    }
    None
}

/// How much of surface point `from` the camera sees along the segment to `to` (light tracing's
/// connection to the camera: `to` is the lens point, or where the segment meets the near clipping
/// plane, `CameraLink::clear`): all of it with nothing in between, the transmittance of the see-through
/// surfaces between (`accel::transmittance`), nothing past anything else, except, with
/// `render.hide_emitters`, emitting surfaces, which the camera does not see (`camera_view`). A point on
/// an emitting surface is then not seen at all. A point `beyond_far` (the far clipping plane) is seen
/// only if the camera's first hit towards it, past the near plane, is a surface its line of sight goes
/// straight on through (see-through, or emitting and hidden), within the far plane: camera rays are
/// clipped on their first segment only, and go on unclipped past such a crossing
/// (`LineOfSight::cross_from`, `camera_view`). Rays past the first are added to `c`.
pub fn camera_sees(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    from: &crate::scene::SurfaceHit,
    to: glam::Vec3,
    beyond_far: bool,
    c: &mut Counters,
) -> crate::color::Rgb {
    if beyond_far && !crossed_within_far(scene, tracer, from.p, to, c) {
        return crate::color::Rgb::ZERO;
    }
    // No absorption on the way: the camera's segment is in no medium (`Scene::absorbed_to`), also where
    // it sits inside coloured glass.
    let ray = from.spawn_to(to);
    if !scene.render.hide_emitters {
        return crate::accel::shadow(scene, tracer, &ray, to, &mut c.rays);
    }
    if emits(scene, from.shape) {
        return crate::color::Rgb::ZERO;
    }
    crate::accel::transmittance(scene, tracer, &ray, to, |shape| emits(scene, shape), &mut c.rays)
}

/// Whether the camera's first hit on the way from `to` (the lens point, or the near plane's point) to
/// `p` is a surface its line of sight crosses (see-through, or emitting under `render.hide_emitters`)
/// within the far clipping plane: the camera then sees on to `p` past that plane.
#[cold]
fn crossed_within_far(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    p: glam::Vec3,
    to: glam::Vec3,
    c: &mut Counters,
) -> bool {
    let mut ray = crate::math::Ray::new(to, p - to);
    // Short of `p`'s own surface (a hit there is `p`, beyond the plane).
    ray.tmax = 1.0 - 1e-4;
    c.rays += 1;
    let Some(hit) = tracer.intersect(&ray) else {
        return false;
    };
    let crossed = scene.is_see_through(hit.shape) || (scene.render.hide_emitters && emits(scene, hit.shape));
    crossed && scene.camera.depth(ray.at(hit.t)) <= scene.camera.clip[1]
}

/// Light tracing's link to the camera: the light `beta` (a light subpath's throughput, a photon's
/// power) arriving at `si` from `wo`, scattered by `mat` towards lens point `lens` (the pinhole for a
/// pinhole camera), splatted with `add(pixel, value)` where it lands on the film, times `weight` of
/// the link and divided by `norm` (the light paths it is one of). `weight` gets the unit direction to
/// the lens (for an orthographic camera, against the view direction) and the density (per unit area at
/// `si`) with which a camera path would reach `si`; a weight of 0 casts no ray. The lens point's
/// density, 1 / (π r²), is the same for every strategy and cancels against the aperture's area in the
/// camera's importance, so neither appears.
#[allow(clippy::too_many_arguments)]
pub fn link_to_camera(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    si: &crate::scene::SurfaceHit,
    wo: glam::Vec3,
    mat: &crate::scene::Material,
    beta: crate::color::Rgb,
    lens: glam::Vec3,
    norm: f32,
    c: &mut Counters,
    weight: impl FnOnce(glam::Vec3, f32) -> f32,
    mut add: impl FnMut(u32, crate::color::Rgb),
) {
    let cam = &scene.camera;
    let Some(link) = cam.link(lens, si.p) else {
        return;
    };
    let dir = link.dir;
    if !si.can_scatter(mat, wo, dir) {
        return;
    }
    let f = si.scatter_light(mat, wo, dir);
    if f == crate::color::Rgb::ZERO {
        return;
    }
    let w = weight(dir, link.pdf * dir.dot(si.ng).abs() / link.dist2);
    if w == 0.0 {
        return;
    }
    c.rays += 1;
    let seen = camera_sees(scene, tracer, si, link.clear, link.beyond_far, c);
    if seen == crate::color::Rgb::ZERO {
        return;
    }
    let val = beta * f * seen * (w * link.pdf / link.dist2 / norm);
    let (px, py) = link.film;
    cam.splat(px, py, |pixel, w| add(pixel, if w == 1.0 { val } else { val * w }));
}

/// What a chain of non-diffuse bounces counts on its way, besides the diffuse hit it ends at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChainLight {
    /// Nothing (final-gather rays: emission they meet is direct light or a caustic, counted elsewhere).
    Skip,
    /// Emission it sees, and direct light at every rough (non-delta) hit: a light sample with a shadow
    /// ray, MIS-weighted against the BSDF samples that find the same lights, as the path tracer does.
    /// A sampled direction never finds a point or distant light, so without the light sample their
    /// glints on rough metal would be missing.
    Count,
    /// As `Count`, and a first hit on smooth glass or water follows both of its lobes (below): a camera
    /// ray's chain, so with `render.hide_emitters` what it sees directly (along its first segment and
    /// on through null surfaces and thin panes) is left out.
    CountSplitFirst,
    /// As `Count`, along the camera's own line of sight (the other lobe of a thin pane that
    /// `CountSplitFirst` split at the camera's first hit, its transmission): with
    /// `render.hide_emitters` what it sees straight on is left out.
    CountSeenDirectly,
}

/// Follows `ray` (throughput `beta`) through non-diffuse surfaces, at most `render.max_depth + 1`
/// hits, to the first diffuse one. Returns the light seen on the way as `light` asks (emission, the
/// diffuse hit's own included, and direct light at rough hits), weighted by the throughput, and the
/// diffuse hit, if the chain reached one.
///
/// With `ChainLight::CountSplitFirst`, a first hit on smooth glass or water follows both of its lobes
/// for the light seen on the way: the lobe sampled (which alone leads to the diffuse hit returned) and
/// the other one, each weighted by its Fresnel share instead of being picked with that probability. A
/// light mirrored in a water surface is then seen by every sample that points at its reflection rather
/// than by one in twenty-five of them; the expectation is unchanged (both lobes' shares add up to the
/// whole), its variance falls.
///
/// With `glossy` (a camera chain of the photon mappers), the first glossy hit the chain meets past a
/// mirror or glass that breaks the camera's line of sight also gathers the photons of delta lights
/// that reached it past a mirror or glass (`GlossyGather`), counted as light seen on the way.
///
/// `sigma`: the absorption of the medium `ray` starts in (`Scene::sigma_next`; zero for a camera
/// ray).
#[allow(clippy::too_many_arguments)]
pub fn specular_chain(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    ray: crate::math::Ray,
    sigma: crate::color::Rgb,
    beta: crate::color::Rgb,
    rng: &mut crate::math::Rng,
    c: &mut Counters,
    light: ChainLight,
    glossy: Option<&GlossyGather>,
) -> (crate::color::Rgb, Option<ChainEnd>) {
    chain_from(scene, tracer, ray, sigma, beta, rng, c, light, 0, glossy)
}

/// The light of point, spot and distant lights that reaches a glossy surface past a mirror or glass
/// (L S⁺ (S|G)* G), for a camera path that reaches that surface past a mirror or glass (E S⁺ G): the
/// paths E S (S|G)* G (S|G)* S L through no diffuse surface. Nothing else finds them: the camera chain's
/// BSDF samples never reach a delta light, its light samples at glossy hits see only light that came
/// straight from the light, and light tracing (the glossy splats) links to the camera only a glossy
/// surface the camera sees directly. The photons are the caustic pass's (`PhotonMaps::glossy_photons`),
/// counted through the glossy BSDF for their own directions (`PhotonMap::glossy_radiance`). Each such
/// path is counted once: at the first glossy hit of the camera chain, and only where the camera does
/// not see that hit directly (through null surfaces and thin panes alone), where the splats count it.
pub struct GlossyGather<'a> {
    pub map: &'a crate::photon::estimate::PhotonMap,
    /// The k nearest photons (the fixed photon map) or a fixed radius (the progressive passes).
    pub reach: crate::photon::estimate::Reach,
    /// Multiply what a gather finds by an estimate of 1 / (the part of its disc over a surface with a
    /// glossy lobe), as the photon maps' gathers do (`edges::inverse_coverage`).
    pub edges: bool,
}

impl GlossyGather<'_> {
    /// Radiance `lobe` scatters towards `wo` at `si` from the photons whose paths fit in `budget`
    /// scattering events (edge probes' rays go to `c`).
    #[allow(clippy::too_many_arguments)]
    pub fn radiance(
        &self,
        scene: &crate::scene::Scene,
        tracer: &dyn crate::accel::Tracer,
        si: &crate::scene::SurfaceHit,
        wo: glam::Vec3,
        lobe: &crate::scene::Material,
        budget: u32,
        rng: &mut crate::math::Rng,
        c: &mut Counters,
    ) -> crate::color::Rgb {
        thread_local! {
            static SCRATCH: std::cell::RefCell<crate::photon::kdtree::KnnResult> =
                std::cell::RefCell::new(crate::photon::kdtree::KnnResult::new());
        }
        let (l, r) = SCRATCH.with(|s| self.map.glossy_radiance(si, wo, lobe, self.reach, budget, &mut s.borrow_mut()));
        if !self.edges || l == crate::color::Rgb::ZERO {
            return l;
        }
        let cone_k = match self.reach {
            crate::photon::estimate::Reach::Knn(g) => g.cone_k,
            crate::photon::estimate::Reach::Radius(_) => 0.0,
        };
        l * photon_map::edge_factor(scene, tracer, si, wo, r, cone_k, rng, c, edges::holds_glossy_photons)
    }
}

/// `specular_chain` for a ray leaving its `first`-th bounce (0: from the camera): its hits count their
/// bounces from there, against `render.max_depth`. The lobe a split leaves unsampled goes on from
/// bounce 1 (counted from 0, a path through a glass ball at max_depth 1 saw the sky through it).
#[allow(clippy::too_many_arguments)]
fn chain_from(
    scene: &crate::scene::Scene,
    tracer: &dyn crate::accel::Tracer,
    mut ray: crate::math::Ray,
    mut sigma: crate::color::Rgb,
    mut beta: crate::color::Rgb,
    rng: &mut crate::math::Rng,
    c: &mut Counters,
    light: ChainLight,
    first: u32,
    glossy: Option<&GlossyGather>,
) -> (crate::color::Rgb, Option<ChainEnd>) {
    use crate::color::Rgb;
    let count = light != ChainLight::Skip;
    // Whether a glossy hit came before (only the first one gathers `glossy`'s photons).
    let mut past_glossy = false;
    let mut emitted = Rgb::ZERO;
    // Light along the sampled lobe after a split is weighted by its share, not divided by its
    // probability: `beta * emit_scale` (the returned hit keeps `beta`).
    let mut emit_scale = 1.0f32;
    // The last bounce: delta (emission found after it counts in full) or rough, with its BSDF density
    // and origin for the MIS weight against the light sample taken there.
    let (mut specular, mut prev_pdf, mut prev_p) = (true, 0.0f32, ray.o);
    // Still the camera's own line of sight (only null surfaces and thin panes crossed so far)?
    let mut view = match light {
        ChainLight::CountSplitFirst | ChainLight::CountSeenDirectly => LineOfSight::CAMERA,
        ChainLight::Skip | ChainLight::Count => LineOfSight::NOT,
    };
    for depth in first..=scene.render.max_depth {
        c.rays += 1;
        let (found, tr) = view.trace_through(scene, tracer, &ray, rng, c);
        beta *= tr * scene.absorbed_to(sigma, &ray, found.as_ref().map(|f| f.0.hit.t));
        let hidden = view.hides(scene);
        if count && !hidden {
            let sampled = (!specular).then_some((prev_pdf, prev_p));
            let (le, w) = direct::emission_seen(scene, found.as_ref().map(|f| &f.0), ray.d, sampled);
            if le != Rgb::ZERO {
                emitted += beta * emit_scale * le * w;
            }
        }
        let Some((crate::accel::Interaction { si, wo, .. }, mut mat)) = found else {
            break;
        };
        // Where photons are held the chain ends, except that a plastic's coat lobe, taken by its share
        // of the choice, carries the chain on (the end then weighs 1 / the base's share). A smooth coat's
        // mirror is the lobe `sample` draws for the same choice; a rough coat's glossy lobe is followed
        // alone, as a rough metal is, weighed by 1 / its share.
        let mut forced_uc = None;
        if mat.holds_photons() {
            let share = mat.coat_share(wo, si.ns);
            let uc = if share > 0.0 { rng.next_f32() } else { 1.0 };
            if uc >= share {
                return (emitted, Some(ChainEnd { si, wo, beta: beta / (1.0 - share), depth, mat, sigma }));
            }
            match mat.coat_lobe() {
                Some(coat) => {
                    beta /= share;
                    mat = coat;
                }
                None => forced_uc = Some(uc),
            }
        }
        if !mat.holds_photons() && count && !mat.is_delta() && depth < scene.render.max_depth {
            let mis = direct::DirectStrategy::Mis;
            emitted +=
                beta * emit_scale * direct::estimate_direct_with(scene, tracer, &si, wo, &mat, sigma, rng, c, mis);
            if let Some(g) = glossy.filter(|_| !past_glossy && view != LineOfSight::CAMERA) {
                let budget = scene.render.max_depth - depth;
                emitted += beta * emit_scale * g.radiance(scene, tracer, &si, wo, &mat, budget, rng, c);
            }
        }
        past_glossy |= !mat.holds_photons() && !mat.is_delta();
        let (u, uc) = (rng.next_2d(), forced_uc.unwrap_or_else(|| rng.next_f32()));
        let Some((bs, next)) = si.scatter_with(&mat, wo, u, uc, crate::scene::TransportMode::Radiance) else {
            break;
        };
        let before = view;
        view = before.after(&mat, bs.transmitted);
        // A smooth dielectric's two delta lobes (bs.pdf is then the lobe's probability).
        let two_lobes = || bs.delta && mat.transmits();
        if light == ChainLight::CountSplitFirst && depth == 0 && bs.pdf < 1.0 && two_lobes() {
            // The other lobe: reflection is chosen for uc < F, so uc = 0 forces it and uc = 1 refraction.
            let other_uc = if bs.transmitted { 0.0 } else { 1.0 };
            if let Some((other, other_ray)) =
                si.scatter_with(&mat, wo, u, other_uc, crate::scene::TransportMode::Radiance)
            {
                let share = other.weight * other.pdf;
                let light = if before.after(&mat, other.transmitted) == LineOfSight::CAMERA {
                    ChainLight::CountSeenDirectly
                } else {
                    ChainLight::Count
                };
                let other_sigma = scene.sigma_next(&si, other_ray.d, sigma);
                emitted +=
                    chain_from(scene, tracer, other_ray, other_sigma, beta * share, rng, c, light, depth + 1, glossy).0;
            }
            emit_scale = bs.pdf;
        }
        beta *= bs.weight;
        if beta == Rgb::ZERO {
            break;
        }
        (specular, prev_pdf, prev_p) = (bs.delta, bs.pdf, si.p);
        sigma = scene.sigma_next(&si, next.d, sigma);
        ray = next;
    }
    (emitted, None)
}
