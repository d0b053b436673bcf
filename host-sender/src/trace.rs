//! `gantry simulate FILE --vcd out.vcd`: run the job on the emulated board and record its step,
//! direction, enable, input and user output pins as a VCD trace (GTKWave, PulseView), and in
//! laser mode the laser PWM duty (`laser_pwm`).

use crate::link::Client;
use crate::program::Program;
use crate::session::stream_program;
use crate::vcd::{counts_to_ns, VcdEvent, VcdOptions, VcdSummary, VcdWriter};
use anyhow::Context;
use gantry_emulator::{EmulatedBoard, PinEvent};
use gantry_machine::board::inputs::INPUT_NAMES;
use gantry_machine::setup::{Setup, USER_OUTPUTS};
use gantry_machine::step::kernel::{StepTiming, KERNEL_TIMER_HZ};
use std::cell::RefCell;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::rc::Rc;

/// What a traced run produced.
pub struct TraceResult {
    pub summary: VcdSummary,
    /// Step pulses the emulated board counted per axis (must equal the trace's rising edges when
    /// no window is set).
    pub pulses: [u64; 6],
    pub completed: bool,
}

/// Streams `program` to an emulated board and writes its pins to `out`.
pub fn trace(
    program: &Program,
    setup: Setup,
    out: &Path,
    from_ns: Option<u64>,
    to_ns: Option<u64>,
) -> anyhow::Result<TraceResult> {
    let file = File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let opts = VcdOptions {
        axes: setup.axis_count as usize,
        inputs: INPUT_NAMES.iter().map(|s| s.to_string()).collect(),
        outputs: USER_OUTPUTS as usize,
        // The pulse as the step interrupt puts it out: the setup's width in whole timer counts.
        pulse_ns: counts_to_ns(
            u64::from(StepTiming::from_setup(&setup.drivers).pulse),
            KERNEL_TIMER_HZ,
        ),
        laser_pwm: setup.outputs.laser,
        from_ns,
        to_ns,
    };
    let writer = Rc::new(RefCell::new(Some(VcdWriter::new(
        BufWriter::new(file),
        &opts,
    )?)));
    let error: Rc<RefCell<Option<std::io::Error>>> = Rc::default();
    let mut board = EmulatedBoard::new(setup);
    let (w, e) = (writer.clone(), error.clone());
    // Steppers are enabled by the first motion (docs/controller.md, "Safety rules as built") and stay enabled for the job. Input
    // changes come as events without steps.
    let mut enabled = false;
    board.observe(move |p: PinEvent| {
        enabled |= p.step != 0;
        if let Some(wr) = w.borrow_mut().as_mut() {
            let ev = VcdEvent {
                time_ns: counts_to_ns(p.time, KERNEL_TIMER_HZ),
                step: p.step,
                dir: p.dir,
                enable: enabled,
                inputs: p.inputs,
                outputs: p.outputs,
                pwm: p.pwm,
            };
            if let Err(err) = wr.event(ev) {
                e.borrow_mut().get_or_insert(err);
            }
        }
    });
    let mut client = Client::connect(board, 2000)?;
    // A simulation stands for no machine: its M0/M1 and M6 stops are answered at once.
    let mut stops = crate::session::job::ThroughStops::new();
    let report = stream_program(&mut client, program, &mut |p| stops.flow(program, p))?;
    if let Some(err) = error.borrow_mut().take() {
        return Err(err).context("writing the VCD trace");
    }
    let summary = writer
        .borrow_mut()
        .take()
        .expect("the writer is only taken here")
        .finish()?;
    Ok(TraceResult {
        summary,
        pulses: client.transport.pulses,
        completed: report.completed,
    })
}
