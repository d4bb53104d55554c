//! The wgpu light-space pass: shaders/light_space.wgsl runs
//! [`super::light_space`]'s estimator, one invocation per pixel and
//! channel, in f32, drawing the same samples as the f64 twin (Philox4x32-10
//! on the same counters, 24-bit uniforms exact in both). Checked against
//! [`super::light_space::light_space_cpu`] within
//! [`light_space_f32_tolerance`] (tests/light_space_gpu.rs, on lavapipe).

use super::gpu::GpuPass;
use super::light_space::{LightSpaceInput, LightSpaceSetup};
use super::Image;
use crate::error::{Error, Result};
use crate::gpu::{assemble_wgsl, wgsl_struct, WGSL_FRESNEL, WGSL_WIDE_MUL};
use crate::profile::mc::gpu::{philox_wgsl_constants, PHILOX_WGSL};
use crate::scene::{LightSource, Measure, V3};

const SHADER: &str = include_str!("../../shaders/light_space.wgsl");

/// Invocations per workgroup (pixels of one channel).
const WORKGROUP: u32 = 64;

/// Largest difference between the f32 pass and the f64 reference for the
/// same samples, relative to the image's peak, at pixels where every
/// sample looks up the same texel on both sides: S_d and the weights are
/// a few dozen f32 operations each (exp, log, sqrt within 2 ulp), and a
/// point light's sample adds a normalisation, a frame and the look-up's
/// perspective division: 128 ulp (2^-23) per sample's value, plus 4 ulp
/// per addition of the mean.
pub fn light_space_f32_tolerance(samples: usize) -> f64 {
    let ulp = (2.0f64).powi(-23);
    128.0 * ulp + 4.0 * ulp * samples as f64
}

/// A sample lands on a different texel in f32 than in f64 where its
/// position lies within the f32 rounding of a texel edge (2^-24 of the
/// coordinate's magnitude, the map's side in texels at most, plus the
/// rounding of the offset r (cos a, sin a)): the share of such samples is
/// that distance over a texel, below 4 x 2^-24 x side per sample. Each
/// moves its pixel by at most its own weight over the samples; the pixels
/// so moved are bounded by this share times the samples per pixel and
/// channel (3 channels), with room: at most this fraction of the pixels
/// may differ beyond [`light_space_f32_tolerance`].
pub fn light_space_texel_flips(map_side: usize, samples: usize) -> f64 {
    4.0 * (2.0f64).powi(-24) * map_side as f64 * samples as f64 * 3.0 * 4.0
}

wgsl_struct! {
    /// The uniform block of the light-space pass.
    struct LsParams {
        width: u32,
        height: u32,
        /// Surface positions per pixel (side^2).
        per: u32,
        /// Samples per pixel, channel and light.
        samples: u32,
        maps: u32,
        seed_lo: u32,
        seed_hi: u32,
        /// 1: the exitance sensor (4 C_phi(1/eta)), 0: radiance (F_t).
        exitance: u32,
    }
}

wgsl_struct! {
    /// One light's map: kind 0 directional (orthographic), 1 point; its
    /// first texel in the texel buffer; centre, forward, u, v as in
    /// `LightMap` (relative to the scene's centre); half; the light's
    /// position (point) relative to the centre.
    struct LsMap {
        kind: u32,
        side: u32,
        offset: u32,
        _pad_u: u32,
        cx: f32,
        cy: f32,
        cz: f32,
        half: f32,
        fx: f32,
        fy: f32,
        fz: f32,
        _p0: f32,
        ux: f32,
        uy: f32,
        uz: f32,
        _p1: f32,
        vx: f32,
        vy: f32,
        vz: f32,
        _p2: f32,
        lx: f32,
        ly: f32,
        lz: f32,
        _p3: f32,
    }
}

wgsl_struct! {
    /// One object's dipole in one channel (`DirectionalDipole`) and the
    /// sampling coefficient sigma of eq. 11.
    struct LsMedium {
        d: f32,
        sigma_tr: f32,
        sigma: f32,
        d_e: f32,
        a: f32,
        c_phi: f32,
        c_e: f32,
        eta: f32,
        sigma_t: f32,
        c_phi_exit: f32,
        _p0: f32,
        _p1: f32,
    }
}

/// The light-space pass: light_space.wgsl, one invocation per pixel and
/// channel.
pub enum LightSpace {}

/// A device with the light-space pipeline compiled.
pub type LightSpaceGpu = GpuPass<LightSpace>;

/// (x, y, z, w) of a point relative to `o`, in f32.
fn rel(p: V3, o: V3, w: f32) -> [f32; 4] {
    let d = p - o;
    [d.x as f32, d.y as f32, d.z as f32, w]
}

fn axis(v: V3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

/// The buffers' contents: maps, texels, surface, media (relative to the
/// scene's centre `o`).
fn upload(input: &LightSpaceInput, o: V3) -> Result<(Vec<LsMap>, Vec<[f32; 4]>)> {
    let mut maps = Vec::new();
    let mut texels = Vec::new();
    for m in &input.maps {
        let offset = u32::try_from(texels.len() / 3).map_err(|_| {
            Error::Unsupported("the light maps hold more texels than a GPU buffer indexes".into())
        })?;
        let (kind, light) = match m.source {
            LightSource::Directional { toward, .. } => (0, toward),
            LightSource::Point { position, .. } => (1, position - o),
        };
        let [cx, cy, cz, _] = rel(m.centre, o, 0.0);
        let [fx, fy, fz, _] = axis(m.forward);
        let [ux, uy, uz, _] = axis(m.u);
        let [vx, vy, vz, _] = axis(m.v);
        let [lx, ly, lz, _] = axis(light);
        maps.push(LsMap {
            kind,
            side: m.side as u32,
            offset,
            _pad_u: 0,
            cx,
            cy,
            cz,
            half: m.half as f32,
            fx,
            fy,
            fz,
            _p0: 0.0,
            ux,
            uy,
            uz,
            _p1: 0.0,
            vx,
            vy,
            vz,
            _p2: 0.0,
            lx,
            ly,
            lz,
            _p3: 0.0,
        });
        for t in 0..m.object.len() {
            texels.push(rel(m.position[t], o, m.object[t] as f32));
            texels.push(axis(m.normal[t]));
            texels.push(std::array::from_fn(|c| {
                if c < 3 {
                    m.transmitted[c][t] as f32
                } else {
                    0.0
                }
            }));
        }
    }
    Ok((maps, texels))
}

impl LightSpaceGpu {
    /// Opens the adapter (see `GpuContext::open`) and compiles the pass.
    pub fn new() -> Result<LightSpaceGpu> {
        Self::open("light space", &shader_source())
    }

    /// The pass on the GPU: the radiance image (f32, returned in f64).
    pub fn apply(&self, input: &LightSpaceInput, setup: &LightSpaceSetup) -> Result<Image> {
        input.check(setup)?;
        let s = &input.surface;
        let (w, h) = (s.width, s.height);
        let n = w * h;
        let o = input.maps.first().map_or(V3::zeros(), |m| m.centre);
        let (maps, texels) = upload(input, o)?;
        let mut surface = Vec::with_capacity(3 * s.object.len());
        for q in 0..s.object.len() {
            surface.push(rel(s.position[q], o, s.object[q] as f32));
            surface.push(axis(s.normal[q]));
            surface.push(axis(s.view[q]));
        }
        let media: Vec<LsMedium> = input
            .dipoles
            .iter()
            .zip(&input.sigma)
            .flat_map(|(ds, sig)| {
                (0..3).map(move |c| {
                    let d = &ds[c];
                    LsMedium {
                        d: d.d as f32,
                        sigma_tr: d.sigma_tr as f32,
                        sigma: sig[c] as f32,
                        d_e: d.d_e as f32,
                        a: d.a as f32,
                        c_phi: d.c_phi as f32,
                        c_e: d.c_e as f32,
                        eta: d.eta as f32,
                        sigma_t: d.sigma_t as f32,
                        c_phi_exit: d.c_phi_exit as f32,
                        _p0: 0.0,
                        _p1: 0.0,
                    }
                })
            })
            .collect();
        let params = LsParams {
            width: w as u32,
            height: h as u32,
            per: (s.side * s.side) as u32,
            samples: setup.samples as u32,
            maps: maps.len() as u32,
            seed_lo: setup.seed as u32,
            seed_hi: (setup.seed >> 32) as u32,
            exitance: (input.measure == Measure::Exitance) as u32,
        };
        let c = &self.ctx;
        let limit = c.device.limits().max_storage_buffer_binding_size as usize;
        for (what, bytes) in [
            ("light maps", texels.len() * 16),
            ("surface", surface.len() * 16),
        ] {
            if bytes > limit {
                return Err(Error::Unsupported(format!(
                    "the {what} take {bytes} bytes; this adapter binds at most {limit}"
                )));
            }
        }
        let zeros = vec![0.0f32; 3 * n];
        let data: Vec<f32> = self.run_once(
            "light space",
            bytemuck::bytes_of(&params),
            &[
                ("maps", bytemuck::cast_slice(&maps)),
                ("texels", bytemuck::cast_slice(&texels)),
                ("surface", bytemuck::cast_slice(&surface)),
                ("media", bytemuck::cast_slice(&media)),
            ],
            bytemuck::cast_slice(&zeros),
            [(n as u32).div_ceil(WORKGROUP), 3, 1],
        )?;
        let mut out = Image::new(w, h);
        for ch in 0..3 {
            for i in 0..n {
                out.rgb[ch][i] = data[ch * n + i] as f64;
            }
        }
        Ok(out)
    }
}

/// The constants light_space.wgsl shares with this file and its twin.
fn shared_constants() -> Vec<(&'static str, u32)> {
    [
        &philox_wgsl_constants()[..],
        &[
            ("UNIFORM_BITS", super::jitter::JITTER_BITS),
            ("WORKGROUP", WORKGROUP),
        ],
    ]
    .concat()
}

/// light_space.wgsl after the definitions it shares with this file and
/// the tracer (the Philox constants, the Fresnel term, the structs).
fn shader_source() -> String {
    assemble_wgsl(
        &shared_constants(),
        &[
            WGSL_WIDE_MUL,
            WGSL_FRESNEL,
            PHILOX_WGSL,
            LsParams::WGSL,
            LsMap::WGSL,
            LsMedium::WGSL,
            SHADER,
        ],
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_assembled_shader_is_valid_wgsl() {
        crate::gpu::tests::assert_valid_wgsl(&super::shader_source(), "light space");
    }

    /// The host's structs have the sizes WGSL gives them (multiples of 16
    /// for the uniform block, scalar-aligned storage elements).
    #[test]
    fn struct_layouts() {
        assert_eq!(std::mem::size_of::<super::LsParams>(), 32);
        assert_eq!(std::mem::size_of::<super::LsMap>(), 96);
        assert_eq!(std::mem::size_of::<super::LsMedium>(), 48);
    }
}
