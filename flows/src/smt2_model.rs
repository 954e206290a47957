//! Yosys's SMT-LIB 2 model of a module (`write_smt2 -stbv`), read as a
//! graph: which functions each function reads, which state fields are
//! registers and what they load, and which internal function each named
//! wire is. From it, the cone of influence of a set of signals unrolled
//! over cycles, stopping at cut signals.
//!
//! Dropping a register's transition from a query only removes an
//! assumption (the register becomes a free value in that cycle), so a
//! query over a cone is *weaker* than over the whole unrolled module: an
//! `unsat` answer over the cone is still a proof. What the cone buys is
//! size: a proof by stages asks about one stage's logic instead of
//! re-reading the whole module at every cycle.

use fxshade_model::convert::narrow;
use std::collections::{HashMap, HashSet};

/// A module's functions and registers, as Yosys's model defines them.
#[derive(Debug, Default)]
pub struct Smt2Model {
    /// Each function (by name, without bars) and the functions its body
    /// applies.
    reads: HashMap<String, Vec<String>>,
    /// Each register's state field and the function it loads (the
    /// transition `(= (|next| state) (|field| next_state))`).
    loads: HashMap<String, String>,
    /// Each named wire (`<module>_n <name>`) that is another function
    /// applied to the state, and that function.
    alias: HashMap<String, String>,
}

/// A register's transition in one cycle: (the function it loads, its
/// state field, the cycle whose value it loads).
pub type Transition = (String, String, u32);

/// `|…|` names in `text`, in order.
fn barred(text: &str) -> impl Iterator<Item = &str> {
    text.split('|').skip(1).step_by(2)
}

/// `line` without its `;` comment (a `;` outside `|…|` names).
fn uncommented(line: &str) -> &str {
    let mut in_bars = false;
    for (k, ch) in line.char_indices() {
        match ch {
            '|' => in_bars = !in_bars,
            ';' if !in_bars => return line[..k].trim_end(),
            _ => {}
        }
    }
    line
}

/// The top-level forms of `smt2` that start a line with `(define-fun`,
/// each whole (Yosys writes long ones, the transition relation, over
/// several lines), lines joined by a space.
fn definitions(smt2: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur: Option<String> = None;
    let mut depth = 0i64;
    for line in smt2.lines() {
        let line = uncommented(line);
        if cur.is_none() {
            if !line.starts_with("(define-fun ") {
                continue;
            }
            cur = Some(String::new());
            depth = 0;
        }
        let c = cur.as_mut().expect("set above");
        if !c.is_empty() {
            c.push(' ');
        }
        c.push_str(line);
        // Parentheses outside `|…|` names.
        for (k, part) in line.split('|').enumerate() {
            if k % 2 == 0 {
                depth += narrow::<i64, _>(part.matches('(').count())
                    - narrow::<i64, _>(part.matches(')').count());
            }
        }
        if depth <= 0 {
            out.extend(cur.take());
        }
    }
    out.extend(cur);
    out
}

impl Smt2Model {
    /// Read `smt2` (module `module`): every `define-fun` line, and the
    /// transition relation `|<module>_t|`.
    pub fn parse(module: &str, smt2: &str) -> Self {
        let mut m = Smt2Model::default();
        let sort = format!("{module}_s");
        let trans = format!("{module}_t");
        for def in definitions(smt2) {
            let Some(rest) = def.strip_prefix("(define-fun |") else {
                continue;
            };
            let Some((name, body)) = rest.split_once('|') else {
                continue;
            };
            if name == trans {
                // (and (= (|next| state) (|field| next_state)) …)
                for conj in body.split("(= (|").skip(1) {
                    let mut it = barred(&format!("|{conj}"))
                        .map(str::to_string)
                        .collect::<Vec<_>>()
                        .into_iter();
                    if let (Some(next), Some(field)) = (it.next(), it.next()) {
                        m.loads.insert(field, next);
                    }
                }
                continue;
            }
            let reads: Vec<String> = barred(body)
                .filter(|n| *n != sort)
                .map(str::to_string)
                .collect();
            // A wire that is one function of the state: `(|f| state))`.
            if name.starts_with(&format!("{module}_n ")) {
                let tail = body.trim_end();
                if reads.len() == 1 && tail.ends_with(&format!("(|{}| state))", reads[0])) {
                    m.alias.insert(name.to_string(), reads[0].clone());
                }
            }
            m.reads.insert(name.to_string(), reads);
        }
        m
    }

    /// The internal function a named wire is (itself when it is not an
    /// alias).
    pub fn resolve<'a>(&'a self, f: &'a str) -> &'a str {
        self.alias.get(f).map_or(f, String::as_str)
    }

    /// The cone of influence of `roots` (function, cycle): the register
    /// transitions `(next, field, cycle)` it needs (the field in cycle
    /// `cycle + 1` loads `next` of cycle `cycle`), and the stops it reached
    /// (function, cycle) in `stops` (not entered: their logic is read,
    /// their registers left free). A register in cycle 0 is free. With
    /// `enter_roots`, a root that is a stop is entered all the same (a
    /// cut's own query).
    pub fn cone(
        &self,
        roots: &[(String, u32)],
        stops: &HashSet<(String, u32)>,
        enter_roots: bool,
    ) -> (Vec<Transition>, Vec<(String, u32)>) {
        let mut seen: HashSet<(String, u32)> = HashSet::new();
        let mut work: Vec<(String, u32)> = roots
            .iter()
            .map(|(f, k)| (self.resolve(f).to_string(), *k))
            .collect();
        let mut trans = Vec::new();
        let mut hit = Vec::new();
        while let Some((f, k)) = work.pop() {
            if !seen.insert((f.clone(), k)) {
                continue;
            }
            // The roots themselves are entered even when they are stops.
            let is_root =
                enter_roots && roots.iter().any(|(r, rk)| *rk == k && self.resolve(r) == f);
            if !is_root && stops.contains(&(f.clone(), k)) {
                hit.push((f, k));
                continue;
            }
            if let Some(next) = self.loads.get(&f) {
                if k > 0 {
                    trans.push((next.clone(), f.clone(), k - 1));
                    work.push((next.clone(), k - 1));
                }
                continue;
            }
            if let Some(rs) = self.reads.get(&f) {
                for r in rs {
                    work.push((r.clone(), k));
                }
            }
        }
        (trans, hit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-register pipeline written as Yosys writes it: `b` loads
    /// `a + 1`, `c` loads `b`.
    const TOY: &str = "\
(define-fun |m#0| ((state |m_s|)) (_ BitVec 4) ((_ extract 3 0) state))
(define-fun |m#1| ((state |m_s|)) (_ BitVec 4) ((_ extract 7 4) state))
(define-fun |m#2| ((state |m_s|)) (_ BitVec 4) ((_ extract 11 8) state))
(define-fun |m#3| ((state |m_s|)) (_ BitVec 4) (bvadd (|m#0| state) #x1))
(define-fun |m_n b| ((state |m_s|)) (_ BitVec 4) (|m#1| state))
(define-fun |m_n c| ((state |m_s|)) (_ BitVec 4) (|m#2| state))
(define-fun |m_t| ((state |m_s|) (next_state |m_s|)) Bool (and
  (= (|m#3| state) (|m#1| next_state)) ; b
  (= (|m#1| state) (|m#2| next_state)) ; c
))
";

    #[test]
    fn reads_registers_and_aliases() {
        let m = Smt2Model::parse("m", TOY);
        assert_eq!(m.resolve("m_n b"), "m#1");
        assert_eq!(m.loads.get("m#2").map(String::as_str), Some("m#1"));
        assert_eq!(m.loads.get("m#1").map(String::as_str), Some("m#3"));
        assert_eq!(m.reads["m#3"], vec!["m#0".to_string()]);
    }

    #[test]
    fn the_cone_follows_registers_back_and_stops_at_cuts() {
        let m = Smt2Model::parse("m", TOY);
        // c in cycle 2: c loads b in cycle 1, which loads a + 1 in cycle 0.
        let (t, hit) = m.cone(&[("m_n c".into(), 2)], &HashSet::new(), true);
        let mut t: Vec<_> = t
            .into_iter()
            .map(|(n, f, k)| format!("{f}<-{n}@{k}"))
            .collect();
        t.sort();
        assert_eq!(t, ["m#1<-m#3@0", "m#2<-m#1@1"]);
        assert!(hit.is_empty());
        // With b in cycle 1 a stop, the cone is one register.
        let stops: HashSet<_> = [("m#1".to_string(), 1)].into_iter().collect();
        let (t, hit) = m.cone(&[("m_n c".into(), 2)], &stops, true);
        assert_eq!(t, vec![("m#1".to_string(), "m#2".to_string(), 1)]);
        assert_eq!(hit, vec![("m#1".to_string(), 1)]);
        // A root that is a stop is entered only when asked.
        let (t, _) = m.cone(&[("m_n b".into(), 1)], &stops, true);
        assert_eq!(t.len(), 1);
        let (t, hit) = m.cone(&[("m_n b".into(), 1)], &stops, false);
        assert!(t.is_empty());
        assert_eq!(hit, vec![("m#1".to_string(), 1)]);
        // A register in cycle 0 is free.
        let (t, _) = m.cone(&[("m_n b".into(), 0)], &HashSet::new(), true);
        assert!(t.is_empty());
    }
}
