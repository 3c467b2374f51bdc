//! Progress on stderr for the long commands without a progress bar of their own (`cull`,
//! `render --cube`, `bench`): indicatif bars, drawn only when stderr is a terminal (indicatif
//! hides them otherwise), so piped and logged runs and `--json` on stdout stay clean.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `len` steps drawn with `template` (indicatif's syntax), ticking by itself so its
/// elapsed time moves during a long step; hidden when stderr is not a terminal.
pub(crate) fn bar(len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::new(len).with_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    if !bar.is_hidden() {
        bar.enable_steady_tick(Duration::from_millis(200));
    }
    bar
}

/// The template of [`bar`] for `unit`s (`frames`, `scenes`, ...): the bar, the position, the
/// message and the elapsed and remaining time.
pub(crate) fn template(unit: &str) -> String {
    format!("{unit} {{bar:30}} {{pos}}/{{len}} {{msg}} [{{elapsed_precise}} < {{eta}}]")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn templates_parse_and_bars_count() {
        let t = template("frames");
        assert!(ProgressStyle::with_template(&t).is_ok(), "{t}");
        let b = bar(3, &t);
        b.inc(2);
        assert_eq!(b.position(), 2);
        assert_eq!(b.length(), Some(3));
    }
}
