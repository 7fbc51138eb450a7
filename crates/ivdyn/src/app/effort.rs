//! Effort given as motor current: which effort of a log the jobs use, and the per-joint
//! torque constants that turn a current into a joint torque, `tau_j = k_t,j i_j`.
//!
//! `k_t` is the torque constant seen at the joint (N m/A): the motor's own torque constant
//! times the gear ratio when the datasheet gives those, `k_t = ratio x k_m`. The
//! conversion is applied once, where a job loads its logs ([`super::io::LogInput::load`]),
//! so identify, payload and diagnose, and their validation and before logs, all see the
//! same torques. It is a plain scale per joint: friction, armature and the offset are
//! still identified from the converted torque as from a measured one.

use std::borrow::Cow;

use crate::error::{Error, Result};
use crate::log::JointLog;

/// Which effort of a log is the joint torque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Effort {
    /// The measured torque when the log has one, else the motor current (converted).
    #[default]
    Auto,
    /// The measured torque (`<joint>.tau`, the measured topic's effort).
    Torque,
    /// The motor current (`<joint>.i`, the current topic), times the torque constants.
    Current,
}

impl Effort {
    /// From its name: `auto`, `torque` or `current`.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "auto" => Ok(Effort::Auto),
            "torque" => Ok(Effort::Torque),
            "current" => Ok(Effort::Current),
            e => Err(Error::option("effort", format!("must be 'auto', 'torque' or 'current', got '{e}'"))),
        }
    }
}

/// A value per joint as a user gives it: one for every joint, one per joint in the
/// chain's order, or `joint = value` pairs naming every joint.
#[derive(Debug, Clone, PartialEq)]
pub enum PerJoint {
    /// The same value for every joint.
    All(f64),
    /// One value per joint, base to tip.
    List(Vec<f64>),
    /// `(joint, value)` for every joint of the chain, in any order.
    Named(Vec<(String, f64)>),
}

impl PerJoint {
    /// Parses the command-line form of `option`: `V` (every joint), `V1,V2,...` (one per
    /// joint, base to tip) or `joint1=V1,joint2=V2,...` (every joint by name).
    pub fn parse(option: &str, text: &str) -> Result<Self> {
        let items: Vec<&str> = text.split(',').map(str::trim).collect();
        let num = |s: &str| {
            s.parse::<f64>().map_err(|_| Error::option(option, format!("'{s}' is not a number (in '{text}')")))
        };
        if items.iter().all(|i| i.contains('=')) {
            let pairs = items.iter().map(|i| {
                let (j, v) = i.split_once('=').expect("checked above");
                Ok((j.trim().to_string(), num(v.trim())?))
            });
            return pairs.collect::<Result<_>>().map(PerJoint::Named);
        }
        if items.iter().any(|i| i.contains('=')) {
            return Err(Error::option(option, format!("mixes values and joint=value pairs in '{text}'; use one form")));
        }
        let values = items.into_iter().map(num).collect::<Result<Vec<f64>>>()?;
        Ok(if let [v] = values[..] { PerJoint::All(v) } else { PerJoint::List(values) })
    }

    /// The value of each joint of `joints` (finite and nonzero); errors name `option` and
    /// the joint.
    pub fn resolve(&self, option: &str, joints: &[String]) -> Result<Vec<f64>> {
        let values = match self {
            PerJoint::All(v) => vec![*v; joints.len()],
            PerJoint::List(v) if v.len() == joints.len() => v.clone(),
            PerJoint::List(v) => {
                return Err(Error::option(
                    option,
                    format!(
                        "has {} values for the {} joints [{}]: give one value, one per joint in this order, or joint=value pairs",
                        v.len(),
                        joints.len(),
                        joints.join(", ")
                    ),
                ));
            }
            PerJoint::Named(pairs) => by_name(option, pairs, joints)?,
        };
        if let Some((j, v)) = joints.iter().zip(&values).find(|(_, v)| !(v.is_finite() && **v != 0.0)) {
            return Err(Error::option(option, format!("for joint '{j}' is {v}; it must be finite and nonzero")));
        }
        Ok(values)
    }
}

/// `pairs` in the order of `joints`: each joint named exactly once, no other name.
fn by_name(option: &str, pairs: &[(String, f64)], joints: &[String]) -> Result<Vec<f64>> {
    let chain = || format!("the chain's joints are [{}]", joints.join(", "));
    for (k, (name, _)) in pairs.iter().enumerate() {
        if !joints.contains(name) {
            return Err(Error::option(option, format!("names joint '{name}', which is not in the chain; {}", chain())));
        }
        if pairs[..k].iter().any(|(n, _)| n == name) {
            return Err(Error::option(option, format!("gives joint '{name}' twice")));
        }
    }
    joints
        .iter()
        .map(|j| {
            let value = pairs.iter().find(|(n, _)| n == j).map(|(_, v)| *v);
            value.ok_or_else(|| Error::option(option, format!("has no value for joint '{j}'; {}", chain())))
        })
        .collect()
}

/// How motor currents become joint torques: the torque constants at the joint, or the
/// gear ratios and the motor torque constants (`k_t = ratio x k_m`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TorqueConstants {
    /// Torque constant at the joint, N m/A.
    pub torque_constant: Option<PerJoint>,
    /// Gear ratio (motor turns per joint turn).
    pub gear_ratio: Option<PerJoint>,
    /// Motor torque constant, N m/A at the motor shaft.
    pub motor_constant: Option<PerJoint>,
}

impl TorqueConstants {
    /// `k_t` per joint of `joints`, `None` when no constant is given. Wrong counts, unknown
    /// or missing joints, and incomplete or clashing options are errors naming them.
    pub fn resolve(&self, joints: &[String]) -> Result<Option<Vec<f64>>> {
        match (&self.torque_constant, &self.gear_ratio, &self.motor_constant) {
            (None, None, None) => Ok(None),
            (Some(kt), None, None) => kt.resolve("torque_constant", joints).map(Some),
            (None, Some(g), Some(km)) => {
                let (g, km) = (g.resolve("gear_ratio", joints)?, km.resolve("motor_constant", joints)?);
                Ok(Some(g.iter().zip(&km).map(|(g, km)| g * km).collect()))
            }
            (Some(_), _, _) => Err(Error::option(
                "torque_constant",
                "and the gear ratios / motor constants are both given: give one of the two",
            )),
            (None, Some(_), None) => {
                Err(Error::option("motor_constant", "is needed with the gear ratios (k_t = ratio x motor constant)"))
            }
            (None, None, Some(_)) => {
                Err(Error::option("gear_ratio", "is needed with the motor constants (k_t = ratio x motor constant)"))
            }
        }
    }
}

/// `log` with the effort `effort` chose as its torque: unchanged when that is the measured
/// torque, else with `tau = k_t i` from its currents. The constants are checked against
/// `joints` whenever given, even when the log's torque is used.
pub fn to_torque<'a>(
    log: Cow<'a, JointLog>,
    effort: Effort,
    constants: &TorqueConstants,
    joints: &[String],
) -> Result<Cow<'a, JointLog>> {
    let k_t = constants.resolve(joints)?;
    let use_current = match effort {
        Effort::Auto => log.tau.is_none() && log.current.is_some(),
        Effort::Torque if log.tau.is_none() && log.current.is_some() => {
            return Err(Error::option("effort", "is 'torque' but the log has no torques, only motor currents"));
        }
        Effort::Torque => false,
        Effort::Current => true,
    };
    if !use_current {
        return Ok(log);
    }
    let Some(current) = log.current.as_ref() else {
        return Err(Error::option(
            "effort",
            "is 'current' but the log has no motor currents (CSV columns <joint>.i, or an MCAP current topic)",
        ));
    };
    let Some(k_t) = k_t else {
        return Err(Error::option(
            "torque_constant",
            "is needed: the log's effort is a motor current (A); give the torque constants (N m/A at the joint), \
             or the gear ratios with the motor constants",
        ));
    };
    let n = k_t.len();
    let tau: Vec<f64> = current.iter().enumerate().map(|(i, c)| k_t[i % n] * c).collect();
    let mut log = log;
    log.to_mut().tau = Some(tau);
    Ok(log)
}

/// `log` with the drive current as its effort (`tau`), for the drive-gain fit, which
/// estimates the torque constants instead of taking them: `auto` takes the motor current
/// when the log has one, else the effort field (a drive that publishes its current there);
/// `current` the current; `torque` the effort field. Returns the log and which signal it is
/// (`"motor current"` or `"effort field"`). Torque constants given are an error.
pub fn current_as_effort<'a>(
    log: Cow<'a, JointLog>,
    effort: Effort,
    constants: &TorqueConstants,
    what: &str,
) -> Result<(Cow<'a, JointLog>, &'static str)> {
    if *constants != TorqueConstants::default() {
        let option = if constants.torque_constant.is_some() { "torque_constant" } else { "gear_ratio/motor_constant" };
        return Err(Error::option(option, "is what the drive-gain fit estimates; leave the torque constants out"));
    }
    let use_current = match effort {
        Effort::Auto => log.current.is_some(),
        Effort::Current if log.current.is_none() => {
            return Err(Error::option(
                "effort",
                format!(
                    "is 'current' but the {what} has no motor currents (CSV columns <joint>.i, or an MCAP current topic)"
                ),
            ));
        }
        Effort::Current => true,
        Effort::Torque => false,
    };
    if use_current {
        let mut log = log;
        let current = log.current.clone();
        log.to_mut().tau = current;
        return Ok((log, "motor current"));
    }
    if log.tau.is_none() {
        return Err(Error::NoCurrent { what: what.into() });
    }
    Ok((log, "effort field"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joints() -> Vec<String> {
        ["a", "b", "c"].iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn parse_the_three_forms() {
        assert_eq!(PerJoint::parse("x", "0.5").unwrap(), PerJoint::All(0.5));
        assert_eq!(PerJoint::parse("x", "1, 2,3").unwrap(), PerJoint::List(vec![1.0, 2.0, 3.0]));
        let named = PerJoint::parse("x", "c=3,a=1, b = 2").unwrap();
        assert_eq!(named.resolve("x", &joints()).unwrap(), vec![1.0, 2.0, 3.0]);
        let e = PerJoint::parse("torque_constant", "a=1,2").unwrap_err().to_string();
        assert!(e.starts_with("torque_constant") && e.contains("one form"), "{e}");
        assert!(PerJoint::parse("x", "1,b").unwrap_err().to_string().contains("'b' is not a number"));
    }

    #[test]
    fn resolve_errors_name_the_option_and_the_joint() {
        let e = |p: PerJoint| p.resolve("torque_constant", &joints()).unwrap_err().to_string();
        let named = |v: &[(&str, f64)]| PerJoint::Named(v.iter().map(|(j, x)| (j.to_string(), *x)).collect());
        assert!(e(PerJoint::List(vec![1.0, 2.0])).contains("2 values for the 3 joints [a, b, c]"));
        assert!(e(named(&[("a", 1.0), ("b", 1.0)])).contains("no value for joint 'c'"));
        assert!(e(named(&[("a", 1.0), ("b", 1.0), ("d", 1.0)])).contains("joint 'd', which is not in the chain"));
        assert!(e(named(&[("a", 1.0), ("a", 1.0), ("b", 1.0)])).contains("joint 'a' twice"));
        assert!(e(PerJoint::List(vec![1.0, 0.0, 1.0])).contains("joint 'b' is 0"));
        assert!(e(PerJoint::All(f64::NAN)).starts_with("torque_constant for joint 'a' is NaN"));
    }

    #[test]
    fn gear_ratio_times_motor_constant() {
        let c = TorqueConstants {
            gear_ratio: Some(PerJoint::List(vec![100.0, 50.0, 10.0])),
            motor_constant: Some(PerJoint::All(0.02)),
            ..Default::default()
        };
        let k = c.resolve(&joints()).unwrap().unwrap();
        assert!((k[0] - 2.0).abs() < 1e-15 && (k[1] - 1.0).abs() < 1e-15 && (k[2] - 0.2).abs() < 1e-15);
        let half = TorqueConstants { gear_ratio: Some(PerJoint::All(100.0)), ..Default::default() };
        assert!(half.resolve(&joints()).unwrap_err().to_string().starts_with("motor_constant is needed"));
        let both = TorqueConstants { torque_constant: Some(PerJoint::All(1.0)), ..c };
        assert!(both.resolve(&joints()).unwrap_err().to_string().contains("both given"));
    }

    fn log(tau: bool, current: bool) -> JointLog {
        JointLog {
            joint_names: joints(),
            t: vec![0.0, 1.0],
            q: vec![0.0; 6],
            tau: tau.then(|| vec![9.0; 6]),
            current: current.then(|| vec![1.0, 2.0, 3.0, -1.0, -2.0, -3.0]),
            ..Default::default()
        }
    }

    #[test]
    fn which_effort_and_the_conversion() {
        let k = TorqueConstants { torque_constant: Some(PerJoint::List(vec![0.5, 2.0, 10.0])), ..Default::default() };
        let none = TorqueConstants::default();
        let run = |l: JointLog, e: Effort, k: &TorqueConstants| {
            to_torque(Cow::Owned(l), e, k, &joints()).map(|l| l.into_owned().tau)
        };
        // auto: torque when there is one, else the current
        assert_eq!(run(log(true, true), Effort::Auto, &k).unwrap(), Some(vec![9.0; 6]));
        let from_i = Some(vec![0.5, 4.0, 30.0, -0.5, -4.0, -30.0]);
        assert_eq!(run(log(false, true), Effort::Auto, &k).unwrap(), from_i);
        assert_eq!(run(log(true, true), Effort::Current, &k).unwrap(), from_i);
        assert_eq!(run(log(false, false), Effort::Auto, &none).unwrap(), None);
        let err = |l, e, k| run(l, e, k).unwrap_err().to_string();
        assert!(err(log(false, true), Effort::Auto, &none).starts_with("torque_constant is needed"));
        assert!(err(log(true, false), Effort::Current, &k).contains("no motor currents"));
        assert!(err(log(false, true), Effort::Torque, &k).contains("only motor currents"));
        // constants are checked even when the torque is used
        let bad = TorqueConstants { torque_constant: Some(PerJoint::List(vec![1.0, 2.0])), ..Default::default() };
        assert!(err(log(true, false), Effort::Auto, &bad).contains("2 values"));
    }
}
