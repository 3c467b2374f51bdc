//! The headless driver: renders a list of cameras offscreen (no window, no event loop) and
//! writes `frame_0000.png`, `frame_0001.png`, ... and `frames.json` with the numbers of every
//! frame (method, triangles drawn, popping pixels) and the popping summary. With the HUD on,
//! each frame carries its numbers in its top-left corner too (see `hud/`), so a recorded
//! flight explains itself; without it the frames are the renderer's output as is. Culling can
//! be frozen at a frame (the later frames fly on with that frame's set) and the frames drawn
//! from the top-down overview ([`HeadlessOptions`]).

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use sightline_core::atomic_file::write_atomic;
use sightline_core::Camera;
use wgpu::{Device, Queue, TextureFormat};

use crate::error::ViewError;
use crate::hud;
use crate::renderer::{read_texture, Renderer};
use crate::viewer::{FrameRecord, PoppingStats, Viewer};

/// The colour format of headless frames (written to PNG as is).
pub const HEADLESS_FORMAT: TextureFormat = TextureFormat::Rgba8Unorm;

/// What a headless run wrote.
#[derive(Clone, Debug, Serialize)]
pub struct HeadlessReport {
    /// The scene's source.
    pub scene: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The GPU adapter's name.
    pub adapter: String,
    /// How popping pixels were counted.
    pub popping_measured_by: &'static str,
    /// Popping over the frames whose popping is counted (not frozen, not in the overview).
    pub popping: PoppingStats,
    /// Mean popping pixels per counted frame.
    pub popping_mean: f64,
    /// Every frame.
    pub frames: Vec<FrameRecord>,
    /// The PNG files, in frame order.
    #[serde(skip)]
    pub pngs: Vec<PathBuf>,
}

/// How a headless run draws its frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HeadlessOptions {
    /// Draw the HUD over each frame ([`Offscreen::draw_hud`]).
    pub hud: bool,
    /// Freeze culling at this frame (0-based): it and the frames after it draw the set chosen
    /// for its camera, while the cameras move on.
    pub freeze_at: Option<u32>,
    /// Draw every frame from the top-down overview camera (the set still chosen from the
    /// frame's camera, or the frozen one).
    pub overview: bool,
}

/// An offscreen colour target and its renderer.
pub struct Offscreen {
    /// The renderer.
    pub renderer: Renderer,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    device: Device,
    queue: Queue,
}

impl Offscreen {
    /// A renderer of `viewer`'s scene with a `width x height` offscreen colour target.
    pub fn new(
        device: &Device,
        queue: &Queue,
        viewer: &Viewer,
        width: u32,
        height: u32,
    ) -> Result<Self, ViewError> {
        let renderer = Renderer::new(
            device,
            queue,
            viewer.scene(),
            HEADLESS_FORMAT,
            width,
            height,
        )?;
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("view offscreen"),
            size: wgpu::Extent3d {
                width: width.max(1),
                height: height.max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HEADLESS_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        Ok(Self {
            renderer,
            texture,
            view,
            device: device.clone(),
            queue: queue.clone(),
        })
    }

    /// Renders one frame of `viewer` from `camera`.
    pub fn frame(
        &mut self,
        viewer: &mut Viewer,
        camera: &Camera,
    ) -> Result<FrameRecord, ViewError> {
        viewer.frame(&mut self.renderer, camera, &self.view)
    }

    /// Blends the HUD of `record`, the last frame of `viewer`, over that frame: the viewer's
    /// lines (method, cell, triangles, objects, popping) and the frame number. No fps, so
    /// the same flight gives the same frames.
    pub fn draw_hud(&mut self, viewer: &Viewer, record: &FrameRecord) {
        let mut lines = hud::frame_lines(viewer, record);
        lines.push(format!("frame {}", record.frame));
        let (w, h) = (self.texture.width(), self.texture.height());
        let panel = hud::panel(&lines, hud::hud_scale(h), w, h);
        self.renderer
            .draw_overlay(&self.view, &panel.pixels, (panel.width, panel.height));
    }

    /// The last frame's colour image.
    pub fn read_rgba(&self) -> Result<image::RgbaImage, ViewError> {
        let raw = read_texture(&self.device, &self.queue, &self.texture, 4)?;
        image::RgbaImage::from_raw(self.texture.width(), self.texture.height(), raw)
            .ok_or_else(|| ViewError::Readback("colour image of the wrong size".into()))
    }
}

/// Renders `cameras` (all of one size) with `viewer` on `device` and writes the PNG frames and
/// `frames.json` into `out_dir` (created if missing), as `options` says (HUD, frozen culling,
/// overview). Each file is written atomically. The report's popping summary counts only the
/// frames whose popping is counted ([`FrameRecord::popping_counted`]: not frozen, not in the
/// overview).
pub fn run_headless(
    device: &Device,
    queue: &Queue,
    adapter: &str,
    viewer: &mut Viewer,
    cameras: &[Camera],
    out_dir: &Path,
    options: &HeadlessOptions,
) -> Result<HeadlessReport, ViewError> {
    let (width, height) = cameras.first().map_or((1, 1), |c| (c.width, c.height));
    std::fs::create_dir_all(out_dir).map_err(|source| ViewError::Write {
        path: out_dir.to_path_buf(),
        source,
    })?;
    let mut offscreen = Offscreen::new(device, queue, viewer, width, height)?;
    let mut report = HeadlessReport {
        scene: viewer.scene().source.clone(),
        width,
        height,
        adapter: adapter.to_string(),
        popping_measured_by: "GPU: triangle-id images (R32Uint) of the full and the culled set \
                              at the frame's resolution, differing pixels counted by a compute \
                              pass",
        popping: PoppingStats::default(),
        popping_mean: 0.0,
        frames: Vec::with_capacity(cameras.len()),
        pngs: Vec::with_capacity(cameras.len()),
    };
    viewer.overview = options.overview;
    for (i, camera) in cameras.iter().enumerate() {
        if options.freeze_at == Some(i as u32) {
            viewer.freeze(*camera);
        }
        let record = offscreen.frame(viewer, camera)?;
        if record.popping_counted {
            report.popping.add(record.popping_pixels);
        }
        if options.hud {
            offscreen.draw_hud(viewer, &record);
        }
        let image = offscreen.read_rgba()?;
        let path = out_dir.join(format!("frame_{:04}.png", record.frame));
        write_png(&path, &image)?;
        report.pngs.push(path);
        report.frames.push(record);
    }
    report.popping_mean = report.popping.mean();
    let json_path = out_dir.join("frames.json");
    let json = serde_json::to_vec_pretty(&report).map_err(|e| ViewError::Write {
        path: json_path.clone(),
        source: e.into(),
    })?;
    write_atomic(&json_path, |w| w.write_all(&json)).map_err(|source| ViewError::Write {
        path: json_path.clone(),
        source,
    })?;
    Ok(report)
}

/// Encodes `image` as PNG in memory and writes it atomically.
fn write_png(path: &Path, image: &image::RgbaImage) -> Result<(), ViewError> {
    let mut bytes = Vec::new();
    image
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| ViewError::Png {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    write_atomic(path, |w| w.write_all(&bytes)).map_err(|source| ViewError::Write {
        path: path.to_path_buf(),
        source,
    })
}
