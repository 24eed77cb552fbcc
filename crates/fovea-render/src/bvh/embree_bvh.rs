//! Intel Embree 3 backend (cargo feature `embree`; needs the system library, Debian
//! `libembree-dev`). One triangle geometry holds every distinct scene triangle in
//! [`Triangles`] order (exact duplicates left out, see [`Distinct`]), so Embree's `primID`
//! is our triangle index, or indexes the kept triangles' list when there were duplicates. Queries use `rtcIntersect1` / `rtcOccluded1`
//! through the raw bindings of the `embree` crate (its safe wrapper borrows the device and
//! scene for a lifetime, which does not fit a long-lived renderer).

use embree::sys;

use super::{Backend, Distinct, Hit, Ray, RayCaster, Triangles};
use crate::error::{RenderError, Result};

/// Embree device + committed scene.
pub struct EmbreeCaster {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    /// The scene index of each `primID` (`None`: the identity).
    original: Option<Vec<u32>>,
}

// Embree scenes are safe to query from many threads once committed; the handles are only
// released in `drop`.
unsafe impl Send for EmbreeCaster {}
unsafe impl Sync for EmbreeCaster {}

const INVALID_ID: u32 = u32::MAX;

impl EmbreeCaster {
    /// Builds the scene (high build quality) over the distinct triangles.
    pub fn new(tris: &Triangles) -> Result<Self> {
        Self::new_distinct(tris, &Distinct::of(&tris.verts))
    }

    /// Builds the scene over the triangles `distinct` keeps.
    pub fn new_distinct(tris: &Triangles, distinct: &Distinct) -> Result<Self> {
        unsafe {
            let device = sys::rtcNewDevice(std::ptr::null());
            if device.is_null() {
                return Err(RenderError::Unsupported(
                    "Embree could not create a device (is libembree3 installed?)".into(),
                ));
            }
            let scene = sys::rtcNewScene(device);
            sys::rtcSetSceneBuildQuality(scene, sys::RTCBuildQuality::HIGH);
            let geom = sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE);
            let n = distinct.len(tris.len());
            let vb = sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTCBufferType::VERTEX,
                0,
                sys::RTCFormat::FLOAT3,
                12,
                3 * n,
            ) as *mut f32;
            let ib = sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTCBufferType::INDEX,
                0,
                sys::RTCFormat::UINT3,
                12,
                n,
            ) as *mut u32;
            if vb.is_null() || ib.is_null() {
                sys::rtcReleaseGeometry(geom);
                sys::rtcReleaseScene(scene);
                sys::rtcReleaseDevice(device);
                return Err(RenderError::ResourceLimit {
                    what: "Embree geometry buffers".into(),
                    needed: format!("{n} triangles"),
                    limit: "what Embree could allocate".into(),
                });
            }
            let v = std::slice::from_raw_parts_mut(vb, 9 * n);
            let ix = std::slice::from_raw_parts_mut(ib, 3 * n);
            for k in 0..n {
                let t = &tris.verts[distinct.original(k as u32) as usize];
                for c in 0..3 {
                    v[9 * k + 3 * c..9 * k + 3 * c + 3].copy_from_slice(&t[c].to_array());
                    ix[3 * k + c] = (3 * k + c) as u32;
                }
            }
            sys::rtcCommitGeometry(geom);
            sys::rtcAttachGeometry(scene, geom);
            sys::rtcReleaseGeometry(geom);
            sys::rtcCommitScene(scene);
            Ok(Self {
                device,
                scene,
                original: distinct.kept.clone(),
            })
        }
    }

    /// The scene's triangle index of Embree's `primID`.
    #[inline]
    fn scene_index(&self, prim: u32) -> u32 {
        self.original.as_ref().map_or(prim, |o| o[prim as usize])
    }

    #[inline]
    fn rtc_ray(ray: &Ray) -> sys::RTCRay {
        sys::RTCRay {
            org_x: ray.origin.x,
            org_y: ray.origin.y,
            org_z: ray.origin.z,
            tnear: ray.t_min,
            dir_x: ray.dir.x,
            dir_y: ray.dir.y,
            dir_z: ray.dir.z,
            time: 0.0,
            tfar: ray.t_max,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    #[inline]
    fn context() -> sys::RTCIntersectContext {
        Self::context_with(sys::RTCIntersectContextFlags::INCOHERENT)
    }

    #[inline]
    fn context_with(flags: sys::RTCIntersectContextFlags) -> sys::RTCIntersectContext {
        sys::RTCIntersectContext {
            flags,
            filter: None,
            instID: [INVALID_ID],
        }
    }

    #[inline]
    fn rtc_ray_hit(ray: &Ray) -> sys::RTCRayHit {
        sys::RTCRayHit {
            ray: Self::rtc_ray(ray),
            hit: sys::RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: INVALID_ID,
                geomID: INVALID_ID,
                instID: [INVALID_ID],
            },
        }
    }
}

impl Drop for EmbreeCaster {
    fn drop(&mut self) {
        unsafe {
            sys::rtcReleaseScene(self.scene);
            sys::rtcReleaseDevice(self.device);
        }
    }
}

impl RayCaster for EmbreeCaster {
    fn backend(&self) -> Backend {
        Backend::Embree
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut rh = Self::rtc_ray_hit(ray);
        let mut ctx = Self::context();
        unsafe { sys::rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geomID != INVALID_ID).then(|| Hit {
            t: rh.ray.tfar,
            tri: self.scene_index(rh.hit.primID),
            bary: glam::Vec2::new(rh.hit.u, rh.hit.v),
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let mut r = Self::rtc_ray(ray);
        let mut ctx = Self::context();
        unsafe { sys::rtcOccluded1(self.scene, &mut ctx, &mut r) };
        // Embree sets tfar to −∞ when the ray is occluded.
        r.tfar == f32::NEG_INFINITY
    }

    /// One `rtcIntersect1M` stream with the coherent flag: Embree gathers the rays into
    /// packets and traverses them together.
    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        let mut rh: Vec<sys::RTCRayHit> = rays.iter().map(Self::rtc_ray_hit).collect();
        let mut ctx = Self::context_with(sys::RTCIntersectContextFlags::COHERENT);
        for chunk in rh.chunks_mut(u32::MAX as usize) {
            // SAFETY: `chunk` is `len` contiguous, initialised RTCRayHit structs with the
            // stride given; the scene is committed and outlives the call.
            unsafe {
                sys::rtcIntersect1M(
                    self.scene,
                    &mut ctx,
                    chunk.as_mut_ptr(),
                    chunk.len() as u32,
                    std::mem::size_of::<sys::RTCRayHit>(),
                )
            };
        }
        for (o, r) in out.iter_mut().zip(&rh) {
            *o = (r.hit.geomID != INVALID_ID).then(|| Hit {
                t: r.ray.tfar,
                tri: self.scene_index(r.hit.primID),
                bary: glam::Vec2::new(r.hit.u, r.hit.v),
            });
        }
    }

    /// One `rtcOccluded1M` stream with the coherent flag (the renderer's batches are the
    /// shadow rays of neighbouring samples towards one light).
    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        let mut rs: Vec<sys::RTCRay> = rays.iter().map(Self::rtc_ray).collect();
        let mut ctx = Self::context_with(sys::RTCIntersectContextFlags::COHERENT);
        for chunk in rs.chunks_mut(u32::MAX as usize) {
            // SAFETY: as in `intersect_batch`, for RTCRay.
            unsafe {
                sys::rtcOccluded1M(
                    self.scene,
                    &mut ctx,
                    chunk.as_mut_ptr(),
                    chunk.len() as u32,
                    std::mem::size_of::<sys::RTCRay>(),
                )
            };
        }
        for (o, r) in out.iter_mut().zip(&rs) {
            *o = r.tfar == f32::NEG_INFINITY;
        }
    }
}
