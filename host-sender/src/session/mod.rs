//! The host's session layer: one [`Session`] owns the link to a board (a USB port, a running
//! `gantry serve`'s socket, or the emulated board), the board's setup (read once when the session
//! opens and kept current: a setup pushed through the session replaces it) and its last status.
//! Everything the host asks of a board goes through it: status, hold / resume / abort, overrides,
//! jog, home, unlock, MDI, setup get / push, and jobs (started, resumed from a line, or taken
//! over) with their progress as events ([`job`]).
//!
//! The CLI's one-shot commands, `gantry stream` and `gantry serve` (`crate::commands`) are its
//! clients; so will be a browser console: nothing here prints or reads a terminal (the words are
//! `crate::present`'s). Realtime requests (hold, resume, abort, overrides, status, jog, home,
//! unlock) travel on the link's realtime lane and never wait behind queued job lines.

pub mod job;
pub mod probe;
pub(crate) mod setup;
pub mod socket;
pub mod standing;
pub(crate) mod start;

pub use job::{
    continue_job, fresh_status, stream_from_line, stream_program, BoardAlarm, Flow, Progress,
    StreamReport,
};
pub(crate) use job::{BoardError, JobStart, LinkEnd};
pub use setup::{pull_setup_over, push_setup_over};
pub(crate) use start::{check_program, check_text, Cleared, Refused};

use crate::link::{Client, OnClose, SerialTransport, Transport};
use crate::program::Program;
use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use gantry_proto::{BoardMsg, HostMsg, Status};

/// What [`Session::pushed_status`] found.
#[derive(Debug, Default)]
pub(crate) struct Pushed {
    /// Status reports, newest last.
    pub(crate) statuses: Vec<Status>,
    /// Jobs that ended.
    pub(crate) jobs_ended: usize,
}

/// Override percentages to set (`None`: leave that one as it is).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Overrides {
    /// Feed override, 10-200 %.
    pub feed: Option<u16>,
    /// Rapid override, 1-100 %.
    pub rapid: Option<u16>,
    /// Spindle speed override, 10-200 %.
    pub spindle: Option<u16>,
}

impl Overrides {
    /// The status shows every override given.
    pub(crate) fn shown_in(&self, s: &Status) -> bool {
        self.feed.is_none_or(|f| s.feed_override == f)
            && self.rapid.is_none_or(|r| s.rapid_override == r)
            && self
                .spindle
                .is_none_or(|p| u16::from(s.spindle_override) == p)
    }
}

/// Where `gantry` sends its commands.
pub enum Target {
    /// The built-in emulated board, with this setup.
    Emulated(Box<Setup>),
    /// A board on this serial port.
    Port(String),
}

/// The link every session uses.
pub(crate) type Link = Client<Box<dyn Transport>>;

/// How long the handshake may take on a port (or through `gantry serve`), ms of link time.
const CONNECT_MS: u32 = 3000;

/// An open session with one board.
pub struct Session {
    link: Link,
    setup: Setup,
    status: Option<Status>,
    /// The link goes through `gantry serve` (other commands reach the board meanwhile).
    served: bool,
}

impl Session {
    /// Opens a session with `target`: the link's handshake, then the board's setup (from the
    /// board itself over a port; through `gantry serve` the server answers from the setup it
    /// keeps, so this never waits behind a running job's lines). `on_close`: what closing the
    /// port does to the board ([`OnClose::DropDtr`] for the sender that owns a job).
    pub(crate) fn connect(target: Target, on_close: OnClose) -> anyhow::Result<Session> {
        match target {
            Target::Emulated(setup) => Self::emulated(EmulatedBoard::new((*setup).clone()), *setup),
            Target::Port(p) => {
                // A `gantry serve` that owns the port takes the session; else the port itself.
                let socket = socket::SocketTransport::connect(&p)?;
                let served = socket.is_some();
                let t: Box<dyn Transport> = match socket {
                    Some(s) => Box::new(s),
                    None => Box::new(SerialTransport::open_with(&p, on_close)?),
                };
                let mut link = Client::connect(t, CONNECT_MS)?;
                let setup = pull_setup_over(&mut link)
                    .map_err(|e| anyhow::anyhow!("{p}: cannot read the board's setup: {e:#}"))?;
                let mut session = Session::over(link, setup);
                session.served = served;
                Ok(session)
            }
        }
    }

    /// A session with an emulated board built with `setup`.
    pub fn emulated(board: EmulatedBoard, setup: Setup) -> anyhow::Result<Session> {
        let t: Box<dyn Transport> = Box::new(board);
        Ok(Session::over(Client::connect(t, 2000)?, setup))
    }

    /// A session over a connected link whose board has `setup`.
    pub(crate) fn over(link: Link, setup: Setup) -> Session {
        Session {
            link,
            setup,
            status: None,
            served: false,
        }
    }

    /// The session goes through `gantry serve`: `gantry resume` and the other commands reach the
    /// board from another terminal while this session runs a job.
    pub(crate) fn served(&self) -> bool {
        self.served
    }

    /// The board's setup (as read when the session opened, or as last pushed or reloaded).
    pub(crate) fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The machine's axis count.
    pub(crate) fn axes(&self) -> usize {
        self.setup.axis_count as usize
    }

    /// The link itself, for what the session has no method for (`gantry serve` relays raw
    /// messages).
    pub(crate) fn link(&mut self) -> &mut Link {
        &mut self.link
    }

    /// The link clock, ms.
    pub(crate) fn now_ms(&self) -> u32 {
        self.link.transport.now_ms()
    }

    /// Exchanges bytes, then lets `ms` milliseconds pass.
    pub(crate) fn pump(&mut self, ms: u32) -> anyhow::Result<()> {
        self.link.pump(ms)
    }

    /// A status the board sends now (asked for, and waited for at most 2 s); other messages
    /// are kept for whoever waits for them.
    pub fn status(&mut self) -> anyhow::Result<Status> {
        let s = fresh_status(&mut self.link)?;
        self.status = Some(s.clone());
        Ok(s)
    }

    /// The newest status seen by the session, without asking (`None` before the first).
    pub(crate) fn last_status(&self) -> Option<&Status> {
        self.status.as_ref()
    }

    /// The status reports the board pushed (every 100 ms) since the last call, newest last, and
    /// how many jobs ended meanwhile (any command's, through `gantry serve`): for a session that
    /// only watches, so nothing on it waits for those `JobDone`s. Every other message is kept for
    /// whoever waits for it.
    pub(crate) fn pushed_status(&mut self) -> anyhow::Result<Pushed> {
        self.link.pump(0)?;
        let mut kept = Vec::new();
        let mut got = Pushed::default();
        while let Some(m) = self.link.recv() {
            match m {
                BoardMsg::Status(s) => got.statuses.push(s),
                BoardMsg::JobDone { .. } => got.jobs_ended += 1,
                other => kept.push(other),
            }
        }
        self.link.put_back(kept);
        if let Some(s) = got.statuses.last() {
            self.status = Some(s.clone());
        }
        Ok(got)
    }

    /// Sends a realtime request (hold, resume, abort, overrides, jog stop, status request).
    pub(crate) fn send(&mut self, msg: HostMsg) -> anyhow::Result<()> {
        self.link.send(msg)
    }

    /// Feed hold: decelerate on the path and hold.
    pub(crate) fn hold(&mut self) -> anyhow::Result<()> {
        self.send(HostMsg::FeedHold)
    }

    /// Resume a hold or a tool-change stop.
    pub(crate) fn resume(&mut self) -> anyhow::Result<()> {
        self.send(HostMsg::Resume)
    }

    /// Abort: stop on the path, end the job.
    pub(crate) fn abort(&mut self) -> anyhow::Result<()> {
        self.send(HostMsg::Abort)
    }

    /// Sets the overrides given (%).
    pub(crate) fn set_overrides(&mut self, o: Overrides) -> anyhow::Result<()> {
        if let Some(f) = o.feed {
            self.send(HostMsg::FeedOverride(f))?;
        }
        if let Some(r) = o.rapid {
            self.send(HostMsg::RapidOverride(r))?;
        }
        if let Some(s) = o.spindle {
            self.send(HostMsg::SpindleOverride(s))?;
        }
        Ok(())
    }

    /// Sends a request the board answers by id, and waits (at most `limit_ms`) for its answer:
    /// 0 accepted, else the refusal's code; `None` when none came.
    fn request(
        &mut self,
        make: impl FnOnce(u32) -> HostMsg,
        limit_ms: u32,
    ) -> anyhow::Result<Option<u16>> {
        let id = self.link.request_id();
        self.link.send(make(id))?;
        self.link.await_answer(id, limit_ms)
    }

    /// Jogs `axis` at `feed_um_min` (the sign is the direction) by `distance_nm` (0: until
    /// [`Session::jog_stop`]); the board's answer as [`Session::request`].
    pub(crate) fn jog(
        &mut self,
        axis: u8,
        feed_um_min: i32,
        distance_nm: u64,
        limit_ms: u32,
    ) -> anyhow::Result<Option<u16>> {
        self.request(
            |id| {
                HostMsg::Jog(gantry_proto::Jog {
                    id,
                    axis,
                    feed_um_min,
                    distance_nm,
                })
            },
            limit_ms,
        )
    }

    /// Ends a jog.
    pub(crate) fn jog_stop(&mut self) -> anyhow::Result<()> {
        self.send(HostMsg::JogStop)
    }

    /// Keeps a continuous jog going (`HostMsg::JogKeepalive`): a sender holding one sends this
    /// at least every 100 ms; the board ends the jog 250 ms after the last (its dead-man,
    /// docs/controller.md "Jogging"). Not sent to a board older than protocol 5.1, which has no
    /// dead-man and cannot decode it.
    pub(crate) fn jog_keepalive(&mut self) -> anyhow::Result<()> {
        if self
            .link
            .peer_version()
            .is_some_and(|v| v >= gantry_proto::JOG_KEEPALIVE_SINCE)
        {
            self.send(HostMsg::JogKeepalive)?;
        }
        Ok(())
    }

    /// Starts homing the axes of `axes` (bit 0 = X; 0 = all); the board's answer.
    pub(crate) fn home(&mut self, axes: u8, limit_ms: u32) -> anyhow::Result<Option<u16>> {
        self.request(|id| HostMsg::Home { id, axes }, limit_ms)
    }

    /// Clears an alarm; the board's answer.
    pub(crate) fn unlock(&mut self, limit_ms: u32) -> anyhow::Result<Option<u16>> {
        self.request(|id| HostMsg::Unlock { id }, limit_ms)
    }

    /// Sends `setup` to the board (validated, applied and saved when idle); the session's setup
    /// is then that one.
    pub(crate) fn push_setup(&mut self, setup: &Setup) -> anyhow::Result<()> {
        push_setup_over(&mut self.link, setup)?;
        self.setup = setup.clone();
        Ok(())
    }

    /// The one setup push from setup text (`gantry setup push FILE`, the console's Push): the
    /// text is parsed and validated (an empty or unreadable setup is an error and nothing is
    /// sent), the board's work offsets and G28/G30 positions are kept where the text names none
    /// (`SetupFile::parse_for_push`, the board's setup read again first), then it is pushed
    /// ([`Session::push_setup`]). Returns the setup the board now has.
    pub(crate) fn push_setup_text(&mut self, text: &str) -> anyhow::Result<Setup> {
        // The offsets kept are the board's now (a job or a zero may have changed them since
        // this session read the setup).
        let board = pull_setup_over(&mut self.link)?;
        let setup = crate::setup_file::SetupFile::parse_for_push(text, &board)?;
        self.push_setup(&setup)?;
        Ok(setup)
    }

    /// Reads the board's setup again (after something else changed it).
    pub fn reload_setup(&mut self) -> anyhow::Result<&Setup> {
        self.setup = pull_setup_over(&mut self.link)?;
        Ok(&self.setup)
    }

    /// The start check ([`start`]) of the program `name` read from `src`, with the board's
    /// setup: cleared to start, or refused with `gantry check`'s report.
    pub(crate) fn check_start<S: gantry_machine::gcode::ProgramSource>(
        &self,
        name: &str,
        src: S,
    ) -> anyhow::Result<Result<Cleared, Refused>> {
        check_program(name, src, &self.setup)
    }

    /// Starts `program` (from its beginning, or from a line) once it passed the start check, and
    /// runs it to its end (or until `on_progress` detaches), with its progress as events. A job
    /// standing at a stop is waited on: only the operator releases it ([`job::run`]).
    pub(crate) fn start_job(
        &mut self,
        program: &Program,
        start: JobStart,
        _cleared: Cleared,
        on_progress: &mut dyn FnMut(&Progress) -> Flow,
    ) -> anyhow::Result<StreamReport> {
        anyhow::ensure!(
            start != JobStart::TakeOver,
            "a take-over starts nothing (Session::take_over_job)"
        );
        self.run_job(program, start, on_progress)
    }

    /// Takes over the job the board runs (`gantry stream --continue`; it passed its check when
    /// it started) and runs it to its end; a stop it stands at stays until the operator resumes.
    pub(crate) fn take_over_job(
        &mut self,
        program: &Program,
        on_progress: &mut dyn FnMut(&Progress) -> Flow,
    ) -> anyhow::Result<StreamReport> {
        self.run_job(program, JobStart::TakeOver, on_progress)
    }

    fn run_job(
        &mut self,
        program: &Program,
        start: JobStart,
        on_progress: &mut dyn FnMut(&Progress) -> Flow,
    ) -> anyhow::Result<StreamReport> {
        let report = job::run(&mut self.link, program, start, on_progress)?;
        if let Some(s) = &report.final_status {
            self.status = Some(s.clone());
        }
        Ok(report)
    }

    /// Runs MDI blocks as a small job, after the start check (a refused block is an error with
    /// `gantry check`'s report, and nothing runs).
    pub fn mdi(
        &mut self,
        blocks: &[String],
        on_progress: &mut dyn FnMut(&Progress) -> Flow,
    ) -> anyhow::Result<(Program, StreamReport)> {
        let text = blocks.join("\n");
        let cleared = match check_text("mdi", &text, &self.setup) {
            Ok(c) => c,
            Err(refused) => anyhow::bail!("{}nothing was run", refused.report),
        };
        let program = Program::from_text(&text);
        let report = self.start_job(&program, JobStart::Beginning, cleared, on_progress)?;
        Ok((program, report))
    }

    /// The alarm and limit reports received since the last call, oldest first.
    pub(crate) fn take_notices(&mut self) -> Vec<BoardMsg> {
        self.link.take_notices()
    }

    /// Gaps in the motion where the step kernel ran dry (the emulated board only).
    pub(crate) fn underruns(&self) -> Option<u64> {
        self.link.transport.underruns()
    }
}
