//! The console's guided probing, on the board's own G38.2 (docs/probing.md): a workflow is a few
//! small jobs (MDI blocks through a session, as `gantry mdi` sends them); between them the exact
//! latched contact (`Status::probe`, machine nm, to the step) is read, and at the end the active
//! work system's offset is set with `G10 L2` so that the work coordinates read what the workflow
//! promises. The page shows the plan ([`Probe::plan`]) and asks before anything moves.
//!
//! - **Z touch plate**: probe down (relative) until the tool touches a plate of thickness T lying
//!   on the work; work Z is then T at the contact (Z0 = the work's top); back up by the retract.
//! - **XY outside corner** (front-left, X+ and Y+ faces): the tool starts above the part, a few
//!   mm inside the corner; it goes out by the clearance, down by the depth, probes X+ towards the
//!   left face, comes up, goes round and probes Y+ towards the front face; work X0 Y0 is then the
//!   corner (the tool's radius added to each contact), and the tool ends above where it started.

use super::args::{num_in, text};
use crate::session::Session;
use gantry_proto::Status;
use serde_json::Value;

/// One workflow, with its validated numbers (mm, mm/min).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Probe {
    Z {
        thickness: f64,
        distance: f64,
        feed: f64,
        retract: f64,
    },
    Corner {
        clearance: f64,
        depth: f64,
        diameter: f64,
        feed: f64,
        retract: f64,
    },
}

impl Probe {
    /// Reads a workflow from the page's request, each number checked.
    pub(crate) fn from_json(v: &Value) -> Result<Probe, String> {
        let feed = num_in(v, "feed", 1.0, 1000.0, " mm/min")?.unwrap_or(100.0);
        let retract = num_in(v, "retract", 0.0, 100.0, " mm")?.unwrap_or(2.0);
        match text(v, "kind")? {
            Some("z") => Ok(Probe::Z {
                thickness: num_in(v, "thickness", 0.0, 100.0, " mm")?.unwrap_or(0.0),
                distance: num_in(v, "distance", 0.1, 200.0, " mm")?.unwrap_or(20.0),
                feed,
                retract,
            }),
            Some("corner") => Ok(Probe::Corner {
                clearance: num_in(v, "clearance", 1.0, 100.0, " mm")?.unwrap_or(15.0),
                depth: num_in(v, "depth", 0.1, 100.0, " mm")?.unwrap_or(5.0),
                diameter: num_in(v, "diameter", 0.0, 50.0, " mm")?.unwrap_or(0.0),
                feed,
                retract,
            }),
            _ => Err("kind: \"z\" or \"corner\"".into()),
        }
    }

    /// What the workflow will do, in words, for the operator to confirm.
    pub(crate) fn plan(&self, system: &str) -> String {
        match *self {
            Probe::Z {
                thickness,
                distance,
                feed,
                retract,
            } => format!(
                "Z touch plate ({thickness} mm thick, on the work):\n\
                 1. probe down up to {distance} mm at {feed} mm/min (G38.2) until the tool touches the plate\n\
                 2. set {system} Z so that work Z = {thickness} at the contact (Z0 = the work's top)\n\
                 3. back up {retract} mm\n\
                 The plate must be under the tool and its clip on; without contact the board stops in alarm 5."
            ),
            Probe::Corner {
                clearance,
                depth,
                diameter,
                feed,
                retract,
            } => format!(
                "XY outside corner (front-left), the tool above the part a few mm inside the corner:\n\
                 1. rapid {clearance} mm to the left, down {depth} mm, probe right (X+) up to {} mm at {feed} mm/min\n\
                 2. back {retract} mm, up, round to {clearance} mm in front, down, probe back (Y+) the same way\n\
                 3. back {retract} mm, up, and above the start again\n\
                 4. set {system} X and Y so that the corner is work X0 Y0 (tool diameter {diameter} mm)\n\
                 Without contact the board stops in alarm 5.",
                clearance + 5.0
            ),
        }
    }
}

/// One step of a workflow: blocks run as one job, nothing refused, no alarm.
fn step(s: &mut Session, blocks: &[String]) -> Result<Status, String> {
    let (program, report) = s
        .mdi(blocks, &mut |_| crate::session::Flow::Continue)
        .map_err(|e| format!("{e:#}"))?;
    if let Some(e) = report.errors.first() {
        return Err(e.describe("probe", &program));
    }
    if let Some(a) = report.alarms.first() {
        return Err(a.describe(&program));
    }
    if !report.completed {
        return Err("the probing job did not complete (held, aborted or the link lost)".into());
    }
    s.status().map_err(|e| format!("{e:#}"))
}

/// The latched contact of the last probe move, machine mm; an error without contact.
fn contact(st: &Status) -> Result<[f64; 3], String> {
    match st.probe {
        Some(p) if p.success => Ok([0, 1, 2].map(|i| p.machine_pos[i] as f64 / 1e6)),
        _ => Err("the probe did not touch".into()),
    }
}

fn mm(nm: i64) -> f64 {
    nm as f64 / 1e6
}

/// Runs `probe` on session `s` (at rest, Idle); returns the report for the page: what was
/// measured and which offset was set.
pub(crate) fn run(s: &mut Session, probe: &Probe) -> Result<String, String> {
    let start = s.status().map_err(|e| format!("{e:#}"))?;
    let ws = usize::from(start.work_system);
    let system = crate::present::work_system_name(start.work_system);
    let offset = s.setup().program.work_offsets[ws];
    // What lies between machine and work besides the system's offset (G92, tool length): kept
    // as it is, so the work position reads exactly what the workflow sets.
    let other = |st: &Status, i: usize| mm(st.machine_pos[i] - st.work_pos[i] - offset[i]);
    let m0 = [0, 1, 2].map(|i| mm(start.machine_pos[i]));
    match *probe {
        Probe::Z {
            thickness,
            distance,
            feed,
            retract,
        } => {
            let st = step(
                s,
                &[
                    format!("G21 G91 G38.2 Z-{distance:.4} F{feed:.1}"),
                    "G90".into(),
                ],
            )?;
            let c = contact(&st)?;
            let z = c[2] - thickness - other(&st, 2);
            step(
                s,
                &[
                    format!("G21 G90 G10 L2 P{} Z{z:.4}", ws + 1),
                    format!("G53 G0 Z{:.4}", c[2] + retract),
                ],
            )?;
            Ok(format!(
                "Z touch plate: contact at machine Z {:.3}; {system} Z set to {z:.3} (work Z {thickness:.3} at the plate's top, 0 at the work's top)",
                c[2]
            ))
        }
        Probe::Corner {
            clearance,
            depth,
            diameter,
            feed,
            retract,
        } => {
            let reach = clearance + 5.0;
            let low = m0[2] - depth;
            let st = step(
                s,
                &[
                    format!("G21 G90 G53 G0 X{:.4}", m0[0] - clearance),
                    format!("G53 G0 Z{low:.4}"),
                    format!("G91 G38.2 X{reach:.4} F{feed:.1}"),
                    "G90".into(),
                ],
            )?;
            let cx = contact(&st)?[0];
            let st = step(
                s,
                &[
                    format!("G21 G90 G53 G0 X{:.4}", cx - retract),
                    format!("G53 G0 Z{:.4}", m0[2]),
                    format!("G53 G0 X{:.4} Y{:.4}", m0[0], m0[1] - clearance),
                    format!("G53 G0 Z{low:.4}"),
                    format!("G91 G38.2 Y{reach:.4} F{feed:.1}"),
                    "G90".into(),
                ],
            )?;
            let cy = contact(&st)?[1];
            let r = diameter / 2.0;
            let (ex, ey) = (cx + r, cy + r);
            let (x, y) = (ex - other(&st, 0), ey - other(&st, 1));
            step(
                s,
                &[
                    format!("G21 G90 G53 G0 Y{:.4}", cy - retract),
                    format!("G53 G0 Z{:.4}", m0[2]),
                    format!("G53 G0 X{:.4} Y{:.4}", m0[0], m0[1]),
                    format!("G10 L2 P{} X{x:.4} Y{y:.4}", ws + 1),
                ],
            )?;
            Ok(format!(
                "XY corner: contacts at machine X {cx:.3} (left face) and Y {cy:.3} (front face); the corner at machine X {ex:.3} Y {ey:.3}; {system} X set to {x:.3}, Y to {y:.3}"
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_workflow_is_read_with_its_numbers_checked() {
        let z = Probe::from_json(&json!({"kind": "z", "thickness": 10, "distance": 20})).unwrap();
        assert_eq!(
            z,
            Probe::Z {
                thickness: 10.0,
                distance: 20.0,
                feed: 100.0,
                retract: 2.0
            }
        );
        assert!(z.plan("G54").contains("set G54 Z so that work Z = 10"));
        assert!(Probe::from_json(&json!({"kind": "z", "distance": 1e9})).is_err());
        assert!(Probe::from_json(&json!({"kind": "z", "feed": "fast"})).is_err());
        assert!(Probe::from_json(&json!({"kind": "bore"})).is_err());
        let c = Probe::from_json(&json!({"kind": "corner", "clearance": 12, "depth": 8})).unwrap();
        assert!(c.plan("G55").contains("up to 17 mm"), "{}", c.plan("G55"));
    }
}
