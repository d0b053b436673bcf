//! SVG → PNG with resvg, using DejaVu Sans embedded from the `dejavu` crate (Bitstream Vera
//! licence, public-domain DejaVu changes), so text renders on machines without system fonts.

use anyhow::Context;
use resvg::tiny_skia::{Pixmap, Transform};
use resvg::usvg::{self, fontdb};
use std::sync::Arc;

/// The font database the rasteriser uses: DejaVu Sans regular and bold, nothing from the system.
fn fonts() -> fontdb::Database {
    let mut db = fontdb::Database::new();
    for data in [dejavu::sans::regular(), dejavu::sans::bold()] {
        db.load_font_source(fontdb::Source::Binary(Arc::new(data)));
    }
    db.set_sans_serif_family("DejaVu Sans");
    db
}

/// Parsing options: DejaVu Sans as the default and only font.
pub(crate) fn options() -> usvg::Options<'static> {
    let mut opt = usvg::Options {
        font_family: "DejaVu Sans".into(),
        ..Default::default()
    };
    *opt.fontdb_mut() = fonts();
    opt
}

/// Rasterises an SVG document at its own size and returns the pixmap.
pub fn rasterise(svg: &str) -> anyhow::Result<Pixmap> {
    let opt = options();
    let tree = usvg::Tree::from_str(svg, &opt).context("parsing the preview SVG")?;
    let size = tree.size().to_int_size();
    let mut pixmap =
        Pixmap::new(size.width(), size.height()).context("preview picture has no size")?;
    resvg::render(&tree, Transform::identity(), &mut pixmap.as_mut());
    Ok(pixmap)
}
