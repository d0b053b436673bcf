//! Renders a [`PreviewJob`] as an SVG document: the four views in a 2×2 grid and a legend panel.
//! Everything but the moves ([`Frame`]) depends only on the job's figures ([`Stats`], which
//! [`StatsBuilder`] sums up one move at a time), so the moves can be streamed into it.
//!
//! Every move becomes one `<path>` per view (`class="rapid"` with a dash pattern, or `class="feed"`
//! / `class="arc"` stroked in its speed colour, `data-line` holding the source line); arcs are
//! cubic Béziers from [`super::geom`]. The same document is rasterised for PNG output, so both
//! formats always show the same picture.

use super::colour::{colour_at, hex, nice_step, Rgb, SpeedScale, STOPS};
use super::geom::{arc_cubics, extend, length};
use super::model::{Box3, MoveKind, PreviewJob, PreviewMove, SpeedSource, P3};
use super::view::{Fit, View};
use std::fmt::Write;
use std::io::Write as _;

/// Picture size in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 1400,
            height: 1000,
        }
    }
}

/// Where a view was drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Panel {
    pub view: View,
    /// Plot area in pixels: x, y, width, height.
    pub(crate) plot: [f64; 4],
    /// Machine → pixel mapping of this view.
    pub fit: Fit,
}

/// The picture's geometry, for callers (and tests) that need to find things in it.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub panels: Vec<Panel>,
}

/// Figures the legend shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    pub extents: Box3,
    pub(crate) rapids: usize,
    pub(crate) feeds: usize,
    pub(crate) arcs: usize,
    pub(crate) rapid_len_mm: f64,
    pub(crate) feed_len_mm: f64,
    pub(crate) scale: Option<SpeedScale>,
    /// Where the first move starts and the last one ends.
    pub(crate) ends: Option<(P3, P3)>,
}

impl Stats {
    pub fn of(job: &PreviewJob) -> Stats {
        let mut b = StatsBuilder::default();
        for m in &job.moves {
            b.add(m);
        }
        b.finish()
    }
}

/// Accumulates [`Stats`] one move at a time, in program order (the sums come out as
/// [`Stats::of`]'s), so a program can be summed up without keeping its moves.
#[derive(Clone, Debug)]
pub(crate) struct StatsBuilder {
    stats: Stats,
    /// Lowest and highest speed of the feeds and arcs so far, mm/min.
    speeds: Option<(f64, f64)>,
}

impl Default for StatsBuilder {
    fn default() -> Self {
        StatsBuilder {
            stats: Stats {
                extents: Box3::EMPTY,
                rapids: 0,
                feeds: 0,
                arcs: 0,
                rapid_len_mm: 0.0,
                feed_len_mm: 0.0,
                scale: None,
                ends: None,
            },
            speeds: None,
        }
    }
}

impl StatsBuilder {
    pub(crate) fn add(&mut self, m: &PreviewMove) {
        let s = &mut self.stats;
        extend(&mut s.extents, m);
        s.ends = Some((s.ends.map_or(m.from, |e| e.0), m.to));
        match m.kind {
            MoveKind::Rapid => {
                s.rapids += 1;
                s.rapid_len_mm += length(m);
            }
            MoveKind::Feed => {
                s.feeds += 1;
                s.feed_len_mm += length(m);
            }
            MoveKind::Arc(_) => {
                s.arcs += 1;
                s.feed_len_mm += length(m);
            }
        }
        if let Some(v) = m
            .speed_mm_min
            .filter(|v| v.is_finite() && m.kind != MoveKind::Rapid)
        {
            self.speeds = Some(
                self.speeds
                    .map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))),
            );
        }
    }

    pub(crate) fn finish(self) -> Stats {
        let scale = self
            .speeds
            .and_then(|(lo, hi)| SpeedScale::from_speeds([lo, hi]));
        Stats {
            scale,
            ..self.stats
        }
    }
}

const FONT: &str = "DejaVu Sans, sans-serif";
const RAPID_COLOUR: &str = "#7b8591";
const RAPID_RGB: Rgb = [0x7b, 0x85, 0x91];
const RAPID_DASH: &str = "5 3";
const NO_SPEED_RGB: Rgb = [0x49, 0x50, 0x57];
const TRAVEL_COLOUR: &str = "#343a40";
const TRAVEL_DASH: &str = "12 3 2 3";
const WARN_COLOUR: &str = "#c92a2a";
const TEXT: &str = "#212529";
const MUTED: &str = "#6c757d";

/// Renders the job; returns the SVG text and where each view went.
pub fn render_svg(job: &PreviewJob, opts: &RenderOptions) -> (String, Layout) {
    let frame = Frame::new(job, &Stats::of(job), opts);
    let mut s = Vec::with_capacity(frame.body.len() + 4096 + job.moves.len() * 4 * 96);
    let _ = frame.write(&mut s, &mut |s, mark| {
        for m in job.moves.iter().filter(|m| Lane::of(m) == mark.lane) {
            s.write_all(frame.element(mark.panel, m).as_bytes())?;
        }
        Ok(())
    });
    let text = String::from_utf8(s).expect("the SVG is text");
    (text, frame.layout)
}

/// The two groups each view draws its moves in: rapids first (dashed, underneath), then feeds and
/// arcs in their speed colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Lane {
    Rapids,
    Feeds,
}

impl Lane {
    pub(crate) fn of(m: &PreviewMove) -> Lane {
        if m.kind == MoveKind::Rapid {
            Lane::Rapids
        } else {
            Lane::Feeds
        }
    }

    /// The index of a view's lane in [`Frame::lanes`].
    pub(crate) fn index(self, panel: usize) -> usize {
        panel * 2 + self as usize
    }
}

/// Where one view's moves of one lane go in the [`Frame`]'s body.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LaneMark {
    /// Byte offset in the body.
    pub(crate) at: usize,
    pub(crate) panel: usize,
    pub(crate) lane: Lane,
    /// The `<g …>` tags open at that point, outermost first.
    pub(crate) groups: Vec<String>,
}

impl LaneMark {
    /// Its index in [`Frame::lanes`].
    pub(crate) fn index(&self) -> usize {
        self.lane.index(self.panel)
    }
}

/// The whole picture but the moves: what the document holds, and where each lane of moves goes.
/// Built from a job's figures ([`Stats`], the title, time and travel box) alone, so the moves can
/// be streamed into it afterwards ([`Frame::write`], [`super::raster`]).
#[derive(Clone, Debug)]
pub(crate) struct Frame {
    pub(crate) layout: Layout,
    /// The `<svg …>` tag.
    pub(crate) open: String,
    /// The white background.
    pub(crate) background: String,
    /// `<defs>…</defs>`: the speed gradient and the views' clip paths.
    pub(crate) defs: String,
    /// The rest of the document, without the closing `</svg>`.
    pub(crate) body: String,
    /// Lane positions in the body, in order: view 0 rapids, view 0 feeds, view 1 rapids, …
    pub(crate) lanes: Vec<LaneMark>,
    scale: Option<SpeedScale>,
}

impl Frame {
    /// The frame of `job` (its moves are not looked at: `stats` sums them up).
    pub(crate) fn new(job: &PreviewJob, stats: &Stats, opts: &RenderOptions) -> Frame {
        let (w, h) = (opts.width as f64, opts.height as f64);
        let legend_w = legend_width(w);
        let layout = layout(job, stats, w - legend_w, h, opts);

        let open = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="{FONT}">
"#
        );
        let background = format!(
            r##"<rect width="{w}" height="{h}" fill="#ffffff"/>
"##
        );
        let mut defs = String::from(
            r#"<defs>
<linearGradient id="speed" x1="0" y1="0" x2="1" y2="0">
"#,
        );
        for (f, c) in STOPS {
            let _ = writeln!(defs, r#"<stop offset="{f}" stop-color="{}"/>"#, hex(c));
        }
        defs.push_str("</linearGradient>\n");
        for (i, p) in layout.panels.iter().enumerate() {
            let [x, y, pw, ph] = p.plot;
            let _ = writeln!(
                defs,
                r#"<clipPath id="clip{i}"><rect x="{x:.1}" y="{y:.1}" width="{pw:.1}" height="{ph:.1}"/></clipPath>"#
            );
        }
        defs.push_str("</defs>\n");

        let mut body = String::new();
        let mut lanes = Vec::new();
        for (i, p) in layout.panels.iter().enumerate() {
            draw_panel(&mut body, &mut lanes, job, stats, p, i);
        }
        draw_legend(
            &mut body,
            job,
            stats,
            w - legend_w + 4.0,
            legend_w - 16.0,
            h,
        );
        Frame {
            layout,
            open,
            background,
            defs,
            body,
            lanes,
            scale: stats.scale,
        }
    }

    /// The SVG element of move `m` in view `panel` (one line).
    pub(crate) fn element(&self, panel: usize, m: &PreviewMove) -> String {
        move_element(&self.layout.panels[panel].fit, self.scale, m)
    }

    /// The stroke colour of move `m`, as its element has it ([`Frame::element`]).
    pub(crate) fn stroke_rgb(&self, m: &PreviewMove) -> Rgb {
        stroke_rgb(self.scale, m)
    }

    /// Writes the document, calling `lane` where each lane's moves go.
    pub(crate) fn write<W: std::io::Write>(
        &self,
        out: &mut W,
        lane: &mut dyn FnMut(&mut W, &LaneMark) -> std::io::Result<()>,
    ) -> std::io::Result<()> {
        out.write_all(self.open.as_bytes())?;
        out.write_all(self.background.as_bytes())?;
        out.write_all(self.defs.as_bytes())?;
        let mut from = 0;
        for mark in &self.lanes {
            out.write_all(&self.body.as_bytes()[from..mark.at])?;
            lane(out, mark)?;
            from = mark.at;
        }
        out.write_all(&self.body.as_bytes()[from..])?;
        out.write_all(b"</svg>\n")
    }
}

/// The legend panel's width in a picture `w` px wide.
fn legend_width(w: f64) -> f64 {
    (w * 0.25).clamp(240.0, 340.0)
}

/// Places the four views: top and isometric above, front and side below (front under top, so X
/// lines up). The lower row is only as tall as the job's Z range needs (within 28–50 % of the
/// height). The three orthographic views share one scale, so they can be compared; the isometric
/// view has its own.
fn layout(job: &PreviewJob, stats: &Stats, views_w: f64, h: f64, opts: &RenderOptions) -> Layout {
    const CHROME_W: f64 = 84.0;
    const CHROME_H: f64 = 72.0;
    let content = padded(content_box(job, stats));
    let size = |i: usize| content.max[i] - content.min[i];
    let pw = views_w / 2.0;
    let s_w = ((pw - CHROME_W) / size(0)).min((pw - CHROME_W) / size(1));
    let s0 = s_w.min((h - 2.0 * CHROME_H) / (size(1) + size(2)));
    let lower = (size(2) * s0 + CHROME_H).clamp(0.28 * h, 0.5 * h);
    let rows = [(0.0, h - lower), (h - lower, lower)];
    let plots: Vec<(View, [f64; 4])> = [View::Top, View::Iso, View::Front, View::Side]
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let (top, rh) = rows[i / 2];
            let (bx, by) = ((i % 2) as f64 * pw + 6.0, top + 6.0);
            let (bw, bh) = (pw - 12.0, rh - 12.0);
            let plot = if v == View::Iso {
                [bx + 12.0, by + 32.0, bw - 24.0, bh - 44.0]
            } else {
                [
                    bx + 58.0,
                    by + 32.0,
                    bw - CHROME_W + 12.0,
                    bh - CHROME_H + 12.0,
                ]
            };
            (v, plot)
        })
        .collect();
    let fit_scale = |v: View, p: &[f64; 4]| Fit::scale_to_fit(v.bounds(&content), p[2], p[3]);
    let ortho = plots
        .iter()
        .filter(|(v, _)| *v != View::Iso)
        .map(|(v, p)| fit_scale(*v, p))
        .fold(f64::INFINITY, f64::min);
    let panels = plots
        .into_iter()
        .map(|(view, plot)| {
            let scale = if view == View::Iso {
                fit_scale(view, &plot)
            } else {
                ortho
            };
            let fit = Fit::centred(view, view.bounds(&content), plot, scale);
            Panel { view, plot, fit }
        })
        .collect();
    Layout {
        width: opts.width,
        height: opts.height,
        panels,
    }
}

/// What the views are fitted to: the job, or the travel box when there is no motion.
fn content_box(job: &PreviewJob, stats: &Stats) -> Box3 {
    if !stats.extents.is_empty() {
        stats.extents
    } else if let Some(t) = job.travel.filter(|t| !t.is_empty()) {
        t
    } else {
        Box3 {
            min: [-1.0; 3],
            max: [1.0; 3],
        }
    }
}

fn padded(b: Box3) -> Box3 {
    let size = (0..3).map(|i| b.max[i] - b.min[i]).fold(0.0, f64::max);
    let pad = (size * 0.04).max(0.5);
    Box3 {
        min: b.min.map(|v| v - pad),
        max: b.max.map(|v| v + pad),
    }
}

fn draw_panel(
    s: &mut String,
    lanes: &mut Vec<LaneMark>,
    job: &PreviewJob,
    stats: &Stats,
    p: &Panel,
    index: usize,
) {
    let [x, y, w, h] = p.plot;
    let fit = &p.fit;
    let box_ = if p.view == View::Iso {
        [x - 6.0, y - 26.0, w + 12.0, h + 32.0]
    } else {
        [x - 52.0, y - 26.0, w + 66.0, h + 54.0]
    };
    let view_group = format!(r#"<g class="view" id="view-{index}">"#);
    let _ = writeln!(
        s,
        r##"{view_group}<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" rx="4" fill="#ffffff" stroke="#dee2e6"/>"##,
        box_[0], box_[1], box_[2], box_[3]
    );
    text(
        s,
        box_[0] + 10.0,
        box_[1] + 19.0,
        14.0,
        "bold",
        TEXT,
        "start",
        p.view.title(),
    );

    if let Some((hname, vname)) = p.view.axis_names() {
        draw_grid(s, p);
        text(
            s,
            x + w - 6.0,
            y + h - 6.0,
            11.0,
            "bold",
            MUTED,
            "end",
            &format!("{hname} mm"),
        );
        text(
            s,
            x + 6.0,
            y + 14.0,
            11.0,
            "bold",
            MUTED,
            "start",
            &format!("{vname} mm"),
        );
    } else {
        draw_triad(s, p);
    }
    let clip_group = format!(r#"<g clip-path="url(#clip{index})">"#);
    let _ = writeln!(s, "{clip_group}");
    let travel = job.travel.filter(|t| !t.is_empty());
    if let Some(t) = &travel {
        draw_outside_travel(s, p, t);
        if p.view == View::Iso {
            // Context only: beneath the moves, which it would otherwise cross.
            draw_travel(s, p, t, &stats.extents);
        }
    }
    if p.view == View::Iso && !stats.extents.is_empty() {
        // The job's bounding box gives the isometric view its depth cue.
        let _ = write!(
            s,
            r##"<path class="extents" fill="none" stroke="#ced4da" stroke-width="1" d="{}"/>"##,
            box_edges(fit, &stats.extents)
        );
        s.push('\n');
    }
    for (lane, group) in [(Lane::Rapids, RAPIDS_GROUP), (Lane::Feeds, FEEDS_GROUP)] {
        s.push_str(group);
        s.push('\n');
        lanes.push(LaneMark {
            at: s.len(),
            panel: index,
            lane,
            groups: vec![view_group.clone(), clip_group.clone(), group.to_string()],
        });
        s.push_str("</g>\n");
    }
    // In the flat views the outline goes on top, so a job that covers it cannot hide it.
    if let Some(t) = travel.filter(|_| p.view != View::Iso) {
        draw_travel(s, p, &t, &stats.extents);
    }
    draw_markers(s, stats, fit);
    s.push_str("</g></g>\n");
}

/// Grid lines at a round spacing, labelled along the left and bottom edges.
fn draw_grid(s: &mut String, p: &Panel) {
    let [x, y, w, h] = p.plot;
    let fit = &p.fit;
    let step = nice_step(64.0 / fit.scale);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let (x0, y1) = fit.unpx(x, y);
    let (x1, y0) = fit.unpx(x + w, y + h);
    let mut grid = String::new();
    let mut axes = String::new();
    let mut k = (x0 / step).ceil() as i64;
    while k as f64 * step <= x1 {
        let v = k as f64 * step;
        let (px, _) = fit.px2(v, 0.0);
        let d = if k == 0 { &mut axes } else { &mut grid };
        let _ = write!(d, "M{px:.1} {y:.1}V{:.1}", y + h);
        let label = fmt_num(v, decimals);
        text(s, px, y + h + 14.0, 10.0, "normal", MUTED, "middle", &label);
        k += 1;
    }
    let mut k = (y0 / step).ceil() as i64;
    while k as f64 * step <= y1 {
        let v = k as f64 * step;
        let (_, py) = fit.px2(0.0, v);
        let d = if k == 0 { &mut axes } else { &mut grid };
        let _ = write!(d, "M{x:.1} {py:.1}H{:.1}", x + w);
        let label = fmt_num(v, decimals);
        text(s, x - 5.0, py + 3.5, 10.0, "normal", MUTED, "end", &label);
        k += 1;
    }
    let note = format!("grid {} mm", fmt_num(step, decimals));
    text(s, x + w, y - 12.0, 10.5, "normal", MUTED, "end", &note);
    let _ = writeln!(
        s,
        r##"<path class="grid" fill="none" stroke="#edf0f2" stroke-width="1" d="{grid}"/>"##
    );
    if !axes.is_empty() {
        let _ = writeln!(
            s,
            r##"<path class="grid axis" fill="none" stroke="#adb5bd" stroke-width="1" d="{axes}"/>"##
        );
    }
}

/// Axis directions in the isometric view.
fn draw_triad(s: &mut String, p: &Panel) {
    let [x, y, _, h] = p.plot;
    let (ox, oy) = (x + 34.0, y + h - 30.0);
    for (i, name) in ["X", "Y", "Z"].iter().enumerate() {
        let mut unit = [0.0; 3];
        unit[i] = 1.0;
        let (dx, dy) = p.view.project(unit);
        let len = dx.hypot(dy);
        let (ex, ey) = (ox + dx / len * 22.0, oy - dy / len * 22.0);
        let _ = writeln!(
            s,
            r##"<path class="triad" stroke="#495057" stroke-width="1.5" d="M{ox:.1} {oy:.1}L{ex:.1} {ey:.1}"/>"##
        );
        let (lx, ly) = (ox + dx / len * 31.0, oy - dy / len * 31.0 + 4.0);
        text(s, lx, ly, 11.0, "bold", "#495057", "middle", name);
    }
}

/// The machine travel box: a red outline, and a red tint over what lies outside it.
fn draw_travel(s: &mut String, p: &Panel, t: &Box3, job: &Box3) {
    let fit = &p.fit;
    if p.view == View::Iso {
        // A far-away travel box is only a stray line across the view: draw it when it is
        // about the job's size or when the job leaves it.
        let area = |b: [f64; 4]| (b[2] - b[0]) * (b[3] - b[1]);
        let near = job.is_empty() || area(p.view.bounds(t)) <= 6.0 * area(p.view.bounds(job));
        if near || !t.contains(job) {
            let _ = writeln!(
                s,
                r##"<path class="travel" fill="none" stroke="#868e96" stroke-width="1" stroke-dasharray="{TRAVEL_DASH}" d="{}"/>"##,
                box_edges(fit, t)
            );
        }
        return;
    }
    let [ax, ay, bx, by] = travel_rect(p, t);
    let _ = writeln!(
        s,
        r#"<path class="travel" fill="none" stroke="{TRAVEL_COLOUR}" stroke-width="1.5" stroke-dasharray="{TRAVEL_DASH}" d="M{ax:.1} {ay:.1}H{bx:.1}V{by:.1}H{ax:.1}Z"/>"#
    );
}

/// The travel box of an orthographic view in pixels (left, top, right, bottom), clamped to a
/// little beyond the plot so huge boxes stay sane numbers.
fn travel_rect(p: &Panel, t: &Box3) -> [f64; 4] {
    let b = p.view.bounds(t);
    let (ax, ay) = p.fit.px2(b[0], b[3]);
    let (bx, by) = p.fit.px2(b[2], b[1]);
    let [x, y, w, h] = p.plot;
    let cl = |v: f64, lo: f64, hi: f64| v.clamp(lo - 10.0, hi + 10.0);
    [
        cl(ax, x, x + w),
        cl(ay, y, y + h),
        cl(bx, x, x + w),
        cl(by, y, y + h),
    ]
}

/// Greys what lies outside the travel box in an orthographic view.
fn draw_outside_travel(s: &mut String, p: &Panel, t: &Box3) {
    if p.view == View::Iso {
        return;
    }
    let [x, y, w, h] = p.plot;
    let [ax, ay, bx, by] = travel_rect(p, t);
    let _ = writeln!(
        s,
        r##"<path class="outside-travel" fill="#868e96" fill-opacity="0.14" fill-rule="evenodd" d="M{:.1} {:.1}H{:.1}V{:.1}H{:.1}Z M{ax:.1} {ay:.1}H{bx:.1}V{by:.1}H{ax:.1}Z"/>"##,
        x - 10.0,
        y - 10.0,
        x + w + 10.0,
        y + h + 10.0,
        x - 10.0
    );
}

/// The twelve edges of a box as path data.
fn box_edges(fit: &Fit, b: &Box3) -> String {
    let c = b.corners();
    let mut d = String::new();
    for (i, j) in [
        (0, 1),
        (2, 3),
        (4, 5),
        (6, 7),
        (0, 2),
        (1, 3),
        (4, 6),
        (5, 7),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
    ] {
        let (ax, ay) = fit.px(c[i]);
        let (bx, by) = fit.px(c[j]);
        let _ = write!(d, "M{ax:.1} {ay:.1}L{bx:.1} {by:.1}");
    }
    d
}

const RAPIDS_GROUP: &str =
    r#"<g class="rapids" fill="none" stroke-width="1" stroke-linecap="butt">"#;
const FEEDS_GROUP: &str = r#"<g class="feeds" fill="none" stroke-width="1.8" stroke-linecap="round" stroke-linejoin="round">"#;

/// The `<path>` line of one move in one view: rapids dashed, feeds and arcs in their speed colour.
fn move_element(fit: &Fit, scale: Option<SpeedScale>, m: &PreviewMove) -> String {
    if m.kind == MoveKind::Rapid {
        return format!(
            r#"<path class="rapid" data-line="{}" stroke="{RAPID_COLOUR}" stroke-dasharray="{RAPID_DASH}" d="{}"/>
"#,
            m.line,
            path_data(fit, m)
        );
    }
    let class = if matches!(m.kind, MoveKind::Arc(_)) {
        "arc"
    } else {
        "feed"
    };
    let colour = hex(stroke_rgb(scale, m));
    format!(
        r#"<path class="{class}" data-line="{}" stroke="{colour}" d="{}"/>
"#,
        m.line,
        path_data(fit, m)
    )
}

/// The stroke colour of a move: rapids grey, feeds and arcs in their speed's colour (dark grey
/// without one).
fn stroke_rgb(scale: Option<SpeedScale>, m: &PreviewMove) -> Rgb {
    if m.kind == MoveKind::Rapid {
        return RAPID_RGB;
    }
    match (m.speed_mm_min, scale) {
        (Some(v), Some(sc)) => sc.colour(v),
        _ => NO_SPEED_RGB,
    }
}

/// Program start (green dot) and end (black square).
fn draw_markers(s: &mut String, stats: &Stats, fit: &Fit) {
    if let Some((first, last)) = stats.ends {
        let (ax, ay) = fit.px(first);
        let (bx, by) = fit.px(last);
        let _ = writeln!(
            s,
            r##"<circle class="start" cx="{ax:.1}" cy="{ay:.1}" r="4" fill="#2f9e44" stroke="#ffffff"/>"##
        );
        let _ = writeln!(
            s,
            r##"<rect class="end" x="{:.1}" y="{:.1}" width="7" height="7" fill="#212529" stroke="#ffffff"/>"##,
            bx - 3.5,
            by - 3.5
        );
    }
}

/// SVG path data of one move in one view.
fn path_data(fit: &Fit, m: &PreviewMove) -> String {
    let (ax, ay) = fit.px(m.from);
    let mut d = format!("M{ax:.2} {ay:.2}");
    match &m.kind {
        MoveKind::Rapid | MoveKind::Feed => {
            let (bx, by) = fit.px(m.to);
            let _ = write!(d, "L{bx:.2} {by:.2}");
        }
        MoveKind::Arc(arc) => {
            for c in arc_cubics(m.from, m.to, arc) {
                let (p1, p2, p3) = (fit.px(c[1]), fit.px(c[2]), fit.px(c[3]));
                let _ = write!(
                    d,
                    "C{:.2} {:.2} {:.2} {:.2} {:.2} {:.2}",
                    p1.0, p1.1, p2.0, p2.1, p3.0, p3.1
                );
            }
        }
    }
    d
}

fn draw_legend(s: &mut String, job: &PreviewJob, stats: &Stats, x: f64, w: f64, h: f64) {
    let _ = writeln!(
        s,
        r##"<g class="legend"><rect x="{x:.1}" y="6" width="{w:.1}" height="{:.1}" rx="4" fill="#f8f9fa" stroke="#dee2e6"/>"##,
        h - 12.0
    );
    let x0 = x + 14.0;
    let right = x + w - 14.0;
    let mut y = 34.0;
    text(s, x0, y, 17.0, "bold", TEXT, "start", "Gantry preview");
    y += 20.0;
    text(
        s,
        x0,
        y,
        12.0,
        "normal",
        MUTED,
        "start",
        &ellipsize(&job.title, 44),
    );
    y += 30.0;

    text(s, x0, y, 13.0, "bold", TEXT, "start", "Total time");
    let time = job
        .total_time_s
        .map(fmt_duration)
        .unwrap_or_else(|| "unknown".into());
    text(s, right, y, 13.0, "bold", TEXT, "end", &time);
    y += 16.0;
    let how = match job.speed_source {
        SpeedSource::Planned => "planned with acceleration (look-ahead)",
        SpeedSource::Programmed => "estimate: programmed feeds, no acceleration",
    };
    text(s, x0, y, 10.5, "normal", MUTED, "start", how);
    y += 24.0;

    for row in figure_rows(stats, x0, right, y) {
        let (x, anchor) = if row.start {
            (row.x0, "start")
        } else {
            (row.x1, "end")
        };
        text(s, x, row.y, row.size, "normal", row.fill, anchor, &row.text);
        y = y.max(row.y + 18.0);
    }
    y += 12.0;

    y = box_table(s, "Job extents (mm)", &stats.extents, x0, right, y);
    if let Some(t) = job.travel.filter(|t| !t.is_empty()) {
        y = box_table(s, "Machine travel (mm)", &t, x0, right, y);
        let (msg, colour) = travel_status(&t, &stats.extents);
        for line in msg {
            text(s, x0, y, 11.5, "bold", colour, "start", &line);
            y += 16.0;
        }
        y += 8.0;
    }

    if let Some(sc) = stats.scale {
        y += 8.0;
        let title = match job.speed_source {
            SpeedSource::Planned => "Planned speed (mm/min)",
            SpeedSource::Programmed => "Programmed feed (mm/min)",
        };
        text(s, x0, y, 13.0, "bold", TEXT, "start", title);
        y += 10.0;
        let bw = right - x0;
        let _ = writeln!(
            s,
            r##"<rect class="speed-scale" x="{x0:.1}" y="{y:.1}" width="{bw:.1}" height="14" fill="url(#speed)" stroke="#adb5bd" stroke-width="0.5"/>"##
        );
        // The ends are labelled (start- and end-aligned); round ticks in between only where
        // their labels keep clear of the ends' (about 6.5 px per character at this size).
        let width = |v: f64| 6.5 * fmt_num(v, 0).chars().count() as f64;
        let mut labels: Vec<f64> = vec![sc.lo, sc.hi];
        for t in sc.ticks() {
            let px = sc.fraction(t) * bw;
            let clear_lo = px - width(t) / 2.0 > width(sc.lo) + 8.0;
            let clear_hi = bw - px - width(t) / 2.0 > width(sc.hi) + 8.0;
            if clear_lo && clear_hi {
                labels.push(t);
            }
        }
        for v in labels {
            let px = x0 + sc.fraction(v) * bw;
            let _ = writeln!(
                s,
                r##"<path class="tick" stroke="#495057" d="M{px:.1} {:.1}V{:.1}"/>"##,
                y + 14.0,
                y + 19.0
            );
            let anchor = if px <= x0 + 1.0 {
                "start"
            } else if px >= right - 1.0 {
                "end"
            } else {
                "middle"
            };
            text(
                s,
                px,
                y + 31.0,
                10.5,
                "normal",
                TEXT,
                anchor,
                &fmt_num(v, 0),
            );
        }
        y += 58.0;
    }

    text(s, x0, y, 13.0, "bold", TEXT, "start", "Key");
    y += 20.0;
    let key_line = |s: &mut String, y: f64, attrs: &str, label: &str| {
        let _ = writeln!(
            s,
            r#"<path class="key" fill="none" {attrs} d="M{x0:.1} {:.1}h34"/>"#,
            y - 4.0
        );
        text(s, x0 + 44.0, y, 12.0, "normal", TEXT, "start", label);
    };
    key_line(
        s,
        y,
        &format!(r#"stroke="{RAPID_COLOUR}" stroke-width="1" stroke-dasharray="{RAPID_DASH}""#),
        "rapid (G0)",
    );
    y += 18.0;
    key_line(
        s,
        y,
        &format!(r#"stroke="{}" stroke-width="1.8""#, hex(colour_at(0.5))),
        "feed / arc (G1, G2, G3), coloured by speed",
    );
    y += 18.0;
    key_line(
        s,
        y,
        &format!(r#"stroke="{TRAVEL_COLOUR}" stroke-width="1.5" stroke-dasharray="{TRAVEL_DASH}""#),
        "machine travel (outside: grey)",
    );
    y += 18.0;
    let _ = writeln!(
        s,
        r##"<circle cx="{:.1}" cy="{:.1}" r="4" fill="#2f9e44"/><rect x="{:.1}" y="{:.1}" width="7" height="7" fill="#212529"/>"##,
        x0 + 8.0,
        y - 4.0,
        x0 + 22.5,
        y - 7.5
    );
    text(
        s,
        x0 + 44.0,
        y,
        12.0,
        "normal",
        TEXT,
        "start",
        "program start / end",
    );
    s.push_str("</g>\n");
}

/// A line of text of the legend and the room it takes, in pixels (its width estimated by
/// [`text_width`]).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TextBox {
    pub(crate) text: String,
    /// Left and right end.
    pub(crate) x0: f64,
    pub(crate) x1: f64,
    /// Baseline.
    pub(crate) y: f64,
    pub(crate) size: f64,
    /// Anchored at its start (x0), else at its end (x1).
    pub(crate) start: bool,
    pub(crate) fill: &'static str,
}

impl TextBox {
    fn new(text: String, x: f64, y: f64, size: f64, start: bool, fill: &'static str) -> TextBox {
        let w = text_width(&text, size);
        let (x0, x1) = if start { (x, x + w) } else { (x - w, x) };
        TextBox {
            text,
            x0,
            x1,
            y,
            size,
            start,
            fill,
        }
    }

    /// Whether the two share a line and some of its width.
    #[cfg(test)]
    pub(crate) fn overlaps(&self, o: &TextBox) -> bool {
        (self.y - o.y).abs() < self.size.max(o.size) && self.x0 < o.x1 && o.x0 < self.x1
    }
}

/// The width of `t` in DejaVu Sans at `size` px, from its advance widths (em fractions), rounded
/// up a little: digits 0.636, lower case at most 0.64 but `m` and `w`, spaces and punctuation
/// about 0.32–0.39.
pub(crate) fn text_width(t: &str, size: f64) -> f64 {
    let em: f64 = t
        .chars()
        .map(|c| match c {
            ' ' | ',' | '.' | ':' | ';' | 'i' | 'l' | 'j' | '\'' => 0.33,
            '(' | ')' | 'f' | 't' | 'r' => 0.42,
            'm' | 'w' => 0.98,
            'M' | 'W' => 1.0,
            c if c.is_ascii_uppercase() => 0.78,
            _ => 0.65,
        })
        .sum();
    em * size
}

/// The legend's figures under the total time, from baseline `y`: each label at `x0` and its
/// value ending at `right`. The move count's breakdown goes on a line of its own when the whole
/// would reach the label (a count of 6 digits or more).
pub(crate) fn figure_rows(stats: &Stats, x0: f64, right: f64, mut y: f64) -> Vec<TextBox> {
    const GAP: f64 = 8.0;
    let total = stats.rapids + stats.feeds + stats.arcs;
    let split = format!(
        "({} rapid, {} feed, {} arc)",
        stats.rapids, stats.feeds, stats.arcs
    );
    let rows = [
        ("Moves", format!("{total}  {split}")),
        ("Cutting path", format!("{:.1} mm", stats.feed_len_mm)),
        ("Rapid path", format!("{:.1} mm", stats.rapid_len_mm)),
    ];
    let mut out = Vec::new();
    for (k, v) in rows {
        let label = TextBox::new(k.to_string(), x0, y, 12.0, true, TEXT);
        let value = TextBox::new(v, right, y, 12.0, false, TEXT);
        if k == "Moves" && value.x0 < label.x1 + GAP {
            out.push(label);
            out.push(TextBox::new(total.to_string(), right, y, 12.0, false, TEXT));
            y += 16.0;
            out.push(TextBox::new(split.clone(), right, y, 11.0, false, MUTED));
        } else {
            out.push(label);
            out.push(value);
        }
        y += 18.0;
    }
    out
}

/// A heading and one row per axis: min … max (size).
fn box_table(s: &mut String, title: &str, b: &Box3, x0: f64, right: f64, mut y: f64) -> f64 {
    text(s, x0, y, 13.0, "bold", TEXT, "start", title);
    y += 18.0;
    if b.is_empty() {
        text(s, x0, y, 12.0, "normal", MUTED, "start", "no motion");
        return y + 26.0;
    }
    for (i, axis) in ["X", "Y", "Z"].iter().enumerate() {
        text(s, x0, y, 12.0, "bold", TEXT, "start", axis);
        text(
            s,
            x0 + 92.0,
            y,
            12.0,
            "normal",
            TEXT,
            "end",
            &fmt_num(b.min[i], 3),
        );
        text(s, x0 + 104.0, y, 12.0, "normal", MUTED, "middle", "…");
        text(
            s,
            x0 + 176.0,
            y,
            12.0,
            "normal",
            TEXT,
            "end",
            &fmt_num(b.max[i], 3),
        );
        let size = format!("({})", fmt_num(b.max[i] - b.min[i], 3));
        text(s, right, y, 12.0, "normal", MUTED, "end", &size);
        y += 17.0;
    }
    y + 10.0
}

/// Whether the job stays inside the travel box, and by how much it leaves it on which side.
pub(crate) fn travel_status(t: &Box3, job: &Box3) -> (Vec<String>, &'static str) {
    if job.is_empty() || t.contains(job) {
        return (vec!["✓ job inside machine travel".into()], "#2b8a3e");
    }
    let mut out = Vec::new();
    for (i, axis) in ["X", "Y", "Z"].iter().enumerate() {
        let below = t.min[i] - job.min[i];
        let above = job.max[i] - t.max[i];
        if below > 1e-6 {
            out.push(format!("{axis}− by {} mm", fmt_num(below, 3)));
        }
        if above > 1e-6 {
            out.push(format!("{axis}+ by {} mm", fmt_num(above, 3)));
        }
    }
    let mut lines = vec!["✗ job leaves machine travel:".to_string()];
    lines.extend(out.into_iter().map(|o| format!("    {o}")));
    (lines, WARN_COLOUR)
}

#[allow(clippy::too_many_arguments)]
fn text(
    s: &mut String,
    x: f64,
    y: f64,
    size: f64,
    weight: &str,
    fill: &str,
    anchor: &str,
    t: &str,
) {
    let _ = writeln!(
        s,
        r#"<text x="{x:.1}" y="{y:.1}" font-size="{size}" font-weight="{weight}" fill="{fill}" text-anchor="{anchor}">{}</text>"#,
        escape(t)
    );
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn ellipsize(t: &str, max: usize) -> String {
    let n = t.chars().count();
    if n <= max {
        t.to_string()
    } else {
        let tail: String = t.chars().skip(n - (max - 1)).collect();
        format!("…{tail}")
    }
}

/// A number with `decimals` decimals, a real minus sign and no "-0".
pub(crate) fn fmt_num(v: f64, decimals: usize) -> String {
    let t = format!("{:.*}", decimals, v);
    let zero = t
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.');
    match t.strip_prefix('-') {
        Some(rest) if !zero => format!("−{rest}"),
        Some(rest) => rest.to_string(),
        None => t,
    }
}

/// `12.3 s`, `4 min 05.2 s`, `1 h 02 min 03 s`.
pub(crate) fn fmt_duration(secs: f64) -> String {
    if secs < 60.0 {
        format!("{secs:.1} s")
    } else if secs < 3600.0 {
        let m = (secs / 60.0).floor();
        format!("{m:.0} min {:04.1} s", secs - m * 60.0)
    } else {
        let total = secs.round() as u64;
        format!(
            "{} h {:02} min {:02} s",
            total / 3600,
            total / 60 % 60,
            total % 60
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_and_time_formats() {
        assert_eq!(fmt_num(-0.0001, 3), "0.000");
        assert_eq!(fmt_num(-4.0, 3), "−4.000");
        assert_eq!(fmt_num(12.5, 1), "12.5");
        assert_eq!(fmt_duration(12.34), "12.3 s");
        assert_eq!(fmt_duration(245.2), "4 min 05.2 s");
        assert_eq!(fmt_duration(3723.0), "1 h 02 min 03 s");
    }

    /// The legend's label and value columns in the default picture, as `Frame::new` and
    /// `draw_legend` place them.
    fn legend_columns() -> (f64, f64) {
        let w = RenderOptions::default().width as f64;
        let lw = legend_width(w);
        let (x, pw) = (w - lw + 4.0, lw - 16.0);
        (x + 14.0, x + pw - 14.0)
    }

    fn counts(rapids: usize, feeds: usize, arcs: usize) -> Stats {
        let mut s = StatsBuilder::default().finish();
        (s.rapids, s.feeds, s.arcs) = (rapids, feeds, arcs);
        s.feed_len_mm = 123456.7;
        s.rapid_len_mm = 98765.4;
        s
    }

    #[test]
    fn a_million_moves_do_not_overprint_their_label() {
        let (x0, right) = legend_columns();
        for (stats, lines) in [
            (counts(40, 900, 60), 3),
            (counts(403, 99_592, 0), 3),
            (counts(1_000, 999_000, 0), 4),
            (counts(250_000, 9_500_000, 250_000), 4),
        ] {
            let rows = figure_rows(&stats, x0, right, 100.0);
            let mut ys: Vec<f64> = rows.iter().map(|r| r.y).collect();
            ys.dedup();
            assert_eq!(ys.len(), lines, "{rows:?}");
            for (i, a) in rows.iter().enumerate() {
                assert!(a.x0 >= x0 - 0.01 && a.x1 <= right + 0.01, "{a:?}");
                for b in &rows[i + 1..] {
                    assert!(!a.overlaps(b), "{a:?} overlaps {b:?}");
                }
            }
            let total = stats.rapids + stats.feeds + stats.arcs;
            assert!(rows.iter().any(|r| r.text.starts_with(&total.to_string())));
        }
    }

    #[test]
    fn text_width_is_not_less_than_the_drawn_text() {
        for t in [
            "Moves",
            "1000000  (1000 rapid, 999000 feed, 0 arc)",
            "Cutting path",
        ] {
            let doc = format!(
                r##"<svg xmlns="http://www.w3.org/2000/svg" width="600" height="30"><text x="10" y="20" font-size="12" font-family="{FONT}" fill="#000">{t}</text></svg>"##
            );
            let pix = super::super::raster::rasterise(&doc).unwrap();
            let inked = (0..600)
                .filter(|&x| (0..30).any(|y| pix.pixel(x, y).unwrap().alpha() > 0))
                .max()
                .unwrap() as f64
                + 1.0
                - 10.0;
            let w = text_width(t, 12.0);
            assert!(
                w >= inked && w <= inked * 1.25 + 4.0,
                "{t}: {w} for {inked}"
            );
        }
    }

    #[test]
    fn travel_status_names_the_side() {
        let t = Box3 {
            min: [0.0; 3],
            max: [100.0; 3],
        };
        let job = Box3 {
            min: [-4.0, 0.0, 0.0],
            max: [50.0, 50.0, 101.0],
        };
        let (lines, _) = travel_status(&t, &job);
        assert_eq!(lines[1].trim(), "X− by 4.000 mm");
        assert_eq!(lines[2].trim(), "Z+ by 1.000 mm");
    }
}
