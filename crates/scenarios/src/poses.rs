//! The poses of every mirror mount of a run (a segmented mirror's `seg{k}_mount`, …) as the
//! poses CSV that `python/inchworm_segments` reads (docs/segments.md): `time`, then for
//! each mount `{prefix}piston_m`, `{prefix}tip_rad`, `{prefix}tilt_rad` (its outputs
//! `piston`, `tip`, `tilt`: the same SI values, the same convention), then `parked`: 1
//! where every actuator of every mount is held, else 0.
//!
//! Held is [`Held`], the rule the controller options are compared by (docs/controller-design.md):
//! parked over the sample and the one before it (the step boundaries of any gait), or in
//! analog hold; so the stepping gait, the deadband and analog mode are judged alike. A
//! mount `{prefix}mount`'s actuators are the controllers `{prefix}controller…` recorded
//! with their three DAC outputs; row k ≥ 1 completes sample k with the DAC volts of row
//! k − 1 (what was held during `[t_{k-1}, t_k)`), and row 0 is not held.

use std::io::{self, Write};

use inchworm_cosim::Error;
use inchworm_fmu_models::{ControllerFmu, MountFmu};

use crate::holding::Held;

/// The poses CSV's columns of a mount prefixed `seg3_`: `seg3_piston_m`, … (the units of
/// python/inchworm_segments' format), in the order of [`MountFmu::PISTON`], `TIP`, `TILT`.
pub const POSE_COLUMNS: [&str; 3] = ["piston_m", "tip_rad", "tilt_rad"];
/// The poses CSV's last column.
pub const PARKED: &str = "parked";

/// One actuator: its three DAC columns, the volts of the row before and its held rule.
#[derive(Clone, Debug)]
struct Actuator {
    dac: [usize; 3],
    before: Option<[f64; 3]>,
    held: Held,
}

/// Every mount's pose columns and every actuator, fed row by row.
#[derive(Clone, Debug)]
pub struct Poses {
    /// Each mount's piston, tip and tilt columns, in the run's order.
    mounts: Vec<[usize; 3]>,
    actuators: Vec<Actuator>,
    header: String,
}

impl Poses {
    /// The mounts among `recorded` (the run's recorded names, in row order). Refuses a run
    /// with no mount, a mount without its three pose columns or without a controller
    /// recorded with its three DAC outputs, naming what is missing.
    pub fn new(recorded: &[String]) -> Result<Poses, Error> {
        let column = |name: &str| recorded.iter().position(|n| n == name);
        let pose = [MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT].map(|v| v.name());
        let dacs = ControllerFmu::DAC_OUTPUTS.map(|v| v.name());
        let (mut mounts, mut actuators) = (Vec::new(), Vec::new());
        let mut header = String::from("time");
        let (mount_suffix, dac_suffix) = (format!("mount.{}", pose[0]), format!(".{}", dacs[0]));
        for name in recorded {
            let Some(prefix) = name.strip_suffix(&mount_suffix) else { continue };
            let mut columns = [0; 3];
            for (c, v) in columns.iter_mut().zip(pose) {
                let want = format!("{prefix}mount.{v}");
                *c = column(&want).ok_or_else(|| {
                    Error::Config(format!("--poses: {prefix}mount records no `{want}`"))
                })?;
            }
            let controller = format!("{prefix}controller");
            let mut found = 0;
            for n in recorded {
                let Some(component) =
                    n.strip_suffix(&dac_suffix).filter(|c| c.starts_with(&controller))
                else {
                    continue;
                };
                let mut dac = [0; 3];
                for (c, v) in dac.iter_mut().zip(dacs) {
                    let want = format!("{component}.{v}");
                    *c = column(&want).ok_or_else(|| {
                        Error::Config(format!("--poses: {component} records no `{want}`"))
                    })?;
                }
                actuators.push(Actuator { dac, before: None, held: Held::default() });
                found += 1;
            }
            if found == 0 {
                return Err(Error::Config(format!(
                    "--poses: no controller `{controller}…` recorded with `{}` for {prefix}mount's parked samples",
                    dacs[0]
                )));
            }
            for c in POSE_COLUMNS {
                header.push_str(&format!(",{prefix}{c}"));
            }
            mounts.push(columns);
        }
        if mounts.is_empty() {
            return Err(Error::Config(format!(
                "--poses: no mount recorded: it needs a `…mount.{}`",
                pose[0]
            )));
        }
        header.push_str(&format!(",{PARKED}\n"));
        Ok(Poses { mounts, actuators, header })
    }

    /// The mounts, in the run's order.
    pub fn mounts(&self) -> usize {
        self.mounts.len()
    }

    /// The header line.
    pub fn write_header(&self, w: &mut dyn Write) -> io::Result<()> {
        w.write_all(self.header.as_bytes())
    }

    /// The row at time `t` (t = 0 first): its poses and whether every actuator is held.
    pub fn write_row(&mut self, w: &mut dyn Write, t: f64, row: &[f64]) -> io::Result<()> {
        let mut parked = true;
        for a in &mut self.actuators {
            let before = a.before.replace(a.dac.map(|i| row[i]));
            // Every actuator's rule takes every sample, whatever the others said.
            let held = before.is_some_and(|dac| a.held.next(&dac));
            parked &= held;
        }
        write!(w, "{t}")?;
        for m in &self.mounts {
            for &i in m {
                write!(w, ",{:e}", row[i])?;
            }
        }
        writeln!(w, ",{}", u8::from(parked))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use inchworm_fmu_models::PlantFmu;

    /// The mount's pose outputs, piston, tip and tilt.
    fn pose() -> [&'static str; 3] {
        [MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT].map(|v| v.name())
    }

    #[test]
    fn mounts_and_their_actuators_are_found_and_judged_held() {
        let mut recorded = Vec::new();
        for k in 0..2 {
            for x in ["a", "b"] {
                for v in ControllerFmu::DAC_OUTPUTS.map(|v| v.name()) {
                    recorded.push(format!("seg{k}_controller_{x}.{v}"));
                }
            }
            for v in pose() {
                recorded.push(format!("seg{k}_mount.{v}"));
            }
        }
        let mut p = Poses::new(&recorded).unwrap();
        assert_eq!(p.mounts(), 2);
        let mut out = Vec::new();
        p.write_header(&mut out).unwrap();
        // Actuator seg1_controller_b drives over rows 0-1, then all four are parked: held
        // from row 4 on the DACs alone (parked over the two samples before), but not before
        // row 41: the rule judges no sample of the first 40.
        let mut row = vec![0.0; recorded.len()];
        let tip = format!("seg1_mount.{}", MountFmu::TIP.name());
        let extension = format!("seg1_controller_b.{}", ControllerFmu::DAC_EXTENSION.name());
        for k in 0..45 {
            let t = k as f64 * 0.002;
            let pose = recorded.iter().position(|n| *n == tip).unwrap();
            row[pose] = -1.5e-6;
            let dac = recorded.iter().position(|n| *n == extension).unwrap();
            row[dac] = if k < 2 { 3.0 } else { 0.0 };
            p.write_row(&mut out, t, &row).unwrap();
        }
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "time,seg0_piston_m,seg0_tip_rad,seg0_tilt_rad,seg1_piston_m,seg1_tip_rad,seg1_tilt_rad,parked"
        );
        assert_eq!(lines[1], "0,0e0,0e0,0e0,0e0,-1.5e-6,0e0,0");
        let parked: Vec<&str> = lines[1..].iter().map(|l| l.rsplit(',').next().unwrap()).collect();
        assert!(parked[..41].iter().all(|p| *p == "0"), "{parked:?}");
        assert!(parked[41..].iter().all(|p| *p == "1"), "{parked:?}");
    }

    #[test]
    fn a_run_without_mounts_or_controllers_is_refused() {
        let [piston, tip, tilt] = pose();
        let plant = [format!("plant.{}", PlantFmu::ENCODER_POSITION.name())];
        let e = Poses::new(&plant).unwrap_err().to_string();
        assert!(e.contains("no mount recorded"), "{e}");
        let e = Poses::new(&[format!("m_mount.{piston}"), format!("m_mount.{tip}")])
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("m_mount.{tilt}")), "{e}");
        let mount = pose().map(|v| format!("mount.{v}"));
        let e = Poses::new(&mount).unwrap_err().to_string();
        assert!(e.contains("no controller"), "{e}");
        let mut one_dac = mount.to_vec();
        one_dac.push(format!("controller_a.{}", ControllerFmu::DAC_EARTH.name()));
        let e = Poses::new(&one_dac).unwrap_err().to_string();
        assert!(e.contains(&format!("controller_a.{}", ControllerFmu::DAC_NONEARTH.name())), "{e}");
    }
}
