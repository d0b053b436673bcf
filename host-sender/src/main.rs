//! `gantry`: stream, check, simulate and preview G-code for a Gantry board (or its emulation).
use clap::{Parser, Subcommand};
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
    },
    /// Stream a program to the board (with no --port: the emulated board) with progress and a report.
    Stream {
        file: PathBuf,
        /// Serial port of the board (e.g. /dev/ttyACM0); without it, the emulated board runs the job.
        #[arg(long)]
        port: Option<String>,
        /// Machine setup for the emulated board (default: the built-in defaults, docs/settings.md).
        #[arg(long)]
        setup: Option<PathBuf>,
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

#[derive(Subcommand)]
enum SetupAction {
    /// Print a setup file's effective values (every default filled in), or the defaults.
    Show { file: Option<PathBuf> },
    /// Validate a setup file; every error names the key and the allowed range.
    Check { file: PathBuf },
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
    }
    Ok(ExitCode::SUCCESS)
}

fn stream(
    file: &std::path::Path,
    port: Option<String>,
    setup: Option<PathBuf>,
) -> anyhow::Result<ExitCode> {
    use host_sender::stream::{run, Target};
    let target = match port {
        Some(p) => Target::Port(p),
        None => Target::Emulated(match setup {
            Some(f) => host_sender::setup_file::SetupFile::load(&f)?,
            None => Default::default(),
        }),
    };
    run(file, target)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check { file, canon } => host_sender::check::run(&file, canon),
        Command::Setup { action } => setup(action),
        Command::Stream { file, port, setup } => stream(&file, port, setup),
        Command::Simulate { file, json } => host_sender::simulate::run(&file, json),
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
