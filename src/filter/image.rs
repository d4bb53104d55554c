//! Images in linear light: OpenEXR (half or float, optional depth channel) and
//! PNG (8 or 16 bit, sRGB-encoded: decoded to linear on read, encoded back on
//! write). Filtering must happen in linear light (Jimenez et al. 2015).

use crate::error::{Error, Result};
use std::path::Path;

/// Linear RGB, planar, f64; alpha is carried through untouched.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// `rgb[c][y * width + x]`.
    pub rgb: [Vec<f64>; 3],
    pub alpha: Option<Vec<f64>>,
}

/// One scalar channel (depth, strength mask).
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f64>,
}

/// What an image file held besides colour.
#[derive(Clone, Debug, Default)]
pub struct Extras {
    /// The depth channel when one was asked for and found.
    pub depth: Option<Plane>,
}

impl Image {
    pub fn new(width: usize, height: usize) -> Image {
        let n = width * height;
        Image {
            width,
            height,
            rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            alpha: None,
        }
    }

    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Largest value of each channel (the "peak" relative errors refer to).
    pub fn peak(&self) -> [f64; 3] {
        let mut p = [0.0f64; 3];
        for (c, plane) in self.rgb.iter().enumerate() {
            p[c] = plane.iter().fold(0.0f64, |a, &v| a.max(v.abs()));
        }
        p
    }

    /// Counts NaN/Inf samples; returns (count, first (x, y, channel)).
    pub fn non_finite(&self) -> (usize, Option<(usize, usize, usize)>) {
        let mut count = 0;
        let mut first = None;
        for i in 0..self.len() {
            for c in 0..3 {
                if !self.rgb[c][i].is_finite() {
                    count += 1;
                    first.get_or_insert((i % self.width, i / self.width, c));
                }
            }
        }
        (count, first)
    }

    /// Rejects non-finite samples, or replaces them by 0 when `sanitize`;
    /// returns how many were replaced.
    pub fn check_finite(&mut self, what: &str, sanitize: bool) -> Result<usize> {
        let (count, first) = self.non_finite();
        if count == 0 {
            return Ok(0);
        }
        if !sanitize {
            let (x, y, c) = first.unwrap_or_default();
            return Err(Error::NonFinite {
                what: what.into(),
                count,
                unit: "samples",
                first: format!("pixel ({x}, {y}) channel {}", ["R", "G", "B"][c]),
                fill: 0.0,
            });
        }
        for plane in self.rgb.iter_mut() {
            plane
                .iter_mut()
                .filter(|v| !v.is_finite())
                .for_each(|v| *v = 0.0);
        }
        Ok(count)
    }
}

impl Plane {
    /// Rejects non-finite values, or replaces them by `fill` when `sanitize`.
    pub fn check_finite(&mut self, what: &str, sanitize: bool, fill: f64) -> Result<usize> {
        let bad: Vec<usize> = (0..self.data.len())
            .filter(|&i| !self.data[i].is_finite())
            .collect();
        if bad.is_empty() {
            return Ok(0);
        }
        if !sanitize {
            let i = bad[0];
            return Err(Error::NonFinite {
                what: what.into(),
                count: bad.len(),
                unit: "values",
                first: format!("pixel ({}, {})", i % self.width, i / self.width),
                fill,
            });
        }
        for &i in &bad {
            self.data[i] = fill;
        }
        Ok(bad.len())
    }
}

/// Requires `(w, h)` to equal the colour image's size.
pub fn check_same_size(what: &str, w: usize, h: usize, image: &Image) -> Result<()> {
    if (w, h) != (image.width, image.height) {
        return Err(Error::Unsupported(format!(
            "{what} is {w}x{h} but the input image is {}x{}",
            image.width, image.height
        )));
    }
    Ok(())
}

// sRGB transfer functions (IEC 61966-2-1).
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

pub fn linear_to_srgb(v: f64) -> f64 {
    if v <= 0.0031308 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

enum Kind {
    Exr,
    Png,
}

fn kind_of(path: &Path) -> Result<Kind> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr") => Ok(Kind::Exr),
        Some("png") => Ok(Kind::Png),
        _ => Err(Error::format(
            path,
            "unknown image type: the file name must end in .exr or .png",
        )),
    }
}

/// Reads a colour image; `depth_channel` names an EXR channel to return as
/// depth (e.g. "Z"); it must exist when given.
pub fn read_image(path: &Path, depth_channel: Option<&str>) -> Result<(Image, Extras)> {
    match kind_of(path)? {
        Kind::Exr => read_exr(path, depth_channel),
        Kind::Png => {
            if depth_channel.is_some() {
                return Err(Error::format(
                    path,
                    "a depth channel can only be read from an EXR file",
                ));
            }
            Ok((read_png(path)?, Extras::default()))
        }
    }
}

/// Reads a scalar image (depth, strength): the EXR channel `channel` (default
/// Z, else Y, else R), or a PNG's first channel as a raw value in [0, 1] (no
/// sRGB decoding: these are data, not colours).
pub fn read_plane(path: &Path, channel: Option<&str>) -> Result<Plane> {
    match kind_of(path)? {
        Kind::Exr => {
            let channels = exr_channels(path)?;
            let (w, h) = channels.0;
            let names: Vec<&str> = match channel {
                Some(c) => vec![c],
                None => vec!["Z", "Y", "R"],
            };
            for n in &names {
                if let Some((_, v)) = channels.1.iter().find(|(name, _)| name == n) {
                    return Ok(Plane {
                        width: w,
                        height: h,
                        data: v.clone(),
                    });
                }
            }
            Err(Error::format(
                path,
                format!(
                    "no channel {} (channels: {})",
                    names.join(" or "),
                    channel_list(&channels.1)
                ),
            ))
        }
        Kind::Png => {
            if channel.is_some() {
                return Err(Error::format(
                    path,
                    "channels can only be named in EXR files",
                ));
            }
            let img = crate::io::decode_png(path)?;
            let (w, h) = (img.width() as usize, img.height() as usize);
            let raw = img.to_luma16();
            Ok(Plane {
                width: w,
                height: h,
                data: raw.pixels().map(|p| p.0[0] as f64 / 65535.0).collect(),
            })
        }
    }
}

/// An EXR file's size (width, height) and its channels, by name.
pub type Channels = ((usize, usize), Vec<(String, Vec<f64>)>);

fn channel_list(ch: &[(String, Vec<f64>)]) -> String {
    ch.iter()
        .map(|(n, _)| n.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Every channel of an EXR file's first layer, by name, with its size
/// (checked against the caps before the pixels are read).
pub fn read_exr_channels(path: &Path) -> Result<Channels> {
    exr_channels(path)
}

/// Writes named f32 channels of `width` x `height` samples (a scene
/// render's planes) atomically; refuses what ssskit could not read back.
pub fn write_exr_channels(
    path: &Path,
    width: usize,
    height: usize,
    channels: &[(&str, &[f64])],
) -> Result<()> {
    use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, SmallVec, WritableImage};
    crate::limits::check_image_size(&path.display().to_string(), width, height)?;
    let mut list = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (name, v) in channels {
        if v.len() != width * height {
            return Err(Error::format(
                path,
                format!(
                    "channel {name} has {} samples for {width}x{height} pixels",
                    v.len()
                ),
            ));
        }
        if let Some(i) = v.iter().position(|x| !(x.abs() <= f32::MAX as f64)) {
            return Err(Error::format(
                path,
                format!(
                    "refusing to write sample {} at pixel ({}, {}) channel {name}: not a finite f32",
                    v[i],
                    i % width,
                    i / width
                ),
            ));
        }
        let samples = FlatSamples::F32(v.iter().map(|&x| x as f32).collect());
        list.push(AnyChannel::new(*name, samples));
    }
    let exr_image = exr::image::Image::from_channels((width, height), AnyChannels::sort(list));
    crate::io::write_atomic_with(path, |w| {
        exr_image
            .write()
            .to_buffered(w)
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}

fn exr_channels(path: &Path) -> Result<Channels> {
    use exr::prelude::{read_all_flat_layers_from_file, Vec2};
    if let Err(e) = std::fs::metadata(path) {
        return Err(Error::io(path, e));
    }
    // The header states the size: refuse it before the pixels are read.
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| Error::format(path, format!("unreadable OpenEXR file: {e}")))?;
    for header in &meta.headers {
        let size = header.layer_size;
        crate::limits::check_image_size(&path.display().to_string(), size.x(), size.y())?;
    }
    let image = read_all_flat_layers_from_file(path)
        .map_err(|e| Error::format(path, format!("unreadable OpenEXR file: {e}")))?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| Error::format(path, "OpenEXR file holds no layer"))?;
    let (w, h) = (layer.size.x(), layer.size.y());
    let mut out = Vec::new();
    for ch in layer.channel_data.list.iter() {
        if ch.sampling != Vec2(1, 1) {
            return Err(Error::format(
                path,
                format!("channel {} is subsampled: not supported", ch.name),
            ));
        }
        let n = ch.sample_data.len();
        let v: Vec<f64> = (0..n)
            .map(|i| ch.sample_data.value_by_flat_index(i).to_f32() as f64)
            .collect();
        out.push((ch.name.to_string(), v));
    }
    Ok(((w, h), out))
}

fn read_exr(path: &Path, depth_channel: Option<&str>) -> Result<(Image, Extras)> {
    let ((w, h), channels) = exr_channels(path)?;
    let find = |n: &str| channels.iter().find(|(name, _)| name == n).map(|c| &c.1);
    let mut rgb: [Vec<f64>; 3] = Default::default();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        rgb[c] = match find(name) {
            Some(v) => v.clone(),
            None => {
                return Err(Error::format(
                    path,
                    format!(
                        "missing channel {name}: an RGB image needs R, G and B (channels: {})",
                        channel_list(&channels)
                    ),
                ))
            }
        };
    }
    let depth = match depth_channel {
        Some(d) => match find(d) {
            Some(v) => Some(Plane {
                width: w,
                height: h,
                data: v.clone(),
            }),
            None => {
                return Err(Error::format(
                    path,
                    format!(
                        "missing depth channel {d} (channels: {})",
                        channel_list(&channels)
                    ),
                ))
            }
        },
        None => None,
    };
    let image = Image {
        width: w,
        height: h,
        rgb,
        alpha: find("A").cloned(),
    };
    Ok((image, Extras { depth }))
}

fn read_png(path: &Path) -> Result<Image> {
    let img = crate::io::decode_png(path)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let has_alpha = img.color().has_alpha();
    let sixteen = img.color().bytes_per_pixel() / img.color().channel_count() > 1;
    let mut out = Image::new(w, h);
    let mut alpha = vec![0.0; w * h];
    let (max, rgba): (u16, Vec<[u16; 4]>) = if sixteen {
        (u16::MAX, img.to_rgba16().pixels().map(|p| p.0).collect())
    } else {
        let pixels = img.to_rgba8();
        (255, pixels.pixels().map(|p| p.0.map(u16::from)).collect())
    };
    let full = max as f64;
    let lut: Vec<f64> = (0..=max).map(|v| srgb_to_linear(v as f64 / full)).collect();
    for (i, p) in rgba.iter().enumerate() {
        for c in 0..3 {
            out.rgb[c][i] = lut[p[c] as usize];
        }
        alpha[i] = p[3] as f64 / full;
    }
    if has_alpha {
        out.alpha = Some(alpha);
    }
    Ok(out)
}

/// PNG bit depth on output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PngDepth {
    Eight,
    Sixteen,
}

/// Writes an image: EXR (32-bit float) or PNG (sRGB-encoded, clamped to
/// [0, 1]) by the file name's extension, atomically.
pub fn write_image(path: &Path, image: &Image, png_depth: PngDepth) -> Result<()> {
    let kind = kind_of(path)?;
    check_writable(path, image)?;
    match kind {
        Kind::Exr => write_exr(path, image, None),
        Kind::Png => write_png(path, image, png_depth),
    }
}

/// What ssskit would refuse to read back: a size over the caps, or samples
/// that are NaN, infinite or beyond f32 (an EXR stores f32; a PNG would
/// silently clip them).
fn check_writable(path: &Path, image: &Image) -> Result<()> {
    crate::limits::check_image_size(&path.display().to_string(), image.width, image.height)?;
    let planes = image.rgb.iter().chain(image.alpha.as_ref());
    for (c, plane) in planes.enumerate() {
        if let Some(i) = plane.iter().position(|v| !(v.abs() <= f32::MAX as f64)) {
            return Err(Error::format(
                path,
                format!(
                    "refusing to write sample {} at pixel ({}, {}) channel {}: not a finite \
                     f32; the kernel or the input holds values too large or not numbers",
                    plane[i],
                    i % image.width.max(1),
                    i / image.width.max(1),
                    ["R", "G", "B", "A"][c]
                ),
            ));
        }
    }
    Ok(())
}

/// Writes an EXR with RGB(A) and an optional depth channel `Z`, samples as
/// given (NaN included: tests build hostile inputs with it); outputs go
/// through [`write_image`], which refuses what ssskit could not read back.
pub fn write_exr(path: &Path, image: &Image, depth: Option<&Plane>) -> Result<()> {
    use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, SmallVec, WritableImage};
    let f = |v: &[f64]| FlatSamples::F32(v.iter().map(|&x| x as f32).collect());
    let mut list = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        list.push(AnyChannel::new(*name, f(&image.rgb[c])));
    }
    if let Some(a) = &image.alpha {
        list.push(AnyChannel::new("A", f(a)));
    }
    if let Some(d) = depth {
        list.push(AnyChannel::new("Z", f(&d.data)));
    }
    let exr_image =
        exr::image::Image::from_channels((image.width, image.height), AnyChannels::sort(list));
    crate::io::write_atomic_with(path, |w| {
        exr_image
            .write()
            .to_buffered(w)
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}

fn write_png(path: &Path, image: &Image, depth: PngDepth) -> Result<()> {
    use image::ImageEncoder;
    let (w, h) = (image.width as u32, image.height as u32);
    let channels = if image.alpha.is_some() { 4 } else { 3 };
    let scale = match depth {
        PngDepth::Eight => 255.0,
        PngDepth::Sixteen => 65535.0,
    };
    let mut samples = Vec::with_capacity(image.len() * channels);
    for i in 0..image.len() {
        for c in 0..3 {
            let v = linear_to_srgb(image.rgb[c][i].clamp(0.0, 1.0));
            samples.push((v * scale).round() as u16);
        }
        if let Some(a) = &image.alpha {
            samples.push((a[i].clamp(0.0, 1.0) * scale).round() as u16);
        }
    }
    let color = match (depth, channels) {
        (PngDepth::Eight, 3) => image::ExtendedColorType::Rgb8,
        (PngDepth::Eight, _) => image::ExtendedColorType::Rgba8,
        (PngDepth::Sixteen, 3) => image::ExtendedColorType::Rgb16,
        (PngDepth::Sixteen, _) => image::ExtendedColorType::Rgba16,
    };
    let bytes: Vec<u8> = match depth {
        PngDepth::Eight => samples.iter().map(|&v| v as u8).collect(),
        // The encoder takes 16-bit samples in native byte order.
        PngDepth::Sixteen => samples.iter().flat_map(|v| v.to_ne_bytes()).collect(),
    };
    crate::io::write_atomic_with(path, |wr| {
        image::codecs::png::PngEncoder::new(wr)
            .write_image(&bytes, w, h, color)
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}

/// The bit depth a PNG file was stored with (16 when it holds 16-bit samples).
pub fn png_depth_of(path: &Path) -> Result<PngDepth> {
    let img = crate::io::decode_png(path)?;
    Ok(
        if img.color().bytes_per_pixel() / img.color().channel_count() > 1 {
            PngDepth::Sixteen
        } else {
            PngDepth::Eight
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_every_8_and_16_bit_code() {
        for v in 0..=255u32 {
            let x = v as f64 / 255.0;
            let back = (linear_to_srgb(srgb_to_linear(x)) * 255.0).round() as u32;
            assert_eq!(back, v);
        }
        for v in 0..=65535u32 {
            let x = v as f64 / 65535.0;
            let back = (linear_to_srgb(srgb_to_linear(x)) * 65535.0).round() as u32;
            assert_eq!(back, v);
        }
    }
}
