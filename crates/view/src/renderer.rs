//! The viewer's GPU renderer: triangle-id images of the full scene and of the culled set, the
//! popping count as the number of pixels where they differ (a compute pass), flat Lambert
//! shading resolved from the id image, and the view-cell wireframe on top.
//!
//! # Passes of one frame
//! 1. **Full id pass**: every triangle into an `R32Uint` image (`id + 1`, 0 = background) with
//!    a reversed-Z `Depth32Float` buffer (as `sightline-gpu`: depth `near / z`, infinite far
//!    plane, compare `Greater`). Triangles are drawn in id order, so an exact depth tie goes
//!    to the lower id, the rule of the reference rasterizer.
//! 2. **Culled id pass**: only the triangles the method draws (an index buffer of the drawn
//!    ids, still in id order), skipped when the method draws everything.
//! 3. **Compare** (compute): counts the pixels whose ids differ: the popping pixels, i.e. the
//!    pixels wrong because visible geometry was culled. Both images come from the same vertex
//!    shader on the same vertices, so a triangle gets the same depth in both (Vulkan's
//!    invariance rule) and the images differ only where the full image's triangle is culled.
//! 4. **Resolve**: a full-screen pass shading each pixel's triangle (flat: its face normal,
//!    double-sided, a headlight and two fixed lights, a colour per object). Popping pixels are
//!    magenta; in x-ray mode the full image is shown with culled triangles tinted red.
//! 5. **Cells**: view-cell edges as lines, depth-tested against the shown image.
//!
//! The renderer takes a device and queue from its caller (tests and the window pass theirs).

use std::sync::mpsc;

use glam::Vec3;
use sightline_core::{Camera, Hit, Scene, TriangleSet};
use wgpu::util::DeviceExt;
use wgpu::{Device, Queue, TextureFormat};

use crate::error::ViewError;

const ID_FORMAT: TextureFormat = TextureFormat::R32Uint;
const DEPTH_FORMAT: TextureFormat = TextureFormat::Depth32Float;

/// What the resolve pass shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Shading {
    /// Show the full image with the culled triangles tinted red instead of hiding them.
    pub xray: bool,
    /// Paint popping pixels magenta (ignored in x-ray mode, where they are tinted red).
    pub mark_popping: bool,
}

/// Which triangle-id image to read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdImage {
    /// Every triangle drawn.
    Full,
    /// Only the triangles of the last frame's culled set (the full image if nothing was culled).
    Culled,
}

/// What the GPU measured in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuFrame {
    /// Pixels whose triangle differs between the culled and the full image.
    pub popping_pixels: u32,
    /// Pixels covered by some triangle in the full image.
    pub covered_pixels: u32,
}

/// A line vertex of the cell wireframe.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LineVertex {
    pub position: [f32; 3],
    pub colour: [f32; 4],
}

/// The camera as the shader reads it (`Camera` in `renderer.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct CameraUniform {
    eye: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    /// `(1 / tan_half_x, 1 / tan_half_y, near, 0)`.
    projection: [f32; 4],
    /// `(width, height, flags, 0)`, flags bit 0 x-ray, bit 1 mark popping.
    screen: [f32; 4],
}

impl CameraUniform {
    fn new(c: &Camera, shading: Shading) -> Self {
        let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
        let flags = u32::from(shading.xray) | (u32::from(shading.mark_popping) << 1);
        Self {
            eye: v4(c.eye),
            right: v4(c.right),
            up: v4(c.up),
            forward: v4(c.forward),
            projection: [1.0 / c.tan_half_x(), 1.0 / c.tan_half_y(), c.near, 0.0],
            screen: [c.width as f32, c.height as f32, flags as f32, 0.0],
        }
    }
}

/// Size-dependent targets.
struct Targets {
    width: u32,
    height: u32,
    ids_full: wgpu::Texture,
    ids_culled: wgpu::Texture,
    depth_full: wgpu::TextureView,
    depth_culled: wgpu::TextureView,
    /// Compare pass: full vs culled, and full vs full (nothing culled).
    compare_culled: wgpu::BindGroup,
    /// Resolve pass, group 0, for the two cases.
    resolve_culled: wgpu::BindGroup,
    resolve_full: wgpu::BindGroup,
}

/// The renderer. See the module documentation.
pub struct Renderer {
    device: Device,
    queue: Queue,
    triangle_count: u32,
    vertices: wgpu::Buffer,
    camera: wgpu::Buffer,
    counters: wgpu::Buffer,
    counters_read: wgpu::Buffer,
    drawn_bits: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    lines: wgpu::Buffer,
    line_count: u32,
    id_pipeline: wgpu::RenderPipeline,
    compare_pipeline: wgpu::ComputePipeline,
    resolve_pipeline: wgpu::RenderPipeline,
    line_pipeline: wgpu::RenderPipeline,
    id_bind: wgpu::BindGroup,
    line_bind: wgpu::BindGroup,
    resolve_scene_bind: wgpu::BindGroup,
    targets: Targets,
    /// Whether the last frame drew a culled set (else the culled image is the full one).
    culled_last: bool,
}

impl Renderer {
    /// A renderer of `scene` into colour targets of `color_format`, `width x height` pixels.
    ///
    /// Fails when the scene does not fit the device's buffer limits.
    pub fn new(
        device: &Device,
        queue: &Queue,
        scene: &Scene,
        color_format: TextureFormat,
        width: u32,
        height: u32,
    ) -> Result<Self, ViewError> {
        let n = scene.triangle_count();
        let limits = device.limits();
        let vertex_bytes = n as u64 * 36;
        let info_bytes = n as u64 * 16;
        if n > (u32::MAX / 3) as usize
            || vertex_bytes > limits.max_buffer_size
            || info_bytes > limits.max_storage_buffer_binding_size
        {
            return Err(ViewError::SceneTooLarge {
                triangles: n,
                max_buffer_bytes: limits.max_buffer_size,
            });
        }
        // Corners expanded per triangle (id = vertex index / 3), and per triangle its face
        // normal and object id for the flat shading.
        let mut corners: Vec<[f32; 3]> = Vec::with_capacity(n * 3);
        let mut info: Vec<[f32; 4]> = Vec::with_capacity(n.max(1));
        for t in 0..n {
            let [a, b, c] = scene.triangle(t as u32);
            corners.extend([a.to_array(), b.to_array(), c.to_array()]);
            let normal = (b - a).cross(c - a).normalize_or_zero();
            let object = scene.object_of_triangle.get(t).copied().unwrap_or(0);
            info.push([normal.x, normal.y, normal.z, f32::from_bits(object)]);
        }
        if info.is_empty() {
            info.push([0.0; 4]);
        }
        if corners.is_empty() {
            corners.push([0.0; 3]);
        }
        use wgpu::BufferUsages as U;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view vertices"),
            contents: bytemuck::cast_slice(&corners),
            usage: U::VERTEX,
        });
        let triangles = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view triangles"),
            contents: bytemuck::cast_slice(&info),
            usage: U::STORAGE,
        });
        let drawn_bits = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view drawn bits"),
            size: (n.div_ceil(32).max(1) * 4) as u64,
            usage: U::STORAGE | U::COPY_DST,
            mapped_at_creation: false,
        });
        let camera = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view camera"),
            size: std::mem::size_of::<CameraUniform>() as u64,
            usage: U::UNIFORM | U::COPY_DST,
            mapped_at_creation: false,
        });
        let counters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view counters"),
            size: 16,
            usage: U::STORAGE | U::COPY_DST | U::COPY_SRC,
            mapped_at_creation: false,
        });
        let counters_read = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view counters readback"),
            size: 16,
            usage: U::MAP_READ | U::COPY_DST,
            mapped_at_creation: false,
        });
        let indices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view culled indices"),
            size: 4,
            usage: U::INDEX | U::COPY_DST,
            mapped_at_creation: false,
        });
        let lines = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view cell lines"),
            size: std::mem::size_of::<LineVertex>() as u64,
            usage: U::VERTEX | U::COPY_DST,
            mapped_at_creation: false,
        });

        let shader = device.create_shader_module(wgpu::include_wgsl!("renderer.wgsl"));
        let depth = |write: bool, compare| {
            Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(write),
                depth_compare: Some(compare),
                stencil: Default::default(),
                bias: Default::default(),
            })
        };
        let position_attr = [wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: 0,
            shader_location: 0,
        }];
        let id_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view ids"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &shader,
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
                module: &shader,
                entry_point: Some("fs_id"),
                compilation_options: Default::default(),
                targets: &[Some(ID_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let compare_pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("view compare"),
            layout: None,
            module: &shader,
            entry_point: Some("cs_compare"),
            compilation_options: Default::default(),
            cache: None,
        });
        let resolve_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view resolve"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: depth(false, wgpu::CompareFunction::Always),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_resolve"),
                compilation_options: Default::default(),
                targets: &[Some(color_format.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
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
        let line_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view cells"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_line"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<LineVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &line_attrs,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::LineList,
                ..Default::default()
            },
            depth_stencil: depth(false, wgpu::CompareFunction::GreaterEqual),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
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
        });
        let camera_only = |pipeline_layout: wgpu::BindGroupLayout, label| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipeline_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                }],
            })
        };
        let id_bind = camera_only(id_pipeline.get_bind_group_layout(0), "view ids");
        let line_bind = camera_only(line_pipeline.get_bind_group_layout(0), "view cells");
        let resolve_scene_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view resolve scene"),
            layout: &resolve_pipeline.get_bind_group_layout(1),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: triangles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: drawn_bits.as_entire_binding(),
                },
            ],
        });
        let targets = Self::make_targets(
            device,
            &camera,
            &counters,
            &compare_pipeline,
            &resolve_pipeline,
            width,
            height,
        );
        Ok(Self {
            device: device.clone(),
            queue: queue.clone(),
            triangle_count: n as u32,
            vertices,
            camera,
            counters,
            counters_read,
            drawn_bits,
            indices,
            index_count: 0,
            lines,
            line_count: 0,
            id_pipeline,
            compare_pipeline,
            resolve_pipeline,
            line_pipeline,
            id_bind,
            line_bind,
            resolve_scene_bind,
            targets,
            culled_last: false,
        })
    }

    fn make_targets(
        device: &Device,
        camera: &wgpu::Buffer,
        counters: &wgpu::Buffer,
        compare: &wgpu::ComputePipeline,
        resolve: &wgpu::RenderPipeline,
        width: u32,
        height: u32,
    ) -> Targets {
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
        let full_view = ids_full.create_view(&Default::default());
        let culled_view = ids_culled.create_view(&Default::default());
        let compare_culled = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view compare"),
            layout: &compare.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&full_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&culled_view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: counters.as_entire_binding(),
                },
            ],
        });
        let resolve_bind = |culled: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("view resolve"),
                layout: &resolve.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: camera.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&full_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(culled),
                    },
                ],
            })
        };
        let resolve_culled = resolve_bind(&culled_view);
        let resolve_full = resolve_bind(&full_view);
        Targets {
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

    /// The size of the images, `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        (self.targets.width, self.targets.height)
    }

    /// Resizes the id and depth images (a no-op at the current size).
    pub fn resize(&mut self, width: u32, height: u32) {
        if (width.max(1), height.max(1)) == self.size() {
            return;
        }
        self.targets = Self::make_targets(
            &self.device,
            &self.camera,
            &self.counters,
            &self.compare_pipeline,
            &self.resolve_pipeline,
            width,
            height,
        );
        self.culled_last = false;
    }

    /// Sets the view-cell wireframe: pairs of line endpoints with their colours.
    pub(crate) fn set_lines(&mut self, lines: &[LineVertex]) {
        let bytes = std::mem::size_of_val(lines) as u64;
        if bytes > self.lines.size() {
            self.lines = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("view cell lines"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        if !lines.is_empty() {
            self.queue
                .write_buffer(&self.lines, 0, bytemuck::cast_slice(lines));
        }
        self.line_count = lines.len() as u32;
    }

    /// Renders one frame from `camera` (whose size must be the renderer's) into `target`, a
    /// view of a texture of the colour format given at creation and the renderer's size.
    /// `drawn` is the set of triangles the method draws; `None` draws everything.
    /// Blocks until the GPU has counted the popping pixels.
    pub fn render(
        &mut self,
        camera: &Camera,
        drawn: Option<&TriangleSet>,
        shading: Shading,
        target: &wgpu::TextureView,
    ) -> Result<GpuFrame, ViewError> {
        if (camera.width, camera.height) != self.size() {
            return Err(ViewError::SizeMismatch {
                camera: (camera.width, camera.height),
                renderer: self.size(),
            });
        }
        self.queue.write_buffer(
            &self.camera,
            0,
            bytemuck::bytes_of(&CameraUniform::new(camera, shading)),
        );
        // The drawn set as bits (for the x-ray tint) and as an index list (for the culled pass).
        let n = self.triangle_count as usize;
        let mut bits = vec![0u32; n.div_ceil(32).max(1)];
        match drawn {
            Some(set) => {
                let mut index_data: Vec<u32> = Vec::with_capacity(set.count_ones(..) * 3);
                for t in set.ones().filter(|&t| t < n) {
                    bits[t / 32] |= 1 << (t % 32);
                    let v = t as u32 * 3;
                    index_data.extend([v, v + 1, v + 2]);
                }
                let bytes = (index_data.len() * 4) as u64;
                if bytes > self.indices.size() {
                    self.indices = self.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("view culled indices"),
                        size: bytes.next_power_of_two(),
                        usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                }
                if !index_data.is_empty() {
                    self.queue
                        .write_buffer(&self.indices, 0, bytemuck::cast_slice(&index_data));
                }
                self.index_count = index_data.len() as u32;
            }
            None => {
                for t in 0..n {
                    bits[t / 32] |= 1 << (t % 32);
                }
                self.index_count = 0;
            }
        }
        self.queue
            .write_buffer(&self.drawn_bits, 0, bytemuck::cast_slice(&bits));
        self.queue.write_buffer(&self.counters, 0, &[0u8; 16]);
        let culled = drawn.is_some();
        self.culled_last = culled;

        let t = &self.targets;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("view frame"),
            });
        let full_view = t.ids_full.create_view(&Default::default());
        let culled_view = t.ids_culled.create_view(&Default::default());
        let id_pass = |encoder: &mut wgpu::CommandEncoder,
                       ids: &wgpu::TextureView,
                       depth: &wgpu::TextureView,
                       indexed: Option<u32>| {
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
            pass.set_pipeline(&self.id_pipeline);
            pass.set_bind_group(0, &self.id_bind, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            match indexed {
                None => pass.draw(0..self.triangle_count * 3, 0..1),
                Some(count) => {
                    if count > 0 {
                        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
                        pass.draw_indexed(0..count, 0, 0..1);
                    }
                }
            }
        };
        id_pass(&mut encoder, &full_view, &t.depth_full, None);
        if culled {
            id_pass(
                &mut encoder,
                &culled_view,
                &t.depth_culled,
                Some(self.index_count),
            );
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("view compare"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.compare_pipeline);
            pass.set_bind_group(0, &t.compare_culled, &[]);
            pass.dispatch_workgroups(t.width.div_ceil(8), t.height.div_ceil(8), 1);
        }
        {
            let show_full = !culled || shading.xray;
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
            pass.set_pipeline(&self.resolve_pipeline);
            pass.set_bind_group(
                0,
                if culled {
                    &t.resolve_culled
                } else {
                    &t.resolve_full
                },
                &[],
            );
            pass.set_bind_group(1, &self.resolve_scene_bind, &[]);
            pass.draw(0..3, 0..1);
            if self.line_count > 0 {
                pass.set_pipeline(&self.line_pipeline);
                pass.set_bind_group(0, &self.line_bind, &[]);
                pass.set_vertex_buffer(0, self.lines.slice(..));
                pass.draw(0..self.line_count, 0..1);
            }
        }
        encoder.copy_buffer_to_buffer(&self.counters, 0, &self.counters_read, 0, 16);
        self.queue.submit([encoder.finish()]);
        let counts = read_buffer(&self.device, &self.counters_read, 16)?;
        let word = |i: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&counts[i * 4..i * 4 + 4]);
            u32::from_ne_bytes(b)
        };
        Ok(GpuFrame {
            popping_pixels: if culled { word(0) } else { 0 },
            covered_pixels: if culled { word(1) } else { 0 },
        })
    }

    /// Reads back an id image of the last frame: per pixel, row-major, top row first, the
    /// triangle id or [`Hit::NONE`] for background (the convention of
    /// [`sightline_core::raster::Frame::ids`]).
    pub fn read_ids(&self, which: IdImage) -> Result<Vec<u32>, ViewError> {
        let texture = match which {
            IdImage::Culled if self.culled_last => &self.targets.ids_culled,
            _ => &self.targets.ids_full,
        };
        let raw = read_texture(&self.device, &self.queue, texture, 4)?;
        Ok(raw
            .chunks_exact(4)
            .map(|b| {
                let v = u32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
                if v == 0 {
                    Hit::NONE
                } else {
                    v - 1
                }
            })
            .collect())
    }
}

/// Maps `buffer` (of `MAP_READ` usage) and copies its first `bytes` bytes out, blocking.
pub(crate) fn read_buffer(
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
