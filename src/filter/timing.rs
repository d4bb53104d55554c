//! GPU time of the post-process per frame, as an engine runs it: a
//! 1080p irradiance image, one kernel's tap table, perspective scale from a
//! depth image and the depth-aware lerp (Freude 2014, eqs. 4.11 and 4.12). Measured
//! with GPU timestamps around the frame's compute pass (no upload or
//! readback); a software rasteriser's numbers are not GPU timings and are
//! not reported.

use super::gpu::Gpu;
use super::signals::{generate, Signal};
use super::{taps_for, FollowSurface, Plane, Scale, Setup, Which};
use crate::error::Result;
use crate::kernel::KernelFile;

/// The frame measured: vertical field of view, scene in metres, Jimenez's
/// follow-surface constant.
pub const FOV_Y_DEG: f64 = 45.0;
pub const SSS_WIDTH: f64 = 0.001;
pub const FOLLOW_SURFACE: f64 = 300.0;

/// The frame's default size (1080p) and frames timed by default.
pub const DEFAULT_FRAME: (usize, usize) = (1920, 1080);
pub const DEFAULT_FRAMES: u32 = 200;

pub struct Timing {
    /// "name (backend, device type, driver)".
    pub adapter: String,
    /// Lavapipe, llvmpipe, WARP: the times are CPU emulation, not a GPU's.
    pub software: bool,
    /// Taps per pass and separable terms of the kernel run.
    pub taps: usize,
    pub rank: usize,
    /// Milliseconds per frame, in the order run (after one warm-up frame).
    pub frames_ms: Vec<f64>,
}

/// A face-sized disc at 0.5 m in front of a wall at 2 m: depth
/// discontinuities for the lerp, a projected kernel of a few pixels to a
/// few dozen, as in a close-up.
pub fn scene_depth(width: usize, height: usize) -> Plane {
    let mut data = vec![2.0; width * height];
    let (cx, cy, r) = (0.5 * width as f64, 0.5 * height as f64, 0.4 * height as f64);
    for y in 0..height {
        for x in 0..width {
            let (dx, dy) = (x as f64 - cx, y as f64 - cy);
            let q = (dx * dx + dy * dy) / (r * r);
            if q < 1.0 {
                data[y * width + x] = 0.5 + 0.1 * q;
            }
        }
    }
    Plane {
        width,
        height,
        data,
    }
}

/// Times `frames` frames of `kernel`'s tap table on a `width` x `height`
/// image on `gpu`.
pub fn time_post_process(
    gpu: &Gpu,
    kernel: &KernelFile,
    width: usize,
    height: usize,
    frames: u32,
) -> Result<Timing> {
    let image = generate(Signal::Shapes, width, height, 16)?;
    let setup = Setup {
        passes: taps_for(kernel, Which::stored(kernel), None)?,
        scale: Scale::Perspective {
            fov_y_deg: FOV_Y_DEG,
            sss_width: SSS_WIDTH,
        },
        depth: Some(scene_depth(width, height)),
        strength: None,
        follow_surface: Some(FollowSurface::InMetres(FOLLOW_SURFACE)),
        specular: None,
        jitter: false,
    };
    let frames_ms = gpu.time_frames(&image, &setup, frames)?;
    Ok(Timing {
        adapter: gpu.describe(),
        software: gpu.is_software(),
        taps: kernel.taps.count,
        rank: kernel.taps.passes.len(),
        frames_ms,
    })
}
