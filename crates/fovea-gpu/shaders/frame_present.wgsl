// frame_present.wgsl: the tone-mapped screen (8-bit sRGB RGB bytes, row-major, four to a u32:
// `fovea_post::tonemap::to_srgb8`'s bytes as tonemap.wgsl packs them) repacked as RGBA8 texels
// (alpha 255), one u32 a pixel, rows padded to the copy's 256-byte row pitch, so that one
// `copy_buffer_to_texture` puts the frame into an `Rgba8Unorm` texture a presenter samples —
// on the render device, without a readback (issue 37, item 6). See src/frame/screen.rs.

struct PresentParams {
    // Screen width, pixels.
    width: u32,
    // Screen height, pixels.
    height: u32,
    // u32 words per padded output row.
    row_words: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> params: PresentParams;
@group(0) @binding(1) var<storage, read> rgb_words: array<u32>;
@group(0) @binding(2) var<storage, read_write> rgba: array<u32>;

// Byte k of the packed RGB stream.
fn rgb_byte(k: u32) -> u32 {
    return (rgb_words[k / 4u] >> (8u * (k % 4u))) & 0xffu;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn present_rgba(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let k = 3u * (y * params.width + x);
    rgba[y * params.row_words + x] =
        rgb_byte(k) | (rgb_byte(k + 1u) << 8u) | (rgb_byte(k + 2u) << 16u) | (0xffu << 24u);
}
