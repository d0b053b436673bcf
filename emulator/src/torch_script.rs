//! A scripted plasma power source and torch height controller for the emulated board
//! (docs/laser-plasma.md "Trying it on the emulated board"): the `arc_ok`, `thc_up` and
//! `thc_down` input pins follow the torch output (the spindle enable) on virtual time, so every
//! torch rule of the core can be tried and tested without a plasma cutter.
//!
//! Every time is counted from the moment the torch fires (the spindle enable rises): arc-OK
//! comes `arc_ok_delay` after it (never with `--no-arc`), goes out `arc_lost_at` after the first
//! firing (once; a re-fired torch gets its arc again), and the height controller asks up or
//! down during the spans of the THC pattern. Everything drops when the torch goes off.

use anyhow::{anyhow, bail, Context};
use gantry_machine::board::inputs::Signal;

/// One span of the height controller's pattern: `up` (else down) from `from_ms` to `to_ms`
/// after the torch fired.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ThcSpan {
    pub up: bool,
    pub from_ms: u64,
    pub to_ms: u64,
}

/// What the emulated power source and height controller do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TorchScript {
    /// Arc-OK this long after the torch fires; `None`: never (`--no-arc`).
    pub arc_ok_delay_ms: Option<u64>,
    /// The arc goes out this long after the first firing.
    pub arc_lost_at_ms: Option<u64>,
    /// The up/down pattern.
    pub thc: Vec<ThcSpan>,
}

impl Default for TorchScript {
    /// Arc-OK 50 ms after the torch fires, never lost, no height signals.
    fn default() -> Self {
        TorchScript {
            arc_ok_delay_ms: Some(50),
            arc_lost_at_ms: None,
            thc: Vec::new(),
        }
    }
}

/// A duration as the options take it: `300ms`, `1.5s` or `300` (ms).
pub fn parse_ms(text: &str) -> anyhow::Result<u64> {
    let t = text.trim();
    let (num, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1000.0)
    } else {
        (t, 1.0)
    };
    let v: f64 = num
        .trim()
        .parse()
        .with_context(|| format!("`{text}`: a duration such as 300ms or 1.5s"))?;
    if !(v >= 0.0 && v.is_finite()) {
        bail!("`{text}`: a duration cannot be negative");
    }
    Ok((v * scale).round() as u64)
}

/// A THC pattern: `up:1000-1500,down:2000-2200` (ms after the torch fired; each bound takes the
/// units of [`parse_ms`]).
pub fn parse_thc(text: &str) -> anyhow::Result<Vec<ThcSpan>> {
    text.split(',')
        .filter(|p| !p.trim().is_empty())
        .map(|part| {
            let (dir, range) = part
                .split_once(':')
                .ok_or_else(|| anyhow!("`{part}`: up:FROM-TO or down:FROM-TO"))?;
            let up = match dir.trim() {
                "up" => true,
                "down" => false,
                d => bail!("`{d}`: up or down"),
            };
            let (from, to) = range
                .split_once('-')
                .ok_or_else(|| anyhow!("`{range}`: FROM-TO"))?;
            let (from_ms, to_ms) = (parse_ms(from)?, parse_ms(to)?);
            if to_ms <= from_ms {
                bail!("`{part}`: the span ends before it starts");
            }
            Ok(ThcSpan { up, from_ms, to_ms })
        })
        .collect()
}

/// The script `gantry emulate`'s options ask for: `--arc-ok-delay`, `--no-arc`,
/// `--arc-lost-at` and `--thc` (a pattern for [`parse_thc`]); `None` when none is given.
pub fn from_options(
    arc_ok_delay_ms: Option<u64>,
    no_arc: bool,
    arc_lost_at_ms: Option<u64>,
    thc: Option<&str>,
) -> anyhow::Result<Option<TorchScript>> {
    let thc = thc.map(parse_thc).transpose()?;
    if arc_ok_delay_ms.is_none() && !no_arc && arc_lost_at_ms.is_none() && thc.is_none() {
        return Ok(None);
    }
    Ok(Some(TorchScript {
        arc_ok_delay_ms: if no_arc {
            None
        } else {
            arc_ok_delay_ms.or(TorchScript::default().arc_ok_delay_ms)
        },
        arc_lost_at_ms,
        thc: thc.unwrap_or_default(),
    }))
}

/// The script running against the torch output.
#[derive(Clone, Debug)]
pub struct TorchModel {
    pub script: TorchScript,
    /// When the torch fired last (virtual ms), while it is on.
    fired_at: Option<u64>,
    /// Firings so far (the arc loss is the first one's).
    firings: u32,
}

impl TorchModel {
    pub fn new(script: TorchScript) -> Self {
        TorchModel {
            script,
            fired_at: None,
            firings: 0,
        }
    }

    /// The torch output (spindle enable) is `on` at virtual time `now_ms`.
    pub fn torch(&mut self, on: bool, now_ms: u64) {
        match (on, self.fired_at) {
            (true, None) => {
                self.fired_at = Some(now_ms);
                self.firings += 1;
            }
            (false, Some(_)) => self.fired_at = None,
            _ => {}
        }
    }

    /// When the torch fired last (virtual ms), while it is on.
    pub fn fired_at(&self) -> Option<u64> {
        self.fired_at
    }

    /// The logical levels (bit per [`Signal`]) of the three torch inputs at `now_ms`.
    pub fn levels(&self, now_ms: u64) -> u32 {
        let Some(at) = self.fired_at else {
            return 0;
        };
        let t = now_ms.saturating_sub(at);
        let s = &self.script;
        let lost = self.firings == 1 && s.arc_lost_at_ms.is_some_and(|l| t >= l);
        let arc = s.arc_ok_delay_ms.is_some_and(|d| t >= d) && !lost;
        let mut bits = 0;
        if arc {
            bits |= 1 << Signal::ArcOk as u32;
            for span in &s.thc {
                if (span.from_ms..span.to_ms).contains(&t) {
                    let sig = if span.up {
                        Signal::ThcUp
                    } else {
                        Signal::ThcDown
                    };
                    bits |= 1 << sig as u32;
                }
            }
        }
        bits
    }
}

/// The three torch input bits.
pub const TORCH_BITS: u32 =
    (1 << Signal::ArcOk as u32) | (1 << Signal::ThcUp as u32) | (1 << Signal::ThcDown as u32);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_and_patterns_parse() {
        assert_eq!(parse_ms("300ms").unwrap(), 300);
        assert_eq!(parse_ms("1.5s").unwrap(), 1500);
        assert_eq!(parse_ms("20").unwrap(), 20);
        assert!(parse_ms("-1ms").is_err() && parse_ms("soon").is_err());
        assert_eq!(
            parse_thc("up:1000-1500,down:2s-2200ms").unwrap(),
            vec![
                ThcSpan {
                    up: true,
                    from_ms: 1000,
                    to_ms: 1500
                },
                ThcSpan {
                    up: false,
                    from_ms: 2000,
                    to_ms: 2200
                },
            ]
        );
        assert!(parse_thc("sideways:1-2").is_err() && parse_thc("up:5-5").is_err());
    }

    #[test]
    fn the_inputs_follow_the_torch() {
        let mut m = TorchModel::new(TorchScript {
            arc_ok_delay_ms: Some(300),
            arc_lost_at_ms: Some(1000),
            thc: parse_thc("up:400-500").unwrap(),
        });
        let arc = 1 << Signal::ArcOk as u32;
        let up = 1 << Signal::ThcUp as u32;
        assert_eq!(m.levels(10), 0);
        m.torch(true, 100);
        assert_eq!((m.levels(399), m.levels(400)), (0, arc));
        assert_eq!(m.levels(550), arc | up);
        assert_eq!(m.levels(1099), arc);
        assert_eq!(m.levels(1100), 0, "lost 1000 ms after the first firing");
        m.torch(false, 1200);
        assert_eq!(m.levels(1300), 0);
        m.torch(true, 2000);
        assert_eq!(m.levels(2300), arc, "a re-fired torch gets its arc again");
        assert_eq!(m.levels(4000), arc);
    }
}
