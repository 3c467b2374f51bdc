//! The renderer's pipelines, one per pass of a frame (id images, compare, resolve, guides as
//! lines and as filled triangles),
//! compiled from `renderer.wgsl` with layouts derived from the shader, and the bind groups that
//! do not depend on the image size.

use wgpu::{Device, TextureFormat};

use super::buffers::Buffers;
use super::types::{LineVertex, DEPTH_FORMAT, ID_FORMAT};

/// The pipelines of a frame.
pub(super) struct Pipelines {
    /// Passes 1 and 2: triangles into an id image and a depth buffer.
    pub(super) id: wgpu::RenderPipeline,
    /// Pass 3: counts the pixels whose ids differ (compute).
    pub(super) compare: wgpu::ComputePipeline,
    /// Pass 4: a full-screen triangle shading each pixel's triangle.
    pub(super) resolve: wgpu::RenderPipeline,
    /// Pass 5: the guides' lines (cell wireframe, frustum, marker), depth-tested against the
    /// shown image.
    pub(super) line: wgpu::RenderPipeline,
    /// Pass 5, before the lines: the guides' filled triangles (the overview's cells).
    pub(super) fill: wgpu::RenderPipeline,
}

impl Pipelines {
    /// Compiles `renderer.wgsl` and makes the pipelines; the resolve and guide passes draw
    /// into colour targets of `color_format`.
    pub(super) fn new(device: &Device, color_format: TextureFormat) -> Self {
        let shader = device.create_shader_module(wgpu::include_wgsl!("../renderer.wgsl"));
        let id = id_pipeline(device, &shader);
        let compare = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("view compare"),
            layout: None,
            module: &shader,
            entry_point: Some("cs_compare"),
            compilation_options: Default::default(),
            cache: None,
        });
        let resolve = resolve_pipeline(device, &shader, color_format);
        let line = guide_pipeline(
            device,
            &shader,
            color_format,
            wgpu::PrimitiveTopology::LineList,
        );
        let fill = guide_pipeline(
            device,
            &shader,
            color_format,
            wgpu::PrimitiveTopology::TriangleList,
        );
        Self {
            id,
            compare,
            resolve,
            line,
            fill,
        }
    }
}

/// A depth test on [`DEPTH_FORMAT`]: whether it writes, and how it compares.
fn depth(write: bool, compare: wgpu::CompareFunction) -> Option<wgpu::DepthStencilState> {
    Some(wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    })
}

/// The id pipeline: double-sided triangles into an [`ID_FORMAT`] image, nearer wins
/// (`Greater` in reversed-Z), so an exact tie keeps the earlier (lower) id.
fn id_pipeline(device: &Device, shader: &wgpu::ShaderModule) -> wgpu::RenderPipeline {
    let position_attr = [wgpu::VertexAttribute {
        format: wgpu::VertexFormat::Float32x3,
        offset: 0,
        shader_location: 0,
    }];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("view ids"),
        layout: None,
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some("vs_id"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: 12,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &position_attr,
            })],
        },
        // Double-sided, as everywhere in sightline.
        primitive: wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: depth(true, wgpu::CompareFunction::Greater),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some("fs_id"),
            compilation_options: Default::default(),
            targets: &[Some(ID_FORMAT.into())],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The resolve pipeline: a full-screen triangle without vertex buffers, shading into
/// `color_format`. Its pass has the shown image's depth buffer attached for the lines drawn
/// after it, which this pipeline neither tests (`Always`) nor writes.
fn resolve_pipeline(
    device: &Device,
    shader: &wgpu::ShaderModule,
    color_format: TextureFormat,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("view resolve"),
        layout: None,
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: depth(false, wgpu::CompareFunction::Always),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some("fs_resolve"),
            compilation_options: Default::default(),
            targets: &[Some(color_format.into())],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A guide pipeline: [`LineVertex`] as a line list (pairs) or triangle list (`topology`),
/// alpha-blended into `color_format`, depth-tested (`GreaterEqual`, no writes) against the
/// shown image, double-sided.
fn guide_pipeline(
    device: &Device,
    shader: &wgpu::ShaderModule,
    color_format: TextureFormat,
    topology: wgpu::PrimitiveTopology,
) -> wgpu::RenderPipeline {
    let line_attrs = [
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: 0,
            shader_location: 0,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x4,
            offset: 12,
            shader_location: 1,
        },
    ];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("view guides"),
        layout: None,
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some("vs_line"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<LineVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &line_attrs,
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: depth(false, wgpu::CompareFunction::GreaterEqual),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some("fs_line"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: color_format,
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The bind groups that do not depend on the image size.
pub(super) struct SceneBinds {
    /// Group 0 of the id pipeline: the camera.
    pub(super) id: wgpu::BindGroup,
    /// Group 0 of the line pipeline: the camera.
    pub(super) line: wgpu::BindGroup,
    /// Group 0 of the fill pipeline: the camera (automatic layouts are not shared).
    pub(super) fill: wgpu::BindGroup,
    /// Group 1 of the resolve pipeline: per-triangle shading data and the drawn bits.
    pub(super) resolve_scene: wgpu::BindGroup,
}

impl SceneBinds {
    /// Binds `buffers` to the layouts of `pipelines`.
    pub(super) fn new(device: &Device, pipelines: &Pipelines, buffers: &Buffers) -> Self {
        let camera_only = |pipeline_layout: wgpu::BindGroupLayout, label| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipeline_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffers.camera.as_entire_binding(),
                }],
            })
        };
        let id = camera_only(pipelines.id.get_bind_group_layout(0), "view ids");
        let line = camera_only(pipelines.line.get_bind_group_layout(0), "view guide lines");
        let fill = camera_only(pipelines.fill.get_bind_group_layout(0), "view guide fills");
        let resolve_scene = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view resolve scene"),
            layout: &pipelines.resolve.get_bind_group_layout(1),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffers.triangles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: buffers.drawn_bits.as_entire_binding(),
                },
            ],
        });
        Self {
            id,
            line,
            fill,
            resolve_scene,
        }
    }
}
