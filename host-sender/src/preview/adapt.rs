//! Adapters into the renderer's input: canonical actions (from the interpreter or from canon JSON
//! Lines, tests/golden/rs274/README.md) become [`PreviewMove`]s in millimetres, with the programmed feed as the speed
//! and a time estimate without acceleration.

use super::geom::length;
use super::model::{
    ArcGeom, Box3, Interpreted, MoveKind, PreviewJob, PreviewMove, ProgramError, SpeedSource, P3,
};
use anyhow::{bail, Context};
use gantry_machine::canon::{Action, ArcDir, Canon, Plane};
use gantry_machine::setup::Setup;
use gantry_machine::units::{Nm, Pos, NM_PER_MM};

fn mm3(p: &Pos) -> P3 {
    [0, 1, 2].map(|i| p[i] as f64 / NM_PER_MM as f64)
}

/// Turns canonical actions into a preview job. The machine starts at 0,0,0 (as `gantry check --canon` assumes); speeds are
/// the programmed feeds and the total time is estimated from feeds and per-axis rapid rates
/// without acceleration (the planner's figures replace both when available).
pub fn from_canon(actions: &[Canon], setup: &Setup, title: &str) -> PreviewJob {
    let mut adapter = MoveAdapter::new(setup);
    let moves = actions.iter().filter_map(|c| adapter.take(c)).collect();
    PreviewJob {
        title: title.to_string(),
        moves,
        total_time_s: Some(adapter.seconds),
        speed_source: SpeedSource::Programmed,
        travel: Some(Box3::travel(setup)),
    }
}

/// Canonical actions to [`PreviewMove`]s one at a time (for tools that stream a program), with
/// the running time estimate of [`from_canon`].
pub(crate) struct MoveAdapter {
    rates: [f64; 3],
    at: P3,
    /// Estimated time so far, s (programmed feeds, no acceleration, dwells included).
    pub(crate) seconds: f64,
}

impl MoveAdapter {
    pub(crate) fn new(setup: &Setup) -> Self {
        MoveAdapter {
            rates: [0, 1, 2].map(|i| setup.axes[i].max_rate as f64 / NM_PER_MM as f64),
            at: [0.0; 3],
            seconds: 0.0,
        }
    }

    /// Moves from machine position `at` (nm) on: the first move starts there.
    pub(crate) fn starting_at(mut self, at: &Pos) -> Self {
        self.at = mm3(at);
        self
    }

    /// The move of `c`, if it is one.
    pub(crate) fn take(&mut self, c: &Canon) -> Option<PreviewMove> {
        let (kind, to, feed) = match c.action {
            Action::Rapid { to } => (MoveKind::Rapid, mm3(&to), None),
            Action::Feed { to, feed } | Action::Probe { to, feed, .. } => {
                (MoveKind::Feed, mm3(&to), Some(feed))
            }
            Action::Arc {
                to,
                center,
                plane,
                dir,
                turns,
                feed,
            } => {
                let arc = ArcGeom {
                    center: mm3(&[center[0], center[1], center[2], 0, 0, 0]),
                    plane,
                    ccw: dir == ArcDir::Ccw,
                    turns: turns.max(1),
                };
                (MoveKind::Arc(arc), mm3(&to), Some(feed))
            }
            Action::Dwell { micros } => {
                self.seconds += micros as f64 / 1e6;
                return None;
            }
            _ => return None,
        };
        let speed = feed.map(|f| f as f64 / NM_PER_MM as f64);
        let m = PreviewMove {
            line: c.line,
            kind,
            from: self.at,
            to,
            speed_mm_min: speed,
        };
        self.seconds += estimate_seconds(&m, &self.rates);
        self.at = to;
        Some(m)
    }
}

/// Time of one move at its programmed feed (rapids at the axes' rates), limited by the slowest
/// axis' maximum rate, without acceleration.
fn estimate_seconds(m: &PreviewMove, rates_mm_min: &[f64; 3]) -> f64 {
    let axis_limited = (0..3)
        .filter(|&i| rates_mm_min[i] > 0.0)
        .map(|i| (m.to[i] - m.from[i]).abs() / rates_mm_min[i])
        .fold(0.0, f64::max);
    let at_feed = match m.speed_mm_min {
        Some(f) if f > 0.0 => length(m) / f,
        _ => 0.0,
    };
    axis_limited.max(at_feed) * 60.0
}

/// Canon JSON Lines (tests/golden/rs274/README.md) back into canonical actions. Records other than motion are
/// skipped; an `error` record ends the program and is returned with its line and message.
pub(crate) fn canon_from_jsonl(text: &str) -> anyhow::Result<Interpreted> {
    let mut actions = JsonlActions::new(text.as_bytes());
    let out: Vec<Canon> = actions.by_ref().collect();
    match actions.failure {
        Some(e) => Err(e),
        None => Ok((out, actions.ended)),
    }
}

/// Canonical actions read from canon JSON Lines one record at a time (nothing is kept), up to an
/// `error` record ([`JsonlActions::ended`]) or a record that does not parse
/// ([`JsonlActions::failure`]).
pub(crate) struct JsonlActions<R> {
    lines: std::io::Lines<R>,
    /// Records read.
    n: usize,
    done: bool,
    /// The `error` record that ended the program.
    pub(crate) ended: Option<ProgramError>,
    /// Why the text could not be read.
    pub(crate) failure: Option<anyhow::Error>,
}

impl<R: std::io::BufRead> JsonlActions<R> {
    pub(crate) fn new(reader: R) -> Self {
        JsonlActions {
            lines: reader.lines(),
            n: 0,
            done: false,
            ended: None,
            failure: None,
        }
    }
}

impl<R: std::io::BufRead> Iterator for JsonlActions<R> {
    type Item = Canon;

    fn next(&mut self) -> Option<Canon> {
        while !self.done {
            let raw = match self.lines.next() {
                None => break,
                Some(Err(e)) => {
                    self.failure = Some(anyhow::Error::new(e).context("canon JSON Lines"));
                    break;
                }
                Some(Ok(raw)) => raw,
            };
            self.n += 1;
            match record(self.n, &raw) {
                Ok(Record::Skip) => {}
                Ok(Record::Action(c)) => return Some(c),
                Ok(Record::Error(e)) => {
                    self.ended = Some(e);
                    break;
                }
                Err(e) => {
                    self.failure = Some(e);
                    break;
                }
            }
        }
        self.done = true;
        None
    }
}

/// What one canon record holds.
enum Record {
    Action(Canon),
    Error(ProgramError),
    Skip,
}

/// Parses record `n` (1-based).
fn record(n: usize, raw: &str) -> anyhow::Result<Record> {
    let raw = raw.trim();
    if raw.is_empty() {
        return Ok(Record::Skip);
    }
    let v: serde_json::Value =
        serde_json::from_str(raw).with_context(|| format!("canon record {n}"))?;
    let line = v["line"].as_u64().unwrap_or(0) as u32;
    let nm3 = |key: &str| -> anyhow::Result<[Nm; 3]> {
        let a = v[key]
            .as_array()
            .with_context(|| format!("canon record {n}: no {key}"))?;
        let mut p = [0; 3];
        for (i, slot) in p.iter_mut().enumerate() {
            let mm = a.get(i).and_then(|x| x.as_f64()).unwrap_or(0.0);
            *slot = (mm * NM_PER_MM as f64).round() as Nm;
        }
        Ok(p)
    };
    let pos = |p: [Nm; 3]| -> Pos { [p[0], p[1], p[2], 0, 0, 0] };
    let feed = || (v["feed"].as_f64().unwrap_or(0.0) * NM_PER_MM as f64).round() as i64;
    let action = match v["op"].as_str().unwrap_or("") {
        "rapid" => Action::Rapid {
            to: pos(nm3("to")?),
        },
        "feed" => Action::Feed {
            to: pos(nm3("to")?),
            feed: feed(),
        },
        "arc" => Action::Arc {
            to: pos(nm3("to")?),
            center: nm3("center")?,
            plane: match v["plane"].as_str() {
                Some("XY") => Plane::XY,
                Some("ZX") => Plane::ZX,
                Some("YZ") => Plane::YZ,
                other => bail!("canon record {n}: unknown plane {other:?}"),
            },
            dir: match v["dir"].as_str() {
                Some("cw") => ArcDir::Cw,
                Some("ccw") => ArcDir::Ccw,
                other => bail!("canon record {n}: unknown arc direction {other:?}"),
            },
            turns: v["turns"].as_u64().unwrap_or(1) as u32,
            feed: feed(),
        },
        "dwell" => match v["seconds"].as_f64() {
            Some(s) => Action::Dwell {
                micros: (s * 1e6).round() as u64,
            },
            None => return Ok(Record::Skip),
        },
        "error" => {
            let message = v["message"].as_str().unwrap_or("error").to_string();
            return Ok(Record::Error(ProgramError { line, message }));
        }
        _ => return Ok(Record::Skip),
    };
    Ok(Record::Action(Canon { line, action }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jsonl_round_trip_and_estimate() {
        let text = r#"{"line":2,"op":"rapid","to":[10,0,0]}
{"line":3,"op":"feed","to":[10,10,0],"feed":600}
{"line":4,"op":"spindle","rpm":1000}
{"line":5,"op":"arc","to":[0,10,0],"center":[5,10,0],"plane":"XY","dir":"ccw","turns":1,"feed":600}
{"line":6,"op":"error","message":"bad word"}
{"line":7,"op":"rapid","to":[0,0,0]}"#;
        let (canon, err) = canon_from_jsonl(text).unwrap();
        assert_eq!(canon.len(), 3);
        let err = err.unwrap();
        assert_eq!((err.line, err.message.as_str()), (6, "bad word"));
        let job = from_canon(&canon, &Setup::default(), "t");
        assert_eq!(job.moves.len(), 3);
        assert_eq!(job.moves[1].from, [10.0, 0.0, 0.0]);
        assert_eq!(job.moves[2].speed_mm_min, Some(600.0));
        // Rapid 10 mm at 3000 mm/min = 0.2 s, feed 10 mm at 600 = 1 s, half circle r 5 = 5π/600 min.
        let expect = 0.2 + 1.0 + 5.0 * std::f64::consts::PI / 10.0;
        assert!((job.total_time_s.unwrap() - expect).abs() < 1e-9);
    }
}
