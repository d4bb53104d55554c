//! The disk kernels as every job builds them (`kernel::disk`): the
//! samples per pixel tried, the frames a temporal filter accumulates, the
//! rotation seed, and the kernel fitted to a profile where the exact
//! reference is cut ([`crate::filter::exact::reference_kernel`], the
//! radius holding [`DEFAULT_HOLD`] of every channel; radii from the
//! widest channel, the default of `fit --model disk`). The advice's
//! scoring of them is [`super::advise::disk`].

use crate::error::{Error, Result};
use crate::filter::disk_error::truncated;
use crate::kernel::disk::{Accumulation, DiskKernelFile, RadiusPdf};
use crate::kernel::disk_fit::fit_disk;
use crate::profile::radius::DEFAULT_HOLD;
use crate::profile::Profile;

/// Frames a temporal filter accumulates by default: 8, the history over
/// which a typical temporal anti-aliasing pass has converged to within a
/// few percent of its limit.
pub const DEFAULT_FRAMES: u32 = 8;

/// Samples per pixel of the disk kernels advise tries: powers of two from
/// the fewest a disk kernel may have to 64, the most Unreal 5's Burley
/// pass takes per pixel (more costs more than the 2 x 33 of the widest
/// separable table).
pub const DISK_SAMPLES: [usize; 5] = [4, 8, 16, 32, 64];

/// Most frames advise accepts: a temporal filter's history is a few dozen
/// frames, and each signal costs [`WINDOWS`] x K disk passes to measure.
pub const MAX_FRAMES: u32 = 64;

/// Windows of K frames the noise after K frames is measured over (batch
/// means): the spread of 4 window means per pixel, averaged over the
/// 16384 pixels of a 128-pixel signal; the bias is the mean of the 4 K
/// frames.
pub const WINDOWS: u32 = 4;

/// The first frame's rotation seed.
pub const DISK_SEED: u32 = 0;

/// The label and model name of a disk row.
pub const DISK: &str = "disk";

/// The disk kernel advise scores with `samples` per pixel.
pub fn disk_kernel(profile: &Profile, samples: usize) -> Result<DiskKernelFile> {
    let radius = (0..profile.channels.len())
        .map(|c| crate::profile::radius_holding(profile, c, DEFAULT_HOLD))
        .fold(0.0, f64::max);
    fit_disk(&truncated(profile, radius), samples, RadiusPdf::Widest)
}

/// A fingerprint of a disk kernel's samples (SHA-256 of their JSON, whose
/// numbers read back to the same bits): the advice carries the chosen
/// row's, so the written file can be checked to be the one scored.
pub fn disk_fingerprint(k: &DiskKernelFile) -> String {
    use sha2::{Digest, Sha256};
    let json = serde_json::to_vec(&k.samples).unwrap_or_default();
    Sha256::digest(json)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// `kernel` recording the frames advise scores it after, the plain mean
/// of `frames` frames from [`DISK_SEED`] under a static camera: what
/// `apply` then runs by default.
pub fn with_frames(mut kernel: DiskKernelFile, frames: u32) -> DiskKernelFile {
    kernel.accumulation = Some(Accumulation::static_mean(frames, DISK_SEED));
    kernel
}

/// (first frame's seed, frames) that `kernel` records, as
/// `screen_space_disk_pass` and `DiskSetup` take them.
pub fn first_and_frames(kernel: &DiskKernelFile) -> (u32, u32) {
    let (frames, first) = kernel.frames_to_run(None, None);
    (first, frames)
}

/// Checks the frames to accumulate.
pub fn check_frames(frames: u32) -> Result<()> {
    if (1..=MAX_FRAMES).contains(&frames) {
        return Ok(());
    }
    Err(Error::invalid(
        "advise",
        "frames",
        frames,
        format!("must be in 1..={MAX_FRAMES}"),
    ))
}
