//! Primary visibility: one ray per sample, closest hit, and the G-buffer record of what it hit
//! (position, shading normal, albedo, material terms, depth).
//!
//! **Texture level of detail from the sample's footprint (ray cones, Akenine-Möller et al.
//! 2019).** Each sample carries the angle its footprint spans (`spread_rad`: one screen
//! pixel for full resolution, the mapping's sample spacing elsewhere, see
//! `crate::pipeline`). At the hit, the cone is `t · spread` metres wide, `/|cos θ|` along the
//! surface; times the triangle's UV-per-metre and the texture size this is the number of texels
//! the sample stands for, whose log2 is the mip level. A VaFR sample at 40° eccentricity thus
//! averages the texels it covers instead of aliasing (DESIGN.md, "the sample footprint").

use glam::{Vec2, Vec3, Vec4};

use crate::bvh::{Hit, Ray};
use crate::scene::Material;
use crate::world::World;

/// The surface model's constants ([`surface`]), named so another executor uploads the same
/// numbers (`fovea-gpu`'s surface pass).
pub mod model {
    /// `|cos θ|` between the ray and the surface is taken at least this large when the ray
    /// cone's footprint is stretched along the surface (grazing hits stay finite).
    pub const MIN_COS: f32 = 0.05;
    /// The texels a footprint covers are taken at least this many before their log2 (the
    /// level of detail stays finite for a zero-width cone).
    pub const MIN_FOOTPRINT_TEXELS: f32 = 1e-8;
    /// Perceptual roughness is clamped to `[MIN_ROUGHNESS, 1]` (GGX's `D` stays finite).
    pub const MIN_ROUGHNESS: f32 = 0.02;
    /// A triangle whose UV parametrisation's `|det|` is below this has no tangent frame (its
    /// normal map is not applied).
    pub const TANGENT_DET_FLOOR: f32 = 1e-12;
    /// Below this fraction of a mip level a texture lookup reads one level, no trilinear
    /// blend ([`crate::scene::Texture::sample`]).
    pub use crate::scene::texture::TRILINEAR_MIN_FRACTION;
}

/// Material index of a G-buffer sample whose ray hit nothing.
pub const MISS: u32 = u32::MAX;

/// What a primary ray saw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GSample {
    /// Hit position, world space.
    pub position: Vec3,
    /// Shading normal (interpolated, normal-mapped), facing the viewer.
    pub normal: Vec3,
    /// Geometric normal, facing the viewer.
    pub face_normal: Vec3,
    /// Unit vector from the hit towards the ray origin.
    pub to_eye: Vec3,
    /// Base colour (factor × texture × vertex colour), linear RGB.
    pub albedo: Vec3,
    /// Metalness.
    pub metallic: f32,
    /// Perceptual roughness.
    pub roughness: f32,
    /// Dielectric specular reflectance at normal incidence.
    pub specular: Vec3,
    /// Emitted radiance.
    pub emissive: Vec3,
    /// Distance along the ray, metres (`f32::INFINITY` for a miss).
    pub t: f32,
    /// Material index, or [`MISS`].
    pub material: u32,
}

impl GSample {
    /// The record of a ray that hit nothing.
    pub fn miss(dir: Vec3) -> Self {
        Self {
            position: Vec3::ZERO,
            normal: Vec3::ZERO,
            face_normal: Vec3::ZERO,
            to_eye: -dir,
            albedo: Vec3::ZERO,
            metallic: 0.0,
            roughness: 1.0,
            specular: Vec3::ZERO,
            emissive: Vec3::ZERO,
            t: f32::INFINITY,
            material: MISS,
        }
    }

    /// Whether the ray hit something.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.material != MISS
    }
}

/// Traces `ray` and fills its G-buffer record. `spread_rad` is the sample footprint's angle.
pub fn trace_sample(world: &World, ray: &Ray, spread_rad: f32) -> GSample {
    match world.caster.intersect(ray) {
        Some(hit) => surface(world, ray, &hit, spread_rad),
        None => GSample::miss(ray.dir),
    }
}

/// Interpolates the surface attributes at `hit`.
pub fn surface(world: &World, ray: &Ray, hit: &Hit, spread_rad: f32) -> GSample {
    let (mi, ti) = world.tris.source[hit.tri as usize];
    let mesh = &world.scene.meshes[mi as usize];
    let idx = mesh.indices[ti as usize];
    let (b1, b2) = (hit.bary.x, hit.bary.y);
    let b0 = 1.0 - b1 - b2;
    let v = &world.tris.verts[hit.tri as usize];
    let position = ray.origin + ray.dir * hit.t;
    let mut ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    let flip = ng.dot(ray.dir) > 0.0;
    if flip {
        ng = -ng;
    }
    let mut n = if mesh.normals.is_empty() {
        ng
    } else {
        let nn = idx.map(|i| mesh.normals[i as usize]);
        let s = (b0 * nn[0] + b1 * nn[1] + b2 * nn[2]).normalize_or_zero();
        let s = if flip { -s } else { s };
        if s == Vec3::ZERO {
            ng
        } else {
            s
        }
    };
    let mat: &Material = &world.scene.materials[mesh.material as usize];
    let mut albedo = mat.base_color;
    let mut metallic = mat.metallic;
    let mut roughness = mat.roughness;
    if !mesh.uvs.is_empty() {
        let uvs = idx.map(|i| mesh.uvs[i as usize]);
        let uv = b0 * uvs[0] + b1 * uvs[1] + b2 * uvs[2];
        let cos = ray.dir.dot(ng).abs().max(model::MIN_COS);
        // Footprint on the surface in UV units.
        let footprint_uv = hit.t * spread_rad / cos * world.uv_per_metre[hit.tri as usize];
        let lod = |tex: &crate::scene::Texture| -> f32 {
            let texels = footprint_uv * ((tex.width() * tex.height()) as f32).sqrt();
            texels.max(model::MIN_FOOTPRINT_TEXELS).log2()
        };
        let textures = &world.scene.textures;
        if let Some(t) = mat.base_color_texture {
            let tex = &textures[t as usize];
            let c = tex.sample(uv, lod(tex));
            albedo *= c.truncate();
        }
        if let Some(t) = mat.metallic_roughness_texture {
            let tex = &textures[t as usize];
            let c = tex.sample(uv, lod(tex));
            roughness *= c.y;
            metallic *= c.z;
        }
        if let Some(t) = mat.normal_texture {
            let tex = &textures[t as usize];
            let c = tex.sample(uv, lod(tex));
            let tn = Vec3::new(
                (2.0 * c.x - 1.0) * mat.normal_scale,
                (2.0 * c.y - 1.0) * mat.normal_scale,
                2.0 * c.z - 1.0,
            );
            if let Some((tangent, bitangent)) = tangent_frame(mesh, idx, [b0, b1, b2], v, uvs, n) {
                let m = (tangent * tn.x + bitangent * tn.y + n * tn.z).normalize_or_zero();
                if m != Vec3::ZERO {
                    n = m;
                }
            }
        }
    }
    // Vertex colours multiply the base colour (glTF: factor × texture × COLOR_0).
    if !mesh.colors.is_empty() {
        let c = idx.map(|i| mesh.colors[i as usize]);
        albedo *= b0 * c[0] + b1 * c[1] + b2 * c[2];
    }
    // Keep the shading normal in the visible hemisphere.
    if n.dot(-ray.dir) < 0.0 {
        n = (n - 2.0 * n.dot(-ray.dir) * (-ray.dir)).normalize_or_zero();
        if n == Vec3::ZERO {
            n = ng;
        }
    }
    GSample {
        position,
        normal: n,
        face_normal: ng,
        to_eye: -ray.dir,
        albedo: albedo.clamp(Vec3::ZERO, Vec3::ONE),
        metallic: metallic.clamp(0.0, 1.0),
        roughness: roughness.clamp(model::MIN_ROUGHNESS, 1.0),
        specular: mat.specular,
        emissive: mat.emissive,
        t: hit.t,
        material: mesh.material,
    }
}

/// Tangent and bitangent at the hit: the mesh's tangents if it has them, else from the
/// triangle's UV derivatives; both orthogonalised against `n`.
fn tangent_frame(
    mesh: &crate::scene::Mesh,
    idx: [u32; 3],
    b: [f32; 3],
    v: &[Vec3; 3],
    uv: [Vec2; 3],
    n: Vec3,
) -> Option<(Vec3, Vec3)> {
    let (t, sign) = if !mesh.tangents.is_empty() {
        let tt: [Vec4; 3] = idx.map(|i| mesh.tangents[i as usize]);
        let t = (b[0] * tt[0] + b[1] * tt[1] + b[2] * tt[2]).truncate();
        (t, if tt[0].w < 0.0 { -1.0 } else { 1.0 })
    } else {
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < model::TANGENT_DET_FLOOR {
            return None;
        }
        let r = 1.0 / det;
        let t = (e1 * d2.y - e2 * d1.y) * r;
        let bt = (e2 * d1.x - e1 * d2.x) * r;
        let sign = if n.cross(t).dot(bt) < 0.0 { -1.0 } else { 1.0 };
        (t, sign)
    };
    let t = (t - n * n.dot(t)).normalize_or_zero();
    if t == Vec3::ZERO {
        return None;
    }
    // glTF: bitangent = cross(normal, tangent) · w.
    Some((t, n.cross(t) * sign))
}
