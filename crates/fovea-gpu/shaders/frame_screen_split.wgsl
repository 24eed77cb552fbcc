// frame_screen_split.wgsl: one screen of `vec4<u32>` pixels (RGB bits, depth bits: what the
// polar reconstruction writes, or a full-resolution sample buffer, which is the screen) split
// into the planar buffers the screen post reads — linear RGB as 3 × f32 a pixel (the DOF's and
// the tone map's input, `Image<Rgb>`'s layout) and depth as u32 bits (the CoC pass's input).
// Bits are copied, never read as floats (depth is +∞ for misses). See src/frame/screen.rs.
//
// Two entry points: `split_screen` writes the colour interleaved (the sample-space AA's input),
// `split_planes` as three planes of one channel each (the resident screen's layout: no binding
// larger than 4 bytes a pixel, so an 8K screen fits lavapipe's 128 MiB bindings; issue 37).

struct SplitParams {
    // The screen's first pixel in the source buffer (a sample layer's offset, or 0).
    offset: u32,
    // Screen width, pixels.
    width: u32,
    // Screen height, pixels.
    height: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> params: SplitParams;
@group(0) @binding(1) var<storage, read> screen: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> color: array<u32>;
@group(0) @binding(3) var<storage, read_write> depth: array<u32>;
@group(0) @binding(4) var<storage, read_write> red: array<u32>;
@group(0) @binding(5) var<storage, read_write> green: array<u32>;
@group(0) @binding(6) var<storage, read_write> blue: array<u32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn split_screen(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let k = y * params.width + x;
    let px = screen[params.offset + k];
    color[3u * k] = px.x;
    color[3u * k + 1u] = px.y;
    color[3u * k + 2u] = px.z;
    depth[k] = px.w;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn split_planes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let k = y * params.width + x;
    let px = screen[params.offset + k];
    red[k] = px.x;
    green[k] = px.y;
    blue[k] = px.z;
    depth[k] = px.w;
}

// Weier's pull-push works on an interleaved pyramid (`shaders/pull_push.wgsl`, level 0 the
// screen): `planes_to_rgb` copies the planes into its level 0 before the pull, `rgb_to_planes`
// copies the push's result back (src/frame/pull_push.rs). Bits only, as above.
@compute @workgroup_size(WORKGROUP_SIZE)
fn planes_to_rgb(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let k = y * params.width + x;
    color[3u * k] = red[k];
    color[3u * k + 1u] = green[k];
    color[3u * k + 2u] = blue[k];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn rgb_to_planes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let k = y * params.width + x;
    red[k] = color[3u * k];
    green[k] = color[3u * k + 1u];
    blue[k] = color[3u * k + 2u];
}
