//! The emulated board's CPU model (`gantry stream --cpu-model f411`, `gantry emulate --cpu-model
//! f411`): each main-loop pass costs the Cortex-M4 instructions its work would take on the MCU,
//! so the emulated board's segment queue runs dry when the real board's would.
//!
//! Without a model the emulated board runs a whole main-loop pass in no time, every virtual
//! millisecond. With one, a pass that received `f` frames of `n` bytes, interprets `l` lines,
//! plans `b` blocks and prepares `s` segments takes
//! `link_pass + f·link_frame + n·link_byte + l·line + b·block + s·segment` instructions at the
//! MCU clock (one per cycle), stretched by the share of the CPU the step interrupt took since
//! the previous pass (each step event costs the interrupt's measured instructions for the axes
//! stepping plus its entry and exit cycles). The segments of the pass's top-up (before it reads
//! the host's bytes, `MainLoop::pass`) reach the kernel's queue once each is prepared; those it
//! prepared after the link and the interpreter, when the pass ends. The next pass starts 1 ms
//! after the previous one or when it ends, whichever is later (the firmware's control task, `firmware/src/control.rs`, runs the
//! pass every millisecond and cannot start one before the last has finished).
//!
//! The figures ([`Measured`]) are not typed here: `scripts/bench-mcu.sh` runs the QEMU
//! benchmarks (target-tests `bench_motion`, `bench_step`, `bench_link`, `-icount shift=0`, one
//! instruction per virtual ns) and writes them into `cpu_model_f411.rs`, and the figures table
//! of firmware/README.md from it ([`figures_table`]; a test keeps the two equal).

use gantry_machine::board::Board;
use gantry_machine::motion::prep::JerkSetup;

/// What the QEMU benchmarks measured on the firmware's Cortex-M4 code, instructions unless
/// named otherwise (`cpu_model_f411.rs`, written by scripts/bench-mcu.sh).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Measured {
    /// Interpreting one short streamed G1 line (`G1 Y-6.789 F3000`, 0.1 mm), lex,
    /// parse and execute (`bench_motion`: `Interpreter::next` from a `StreamSource`).
    pub interpret_line: u64,
    /// Planning its block (`Motion::push`).
    pub plan_block: u64,
    /// Preparing one segment (`Motion::next_segment`; a short block is one segment).
    pub prepare_segment: u64,
    /// The same with a jerk limit on every axis (5,000 mm/s³; `motion/prep/jerk_line.rs`): two
    /// segments a short line there (the tracker's 2 ms step crosses one block end), each
    /// charged half the step's own cost, more than a step over many shorter blocks costs.
    pub prepare_jerk_segment: u64,
    /// The step kernel's tick alone for 1, 3 and 6 axes stepping (`bench_motion`).
    pub kernel_tick: [u64; 3],
    /// The step interrupt per step event, kernel tick included, for 1, 3 and 6 axes stepping
    /// (`bench_step`: firmware/src/step_body.rs), and its exception entry plus exit in cycles.
    pub step_event: [u64; 3],
    pub step_entry_exit_cycles: u64,
    /// The board's side of the link (`bench_link`: `BoardLink::on_bytes`, `service` twice,
    /// `poll_transmit`): per main-loop pass, per received frame and per received wire byte. The
    /// frame figure is that of a steady-state batch (`lines_per_frame` short lines, the batches
    /// `gantry stream` sends while nothing is retransmitted), its lines' own share included.
    pub link_pass: u64,
    pub link_frame: u64,
    pub link_byte: u64,
    /// Per short streamed line all told, with its wire bytes, the lines a frame carried and the
    /// lines a pass took.
    pub link_line: u64,
    pub line_bytes: u64,
    pub lines_per_frame: u64,
    pub lines_per_pass: u64,
}

/// The STM32F411's figures, from the last `scripts/bench-mcu.sh` run.
pub const F411_MEASURED: Measured = include!("cpu_model_f411.rs");

/// The axis counts [`Measured::step_event`] and [`Measured::kernel_tick`] were measured at.
const MEASURED_AXES: [u64; 3] = [1, 3, 6];

impl Measured {
    /// Instructions of preparing one segment, jerk-limited or not.
    pub fn segment(&self, jerk: bool) -> u64 {
        if jerk {
            self.prepare_jerk_segment
        } else {
            self.prepare_segment
        }
    }

    /// Cycles of one step interrupt that stepped `axes` axes (at least one): the measured
    /// instructions (one per cycle), linear between the measured axis counts, plus entry and exit.
    pub fn step_event_cycles(&self, axes: u32) -> u64 {
        let n = u64::from(axes.clamp(1, 6));
        let [a1, a3, a6] = MEASURED_AXES;
        let [e1, e3, e6] = self.step_event;
        let (lo_n, lo, hi_n, hi) = if n <= a3 {
            (a1, e1, a3, e3)
        } else {
            (a3, e3, a6, e6)
        };
        let body = lo + (hi.saturating_sub(lo) * (n - lo_n) + (hi_n - lo_n) / 2) / (hi_n - lo_n);
        body + self.step_entry_exit_cycles
    }

    /// Instructions of one short streamed line on the board: link, interpret, plan, prepare.
    pub fn short_line(&self) -> u64 {
        self.link_line + self.interpret_line + self.plan_block + self.prepare_segment
    }
}

/// Instructions per unit of main-loop and interrupt work, and the clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CpuModel {
    /// What `--cpu-model` calls it.
    pub name: &'static str,
    /// Core clock, Hz.
    pub hz: u64,
    /// The benchmarks' figures.
    pub figures: Measured,
}

impl CpuModel {
    /// The Black Pill's STM32F411 at 96 MHz.
    pub const F411: CpuModel = CpuModel {
        name: "f411",
        hz: 96_000_000,
        figures: F411_MEASURED,
    };

    /// The models `--cpu-model` accepts.
    pub const ALL: [CpuModel; 1] = [CpuModel::F411];

    /// The model called `name` (case-insensitive).
    pub fn named(name: &str) -> Option<CpuModel> {
        Self::ALL
            .into_iter()
            .find(|m| m.name.eq_ignore_ascii_case(name))
    }

    /// Cycles of one step event that stepped the axes in `step` (bit per axis).
    pub fn tick(&self, step: u8) -> u64 {
        self.figures.step_event_cycles(step.count_ones())
    }

    /// Instructions of a main-loop pass that did `work`.
    pub fn pass(&self, work: &PassWork) -> u64 {
        let f = &self.figures;
        f.link_pass
            + work.frames * f.link_frame
            + work.bytes * f.link_byte
            + work.lines * f.interpret_line
            + work.blocks * f.plan_block
            + work.segments * f.segment(work.jerk)
    }
}

/// What one main-loop pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassWork {
    /// Frames and bytes received from the host.
    pub frames: u64,
    pub bytes: u64,
    pub lines: u64,
    pub blocks: u64,
    pub segments: u64,
    /// Whether the segments were jerk-limited ones.
    pub jerk: bool,
}

/// Markers around the generated table in firmware/README.md.
pub const TABLE_BEGIN: &str =
    "<!-- bench-mcu: generated by scripts/bench-mcu.sh from emulator/src/cpu_model_f411.rs -->";
pub const TABLE_END: &str = "<!-- bench-mcu: end -->";

/// Thousands separated by commas (`12,345`).
fn grouped(v: u64) -> String {
    let digits = v.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The figures table of firmware/README.md for `model` (markdown, markers excluded).
pub fn figures_table(model: &CpuModel) -> String {
    let f = &model.figures;
    let mhz = model.hz / 1_000_000;
    let per_axes = |v: [u64; 3]| format!("{} / {} / {}", v[0], v[1], v[2]);
    let cycles = MEASURED_AXES.map(|n| f.step_event_cycles(n as u32));
    let khz = cycles.map(|c| model.hz / 1000 / c);
    let line = f.short_line();
    let rows = [
        (
            "step interrupt per step event, 1 / 3 / 6 axes stepping (`bench_step`)".to_owned(),
            per_axes(f.step_event),
            format!(
                "{} cycles with {} entry + exit: at most {} kHz per axis at {mhz} MHz",
                per_axes(cycles),
                f.step_entry_exit_cycles,
                per_axes(khz)
            ),
        ),
        (
            "step kernel tick alone, 1 / 3 / 6 axes (`bench_motion`)".to_owned(),
            per_axes(f.kernel_tick),
            "part of the step interrupt's figures".to_owned(),
        ),
        (
            "short G1 line: interpret (lex, parse, execute; `bench_motion`)".to_owned(),
            grouped(f.interpret_line),
            "`G1 X-99.893 Y-6.789 F3000`, 0.1 mm".to_owned(),
        ),
        (
            "short G1 line: plan its block".to_owned(),
            grouped(f.plan_block),
            String::new(),
        ),
        (
            "short G1 line: prepare its segment".to_owned(),
            grouped(f.prepare_segment),
            "a short block is one segment".to_owned(),
        ),
        (
            "short G1 line, jerk-limited (5,000 mm/s³): prepare a segment".to_owned(),
            grouped(f.prepare_jerk_segment),
            "two segments a line (`motion/prep/jerk_line.rs`)".to_owned(),
        ),
        (
            "short G1 line: the board's link (`bench_link`)".to_owned(),
            grouped(f.link_line),
            format!(
                "{} wire bytes, {} lines a frame, {} lines per pass: {} per pass + {} per frame + {} per byte",
                f.line_bytes,
                f.lines_per_frame,
                f.lines_per_pass,
                grouped(f.link_pass),
                grouped(f.link_frame),
                f.link_byte
            ),
        ),
        (
            "**short G1 line, all told**".to_owned(),
            format!("**{}**", grouped(line)),
            format!(
                "{} lines/s at {mhz} MHz with the whole CPU",
                grouped(model.hz / line)
            ),
        ),
    ];
    let mut out = String::from("| work | instructions | notes |\n|---|---:|---|\n");
    for (what, n, notes) in rows {
        out.push_str(&format!("| {what} | {n} | {notes} |\n"));
    }
    out
}

/// `readme` with the text between [`TABLE_BEGIN`] and [`TABLE_END`] replaced by `table`;
/// `None` when the markers are missing.
pub fn with_figures_table(readme: &str, table: &str) -> Option<String> {
    let begin = readme.find(TABLE_BEGIN)? + TABLE_BEGIN.len();
    let end = begin + readme[begin..].find(TABLE_END)?;
    Some(format!("{}\n{}{}", &readme[..begin], table, &readme[end..]))
}

/// The model's running state on an emulated board.
#[derive(Clone, Debug)]
pub struct CpuMeter {
    pub model: CpuModel,
    /// Step interrupt cycles since the last pass started.
    isr_cycles: u64,
    /// Frames (delimiters) and bytes received from the host since the last pass ended.
    rx_frames: u64,
    rx_bytes: u64,
    /// Virtual time (kernel timer counts) the last pass started.
    last_pass_at: u64,
    /// Highest planner block sequence number seen.
    last_seq: Option<u32>,
    /// Source line of the newest block seen (a line's blocks count as one interpreted line).
    last_line: u32,
    /// Segments handed out in the pass running now, and whether the board prepares them
    /// jerk-limited (as of the last pass).
    pub segments: u64,
    jerk: bool,
    /// Main-loop instructions so far, and the passes that took longer than 1 ms.
    pub instructions: u64,
    pub long_passes: u64,
}

impl CpuMeter {
    pub fn new(model: CpuModel) -> Self {
        CpuMeter {
            model,
            isr_cycles: 0,
            rx_frames: 0,
            rx_bytes: 0,
            last_pass_at: 0,
            last_seq: None,
            last_line: 0,
            segments: 0,
            jerk: false,
            instructions: 0,
            long_passes: 0,
        }
    }

    /// The kernel ticked (one step interrupt), stepping the axes in `step`.
    pub fn on_tick(&mut self, step: u8) {
        self.isr_cycles += self.model.tick(step);
    }

    /// The main loop read `bytes` from the host (a frame ends at each 0x00).
    pub fn on_received(&mut self, bytes: &[u8]) {
        self.rx_bytes += bytes.len() as u64;
        self.rx_frames += bytes.iter().filter(|&&b| b == 0).count() as u64;
    }

    /// Blocks planned and lines interpreted since the last look at the planner: blocks newer
    /// than the newest seen (by sequence number), lines counted where the source line changes;
    /// blocks planned and finished between two looks count one line each.
    fn planned(&mut self, board: &Board) -> (u64, u64) {
        let planner = board.motion().planner();
        let Some(tail) = planner.len().checked_sub(1).and_then(|i| planner.get(i)) else {
            return (0, 0);
        };
        let new = match self.last_seq {
            Some(s) => u64::from(tail.seq.wrapping_sub(s)).min(1 << 20),
            None => planner.len() as u64,
        };
        let mut lines = 0;
        let in_ring = (new as usize).min(planner.len());
        for i in planner.len() - in_ring..planner.len() {
            if let Some(b) = planner.get(i) {
                if b.line != self.last_line {
                    lines += 1;
                    self.last_line = b.line;
                }
            }
        }
        lines += new - in_ring as u64;
        self.last_seq = Some(tail.seq);
        (new, lines)
    }

    /// Kernel timer counts of preparing one segment, the CPU's whole attention on it.
    pub fn segment_counts(&self, timer_hz: u64) -> u64 {
        (self.model.figures.segment(self.jerk) * timer_hz).div_ceil(self.model.hz)
    }

    /// A pass started at `start` (kernel timer counts) and did its work on `board`: returns its
    /// duration in kernel timer counts.
    pub fn pass_done(&mut self, board: &Board, start: u64, timer_hz: u64) -> u64 {
        let (blocks, lines) = self.planned(board);
        self.jerk = JerkSetup::of(board.motion().config()).is_some();
        let work = PassWork {
            frames: core::mem::take(&mut self.rx_frames),
            bytes: core::mem::take(&mut self.rx_bytes),
            lines,
            blocks,
            segments: core::mem::take(&mut self.segments),
            jerk: self.jerk,
        };
        let instructions = self.model.pass(&work);
        self.instructions += instructions;
        // The step interrupt's share of the CPU since the last pass.
        let interval = start.saturating_sub(self.last_pass_at).max(1);
        let isr_capacity = interval as u128 * self.model.hz as u128 / timer_hz as u128;
        let isr_permille = (core::mem::take(&mut self.isr_cycles) as u128 * 1000
            / isr_capacity.max(1))
        .min(900) as u64;
        self.last_pass_at = start;
        let counts = instructions as u128 * timer_hz as u128 * 1000
            / (self.model.hz as u128 * (1000 - isr_permille) as u128);
        if counts > timer_hz as u128 / 1000 {
            self.long_passes += 1;
        }
        counts as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_f411_model_charges_the_measured_figures() {
        let m = CpuModel::named("F411").unwrap();
        let f = F411_MEASURED;
        assert_eq!(m.figures, f);
        // A step event: the interrupt's instructions plus entry and exit, between the measured
        // axis counts linearly.
        assert_eq!(
            [m.tick(0b1), m.tick(0b111), m.tick(0b11_1111)],
            [0, 1, 2].map(|i| f.step_event[i] + f.step_entry_exit_cycles)
        );
        assert_eq!(m.tick(0), m.tick(0b1));
        let two = m.tick(0b11) - f.step_entry_exit_cycles;
        assert_eq!(two, (f.step_event[0] + f.step_event[1]).div_ceil(2));
        // One short G1 line in a pass of its own: the pass, its frame and bytes, the G-code work.
        let line = PassWork {
            frames: 1,
            bytes: 43,
            lines: 1,
            blocks: 1,
            segments: 1,
            jerk: false,
        };
        assert_eq!(
            m.pass(&PassWork { jerk: true, ..line }) - m.pass(&line),
            f.prepare_jerk_segment - f.prepare_segment
        );
        assert_eq!(
            m.pass(&line),
            f.link_pass
                + f.link_frame
                + 43 * f.link_byte
                + f.interpret_line
                + f.plan_block
                + f.prepare_segment
        );
        assert_eq!(m.pass(&PassWork::default()), f.link_pass);
        assert!(CpuModel::named("f446").is_none());
    }

    #[test]
    fn received_frames_are_counted_at_their_delimiters() {
        let mut meter = CpuMeter::new(CpuModel::F411);
        meter.on_received(&[3, 1, 2, 0, 5, 1]);
        meter.on_received(&[1, 1, 0]);
        assert_eq!((meter.rx_frames, meter.rx_bytes), (2, 9));
    }

    #[test]
    fn grouped_thousands() {
        assert_eq!(
            [0, 999, 1_000, 12_345, 1_234_567].map(grouped),
            ["0", "999", "1,000", "12,345", "1,234,567"]
        );
    }

    /// firmware/README.md's figures table is the one `cpu_model_f411.rs` gives (both written by
    /// scripts/bench-mcu.sh; a hand edit of either fails here).
    #[test]
    fn readme_table_is_the_generated_one() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware/README.md");
        let readme = std::fs::read_to_string(path).unwrap();
        let expected = with_figures_table(&readme, &figures_table(&CpuModel::F411))
            .expect("firmware/README.md has the bench-mcu markers");
        assert!(
            readme == expected,
            "firmware/README.md's figures table differs from emulator/src/cpu_model_f411.rs: run scripts/bench-mcu.sh"
        );
    }

    #[test]
    fn the_table_goes_between_the_markers() {
        let doc = format!("a\n{TABLE_BEGIN}\nold\n{TABLE_END}\nb\n");
        assert_eq!(
            with_figures_table(&doc, "new\n").unwrap(),
            format!("a\n{TABLE_BEGIN}\nnew\n{TABLE_END}\nb\n")
        );
        assert_eq!(with_figures_table("no markers", "new"), None);
    }
}
