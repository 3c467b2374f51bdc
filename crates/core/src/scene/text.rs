//! Line splitting for the text formats: `\n`, `\r\n` and a lone `\r` (classic Mac OS) each end
//! a line, so a file with CR-only line endings is not read as one long line (an OBJ file read
//! that way is its first vertex and nothing else).

/// The lines of `bytes` without their terminators, like `split(|b| b == b'\n')` (a final
/// terminator gives a last, empty line) but also ending lines at `\r\n` and `\r`.
pub(crate) fn lines(bytes: &[u8]) -> Lines<'_> {
    Lines { rest: Some(bytes) }
}

/// Iterator of [`lines`].
pub(crate) struct Lines<'a> {
    rest: Option<&'a [u8]>,
}

impl<'a> Iterator for Lines<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let rest = self.rest?;
        match rest.iter().position(|&b| b == b'\n' || b == b'\r') {
            None => {
                self.rest = None;
                Some(rest)
            }
            Some(i) => {
                let crlf = rest[i] == b'\r' && rest.get(i + 1) == Some(&b'\n');
                self.rest = Some(&rest[i + 1 + usize::from(crlf)..]);
                Some(&rest[..i])
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_line_ending_splits() {
        let got: Vec<&[u8]> = lines(b"a\nb\r\nc\rd").collect();
        assert_eq!(got, [&b"a"[..], b"b", b"c", b"d"]);
    }

    #[test]
    fn final_terminator_gives_an_empty_line() {
        assert_eq!(lines(b"a\r").count(), 2);
        assert_eq!(lines(b"").count(), 1);
    }
}
