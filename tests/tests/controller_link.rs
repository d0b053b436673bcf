//! The controller seen over the real protocol: a streamed job that runs into a limit switch
//! ends with alarm 1 at the sender, and the status reports the alarm state, the stopped position,
//! the homed flags and the input levels.

mod controller_support;

use controller_support::*;
use gantry_machine::board::AlarmCode;
use gantry_proto::MachineState;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{stream_program, BoardAlarm, Flow};

#[test]
fn a_streamed_job_into_a_limit_switch_ends_with_alarm_1_at_the_sender() {
    let mut eb = board(|s| s.inputs.limit_max = 0b001);
    eb.add_switch(0, true, 40 * MM);
    let mut client = Client::connect(eb, 2000).unwrap();
    let program = Program::from_text("G21 G90\nG0 X20\nG1 X60 F2000\nG0 X0\nM30\n");
    let report = stream_program(&mut client, &program, &mut |_| Flow::Continue).unwrap();
    assert!(!report.completed);
    // The limit report names the axis and side; alarm 1 carries the line that ran into it.
    assert_eq!(report.limits, vec![(0, true)]);
    assert_eq!(
        report.alarms,
        vec![BoardAlarm {
            code: AlarmCode::HardLimit as u16,
            line: 3
        }]
    );
    assert_eq!(
        report.alarms[0].describe(&program),
        "line 3: alarm 1 (hard limit): a limit switch stopped the machine; the job ended; rehome the tripped axis\n    G1 X60 F2000"
    );
    let status = report.final_status.unwrap();
    assert_eq!(status.state, MachineState::Alarm { code: 1 });
    // The switch step, then the two steps the interrupt had prepared (as on the board).
    assert_eq!(status.machine_pos[0], 40 * MM + AHEAD * MM / STEPS_PER_MM);
    assert_eq!(status.homed, 0);
    // The switch is still pressed: the inputs word shows the X max bit.
    assert_ne!(status.inputs & (1 << 22), 0);
    assert_eq!(
        client.transport.isr.kernel.position()[0],
        40 * STEPS_PER_MM + AHEAD
    );
}
