//! The few Embree 3 entry points the bench needs, bound by hand (`/usr/include/embree3`,
//! version 3.13), and a safe scene wrapper. One triangle geometry, default (medium) build
//! quality, `rtcIntersect1` / `rtcOccluded1` with an incoherent context: one ray per call.

use std::ffi::c_void;
use std::os::raw::{c_char, c_int, c_uint};

type RtcDevice = *mut c_void;
type RtcScene = *mut c_void;
type RtcGeometry = *mut c_void;

const RTC_GEOMETRY_TYPE_TRIANGLE: c_int = 0;
const RTC_BUFFER_TYPE_INDEX: c_int = 0;
const RTC_BUFFER_TYPE_VERTEX: c_int = 1;
const RTC_FORMAT_UINT3: c_int = 0x5003;
const RTC_FORMAT_FLOAT3: c_int = 0x9003;
const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;
const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: c_int = 0;

/// `struct RTCIntersectContext` (RTC_MAX_INSTANCE_LEVEL_COUNT 1, RTC_MIN_WIDTH 0): 24 bytes.
#[repr(C)]
struct RtcIntersectContext {
    flags: c_int,
    filter: *const c_void,
    inst_id: [c_uint; 1],
}

/// `struct RTCRay`.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RtcRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: c_uint,
    id: c_uint,
    flags: c_uint,
}

/// `struct RTCHit`.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RtcHit {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: c_uint,
    geom_id: c_uint,
    inst_id: [c_uint; 1],
}

/// `struct RTCRayHit`: 80 bytes, the hit at offset 48.
#[repr(C, align(16))]
struct RtcRayHit {
    ray: RtcRay,
    hit: RtcHit,
}

const _: () = assert!(std::mem::size_of::<RtcIntersectContext>() == 24);
const _: () = assert!(std::mem::size_of::<RtcRayHit>() == 80);
const _: () = assert!(std::mem::offset_of!(RtcRayHit, hit) == 48);

unsafe extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RtcDevice;
    fn rtcReleaseDevice(device: RtcDevice);
    fn rtcNewScene(device: RtcDevice) -> RtcScene;
    fn rtcReleaseScene(scene: RtcScene);
    fn rtcNewGeometry(device: RtcDevice, kind: c_int) -> RtcGeometry;
    fn rtcReleaseGeometry(geometry: RtcGeometry);
    fn rtcSetNewGeometryBuffer(
        geometry: RtcGeometry,
        kind: c_int,
        slot: c_uint,
        format: c_int,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: RtcGeometry);
    fn rtcAttachGeometry(scene: RtcScene, geometry: RtcGeometry) -> c_uint;
    fn rtcCommitScene(scene: RtcScene);
    fn rtcIntersect1(scene: RtcScene, context: *mut RtcIntersectContext, rayhit: *mut RtcRayHit);
    fn rtcOccluded1(scene: RtcScene, context: *mut RtcIntersectContext, ray: *mut RtcRay);
}

/// A committed Embree scene of one triangle mesh.
pub struct Embree {
    device: RtcDevice,
    scene: RtcScene,
}

impl Embree {
    /// Builds the scene over `triangles` (primitive ids = indices into `triangles`).
    pub fn new(triangles: &[[[f32; 3]; 3]]) -> Result<Embree, String> {
        // SAFETY: a null config string is allowed ("default configuration").
        let device = unsafe { rtcNewDevice(std::ptr::null()) };
        if device.is_null() {
            return Err("rtcNewDevice failed".into());
        }
        // SAFETY: `device` is a valid device; the buffers Embree returns hold exactly the item
        // counts asked for (it pads them itself), and are written in bounds below.
        unsafe {
            let scene = rtcNewScene(device);
            let geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
            let n = triangles.len();
            let vertices = rtcSetNewGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_VERTEX,
                0,
                RTC_FORMAT_FLOAT3,
                12,
                3 * n,
            ) as *mut [f32; 3];
            let indices = rtcSetNewGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                12,
                n,
            ) as *mut [u32; 3];
            if scene.is_null() || geometry.is_null() || vertices.is_null() || indices.is_null() {
                rtcReleaseDevice(device);
                return Err("Embree scene setup failed".into());
            }
            for (i, t) in triangles.iter().enumerate() {
                for (k, p) in t.iter().enumerate() {
                    vertices.add(3 * i + k).write(*p);
                }
                let b = 3 * i as u32;
                indices.add(i).write([b, b + 1, b + 2]);
            }
            rtcCommitGeometry(geometry);
            rtcAttachGeometry(scene, geometry);
            rtcReleaseGeometry(geometry);
            rtcCommitScene(scene);
            Ok(Embree { device, scene })
        }
    }

    fn context() -> RtcIntersectContext {
        RtcIntersectContext {
            flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: std::ptr::null(),
            inst_id: [RTC_INVALID_GEOMETRY_ID],
        }
    }

    fn ray(origin: [f32; 3], dir: [f32; 3], t_min: f32, t_max: f32) -> RtcRay {
        RtcRay {
            org: origin,
            tnear: t_min,
            dir,
            time: 0.0,
            tfar: t_max,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// The closest hit `(t, primitive)` with `t` in `[t_min, t_max]`.
    pub fn closest_hit(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, u32)> {
        let mut context = Self::context();
        let mut rh = RtcRayHit {
            ray: Self::ray(origin, dir, t_min, t_max),
            hit: RtcHit {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: RTC_INVALID_GEOMETRY_ID,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
        };
        // SAFETY: the scene is committed; context and ray-hit are valid, aligned structs.
        unsafe { rtcIntersect1(self.scene, &mut context, &mut rh) };
        (rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID).then_some((rh.ray.tfar, rh.hit.prim_id))
    }

    /// Whether anything is hit with `t` in `[t_min, t_max]`.
    pub fn any_hit(&self, origin: [f32; 3], dir: [f32; 3], t_min: f32, t_max: f32) -> bool {
        let mut context = Self::context();
        let mut ray = Self::ray(origin, dir, t_min, t_max);
        // SAFETY: as in `closest_hit`.
        unsafe { rtcOccluded1(self.scene, &mut context, &mut ray) };
        // Embree sets tfar to -inf for an occluded ray.
        ray.tfar == f32::NEG_INFINITY
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        // SAFETY: both handles were created by `new` and are released once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}
