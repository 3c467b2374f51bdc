//! How an error is printed: its chain of causes once each, and no raw bytes.

/// Ends a command with this exit status instead of 1. Its message is empty, so as the error
/// itself it prints nothing (`pvs diff` found differences, exit 1, as `diff`); as the context
/// of another error it sets that error's status (`pvs diff` failed, exit 2), and the error's
/// own chain is printed.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ExitStatus(pub u8);

impl std::fmt::Display for ExitStatus {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

impl std::error::Error for ExitStatus {}

/// Longest message printed; the rest is cut (a parser quoting a whole binary "line").
const MAX_MESSAGE_CHARS: usize = 2000;

/// `e` and its causes joined by ": ", as anyhow's `{:#}`, except that a cause whose text an
/// outer message already includes is left out: errors like `PvsError::Io` show their source
/// in their own message ("{path}: {source}") and also return it as `source()`, which would
/// print every OS error twice.
pub(crate) fn error_chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    printable(&out)
}

/// `text` safe for a terminal: control characters (a binary file's bytes quoted by a parser:
/// escape sequences, NULs, carriage returns) escaped as `\u{..}`, line breaks kept, at most
/// [`MAX_MESSAGE_CHARS`] characters.
pub(crate) fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len().min(MAX_MESSAGE_CHARS + 16));
    for (n, c) in text.chars().enumerate() {
        if n == MAX_MESSAGE_CHARS {
            out.push_str("... (cut)");
            break;
        }
        match c {
            '\n' => out.push(c),
            c if c.is_control() => out.extend(c.escape_unicode()),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("{path}: {source}")]
    struct WithPath {
        path: String,
        source: std::io::Error,
    }

    #[test]
    fn an_os_error_shown_by_its_parent_is_printed_once() {
        let io = std::io::Error::from_raw_os_error(2);
        let text = io.to_string();
        let e = anyhow::Error::new(WithPath {
            path: "a.pvs".into(),
            source: io,
        })
        .context("reading a.pvs");
        let chain = error_chain(&e);
        assert_eq!(chain.matches(&text).count(), 1, "{chain}");
        assert!(chain.starts_with("reading a.pvs: a.pvs: "), "{chain}");
    }

    #[test]
    fn control_characters_are_escaped_and_long_text_cut() {
        assert_eq!(printable("a\u{1b}[31mb\0\nc"), "a\\u{1b}[31mb\\u{0}\nc");
        let long = "x".repeat(3 * MAX_MESSAGE_CHARS);
        assert!(printable(&long).chars().count() < MAX_MESSAGE_CHARS + 20);
    }
}
