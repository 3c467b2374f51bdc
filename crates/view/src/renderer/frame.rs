//! Encoding the passes of one frame, in the order of the module documentation: the full id
//! pass, then (when the method culls) the culled id pass and the compare pass, then the resolve
//! pass with the guides (filled triangles, then lines) on top.

use super::buffers::Buffers;
use super::pipelines::{Pipelines, SceneBinds};
use super::targets::Targets;

/// What the passes of a frame read: the renderer's GPU objects and this frame's counts.
pub(super) struct FramePasses<'a> {
    pub(super) pipelines: &'a Pipelines,
    pub(super) binds: &'a SceneBinds,
    pub(super) buffers: &'a Buffers,
    pub(super) targets: &'a Targets,
    /// Triangles of the scene (the full pass draws all of them).
    pub(super) triangle_count: u32,
    /// Indices of the culled pass.
    pub(super) index_count: u32,
    /// Vertices of the guides' lines (0: no line draw).
    pub(super) line_count: u32,
    /// Vertices of the guides' filled triangles (0: no fill draw).
    pub(super) fill_count: u32,
}

impl FramePasses<'_> {
    /// Encodes the frame's passes into `encoder`, resolving into `target`. `culled`: the
    /// method drew a subset (else the culled pass and the compare are skipped); `xray`: show
    /// the full image with the culled triangles tinted.
    pub(super) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        culled: bool,
        xray: bool,
    ) {
        let t = self.targets;
        let full_view = t.ids_full.create_view(&Default::default());
        let culled_view = t.ids_culled.create_view(&Default::default());
        self.id_pass(encoder, &full_view, &t.depth_full, None);
        if culled {
            self.id_pass(
                encoder,
                &culled_view,
                &t.depth_culled,
                Some(self.index_count),
            );
            self.compare_pass(encoder);
        }
        self.resolve_pass(encoder, target, culled, !culled || xray);
    }

    /// Passes 1 and 2: triangles into the id image `ids` and depth buffer `depth`, both cleared
    /// first; every triangle (`indexed` `None`) or the first `count` indices of the drawn set.
    fn id_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        ids: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        indexed: Option<u32>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view ids"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: ids,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    // Reversed-Z: 0 is infinitely far.
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipelines.id);
        pass.set_bind_group(0, &self.binds.id, &[]);
        pass.set_vertex_buffer(0, self.buffers.vertices.slice(..));
        match indexed {
            None => pass.draw(0..self.triangle_count * 3, 0..1),
            Some(count) => {
                if count > 0 {
                    pass.set_index_buffer(
                        self.buffers.indices.slice(..),
                        wgpu::IndexFormat::Uint32,
                    );
                    pass.draw_indexed(0..count, 0, 0..1);
                }
            }
        }
    }

    /// Pass 3: counts the pixels whose ids differ between the full and the culled image, one
    /// invocation per pixel in 8 x 8 workgroups.
    fn compare_pass(&self, encoder: &mut wgpu::CommandEncoder) {
        let t = self.targets;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("view compare"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipelines.compare);
        pass.set_bind_group(0, &t.compare_culled, &[]);
        pass.dispatch_workgroups(t.width.div_ceil(8), t.height.div_ceil(8), 1);
    }

    /// Passes 4 and 5: shades `target` from the culled (`culled`) or full id image, keeping the
    /// depth buffer of the image shown (`show_full`: the full one) for the guides drawn on top.
    fn resolve_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        culled: bool,
        show_full: bool,
    ) {
        let t = self.targets;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view resolve"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: if show_full {
                    &t.depth_full
                } else {
                    &t.depth_culled
                },
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipelines.resolve);
        pass.set_bind_group(
            0,
            if culled {
                &t.resolve_culled
            } else {
                &t.resolve_full
            },
            &[],
        );
        pass.set_bind_group(1, &self.binds.resolve_scene, &[]);
        pass.draw(0..3, 0..1);
        if self.fill_count > 0 {
            pass.set_pipeline(&self.pipelines.fill);
            pass.set_bind_group(0, &self.binds.fill, &[]);
            pass.set_vertex_buffer(0, self.buffers.fills.slice(..));
            pass.draw(0..self.fill_count, 0..1);
        }
        if self.line_count > 0 {
            pass.set_pipeline(&self.pipelines.line);
            pass.set_bind_group(0, &self.binds.line, &[]);
            pass.set_vertex_buffer(0, self.buffers.lines.slice(..));
            pass.draw(0..self.line_count, 0..1);
        }
    }
}
