//! [`PlantError`]: every failure of this crate, displayed on one line as
//! `FILE:LINE:COL: what — fix` where a location applies (the CLI prints `error: {e}`).

/// A place in a source file: 1-based line and column (columns count characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pos {
    /// 1-based line.
    pub line: u32,
    /// 1-based column, in characters.
    pub col: u32,
}

/// Errors from building, loading or exporting a plant. Display is one line:
/// `FILE:LINE:COL: what — fix` where a location applies, else `FILE: what — fix`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlantError {
    /// Unknown preset name.
    #[error("unknown plant preset '{0}' — use one of: pine, prunus, bush, chestnut, beech")]
    UnknownPreset(String),
    /// An error at a place in a source file (syntax, bad expression, division by zero, a limit
    /// exceeded by a production).
    #[error("{file}:{line}:{col}: {what} — {fix}", line = pos.line, col = pos.col)]
    At {
        /// File name as given (or `<preset>` / `<input>`).
        file: String,
        /// Where.
        pos: Pos,
        /// What went wrong.
        what: String,
        /// How to fix it.
        fix: String,
    },
    /// An error about a whole file (unreadable, malformed mesh, unsupported format).
    #[error("{file}: {what} — {fix}")]
    File {
        /// File name as given.
        file: String,
        /// What went wrong.
        what: String,
        /// How to fix it.
        fix: String,
    },
}

impl PlantError {
    /// An error at `pos` in `file`.
    pub fn at(file: &str, pos: Pos, what: impl Into<String>, fix: impl Into<String>) -> Self {
        let one = |s: String| s.replace(['\n', '\r'], " ");
        PlantError::At {
            file: file.to_string(),
            pos,
            what: one(what.into()),
            fix: one(fix.into()),
        }
    }

    /// An error about the whole of `file`.
    pub fn file(file: &str, what: impl Into<String>, fix: impl Into<String>) -> Self {
        let one = |s: String| s.replace(['\n', '\r'], " ");
        PlantError::File {
            file: file.to_string(),
            what: one(what.into()),
            fix: one(fix.into()),
        }
    }
}
