//! Where an output file goes as it is made: the temporary file of an atomic write, or memory.
//!
//! A big level's output is mostly its BIN chunk, which is already in memory as the input's
//! buffers; writing it straight to the file instead of into one output buffer first saves a
//! copy as large as the file.

use std::io::{Cursor, Seek, SeekFrom, Write};

/// A writable, seekable output that can start over.
pub(crate) trait Sink: Write + Seek {
    /// Empties the output (a writer that declined half-way starts over with another path).
    fn reset(&mut self) -> std::io::Result<()>;

    /// Appends what `r` reads (the input's BIN chunk), returning how many bytes.
    fn copy_from(&mut self, r: &mut std::io::Take<std::fs::File>) -> std::io::Result<u64> {
        std::io::copy(r, self)
    }
}

impl Sink for std::fs::File {
    fn reset(&mut self) -> std::io::Result<()> {
        self.set_len(0)?;
        self.seek(SeekFrom::Start(0)).map(|_| ())
    }

    /// File to file: the standard library has the kernel copy it (`copy_file_range` on Linux),
    /// never through this process's memory.
    fn copy_from(&mut self, r: &mut std::io::Take<std::fs::File>) -> std::io::Result<u64> {
        std::io::copy(r, self)
    }
}

impl Sink for Cursor<Vec<u8>> {
    fn reset(&mut self) -> std::io::Result<()> {
        self.get_mut().clear();
        self.set_position(0);
        Ok(())
    }
}

/// Counts what passes through, for chunk lengths known only once written.
pub(crate) struct Counted<W> {
    pub inner: W,
    pub bytes: u64,
}

impl<W: Write> Write for Counted<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}
