//! The Vulkan device a test binary shares: creating one on lavapipe takes a while, and the GPU
//! tests must FAIL, never skip, when there is no adapter (CI installs `mesa-vulkan-drivers`).

use std::sync::OnceLock;

use wgpu::{AdapterInfo, Device, Queue};

/// The device of [`sightline_gpu::vulkan_device`], created once per test binary; panics with
/// how to install a Vulkan driver when there is none. `crate_name` names the tests in the
/// message.
pub fn shared_device(crate_name: &str) -> &'static (Device, Queue, AdapterInfo) {
    static DEVICE: OnceLock<(Device, Queue, AdapterInfo)> = OnceLock::new();
    DEVICE.get_or_init(|| {
        sightline_gpu::vulkan_device().unwrap_or_else(|e| {
            panic!(
                "{e}\nThe {crate_name} tests need a Vulkan adapter and fail rather than skip. \
                 Install Mesa's software Vulkan driver: apt-get install -y mesa-vulkan-drivers"
            )
        })
    })
}
