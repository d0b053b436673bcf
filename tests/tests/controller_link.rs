//! The controller seen over the real protocol: a streamed job that runs into a limit switch
//! ends with alarm 1 at the sender, and the status reports the alarm state, the stopped position,
//! the homed flags and the input levels.

mod controller_support;

use controller_support::*;
use gantry_machine::controller::AlarmCode;
use gantry_proto::MachineState;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::stream::{stream_program, Flow};

#[test]
fn a_streamed_job_into_a_limit_switch_ends_with_alarm_1_at_the_sender() {
    let mut eb = board(|s| s.inputs.limit_max = 0b001);
    eb.add_switch(0, true, 40 * MM);
    let mut client = Client::connect(eb, 2000).unwrap();
    let program = Program::from_text("G21 G90\nG0 X20\nG1 X60 F2000\nG0 X0\nM30\n");
    let report = stream_program(&mut client, &program, &mut |_| Flow::Continue).unwrap();
    assert!(!report.completed);
    assert_eq!(report.alarms, vec![AlarmCode::HardLimit as u16]);
    let status = report.final_status.unwrap();
    assert_eq!(status.state, MachineState::Alarm);
    assert_eq!(status.machine_pos[0], 40 * MM);
    assert_eq!(status.homed, 0);
    // The switch is still pressed: the inputs word shows the X max bit.
    assert_ne!(status.inputs & (1 << 22), 0);
    assert_eq!(client.transport.kernel.position()[0], 40 * STEPS_PER_MM);
}
