//! Where the drawing pass puts each move's SVG element, so that a picture of any program is drawn
//! in bounded memory: every view draws its rapids, then its feeds ([`Lane`]), but the program
//! gives them mixed, so each lane is kept apart until the document is put together —
//!
//! - [`SvgLanes`]: one unnamed temporary file per lane, copied into the document in order (the
//!   file is byte for byte what the whole document built in memory would be);
//! - [`PngLanes`]: one transparent pixmap per lane (the size of its view's plot), onto which each
//!   move is drawn as it comes, as resvg would draw its element (no SVG text for the moves):
//!   tiny-skia strokes it with the element's stroke, or, for a straight move shorter than
//!   [`SHORT_PX`], [`stamp`] covers its few pixels directly (stroking a path costs far more than
//!   that); the view's clip is laid on each lane at the end, and the frame is then rasterised
//!   piece by piece in document order with each lane's pixmap laid on it at its place.
//!
//! The PNG can differ from rasterising the whole document at once by a level or two of a colour
//! channel at anti-aliased pixels where moves overlap (each lane is composited as its own layer)
//! and at the clip edge of a view, and by up to about a tenth of full scale at the anti-aliased
//! edge pixels of stamped short moves.

use super::colour::Rgb;
use super::geom::arc_cubics;
use super::model::{MoveKind, PreviewMove};
use super::raster;
use super::svg::{Frame, Lane};
use anyhow::Context;
use resvg::tiny_skia::{
    self, FillRule, LineCap, LineJoin, Mask, Paint, PathBuilder, Pixmap, PixmapPaint, Stroke,
    StrokeDash, Transform,
};
use resvg::usvg;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};

/// The lane of every view for a move of lane `lane`, as indices into [`Frame::lanes`].
pub(crate) fn lanes_of(frame: &Frame, lane: Lane) -> impl Iterator<Item = usize> {
    (0..frame.layout.panels.len()).map(move |p| lane.index(p))
}

/// Lanes kept in temporary files, for an SVG picture.
pub(crate) struct SvgLanes {
    files: Vec<BufWriter<File>>,
}

impl SvgLanes {
    /// `n` empty lanes, in unnamed files of the temporary directory (removed at once; the space
    /// is freed when they are closed).
    pub(crate) fn new(n: usize) -> anyhow::Result<SvgLanes> {
        let dir = std::env::temp_dir();
        let mut files = Vec::with_capacity(n);
        for k in 0..n {
            let path = dir.join(format!("gantry-preview-{}-{k}.part", std::process::id()));
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(true)
                .open(&path)
                .with_context(|| format!("cannot create {}", path.display()))?;
            let _ = std::fs::remove_file(&path);
            files.push(BufWriter::with_capacity(1 << 16, file));
        }
        Ok(SvgLanes { files })
    }

    pub(crate) fn put(&mut self, lane: usize, element: &str) -> anyhow::Result<()> {
        self.files[lane]
            .write_all(element.as_bytes())
            .context("writing the preview's temporary file")
    }

    /// Writes the whole document: the frame with every lane copied in its place.
    pub(crate) fn write_document(self, frame: &Frame, out: &mut impl Write) -> anyhow::Result<()> {
        let mut files = Vec::with_capacity(self.files.len());
        for f in self.files {
            let mut f = f.into_inner().map_err(|e| e.into_error())?;
            f.seek(SeekFrom::Start(0))?;
            files.push(f);
        }
        frame.write(out, &mut |out, mark| {
            std::io::copy(&mut files[mark.index()], out).map(drop)
        })?;
        Ok(())
    }
}

/// Moves (straight, in pixels) shorter than this are drawn by [`stamp`] instead of tiny-skia:
/// at this length a dashed rapid is one dash, and the two drawings differ only by a few levels at
/// anti-aliased pixels.
pub(crate) const SHORT_PX: f64 = 3.0;

/// A lane rasterised so far.
struct PngLane {
    pixmap: Pixmap,
    /// Top-left pixel of the pixmap in the picture.
    origin: (i32, i32),
    /// The view's clip rectangle, in the pixmap's pixels.
    clip: Option<tiny_skia::Rect>,
}

/// Lanes rasterised into pixmaps, for a PNG picture.
pub(crate) struct PngLanes<'f> {
    frame: &'f Frame,
    options: usvg::Options<'static>,
    lanes: Vec<PngLane>,
    rapid: Stroke,
    feed: Stroke,
    /// Straight moves shorter than this many pixels are stamped ([`SHORT_PX`]).
    pub(crate) short_px: f64,
}

impl<'f> PngLanes<'f> {
    pub(crate) fn new(frame: &'f Frame) -> anyhow::Result<PngLanes<'f>> {
        let mut lanes = Vec::with_capacity(frame.lanes.len());
        for mark in &frame.lanes {
            let [x, y, w, h] = frame.layout.panels[mark.panel].plot;
            let (x0, y0) = (x.floor(), y.floor());
            let (pw, ph) = ((x + w).ceil() - x0, (y + h).ceil() - y0);
            let pixmap = Pixmap::new(pw.max(1.0) as u32, ph.max(1.0) as u32)
                .context("preview view has no size")?;
            // The clipPath's rectangle, as the document writes it (one decimal).
            let tenth = |v: f64| ((v * 10.0).round() / 10.0) as f32;
            let clip = tiny_skia::Rect::from_xywh(
                tenth(x) - x0 as f32,
                tenth(y) - y0 as f32,
                tenth(w),
                tenth(h),
            );
            lanes.push(PngLane {
                pixmap,
                origin: (x0 as i32, y0 as i32),
                clip,
            });
        }
        // The strokes of the lanes' groups and of the moves' elements (`svg::move_element`).
        let rapid = Stroke {
            width: 1.0,
            line_cap: LineCap::Butt,
            dash: StrokeDash::new(vec![5.0, 3.0], 0.0),
            ..Stroke::default()
        };
        let feed = Stroke {
            width: 1.8,
            line_cap: LineCap::Round,
            line_join: LineJoin::Round,
            ..Stroke::default()
        };
        Ok(PngLanes {
            frame,
            options: raster::options(),
            lanes,
            rapid,
            feed,
            short_px: SHORT_PX,
        })
    }

    /// Draws move `m` onto lane `lane` (of its view), as resvg draws its SVG element: straight
    /// moves shorter than [`SHORT_PX`] with [`stamp`], the others stroked by tiny-skia.
    pub(crate) fn draw(&mut self, lane: usize, m: &PreviewMove) {
        let frame = self.frame;
        let fit = &frame.layout.panels[frame.lanes[lane].panel].fit;
        let l = &mut self.lanes[lane];
        let (ox, oy) = (l.origin.0, l.origin.1);
        // As the element's path data has it (two decimals, in the picture's pixels, as f32);
        // tiny-skia shifts it onto the lane (`shift`) as resvg did.
        let at = |p| {
            let (x, y) = fit.px(p);
            let r = |v: f64| ((v * 100.0).round() / 100.0) as f32;
            (r(x), r(y))
        };
        let shift = Transform::from_translate(-ox as f32, -oy as f32);
        let rgb = frame.stroke_rgb(m);
        let rapid = m.kind == MoveKind::Rapid;
        let a = at(m.from);
        let mut pb = PathBuilder::new();
        pb.move_to(a.0, a.1);
        match &m.kind {
            MoveKind::Rapid | MoveKind::Feed => {
                let b = at(m.to);
                let len = ((b.0 - a.0) as f64).hypot((b.1 - a.1) as f64);
                // A zero-length feed is a dot: left to tiny-skia, which draws its round caps (a
                // plunge seen from above; rare).
                if len < self.short_px && len > 0.0 {
                    let half = if rapid { 0.5 } else { 0.9 };
                    let on = |p: (f32, f32)| (p.0 - ox as f32, p.1 - oy as f32);
                    stamp(&mut l.pixmap, on(a), on(b), half, !rapid, rgb);
                    return;
                }
                pb.line_to(b.0, b.1);
            }
            MoveKind::Arc(arc) => {
                for c in arc_cubics(m.from, m.to, arc) {
                    let (p1, p2, p3) = (at(c[1]), at(c[2]), at(c[3]));
                    pb.cubic_to(p1.0, p1.1, p2.0, p2.1, p3.0, p3.1);
                }
            }
        }
        let Some(path) = pb.finish() else {
            return;
        };
        let mut paint = Paint::default();
        paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
        paint.anti_alias = true;
        let stroke = if rapid { &self.rapid } else { &self.feed };
        l.pixmap.stroke_path(&path, &paint, stroke, shift, None);
    }

    /// Lays each lane's clip rectangle on it (as resvg clips the view's group).
    fn clip(&mut self) {
        for l in &mut self.lanes {
            let Some(rect) = l.clip else {
                continue;
            };
            let Some(mut mask) = Mask::new(l.pixmap.width(), l.pixmap.height()) else {
                continue;
            };
            mask.fill_path(
                &PathBuilder::from_rect(rect),
                FillRule::Winding,
                true,
                Transform::identity(),
            );
            l.pixmap.apply_mask(&mask);
        }
    }

    /// The picture: the frame rasterised piece by piece in document order, each lane laid on it
    /// at its place.
    pub(crate) fn finish(mut self) -> anyhow::Result<Pixmap> {
        self.clip();
        let frame = self.frame;
        let size = (frame.layout.width, frame.layout.height);
        let mut picture = Pixmap::new(size.0, size.1).context("preview picture has no size")?;
        let mut from = 0;
        let mut open: &[String] = &[];
        for k in 0..=frame.lanes.len() {
            let (to, close) = match frame.lanes.get(k) {
                Some(mark) => (mark.at, &mark.groups[..]),
                None => (frame.body.len(), &[][..]),
            };
            let mut doc = String::with_capacity(to - from + 4096);
            doc.push_str(&frame.open);
            if k == 0 {
                doc.push_str(&frame.background);
            }
            doc.push_str(&frame.defs);
            open.iter().for_each(|g| doc.push_str(g));
            doc.push_str(&frame.body[from..to]);
            close.iter().for_each(|_| doc.push_str("</g>"));
            doc.push_str("</svg>\n");
            let tree =
                usvg::Tree::from_str(&doc, &self.options).context("parsing the preview SVG")?;
            resvg::render(&tree, Transform::identity(), &mut picture.as_mut());
            if let Some(lane) = self.lanes.get(k) {
                picture.draw_pixmap(
                    lane.origin.0,
                    lane.origin.1,
                    lane.pixmap.as_ref(),
                    &PixmapPaint::default(),
                    Transform::identity(),
                    None,
                );
            }
            from = to;
            open = close;
        }
        Ok(picture)
    }
}

/// Draws a straight stroke from `a` to `b` (pixels of `pixmap`) of half-width `half`, with round
/// caps (`round`) or butt ones, in `rgb` over what is there: each pixel in reach is covered by the
/// part of its area within the stroke (its centre's distance from the stroke's edge, ±½ px).
/// For short moves, where stroking a path with tiny-skia costs far more than the few pixels it
/// touches.
pub(crate) fn stamp(
    pixmap: &mut Pixmap,
    a: (f32, f32),
    b: (f32, f32),
    half: f32,
    round: bool,
    rgb: Rgb,
) {
    let (w, h) = (pixmap.width() as i32, pixmap.height() as i32);
    let reach = half + 1.0;
    let x0 = ((a.0.min(b.0) - reach).floor() as i32).max(0);
    let x1 = ((a.0.max(b.0) + reach).ceil() as i32).min(w);
    let y0 = ((a.1.min(b.1) - reach).floor() as i32).max(0);
    let y1 = ((a.1.max(b.1) + reach).ceil() as i32).min(h);
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let len = len2.sqrt();
    let data = pixmap.data_mut();
    for y in y0..y1 {
        let py = y as f32 + 0.5 - a.1;
        let row = (y * w) as usize * 4;
        for x in x0..x1 {
            let px = x as f32 + 0.5 - a.0;
            // Along the stroke, 0..=1 between its ends.
            let t = if len2 > 0.0 {
                (px * dx + py * dy) / len2
            } else {
                0.0
            };
            let cover = if round {
                let tc = t.clamp(0.0, 1.0);
                let (ex, ey) = (px - dx * tc, py - dy * tc);
                half + 0.5 - (ex * ex + ey * ey).sqrt()
            } else {
                if len2 == 0.0 {
                    return;
                }
                let across = (px * dy - py * dx).abs() / len;
                let along = t * len;
                (half + 0.5 - across)
                    .min(along + 0.5)
                    .min(len - along + 0.5)
                    .min(1.0)
            };
            if cover <= 0.0 {
                continue;
            }
            let alpha = (cover.min(1.0) * 255.0 + 0.5) as u32;
            let keep = 255 - alpha;
            let i = row + x as usize * 4;
            let p = &mut data[i..i + 4];
            for (c, s) in p[..3].iter_mut().zip(rgb) {
                *c = ((s as u32 * alpha + *c as u32 * keep + 127) / 255) as u8;
            }
            p[3] = ((alpha * 255 + p[3] as u32 * keep + 127) / 255) as u8;
        }
    }
}
