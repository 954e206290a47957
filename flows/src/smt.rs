//! The SMT back end: one SMT-LIB 2 script to a solver process, its reply
//! read with an s-expression parser. `fxshade equiv` and `fxshade mutate`
//! both ask through here.
//!
//! Solvers ([`Solver`]): z3 (Debian's `z3`, run as `z3 -in -smt2`) and
//! Bitwuzla (PyPI's `bitwuzla` module, whose SMT-LIB 2 parser runs the
//! script: `python3 -m pip install bitwuzla`). A time limit, when given,
//! is the solver's own (z3 `-t:`, Bitwuzla `time-limit-per`), so a query
//! past it answers `unknown` rather than being killed; the process limit
//! ([`crate::proc::Limit::formal`]) only stops a hung solver.

use fxshade_model::convert::narrow;
use std::process::Command;

use anyhow::{bail, Context};

/// A solver.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Solver {
    /// z3 (`apt-get install z3`).
    Z3,
    /// Bitwuzla through its Python module (`pip install bitwuzla`).
    Bitwuzla,
}

/// Runs an SMT-LIB 2 script from standard input with Bitwuzla's parser;
/// argv[1] is the time limit per query in milliseconds (0: none).
const BITWUZLA_DRIVER: &str = r#"
import sys
import bitwuzla as b
tm = b.TermManager()
o = b.Options()
o.set(b.Option.PRODUCE_MODELS, True)
if int(sys.argv[1]) > 0:
    o.set(b.Option.TIME_LIMIT_PER, int(sys.argv[1]))
p = b.Parser(tm, o)
try:
    p.parse(sys.stdin.read(), False, False)
except b.BitwuzlaException as e:
    sys.stdout.flush()
    print('(error "' + str(e).replace('"', "'") + '")')
    sys.exit(1)
sys.stdout.flush()
"#;

impl Solver {
    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Solver::Z3 => "z3",
            Solver::Bitwuzla => "bitwuzla",
        }
    }
    /// Its version, or an error saying how to install it.
    ///
    /// # Errors
    ///
    /// The solver is not installed (the error says how to install it).
    pub fn version(self) -> anyhow::Result<String> {
        let (mut c, how) = match self {
            Solver::Z3 => {
                let mut c = Command::new("z3");
                c.arg("--version");
                (
                    c,
                    "z3 is not installed: `sudo apt-get install z3` (./scripts/test does it when run as root)",
                )
            }
            Solver::Bitwuzla => {
                let mut c = Command::new("python3");
                c.args(["-c", "import bitwuzla; print(bitwuzla.version())"]);
                (
                    c,
                    "bitwuzla is not installed: `python3 -m pip install bitwuzla` (./scripts/test does it when run as root)",
                )
            }
        };
        match crate::proc::run(&mut c, self.name(), crate::proc::Limit::probe(), None) {
            Ok(o) if o.status.success() => Ok(o.stdout.trim().to_string()),
            _ => bail!("{how}"),
        }
    }

    /// Run `script` (which ends with `(check-sat)` and, for a model,
    /// `(get-value (…))`), with a time limit per query of `timeout_s`
    /// seconds (0: none).
    ///
    /// # Errors
    ///
    /// As [`Solver::check_limited`].
    pub fn check(self, script: &str, timeout_s: u64) -> anyhow::Result<Reply> {
        self.check_limited(script, timeout_s, 0)
    }

    /// As [`Solver::check`], with z3's resource limit `rlimit` too (0:
    /// none; a count of z3's internal steps, the same on every machine, so
    /// an answer never depends on the machine's load; Bitwuzla has none
    /// and ignores it).
    ///
    /// # Errors
    ///
    /// The solver cannot be run, runs past the formal process limit, or answers what cannot be
    /// parsed.
    pub fn check_limited(self, script: &str, timeout_s: u64, rlimit: u64) -> anyhow::Result<Reply> {
        let mut c = self.command(timeout_s, rlimit);
        let Some(o) = run_within(&mut c, self.name(), script, timeout_s)? else {
            return Ok(Reply::Unknown("timeout".into()));
        };
        Reply::parse(&o.stdout).with_context(|| format!("{}: {}", self.name(), o.text().trim_end()))
    }
}

impl Solver {
    /// The solver's command reading a script from standard input, with a
    /// time limit per query (0: none) and z3's resource limit (0: none).
    fn command(self, timeout_s: u64, rlimit: u64) -> Command {
        match self {
            Solver::Z3 => {
                let mut c = Command::new("z3");
                c.args(["-in", "-smt2"]);
                if timeout_s > 0 {
                    c.arg(format!("-t:{}", timeout_s.saturating_mul(1000)));
                }
                if rlimit > 0 {
                    c.arg(format!("rlimit={rlimit}"));
                }
                c
            }
            Solver::Bitwuzla => {
                let mut c = Command::new("python3");
                c.args([
                    "-c",
                    BITWUZLA_DRIVER,
                    &timeout_s.saturating_mul(1000).to_string(),
                ]);
                c
            }
        }
    }

    /// Run `script` of several `(check-sat)` commands (no `get-value`),
    /// all of them within `timeout_s` seconds (0: no limit): the answers
    /// in order, each `Unsat`, `Unknown` or `Sat` (no values); a run
    /// stopped at the limit ends with one `Unknown`.
    ///
    /// # Errors
    ///
    /// As [`Solver::check_limited`], or fewer answers than `check-sat`s.
    pub fn check_each(self, script: &str, timeout_s: u64) -> anyhow::Result<Vec<Reply>> {
        let mut c = self.command(timeout_s, 0);
        // The whole run within the limit too (every query at once): past
        // it, the answers so far.
        let Some(o) = run_within(&mut c, self.name(), script, timeout_s)? else {
            return Ok(vec![Reply::Unknown("timeout".into())]);
        };
        let exprs = SExpr::parse_all(&o.stdout)
            .with_context(|| format!("{}: {}", self.name(), o.text().trim_end()))?;
        if let Some(e) = exprs.iter().find(|e| e.head() == Some("error")) {
            bail!("{} reports an error: {e}", self.name());
        }
        exprs
            .iter()
            .map(|e| match e.atom() {
                Some("unsat") => Ok(Reply::Unsat),
                Some("sat") => Ok(Reply::Sat(Vec::new())),
                Some(w @ ("unknown" | "timeout")) => Ok(Reply::Unknown(w.to_string())),
                _ => bail!("{}: unexpected answer {e}", self.name()),
            })
            .collect()
    }
}

/// Run a solver on `script`, stopped (with every process it started) when
/// it runs `timeout_s` seconds and 5 more (z3's own limit is soft: inside
/// a large bit-blast it can overrun by minutes): `None` then. With no
/// limit (0), the process limit of [`crate::proc::Limit::formal`] only.
fn run_within(
    c: &mut Command,
    what: &str,
    script: &str,
    timeout_s: u64,
) -> anyhow::Result<Option<crate::proc::Output>> {
    let limit = if timeout_s > 0 {
        crate::proc::Limit {
            time: std::time::Duration::from_secs(timeout_s.saturating_add(5)),
            var: "--timeout",
        }
    } else {
        crate::proc::Limit::formal()
    };
    match crate::proc::run(c, what, limit, Some(script.as_bytes())) {
        Ok(o) => Ok(Some(o)),
        Err(e) if timeout_s > 0 && e.to_string().contains("did not finish within") => Ok(None),
        Err(e) => Err(e),
    }
}

/// A solver's answer to `(check-sat)` (and `(get-value …)`).
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// Satisfiable, with the values asked for: (term, value) pairs.
    Sat(Vec<(SExpr, SExpr)>),
    /// Unsatisfiable.
    Unsat,
    /// Unknown (a time limit, or the solver gave up), with its reason.
    Unknown(String),
}

impl Reply {
    /// Read a solver's standard output: `sat` and a get-value list,
    /// `unsat`, `unknown` (or `timeout`); an `(error …)` fails.
    ///
    /// # Errors
    ///
    /// `text` is neither `sat` with a model, `unsat` nor `unknown`.
    pub fn parse(text: &str) -> anyhow::Result<Reply> {
        let exprs = SExpr::parse_all(text)?;
        if let Some(e) = exprs.iter().find(|e| e.head() == Some("error")) {
            bail!("the solver reports an error: {e}");
        }
        match exprs.first().and_then(SExpr::atom) {
            Some("unsat") => Ok(Reply::Unsat),
            Some("sat") => {
                let mut pairs = Vec::new();
                for e in &exprs[1..] {
                    let SExpr::List(items) = e else {
                        bail!("unexpected reply after sat: {e}");
                    };
                    for it in items {
                        match it {
                            SExpr::List(p) if p.len() == 2 => {
                                pairs.push((p[0].clone(), p[1].clone()));
                            }
                            _ => bail!("a get-value entry is not a (term value) pair: {it}"),
                        }
                    }
                }
                Ok(Reply::Sat(pairs))
            }
            Some(w @ ("unknown" | "timeout")) => Ok(Reply::Unknown(w.to_string())),
            _ => bail!("no check-sat answer in the solver's reply"),
        }
    }
}

/// An s-expression: an atom (symbol, numeral, `#b…`/`#x…` literal,
/// `|quoted symbol|`, `"string"`) or a list.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SExpr {
    /// An atom, as written (quoted symbols and strings keep their quotes).
    Atom(String),
    /// A parenthesised list.
    List(Vec<SExpr>),
}

impl std::fmt::Display for SExpr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SExpr::Atom(a) => f.write_str(a),
            SExpr::List(l) => {
                f.write_str("(")?;
                for (k, e) in l.iter().enumerate() {
                    if k > 0 {
                        f.write_str(" ")?;
                    }
                    write!(f, "{e}")?;
                }
                f.write_str(")")
            }
        }
    }
}

impl SExpr {
    /// The atom's text.
    pub fn atom(&self) -> Option<&str> {
        match self {
            SExpr::Atom(a) => Some(a),
            SExpr::List(_) => None,
        }
    }
    /// A list's first atom.
    pub fn head(&self) -> Option<&str> {
        match self {
            SExpr::List(l) => l.first().and_then(SExpr::atom),
            SExpr::Atom(_) => None,
        }
    }

    /// Every s-expression of `text`, in order (`;` comments skipped).
    ///
    /// # Errors
    ///
    /// `text` has an unbalanced parenthesis or an unterminated string or quoted symbol.
    ///
    /// # Panics
    ///
    /// Never: the stack is checked non-empty before each pop.
    pub fn parse_all(text: &str) -> anyhow::Result<Vec<SExpr>> {
        let b = text.as_bytes();
        let mut i = 0;
        let mut stack: Vec<Vec<SExpr>> = vec![Vec::new()];
        while i < b.len() {
            let c = b[i];
            match c {
                b' ' | b'\t' | b'\n' | b'\r' => i += 1,
                b';' => {
                    while i < b.len() && b[i] != b'\n' {
                        i += 1;
                    }
                }
                b'(' => {
                    stack.push(Vec::new());
                    i += 1;
                }
                b')' => {
                    if stack.len() < 2 {
                        bail!("unbalanced ')' at byte {i}");
                    }
                    let l = stack.pop().expect("checked");
                    stack.last_mut().expect("checked").push(SExpr::List(l));
                    i += 1;
                }
                b'|' | b'"' => {
                    let j = b[i + 1..]
                        .iter()
                        .position(|&x| x == c)
                        .with_context(|| format!("unterminated {} at byte {i}", c as char))?;
                    let end = i + 1 + j + 1;
                    stack
                        .last_mut()
                        .expect("non-empty")
                        .push(SExpr::Atom(text[i..end].to_string()));
                    i = end;
                }
                _ => {
                    let s = i;
                    while i < b.len() && !b" \t\n\r();|\"".contains(&b[i]) {
                        i += 1;
                    }
                    stack
                        .last_mut()
                        .expect("non-empty")
                        .push(SExpr::Atom(text[s..i].to_string()));
                }
            }
        }
        if stack.len() != 1 {
            bail!("{} unclosed '('", stack.len() - 1);
        }
        Ok(stack.pop().expect("one"))
    }

    /// A bit-vector value (`#b…`, `#x…`, `(_ bvN W)`) or Boolean
    /// (`true`/`false`: 1/0) as its unsigned bits, with its width.
    pub fn bits(&self) -> Option<(u128, u32)> {
        match self {
            SExpr::Atom(a) => {
                if let Some(h) = a.strip_prefix("#x") {
                    (h.len() <= 32)
                        .then(|| u128::from_str_radix(h, 16).ok())
                        .flatten()
                        .map(|v| (v, 4 * narrow::<u32, _>(h.len())))
                } else if let Some(d) = a.strip_prefix("#b") {
                    (d.len() <= 128)
                        .then(|| u128::from_str_radix(d, 2).ok())
                        .flatten()
                        .map(|v| (v, narrow::<u32, _>(d.len())))
                } else {
                    match a.as_str() {
                        "true" => Some((1, 1)),
                        "false" => Some((0, 1)),
                        _ => None,
                    }
                }
            }
            SExpr::List(l) => match l.as_slice() {
                [SExpr::Atom(u), SExpr::Atom(v), SExpr::Atom(w)] if u == "_" => {
                    let v = v.strip_prefix("bv")?.parse().ok()?;
                    Some((v, w.parse().ok()?))
                }
                _ => None,
            },
        }
    }
}

/// Bits of operand in [`abstract_products`]: products of operands up to
/// this wide are abstracted.
pub const PRODUCT_OPERAND_BITS: u32 = 128;

/// The declarations [`abstract_products`] refers to: `fxs_mul`, an
/// uninterpreted function of two `PRODUCT_OPERAND_BITS`-bit operands to
/// twice as many bits (the exact product, for the proof any function), and
/// `fxs_mulc`, which orders its operands first (a product commutes).
pub fn product_declarations() -> String {
    let w = PRODUCT_OPERAND_BITS;
    format!(
        "(declare-fun fxs_mul ((_ BitVec {w}) (_ BitVec {w})) (_ BitVec {}))\n\
         (define-fun fxs_mulc ((a (_ BitVec {w})) (b (_ BitVec {w}))) (_ BitVec {})\n  \
         (ite (bvslt a b) (fxs_mul a b) (fxs_mul b a)))\n",
        2 * w,
        2 * w
    )
}

/// Every `(bvmul x y)` of width `W` ≤ [`PRODUCT_OPERAND_BITS`] in `script`
/// replaced by the low `W` bits of `fxs_mulc(sext(x), sext(y))`, the
/// operands sign-extended to `PRODUCT_OPERAND_BITS`; returns the script
/// and how many products it replaced.
///
/// The replacement is exact when `fxs_mul` is the product (x·y mod 2^W
/// depends only on x and y mod 2^W, and sign extension keeps them), so a
/// proof with `fxs_mul` uninterpreted — for every function — holds for the
/// product: an abstraction, sound for `unsat`. Two products of the same
/// operand values, however written (widths, extensions, order), become one
/// application, so the solver matches identical multipliers instead of
/// bit-blasting them; a model, though, may owe to the abstraction and must
/// be checked on the real products. A product with an operand of at most
/// two significant bits (a selection) is left as it is.
///
/// # Errors
///
/// The script cannot be parsed ([`parse_all`]).
pub fn abstract_products(script: &str) -> anyhow::Result<(String, usize)> {
    abstract_products_with(script, false)
}

/// As [`abstract_products`], and with `odd_constants` a product by a
/// literal constant `c = c'·2^k` (`c'` odd) becomes `(bvshl P k)`, `P`
/// the abstracted product by `c'`: a synthesizer that multiplies by `c'`
/// and shifts the result in the wiring (Yosys's `wreduce` does) then
/// meets the same application as the RTL's product by `c`. Exact: `x·c
/// mod 2^W = (x·c' mod 2^W)·2^k mod 2^W`.
///
/// # Errors
///
/// The script cannot be parsed ([`parse_all`]).
pub fn abstract_products_with(
    script: &str,
    odd_constants: bool,
) -> anyhow::Result<(String, usize)> {
    abstract_products_keep(script, odd_constants, &std::collections::HashSet::new())
}

/// As [`abstract_products_with`], the products numbered in `keep` left as
/// they are. Products are numbered in the order they appear, every
/// product [`abstract_products`] would abstract counted (kept or not), so
/// a number names the same product in every call on one script.
///
/// # Errors
///
/// The script cannot be parsed ([`parse_all`]).
pub fn abstract_products_keep(
    script: &str,
    odd_constants: bool,
    keep: &std::collections::HashSet<usize>,
) -> anyhow::Result<(String, usize)> {
    let (out, n, _) = abstract_products_sites(script, odd_constants, keep)?;
    Ok((out, n))
}

/// A product [`abstract_products_sites`] found that is the whole body of
/// a function of one argument (`(define-fun |f| ((state S)) (_ BitVec w)
/// (bvmul a b))`, as Yosys writes a `$mul` cell): its number, the
/// function, and its operands as terms of that argument (abstracted as
/// the script is).
#[derive(Clone, Debug)]
pub struct ProductSite {
    /// The product's number (see [`abstract_products_keep`]).
    pub number: usize,
    /// The function whose body it is.
    pub function: String,
    /// The function's argument.
    pub arg: String,
    /// Its sort.
    pub arg_sort: String,
    /// The operands.
    pub a: SExpr,
    /// The second operand.
    pub b: SExpr,
    /// Width of the operands and the product.
    pub width: u32,
    /// The uninterpreted product as written in its place (`(fxs_mulc A B)`,
    /// over the function's argument), when abstracted.
    pub uf: Option<String>,
    /// Bounds of the exact product of its operands' values, as signed
    /// numbers (from their forms: a literal, a zero or sign extension):
    /// the range lemma [`range_lemma`] states.
    pub bounds: Option<(i128, i128)>,
}

/// The range lemma of an abstracted product `site` in state `state`:
/// `lo <= fxs_mulc(A, B) <= hi` (signed), the bounds of the exact product
/// of operands known by their form (a literal's value; a zero extension of
/// `w` bits is in `[0, 2^w - 1]`; a sign extension of `w` bits in
/// `[-2^(w-1), 2^(w-1) - 1]`): true of the product, so sound to assume. It
/// keeps the abstraction from giving a product a sign or high bits the
/// exact product cannot have, which one side of a miter reads and the
/// other (narrowed by synthesis) does not; a product by 0 is 0.
pub fn range_lemma(site: &ProductSite, state: &str) -> Option<String> {
    let (uf, (lo, hi)) = (site.uf.as_ref()?, site.bounds?);
    let w = 2 * PRODUCT_OPERAND_BITS;
    let lit = |v: i128| {
        if v < 0 {
            format!("(bvneg (_ bv{} {w}))", v.unsigned_abs())
        } else {
            format!("(_ bv{v} {w})")
        }
    };
    Some(format!(
        "(assert (let (({arg} {state})) (let ((p {uf})) (and (bvsle {} p) (bvsle p {})))))",
        lit(lo),
        lit(hi),
        arg = site.arg,
    ))
}

/// The bounds of the exact product of two values in `a` and `b`.
fn product_bounds(a: (i128, i128), b: (i128, i128)) -> Option<(i128, i128)> {
    let c = [
        a.0.checked_mul(b.0)?,
        a.0.checked_mul(b.1)?,
        a.1.checked_mul(b.0)?,
        a.1.checked_mul(b.1)?,
    ];
    Some((*c.iter().min()?, *c.iter().max()?))
}

/// The bounds of a term's value read as a signed number of its width, from
/// its form (see [`range_lemma`]); `None` past 64 bits.
fn signed_bounds(
    t: &SExpr,
    globals: &std::collections::HashMap<String, u32>,
    locals: &std::collections::HashMap<String, u32>,
) -> Option<(i128, i128)> {
    let full = |w: u32| {
        (1..=64)
            .contains(&w)
            .then(|| (-(1i128 << (w - 1)), (1i128 << (w - 1)) - 1))
    };
    if let Some((v, bw)) = t.bits() {
        if bw == 0 || bw > 64 {
            return None;
        }
        let sv = (v << (128 - bw)).cast_signed() >> (128 - bw);
        return Some((sv, sv));
    }
    let w = term_width(t, globals, locals)?;
    let SExpr::List(l) = t else {
        return full(w);
    };
    let unsigned = |x: &SExpr| {
        term_width(x, globals, locals)
            .filter(|&k| k <= 63)
            .map(|k| (0, (1i128 << k) - 1))
    };
    if let Some(SExpr::List(h)) = l.first() {
        if h.first().and_then(SExpr::atom) == Some("_") {
            match h.get(1).and_then(SExpr::atom) {
                Some("zero_extend") if h.get(2).and_then(SExpr::atom) != Some("0") => {
                    return unsigned(l.get(1)?);
                }
                Some("sign_extend") => return signed_bounds(l.get(1)?, globals, locals),
                _ => {}
            }
        }
    }
    if l.first().and_then(SExpr::atom) == Some("concat") && l.len() == 3 {
        if let Some(c) = l[1].atom().and_then(|a| a.strip_prefix("#b")) {
            if !c.is_empty() && c.chars().all(|ch| ch == '0') {
                return unsigned(&l[2]);
            }
        }
        if let Some(x) = sign_extended(t, globals, locals) {
            return signed_bounds(x, globals, locals);
        }
    }
    full(w)
}

/// As [`abstract_products_keep`], with the products that are whole
/// function bodies listed.
///
/// # Errors
///
/// The script cannot be parsed ([`parse_all`]).
pub fn abstract_products_sites(
    script: &str,
    odd_constants: bool,
    keep: &std::collections::HashSet<usize>,
) -> anyhow::Result<(String, usize, Vec<ProductSite>)> {
    let mut ctx = MulCtx {
        odd: odd_constants,
        keep,
        site: 0,
        count: 0,
        body: None,
        sites: Vec::new(),
    };
    let exprs = SExpr::parse_all(script)?;
    let mut globals: std::collections::HashMap<String, u32> = std::collections::HashMap::new();
    let mut sorts: std::collections::HashMap<String, u32> = std::collections::HashMap::new();
    let mut out = String::with_capacity(script.len() + script.len() / 4);
    for e in exprs {
        let e = match (e.head(), &e) {
            (Some("define-sort"), SExpr::List(l)) if l.len() == 4 => {
                if let (Some(n), Some(w)) = (l[1].atom(), sort_width(&l[3], &sorts)) {
                    sorts.insert(n.to_string(), w);
                }
                e
            }
            (Some("declare-const"), SExpr::List(l)) if l.len() == 3 => {
                if let (Some(n), Some(w)) = (l[1].atom(), sort_width(&l[2], &sorts)) {
                    globals.insert(n.to_string(), w);
                } else if let (Some(n), Some(w)) = (l[1].atom(), array_elem_width(&l[2])) {
                    globals.insert(format!("select:{n}"), w);
                }
                e
            }
            (Some("declare-fun"), SExpr::List(l)) if l.len() == 4 => {
                if let (Some(n), Some(w)) = (l[1].atom(), sort_width(&l[3], &sorts)) {
                    globals.insert(n.to_string(), w);
                }
                e
            }
            (Some("define-fun"), SExpr::List(l)) if l.len() == 5 => {
                let mut locals = std::collections::HashMap::new();
                if let SExpr::List(args) = &l[2] {
                    for a in args {
                        if let SExpr::List(p) = a {
                            if let (Some(n), Some(w)) = (
                                p.first().and_then(SExpr::atom),
                                p.get(1).and_then(|s| sort_width(s, &sorts)),
                            ) {
                                locals.insert(n.to_string(), w);
                            }
                        }
                    }
                }
                // A one-argument function whose body is a product.
                ctx.body = match (&l[2], l[1].atom()) {
                    (SExpr::List(args), Some(f)) if args.len() == 1 => match &args[0] {
                        SExpr::List(p) if p.len() == 2 => Some((
                            f.trim_matches('|').to_string(),
                            p[0].to_string(),
                            p[1].to_string(),
                            &l[4] as *const SExpr,
                        )),
                        _ => None,
                    },
                    _ => None,
                };
                let body = rewrite_mul(&l[4], &globals, &mut locals, &mut ctx);
                ctx.body = None;
                if let (Some(n), Some(w)) = (l[1].atom(), sort_width(&l[3], &sorts)) {
                    globals.insert(n.to_string(), w);
                }
                SExpr::List(vec![
                    l[0].clone(),
                    l[1].clone(),
                    l[2].clone(),
                    l[3].clone(),
                    body,
                ])
            }
            (Some("assert"), SExpr::List(l)) if l.len() == 2 => {
                let body = rewrite_mul(
                    &l[1],
                    &globals,
                    &mut std::collections::HashMap::new(),
                    &mut ctx,
                );
                SExpr::List(vec![l[0].clone(), body])
            }
            _ => e,
        };
        out += &e.to_string();
        out.push('\n');
    }
    Ok((out, ctx.count, ctx.sites))
}

/// The width of a bit-vector sort (`(_ BitVec w)` or a defined sort).
fn sort_width(s: &SExpr, sorts: &std::collections::HashMap<String, u32>) -> Option<u32> {
    match s {
        SExpr::List(l)
            if l.len() == 3 && l[0].atom() == Some("_") && l[1].atom() == Some("BitVec") =>
        {
            l[2].atom()?.parse().ok()
        }
        SExpr::Atom(a) => sorts.get(a).copied(),
        _ => None,
    }
}

/// The element width of `(Array I (_ BitVec w))`.
fn array_elem_width(s: &SExpr) -> Option<u32> {
    match s {
        SExpr::List(l) if l.len() == 3 && l[0].atom() == Some("Array") => {
            sort_width(&l[2], &std::collections::HashMap::new())
        }
        _ => None,
    }
}

/// The bit-vector width of term `t` (`None`: Boolean or not known).
/// The bits of `t` that carry its value: its width less the bits an
/// outermost extension (`zero_extend`, `sign_extend`, or a `concat` with a
/// zero constant first) added.
fn significant_bits(
    t: &SExpr,
    globals: &std::collections::HashMap<String, u32>,
    locals: &std::collections::HashMap<String, u32>,
) -> Option<u32> {
    let w = term_width(t, globals, locals)?;
    let SExpr::List(l) = t else {
        return Some(w);
    };
    if let Some(SExpr::List(h)) = l.first() {
        if h.first().and_then(SExpr::atom) == Some("_")
            && matches!(
                h.get(1).and_then(SExpr::atom),
                Some("zero_extend" | "sign_extend")
            )
        {
            return significant_bits(l.get(1)?, globals, locals);
        }
    }
    if l.first().and_then(SExpr::atom) == Some("concat") && l.len() == 3 {
        if let Some(c) = l[1].atom().and_then(|a| a.strip_prefix("#b")) {
            if c.chars().all(|ch| ch == '0') {
                return significant_bits(&l[2], globals, locals);
            }
        }
        if let Some(x) = sign_extended(t, globals, locals) {
            return significant_bits(x, globals, locals);
        }
    }
    Some(w)
}

/// `x` when `t` is `x` sign-extended bit by bit, as Yosys writes it:
/// `(concat ((_ extract k k) x) (concat … x))`, `k` the top bit of `x`.
fn sign_extended<'t>(
    t: &'t SExpr,
    globals: &std::collections::HashMap<String, u32>,
    locals: &std::collections::HashMap<String, u32>,
) -> Option<&'t SExpr> {
    let SExpr::List(l) = t else {
        return None;
    };
    if l.len() != 3 || l[0].atom() != Some("concat") {
        return None;
    }
    // The repeated bit: `((_ extract k k) x)`.
    let SExpr::List(bit) = &l[1] else {
        return None;
    };
    let SExpr::List(h) = bit.first()? else {
        return None;
    };
    if bit.len() != 2 || h.len() != 4 || h[1].atom() != Some("extract") || h[2] != h[3] {
        return None;
    }
    let k: u32 = h[2].atom()?.parse().ok()?;
    let x = &bit[1];
    if term_width(x, globals, locals)? != k + 1 {
        return None;
    }
    if &l[2] == x || sign_extended(&l[2], globals, locals) == Some(x) {
        Some(x)
    } else {
        None
    }
}

fn term_width(
    t: &SExpr,
    globals: &std::collections::HashMap<String, u32>,
    locals: &std::collections::HashMap<String, u32>,
) -> Option<u32> {
    let w = |x: &SExpr| term_width(x, globals, locals);
    match t {
        SExpr::Atom(a) => {
            if let Some(b) = a.strip_prefix("#b") {
                Some(narrow::<u32, _>(b.len()))
            } else if let Some(h) = a.strip_prefix("#x") {
                Some(4 * narrow::<u32, _>(h.len()))
            } else {
                locals.get(a).or_else(|| globals.get(a)).copied()
            }
        }
        SExpr::List(l) => {
            let head = l.first()?;
            match head {
                SExpr::List(h) if h.first().and_then(SExpr::atom) == Some("_") => {
                    let op = h.get(1)?.atom()?;
                    let n = |k: usize| h.get(k).and_then(SExpr::atom)?.parse::<u32>().ok();
                    match op {
                        "extract" => Some(n(2)? - n(3)? + 1),
                        "sign_extend" | "zero_extend" => Some(n(2)? + w(l.get(1)?)?),
                        "repeat" => Some(n(2)? * w(l.get(1)?)?),
                        "rotate_left" | "rotate_right" => w(l.get(1)?),
                        _ => None,
                    }
                }
                SExpr::Atom(a) => match a.as_str() {
                    "_" => l.get(2)?.atom()?.parse().ok(),
                    "concat" => l[1..].iter().map(w).sum(),
                    "ite" => w(l.get(2)?).or_else(|| w(l.get(3)?)),
                    "bvcomp" => Some(1),
                    "select" => globals
                        .get(&format!("select:{}", l.get(1)?.atom()?))
                        .copied(),
                    "let" => {
                        let mut inner = locals.clone();
                        if let Some(SExpr::List(bs)) = l.get(1) {
                            for b in bs {
                                if let SExpr::List(p) = b {
                                    if let (Some(n), Some(x)) =
                                        (p.first().and_then(SExpr::atom), p.get(1))
                                    {
                                        if let Some(bw) = term_width(x, globals, &inner) {
                                            inner.insert(n.to_string(), bw);
                                        }
                                    }
                                }
                            }
                        }
                        term_width(l.get(2)?, globals, &inner)
                    }
                    op if op.starts_with("bv") => match op {
                        "bvult" | "bvule" | "bvugt" | "bvuge" | "bvslt" | "bvsle" | "bvsgt"
                        | "bvsge" => None,
                        _ => w(l.get(1)?),
                    },
                    f => globals.get(f).copied(),
                },
                _ => None,
            }
        }
    }
}

/// What [`rewrite_mul`] carries: the options, the next product's number
/// and how many it abstracted.
struct MulCtx<'a> {
    odd: bool,
    keep: &'a std::collections::HashSet<usize>,
    site: usize,
    count: usize,
    /// The function whose body is being rewritten, its argument, and the
    /// body (a product there is a site).
    body: Option<(String, String, String, *const SExpr)>,
    sites: Vec<ProductSite>,
}

/// [`abstract_products`] on one term.
fn rewrite_mul(
    t: &SExpr,
    globals: &std::collections::HashMap<String, u32>,
    locals: &mut std::collections::HashMap<String, u32>,
    ctx: &mut MulCtx,
) -> SExpr {
    let SExpr::List(l) = t else {
        return t.clone();
    };
    // `let` bindings are in scope in the body.
    if l.first().and_then(SExpr::atom) == Some("let") && l.len() == 3 {
        let mut inner = locals.clone();
        let mut binds = Vec::new();
        if let SExpr::List(bs) = &l[1] {
            for b in bs {
                if let SExpr::List(p) = b {
                    if p.len() == 2 {
                        let x = rewrite_mul(&p[1], globals, locals, ctx);
                        if let (Some(n), Some(bw)) =
                            (p[0].atom(), term_width(&p[1], globals, locals))
                        {
                            inner.insert(n.to_string(), bw);
                        }
                        binds.push(SExpr::List(vec![p[0].clone(), x]));
                        continue;
                    }
                }
                binds.push(b.clone());
            }
        }
        let body = rewrite_mul(&l[2], globals, &mut inner, ctx);
        return SExpr::List(vec![l[0].clone(), SExpr::List(binds), body]);
    }
    let items: Vec<SExpr> = l
        .iter()
        .map(|x| rewrite_mul(x, globals, locals, ctx))
        .collect();
    // A product with an operand of at most 2 significant bits is a
    // selection (or a negation): left to the solver, as a synthesizer
    // leaves it in the fabric.
    let narrow = items.len() == 3
        && (significant_bits(&l[1], globals, locals).is_some_and(|b| b <= 2)
            || significant_bits(&l[2], globals, locals).is_some_and(|b| b <= 2));
    if items.len() == 3 && items[0].atom() == Some("bvmul") && !narrow {
        if let Some(w) = term_width(&l[1], globals, locals).filter(|&w| w <= PRODUCT_OPERAND_BITS) {
            ctx.site += 1;
            if let Some((f, arg, sort, _)) = ctx.body.as_ref().filter(|b| std::ptr::eq(b.3, t)) {
                ctx.sites.push(ProductSite {
                    number: ctx.site - 1,
                    function: f.clone(),
                    arg: arg.clone(),
                    arg_sort: sort.clone(),
                    a: items[1].clone(),
                    b: items[2].clone(),
                    width: w,
                    uf: None,
                    bounds: None,
                });
            }
            if ctx.keep.contains(&(ctx.site - 1)) {
                return SExpr::List(items);
            }
            ctx.count += 1;
            let odd = ctx.odd;
            let ext = |x: &SExpr| {
                if w == PRODUCT_OPERAND_BITS {
                    x.to_string()
                } else {
                    format!("((_ sign_extend {}) {x})", PRODUCT_OPERAND_BITS - w)
                }
            };
            // A literal operand's trailing zeros as a shift of the product.
            let shift = |x: &SExpr| -> Option<(String, u32)> {
                let (v, bw) = x.bits()?;
                if !odd || v == 0 || bw != w || v.trailing_zeros() == 0 {
                    return None;
                }
                let k = v.trailing_zeros();
                // Signed w-bit value, shifted right arithmetically.
                let sv = (v << (128 - w)).cast_signed() >> (128 - w);
                let c = (sv >> k).cast_unsigned() & (u128::MAX >> (128 - w));
                Some((format!("(_ bv{c} {w})"), k))
            };
            let (a, b, k) = match (shift(&items[1]), shift(&items[2])) {
                (_, Some((c, k))) => (items[1].to_string(), c, k),
                (Some((c, k)), None) => (c, items[2].to_string(), k),
                (None, None) => (items[1].to_string(), items[2].to_string(), 0),
            };
            let parse = |t: String| SExpr::parse_all(&t).ok().and_then(|mut v| v.pop());
            let (Some(a), Some(b)) = (parse(a), parse(b)) else {
                return SExpr::List(items);
            };
            let uf = format!("(fxs_mulc {} {})", ext(&a), ext(&b));
            if let Some(site) = ctx.sites.last_mut().filter(|s| s.number == ctx.site - 1) {
                site.bounds = signed_bounds(&a, globals, locals)
                    .zip(signed_bounds(&b, globals, locals))
                    .and_then(|(x, y)| product_bounds(x, y));
                site.uf = Some(uf.clone());
            }
            let mut text = format!("((_ extract {} 0) {uf})", w - 1);
            if k > 0 {
                text = format!("(bvshl {text} (_ bv{k} {w}))");
            }
            return SExpr::parse_all(&text)
                .ok()
                .and_then(|mut v| v.pop())
                .unwrap_or(SExpr::List(items));
        }
    }
    SExpr::List(items)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A product of a zero-extended 4-bit value and the literal -3 (8 bits)
    /// lies in [-45, 0]: -3 · [0, 15], corners computed by hand; a
    /// sign-extended 4-bit operand by 6 in [-48, 42].
    #[test]
    fn products_are_bounded_by_their_operands_forms() {
        let q = "(declare-fun x () (_ BitVec 4))\n\
                 (define-fun p ((state (_ BitVec 4))) (_ BitVec 8) \
                 (bvmul (concat #b0000 state) #xfd))\n\
                 (define-fun r ((state (_ BitVec 4))) (_ BitVec 8) \
                 (bvmul ((_ sign_extend 4) state) #x06))\n";
        let (_, _, sites) = abstract_products_sites(q, true, &Default::default()).unwrap();
        let b: Vec<_> = sites.iter().map(|s| s.bounds).collect();
        // #x06 is 3·2: the product by 3, shifted.
        assert_eq!(b, vec![Some((-45, 0)), Some((-24, 21))]);
        let l = range_lemma(&sites[0], "x").unwrap();
        assert!(
            l.contains("(bvneg (_ bv45 256))") && l.contains("(_ bv0 256)"),
            "{l}"
        );
    }

    #[test]
    fn replies_parse_into_values() {
        let r = Reply::parse("sat\n((in0 #b0101) (|m_n out_o| #x0f) ((f s) (_ bv7 8)) (v true))\n")
            .unwrap();
        let Reply::Sat(p) = r else { panic!("{r:?}") };
        assert_eq!(p.len(), 4);
        assert_eq!(p[0].0, SExpr::Atom("in0".into()));
        assert_eq!(p[0].1.bits(), Some((5, 4)));
        assert_eq!(p[1].0.to_string(), "|m_n out_o|");
        assert_eq!(p[1].1.bits(), Some((15, 8)));
        assert_eq!(p[2].0.to_string(), "(f s)");
        assert_eq!(p[2].1.bits(), Some((7, 8)));
        assert_eq!(p[3].1.bits(), Some((1, 1)));
        assert_eq!(Reply::parse("unsat\n").unwrap(), Reply::Unsat);
        assert_eq!(
            Reply::parse("unknown\n").unwrap(),
            Reply::Unknown("unknown".into())
        );
        assert!(Reply::parse("(error \"line 3: bad\")\n").is_err());
        assert!(Reply::parse("sat\n((x #b1)").is_err());
        assert!(Reply::parse("").is_err());
    }

    /// Both solvers answer a small query the same way, with a model that
    /// satisfies it (3x = 9 mod 256 has the one root x = 3).
    #[test]
    fn every_installed_solver_finds_the_one_root() {
        let q = "(set-logic QF_BV)\n(declare-const x (_ BitVec 8))\n\
                 (assert (= (bvmul x #x03) #x09))\n(check-sat)\n(get-value (x))\n";
        let u = "(set-logic QF_BV)\n(declare-const x (_ BitVec 8))\n\
                 (assert (= (bvmul x #x02) #x09))\n(check-sat)\n";
        for s in [Solver::Z3, Solver::Bitwuzla] {
            s.version().unwrap_or_else(|e| panic!("{e}"));
            let Reply::Sat(p) = s.check(q, 0).unwrap() else {
                panic!("{} did not find x", s.name())
            };
            assert_eq!(p[0].1.bits(), Some((3, 8)), "{}", s.name());
            assert_eq!(s.check(u, 0).unwrap(), Reply::Unsat, "{}", s.name());
        }
    }

    /// With odd constants, a product by 20 (or −20) and the product by 5
    /// (−5) shifted left by 2, as a synthesizer writes it, are one
    /// application: Bitwuzla proves them equal under the abstraction, and
    /// without the option it cannot.
    #[test]
    fn products_by_constants_meet_their_odd_factor() {
        for (c, odd) in [("#x14", "#x05"), ("#xec", "#xfb")] {
            let q = format!(
                "(set-logic QF_BV)\n(declare-const x (_ BitVec 8))\n\
                 (assert (not (= (bvmul x {c}) (bvshl (bvmul {odd} x) #x02))))\n(check-sat)\n"
            );
            let ask = |odd_constants: bool| {
                let (abs, n) = abstract_products_with(&q, odd_constants).unwrap();
                assert_eq!(n, 2);
                let abs = abs.replacen(
                    "(set-logic QF_BV)",
                    &format!("(set-logic QF_UFBV)\n{}", product_declarations()),
                    1,
                );
                Solver::Bitwuzla.check(&abs, 0).unwrap()
            };
            assert_eq!(ask(true), Reply::Unsat, "{c}");
            assert!(matches!(ask(false), Reply::Sat(_)), "{c}");
        }
    }

    /// Products are numbered in order, kept ones left as `bvmul`, and the
    /// products that are a one-argument function's whole body are listed
    /// with their operands (a nested one is not).
    #[test]
    fn product_sites_are_numbered_listed_and_kept() {
        let q = "(set-logic QF_BV)\n(declare-sort S 0)\n\
                 (declare-fun x (S) (_ BitVec 8))\n(declare-fun y (S) (_ BitVec 8))\n\
                 (define-fun p ((state S)) (_ BitVec 8) (bvmul (x state) (y state)))\n\
                 (define-fun q ((state S)) (_ BitVec 8) (bvadd (bvmul (x state) #x03) #x01))\n\
                 (check-sat)\n";
        let none = std::collections::HashSet::new();
        let (abs, n, sites) = abstract_products_sites(q, false, &none).unwrap();
        assert_eq!(n, 2);
        assert!(!abs.contains("bvmul"));
        assert_eq!(sites.len(), 1, "{sites:?}");
        let s = &sites[0];
        assert_eq!((s.number, s.function.as_str(), s.width), (0, "p", 8));
        assert_eq!((s.arg.as_str(), s.arg_sort.as_str()), ("state", "S"));
        assert_eq!(s.a.to_string(), "(x state)");
        assert_eq!(s.b.to_string(), "(y state)");
        let keep: std::collections::HashSet<usize> = [1].into_iter().collect();
        let (abs, n, _) = abstract_products_sites(q, false, &keep).unwrap();
        assert_eq!(n, 1);
        assert_eq!(abs.matches("bvmul").count(), 1);
        assert!(abs.contains("(bvmul (x state) #x03)"), "{abs}");
    }

    /// Products abstracted: the same product written two ways (operands
    /// swapped, widths and extensions different) is matched, so the
    /// equality is proved; a sum is not a product, so its difference is
    /// found.
    #[test]
    fn abstracted_products_match_whatever_their_form() {
        let base = "(set-logic QF_BV)\n(declare-const x (_ BitVec 8))\n\
                    (declare-const y (_ BitVec 6))\n\
                    (define-fun p () (_ BitVec 14) (bvmul ((_ sign_extend 6) x) ((_ sign_extend 8) y)))\n\
                    (define-fun q () (_ BitVec 16) (bvmul ((_ sign_extend 10) y) ((_ sign_extend 8) x)))\n";
        let same = format!("{base}(assert (not (= p ((_ extract 13 0) q))))\n(check-sat)\n");
        let (abs, n) = abstract_products(&same).unwrap();
        assert_eq!(n, 2);
        assert!(!abs.contains("bvmul"));
        let abs = abs.replacen(
            "(set-logic QF_BV)",
            &format!("(set-logic QF_UFBV)\n{}", product_declarations()),
            1,
        );
        let other = format!(
            "{base}(assert (not (= p (bvadd ((_ sign_extend 6) x) ((_ sign_extend 8) y)))))\n(check-sat)\n"
        );
        let (other, _) = abstract_products(&other).unwrap();
        let other = other.replacen(
            "(set-logic QF_BV)",
            &format!("(set-logic QF_UFBV)\n{}", product_declarations()),
            1,
        );
        for s in [Solver::Z3, Solver::Bitwuzla] {
            assert_eq!(s.check(&abs, 0).unwrap(), Reply::Unsat, "{}", s.name());
            assert!(
                matches!(s.check(&other, 0).unwrap(), Reply::Sat(_)),
                "{}",
                s.name()
            );
        }
    }

    /// Slices of `w` bits (`signed`: the top one signed) `c` bits wide.
    fn slices(w: u32, signed: bool, c: u32) -> Vec<fxshade_model::datapath::Chunk> {
        (0..w.div_ceil(c))
            .map(|j| {
                let lo = j * c;
                let width = c.min(w - lo);
                fxshade_model::datapath::Chunk {
                    lo,
                    width,
                    signed: signed && lo + width == w,
                }
            })
            .collect()
    }

    /// The split lemma (`MulSplit`) on small shapes, every signedness: z3
    /// proves the sum of the partial products equal to the product for
    /// every operand value (no abstraction: real `bvmul`s), a product node
    /// narrower than the full product included; a split with one slice
    /// moved is refused by `covers`, and its sum differs (z3 finds a
    /// value).
    #[test]
    fn a_split_product_is_the_sum_of_its_partial_products() {
        use fxshade_model::datapath::{MulSplit, PartialProduct};
        for (wa, sa, wb, sb, ca, cb, w) in [
            (7u32, true, 6u32, true, 3u32, 4u32, 13u32),
            (7, true, 6, false, 4, 6, 13),
            (6, false, 7, true, 2, 3, 13),
            (6, false, 5, false, 2, 3, 11),
            (8, true, 7, true, 5, 5, 10),
        ] {
            let (xa, xb) = (slices(wa, sa, ca), slices(wb, sb, cb));
            let parts: Vec<PartialProduct> = xa
                .iter()
                .flat_map(|&a| xb.iter().map(move |&b| PartialProduct { a, b }))
                .collect();
            let m = MulSplit { node: 0, parts };
            assert!(m.covers(wa, sa, wb, sb), "{wa} {wb}");
            let ext = |x: &str, from: u32, signed: bool| {
                let how = if signed { "sign_extend" } else { "zero_extend" };
                format!("((_ {how} {}) {x})", w.saturating_sub(from))
            };
            let full = |x: &str, from: u32, signed: bool| {
                if w >= from {
                    ext(x, from, signed)
                } else {
                    format!("((_ extract {} 0) {x})", w - 1)
                }
            };
            let query = |m: &MulSplit| {
                format!(
                    "(set-logic QF_BV)\n(declare-const a (_ BitVec {wa}))\n\
                     (declare-const b (_ BitVec {wb}))\n\
                     (assert (not (= (bvmul {} {}) {})))\n(check-sat)\n",
                    full("a", wa, sa),
                    full("b", wb, sb),
                    m.smt_sum("a", wa, "b", wb, w)
                )
            };
            assert_eq!(Solver::Z3.check(&query(&m), 0).unwrap(), Reply::Unsat);
            // The first operand's high slices read a bit lower (as the
            // sabotage of the equivalence tests does): not a partition,
            // and a wrong sum.
            let mut bad = m.clone();
            for p in &mut bad.parts {
                if p.a.lo > 0 {
                    p.a.lo -= 1;
                }
            }
            if bad == m {
                continue;
            }
            assert!(!bad.covers(wa, sa, wb, sb), "{wa} {wb}");
            assert!(matches!(
                Solver::Z3.check(&query(&bad), 0).unwrap(),
                Reply::Sat(_)
            ));
            // Slices whose ends wrap around u32 (0..MAX, then MAX..MAX+wa+1,
            // which wraps to wa): refused, not taken for a partition.
            let whole_b = fxshade_model::datapath::Chunk {
                lo: 0,
                width: wb,
                signed: sb,
            };
            let wrap = MulSplit {
                node: 0,
                parts: vec![
                    PartialProduct {
                        a: fxshade_model::datapath::Chunk {
                            lo: 0,
                            width: u32::MAX,
                            signed: false,
                        },
                        b: whole_b,
                    },
                    PartialProduct {
                        a: fxshade_model::datapath::Chunk {
                            lo: u32::MAX,
                            width: wa + 1,
                            signed: sa,
                        },
                        b: whole_b,
                    },
                ],
            };
            assert!(!wrap.covers(wa, sa, wb, sb));
            // A missing partial product or a slice read unsigned: refused.
            let mut short = m.clone();
            short.parts.pop();
            assert!(!short.covers(wa, sa, wb, sb));
            if sa {
                let mut unsigned = m.clone();
                for p in &mut unsigned.parts {
                    p.a.signed = false;
                }
                assert!(!unsigned.covers(wa, sa, wb, sb));
            }
        }
    }

    /// A product whose operand is a two-bit value sign-extended bit by bit
    /// (as Yosys writes `$signed` of a narrow register) is a selection,
    /// left as it is, as the same product written with `sign_extend` is.
    #[test]
    fn a_bitwise_sign_extension_keeps_a_narrow_product() {
        let by_bits = "(declare-const x (_ BitVec 2))\n(declare-const y (_ BitVec 6))\n\
            (define-fun p () (_ BitVec 6) (bvmul (concat ((_ extract 1 1) x) \
            (concat ((_ extract 1 1) x) (concat ((_ extract 1 1) x) \
            (concat ((_ extract 1 1) x) x)))) y))\n";
        let (_, n) = abstract_products(by_bits).unwrap();
        assert_eq!(n, 0);
        let by_ext = "(declare-const x (_ BitVec 2))\n(declare-const y (_ BitVec 6))\n\
            (define-fun p () (_ BitVec 6) (bvmul ((_ sign_extend 4) x) y))\n";
        assert_eq!(abstract_products(by_ext).unwrap().1, 0);
        // Three significant bits, or a bit that is not the top one: a product.
        let wide = "(declare-const x (_ BitVec 3))\n(declare-const y (_ BitVec 6))\n\
            (define-fun p () (_ BitVec 6) (bvmul (concat ((_ extract 2 2) x) \
            (concat ((_ extract 2 2) x) (concat ((_ extract 2 2) x) x))) y))\n";
        let (_, n) = abstract_products(wide).unwrap();
        assert_eq!(n, 1, "{wide}");
        let other = by_bits.replace("((_ extract 1 1) x) x)", "((_ extract 0 0) x) x)");
        assert_eq!(abstract_products(&other).unwrap().1, 1);
    }
}
