//! The wgpu disk pass: shaders/disk.wgsl runs every frame of a
//! [`DiskSetup`] in one dispatch, adding the mean to the output, which
//! starts as the specular image. f32 throughout; checked against
//! [`super::disk::apply_disk`] (f64) within [`disk_f32_tolerance`].

use super::disk::DiskSetup;
use super::gpu::{
    check_binding, ign_constants, image_from_rgba, plane_or_ones, rgba, GpuPass, SCREEN_COMMON_WGSL,
};
use super::Image;
use crate::error::Result;
use crate::gpu::{assemble_wgsl, wgsl_struct, WGSL_WIDE_MUL};

const SHADER: &str = include_str!("../../shaders/disk.wgsl");

/// Largest difference between the f32 pass and the f64 reference for the
/// same rotation seed, relative to the image's peak, on a `width` x
/// `height` image with `samples` samples: a sample position is the
/// coordinate (below the longer side L) plus an offset, rounded a few
/// times in f32 (4 ulps, 4 L 2^-23 pixel; sin and cos of the rotation err
/// by less than that at radii below L), which moves a bilinear fetch by
/// that fraction of the largest step between neighbouring pixels (at most
/// the peak); summing the samples in f32 adds 4 x 2^-23 of the peak per
/// sample.
pub fn disk_f32_tolerance(width: usize, height: usize, samples: usize) -> f64 {
    let ulp = (2.0f64).powi(-23);
    4.0 * ulp * (width.max(height) + samples) as f64
}

wgsl_struct! {
    /// The uniform block of the disk pass.
    struct DiskParams {
        width: u32,
        height: u32,
        nsamples: u32,
        /// 0: orthographic step, 1: perspective step divided by depth
        /// (Freude 2014, eq. 4.11).
        perspective: u32,
        /// 1: lerp toward the centre colour by depth difference (Freude
        /// 2014, eq. 4.12).
        follow: u32,
        /// The first frame's index (seed), and the frames averaged.
        first_frame: u32,
        frames: u32,
        _pad_u: u32,
        /// Pixels per kernel mm before strength and depth.
        step_base: f32,
        /// k of t = clamp(k |d_centre - d_sample|, 0, 1).
        follow_k: f32,
        _pad0: f32,
        _pad1: f32,
    }
}

/// Side of the square workgroup of disk.wgsl, in pixels.
const WORKGROUP_SIDE: u32 = 8;

/// The disk pass: disk.wgsl, every frame in one dispatch.
pub enum Disk {}

/// A device with the disk pipeline compiled.
pub type DiskGpu = GpuPass<Disk>;

impl DiskGpu {
    /// Opens the adapter (see `GpuContext::open`) and compiles the pass.
    pub fn new() -> Result<DiskGpu> {
        Self::open("disk", &shader_source())
    }

    /// Runs `setup` on `image`: the mean over its frames plus the specular
    /// image.
    pub fn apply(&self, image: &Image, setup: &DiskSetup) -> Result<Image> {
        setup.validate(image)?;
        if setup.accumulate != super::accumulate::Accumulate::Mean {
            return Err(crate::error::Error::Unsupported(format!(
                "the wgpu disk pass accumulates its frames by the plain mean; {} runs on the CPU",
                setup.accumulate.name()
            )));
        }
        let (w, h) = (image.width, image.height);
        let n = w * h;
        check_binding(&self.ctx, w, h)?;
        let v = &setup.view;
        let scalar = |p: Option<&super::Plane>| plane_or_ones(p, n);
        let points: Vec<[f32; 2]> = setup
            .taps
            .iter()
            .map(|t| [t.x_mm as f32, t.y_mm as f32])
            .collect();
        let weights: Vec<[f32; 4]> = setup
            .taps
            .iter()
            .map(|t| {
                [
                    t.weight[0] as f32,
                    t.weight[1] as f32,
                    t.weight[2] as f32,
                    0.0,
                ]
            })
            .collect();
        let start = match &v.specular {
            Some(s) => rgba(s),
            None => vec![[0.0; 4]; n],
        };
        let params = DiskParams {
            width: w as u32,
            height: h as u32,
            nsamples: setup.taps.len() as u32,
            perspective: matches!(v.scale, super::Scale::Perspective { .. }) as u32,
            follow: v.follow_surface.is_some() as u32,
            first_frame: setup.seed,
            frames: setup.frames,
            _pad_u: 0,
            step_base: v.scale.step_base(h) as f32,
            follow_k: v.follow_surface.map_or(0.0, |f| f.rate(&v.scale)) as f32,
            _pad0: 0.0,
            _pad1: 0.0,
        };
        let data: Vec<[f32; 4]> = self.run_once(
            "disk",
            bytemuck::bytes_of(&params),
            &[
                ("image", bytemuck::cast_slice(&rgba(image))),
                ("depth", bytemuck::cast_slice(&scalar(v.depth.as_ref()))),
                (
                    "strength",
                    bytemuck::cast_slice(&scalar(v.strength.as_ref())),
                ),
                ("points", bytemuck::cast_slice(&points)),
                ("weights", bytemuck::cast_slice(&weights)),
            ],
            bytemuck::cast_slice(&start),
            [
                (w as u32).div_ceil(WORKGROUP_SIDE),
                (h as u32).div_ceil(WORKGROUP_SIDE),
                1,
            ],
        )?;
        Ok(image_from_rgba(&data, image))
    }
}

/// The constants disk.wgsl shares with this file and the CPU twin
/// ([`super::jitter`]).
fn shared_constants() -> Vec<(&'static str, u32)> {
    [
        &ign_constants()[..],
        &[
            ("SILVER_U32", super::jitter::SILVER_U32),
            ("WORKGROUP_SIDE", WORKGROUP_SIDE),
        ],
    ]
    .concat()
}

/// disk.wgsl after the definitions it shares with this file and the
/// separable pass (the noise constants, the screen-space bindings).
fn shader_source() -> String {
    assemble_wgsl(
        &shared_constants(),
        &[WGSL_WIDE_MUL, SCREEN_COMMON_WGSL, DiskParams::WGSL, SHADER],
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_assembled_shader_is_valid_wgsl() {
        crate::gpu::tests::assert_valid_wgsl(&super::shader_source(), "disk");
    }
}
