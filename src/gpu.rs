//! The wgpu adapter and device every GPU path of ssskit opens (the filter
//! pass, the Monte Carlo tracer): one place decides which adapter is used
//! and what counts as a software rasteriser.

use crate::error::{Error, Result};

/// An opened adapter: its device, queue and description.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
}

impl GpuContext {
    /// Opens the first adapter the environment allows (WGPU_BACKEND etc. are
    /// honoured), preferring a high-performance one; an error, never a
    /// silent CPU fallback, when there is none.
    pub fn open() -> Result<GpuContext> {
        pollster::block_on(GpuContext::open_async())
    }

    pub async fn open_async() -> Result<GpuContext> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
            .map_err(|e| {
                Error::Unsupported(format!(
                    "no GPU adapter found ({e}); without a GPU, install Mesa's lavapipe \
                     (scripts/setup) and `source scripts/env.sh`, or use --backend cpu"
                ))
            })?;
        let info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("ssskit"),
                required_limits: adapter.limits(),
                // Timestamps for the filter's frame timing when the adapter has them.
                required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
                ..Default::default()
            })
            .await
            .map_err(|e| Error::Unsupported(format!("cannot open the GPU device: {e}")))?;
        Ok(GpuContext {
            device,
            queue,
            info,
        })
    }

    /// True for a software rasteriser (lavapipe/llvmpipe, WARP): correct,
    /// but slower than the CPU paths, so automatic backend choices skip it.
    pub fn is_software(&self) -> bool {
        is_software(&self.info)
    }

    /// "name (backend, device type, driver)".
    pub fn describe(&self) -> String {
        describe(&self.info)
    }
}

/// See `GpuContext::is_software`.
pub fn is_software(info: &wgpu::AdapterInfo) -> bool {
    info.device_type == wgpu::DeviceType::Cpu
}

/// See `GpuContext::describe`.
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    format!(
        "{} ({:?}, {:?}, {} {})",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    )
}
