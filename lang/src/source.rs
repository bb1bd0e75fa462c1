//! The source map: every file the front end loaded (the main file, each included file once,
//! and the synthetic files holding predefined and command-line macros), addressed by
//! [`FileId`], and [`Span`]s (byte ranges in one file) with their line/column lookup.
//!
//! Spans always point into the original text of a loaded file, never into macro-expanded
//! text, so a diagnostic can show the line the user wrote.

use std::ops::Range;
use std::path::{Path, PathBuf};

/// Largest source file accepted, in bytes (64 MiB): spans are `u32` offsets, and a larger
/// shader is not a shader.
pub const MAX_FILE_BYTES: usize = 64 << 20;

/// Index of a file in a [`SourceMap`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FileId(pub u32);

/// A byte range `start..end` in one file of the source map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Span {
    /// The file the range is in.
    pub file: FileId,
    /// First byte.
    pub start: u32,
    /// One past the last byte.
    pub end: u32,
}

impl Span {
    /// A span from byte `start` to `end` of `file`.
    pub fn new(file: FileId, start: usize, end: usize) -> Span {
        Span {
            file,
            start: start as u32,
            end: end as u32,
        }
    }

    /// The smallest span covering `self` and `other` when both are in the same file, else
    /// `self`.
    pub fn to(self, other: Span) -> Span {
        if self.file != other.file {
            return self;
        }
        Span {
            file: self.file,
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    /// The byte range as `usize`s.
    pub fn range(self) -> Range<usize> {
        self.start as usize..self.end as usize
    }
}

/// One loaded file.
#[derive(Debug)]
pub struct SourceFile {
    /// The path it was read from (or the name given to [`SourceMap::add`]).
    pub path: PathBuf,
    /// The name shown in diagnostics.
    pub name: String,
    /// The text (valid UTF-8; a file that was not is rejected before it is parsed).
    pub text: String,
    line_starts: Vec<usize>,
}

impl SourceFile {
    /// 0-based index of the line holding byte `offset`.
    pub fn line_index(&self, offset: usize) -> usize {
        match self.line_starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i - 1,
        }
    }

    /// Byte range of 0-based line `line` (with its line break), if it exists.
    pub fn line_range(&self, line: usize) -> Option<Range<usize>> {
        let start = *self.line_starts.get(line)?;
        let end = self
            .line_starts
            .get(line + 1)
            .copied()
            .unwrap_or(self.text.len());
        Some(start..end)
    }
}

/// 1-based line and column (in characters) of a byte offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineCol {
    /// 1-based line.
    pub line: usize,
    /// 1-based column, counted in characters.
    pub column: usize,
}

/// Every file the front end loaded.
#[derive(Debug, Default)]
pub struct SourceMap {
    files: Vec<SourceFile>,
}

impl SourceMap {
    /// An empty map.
    pub fn new() -> SourceMap {
        SourceMap::default()
    }

    /// Adds a file and returns its id. `text` must be under [`MAX_FILE_BYTES`] (the loader
    /// checks; longer text is cut there so spans stay valid).
    pub fn add(&mut self, path: impl Into<PathBuf>, mut text: String) -> FileId {
        if text.len() > MAX_FILE_BYTES {
            let mut cut = MAX_FILE_BYTES;
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            text.truncate(cut);
        }
        let path = path.into();
        let name = path.display().to_string();
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        self.files.push(SourceFile {
            path,
            name,
            text,
            line_starts,
        });
        FileId(self.files.len() as u32 - 1)
    }

    /// The file with id `id`. Ids come from this map, so this does not fail for them.
    pub fn file(&self, id: FileId) -> &SourceFile {
        &self.files[id.0 as usize]
    }

    /// The id of the file loaded from `path`, if any.
    pub fn find(&self, path: &Path) -> Option<FileId> {
        self.files
            .iter()
            .position(|f| f.path == path)
            .map(|i| FileId(i as u32))
    }

    /// Number of files.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether no file is loaded.
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// The text a span covers (empty if the span is out of range).
    pub fn text(&self, span: Span) -> &str {
        self.file(span.file).text.get(span.range()).unwrap_or("")
    }

    /// 1-based line and column of the start of `span`.
    pub fn line_col(&self, span: Span) -> LineCol {
        let f = self.file(span.file);
        let offset = (span.start as usize).min(f.text.len());
        let line = f.line_index(offset);
        let start = f.line_starts[line];
        let column = f.text.get(start..offset).map_or(0, |s| s.chars().count()) + 1;
        LineCol {
            line: line + 1,
            column,
        }
    }

    /// `name:line:column` of the start of `span`.
    pub fn describe(&self, span: Span) -> String {
        let lc = self.line_col(span);
        format!("{}:{}:{}", self.file(span.file).name, lc.line, lc.column)
    }
}

impl<'a> codespan_reporting::files::Files<'a> for SourceMap {
    type FileId = FileId;
    type Name = &'a str;
    type Source = &'a str;

    fn name(&'a self, id: FileId) -> Result<&'a str, codespan_reporting::files::Error> {
        self.files
            .get(id.0 as usize)
            .map(|f| f.name.as_str())
            .ok_or(codespan_reporting::files::Error::FileMissing)
    }

    fn source(&'a self, id: FileId) -> Result<&'a str, codespan_reporting::files::Error> {
        self.files
            .get(id.0 as usize)
            .map(|f| f.text.as_str())
            .ok_or(codespan_reporting::files::Error::FileMissing)
    }

    fn line_index(
        &'a self,
        id: FileId,
        byte_index: usize,
    ) -> Result<usize, codespan_reporting::files::Error> {
        let f = self
            .files
            .get(id.0 as usize)
            .ok_or(codespan_reporting::files::Error::FileMissing)?;
        Ok(f.line_index(byte_index.min(f.text.len())))
    }

    fn line_range(
        &'a self,
        id: FileId,
        line_index: usize,
    ) -> Result<Range<usize>, codespan_reporting::files::Error> {
        let f = self
            .files
            .get(id.0 as usize)
            .ok_or(codespan_reporting::files::Error::FileMissing)?;
        f.line_range(line_index)
            .ok_or(codespan_reporting::files::Error::LineTooLarge {
                given: line_index,
                max: f.line_starts.len() - 1,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        let mut sm = SourceMap::new();
        let f = sm.add("a.sl", "ab\ncdé f\n".to_string());
        assert_eq!(
            sm.line_col(Span::new(f, 0, 1)),
            LineCol { line: 1, column: 1 }
        );
        assert_eq!(
            sm.line_col(Span::new(f, 3, 4)),
            LineCol { line: 2, column: 1 }
        );
        // 'f' follows the two-byte 'é' and a space: column 5 in characters.
        assert_eq!(
            sm.line_col(Span::new(f, 8, 9)),
            LineCol { line: 2, column: 5 }
        );
        assert_eq!(sm.describe(Span::new(f, 8, 9)), "a.sl:2:5");
        assert_eq!(sm.text(Span::new(f, 3, 5)), "cd");
    }
}
