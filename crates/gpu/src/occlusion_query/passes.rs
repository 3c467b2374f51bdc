//! Encoding one submission: the recorded commands replayed into one render pass per query set
//! (the depth pre-pass interleaved with the queries in recording order, Seletsky 2013, section
//! 4.3.2), then the query sets resolved and the counts copied into the mappable buffer.

use super::buffers::FrameBuffers;
use super::pipelines::{Pipelines, UnitCube};
use super::types::{Command, CUBE_INDICES, QUERIES_PER_SET};

/// Everything the render passes read: the targets, the fixed GPU objects, this submission's
/// buffers and the recorded commands.
pub(super) struct PassInputs<'a> {
    /// The depth target.
    pub(super) depth_view: &'a wgpu::TextureView,
    /// The query sets, at least as many as the submission has sets of queries.
    pub(super) query_sets: &'a [wgpu::QuerySet],
    /// Camera bind group and the two pipelines.
    pub(super) pipelines: &'a Pipelines,
    /// The unit cube of the query boxes.
    pub(super) cube: &'a UnitCube,
    /// The uploaded vertices, translations and boxes of this submission.
    pub(super) buffers: &'a FrameBuffers,
    /// Uploaded meshes: vertex buffer and vertex count.
    pub(super) meshes: &'a [(wgpu::Buffer, u32)],
    /// The recorded commands, in order.
    pub(super) commands: &'a [Command],
    /// The depth buffer was cleared by an earlier submission of this frame (load it, then).
    pub(super) depth_started: bool,
}

/// What is bound, to skip redundant state changes between consecutive draws.
#[derive(PartialEq)]
enum Bound {
    Nothing,
    Triangles,
    Mesh(u32),
    Boxes,
}

/// Encodes the render passes of `n_sets` query sets: pass `set` replays the commands up to the
/// first query of the next set, so the depth buffer carries every occluder recorded before a
/// query into that query's pass.
pub(super) fn encode_query_passes(
    encoder: &mut wgpu::CommandEncoder,
    inputs: &PassInputs,
    n_sets: u32,
) {
    let mut next = 0;
    for set in 0..n_sets {
        let load = if inputs.depth_started || set > 0 {
            wgpu::LoadOp::Load
        } else {
            // Reversed-Z: 0 is infinitely far.
            wgpu::LoadOp::Clear(0.0)
        };
        next = encode_set_pass(encoder, inputs, set, load, next);
    }
}

/// Encodes the render pass of query set `set`, replaying commands from `next` on; returns the
/// first command it did not replay (a query of a later set, or the end).
fn encode_set_pass(
    encoder: &mut wgpu::CommandEncoder,
    inputs: &PassInputs,
    set: u32,
    load: wgpu::LoadOp<f32>,
    mut next: usize,
) -> usize {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("sightline occlusion"),
        color_attachments: &[],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: inputs.depth_view,
            depth_ops: Some(wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: Some(&inputs.query_sets[set as usize]),
        multiview_mask: None,
    });
    pass.set_bind_group(0, &inputs.pipelines.bind_group, &[]);
    let mut bound = Bound::Nothing;
    while let Some(&command) = inputs.commands.get(next) {
        match command {
            Command::Depth { .. } | Command::Mesh { .. } => {
                draw_occluder(&mut pass, inputs, command, &mut bound);
            }
            Command::Query { index } => {
                if index / QUERIES_PER_SET != set {
                    break;
                }
                draw_query_box(&mut pass, inputs, index, &mut bound);
            }
        }
        next += 1;
    }
    next
}

/// Draws an occluder command (`Depth` or `Mesh`) into the depth buffer, binding the depth
/// pipeline and the command's vertex buffer unless `bound` says they already are.
fn draw_occluder(
    pass: &mut wgpu::RenderPass,
    inputs: &PassInputs,
    command: Command,
    bound: &mut Bound,
) {
    if matches!(bound, Bound::Nothing | Bound::Boxes) {
        pass.set_pipeline(&inputs.pipelines.depth_pipeline);
        pass.set_vertex_buffer(1, inputs.buffers.translations.buffer.slice(..));
    }
    match command {
        Command::Depth { first, count } => {
            if *bound != Bound::Triangles {
                pass.set_vertex_buffer(0, inputs.buffers.vertices.buffer.slice(..));
                *bound = Bound::Triangles;
            }
            pass.draw(first..first + count, 0..1);
        }
        Command::Mesh { mesh, instance } => {
            // Ids were checked in `draw_mesh`; meshes are never removed.
            if let Some((buffer, count)) = inputs.meshes.get(mesh as usize) {
                if *bound != Bound::Mesh(mesh) {
                    pass.set_vertex_buffer(0, buffer.slice(..));
                    *bound = Bound::Mesh(mesh);
                }
                pass.draw(0..*count, instance..instance + 1);
            }
        }
        Command::Query { .. } => {}
    }
}

/// Draws query box `index` inside its own occlusion query (slot `index % QUERIES_PER_SET` of
/// the pass's set), binding the query pipeline and the cube unless `bound` says they already are.
fn draw_query_box(pass: &mut wgpu::RenderPass, inputs: &PassInputs, index: u32, bound: &mut Bound) {
    if *bound != Bound::Boxes {
        pass.set_pipeline(&inputs.pipelines.query_pipeline);
        pass.set_vertex_buffer(0, inputs.cube.corners.slice(..));
        pass.set_vertex_buffer(1, inputs.buffers.boxes.buffer.slice(..));
        pass.set_index_buffer(inputs.cube.indices.slice(..), wgpu::IndexFormat::Uint16);
        *bound = Bound::Boxes;
    }
    pass.begin_occlusion_query(index % QUERIES_PER_SET);
    pass.draw_indexed(0..CUBE_INDICES.len() as u32, 0, index..index + 1);
    pass.end_occlusion_query();
}

/// Resolves the first `n_queries` queries of `query_sets` into the resolve buffer, in query
/// order, and copies its first `result_bytes` into the readback buffer.
pub(super) fn encode_resolve_and_copy(
    encoder: &mut wgpu::CommandEncoder,
    query_sets: &[wgpu::QuerySet],
    buffers: &FrameBuffers,
    n_queries: u32,
    result_bytes: u64,
) {
    let n_sets = n_queries.div_ceil(QUERIES_PER_SET);
    for set in 0..n_sets {
        let first = set * QUERIES_PER_SET;
        let count = (n_queries - first).min(QUERIES_PER_SET);
        encoder.resolve_query_set(
            &query_sets[set as usize],
            0..count,
            &buffers.resolve.buffer,
            u64::from(first) * u64::from(wgpu::QUERY_SIZE),
        );
    }
    encoder.copy_buffer_to_buffer(
        &buffers.resolve.buffer,
        0,
        &buffers.readback.buffer,
        0,
        result_bytes,
    );
}
