//! Decoding bytes to text, splitting lines, and reading numbers with line numbers.

use crate::IesError;

/// Decodes the input: UTF-8 when it is valid UTF-8 (a byte-order mark is dropped), Latin-1
/// otherwise (every byte is a character, so decoding never fails).
pub(crate) fn decode(bytes: &[u8]) -> String {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_owned(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    }
}

/// Splits text into lines. `\n`, `\r\n` and (for files with no `\n` at all) a lone `\r` end a
/// line. The line terminator is not part of the line.
pub(crate) fn lines(text: &str) -> Vec<&str> {
    if !text.contains('\n') && text.contains('\r') {
        return text.split('\r').collect();
    }
    text.split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .collect()
}

/// Shortens a token for an error message.
pub(crate) fn shorten(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    out
}

/// A stream of whitespace- or comma-separated tokens over a range of lines, each token with its
/// 1-based line number.
pub(crate) struct Tokens<'a> {
    lines: &'a [&'a str],
    /// Index into `lines` of the line being read.
    line: usize,
    /// Byte offset inside that line.
    col: usize,
    /// Offset added to line indices to give 1-based file line numbers.
    first_line_number: usize,
    /// Whether a comma inside a token is a decimal comma (EULUMDAT) rather than a separator.
    decimal_comma: bool,
    /// Line number of the last token returned.
    last_token_line: Option<usize>,
}

impl<'a> Tokens<'a> {
    /// Tokens of `lines`, where `lines[0]` is line `first_line_number` of the file.
    pub(crate) fn new(lines: &'a [&'a str], first_line_number: usize) -> Self {
        Tokens {
            lines,
            line: 0,
            col: 0,
            first_line_number,
            decimal_comma: false,
            last_token_line: None,
        }
    }

    /// Same, with `,` read as a decimal separator inside numbers, and `;` and whitespace as
    /// separators.
    pub(crate) fn with_decimal_comma(lines: &'a [&'a str], first_line_number: usize) -> Self {
        Tokens {
            decimal_comma: true,
            ..Tokens::new(lines, first_line_number)
        }
    }

    /// Separators: ASCII whitespace, and `,` (LM-63) or `;` (EULUMDAT, where `,` is a decimal
    /// comma). Bytes of non-ASCII characters are never separators.
    fn is_sep(&self, b: u8) -> bool {
        b.is_ascii_whitespace() || b == if self.decimal_comma { b';' } else { b',' }
    }

    /// Line number of the line the stream is at (the last line when at the end).
    pub(crate) fn line_number(&self) -> usize {
        self.first_line_number + self.line.min(self.lines.len().saturating_sub(1))
    }

    /// The next token and its line number, or `None` at the end.
    pub(crate) fn next_token(&mut self) -> Option<(&'a str, usize)> {
        while self.line < self.lines.len() {
            let l: &'a str = self.lines[self.line];
            let bytes = l.as_bytes();
            let mut i = self.col;
            while i < bytes.len() && self.is_sep(bytes[i]) {
                i += 1;
            }
            if i >= bytes.len() {
                self.line += 1;
                self.col = 0;
                continue;
            }
            let mut j = i;
            while j < bytes.len() && !self.is_sep(bytes[j]) {
                j += 1;
            }
            self.col = j;
            let line = self.first_line_number + self.line;
            self.last_token_line = Some(line);
            // Token boundaries are ASCII bytes or the line ends, so they are char boundaries.
            return l.get(i..j).map(|tok| (tok, line));
        }
        None
    }

    /// Reads a finite number.
    pub(crate) fn number(&mut self, expected: &str) -> Result<(f64, usize), IesError> {
        let Some((tok, line)) = self.next_token() else {
            return Err(IesError::UnexpectedEof {
                line: self.last_token_line.unwrap_or_else(|| self.line_number()),
                expected: expected.to_owned(),
            });
        };
        let value = parse_number(tok, self.decimal_comma).ok_or_else(|| IesError::Syntax {
            line,
            expected: format!("{expected} (a finite number)"),
            found: shorten(tok),
        })?;
        Ok((value, line))
    }

    /// Reads `n` finite numbers; also returns the line of the first (the current line when
    /// `n` is 0).
    pub(crate) fn numbers(
        &mut self,
        n: usize,
        expected: &str,
    ) -> Result<(Vec<f64>, usize), IesError> {
        let mut out = Vec::with_capacity(n);
        let mut first_line = self.line_number();
        for k in 0..n {
            let (v, line) = self.number(expected)?;
            if k == 0 {
                first_line = line;
            }
            out.push(v);
        }
        Ok((out, first_line))
    }

    /// Reads a number that must be a whole number in `min..=max`.
    pub(crate) fn integer(
        &mut self,
        expected: &str,
        min: i64,
        max: i64,
    ) -> Result<(i64, usize), IesError> {
        let (v, line) = self.number(expected)?;
        integer_in(v, line, expected, min, max).map(|i| (i, line))
    }
}

/// `v` as an integer in `min..=max`, or an error naming `what`.
pub(crate) fn integer_in(
    v: f64,
    line: usize,
    what: &str,
    min: i64,
    max: i64,
) -> Result<i64, IesError> {
    // Both bounds are far below 2^53, so the float comparison is exact.
    if v.fract() != 0.0 || v < min as f64 || v > max as f64 {
        return Err(IesError::OutOfRange {
            line,
            what: what.to_owned(),
            value: v,
            expected: format!("a whole number from {min} to {max}"),
        });
    }
    Ok(v as i64)
}

/// Parses a decimal number; rejects NaN, infinities and anything that is not a plain number.
pub(crate) fn parse_number(tok: &str, decimal_comma: bool) -> Option<f64> {
    // Only digits, sign, point, exponent: this rejects "inf", "NaN", "infinity" up front.
    let ok = tok.bytes().all(|b| {
        b.is_ascii_digit()
            || matches!(b, b'+' | b'-' | b'.' | b'e' | b'E')
            || (decimal_comma && b == b',')
    });
    if !ok {
        return None;
    }
    let v: f64 = if decimal_comma && tok.contains(',') {
        tok.replace(',', ".").parse().ok()?
    } else {
        tok.parse().ok()?
    };
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_utf8_and_latin1() {
        assert_eq!(decode("µ°".as_bytes()), "µ°");
        assert_eq!(decode(b"\xB5\xB0"), "µ°");
        assert_eq!(decode(b"\xEF\xBB\xBFabc"), "abc");
    }

    #[test]
    fn splits_crlf_lf_and_cr() {
        assert_eq!(lines("a\r\nb\nc"), ["a", "b", "c"]);
        assert_eq!(lines("a\rb"), ["a", "b"]);
    }

    #[test]
    fn tokens_cross_lines_and_commas() {
        let ls = ["1, 2", "", "  3,4  5"];
        let mut t = Tokens::new(&ls, 10);
        let got: Vec<_> = std::iter::from_fn(|| t.next_token()).collect();
        assert_eq!(got, [("1", 10), ("2", 10), ("3", 12), ("4", 12), ("5", 12)]);
    }

    #[test]
    fn decimal_comma_tokens() {
        let ls = ["0,5", "1.5;2"];
        let mut t = Tokens::with_decimal_comma(&ls, 1);
        assert_eq!(t.number("x").unwrap(), (0.5, 1));
        assert_eq!(t.number("x").unwrap(), (1.5, 2));
        assert_eq!(t.number("x").unwrap(), (2.0, 2));
        assert!(matches!(
            t.number("x"),
            Err(IesError::UnexpectedEof { line: 2, .. })
        ));
    }

    #[test]
    fn rejects_non_finite_and_garbage() {
        for bad in [
            "NaN", "inf", "-inf", "infinity", "1e999", "1.0abc", "", "--1", "0x10",
        ] {
            assert_eq!(parse_number(bad, false), None, "{bad}");
        }
        assert_eq!(parse_number(".21", false), Some(0.21));
        assert_eq!(parse_number("-1", false), Some(-1.0));
        assert_eq!(parse_number("1E2", false), Some(100.0));
    }

    #[test]
    fn integers_checked() {
        assert_eq!(integer_in(3.0, 1, "n", 1, 5).unwrap(), 3);
        assert!(integer_in(3.5, 1, "n", 1, 5).is_err());
        assert!(integer_in(0.0, 1, "n", 1, 5).is_err());
        assert!(integer_in(1e300, 1, "n", 1, 5).is_err());
    }
}
