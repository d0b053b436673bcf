//! The `--port` path end to end: the sender's serial transport on one end of a pseudo-terminal
//! pair, the emulated board (paced to the wall clock) on the other.

use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use host_sender::link::{Client, SerialTransport};
use host_sender::program::Program;
use host_sender::session::{stream_program, Flow};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Runs an emulated board on `port` in real time until `stop` is set; returns its final kernel
/// step position.
fn board_on(mut port: TTYPort, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<[i64; 6]> {
    std::thread::spawn(move || {
        let mut board = EmulatedBoard::new(Setup::default());
        port.set_timeout(Duration::from_millis(1)).unwrap();
        let start = Instant::now();
        let mut buf = [0u8; 512];
        while !stop.load(Ordering::SeqCst) {
            if let Ok(n) = port.read(&mut buf) {
                board.receive(&buf[..n]);
            }
            // Keep virtual time level with the wall clock (the host's link clock).
            let behind = start.elapsed().as_millis() as u64 - board.now_ms() as u64;
            board.run_ms(behind.min(50));
            let out = board.take_output();
            if !out.is_empty() {
                port.write_all(&out).unwrap();
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        board.isr.kernel.position()
    })
}

#[test]
fn a_job_streams_over_a_serial_port() {
    let (master, slave) = TTYPort::pair().expect("a pty pair");
    let path = slave.name().expect("the pty has a path");
    let stop = Arc::new(AtomicBool::new(false));
    let board = board_on(master, stop.clone());
    let mut client = Client::connect(SerialTransport::open(&path).unwrap(), 3000).unwrap();
    let program = Program::from_text("G21 G90\nG0 X2 Y-1\nG1 X3 F3000\nM30\n");
    let report = stream_program(&mut client, &program, &mut |_| Flow::Continue).unwrap();
    stop.store(true, Ordering::SeqCst);
    let steps = board.join().unwrap();
    assert!(report.completed, "{:?}", report.errors);
    assert_eq!(
        &report.final_status.unwrap().machine_pos[..2],
        &[3_000_000, -1_000_000]
    );
    assert_eq!(&steps[..2], &[1920, -640]);
    drop(slave);
}
