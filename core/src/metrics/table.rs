//! The lip roughness table as a tab-separated file, the thesis's `dataMetrics.txt` with a
//! header line: `frame time_s mask_vertex min max mean`. Numbers are written in Rust's
//! shortest round-trip form, so a reader gets back the exact f64 values.

use std::io::Write;

use super::lip_roughness::LipRoughnessRow;

/// The header line (without its newline).
pub const TSV_HEADER: &str = "frame\ttime_s\tmask_vertex\tmin\tmax\tmean";

/// A failed write, saying what was being written.
#[derive(Debug, thiserror::Error)]
pub enum TsvError {
    #[error("cannot write the roughness table header: {0}")]
    Header(#[source] std::io::Error),
    #[error("cannot write the roughness table row of frame {frame}: {source}")]
    Row { frame: u64, source: std::io::Error },
    #[error("cannot flush the roughness table: {0}")]
    Flush(#[source] std::io::Error),
}

/// Writes rows under the header; wrap files in a `BufWriter`. Writing allocates nothing.
#[derive(Debug)]
pub struct RoughnessTsvWriter<W: Write> {
    out: W,
}

impl<W: Write> RoughnessTsvWriter<W> {
    /// Writes the header.
    pub fn new(mut out: W) -> Result<RoughnessTsvWriter<W>, TsvError> {
        writeln!(out, "{TSV_HEADER}").map_err(TsvError::Header)?;
        Ok(RoughnessTsvWriter { out })
    }

    /// Writes rows, one line each.
    pub fn write_rows(&mut self, rows: &[LipRoughnessRow]) -> Result<(), TsvError> {
        for r in rows {
            writeln!(
                self.out,
                "{}\t{}\t{}\t{}\t{}\t{}",
                r.frame, r.time_s, r.mask_vertex, r.min, r.max, r.mean
            )
            .map_err(|source| TsvError::Row {
                frame: r.frame,
                source,
            })?;
        }
        Ok(())
    }

    /// Flushes and hands back the writer.
    pub fn finish(mut self) -> Result<W, TsvError> {
        self.out.flush().map_err(TsvError::Flush)?;
        Ok(self.out)
    }
}
