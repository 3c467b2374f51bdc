//! The renderer's size-dependent targets: the full and culled id images with their depth
//! buffers, and the bind groups of the compare and resolve passes that read those images.
//! Made again on every resize.

use wgpu::Device;

use super::buffers::Buffers;
use super::pipelines::Pipelines;
use super::types::{DEPTH_FORMAT, ID_FORMAT};

/// Size-dependent targets.
pub(super) struct Targets {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) ids_full: wgpu::Texture,
    pub(super) ids_culled: wgpu::Texture,
    pub(super) depth_full: wgpu::TextureView,
    pub(super) depth_culled: wgpu::TextureView,
    /// Compare pass: full vs culled, and full vs full (nothing culled).
    pub(super) compare_culled: wgpu::BindGroup,
    /// Resolve pass, group 0, for the two cases.
    pub(super) resolve_culled: wgpu::BindGroup,
    pub(super) resolve_full: wgpu::BindGroup,
}

impl Targets {
    /// Targets of `width x height` pixels (at least 1 x 1), bound for `pipelines` with the
    /// camera and counters of `buffers`.
    pub(super) fn new(
        device: &Device,
        buffers: &Buffers,
        pipelines: &Pipelines,
        width: u32,
        height: u32,
    ) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        use wgpu::TextureUsages as T;
        let id_usage = T::RENDER_ATTACHMENT | T::TEXTURE_BINDING | T::COPY_SRC;
        let ids_full = texture("view ids full", ID_FORMAT, id_usage);
        let ids_culled = texture("view ids culled", ID_FORMAT, id_usage);
        let depth_full = texture("view depth full", DEPTH_FORMAT, T::RENDER_ATTACHMENT)
            .create_view(&Default::default());
        let depth_culled = texture("view depth culled", DEPTH_FORMAT, T::RENDER_ATTACHMENT)
            .create_view(&Default::default());
        let images = IdViews {
            full: ids_full.create_view(&Default::default()),
            culled: ids_culled.create_view(&Default::default()),
        };
        let compare_culled = images.compare_bind(device, pipelines, buffers);
        let resolve_culled = images.resolve_bind(device, pipelines, buffers, &images.culled);
        let resolve_full = images.resolve_bind(device, pipelines, buffers, &images.full);
        Self {
            width,
            height,
            ids_full,
            ids_culled,
            depth_full,
            depth_culled,
            compare_culled,
            resolve_culled,
            resolve_full,
        }
    }
}

/// Views of the two id images, for binding.
struct IdViews {
    full: wgpu::TextureView,
    culled: wgpu::TextureView,
}

impl IdViews {
    /// The compare pass's group 0: both id images and the counters it adds to.
    fn compare_bind(
        &self,
        device: &Device,
        pipelines: &Pipelines,
        buffers: &Buffers,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view compare"),
            layout: &pipelines.compare.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&self.full),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&self.culled),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: buffers.counters.as_entire_binding(),
                },
            ],
        })
    }

    /// The resolve pass's group 0: the camera, the full id image and `culled` as the image
    /// of the drawn set (the full image itself when nothing is culled).
    fn resolve_bind(
        &self,
        device: &Device,
        pipelines: &Pipelines,
        buffers: &Buffers,
        culled: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view resolve"),
            layout: &pipelines.resolve.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffers.camera.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&self.full),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(culled),
                },
            ],
        })
    }
}
