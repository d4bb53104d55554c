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

    /// Adds `other`'s colour pixel by pixel (a specular image after the
    /// diffuse pass); `None` adds nothing.
    pub fn add(&mut self, other: Option<&Image>) {
        if let Some(o) = other {
            for c in 0..3 {
                self.rgb[c]
                    .iter_mut()
                    .zip(&o.rgb[c])
                    .for_each(|(a, v)| *a += v);
            }
        }
    }

    /// Largest value of each channel (the "peak" relative errors refer to).
    pub fn peak(&self) -> [f64; 3] {
        let mut p = [0.0f64; 3];
        for (c, plane) in self.rgb.iter().enumerate() {
            p[c] = plane.iter().fold(0.0f64, |a, &v| a.max(v.abs()));
        }
        p
    }

    /// Counts NaN/Inf samples, alpha included; returns (count, first (x, y,
    /// channel)), channel 3 being alpha.
    pub fn non_finite(&self) -> (usize, Option<(usize, usize, usize)>) {
        let mut count = 0;
        let mut first = None;
        for i in 0..self.len() {
            let alpha = self.alpha.as_ref().map(|a| a[i]);
            for (c, v) in self.rgb.iter().map(|p| p[i]).chain(alpha).enumerate() {
                if !v.is_finite() {
                    count += 1;
                    first.get_or_insert((i % self.width, i / self.width, c));
                }
            }
        }
        (count, first)
    }

    /// Rejects non-finite samples (colour and alpha), or replaces them by 0
    /// when `sanitize`; returns how many were replaced.
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
                first: format!("pixel ({x}, {y}) channel {}", ["R", "G", "B", "A"][c]),
                fill: 0.0,
            });
        }
        for plane in self.rgb.iter_mut().chain(self.alpha.as_mut()) {
            plane
                .iter_mut()
                .filter(|v| !v.is_finite())
                .for_each(|v| *v = 0.0);
        }
        Ok(count)
    }
}

impl Plane {
    /// The `w` x `h` plane whose value at row-major index `i` is `value(i)`.
    pub fn from_index(w: usize, h: usize, value: impl Fn(usize) -> f64) -> Plane {
        Plane {
            width: w,
            height: h,
            data: (0..w * h).map(value).collect(),
        }
    }

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

    /// [`Plane::check_finite`] for a depth plane: a non-finite depth is
    /// refused or, when `sanitize`, set to the farthest finite depth (the
    /// background a missing sample most likely shows; 1 when none is
    /// finite).
    pub fn check_finite_depth(&mut self, what: &str, sanitize: bool) -> Result<usize> {
        let far = self
            .data
            .iter()
            .filter(|v| v.is_finite())
            .fold(f64::NAN, |a: f64, &b| a.max(b));
        let fill = if far.is_finite() { far } else { 1.0 };
        self.check_finite(what, sanitize, fill)
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
            let names: Vec<&str> = match channel {
                Some(c) => vec![c],
                None => vec!["Z", "Y", "R"],
            };
            let ((width, height), data) = super::exr_plane::read_exr_plane(path, &names)?;
            Ok(Plane {
                width,
                height,
                data,
            })
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

/// Stages named f32 channels of `width` x `height` samples (a scene
/// render's planes) in `group`, committed with the files that belong with
/// them; refuses what ssskit could not read back.
pub fn write_exr_channels(
    group: &mut crate::io::AtomicGroup,
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
    group.add_with(path, |w| {
        exr_image
            .write()
            .to_buffered(w)
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}

fn exr_channels(path: &Path) -> Result<Channels> {
    use exr::image::read::{image::ReadLayers, layers::ReadChannels};
    use exr::prelude::{read, Vec2};
    let unreadable =
        |e: exr::error::Error| Error::format(path, format!("unreadable OpenEXR file: {e}"));
    let buffered = |path: &Path| crate::io::open_seekable_input(path).map(std::io::BufReader::new);
    // The headers state the sizes: refuse them before any pixel is read.
    let meta =
        exr::meta::MetaData::read_from_buffered(buffered(path)?, false).map_err(unreadable)?;
    super::exr_plane::check_exr_headers(&path.display().to_string(), &meta.headers)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(buffered(path)?)
        .map_err(unreadable)?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.x(), layer.size.y());
    crate::limits::check_image_size(&path.display().to_string(), w, h)?;
    let mut out = Vec::new();
    // Channel by channel, each decoded plane dropped once converted: the
    // f64 planes never coexist with all the decoded ones.
    for ch in layer.channel_data.list.into_iter() {
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
    let ((w, h), mut channels) = exr_channels(path)?;
    let names = channel_list(&channels);
    // Planes are moved out, never copied: an image holds each sample once.
    let mut take = |n: &str| {
        channels
            .iter()
            .position(|(name, _)| name == n)
            .map(|i| std::mem::take(&mut channels[i].1))
    };
    let mut rgb: [Vec<f64>; 3] = Default::default();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        rgb[c] = match take(name) {
            Some(v) => v,
            None => {
                return Err(Error::format(
                    path,
                    format!(
                        "missing channel {name}: an RGB image needs R, G and B (channels: {names})"
                    ),
                ))
            }
        };
    }
    // A depth channel that is also a colour channel is the one copy made.
    let colour = |d: &str| ["R", "G", "B"].iter().position(|c| *c == d);
    let depth = match depth_channel {
        Some(d) => match colour(d).map(|c| rgb[c].clone()).or_else(|| take(d)) {
            Some(v) => Some(Plane {
                width: w,
                height: h,
                data: v,
            }),
            None => {
                return Err(Error::format(
                    path,
                    format!("missing depth channel {d} (channels: {names})"),
                ))
            }
        },
        None => None,
    };
    let alpha = take("A");
    let image = Image {
        width: w,
        height: h,
        rgb,
        alpha,
    };
    Ok((image, Extras { depth }))
}

fn read_png(path: &Path) -> Result<Image> {
    let img = crate::io::decode_png(path)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let channels = img.color().channel_count() as usize;
    let has_alpha = img.color().has_alpha();
    let mut out = Image::new(w, h);
    out.alpha = has_alpha.then(|| vec![0.0; w * h]);
    // Straight from the decoder's samples (no RGBA copy of the image).
    if let Some(f) = img.as_flat_samples_u8() {
        fill_from_samples(f.samples, channels, u8::MAX as u16, &mut out);
    } else if let Some(f) = img.as_flat_samples_u16() {
        fill_from_samples(f.samples, channels, u16::MAX, &mut out);
    } else {
        return Err(Error::format(
            path,
            format!("unsupported PNG sample type {:?}", img.color()),
        ));
    }
    Ok(out)
}

/// Decodes interleaved sRGB samples (grey, grey + alpha, RGB or RGBA) of
/// full scale `max` into linear `out` (alpha raw, as stored).
fn fill_from_samples<T: Copy + Into<u16>>(
    samples: &[T],
    channels: usize,
    max: u16,
    out: &mut Image,
) {
    let full = max as f64;
    let lut: Vec<f64> = (0..=max).map(|v| srgb_to_linear(v as f64 / full)).collect();
    let colour = if channels >= 3 { 3 } else { 1 };
    for (i, px) in samples.chunks_exact(channels).enumerate() {
        for c in 0..3 {
            out.rgb[c][i] = lut[px[c.min(colour - 1)].into() as usize];
        }
        if let Some(a) = out.alpha.as_mut() {
            a[i] = px[channels - 1].into() as f64 / full;
        }
    }
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
    use exr::prelude::{ChannelDescription, SampleType, SpecificChannels, Vec2, WritableImage};
    // Samples are converted to f32 block by block as the encoder asks for
    // them: no f32 copy of the image is made (an 8K RGB copy is 398 MB).
    let named = |n: &str| ChannelDescription::named(n, SampleType::F32);
    let channels = (
        named("R"),
        named("G"),
        named("B"),
        image.alpha.as_ref().map(|_| named("A")),
        depth.map(|_| named("Z")),
    );
    let (w, [r, g, b]) = (image.width, &image.rgb);
    let (alpha, z) = (image.alpha.as_deref(), depth.map(|d| d.data.as_slice()));
    let at = |v: Option<&[f64]>, i: usize| v.map_or(0.0, |v| v[i] as f32);
    let pixels = |p: Vec2<usize>| {
        let i = p.y() * w + p.x();
        (
            r[i] as f32,
            g[i] as f32,
            b[i] as f32,
            at(alpha, i),
            at(z, i),
        )
    };
    let exr_image = exr::image::Image::from_channels(
        (image.width, image.height),
        SpecificChannels { channels, pixels },
    );
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
