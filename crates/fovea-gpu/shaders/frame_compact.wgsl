// frame_compact.wgsl: the resident frame's list of shaded texels (issue 37) — stream compaction
// by an atomic append (Harris, Sengupta & Owens, "Parallel Prefix Sum (Scan) with CUDA", GPU
// Gems 3 ch. 39, §39.3.1 "stream compaction", its append form) of the texels the plan shades,
// so that the shade kernels (`frame_surface`, `frame_direct`, `frame_environment`) and the
// bounce kernels (frame_bounce.wgsl) run over those texels only. Appended after
// frame_shade.wgsl, whose `frame_point` decides, bit for bit, which texels are shaded, and
// whose `frame_texel` reads the list when `frame.listed` is set (a polar buffer's layout; every
// other layout walks its tiles as before).
//
// `frame_compact`: one workgroup per 8×8 tile of the layer (`frame_tile_texel`, the order the
// kernels walk without a list), one invocation per texel, which asks `frame_point(i, j).w`. A
// shaded texel takes the next slot of `frame_list` (one atomic on `frame_count`, zeroed by the
// host's `clear_buffer` before the pass); an unshaded one gets here what `frame_surface`
// writes for it without a list (black at +∞ depth, state UNSHADED, empty guides). The list's
// order is the device's; every texel's result depends on its own (i, j) only, so the samples
// are the same bits in any order.
//
// The kernels' dispatch over the list is sized on the host from an upper bound of the count
// (the rows of the columns' runs, `fovea_gpu::frame::compact::shaded_bound`); invocations past
// the count return at once. An indirect dispatch would need no bound, but wgpu 30's check of
// indirect arguments aborts lavapipe 22.3 ("stack smashing detected").

// The shaded texels of the layer, as texel indices `j · width + i`; the first `frame_count`
// are this frame's.
@group(0) @binding(35) var<storage, read_write> frame_list: array<u32>;
// Texels listed this frame (zeroed before the pass).
@group(0) @binding(36) var<storage, read_write> frame_count: atomic<u32>;

// The kernels' texel of invocation `id` over the list: the n-th listed texel, or
// `frame.texels` (none) past this frame's count. The dispatch over the list has rows of at
// most the tile walk's workgroups, so `frame.row_invocations` is its stride too.
fn frame_listed(id: vec3<u32>) -> u32 {
    let n = id.x + id.y * frame.row_invocations;
    if n >= atomicLoad(&frame_count) {
        return frame.texels;
    }
    return frame_list[n];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn frame_compact(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = frame_tile_texel(id);
    if k >= frame.texels {
        return;
    }
    let w = frame.layer.width;
    if frame_point(k % w, k / w).w != 0.0 {
        frame_list[atomicAdd(&frame_count, 1u)] = k;
        return;
    }
    // What `frame_surface` writes for a texel the plan does not shade.
    let out = frame.layer.offset + k;
    frame_samples[out] = vec4<f32>(0.0, 0.0, 0.0, bitcast<f32>(frame.inf_bits));
    frame_material[2u * k + 1u] = vec4<f32>(0.0, 0.0, 0.0, STATE_UNSHADED);
    if frame.guides != 0u {
        frame_guide_albedo[out] = vec4<f32>(0.0);
        frame_guide_normal[out] = vec4<f32>(0.0);
        frame_guide_noisy[out] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
}
