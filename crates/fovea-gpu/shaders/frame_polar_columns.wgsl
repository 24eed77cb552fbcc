// frame_polar_columns.wgsl: a polar sample buffer on the device (`frame::DeviceSamples`,
// `vec4<f32>` texels: RGB, depth) laid out as the reconstruction reads it — column after
// column, each padded by one row on either side, and for the footprint filter each column's
// colour boxed along its rows to a pixel's width (VaFR Sec. 3.4; the prefilter of
// `fovea_post::inverse_map::PolarColumns::new` and `box_along_column`). The resident frame's
// replacement for the CPU building these columns and uploading them (src/frame/reconstruct.rs).
//
// One invocation per stored texel: x = the stored row p (0 = the copy of the last row,
// 1..=n the rows, n + 1 = the copy of the first), y = the column. Column i has n shaded rows
// (n = 0: one black texel at +∞ depth stored three times, as on the CPU).
//
// The prefilter: with `extra[i] > 1e-3`, row j's colour is the mean over the cyclic box
// [j − w/2, j + w/2] (w = extra[i] rows, each row standing for a unit interval, fractional ends
// weighted by their overlap); w ≥ n gives the column's mean. The CPU sums the same overlaps
// through f64 prefix sums; here they are summed directly in f32 (≤ n + 2 terms a texel).
//
// With sample-space AA (`aa != 0`), a column's colour comes from the AA pass's output (RGB
// f32, row-major at the layer's width) unless the column is kept (`keep[i] != 0`: its texels
// are denser than the screen both ways, and the CPU restores them after AA:
// `fovea_render::pipeline::sample_post`'s `restore_columns`); depth always from the samples.
//
// Colour and depth are moved as u32 bits; depth is never read as a float (+∞ for misses, and
// WGSL lets an implementation assume no float is infinite).

struct PadParams {
    // The layer's first texel in the sample buffer.
    offset: u32,
    // The layer's width in texels (row stride).
    width: u32,
    // Columns to lay out.
    n_columns: u32,
    // Most stored texels of any column (rows + 2).
    stored_max: u32,
    // 1: colour from the AA output where the column is not kept.
    aa: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// The reconstruction's column record (polar_reconstruct.wgsl's `Column`).
struct PadColumn {
    base: u32,
    rows: u32,
    period: f32,
    texels_per_px: f32,
}

@group(0) @binding(0) var<uniform> params: PadParams;
@group(0) @binding(1) var<storage, read> columns: array<PadColumn>;
@group(0) @binding(2) var<storage, read> extra: array<f32>;
@group(0) @binding(3) var<storage, read> samples: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> texels: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read> aa_rgb: array<f32>;
@group(0) @binding(6) var<storage, read> keep: array<u32>;

// The colour of column i's row j (j < n): the AA output's, or the samples'.
fn sample_rgb(i: u32, j: u32) -> vec3<f32> {
    let k = j * params.width + i;
    if params.aa != 0u && keep[i] == 0u {
        return vec3<f32>(aa_rgb[3u * k], aa_rgb[3u * k + 1u], aa_rgb[3u * k + 2u]);
    }
    return bitcast<vec3<f32>>(samples[params.offset + k].xyz);
}

// The mean colour over the cyclic box of `w` rows centred on row j of column i (n rows).
fn box_along_column(i: u32, j: u32, n: u32, w: f32) -> vec3<f32> {
    var sum = vec3<f32>(0.0, 0.0, 0.0);
    if w >= f32(n) {
        for (var m = 0u; m < n; m = m + 1u) {
            sum = sum + sample_rgb(i, m);
        }
        return sum / f32(n);
    }
    // Offsets from row j (texel j + d covers [d − ½, d + ½]): small numbers, so a narrow
    // box's overlaps keep their precision however far down the column j lies.
    let h = 0.5 * w;
    let d0 = i32(floor(0.5 - h));
    let d1 = i32(floor(h + 0.5));
    let ni = i32(n);
    let ji = i32(j);
    for (var d = d0; d <= d1; d = d + 1) {
        let overlap = min(h, f32(d) + 0.5) - max(-h, f32(d) - 0.5);
        if overlap > 0.0 {
            let k = (((ji + d) % ni) + ni) % ni;
            sum = sum + overlap * sample_rgb(i, u32(k));
        }
    }
    return sum / w;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn pad_columns(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    let i = gid.y;
    if i >= params.n_columns {
        return;
    }
    let col = columns[i];
    // A column without shaded rows has period 0 and one stored row.
    var n = col.rows;
    if col.period == 0.0 {
        n = 0u;
    }
    if n == 0u {
        if p < 3u {
            texels[col.base + p] = vec4<u32>(0u, 0u, 0u, 0x7f800000u);
        }
        return;
    }
    if p >= n + 2u {
        return;
    }
    var j = p - 1u;
    if p == 0u {
        j = n - 1u;
    } else if p == n + 1u {
        j = 0u;
    }
    let depth_bits = samples[params.offset + j * params.width + i].w;
    var rgb = sample_rgb(i, j);
    let w = extra[i];
    if w > 1e-3 {
        rgb = box_along_column(i, j, n, w);
    }
    texels[col.base + p] = vec4<u32>(bitcast<vec3<u32>>(rgb), depth_bits);
}
