//! The SMT encoding of the compiled trace, checked on every unit of the
//! default configuration (these tests need the units, which sit above the
//! IR crate that owns the encoding, `crate::datapath::SmtFunction`).

use crate::rtl::units::{self, Part};

/// The codes of every `#b…`/`#x…` literal of a solver's output, in
/// order.
fn literals(text: &str) -> Vec<u128> {
    text.split(|c: char| c.is_whitespace() || c == '(' || c == ')')
        .filter_map(|t| {
            if let Some(b) = t.strip_prefix("#b") {
                u128::from_str_radix(b, 2).ok()
            } else if let Some(h) = t.strip_prefix("#x") {
                u128::from_str_radix(h, 16).ok()
            } else {
                None
            }
        })
        .collect()
}

/// Runs z3 on `script`, its standard output.
fn z3(script: &str) -> String {
    assert!(
        std::process::Command::new("z3")
            .arg("--version")
            .output()
            .is_ok(),
        "z3 is not installed: `sudo apt-get install z3` (./scripts/test does it as root)"
    );
    let o = std::process::Command::new("z3")
        .args(["-in", "-smt2"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            use std::io::Write;
            c.stdin.take().unwrap().write_all(script.as_bytes())?;
            c.wait_with_output()
        })
        .unwrap();
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The two forms of a table read agree: for every table of every unit
/// of the default configuration, z3 finds no index where the `ite`
/// tree `fxshade equiv` uses differs from the array of the entries
/// (the form the evaluation test below checks row by row).
#[test]
fn table_trees_are_the_table_arrays() {
    let cfg = crate::Config::embedded();
    let mut tables = 0;
    for u in units::all() {
        let d = u.design(&cfg).unwrap();
        let t = &d.trace;
        let all = vec![true; t.ops().len()];
        let (mut tree, mut arr) = (String::new(), String::new());
        t.smt_nodes(&all, &[], &[], true, &mut tree).unwrap();
        t.smt_nodes(&all, &[], &[], false, &mut arr).unwrap();
        for line in tree.lines().filter(|l| l.starts_with("(define-fun tab")) {
            // `(define-fun tab<slot>_<w> ((a (_ BitVec k))) …`
            let name = line.split_whitespace().nth(1).unwrap();
            let k: u32 = line
                .split("BitVec ")
                .nth(1)
                .and_then(|r| r.split(')').next())
                .unwrap()
                .parse()
                .unwrap();
            let decl: String = arr
                .lines()
                .filter(|l| {
                    l.starts_with(&format!("(declare-const {name} "))
                        || l.starts_with(&format!("(assert (= (select {name} "))
                })
                .map(|l| format!("{l}\n"))
                .collect();
            assert!(decl.contains("declare-const"), "{}: {name}", u.name);
            let script = format!(
                "(set-logic QF_ABV)\n{decl}{}\n(declare-const x (_ BitVec {k}))\n\
                 (assert (distinct (tree_{name} x) (select {name} x)))\n(check-sat)\n",
                line.replacen("define-fun tab", "define-fun tree_tab", 1)
            );
            let out = z3(&script);
            assert_eq!(out.trim(), "unsat", "{}: {name}: {out}", u.name);
            tables += 1;
        }
    }
    assert!(tables >= 2, "only {tables} tables found");
}

/// The SMT encoding that `fxshade equiv` proves the RTL against is the
/// compiled trace's function: for every unit of the default
/// configuration, z3 evaluates [`SmtFunction`](crate::datapath::SmtFunction) (tables as
/// arrays; the test above shows the `ite` trees equal them) on the
/// corner cases and random rows, and every output and flag equals the
/// compiled program's (the program the vectors check the RTL against).
#[test]
fn the_smt_function_is_the_compiled_trace() {
    let cfg = crate::Config::embedded();
    for u in units::all() {
        let d = u.design(&cfg).unwrap();
        let f = d
            .trace
            .smt_function_tables(&[], &[], false)
            .expect("no division in an RTL unit");
        let mut rows = (u.inputs)(&cfg, Part::Corners, 7).unwrap();
        rows.truncate(40);
        rows.extend((u.inputs)(&cfg, Part::Random(40), 7).unwrap());
        let prog = units::compile_outputs(&d).unwrap();
        let cols: Vec<Vec<i128>> = (0..f.inputs.len())
            .map(|k| rows.iter().map(|r| r[k]).collect())
            .collect();
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let (outs, flags) = prog.run_flags_i128(&refs);
        let mut s = String::from(if f.arrays {
            "(set-logic QF_ABV)\n"
        } else {
            "(set-logic QF_BV)\n"
        });
        s += &f.defs;
        // Named, so the echoed terms hold no literals.
        let mut asked = Vec::new();
        for (k, (_, t, w)) in f.outputs.iter().enumerate() {
            s += &format!("(define-fun out{k} () (_ BitVec {w}) {t})\n");
            asked.push(format!("out{k}"));
        }
        for (k, (_, t)) in f.flags.iter().enumerate() {
            s += &format!("(define-fun flag{k} () (_ BitVec 1) (ite {t} #b1 #b0))\n");
            asked.push(format!("flag{k}"));
        }
        for r in &rows {
            s += "(push 1)\n";
            for (k, (name, w)) in f.inputs.iter().enumerate() {
                s += &format!(
                    "(assert (= {name} {}))\n",
                    crate::datapath::smt_literal(r[k], *w)
                );
            }
            s += &format!("(check-sat)\n(get-value ({}))\n(pop 1)\n", asked.join(" "));
        }
        let text = z3(&s);
        assert_eq!(
            text.matches("unsat").count(),
            0,
            "{}: an input row has no model",
            u.name
        );
        let vals = literals(&text);
        assert_eq!(vals.len(), rows.len() * asked.len(), "{}: {text}", u.name);
        let nf = f.flags.len();
        for (j, got) in vals.chunks(asked.len()).enumerate() {
            for (k, (name, _, w)) in f.outputs.iter().enumerate() {
                let fmt = d.trace.output_ports()[k].format;
                assert_eq!(
                    fmt.from_bits(got[k] as u64),
                    outs[k][j],
                    "{}: output {name} of row {:?} ({w} bits)",
                    u.name,
                    rows[j]
                );
            }
            for k in 0..nf {
                let want = (flags[j] >> (nf - 1 - k)) & 1;
                assert_eq!(
                    got[f.outputs.len() + k] as u64,
                    want,
                    "{}: flag {} of row {:?}",
                    u.name,
                    f.flags[k].0,
                    rows[j]
                );
            }
        }
    }
}
