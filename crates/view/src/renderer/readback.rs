//! Blocking readback for the renderer and the headless driver: map a buffer and copy it out,
//! or copy a texture into a buffer first (rows padded to wgpu's 256-byte alignment, then
//! packed again).

use std::sync::mpsc;

use wgpu::{Device, Queue};

use crate::error::ViewError;

/// Maps `buffer` (of `MAP_READ` usage) and copies its first `bytes` bytes out, blocking.
pub(super) fn read_buffer(
    device: &Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u8>, ViewError> {
    let slice = buffer.slice(..bytes);
    let (tx, rx) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        // The receiver waits below; if it is gone there is nobody to tell.
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| ViewError::Readback(e.to_string()))?;
    match rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(ViewError::Readback(e.to_string())),
        Err(e) => return Err(ViewError::Readback(e.to_string())),
    }
    let out = slice.get_mapped_range().map(|view| view.to_vec());
    buffer.unmap();
    out.map_err(|e| ViewError::Readback(e.to_string()))
}

/// Copies a 2D texture with `texel_bytes` bytes per texel into memory, rows tightly packed.
pub(crate) fn read_texture(
    device: &Device,
    queue: &Queue,
    texture: &wgpu::Texture,
    texel_bytes: u32,
) -> Result<Vec<u8>, ViewError> {
    let (w, h) = (texture.width(), texture.height());
    let row = w * texel_bytes;
    // Texture-to-buffer copies need rows aligned to 256 bytes.
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let size = u64::from(padded) * u64::from(h);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("view texture readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("view texture readback"),
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    let raw = read_buffer(device, &buffer, size)?;
    let mut out = Vec::with_capacity((row * h) as usize);
    for y in 0..h as usize {
        let start = y * padded as usize;
        out.extend_from_slice(&raw[start..start + row as usize]);
    }
    Ok(out)
}
