//! The console's probing requests: the page's numbers read and checked into a
//! [`crate::session::probe::Probe`] (the workflows themselves are the session's, one function
//! each, docs/probing.md "Workflows"); the page shows the plan and asks before anything moves.

use super::args::{num_in, text, whole_in};
use crate::session::probe::{Approach, Corner, Probe, Side};
use serde_json::Value;

/// Reads a workflow from the page's request, each number checked. `tool`: the tool in the
/// spindle now (0 = none), the tool-length workflow's default.
pub(crate) fn from_json(v: &Value, tool: u32) -> Result<Probe, String> {
    let feed = num_in(v, "feed", 1.0, 1000.0, " mm/min")?.unwrap_or(100.0);
    let retract = num_in(v, "retract", 0.0, 100.0, " mm")?.unwrap_or(2.0);
    let diameter = num_in(v, "diameter", 0.0, 50.0, " mm")?.unwrap_or(0.0);
    let approach = || -> Result<Approach, String> {
        Ok(Approach {
            clearance: num_in(v, "clearance", 1.0, 100.0, " mm")?.unwrap_or(15.0),
            depth: num_in(v, "depth", 0.1, 100.0, " mm")?.unwrap_or(5.0),
            diameter,
        })
    };
    match text(v, "kind")? {
        Some("z") => Ok(Probe::Z {
            thickness: num_in(v, "thickness", 0.0, 100.0, " mm")?.unwrap_or(0.0),
            distance: num_in(v, "distance", 0.1, 200.0, " mm")?.unwrap_or(20.0),
            feed,
            retract,
        }),
        Some("edge") => Ok(Probe::Edge {
            side: text(v, "side")?
                .and_then(Side::parse)
                .ok_or("side: \"x+\", \"x-\", \"y+\" or \"y-\" (the probing direction)")?,
            approach: approach()?,
            feed,
            retract,
        }),
        Some("corner") => Ok(Probe::Corner {
            corner: match text(v, "corner")? {
                None => Corner::FrontLeft,
                Some(c) => Corner::parse(c).ok_or(
                    "corner: \"front-left\", \"front-right\", \"back-left\" or \"back-right\"",
                )?,
            },
            approach: approach()?,
            feed,
            retract,
        }),
        Some("bore") => Ok(Probe::Bore {
            size: num_in(v, "size", 1.0, 500.0, " mm")?
                .ok_or("size: the bore's diameter at most, mm")?,
            diameter,
            feed,
            retract,
        }),
        Some("boss") => Ok(Probe::Boss {
            size: num_in(v, "size", 1.0, 500.0, " mm")?
                .ok_or("size: the boss's diameter at most, mm")?,
            approach: approach()?,
            feed,
            retract,
        }),
        Some("tool") => Ok(Probe::ToolLength {
            tool: match whole_in(v, "tool", 1, 9999)? {
                Some(t) => t as u32,
                None if tool != 0 => tool,
                None => return Err("tool: which tool is in the spindle (none after no M6)?".into()),
            },
            setter_z: num_in(v, "setter_z", -100_000.0, 100_000.0, " mm")?
                .ok_or("setter_z: the machine Z at which a tool of length 0 touches the setter")?,
            distance: num_in(v, "distance", 0.1, 200.0, " mm")?.unwrap_or(50.0),
            feed,
            retract,
        }),
        _ => Err("kind: \"z\", \"edge\", \"corner\", \"bore\", \"boss\" or \"tool\"".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_workflow_is_read_with_its_numbers_checked() {
        let z = from_json(&json!({"kind": "z", "thickness": 10, "distance": 20}), 0).unwrap();
        assert_eq!(
            z,
            Probe::Z {
                thickness: 10.0,
                distance: 20.0,
                feed: 100.0,
                retract: 2.0
            }
        );
        assert!(z
            .plan("G54", [0.0; 3])
            .contains("set G54 Z so that work Z = 10"));
        assert!(from_json(&json!({"kind": "z", "distance": 1e9}), 0).is_err());
        assert!(from_json(&json!({"kind": "z", "feed": "fast"}), 0).is_err());
        assert!(from_json(&json!({"kind": "bore"}), 0).is_err());
        assert!(from_json(&json!({"kind": "edge", "side": "z+"}), 0).is_err());
        assert!(from_json(&json!({"kind": "corner", "corner": "top"}), 0).is_err());
        let c = from_json(&json!({"kind": "corner", "clearance": 12, "depth": 8}), 0).unwrap();
        assert!(
            c.plan("G55", [0.0; 3]).contains("up to 17 mm"),
            "{}",
            c.plan("G55", [0.0; 3])
        );
        // The tool length: the tool in the spindle unless one is named; none is an error.
        let t = json!({"kind": "tool", "setter_z": -20});
        assert!(matches!(
            from_json(&t, 2),
            Ok(Probe::ToolLength { tool: 2, .. })
        ));
        assert!(from_json(&t, 0).is_err());
        assert!(from_json(&json!({"kind": "tool", "tool": 1.5, "setter_z": 0}), 2).is_err());
        assert!(from_json(&json!({"kind": "tool", "tool": 3}), 2).is_err());
    }
}
