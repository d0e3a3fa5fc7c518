//! The shipped font: registered with plotters (text layout of the SVG) and loaded into
//! resvg's font database (text of the PNG), so figures look the same on any machine and
//! need no system font libraries (licence: `assets/DejaVu-LICENSE.txt`).

use std::sync::{Arc, OnceLock};

use plotters::style::FontStyle;
use resvg::{tiny_skia, usvg};

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The family name every figure asks for.
pub const FAMILY: &str = "sans-serif";

/// Registers the font with plotters (idempotent).
pub fn ensure() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        for style in [FontStyle::Normal, FontStyle::Bold] {
            if plotters::style::register_font(FAMILY, style, FONT).is_err() {
                unreachable!("the shipped font is a valid TTF");
            }
        }
    });
}

fn fonts() -> Arc<usvg::fontdb::Database> {
    static DB: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(FONT.to_vec());
        db.set_sans_serif_family("DejaVu Sans");
        Arc::new(db)
    })
    .clone()
}

/// Rasterises an SVG document of `w` × `h` pixels to PNG bytes on a white background.
pub fn rasterise(svg: &str, w: u32, h: u32) -> Result<Vec<u8>, String> {
    let opts = usvg::Options { font_family: "DejaVu Sans".into(), fontdb: fonts(), ..Default::default() };
    let tree = usvg::Tree::from_str(svg, &opts).map_err(|e| format!("parsing the SVG: {e}"))?;
    let mut pixmap = tiny_skia::Pixmap::new(w, h).ok_or_else(|| format!("cannot allocate a {w}×{h} image"))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    let size = tree.size();
    let transform = tiny_skia::Transform::from_scale(w as f32 / size.width(), h as f32 / size.height());
    resvg::render(&tree, transform, &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| format!("encoding the PNG: {e}"))
}
