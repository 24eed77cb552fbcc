// frame_shade_layers.wgsl: the resident sample kernels' rays for screen-aligned layered
// buffers (Guenter et al. 2012's nested layers, the inset of Liu et al.), appended to the
// shade module before frame_shade.wgsl, whose `frame_point` asks `frame_layer_point` for a
// texel when `frame.kind` is FRAME_LAYERED. One dispatch per layer, each layer's block at
// binding 30 (`fovea_gpu::frame::layers::ShadeLayerGpu`).
//
// Texel (i, j) of a layer covering the screen rectangle from `origin` at `scale` pixels a
// texel goes through the screen point `origin + (i + offset, j + offset) · scale`
// (`Layers::inverse` of fovea-core); it is shaded where its centre lies on the screen, the
// rectangle `shaded` of the layer (`Layers::is_shaded`, decided on the CPU in f64). Its cone
// is `sample_spread_rad`'s for a layered mapping in closed form: the sample spacing
// `scale(r) · c_r · cos² e` with `tan e = c_r · r` (the layer's scale divides the screen's
// own rate, VaFR Eq. 13), `r` the point's distance from the gaze, clamped to
// [floor, 10°]; `scale(r)` is the step function of the CPU mapping's rates (the layer owning
// the point at distance `r` along the mapping's probe direction), uploaded as its steps.

struct FrameScreenLayer {
    // The layer's origin minus the principal point, pixels.
    origin: vec2<f32>,
    // Screen pixels per texel.
    scale: f32,
    // Steps of `scale(r)` in use (at most 8).
    steps: u32,
    // Shaded texels: i in [x, y), j in [z, w).
    shaded: vec4<u32>,
    // The gaze minus the principal point, pixels.
    gaze: vec2<f32>,
    // Tangent of the eccentricity per pixel (`DisplayProfile::c_r`).
    c_r: f32,
    // The narrowest cone, radians (`SampleFootprint::floor_rad`).
    floor_rad: f32,
    // The widest cone, radians (10°).
    max_rad: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
    // Step n starts at radius step_r[n / 4][n % 4] (pixels, increasing) with the scale
    // step_scale[n / 4][n % 4] (0: no layer there, the floor).
    step_r: array<vec4<f32>, 2>,
    step_scale: array<vec4<f32>, 2>,
}

@group(0) @binding(30) var<uniform> frame_layer: FrameScreenLayer;

const FRAME_LAYERED: u32 = 2u;

// Texel (i, j)'s ray of a layered buffer: its screen point relative to the principal point
// (xy), its cone (z), whether the plan shades it (w: 1 or 0); as `frame_point`.
fn frame_layer_point(i: u32, j: u32) -> vec4<f32> {
    let s = frame_layer.shaded;
    let shaded = i >= s.x && i < s.y && j >= s.z && j < s.w;
    let p = frame_layer.origin + vec2<f32>(f32(i) + frame.offset.x, f32(j) + frame.offset.y) * frame_layer.scale;
    let r = length(p - frame_layer.gaze);
    var scale = 0.0;
    for (var n = 0u; n < frame_layer.steps; n = n + 1u) {
        if r >= frame_layer.step_r[n / 4u][n % 4u] {
            scale = frame_layer.step_scale[n / 4u][n % 4u];
        }
    }
    let t = frame_layer.c_r * r;
    let spread = max(min(scale * frame_layer.c_r / (1.0 + t * t), frame_layer.max_rad), frame_layer.floor_rad);
    return vec4<f32>(p, spread, select(0.0, 1.0, shaded));
}
