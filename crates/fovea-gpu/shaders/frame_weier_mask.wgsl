// frame_weier_mask.wgsl: the screen side's mask of Weier's sparse pattern for the pull-push
// reconstruction (`pull_push.wgsl` reads one bit per screen pixel, bit k % 32 of word k / 32)
// — per frame, on the device, from the pattern's tables (`frame_sparse.wgsl`, appended before
// this file) and the frame's point of regard: one invocation per 32 pixels. The mask is
// `fovea_post::inverse_map::mask_of` of the plan's mapping, which the CPU's reconstruction
// builds; see src/frame/pull_push.rs.

struct MaskParams {
    // Screen pixels (width × height).
    pixels: u32,
    // Screen width, pixels.
    width: u32,
    // Mask words, ⌈pixels / 32⌉.
    words: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> mask_params: MaskParams;
@group(0) @binding(1) var<storage, read> frame_runs: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read_write> mask_bits: array<u32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn weier_mask(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let word = gid.y * groups.x * WORKGROUP_SIZE + gid.x;
    if word >= mask_params.words {
        return;
    }
    var bits = 0u;
    for (var b = 0u; b < 32u; b++) {
        let k = 32u * word + b;
        if k < mask_params.pixels && sparse_shaded(k % mask_params.width, k / mask_params.width) {
            bits = bits | (1u << b);
        }
    }
    mask_bits[word] = bits;
}
