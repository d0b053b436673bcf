//! The machine setup travels to the board and back over the real protocol, and a board refuses
//! a setup while a job runs.

use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{pull_setup_over, push_setup_over};
use host_sender::session::{stream_program, Flow};
use host_sender::setup_file::SetupFile;

#[test]
fn a_pushed_setup_is_applied_and_pulled_back_identical() {
    let setup = SetupFile::parse(
        "axes = [\"X\", \"Y\", \"Z\", \"A\"]\n[axis.X]\nsteps_per = [400, 0.2]\n[axis.A]\nsteps_per = [4000, 360.0]\n[[tool]]\nnumber = 3\nlength = 12.5\n[work_offsets]\n\"G55\" = [10, 20, 0, 0]\n",
    )
    .unwrap();
    let mut client = Client::connect(EmulatedBoard::new(Setup::default()), 2000).unwrap();
    push_setup_over(&mut client, &setup).unwrap();
    assert_eq!(client.transport.board.setup(), &setup);
    assert_eq!(pull_setup_over(&mut client).unwrap(), setup);
    // The new step ratio is in force: G0 X1 is 1 mm at 400 steps per 0.2 mm = 2000 steps.
    let report = stream_program(
        &mut client,
        &Program::from_text("G21 G90 G0 X1 A90\nM30\n"),
        &mut |_| Flow::Continue,
    )
    .unwrap();
    assert!(report.completed, "{:?}", report.errors);
    assert_eq!(client.transport.isr.kernel.position()[0], 2000);
    assert_eq!(client.transport.isr.kernel.position()[3], 1000);
}

#[test]
fn a_setup_is_refused_while_a_job_runs() {
    let mut client = Client::connect(EmulatedBoard::new(Setup::default()), 2000).unwrap();
    let program = Program::from_text("G21 G90 G1 X100 F600\nM30\n");
    stream_program(&mut client, &program, &mut |p| {
        if p.line >= 1 {
            Flow::Detach
        } else {
            Flow::Continue
        }
    })
    .unwrap();
    assert_eq!(
        client.transport.board.state(),
        gantry_machine::board::State::Run
    );
    let err = push_setup_over(&mut client, &Setup::default()).unwrap_err();
    assert!(err.to_string().contains("not idle"), "{err}");
}

/// `gantry setup check FILE` as a process: a setup file grbl's `$110=10` would also make (max
/// rate below the start speed) fails with exit code 2 and the core's message; a valid one passes.
#[test]
fn setup_check_refuses_with_the_cores_message_and_exit_code() {
    let dir = std::env::temp_dir().join(format!("gantry-setup-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let run = |text: &str| {
        let file = dir.join("setup.toml");
        std::fs::write(&file, text).unwrap();
        std::process::Command::new(env!("CARGO_BIN_EXE_gantry-under-test"))
            .args(["setup", "check"])
            .arg(&file)
            .output()
            .unwrap()
    };
    // An invalid setup is exit 1 (every error listed, as `gantry check` does for a program); an
    // unreadable file stays exit 2.
    let out = run("[axis.X]\nmax_rate = 10\n");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    let mut setup = Setup::default();
    gantry_machine::device::grbl::settings::write(110, 10_000, &mut setup).unwrap();
    let refusal = setup.validate().unwrap_err().to_string();
    assert_eq!(
        refusal,
        "axis.X.start_speed = 60: must not exceed axis.X.max_rate (10)"
    );
    assert!(err.contains(&refusal), "{err}");
    let out = run("[axis.X]\nmax_rate = 300000\n");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("axis.X.max_rate = 300000: must be between 1 and 200000"),
        "{out:?}"
    );
    let out = run("[axis.X]\nmax_rate = 2000\n");
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_gantry-under-test"))
        .args(["setup", "check"])
        .arg(dir.join("no-such.toml"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
