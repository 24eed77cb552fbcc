// tonemap.wgsl: exposure, tone curve and 8-bit sRGB encoding of linear RGB (IEC 61966-2-1's
// transfer function; Reinhard et al. 2002's x/(1+x) curve; DESIGN.md stage 7's tone map).
// The GPU twin of `fovea_post::tonemap::to_srgb8`; see src/tonemap.rs.
//
// Per value v (one invocation packs four consecutive channel values into one u32, byte k at
// bits 8k, so the output is the CPU's byte vector):
//
//   x = max(v·k, 0)                 k = 2^stops, computed by the Rust side
//   x = x / (1 + x)                 (curve 1, Reinhard; curve 0 clips)
//   code = #{thresholds ≤ x}        the 255 linear thresholds where the rounded sRGB code
//                                   steps (`tonemap::srgb8_thresholds`, uploaded)
//
// Non-finite values (and v·k overflowing) encode as 0, as on the CPU; they are classified by
// their bits because WGSL lets an implementation assume no float is infinite or NaN.
//
// Two entry points, the same encoding: `tonemap` reads the values interleaved (r, g, b a
// pixel: `Image<Rgb>`'s layout, the per-call path), `tonemap_planes` reads them as three
// planes of one channel each (the resident screen's layout, so that no binding is larger than
// 4 bytes a pixel: an 8K screen's plane is 126.6 MiB, within lavapipe's 128 MiB; issue 37).
// Value v is channel v % 3 of pixel v / 3 either way, so the output bytes are the same.

struct ToneParams {
    // Channel values (3 per pixel).
    n_values: u32,
    // Output words (ceil(n_values / 4)).
    n_words: u32,
    // 2^exposure_stops.
    scale: f32,
    // 0 clamp, 1 Reinhard.
    curve: u32,
}

@group(0) @binding(0) var<uniform> params: ToneParams;
@group(0) @binding(1) var<storage, read> values: array<u32>;
@group(0) @binding(2) var<storage, read> thresholds: array<f32, 255>;
@group(0) @binding(3) var<storage, read_write> out_words: array<u32>;
// `tonemap_planes`' input: one plane a channel.
@group(0) @binding(4) var<storage, read> red: array<u32>;
@group(0) @binding(5) var<storage, read> green: array<u32>;
@group(0) @binding(6) var<storage, read> blue: array<u32>;

const EXPONENT_MASK: u32 = 0x7f800000u;

fn finite(bits: u32) -> bool {
    return (bits & EXPONENT_MASK) != EXPONENT_MASK;
}

// The sRGB code of one linear value's bits.
fn encode(bits: u32) -> u32 {
    if !finite(bits) {
        return 0u;
    }
    var x = max(bitcast<f32>(bits) * params.scale, 0.0);
    if !finite(bitcast<u32>(x)) {
        return 0u;
    }
    if params.curve == 1u {
        x = x / (1.0 + x);
    }
    // Binary search: the number of thresholds ≤ x.
    var lo = 0u;
    var hi = 255u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if thresholds[mid] <= x {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tonemap(@builtin(global_invocation_id) id: vec3<u32>) {
    let wi = id.y * 65535u * WORKGROUP_SIZE + id.x;
    if wi >= params.n_words {
        return;
    }
    var word = 0u;
    for (var b = 0u; b < 4u; b++) {
        let v = 4u * wi + b;
        if v < params.n_values {
            word |= encode(values[v]) << (8u * b);
        }
    }
    out_words[wi] = word;
}

// Value v of the planes: channel v % 3 of pixel v / 3.
fn plane_value(v: u32) -> u32 {
    let k = v / 3u;
    switch v % 3u {
        case 0u: {
            return red[k];
        }
        case 1u: {
            return green[k];
        }
        default: {
            return blue[k];
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tonemap_planes(@builtin(global_invocation_id) id: vec3<u32>) {
    let wi = id.y * 65535u * WORKGROUP_SIZE + id.x;
    if wi >= params.n_words {
        return;
    }
    var word = 0u;
    for (var b = 0u; b < 4u; b++) {
        let v = 4u * wi + b;
        if v < params.n_values {
            word |= encode(plane_value(v)) << (8u * b);
        }
    }
    out_words[wi] = word;
}
