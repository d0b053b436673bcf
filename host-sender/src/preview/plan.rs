//! Planner figures for the preview: runs the core's motion pipeline on virtual time
//! (`gantry_machine::motion::sim`) and puts each move's planned peak speed and the job's total time
//! into a [`PreviewJob`].
//!
//! The planner reports per block (arcs are cut into chords), tagged with the source line; a move
//! takes the highest peak of the feed blocks of its line.

use super::model::{MoveKind, PreviewJob, SpeedSource};
use gantry_machine::canon::Canon;
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::kernel::KERNEL_TIMER_HZ;
use gantry_machine::motion::sim::{Sim, SimEvent};
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

/// Plans `canon` with the machine `setup` on virtual time.
pub fn plan(canon: &[Canon], setup: &Setup) -> anyhow::Result<Plan> {
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
    sim.run(canon.iter().copied(), &mut on)
        .map_err(|(c, e)| anyhow::anyhow!("line {}: planner refused the move: {e:?}", c.line))?;
    Ok(Plan {
        peak_mm_min,
        total_time_s: sim.now as f64 / KERNEL_TIMER_HZ as f64,
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
