//! A character cursor over one line of an `.lsys` file, tracking 1-based positions.

use crate::error::Pos;

/// Reads one source line character by character.
pub struct Cursor {
    chars: Vec<char>,
    i: usize,
    line: u32,
    col0: u32,
}

impl Cursor {
    /// A cursor over `text`, which starts at `line`, column `col0 + 1`.
    pub fn new(text: &str, line: u32, col0: u32) -> Self {
        Cursor {
            chars: text.chars().collect(),
            i: 0,
            line,
            col0,
        }
    }

    /// Position of the next character.
    pub fn pos(&self) -> Pos {
        Pos {
            line: self.line,
            col: self.col0 + self.i as u32 + 1,
        }
    }

    /// The next character.
    pub fn peek(&self) -> Option<char> {
        self.chars.get(self.i).copied()
    }

    /// The character `n` ahead of the next one.
    pub fn peek_at(&self, n: usize) -> Option<char> {
        self.chars.get(self.i + n).copied()
    }

    /// Skips `n` characters.
    pub fn advance(&mut self, n: usize) {
        self.i = (self.i + n).min(self.chars.len());
    }

    /// Skips spaces and tabs.
    pub fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(c) if c.is_whitespace()) {
            self.i += 1;
        }
    }

    /// True when only whitespace is left.
    pub fn at_end(&mut self) -> bool {
        self.skip_ws();
        self.i >= self.chars.len()
    }

    /// An identifier `[A-Za-z_][A-Za-z0-9_]*` (may be empty).
    pub fn ident(&mut self) -> String {
        let start = self.i;
        while matches!(self.peek(), Some(c) if c.is_ascii_alphanumeric() || c == '_') {
            self.i += 1;
        }
        self.chars[start..self.i].iter().collect()
    }

    /// A decimal number with optional fraction and exponent.
    pub fn number(&mut self) -> Option<f64> {
        let start = self.i;
        while matches!(self.peek(), Some(c) if c.is_ascii_digit()) {
            self.i += 1;
        }
        if self.peek() == Some('.') {
            self.i += 1;
            while matches!(self.peek(), Some(c) if c.is_ascii_digit()) {
                self.i += 1;
            }
        }
        if matches!(self.peek(), Some('e' | 'E')) {
            let save = self.i;
            self.i += 1;
            if matches!(self.peek(), Some('+' | '-')) {
                self.i += 1;
            }
            if matches!(self.peek(), Some(c) if c.is_ascii_digit()) {
                while matches!(self.peek(), Some(c) if c.is_ascii_digit()) {
                    self.i += 1;
                }
            } else {
                self.i = save;
            }
        }
        let s: String = self.chars[start..self.i].iter().collect();
        s.parse::<f64>().ok().filter(|v| v.is_finite())
    }

    /// The rest of the line from the cursor.
    pub fn rest(&self) -> String {
        self.chars[self.i..].iter().collect()
    }
}
