//! The environment of headless GPU work (`view --frames N --out DIR`, `cull --backend gpu`).

/// Keeps Mesa's `VK_LAYER_MESA_device_select` implicit Vulkan layer out of headless runs.
///
/// The layer picks "the GPU of the display" by connecting to Wayland and X11 when the Vulkan
/// instance is created; with no session (a server, CI, ssh) libwayland prints
/// `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` twice, which reads as
/// a failure of the run although nothing failed. Headless runs have no display and choose
/// their adapter themselves (`sightline_gpu::vulkan_device` ranks them), so the layer has
/// nothing to do: `NODEVICE_SELECT=1` is the switch Mesa documents to skip it. A value the
/// user set is kept.
pub(crate) fn quiet_vulkan_layers() {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // Set before the Vulkan loader starts (it reads the variable when the instance is
        // created); no other thread reads the environment at this point of the command.
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}
