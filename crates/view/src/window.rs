//! The interactive window (`winit` + `wgpu` on Vulkan): a fly camera over the scene, the
//! method chosen with the number keys, the frame's numbers in the HUD (top-left) and in the
//! window title.
//!
//! The keys and mouse inputs are those of [`CONTROLS`], which
//! `sightline view --help` prints too. The HUD shows the method, the current cell, triangles
//! and objects drawn, the popping pixels of the frame with their maximum and mean since the
//! last method change, and fps. Its help lines (the controls) are shown for the first
//! [`HELP_AT_START`] seconds and then on H or F1; otherwise one line says which key shows
//! them. Shown at the start, a first-time user sees the keys without asking; hidden after, they
//! do not cover the image a designer is judging, and the hint line keeps them one key away.

use std::sync::Arc;
use std::time::Instant;

use sightline_gpu::{check_vulkan, pick_adapter};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::controls::{action_of, help_lines, Action, Direction, CONTROLS};
use crate::error::ViewError;
use crate::fly_camera::{FlyCamera, Movement};
use crate::hud;
use crate::renderer::Renderer;
use crate::viewer::{FrameRecord, Viewer};

/// Seconds the help lines are shown after the window opens.
const HELP_AT_START: f32 = 8.0;

/// Lens settings of the window's camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Near-plane distance.
    pub near: f32,
}

/// Everything that exists once the window is open.
struct Open {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    device: wgpu::Device,
    queue: wgpu::Queue,
    renderer: Renderer,
    adapter_name: String,
}

struct App {
    viewer: Viewer,
    camera: FlyCamera,
    lens: Lens,
    size: (u32, u32),
    open: Option<Open>,
    keys: Movement,
    looking: bool,
    /// The last cursor position in the window, in physical pixels.
    cursor: Option<(f64, f64)>,
    last: Instant,
    /// When the window opened (the help lines show for [`HELP_AT_START`] seconds).
    opened: Instant,
    /// The help lines toggled with H or F1 (`None`: not yet, shown at the start).
    help: Option<bool>,
    error: Option<ViewError>,
}

/// Opens a `width x height` window on `viewer`'s scene with the camera `camera` and runs until
/// it is closed. Needs a display (X11 or Wayland) and a Vulkan driver.
pub fn run_window(
    viewer: Viewer,
    camera: FlyCamera,
    lens: Lens,
    width: u32,
    height: u32,
) -> Result<(), ViewError> {
    let event_loop = EventLoop::new().map_err(|e| ViewError::Window(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        viewer,
        camera,
        lens,
        size: (width.max(1), height.max(1)),
        open: None,
        keys: Movement::default(),
        looking: false,
        cursor: None,
        last: Instant::now(),
        opened: Instant::now(),
        help: None,
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewError::Window(e.to_string()))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl App {
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<Open, ViewError> {
        let window = event_loop
            .create_window(
                Window::default_attributes()
                    .with_title("sightline view")
                    .with_inner_size(PhysicalSize::new(self.size.0, self.size.1)),
            )
            .map_err(|e| ViewError::Window(e.to_string()))?;
        let window = Arc::new(window);
        // Vulkan only, as in sightline-gpu.
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| ViewError::Window(format!("creating a Vulkan surface: {e}")))?;
        // The Vulkan adapters that can present to the window, chosen as sightline-gpu chooses.
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
            .into_iter()
            .filter(|a| a.is_surface_supported(&surface))
            .collect();
        let adapter = pick_adapter(adapters).ok_or(sightline_gpu::GpuError::NoVulkanAdapter)?;
        let info = adapter.get_info();
        check_vulkan(&info)?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sightline-view"),
            ..Default::default()
        }))
        .map_err(sightline_gpu::GpuError::from)?;
        let inner = window.inner_size();
        let (w, h) = (inner.width.max(1), inner.height.max(1));
        let mut config = surface.get_default_config(&adapter, w, h).ok_or_else(|| {
            ViewError::Window("the surface is not supported by the adapter".into())
        })?;
        // The resolve shader writes display values: prefer a non-sRGB format.
        let caps = surface.get_capabilities(&adapter);
        if let Some(f) = caps.formats.iter().find(|f| !f.is_srgb()) {
            config.format = *f;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&device, &config);
        let renderer = Renderer::new(&device, &queue, self.viewer.scene(), config.format, w, h)?;
        Ok(Open {
            window,
            surface,
            config,
            device,
            queue,
            renderer,
            adapter_name: info.name,
        })
    }

    fn redraw(&mut self) -> Result<(), ViewError> {
        let now = Instant::now();
        let dt = (now - self.last).as_secs_f32().min(0.25);
        self.last = now;
        self.camera.update(&self.keys, dt);
        let help = self.help_shown();
        let Some(open) = &mut self.open else {
            return Ok(());
        };
        let frame = match open.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                open.surface.configure(&open.device, &open.config);
                return Ok(());
            }
            _ => return Ok(()),
        };
        let view = frame.texture.create_view(&Default::default());
        let camera = self.camera.camera(
            self.lens.fov_y_deg,
            open.config.width,
            open.config.height,
            self.lens.near,
        )?;
        let record = self.viewer.frame(&mut open.renderer, &camera, &view)?;
        let fps = if dt > 0.0 { 1.0 / dt } else { 0.0 };
        let lines = hud_lines(&self.viewer, &record, fps, self.camera.speed, help);
        let (w, h) = (open.config.width, open.config.height);
        let panel = hud::panel(&lines, hud::hud_scale(h), w, h);
        open.renderer
            .draw_overlay(&view, &panel.pixels, (panel.width, panel.height));
        open.window.pre_present_notify();
        open.queue.present(frame);
        open.window.set_title(&format!(
            "sightline view | {} | {:.0} fps | speed {:.3} | {}",
            self.viewer.status(&record),
            fps,
            self.camera.speed,
            open.adapter_name
        ));
        Ok(())
    }

    /// Whether the HUD shows the help lines: as toggled, else during the first seconds.
    fn help_shown(&self) -> bool {
        self.help
            .unwrap_or(self.opened.elapsed().as_secs_f32() < HELP_AT_START)
    }

    /// Acts on key `code` going down (`pressed`) or up, as [`CONTROLS`] says: movement keys
    /// while held, the others once when pressed.
    fn key(&mut self, code: KeyCode, pressed: bool, event_loop: &ActiveEventLoop) {
        let Some(action) = action_of(code) else {
            return;
        };
        match action {
            Action::Move(direction) => hold(&mut self.keys, direction, pressed),
            _ if !pressed => {}
            Action::Method(m) => self.viewer.set_method(m),
            Action::ToggleXray => self.viewer.shading.xray = !self.viewer.shading.xray,
            Action::TogglePopping => {
                self.viewer.shading.mark_popping = !self.viewer.shading.mark_popping;
            }
            Action::ToggleCells => self.viewer.show_cells = !self.viewer.show_cells,
            Action::ToggleFreeze => self.toggle_freeze(),
            Action::StepCell(next) => self.viewer.step_cell(next),
            // Picking none always succeeds.
            Action::EyeCell => self.viewer.pick_cell(None).unwrap_or_default(),
            Action::ToggleOverview => self.viewer.overview = !self.viewer.overview,
            Action::ToggleHelp => self.help = Some(!self.help_shown()),
            Action::Quit => event_loop.exit(),
            // Mouse inputs: handled in `window_event`.
            Action::Look | Action::Speed => {}
        }
    }

    /// Freezes culling at the camera of the current pose and window size, or unfreezes.
    fn toggle_freeze(&mut self) {
        if self.viewer.frozen().is_some() {
            self.viewer.unfreeze();
            return;
        }
        let Some(open) = &self.open else {
            return;
        };
        let (w, h) = (open.config.width, open.config.height);
        // A pose without a camera (cannot happen with the pitch limit) leaves culling live.
        if let Ok(camera) = self
            .camera
            .camera(self.lens.fov_y_deg, w, h, self.lens.near)
        {
            self.viewer.freeze(camera);
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewError) {
        self.error = Some(e);
        event_loop.exit();
    }
}

/// Sets the held state of `direction` in `keys`.
fn hold(keys: &mut Movement, direction: Direction, pressed: bool) {
    let held = match direction {
        Direction::Forward => &mut keys.forward,
        Direction::Back => &mut keys.back,
        Direction::Left => &mut keys.left,
        Direction::Right => &mut keys.right,
        Direction::Up => &mut keys.up,
        Direction::Down => &mut keys.down,
    };
    *held = pressed;
}

/// The window's HUD lines: the frame's numbers, fps and fly speed, then the help lines
/// (`help`) or the line saying how to show them.
fn hud_lines(
    viewer: &Viewer,
    record: &FrameRecord,
    fps: f32,
    speed: f32,
    help: bool,
) -> Vec<String> {
    let mut lines = hud::frame_lines(viewer, record);
    lines.push(format!("{fps:.0} fps  speed {speed:.3}"));
    if help {
        lines.push(String::new());
        lines.extend(help_lines());
    } else {
        let toggle = CONTROLS.iter().find(|c| c.action == Action::ToggleHelp);
        lines.push(format!("{}: keys", toggle.map_or("?", |c| c.input)));
    }
    lines
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.open.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(open) => {
                open.window.request_redraw();
                self.open = Some(open);
                self.last = Instant::now();
                self.opened = self.last;
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(open) = &mut self.open {
                    let (w, h) = (size.width.max(1), size.height.max(1));
                    open.config.width = w;
                    open.config.height = h;
                    open.surface.configure(&open.device, &open.config);
                    open.renderer.resize(w, h);
                }
            }
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    self.key(code, event.state == ElementState::Pressed, event_loop);
                }
            }
            // Mouse look from cursor positions while a button is held (a drag), rather than
            // raw device motion: it works the same on X11, Wayland, Xvfb and remote displays.
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let (true, Some(last)) = (self.looking, self.cursor) {
                    self.camera
                        .rotate((p.0 - last.0) as f32, (p.1 - last.1) as f32);
                }
                self.cursor = Some(p);
            }
            WindowEvent::MouseInput { state, button, .. } => {
                if matches!(button, MouseButton::Right | MouseButton::Left) {
                    self.looking = state == ElementState::Pressed;
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.camera.scroll(steps);
            }
            WindowEvent::Focused(false) => {
                self.keys = Movement::default();
                self.looking = false;
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw() {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(open) = &self.open {
            open.window.request_redraw();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewer::{Method, ViewerOptions};

    fn viewer_and_record() -> (Viewer, FrameRecord) {
        let scene = sightline_core::scene::open("procedural:city?size=200", &Default::default())
            .expect("the procedural city opens");
        let record = FrameRecord {
            frame: 0,
            method: Method::None,
            eye: [0.0; 3],
            forward: [1.0, 0.0, 0.0],
            cell: None,
            cell_picked: false,
            frozen_at: None,
            overview: false,
            popping_counted: true,
            triangles_drawn: scene.triangle_count(),
            triangles_total: scene.triangle_count(),
            objects_drawn: scene.objects.len(),
            objects_total: scene.objects.len(),
            popping_pixels: 0,
            covered_pixels: 0,
            cull_ms: 0.0,
        };
        let viewer = Viewer::new(scene, None, ViewerOptions::default()).expect("no .pvs");
        (viewer, record)
    }

    #[test]
    fn hud_shows_every_control_with_help_on() {
        let (viewer, record) = viewer_and_record();
        let lines = hud_lines(&viewer, &record, 59.6, 2.5, true);
        assert_eq!(lines[4], "60 fps  speed 2.500");
        assert!(lines.ends_with(&help_lines()));
    }

    #[test]
    fn hud_says_how_to_show_help_with_help_off() {
        let (viewer, record) = viewer_and_record();
        let lines = hud_lines(&viewer, &record, 0.0, 1.0, false);
        assert_eq!(lines.last().map(String::as_str), Some("H, F1: keys"));
        assert_eq!(lines.len(), 6);
    }
}
