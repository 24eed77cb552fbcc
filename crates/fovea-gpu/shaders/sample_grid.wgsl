// sample_grid.wgsl: neighbours inside a sample buffer, for the sample-space AA passes
// (fxaa.wgsl, gaussian_aa.wgsl); the twin of `fovea_post::grid::Grid::step`. Appended to
// common.wgsl and prepended to each AA module (WGSL has no include); see src/sample_aa.rs.
//
// The buffer is `width × height` texels, RGB f32, texel (i, j) at index j·width + i (column i
// along x, row j along y, as `fovea_core::Image`). Two topologies:
//
// * rect (`polar == 0`): neighbours clamped at the border;
// * polar (`polar == 1`, VaFR / visual-polar / KFR / LaFR buffers): column i holds
//   `rows[i]` texels and rows wrap at the angular seam; the neighbour of (i, j) in column
//   i ± 1 is the row at the same angle, `round((j + ½)·period[i±1]/period[i] − ½)` wrapped.
//
// Every derived number is the Rust side's: per column the shaded rows and the column reached
// one step left and right (the column itself where that one is missing or empty, as the CPU
// stays), and per texel the two angle-aligned rows (computed in f64 by `Grid::step` itself:
// in f32 the product (j + ½)·scale rounds differently near half-integers and would move
// hundreds of neighbours in a VaFR buffer). The shader only indexes and wraps.

struct SampleAaParams {
    // Texels per row (columns) and rows of the buffer.
    width: u32,
    height: u32,
    // 1: polar (rows wrap, columns aligned by angle through `align`), 0: rect (clamped).
    polar: u32,
    // FXAA: steps of the edge search each way (`FxaaParams::search_steps`).
    search_steps: u32,
    // FXAA: relative and absolute contrast thresholds, sub-pixel amount (`FxaaParams`).
    edge_threshold: f32,
    edge_threshold_min: f32,
    subpix: f32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> params: SampleAaParams;
// RGB of every texel, 3 floats each.
@group(0) @binding(1) var<storage, read> texels: array<f32>;
// Per column: (shaded rows, column one step left, column one step right, 0).
@group(0) @binding(2) var<storage, read> columns: array<vec4<u32>>;
// Per texel (polar only): the row at its angle in the left column (low 16 bits) and in the
// right column (high 16 bits), already wrapped. One entry for a rect buffer (unused).
@group(0) @binding(3) var<storage, read> align: array<u32>;
// The filtered RGB of every texel, 3 floats each.
@group(0) @binding(5) var<storage, read_write> out_rgb: array<f32>;

fn texel_index(p: vec2<u32>) -> u32 {
    return p.y * params.width + p.x;
}

fn rgb_at(p: vec2<u32>) -> vec3<f32> {
    let k = 3u * texel_index(p);
    return vec3<f32>(texels[k], texels[k + 1u], texels[k + 2u]);
}

fn write_rgb(p: vec2<u32>, c: vec3<f32>) {
    let k = 3u * texel_index(p);
    out_rgb[k] = c.x;
    out_rgb[k + 1u] = c.y;
    out_rgb[k + 2u] = c.z;
}

// Whether (i, j) holds a sample (a rect's columns have `height` rows).
fn is_valid(p: vec2<u32>) -> bool {
    return p.y < columns[p.x].x;
}

// One column left (di < 0) or right (di > 0) at the same angle; di = 0 stays.
fn step_column(p: vec2<u32>, di: i32) -> vec2<u32> {
    if di == 0 {
        return p;
    }
    let c = columns[p.x];
    var ni = c.z;
    if di < 0 {
        ni = c.y;
    }
    if ni == p.x {
        return p;
    }
    if params.polar == 0u {
        return vec2<u32>(ni, p.y);
    }
    let a = align[texel_index(p)];
    var row = a >> 16u;
    if di < 0 {
        row = a & 0xffffu;
    }
    return vec2<u32>(ni, row);
}

// One row down (dj < 0) or up (dj > 0): wrapped in a polar column, clamped in a rect.
fn step_row(p: vec2<u32>, dj: i32) -> vec2<u32> {
    if dj == 0 {
        return p;
    }
    let rows = max(columns[p.x].x, 1u);
    var j = p.y;
    if dj < 0 {
        if j == 0u {
            if params.polar != 0u {
                j = rows - 1u;
            }
        } else {
            j = j - 1u;
        }
    } else {
        if j + 1u >= rows {
            if params.polar != 0u {
                j = 0u;
            }
        } else {
            j = j + 1u;
        }
    }
    return vec2<u32>(p.x, j);
}

// `Grid::step`: `di` columns (at the same angle), then `dj` rows; |di|, |dj| ≤ 1.
fn grid_step(p: vec2<u32>, di: i32, dj: i32) -> vec2<u32> {
    return step_row(step_column(p, di), dj);
}
