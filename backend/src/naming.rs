//! The writer's naming pass: lowRISC register suffixes.
//!
//! The emitter names a value stage-locally ([`crate::node_names`]:
//! `normalize_d_0`, its copy in stage 3 `normalize_d_0_s3`, its overflow
//! bit `normalize_d_0_ovf`) and the logic computing a register's next
//! value after the register (`normalize_d_0_c`). This pass gives the
//! module the lowRISC style guide's names: every flip-flop of the module
//! (a `reg` declared at module level and loaded by a non-blocking
//! assignment) ends in `_q` (`normalize_d_0_q`, `normalize_d_0_s3_q`),
//! and the wire its value is computed in, when it is the register's name
//! with `_c`, ends in `_d` (`normalize_d_0_d`). Registers already named
//! `_q`, combinational `reg`s (assigned in `always @*`), memories and the
//! formal block's own registers (`f_…`) keep their names. A name is only
//! changed when the new one is not already taken.
//!
//! The pass rewrites identifiers, never other text, and returns the map it
//! applied so that whatever the emitter reports by signal name (the proof's
//! cut points) follows.

use std::collections::{HashMap, HashSet};

/// Whether `c` continues a Verilog identifier.
fn ident_char(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'$'
}

/// `text` cut into maximal runs of identifier characters and of other
/// characters, in order: `(is_identifier_run, run)`. The runs joined are
/// `text`.
fn runs(text: &str) -> impl Iterator<Item = (bool, &str)> {
    let b = text.as_bytes();
    let mut i = 0;
    std::iter::from_fn(move || {
        if i >= b.len() {
            return None;
        }
        let ident = ident_char(b[i]);
        let j = b[i..]
            .iter()
            .position(|&c| ident_char(c) != ident)
            .map_or(b.len(), |k| i + k);
        let run = &text[i..j];
        i = j;
        Some((ident, run))
    })
}

/// The identifiers of `text` (identifier runs that start with a letter or
/// `_`, so not the digits of a literal such as `18'h3ffff`).
fn identifiers(text: &str) -> HashSet<&str> {
    runs(text)
        .filter(|&(ident, r)| {
            ident && (r.as_bytes()[0].is_ascii_alphabetic() || r.starts_with('_'))
        })
        .map(|(_, r)| r)
        .collect()
}

/// The names a module-level declaration line (`  reg  signed [3:0] a, b;`,
/// `  wire [3:0] c = …;`) declares, for the keyword `kw`; memories
/// (`reg [7:0] m [0:15];`) and declarations with an initializer of a `reg`
/// are not included.
fn declared<'a>(line: &'a str, kw: &str) -> Vec<&'a str> {
    let Some(rest) = line
        .strip_prefix("  ")
        .and_then(|l| l.strip_prefix(kw))
        .filter(|r| r.starts_with(' '))
    else {
        return Vec::new();
    };
    let mut rest = rest.trim_start();
    rest = rest.strip_prefix("signed").unwrap_or(rest).trim_start();
    if rest.starts_with('[') {
        match rest.find(']') {
            Some(k) => rest = rest[k + 1..].trim_start(),
            None => return Vec::new(),
        }
    }
    if kw == "wire" {
        let end = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        return vec![&rest[..end]];
    }
    let Some(list) = rest.strip_suffix(';') else {
        return Vec::new();
    };
    if list.contains('[') || list.contains('=') {
        return Vec::new();
    }
    list.split(',').map(str::trim).collect()
}

/// The names loaded by a non-blocking assignment that starts a statement
/// (`q <= d;`, `if (x) q <= d;`, `else q <= d;`, `begin q <= d;`).
fn loaded(text: &str) -> HashSet<&str> {
    let mut out = HashSet::new();
    for line in text.lines() {
        let mut from = 0;
        while let Some(k) = line[from..].find(" <= ") {
            let at = from + k;
            let b = line.as_bytes();
            let start = b[..at]
                .iter()
                .rposition(|&c| !ident_char(c))
                .map_or(0, |p| p + 1);
            let before = line[..start].trim_end();
            if start < at
                && (before.is_empty()
                    || before.ends_with(')')
                    || before.ends_with("else")
                    || before.ends_with("begin"))
            {
                out.insert(&line[start..at]);
            }
            from = at + 4;
        }
    }
    out
}

/// The renaming of a module's text: every flip-flop named `…_q`, the wire
/// of its next value `…_d` (module doc).
pub fn plan(module: &str) -> HashMap<String, String> {
    let taken = identifiers(module);
    let loads = loaded(module);
    let mut wires = HashSet::new();
    let mut regs = Vec::new();
    for line in module.lines() {
        wires.extend(declared(line, "wire"));
        regs.extend(declared(line, "reg"));
    }
    let mut map = HashMap::new();
    for r in regs {
        if r.ends_with("_q") || r.starts_with("f_") || !loads.contains(r) {
            continue;
        }
        let q = format!("{r}_q");
        if taken.contains(q.as_str()) {
            continue;
        }
        let (c, d) = (format!("{r}_c"), format!("{r}_d"));
        if wires.contains(c.as_str()) && !taken.contains(d.as_str()) {
            map.insert(c, d);
        }
        map.insert(r.to_string(), q);
    }
    map
}

/// `text` with every identifier that `map` names replaced, in code only:
/// `//` comments and string literals are left as they are (a header's
/// configuration path is the user's text, even where it reads like a
/// register's name).
pub fn rename(text: &str, map: &HashMap<String, String>) -> String {
    if map.is_empty() {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len() + text.len() / 8);
    for (code, literal) in code_and_literals(text) {
        if literal {
            out.push_str(code);
            continue;
        }
        for (ident, run) in runs(code) {
            out.push_str(match map.get(run) {
                Some(new) if ident => new,
                _ => run,
            });
        }
    }
    out
}

/// `text` cut into code and literal text (`//` comments to the end of
/// their line, string literals with their quotes and escapes), in order:
/// `(is_literal, piece)`. The pieces joined are `text`.
fn code_and_literals(text: &str) -> Vec<(&str, bool)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let (mut from, mut i) = (0, 0);
    while i < b.len() {
        let end = match b[i] {
            b'"' => {
                let mut j = i + 1;
                while j < b.len() && b[j] != b'"' && b[j] != b'\n' {
                    j += if b[j] == b'\\' { 2 } else { 1 };
                }
                Some((j + 1).min(b.len()))
            }
            b'/' if b.get(i + 1) == Some(&b'/') => Some(
                b[i..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |k| i + k),
            ),
            _ => None,
        };
        match end {
            Some(j) => {
                if from < i {
                    out.push((&text[from..i], false));
                }
                out.push((&text[i..j], true));
                from = j;
                i = j;
            }
            None => i += 1,
        }
    }
    if from < b.len() {
        out.push((&text[from..], false));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const M: &str = "module m (
  input  wire clk_i,
  input  wire [3:0] a_i,
  output wire [3:0] y_o
);
  reg  [1:0] valid_q;
  wire [3:0] x_15_c = a_i + 4'd1;
  wire x_15_ovf_c = a_i[3];
  reg  [3:0] x_15;
  reg  [0:0] x_15_ovf;
  reg  [3:0] x_15_s2, x_15_s3;
  reg  [3:0] sel;
  reg  [7:0] rom [0:15];
  reg  [2:0] f_idle;
  always @* begin
    case (a_i[0])
      1'b1: sel = x_15_s3;
      default: sel = x_15;
    endcase
  end
  always @(posedge clk_i) begin
    if (valid_q[0]) begin
      x_15 <= x_15_c;
      x_15_ovf <= x_15_ovf_c;
    end
    x_15_s2 <= x_15;
    if (a_i[1]) x_15_s3 <= x_15_s2;
    f_idle <= (x_15 <= 4'd3) ? 3'd0 : 3'd1;
  end
  assign y_o = sel ^ {3'b0, x_15_ovf} ^ rom[x_15];
endmodule
";

    #[test]
    fn flip_flops_get_q_and_their_next_values_d() {
        let map = plan(M);
        let want: HashMap<String, String> = [
            ("x_15", "x_15_q"),
            ("x_15_c", "x_15_d"),
            ("x_15_ovf", "x_15_ovf_q"),
            ("x_15_ovf_c", "x_15_ovf_d"),
            ("x_15_s2", "x_15_s2_q"),
            ("x_15_s3", "x_15_s3_q"),
        ]
        .into_iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
        // Not renamed: `valid_q` (already `_q`), `sel` (combinational),
        // `rom` (a memory), `f_idle` (the formal block's).
        assert_eq!(map, want);
        let r = rename(M, &map);
        assert!(r.contains("      x_15_q <= x_15_d;\n"), "{r}");
        assert!(r.contains("if (a_i[1]) x_15_s3_q <= x_15_s2_q;"), "{r}");
        // A comparison is not a load, and is renamed as an expression.
        assert!(r.contains("(x_15_q <= 4'd3)"), "{r}");
        // Literals and system functions are not identifiers to rename.
        assert!(r.contains("4'd1") && r.contains("rom[x_15_q]"), "{r}");
        // Every identifier of the old text is either kept or renamed, and
        // renaming back gives the old text.
        let back: HashMap<String, String> =
            map.iter().map(|(a, b)| (b.clone(), a.clone())).collect();
        assert_eq!(rename(&r, &back), M);
    }

    #[test]
    fn comments_and_strings_are_the_users_text_and_keep_their_words() {
        let m = "// Configuration: x_15.toml (hash 1)\n  reg  [3:0] x_15;\n  \
                 always @(posedge c) x_15 <= a; // x_15 loads a\n  \
                 initial $display(\"x_15 = %0d\", x_15);\n";
        let map = plan(m);
        assert_eq!(map.get("x_15").map(String::as_str), Some("x_15_q"));
        let r = rename(m, &map);
        assert!(
            r.starts_with("// Configuration: x_15.toml (hash 1)\n"),
            "{r}"
        );
        assert!(r.contains("x_15_q <= a; // x_15 loads a\n"), "{r}");
        assert!(r.contains("$display(\"x_15 = %0d\", x_15_q);"), "{r}");
    }

    #[test]
    fn a_taken_name_is_not_reused() {
        let m = "  reg  a;\n  wire a_q = 1'b0;\n  always @(posedge c) a <= a_q;\n";
        assert!(plan(m).is_empty());
    }
}
