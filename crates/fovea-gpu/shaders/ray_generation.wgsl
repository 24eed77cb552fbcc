// ray_generation.wgsl: the trace stage's primary rays generated on the device, traced through
// the BVH of trace.wgsl (appended to it: the same bindings 0–3 and `traverse`), one
// invocation per ray. Two entry points differ only in how a ray's screen point arrives:
//
// * `closest_hit_polar` (a polar buffer): its polar coordinates around the mapping's centre
//   (VaFR Eq. 11: `p = c + r·(cos θ, sin θ)`, θ = 2π·turn; the ring's radius and the turn come
//   from the CPU's f64 mapping, `fovea_core::mapping::Ring::polar`);
// * `closest_hit_screen` (a screen-aligned buffer: full resolution, Guenter's layers, the
//   inset, Weier's sparse set): the point itself, the CPU mapping's `inverse` rounded to f32
//   — the rounding `EyeCamera::ray` does itself.
//
// Both then take the pinhole camera's ray through the point (`camera_ray`, as
// `fovea_render::camera::EyeCamera::direction`). `RayGenCamera.centre` is the origin of the
// uploaded coordinates minus the principal point (subtracted in f64 by the caller): the
// rings' centre for a polar ray, so the point's offset from the view axis is
// `centre + r·(cos, sin)` without the cancellation of two screen coordinates near 10⁴ px
// (`cos_sin_turns` reduces the angle exactly, so its error stays ~1e-7 rad anywhere on the
// circle); the screen's origin for a screen ray, so `centre + p` is the CPU's own f32
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
    _pad0: f32,
    // The origin of the rays' coordinates minus the principal point, pixels: the rings'
    // centre (polar rays) or the screen's (0, 0) (screen rays).
    centre: vec2<f32>,
    _pad1: vec2<f32>,
}

// (radius in pixels, angle in turns).
struct PolarRay {
    r_px: f32,
    turn: f32,
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
    let pr = polar_rays[i];
    trace_camera_ray(i, camera.centre + pr.r_px * cos_sin_turns(pr.turn, camera.rad_per_turn));
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
