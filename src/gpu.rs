//! The wgpu adapter and device every GPU path of ssskit opens (the filter
//! pass, the Monte Carlo tracer): one place decides which adapter is used
//! and what counts as a software rasteriser, and holds what both paths do
//! with it (compiling a compute shader, binding buffers, reading a buffer
//! back).

use crate::error::{Error, Result};
use wgpu::util::DeviceExt;

/// shaders/wide_mul.wgsl: the 64-bit products of the shaders' integer
/// generators, prepended to each shader that uses them.
pub const WGSL_WIDE_MUL: &str = include_str!("../shaders/wide_mul.wgsl");

/// A shader's source as its pipeline compiles it: the WGSL declarations of
/// `consts` ([`wgsl_u32_consts`]), then `parts` in order (shared snippets,
/// structs, the body).
pub fn assemble_wgsl(consts: &[(&str, u32)], parts: &[&str]) -> String {
    let consts = wgsl_u32_consts(consts);
    std::iter::once(consts.as_str())
        .chain(parts.iter().copied())
        .collect::<Vec<_>>()
        .join("\n")
}

/// shaders/fresnel.wgsl: the Fresnel reflectance of a dielectric interface,
/// prepended to the tracer's and the light-space pass's shaders.
pub const WGSL_FRESNEL: &str = include_str!("../shaders/fresnel.wgsl");

/// WGSL declarations `const NAME: u32 = VALUEu;` of `consts`: an integer
/// constant of a generator is defined once, in Rust, and given to both the
/// CPU twin and the shader.
pub fn wgsl_u32_consts(consts: &[(&str, u32)]) -> String {
    consts
        .iter()
        .map(|(name, value)| format!("const {name}: u32 = {value}u;\n"))
        .collect()
}

/// Declares a plain-data struct that a shader reads (a uniform block, the
/// elements of a storage array) once for both sides: the `#[repr(C)]` Rust
/// struct and `NAME::WGSL`, its WGSL declaration, which the host prepends to
/// the shader. Fields are `u32` or `f32`, spelled alike in both languages,
/// so the layouts agree field by field (pad with scalars to the WGSL size,
/// a multiple of 16 bytes for a uniform block).
macro_rules! wgsl_struct {
    (
        $(#[$meta:meta])*
        struct $name:ident {
            $($(#[$field_meta:meta])* $field:ident: $ty:ident,)*
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
        struct $name {
            $($(#[$field_meta])* $field: $ty,)*
        }

        impl $name {
            /// The WGSL declaration of this struct.
            const WGSL: &'static str = concat!(
                "struct ", stringify!($name), " {\n",
                $("    ", stringify!($field), ": ", stringify!($ty), ",\n",)*
                "}\n"
            );
        }
    };
}
pub(crate) use wgsl_struct;

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
                     (scripts/setup) and `source scripts/env.sh`, or use the CPU backend"
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

    /// A compute pipeline from WGSL `source`, its bind group layout derived
    /// from the shader. A shader this adapter rejects is an error for the
    /// caller, not a panic in wgpu's default handler.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> Result<wgpu::ComputePipeline> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Unsupported(format!(
                "the {label} shader does not compile on {}: {e}",
                self.describe()
            )));
        }
        Ok(pipeline)
    }

    /// A buffer initialised with `contents`.
    pub fn buffer(&self, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    }

    /// Bind group 0 of `pipeline` with `buffers` at bindings 0, 1, ... in
    /// order.
    pub fn bind_group(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// An encoder holding one compute pass of `pipeline`, its bind group 0
    /// made of `buffers` (bindings 0, 1, ... in order), dispatched as
    /// `groups` workgroups: what a filter pass submits before reading back.
    pub fn dispatch(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
        groups: [u32; 3],
    ) -> wgpu::CommandEncoder {
        let group = self.bind_group(pipeline, buffers);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        }
        encoder
    }

    /// Submits `encoder` with a copy of the first `size` bytes of `src` (a
    /// COPY_SRC buffer) appended, waits for the device and returns those
    /// bytes as `T`s.
    pub fn read_back<T: bytemuck::Pod>(
        &self,
        mut encoder: wgpu::CommandEncoder,
        src: &wgpu::Buffer,
        size: u64,
    ) -> Result<Vec<T>> {
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        encoder.copy_buffer_to_buffer(src, 0, &readback, 0, size);
        self.queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Unsupported(format!("GPU wait failed: {e}")))?;
        rx.recv()
            .map_err(|e| Error::Unsupported(format!("GPU readback lost: {e}")))?
            .map_err(|e| Error::Unsupported(format!("GPU readback failed: {e}")))?;
        let view = slice
            .get_mapped_range()
            .map_err(|e| Error::Unsupported(format!("GPU readback failed: {e}")))?;
        let data = bytemuck::cast_slice::<u8, T>(&view).to_vec();
        drop(view);
        readback.unmap();
        Ok(data)
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

/// Points wgpu at lavapipe when no Vulkan driver was chosen, as
/// scripts/env.sh does; for tests, which `cargo test` may run without it.
pub fn use_software_vulkan_if_unset() {
    if std::env::var_os("VK_DRIVER_FILES").is_none()
        && std::env::var_os("VK_ICD_FILENAMES").is_none()
    {
        if let Ok(dir) = std::fs::read_dir("/usr/share/vulkan/icd.d") {
            let mut lvp: Vec<_> = dir
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| n.starts_with("lvp_icd.") && n.ends_with(".json"))
                })
                .collect();
            lvp.sort();
            if let Some(p) = lvp.first() {
                std::env::set_var("VK_DRIVER_FILES", p);
            }
        }
    }
    if std::env::var_os("WGPU_BACKEND").is_none() {
        std::env::set_var("WGPU_BACKEND", "vulkan");
    }
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Parses and validates `source` with naga, the shader compiler of
    /// wgpu: a shader assembled from several parts is checked without an
    /// adapter.
    pub(crate) fn assert_valid_wgsl(source: &str, what: &str) {
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{what}: {}", e.emit_to_string(source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{what}: naga validation failed: {e:?}"));
    }

    wgsl_struct! {
        /// A block with both field types and a doc comment on a field.
        struct Block {
            count: u32,
            /// Described on the Rust side only.
            scale: f32,
        }
    }

    #[test]
    fn shared_declarations_are_valid_wgsl_of_the_same_layout() {
        assert_eq!(
            Block::WGSL,
            "struct Block {\n    count: u32,\n    scale: f32,\n}\n"
        );
        assert_eq!(std::mem::size_of::<Block>(), 8);
        assert_valid_wgsl(Block::WGSL, "Block");
        assert_eq!(
            wgsl_u32_consts(&[("A", 0), ("B", u32::MAX)]),
            "const A: u32 = 0u;\nconst B: u32 = 4294967295u;\n"
        );
    }
}
