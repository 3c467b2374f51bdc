//! The overlay pass: an RGBA image (the HUD panel) uploaded to a texture of its own size and
//! alpha-blended over a finished frame at the frame's top-left corner (`overlay.wgsl`).
//!
//! Its own pipeline, texture and submission, after the frame's: a frame drawn without an
//! overlay goes through exactly the passes it went through before the HUD existed, and the
//! pipeline is only made when an overlay is first drawn.

use wgpu::{Device, Queue, TextureFormat};

/// The panel's texels: 8-bit RGBA, not sRGB (the HUD's colours are display values, as the
/// resolve pass writes them).
const PANEL_FORMAT: TextureFormat = TextureFormat::Rgba8Unorm;

/// The overlay pipeline and the current panel texture.
pub(super) struct Overlay {
    pipeline: wgpu::RenderPipeline,
    /// The panel texture and its bind group, kept while the panel's size stays the same.
    panel: Option<(wgpu::Texture, wgpu::BindGroup)>,
}

impl Overlay {
    /// The overlay pipeline, blending into colour targets of `color_format`.
    pub(super) fn new(device: &Device, color_format: TextureFormat) -> Self {
        let shader = device.create_shader_module(wgpu::include_wgsl!("overlay.wgsl"));
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view overlay"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_overlay"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_overlay"),
                compilation_options: Default::default(),
                // Straight alpha: colour = panel * a + frame * (1 - a); an opaque panel
                // texel replaces the frame's pixel exactly.
                targets: &[Some(wgpu::ColorTargetState {
                    format: color_format,
                    blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Self {
            pipeline,
            panel: None,
        }
    }

    /// Blends `rgba` (`width x height` pixels, row-major, top row first) over `target`'s
    /// top-left corner and submits. A zero-sized panel draws nothing.
    pub(super) fn draw(
        &mut self,
        device: &Device,
        queue: &Queue,
        target: &wgpu::TextureView,
        rgba: &[u8],
        (width, height): (u32, u32),
    ) {
        if width == 0 || height == 0 {
            return;
        }
        debug_assert_eq!(rgba.len(), width as usize * height as usize * 4);
        let (texture, bind) = self.panel_texture(device, width, height);
        queue.write_texture(
            texture.as_image_copy(),
            rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(width * 4),
                rows_per_image: Some(height),
            },
            texture.size(),
        );
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("view overlay"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("view overlay"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.draw(0..3, 0..1);
        }
        queue.submit([encoder.finish()]);
    }

    /// The panel texture of `width x height`, made again when the size changed (the text's
    /// length changes the panel's width now and then, not every frame).
    fn panel_texture(
        &mut self,
        device: &Device,
        width: u32,
        height: u32,
    ) -> (wgpu::Texture, wgpu::BindGroup) {
        if let Some((t, b)) = &self.panel {
            if (t.width(), t.height()) == (width, height) {
                return (t.clone(), b.clone());
            }
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("view overlay panel"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: PANEL_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view overlay panel"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(
                    &texture.create_view(&Default::default()),
                ),
            }],
        });
        self.panel = Some((texture.clone(), bind.clone()));
        (texture, bind)
    }
}
