//! The emulated board: the very same [`Board`] and [`BoardLink`] the firmware runs, with the step
//! kernel ticked on a virtual clock instead of a timer interrupt.
//!
//! Virtual time counts kernel timer counts ([`KERNEL_TIMER_HZ`]). The main loop (link service,
//! interpretation, segment preparation) runs once per virtual millisecond, the kernel at the
//! periods it asks for, so the emulation runs as fast as the host can while keeping the board's
//! timing. Every step is counted per axis, and an optional observer sees every tick that stepped
//! (for VCD traces).

use gantry_machine::board::link::{BoardLink, KernelView};
use gantry_machine::board::Board;
use gantry_machine::controller::State;
use gantry_machine::motion::kernel::{StepKernel, KERNEL_TIMER_HZ};
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::motion::sim::{SegmentFifo, SEGMENT_QUEUE};
use gantry_machine::setup::Setup;
use gantry_machine::units::MAX_AXES;

/// Kernel timer counts per millisecond.
pub const COUNTS_PER_MS: u64 = KERNEL_TIMER_HZ as u64 / 1000;

/// One tick of the kernel that changed the step or direction outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinEvent {
    /// Virtual time, kernel timer counts.
    pub time: u64,
    pub step: u8,
    pub dir: u8,
}

/// A board with its kernel on a virtual clock.
pub struct EmulatedBoard {
    pub board: Board,
    pub link: BoardLink,
    pub kernel: StepKernel,
    fifo: SegmentFifo<SEGMENT_QUEUE>,
    /// Virtual time, kernel timer counts.
    now: u64,
    next_main_loop: u64,
    /// When the kernel ticks next (`None`: idle until the main loop hands it a segment).
    next_tick: Option<u64>,
    /// Step pulses per axis since power-up (direction-independent).
    pub pulses: [u64; MAX_AXES],
    /// Debounced input levels the controller sees.
    pub inputs: u32,
    /// Limit flag handed to the kernel.
    pub limit: bool,
    last_dir: u8,
    /// Pulses at the previous main-loop pass, and the path speed measured from them.
    pulses_at_last_loop: [u64; MAX_AXES],
    measured_um_min: u32,
    observer: Option<Box<dyn FnMut(PinEvent)>>,
    /// Main-loop passes that found the kernel idle with motion still to run and nothing prepared
    /// (the planner starved the kernel).
    pub underruns: u64,
    /// Bytes the board has sent and the host not yet read.
    outbox: Vec<u8>,
}

impl EmulatedBoard {
    pub fn new(setup: Setup) -> Self {
        EmulatedBoard {
            board: Board::new(setup),
            link: BoardLink::new(0x6a17_0001),
            kernel: StepKernel::new(),
            fifo: SegmentFifo::default(),
            now: 0,
            next_main_loop: 0,
            next_tick: None,
            pulses: [0; MAX_AXES],
            inputs: 0,
            limit: false,
            last_dir: 0,
            pulses_at_last_loop: [0; MAX_AXES],
            measured_um_min: 0,
            observer: None,
            underruns: 0,
            outbox: Vec::new(),
        }
    }

    /// Calls `f` for every kernel tick that stepped or changed direction.
    pub fn observe(&mut self, f: impl FnMut(PinEvent) + 'static) {
        self.observer = Some(Box::new(f));
    }

    /// Virtual time in kernel timer counts.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// Virtual time in milliseconds (the link's clock).
    pub fn now_ms(&self) -> u32 {
        (self.now / COUNTS_PER_MS) as u32
    }

    /// Virtual time in seconds.
    pub fn seconds(&self) -> f64 {
        self.now as f64 / KERNEL_TIMER_HZ as f64
    }

    /// Bytes from the host.
    pub fn receive(&mut self, bytes: &[u8]) {
        let now = self.now_ms();
        self.link.on_bytes(now, bytes);
    }

    /// Bytes for the host (everything sent since the last call).
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.outbox)
    }

    /// What the status reports see of the kernel.
    pub fn kernel_view(&self) -> KernelView {
        KernelView {
            steps: self.kernel.position(),
            inputs: self.inputs,
            feed_um_min: self.measured_um_min,
        }
    }

    /// Runs the board for `counts` kernel timer counts of virtual time.
    pub fn run_for(&mut self, counts: u64) {
        let end = self.now + counts;
        while self.now < end {
            if self.now >= self.next_main_loop {
                self.main_loop();
                self.next_main_loop = self.now + COUNTS_PER_MS;
            }
            if self.next_tick.is_some_and(|t| t <= self.now) {
                self.tick();
            }
            let mut next = self.next_main_loop.min(end);
            if let Some(t) = self.next_tick {
                next = next.min(t);
            }
            self.now = next.max(self.now);
        }
    }

    fn tick(&mut self) {
        let out = self.kernel.tick(&mut self.fifo, self.limit);
        if out.step != 0 || out.dir != self.last_dir {
            for (axis, p) in self.pulses.iter_mut().enumerate() {
                *p += u64::from(out.step >> axis & 1);
            }
            if let Some(f) = self.observer.as_mut() {
                f(PinEvent {
                    time: self.now,
                    step: out.step,
                    dir: out.dir,
                });
            }
            self.last_dir = out.dir;
        }
        self.next_tick = (out.period != 0).then(|| self.now + out.period as u64);
    }

    /// Path speed over the last main-loop interval (1 ms), from the pulses the axes made.
    fn measure_speed(&mut self) {
        let cfg = self.board.motion_config();
        let mut sum_sq = 0.0f64;
        for axis in 0..cfg.axis_count as usize {
            let n = self.pulses[axis] - self.pulses_at_last_loop[axis];
            let a = &cfg.axes[axis];
            let nm = n as f64 * a.units as f64 / a.steps as f64;
            sum_sq += nm * nm;
        }
        self.pulses_at_last_loop = self.pulses;
        // nm per ms → µm per min.
        self.measured_um_min = (sum_sq.sqrt() * 60.0).round() as u32;
    }

    /// One pass of the firmware's main loop: link, controller, segment preparation.
    fn main_loop(&mut self) {
        self.measure_speed();
        let now = self.now_ms();
        let view = self.kernel_view();
        self.link.service(&mut self.board, now, &view);
        let drained = self.fifo.0.is_empty() && self.next_tick.is_none();
        self.board.poll(drained);
        while !self.fifo.0.is_full() {
            match self.board.next_segment() {
                Some(s) => {
                    let _ = self.fifo.0.push_back(s);
                }
                None => break,
            }
        }
        if self.next_tick.is_none() {
            if !self.fifo.0.is_empty() {
                self.next_tick = Some(self.now);
            } else if drained
                && self.board.motion().state() == MotionState::Running
                && self.board.state() == State::Run
            {
                self.underruns += 1;
            }
        }
        // Events raised by this poll go out in the same pass.
        self.link.service(&mut self.board, now, &view);
        let mut frame = [0u8; gantry_proto::MAX_FRAME_LEN];
        while let Some(n) = self.link.poll_transmit(now, &mut frame) {
            self.outbox.extend_from_slice(&frame[..n]);
        }
    }
}
