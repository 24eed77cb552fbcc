// frame_layers.wgsl: the resident frame's reconstruction of screen-aligned layered sample
// buffers (Guenter et al. 2012's nested layers; see src/frame/layers.rs), the twin of
// `fovea_post::inverse_map`'s `layered`: per screen pixel, the finest layer owning its centre
// (its rectangle, and its disc where it has one: `ScreenLayer::contains`), the layer's
// coordinates `(p − origin) / scale`, bilinear between the four nearest texels clamped to
// the layer's shaded rectangle, and the nearest texel's depth. Output: the screen's
// `vec4<u32>` pixels (RGB bits, depth bits), as the polar reconstruction writes them; a pixel
// no layer owns is black at +∞.
//
// With `strip` > 0 (the inset with the naive alpha blend of Liu et al. Sec. 3.1, as
// `fovea_post::inset_smoothing::composite`): a pixel of the inset (layer 0) within `strip`
// pixels of a boundary edge that is not the screen's (`boundary_distance`: whole pixels, the
// border pixel at d = 0) takes the periphery's (layer 1) bilinear colour with weight
// 1 − (d + ½)/strip. The depth stays the layer's.

struct LayerRecord {
    origin: vec2<f32>,
    size: vec2<f32>,
    // Centre (xy), radius (z), 1 where the layer has a disc (w).
    disc: vec4<f32>,
    // The shaded rectangle, inclusive: i0, i1, j0, j1.
    rect: vec4<u32>,
    scale: f32,
    offset: u32,
    width: u32,
    pad: u32,
}

struct LayersParams {
    width: u32,
    height: u32,
    count: u32,
    inf_bits: u32,
    // The inset's rectangle, inclusive: x0, y0, x1, y1.
    inset: vec4<u32>,
    // The alpha blend's strip, pixels (0: a hard boundary).
    strip: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
    layers: array<LayerRecord, 4>,
}

@group(0) @binding(0) var<uniform> params: LayersParams;
@group(0) @binding(1) var<storage, read> samples: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> screen: array<vec4<u32>>;

// Texel (i, j) of layer l as bits: RGB, depth (+∞ for a miss, copied as bits, never read as
// a float).
fn layer_texel(l: LayerRecord, i: u32, j: u32) -> vec4<u32> {
    return samples[l.offset + j * l.width + i];
}

// Layer l's bilinear colour at f (texel coordinates, already clamped to its shaded
// rectangle r): `layered`'s lookup.
fn layer_bilinear(l: LayerRecord, f: vec2<f32>) -> vec3<f32> {
    let r = l.rect;
    let a = vec2<u32>(floor(f));
    let b = vec2<u32>(min(a.x + 1u, r.y), min(a.y + 1u, r.w));
    let t = f - vec2<f32>(a);
    let c00 = bitcast<vec3<f32>>(layer_texel(l, a.x, a.y).xyz);
    let c10 = bitcast<vec3<f32>>(layer_texel(l, b.x, a.y).xyz);
    let c01 = bitcast<vec3<f32>>(layer_texel(l, a.x, b.y).xyz);
    let c11 = bitcast<vec3<f32>>(layer_texel(l, b.x, b.y).xyz);
    let top = c00 + (c10 - c00) * t.x;
    let bot = c01 + (c11 - c01) * t.x;
    return top + (bot - top) * t.y;
}

// Layer l's texel coordinates of screen point p, clamped to its shaded rectangle.
fn layer_coords(l: LayerRecord, p: vec2<f32>) -> vec2<f32> {
    let u = (p - l.origin) / l.scale;
    let r = l.rect;
    return clamp(u - vec2<f32>(0.5), vec2<f32>(f32(r.x), f32(r.z)), vec2<f32>(f32(r.y), f32(r.w)));
}

// Whole pixels from inset pixel (x, y) to the nearest boundary edge that is not the
// screen's (`boundary_distance` inside the rectangle); 0xffffffff where there is none.
fn inset_distance(x: u32, y: u32) -> u32 {
    let q = params.inset;
    var d = 0xffffffffu;
    if q.x > 0u {
        d = min(d, x - q.x);
    }
    if q.z + 1u < params.width {
        d = min(d, q.z - x);
    }
    if q.y > 0u {
        d = min(d, y - q.y);
    }
    if q.w + 1u < params.height {
        d = min(d, q.w - y);
    }
    return d;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn reconstruct_layers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let p = vec2<f32>(f32(x) + 0.5, f32(y) + 0.5);
    var k = params.count;
    for (var n = 0u; n < params.count; n = n + 1u) {
        let l = params.layers[n];
        let hi = l.origin + l.size;
        var inside = p.x >= l.origin.x && p.x < hi.x && p.y >= l.origin.y && p.y < hi.y;
        if inside && l.disc.w != 0.0 {
            inside = length(p - l.disc.xy) <= l.disc.z;
        }
        if inside {
            k = n;
            break;
        }
    }
    let out = y * params.width + x;
    if k >= params.count {
        screen[out] = vec4<u32>(0u, 0u, 0u, params.inf_bits);
        return;
    }
    let l = params.layers[k];
    let r = l.rect;
    let f = layer_coords(l, p);
    var c = layer_bilinear(l, f);
    if params.strip > 0u && k == 0u && params.count > 1u {
        let d = inset_distance(x, y);
        if d < params.strip {
            let a_low = 1.0 - (f32(d) + 0.5) / f32(params.strip);
            let periphery = params.layers[1];
            let low = layer_bilinear(periphery, layer_coords(periphery, p));
            c = c + (low - c) * a_low;
        }
    }
    // Rust's `round` (half away from zero) of a coordinate ≥ 0.
    let nearest = vec2<u32>(floor(f + vec2<f32>(0.5)));
    let d = layer_texel(l, min(nearest.x, r.y), min(nearest.y, r.w)).w;
    screen[out] = vec4<u32>(bitcast<vec3<u32>>(c), d);
}
