//! `gantry`: stream, check, simulate and preview G-code for a Gantry board (or its emulation).
use clap::{Parser, Subcommand};
use gantry_proto::HostMsg;
use host_sender::commands::oneshot;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "gantry",
    version,
    about = "Gantry USB CNC controller: sender, checker and emulated board"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Serial port of the board (e.g. /dev/ttyACM0, or the pty of `gantry emulate`), before or
    /// after the subcommand, for the commands that use a board. Without it (and without
    /// GANTRY_PORT): the one Gantry board plugged in (by its USB id), else the emulated board
    /// (docs/ports.md).
    #[arg(long, env = "GANTRY_PORT")]
    port: Option<String>,
    /// Use the built-in emulated board even for commands that control a machine (they refuse a
    /// fresh emulated board otherwise, so that a missing --port never goes unnoticed).
    #[arg(long)]
    emulated: bool,
}

/// Which board a command uses: given after the subcommand (the same options before it are the
/// top level's, [`Cli`]); only the commands that use a board take them, so an offline command's
/// help does not offer them.
#[derive(clap::Args, Default)]
struct Conn {
    /// Serial port of the board (e.g. /dev/ttyACM0, or the pty of `gantry emulate`). Without
    /// it (and without GANTRY_PORT): the one Gantry board plugged in, else the emulated board
    /// (docs/ports.md).
    #[arg(long, env = "GANTRY_PORT")]
    port: Option<String>,
    /// Use the built-in emulated board even for commands that control a machine (they refuse a
    /// fresh emulated board otherwise, so that a missing --port never goes unnoticed).
    #[arg(long)]
    emulated: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Interpret a program without motion and report every error (line, N word, the bad word, why).
    Check {
        file: PathBuf,
        /// Print the interpreted program as JSON Lines of canonical actions (format: tests/golden/rs274/README.md).
        /// Every stdout line is JSON: a program error is an `{"op":"error"}` record (exit 1); an unreadable
        /// file or setup goes to stderr only (exit 2). See docs/errors.md.
        #[arg(long)]
        canon: bool,
        /// Machine setup (dialect, tools, travel) instead of the board's (default: the board of
        /// --port / GANTRY_PORT / the one plugged in, and where it stands; with no board the
        /// built-in defaults).
        #[arg(long)]
        setup: Option<PathBuf>,
        #[command(flatten)]
        conn: Conn,
    },
    /// Stream a program to the board (with no --port: the emulated board) with progress and a report.
    Stream {
        file: PathBuf,
        /// Run from this line: the state before it is rebuilt by interpreting without motion, and
        /// a short preamble (offsets, tool, spindle, coolant, position, modes) runs first.
        #[arg(long)]
        from_line: Option<u32>,
        /// Take over the job the board is running (after this sender was closed or crashed): the
        /// board asks for exactly the lines it is missing; a held job stays held until the
        /// operator resumes it (Enter, cycle start, `gantry resume`).
        #[arg(long = "continue", conflicts_with = "from_line")]
        take_over: bool,
        /// Emulated board only: charge each main-loop pass the instructions it costs on this MCU
        /// (f411: the Black Pill at 96 MHz), so the report's underruns show whether it keeps up.
        #[arg(long, value_parser = parse_cpu_model)]
        cpu_model: Option<gantry_emulator::cpu_model::CpuModel>,
        /// Start without checking the whole program first (for programs too long to check
        /// before they run): the board then stops at the first bad line.
        #[arg(long)]
        no_check: bool,
        /// Emulated board in this process only (no --port): answer every M0/M1 and M6 stop at
        /// once, for unattended runs (scripts, tests). Without it a stop waits for Enter, and one
        /// nobody can answer (standard input closed) aborts the job. Refused with --port: on a
        /// machine only the operator continues a stop.
        #[arg(long)]
        through_stops: bool,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Show the board's status: state, positions, feed, overrides, line, buffers, inputs.
    Status {
        /// Live readout: refresh every 200 ms until Ctrl-C (or for this many seconds with --for).
        #[arg(long)]
        watch: bool,
        /// With --watch: stop after this many seconds.
        #[arg(long = "for", requires = "watch")]
        duration: Option<f64>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Feed hold: decelerate on the path and stop there.
    Hold {
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Resume after a feed hold or an M0/M1 stop (cycle start).
    Resume {
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Abort the job: stop on the path, spindle and coolant off, remember the line.
    Abort {
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Clear an alarm (the machine must be at rest); with homing required it asks for homing.
    Unlock {
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Set the feed (10-200 %), rapid (1-100 %) and/or spindle speed (10-200 %) override.
    Override {
        #[arg(long)]
        feed: Option<u16>,
        #[arg(long)]
        rapid: Option<u16>,
        /// Spindle speed override: scales the spindle output; the programmed S stays.
        #[arg(long)]
        spindle: Option<u16>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Jog one axis by a distance (e.g. `gantry jog X -10 --feed 1000`), or continuously
    /// (`gantry jog X --continuous +`, until Ctrl-C); soft limits apply.
    Jog {
        /// Axis letter (X Y Z A B C).
        axis: char,
        /// Distance in mm (degrees for A/B/C), signed, at least 0.000001 (0, nan and inf are
        /// refused).
        #[arg(allow_hyphen_values = true, required_unless_present = "continuous")]
        distance: Option<f64>,
        /// Jog in this direction (`+` or `-`) until Ctrl-C (or --for), never beyond the travel.
        #[arg(long, value_parser = ["+", "-"], conflicts_with = "distance", allow_hyphen_values = true)]
        continuous: Option<String>,
        /// With --continuous: stop after this many seconds.
        #[arg(long = "for", requires = "continuous")]
        duration: Option<f64>,
        /// Speed, mm/min.
        #[arg(long, default_value_t = 1000.0)]
        feed: f64,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Run the homing cycle (limit-switch seek) for the given axes (default: all).
    Home {
        /// Axis letters, e.g. `XY`; all homed axes when omitted.
        axes: Option<String>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Run blocks typed here (each argument one line), e.g. `gantry mdi "G0 X10 Y5"`.
    Mdi {
        #[arg(required = true)]
        blocks: Vec<String>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Show or check the machine setup (docs/settings.md).
    Setup {
        #[command(subcommand)]
        action: SetupAction,
    },
    /// Plan a program and print each move's entry/cruise/exit speed and time.
    Simulate {
        file: PathBuf,
        /// JSON Lines instead of a table.
        #[arg(long)]
        json: bool,
        /// Also run the job on the emulated board and write its step/dir/enable/input/output
        /// pins as a VCD trace (GTKWave, PulseView).
        #[arg(long)]
        vcd: Option<PathBuf>,
        /// Start of the trace window (e.g. `1.5s`, `200ms`, `750us`, `1200ns`).
        #[arg(long, requires = "vcd")]
        from: Option<String>,
        /// End of the trace window.
        #[arg(long, requires = "vcd")]
        to: Option<String>,
        /// Machine setup (the plan and the emulated board) instead of the board's (as for `check`).
        #[arg(long)]
        setup: Option<PathBuf>,
        #[command(flatten)]
        conn: Conn,
    },
    /// Run the emulated board behind a pseudo-terminal linked at PATH, in real time, until
    /// killed: `gantry … --port PATH` talks to it as to the USB board (docs/ports.md).
    Emulate {
        /// Where the pty is linked (a symlink, replaced when it exists).
        #[arg(long, required_unless_present = "tcp", conflicts_with = "tcp")]
        pty: Option<PathBuf>,
        /// Listen on this TCP address instead (e.g. 127.0.0.1:2323; grbl senders that connect
        /// by address). Loopback only unless --allow-remote.
        #[arg(long)]
        tcp: Option<std::net::SocketAddr>,
        /// Allow a --tcp address other hosts can reach (anyone reaching it can move the machine).
        #[arg(long, requires = "tcp")]
        allow_remote: bool,
        /// Setup to store in the board: its machine settings replace the stored ones; the work
        /// offsets, G28/G30 positions and tool table stored in --state stay unless the file
        /// names them (as `setup push` does). A new --state takes everything from the file.
        #[arg(long)]
        setup: Option<PathBuf>,
        /// The board's flash: its stored setup, read at start, written when a setup is pushed.
        #[arg(long)]
        state: Option<PathBuf>,
        /// Something the emulated touch probe touches (repeatable; machine coordinates, mm):
        /// `plane:Z`, `boss:X0,Y0,X1,Y1,TOP`, `hole:X0,Y0,X1,Y1,TOP,BOTTOM`,
        /// `ring:X,Y,D_INSIDE,D_OUTSIDE,TOP` or `cylinder:X,Y,D,TOP` (docs/probing.md).
        #[arg(long = "probe-target", allow_hyphen_values = true)]
        probe_targets: Vec<String>,
        /// Charge each main-loop pass the instructions it costs on this MCU (f411) and log every
        /// underrun (docs/ports.md).
        #[arg(long, value_parser = parse_cpu_model)]
        cpu_model: Option<gantry_emulator::cpu_model::CpuModel>,
        /// Plasma: the emulated power source's arc-OK comes this long after the torch fires
        /// (`300ms`, `1.5s`; default 50ms with a torch setup; docs/laser-plasma.md).
        #[arg(long, value_parser = gantry_emulator::torch_script::parse_ms, conflicts_with = "no_arc")]
        arc_ok_delay: Option<u64>,
        /// Plasma: arc-OK never comes (the board raises alarm 22).
        #[arg(long)]
        no_arc: bool,
        /// Plasma: the arc goes out this long after the first firing (once).
        #[arg(long, value_parser = gantry_emulator::torch_script::parse_ms)]
        arc_lost_at: Option<u64>,
        /// Plasma: the height controller's pattern, ms after the torch fired:
        /// `up:1000-1500,down:2000-2200`.
        #[arg(long)]
        thc: Option<String>,
    },
    /// Own the board's port (--port) until killed, and let other `gantry` commands reach the
    /// board through a local socket named after the port while a job runs (docs/ports.md).
    Serve {
        /// Serve the operator's console (a web page) on this address, e.g. 127.0.0.1:8080
        /// (docs/console.md). Loopback only unless --allow-remote.
        #[arg(long)]
        http: Option<std::net::SocketAddr>,
        /// Allow an --http address other hosts can reach (the console has no authentication:
        /// anyone who reaches it can move the machine).
        #[arg(long, requires = "http")]
        allow_remote: bool,
        /// Serial port of the board to serve (without it and GANTRY_PORT: the one Gantry board
        /// plugged in).
        #[arg(long, env = "GANTRY_PORT")]
        port: Option<String>,
        /// Give the console a new token (the one kept in serve's runtime directory from its last
        /// start is otherwise used again, so open pages come back; docs/console.md).
        #[arg(long, requires = "http")]
        new_token: bool,
    },
    /// Draw a program's tool path (top, front, side, isometric views) to a PNG or SVG file.
    Preview {
        file: PathBuf,
        /// Output picture; the extension (.png or .svg) picks the format.
        #[arg(short, long)]
        output: PathBuf,
        /// Machine setup file (travel box, rates) instead of the board's (as for `check`).
        #[arg(long)]
        setup: Option<PathBuf>,
        #[command(flatten)]
        conn: Conn,
    },
}

/// The emulated board's setup (when a command runs without a port).
#[derive(clap::Args, Default)]
struct BoardArgs {
    /// Machine setup for the emulated board (default: the built-in defaults, docs/settings.md).
    #[arg(long)]
    setup: Option<PathBuf>,
    #[command(flatten)]
    conn: Conn,
}

impl Command {
    /// The board options given after the subcommand, for the commands that take them.
    fn conn(&self) -> Option<&Conn> {
        match self {
            Command::Check { conn, .. }
            | Command::Simulate { conn, .. }
            | Command::Preview { conn, .. } => Some(conn),
            Command::Stream { board, .. }
            | Command::Status { board, .. }
            | Command::Hold { board }
            | Command::Resume { board }
            | Command::Abort { board }
            | Command::Unlock { board }
            | Command::Override { board, .. }
            | Command::Jog { board, .. }
            | Command::Home { board, .. }
            | Command::Mdi { board, .. } => Some(&board.conn),
            Command::Setup { action } => match action {
                SetupAction::Show { conn, .. } => Some(conn),
                SetupAction::Push { board, .. } | SetupAction::Pull { board, .. } => {
                    Some(&board.conn)
                }
                SetupAction::Check { .. } | SetupAction::Docs { .. } => None,
            },
            Command::Serve { .. } | Command::Emulate { .. } => None,
        }
    }
}

impl BoardArgs {
    /// The setup file given, or the defaults.
    fn setup(&self) -> anyhow::Result<gantry_machine::setup::Setup> {
        match &self.setup {
            Some(f) => host_sender::setup_file::SetupFile::load(f),
            None => Ok(Default::default()),
        }
    }
}

/// Where the machine is: the global `--port`/`GANTRY_PORT`/`--emulated` choice.
struct Machine {
    port: Option<String>,
    emulated: bool,
}

/// Does a command move or change the machine (refused on a fresh emulated board unless
/// `--emulated` is given)?
#[derive(Clone, Copy, PartialEq, Eq)]
enum Use {
    Controls,
    Reads,
}

impl Machine {
    fn target(&self, board: &BoardArgs, use_: Use) -> anyhow::Result<host_sender::session::Target> {
        use host_sender::port::{discover, Found};
        use host_sender::session::Target;
        if let Some(p) = &self.port {
            return Ok(Target::Port(p.clone()));
        }
        if !self.emulated {
            if let Found::One(p) = discover()? {
                eprintln!("gantry: using the Gantry board on {p}");
                return Ok(Target::Port(p));
            }
            anyhow::ensure!(
                use_ == Use::Reads,
                "no board: give --port PATH (or set GANTRY_PORT) for the machine; no Gantry board is plugged in.\n  This command would only act on a fresh emulated board: add --emulated to try it there."
            );
        }
        Ok(Target::Emulated(Box::new(board.setup()?)))
    }
}

#[derive(Subcommand)]
enum SetupAction {
    /// Print the effective values (every default filled in) of a setup file; without FILE, of
    /// the board's setup (--port, GANTRY_PORT or the one Gantry board plugged in), else of the
    /// defaults.
    Show {
        file: Option<PathBuf>,
        /// The built-in defaults, even with a board.
        #[arg(long, conflicts_with = "file")]
        defaults: bool,
        #[command(flatten)]
        conn: Conn,
    },
    /// Validate a setup file; every error names the key and the allowed range.
    Check { file: PathBuf },
    /// Validate a setup file and send it to the board, which saves it in flash (only when idle).
    Push {
        file: PathBuf,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Regenerate the per-setting tables of a settings reference (docs/settings.md) from the
    /// settings table, in place; with --check only report whether they are up to date.
    Docs {
        file: PathBuf,
        #[arg(long)]
        check: bool,
    },
    /// Read the board's setup and write it as a setup file (to standard output without FILE).
    Pull {
        file: Option<PathBuf>,
        #[command(flatten)]
        board: BoardArgs,
    },
}

fn setup(action: SetupAction, machine: &Machine) -> anyhow::Result<ExitCode> {
    use host_sender::setup_file::{to_toml, SetupFile};
    match action {
        SetupAction::Show { file, defaults, .. } => {
            let (origin, setup) = match file {
                Some(f) => (format!("setup file {}", f.display()), SetupFile::load(&f)?),
                None => show_source(machine, defaults)?,
            };
            println!("# Effective values of the {origin}.");
            print!("{}", to_toml(&setup));
        }
        SetupAction::Check { file } => {
            let text = SetupFile::read_bounded(&file)?;
            let errors = SetupFile::check_all(&text);
            if !errors.is_empty() {
                // Every error, each with its line (as `gantry check` prints a program's).
                let f = file.display();
                for (line, e) in &errors {
                    match line {
                        0 => eprintln!("{f}: error: {e}"),
                        n => eprintln!("{f}:{n}: error: {e}"),
                    }
                }
                let n = errors.len();
                eprintln!("{f}: {n} error{}", if n == 1 { "" } else { "s" });
                return Ok(ExitCode::from(1));
            }
            println!("{}: setup is valid", file.display());
        }
        SetupAction::Docs { file, check } => {
            let doc = std::fs::read_to_string(&file)?;
            let want = host_sender::settings_doc::render(&doc)?;
            if want == doc {
                println!("{}: up to date", file.display());
            } else if check {
                anyhow::bail!("{}: stale: run gantry setup docs {0}", file.display());
            } else {
                std::fs::write(&file, want)?;
                println!("{}: regenerated", file.display());
            }
        }
        SetupAction::Push { file, board } => {
            // Checked before anything connects; pushed with the board's offsets kept.
            SetupFile::load(&file)?;
            let target = machine.target(&board, Use::Controls)?;
            let emulated = matches!(target, host_sender::session::Target::Emulated(_));
            oneshot::setup_push_file(target, &file)?;
            if emulated {
                println!(
                    "{}: valid, and applied by the emulated board (which forgets it when gantry exits: give --setup FILE to commands that use the emulated board)",
                    file.display()
                );
            } else {
                println!("{}: sent, applied and saved by the board", file.display());
            }
        }
        SetupAction::Pull { file, board } => {
            // A fresh emulated board's setup is the defaults: `setup show` prints those.
            let text = to_toml(&oneshot::setup_pull(
                machine.target(&board, Use::Controls)?,
            )?);
            match file {
                Some(f) => {
                    std::fs::write(&f, text)?;
                    println!("board setup written to {}", f.display());
                }
                None => print!("{text}"),
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// What `setup show` without a file shows: the board's setup when there is a board (printing
/// the defaults beside a configured board misled), else the defaults, saying which.
fn show_source(
    machine: &Machine,
    defaults: bool,
) -> anyhow::Result<(String, gantry_machine::setup::Setup)> {
    use host_sender::session::Target;
    if defaults {
        return Ok(("built-in defaults".into(), Default::default()));
    }
    let no_setup = BoardArgs::default();
    match machine.target(&no_setup, Use::Reads)? {
        Target::Port(p) => Ok((
            format!("board's setup on {p}"),
            oneshot::setup_pull(Target::Port(p))?,
        )),
        Target::Emulated(_) => Ok((
            "built-in defaults (no board: give --port for the board's setup)".into(),
            Default::default(),
        )),
    }
}

/// The machine `check`, `simulate` and `preview` measure a program against
/// (`host_sender::session::standing`): `--setup FILE` when given, else the board of `--port`,
/// `GANTRY_PORT` or the one plugged in (its setup, and where it stands), else the defaults; the
/// choice is said on stderr (stdout may be JSON).
fn standing(
    m: &Machine,
    setup: Option<PathBuf>,
    command: &str,
) -> anyhow::Result<host_sender::session::standing::Standing> {
    use host_sender::port::{discover, Found};
    use host_sender::session::standing::{standing, Basis};
    let basis = match (setup, &m.port) {
        (Some(f), _) => Basis::File(f),
        (None, Some(p)) => Basis::Port(p.clone()),
        (None, None) if m.emulated => Basis::Defaults,
        (None, None) => match discover()? {
            Found::One(p) => Basis::Port(p),
            _ => Basis::Defaults,
        },
    };
    let s = standing(basis)?;
    eprintln!("gantry {command}: {}", s.origin);
    Ok(s)
}

fn simulate(
    file: &std::path::Path,
    json: bool,
    vcd: Option<PathBuf>,
    from: Option<String>,
    to: Option<String>,
    machine: host_sender::session::standing::Standing,
) -> anyhow::Result<ExitCode> {
    let setup = machine.setup;
    let code = host_sender::simulate::run(file, json, &setup, &machine.at)?;
    let Some(out) = vcd else {
        return Ok(code);
    };
    let time = |t: Option<String>| -> anyhow::Result<Option<u64>> {
        t.map(|t| host_sender::vcd::parse_time_ns(&t).map_err(anyhow::Error::msg))
            .transpose()
    };
    let axes = setup.axis_count as usize;
    let program = host_sender::program::Program::load(file)?;
    let r = host_sender::trace::trace(&program, setup, &out, time(from)?, time(to)?)?;
    println!(
        "vcd: {} written, {:.3} s; step pulses per axis {:?} (emulated board counted {:?})",
        out.display(),
        r.summary.end_ns as f64 / 1e9,
        &r.summary.steps[..axes],
        &r.pulses[..axes]
    );
    Ok(if r.completed { code } else { ExitCode::from(1) })
}

fn axis_index(letter: char) -> anyhow::Result<u8> {
    gantry_machine::units::AXIS_LETTERS
        .iter()
        .position(|l| l.eq_ignore_ascii_case(&letter))
        .map(|i| i as u8)
        .ok_or_else(|| anyhow::anyhow!("{letter}: not an axis letter (X Y Z A B C)"))
}

fn axis_mask(letters: Option<&str>) -> anyhow::Result<u8> {
    letters.map_or(Ok(0), |l| {
        l.chars()
            .try_fold(0u8, |mask, c| axis_index(c).map(|i| mask | 1 << i))
    })
}

/// A closed standard output (`gantry status | head -1`) ends the command quietly, as SIGPIPE
/// would, instead of a panic report; every other panic is reported as usual.
fn quiet_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let text = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if text.contains("Broken pipe") {
            // 128 + SIGPIPE, what a shell shows for a writer killed by SIGPIPE.
            std::process::exit(141);
        }
        default(info);
    }));
}

/// The error is a write to a closed pipe (standard output read by `head`).
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

fn main() -> ExitCode {
    quiet_broken_pipe();
    let cli = Cli::parse();
    // After the subcommand or before it (the top level's), or GANTRY_PORT (both read it).
    let conn = cli.command.conn();
    let machine = Machine {
        port: conn.and_then(|c| c.port.clone()).or(cli.port.clone()),
        emulated: conn.is_some_and(|c| c.emulated) || cli.emulated,
    };
    let m = &machine;
    // A program is read line by line in bounded memory; a line no G-code program has (a binary
    // file, /dev/zero) is refused before anything reads it whole (`stream` checks it where it
    // reads the file, host-sender/src/commands/stream.rs).
    let program = match &cli.command {
        Command::Check { file, .. }
        | Command::Simulate { file, .. }
        | Command::Preview { file, .. } => Some(file.clone()),
        _ => None,
    };
    if let Some(file) = program {
        if let Err(e) = host_sender::program::check_line_lengths(&file) {
            eprintln!("gantry: {e:#}");
            return ExitCode::from(2);
        }
    }
    let result = match cli.command {
        Command::Check {
            file, canon, setup, ..
        } => standing(m, setup, "check")
            .and_then(|s| host_sender::check::run(&file, canon, &s.setup, &s.at)),
        Command::Setup { action } => setup(action, m),
        Command::Stream {
            file,
            from_line,
            take_over,
            cpu_model,
            no_check,
            through_stops,
            board,
        } => board.setup().and_then(|setup| {
            use host_sender::commands::stream::Start;
            let target = m.target(&board, Use::Reads)?;
            let start = match (from_line, take_over) {
                (Some(n), _) => Start::FromLine(n),
                (None, true) => Start::TakeOver,
                (None, false) => Start::Beginning,
            };
            host_sender::commands::stream::run_checked(
                &file,
                target,
                setup,
                start,
                cpu_model,
                !no_check,
                through_stops,
            )
        }),
        // The status of a fresh emulated board says nothing of the machine: refused without a
        // board unless --emulated.
        Command::Status {
            watch: false,
            board,
            ..
        } => m
            .target(&board, Use::Controls)
            .and_then(|t| oneshot::realtime(t, None)),
        Command::Status {
            watch: true,
            duration,
            board,
        } => m
            .target(&board, Use::Controls)
            .and_then(|t| oneshot::watch(t, duration)),
        Command::Hold { board } => m
            .target(&board, Use::Controls)
            .and_then(|t| oneshot::realtime(t, Some(HostMsg::FeedHold))),
        Command::Resume { board } => m
            .target(&board, Use::Controls)
            .and_then(|t| oneshot::realtime(t, Some(HostMsg::Resume))),
        Command::Abort { board } => m
            .target(&board, Use::Controls)
            .and_then(|t| oneshot::realtime(t, Some(HostMsg::Abort))),
        Command::Unlock { board } => m.target(&board, Use::Controls).and_then(oneshot::unlock),
        Command::Override {
            feed,
            rapid,
            spindle,
            board,
        } => m.target(&board, Use::Controls).and_then(|t| {
            if let Some(f) = feed {
                anyhow::ensure!((10..=200).contains(&f), "--feed {f}: must be 10-200 %");
            }
            if let Some(r) = rapid {
                anyhow::ensure!((1..=100).contains(&r), "--rapid {r}: must be 1-100 %");
            }
            if let Some(s) = spindle {
                anyhow::ensure!((10..=200).contains(&s), "--spindle {s}: must be 10-200 %");
            }
            let o = host_sender::session::Overrides {
                feed,
                rapid,
                spindle,
            };
            anyhow::ensure!(
                o != host_sender::session::Overrides::default(),
                "give --feed, --rapid and/or --spindle"
            );
            oneshot::set_overrides(t, o)
        }),
        Command::Jog {
            axis,
            distance,
            continuous,
            duration,
            feed,
            board,
        } => axis_index(axis).and_then(|a| {
            let how = match (distance, continuous) {
                (Some(d), _) => oneshot::JogMove::By(d),
                (None, Some(dir)) => oneshot::JogMove::Continuous {
                    positive: dir == "+",
                    seconds: duration,
                },
                (None, None) => anyhow::bail!("give a distance or --continuous + / -"),
            };
            // Refuse a bad distance or feed before any port is opened.
            if let oneshot::JogMove::By(d) = how {
                oneshot::jog_distance_nm(d)?;
            }
            oneshot::jog_feed_um_min(feed)?;
            m.target(&board, Use::Controls)
                .and_then(|t| oneshot::jog(t, a, how, feed))
        }),
        Command::Home { axes, board } => axis_mask(axes.as_deref()).and_then(|mask| {
            m.target(&board, Use::Controls)
                .and_then(|t| oneshot::home(t, mask))
        }),
        Command::Mdi { blocks, board } => m
            .target(&board, Use::Controls)
            .and_then(|t| oneshot::mdi(t, &blocks)),
        Command::Serve {
            http,
            allow_remote,
            port,
            new_token,
        } => {
            let http = http.map(|addr| host_sender::console::Options {
                addr,
                allow_remote,
                new_token,
            });
            match port.as_ref().or(m.port.as_ref()) {
                Some(p) => host_sender::commands::serve::run(p, http.as_ref()),
                None => match host_sender::port::discover() {
                    Ok(host_sender::port::Found::One(p)) => {
                        host_sender::commands::serve::run(&p, http.as_ref())
                    }
                    Ok(host_sender::port::Found::None) => Err(anyhow::anyhow!(
                        "gantry serve: give --port PATH (or GANTRY_PORT)"
                    )),
                    Err(e) => Err(e),
                },
            }
        }
        Command::Emulate {
            pty,
            tcp,
            allow_remote,
            setup,
            state,
            probe_targets,
            cpu_model,
            arc_ok_delay,
            no_arc,
            arc_lost_at,
            thc,
        } => gantry_emulator::torch_script::from_options(
            arc_ok_delay,
            no_arc,
            arc_lost_at,
            thc.as_deref(),
        )
        .and_then(|torch| {
            let opts = host_sender::emulate::BoardOptions {
                probe_targets,
                cpu: cpu_model,
                torch,
            };
            match (pty, tcp) {
                (Some(pty), _) => host_sender::emulate::run(&pty, setup, state, &opts),
                (None, Some(addr)) => {
                    host_sender::tcp::run(addr, allow_remote, setup, state, &opts)
                }
                (None, None) => unreachable!("clap requires --pty or --tcp"),
            }
        }),
        Command::Simulate {
            file,
            json,
            vcd,
            from,
            to,
            setup,
            ..
        } => standing(m, setup, "simulate").and_then(|s| simulate(&file, json, vcd, from, to, s)),
        Command::Preview {
            file,
            output,
            setup,
            ..
        } => standing(m, setup, "preview")
            .and_then(|s| host_sender::preview::run(&file, &output, &s.setup, &s.at)),
    };
    match result {
        Ok(code) => code,
        // `gantry simulate … | head`: the reader went away; end quietly, as SIGPIPE would.
        Err(e) if is_broken_pipe(&e) => ExitCode::from(141),
        Err(e) => {
            eprintln!("gantry: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// `--cpu-model NAME`.
fn parse_cpu_model(name: &str) -> Result<gantry_emulator::cpu_model::CpuModel, String> {
    gantry_emulator::cpu_model::CpuModel::named(name).ok_or_else(|| {
        let known: Vec<&str> = gantry_emulator::cpu_model::CpuModel::ALL
            .iter()
            .map(|m| m.name)
            .collect();
        format!("unknown CPU model {name:?} (known: {})", known.join(", "))
    })
}
