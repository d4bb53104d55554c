//! Caps on work and memory, derived from the inputs and checked before any
//! allocation they guard, so that no input can make ssskit eat a shared
//! machine. Each error names the limit, the value that broke it and what to
//! change. The caps in one place:
//!
//! - worker threads: [`THREADS_PER_CORE`] x the available cores;
//! - images: at most [`MAX_IMAGE_PIXELS`] pixels and [`MAX_IMAGE_SIDE`] per
//!   side, on read and on write (so ssskit reads back every image it writes);
//! - 1D kernels applied as fixed pixel kernels: at most
//!   [`max_kernel_pixels`] wide for the image, and at most
//!   [`MAX_FILTER_WORK`] multiply-adds per filtering;
//! - the exact 2D reference convolution: at most [`MAX_FFT_CELLS`] cells in
//!   its padded FFT grid;
//! - files whose headers state counts (.mci runs, layers, bins): the counts
//!   must fit in the file's length (see `profile::mc::mci`);
//! - input files: at most [`MAX_MATERIAL_BYTES`] (material TOML),
//!   [`MAX_MCI_BYTES`] (.mci) and [`MAX_JSON_BYTES`] (profiles, kernels,
//!   shards) are read, counted while reading (a device or a pipe has no
//!   length to check first);
//! - EXR files: at most [`MAX_EXR_DECODE_BYTES`] of samples declared over
//!   all channels and parts, checked on the headers before any pixel;
//! - radial grids: at most [`MAX_RADIAL_BINS`] bins; a Monte Carlo run's
//!   tallies at most [`MAX_TALLY_BYTES`] (fewer worker threads where needed:
//!   results never depend on their number);
//! - the light-space directional method: light maps of at most
//!   [`MAX_LIGHT_MAP_SIDE`] texels per side, at most
//!   [`MAX_LIGHT_SPACE_SAMPLES`] samples per pixel and channel, and at most
//!   [`MAX_LIGHT_SPACE_WORK`] dipole evaluations per pass
//!   ([`check_light_space`]).

use crate::error::{Error, Result};

/// Worker threads allowed per available core: more only adds scheduling
/// overhead (results never depend on the thread count).
pub const THREADS_PER_CORE: usize = 4;

/// Cores this process may run on (1 when the system does not say).
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Most worker threads a caller may ask for.
pub fn max_threads() -> usize {
    THREADS_PER_CORE * available_cores()
}

/// Refuses a thread count of 0 or above [`max_threads`]; `context` names the
/// parameter.
pub fn check_threads(context: &str, n: usize) -> Result<()> {
    check_thread_count(context, "threads", &n.to_string(), n)
}

fn check_thread_count(context: &str, field: &str, value: &str, n: usize) -> Result<()> {
    let max = max_threads();
    if n == 0 || n > max {
        return Err(Error::invalid(
            context,
            field,
            value,
            format!(
                "must be between 1 and {max} ({THREADS_PER_CORE} per available core, {} \
                 cores); results are the same for any thread count",
                available_cores()
            ),
        ));
    }
    Ok(())
}

/// The environment variable rayon reads for its default thread count.
pub const THREADS_VARIABLE: &str = "RAYON_NUM_THREADS";

/// The thread count the environment asks for ([`THREADS_VARIABLE`]), None
/// when unset, empty or 0 (rayon's "default"); refused when it is not a
/// count or above [`max_threads`]: the variable obeys the same cap as a
/// thread count given any other way.
pub fn threads_from_env() -> Result<Option<usize>> {
    let Some(raw) = std::env::var_os(THREADS_VARIABLE) else {
        return Ok(None);
    };
    let text = raw.to_string_lossy();
    let t = text.trim();
    if t.is_empty() || t == "0" {
        return Ok(None);
    }
    let n: usize = t.parse().map_err(|_| {
        Error::invalid(
            "environment",
            THREADS_VARIABLE,
            format!("'{text}'"),
            format!(
                "expected a whole number of threads between 1 and {}",
                max_threads()
            ),
        )
    })?;
    check_thread_count("environment", THREADS_VARIABLE, t, n)?;
    Ok(Some(n))
}

/// Worker threads for a pool: `requested` (checked by [`check_threads`]),
/// else the environment's ([`threads_from_env`]), else one per available
/// core.
pub fn worker_threads(requested: Option<usize>) -> Result<usize> {
    match requested {
        Some(n) => check_threads("worker threads", n).map(|()| n),
        None => Ok(threads_from_env()?.unwrap_or_else(available_cores)),
    }
}

/// A pool of `threads` worker threads; a pool that cannot start (a process
/// or memory limit) is an error naming the count, never a panic later.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| pool_error(threads, e))
}

fn pool_error(threads: usize, e: rayon::ThreadPoolBuildError) -> Error {
    Error::Unsupported(format!(
        "cannot start {threads} worker thread(s): {e} (a limit on processes, threads or memory; \
         lower {THREADS_VARIABLE} or --threads, or raise the limit)"
    ))
}

/// Starts rayon's global pool, which every parallel loop outside an
/// explicit pool uses, with [`worker_threads`]`(None)` threads: the
/// environment cannot ask for more than the cap, and a pool that cannot
/// start is an error here rather than a panic inside the first parallel
/// loop. For binaries, before any work; returns the thread count.
pub fn start_global_pool() -> Result<usize> {
    let n = worker_threads(None)?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| pool_error(n, e))?;
    Ok(n)
}

/// Largest image, in pixels: 2^25, room for an 8K UHD frame (7680 x 4320).
/// An image in memory takes 32 bytes per pixel (f64 RGB and alpha), 1 GiB
/// at this size, and a 16-bit RGBA PNG of it decodes within the decoder's
/// allocation limit ([`PNG_DECODE_BYTES`]).
pub const MAX_IMAGE_PIXELS: usize = 1 << 25;
/// Longest image side.
pub const MAX_IMAGE_SIDE: usize = 16384;
/// The PNG decoder's allocation limit: a 16-bit RGBA image of
/// [`MAX_IMAGE_PIXELS`] pixels (8 bytes each) fits exactly.
pub const PNG_DECODE_BYTES: u64 = 8 * MAX_IMAGE_PIXELS as u64;

/// Refuses an image size outside 1..=[`MAX_IMAGE_SIDE`] per side or above
/// [`MAX_IMAGE_PIXELS`]; `what` names the image (file or parameter).
pub fn check_image_size(what: &str, width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::invalid(
            what,
            "size",
            format!("{width}x{height}"),
            "an image needs at least one pixel",
        ));
    }
    let pixels = width.saturating_mul(height);
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE || pixels > MAX_IMAGE_PIXELS {
        return Err(Error::invalid(
            what,
            "size",
            format!("{width}x{height}"),
            format!(
                "images are limited to {MAX_IMAGE_SIDE} pixels per side and {MAX_IMAGE_PIXELS} \
                 pixels in all (e.g. 7680x4320; 1 GiB in memory): use a smaller image"
            ),
        ));
    }
    Ok(())
}

/// Widest 1D pixel kernel applied to a `width` x `height` image: four times
/// the longer side (with clamp-to-edge borders, taps further out all read the
/// border pixel), and never less than 4096.
pub fn max_kernel_pixels(width: usize, height: usize) -> usize {
    (4 * width.max(height)).max(4096)
}

/// Most multiply-adds one filtering may take (pixels x taps x channels x
/// passes): about a minute of CPU time on two cores.
pub const MAX_FILTER_WORK: f64 = 1e12;

/// Most cells of the padded FFT grid of an exact 2D convolution: 2^26,
/// three complex f64 buffers of it are 3 GiB.
pub const MAX_FFT_CELLS: usize = 1 << 26;

/// Most bytes read from a material TOML file (a few lines; the TOML parser
/// needs several times the text in memory).
pub const MAX_MATERIAL_BYTES: u64 = 1 << 20;
/// Most bytes read from an MCML .mci file (a few lines per run).
pub const MAX_MCI_BYTES: u64 = 16 << 20;
/// Most bytes read from a JSON file (profile, kernel, shard, report): a
/// shard of [`MAX_RADIAL_BINS`] bins in three channels, its exact sums as
/// hexadecimal text, is about 400 MB.
pub const MAX_JSON_BYTES: u64 = 512 << 20;

/// Most bytes of samples an EXR file may declare over all its channels
/// and parts: RGBA and a depth channel in f32 at [`MAX_IMAGE_PIXELS`]
/// (640 MiB). The decoder holds them while they are converted to f64.
pub const MAX_EXR_DECODE_BYTES: u64 = 5 * 4 * MAX_IMAGE_PIXELS as u64;

/// Most bins of a radial grid (tallies, profiles): 10^6 bins per channel
/// make a 150 MB profile and, in a Monte Carlo run, 200 MB of exact sums
/// per channel.
pub const MAX_RADIAL_BINS: usize = 1_000_000;

/// Most memory of a Monte Carlo run's tallies (exact sums per channel and
/// per-thread scratch); see `profile::mc`.
pub const MAX_TALLY_BYTES: u64 = 1 << 30;

/// Longest side of a light map (the light-space G-buffer of the
/// directional method): 4096, 2^24 texels of 80 bytes (position, normal,
/// transmitted irradiance in f64, the object) is 1.3 GiB. Dal Corso et al.
/// 2017 (section 5) use 512 and find 1024 enough in hard cases.
pub const MAX_LIGHT_MAP_SIDE: usize = 4096;
/// Most samples per pixel and channel of the light-space method.
pub const MAX_LIGHT_SPACE_SAMPLES: usize = 1 << 16;
/// Most directional-dipole evaluations of one light-space pass (positions
/// x samples x channels x lights): about the multiply-adds of
/// [`MAX_FILTER_WORK`] at a hundred per evaluation.
pub const MAX_LIGHT_SPACE_WORK: f64 = 1e10;

/// Refuses a light map side of 0 or above [`MAX_LIGHT_MAP_SIDE`], 0 samples
/// or more than [`MAX_LIGHT_SPACE_SAMPLES`], and a pass of more than
/// [`MAX_LIGHT_SPACE_WORK`] evaluations over `positions` surface positions
/// and `lights` lights, before anything is allocated; `context` names the
/// caller.
pub fn check_light_space(
    context: &str,
    side: usize,
    samples: usize,
    positions: usize,
    lights: usize,
) -> Result<()> {
    for (field, v, max, unit) in [
        (
            "light_map_side",
            side,
            MAX_LIGHT_MAP_SIDE,
            format!(
                "texels per side ({LIGHT_MAP_TEXEL_BYTES} bytes per texel; Dal Corso et al. 2017 \
                 use 512 to 1024)"
            ),
        ),
        (
            "samples",
            samples,
            MAX_LIGHT_SPACE_SAMPLES,
            "samples per pixel and channel (the estimator of scattered radiosity needs at \
             least one)"
                .to_string(),
        ),
    ] {
        if v == 0 || v > max {
            return Err(Error::invalid(
                context,
                field,
                v,
                format!("must be in 1..={max} {unit}"),
            ));
        }
    }
    let work = positions as f64 * samples as f64 * 3.0 * lights as f64;
    if work > MAX_LIGHT_SPACE_WORK {
        return Err(Error::invalid(
            context,
            "samples",
            samples,
            format!(
                "{positions} surface positions x {samples} samples x 3 channels x {lights} \
                 light(s) = {work:.3e} dipole evaluations, above the cap of \
                 {MAX_LIGHT_SPACE_WORK:e}: fewer samples or positions"
            ),
        ));
    }
    Ok(())
}

/// Bytes of one light-map texel: position, normal and transmitted
/// irradiance (f64) and the object index.
pub const LIGHT_MAP_TEXEL_BYTES: usize = 9 * 8 + 8;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_space_caps_refuse_zero_and_too_much() {
        assert!(check_light_space("m", 512, 32, 1 << 16, 1).is_ok());
        let e = |r: Result<()>| r.unwrap_err().to_string();
        assert!(e(check_light_space("m", 0, 32, 1, 1)).contains("light_map_side"));
        assert!(e(check_light_space("m", MAX_LIGHT_MAP_SIDE + 1, 32, 1, 1)).contains("1..="));
        assert!(e(check_light_space("m", 512, 0, 1, 1)).contains("at least one"));
        assert!(e(check_light_space("m", 512, 1 << 16, 1 << 30, 1)).contains("cap"));
    }

    #[test]
    fn thread_cap_scales_with_cores() {
        assert!(check_threads("t", 1).is_ok());
        assert!(check_threads("t", max_threads()).is_ok());
        let e = check_threads("t", max_threads() + 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("per available core"), "{e}");
        assert!(check_threads("t", 0).is_err());
    }

    #[test]
    fn environment_thread_count_obeys_the_cap() {
        // The variable is read by this test only (tests in this binary run
        // in threads of one process: set and restored under a lock).
        static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _g = LOCK.lock().unwrap_or_else(|e| e.into_inner());
        let old = std::env::var_os(THREADS_VARIABLE);
        let with = |v: &str| {
            std::env::set_var(THREADS_VARIABLE, v);
            threads_from_env()
        };
        assert_eq!(with("1").unwrap(), Some(1));
        assert_eq!(with(" 0 ").unwrap(), None);
        assert_eq!(with("").unwrap(), None);
        let over = (max_threads() + 1).to_string();
        for bad in [over.as_str(), "5000", "-1", "two", "1e3"] {
            let e = with(bad).unwrap_err().to_string();
            assert!(
                e.contains(THREADS_VARIABLE) && e.contains(bad) && e.contains("between 1 and"),
                "{bad}: {e}"
            );
        }
        assert_eq!(worker_threads(Some(1)).unwrap(), 1);
        match old {
            Some(v) => std::env::set_var(THREADS_VARIABLE, v),
            None => std::env::remove_var(THREADS_VARIABLE),
        }
    }

    #[test]
    fn image_cap_admits_8k_and_refuses_more() {
        assert!(check_image_size("i", 7680, 4320).is_ok());
        assert!(check_image_size("i", 16384, 2048).is_ok());
        assert!(check_image_size("i", 16384, 16384).is_err());
        assert!(check_image_size("i", 16385, 1).is_err());
        assert!(check_image_size("i", 0, 5).is_err());
        assert!(check_image_size("i", usize::MAX, usize::MAX).is_err());
    }
}
