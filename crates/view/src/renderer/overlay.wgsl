// The overlay pass: the HUD panel (an RGBA texture, straight alpha) blended over the finished
// frame with its top-left corner on the frame's. One full-screen triangle; fragments outside
// the panel are discarded, the others read the panel's texel at their own pixel (no sampler,
// no scaling: the panel is drawn at the frame's resolution on the CPU).

@group(0) @binding(0) var panel: texture_2d<f32>;

@vertex
fn vs_overlay(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(index & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_overlay(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let size = textureDimensions(panel);
    let pixel = vec2<u32>(position.xy);
    if (pixel.x >= size.x || pixel.y >= size.y) {
        discard;
    }
    return textureLoad(panel, pixel, 0);
}
