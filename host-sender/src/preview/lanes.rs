//! Where the drawing pass puts each move's SVG element, so that a picture of any program is drawn
//! in bounded memory: every view draws its rapids, then its feeds ([`Lane`]), but the program
//! gives them mixed, so each lane is kept apart until the document is put together —
//!
//! - [`SvgLanes`]: one unnamed temporary file per lane, copied into the document in order (the
//!   file is byte for byte what the whole document built in memory would be);
//! - [`PngLanes`]: one transparent pixmap per lane (the size of its view's plot), onto which the
//!   elements are rasterised by resvg in chunks of [`CHUNK_BYTES`]; the frame is then rasterised
//!   piece by piece in document order with each lane's pixmap laid on it at its place.
//!
//! The PNG can differ from rasterising the whole document at once by a level or two of a colour
//! channel at anti-aliased pixels where moves overlap (each chunk and lane is composited as its own
//! layer, with 8-bit rounding in between) and at the clip edge of a view.

use super::raster;
use super::svg::{Frame, Lane};
use anyhow::Context;
use resvg::tiny_skia::{Pixmap, PixmapPaint, Transform};
use resvg::usvg;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};

/// SVG text gathered per lane before it is rasterised.
pub const CHUNK_BYTES: usize = 256 * 1024;

/// The lane of every view for a move of lane `lane`, as indices into [`Frame::lanes`].
pub fn lanes_of(frame: &Frame, lane: Lane) -> impl Iterator<Item = usize> {
    (0..frame.layout.panels.len()).map(move |p| lane.index(p))
}

/// Lanes kept in temporary files, for an SVG picture.
pub struct SvgLanes {
    files: Vec<BufWriter<File>>,
}

impl SvgLanes {
    /// `n` empty lanes, in unnamed files of the temporary directory (removed at once; the space
    /// is freed when they are closed).
    pub fn new(n: usize) -> anyhow::Result<SvgLanes> {
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

    pub fn put(&mut self, lane: usize, element: &str) -> anyhow::Result<()> {
        self.files[lane]
            .write_all(element.as_bytes())
            .context("writing the preview's temporary file")
    }

    /// Writes the whole document: the frame with every lane copied in its place.
    pub fn write_document(self, frame: &Frame, out: &mut impl Write) -> anyhow::Result<()> {
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

/// A lane rasterised so far, and the text not yet rasterised.
struct PngLane {
    pixmap: Pixmap,
    /// Top-left pixel of the pixmap in the picture.
    origin: (i32, i32),
    chunk: String,
}

/// Lanes rasterised into pixmaps, for a PNG picture.
pub struct PngLanes<'f> {
    frame: &'f Frame,
    options: usvg::Options<'static>,
    lanes: Vec<PngLane>,
}

impl<'f> PngLanes<'f> {
    pub fn new(frame: &'f Frame) -> anyhow::Result<PngLanes<'f>> {
        let mut lanes = Vec::with_capacity(frame.lanes.len());
        for mark in &frame.lanes {
            let [x, y, w, h] = frame.layout.panels[mark.panel].plot;
            let (x0, y0) = (x.floor(), y.floor());
            let (pw, ph) = ((x + w).ceil() - x0, (y + h).ceil() - y0);
            let pixmap = Pixmap::new(pw.max(1.0) as u32, ph.max(1.0) as u32)
                .context("preview view has no size")?;
            lanes.push(PngLane {
                pixmap,
                origin: (x0 as i32, y0 as i32),
                chunk: String::new(),
            });
        }
        Ok(PngLanes {
            frame,
            options: raster::options(),
            lanes,
        })
    }

    pub fn put(&mut self, lane: usize, element: &str) -> anyhow::Result<()> {
        self.lanes[lane].chunk.push_str(element);
        if self.lanes[lane].chunk.len() >= CHUNK_BYTES {
            self.flush(lane)?;
        }
        Ok(())
    }

    /// Rasterises the lane's pending text onto its pixmap.
    fn flush(&mut self, k: usize) -> anyhow::Result<()> {
        let groups = &self.frame.lanes[k].groups;
        let lane = &mut self.lanes[k];
        if lane.chunk.is_empty() {
            return Ok(());
        }
        let mut doc = String::with_capacity(lane.chunk.len() + 4096);
        doc.push_str(&self.frame.open);
        doc.push_str(&self.frame.defs);
        groups.iter().for_each(|g| doc.push_str(g));
        doc.push_str(&lane.chunk);
        groups.iter().for_each(|_| doc.push_str("</g>"));
        doc.push_str("</svg>\n");
        lane.chunk.clear();
        let tree = usvg::Tree::from_str(&doc, &self.options).context("parsing the preview SVG")?;
        let (x0, y0) = lane.origin;
        let shift = Transform::from_translate(-x0 as f32, -y0 as f32);
        resvg::render(&tree, shift, &mut lane.pixmap.as_mut());
        Ok(())
    }

    /// The picture: the frame rasterised piece by piece in document order, each lane laid on it
    /// at its place.
    pub fn finish(mut self) -> anyhow::Result<Pixmap> {
        for k in 0..self.lanes.len() {
            self.flush(k)?;
        }
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
