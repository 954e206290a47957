//! User strings (paths, `--set` values, mesh names) written into generated
//! files and onto the terminal: each is escaped for where it goes, so no
//! string can end a comment, start a directive, or put a control sequence
//! on a terminal.

/// `s` as one line of printable ASCII: a backslash is doubled, newline,
/// carriage return and tab become `\n`, `\r`, `\t`, any other control
/// character or non-ASCII character `\u{XXXX}`. Safe inside a line comment
/// of Verilog, TOML, Yosys or shell scripts, and on a terminal; the
/// original is recoverable.
///
/// ```
/// use fxshade_ir::escape::line;
/// assert_eq!(line("a b.toml"), "a b.toml");
/// assert_eq!(line("x\n`define Y\n"), "x\\n`define Y\\n");
/// assert_eq!(line("Θ\\"), "\\u{398}\\\\");
/// ```
pub fn line(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            ' '..='~' => out.push(c),
            _ => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
        }
    }
    out
}

/// `s` in printable ASCII for a generated file's comment: the symbols
/// fxshade's own notes use spelled out (`Θ` as `Theta`, `·` as `*`, `−` as
/// `-`, `≤` as `<=`, `×` as `x`, `√` as `sqrt`, `°` as ` deg`), anything
/// else as [`line`](fn@line) writes it.
///
/// ```
/// assert_eq!(fxshade_ir::escape::ascii("I0·km, Θ = 0.5"), "I0*km, Theta = 0.5");
/// ```
pub fn ascii(s: &str) -> String {
    let mut t = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            'Θ' => t.push_str("Theta"),
            'θ' => t.push_str("theta"),
            '·' => t.push('*'),
            '−' | '–' => t.push('-'),
            '≤' => t.push_str("<="),
            '≥' => t.push_str(">="),
            '×' => t.push('x'),
            '√' => t.push_str("sqrt"),
            '°' => t.push_str(" deg"),
            'α' => t.push_str("alpha"),
            'β' => t.push_str("beta"),
            '…' => t.push_str("..."),
            '→' => t.push_str("->"),
            _ => t.push(c),
        }
    }
    line(&t)
}

/// The characters Markdown gives a meaning escaped with a backslash, and
/// control or non-ASCII characters as [`line`](fn@line) writes them, so a line of
/// text (one [`line`](fn@line) made already, say) shows literally in a Markdown
/// page.
///
/// ```
/// assert_eq!(fxshade_ir::escape::markdown("a_b `c`\n"), "a\\_b \\`c\\`\\n");
/// ```
pub fn markdown(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if "`*_[]<>#|!".contains(c) {
            out.push('\\');
            out.push(c);
        } else if c == '\\' || (' '..='~').contains(&c) {
            out.push(c);
        } else {
            out.push_str(&line(&c.to_string()));
        }
    }
    out
}

/// The first control character of `s`, if any (what a configuration value
/// never needs).
pub fn control_char(s: &str) -> Option<char> {
    s.chars().find(|c| c.is_control())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_ends_a_line_comment() {
        for s in [
            "\n",
            "\r\n",
            "a\u{2028}b",
            "*/",
            "`",
            "\"$(rm -rf)\"",
            "\u{1b}[31m",
        ] {
            let l = line(s);
            assert!(
                l.chars().all(|c| (' '..='~').contains(&c)),
                "{s:?} -> {l:?}"
            );
        }
    }
}
