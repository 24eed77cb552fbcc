// gaussian_aa.wgsl: the 3×3 Gaussian (binomial [1 2 1]/4 per axis) that KFR/LMFR (Meng et
// al. 2018, Sec. 4) and LaFR apply inside their log-polar buffer before the inverse mapping;
// stage 5 of DESIGN.md on the GPU, the twin of `fovea_post::gaussian_aa::gaussian_3x3` (same
// neighbours through sample_grid.wgsl, same weights, same order of the sums). One invocation
// per texel; texels the grid marks invalid are copied.

@compute @workgroup_size(WORKGROUP_SIZE)
fn gaussian_3x3(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    let p = vec2<u32>(gid.x, gid.y);
    if !is_valid(p) {
        write_rgb(p, rgb_at(p));
        return;
    }
    var acc = vec3<f32>(0.0, 0.0, 0.0);
    // Weights w_i · w_j / 16 with w = (1, 2, 1): exact in f32. Columns outer, rows inner,
    // as the CPU loop.
    for (var a = 0; a < 3; a = a + 1) {
        let wi = f32(1 + a % 2);
        for (var b = 0; b < 3; b = b + 1) {
            let wj = f32(1 + b % 2);
            let q = grid_step(p, a - 1, b - 1);
            acc = acc + (wi * wj / 16.0) * rgb_at(q);
        }
    }
    write_rgb(p, acc);
}
