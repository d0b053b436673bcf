//! `gantry preview FILE -o out.png|out.svg`: a picture of a program's tool path.
//!
//! Four views (top, front, side, isometric) with rapids dashed, feeds and arcs coloured by planned
//! speed, arcs drawn as true curves, the machine travel box and a legend with the total time and
//! the job's extents. The picture is built as SVG ([`svg`]) and rasterised by resvg for PNG
//! ([`raster`]), with an embedded font, so it looks the same everywhere.
//!
//! Pipeline: program → canonical actions (the core's interpreter, or canon JSON Lines for
//! `.jsonl` files) → [`adapt`] → [`PreviewJob`] → [`plan`] (planned speeds and time, when the
//! planner accepts the program) → [`render`].

pub mod adapt;
pub mod colour;
pub mod geom;
pub mod model;
pub mod plan;
pub mod raster;
pub mod source;
pub mod svg;
pub mod view;

pub use model::{ArcGeom, Box3, MoveKind, PreviewJob, PreviewMove, ProgramError, SpeedSource};
pub use svg::{Layout, RenderOptions};
pub use view::View;

use anyhow::{bail, Context};
use gantry_machine::setup::Setup;
use std::path::Path;
use std::process::ExitCode;

/// Output format of the picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Svg,
    Png,
}

impl Format {
    /// From the output file's extension.
    pub fn from_path(p: &Path) -> anyhow::Result<Format> {
        match p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("svg") => Ok(Format::Svg),
            Some("png") => Ok(Format::Png),
            _ => bail!("{}: the output must end in .png or .svg", p.display()),
        }
    }
}

/// Renders a job into the bytes of an SVG or PNG file. Pure: no files, no interpreter.
pub fn render(job: &PreviewJob, format: Format, opts: &RenderOptions) -> anyhow::Result<Vec<u8>> {
    let (text, _) = svg::render_svg(job, opts);
    match format {
        Format::Svg => Ok(text.into_bytes()),
        Format::Png => raster::svg_to_png(&text),
    }
}

/// A program made ready for drawing.
#[derive(Clone, Debug, PartialEq)]
pub struct Prepared {
    pub job: PreviewJob,
    /// The interpreter error that ended the program early.
    pub error: Option<ProgramError>,
    /// Why the planner's figures are missing, when they are.
    pub note: Option<String>,
}

/// Builds the preview job of a program text: interprets it (or reads canon JSON Lines when
/// `jsonl`), then plans it.
pub fn job_from_program(
    program: &[u8],
    jsonl: bool,
    setup: &Setup,
    title: &str,
) -> anyhow::Result<Prepared> {
    if !jsonl {
        return Ok(job_from_source(
            gantry_machine::gcode::MemorySource::new(program),
            setup,
            title,
        ));
    }
    let (canon, error) =
        adapt::canon_from_jsonl(std::str::from_utf8(program).context("canon JSON Lines")?)?;
    let mut job = adapt::from_canon(&canon, setup, title);
    let note = match plan::plan(&canon, setup) {
        Ok(p) => {
            plan::apply(&mut job, &p);
            None
        }
        Err(e) => Some(planner_note(&e)),
    };
    Ok(Prepared { job, error, note })
}

fn planner_note(e: &anyhow::Error) -> String {
    format!("planner: {e:#}; colouring by programmed feed, time estimated without acceleration")
}

/// Builds the preview job of the program in `src` in one pass: each action becomes a move as it
/// is interpreted and goes to the planner at once (the moves are kept, for drawing; the actions
/// and the program text are not).
pub fn job_from_source<S: gantry_machine::gcode::ProgramSource>(
    src: S,
    setup: &Setup,
    title: &str,
) -> Prepared {
    let mut actions = source::Actions::new(src, &setup.interp_config());
    let mut adapter = adapt::MoveAdapter::new(setup);
    let mut moves = Vec::new();
    let mut peaks = plan::Peaks::default();
    let planned = {
        let mut each = actions.by_ref().inspect(|c| {
            if let Some(m) = adapter.take(c) {
                moves.push(m);
            }
        });
        let planned = plan::plan_stream(each.by_ref(), setup, &mut |r, _| peaks.add(r));
        if planned.is_err() {
            each.for_each(drop);
        }
        planned
    };
    let error = source::ended_error(&actions.ended, "preview");
    let mut job = PreviewJob {
        title: title.to_string(),
        moves,
        total_time_s: Some(adapter.seconds),
        speed_source: SpeedSource::Programmed,
        travel: Some(Box3::travel(setup)),
    };
    let note = match planned {
        Ok(counts) => {
            let p = plan::Plan {
                peak_mm_min: peaks.0,
                total_time_s: plan::seconds(counts),
            };
            plan::apply(&mut job, &p);
            None
        }
        Err((c, e)) => Some(planner_note(&anyhow::anyhow!(
            "line {}: planner refused the move: {e:?}",
            c.line
        ))),
    };
    Prepared { job, error, note }
}

/// Runs `gantry preview FILE -o OUT`: exit code 0, or 1 when the program has an error (the
/// picture then shows it up to the error).
pub fn run(file: &Path, out: &Path, setup: &Setup) -> anyhow::Result<ExitCode> {
    let format = Format::from_path(out)?;
    let jsonl = file.extension().is_some_and(|e| e == "jsonl");
    let title = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let Prepared { job, error, note } = if jsonl {
        let program =
            std::fs::read(file).with_context(|| format!("cannot read {}", file.display()))?;
        job_from_program(&program, jsonl, setup, &title)?
    } else {
        let src = source::FileSource::open(file)
            .with_context(|| format!("cannot read {}", file.display()))?;
        job_from_source(src, setup, &title)
    };
    if let Some(n) = note {
        eprintln!("gantry preview: {n}");
    }
    if let Some(e) = &error {
        eprintln!(
            "{}:{}: {} (the preview shows the program up to this line)",
            file.display(),
            e.line,
            e.message
        );
    }
    let bytes = render(&job, format, &RenderOptions::default())?;
    std::fs::write(out, &bytes).with_context(|| format!("cannot write {}", out.display()))?;
    println!(
        "{}: {} moves, total time {} → {} ({} bytes)",
        file.display(),
        job.moves.len(),
        job.total_time_s
            .map(svg::fmt_duration)
            .unwrap_or_else(|| "unknown".into()),
        out.display(),
        bytes.len()
    );
    Ok(if error.is_some() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
