// surface.wgsl: the G-buffer record at each primary hit, interpolated on the device — the
// renderer's `fovea_render::trace::surface`, step for step — for primary rays generated as
// ray_generation.wgsl generates them (appended after trace.wgsl and ray_generation.wgsl: the
// same bindings 0–3 and 6, `traverse` and `camera_ray`), one invocation per ray.
//
// At a hit: the geometric normal (flipped towards the ray), the interpolated vertex normal,
// the material's factors times its textures — base colour, metallic-roughness (G roughness,
// B metalness), the tangent-space normal map in the mesh's tangent frame or the one derived
// from the triangle's UVs — sampled bilinearly with repeat wrap at the level of detail of the
// ray's cone (Akenine-Möller et al. 2019: the cone `t · spread` wide, `/ |cos θ|` along the
// surface, times the triangle's UV per metre and the texture's side: the log2 of the texels
// it covers), trilinear between levels; the vertex colours; the shading normal kept in the
// visible hemisphere; the clamps. The textures' mip chains are the CPU's own texels
// (`fovea_render::scene::Texture::level`), f32, in one buffer. Every constant of the model
// comes from `SurfaceModel`, uploaded from `fovea_render::trace::model`.
//
// Output per ray: the record, or a miss (`material == MISS`, `to_eye` = −direction).

// A ray's screen point and its cone: a polar ray's fixed-point offset from the camera
// block's centre (`surface_polar`, i32 bits, as `PolarRay`), or (x_px, y_px) from the
// screen's origin (`surface_screen`, f32 bits); the cone's angle, radians.
struct SurfaceRay {
    a: u32,
    b: u32,
    spread: f32,
}

// A triangle of the world's list (`fovea_render::bvh::Triangles`, in that order): its
// vertices in `vertices`, its material, its position in `tris` (the BVH's leaf order), its
// UV units per metre (`World::uv_per_metre`) and which attributes its mesh has.
struct SurfaceTri {
    v0: u32,
    v1: u32,
    v2: u32,
    material: u32,
    slot: u32,
    uv_per_metre: f32,
    flags: u32,
    _pad: u32,
}

// A vertex's attributes (zero where its mesh has none).
struct SurfaceVertex {
    normal: vec3<f32>,
    u: f32,
    tangent: vec4<f32>,
    color: vec3<f32>,
    v: f32,
}

// A material's factors and its textures: each texture as its first mip level in `mips` and
// its level count (0: none).
struct SurfaceMaterial {
    base_color: vec3<f32>,
    metallic: f32,
    specular: vec3<f32>,
    roughness: f32,
    emissive: vec3<f32>,
    normal_scale: f32,
    base_mip: u32,
    base_levels: u32,
    mr_mip: u32,
    mr_levels: u32,
    normal_mip: u32,
    normal_levels: u32,
    _pad0: u32,
    _pad1: u32,
}

// A mip level: its first texel in `texels`, its size.
struct Mip {
    offset: u32,
    width: u32,
    height: u32,
    _pad: u32,
}

// `fovea_render::trace::model`.
struct SurfaceModel {
    // |cos θ| of the cone's footprint is taken at least this large.
    min_cos: f32,
    // The footprint is taken at least this many texels (the log2's floor).
    min_footprint_texels: f32,
    // Below this fraction of a level, no trilinear blend.
    trilinear_min_fraction: f32,
    // Perceptual roughness is clamped to [min_roughness, 1].
    min_roughness: f32,
    // A UV parametrisation whose |det| is below this has no tangent frame.
    tangent_det_floor: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// `fovea_render::trace::GSample` (`t` of a miss: FAR).
struct GRecord {
    position: vec3<f32>,
    t: f32,
    normal: vec3<f32>,
    metallic: f32,
    face_normal: vec3<f32>,
    roughness: f32,
    to_eye: vec3<f32>,
    material: u32,
    albedo: vec3<f32>,
    _pad0: f32,
    specular: vec3<f32>,
    _pad1: f32,
    emissive: vec3<f32>,
    _pad2: f32,
}

@group(0) @binding(7) var<storage, read> surface_rays: array<SurfaceRay>;
@group(0) @binding(8) var<storage, read_write> records: array<GRecord>;
@group(0) @binding(9) var<storage, read> surface_tris: array<SurfaceTri>;
@group(0) @binding(10) var<storage, read> vertices: array<SurfaceVertex>;
@group(0) @binding(11) var<storage, read> materials: array<SurfaceMaterial>;
@group(0) @binding(12) var<storage, read> mips: array<Mip>;
@group(0) @binding(13) var<storage, read> texels: array<vec4<f32>>;
@group(0) @binding(14) var<uniform> model: SurfaceModel;

const HAS_NORMALS: u32 = 1u;
const HAS_UVS: u32 = 2u;
const HAS_TANGENTS: u32 = 4u;
const HAS_COLORS: u32 = 8u;

// `v.rem_euclid(n)` for the integral `v` (exact for |v| < 2³¹).
fn wrap(v: f32, n: u32) -> u32 {
    let i = i32(clamp(v, -2.0e9, 2.0e9));
    let m = i32(n);
    return u32(((i % m) + m) % m);
}

// glam's `lerp`: a·(1 − s) + b·s.
fn lerp4(a: vec4<f32>, b: vec4<f32>, s: f32) -> vec4<f32> {
    return a * (1.0 - s) + b * s;
}

// `Texture::bilinear`: repeat wrap, texel centres at half-integers.
fn bilinear(m: Mip, uv: vec2<f32>) -> vec4<f32> {
    let x = uv.x * f32(m.width) - 0.5;
    let y = uv.y * f32(m.height) - 0.5;
    if !(abs(x) <= FAR && abs(y) <= FAR) {
        return texels[m.offset];
    }
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xa = wrap(x0, m.width);
    let xb = wrap(x0 + 1.0, m.width);
    let ya = wrap(y0, m.height);
    let yb = wrap(y0 + 1.0, m.height);
    let top = lerp4(texels[m.offset + ya * m.width + xa], texels[m.offset + ya * m.width + xb], fx);
    let bot = lerp4(texels[m.offset + yb * m.width + xa], texels[m.offset + yb * m.width + xb], fx);
    return lerp4(top, bot, fy);
}

// `Texture::sample` of the texture whose levels start at `first` (`levels` of them) at the
// level of a footprint `footprint_uv` UV units wide.
fn sample_texture(first: u32, levels: u32, uv: vec2<f32>, footprint_uv: f32) -> vec4<f32> {
    let base = mips[first];
    let covered = footprint_uv * sqrt(f32(base.width * base.height));
    let lod = log2(max(covered, model.min_footprint_texels));
    var l = 0.0;
    if abs(lod) <= FAR {
        l = clamp(lod, 0.0, f32(levels - 1u));
    }
    let l0 = floor(l);
    let f = l - l0;
    let i0 = u32(l0);
    let a = bilinear(mips[first + i0], uv);
    if f > model.trilinear_min_fraction && i0 + 1u < levels {
        return lerp4(a, bilinear(mips[first + i0 + 1u], uv), f);
    }
    return a;
}

// `tangent_frame`'s answer: the tangent and bitangent, when there is a frame.
struct Frame {
    tangent: vec3<f32>,
    found: bool,
    bitangent: vec3<f32>,
}

// `tangent_frame`: the mesh's tangents if it has them, else from the triangle's UV
// derivatives; orthogonalised against `n`.
fn tangent_frame(st: SurfaceTri, va: SurfaceVertex, vb: SurfaceVertex, vc: SurfaceVertex, b: vec3<f32>, tri: Tri, uv: array<vec2<f32>, 3>, n: vec3<f32>) -> Frame {
    var none: Frame;
    none.found = false;
    var t: vec3<f32>;
    var sign = 1.0;
    if (st.flags & HAS_TANGENTS) != 0u {
        t = (b.x * va.tangent + b.y * vb.tangent + b.z * vc.tangent).xyz;
        if va.tangent.w < 0.0 {
            sign = -1.0;
        }
    } else {
        let e1 = tri.v1.xyz - tri.v0.xyz;
        let e2 = tri.v2.xyz - tri.v0.xyz;
        let d1 = uv[1] - uv[0];
        let d2 = uv[2] - uv[0];
        let det = d1.x * d2.y - d2.x * d1.y;
        if abs(det) < model.tangent_det_floor {
            return none;
        }
        let r = 1.0 / det;
        t = (e1 * d2.y - e2 * d1.y) * r;
        let bt = (e2 * d1.x - e1 * d2.x) * r;
        if dot(cross(n, t), bt) < 0.0 {
            sign = -1.0;
        }
    }
    let to = normalize_or_zero(t - n * dot(n, t));
    if all(to == vec3<f32>(0.0)) {
        return none;
    }
    return Frame(to, true, cross(n, to) * sign);
}

// `fovea_render::trace::surface` of the ray from `origin` along the unit `dir` whose closest
// hit is `h`, its cone `spread` radians.
fn surface_at(origin: vec3<f32>, dir: vec3<f32>, h: Hit, spread: f32) -> GRecord {
    var g: GRecord;
    g.to_eye = -dir;
    if h.prim == MISS {
        g.t = FAR;
        g.roughness = 1.0;
        g.material = MISS;
        return g;
    }
    let st = surface_tris[h.prim];
    let tri = tris[st.slot];
    let b1 = h.u;
    let b2 = h.v;
    let b0 = 1.0 - b1 - b2;
    let va = vertices[st.v0];
    let vb = vertices[st.v1];
    let vc = vertices[st.v2];
    var ng = normalize_or_zero(cross(tri.v1.xyz - tri.v0.xyz, tri.v2.xyz - tri.v0.xyz));
    let flip = dot(ng, dir) > 0.0;
    if flip {
        ng = -ng;
    }
    var n = ng;
    if (st.flags & HAS_NORMALS) != 0u {
        var s = normalize_or_zero(b0 * va.normal + b1 * vb.normal + b2 * vc.normal);
        if flip {
            s = -s;
        }
        if any(s != vec3<f32>(0.0)) {
            n = s;
        }
    }
    let mat = materials[st.material];
    var albedo = mat.base_color;
    var metallic = mat.metallic;
    var roughness = mat.roughness;
    if (st.flags & HAS_UVS) != 0u {
        let uvs = array<vec2<f32>, 3>(vec2<f32>(va.u, va.v), vec2<f32>(vb.u, vb.v), vec2<f32>(vc.u, vc.v));
        let uv = b0 * uvs[0] + b1 * uvs[1] + b2 * uvs[2];
        let cos = max(abs(dot(dir, ng)), model.min_cos);
        let footprint_uv = h.t * spread / cos * st.uv_per_metre;
        if mat.base_levels > 0u {
            albedo = albedo * sample_texture(mat.base_mip, mat.base_levels, uv, footprint_uv).xyz;
        }
        if mat.mr_levels > 0u {
            let c = sample_texture(mat.mr_mip, mat.mr_levels, uv, footprint_uv);
            roughness = roughness * c.y;
            metallic = metallic * c.z;
        }
        if mat.normal_levels > 0u {
            let c = sample_texture(mat.normal_mip, mat.normal_levels, uv, footprint_uv);
            let tn = vec3<f32>((2.0 * c.x - 1.0) * mat.normal_scale, (2.0 * c.y - 1.0) * mat.normal_scale, 2.0 * c.z - 1.0);
            let frame = tangent_frame(st, va, vb, vc, vec3<f32>(b0, b1, b2), tri, uvs, n);
            if frame.found {
                let m = normalize_or_zero(frame.tangent * tn.x + frame.bitangent * tn.y + n * tn.z);
                if any(m != vec3<f32>(0.0)) {
                    n = m;
                }
            }
        }
    }
    if (st.flags & HAS_COLORS) != 0u {
        albedo = albedo * (b0 * va.color + b1 * vb.color + b2 * vc.color);
    }
    // Keep the shading normal in the visible hemisphere.
    let e = -dir;
    if dot(n, e) < 0.0 {
        n = normalize_or_zero(n - 2.0 * dot(n, e) * e);
        if all(n == vec3<f32>(0.0)) {
            n = ng;
        }
    }
    g.position = origin + dir * h.t;
    g.t = h.t;
    g.normal = n;
    g.face_normal = ng;
    g.albedo = clamp(albedo, vec3<f32>(0.0), vec3<f32>(1.0));
    g.metallic = clamp(metallic, 0.0, 1.0);
    g.roughness = clamp(roughness, model.min_roughness, 1.0);
    g.specular = mat.specular;
    g.emissive = mat.emissive;
    g.material = st.material;
    return g;
}

// Traces the camera's ray through `p` and writes the surface at its hit into `records[i]`.
fn surface_of_camera_ray(i: u32, p: vec2<f32>, spread: f32) {
    let ray = camera_ray(p);
    records[i] = surface_at(ray.origin, ray.dir, traverse(ray, false), spread);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn surface_polar(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    let r = surface_rays[i];
    let p = polar_point(bitcast<vec2<i32>>(vec2<u32>(r.a, r.b)));
    surface_of_camera_ray(i, p.xy + p.zw, r.spread);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn surface_screen(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    let r = surface_rays[i];
    surface_of_camera_ray(i, camera.centre + bitcast<vec2<f32>>(vec2<u32>(r.a, r.b)), r.spread);
}
