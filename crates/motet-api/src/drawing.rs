//! The executed path drawn as the machine runs, so that a session of any
//! length holds one picture, not its strokes.

use motet_render::{PngCanvas, RenderSpec, Stroke, SvgWriter, SVG_END};
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;

/// Why the drawing could not be made or written.
#[derive(Debug, thiserror::Error)]
pub(crate) enum DrawingError {
    /// The picture could not be made or encoded.
    #[error("{0}")]
    Render(#[from] motet_render::RenderError),
    /// A file could not be written (the SVG's spool or a saved file).
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// The picture, rasterised stroke by stroke, and the SVG, written stroke by
/// stroke to an unnamed temporary file (the operating system removes it
/// with the process) that each save copies. Memory: the image; the SVG is
/// on disk.
pub(crate) struct Drawing {
    png: PngCanvas,
    svg: SvgWriter<BufWriter<File>>,
    /// The first failure writing the spool; saving reports it, drawing
    /// goes on in the picture.
    spool_error: Option<std::io::Error>,
}

impl Drawing {
    /// A blank drawing for `spec`.
    pub(crate) fn new(spec: &RenderSpec) -> Result<Drawing, DrawingError> {
        let png = PngCanvas::new(spec)?;
        let spool = BufWriter::new(tempfile::tempfile()?);
        let svg = SvgWriter::new(spool, spec)?;
        Ok(Drawing {
            png,
            svg,
            spool_error: None,
        })
    }

    /// Draws strokes of the executed path, in order.
    pub(crate) fn draw(&mut self, strokes: &[Stroke]) {
        for s in strokes {
            self.png.draw(s);
            if self.spool_error.is_none() {
                self.spool_error = self.svg.stroke(s).err();
            }
        }
    }

    /// Writes `path.png` and `path.svg` of everything drawn so far into
    /// `dir`; the drawing goes on.
    pub(crate) fn save(&mut self, dir: &Path) -> Result<(), DrawingError> {
        std::fs::write(dir.join("path.png"), self.png.snapshot()?)?;
        if let Some(e) = &self.spool_error {
            // Strokes are missing from the spool: no whole SVG can be made
            // any more, so every later save says so too.
            let what = format!("spooling the SVG of the path failed: {e}");
            return Err(std::io::Error::new(e.kind(), what).into());
        }
        let spool = self.svg.get_mut();
        spool.flush()?;
        let file = spool.get_mut();
        let written = file.stream_position()?;
        file.seek(SeekFrom::Start(0))?;
        let mut out = BufWriter::new(File::create(dir.join("path.svg"))?);
        let copied = std::io::copy(&mut (&mut *file).take(written), &mut out);
        // Back to the end, for the strokes to come, whatever the copy did.
        file.seek(SeekFrom::Start(written))?;
        copied?;
        out.write_all(SVG_END.as_bytes())?;
        out.flush()?;
        Ok(())
    }
}
