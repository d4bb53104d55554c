//! The wgpu post-process: shaders/sss_pass.wgsl run per rank as a horizontal
//! then a vertical pass, the vertical pass accumulating into the output,
//! which starts as the specular image (so specular is added after the blur).
//! f32 throughout; checked against `screen_space::apply_screen_space` (f64).

use super::{Image, Setup};
use crate::error::{Error, Result};
use crate::gpu::{assemble_wgsl, wgsl_struct, GpuContext, WGSL_WIDE_MUL};
use std::marker::PhantomData;

const SHADER: &str = include_str!("../../shaders/sss_pass.wgsl");

/// What both screen-space passes' shaders share: the image, depth and
/// strength bindings and the interleaved gradient noise (after
/// `WGSL_WIDE_MUL` and [`ign_constants`]).
pub(super) const SCREEN_COMMON_WGSL: &str = include_str!("../../shaders/screen_common.wgsl");

/// A device with one pass's pipeline compiled: [`Gpu`] (the separable
/// pass), [`super::disk_gpu::DiskGpu`] and
/// [`super::light_space_gpu::LightSpaceGpu`]. `K` names the pass, whose
/// own methods (`new`, `apply`) are written for `GpuPass<K>`.
pub struct GpuPass<K> {
    pub(super) ctx: GpuContext,
    pub(super) pipeline: wgpu::ComputePipeline,
    kind: PhantomData<K>,
}

impl<K> GpuPass<K> {
    /// Opens the adapter (see `GpuContext::open`) and compiles `source`'s
    /// entry point `main` as the pipeline `label`.
    pub(super) fn open(label: &str, source: &str) -> Result<Self> {
        let ctx = GpuContext::open()?;
        let pipeline = ctx.compute_pipeline(label, source, "main")?;
        Ok(GpuPass {
            ctx,
            pipeline,
            kind: PhantomData,
        })
    }

    /// True for a software rasteriser (lavapipe/llvmpipe, WARP): correct, but
    /// slower than the CPU path, so an automatic backend choice skips it.
    pub fn is_software(&self) -> bool {
        self.ctx.is_software()
    }

    /// "name (backend, device type, driver)".
    pub fn describe(&self) -> String {
        self.ctx.describe()
    }

    /// One dispatch of `groups` workgroups over the bindings in order: the
    /// uniform block `params`, the storage `inputs`, then the storage
    /// output, which starts as `output` and is read back.
    pub(super) fn run_once<T: bytemuck::Pod>(
        &self,
        label: &str,
        params: &[u8],
        inputs: &[(&str, &[u8])],
        output: &[u8],
        groups: [u32; 3],
    ) -> Result<Vec<T>> {
        let c = &self.ctx;
        let storage = wgpu::BufferUsages::STORAGE;
        let mut buffers = vec![c.buffer("params", params, wgpu::BufferUsages::UNIFORM)];
        buffers.extend(
            inputs
                .iter()
                .map(|(name, bytes)| c.buffer(name, bytes, storage)),
        );
        buffers.push(c.buffer("output", output, storage | wgpu::BufferUsages::COPY_SRC));
        let refs: Vec<&wgpu::Buffer> = buffers.iter().collect();
        let encoder = c.dispatch(label, &self.pipeline, &refs, groups);
        c.read_back(encoder, &buffers[inputs.len() + 1], output.len() as u64)
    }
}

/// The separable pass: sss_pass.wgsl per rank, horizontal then vertical.
pub enum Separable {}

/// A device with the separable pass's pipeline compiled.
pub type Gpu = GpuPass<Separable>;

wgsl_struct! {
    /// The uniform block of one 1D pass.
    struct Params {
        width: u32,
        height: u32,
        ntaps: u32,
        /// 0: horizontal, 1: vertical.
        axis: u32,
        /// 0: orthographic step, 1: perspective step divided by depth
        /// (Freude 2014, eq. 4.11).
        perspective: u32,
        /// 1: lerp toward the centre colour by depth difference (Freude
        /// 2014, eq. 4.12).
        follow: u32,
        /// 1: dst += result (vertical pass of a rank), 0: dst = result.
        accumulate: u32,
        /// 1: each tap jittered inside its footprint (interleaved gradient
        /// noise).
        jitter: u32,
        /// Pixels per kernel mm before strength and depth.
        step_base: f32,
        /// k of t = clamp(k |d_centre - d_sample|, 0, 1).
        follow_k: f32,
        _pad0: f32,
        _pad1: f32,
    }
}

impl Gpu {
    /// Opens the adapter (see `GpuContext::open`) and compiles the pass.
    pub fn new() -> Result<Gpu> {
        Self::open("sss_pass", &shader_source())
    }

    /// Runs `setup` on `image`.
    pub fn apply(&self, image: &Image, setup: &Setup) -> Result<Image> {
        let frame = self.prepare(image, setup)?;
        let (w, h) = (image.width, image.height);
        let mut encoder = self.encoder();
        self.encode(&mut encoder, &frame, None);
        let data: Vec<[f32; 4]> = self
            .ctx
            .read_back(encoder, &frame.acc, (w * h * 16) as u64)?;
        Ok(image_from_rgba(&data, image))
    }

    /// Whether the device records GPU timestamps ([`Gpu::time_frames`]).
    pub fn has_timestamps(&self) -> bool {
        self.ctx
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// GPU time of the post-process, in milliseconds, for each of `frames`
    /// frames after one warm-up frame: timestamps written at the start and
    /// the end of the compute pass that holds every dispatch of a frame, so
    /// uploads and readback are outside. An error when the adapter has no
    /// timestamp queries.
    pub fn time_frames(&self, image: &Image, setup: &Setup, frames: u32) -> Result<Vec<f64>> {
        if !self.has_timestamps() {
            return Err(Error::Unsupported(format!(
                "{} has no timestamp queries (wgpu Features::TIMESTAMP_QUERY)",
                self.describe()
            )));
        }
        crate::error::count_up_to("bench", "frames", frames as usize, 1000)?;
        let frame = self.prepare(image, setup)?;
        let count = 2 * (frames + 1);
        let queries = self.ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("frame timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let bytes = count as u64 * wgpu::QUERY_SIZE as u64;
        let resolved = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        for f in 0..=frames {
            let mut encoder = self.encoder();
            self.encode(&mut encoder, &frame, Some((&queries, 2 * f)));
            self.ctx.queue.submit([encoder.finish()]);
        }
        let mut encoder = self.encoder();
        encoder.resolve_query_set(&queries, 0..count, &resolved, 0);
        let ticks: Vec<u64> = self.ctx.read_back(encoder, &resolved, bytes)?;
        let ns_per_tick = self.ctx.queue.get_timestamp_period() as f64;
        Ok(ticks
            .chunks_exact(2)
            .skip(1)
            .map(|t| t[1].wrapping_sub(t[0]) as f64 * ns_per_tick * 1e-6)
            .collect())
    }

    /// Uploads the image and the tables and builds one bind group per 1D
    /// pass: the whole frame, ready to encode any number of times.
    fn prepare(&self, image: &Image, setup: &Setup) -> Result<Frame> {
        setup.validate(image)?;
        let (w, h) = (image.width, image.height);
        let n = w * h;
        check_binding(&self.ctx, w, h)?;
        let scalar = |p: Option<&super::Plane>| plane_or_ones(p, n);
        let storage = wgpu::BufferUsages::STORAGE;
        let src = self
            .ctx
            .buffer("image", bytemuck::cast_slice(&rgba(image)), storage);
        let depth = self.ctx.buffer(
            "depth",
            bytemuck::cast_slice(&scalar(setup.depth.as_ref())),
            storage,
        );
        let strength = self.ctx.buffer(
            "strength",
            bytemuck::cast_slice(&scalar(setup.strength.as_ref())),
            storage,
        );
        let tmp = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("horizontal"),
            size: (n * 16) as u64,
            usage: storage,
            mapped_at_creation: false,
        });
        let start = match &setup.specular {
            Some(s) => rgba(s),
            None => vec![[0.0; 4]; n],
        };
        let acc = self.ctx.buffer(
            "output",
            bytemuck::cast_slice(&start),
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        let base = Params {
            width: w as u32,
            height: h as u32,
            ntaps: 0,
            axis: 0,
            perspective: matches!(setup.scale, super::Scale::Perspective { .. }) as u32,
            follow: setup.follow_surface.is_some() as u32,
            accumulate: 0,
            jitter: setup.jitter as u32,
            step_base: setup.scale.step_base(h) as f32,
            follow_k: setup.follow_surface.map_or(0.0, |f| f.rate(&setup.scale)) as f32,
            _pad0: 0.0,
            _pad1: 0.0,
        };
        let mut groups = Vec::new();
        for taps in &setup.passes {
            let table: Vec<[f32; 4]> = taps
                .offsets_mm
                .iter()
                .zip(&taps.weights)
                .map(|(o, w)| [w[0] as f32, w[1] as f32, w[2] as f32, *o as f32])
                .collect();
            let spans: Vec<[f32; 2]> = taps
                .footprints()
                .iter()
                .map(|&(lo, width)| [lo as f32, width as f32])
                .collect();
            let tap_buf = self
                .ctx
                .buffer("taps", bytemuck::cast_slice(&table), storage);
            let span_buf = self
                .ctx
                .buffer("footprints", bytemuck::cast_slice(&spans), storage);
            for (axis, from, to) in [(0u32, &src, &tmp), (1u32, &tmp, &acc)] {
                let p = Params {
                    ntaps: table.len() as u32,
                    axis,
                    accumulate: axis,
                    ..base
                };
                let ubuf = self.ctx.buffer(
                    "params",
                    bytemuck::bytes_of(&p),
                    wgpu::BufferUsages::UNIFORM,
                );
                groups.push(self.ctx.bind_group(
                    &self.pipeline,
                    &[&ubuf, from, &depth, &strength, &tap_buf, to, &span_buf],
                ));
            }
        }
        Ok(Frame {
            groups,
            acc,
            workgroups: (
                (w as u32).div_ceil(WORKGROUP_SIDE),
                (h as u32).div_ceil(WORKGROUP_SIDE),
            ),
        })
    }

    /// Every 1D pass of a frame in one compute pass (wgpu orders the
    /// dispatches' storage accesses), with optional timestamps at its start
    /// and end (query indices `first` and `first + 1`).
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &Frame,
        timestamps: Option<(&wgpu::QuerySet, u32)>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("sss frame"),
            timestamp_writes: timestamps.map(|(query_set, first)| {
                wgpu::ComputePassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: Some(first),
                    end_of_pass_write_index: Some(first + 1),
                }
            }),
        });
        pass.set_pipeline(&self.pipeline);
        for group in &frame.groups {
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(frame.workgroups.0, frame.workgroups.1, 1);
        }
    }

    fn encoder(&self) -> wgpu::CommandEncoder {
        self.ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
    }
}

/// Side of the square workgroup of sss_pass.wgsl, in pixels.
const WORKGROUP_SIDE: u32 = 8;

/// The constants sss_pass.wgsl shares with this file and the CPU twin
/// ([`super::jitter`]), prepended to it as WGSL `const`s: the shader names
/// them and never spells their values.
fn shared_constants() -> Vec<(&'static str, u32)> {
    [
        &ign_constants()[..],
        &[
            ("GOLDEN_U32", super::jitter::GOLDEN_U32),
            ("WORKGROUP_SIDE", WORKGROUP_SIDE),
        ],
    ]
    .concat()
}

/// The interleaved gradient noise's fixed-point constants, shared by the
/// separable and the disk pass's shaders with their CPU twin
/// ([`super::jitter`]).
pub(super) fn ign_constants() -> [(&'static str, u32); 5] {
    use super::jitter::{IGN_FRACTION, IGN_WHOLE, IGN_X, IGN_Y, JITTER_BITS};
    [
        ("IGN_X", IGN_X),
        ("IGN_Y", IGN_Y),
        ("IGN_WHOLE", IGN_WHOLE),
        ("IGN_FRACTION", IGN_FRACTION),
        ("JITTER_BITS", JITTER_BITS),
    ]
}

/// Refuses a `w` x `h` image whose RGBA f32 buffer is larger than the
/// adapter binds.
pub(super) fn check_binding(ctx: &GpuContext, w: usize, h: usize) -> Result<()> {
    let bytes = w * h * 16;
    let limit = ctx.device.limits().max_storage_buffer_binding_size as usize;
    if bytes > limit {
        return Err(Error::Unsupported(format!(
            "a {w}x{h} image needs {bytes} bytes per buffer; this adapter binds at most {limit}"
        )));
    }
    Ok(())
}

/// The image as the shaders read it: RGBA f32, alpha 1.
pub(super) fn rgba(img: &Image) -> Vec<[f32; 4]> {
    (0..img.len())
        .map(|i| {
            [
                img.rgb[0][i] as f32,
                img.rgb[1][i] as f32,
                img.rgb[2][i] as f32,
                1.0,
            ]
        })
        .collect()
}

/// The colour of a read-back RGBA f32 buffer (the inverse of [`rgba`]) as
/// an image of `like`'s size, with its alpha.
pub(super) fn image_from_rgba(data: &[[f32; 4]], like: &Image) -> Image {
    let mut out = Image::new(like.width, like.height);
    out.alpha = like.alpha.clone();
    for (i, px) in data.iter().enumerate() {
        for c in 0..3 {
            out.rgb[c][i] = px[c] as f64;
        }
    }
    out
}

/// A per-pixel plane (depth, strength) in f32, or ones where there is none.
pub(super) fn plane_or_ones(p: Option<&super::Plane>, n: usize) -> Vec<f32> {
    p.map_or_else(
        || vec![1.0; n],
        |p| p.data.iter().map(|&v| v as f32).collect(),
    )
}

/// The WGSL of the pass: sss_pass.wgsl after the definitions it shares with
/// this file and the CPU twin (the noise constants, the workgroup size, the
/// wide product, the uniform block).
fn shader_source() -> String {
    assemble_wgsl(
        &shared_constants(),
        &[WGSL_WIDE_MUL, SCREEN_COMMON_WGSL, Params::WGSL, SHADER],
    )
}

/// The bound resources of one image and setup.
struct Frame {
    /// Two per rank: horizontal, vertical.
    groups: Vec<wgpu::BindGroup>,
    /// The output (starts as the specular image).
    acc: wgpu::Buffer,
    workgroups: (u32, u32),
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_assembled_shader_is_valid_wgsl() {
        crate::gpu::tests::assert_valid_wgsl(&super::shader_source(), "sss_pass");
    }

    /// What is wrong with `shader` (sss_pass.wgsl's text) against the
    /// constants it shares with Rust: a constant not used, declared in the
    /// shader itself, or its value (or the jitter's scale 2^JITTER_BITS)
    /// spelled as a literal.
    fn spelled_shared_constants(shader: &str) -> Vec<String> {
        let code: String = shader
            .lines()
            .map(|l| l.split("//").next().unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\n");
        let tokens: Vec<&str> = code
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.'))
            .filter(|t| !t.is_empty())
            .collect();
        let consts = super::shared_constants();
        let mut values: Vec<u64> = consts.iter().map(|&(_, v)| v as u64).collect();
        values.push(1u64 << super::super::jitter::JITTER_BITS);
        let mut bad = Vec::new();
        for &(name, _) in &consts {
            if !tokens.contains(&name) {
                bad.push(format!("{name} not used"));
            }
            if code.contains(&format!("const {name}")) {
                bad.push(format!("{name} declared in the shader"));
            }
        }
        for t in &tokens {
            let digits = t.trim_end_matches(['u', 'i']).trim_end_matches(".0");
            if values.iter().any(|v| digits == v.to_string()) {
                bad.push(format!("the shared value '{t}' spelled out"));
            }
        }
        bad
    }

    /// sss_pass.wgsl with what it shares with the disk pass (screen_common.wgsl)
    /// names every constant it shares with Rust and spells none of their
    /// values, so a constant changed on one side only cannot
    /// go unnoticed; the check itself catches a value written back in.
    #[test]
    fn the_shader_spells_no_shared_constant() {
        let bodies = [super::SCREEN_COMMON_WGSL, super::SHADER].join("\n");
        assert_eq!(spelled_shared_constants(&bodies), Vec::<String>::new());
        for (from, to) in [
            ("IGN_WHOLE * inner", "52u * inner"),
            ("f32(1u << JITTER_BITS)", "16777216.0"),
            (
                "@workgroup_size(WORKGROUP_SIDE, WORKGROUP_SIDE, 1)",
                "@workgroup_size(8, 8, 1)",
            ),
        ] {
            assert!(bodies.contains(from), "{from}");
            let mutated = bodies.replace(from, to);
            assert!(
                !spelled_shared_constants(&mutated).is_empty(),
                "{to} passed"
            );
        }
    }
}
