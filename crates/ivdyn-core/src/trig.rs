//! Sine and cosine of joint angles, for one sample (`f64`) or a pack of samples in
//! lock step (see [`Lanes`]).
//!
//! Why not `f64::sin_cos` per lane: it is a library call that cannot be vectorised, and
//! six of them were half the time of a UR5 regressor in the batch kernels. This is the
//! classic fdlibm scheme (Cody-Waite reduction by `pi/2` with a 4-part constant, then
//! the minimax polynomials of fdlibm's `__kernel_sin` / `__kernel_cos` on
//! `[-pi/4, pi/4]`), written with plain arithmetic so it vectorises. Error within about
//! 1 ulp of the result (the kernels are < 1 ulp; the reduction is exact up to one
//! rounding for `|x| <= 1e5`); lanes outside that range, and non-finite lanes, take
//! the library's `sin_cos`. Each lane's result depends only on that lane, and `f64`
//! and the packs run the same code: the batch and single-sample paths agree bit for bit.
//!
//! The coefficients are fdlibm's (Sun Microsystems, 1993: "Permission to use, copy,
//! modify, and distribute this software is freely granted, provided that this notice
//! is preserved.").

#![allow(clippy::excessive_precision)]

use crate::types::Lanes;

// The constants are fdlibm's decimal literals verbatim (they parse to fdlibm's bit
// patterns, e.g. P1 = 0x3FF921FB54400000, S1 = 0xBFC5555555555549, C6 = 0xBDA8FAE9BE8838D4):
// more digits than a double holds, on purpose (hence the allow at the top).

const INV_PIO2: f64 = core::f64::consts::FRAC_2_PI;
// pi/2 = P1 + P2 + P3 + P3T; P1..P3 have 33 significant bits, so n * Pk is exact for
// |n| < 2^20 (fdlibm's pio2_1, pio2_2, pio2_3, pio2_3t)
const P1: f64 = 1.570_796_326_734_125_614_17e0;
const P2: f64 = 6.077_100_506_303_965_976_60e-11;
const P3: f64 = 2.022_266_248_711_166_455_80e-21;
const P3T: f64 = 8.478_427_660_368_899_569_97e-32;
/// Beyond this the reduction above loses accuracy (and `n` bits): library call.
const REDUCE_MAX: f64 = 1.0e5;
/// 1.5 * 2^52: `(y + ROUND) - ROUND` rounds `y` to the nearest integer (ties to even)
/// for `|y| < 2^51`, with two additions instead of a library call.
const ROUND: f64 = 6_755_399_441_055_744.0;

/// Per quadrant `n mod 4`, the factors of the kernels' results: `sin x = ks KS + kc KC`,
/// `cos x = kc KS - ks KC` (`KS = +-1` when the quadrant is even, `KC = +-1` when odd; the
/// other factor is a zero of the same sign, so the sum is the signed kernel exactly).
const KS: [f64; 4] = [1.0, 0.0, -1.0, -0.0];
const KC: [f64; 4] = [0.0, 1.0, -0.0, -1.0];

const S1: f64 = -1.666_666_666_666_663_243_48e-1;
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

const C1: f64 = 4.166_666_666_666_660_190_37e-2;
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
const C5: f64 = 2.087_572_321_298_174_827_90e-9;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// `(sin x, cos x)` of every lane, by the scheme of the module docs. Also used for a
/// single `f64`, so that a sample gets the same bits alone as in a pack.
#[inline(always)]
pub fn sin_cos<T: Lanes>(x: T) -> (T, T) {
    let s = T::splat;
    // x = n pi/2 + r, |r| <= pi/4 (a little more at ties: the kernels are fine there)
    let y = x * s(INV_PIO2) + s(ROUND);
    let n = y - s(ROUND);
    let r = ((x - n * s(P1)) - n * s(P2)) - n * s(P3) - n * s(P3T);
    // fdlibm __kernel_sin(r, 0) and __kernel_cos(r, 0)
    let z = r * r;
    let ks = r + z * r * (s(S1) + z * (s(S2) + z * (s(S3) + z * (s(S4) + z * (s(S5) + z * s(S6))))));
    let poly = z * (s(C1) + z * (s(C2) + z * (s(C3) + z * (s(C4) + z * (s(C5) + z * s(C6))))));
    let hz = s(0.5) * z;
    let w = s(1.0) - hz;
    let kc = w + (((s(1.0) - w) - hz) + z * poly);
    // quadrant n mod 4: odd swaps (sin, cos) -> (cos, -sin), >= 2 negates both; blends
    // by 0 / +-1 factors are exact
    let (mut fs, mut fc) = (x, x);
    for k in 0..T::LANES {
        // y = 1.5 * 2^52 + n has a unit last place, so its low mantissa bits are those of
        // n (two's complement, |n| < 2^51): n mod 4 without a float-to-integer conversion
        // (Rust's saturating `as` adds compares and selects; lanes out of range are
        // replaced below). No branches: the quadrant is random from sample to sample.
        let q = (y.extract(k).to_bits() & 3) as usize;
        fs.replace(k, KS[q]);
        fc.replace(k, KC[q]);
    }
    // the signs folded into the tables: two products fewer than `neg * (ks even + kc odd)`,
    // the same bits (a sign flip and a product by +-1 are exact; the zeros' signs could
    // differ only for ks = 0 with n != 0, and r = 0 needs n = 0: no double lies that close
    // to a nonzero multiple of pi/2)
    let sin = ks * fs + kc * fc;
    let cos = kc * fs - ks * fc;
    if (0..T::LANES).any(|k| !(x.extract(k).abs() <= REDUCE_MAX)) {
        return library_lanes(x, sin, cos);
    }
    (sin, cos)
}

/// The library's `sin_cos` for the lanes of `x` beyond the reduction's range (and
/// non-finite ones). Out of line and cold on purpose: inlined, the compiler evaluated
/// the library call for every angle before the range test and then discarded it
/// (callgrind, paper robot: single-sample RNEA 4425 -> 3539 instructions per call once it
/// moved here, issue 19).
#[cold]
#[inline(never)]
fn library_lanes<T: Lanes>(x: T, mut sin: T, mut cos: T) -> (T, T) {
    // by value, not through `&mut`: the results of the common path stay in registers
    // (through references they were stored to the stack for every angle)
    for k in 0..T::LANES {
        let xk = x.extract(k);
        if !(xk.abs() <= REDUCE_MAX) {
            let (sk, ck) = nalgebra::ComplexField::sin_cos(xk);
            sin.replace(k, sk);
            cos.replace(k, ck);
        }
    }
    (sin, cos)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// Distance in units in the last place of `want` (at least the smallest normal's).
    fn ulps(got: f64, want: f64) -> f64 {
        let ulp = f64::EPSILON * want.abs().max(f64::MIN_POSITIVE);
        (got - want).abs() / ulp
    }

    // The reference is the C library's sin/cos (std, within 1 ulp); ours is within about
    // 1 ulp (module docs): their distance must stay within 2 ulp of the result, plus the
    // reduction's rounding, which is an absolute ~ulp(pi/4) when the result is near 0.
    fn check(x: f64) {
        let (s, c) = sin_cos(x);
        let (se, ce) = (std::primitive::f64::sin(x), std::primitive::f64::cos(x));
        let abs_floor = f64::EPSILON; // ulp of |r| <= pi/4 ~ 2^-52 absolute
        assert!(ulps(s, se) <= 2.0 || (s - se).abs() <= abs_floor, "sin({x:e}) = {s:e}, libm {se:e}");
        assert!(ulps(c, ce) <= 2.0 || (c - ce).abs() <= abs_floor, "cos({x:e}) = {c:e}, libm {ce:e}");
    }

    #[test]
    fn matches_libm_over_joint_ranges_and_beyond() {
        let mut rng = crate::rng::Rng::new(7);
        for _ in 0..200_000 {
            check(rng.uniform(-10.0, 10.0));
        }
        for _ in 0..50_000 {
            check(rng.uniform(-1.0e5, 1.0e5));
        }
        for _ in 0..10_000 {
            check(rng.uniform(-1.0e9, 1.0e9)); // library fallback
        }
        // quadrant boundaries, tiny and signed zero arguments
        for k in -40..=40 {
            let b = k as f64 * core::f64::consts::FRAC_PI_4;
            for d in [0.0, 1e-300, -1e-300, 1e-17, -1e-17, 1e-9, -1e-9] {
                check(b + d);
            }
        }
        check(-0.0);
        check(f64::MIN_POSITIVE);
    }

    #[test]
    fn special_values() {
        let (s, c) = sin_cos(0.0);
        assert_eq!((s, c), (0.0, 1.0));
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
    }

    #[test]
    fn each_lane_as_alone() {
        use simba::simd::AutoF64x4;
        let xs = [0.3, -2.9, 1.0e6, f64::NAN];
        let (s4, c4) = sin_cos(AutoF64x4::from(xs));
        for (k, &x) in xs.iter().enumerate() {
            let (s, c) = sin_cos(x);
            assert_eq!(s4.0[k].to_bits(), s.to_bits());
            assert_eq!(c4.0[k].to_bits(), c.to_bits());
        }
    }
}
