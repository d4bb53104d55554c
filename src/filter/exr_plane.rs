//! EXR headers checked against the caps, and one channel of an EXR file as
//! a plane (depth, strength) decoded alone: the other channels of the file
//! are never held (reading the depth of an 8K RGB EXR beside the image it
//! belongs to once cost its three f64 planes, 796 MB, and their f32
//! samples).

use crate::error::{Error, Result};
use std::path::Path;

/// The first of `names` that the EXR file's first layer holds, as f64
/// samples (f16, f32 and u32 converted through f32, as for the colour
/// channels) with the layer's size; the file's caps are checked before any
/// pixel is read.
pub fn read_exr_plane(path: &Path, names: &[&str]) -> Result<((usize, usize), Vec<f64>)> {
    use exr::prelude::{read, ReadChannels, ReadLayers, ReadSpecificChannel, Vec2};
    let unreadable =
        |e: exr::error::Error| Error::format(path, format!("unreadable OpenEXR file: {e}"));
    let buffered = |path: &Path| crate::io::open_seekable_input(path).map(std::io::BufReader::new);
    let meta =
        exr::meta::MetaData::read_from_buffered(buffered(path)?, false).map_err(unreadable)?;
    check_exr_headers(&path.display().to_string(), &meta.headers)?;
    let Some(header) = meta.headers.first() else {
        return Err(Error::format(path, "no layer"));
    };
    let (w, h) = (header.layer_size.x(), header.layer_size.y());
    crate::limits::check_image_size(&path.display().to_string(), w, h)?;
    let list = &header.channels.list;
    let found = names
        .iter()
        .find_map(|n| list.iter().find(|c| c.name.to_string() == *n));
    let Some(channel) = found else {
        let all: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
        return Err(Error::format(
            path,
            format!(
                "no channel {} (channels: {})",
                names.join(" or "),
                all.join(", ")
            ),
        ));
    };
    if channel.sampling != Vec2(1, 1) {
        return Err(Error::format(
            path,
            format!("channel {} is subsampled: not supported", channel.name),
        ));
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required(channel.name.clone())
        .collect_pixels(
            |size, _| (size.width(), vec![0.0f64; size.width() * size.height()]),
            |(width, data): &mut (usize, Vec<f64>), at, (v,): (f32,)| {
                data[at.y() * *width + at.x()] = v as f64;
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(buffered(path)?)
        .map_err(unreadable)?;
    let (width, data) = image.layer_data.channel_data.pixels;
    debug_assert_eq!(width, w);
    Ok(((w, h), data))
}

/// Refuses EXR headers whose parts are over the image size cap, or whose
/// samples over all channels and parts exceed
/// [`crate::limits::MAX_EXR_DECODE_BYTES`] (64 channels or 200 parts of an
/// 8K image each pass the per-layer size check). `what` names the file.
pub fn check_exr_headers(what: &str, headers: &[exr::meta::header::Header]) -> Result<()> {
    let max = crate::limits::MAX_EXR_DECODE_BYTES;
    let mut declared: u64 = 0;
    let mut channels = 0usize;
    for header in headers {
        let size = header.layer_size;
        crate::limits::check_image_size(what, size.x(), size.y())?;
        for ch in header.channels.list.iter() {
            let (sx, sy) = (ch.sampling.x().max(1), ch.sampling.y().max(1));
            let samples = (size.x() / sx) as u64 * (size.y() / sy) as u64;
            let bytes = samples.saturating_mul(ch.sample_type.bytes_per_sample() as u64);
            declared = declared.saturating_add(bytes);
            channels += 1;
        }
    }
    if declared > max {
        return Err(Error::invalid(
            what,
            "samples",
            format!(
                "{declared} bytes in {channels} channel(s) of {} part(s)",
                headers.len()
            ),
            format!(
                "at most {max} bytes ({} MiB: RGBA and depth in f32 at the image size cap) over \
                 all channels and parts: keep the channels ssskit reads (R, G, B, A, depth) in \
                 one part",
                max >> 20
            ),
        ));
    }
    Ok(())
}
