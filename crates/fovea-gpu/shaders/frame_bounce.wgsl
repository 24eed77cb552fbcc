// frame_bounce.wgsl: indirect light in the resident frame (issues 37 and 38) — the renderer's
// `fovea_render::shade::indirect` (a path from each texel's primary hit: a BRDF-sampled
// bounce, next-event estimation of every light and of the environment at the surface it
// reaches, Russian roulette from the second bounce on) step for step, with its random numbers.
// Appended after frame_shade.wgsl (its bindings 21–29, `frame_texel` — over the list of
// shaded texels of frame_compact.wgsl for a polar buffer —, `frame_record`,
// `frame_ray`) and the files before it (`traverse`, `surface_at`, `direct_at`,
// `environment_at`, `brdf_new`, `brdf_sample`, `brdf_pdf`, `brdf_cos`, `mix64`, `sobol02`).
//
// A path is advanced one bounce at a time by three kernels, each walking the BVH from one
// place (frame_shade.wgsl says why), dispatched once per bounce after frame_environment,
// and a fourth once at the end:
//
// * `frame_bounce_trace`: the bounce's direction sampled at the path's vertex (the primary
//   hit from the G-buffer at the first bounce, the previous bounce's surface after), the
//   throughput updated, the roulette (from the second bounce), the bounce ray traced and the
//   surface at its hit interpolated into the G-buffer (which the primary's kernels no longer
//   need), its emission kept; a path that ends is marked done;
// * `frame_bounce_direct`: the lights at that surface (one shadow ray each) added to the kept
//   emission;
// * `frame_bounce_environment`: the environment's light there — one occluded ray with the
//   bounce's key (`bounce_env_light`; the EnvParams bound here carry its ray count), or the
//   unshadowed ambient term — and `throughput · (emission + lights + environment)` added to
//   the path's sum, as the CPU sums it;
// * `frame_bounce_add`: each path's sum added to its texel's colour (and to the denoiser's
//   Monte Carlo part: the bounces' light is Monte Carlo throughout), as `add_bounces` does.
//
// A texel's path lives in `frame_paths_a`, `_b`, `_c` (five records per texel, as u32 bits):
// throughput and bounces done; the vertex's position and the low word of the `later` stream;
// its `to_eye` and the high word; the sum; the emission plus the lights of the vertex. Its
// state is the G-buffer's (STATE_HIT: the primary hit, no bounce yet; STATE_BOUNCE: at a
// bounce's surface; STATE_DONE: ended).
//
// Random numbers (`shade::bounce`, `frame_noise`): the first bounce's two from
// mix64(without_frame(key) ^ BOUNCE_SALT), each rotated by the frame's (0, 2)-sequence point
// (Cranley-Patterson); every later one — the later bounces' directions, the roulette — from
// mix64(key ^ BOUNCE_LATER_SALT), unrotated; each number the top `unit_bits` bits of the next
// mix64 state over 2^unit_bits. Every constant comes from `BounceParams`, uploaded from
// `fovea_render::shade`.

struct BounceParams {
    // Bounces of the plan (dispatches of the three kernels).
    bounces: u32,
    // `frame_noise::UNIT_BITS`.
    unit_bits: u32,
    // `ROULETTE_MAX`.
    roulette_max: f32,
    // `BOUNCE_SPREAD_RAD`: the bounce ray's cone.
    spread: f32,
    // `BOUNCE_SALT` and `BOUNCE_LATER_SALT` (low, high word).
    first_salt: vec2<u32>,
    later_salt: vec2<u32>,
    // `bounce_env_key_mask(depth)` (xy) per depth.
    env_keys: array<vec4<u32>, 16>,
}

@group(0) @binding(31) var<uniform> bounce: BounceParams;
// A texel's path (u32 bits), in three bindings of at most 32 bytes a texel as the G-buffer's
// (a binding's size bounds the texels): (throughput, bounces done), (vertex position, `later`
// low word); (vertex `to_eye`, `later` high word), (sum, 0); (emission plus lights, 0).
@group(0) @binding(32) var<storage, read_write> frame_paths_a: array<vec4<u32>>;
@group(0) @binding(33) var<storage, read_write> frame_paths_b: array<vec4<u32>>;
@group(0) @binding(34) var<storage, read_write> frame_paths_c: array<vec4<u32>>;

const STATE_BOUNCE: f32 = 3.0;
const STATE_DONE: f32 = 4.0;

// The next number of the stream `rng` as its top `unit_bits` bits (`frame_noise`).
fn bounce_bits(rng: ptr<function, vec2<u32>>) -> u32 {
    *rng = mix64(*rng);
    return (*rng).y >> (32u - bounce.unit_bits);
}

// `rotated_unit`: the number `bits / 2^unit_bits` rotated by `rotation / 2^unit_bits`.
fn bounce_unit(bits: u32, rotation: u32) -> f32 {
    let mask = (1u << bounce.unit_bits) - 1u;
    return f32((bits + rotation) & mask) / f32(1u << bounce.unit_bits);
}

// Texel k's key (`frame_record`'s): low and high word.
fn bounce_key(k: u32) -> vec2<u32> {
    let w = frame.layer.width;
    let i = k % w;
    let j = k / w;
    let lo = frame.rank[j % 4u][i % 4u] | (((i / 4u) & 0x3fffu) << 4u) | (((j / 4u) & 0x3fffu) << 18u);
    return vec2<u32>(lo, frame.layer.key_hi);
}

// The surface of the bounce texel k reached (G-buffer and path), keyed with `key`.
fn bounce_vertex(k: u32, key: vec2<u32>) -> Surface {
    let g0 = frame_geometry[2u * k];
    let g1 = frame_geometry[2u * k + 1u];
    let m0 = frame_material[2u * k];
    let m1 = frame_material[2u * k + 1u];
    let position = bitcast<vec3<f32>>(frame_paths_a[2u * k + 1u].xyz);
    let to_eye = bitcast<vec3<f32>>(frame_paths_b[2u * k].xyz);
    return Surface(position, g0.w, g0.xyz, g1.w, g1.xyz, m0.w, to_eye, key.x, m0.xyz, key.y, m1.xyz, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_bounce_trace(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels {
        return;
    }
    let state = frame_material[2u * k + 1u].w;
    var s: Surface;
    var depth: u32;
    var throughput: vec3<f32>;
    var later: vec2<u32>;
    var u: vec2<f32>;
    if state == STATE_HIT {
        // The first bounce: from the primary hit, its numbers hashed without the frame and
        // rotated by the frame's point.
        s = frame_record(k, frame_ray(k));
        let key = vec2<u32>(s.key_lo, s.key_hi);
        depth = 0u;
        throughput = vec3<f32>(1.0);
        later = mix64(key ^ bounce.later_salt);
        let frame_index = (key.y & env.frame_mask_hi) >> countTrailingZeros(env.frame_mask_hi);
        let rotation = sobol02(frame_index) >> vec2<u32>(32u - bounce.unit_bits);
        var first = mix64(vec2<u32>(key.x, key.y & ~env.frame_mask_hi) ^ bounce.first_salt);
        let u0 = bounce_unit(bounce_bits(&first), rotation.x);
        let u1 = bounce_unit(bounce_bits(&first), rotation.y);
        u = vec2<f32>(u0, u1);
        frame_paths_b[2u * k + 1u] = vec4<u32>(0u);
    } else if state == STATE_BOUNCE {
        s = bounce_vertex(k, bounce_key(k));
        let r0 = frame_paths_a[2u * k];
        depth = r0.w;
        throughput = bitcast<vec3<f32>>(r0.xyz);
        later = vec2<u32>(frame_paths_a[2u * k + 1u].w, frame_paths_b[2u * k].w);
        let u0 = bounce_unit(bounce_bits(&later), 0u);
        let u1 = bounce_unit(bounce_bits(&later), 0u);
        u = vec2<f32>(u0, u1);
    } else {
        return;
    }
    let brdf = brdf_new(s);
    let d = brdf_sample(brdf, u);
    let dir = d.xyz;
    var alive = d.w != 0.0 && dot(dir, s.face_normal) > 0.0;
    if alive {
        let pdf = brdf_pdf(brdf, dir);
        let f = brdf_cos(s, dir);
        // !(pdf > 0 && finite) || f == 0 (WGSL may assume finite values: FAR stands for ∞).
        alive = pdf > 0.0 && pdf < FAR && any(f != vec3<f32>(0.0));
        if alive {
            throughput = throughput * (f / pdf);
        }
    }
    if alive && depth > 0u {
        // Russian roulette.
        let survive = min(max(throughput.x, max(throughput.y, throughput.z)), bounce.roulette_max);
        if !(survive > 0.0) || bounce_unit(bounce_bits(&later), 0u) >= survive {
            alive = false;
        } else {
            throughput = throughput / survive;
        }
    }
    if alive {
        let origin = s.position + s.face_normal * (params.offset_per_t * (1.0 + min(s.t, params.offset_t_cap)));
        let g = surface_at(origin, dir, traverse(Ray(origin, 0.0, dir, params.max_distance), false), bounce.spread);
        if g.material == MISS {
            alive = false;
        } else {
            frame_geometry[2u * k] = vec4<f32>(g.normal, g.t);
            frame_geometry[2u * k + 1u] = vec4<f32>(g.face_normal, g.metallic);
            frame_material[2u * k] = vec4<f32>(g.albedo, g.roughness);
            frame_material[2u * k + 1u] = vec4<f32>(g.specular, STATE_BOUNCE);
            frame_paths_a[2u * k] = vec4<u32>(bitcast<vec3<u32>>(throughput), depth + 1u);
            frame_paths_a[2u * k + 1u] = vec4<u32>(bitcast<vec3<u32>>(g.position), later.x);
            frame_paths_b[2u * k] = vec4<u32>(bitcast<vec3<u32>>(g.to_eye), later.y);
            frame_paths_c[k] = vec4<u32>(bitcast<vec3<u32>>(g.emissive), 0u);
        }
    }
    if !alive {
        frame_material[2u * k + 1u].w = STATE_DONE;
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_bounce_direct(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels || frame_material[2u * k + 1u].w != STATE_BOUNCE {
        return;
    }
    let emitted = bitcast<vec3<f32>>(frame_paths_c[k].xyz);
    let lit = emitted + direct_at(bounce_vertex(k, bounce_key(k))).xyz;
    frame_paths_c[k] = vec4<u32>(bitcast<vec3<u32>>(lit), 0u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_bounce_environment(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels || frame_material[2u * k + 1u].w != STATE_BOUNCE {
        return;
    }
    let r0 = frame_paths_a[2u * k];
    var e = vec3<f32>(0.0);
    if frame.unshadowed != 0u {
        // The unshadowed ambient term `mean · albedo · (1 − metallic)`.
        e = frame.ambient.xyz * frame_material[2u * k].xyz * (1.0 - frame_geometry[2u * k + 1u].w);
    } else if env.samples > 0u {
        // The bounce's key: the sample's, its tile and sub-sample fields xor-ed by depth.
        let mask = bounce.env_keys[r0.w - 1u].xy;
        e = environment_at(bounce_vertex(k, bounce_key(k) ^ mask)).xyz;
    }
    let lit = bitcast<vec3<f32>>(frame_paths_c[k].xyz);
    let throughput = bitcast<vec3<f32>>(r0.xyz);
    let sum = bitcast<vec3<f32>>(frame_paths_b[2u * k + 1u].xyz) + throughput * (lit + e);
    frame_paths_b[2u * k + 1u] = vec4<u32>(bitcast<vec3<u32>>(sum), 0u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_bounce_add(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels {
        return;
    }
    let state = frame_material[2u * k + 1u].w;
    if state != STATE_BOUNCE && state != STATE_DONE {
        return;
    }
    let sum = bitcast<vec3<f32>>(frame_paths_b[2u * k + 1u].xyz);
    let out = frame.layer.offset + k;
    let before = frame_samples[out];
    frame_samples[out] = vec4<f32>(before.xyz + sum, before.w);
    if frame.guides != 0u {
        let noisy = frame_guide_noisy[out];
        frame_guide_noisy[out] = vec4<f32>(noisy.xyz + sum, noisy.w);
    }
}
