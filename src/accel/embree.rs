//! Embree 3 backend (through the `embree3` crate's raw `sys` API): one BVH over every triangle mesh and
//! analytic sphere (user geometry with an exact f64 intersector). The only module with unsafe code.
#![allow(unsafe_code)]

use super::{sphere_root, Hit, Tracer};
use crate::math::Ray;
use crate::scene::{Geometry, Scene};
use embree3::sys::*;
use std::os::raw::c_void;
use std::ptr;

const INVALID: u32 = u32::MAX;

/// A sphere handed to Embree as user data (lives as long as the `Accel`).
#[repr(C)]
struct SphereData {
    center: [f32; 3],
    radius: f32,
}

/// The Embree device and scene; released in `Drop`.
pub struct Accel {
    device: RTCDevice,
    scene: RTCScene,
    // Boxed so each sphere keeps its address (Embree holds the pointer) while the Vec grows.
    #[allow(clippy::vec_box)]
    _spheres: Vec<Box<SphereData>>,
    /// Seconds spent in rtcCommitScene.
    pub build_seconds: f64,
}

// SAFETY: Embree scenes are safe to query from many threads once committed; we never modify after commit.
unsafe impl Send for Accel {}
// SAFETY: as above; all query entry points take &self and Embree's traversal is reentrant.
unsafe impl Sync for Accel {}

#[repr(C, align(64))]
struct Packet16(RTCRayHit16);

fn context() -> RTCIntersectContext {
    RTCIntersectContext { flags: RTCIntersectContextFlags::INCOHERENT, filter: None, instID: [INVALID] }
}

/// Lane accessors for Embree's SoA ray layout (`RTCRayHitN`): field k of lane i is at k·N + i.
mod lane {
    pub const ORG: usize = 0;
    pub const TNEAR: usize = 3;
    pub const DIR: usize = 4;
    pub const TFAR: usize = 8;
    pub const NG: usize = 12;
    pub const U: usize = 15;
    pub const V: usize = 16;
    pub const PRIM: usize = 17;
    pub const GEOM: usize = 18;
    pub const INST: usize = 19;
}

unsafe extern "C" fn sphere_bounds(args: *const RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes a valid argument struct whose user pointer is the SphereData we registered.
    unsafe {
        let a = &*args;
        let s = &*(a.geometryUserPtr as *const SphereData);
        let b = &mut *a.bounds_o;
        let pad = s.radius * (1.0 + 1e-5);
        b.lower_x = s.center[0] - pad;
        b.lower_y = s.center[1] - pad;
        b.lower_z = s.center[2] - pad;
        b.upper_x = s.center[0] + pad;
        b.upper_y = s.center[1] + pad;
        b.upper_z = s.center[2] + pad;
    }
}

/// Reads one ray lane (origin, direction, tnear, tfar) from an SoA block of N rays.
///
/// # Safety
/// `base` must point to at least 9·n floats of a valid RTCRayN block and `i < n`.
unsafe fn read_lane(base: *const f32, n: usize, i: usize) -> ([f32; 3], [f32; 3], f32, f32) {
    // SAFETY: guaranteed by the caller.
    unsafe {
        let g = |k: usize| *base.add(k * n + i);
        (
            [g(lane::ORG), g(lane::ORG + 1), g(lane::ORG + 2)],
            [g(lane::DIR), g(lane::DIR + 1), g(lane::DIR + 2)],
            g(lane::TNEAR),
            g(lane::TFAR),
        )
    }
}

unsafe extern "C" fn sphere_intersect(args: *const RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes N valid lanes of an RTCRayHitN block (SoA, 4-byte fields) and our user data.
    unsafe {
        let a = &*args;
        let n = a.N as usize;
        let s = &*(a.geometryUserPtr as *const SphereData);
        let base = a.rayhit as *mut f32;
        for i in 0..n {
            if *a.valid.add(i) == 0 {
                continue;
            }
            let (o, d, tnear, tfar) = read_lane(base, n, i);
            if let Some(t) = sphere_root(o, d, s.center, s.radius, tnear, tfar) {
                let set = |k: usize, v: f32| *base.add(k * n + i) = v;
                let setu = |k: usize, v: u32| *(base.add(k * n + i) as *mut u32) = v;
                set(lane::TFAR, t);
                for (k, c) in s.center.iter().enumerate() {
                    set(lane::NG + k, o[k] + t * d[k] - c);
                }
                set(lane::U, 0.0);
                set(lane::V, 0.0);
                setu(lane::PRIM, a.primID);
                setu(lane::GEOM, a.geomID);
                setu(lane::INST, (*a.context).instID[0]);
            }
        }
    }
}

unsafe extern "C" fn sphere_occluded(args: *const RTCOccludedFunctionNArguments) {
    // SAFETY: as for sphere_intersect, with an RTCRayN block.
    unsafe {
        let a = &*args;
        let n = a.N as usize;
        let s = &*(a.geometryUserPtr as *const SphereData);
        let base = a.ray as *mut f32;
        for i in 0..n {
            if *a.valid.add(i) == 0 {
                continue;
            }
            let (o, d, tnear, tfar) = read_lane(base, n, i);
            if sphere_root(o, d, s.center, s.radius, tnear, tfar).is_some() {
                *base.add(lane::TFAR * n + i) = f32::NEG_INFINITY;
            }
        }
    }
}

/// Embree's filter for a mesh whose backs are culled (`TriMesh::cull_back`): a hit where the ray meets
/// the triangle from behind its geometric normal (Embree's, which faces as the winding does) is
/// rejected, and the ray goes on.
unsafe extern "C" fn cull_back_faces(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes N lanes of SoA ray and hit blocks (4-byte fields) and their valid mask.
    unsafe {
        let a = &*args;
        let n = a.N as usize;
        let (ray, hit) = (a.ray as *const f32, a.hit as *const f32);
        for i in 0..n {
            if *a.valid.add(i) == 0 {
                continue;
            }
            // RTCRayN: org (3), tnear, dir (3)…; RTCHitN: Ng (3)….
            let facing: f32 = (0..3).map(|k| *ray.add((lane::DIR + k) * n + i) * *hit.add(k * n + i)).sum();
            if facing > 0.0 {
                *a.valid.add(i) = 0;
            }
        }
    }
}

impl Accel {
    /// Builds one Embree scene over all shapes; geometry ID = shape index.
    pub fn new(scene: &Scene) -> Result<Accel, String> {
        // SAFETY: plain Embree C API calls; every handle is checked or released; buffers are sized
        // from the counts we pass, and user data outlives the scene (kept in `_spheres`).
        unsafe {
            let device = rtcNewDevice(ptr::null());
            if device.is_null() {
                return Err("Embree: rtcNewDevice failed".into());
            }
            let rscene = rtcNewScene(device);
            let mut spheres = Vec::new();
            for (si, shape) in scene.shapes.iter().enumerate() {
                let geom = match &shape.geometry {
                    Geometry::Mesh(m) => {
                        let g = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
                        let vb = rtcSetNewGeometryBuffer(
                            g,
                            RTCBufferType::VERTEX,
                            0,
                            RTCFormat::FLOAT3,
                            12,
                            m.positions.len(),
                        ) as *mut f32;
                        let ib =
                            rtcSetNewGeometryBuffer(g, RTCBufferType::INDEX, 0, RTCFormat::UINT3, 12, m.indices.len())
                                as *mut u32;
                        if vb.is_null() || ib.is_null() {
                            rtcReleaseGeometry(g);
                            rtcReleaseScene(rscene);
                            rtcReleaseDevice(device);
                            return Err(format!("Embree: cannot allocate buffers for {}", shape.name));
                        }
                        ptr::copy_nonoverlapping(m.positions.as_ptr() as *const f32, vb, m.positions.len() * 3);
                        ptr::copy_nonoverlapping(m.indices.as_ptr() as *const u32, ib, m.indices.len() * 3);
                        if m.cull_back {
                            rtcSetGeometryIntersectFilterFunction(g, Some(cull_back_faces));
                            rtcSetGeometryOccludedFilterFunction(g, Some(cull_back_faces));
                        }
                        g
                    }
                    Geometry::Sphere { center, radius, .. } => {
                        let data = Box::new(SphereData { center: center.to_array(), radius: *radius });
                        let g = rtcNewGeometry(device, RTCGeometryType::USER);
                        rtcSetGeometryUserPrimitiveCount(g, 1);
                        let up = &*data as *const SphereData as *mut c_void;
                        rtcSetGeometryUserData(g, up);
                        rtcSetGeometryBoundsFunction(g, Some(sphere_bounds), ptr::null_mut());
                        rtcSetGeometryIntersectFunction(g, Some(sphere_intersect));
                        rtcSetGeometryOccludedFunction(g, Some(sphere_occluded));
                        spheres.push(data);
                        g
                    }
                };
                rtcCommitGeometry(geom);
                rtcAttachGeometryByID(rscene, geom, si as u32);
                rtcReleaseGeometry(geom);
            }
            let t0 = std::time::Instant::now();
            rtcCommitScene(rscene);
            let build_seconds = t0.elapsed().as_secs_f64();
            let err = rtcGetDeviceError(device);
            if err != RTCError::NONE {
                rtcReleaseScene(rscene);
                rtcReleaseDevice(device);
                return Err(format!("Embree error {err:?} while building the scene"));
            }
            Ok(Accel { device, scene: rscene, _spheres: spheres, build_seconds })
        }
    }

    /// The baseline for `caustica bench rays`: a bare `rtcIntersect16` loop over rays already laid out
    /// in Embree's SoA packets (a copy of the prepared packet, the call, nothing decoded). Returns hits.
    pub fn raw_intersect16(&self, packets: &RawPackets) -> usize {
        let valid = ValidMask([-1i32; 16]);
        let mut hits = 0;
        for p in &packets.0 {
            let mut q = Packet16(p.0);
            let mut ctx = context();
            // SAFETY: committed scene, 64-byte aligned packet and 16-lane valid mask.
            unsafe { rtcIntersect16(valid.0.as_ptr(), self.scene, &mut ctx, &mut q.0) };
            hits += q.0.hit.geomID.iter().filter(|&&g| g != INVALID).count();
        }
        hits
    }
}

impl Accel {
    /// The baseline for `caustica bench photons`: bare `rtcIntersect1` calls on prepared rays.
    pub fn raw_intersect1(&self, rays: &[RTCRayHit]) -> usize {
        let mut hits = 0;
        for r in rays {
            let mut rh = *r;
            let mut ctx = context();
            // SAFETY: committed scene; rh and ctx are valid for the call.
            unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rh) };
            hits += (rh.hit.geomID != INVALID) as usize;
        }
        hits
    }

    /// Rays in Embree's single-ray layout, prepared outside the timed loop.
    pub fn prepare_single(rays: &[Ray]) -> Vec<RTCRayHit> {
        rays.iter().map(rtc_ray_hit).collect()
    }
}

/// Rays converted ahead of time to Embree's 16-wide SoA packets (for the bare-Embree baseline).
pub struct RawPackets(Vec<Packet16>);

impl RawPackets {
    pub fn new(packets: &[[Ray; 16]]) -> RawPackets {
        RawPackets(packets.iter().map(|p| Packet16(to_packet(p))).collect())
    }
}

/// Lays rays out in one of Embree's SoA packet types (`RTCRayHit8`, `RTCRayHit16`), unused lanes empty.
macro_rules! to_packet {
    ($ty:ty, $rays:expr) => {{
        // SAFETY: Embree's packet structs are plain old data; all-zero is a valid bit pattern.
        let mut p: $ty = unsafe { std::mem::zeroed() };
        for (i, r) in $rays.iter().enumerate() {
            p.ray.org_x[i] = flushed(r.o.x);
            p.ray.org_y[i] = flushed(r.o.y);
            p.ray.org_z[i] = flushed(r.o.z);
            p.ray.dir_x[i] = flushed(r.d.x);
            p.ray.dir_y[i] = flushed(r.d.y);
            p.ray.dir_z[i] = flushed(r.d.z);
            p.ray.tnear[i] = flushed(r.tmin);
            p.ray.tfar[i] = r.tmax;
            p.ray.mask[i] = u32::MAX;
            p.hit.geomID[i] = INVALID;
            p.hit.instID[0][i] = INVALID;
        }
        p
    }};
}

fn to_packet(rays: &[Ray]) -> RTCRayHit16 {
    to_packet!(RTCRayHit16, rays)
}

#[repr(C, align(32))]
struct Packet8(RTCRayHit8);

/// Embree's valid masks must be aligned like their packets (32 bytes for 8 lanes, 64 for 16): its
/// AVX-512 kernels load them with aligned loads. A plain `[i32; N]` is only 4-byte aligned; it was
/// aligned by luck until a change of compiler flags moved it and `rtcIntersect16` crashed.
#[repr(C, align(64))]
struct ValidMask<const N: usize>([i32; N]);
const _: () = assert!(std::mem::align_of::<ValidMask<16>>() >= 64 && std::mem::align_of::<Packet16>() >= 64);

/// Traces up to `W` rays as one Embree packet of width W and decodes the hits.
macro_rules! trace_packet {
    ($self:expr, $rays:expr, $out:expr, $wrap:ident, $ty:ty, $call:ident, $w:expr) => {{
        let mut p = $wrap(to_packet!($ty, $rays));
        let mut mask = ValidMask([0i32; $w]);
        for (m, r) in mask.0.iter_mut().zip($rays) {
            *m = if valid(r) { -1 } else { 0 };
        }
        let mut ctx = context();
        // SAFETY: committed scene, packet and valid mask aligned to 64 bytes (at least their width),
        // the mask covering only filled lanes.
        unsafe { $call(mask.0.as_ptr(), $self.scene, &mut ctx, &mut p.0) };
        let mask = mask.0;
        let h = &p.0.hit;
        for (i, o) in $out.iter_mut().enumerate() {
            *o = (mask[i] != 0 && h.geomID[i] != INVALID).then_some(Hit {
                t: p.0.ray.tfar[i],
                u: h.u[i],
                v: h.v[i],
                shape: h.geomID[i],
                prim: h.primID[i],
            });
        }
    }};
}

/// Embree (Debian's build keeps its assertions) aborts the process on a ray with NaN or huge values;
/// such rays are answered "no hit" here instead.
fn valid(r: &Ray) -> bool {
    const LARGE: f32 = 1.8e18;
    r.o.is_finite()
        && r.d.is_finite()
        && r.o.abs().max_element() <= LARGE
        && r.d.abs().max_element() <= LARGE
        && r.tmin >= 0.0
        && !r.tmax.is_nan()
}

/// A single ray with an empty hit record, ready for `rtcIntersect1`.
fn rtc_ray_hit(r: &Ray) -> RTCRayHit {
    RTCRayHit {
        ray: rtc_ray(r),
        hit: RTCHit {
            Ng_x: 0.0,
            Ng_y: 0.0,
            Ng_z: 0.0,
            u: 0.0,
            v: 0.0,
            primID: INVALID,
            geomID: INVALID,
            instID: [INVALID],
        },
    }
}

/// A ray component as Embree gets it: subnormal values (nonzero, below `f32::MIN_POSITIVE` in size) as
/// zero. Debian's Embree aborted on its `ray.valid()` assertion for a ray whose origin and direction each
/// had a subnormal component (a light placed at y = 1e-40 over a floor); to any geometry they are zero.
#[inline(always)]
fn flushed(x: f32) -> f32 {
    if x.abs() < f32::MIN_POSITIVE {
        0.0
    } else {
        x
    }
}

fn rtc_ray(r: &Ray) -> RTCRay {
    RTCRay {
        org_x: flushed(r.o.x),
        org_y: flushed(r.o.y),
        org_z: flushed(r.o.z),
        tnear: flushed(r.tmin),
        dir_x: flushed(r.d.x),
        dir_y: flushed(r.d.y),
        dir_z: flushed(r.d.z),
        time: 0.0,
        tfar: r.tmax,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl Tracer for Accel {
    fn intersect(&self, r: &Ray) -> Option<Hit> {
        if !valid(r) {
            return None;
        }
        let mut rh = rtc_ray_hit(r);
        let mut ctx = context();
        // SAFETY: committed scene; rh and ctx are valid for the call.
        unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geomID != INVALID).then_some(Hit {
            t: rh.ray.tfar,
            u: rh.hit.u,
            v: rh.hit.v,
            shape: rh.hit.geomID,
            prim: rh.hit.primID,
        })
    }

    fn occluded(&self, r: &Ray) -> bool {
        if !valid(r) {
            return false;
        }
        let mut ray = rtc_ray(r);
        let mut ctx = context();
        // SAFETY: committed scene; ray and ctx are valid for the call.
        unsafe { rtcOccluded1(self.scene, &mut ctx, &mut ray) };
        ray.tfar == f32::NEG_INFINITY
    }

    fn intersect_packet(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert!(rays.len() <= 16 && out.len() == rays.len());
        if rays.len() <= 8 {
            trace_packet!(self, rays, out, Packet8, RTCRayHit8, rtcIntersect8, 8);
        } else {
            trace_packet!(self, rays, out, Packet16, RTCRayHit16, rtcIntersect16, 16);
        }
    }
}

impl Drop for Accel {
    fn drop(&mut self) {
        // SAFETY: handles were created in `new` and are released exactly once here.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}
