//! Scene errors: typed, and displayed as ONE line `FILE:LINE:COL: what — fix` (or `FILE: what —
//! fix` where no position inside the file applies), as the CLI contract in DESIGN.md requires.

use std::fmt;
use std::path::{Path, PathBuf};

/// What went wrong, for callers that branch on it (the message says it for people).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A file could not be read (missing, permissions, …).
    Io,
    /// The scene or camera-path file is not valid TOML, or a value has the wrong type.
    Syntax,
    /// A key the format does not know.
    UnknownKey,
    /// A value is out of range or inconsistent with another (e.g. `height_m` min > max).
    InvalidValue,
    /// A heightmap or density map is not a supported image.
    Image,
    /// A positions CSV has a bad header or row.
    Csv,
    /// A size limit (trees, samples, image dimensions, rows) would be exceeded.
    Limit,
}

/// Where an error is: a file and, when known, a 1-based line and column in it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// The file the error is in (the scene file, a heightmap, a CSV, …).
    pub file: PathBuf,
    /// 1-based line and column (characters), when the error points inside a text file.
    pub line_col: Option<(usize, usize)>,
}

impl Location {
    /// A whole file, no position.
    pub fn file(file: &Path) -> Self {
        Self {
            file: file.to_path_buf(),
            line_col: None,
        }
    }

    /// A position in a text file.
    pub fn at(file: &Path, line: usize, col: usize) -> Self {
        Self {
            file: file.to_path_buf(),
            line_col: Some((line, col)),
        }
    }

    /// The position of byte `offset` in `text` (clamped to the text's end).
    pub fn at_offset(file: &Path, text: &str, offset: usize) -> Self {
        let (line, col) = line_col(text, offset);
        Self::at(file, line, col)
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line_col {
            Some((line, col)) => write!(f, "{}:{line}:{col}", self.file.display()),
            None => write!(f, "{}", self.file.display()),
        }
    }
}

/// 1-based line and column (in characters) of byte `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = before[line_start..].chars().count() + 1;
    (line, col)
}

/// An error from loading or building a scene or camera path.
///
/// `Display` is a single line: `FILE:LINE:COL: what — fix`.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The category.
    pub kind: ErrorKind,
    /// The file and position.
    pub location: Location,
    /// What is wrong (one line).
    pub what: String,
    /// How to fix it (one line).
    pub fix: String,
}

impl SceneError {
    /// A new error; newlines in `what` and `fix` are folded so the message stays one line.
    pub fn new(
        kind: ErrorKind,
        location: Location,
        what: impl Into<String>,
        fix: impl Into<String>,
    ) -> Self {
        Self {
            kind,
            location,
            what: one_line(&what.into()),
            fix: one_line(&fix.into()),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {} — {}", self.location, self.what, self.fix)
    }
}

impl std::error::Error for SceneError {}

/// Reads the text file `path` (a `what`, e.g. "scene file") through `sylvan_io` within `limit`
/// bytes. Errors are at `at` (where the file is named) except a non-UTF-8 byte, which is placed
/// in the file itself.
pub(crate) fn read_text(
    path: &Path,
    limit: u64,
    at: &Location,
    what: &str,
) -> Result<String, SceneError> {
    sylvan_io::read_to_string(path, limit).map_err(|e| read_error(e, path, at, what))
}

/// A `sylvan_io` error as a scene error: `at` where the file is named, `what` the file's role.
pub(crate) fn read_error(
    e: sylvan_io::ReadError,
    path: &Path,
    at: &Location,
    what: &str,
) -> SceneError {
    match e.kind() {
        sylvan_io::ErrorKind::NotUtf8 { line, col } => SceneError::new(
            ErrorKind::Io,
            Location::at(path, *line, *col),
            format!("the {what} is not UTF-8 text"),
            e.fix(),
        ),
        sylvan_io::ErrorKind::TooLarge { .. } => SceneError::new(
            ErrorKind::Limit,
            at.clone(),
            format!("{what} {}: {e}", path.display()),
            e.fix(),
        ),
        _ => {
            let text = e.to_string();
            let why = text.strip_prefix("cannot read: ").unwrap_or(&text);
            let named = if at.file == path {
                format!("cannot read {what}: {why}")
            } else {
                format!("cannot read {what} {}: {why}", path.display())
            };
            SceneError::new(ErrorKind::Io, at.clone(), named, e.fix())
        }
    }
}

/// A number for messages: plain when moderate, scientific when huge or tiny (`1e30`, not a
/// 31-digit string).
pub(crate) fn num(v: f32) -> String {
    if v != 0.0 && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Collapse whitespace runs containing newlines into single spaces.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_from_one() {
        let t = "ab\ncdé\nf";
        assert_eq!(line_col(t, 0), (1, 1));
        assert_eq!(line_col(t, 3), (2, 1));
        assert_eq!(line_col(t, 5), (2, 3));
        assert_eq!(line_col(t, 8), (3, 1));
        assert_eq!(line_col(t, 999), (3, 2));
    }

    #[test]
    fn display_is_one_line() {
        let e = SceneError::new(
            ErrorKind::Syntax,
            Location::at(Path::new("a.toml"), 3, 7),
            "bad\n  thing",
            "fix it",
        );
        assert_eq!(e.to_string(), "a.toml:3:7: bad thing — fix it");
    }
}
