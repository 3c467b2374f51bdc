//! The backend's fixed GPU objects, made once per backend: the camera uniform and its bind
//! group, the depth pre-pass and query-box pipelines (Seletsky 2013, section 2.4: colour and
//! depth writes off while a box is drawn), and the unit cube every query box is drawn from.

use wgpu::util::DeviceExt;
use wgpu::Device;

use super::types::{BoxInstance, CameraUniform, CUBE_CORNERS, CUBE_INDICES, DEPTH_FORMAT};

/// A `vec3<f32>` vertex attribute at byte `offset` of its buffer, for shader `location`.
const fn vec3_at(location: u32, offset: u64) -> wgpu::VertexAttribute {
    wgpu::VertexAttribute {
        format: wgpu::VertexFormat::Float32x3,
        offset,
        shader_location: location,
    }
}

/// Corner positions (occluder triangles and unit-cube corners), location 0.
const POSITION_ATTRS: [wgpu::VertexAttribute; 1] = [vec3_at(0, 0)];
/// The per-draw translation of the depth pre-pass, location 1.
const TRANSLATION_ATTRS: [wgpu::VertexAttribute; 1] = [vec3_at(1, 0)];
/// A query box's `min` and `max` corners ([`BoxInstance`]), locations 1 and 2.
const BOX_ATTRS: [wgpu::VertexAttribute; 2] = [vec3_at(1, 0), vec3_at(2, 12)];

/// The camera uniform, the bind group that holds it and the two pipelines of the passes.
pub(super) struct Pipelines {
    /// The [`CameraUniform`], written once per submission.
    pub(super) camera_buffer: wgpu::Buffer,
    /// Group 0 of both pipelines: the camera.
    pub(super) bind_group: wgpu::BindGroup,
    /// Occluders into the depth buffer (depth writes on, compare `Greater`).
    pub(super) depth_pipeline: wgpu::RenderPipeline,
    /// Query boxes against the depth buffer (depth writes off, compare `GreaterEqual`).
    pub(super) query_pipeline: wgpu::RenderPipeline,
}

impl Pipelines {
    /// Compiles `occlusion_query.wgsl` and makes the camera binding and both pipelines.
    pub(super) fn new(device: &Device) -> Self {
        let shader = device.create_shader_module(wgpu::include_wgsl!("../occlusion_query.wgsl"));
        let camera_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sightline camera"),
            size: std::mem::size_of::<CameraUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_layout = camera_bind_layout(device);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sightline camera"),
            layout: &bind_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: camera_buffer.as_entire_binding(),
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sightline occlusion"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        let stage = PipelineStage {
            device,
            layout: &layout,
            shader: &shader,
        };
        Self {
            camera_buffer,
            bind_group,
            depth_pipeline: stage.depth_pipeline(),
            query_pipeline: stage.query_pipeline(),
        }
    }
}

/// The layout of group 0: one uniform buffer (the camera) read by the vertex stage.
fn camera_bind_layout(device: &Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("sightline camera"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    })
}

/// What both pipelines share: the device, the pipeline layout and the shader module.
struct PipelineStage<'a> {
    device: &'a Device,
    layout: &'a wgpu::PipelineLayout,
    shader: &'a wgpu::ShaderModule,
}

impl PipelineStage<'_> {
    /// The depth pre-pass: occluder corners (per vertex) moved by a translation (per instance),
    /// writing depth where nearer (`Greater` in reversed-Z).
    fn depth_pipeline(&self) -> wgpu::RenderPipeline {
        self.depth_only(
            "sightline depth pre-pass",
            "vs_depth",
            &[
                Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &POSITION_ATTRS,
                }),
                Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &TRANSLATION_ATTRS,
                }),
            ],
            DepthTest {
                write: true,
                compare: wgpu::CompareFunction::Greater,
            },
        )
    }

    /// The query boxes: unit-cube corners (per vertex) scaled into a box (per instance),
    /// depth-tested with `GreaterEqual` and never written, so that only the query counts.
    fn query_pipeline(&self) -> wgpu::RenderPipeline {
        self.depth_only(
            "sightline query boxes",
            "vs_box",
            &[
                Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &POSITION_ATTRS,
                }),
                Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<BoxInstance>() as u64,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &BOX_ATTRS,
                }),
            ],
            DepthTest {
                write: false,
                compare: wgpu::CompareFunction::GreaterEqual,
            },
        )
    }

    /// A depth-only pipeline (double-sided triangles, no fragment stage) with vertex entry
    /// `entry`, vertex `buffers` and `depth` test.
    fn depth_only(
        &self,
        label: &str,
        entry: &str,
        buffers: &[Option<wgpu::VertexBufferLayout>],
        depth: DepthTest,
    ) -> wgpu::RenderPipeline {
        self.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(self.layout),
                vertex: wgpu::VertexState {
                    module: self.shader,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(depth.write),
                    depth_compare: Some(depth.compare),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                // No fragment stage and no colour target: depth-only. Occlusion queries count
                // samples passing the depth test, which needs no fragment shader.
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
    }
}

/// A pipeline's depth test: whether it writes depth, and how it compares.
struct DepthTest {
    write: bool,
    compare: wgpu::CompareFunction,
}

/// The unit cube, uploaded once: every query box is this cube scaled into the box.
pub(super) struct UnitCube {
    /// [`CUBE_CORNERS`], a vertex buffer.
    pub(super) corners: wgpu::Buffer,
    /// [`CUBE_INDICES`], a 16-bit index buffer.
    pub(super) indices: wgpu::Buffer,
}

impl UnitCube {
    /// Uploads the cube's corners and indices.
    pub(super) fn new(device: &Device) -> Self {
        let corners = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sightline unit cube"),
            contents: bytemuck::cast_slice(&CUBE_CORNERS),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sightline unit cube indices"),
            contents: bytemuck::cast_slice(&CUBE_INDICES),
            usage: wgpu::BufferUsages::INDEX,
        });
        Self { corners, indices }
    }
}
