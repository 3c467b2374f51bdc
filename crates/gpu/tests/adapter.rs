//! The adapter really is Vulkan (wgpu's GL fallback has only boolean queries).

use super::shared_device;

#[test]
fn vulkan_device_is_vulkan() {
    let (_, _, info) = shared_device();
    eprintln!(
        "adapter: {} ({:?}, driver {} {})",
        info.name, info.device_type, info.driver, info.driver_info
    );
    assert_eq!(info.backend, wgpu::Backend::Vulkan);
    assert!(sightline_gpu::check_vulkan(info).is_ok());
}

#[test]
fn backend_reports_its_adapter() {
    let gpu = super::gpu();
    assert_eq!(gpu.adapter_info().backend, wgpu::Backend::Vulkan);
}
