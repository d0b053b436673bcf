//! The emulated board runs the firmware's main loop (`MainLoop::pass` in
//! machine/src/device/main_loop.rs): where the emulator's own copy used to differ from
//! firmware/src/control.rs, it now does what the board does.
//! - the path speed, and `Hold { stopped }` built from it, come from the 20 ms integer window
//!   (0 once a job has ended and the kernel drained);
//! - a limit stop keeps the kernel latched (stopped, no segments) while the board is in alarm;
//! - the host closing the port (DTR drop) holds a running job;
//! - the segment queue holds the firmware's 15 segments;
//! - a setup from the host is written to flash once, by the pass (the rule settings-store's
//!   `SavePolicy` used to hold for the firmware alone).

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::ERROR_LIMIT_PRESSED;
use gantry_machine::board::{AlarmCode, State};
use gantry_machine::device::link::status_of;
use gantry_machine::device::main_loop::{SpeedMeter, SEGMENT_QUEUE_DEPTH};
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::setup::Setup;
use gantry_proto::MachineState;
use host_sender::link::Client;
use host_sender::session::push_setup_over;

/// 100 mm at 3000 mm/min.
const LONG_CUT: &str = "G21 G90\nG1 X100 F3000\nM30\n";

/// `stopped` of the status the board would send now (None: not in a hold).
fn hold_stopped(eb: &EmulatedBoard) -> Option<bool> {
    match status_of(&eb.board, &eb.kernel_view()).state {
        MachineState::Hold { stopped } => Some(stopped),
        _ => None,
    }
}

#[test]
fn a_hold_reports_stopped_on_the_firmwares_20_ms_speed_window() {
    let mut eb = board(|_| {});
    job(&mut eb, LONG_CUT);
    assert!(eb.run_until(5_000, |b| b.now_ms() == 1000));
    // Cruising: the meter reads the programmed feed (3000 mm/min) to the rounding of a window.
    let feed = eb.kernel_view().feed_um_min;
    assert!((2_990_000..=3_010_000).contains(&feed), "{feed} µm/min");
    eb.board.feed_hold();
    // Pass by pass until the status says stopped.
    let mut first_stopped = None;
    for _ in 0..2_000 {
        eb.run_ms(1);
        let pass_ms = eb.now_ms() - 1;
        assert!(hold_stopped(&eb).is_some());
        if hold_stopped(&eb) == Some(true) {
            first_stopped = Some(pass_ms);
            break;
        }
    }
    let first_stopped = first_stopped.expect("the hold stopped");
    assert_eq!(eb.board.motion().state(), MotionState::Held);
    // The first pass that saw the last step, then the first window boundary whose whole window
    // came after it: windows end every 20 ms of main-loop time.
    let saw_rest = eb.last_step_at / COUNTS_PER_MS + 1;
    let window = u64::from(SpeedMeter::WINDOW_MS);
    let expected = (saw_rest.div_ceil(window) + 1) * window;
    assert_eq!(u64::from(first_stopped), expected);
    // The emulator's old 1 ms pulse count said stopped in the first pass at rest.
    assert!(u64::from(first_stopped) > saw_rest);
    assert_eq!(eb.kernel_view().feed_um_min, 0);
}

#[test]
fn a_job_that_ended_reports_no_feed_in_its_first_idle_status() {
    for feed in [600, 1500, 3000] {
        let mut eb = board(|_| {});
        job(&mut eb, &format!("G21 G90\nG1 X5 F{feed}\nM30\n"));
        assert!(eb.run_until(10_000, |b| b.board.state() == State::Idle));
        // The first status the link can send: from the next pass (link.service runs after the
        // pass has measured the speed; the job ended later in the pass before).
        eb.run_ms(1);
        let status = status_of(&eb.board, &eb.kernel_view());
        assert_eq!(status.state, MachineState::Idle);
        assert_eq!(status.feed_um_min, 0, "F{feed}: the machine is at rest");
    }
}

/// X with a max switch at 10 mm.
fn switch_at_10() -> EmulatedBoard {
    let mut eb = board(|s| s.inputs.limit_max = 0b001);
    eb.add_switch(0, true, 10 * MM);
    eb
}

#[test]
fn a_limit_stop_keeps_the_kernel_latched_until_unlock() {
    let mut eb = switch_at_10();
    job(&mut eb, "G21 G90\nG1 X50 F1200\nM30\n");
    until_state(&mut eb, State::Alarm, 10_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    let at = eb.isr.kernel.position();
    assert_eq!(at[0], 10 * STEPS_PER_MM + AHEAD);
    // In the alarm the kernel stays stopped and gets nothing (the firmware's latch).
    eb.run_ms(500);
    assert!(eb.isr.kernel.is_stopped());
    assert!(eb.kernel_latched());
    assert!(eb.kernel_drained());
    assert_eq!(eb.isr.kernel.position(), at);
    assert_eq!(eb.limit_stops, 1);
    // The switch is still pressed: no unlock (905), the kernel stays latched.
    assert_eq!(eb.board.try_unlock(), Err(ERROR_LIMIT_PRESSED));
    eb.run_ms(1);
    assert!(eb.kernel_latched());
    // A jog off it (the pressed switch is disarmed until it releases) runs from the alarm: the
    // next pass re-arms the kernel; at rest the alarm is back, and the unlock clears it.
    assert!(eb.board.jog(0, -600_000, 2 * MM as u64));
    eb.run_ms(1);
    assert!(!eb.isr.kernel.is_stopped());
    assert!(!eb.kernel_latched());
    until_state(&mut eb, State::Alarm, 5_000);
    assert_eq!(eb.isr.kernel.position()[0], 8 * STEPS_PER_MM + AHEAD);
    assert_eq!(eb.limit_stops, 1);
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Idle);
    eb.run_ms(1);
    assert!(!eb.kernel_latched());
}

#[test]
fn the_host_closing_the_port_holds_a_running_job() {
    let mut eb = board(|_| {});
    job(&mut eb, LONG_CUT);
    eb.run_ms(1000);
    assert_eq!(eb.board.state(), State::Run);
    eb.set_dtr(false);
    eb.run_ms(1);
    assert_eq!(eb.board.state(), State::Hold);
    assert!(eb.board.feed_held());
    assert!(
        eb.run_until(1_000, |b| b.board.motion().state() == MotionState::Held
            && b.kernel_drained())
    );
    let at = eb.isr.kernel.position();
    // Reopening the port does not resume by itself; a cycle start does.
    eb.set_dtr(true);
    eb.run_ms(100);
    assert_eq!(eb.isr.kernel.position(), at);
    assert_eq!(eb.board.state(), State::Hold);
    eb.board.resume();
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 100 * STEPS_PER_MM);
    // Closing the port while idle does nothing.
    eb.set_dtr(false);
    eb.run_ms(5);
    assert_eq!(eb.board.state(), State::Idle);
}

/// Safety: losing the host holds the job on its path with spindle and coolant
/// running while the tool decelerates along the cut, switches them off once at rest, and a host
/// that resumes the job gets them back before the motion goes on.
#[test]
fn a_lost_host_holds_then_switches_spindle_and_coolant_off_at_rest_and_resume_restores_them() {
    let mut eb = board(|_| {});
    job(&mut eb, "G21 G90\nM3 S1000 M8\nG1 X100 F3000\nM30\n");
    eb.run_ms(1000);
    assert_eq!(eb.board.state(), State::Run);
    let on = |eb: &EmulatedBoard| {
        let o = eb.board.outputs();
        (o.spindle != gantry_machine::canon::Spindle::Off, o.flood)
    };
    assert_eq!(on(&eb), (true, true));
    eb.set_dtr(false);
    eb.run_ms(1);
    assert_eq!(eb.board.state(), State::Hold);
    // Decelerating along the cut: the spindle and coolant keep running.
    let mut moved_with_outputs_off = 0;
    let mut last = eb.isr.kernel.position();
    for _ in 0..1000 {
        eb.run_ms(1);
        let p = eb.isr.kernel.position();
        if p != last && on(&eb) != (true, true) {
            moved_with_outputs_off += 1;
        }
        last = p;
        if eb.board.motion().state() == MotionState::Held && eb.kernel_drained() {
            break;
        }
    }
    assert_eq!(moved_with_outputs_off, 0);
    eb.run_ms(2);
    assert_eq!(on(&eb), (false, false), "at rest: spindle and coolant off");
    let at = eb.isr.kernel.position();
    // The host comes back and resumes: outputs first, then the rest of the cut.
    eb.set_dtr(true);
    eb.run_ms(50);
    assert_eq!(eb.isr.kernel.position(), at);
    eb.board.resume();
    eb.run_ms(1);
    assert_eq!(on(&eb), (true, true), "restored on resume");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 100 * STEPS_PER_MM);
}

/// A `gantry` one-shot command closes the port with DTR kept up: a job owned by another sender
/// runs on, outputs untouched.
#[test]
fn a_close_that_keeps_dtr_leaves_a_framed_job_running() {
    let mut eb = board(|_| {});
    job(&mut eb, "G21 G90\nM3 S1000 M8\nG1 X100 F3000\nM30\n");
    eb.run_ms(500);
    eb.close_keeping_dtr();
    eb.run_ms(200);
    assert_eq!(eb.board.state(), State::Run);
    assert!(eb.board.outputs().flood);
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 100 * STEPS_PER_MM);
}

#[test]
fn the_segment_queue_holds_the_firmwares_15_segments() {
    assert_eq!(SEGMENT_QUEUE_DEPTH, 15);
    let mut eb = board(|_| {});
    job(&mut eb, LONG_CUT);
    eb.run_ms(500);
    // Cruising at 3000 mm/min in segments of about 2 ms: the queue is full after the pass.
    let queued = eb.queued_ms();
    assert!((25.0..=32.0).contains(&queued), "{queued} ms queued");
}

#[test]
fn a_setup_from_the_host_is_saved_to_flash_once() {
    let mut client = Client::connect(board(|_| {}), 2000).unwrap();
    assert_eq!(client.transport.setups_saved, 0);
    let mut setup = Setup::default();
    setup.inputs.debounce_ms = 3;
    push_setup_over(&mut client, &setup).unwrap();
    client.transport.run_ms(50);
    assert_eq!(client.transport.board.setup(), &setup);
    // Idle with the kernel drained: written at once, and only once.
    assert_eq!(client.transport.setups_saved, 1);
}

/// Work offsets and G28/G30 positions a job sets are the board's to keep: they go to
/// the setup and to flash once idle, and a board that restarts from that flash has them.
#[test]
fn work_offsets_a_job_sets_are_saved_to_flash_and_survive_a_restart() {
    let mut eb = board(|_| {});
    let saved: std::rc::Rc<std::cell::RefCell<Vec<gantry_machine::setup::Setup>>> =
        Default::default();
    let s2 = saved.clone();
    eb.on_setup_saved(move |s| s2.borrow_mut().push(s.clone()));
    job(
        &mut eb,
        "G21 G90\nG0 X10 Y5\nG10 L20 P1 X0 Y0\nG10 L2 P2 X7\nG28.1\n",
    );
    until_state(&mut eb, State::Idle, 5_000);
    eb.run_ms(5);
    let flash = saved.borrow().last().cloned().expect("nothing saved");
    assert_eq!(saved.borrow().len(), 1);
    let p = &flash.program;
    assert_eq!(p.work_offsets[0][..2], [10 * MM, 5 * MM]);
    assert_eq!(p.work_offsets[1][0], 7 * MM);
    assert_eq!(p.g28_home[..2], [10 * MM, 5 * MM]);
    // A restart from that flash: G54 X0 is machine X10 again.
    let mut eb = EmulatedBoard::new(flash);
    let s3 = saved.clone();
    eb.on_setup_saved(move |s| s3.borrow_mut().push(s.clone()));
    job(&mut eb, "G21 G90 G54\nG0 X1 Y1\n");
    until_state(&mut eb, State::Idle, 5_000);
    eb.run_ms(5);
    assert_eq!(
        eb.isr.kernel.position()[..2],
        [11 * STEPS_PER_MM, 6 * STEPS_PER_MM]
    );
    // A job that changes no offset writes nothing.
    assert_eq!(saved.borrow().len(), 1);
}

#[test]
fn an_abort_or_a_hold_is_no_underrun() {
    // An abort stops on the path: the kernel drains because the job ends, not because segment
    // preparation fell behind (each abort was counted as an underrun).
    let zigzag: String = (1..400)
        .map(|i| format!("G1 X{}.{} Y{}\n", i % 50, i % 10, i % 7))
        .collect();
    let mut eb = board(|_| {});
    job(&mut eb, &format!("G21 G90 F3000\n{zigzag}M30\n"));
    assert_eq!(eb.board.state(), State::Run);
    eb.run_ms(100);
    eb.board.abort();
    assert!(eb.run_until(5_000, |b| b.board.state() == State::Idle));
    eb.run_ms(50);
    assert_eq!(eb.starved.gaps, 0, "abort");
    // The sender went away mid-job: a hold on the path.
    let mut eb = board(|_| {});
    job(&mut eb, &format!("G21 G90 F3000\n{zigzag}M30\n"));
    eb.run_ms(100);
    eb.board.host_lost();
    assert!(eb.run_until(5_000, |b| b.board.motion().state() == MotionState::Held));
    eb.run_ms(100);
    assert_eq!(eb.starved.gaps, 0, "host lost");
    // A hold, at rest, then a resume to the end.
    let mut eb = board(|_| {});
    job(&mut eb, LONG_CUT);
    assert!(eb.run_until(5_000, |b| b.now_ms() == 500));
    eb.board.feed_hold();
    assert!(eb.run_until(5_000, |b| b.board.motion().state() == MotionState::Held));
    eb.run_ms(100);
    eb.board.resume();
    assert!(eb.run_until(10_000, |b| b.board.state() == State::Idle));
    assert_eq!(eb.starved.gaps, 0, "hold");
}
