//! The scene's surfaces on the GPU (`shaders/surface.wgsl`): each primary ray generated and
//! traced as [`crate::ray_generation`] does, and the G-buffer record of its hit interpolated
//! on the device — `fovea_render::trace::surface`, step for step — so that the CPU no longer
//! interpolates normals, UVs, materials and textures per sample.
//!
//! [`GpuSurfaces::new`] uploads, once per world, beside the tracer's BVH and triangles:
//!
//! * per triangle of the world's list ([`SurfaceTriGpu`]): its three vertices' indices, its
//!   material, its position in the BVH's leaf order, its UV units per metre
//!   (`World::uv_per_metre`, the ray cone's scale) and which attributes its mesh has;
//! * per vertex ([`SurfaceVertexGpu`]): the normal, UV, tangent (with the bitangent's sign)
//!   and colour of every mesh, concatenated;
//! * per material ([`SurfaceMaterialGpu`]): the factors, and each texture as its first mip
//!   level and level count;
//! * the textures' mip chains — the CPU's own box-filtered levels
//!   (`fovea_render::scene::Texture::level`), linear RGBA f32 — in one texel buffer (an
//!   atlas of levels, each addressed by its [`MipGpu`] record);
//! * the model's constants (`fovea_render::trace::model`, [`SurfaceModelGpu`]).
//!
//! Every buffer is checked against the adapter's binding limit before anything is allocated,
//! and the pass needs ten storage buffers in one stage: textures larger than a binding
//! ([`GpuError::AdapterTooSmall`]) or a device that offers fewer buffers
//! ([`GpuError::Unsupported`]) are refused here, and the caller interpolates on the CPU
//! instead.

use bytemuck::{Pod, Zeroable};
use fovea_render::trace::{model, GSample, MISS as MISS_MATERIAL};
use fovea_render::world::World;
use glam::Vec3;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::ray_generation::{direction, polar_offset, RayGenCamera};
use crate::shaders::ShaderSource;
use crate::trace::{GpuTracer, TraceTimes};
use crate::transfer::upload;

/// The module: `trace.wgsl` (the traversal) and `ray_generation.wgsl` (the camera's ray) with
/// `surface.wgsl` appended; the pass creates pipelines for its own entry points only
/// ([`ENTRY_POINTS`]), not for the four those files bring along.
pub const SHADER: ShaderSource = ShaderSource {
    file: "surface.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/trace.wgsl"),
        include_str!("../shaders/ray_generation.wgsl"),
        include_str!("../shaders/surface.wgsl")
    ),
    entry_points: &[
        "closest_hit",
        "any_hit",
        "closest_hit_polar",
        "closest_hit_screen",
        "polar_point_check",
        "surface_polar",
        "surface_screen",
    ],
    uniform: ("SurfaceModel", std::mem::size_of::<SurfaceModelGpu>()),
};

/// The surface pass's own entry points, the pipelines it creates.
pub const ENTRY_POINTS: [&str; 2] = ["surface_polar", "surface_screen"];

/// Storage buffers the surface pass binds in its one stage (the BVH's three, the rays, the
/// records, and the five of the surfaces).
pub const STORAGE_BUFFERS: u32 = 10;

/// A primary ray as the surface pass reads it (`SurfaceRay`): its screen point — a polar
/// ray's fixed-point offset from the camera block's centre
/// ([`GpuPolarRay::offset_q`](crate::GpuPolarRay)), or `(x_px, y_px)` from the screen's
/// origin as f32 bits — and its cone's angle, radians.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSurfaceRay {
    /// The offset's x (polar, `i32` bits) or `x_px` (screen, `f32` bits).
    pub a: u32,
    /// The offset's y (polar) or `y_px` (screen).
    pub b: u32,
    /// The cone's angle, radians.
    pub spread: f32,
}

impl GpuSurfaceRay {
    /// A polar ray at `r_px` pixels from the camera block's centre and `turn` turns, its
    /// cone `spread_rad` wide (errors as [`GpuPolarRay::new`](crate::GpuPolarRay::new)).
    pub fn polar(r_px: f64, turn: f64, spread_rad: f32) -> Result<Self> {
        let [x, y] = crate::GpuPolarRay::new(r_px, turn)?.offset_q;
        Ok(Self {
            a: x as u32,
            b: y as u32,
            spread: spread_rad,
        })
    }

    /// The polar ray whose offset `a`, `b` hold.
    fn as_polar(&self) -> crate::GpuPolarRay {
        crate::GpuPolarRay {
            offset_q: [self.a as i32, self.b as i32],
        }
    }

    /// The screen point `a`, `b` hold, pixels.
    fn as_screen(&self) -> [f32; 2] {
        [f32::from_bits(self.a), f32::from_bits(self.b)]
    }

    /// A screen-aligned ray through `(x_px, y_px)`, rounded to f32 as `EyeCamera::ray`
    /// rounds them, its cone `spread_rad` wide.
    pub fn screen(x_px: f64, y_px: f64, spread_rad: f32) -> Self {
        Self {
            a: (x_px as f32).to_bits(),
            b: (y_px as f32).to_bits(),
            spread: spread_rad,
        }
    }
}

/// A triangle's surface record (`SurfaceTri`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SurfaceTriGpu {
    /// Its vertices in the vertex buffer.
    pub v: [u32; 3],
    /// Its material.
    pub material: u32,
    /// Its position in the BVH's leaf order.
    pub slot: u32,
    /// UV units per metre.
    pub uv_per_metre: f32,
    /// [`HAS_NORMALS`] | [`HAS_UVS`] | [`HAS_TANGENTS`] | [`HAS_COLORS`] of its mesh.
    pub flags: u32,
    _pad: u32,
}

/// The mesh has vertex normals.
pub const HAS_NORMALS: u32 = 1;
/// The mesh has UVs.
pub const HAS_UVS: u32 = 2;
/// The mesh has tangents.
pub const HAS_TANGENTS: u32 = 4;
/// The mesh has vertex colours.
pub const HAS_COLORS: u32 = 8;

/// A vertex's attributes (`SurfaceVertex`), zero where its mesh has none.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SurfaceVertexGpu {
    /// Shading normal.
    pub normal: [f32; 3],
    /// Texture coordinate u.
    pub u: f32,
    /// Tangent, and the bitangent's sign in w.
    pub tangent: [f32; 4],
    /// Colour, linear RGB.
    pub color: [f32; 3],
    /// Texture coordinate v.
    pub v: f32,
}

/// A material (`SurfaceMaterial`): its factors, and each texture as its first level in the
/// mip table and its level count (0: none).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SurfaceMaterialGpu {
    /// Base colour factor.
    pub base_color: [f32; 3],
    /// Metalness factor.
    pub metallic: f32,
    /// Dielectric specular reflectance.
    pub specular: [f32; 3],
    /// Perceptual roughness factor.
    pub roughness: f32,
    /// Emitted radiance.
    pub emissive: [f32; 3],
    /// The normal map's XY scale.
    pub normal_scale: f32,
    /// Base colour texture: first level, level count.
    pub base: [u32; 2],
    /// Metallic-roughness texture: first level, level count.
    pub metallic_roughness: [u32; 2],
    /// Normal map: first level, level count.
    pub normal_map: [u32; 2],
    _pad: [u32; 2],
}

/// A mip level (`Mip`): its first texel in the texel buffer, its size.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MipGpu {
    /// First texel.
    pub offset: u32,
    /// Width, texels.
    pub width: u32,
    /// Height, texels.
    pub height: u32,
    _pad: u32,
}

/// The model's constants (`SurfaceModel`), from `fovea_render::trace::model`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SurfaceModelGpu {
    /// [`model::MIN_COS`].
    pub min_cos: f32,
    /// [`model::MIN_FOOTPRINT_TEXELS`].
    pub min_footprint_texels: f32,
    /// [`model::TRILINEAR_MIN_FRACTION`].
    pub trilinear_min_fraction: f32,
    /// [`model::MIN_ROUGHNESS`].
    pub min_roughness: f32,
    /// [`model::TANGENT_DET_FLOOR`].
    pub tangent_det_floor: f32,
    _pad: [f32; 3],
}

impl SurfaceModelGpu {
    /// The renderer's model.
    pub const RENDERER: SurfaceModelGpu = SurfaceModelGpu {
        min_cos: model::MIN_COS,
        min_footprint_texels: model::MIN_FOOTPRINT_TEXELS,
        trilinear_min_fraction: model::TRILINEAR_MIN_FRACTION,
        min_roughness: model::MIN_ROUGHNESS,
        tangent_det_floor: model::TANGENT_DET_FLOOR,
        _pad: [0.0; 3],
    };
}

/// The G-buffer record as the shader writes it (`GRecord`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct GRecordGpu {
    pub(crate) position: [f32; 3],
    pub(crate) t: f32,
    pub(crate) normal: [f32; 3],
    pub(crate) metallic: f32,
    pub(crate) face_normal: [f32; 3],
    pub(crate) roughness: f32,
    pub(crate) to_eye: [f32; 3],
    pub(crate) material: u32,
    pub(crate) albedo: [f32; 3],
    _pad0: f32,
    pub(crate) specular: [f32; 3],
    _pad1: f32,
    pub(crate) emissive: [f32; 3],
    _pad2: f32,
}

/// The WGSL names and Rust sizes of the pass's records (`tests/shaders.rs` compares them with
/// naga).
pub const RECORD_STRUCTS: [(&str, usize); 6] = [
    ("SurfaceRay", std::mem::size_of::<GpuSurfaceRay>()),
    ("SurfaceTri", std::mem::size_of::<SurfaceTriGpu>()),
    ("SurfaceVertex", std::mem::size_of::<SurfaceVertexGpu>()),
    ("SurfaceMaterial", std::mem::size_of::<SurfaceMaterialGpu>()),
    ("Mip", std::mem::size_of::<MipGpu>()),
    ("GRecord", std::mem::size_of::<GRecordGpu>()),
];

impl GRecordGpu {
    fn sample(&self) -> GSample {
        if self.material == MISS_MATERIAL {
            return GSample::miss(-Vec3::from(self.to_eye));
        }
        GSample {
            position: self.position.into(),
            normal: self.normal.into(),
            face_normal: self.face_normal.into(),
            to_eye: self.to_eye.into(),
            albedo: self.albedo.into(),
            metallic: self.metallic,
            roughness: self.roughness,
            specular: self.specular.into(),
            emissive: self.emissive.into(),
            t: self.t,
            material: self.material,
        }
    }
}

/// What [`GpuSurfaces::new`] uploaded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceStats {
    /// Triangles.
    pub triangles: usize,
    /// Vertices (all meshes).
    pub vertices: usize,
    /// Materials.
    pub materials: usize,
    /// Textures.
    pub textures: usize,
    /// Mip levels, all textures.
    pub mip_levels: usize,
    /// Bytes uploaded, all buffers.
    pub bytes: u64,
    /// The texel buffer's bytes (the largest binding for a textured scene).
    pub texel_bytes: u64,
    /// Preparing and uploading, wall ms.
    pub upload_ms: f64,
}

/// A world's surfaces on the device, with the pass's pipelines; used with the [`GpuTracer`]
/// of the same world's triangles.
pub struct GpuSurfaces {
    triangles: usize,
    stats: SurfaceStats,
    /// Bindings 9–14 of the surface pass (triangles, vertices, materials, mips, texels, model).
    pub(crate) buffers: [wgpu::Buffer; 6],
    polar: wgpu::ComputePipeline,
    screen: wgpu::ComputePipeline,
}

/// The world's surface records on the CPU, before upload.
struct Records {
    tris: Vec<SurfaceTriGpu>,
    vertices: Vec<SurfaceVertexGpu>,
    materials: Vec<SurfaceMaterialGpu>,
    mips: Vec<MipGpu>,
    texels: Vec<[f32; 4]>,
}

impl Records {
    /// Flattens `world`'s meshes, materials and textures; `slots`: each triangle's leaf
    /// position. Errors: a buffer larger than `u32` addresses.
    fn of(world: &World, slots: &[u32]) -> Result<Self> {
        let scene = &world.scene;
        // The textures' levels, in order; each texture's first level and count.
        let mut mips = Vec::new();
        let mut first_level = Vec::with_capacity(scene.textures.len());
        let mut texel_count = 0u64;
        for tex in &scene.textures {
            first_level.push([mips.len() as u32, tex.level_count() as u32]);
            for l in 0..tex.level_count() {
                let Some((width, height, _)) = tex.level(l) else {
                    break;
                };
                mips.push(MipGpu {
                    offset: u32::try_from(texel_count).map_err(|_| too_many("texels"))?,
                    width,
                    height,
                    _pad: 0,
                });
                texel_count += u64::from(width) * u64::from(height);
            }
        }
        u32::try_from(texel_count).map_err(|_| too_many("texels"))?;
        let mut texels = Vec::with_capacity(texel_count as usize);
        for tex in &scene.textures {
            for l in 0..tex.level_count() {
                if let Some((_, _, t)) = tex.level(l) {
                    texels.extend(t.iter().map(|c| c.to_array()));
                }
            }
        }
        let texture = |t: Option<u32>| -> [u32; 2] {
            t.and_then(|t| first_level.get(t as usize).copied())
                .unwrap_or([0, 0])
        };
        let materials = scene
            .materials
            .iter()
            .map(|m| SurfaceMaterialGpu {
                base_color: m.base_color.to_array(),
                metallic: m.metallic,
                specular: m.specular.to_array(),
                roughness: m.roughness,
                emissive: m.emissive.to_array(),
                normal_scale: m.normal_scale,
                base: texture(m.base_color_texture),
                metallic_roughness: texture(m.metallic_roughness_texture),
                normal_map: texture(m.normal_texture),
                _pad: [0; 2],
            })
            .collect();
        // Every mesh's vertices, concatenated; each mesh's first vertex and flags.
        let mut vertices = Vec::new();
        let mut mesh_base = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            let flags = [
                (!m.normals.is_empty(), HAS_NORMALS),
                (!m.uvs.is_empty(), HAS_UVS),
                (!m.tangents.is_empty(), HAS_TANGENTS),
                (!m.colors.is_empty(), HAS_COLORS),
            ]
            .iter()
            .filter(|(has, _)| *has)
            .fold(0, |f, (_, bit)| f | bit);
            let base = u32::try_from(vertices.len()).map_err(|_| too_many("vertices"))?;
            mesh_base.push((base, flags));
            let at = |k: usize| SurfaceVertexGpu {
                normal: m.normals.get(k).map_or([0.0; 3], |n| n.to_array()),
                u: m.uvs.get(k).map_or(0.0, |uv| uv.x),
                tangent: m.tangents.get(k).map_or([0.0; 4], |t| t.to_array()),
                color: m.colors.get(k).map_or([0.0; 3], |c| c.to_array()),
                v: m.uvs.get(k).map_or(0.0, |uv| uv.y),
            };
            vertices.extend((0..m.positions.len()).map(at));
        }
        u32::try_from(vertices.len()).map_err(|_| too_many("vertices"))?;
        let tris = world
            .tris
            .source
            .iter()
            .enumerate()
            .map(|(k, &(mi, ti))| {
                let m = &scene.meshes[mi as usize];
                let (base, flags) = mesh_base[mi as usize];
                SurfaceTriGpu {
                    v: m.indices[ti as usize].map(|i| base + i),
                    material: m.material,
                    slot: slots.get(k).copied().unwrap_or(0),
                    uv_per_metre: world.uv_per_metre.get(k).copied().unwrap_or(0.0),
                    flags,
                    _pad: 0,
                }
            })
            .collect();
        Ok(Self {
            tris,
            vertices,
            materials,
            mips,
            texels,
        })
    }
}

fn too_many(what: &str) -> GpuError {
    GpuError::Input(format!(
        "the scene has more {what} than the GPU surface pass addresses (2^32); use --backend cpu"
    ))
}

impl GpuSurfaces {
    /// Uploads `world`'s surfaces for `tracer`, which must have been built from the same
    /// world's triangles (`world.tris`, in order). Errors before any allocation: another
    /// triangle count ([`GpuError::Input`]), a device with fewer than [`STORAGE_BUFFERS`]
    /// storage buffers per stage ([`GpuError::Unsupported`]) or a buffer larger than a
    /// binding ([`GpuError::AdapterTooSmall`]).
    pub fn new(tracer: &GpuTracer, world: &World) -> Result<Self> {
        let t0 = std::time::Instant::now();
        let ctx: &GpuContext = &tracer.ctx;
        let triangles = world.tris.len();
        if triangles != tracer.stats().triangles {
            return Err(GpuError::Input(format!(
                "the world has {triangles} triangles, the GPU tracer {}: build both from the \
                 same world",
                tracer.stats().triangles
            )));
        }
        let per_stage = ctx.limits().max_storage_buffers_per_shader_stage;
        if per_stage < STORAGE_BUFFERS {
            return Err(GpuError::Unsupported(format!(
                "the surface pass binds {STORAGE_BUFFERS} storage buffers in one stage, the \
                 device {per_stage}"
            )));
        }
        let records = Records::of(world, &tracer.slots)?;
        let bytes = |len: usize, each: usize| (len.max(1) * each) as u64;
        let sizes = [
            (
                "the surface triangles",
                bytes(records.tris.len(), std::mem::size_of::<SurfaceTriGpu>()),
            ),
            (
                "the surface vertices",
                bytes(
                    records.vertices.len(),
                    std::mem::size_of::<SurfaceVertexGpu>(),
                ),
            ),
            (
                "the materials",
                bytes(
                    records.materials.len(),
                    std::mem::size_of::<SurfaceMaterialGpu>(),
                ),
            ),
            (
                "the mip levels",
                bytes(records.mips.len(), std::mem::size_of::<MipGpu>()),
            ),
            (
                "the texture texels",
                bytes(records.texels.len(), std::mem::size_of::<[f32; 4]>()),
            ),
        ];
        for (what, b) in sizes {
            ctx.check_storage_binding(what, b)?;
        }
        // Empty lists still bind one zeroed record.
        fn or_one<T: Pod + Zeroable>(v: &[T]) -> Vec<u8> {
            if v.is_empty() {
                vec![0; std::mem::size_of::<T>()]
            } else {
                bytemuck::cast_slice(v).to_vec()
            }
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let (buffers, pipelines) = ctx.scoped(
            "uploading the scene's surfaces and building the surface pipelines",
            || {
                (
                    [
                        upload(ctx, "surface triangles", &or_one(&records.tris), storage),
                        upload(ctx, "surface vertices", &or_one(&records.vertices), storage),
                        upload(ctx, "materials", &or_one(&records.materials), storage),
                        upload(ctx, "mip levels", &or_one(&records.mips), storage),
                        upload(ctx, "texels", &or_one(&records.texels), storage),
                        upload(
                            ctx,
                            "surface model",
                            bytemuck::bytes_of(&SurfaceModelGpu::RENDERER),
                            wgpu::BufferUsages::UNIFORM,
                        ),
                    ],
                    SHADER.pipelines_of(ctx.device(), &ENTRY_POINTS),
                )
            },
        )?;
        let [polar, screen]: [wgpu::ComputePipeline; 2] = pipelines.try_into().map_err(|_| {
            GpuError::Input(
                "the surface module lacks one of its entry points (surface_polar, \
                     surface_screen)"
                    .into(),
            )
        })?;
        let stats = SurfaceStats {
            triangles,
            vertices: records.vertices.len(),
            materials: records.materials.len(),
            textures: world.scene.textures.len(),
            mip_levels: records.mips.len(),
            bytes: sizes.iter().map(|(_, b)| b).sum(),
            texel_bytes: sizes[4].1,
            upload_ms: t0.elapsed().as_secs_f64() * 1e3,
        };
        Ok(Self {
            triangles,
            stats,
            buffers,
            polar,
            screen,
        })
    }

    /// What was uploaded.
    pub fn stats(&self) -> SurfaceStats {
        self.stats
    }
}

impl GpuTracer {
    /// Generates the primary ray of each of `rays` — polar `(r_px, turn)` around the camera
    /// block's centre, as [`GpuTracer::closest_hits_polar_timed`] — traces it and returns
    /// the G-buffer record of its hit interpolated on the device (`fovea_render::trace::
    /// surface` with the ray's cone `spread`; a miss: `GSample::miss` of its direction), and
    /// where the time went. A non-finite ray or camera is an input error naming it.
    pub fn surfaces_polar_timed(
        &self,
        surfaces: &GpuSurfaces,
        camera: &RayGenCamera,
        rays: &[GpuSurfaceRay],
    ) -> Result<(Vec<GSample>, TraceTimes)> {
        if let Some(k) = rays.iter().position(|r| !r.spread.is_finite()) {
            return Err(GpuError::Input(format!(
                "polar ray {k} has no finite cone ({:?})",
                rays[k]
            )));
        }
        self.surfaces(surfaces, camera, rays, &surfaces.polar, |r| {
            polar_offset(camera, &r.as_polar())
        })
    }

    /// Generates the primary ray through each screen point of `rays` (pixels from the
    /// screen's origin, as [`GpuTracer::closest_hits_screen_timed`]) and returns the
    /// G-buffer record of its hit, as [`surfaces_polar_timed`](Self::surfaces_polar_timed).
    pub fn surfaces_screen_timed(
        &self,
        surfaces: &GpuSurfaces,
        camera: &RayGenCamera,
        rays: &[GpuSurfaceRay],
    ) -> Result<(Vec<GSample>, TraceTimes)> {
        let bad = rays
            .iter()
            .position(|r| !(r.as_screen().iter().all(|c| c.is_finite()) && r.spread.is_finite()));
        if let Some(k) = bad {
            return Err(GpuError::Input(format!(
                "screen ray {k} is not a finite point with a finite cone ({:?})",
                rays[k]
            )));
        }
        self.surfaces(surfaces, camera, rays, &surfaces.screen, |r| {
            let [x, y] = r.as_screen();
            [camera.centre[0] + x, camera.centre[1] + y]
        })
    }

    fn surfaces(
        &self,
        surfaces: &GpuSurfaces,
        camera: &RayGenCamera,
        rays: &[GpuSurfaceRay],
        pipeline: &wgpu::ComputePipeline,
        offset: impl Fn(&GpuSurfaceRay) -> [f32; 2],
    ) -> Result<(Vec<GSample>, TraceTimes)> {
        if surfaces.triangles != self.stats().triangles {
            return Err(GpuError::Input(format!(
                "these surfaces are of {} triangles, the tracer holds {}",
                surfaces.triangles,
                self.stats().triangles
            )));
        }
        let resident: Vec<(u32, &wgpu::Buffer)> =
            (9..).zip(surfaces.buffers.iter()).collect::<Vec<_>>();
        self.generated(
            camera,
            rays,
            |_| Some((pipeline, resident)),
            |r, _| GSample::miss(Vec3::from(direction(camera, offset(r)))),
            GRecordGpu::sample,
        )
    }
}
