//! A whitespace tokenizer that remembers line numbers (for ASCII STL and OBJ errors).

use std::str::{Lines, SplitWhitespace};

/// Yields `(1-based line, token)` pairs.
pub(crate) struct Lexer<'a> {
    lines: Lines<'a>,
    line_no: usize,
    current: Option<SplitWhitespace<'a>>,
}

impl<'a> Lexer<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        Self { lines: text.lines(), line_no: 0, current: None }
    }

    /// Line of the last token returned (or the last line read).
    pub(crate) fn line(&self) -> usize {
        self.line_no.max(1)
    }

    /// Drops what is left of the current line.
    pub(crate) fn skip_line(&mut self) {
        self.current = None;
    }

    /// Next token, crossing lines.
    pub(crate) fn next_token(&mut self) -> Option<(usize, &'a str)> {
        loop {
            if let Some(tok) = self.current.as_mut().and_then(|c| c.next()) {
                return Some((self.line_no, tok));
            }
            let line = self.lines.next()?;
            self.line_no += 1;
            self.current = Some(line.split_whitespace());
        }
    }
}
