//! Planner figures for the preview: runs the core's motion pipeline on virtual time
//! (`gantry_machine::motion::sim`) and puts each move's planned peak speed and the job's total time
//! into a [`PreviewJob`].
//!
//! The planner reports per block (arcs are cut into chords), tagged with the source line; a move
//! takes the highest peak of the feed blocks of its line.

use super::model::{MoveKind, PreviewJob, SpeedSource};
use gantry_machine::canon::{Action, Canon};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::kernel::KERNEL_TIMER_HZ;
use gantry_machine::motion::sim::{Feeder, Sim, SimEvent};
use gantry_machine::setup::Setup;
use gantry_machine::units::NM_PER_MM;
use std::collections::HashMap;

/// Look-ahead ring size used for the preview (as on the board, `motion::pipeline`).
const RING: usize = 128;

/// Planned peak speed (mm/min) per source line, and the total time (s), of a program.
pub struct Plan {
    pub peak_mm_min: HashMap<u32, f64>,
    pub total_time_s: f64,
}

/// `canon` with every dwell shortened to zero, and the dwell time taken out (kernel timer counts,
/// exactly what the board's prep would count: `motion/pipeline.rs`). A zero dwell is still a
/// stop for the planner, so the motion planned is unchanged; the time is added back in closed
/// form instead of being stepped through by the simulation, whose work would otherwise grow
/// with the dwell time (`G4 P1000`).
pub fn without_dwell_time(canon: &[Canon]) -> (Vec<Canon>, u64) {
    let counts_per_us = u64::from(KERNEL_TIMER_HZ / 1_000_000);
    let mut dwell_counts = 0u64;
    let out = canon
        .iter()
        .map(|c| match c.action {
            Action::Dwell { micros } => {
                dwell_counts = dwell_counts.saturating_add(micros.saturating_mul(counts_per_us));
                Canon {
                    action: Action::Dwell { micros: 0 },
                    ..*c
                }
            }
            _ => *c,
        })
        .collect();
    (out, dwell_counts)
}

/// Runs `program` through `sim`'s planner and segment prep like [`Sim::run`], but adds each
/// segment's duration (`ticks × period`) to `sim.now` instead of stepping the kernel through it,
/// so the work grows with the number of segments, not with the steps (deep peck cycles).
/// Sync points are released at once; nothing waits on a real kernel.
pub fn run_segments<const N: usize>(
    sim: &mut Sim<N>,
    program: impl IntoIterator<Item = Canon>,
    on: &mut impl FnMut(SimEvent),
) -> Result<(), (Canon, gantry_machine::motion::pipeline::PushError)> {
    let mut feeder = Feeder::new(program.into_iter());
    loop {
        feeder.feed(sim)?;
        let exhausted = feeder.exhausted();
        let seg = sim.motion.next_segment();
        if let Some(report) = sim.motion.take_report() {
            on(SimEvent::Block {
                report,
                time: sim.now,
            });
        }
        match seg {
            Some(s) => sim.now += s.duration(),
            None => {
                if let Some(canon) = sim.motion.sync_point().copied() {
                    on(SimEvent::Sync {
                        canon,
                        time: sim.now,
                    });
                    sim.motion.release_sync();
                } else if exhausted && !sim.motion.output_pending() {
                    return Ok(());
                }
            }
        }
    }
}

/// Plans `canon` with the machine `setup` on virtual time.
pub fn plan(canon: &[Canon], setup: &Setup) -> anyhow::Result<Plan> {
    let (canon, dwell_counts) = without_dwell_time(canon);
    let mut sim: Sim<RING> = Sim::new(MotionConfig::from_setup(setup));
    let mut peak_mm_min: HashMap<u32, f64> = HashMap::new();
    let mut on = |e: SimEvent| {
        if let SimEvent::Block { report, .. } = e {
            if !report.rapid && report.length > 0 {
                // nm/s → mm/min.
                let v = report.peak as f64 * 60.0 / NM_PER_MM as f64;
                let e = peak_mm_min.entry(report.line).or_insert(0.0);
                *e = e.max(v);
            }
        }
    };
    run_segments(&mut sim, canon.iter().copied(), &mut on)
        .map_err(|(c, e)| anyhow::anyhow!("line {}: planner refused the move: {e:?}", c.line))?;
    Ok(Plan {
        peak_mm_min,
        total_time_s: (sim.now + dwell_counts) as f64 / KERNEL_TIMER_HZ as f64,
    })
}

/// Replaces the programmed feeds and the estimated time of `job` by the planned figures.
pub fn apply(job: &mut PreviewJob, plan: &Plan) {
    for m in job.moves.iter_mut().filter(|m| m.kind != MoveKind::Rapid) {
        if let Some(v) = plan.peak_mm_min.get(&m.line) {
            m.speed_mm_min = Some(*v);
        }
    }
    job.total_time_s = Some(plan.total_time_s);
    job.speed_source = SpeedSource::Planned;
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let (simulated, counts) = without_dwell_time(&canon(&program));
        // Nothing left for the simulation to step through...
        assert!(simulated
            .iter()
            .all(|c| matches!(c.action, Action::Dwell { micros: 0 })));
        assert_eq!(counts, 2000 * 60 * u64::from(KERNEL_TIMER_HZ));
        // ...and the plan still takes the full 2,000 minutes.
        let p = plan(&canon(&program), &Setup::default()).unwrap();
        assert_eq!(p.total_time_s, 120_000.0);
    }

    #[test]
    fn adding_segment_durations_gives_the_stepped_time_and_reports() {
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
        let mut fast: Box<Sim<RING>> = Box::new(Sim::new(cfg));
        let mut fast_reports = Vec::new();
        run_segments(&mut *fast, actions.iter().copied(), &mut |e| {
            if let SimEvent::Block { report, .. } = e {
                fast_reports.push(report);
            }
        })
        .unwrap();
        assert!(stepped.now > 0);
        assert_eq!(fast.now, stepped.now);
        assert_eq!(fast_reports, stepped_reports);
        // No step events: the kernel never ran.
        assert_eq!(fast.kernel.position(), [0; gantry_machine::units::MAX_AXES]);
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
