//! `gantry jog` and `gantry home` over the real protocol: the link carries jog and homing
//! requests to the board, and Mark presses back to the host.

use gantry_emulator::emulated_with_switches;
use gantry_machine::setup::Setup;
use gantry_proto::{BoardMsg, HostMsg, Jog, MachineState};
use host_sender::link::Client;
use host_sender::session::fresh_status;
use host_sender::setup_file::SetupFile;

#[test]
fn a_host_jog_moves_exactly_the_distance() {
    let board = gantry_emulator::EmulatedBoard::new(Setup::default());
    let mut client = Client::connect(board, 2000).unwrap();
    client
        .send(HostMsg::Jog(Jog {
            id: 1,
            axis: 1,
            feed_um_min: -1_200_000,
            distance_nm: 12_500_000,
        }))
        .unwrap();
    client.pump(3000).unwrap();
    let s = fresh_status(&mut client).unwrap();
    assert_eq!(s.state, MachineState::Idle);
    assert_eq!(s.machine_pos[1], -12_500_000);
    // 12.5 mm at 3200 steps / 5 mm.
    assert_eq!(client.transport.isr.kernel.position()[1], -8000);
}

#[test]
fn homing_over_the_link_seeks_retracts_and_sets_home() {
    let setup = SetupFile::parse(
        "[inputs]\nlimits_min = [\"X\"]\n[homing.axis.X]\npriority = 1\nseek_rate = 600.0\nretract = 2.0\nhome_position = 5.0\n",
    )
    .unwrap();
    let mut client = Client::connect(emulated_with_switches(setup), 2000).unwrap();
    client.send(HostMsg::Home { id: 1, axes: 0 }).unwrap();
    let mut s = fresh_status(&mut client).unwrap();
    for _ in 0..1000 {
        if s.state != MachineState::Homing {
            break;
        }
        client.pump(100).unwrap();
        s = fresh_status(&mut client).unwrap();
    }
    assert_eq!(s.state, MachineState::Idle);
    assert_eq!(s.homed & 1, 1);
    assert_eq!(s.machine_pos[0], 5_000_000);
    let mut saw_alarm = false;
    while let Some(m) = client.recv() {
        saw_alarm |= matches!(m, BoardMsg::Alarm { .. });
    }
    assert!(!saw_alarm, "homing onto its own switch raises no alarm");
}

#[test]
fn a_joystick_mark_reaches_the_host() {
    use gantry_machine::board::inputs::Signal;
    let mut s = Setup::default();
    s.inputs.debounce_ms = 1;
    let mut client = Client::connect(gantry_emulator::EmulatedBoard::new(s), 2000).unwrap();
    let press = |c: &mut Client<gantry_emulator::EmulatedBoard>, sig: Signal, on: bool| {
        c.transport.set_pin(sig as u32, on)
    };
    // Mark + Release together enter joystick jog; Mark alone is a teach-in mark.
    press(&mut client, Signal::Mark, true);
    press(&mut client, Signal::Release, true);
    client.pump(3).unwrap();
    press(&mut client, Signal::Mark, false);
    press(&mut client, Signal::Release, false);
    client.pump(3).unwrap();
    press(&mut client, Signal::Mark, true);
    client.pump(3).unwrap();
    press(&mut client, Signal::Mark, false);
    let mut marks = Vec::new();
    for _ in 0..50 {
        client.pump(1).unwrap();
        while let Some(m) = client.recv() {
            if let BoardMsg::Mark { id, .. } = m {
                marks.push(id);
            }
        }
    }
    assert_eq!(marks, vec![1]);
}
