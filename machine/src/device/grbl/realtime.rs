//! grbl's realtime bytes: picked out of the byte stream wherever they come (inside a line too)
//! and acted on at the next main-loop pass, ahead of every queued line.

/// A realtime command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Realtime {
    /// `?`: one status report.
    Status,
    /// `!`: feed hold.
    FeedHold,
    /// `~`: cycle start / resume.
    CycleStart,
    /// 0x18 (Ctrl-X): soft reset.
    Reset,
    /// 0x84: safety door (`grbl/door.rs`).
    SafetyDoor,
    /// 0x85: jog cancel.
    JogCancel,
    /// 0x90-0x94: feed override to 100 %, +10, -10, +1, -1.
    Feed(FeedStep),
    /// 0x95-0x97: rapid override 100, 50, 25 %.
    Rapid(u16),
    /// 0x99-0x9D: spindle speed override to 100 %, +10, -10, +1, -1.
    SpindleSpeed(FeedStep),
    /// 0x9E: spindle stop (in a feed hold at rest).
    SpindleStop,
    /// 0xA0 flood (`true`), 0xA1 mist (`false`) toggle.
    Coolant { flood: bool },
    /// A byte of 0x80-0xFF grbl does not define: dropped.
    Unknown,
}

/// A feed or spindle override step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FeedStep {
    Reset,
    Add(i16),
}

impl Realtime {
    /// The realtime command of `b`, or `None` for a byte of line text.
    pub fn of(b: u8) -> Option<Realtime> {
        Some(match b {
            b'?' => Realtime::Status,
            b'!' => Realtime::FeedHold,
            b'~' => Realtime::CycleStart,
            0x18 => Realtime::Reset,
            0x84 => Realtime::SafetyDoor,
            0x85 => Realtime::JogCancel,
            0x90 => Realtime::Feed(FeedStep::Reset),
            0x91 => Realtime::Feed(FeedStep::Add(10)),
            0x92 => Realtime::Feed(FeedStep::Add(-10)),
            0x93 => Realtime::Feed(FeedStep::Add(1)),
            0x94 => Realtime::Feed(FeedStep::Add(-1)),
            0x95 => Realtime::Rapid(100),
            0x96 => Realtime::Rapid(50),
            0x97 => Realtime::Rapid(25),
            0x99 => Realtime::SpindleSpeed(FeedStep::Reset),
            0x9A => Realtime::SpindleSpeed(FeedStep::Add(10)),
            0x9B => Realtime::SpindleSpeed(FeedStep::Add(-10)),
            0x9C => Realtime::SpindleSpeed(FeedStep::Add(1)),
            0x9D => Realtime::SpindleSpeed(FeedStep::Add(-1)),
            0x9E => Realtime::SpindleStop,
            0xA0 => Realtime::Coolant { flood: true },
            0xA1 => Realtime::Coolant { flood: false },
            0x80..=0xFF => Realtime::Unknown,
            _ => return None,
        })
    }
}

/// The feed or spindle override after `step` from `pct` (grbl's range, 10-200 %).
pub(crate) fn feed_after(pct: u16, step: FeedStep) -> u16 {
    match step {
        FeedStep::Reset => 100,
        FeedStep::Add(d) => (i32::from(pct) + i32::from(d)).max(10).min(200) as u16,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_realtime_byte_has_its_meaning() {
        assert_eq!(Realtime::of(b'?'), Some(Realtime::Status));
        assert_eq!(Realtime::of(b'!'), Some(Realtime::FeedHold));
        assert_eq!(Realtime::of(b'~'), Some(Realtime::CycleStart));
        assert_eq!(Realtime::of(0x18), Some(Realtime::Reset));
        assert_eq!(Realtime::of(0x84), Some(Realtime::SafetyDoor));
        assert_eq!(Realtime::of(0x85), Some(Realtime::JogCancel));
        assert_eq!(Realtime::of(0x97), Some(Realtime::Rapid(25)));
        assert_eq!(
            Realtime::of(0x9A),
            Some(Realtime::SpindleSpeed(FeedStep::Add(10)))
        );
        assert_eq!(Realtime::of(0x9E), Some(Realtime::SpindleStop));
        assert_eq!(Realtime::of(0xA0), Some(Realtime::Coolant { flood: true }));
        assert_eq!(Realtime::of(0xA1), Some(Realtime::Coolant { flood: false }));
        assert_eq!(Realtime::of(0xFF), Some(Realtime::Unknown));
        assert_eq!(Realtime::of(b'G'), None);
        assert_eq!(Realtime::of(b'\n'), None);
        let steps = [0x90u8, 0x91, 0x92, 0x93, 0x94].map(|b| match Realtime::of(b) {
            Some(Realtime::Feed(s)) => feed_after(150, s),
            other => panic!("{other:?}"),
        });
        assert_eq!(steps, [100, 160, 140, 151, 149]);
        assert_eq!(feed_after(195, FeedStep::Add(10)), 200);
        assert_eq!(feed_after(15, FeedStep::Add(-10)), 10);
    }
}
