// frame_shade.wgsl: the resident frame's sample side — per texel of one eye's sample buffer,
// its primary ray generated, traced, the surface at the hit interpolated, lit (each light's
// shadow ray, the environment's MIS estimate with its shadow rays) and its colour + depth
// written into the frame's sample buffers (`fovea_gpu::frame::DeviceSamples`), nothing going
// back to the host. Appended after trace.wgsl, direct_light.wgsl, ray_generation.wgsl,
// surface.wgsl and environment_light.wgsl: their functions, step for step the renderer's
// (`fovea_render::pipeline::trace_shade`'s trace and shade of one ray per texel,
// `fovea_render::shade::shade` in direct shading), called from three entry points, one
// invocation per texel each, in one compute pass:
//
// * `frame_surface`: the ray, its closest hit and the G-buffer record at the hit, kept on the
//   device (`frame_geometry`, `frame_material`: 32 bytes each per texel); the texel's emission
//   and depth written;
// * `frame_direct`: the ray placed again (the same arithmetic: the same direction, position
//   `origin + dir·t` and `to_eye` as the record's), the lights added (a miss: the
//   environment's radiance along the ray);
// * `frame_environment`: the environment's light added (its MIS estimate, or the unshadowed
//   ambient term).
//
// Each kernel walks the BVH from one place only, as each staged pass does: lavapipe (Mesa
// 22.3) corrupts memory — "stack smashing detected", heap corruption — running a kernel that
// inlines `traverse` two or three times (its 64-entry stack each), where each part alone
// runs; the records between them stay on the device.
//
// Which ray a texel casts is the CPU plan's: a polar buffer's texel (i, j) lies on the ring of
// its column (`FoveationMapping::ring` of u = i + ½ + jitter, the CPU mapping's f64 radius and
// rows per turn, uploaded per column) at the angle v/period turns, v = j + ½ + jitter (VaFR
// Eq. 11, `Ring::polar`); it is shaded where the mapping shades it (its column's runs of rows,
// `FoveationMapping::is_shaded`). A screen-aligned (full-resolution) texel's ray goes through
// the screen point (i + ½ + jitter, j + ½ + jitter). The key of its random numbers is
// `texel_key(layer, i, j)` with the frame and the eye (`frame_noise::with_frame`): the rank in
// its 4×4 tile (uploaded), the tile's column and row, the frame's high word (uploaded).
//
// Output per texel: linear RGB and depth along the view axis (`EyeCamera::view_depth`), +∞
// for a miss (the environment's radiance along the ray) and for a texel the plan does not
// shade (black), as the CPU's buffers hold them.
//
// With `frame.guides` set (the plan denoises, issue 38) the kernels also write the sample-space
// denoiser's guides (`fovea_gpu::denoise::DeviceGuides`, the layers of the samples), what the
// CPU's `trace_shade::record_guides` and `shade_chunk` record for one ray per texel:
// `frame_surface` the albedo and the unit shading normal of a hit (zero normal otherwise: no
// surface record) and a zero Monte Carlo part; `frame_environment` the environment's occluded
// estimate as the Monte Carlo part (`shade::monte_carlo_part`: the lights' shadow rays, the
// emission and the unshadowed ambient term are exact, so they stay out of it).

// A sample layer of the frame (`fovea_gpu::frame::SampleLayer`) and its key's high word.
struct FrameLayer {
    offset: u32,
    width: u32,
    height: u32,
    key_hi: u32,
}

struct FrameParams {
    // Texels of the layer (the invocations that write).
    texels: u32,
    // FRAME_POLAR or FRAME_SCREEN.
    kind: u32,
    // +∞ as bits (WGSL may assume no infinities, so it arrives as data).
    inf_bits: u32,
    // 1: the environment as the unshadowed ambient term `ambient · albedo · (1 − metallic)`;
    // 0: its occluded estimate with env.samples rays.
    unshadowed: u32,
    layer: FrameLayer,
    // The ray's offset in its texel plus the plan's jitter, buffer texels (u, v).
    offset: vec2<f32>,
    // A screen-aligned texel's ray cone, radians.
    pixel_spread: f32,
    // Invocations per row of the dispatch's grid (its x size times the workgroup's).
    row_invocations: u32,
    // The environment's mean radiance (xyz).
    ambient: vec4<f32>,
    // The rank of texel (i, j) in its 4×4 tile: rank[j % 4][i % 4].
    rank: array<vec4<u32>, 4>,
    // 1: write the denoiser's guides (bindings 27–29); 0: leave them alone.
    guides: u32,
    // 1: the kernels run over the list of shaded texels (frame_compact.wgsl, bindings 35–36);
    // 0: over every texel, tile by tile.
    listed: u32,
    pad1: u32,
    pad2: u32,
}

// A polar buffer's column: its ring (radius, rows per turn), its rays' cone, and where its
// shaded runs of rows start in `frame_runs` (the next column's `runs` ends them).
struct FrameColumn {
    r_px: f32,
    period: f32,
    spread: f32,
    runs: u32,
}

@group(0) @binding(21) var<uniform> frame: FrameParams;
@group(0) @binding(22) var<storage, read> frame_columns: array<FrameColumn>;
@group(0) @binding(23) var<storage, read> frame_runs: array<vec2<u32>>;
@group(0) @binding(24) var<storage, read_write> frame_samples: array<vec4<f32>>;
// Per texel: (shading normal, t), (geometric normal, metallic).
@group(0) @binding(25) var<storage, read_write> frame_geometry: array<vec4<f32>>;
// Per texel: (albedo, roughness), (specular, state).
@group(0) @binding(26) var<storage, read_write> frame_material: array<vec4<f32>>;
// The denoiser's guides, per texel of the samples' layers (`DeviceGuides`): albedo (rgb),
// unit shading normal (xyz; zero: no surface), the colour's Monte Carlo part (rgb) with the
// temporal variance in its w (−1: none); the other w lanes 0.
@group(0) @binding(27) var<storage, read_write> frame_guide_albedo: array<vec4<f32>>;
@group(0) @binding(28) var<storage, read_write> frame_guide_normal: array<vec4<f32>>;
@group(0) @binding(29) var<storage, read_write> frame_guide_noisy: array<vec4<f32>>;

const FRAME_POLAR: u32 = 0u;
const FRAME_SCREEN: u32 = 1u;
// Weier's sparse pattern: screen-aligned, shaded where `sparse_shaded` (frame_sparse.wgsl,
// appended) says from the pattern's tables in `frame_runs`, each ray's cone `sparse_spread`.
const FRAME_SPARSE: u32 = 3u;
// A texel's state in `frame_material` (w of its second record).
const STATE_HIT: f32 = 0.0;
const STATE_MISS: f32 = 1.0;
const STATE_UNSHADED: f32 = 2.0;

// Whether row j of column i is one the mapping shades.
fn frame_shaded(i: u32, j: u32) -> bool {
    let a = frame_columns[i].runs;
    let b = frame_columns[i + 1u].runs;
    for (var r = a; r < b; r = r + 1u) {
        let run = frame_runs[r];
        if j >= run.x && j < run.y {
            return true;
        }
    }
    return false;
}

// The texel of invocation `id`: with `frame.listed` the id-th of the frame's shaded texels
// (frame_compact.wgsl, appended), else `frame_tile_texel`'s.
fn frame_texel(id: vec3<u32>) -> u32 {
    if frame.listed != 0u {
        return frame_listed(id);
    }
    return frame_tile_texel(id);
}

// The texel of invocation `id`, row-major in the layer (`frame.texels` and beyond: none).
// Each workgroup takes an 8×8 tile of texels, so that its rays run close together.
fn frame_tile_texel(id: vec3<u32>) -> u32 {
    let n = id.x + id.y * frame.row_invocations;
    let w = frame.layer.width;
    let tiles_x = (w + 7u) / 8u;
    let t = n / 64u;
    let l = n % 64u;
    let i = (t % tiles_x) * 8u + l % 8u;
    let j = (t / tiles_x) * 8u + l / 8u;
    if i >= w || j >= frame.layer.height {
        return frame.texels;
    }
    return j * w + i;
}

// Texel (i, j)'s ray: its screen point relative to the principal point (xy), its cone (z),
// and whether the plan shades the texel (w: 1 or 0).
fn frame_point(i: u32, j: u32) -> vec4<f32> {
    if frame.kind == FRAME_LAYERED {
        // Guenter's layers, the inset: frame_shade_layers.wgsl.
        return frame_layer_point(i, j);
    }
    if frame.kind != FRAME_POLAR {
        let p = camera.centre + vec2<f32>(f32(i) + frame.offset.x, f32(j) + frame.offset.y);
        if frame.kind == FRAME_SPARSE {
            // The cone from the screen point itself (p is relative to the principal point).
            let s = vec2<f32>(f32(i) + frame.offset.x, f32(j) + frame.offset.y);
            return vec4<f32>(p, sparse_spread(s), select(0.0, 1.0, sparse_shaded(i, j)));
        }
        return vec4<f32>(p, frame.pixel_spread, 1.0);
    }
    var shaded = frame_shaded(i, j);
    let c = frame_columns[i];
    let v = f32(j) + frame.offset.y;
    var p = camera.centre;
    // `Ring::polar`: a ring without rows has only the pole, at v = 0.
    if c.period <= 0.0 {
        shaded = shaded && v == 0.0;
    } else {
        shaded = shaded && v >= 0.0 && v <= c.period;
        p = camera.centre + c.r_px * cos_sin_turns(v / c.period, camera.rad_per_turn);
    }
    return vec4<f32>(p, c.spread, select(0.0, 1.0, shaded));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_surface(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels {
        return;
    }
    let w = frame.layer.width;
    let q = frame_point(k % w, k / w);
    let out = frame.layer.offset + k;
    let unshaded = vec4<f32>(0.0, 0.0, 0.0, bitcast<f32>(frame.inf_bits));
    if frame.guides != 0u {
        // No surface record until a hit says otherwise; the emission is exact.
        frame_guide_albedo[out] = vec4<f32>(0.0);
        frame_guide_normal[out] = vec4<f32>(0.0);
        // w: no temporal variance (the denoiser's spatial estimate; a temporal pass would
        // write its moments' variance here).
        frame_guide_noisy[out] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    if q.w == 0.0 {
        frame_samples[out] = unshaded;
        frame_material[2u * k + 1u] = vec4<f32>(0.0, 0.0, 0.0, STATE_UNSHADED);
        return;
    }
    let ray = camera_ray(q.xy);
    let g = surface_at(ray.origin, ray.dir, traverse(ray, false), q.z);
    if g.material == MISS {
        frame_samples[out] = unshaded;
        frame_material[2u * k + 1u] = vec4<f32>(0.0, 0.0, 0.0, STATE_MISS);
        return;
    }
    if frame.guides != 0u {
        // `record_guides` of one ray: its albedo, its normal normalised (`normalize_or_zero`).
        frame_guide_albedo[out] = vec4<f32>(g.albedo, 0.0);
        let len2 = dot(g.normal, g.normal);
        if len2 > 0.0 {
            frame_guide_normal[out] = vec4<f32>(g.normal * (1.0 / sqrt(len2)), 0.0);
        }
    }
    frame_samples[out] = vec4<f32>(g.emissive, g.t * dot(ray.dir, camera.forward));
    frame_geometry[2u * k] = vec4<f32>(g.normal, g.t);
    frame_geometry[2u * k + 1u] = vec4<f32>(g.face_normal, g.metallic);
    frame_material[2u * k] = vec4<f32>(g.albedo, g.roughness);
    frame_material[2u * k + 1u] = vec4<f32>(g.specular, STATE_HIT);
}

// Texel k's surface record as `Surface` (direct_light.wgsl), with its key
// (`texel_key(layer, i, j)` with the frame's and the eye's fields, `with_frame`), rebuilt from
// the G-buffer and the ray placed again: surface.wgsl's `position = origin + dir · t` and
// `to_eye = −dir`.
fn frame_record(k: u32, ray: Ray) -> Surface {
    let w = frame.layer.width;
    let i = k % w;
    let j = k / w;
    let g0 = frame_geometry[2u * k];
    let g1 = frame_geometry[2u * k + 1u];
    let m0 = frame_material[2u * k];
    let m1 = frame_material[2u * k + 1u];
    let key_lo = frame.rank[j % 4u][i % 4u] | (((i / 4u) & 0x3fffu) << 4u) | (((j / 4u) & 0x3fffu) << 18u);
    let position = ray.origin + ray.dir * g0.w;
    return Surface(position, g0.w, g0.xyz, g1.w, g1.xyz, m0.w, -ray.dir, key_lo, m0.xyz, frame.layer.key_hi, m1.xyz, 0.0);
}

// The ray of texel k, placed again as frame_surface placed it (the same arithmetic: the same
// bits).
fn frame_ray(k: u32) -> Ray {
    let w = frame.layer.width;
    return camera_ray(frame_point(k % w, k / w).xy);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_direct(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels {
        return;
    }
    let state = frame_material[2u * k + 1u].w;
    if state == STATE_UNSHADED {
        return;
    }
    let out = frame.layer.offset + k;
    let ray = frame_ray(k);
    if state == STATE_MISS {
        frame_samples[out] = vec4<f32>(env_radiance(ray.dir), bitcast<f32>(frame.inf_bits));
        return;
    }
    // `shade` in direct shading: emission (written), then the lights.
    let before = frame_samples[out];
    frame_samples[out] = vec4<f32>(before.xyz + direct_at(frame_record(k, ray)).xyz, before.w);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_environment(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_texel(id);
    if k >= frame.texels || frame_material[2u * k + 1u].w != STATE_HIT {
        return;
    }
    let out = frame.layer.offset + k;
    let before = frame_samples[out];
    var c = before.xyz;
    if frame.unshadowed != 0u {
        // The unshadowed ambient term `mean · albedo · (1 − metallic)`.
        c = c + frame.ambient.xyz * frame_material[2u * k].xyz * (1.0 - frame_geometry[2u * k + 1u].w);
    } else if env.samples > 0u {
        let e = environment_at(frame_record(k, frame_ray(k))).xyz;
        c = c + e;
        if frame.guides != 0u {
            // The occluded environment's estimate: the Monte Carlo part.
            frame_guide_noisy[out] = vec4<f32>(e, -1.0);
        }
    } else {
        return;
    }
    frame_samples[out] = vec4<f32>(c, before.w);
}
