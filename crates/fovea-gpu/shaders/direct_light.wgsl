// direct_light.wgsl: direct light at surface samples — the renderer's shading model
// (`fovea_render::shade`: `light_at`, `brdf_cos`, `shadow_ray`) with each light's shadow ray
// cast through the BVH of trace.wgsl (appended to it: the same bindings 0–3 and `traverse`),
// one invocation per sample. GGX `D`, height-correlated Smith visibility and Schlick `F`
// (Walter et al. 2007; Karis 2013; Heitz 2014) plus Lambert, times `n·l`; point and spot
// radiance `I/d²` (a spot's smooth cone `k²`), directional irradiance `E`. Every constant of
// the model (π, the shadow-ray offset, the floors) comes from `TraceParams`, uploaded from
// `fovea_render::shade::constants` by the caller.
//
// Output per sample: (r, g, b, shadow rays cast), the lights summed in their order.

struct Surface {
    position: vec3<f32>,
    t: f32,
    normal: vec3<f32>,
    metallic: f32,
    face_normal: vec3<f32>,
    roughness: f32,
    to_eye: vec3<f32>,
    // The sample's key (`fovea_render::shade::texel_key`), low and high words: the seed of
    // environment_light.wgsl's random numbers.
    key_lo: u32,
    albedo: vec3<f32>,
    key_hi: u32,
    specular: vec3<f32>,
    pad2: f32,
}

// kind: 0 point, 1 spot, 2 directional (direction: where the light travels; intensity: the
// irradiance). A range of "none" arrives as the largest distance.
struct Light {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    range: f32,
    intensity: vec3<f32>,
    cos_inner: f32,
    cos_outer: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

@group(0) @binding(6) var<storage, read> surfaces: array<Surface>;
@group(0) @binding(7) var<storage, read> lights: array<Light>;
@group(0) @binding(8) var<storage, read_write> shaded: array<vec4<f32>>;

const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

// `brdf_cos`: GGX + Lambert times n·l for the unit direction `l` towards the light.
fn brdf_cos(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let n = s.normal;
    let v = s.to_eye;
    let nl = dot(n, l);
    let nv = max(dot(n, v), params.min_nv);
    if nl <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize_or_zero(l + v);
    let nh = max(dot(n, h), 0.0);
    let vh = max(dot(v, h), 0.0);
    let a = s.roughness * s.roughness;
    let a2 = a * a;
    let dd = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / max(params.pi * (dd * dd), params.d_floor);
    let vis = 0.5 / max(nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2), params.vis_floor);
    let f0 = mix(s.specular, s.albedo, vec3<f32>(s.metallic));
    let m = 1.0 - vh;
    let m2 = m * m;
    let f = f0 + (vec3<f32>(1.0) - f0) * (m2 * m2 * m);
    let spec = d * vis * f;
    let diffuse = (vec3<f32>(1.0) - f) * (1.0 - s.metallic) * s.albedo / params.pi;
    return (diffuse + spec) * nl;
}

fn direct_at(s: Surface) -> vec4<f32> {
    let origin = s.position + s.face_normal * (params.offset_per_t * (1.0 + min(s.t, params.offset_t_cap)));
    var sum = vec3<f32>(0.0);
    var rays_cast = 0u;
    for (var i = 0u; i < params.light_count; i = i + 1u) {
        let light = lights[i];
        var l: vec3<f32>;
        var t_max: f32;
        var radiance: vec3<f32>;
        if light.kind == LIGHT_DIRECTIONAL {
            l = -light.direction;
            t_max = params.max_distance;
            radiance = light.intensity;
        } else {
            let d = light.position - origin;
            let dist = length(d);
            if dist > light.range || dist < params.min_light_distance {
                continue;
            }
            l = d / dist;
            t_max = dist * (1.0 - params.shadow_shorten);
            if light.kind == LIGHT_SPOT {
                let c = dot(-l, light.direction);
                let k = clamp((c - light.cos_outer) / max(light.cos_inner - light.cos_outer, params.spot_min_width), 0.0, 1.0);
                if k <= 0.0 {
                    continue;
                }
                radiance = light.intensity * (k * k) / (dist * dist);
            } else {
                radiance = light.intensity / (dist * dist);
            }
        }
        if dot(s.face_normal, l) <= 0.0 && dot(s.normal, l) <= 0.0 {
            continue;
        }
        let b = brdf_cos(s, l);
        if all(b == vec3<f32>(0.0)) {
            continue;
        }
        rays_cast = rays_cast + 1u;
        if traverse(Ray(origin, 0.0, l, t_max), true).prim == MISS {
            sum = sum + b * radiance;
        }
    }
    return vec4<f32>(sum, f32(rays_cast));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn direct_light(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    shaded[i] = direct_at(surfaces[i]);
}
