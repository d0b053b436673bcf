//! Command lists (reduced to output actions; docs/controller.md "Outputs"): set or clear user outputs, dwell,
//! wait for an input with a timeout. Homing runs three of them per axis, user M codes one each.
//!
//! A [`ListRunner`] is stepped from the main loop with the time and the debounced inputs; it
//! never blocks.

use crate::board::inputs::InputBits;
use crate::setup::ListCommand;
use heapless::Vec;

/// Longest list the runner holds.
pub(crate) const RUNNER_CAPACITY: usize = 8;

/// What a list is doing after a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ListStatus {
    /// Waiting (dwell or input); step again later.
    Running,
    /// Every command has run.
    Done,
    /// An input wait timed out (the controller alarms).
    Timeout,
    /// A [`ListCommand::Seek`] ran: the owner seeks, then steps the list again.
    Seek,
}

/// Runs one command list.
#[derive(Clone, Debug, Default)]
pub(crate) struct ListRunner {
    commands: Vec<ListCommand, RUNNER_CAPACITY>,
    next: usize,
    /// The running wait started at this time (ms).
    since: Option<u32>,
    /// The list starts with the `DisableLimitReport` directive (seed: "must be the first
    /// entry"): switch hits its `seek` commands cause are not reported to the host.
    limit_report_disabled: bool,
}

impl ListRunner {
    /// A runner for `commands` (extra commands beyond the capacity are dropped).
    pub fn new(commands: &[ListCommand]) -> Self {
        let mut r = ListRunner {
            limit_report_disabled: commands.first() == Some(&ListCommand::DisableLimitReport),
            ..ListRunner::default()
        };
        for c in commands.iter().take(RUNNER_CAPACITY) {
            let _ = r.commands.push(*c);
        }
        r
    }

    /// True when switch hits during this list's sequence are reported to the host (the list does
    /// not start with `DisableLimitReport`).
    pub(crate) fn reports_limits(&self) -> bool {
        !self.limit_report_disabled
    }

    /// Runs commands until one has to wait or the list ends; `user` holds the user outputs.
    pub fn step(&mut self, now_ms: u32, inputs: InputBits, user: &mut u16) -> ListStatus {
        while let Some(cmd) = self.commands.get(self.next).copied() {
            match cmd {
                ListCommand::Set(n) => *user |= 1u16.checked_shl(u32::from(n)).unwrap_or(0),
                ListCommand::Clear(n) => *user &= !1u16.checked_shl(u32::from(n)).unwrap_or(0),
                // Acts through `reports_limits` for the whole list (it must come first).
                ListCommand::DisableLimitReport => {}
                ListCommand::Seek => {
                    self.since = None;
                    self.next += 1;
                    return ListStatus::Seek;
                }
                ListCommand::DwellMs(ms) => {
                    let since = *self.since.get_or_insert(now_ms);
                    if now_ms.wrapping_sub(since) < u32::from(ms) {
                        return ListStatus::Running;
                    }
                }
                ListCommand::WaitInput {
                    bit,
                    level,
                    timeout_ms,
                } => {
                    let since = *self.since.get_or_insert(now_ms);
                    let on = bit < 32 && inputs.0 & (1 << bit) != 0;
                    if on != level {
                        if timeout_ms != 0 && now_ms.wrapping_sub(since) >= u32::from(timeout_ms) {
                            return ListStatus::Timeout;
                        }
                        return ListStatus::Running;
                    }
                }
            }
            self.since = None;
            self.next += 1;
        }
        ListStatus::Done
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_dwell_and_input_waits_run_in_order() {
        let list = [
            ListCommand::Set(3),
            ListCommand::DwellMs(10),
            ListCommand::Clear(3),
            ListCommand::WaitInput {
                bit: 2,
                level: true,
                timeout_ms: 0,
            },
            ListCommand::Set(0),
        ];
        let mut r = ListRunner::new(&list);
        let mut user = 0;
        assert_eq!(r.step(100, InputBits(0), &mut user), ListStatus::Running);
        assert_eq!(user, 0b1000);
        assert_eq!(r.step(109, InputBits(0), &mut user), ListStatus::Running);
        assert_eq!(r.step(110, InputBits(0), &mut user), ListStatus::Running);
        assert_eq!(user, 0);
        assert_eq!(r.step(5000, InputBits(0), &mut user), ListStatus::Running);
        assert_eq!(r.step(5001, InputBits(0b100), &mut user), ListStatus::Done);
        assert_eq!(user, 1);
    }

    #[test]
    fn the_report_directive_counts_only_as_the_first_entry() {
        let first = [ListCommand::DisableLimitReport, ListCommand::Seek];
        let later = [ListCommand::Seek, ListCommand::DisableLimitReport];
        assert!(!ListRunner::new(&first).reports_limits());
        assert!(ListRunner::new(&later).reports_limits());
        assert!(ListRunner::new(&[]).reports_limits());
    }

    #[test]
    fn an_input_wait_times_out() {
        let list = [ListCommand::WaitInput {
            bit: 5,
            level: true,
            timeout_ms: 50,
        }];
        let mut r = ListRunner::new(&list);
        let mut user = 0;
        assert_eq!(r.step(0, InputBits(0), &mut user), ListStatus::Running);
        assert_eq!(r.step(49, InputBits(0), &mut user), ListStatus::Running);
        assert_eq!(r.step(50, InputBits(0), &mut user), ListStatus::Timeout);
    }
}
