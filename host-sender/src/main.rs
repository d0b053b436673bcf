//! `gantry`: stream, check, simulate and preview G-code for a Gantry board (or its emulation).
use clap::{Parser, Subcommand};
use gantry_proto::HostMsg;
use host_sender::commands;
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
}

#[derive(Subcommand)]
enum Command {
    /// Interpret a program without motion and report every error (line, N word, the bad word, why).
    Check {
        file: PathBuf,
        /// Print the interpreted program as JSON Lines of canonical actions (DESIGN §7).
        #[arg(long)]
        canon: bool,
        /// Machine setup (dialect, tools, travel) for plain `check` (default: built-in defaults).
        #[arg(long)]
        setup: Option<PathBuf>,
    },
    /// Stream a program to the board (with no --port: the emulated board) with progress and a report.
    Stream {
        file: PathBuf,
        /// Run from this line: the state before it is rebuilt by interpreting without motion, and
        /// a short preamble (offsets, tool, spindle, coolant, position, modes) runs first.
        #[arg(long)]
        from_line: Option<u32>,
        /// Take over the job the board is running (after this sender was closed or crashed): the
        /// board asks for exactly the lines it is missing and the held job resumes.
        #[arg(long = "continue", conflicts_with = "from_line")]
        take_over: bool,
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
    /// Set the feed (10-200 %) and/or rapid (1-100 %) override.
    Override {
        #[arg(long)]
        feed: Option<u16>,
        #[arg(long)]
        rapid: Option<u16>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Jog one axis by a distance (e.g. `gantry jog X -10 --feed 1000`); soft limits apply.
    Jog {
        /// Axis letter (X Y Z A B C).
        axis: char,
        /// Distance in mm (degrees for A/B/C), signed.
        #[arg(allow_hyphen_values = true)]
        distance: f64,
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
        /// Machine setup (the plan and the emulated board; default: the built-in one).
        #[arg(long)]
        setup: Option<PathBuf>,
    },
    /// Draw a program's tool path (top, front, side, isometric views) to a PNG or SVG file.
    Preview {
        file: PathBuf,
        /// Output picture; the extension (.png or .svg) picks the format.
        #[arg(short, long)]
        output: PathBuf,
        /// Machine setup file (travel box, rates); the default setup otherwise.
        #[arg(long)]
        setup: Option<PathBuf>,
    },
}

/// Which board a command talks to.
#[derive(clap::Args)]
struct BoardArgs {
    /// Serial port of the board (e.g. /dev/ttyACM0); without it, the emulated board.
    #[arg(long)]
    port: Option<String>,
    /// Machine setup for the emulated board (default: the built-in defaults, docs/settings.md).
    #[arg(long)]
    setup: Option<PathBuf>,
}

impl BoardArgs {
    /// The setup file given, or the defaults.
    fn setup(&self) -> anyhow::Result<gantry_machine::setup::Setup> {
        match &self.setup {
            Some(f) => host_sender::setup_file::SetupFile::load(f),
            None => Ok(Default::default()),
        }
    }

    fn target(&self) -> anyhow::Result<host_sender::stream::Target> {
        use host_sender::stream::Target;
        Ok(match &self.port {
            Some(p) => Target::Port(p.clone()),
            None => Target::Emulated(Box::new(self.setup()?)),
        })
    }
}

#[derive(Subcommand)]
enum SetupAction {
    /// Print a setup file's effective values (every default filled in), or the defaults.
    Show { file: Option<PathBuf> },
    /// Validate a setup file; every error names the key and the allowed range.
    Check { file: PathBuf },
    /// Validate a setup file and send it to the board, which saves it in flash (only when idle).
    Push {
        file: PathBuf,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Read the board's setup and write it as a setup file (to standard output without FILE).
    Pull {
        file: Option<PathBuf>,
        #[command(flatten)]
        board: BoardArgs,
    },
}

fn setup(action: SetupAction) -> anyhow::Result<ExitCode> {
    use host_sender::setup_file::{to_toml, SetupFile};
    match action {
        SetupAction::Show { file } => {
            let setup = match file {
                Some(f) => SetupFile::load(&f)?,
                None => Default::default(),
            };
            print!("{}", to_toml(&setup));
        }
        SetupAction::Check { file } => {
            SetupFile::load(&file)?;
            println!("{}: setup is valid", file.display());
        }
        SetupAction::Push { file, board } => {
            let setup = SetupFile::load(&file)?;
            let emulated = board.port.is_none();
            commands::setup_push(board.target()?, &setup)?;
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
            let text = to_toml(&commands::setup_pull(board.target()?)?);
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

fn simulate(
    file: &std::path::Path,
    json: bool,
    vcd: Option<PathBuf>,
    from: Option<String>,
    to: Option<String>,
    setup: Option<PathBuf>,
) -> anyhow::Result<ExitCode> {
    let setup = match setup {
        Some(f) => host_sender::setup_file::SetupFile::load(&f)?,
        None => Default::default(),
    };
    let code = host_sender::simulate::run(file, json, &setup)?;
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check { file, canon, setup } => setup
            .map_or_else(
                || Ok(Default::default()),
                |f| host_sender::setup_file::SetupFile::load(&f),
            )
            .and_then(|s| host_sender::check::run(&file, canon, &s)),
        Command::Setup { action } => setup(action),
        Command::Stream {
            file,
            from_line,
            take_over,
            board,
        } => board.setup().and_then(|setup| {
            use host_sender::stream::Start;
            let target = board.target()?;
            let start = match (from_line, take_over) {
                (Some(n), _) => Start::FromLine(n),
                (None, true) => Start::TakeOver,
                (None, false) => Start::Beginning,
            };
            host_sender::stream::run(&file, target, setup, start)
        }),
        Command::Status {
            watch: false,
            board,
            ..
        } => board.target().and_then(|t| commands::realtime(t, None)),
        Command::Status {
            watch: true,
            duration,
            board,
        } => board.target().and_then(|t| commands::watch(t, duration)),
        Command::Hold { board } => board
            .target()
            .and_then(|t| commands::realtime(t, Some(HostMsg::FeedHold))),
        Command::Resume { board } => board
            .target()
            .and_then(|t| commands::realtime(t, Some(HostMsg::Resume))),
        Command::Abort { board } => board
            .target()
            .and_then(|t| commands::realtime(t, Some(HostMsg::Abort))),
        Command::Unlock { board } => board
            .target()
            .and_then(|t| commands::realtime(t, Some(HostMsg::Unlock))),
        Command::Override { feed, rapid, board } => board.target().and_then(|t| {
            let (mut client, axes) = commands::connect(t)?;
            if let Some(f) = feed {
                anyhow::ensure!((10..=200).contains(&f), "--feed {f}: must be 10-200 %");
                client.send(HostMsg::FeedOverride(f))?;
            }
            if let Some(r) = rapid {
                anyhow::ensure!((1..=100).contains(&r), "--rapid {r}: must be 1-100 %");
                client.send(HostMsg::RapidOverride(r))?;
            }
            client.pump(100)?;
            let status = host_sender::stream::fresh_status(&mut client)?;
            println!("{}", commands::format_status(&status, axes));
            Ok(ExitCode::SUCCESS)
        }),
        Command::Jog {
            axis,
            distance,
            feed,
            board,
        } => axis_index(axis).and_then(|a| {
            board
                .target()
                .and_then(|t| commands::jog(t, a, distance, feed))
        }),
        Command::Home { axes, board } => axis_mask(axes.as_deref())
            .and_then(|mask| board.target().and_then(|t| commands::home(t, mask))),
        Command::Mdi { blocks, board } => board.target().and_then(|t| commands::mdi(t, &blocks)),
        Command::Simulate {
            file,
            json,
            vcd,
            from,
            to,
            setup,
        } => simulate(&file, json, vcd, from, to, setup),
        Command::Preview {
            file,
            output,
            setup,
        } => setup
            .map_or_else(
                || Ok(Default::default()),
                |f| host_sender::setup_file::SetupFile::load(&f),
            )
            .and_then(|s| host_sender::preview::run(&file, &output, &s)),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("gantry: {e:#}");
            ExitCode::from(2)
        }
    }
}
