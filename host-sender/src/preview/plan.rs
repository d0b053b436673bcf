//! Planner figures for the preview, `gantry check` and `gantry simulate`: runs the core's motion
//! pipeline on virtual time, each planned block timed in closed form
//! ([`gantry_machine::motion::sim::Sim::run_planned`]: the profile the board runs, without cutting
//! it into segments or stepping it), and reports each finished block with the time it ends and
//! the job's total time. The planner reports per block (arcs are cut into chords), tagged with the
//! source line (`preview/pass.rs` gives each move the highest peak of its line's feed blocks).

use gantry_machine::canon::Canon;
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::PushError;
use gantry_machine::motion::prep::BlockReport;
use gantry_machine::motion::sim::{Sim, SimEvent};
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use gantry_machine::units::{Pos, MAX_AXES};

/// Look-ahead ring size used for the preview (as on the board, `motion::pipeline`).
const RING: usize = 128;

/// The total time (s) of a program as planned.
#[cfg(test)]
pub(crate) struct Plan {
    pub(crate) total_time_s: f64,
}

/// The virtual machine the planned time is taken on: the setup's motion, and its on-the-fly M
/// codes queued as the board queues them.
pub(crate) fn machine(setup: &Setup) -> Box<Sim<RING>> {
    let mut sim: Box<Sim<RING>> = Box::new(Sim::new(MotionConfig::from_setup(setup)));
    for l in &setup.outputs.mcode_lists {
        if let Some(output) = l.on_the_fly() {
            let _ = sim.on_the_fly.push((l.code, output));
        }
    }
    sim
}

/// Plans `program` (pulled one action at a time, so nothing is held) on the `setup` machine and
/// calls `on_block` with every block the planner finished and the time it ends (kernel timer
/// counts from the start); returns the total time in kernel timer counts (dwells included), or
/// the action the planner refused.
pub(crate) fn plan_stream(
    program: impl IntoIterator<Item = Canon>,
    setup: &Setup,
    on_block: &mut impl FnMut(&BlockReport, u64),
) -> Result<u64, (Canon, PushError)> {
    plan_stream_from(program, setup, &[0; MAX_AXES], on_block)
}

/// [`plan_stream`] with the machine standing at `at` (nm) when the program starts.
pub(crate) fn plan_stream_from(
    program: impl IntoIterator<Item = Canon>,
    setup: &Setup,
    at: &Pos,
    on_block: &mut impl FnMut(&BlockReport, u64),
) -> Result<u64, (Canon, PushError)> {
    let mut sim = machine(setup);
    sim.motion.set_position(*at);
    sim.run_planned(program, &mut |e| {
        if let SimEvent::Block { report, time } = e {
            on_block(&report, time);
        }
    })?;
    Ok(sim.now)
}

/// Kernel timer counts → seconds.
pub(crate) fn seconds(counts: u64) -> f64 {
    counts as f64 / KERNEL_TIMER_HZ as f64
}

/// Plans `canon` with the machine `setup` on virtual time: the total time (tests).
#[cfg(test)]
pub(crate) fn plan(canon: &[Canon], setup: &Setup) -> anyhow::Result<Plan> {
    let counts = plan_stream(canon.iter().copied(), setup, &mut |_, _| {})
        .map_err(|(c, e)| anyhow::anyhow!("line {}: planner refused the move: {e:?}", c.line))?;
    Ok(Plan {
        total_time_s: seconds(counts),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use gantry_machine::canon::Action;

    fn canon(program: &str) -> Vec<Canon> {
        let setup = Setup::default();
        let mut interp = gantry_machine::gcode::Interpreter::new(&setup.interp_config());
        let mut src = gantry_machine::gcode::MemorySource::new(program.as_bytes());
        std::iter::from_fn(|| interp.next(&mut src))
            .map(|c| c.unwrap())
            .collect()
    }

    #[test]
    fn dwell_time_is_counted_in_closed_form_not_simulated() {
        let program = "G4 P60\n".repeat(2000);
        assert!(canon(&program)
            .iter()
            .all(|c| matches!(c.action, Action::Dwell { .. })));
        // 2,000 minutes, planned in one step per dwell.
        let p = plan(&canon(&program), &Setup::default()).unwrap();
        assert_eq!(p.total_time_s, 120_000.0);
    }

    #[test]
    fn planned_time_agrees_with_the_stepped_run_and_reports() {
        let program = "G21 G90 F300\nG0 X5 Y5 Z5\nG1 Z-1\nG2 X15 Y5 I5 J0\nM3 S1000\n\
                       G99 G83 X20 Y20 Z-4 R1 Q0.3\nX25\nG80\nG4 P0.2\nG0 Z5\nM0\nG1 X0 Y0\nM30\n";
        let actions = canon(program);
        let cfg = MotionConfig::from_setup(&Setup::default());
        let mut stepped: Box<Sim<RING>> = Box::new(Sim::new(cfg));
        let mut stepped_reports = Vec::new();
        stepped
            .run(actions.iter().copied(), &mut |e| {
                if let SimEvent::Block { report, .. } = e {
                    stepped_reports.push(report);
                }
            })
            .unwrap();
        let mut planned_reports = Vec::new();
        let planned = plan_stream(actions.iter().copied(), &Setup::default(), &mut |r, _| {
            planned_reports.push(*r)
        })
        .unwrap();
        assert!(stepped.now > 0);
        // Within 0.01 % (the closed form does not lose each segment's period rounding).
        assert!(
            planned.abs_diff(stepped.now) * 10_000 <= stepped.now,
            "{planned} {}",
            stepped.now
        );
        assert_eq!(planned_reports.len(), stepped_reports.len());
        for (p, s) in planned_reports.iter().zip(&stepped_reports) {
            assert_eq!((p.line, p.length, p.entry), (s.line, s.length, s.entry));
        }
    }

    #[test]
    fn a_dwell_still_stops_the_motion_between_moves() {
        let with = plan(&canon("G1 X10 F600\nG4 P0.5\nX20\n"), &Setup::default()).unwrap();
        let without = plan(&canon("G1 X10 F600\nX20\n"), &Setup::default()).unwrap();
        // Half a second of dwell plus a stop and a restart the blended path does not have.
        assert!(
            with.total_time_s > without.total_time_s + 0.5,
            "{} {}",
            with.total_time_s,
            without.total_time_s
        );
    }
}
