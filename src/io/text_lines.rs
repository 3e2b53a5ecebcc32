//! Reading the text files of an import (DESIGN §2.4) line by line: the error type every
//! importer returns, naming the file and the 1-based line, and the parsers of one field.
//! A last line with text but no end of line is refused as a cut (truncated) file.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use thiserror::Error;

use crate::model::component::ComponentError;

/// Why an import failed; every variant names the file (and the line where it applies).
#[derive(Debug, Error)]
pub enum ImportError {
    /// A file cannot be opened or read.
    #[error("{}: cannot read: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A line of a file is malformed.
    #[error("{}:{line}: {reason}", file.display())]
    Line {
        /// The file.
        file: PathBuf,
        /// Line number (1-based).
        line: usize,
        /// What is wrong with the line.
        reason: String,
    },
    /// A file as a whole is wrong (not tied to one line, e.g. no DOFs).
    #[error("{}: {reason}", file.display())]
    File {
        /// The file.
        file: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The import specification is invalid (holds the reason).
    #[error("import specification: {0}")]
    Spec(String),
    /// The Craig–Bampton reduction (paper ref. 26) of the imported matrices failed.
    #[error("reduction: {0}")]
    Reduction(#[from] ComponentError),
    /// The reduced model fails [`crate::model::rom::CyclicRom::validate`].
    #[error("the reduced model is invalid: {0}")]
    Rom(#[from] crate::model::rom::RomError),
}

impl ImportError {
    pub(crate) fn line(file: &Path, line: usize, reason: impl Into<String>) -> Self {
        ImportError::Line {
            file: file.to_path_buf(),
            line,
            reason: reason.into(),
        }
    }
    pub(crate) fn file(file: &Path, reason: impl Into<String>) -> Self {
        ImportError::File {
            file: file.to_path_buf(),
            reason: reason.into(),
        }
    }
}

/// Streams a text file line by line into a reused buffer, counting lines.
pub(crate) struct LineReader {
    pub path: PathBuf,
    reader: BufReader<File>,
    buf: Vec<u8>,
    /// 1-based number of the line last returned.
    pub line: usize,
    /// Whether the line last returned ended with a newline (false: last line of a file
    /// cut short, or a file written without a final newline).
    pub complete: bool,
}

impl LineReader {
    pub fn open(path: &Path) -> Result<Self, ImportError> {
        let file = File::open(path).map_err(|source| ImportError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        Ok(Self {
            path: path.to_path_buf(),
            reader: BufReader::with_capacity(1 << 20, file),
            buf: Vec::with_capacity(256),
            line: 0,
            complete: true,
        })
    }

    /// The next line without its end-of-line characters, or `None` at the end of the file.
    /// A last line with text but no newline is refused: that is how a cut file ends.
    pub fn next_line(&mut self) -> Result<Option<Line<'_>>, ImportError> {
        self.buf.clear();
        let n = self
            .reader
            .read_until(b'\n', &mut self.buf)
            .map_err(|source| ImportError::Io {
                file: self.path.clone(),
                source,
            })?;
        if n == 0 {
            return Ok(None);
        }
        self.line += 1;
        self.complete = self.buf.last() == Some(&b'\n');
        while matches!(self.buf.last(), Some(b'\n' | b'\r')) {
            self.buf.pop();
        }
        let text = std::str::from_utf8(&self.buf)
            .map_err(|_| ImportError::line(&self.path, self.line, "not valid UTF-8 text"))?;
        if !self.complete && !text.trim().is_empty() {
            return Err(ImportError::line(
                &self.path,
                self.line,
                "last line has no end of line: truncated file (end a complete file with a newline)",
            ));
        }
        Ok(Some(Line {
            text,
            no: self.line,
            path: &self.path,
        }))
    }

    /// An error at the line last read.
    pub fn err(&self, reason: impl Into<String>) -> ImportError {
        ImportError::line(&self.path, self.line, reason)
    }
}

/// One line of a file, with what an error message needs.
pub(crate) struct Line<'a> {
    pub text: &'a str,
    /// 1-based line number.
    pub no: usize,
    /// The file the line is in.
    pub path: &'a Path,
}

impl Line<'_> {
    pub fn err(&self, reason: impl Into<String>) -> ImportError {
        ImportError::line(self.path, self.no, reason)
    }
}

/// One matrix entry `row col value` (1-based indices ≤ `n`, 0-based on return) from the
/// fields of a line; the error says what is wrong and what was expected.
pub(crate) fn parse_entry<'a>(
    mut fields: impl Iterator<Item = &'a str>,
    n: usize,
) -> Result<(usize, usize, f64), String> {
    let parsed = (|| {
        let r = parse_index(fields.next(), n, "row")?;
        let c = parse_index(fields.next(), n, "column")?;
        let v = parse_value(fields.next(), "value")?;
        if let Some(extra) = fields.next() {
            return Err(format!("unexpected extra field '{extra}'"));
        }
        Ok((r, c, v))
    })();
    parsed.map_err(|e| format!("{e} (expected 'row col value')"))
}

/// Parses a 1-based index in `1..=n` and returns it 0-based.
pub(crate) fn parse_index(tok: Option<&str>, n: usize, what: &str) -> Result<usize, String> {
    let tok = tok.ok_or_else(|| format!("missing {what}"))?;
    let i: usize = tok
        .parse()
        .map_err(|_| format!("{what} '{tok}' is not a positive integer"))?;
    if i == 0 || i > n {
        return Err(format!("{what} {i} out of range 1..={n}"));
    }
    Ok(i - 1)
}

/// Parses a finite floating-point value.
pub(crate) fn parse_value(tok: Option<&str>, what: &str) -> Result<f64, String> {
    let tok = tok.ok_or_else(|| format!("missing {what}"))?;
    let v: f64 = tok
        .parse()
        .map_err(|_| format!("{what} '{tok}' is not a number"))?;
    if !v.is_finite() {
        return Err(format!("{what} '{tok}' is not finite"));
    }
    Ok(v)
}
