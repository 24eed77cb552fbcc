// ray_generation.wgsl: the trace stage's primary rays generated on the device, traced through
// the BVH of trace.wgsl (appended to it: the same bindings 0–3 and `traverse`), one
// invocation per ray. Two entry points differ only in how a ray's screen point arrives:
//
// * `closest_hit_polar` (a polar buffer): its offset from the mapping's centre (VaFR Eq. 11:
//   `r·(cos θ, sin θ)`, θ = 2π·turn, from the CPU's f64 `fovea_core::mapping::Ring::polar`),
//   in fixed point, 2^16 units a pixel (`GpuPolarRay`): `polar_point` adds it to the centre
//   as an f32 pair hi + lo that holds the f64 point to ~1e-5 px (f32 polar coordinates and
//   f32 cos/sin left up to ~1.7e-3 px at 8K);
// * `closest_hit_screen` (a screen-aligned buffer: full resolution, Guenter's layers, the
//   inset, Weier's sparse set): the point itself, the CPU mapping's `inverse` rounded to f32
//   — the rounding `EyeCamera::ray` does itself.
//
// Both then take the pinhole camera's ray through the point (`camera_ray`, as
// `fovea_render::camera::EyeCamera::direction`). `RayGenCamera.centre` is the origin of the
// uploaded coordinates minus the principal point (subtracted in f64 by the caller): the
// rings' centre for a polar ray (with `centre_lo`, what f32 leaves of the f64 difference), so
// the point's offset from the view axis comes without the cancellation of two screen
// coordinates near 10⁴ px; the screen's origin for a screen ray, so `centre + p` is the CPU's own f32
// `x − c_x`. Output per ray: the hit (as `closest_hit`) and the unit direction the ray was
// cast along (the CPU builds the surface record from it).

struct RayGenCamera {
    // Eye position, world space.
    origin: vec3<f32>,
    // Focal length along x, pixels.
    fx: f32,
    // Unit viewing direction.
    forward: vec3<f32>,
    // Focal length along y, pixels.
    fy: f32,
    // Unit right vector (screen +x).
    right: vec3<f32>,
    // 2π.
    rad_per_turn: f32,
    // Unit up vector (screen −y).
    up: vec3<f32>,
    // Pixels per unit of a polar ray's fixed-point offset (2^-16).
    px_per_q: f32,
    // The origin of the rays' coordinates minus the principal point, pixels: the rings'
    // centre (polar rays) or the screen's (0, 0) (screen rays); `centre + centre_lo` is the
    // f64 difference.
    centre: vec2<f32>,
    centre_lo: vec2<f32>,
}

// The offset of the point from the rings' centre, 2^16 units a pixel (`GpuPolarRay`).
struct PolarRay {
    offset_q: vec2<i32>,
}

// A screen point, pixels.
struct ScreenRay {
    x_px: f32,
    y_px: f32,
}

struct GeneratedHit {
    hit: Hit,
    dir: vec3<f32>,
    _pad: f32,
}

@group(0) @binding(6) var<uniform> camera: RayGenCamera;
@group(0) @binding(7) var<storage, read> polar_rays: array<PolarRay>;
@group(0) @binding(7) var<storage, read> screen_rays: array<ScreenRay>;
@group(0) @binding(8) var<storage, read_write> generated_hits: array<GeneratedHit>;
// `polar_point_check`'s output: each ray's point as (hi, lo).
@group(0) @binding(8) var<storage, read_write> polar_points_out: array<vec4<f32>>;

// A polar ray's screen point relative to the principal point, as the f32 pair (hi.xy, lo.xy)
// whose sum is the CPU's f64 point to ~1e-5 px: the offset splits exactly into whole pixels
// (|q >> 16| ≤ 2^15) and the fraction (16 bits), the centre into floor(centre) and
// `centre_lo` (uploaded); the integers add exactly and the fractions are below 2, so no sum
// needs its rounding error kept (a two-sum would not survive a compiler that reassociates
// float sums, as Mesa's does).
fn polar_point(q: vec2<i32>) -> vec4<f32> {
    let whole = vec2<f32>(q >> vec2<u32>(16u));
    let frac = vec2<f32>(q & vec2<i32>(0xffff)) * camera.px_per_q;
    return vec4<f32>(floor(camera.centre) + whole, camera.centre_lo + frac);
}

// The pinhole camera's ray through the point `p` pixels from the principal point (screen +y
// down), unit direction (surface.wgsl too).
fn camera_ray(p: vec2<f32>) -> Ray {
    let dir = normalize(camera.forward + (p.x / camera.fx) * camera.right - (p.y / camera.fy) * camera.up);
    return Ray(camera.origin, 0.0, dir, params.max_distance);
}

// Traces the camera's ray through `p` into `generated_hits[i]`.
fn trace_camera_ray(i: u32, p: vec2<f32>) {
    let ray = camera_ray(p);
    generated_hits[i] = GeneratedHit(traverse(ray, false), ray.dir, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn closest_hit_polar(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    let p = polar_point(polar_rays[i].offset_q);
    trace_camera_ray(i, p.xy + p.zw);
}

// A probe of `polar_point` for the tests of its precision (`GpuTracer::polar_points`): each
// ray's (hi, lo). It names the BVH's bindings, which every pass of the module binds.
@compute @workgroup_size(WORKGROUP_SIZE)
fn polar_point_check(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    _ = arrayLength(&nodes) + arrayLength(&tris) + arrayLength(&prim_ids);
    polar_points_out[i] = polar_point(polar_rays[i].offset_q);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn closest_hit_screen(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    let s = screen_rays[i];
    trace_camera_ray(i, camera.centre + vec2<f32>(s.x_px, s.y_px));
}
