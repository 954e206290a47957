//! The writer's last pass: Verilog lines of at most [`WIDTH`] columns.
//!
//! The emitter builds each statement on one line; this pass breaks the
//! ones that are too long, as a person would, without changing a token:
//!
//! * a `//` comment is word-wrapped, its continuation lines indented two
//!   columns past the `//` (`//   more`); a comment that follows code on
//!   the same line moves to its own line above the code;
//! * a statement breaks first after its assignment (`=` or `<=`), then at
//!   the shallowest nesting level (parentheses, braces, brackets) that
//!   makes the pieces fit: after a comma, or before a binary or ternary
//!   operator (`?`, `:`, `|`, `&`, `^`, `+`, `-`, `*`, comparisons), so a
//!   long reduction becomes a column of operands and a long concatenation a
//!   column of fields; continuation lines are indented four columns past
//!   the statement.
//!
//! Breaks replace a single space with a newline and indentation, and only
//! outside string literals, so the token stream is unchanged (a unit test
//! checks it). Lines that cannot be broken that way (a preprocessor
//! directive, a block comment, a single token longer than the line) are
//! left as they are; the suite's style test reports them.

/// The longest line the writer produces (the lowRISC Verilog style guide's
/// limit).
pub const WIDTH: usize = 100;

/// `text` with every line longer than `width` columns broken as the module
/// doc describes; lines that fit are unchanged, and so is the text when
/// every line fits.
///
/// ```
/// use fxshade_backend::wrap::wrap_verilog;
/// let long = "  wire [3:0] x = {a_long_name, b_long_name, c_long_name};\n";
/// assert_eq!(
///     wrap_verilog(long, 40),
///     "  wire [3:0] x =\n      {a_long_name, b_long_name,\n      c_long_name};\n"
/// );
/// ```
pub fn wrap_verilog(text: &str, width: usize) -> String {
    let mut out = String::with_capacity(text.len() + text.len() / 16);
    for piece in text.split_inclusive('\n') {
        let (line, nl) = match piece.strip_suffix('\n') {
            Some(l) => (l, "\n"),
            None => (piece, ""),
        };
        if line.chars().count() <= width {
            out.push_str(line);
        } else {
            out.push_str(&wrap_line(line, width));
        }
        out.push_str(nl);
    }
    out
}

/// One line broken to `width` columns (joined by newlines, no final one).
fn wrap_line(line: &str, width: usize) -> String {
    let indent = line.len() - line.trim_start_matches(' ').len();
    let body = &line[indent..];
    if body.starts_with('`') || line.contains("/*") || !line.is_ascii() {
        return line.to_string();
    }
    if let Some(text) = body.strip_prefix("//") {
        return wrap_comment(&line[..indent], text, width);
    }
    let (code, comment) = split_comment(line);
    let code = code.trim_end();
    let mut out = String::new();
    if let Some(c) = comment {
        out += &wrap_comment(&line[..indent], &c[2..], width);
        out.push('\n');
        if code.len() <= width {
            out += code;
            return out;
        }
    }
    out += &wrap_code(code, indent, width);
    out
}

/// A comment's text (after `//`) word-wrapped behind `indent`.
fn wrap_comment(indent: &str, text: &str, width: usize) -> String {
    let lead = text.len() - text.trim_start().len();
    let first = format!("{indent}//{}", &text[..lead]);
    let cont = format!("{indent}//{}  ", &text[..lead]);
    let mut lines = vec![first.clone()];
    let mut fresh = true;
    // A word that opens a parenthesis it does not close stays with the
    // next one: `(hash 511de6b7919ec8e7)` is never split.
    let mut words: Vec<String> = Vec::new();
    let mut glue = false;
    for word in text[lead..].split(' ') {
        if glue {
            let last = words.last_mut().expect("a word");
            last.push(' ');
            last.push_str(word);
        } else {
            words.push(word.to_string());
        }
        glue = !glue && word.starts_with('(') && !word.contains(')');
    }
    for word in &words {
        let cur = lines.last_mut().expect("a line");
        if fresh {
            cur.push_str(word);
            fresh = false;
        } else if cur.len() + 1 + word.len() <= width || word.is_empty() {
            cur.push(' ');
            cur.push_str(word);
        } else {
            lines.push(format!("{cont}{word}"));
        }
    }
    lines.join("\n")
}

/// The code and the `//` comment of a line (outside string literals).
fn split_comment(line: &str) -> (&str, Option<&str>) {
    let b = line.as_bytes();
    let mut in_str = false;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'\\' if in_str => i += 1,
            b'"' => in_str = !in_str,
            b'/' if !in_str && b.get(i + 1) == Some(&b'/') => {
                return (&line[..i], Some(&line[i..]));
            }
            _ => {}
        }
        i += 1;
    }
    (line, None)
}

/// Tokens made only of these characters are operators.
fn is_operator(tok: &[u8]) -> bool {
    !tok.is_empty() && tok.iter().all(|c| b"?:|&^+-*/%<>=!~".contains(c))
}

/// The places a code line may break: the positions of spaces, each with
/// its nesting depth (the space after a top-level assignment has depth
/// −1, so it is the first break).
fn break_points(b: &[u8]) -> Vec<(usize, i32)> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut in_str = false;
    let mut assigned = false;
    let start = b.iter().position(|&c| c != b' ').unwrap_or(b.len());
    let mut i = start;
    while i < b.len() {
        let c = b[i];
        if in_str {
            match c {
                b'\\' => i += 1,
                b'"' => in_str = false,
                _ => {}
            }
            i += 1;
            continue;
        }
        match c {
            b'"' => in_str = true,
            b'(' | b'{' | b'[' => depth += 1,
            b')' | b'}' | b']' => depth -= 1,
            b' ' => {
                let next_end = b[i + 1..]
                    .iter()
                    .position(|&c| c == b' ')
                    .map_or(b.len(), |k| i + 1 + k);
                let next = &b[i + 1..next_end];
                let prev_end = i;
                let prev_start = b[..i].iter().rposition(|&c| c == b' ').map_or(0, |k| k + 1);
                let prev = &b[prev_start..prev_end];
                if depth == 0 && !assigned && (prev == b"=" || prev == b"<=") {
                    assigned = true;
                    out.push((i, -1));
                } else if depth == 0 && !assigned && (next == b"=" || next == b"<=") {
                    // The assignment's own operator stays on the first line.
                } else if prev.last() == Some(&b',') || (is_operator(next) && !prev.is_empty()) {
                    out.push((i, depth));
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// A code line broken at its [`break_points`] to fit `width`.
fn wrap_code(line: &str, indent: usize, width: usize) -> String {
    let b = line.as_bytes();
    let mut w = Wrapper {
        points: break_points(b),
        width,
        cont: indent + 4,
        breaks: Vec::new(),
    };
    w.place(indent, b.len(), indent);
    w.breaks.sort_unstable();
    let mut out = String::with_capacity(line.len() + 8 * w.breaks.len());
    let mut from = 0;
    for &p in &w.breaks {
        out += &line[from..p];
        out.push('\n');
        out.extend(std::iter::repeat_n(' ', indent + 4));
        from = p + 1;
    }
    out += &line[from..];
    out
}

struct Wrapper {
    points: Vec<(usize, i32)>,
    width: usize,
    cont: usize,
    breaks: Vec<usize>,
}

impl Wrapper {
    /// Place the span `a..b` starting at column `col`; the column after it.
    fn place(&mut self, a: usize, b: usize, col: usize) -> usize {
        if col + (b - a) <= self.width {
            return col + (b - a);
        }
        let inner: Vec<(usize, i32)> = self
            .points
            .iter()
            .copied()
            .filter(|&(p, _)| p > a && p < b)
            .collect();
        let Some(dmin) = inner.iter().map(|&(_, d)| d).min() else {
            return col + (b - a);
        };
        let cuts: Vec<usize> = inner
            .iter()
            .filter(|&&(_, d)| d == dmin)
            .map(|&(p, _)| p)
            .collect();
        let mut col = self.place(a, cuts[0], col);
        for (k, &c) in cuts.iter().enumerate() {
            let end = cuts.get(k + 1).copied().unwrap_or(b);
            let len = end - (c + 1);
            if col + 1 + len <= self.width {
                col += 1 + len;
            } else {
                self.breaks.push(c);
                col = self.place(c + 1, end, self.cont);
            }
        }
        col
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The text with every run of whitespace made one space: what a
    /// Verilog parser sees, token for token.
    fn tokens(s: &str) -> String {
        s.split_whitespace().collect::<Vec<_>>().join(" ")
    }

    #[test]
    fn short_lines_are_left_alone() {
        let t = "module m;\n  wire a = b | c;\nendmodule\n";
        assert_eq!(wrap_verilog(t, 100), t);
    }

    #[test]
    fn a_long_saturation_breaks_after_the_assignment_then_at_the_ternary() {
        // From rtl/normalize.v: 136 columns.
        let l = "  wire signed [17:0] normalize_horner_18_c = $signed(normalize_horner_18_ovf_c ? \
                 (normalize_horner_18_r[20] ? 18'h20000 : 18'h1ffff) : normalize_horner_18_r[17:0]);";
        let w = wrap_verilog(l, 100);
        assert_eq!(
            w,
            "  wire signed [17:0] normalize_horner_18_c =\n      \
             $signed(normalize_horner_18_ovf_c ? (normalize_horner_18_r[20] ? 18'h20000 : 18'h1ffff)\n      \
             : normalize_horner_18_r[17:0]);"
        );
        assert_eq!(tokens(&w), tokens(l));
    }

    #[test]
    fn a_long_reduction_becomes_a_column_that_fits() {
        let names: Vec<String> = (0..40).map(|i| format!("stage_{i}_ovf_q")).collect();
        let l = format!("  wire any = ^{{{}}};", names.join(", "));
        let w = wrap_verilog(&l, 100);
        assert!(w.lines().count() > 5, "{w}");
        assert!(w.lines().all(|x| x.len() <= 100), "{w}");
        assert!(w.lines().skip(1).all(|x| x.starts_with("      ")), "{w}");
        assert_eq!(tokens(&w), tokens(&l));
    }

    #[test]
    fn strings_are_never_broken_and_commas_inside_them_are_not_places() {
        let s = "x, ".repeat(40);
        let l = format!("      $display(\"{s}\", a, b);");
        let w = wrap_verilog(&l, 100);
        assert!(w.contains(&format!("\"{s}\"")), "{w}");
        assert_eq!(tokens(&w), tokens(&l));
    }

    #[test]
    fn comments_are_word_wrapped_and_trailing_comments_move_above() {
        let c = format!("// {}", "word ".repeat(30).trim_end());
        let w = wrap_verilog(&c, 40);
        assert!(w.lines().all(|x| x.len() <= 40), "{w}");
        assert!(w.lines().skip(1).all(|x| x.starts_with("//   word")), "{w}");
        assert_eq!(tokens(&w.replace("//", "")), tokens(&c.replace("//", "")));
        let l = format!("  assign y = a + b; {c}");
        let w = wrap_verilog(&l, 40);
        assert!(w.ends_with("\n  assign y = a + b;"), "{w}");
        assert!(w.starts_with("  // word"), "{w}");
    }

    #[test]
    fn a_parenthesis_and_its_first_word_stay_together() {
        let c = format!(
            "// Configuration: {} (hash 511de6b7919ec8e7)",
            "x".repeat(70)
        );
        let w = wrap_verilog(&c, 100);
        assert_eq!(
            w.lines().nth(1),
            Some("//   (hash 511de6b7919ec8e7)"),
            "{w}"
        );
    }

    #[test]
    fn directives_and_unbreakable_lines_stay_as_they_are() {
        let d = format!("`define LONG {}", "x".repeat(120));
        assert_eq!(wrap_verilog(&d, 100), d);
        let t = format!("  wire {};", "y".repeat(120));
        assert_eq!(wrap_verilog(&t, 100), t);
    }

    #[test]
    fn every_line_fits_when_the_breaks_allow_it() {
        // A nest of additions and concatenations, 3 levels deep.
        let inner = |k: usize| format!("{{{{4{{a{k}[3]}}}}, a{k}[3:0], 2'b00}}");
        let terms: Vec<String> = (0..12).map(inner).collect();
        let l = format!("  wire [9:0] s = $signed({});", terms.join(" + "));
        for width in [60, 80, 100] {
            let w = wrap_verilog(&l, width);
            assert!(w.lines().all(|x| x.len() <= width), "{width}:\n{w}");
            assert_eq!(tokens(&w), tokens(&l));
        }
    }
}
