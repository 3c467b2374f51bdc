//! The viewer's errors.

use std::path::PathBuf;

/// Why the viewer could not start or render.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewError {
    /// No usable Vulkan device (see `sightline_gpu::vulkan_device`).
    #[error(transparent)]
    Gpu(#[from] sightline_gpu::GpuError),
    /// The `.pvs` file does not belong to the scene, or could not be read.
    #[error("PVS: {0}")]
    Pvs(#[from] sightline_region::PvsError),
    /// The scene has more triangles than the device's buffers hold.
    #[error(
        "the scene's {triangles} triangles do not fit the GPU's buffers (largest buffer \
         {max_buffer_bytes} bytes)"
    )]
    SceneTooLarge {
        /// Triangles in the scene.
        triangles: usize,
        /// The device's largest buffer.
        max_buffer_bytes: u64,
    },
    /// A camera of another size than the renderer's images.
    #[error("camera is {}x{} but the renderer draws {}x{}", camera.0, camera.1, renderer.0, renderer.1)]
    SizeMismatch {
        /// The camera's size.
        camera: (u32, u32),
        /// The renderer's size.
        renderer: (u32, u32),
    },
    /// The exact method's analytic visibility failed (an invalid camera).
    #[error("exact visibility: {0}")]
    Exact(String),
    /// Reading a GPU buffer back failed.
    #[error("reading GPU results back failed: {0}")]
    Readback(String),
    /// A camera could not be built (eye equal to look point, look along the up axis...).
    #[error("camera: {0}")]
    Camera(#[from] sightline_core::camera::CameraError),
    /// A camera path file is unreadable or malformed.
    #[error(transparent)]
    CameraPath(#[from] sightline_core::camera_path::CameraPathError),
    /// Writing an output file failed.
    #[error("writing {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Encoding a PNG failed.
    #[error("encoding {path}: {message}")]
    Png {
        /// The file.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// A cell index past the `.pvs` file's cells.
    #[error("there is no cell {cell}: the .pvs has {cells} cells (0 to {})", cells.saturating_sub(1))]
    NoSuchCell {
        /// The cell asked for.
        cell: usize,
        /// Cells in the `.pvs` (0 without one).
        cells: usize,
    },
    /// The window or its surface could not be created.
    #[error("window: {0}")]
    Window(String),
}
