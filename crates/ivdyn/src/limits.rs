//! Bounds on what an option or a file may ask for, and the checks that enforce them.
//!
//! Every job checks its options against these before any work or allocation they size
//! (issue 16, `docs/reliability.md`): a value out of range is an [`Error::Option`] naming
//! the option, the value and the allowed range, never a NaN result, an abort or a hang.

use crate::error::{Error, Result};

/// Largest magnitude accepted for any logged or simulated value (position, velocity,
/// effort, command, current) in SI units. No arm moves 1e6 rad or m, or 1e6 rad/s, or
/// carries 1e6 N m; such a value is a corrupt sample, and squared in the regressors
/// (1e300 squared is infinite) it stalls the linear algebra downstream instead of failing.
pub const MAX_MAGNITUDE: f64 = 1e6;

/// Most samples a generated trajectory or log may have (`duration * rate`, in `simulate`
/// and `excite`): every array is allocated at this length up front. 10 million is 2.8 h
/// at 1 kHz (`make bench-hour` needs 3.6 million), about 3 GB for a 6-joint arm.
pub const MAX_SAMPLES: f64 = 1e7;

/// Heaviest payload accepted (kg): the heaviest industrial arms carry about 2.3 t.
pub const MAX_PAYLOAD_MASS: f64 = 1e4;

/// Largest payload COM offset from the last link's frame (m, per coordinate): the
/// longest arms reach about 4 m.
pub const MAX_PAYLOAD_COM: f64 = 10.0;

/// Most Fourier harmonics of a generated trajectory (`excite`, `simulate`): the
/// coefficient and basis arrays grow with it; excitation designs use 3 to 10.
pub const MAX_HARMONICS: usize = 100;

/// `x` as a person reads it: `1e300`, not 301 digits; `0.25` as is.
pub fn num(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e6).contains(&a) { format!("{x:e}") } else { format!("{x}") }
}

/// `Err` unless `lo <= x <= hi` (and `x` finite), naming `option` and the range.
pub fn in_range(option: &str, x: f64, lo: f64, hi: f64) -> Result<()> {
    if x.is_finite() && (lo..=hi).contains(&x) {
        return Ok(());
    }
    Err(Error::option(option, format!("must be in [{}, {}], got {}", num(lo), num(hi), num(x))))
}

/// `Err` unless `0 < x <= hi` (and `x` finite), naming `option` and the range.
pub fn positive_up_to(option: &str, x: f64, hi: f64) -> Result<()> {
    if x.is_finite() && x > 0.0 && x <= hi {
        return Ok(());
    }
    Err(Error::option(option, format!("must be > 0 and at most {}, got {}", num(hi), num(x))))
}

/// `Err` unless `lo <= n <= hi`, naming `option` and the range.
pub fn count_in(option: &str, n: usize, lo: usize, hi: usize) -> Result<()> {
    if (lo..=hi).contains(&n) {
        return Ok(());
    }
    Err(Error::option(option, format!("must be in {lo}..={hi}, got {n}")))
}

/// [`in_range`] on every value of a per-joint list (`option[i]`).
pub fn all_in_range(option: &str, xs: &[f64], lo: f64, hi: f64) -> Result<()> {
    xs.iter().enumerate().try_for_each(|(i, &x)| in_range(&format!("{option}[{i}]"), x, lo, hi))
}

/// `duration * rate` samples at most [`MAX_SAMPLES`] (both already checked positive).
pub fn samples_bounded(duration_s: f64, rate_hz: f64) -> Result<()> {
    let samples = duration_s * rate_hz;
    if samples <= MAX_SAMPLES {
        return Ok(());
    }
    Err(Error::option(
        "duration",
        format!(
            "{duration_s} s at {rate_hz} Hz is {samples:.3e} samples; at most {MAX_SAMPLES:.0e} per run (a shorter duration or a lower rate)"
        ),
    ))
}

/// A checked payload: mass (kg), COM `x, y, z` (m), inertia about the COM `Ixx, Ixy, Iyy,
/// Ixz, Iyz, Izz` (kg m^2, ivdyn's order).
pub type PayloadParts = (f64, Option<[f64; 3]>, Option<[f64; 6]>);

/// A payload as a user gives it, checked: mass in (0, [`MAX_PAYLOAD_MASS`]] kg; COM `x, y, z`
/// within [`MAX_PAYLOAD_COM`] m; inertia `Ixx, Ixy, Iyy, Ixz, Iyz, Izz` about the COM
/// physical (positive semi-definite, principal moments obeying the triangle inequalities;
/// zero is a point mass). Errors name the option (`payload_mass`, `payload_com`,
/// `payload_inertia`).
pub fn payload_parts(mass: f64, com: Option<&[f64]>, inertia: Option<&[f64]>) -> Result<PayloadParts> {
    if !(mass.is_finite() && mass > 0.0 && mass <= MAX_PAYLOAD_MASS) {
        return Err(Error::option(
            "payload_mass",
            format!("must be positive and at most {} kg, got {}", num(MAX_PAYLOAD_MASS), num(mass)),
        ));
    }
    let com = match com {
        Some(c) if c.len() != 3 || c.iter().any(|x| !(x.abs() <= MAX_PAYLOAD_COM)) => {
            return Err(Error::option(
                "payload_com",
                format!(
                    "needs 3 finite values x, y, z (m) in the last link's frame, each within +-{MAX_PAYLOAD_COM} m, got {c:?}"
                ),
            ));
        }
        c => c.map(|c| [c[0], c[1], c[2]]),
    };
    let inertia = match inertia {
        Some(i) if i.len() != 6 || i.iter().any(|x| !x.is_finite()) => {
            return Err(Error::option("payload_inertia", "needs 6 finite values (kg m^2) about the COM"));
        }
        // no body within the mass and COM bounds has a moment above m r^2 = 1e6 kg m^2
        Some(i) if i.iter().any(|x| !(x.abs() <= MAX_PAYLOAD_MASS * MAX_PAYLOAD_COM * MAX_PAYLOAD_COM)) => {
            return Err(Error::option(
                "payload_inertia",
                format!(
                    "values must be within +-{} kg m^2, got {i:?}",
                    num(MAX_PAYLOAD_MASS * MAX_PAYLOAD_COM * MAX_PAYLOAD_COM)
                ),
            ));
        }
        Some(i) => Some(physical_inertia([i[0], i[1], i[2], i[3], i[4], i[5]])?),
        None => None,
    };
    Ok((mass, com, inertia))
}

/// `i_c` (about the COM) if its principal moments are >= 0 and obey `I1 + I2 >= I3`
/// (the mass distribution's second moments are non-negative), to rounding.
fn physical_inertia(i_c: [f64; 6]) -> Result<[f64; 6]> {
    let m = ivdyn_core::inertia_matrix(&i_c);
    let mut e: Vec<f64> = m.symmetric_eigenvalues().iter().copied().collect();
    e.sort_by(f64::total_cmp);
    let tol = 1e-12 * e[2].abs().max(f64::MIN_POSITIVE);
    if e[0] < -tol || e[0] + e[1] < e[2] - tol {
        return Err(Error::option(
            "payload_inertia",
            format!(
                "is not a body's inertia about its COM: principal moments {:.4e}, {:.4e}, {:.4e} must be >= 0 with I1 + I2 >= I3",
                e[0], e[1], e[2]
            ),
        ));
    }
    Ok(i_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_reject_nan_and_name_the_option() {
        assert!(in_range("alpha", 0.5, 0.0, 1.0).is_ok());
        for x in [f64::NAN, f64::INFINITY, -0.1, 1.1] {
            let e = in_range("alpha", x, 0.0, 1.0).unwrap_err().to_string();
            assert!(e.contains("alpha") && e.contains("must be in"), "{e}");
        }
        assert!(positive_up_to("rate", 0.0, 1.0).is_err());
        assert!(count_in("starts", 0, 1, 10).is_err() && count_in("starts", 10, 1, 10).is_ok());
        assert!(all_in_range("fc", &[1.0, -1.0], 0.0, 2.0).unwrap_err().to_string().contains("fc[1]"));
        assert!(samples_bounded(1e9, 100.0).is_err() && samples_bounded(20.0, 500.0).is_ok());
    }

    #[test]
    fn payload_parts_are_physical() {
        // inertias in ivdyn's order [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]
        // a 0.1 m solid cube of 1 kg: I = m a^2 / 6 on each axis
        let cube = [1.0 / 600.0, 0.0, 1.0 / 600.0, 0.0, 0.0, 1.0 / 600.0];
        assert!(payload_parts(1.0, Some(&[0.0, 0.0, 0.1]), Some(&cube)).is_ok());
        assert!(payload_parts(1.0, None, Some(&[0.0; 6])).is_ok(), "a point mass");
        // a thin rod along z: I = (m L^2 / 12, same, 0): on the triangle inequality's edge
        assert!(payload_parts(1.0, None, Some(&[1.0 / 12.0, 0.0, 1.0 / 12.0, 0.0, 0.0, 0.0])).is_ok());
        // a negative moment; moments 1, 0.1, 0.1 (0.1 + 0.1 < 1)
        for bad in [[-1.0, 0.0, 1.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.1, 0.0, 0.0, 0.1]] {
            let e = payload_parts(1.0, None, Some(&bad)).unwrap_err().to_string();
            assert!(e.starts_with("payload_inertia is not a body's inertia"), "{e}");
        }
        assert!(payload_parts(1e308, None, None).unwrap_err().to_string().starts_with("payload_mass"));
        assert!(payload_parts(1.0, Some(&[1e300, 0.0, 0.0]), None).unwrap_err().to_string().starts_with("payload_com"));
    }
}
