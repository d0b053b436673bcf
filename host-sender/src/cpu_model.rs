//! The emulated board's CPU model (`gantry stream --cpu-model f411`, `gantry emulate --cpu-model
//! f411`): each main-loop pass costs the Cortex-M4 instructions its work would take on the MCU,
//! so the emulated board's segment queue runs dry when the real board's would.
//!
//! Without a model the emulated board runs a whole main-loop pass in no time, every virtual
//! millisecond. With one, a pass that interprets `l` lines, plans `b` blocks and prepares `s`
//! segments takes `l·line + b·block + s·segment` instructions at the MCU clock, stretched by the
//! share of the CPU the step interrupt took since the previous pass (each kernel tick costs
//! `tick_base + tick_axis·(axes stepping)`); the segments it prepared reach the kernel's queue
//! only when the pass ends, and the next pass starts 1 ms after the previous one or when it
//! ends, whichever is later (the firmware's control task, `firmware/src/control.rs`, runs the
//! pass every millisecond and cannot start one before the last has finished).
//!
//! The figures of [`CpuModel::F411`] come from `target-tests/src/bin/bench_motion.rs` under QEMU
//! (`-icount shift=0`, one instruction per virtual ns): see that file and firmware/README.md for
//! how they are taken.

use gantry_machine::board::Board;

/// Instructions per unit of main-loop and interrupt work, and the clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CpuModel {
    /// What `--cpu-model` calls it.
    pub name: &'static str,
    /// Core clock, Hz.
    pub hz: u64,
    /// Interpreting one line that makes a move (a short G1).
    pub line: u64,
    /// Planning one block (the look-ahead's share of `bench_motion`'s "plan + prep").
    pub block: u64,
    /// Preparing one segment.
    pub segment: u64,
    /// One step-kernel tick: `tick_base + tick_axis × axes stepping` (at least one axis).
    pub tick_base: u64,
    pub tick_axis: u64,
}

impl CpuModel {
    /// The Black Pill's STM32F411 at 96 MHz. `bench_motion` (re-measured 2026-11-25, round 2
    /// session 5): 39 / 67 / 108 instructions per kernel tick for 1 / 3 / 6 axes (fitted as
    /// 23 + 14 per axis, plus the loop's own); a short G1 line streamed the board's way
    /// (`G1 Y-6.789 F3000`, 0.1 mm, one segment): 3,740 to interpret
    /// (`Interpreter::next` from a `StreamSource`: 2,026 lex + parse, 1,716 execute), 3,300 to
    /// plan (`Motion::push`) and 1,760 to prepare its segment (a short block is one segment: a
    /// remainder of less than half a segment joins the one before, machine/src/motion/prep.rs).
    pub const F411: CpuModel = CpuModel {
        name: "f411",
        hz: 96_000_000,
        line: 3_740,
        block: 3_300,
        segment: 1_760,
        tick_base: 23,
        tick_axis: 14,
    };

    /// The models `--cpu-model` accepts.
    pub const ALL: [CpuModel; 1] = [CpuModel::F411];

    /// The model called `name` (case-insensitive).
    pub fn named(name: &str) -> Option<CpuModel> {
        Self::ALL
            .into_iter()
            .find(|m| m.name.eq_ignore_ascii_case(name))
    }

    /// Instructions of one kernel tick that stepped the axes in `step` (bit per axis).
    pub fn tick(&self, step: u8) -> u64 {
        self.tick_base + self.tick_axis * u64::from(step.count_ones().max(1))
    }

    /// Instructions of a main-loop pass that did `work`.
    pub fn pass(&self, work: &PassWork) -> u64 {
        work.lines * self.line + work.blocks * self.block + work.segments * self.segment
    }
}

/// What one main-loop pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassWork {
    pub lines: u64,
    pub blocks: u64,
    pub segments: u64,
}

/// The model's running state on an emulated board.
#[derive(Clone, Debug)]
pub struct CpuMeter {
    pub model: CpuModel,
    /// Tick instructions since the last pass started.
    tick_instructions: u64,
    /// Virtual time (kernel timer counts) the last pass started.
    last_pass_at: u64,
    /// Highest planner block sequence number seen.
    last_seq: Option<u32>,
    /// Source line of the newest block seen (a line's blocks count as one interpreted line).
    last_line: u32,
    /// Segments handed out in the pass running now.
    pub segments: u64,
    /// Main-loop instructions so far, and the passes that took longer than 1 ms.
    pub instructions: u64,
    pub long_passes: u64,
}

impl CpuMeter {
    pub fn new(model: CpuModel) -> Self {
        CpuMeter {
            model,
            tick_instructions: 0,
            last_pass_at: 0,
            last_seq: None,
            last_line: 0,
            segments: 0,
            instructions: 0,
            long_passes: 0,
        }
    }

    /// The kernel ticked, stepping the axes in `step`.
    pub fn on_tick(&mut self, step: u8) {
        self.tick_instructions += self.model.tick(step);
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

    /// A pass started at `start` (kernel timer counts) and did its work on `board`: returns its
    /// duration in kernel timer counts.
    pub fn pass_done(&mut self, board: &Board, start: u64, timer_hz: u64) -> u64 {
        let (blocks, lines) = self.planned(board);
        let work = PassWork {
            lines,
            blocks,
            segments: core::mem::take(&mut self.segments),
        };
        let instructions = self.model.pass(&work);
        self.instructions += instructions;
        // The step interrupt's share of the CPU since the last pass.
        let interval = start.saturating_sub(self.last_pass_at).max(1);
        let isr_capacity = interval as u128 * self.model.hz as u128 / timer_hz as u128;
        let isr_permille = (core::mem::take(&mut self.tick_instructions) as u128 * 1000
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
    fn the_f411_model_matches_the_benchmarks() {
        let m = CpuModel::named("F411").unwrap();
        assert_eq!(
            [m.tick(0b1), m.tick(0b111), m.tick(0b11_1111)],
            [37, 65, 107]
        );
        // One short G1 line, planned and prepared as one segment: 3,740 + 3,300 + 1,760.
        let line = PassWork {
            lines: 1,
            blocks: 1,
            segments: 1,
        };
        assert_eq!(m.pass(&line), 8_800);
        // ≈ 10,900 such lines per second at 100 % of the CPU.
        assert_eq!(m.hz / m.pass(&line), 10_909);
        assert!(CpuModel::named("f446").is_none());
    }
}
