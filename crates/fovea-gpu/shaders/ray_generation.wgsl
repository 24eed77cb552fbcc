// ray_generation.wgsl: the trace stage's primary rays of a polar buffer generated on the
// device — a texel ray's screen point from its polar coordinates around the mapping's centre
// (VaFR Eq. 11: `p = c + r·(cos θ, sin θ)`, θ = 2π·turn; the ring's radius and the turn come
// from the CPU's f64 mapping, `fovea_core::mapping::Ring::polar`), then the pinhole camera's
// ray through it (`fovea_render::camera::EyeCamera::direction`), traced through the BVH of
// trace.wgsl (appended to it: the same bindings 0–3 and `traverse`), one invocation per ray.
//
// The centre arrives relative to the principal point (subtracted in f64 by the caller), so
// the point's offset from the view axis is `centre + r·(cos, sin)` without the cancellation
// of two screen coordinates near 10⁴ px; `cos_sin_turns` reduces the angle exactly, so its
// error stays ~1e-7 rad anywhere on the circle. Output per ray: the hit (as `closest_hit`)
// and the unit direction the ray was cast along (the CPU builds the surface record from it).

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
    // The rings' centre minus the principal point, pixels.
    centre: vec2<f32>,
    _pad1: vec2<f32>,
}

// (radius in pixels, angle in turns).
struct PolarRay {
    r_px: f32,
    turn: f32,
}

struct PolarHit {
    hit: Hit,
    dir: vec3<f32>,
    _pad: f32,
}

@group(0) @binding(6) var<uniform> camera: RayGenCamera;
@group(0) @binding(7) var<storage, read> polar_rays: array<PolarRay>;
@group(0) @binding(8) var<storage, read_write> polar_hits: array<PolarHit>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn closest_hit_polar(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    let pr = polar_rays[i];
    let p = camera.centre + pr.r_px * cos_sin_turns(pr.turn, camera.rad_per_turn);
    let dir = normalize(camera.forward + (p.x / camera.fx) * camera.right - (p.y / camera.fy) * camera.up);
    let ray = Ray(camera.origin, 0.0, dir, params.max_distance);
    polar_hits[i] = PolarHit(traverse(ray, false), dir, 0.0);
}
