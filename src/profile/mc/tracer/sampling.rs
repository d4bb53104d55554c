//! The random draws of the walk: uniforms, free-path optical depths (a
//! table-driven -ln), Henyey-Greenstein polar cosines, azimuths and
//! isotropic directions (Wang et al. 1995), each from the chunk's
//! Xoshiro256++ stream, and the lookup tables they use.

use super::LayerOptics;
use rand_core::RngCore;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Uniform in [0, 1) with 53 random bits.
#[inline(always)]
pub(crate) fn uniform(rng: &mut Xoshiro256PlusPlus) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// An optical depth -ln(xi), xi uniform in (0, 1] with 53 random bits
/// (Wang et al. 1995), inlined and branch-free (see `neg_ln`).
#[inline(always)]
pub(super) fn optical_depth(rng: &mut Xoshiro256PlusPlus, t: &LogTable) -> f64 {
    let xi = ((rng.next_u64() >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64);
    neg_ln(xi, t)
}

/// (c, 1/c, ln c) for the 256 intervals of m in [1/2, 2) that the last
/// exponent bit and the top 7 mantissa bits pick (width 1/256 below 1,
/// 1/128 above), c at the centre, except c = 1 on both sides of 1 so that
/// r = m - 1 is exact there and -ln x keeps its relative accuracy near 1.
pub(super) struct LogTable([(f64, f64, f64); 256]);

impl LogTable {
    pub(super) fn new() -> LogTable {
        let mut t = [(1.0, 1.0, 0.0); 256];
        for (i, e) in t.iter_mut().enumerate() {
            let j = (i & 127) as f64;
            let c = match i {
                127 | 128 => 1.0,
                0..=126 => 0.5 + (j + 0.5) / 256.0,
                _ => 1.0 + (j + 0.5) / 128.0,
            };
            *e = (c, 1.0 / c, c.ln());
        }
        LogTable(t)
    }
}

/// -ln(x) for normal x in (0, 1]: x = 2^e m with m in [sqrt(1/2),
/// sqrt(2)), ln m = ln c + ln(1 + r) with c from `LogTable`, r = (m - c)/c
/// (m - c exact, |r| < 1/128) and ln(1 + r) summed to r^8 (truncation
/// below 2^-59 relative): as exact as the library log, without its call or
/// a division. The chain from the draw to the step length is what a
/// mispredicted boundary test waits on, so it is kept short: one table
/// load and a depth-4 polynomial.
#[inline(always)]
fn neg_ln(x: f64, t: &LogTable) -> f64 {
    let bits = x.to_bits();
    let mut e = ((bits >> 52) as i64) - 1023;
    let mut mb = (bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000;
    // m in [1, 2); halve it (exponent - 1) where m >= sqrt(2).
    let big = (f64::from_bits(mb) >= std::f64::consts::SQRT_2) as u64;
    mb -= big << 52;
    e += big as i64;
    let m = f64::from_bits(mb);
    let (c, inv_c, ln_c) = t.0[((mb >> 45) & 0xff) as usize];
    let r = (m - c) * inv_c;
    let r2 = r * r;
    // ln(1 + r) = r + r^2 q, q = -1/2 + r/3 - r^2/4 + ... - r^6/8 (Estrin).
    let q = (-0.5 + r * (1.0 / 3.0))
        + r2 * ((-0.25 + r * 0.2) + r2 * ((-1.0 / 6.0 + r * (1.0 / 7.0)) + r2 * -0.125));
    -(e as f64 * std::f64::consts::LN_2 + (ln_c + (r + r2 * q)))
}

/// cos(theta) from the Henyey-Greenstein phase function by inversion
/// (Wang et al. 1995; MCML SpinTheta).
#[inline(always)]
pub(crate) fn sample_hg_cos(l: &LayerOptics, xi: f64) -> f64 {
    if l.inv_2g == 0.0 {
        return 2.0 * xi - 1.0;
    }
    let t = l.one_minus_g2 / (1.0 - l.g + 2.0 * l.g * xi);
    ((l.one_plus_g2 - t * t) * l.inv_2g).clamp(-1.0, 1.0)
}

/// Bits of the azimuth that index `Azimuths`.
const AZ_BITS: u32 = 8;

/// (cos, sin) of 2 pi k / 2^AZ_BITS, k = 0..2^AZ_BITS: built once per chunk
/// (256 library calls for 8192 photons).
pub(super) struct Azimuths([(f64, f64); 1 << AZ_BITS]);

impl Azimuths {
    pub(super) fn new() -> Azimuths {
        let mut t = [(1.0, 0.0); 1 << AZ_BITS];
        for (k, e) in t.iter_mut().enumerate() {
            let (s, c) = (std::f64::consts::TAU * k as f64 / (1 << AZ_BITS) as f64).sin_cos();
            *e = (c, s);
        }
        Azimuths(t)
    }

    /// (cos phi, sin phi) for phi = 2 pi a / 2^32: the table's angle for the
    /// top AZ_BITS bits rotated by the rest, delta < 2 pi / 256, through
    /// Taylor series to delta^6 and delta^7 (truncation < 1e-17). No branch
    /// and no rejection loop, whose mispredicted exit (on 1 - pi/4 = 21% of
    /// draws) cost more than the arithmetic.
    #[inline(always)]
    fn cos_sin(&self, a: u32) -> (f64, f64) {
        const STEP: f64 = std::f64::consts::TAU / 4_294_967_296.0;
        let (c0, s0) = self.0[(a >> (32 - AZ_BITS)) as usize];
        let d = (a & ((1 << (32 - AZ_BITS)) - 1)) as f64 * STEP;
        let d2 = d * d;
        let cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)));
        let sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))));
        (c0 * cd - s0 * sd, s0 * cd + c0 * sd)
    }
}

/// (cos phi, sin phi) for phi uniform in [0, 2 pi), 32 random bits.
#[inline(always)]
pub(super) fn sample_azimuth(rng: &mut Xoshiro256PlusPlus, az: &Azimuths) -> (f64, f64) {
    az.cos_sin(rng.next_u64() as u32)
}

/// A direction uniform on the unit sphere from one 64-bit draw: cos(theta)
/// uniform in (-1, 1) (Archimedes' hat-box theorem) from 32 bits, the
/// azimuth from the other 32; one square root, no rejection.
#[inline(always)]
pub(super) fn sample_sphere(rng: &mut Xoshiro256PlusPlus, az: &Azimuths) -> (f64, f64, f64) {
    const INV32: f64 = 1.0 / 4_294_967_296.0;
    let r = rng.next_u64();
    let uz = 1.0 - 2.0 * ((r >> 32) as f64 + 0.5) * INV32;
    let (cp, sp) = az.cos_sin(r as u32);
    let st = ((1.0 - uz) * (1.0 + uz)).sqrt();
    (st * cp, st * sp, uz)
}

/// Lookup tables of the walk, built once per chunk.
pub(super) struct Tables {
    pub(super) az: Azimuths,
    pub(super) log: LogTable,
}

#[cfg(test)]
mod tests {
    use super::super::HG_ISOTROPIC;
    use super::*;

    fn layer(g: f64) -> LayerOptics {
        LayerOptics {
            z_top: 0.0,
            z_bottom: f64::INFINITY,
            sigma_t: 1.0,
            inv_sigma_t: 1.0,
            albedo: 0.5,
            g,
            one_minus_g2: 1.0 - g * g,
            one_plus_g2: 1.0 + g * g,
            inv_2g: if g.abs() < HG_ISOTROPIC { 0.0 } else { 0.5 / g },
            n: 1.0,
        }
    }

    #[test]
    fn hg_sampling_has_mean_cosine_g() {
        // <cos theta> of Henyey-Greenstein is g; midpoint rule over xi.
        for g in [-0.99, -0.5, 0.0, 0.3, 0.9, 0.99] {
            let l = layer(g);
            let n = 200_000;
            let mean: f64 = (0..n)
                .map(|i| sample_hg_cos(&l, (i as f64 + 0.5) / n as f64))
                .sum::<f64>()
                / n as f64;
            assert!((mean - g).abs() < 2e-3, "g = {g}: mean cos {mean}");
            assert!(sample_hg_cos(&l, 0.0).abs() <= 1.0);
            assert!(sample_hg_cos(&l, 1.0 - 1e-16).abs() <= 1.0);
        }
    }

    #[test]
    fn fast_log_matches_the_library() {
        use rand_core::SeedableRng;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
        let t = LogTable::new();
        let mut worst: f64 = 0.0;
        for k in 0..200_000u64 {
            let x = if k < 1000 {
                // Edges: 1, just below 1, sqrt(1/2), tiny.
                [
                    1.0,
                    1.0 - f64::EPSILON / 2.0,
                    std::f64::consts::FRAC_1_SQRT_2,
                    2f64.powi(-53),
                ][(k % 4) as usize]
            } else {
                ((rng.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (neg_ln(x, &t), -x.ln());
            worst = worst.max((a - b).abs() / b.abs().max(1e-300));
            assert!(
                a >= 0.0 && (a - b).abs() <= 4.0 * f64::EPSILON * b.abs().max(1e-16),
                "{x}: {a} vs {b}"
            );
        }
        assert!(worst < 1e-14, "{worst}");
        assert_eq!(neg_ln(1.0, &t), 0.0);
    }

    #[test]
    fn azimuth_table_matches_the_library() {
        use rand_core::SeedableRng;
        let az = Azimuths::new();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let edges = [0u32, 1, (1 << 24) - 1, 1 << 24, u32::MAX, 1 << 31, 3 << 30];
        for k in 0..100_000usize {
            let a = edges.get(k).copied().unwrap_or(rng.next_u64() as u32);
            let (c, s) = az.cos_sin(a);
            // The reference's angle is itself rounded, by up to half an ulp
            // of 2 pi (4.4e-16): the bound allows that plus a few ulps.
            let (s_ref, c_ref) = (std::f64::consts::TAU * a as f64 / 4_294_967_296.0).sin_cos();
            assert!(
                (c - c_ref).abs() < 1.5e-15 && (s - s_ref).abs() < 1.5e-15,
                "{a}: ({c}, {s}) vs ({c_ref}, {s_ref})"
            );
            assert!((c * c + s * s - 1.0).abs() < 1e-15, "{a}");
        }
    }

    #[test]
    fn azimuth_is_uniform() {
        use rand_core::SeedableRng;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let az = Azimuths::new();
        let n = 200_000;
        let (mut c, mut s, mut c2, mut q1) = (0.0, 0.0, 0.0, 0);
        for _ in 0..n {
            let (cp, sp) = sample_azimuth(&mut rng, &az);
            assert!((cp * cp + sp * sp - 1.0).abs() < 1e-12);
            c += cp;
            s += sp;
            c2 += cp * cp;
            q1 += (cp > 0.0 && sp > 0.0) as usize;
        }
        let nf = n as f64;
        // Means 0, <cos^2> = 1/2, a quarter in each quadrant; 5 sigma bounds.
        assert!((c / nf).abs() < 5.0 * (0.5 / nf).sqrt());
        assert!((s / nf).abs() < 5.0 * (0.5 / nf).sqrt());
        assert!((c2 / nf - 0.5).abs() < 5.0 * (0.125 / nf).sqrt());
        assert!((q1 as f64 / nf - 0.25).abs() < 5.0 * (0.1875 / nf).sqrt());
    }

    #[test]
    fn sphere_directions_are_isotropic() {
        use rand_core::SeedableRng;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let az = Azimuths::new();
        let n = 200_000;
        let (mut mz, mut mz2, mut mx) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let (x, y, z) = sample_sphere(&mut rng, &az);
            assert!((x * x + y * y + z * z - 1.0).abs() < 1e-12);
            mz += z;
            mz2 += z * z;
            mx += x;
        }
        let nf = n as f64;
        // Uniform cos: mean 0, <z^2> = 1/3 (var of z^2 is 4/45); 5 sigma.
        assert!((mz / nf).abs() < 5.0 * (1.0 / 3.0 / nf).sqrt());
        assert!((mx / nf).abs() < 5.0 * (1.0 / 3.0 / nf).sqrt());
        assert!((mz2 / nf - 1.0 / 3.0).abs() < 5.0 * (4.0 / 45.0 / nf).sqrt());
    }
}
