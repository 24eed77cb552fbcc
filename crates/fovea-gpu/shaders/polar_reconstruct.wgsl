// polar_reconstruct.wgsl: a polar sample buffer (VaFR, KFR, LaFR, visual-polar) back to the
// screen, one invocation per screen pixel (VaFR Sec. 3.4 / Eq. 10–11, the reconstruct stage).
// The GPU twin of `fovea_post::inverse_map`'s polar loop; see src/reconstruct.rs.
//
// Everything derived is computed by the Rust side and uploaded (`fovea_post::inverse_map::
// PolarTables`): the u(r) lookup table (the mapping's own forward map every 1/8 px of radius),
// the padded columns (each column's last row copied before its first and its first after its
// last, so a lookup never wraps), angularly prefiltered for the footprint filter, and the
// radial footprint du/dr per column. The shader only interpolates:
//
// 1. u from the table, linear between entries; past the last column's outer edge (or where
//    the mapping has no sample) the pixel is black at the miss depth;
// 2. the angle in turns with common.wgsl's own atan (lavapipe's atan2 is ~1e-5 rad off);
// 3. bilinear across the two nearest columns, each read at its own angle v = turn·period;
// 4. the footprint filter (`footprint != 0`): where a pixel spans more than one column, a box
//    of du/dr columns, each weighted by its overlap.
//
// Colour and depth travel as u32 bit patterns (`vec4<u32>`: r, g, b, depth): depth is
// +∞ for misses, and WGSL lets an implementation assume that no float is infinite, so depth
// is only ever copied, never read as a float.
//
// Two entry points, the same pixels: `reconstruct` writes `vec4<u32>` a pixel (the per-call
// path, in bands), `reconstruct_planes` writes four planes of 4 bytes a pixel — red, green,
// blue, depth — straight into the resident screen's buffers (src/frame/reconstruct.rs), so no
// binding holds more than 4 bytes a pixel (an 8K plane is 126.6 MiB; issue 37).

struct ReconstructParams {
    // The pole (gaze), screen pixels, as the f32 pair hi + lo.
    pole_hi: vec2<f32>,
    pole_lo: vec2<f32>,
    // Screen width, pixels.
    width: u32,
    // First screen row of this dispatch (the screen is split into bands that fit the
    // adapter's storage-binding limit).
    row0: u32,
    // Rows in this band.
    band_rows: u32,
    // Largest table index k with k + 1 in the table (len − 2).
    lut_max_k: u32,
    // 1 / table step (8 per pixel).
    inv_step: f32,
    // last + 1: past this u (a texel's outer edge) the pixel is uncovered.
    cols_end: f32,
    // The last column with shaded rows.
    last: u32,
    // Depth bits of an uncovered pixel (+∞).
    miss_depth_bits: u32,
    // 1: footprint filter, 0: bilinear.
    footprint: u32,
    // 1/(2π).
    turns_per_rad: f32,
    // 2π.
    rad_per_turn: f32,
    pad: u32,
}

// One column: first stored texel, stored rows, rows per turn, columns per pixel radially.
struct Column {
    base: u32,
    rows: u32,
    period: f32,
    texels_per_px: f32,
}

@group(0) @binding(0) var<uniform> params: ReconstructParams;
@group(0) @binding(1) var<storage, read> lut: array<f32>;
@group(0) @binding(2) var<storage, read> columns: array<Column>;
@group(0) @binding(3) var<storage, read> texels: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> out_px: array<vec4<u32>>;
// `reconstruct_planes`' output: one plane each of red, green, blue and depth bits.
@group(0) @binding(5) var<storage, read_write> out_red: array<u32>;
@group(0) @binding(6) var<storage, read_write> out_green: array<u32>;
@group(0) @binding(7) var<storage, read_write> out_blue: array<u32>;
@group(0) @binding(8) var<storage, read_write> out_depth: array<u32>;

struct Lookup {
    rgb: vec3<f32>,
    depth_bits: u32,
}

// Column i at the angle `turn` in [0, 1]: colour linear between the two rows around
// v = turn·period (stored at jf and jf + 1, the padding making the wrap a plain read), depth
// of the nearer. v ≥ ½, so u32() is a floor; the clamp keeps any rounding inside the column.
fn read_column(i: u32, turn: f32) -> Lookup {
    let col = columns[i];
    let v = turn * col.period + 0.5;
    let jf = min(u32(v), col.rows);
    let k = col.base + jf;
    let a = texels[k];
    let b = texels[k + 1u];
    let f = v - f32(jf);
    let ca = bitcast<vec3<f32>>(a.xyz);
    let cb = bitcast<vec3<f32>>(b.xyz);
    var d = a.w;
    if !(f < 0.5) {
        d = b.w;
    }
    return Lookup(ca + (cb - ca) * f, d);
}

// The colour boxed over `width` ≥ 1 columns centred on `uc` (column centres at integers):
// every column i in [uc − width/2, uc + width/2] read at the angle and weighted by its
// overlap with [i − ½, i + ½]; columns outside 0..=last left out.
fn box_across_columns(uc: f32, width: f32, turn: f32) -> vec3<f32> {
    let lo = uc - 0.5 * width;
    let hi = uc + 0.5 * width;
    let first = u32(max(floor(lo + 0.5), 0.0));
    let end = min(u32(max(floor(hi + 0.5), 0.0)), params.last);
    var sum = vec3<f32>(0.0, 0.0, 0.0);
    var weight = 0.0;
    for (var i = first; i <= end; i = i + 1u) {
        let w = min(hi, f32(i) + 0.5) - max(lo, f32(i) - 0.5);
        if w > 0.0 {
            sum = sum + w * read_column(i, turn).rgb;
            weight = weight + w;
        }
    }
    if weight > 0.0 {
        return sum / weight;
    }
    // uc ≥ 0: floor(uc + ½) rounds half away from zero, as the CPU's f32::round.
    return read_column(u32(clamp(floor(uc + 0.5), 0.0, f32(params.last))), turn).rgb;
}

// The pixel (x, y): RGB bits and depth bits.
fn reconstruct_pixel(x: u32, y: u32) -> vec4<u32> {
    let p = vec2<f32>(f32(x) + 0.5, f32(y) + 0.5);
    let d = offset_from_pole(p, params.pole_hi, params.pole_lo);
    // 1. u(r) − ½ from the table (texel centres at integers).
    let t = sqrt(d.x * d.x + d.y * d.y) * params.inv_step;
    let k = min(u32(t), params.lut_max_k);
    let f = min(t - f32(k), 1.0);
    var u = lut[k];
    // (`f > 0` keeps a covered entry next to an uncovered one as it is.)
    if f > 0.0 {
        u = lut[k] + (lut[k + 1u] - lut[k]) * f;
    }
    u = u - 0.5;
    if !(u <= params.cols_end) {
        return vec4<u32>(0u, 0u, 0u, params.miss_depth_bits);
    }
    let uc = clamp(u, 0.0, f32(params.last));
    // 2. The angle.
    let turn = angle_turns(d.x, d.y, params.turns_per_rad, params.rad_per_turn);
    // 3. Bilinear across the two nearest columns.
    let i0 = u32(uc);
    let i1 = min(i0 + 1u, params.last);
    let fu = uc - f32(i0);
    let a = read_column(i0, turn);
    let b = read_column(i1, turn);
    var rgb = a.rgb + (b.rgb - a.rgb) * fu;
    var depth = a.depth_bits;
    if !(fu < 0.5) {
        depth = b.depth_bits;
    }
    // 4. The pixel's radial footprint where it spans more than one column.
    if params.footprint != 0u {
        let t0 = columns[i0].texels_per_px;
        let t1 = columns[i1].texels_per_px;
        if max(t0, t1) > 1.0 {
            let width = t0 + (t1 - t0) * fu;
            rgb = box_across_columns(uc, max(width, 1.0), turn);
        }
    }
    return vec4<u32>(bitcast<vec3<u32>>(rgb), depth);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn reconstruct(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    if x >= params.width || gid.y >= params.band_rows {
        return;
    }
    out_px[gid.y * params.width + x] = reconstruct_pixel(x, params.row0 + gid.y);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn reconstruct_planes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    if x >= params.width || gid.y >= params.band_rows {
        return;
    }
    let index = gid.y * params.width + x;
    let px = reconstruct_pixel(x, params.row0 + gid.y);
    out_red[index] = px.x;
    out_green[index] = px.y;
    out_blue[index] = px.z;
    out_depth[index] = px.w;
}
