//! What the board hands its owner, each taken once: events for the host (in order, never dropped
//! while the link drains them), the joystick's Mark events, and the news that a job changed the
//! stored offsets (the owner writes the setup to flash).

use super::source::JumpRequest;
use crate::board::state::AlarmCode;
use crate::units::Pos;
use heapless::Deque;

/// Events waiting for the link.
const EVENT_QUEUE: usize = 8;
/// Mark events waiting for the link.
const MARK_QUEUE: usize = 4;

/// Something the host must hear about (in order, never dropped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardEvent {
    /// A block was rejected: `code` is the documented error number, `column` the bad word (0 = none).
    Error { line: u32, code: u16, column: u16 },
    /// The machine entered the alarm state. `line`: the program line concerned (the block that
    /// would have left the travel for alarm 2, the line running for alarms raised during a job;
    /// 0 = none).
    Alarm { code: AlarmCode, line: u32 },
    /// A limit switch stopped motion (the axis and the switch side; docs/controller.md "Limit reports").
    /// Sent before alarm 1 for every tripped switch, and alone for the switch hits a homing
    /// list's `seek` commands cause, unless that list starts with `DisableLimitReport`.
    Limit { axis: u8, max: bool },
    /// The job ended (M2/M30, end of the program, an error, an abort or an alarm); `line` is the
    /// last line run, `end` says how.
    JobDone { line: u32, end: JobEnd },
    /// The interpreter jumped: the host must serve lines from the request's target.
    Jump(JumpRequest),
    /// The answer to the host request tagged `id` (`gantry_proto::BoardMsg::Answer`): 0 =
    /// accepted, else the refusal's code. Queued by the link when it hands the request over, so
    /// it follows every event emitted before.
    Answer { id: u32, code: u16 },
}

/// How a job ended (in [`BoardEvent::JobDone`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobEnd {
    /// It ran to its end (M2/M30 or the end of the program).
    Completed,
    /// A block was rejected (the `Error` event before it says which).
    Failed,
    /// An abort stopped it on its path.
    Aborted,
    /// An alarm ended it (the `Alarm` event before it says which).
    Alarm,
}

/// The joystick's Mark switch was pressed in jog mode (teach-in, docs/controller.md "Jogging"): the host hears where
/// the machine stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MarkEvent {
    /// Running count of marks since power-up (1, 2, …).
    pub id: u32,
    /// Machine position, nm.
    pub position: Pos,
}

/// The board's outgoing news, until the owner takes it.
pub(super) struct Outbox {
    events: Deque<BoardEvent, EVENT_QUEUE>,
    marks: Deque<MarkEvent, MARK_QUEUE>,
    /// A job changed the stored offsets since the last [`Outbox::take_offsets_changed`].
    offsets_changed: bool,
}

impl Outbox {
    /// Nothing to hand out.
    #[inline(always)]
    pub(super) const fn new() -> Self {
        Outbox {
            events: Deque::new(),
            marks: Deque::new(),
            offsets_changed: false,
        }
    }

    /// Queues `e` for the host. The queue is drained every link poll; if it ever overflows, the
    /// oldest event goes, so the newest alarm is kept.
    pub(super) fn emit(&mut self, e: BoardEvent) {
        if self.events.push_back(e).is_err() {
            self.events.pop_front();
            let _ = self.events.push_back(e);
        }
    }

    /// The next event for the host.
    pub(super) fn take_event(&mut self) -> Option<BoardEvent> {
        self.events.pop_front()
    }

    /// Queues a Mark for the host; the oldest waiting Mark goes when the queue is full.
    pub(super) fn mark(&mut self, mark: MarkEvent) {
        if self.marks.is_full() {
            self.marks.pop_front();
        }
        let _ = self.marks.push_back(mark);
    }

    /// The next Mark event for the host.
    pub(super) fn take_mark(&mut self) -> Option<MarkEvent> {
        self.marks.pop_front()
    }

    /// A job changed the stored offsets.
    pub(super) fn offsets_changed(&mut self) {
        self.offsets_changed = true;
    }

    /// True once after [`Outbox::offsets_changed`].
    pub(super) fn take_offsets_changed(&mut self) -> bool {
        core::mem::take(&mut self.offsets_changed)
    }
}
