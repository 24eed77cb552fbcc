// environment_light.wgsl: the environment's light at surface samples — the renderer's MIS
// estimator (`fovea_render::shade::env_light`: `environment_rays`, `occluded`; Veach and
// Guibas 1995 Eq. 7–8, the balance heuristic over the BRDF mixture and the map's importance
// sampling) with each ray's any-hit shadow ray to infinity cast through the BVH of trace.wgsl
// (appended to it after direct_light.wgsl: the bindings 0–3, `traverse`, `Surface`,
// `surfaces`, `shaded` and `brdf_cos`), one invocation per sample. Its own bindings are 16–20,
// clear of surface.wgsl's 9–14, so that one module can carry both (frame_shade.wgsl).
//
// The same random numbers as the CPU: SplitMix64 (`fovea_core::math::mix64`) emulated with
// pairs of u32 (x: low word, y: high word), bit for bit; the R2 sequence (Roberts 2018) with
// its Cranley-Patterson shift summed in 0.64 fixed point, which is the CPU's f64 sum without
// its roundings, then rounded once to f32. The map's lookup (bilinear, wrapping in u, clamped
// at the poles; angles from common.wgsl's atan, sines and cosines from its Taylor series in
// turns, as the driver's are not precise enough) and its sampling tables (pbrt-v4 `PiecewiseConstant2D`: a marginal CDF over
// rows, one conditional CDF per row, found by binary search) are `EnvMap`'s, uploaded. Every
// constant — the hash's, the sequence's, the floors, the table offsets — comes from
// `EnvParams`, uploaded from `fovea_render` and `fovea_core` by the caller.
//
// Output per sample: (r, g, b, environment rays cast), the rays summed in the CPU's order.

struct EnvParams {
    // Rays per sample; of them, from the map's sampling (the first) and from the BRDF's.
    samples: u32,
    n_map: u32,
    n_brdf: u32,
    // ENV_CONSTANT or ENV_MAP.
    kind: u32,
    salt: vec2<u32>,
    mix_increment: vec2<u32>,
    mix_mul0: vec2<u32>,
    mix_mul1: vec2<u32>,
    // The hash's three right shifts, and the random numbers' bits (w).
    mix_shifts: vec4<u32>,
    // The R2 steps and the offset ½, 0.64 fixed point.
    r2_a1: vec2<u32>,
    r2_a2: vec2<u32>,
    r2_half: vec2<u32>,
    // The map's size, pixels.
    width: u32,
    height: u32,
    // Luminance weights (xyz), GGX α² floor (w).
    luminance: vec4<f32>,
    // A constant environment's radiance (xyz); the map's scale (w).
    constant: vec4<f32>,
    map_from_world: mat3x3<f32>,
    world_from_map: mat3x3<f32>,
    tau: f32,
    // The largest random number below 1, and the largest x a 1D table returns.
    below_one: f32,
    x_max: f32,
    // 1/2π, for common.wgsl's angle in turns.
    turns_per_rad: f32,
    // Offsets into `env_tables`: the marginal's CDF and values, the conditionals' CDFs,
    // values and integrals, the rows' edge cosines.
    off_marginal_cdf: u32,
    off_marginal_func: u32,
    off_cond_cdf: u32,
    off_cond_func: u32,
    off_cond_int: u32,
    off_cos_edge: u32,
    marginal_int: f32,
    // The shading key's frame field in the key's high word (`frame_noise`).
    frame_mask_hi: u32,
}

@group(0) @binding(16) var<uniform> env: EnvParams;
// The map's pixels, linear RGB, row-major from the top row (before `env.constant.w`).
@group(0) @binding(17) var<storage, read> env_pixels: array<f32>;
// The sampling tables (offsets in `env`).
@group(0) @binding(18) var<storage, read> env_tables: array<f32>;
// `mix64_check`: the outputs and inputs.
@group(0) @binding(19) var<storage, read_write> hash_out: array<vec2<u32>>;
@group(0) @binding(20) var<storage, read> hash_in: array<vec2<u32>>;

const ENV_MAP: u32 = 1u;

// ---- u64 as vec2<u32> (x low, y high) ----

fn u64_add(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// a >> k for k in 0..64.
fn u64_shr(a: vec2<u32>, k: u32) -> vec2<u32> {
    if k == 0u {
        return a;
    }
    if k >= 32u {
        return vec2<u32>(a.y >> (k - 32u), 0u);
    }
    return vec2<u32>((a.x >> k) | (a.y << (32u - k)), a.y >> k);
}

// a << k for k in 0..64.
fn u64_shl(a: vec2<u32>, k: u32) -> vec2<u32> {
    if k == 0u {
        return a;
    }
    if k >= 32u {
        return vec2<u32>(0u, a.x << (k - 32u));
    }
    return vec2<u32>(a.x << k, (a.y << k) | (a.x >> (32u - k)));
}

// The full 64-bit product of two u32, from 16-bit halves.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// a · b mod 2^64 (Rust's wrapping_mul).
fn u64_mul(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let p = mul_wide(a.x, b.x);
    return vec2<u32>(p.x, p.y + a.x * b.y + a.y * b.x);
}

// `fovea_core::math::mix64`.
fn mix64(z0: vec2<u32>) -> vec2<u32> {
    var z = u64_add(z0, env.mix_increment);
    z = u64_mul(z ^ u64_shr(z, env.mix_shifts.x), env.mix_mul0);
    z = u64_mul(z ^ u64_shr(z, env.mix_shifts.y), env.mix_mul1);
    return z ^ u64_shr(z, env.mix_shifts.z);
}

// The fraction a / 2^64 rounded to the nearest f32 (ties to even), as Rust's `as f32`.
fn frac64_to_f32(a: vec2<u32>) -> f32 {
    if a.x == 0u && a.y == 0u {
        return 0.0;
    }
    let lz = select(32u + countLeadingZeros(a.x), countLeadingZeros(a.y), a.y != 0u);
    let n = u64_shl(a, lz);
    var top = n.y >> 8u;
    let r = n.y & 0xffu;
    if r > 0x80u || (r == 0x80u && (n.x != 0u || (top & 1u) == 1u)) {
        top = top + 1u;
    }
    return ldexp(f32(top), -i32(24u + lz));
}

// The `i`-th point of the R2 sequence shifted by the fixed-point `shift` (`r2_shifted`).
fn r2_shifted(i: u32, shift_x: vec2<u32>, shift_y: vec2<u32>) -> vec2<f32> {
    let x = u64_add(u64_add(env.r2_half, u64_mul(vec2<u32>(i, 0u), env.r2_a1)), shift_x);
    let y = u64_add(u64_add(env.r2_half, u64_mul(vec2<u32>(i, 0u), env.r2_a2)), shift_y);
    return vec2<f32>(min(frac64_to_f32(x), env.below_one), min(frac64_to_f32(y), env.below_one));
}

// ---- the environment (`Environment`, `EnvMap`) ----

fn luminance(c: vec3<f32>) -> f32 {
    return env.luminance.x * c.x + env.luminance.y * c.y + env.luminance.z * c.z;
}

// glam's Mat3 · Vec3.
fn mat_mul(m: mat3x3<f32>, v: vec3<f32>) -> vec3<f32> {
    return m[0] * v.x + m[1] * v.y + m[2] * v.z;
}

// glam's Vec3::lerp.
fn lerp3(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a * (1.0 - s) + b * s;
}

fn unit(v: vec3<f32>) -> vec3<f32> {
    return v * (1.0 / length(v));
}

fn env_pixel(x: u32, y: u32) -> vec3<f32> {
    let k = 3u * (y * env.width + x);
    return vec3<f32>(env_pixels[k], env_pixels[k + 1u], env_pixels[k + 2u]);
}

// acos(clamp(z, −1, 1)) / π, as the angle of (z, √((1 − z)(1 + z))) from common.wgsl's
// atan (the driver's acos and atan2 may be ~1e-5 off, WGSL leaving their precision open).
fn acos_over_pi(z: f32) -> f32 {
    let c = clamp(z, -1.0, 1.0);
    let s = sqrt(max((1.0 - c) * (1.0 + c), 0.0));
    return 2.0 * angle_turns(c, s, env.turns_per_rad, env.tau);
}

// `direction_to_uv`: u = atan2(x, −z) / 2π wrapped to [0, 1) (in turns directly), v = θ / π.
fn direction_to_uv(d: vec3<f32>) -> vec2<f32> {
    var u = angle_turns(-d.z, d.x, env.turns_per_rad, env.tau);
    if u >= 1.0 {
        u = 0.0;
    }
    return vec2<f32>(u, acos_over_pi(d.y));
}

// `EnvMap::lookup`: bilinear, wrapping in u, clamped in v.
fn env_lookup(uv: vec2<f32>) -> vec3<f32> {
    let w = i32(env.width);
    let h = i32(env.height);
    let x = uv.x * f32(env.width) - 0.5;
    let y = clamp(uv.y * f32(env.height) - 0.5, 0.0, f32(h - 1));
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xa = i32(x0);
    let ya = i32(y0);
    let xa_w = u32(((xa % w) + w) % w);
    let xb_w = u32((((xa + 1) % w) + w) % w);
    let yb = u32(min(ya + 1, h - 1));
    let yau = u32(ya);
    let top = lerp3(env_pixel(xa_w, yau), env_pixel(xb_w, yau), fx);
    let bot = lerp3(env_pixel(xa_w, yb), env_pixel(xb_w, yb), fx);
    return lerp3(top, bot, fy) * env.constant.w;
}

// `Environment::radiance`.
fn env_radiance(dir: vec3<f32>) -> vec3<f32> {
    if env.kind != ENV_MAP {
        return env.constant.xyz;
    }
    let local = normalize_or_zero(mat_mul(env.map_from_world, dir));
    if all(local == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    return env_lookup(direction_to_uv(local));
}

struct Sample1D {
    x: f32,
    pdf: f32,
    bin: u32,
}

// `Distribution1D::sample` of the table with `n` bins at `cdf` (n + 1 values) and `func`.
fn dist_sample(cdf: u32, func: u32, n: u32, func_int: f32, u: f32) -> Sample1D {
    // partition_point(c ≤ u) over cdf[0..=n].
    var lo = 0u;
    var hi = n + 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if env_tables[cdf + mid] <= u {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let o = min(max(lo, 1u) - 1u, n - 1u);
    let c0 = env_tables[cdf + o];
    let width = env_tables[cdf + o + 1u] - c0;
    var du = 0.0;
    if width > 0.0 {
        du = clamp((u - c0) / width, 0.0, 1.0);
    }
    let x = min((f32(o) + du) / f32(n), env.x_max);
    return Sample1D(x, env_tables[func + o] / func_int, o);
}

// `Distribution1D::bin`.
fn dist_bin(n: u32, x: f32) -> u32 {
    let k = floor(x * f32(n));
    if k > 0.0 {
        return u32(min(k, f32(n - 1u)));
    }
    return 0u;
}

struct MapSample {
    ok: bool,
    direction: vec3<f32>,
    radiance: vec3<f32>,
}

// `EnvMap::sample`.
fn env_map_sample(u: vec2<f32>) -> MapSample {
    let h = env.height;
    let w = env.width;
    let m = dist_sample(env.off_marginal_cdf, env.off_marginal_func, h, env.marginal_int, u.y);
    let row_int = env_tables[env.off_cond_int + m.bin];
    let c = dist_sample(env.off_cond_cdf + m.bin * (w + 1u), env.off_cond_func + m.bin * w, w, row_int, u.x);
    let pdf_xy = c.pdf * m.pdf;
    let y = m.x * f32(h);
    let j = min(u32(y), h - 1u);
    let t = clamp(y - f32(j), 0.0, 1.0);
    let c0 = env_tables[env.off_cos_edge + j];
    let dz = c0 - env_tables[env.off_cos_edge + j + 1u];
    if !(pdf_xy > 0.0 && dz > 0.0) {
        return MapSample(false, vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let z = c0 - t * dz;
    let st = sqrt(max(1.0 - z * z, 0.0));
    let cs = cos_sin_turns(c.x, env.tau);
    let local = vec3<f32>(st * cs.y, z, -st * cs.x);
    return MapSample(true, unit(mat_mul(env.world_from_map, local)), env_lookup(direction_to_uv(local)));
}

// `EnvMap::pdf`.
fn env_map_pdf(dir: vec3<f32>) -> f32 {
    let local = normalize_or_zero(mat_mul(env.map_from_world, dir));
    if all(local == vec3<f32>(0.0)) {
        return 0.0;
    }
    let h = env.height;
    let w = env.width;
    let j = min(u32(max(acos_over_pi(local.y) * f32(h), 0.0)), h - 1u);
    let dz = env_tables[env.off_cos_edge + j] - env_tables[env.off_cos_edge + j + 1u];
    if dz <= 0.0 {
        return 0.0;
    }
    let x = direction_to_uv(local).x;
    let y = (f32(j) + 0.5) / f32(h);
    let row = dist_bin(h, y);
    let p_v = env_tables[env.off_marginal_func + row] / env.marginal_int;
    let p_u = env_tables[env.off_cond_func + row * w + dist_bin(w, x)] / env_tables[env.off_cond_int + row];
    return p_v * p_u / (env.tau * f32(h) * dz);
}

// ---- the BRDF mixture (`BrdfSampler`) ----

struct Brdf {
    n: vec3<f32>,
    v: vec3<f32>,
    t: vec3<f32>,
    b: vec3<f32>,
    a2: f32,
    q_spec: f32,
}

// glam's `any_orthonormal_pair` (Duff et al. 2017), with f32::signum's sign of −0.
fn orthonormal_pair(n: vec3<f32>) -> array<vec3<f32>, 2> {
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return array<vec3<f32>, 2>(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
    );
}

fn brdf_new(s: Surface) -> Brdf {
    let f0 = lerp3(s.specular, s.albedo, s.metallic);
    let w_spec = max(luminance(f0), 0.0);
    let w_diff = max(luminance(s.albedo) * (1.0 - s.metallic), 0.0);
    var q = 0.5;
    if w_spec + w_diff > 0.0 {
        q = w_spec / (w_spec + w_diff);
    }
    let tb = orthonormal_pair(s.normal);
    let a = s.roughness * s.roughness;
    return Brdf(s.normal, s.to_eye, tb[0], tb[1], max(a * a, env.luminance.w), q);
}

// `cosine_hemisphere`.
fn cosine_hemisphere(n: vec3<f32>, u1: f32, u2: f32) -> vec3<f32> {
    let r = sqrt(u1);
    let cs = cos_sin_turns(u2, env.tau);
    let x = r * cs.x;
    let y = r * cs.y;
    let z = sqrt(max(1.0 - u1, 0.0));
    let tb = orthonormal_pair(n);
    return unit(tb[0] * x + tb[1] * y + n * z);
}

// `BrdfSampler::sample`: w = 0 when the mirrored GGX direction points below the surface.
fn brdf_sample(s: Brdf, u: vec2<f32>) -> vec4<f32> {
    if u.x >= s.q_spec {
        let u0 = min((u.x - s.q_spec) / (1.0 - s.q_spec), env.below_one);
        return vec4<f32>(cosine_hemisphere(s.n, u0, u.y), 1.0);
    }
    let u0 = u.x / s.q_spec;
    let cos2 = (1.0 - u0) / (1.0 + (s.a2 - 1.0) * u0);
    let cos_h = sqrt(clamp(cos2, 0.0, 1.0));
    let sin_h = sqrt(max(1.0 - cos_h * cos_h, 0.0));
    let cs = cos_sin_turns(u.y, env.tau);
    let h = s.t * (sin_h * cs.x) + s.b * (sin_h * cs.y) + s.n * cos_h;
    let vh = dot(s.v, h);
    let l = normalize_or_zero(2.0 * vh * h - s.v);
    return vec4<f32>(l, select(0.0, 1.0, vh > 0.0 && dot(l, s.n) > 0.0));
}

// `BrdfSampler::pdf`.
fn brdf_pdf(s: Brdf, l: vec3<f32>) -> f32 {
    let nl = dot(s.n, l);
    if nl <= 0.0 {
        return 0.0;
    }
    let p_cos = nl / params.pi;
    if s.q_spec <= 0.0 {
        return p_cos;
    }
    let h = normalize_or_zero(l + s.v);
    let nh = dot(s.n, h);
    let vh = dot(s.v, h);
    var p_ggx = 0.0;
    if nh > 0.0 && vh > 0.0 {
        let dd = nh * nh * (s.a2 - 1.0) + 1.0;
        let d = s.a2 / max(params.pi * (dd * dd), params.d_floor);
        p_ggx = d * nh / (4.0 * vh);
    }
    return s.q_spec * p_ggx + (1.0 - s.q_spec) * p_cos;
}

// ---- the estimator (`environment_rays` + `occluded`) ----

// The next random number of the stream `rng`, in [0, 1).
fn next_random(rng: ptr<function, vec2<u32>>) -> vec2<u32> {
    *rng = mix64(*rng);
    // The top `bits` bits, as a 0.64 fixed-point fraction.
    return u64_shl(u64_shr(*rng, 64u - env.mix_shifts.w), 64u - env.mix_shifts.w);
}

// The `i`-th point of the (0, 2)-sequence in base 2 as 32-bit fractions
// (`frame_noise::sobol02_bits`): the radical inverse, and the Pascal matrix's image.
fn sobol02(i: u32) -> vec2<u32> {
    var y = 0u;
    var v = 0x80000000u;
    var k = i;
    for (; k != 0u; k = k >> 1u) {
        if (k & 1u) != 0u {
            y = y ^ v;
        }
        v = v ^ (v >> 1u);
    }
    return vec2<u32>(reverseBits(i), y);
}

// A random number of `next_random` rotated by the frame's point (its top bits, as
// `frame_noise::rotated_unit`): the 0.64 fixed-point sum, wrapping at 1.
fn rotated(r: vec2<u32>, rotation: u32) -> vec2<u32> {
    let keep = ~((1u << (32u - env.mix_shifts.w)) - 1u);
    return vec2<u32>(r.x, r.y + (rotation & keep));
}

fn environment_at(s: Surface) -> vec4<f32> {
    let key = vec2<u32>(s.key_lo, s.key_hi);
    let rank = key.x & 15u;
    // The tile's shifts hash the key without its frame; the frame rotates them
    // (`frame_noise`).
    let frame = (key.y & env.frame_mask_hi) >> countTrailingZeros(env.frame_mask_hi);
    let rotation = sobol02(frame);
    var rng = mix64(u64_shr(vec2<u32>(key.x, key.y & ~env.frame_mask_hi), 4u) ^ env.salt);
    let shift_map_x = rotated(next_random(&rng), rotation.x);
    let shift_map_y = rotated(next_random(&rng), rotation.y);
    let shift_brdf_x = rotated(next_random(&rng), rotation.x);
    let shift_brdf_y = rotated(next_random(&rng), rotation.y);
    let is_map = env.kind == ENV_MAP;
    let brdf = brdf_new(s);
    let origin = s.position + s.face_normal * (params.offset_per_t * (1.0 + min(s.t, params.offset_t_cap)));
    var sum = vec3<f32>(0.0);
    var rays_cast = 0u;
    for (var i = 0u; i < env.samples; i = i + 1u) {
        var dir: vec3<f32>;
        var radiance: vec3<f32>;
        if is_map && i < env.n_map {
            let m = env_map_sample(r2_shifted(rank * env.n_map + i, shift_map_x, shift_map_y));
            if !m.ok {
                continue;
            }
            dir = m.direction;
            radiance = m.radiance;
        } else {
            let d = brdf_sample(brdf, r2_shifted(rank * env.n_brdf + i - env.n_map, shift_brdf_x, shift_brdf_y));
            if d.w == 0.0 {
                continue;
            }
            dir = d.xyz;
            radiance = env_radiance(dir);
        }
        if dot(dir, s.face_normal) <= 0.0 || max(radiance.x, max(radiance.y, radiance.z)) <= 0.0 {
            continue;
        }
        let f = brdf_cos(s, dir);
        if all(f == vec3<f32>(0.0)) {
            continue;
        }
        var p_map = 0.0;
        if is_map {
            p_map = env_map_pdf(dir);
        }
        let denom = f32(env.n_map) * p_map + f32(env.n_brdf) * brdf_pdf(brdf, dir);
        // !(denom > 0 && finite): WGSL may assume finite values, so only the first test.
        if !(denom > 0.0 && denom < FAR) {
            continue;
        }
        rays_cast = rays_cast + 1u;
        if traverse(Ray(origin, 0.0, dir, params.max_distance), true).prim == MISS {
            sum = sum + f * radiance / denom;
        }
    }
    return vec4<f32>(sum, f32(rays_cast));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn environment_light(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    shaded[i] = environment_at(surfaces[i]);
}

// The hash alone, for the check against `fovea_core::math::mix64`.
@compute @workgroup_size(WORKGROUP_SIZE)
fn mix64_check(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    hash_out[i] = mix64(hash_in[i]);
}
