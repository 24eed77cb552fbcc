// dof_coc.wgsl: the signed circle of confusion of every screen pixel from its depth and the
// eye model (Liu et al., "hybrid foveated DOF", Eq. 12's thin-lens form and Eq. 13 scaled;
// DESIGN.md stage 7), and the per-pixel planes the gather filter reads. The GPU twin of
// `fovea_post::dof::coc::coc_map` and of the gather's input sanitising
// (`fovea_post::dof::gather`, `disc::Prepared`); see src/dof.rs.
//
// Every constant is computed by the Rust side (`fovea_post::dof::coc::coc_constants`, in f64,
// rounded once to f32) and uploaded:
//
//   form 0 (thin lens):  c = a · (b − 1/d)      a = τ·f_px px/dioptre, b = 1/F
//   form 1 (Eq. 13):     c = (d − b) · a        a = px per metre, b = F
//   form 2:              c = 0
//   form 3:              c = the uploaded CoC map (non-finite → 0), for a caller's own map
//
// then clamped to ±max_coc_px. A pixel with no hit (depth NaN, ≤ 0 or +∞) takes
// `no_hit_coc` (the CPU's value at d = +∞). Depth travels as u32 bit patterns and is
// classified by its bits: WGSL lets an implementation assume that no float is infinite or NaN.
//
// The planes, one 4-byte value a pixel each (so that no binding is larger than 4 bytes a
// pixel: an 8K plane is 126.6 MiB, within lavapipe's 128 MiB; issue 37): the depth's bits
// (0 for no hit — a surface's depth is positive, so its bits are never 0 and the gather reads
// the hit flag from them), the CoC radius clamp(|c|/2, ½, max_radius) and 1/A(r) from the
// uploaded area table (linear between entries every 1/16 px, exactly as
// `disc::AreaLut::inv`).

struct DofCocParams {
    width: u32,
    height: u32,
    // 0 thin lens, 1 linear (Eq. 13), 2 zero, 3 uploaded map.
    form: u32,
    // Largest index k of the area table with k + 1 in it (len − 2).
    lut_max_k: u32,
    a: f32,
    b: f32,
    max_coc_px: f32,
    no_hit_coc_px: f32,
    // The gather's largest radius, pixels.
    max_radius_px: f32,
    // Area-table entries per pixel of radius.
    lut_steps_per_px: f32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: DofCocParams;
@group(0) @binding(1) var<storage, read> depth_bits: array<u32>;
@group(0) @binding(2) var<storage, read> coc_in: array<u32>;
@group(0) @binding(3) var<storage, read> inv_area_table: array<f32>;
@group(0) @binding(4) var<storage, read_write> coc_out: array<f32>;
@group(0) @binding(5) var<storage, read_write> plane_depth: array<u32>;
@group(0) @binding(6) var<storage, read_write> plane_radius: array<f32>;
@group(0) @binding(7) var<storage, read_write> plane_inv_area: array<f32>;

const EXPONENT_MASK: u32 = 0x7f800000u;

// A positive finite f32 (a surface's depth): sign clear, exponent not all ones, not zero.
fn is_hit(bits: u32) -> bool {
    return bits > 0u && bits < EXPONENT_MASK;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn coc(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let i = y * params.width + x;
    let bits = depth_bits[i];
    let hit = is_hit(bits);
    let d = select(0.0, bitcast<f32>(bits), hit);
    var c = 0.0;
    switch params.form {
        case 0u: {
            c = select(params.no_hit_coc_px, params.a * (params.b - 1.0 / d), hit);
        }
        case 1u: {
            c = select(params.no_hit_coc_px, (d - params.b) * params.a, hit);
        }
        case 3u: {
            // The caller's map: non-finite values are in focus.
            let cb = coc_in[i];
            c = select(bitcast<f32>(cb), 0.0, (cb & EXPONENT_MASK) == EXPONENT_MASK);
        }
        default: {
            c = 0.0;
        }
    }
    if params.form != 3u {
        c = clamp(c, -params.max_coc_px, params.max_coc_px);
    }
    coc_out[i] = c;
    // The gather's radius and 1/A(r) (disc::AreaLut::inv).
    let r = clamp(0.5 * abs(c), 0.5, params.max_radius_px);
    let t = max((r - 0.5) * params.lut_steps_per_px, 0.0);
    let k = min(u32(t), params.lut_max_k);
    let f = min(t - f32(k), 1.0);
    let a0 = inv_area_table[k];
    let inv_area = a0 + f * (inv_area_table[k + 1u] - a0);
    plane_depth[i] = select(0u, bits, hit);
    plane_radius[i] = r;
    plane_inv_area[i] = inv_area;
}
