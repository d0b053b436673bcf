//! Support code for Gantry's whole-system tests: a lossy transport in front of the emulated board,
//! the core's own simulation of a program as the reference, and generated CAM-like programs.

use gantry_emulator::EmulatedBoard;
use gantry_machine::canon::Canon;
use gantry_machine::gcode::{Interpreter, MemorySource};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::sim::{Sim, SimEvent};
use gantry_machine::setup::Setup;
use gantry_machine::units::MAX_AXES;
use gantry_proto::fault::{Faults, FaultyPipe};
use host_sender::link::Transport;
use std::fmt::Write as _;

/// Bytes a faulty pipe holds in transit.
const PIPE_BYTES: usize = 8192;

/// The emulated board behind two lossy pipes (host → board and board → host).
pub struct FaultyBoard {
    pub board: EmulatedBoard,
    pub to_board: Box<FaultyPipe<PIPE_BYTES>>,
    pub to_host: Box<FaultyPipe<PIPE_BYTES>>,
    /// While false, nothing gets through in either direction (a pulled cable).
    pub connected: bool,
    /// A scheduled cable pull: no byte gets through from the first to the second link time (ms).
    pub outage: Option<(u32, u32)>,
    /// Milliseconds of the outage the board spent in a feed hold.
    pub held_in_outage_ms: u32,
}

impl FaultyBoard {
    pub fn new(setup: Setup, seed: u64, faults: Faults) -> Self {
        FaultyBoard {
            board: EmulatedBoard::new(setup),
            to_board: Box::new(FaultyPipe::new(seed, faults)),
            to_host: Box::new(FaultyPipe::new(seed ^ 0xa5a5_a5a5, faults)),
            connected: true,
            outage: None,
            held_in_outage_ms: 0,
        }
    }

    /// True when bytes get through now.
    fn link_up(&self) -> bool {
        let now = self.board.now_ms();
        self.connected
            && !self
                .outage
                .is_some_and(|(from, to)| now >= from && now < to)
    }
}

impl Transport for FaultyBoard {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        if self.link_up() {
            let now = self.board.now_ms();
            self.to_board.write(now, bytes);
        }
        Ok(())
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        let now = self.board.now_ms();
        let mut buf = [0u8; 256];
        loop {
            let n = self.to_host.read(now, &mut buf);
            if n == 0 {
                return Ok(());
            }
            into.extend_from_slice(&buf[..n]);
        }
    }

    fn wait(&mut self, ms: u32) {
        for _ in 0..ms {
            let now = self.board.now_ms();
            let mut buf = [0u8; 256];
            loop {
                let n = self.to_board.read(now, &mut buf);
                if n == 0 {
                    break;
                }
                self.board.receive(&buf[..n]);
            }
            self.board.wait(1);
            let now = self.board.now_ms();
            if self
                .outage
                .is_some_and(|(from, to)| now >= from && now < to)
                && self.board.board.state() == gantry_machine::board::State::Hold
            {
                self.held_in_outage_ms += 1;
            }
            let out = self.board.take_output();
            if self.link_up() {
                let now = self.board.now_ms();
                self.to_host.write(now, &out);
            }
        }
    }

    fn now_ms(&self) -> u32 {
        self.board.now_ms()
    }
}

/// What the core's own simulation of a program ends with.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    /// Final step position per axis.
    pub steps: [i64; MAX_AXES],
    /// Step pulses per axis.
    pub pulses: [u64; MAX_AXES],
    /// Machine time of the whole program, seconds.
    pub seconds: f64,
}

/// Interprets `program` from memory and runs planner + prep + kernel on virtual time: the result
/// a streamed job must reproduce exactly.
pub fn reference(program: &str, setup: &Setup) -> Reference {
    let mut interp = Interpreter::new(&setup.interp_config());
    let mut src = MemorySource::new(program.as_bytes());
    let mut canon: Vec<Canon> = Vec::new();
    while let Some(r) = interp.next(&mut src) {
        canon.push(r.expect("reference programs are valid"));
    }
    let mut sim: Box<Sim<128>> = Box::new(Sim::new(MotionConfig::from_setup(setup)));
    let mut pulses = [0u64; MAX_AXES];
    sim.run(canon, &mut |e| {
        if let SimEvent::Step(s) = e {
            for (axis, p) in pulses.iter_mut().enumerate() {
                *p += u64::from(s.step >> axis & 1);
            }
        }
    })
    .expect("reference programs stay within the travel");
    Reference {
        steps: sim.kernel.position(),
        pulses,
        seconds: sim.now as f64 / gantry_machine::step::kernel::KERNEL_TIMER_HZ as f64,
    }
}

/// A CAM-like finishing program: `lines` G1 moves of 0.1 mm on a wavy raster, one block per line,
/// at 1500 mm/min.
pub fn cam_program(lines: usize) -> String {
    cam_program_at(lines, 1500)
}

/// [`cam_program`] at feed `feed` mm/min.
pub fn cam_program_at(lines: usize, feed: u32) -> String {
    let mut p = format!("G21 G90 G17 G94\nG0 Z1.\nG0 X0 Y0\nG1 Z-0.2 F600\nF{feed}\n");
    let (mut x, mut y) = (0i64, 0i64); // µm
    let mut dir = 1i64;
    for i in 0..lines {
        // Rows of 500 segments (50 mm), stepping 0.1 mm in Y between rows, with a small Z ripple.
        if i % 500 == 499 {
            y += 100;
            dir = -dir;
        } else {
            x += 100 * dir;
        }
        let z = -200 + ((i % 40) as i64 - 20).abs() * 2;
        let _ = writeln!(
            p,
            "G1 X{}.{:03} Y{}.{:03} Z-0.{:03}",
            x / 1000,
            x % 1000,
            y / 1000,
            y % 1000,
            -z
        );
    }
    p.push_str("G0 Z5.\nM30\n");
    p
}

/// The operator of an in-process test: presses cycle start once, the first time the job is seen
/// held at rest after `after_ms` of link time (a held job is never resumed by the host on its own:
/// docs/controller.md "Only the operator releases a stop"). Returns the progress callback and
/// keeps, in `held_ms`, for how long the job stood held before that press.
pub struct CycleStart {
    after_ms: u32,
    held_since: Option<u32>,
    pub pressed_at: Option<u32>,
    pub held_ms: u32,
}

impl CycleStart {
    pub fn after(after_ms: u32) -> Self {
        CycleStart {
            after_ms,
            held_since: None,
            pressed_at: None,
            held_ms: 0,
        }
    }

    /// The callback's answer at this progress.
    pub fn flow(&mut self, p: &host_sender::session::Progress) -> host_sender::session::Flow {
        use gantry_proto::MachineState;
        use host_sender::session::Flow;
        let held = matches!(
            p.status.as_ref().map(|s| s.state),
            Some(MachineState::Hold { stopped: true })
        );
        if self.pressed_at.is_some() || !held {
            return Flow::Continue;
        }
        let since = *self.held_since.get_or_insert(p.elapsed_ms);
        if p.elapsed_ms.wrapping_sub(since) >= self.after_ms {
            self.pressed_at = Some(p.elapsed_ms);
            self.held_ms = p.elapsed_ms.wrapping_sub(since);
            return Flow::Resume;
        }
        Flow::Continue
    }
}
