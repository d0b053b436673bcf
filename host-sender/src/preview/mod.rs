//! `gantry preview FILE -o out.png|out.svg`: a picture of a program's tool path.
//!
//! Four views (top, front, side, isometric) with rapids dashed, feeds and arcs coloured by planned
//! speed, arcs drawn as true curves, the machine travel box and a legend with the total time and
//! the job's extents. The picture is built as SVG ([`svg`]); for PNG its frame is rasterised by
//! resvg ([`raster`]), with an embedded font, so it looks the same everywhere, and the moves are
//! drawn straight into pixmaps as resvg would draw their elements ([`lanes::PngLanes`]).
//!
//! Pipeline: program → canonical actions (the core's interpreter, or canon JSON Lines for
//! `.jsonl` files) → [`adapt`] → moves → [`pass`] (each move's planned speed and the job's time,
//! when the planner accepts the program) → [`svg`] / [`lanes`] / [`raster`].
//!
//! `gantry preview` ([`run`]) reads the file twice and keeps no moves: the first pass sums the job
//! up ([`svg::StatsBuilder`]: extents, speed range, lengths, time), which fixes the picture's frame
//! ([`svg::Frame`]); the second draws each move into its view's lane as it comes ([`lanes`]).
//! Memory stays bounded whatever the program's length: the planner's look-ahead, one chunk of
//! SVG text per lane (in temporary files) or, for PNG, one pixmap per view and lane.
//! [`PreviewJob`] (every move in memory) remains for callers that build a job themselves and for tests.

pub mod adapt;
pub(crate) mod colour;
pub mod geom;
pub(crate) mod lanes;
pub(crate) mod model;
pub(crate) mod pass;
pub(crate) mod plan;
pub mod raster;
pub mod source;
pub mod svg;
pub(crate) mod view;

pub use model::{ArcGeom, Box3, MoveKind, PreviewJob, PreviewMove, ProgramError, SpeedSource};
pub use svg::{Layout, RenderOptions};
pub use view::View;

use anyhow::{bail, Context};
use gantry_machine::setup::Setup;
use std::io::Write as _;
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
    pub(crate) fn from_path(p: &Path) -> anyhow::Result<Format> {
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
    match format {
        Format::Svg => Ok(svg::render_svg(job, opts).0.into_bytes()),
        Format::Png => {
            let frame = svg::Frame::new(job, &svg::Stats::of(job), opts);
            let mut lanes = lanes::PngLanes::new(&frame)?;
            for m in &job.moves {
                for k in lanes::lanes_of(&frame, svg::Lane::of(m)) {
                    lanes.draw(k, m);
                }
            }
            lanes
                .finish()?
                .encode_png()
                .context("encoding the preview PNG")
        }
    }
}

/// A program made ready for drawing.
#[derive(Clone, Debug, PartialEq)]
pub struct Prepared {
    pub job: PreviewJob,
    /// The interpreter error that ended the program early.
    pub error: Option<ProgramError>,
    /// Why the planner's figures are missing, when they are.
    pub(crate) note: Option<String>,
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
    let (job, note) = job_from_actions(canon.into_iter(), setup, title);
    Ok(Prepared { job, error, note })
}

fn planner_note(e: &anyhow::Error) -> String {
    format!("planner: {e:#}; colouring by programmed feed, time estimated without acceleration")
}

/// Builds the preview job of the program in `src` in one pass: each action becomes a move as it
/// is interpreted and goes to the planner at once (the moves are kept, for drawing; the actions
/// and the program text are not). `gantry preview` itself keeps no moves ([`run`]).
pub(crate) fn job_from_source<S: gantry_machine::gcode::ProgramSource>(
    src: S,
    setup: &Setup,
    title: &str,
) -> Prepared {
    let mut actions = source::Actions::new(src, &setup.interp_config());
    let (job, note) = job_from_actions(actions.by_ref(), setup, title);
    let error = source::ended_error(&actions.ended, "preview");
    Prepared { job, error, note }
}

/// The job of `actions`, with every move, and the planner's note.
fn job_from_actions(
    actions: impl Iterator<Item = gantry_machine::canon::Canon>,
    setup: &Setup,
    title: &str,
) -> (PreviewJob, Option<String>) {
    let mut moves = Vec::new();
    let end = pass::each_move(
        actions,
        setup,
        &[0; gantry_machine::units::MAX_AXES],
        true,
        &mut |m, peak| moves.push((*m, peak)),
    );
    let (mut job, note) = heading(title, setup, &end);
    let planned = job.speed_source == SpeedSource::Planned;
    job.moves = moves
        .into_iter()
        .map(|(m, peak)| if planned { with_peak(&m, peak) } else { m })
        .collect();
    (job, note)
}

/// A move coloured by its planned peak speed, when it has one.
fn with_peak(m: &PreviewMove, peak: Option<f64>) -> PreviewMove {
    PreviewMove {
        speed_mm_min: peak.or(m.speed_mm_min),
        ..*m
    }
}

/// Everything of a job but its moves, after a pass over it (planned figures when the planner
/// accepted the whole program), and the planner's note.
fn heading(title: &str, setup: &Setup, end: &pass::PassEnd) -> (PreviewJob, Option<String>) {
    let (total, source, note) = match &end.planned {
        Some(Ok(counts)) => (plan::seconds(*counts), SpeedSource::Planned, None),
        Some(Err(note)) => (end.estimate_s, SpeedSource::Programmed, Some(note.clone())),
        None => (end.estimate_s, SpeedSource::Programmed, None),
    };
    let job = PreviewJob {
        title: title.to_string(),
        moves: Vec::new(),
        total_time_s: Some(total),
        speed_source: source,
        travel: Some(Box3::travel(setup)),
    };
    (job, note)
}

/// A program file, read once per pass (G-code, or canon JSON Lines for `.jsonl` files).
struct ProgramFile<'a> {
    path: &'a Path,
    jsonl: bool,
    setup: &'a Setup,
    /// Where the machine stands at the start (nm).
    at: &'a gantry_machine::units::Pos,
}

impl ProgramFile<'_> {
    /// One pass over the program (see [`pass::each_move`]); also returns the error that ended
    /// it early.
    fn pass(
        &self,
        planning: bool,
        each: &mut dyn FnMut(&PreviewMove, Option<f64>),
    ) -> anyhow::Result<(pass::PassEnd, Option<ProgramError>)> {
        let cannot = || format!("cannot read {}", self.path.display());
        if self.jsonl {
            let file = std::fs::File::open(self.path).with_context(cannot)?;
            let mut actions = adapt::JsonlActions::new(std::io::BufReader::new(file));
            let end = pass::each_move(actions.by_ref(), self.setup, self.at, planning, each);
            if let Some(e) = actions.failure.take() {
                return Err(e);
            }
            return Ok((end, actions.ended.take()));
        }
        let src = source::FileSource::open(self.path).with_context(cannot)?;
        let mut actions =
            source::Actions::new(src, &self.setup.interp_config()).starting_at(self.at);
        let end = pass::each_move(actions.by_ref(), self.setup, self.at, planning, each);
        Ok((end, source::ended_error(&actions.ended, "preview")))
    }
}

/// Runs `gantry preview FILE -o OUT`: exit code 0, or 1 when the program has an error (the
/// picture then shows it up to the error).
///
/// Two passes over the file, each in constant memory: the first sums the job up (extents, speed
/// range, lengths, time: [`svg::StatsBuilder`]), the second draws each move as it comes into its
/// view's lane ([`lanes`]); no move is kept beyond the planner's look-ahead.
///
/// `at`: where the machine stands when the job starts (nm; `crate::session::standing`).
pub fn run(
    file: &Path,
    out: &Path,
    setup: &Setup,
    at: &gantry_machine::units::Pos,
) -> anyhow::Result<ExitCode> {
    let format = Format::from_path(out)?;
    let program = ProgramFile {
        path: file,
        jsonl: file.extension().is_some_and(|e| e == "jsonl"),
        setup,
        at,
    };
    let title = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut planned = svg::StatsBuilder::default();
    let mut programmed = svg::StatsBuilder::default();
    let (end, error) = program.pass(true, &mut |m, peak| {
        programmed.add(m);
        planned.add(&with_peak(m, peak));
    })?;
    let (job, note) = heading(&title, setup, &end);
    let planning = job.speed_source == SpeedSource::Planned;
    let stats = if planning { planned } else { programmed }.finish();
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
    let frame = svg::Frame::new(&job, &stats, &RenderOptions::default());
    let mut failed = None;
    let mut draw = |put: &mut dyn FnMut(usize, &PreviewMove) -> anyhow::Result<()>| {
        program.pass(planning, &mut |m, peak| {
            let m = if planning { with_peak(m, peak) } else { *m };
            for k in lanes::lanes_of(&frame, svg::Lane::of(&m)) {
                if failed.is_none() {
                    failed = put(k, &m).err();
                }
            }
        })
    };
    let write = |bytes: &[u8]| {
        std::fs::write(out, bytes).with_context(|| format!("cannot write {}", out.display()))
    };
    match format {
        Format::Svg => {
            let mut parts = lanes::SvgLanes::new(frame.lanes.len())?;
            draw(&mut |k, m| parts.put(k, &frame.element(frame.lanes[k].panel, m)))?;
            if let Some(e) = failed {
                return Err(e);
            }
            let file = std::fs::File::create(out)
                .with_context(|| format!("cannot write {}", out.display()))?;
            let mut w = std::io::BufWriter::new(file);
            parts.write_document(&frame, &mut w)?;
            w.flush()
                .with_context(|| format!("cannot write {}", out.display()))?;
        }
        Format::Png => {
            let mut pixmaps = lanes::PngLanes::new(&frame)?;
            draw(&mut |k, m| {
                pixmaps.draw(k, m);
                Ok(())
            })?;
            if let Some(e) = failed {
                return Err(e);
            }
            let png = pixmaps
                .finish()?
                .encode_png()
                .context("encoding the preview PNG")?;
            write(&png)?;
        }
    }
    let size = std::fs::metadata(out).map(|m| m.len()).unwrap_or(0);
    println!(
        "{}: {} moves, total time {} → {} ({} bytes)",
        file.display(),
        stats.rapids + stats.feeds + stats.arcs,
        job.total_time_s
            .map(svg::fmt_duration)
            .unwrap_or_else(|| "unknown".into()),
        out.display(),
        size
    );
    Ok(if error.is_some() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
