//! Text from users and files as error messages show it. A message quotes the value or line it
//! is about, but a value can be a 1.5 MB string and a "line" the whole of a binary file, and a
//! file that failed to parse may be one the user did not mean to show (`adhesion.file =
//! "/etc/shadow"`): every value or line echoed in a message goes through [`excerpt`], which keeps
//! at most [`EXCERPT_CHARS`] characters on one line. Numbers a message shows to a reader go
//! through [`format_sig`].

/// The most characters of a value or line an error message shows.
pub const EXCERPT_CHARS: usize = 80;

/// `text` as a message shows it: its first [`EXCERPT_CHARS`] characters, with control characters
/// escaped (`\n`, `\t`, `\u{1b}`: the message stays one line and a terminal's escape sequences
/// stay inert), and when cut, `…` and the full length in bytes.
pub fn excerpt(text: &str) -> String {
    let mut out = String::new();
    for (n, c) in text.chars().enumerate() {
        if n == EXCERPT_CHARS {
            out.push_str(&format!("… ({} bytes in all)", text.len()));
            return out;
        }
        match c {
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    out
}

/// A line of a file that did not parse as what djkr expected, described without its content:
/// the file may be one the user did not mean to show (`adhesion.file = "/etc/shadow"`), so a
/// message gives the line's number (the caller's) and its shape, never its text.
pub fn unquoted_line(line: &str) -> String {
    let fields = line
        .split([',', ';', '\t', ' '])
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>();
    let numbers = fields.iter().filter(|f| f.parse::<f64>().is_ok()).count();
    format!(
        "(a line of {} characters, not shown: {} field(s), {numbers} of them numbers)",
        line.chars().count(),
        fields.len()
    )
}

/// `x` to `sig` significant digits for a human reader: plain decimals for magnitudes in
/// [1e-3, 1e6) (`560.178239`, not `5.60178239e2`), exponent notation beyond. Machine files use
/// djkr's `format_f64` (the shortest round trip) instead.
pub fn format_sig(x: f64, sig: usize) -> String {
    let m = x.abs();
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let sig = sig.max(1);
    if (1e-3..1e6).contains(&m) {
        // Digits after the point: sig minus the digits before it (rounding may add one).
        let mut exp = m.log10().floor() as i64;
        // 999.9996 to 6 digits rounds up into the next decade: one digit fewer after the point.
        if format!("{m:.prec$e}", prec = sig - 1)
            .parse::<f64>()
            .unwrap_or(m)
            >= 10f64.powi(exp as i32 + 1)
        {
            exp += 1;
        }
        let decimals = (sig as i64 - 1 - exp).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = sig - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_text_is_kept_and_long_text_is_cut() {
        assert_eq!(excerpt("51mm"), "51mm");
        assert_eq!(excerpt("a\nb\tc\u{1b}[2J"), "a\\nb\\tc\\u{1b}[2J");
        let long = "x".repeat(1_500_000);
        let e = excerpt(&long);
        assert!(e.starts_with(&"x".repeat(EXCERPT_CHARS)));
        assert!(e.ends_with("… (1500000 bytes in all)"), "{e}");
        assert!(e.chars().count() < EXCERPT_CHARS + 30);
        // Characters, not bytes: a multi-byte character is never split.
        let mus = "µ".repeat(200);
        assert_eq!(
            excerpt(&mus).chars().filter(|&c| c == 'µ').count(),
            EXCERPT_CHARS
        );
    }

    #[test]
    fn a_line_of_a_file_is_described_not_shown() {
        let d = unquoted_line("daemon:*:19000:0:99999:7:::");
        assert!(!d.contains("daemon") && !d.contains("19000"), "{d}");
        assert_eq!(
            unquoted_line("1e-3, abc"),
            "(a line of 9 characters, not shown: 2 field(s), 1 of them numbers)"
        );
    }
}
