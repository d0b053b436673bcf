//! The board's side of the host link: moves protocol messages between a [`BoardEndpoint`] and the
//! [`Board`], and reports status and events back. Sans-IO: the owner feeds received bytes in,
//! drains frames out, and calls [`BoardLink::service`] from its main loop.

use super::{Board, BoardEvent, JumpTarget};
use crate::controller::State;
use crate::units::MAX_AXES;
use gantry_proto::{
    BoardEndpoint, BoardMsg, Config, HostMsg, Lane, LinkEvent, MachineState, ProgramTarget, Status,
};

/// Interval between unsolicited status reports, ms.
pub const STATUS_INTERVAL_MS: u32 = 100;

/// Silence after which the host counts as gone (four keepalive intervals), ms: the board then
/// holds a running job on its path (DESIGN §5) until a host reconnects and resumes it.
pub const HOST_TIMEOUT_MS: u32 = 4 * Config::USB_MS.keepalive;

/// What only the kernel's owner knows, for status reports.
#[derive(Clone, Copy, Debug, Default)]
pub struct KernelView {
    /// Step position the kernel has reached.
    pub steps: [i64; MAX_AXES],
    /// Debounced input levels.
    pub inputs: u32,
    /// Current path speed, µm/min.
    pub feed_um_min: u32,
}

/// Link endpoint + the glue to the board.
pub struct BoardLink {
    endpoint: BoardEndpoint,
    /// An event the send queue had no room for yet.
    unsent: Option<BoardMsg>,
    last_status: Option<u32>,
    status_requested: bool,
    host_attached: bool,
    /// The host went silent during this power-up.
    host_lost: bool,
}

impl BoardLink {
    /// `boot_id` must differ at every power-up (the host detects board resets by it).
    pub fn new(boot_id: u32) -> Self {
        BoardLink {
            endpoint: BoardEndpoint::new_board(Config::USB_MS, boot_id),
            unsent: None,
            last_status: None,
            status_requested: false,
            host_attached: false,
            host_lost: false,
        }
    }

    /// Bytes received from the host.
    pub fn on_bytes(&mut self, now_ms: u32, bytes: &[u8]) {
        self.endpoint.on_bytes(now_ms, bytes);
    }

    /// The next frame to send (call until `None`); `out` must hold `gantry_proto::MAX_FRAME_LEN`.
    pub fn poll_transmit(&mut self, now_ms: u32, out: &mut [u8]) -> Option<usize> {
        self.endpoint.poll_transmit(now_ms, out)
    }

    /// True while a host is attached and has been heard from recently.
    pub fn host_alive(&self, now_ms: u32) -> bool {
        self.host_attached
            && self
                .endpoint
                .peer_alive(now_ms, 4 * gantry_proto::Config::USB_MS.keepalive)
    }

    pub fn endpoint(&self) -> &BoardEndpoint {
        &self.endpoint
    }

    /// Delivers what the host sent to the board and sends what the board has to say.
    pub fn service(&mut self, board: &mut Board, now_ms: u32, view: &KernelView) {
        while let Some(ev) = self.endpoint.poll_event() {
            if let LinkEvent::HostAttached { .. } = ev {
                if self.host_attached || self.host_lost {
                    // A host came back (or a new one took over): it serves the job again from
                    // the line after the last one interpreted.
                    board.resync_stream();
                }
                self.host_attached = true;
                self.host_lost = false;
                self.status_requested = true;
            }
        }
        if self.host_attached && !self.endpoint.peer_alive(now_ms, HOST_TIMEOUT_MS) {
            self.host_attached = false;
            self.host_lost = true;
            board.feed_hold();
        }
        while let Some(msg) = self.endpoint.recv_realtime() {
            self.realtime(board, msg);
        }
        // Queued messages: take a line only when the board has room for it, so the credit the
        // host sees is exactly the board's free line buffer.
        while let Some(msg) = self.endpoint.peek_queued() {
            let is_line = matches!(msg, HostMsg::Line(_) | HostMsg::ProgramLine { .. });
            if is_line && board.line_room() == 0 {
                break;
            }
            let Some(msg) = self.endpoint.recv_queued() else {
                break;
            };
            Self::queued(board, msg);
        }
        self.send_events(board);
        let due = self
            .last_status
            .is_none_or(|t| now_ms.wrapping_sub(t) >= STATUS_INTERVAL_MS);
        if (due || self.status_requested) && self.endpoint.send_capacity(Lane::Realtime) > 0 {
            let status = status_of(board, view);
            if self.endpoint.send(BoardMsg::Status(status)).is_ok() {
                self.last_status = Some(now_ms);
                self.status_requested = false;
            }
        }
    }

    fn realtime(&mut self, board: &mut Board, msg: HostMsg) {
        match msg {
            HostMsg::FeedHold => board.feed_hold(),
            HostMsg::Resume => board.resume(),
            HostMsg::Abort => board.abort(),
            HostMsg::FeedOverride(p) => board.set_feed_override(p),
            HostMsg::RapidOverride(p) => board.set_rapid_override(p),
            HostMsg::StatusRequest => self.status_requested = true,
            HostMsg::Unlock => board.unlock(),
            // Jogging and homing are not implemented on the board yet: they are refused (the
            // state does not change, which the host sees in the next status).
            HostMsg::Jog(_) | HostMsg::JogStop | HostMsg::Home { .. } => {}
            _ => {}
        }
    }

    fn queued(board: &mut Board, msg: HostMsg) {
        match msg {
            HostMsg::Start | HostMsg::StartFromLine { .. } => {
                board.start_job();
            }
            HostMsg::Line(l) => {
                board.push_line(0, l.line_no, &l.text);
            }
            HostMsg::ProgramLine { id, line } => {
                board.push_line(id, line.line_no, &line.text);
            }
            HostMsg::ProgramEnd { id, .. } => board.end_of_lines(id),
            HostMsg::EndOfJob => board.end_of_lines(0),
            _ => {}
        }
    }

    fn send_events(&mut self, board: &mut Board) {
        loop {
            let msg = match self.unsent.take() {
                Some(m) => m,
                None => match board.take_event() {
                    Some(e) => event_message(e),
                    None => return,
                },
            };
            if let Err(gantry_proto::SendError::Full(m)) = self.endpoint.send(msg) {
                self.unsent = Some(m);
                return;
            }
        }
    }
}

fn event_message(e: BoardEvent) -> BoardMsg {
    match e {
        BoardEvent::Error { line, code, column } => BoardMsg::Error { line, code, column },
        BoardEvent::Alarm(code) => BoardMsg::Alarm { code: code as u16 },
        BoardEvent::JobDone { line } => BoardMsg::JobDone { line },
        BoardEvent::Jump(req) => BoardMsg::ProgramRequest {
            id: req.id,
            target: match req.target {
                JumpTarget::Program(p) => ProgramTarget::Program(p),
                JumpTarget::Sequence(n) => ProgramTarget::Sequence(n),
                JumpTarget::Line(n) => ProgramTarget::Line(n),
            },
        },
    }
}

/// The status report of the board as the kernel sees it now.
pub fn status_of(board: &Board, view: &KernelView) -> Status {
    let machine = board.machine_position(&view.steps);
    let work = board.work_position(&machine);
    let state = match board.state() {
        State::Idle => MachineState::Idle,
        State::Run => MachineState::Run,
        State::Hold => MachineState::Hold {
            stopped: view.feed_um_min == 0,
        },
        State::Alarm => MachineState::Alarm,
        State::Homing => MachineState::Homing,
        State::Jog => MachineState::Jog,
        State::Check => MachineState::Check,
    };
    Status {
        state,
        machine_pos: machine,
        work_pos: work,
        feed_um_min: view.feed_um_min,
        feed_override: board.motion().planner().feed_override(),
        rapid_override: board.motion().planner().rapid_override(),
        planner_fill: board.motion().planner().len() as u16,
        queue_fill: board.lines_buffered() as u16,
        line: board.line(),
        inputs: view.inputs,
        homed: board.homed(),
    }
}
