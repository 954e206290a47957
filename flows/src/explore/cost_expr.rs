//! A cost to minimize written as a weighted sum of cost metrics, so a
//! designer can say what one device resource is worth in another:
//! `2*dsp_est + lut/100`, `bit_products + 8*table_bits/1024`.
//!
//! Grammar: `expr := term (('+' | '-') term)*`, `term := factor (('*' |
//! '/') factor)*`, `factor := number | metric`; each term holds exactly
//! one metric (the sum is linear in the metrics). Its value is
//! `Σ cᵢ · metricᵢ` in f64; none when a metric was not measured.

/// A parsed cost expression: `(coefficient, metric)` per term.
#[derive(Clone, Debug, PartialEq)]
pub struct CostExpr {
    /// The terms, in the order written.
    pub terms: Vec<(f64, String)>,
}

/// Whether `s` is an expression rather than one metric's name (it holds an
/// operator).
pub fn is_expr(s: &str) -> bool {
    s.contains(['+', '-', '*', '/'])
}

impl CostExpr {
    /// Parse `s`; errors say what is wrong and where.
    ///
    /// # Errors
    ///
    /// `Err` saying where `s` is not a sum of weighted metrics (an empty term, a negative or
    /// non-numeric weight, two metrics in a term).
    pub fn parse(s: &str) -> Result<CostExpr, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err("an empty cost".into());
        }
        let mut terms = Vec::new();
        let (mut sign, body) = match s.strip_prefix('-') {
            Some(r) => (-1.0, r),
            None => (1.0, s.strip_prefix('+').unwrap_or(s)),
        };
        let b = body.as_bytes();
        let mut start = 0;
        for i in 0..=b.len() {
            let at_end = i == b.len();
            if !(at_end || b[i] == b'+' || b[i] == b'-') {
                continue;
            }
            if !at_end && exponent_sign(&body[start..i]) {
                continue;
            }
            let text = body[start..i].trim();
            if text.is_empty() && !at_end && start > 0 {
                return Err(format!(
                    "`{s}`: a sign after an operator; write `lut - 2*dsp`, not `lut + -2*dsp`"
                ));
            }
            if text.is_empty() {
                return Err(format!(
                    "`{s}`: a term is missing {}",
                    if at_end {
                        "after the last operator"
                    } else {
                        "between two operators"
                    }
                ));
            }
            let (coef, metric) = term(text)?;
            terms.push((sign * coef, metric));
            if !at_end {
                sign = if b[i] == b'-' { -1.0 } else { 1.0 };
                start = i + 1;
            }
        }
        if let Some((_, m)) = terms.iter().find(|(c, _)| *c < 0.0) {
            return Err(format!(
                "`{s}`: `{m}` has a negative weight; a cost is a sum of non-negative weights \
                 (minimizing a negative weight would maximize `{m}`)"
            ));
        }
        Ok(CostExpr { terms })
    }

    /// The metric names, in order.
    pub fn metrics(&self) -> impl Iterator<Item = &str> {
        self.terms.iter().map(|(_, m)| m.as_str())
    }

    /// `Σ c · metric`, or None when `get` lacks a metric.
    pub fn eval(&self, get: impl Fn(&str) -> Option<f64>) -> Option<f64> {
        self.terms.iter().map(|(c, m)| get(m).map(|v| c * v)).sum()
    }
}

/// Whether a `+`/`-` after `before` is a number's exponent sign (`1e-2`):
/// `before` ends in a factor of digits and `.` followed by `e`.
fn exponent_sign(before: &str) -> bool {
    let f = before.rsplit(['*', '/', ' ']).next().unwrap_or("");
    match f.strip_suffix(['e', 'E']) {
        Some(m) => !m.is_empty() && m.chars().all(|c| c.is_ascii_digit() || c == '.'),
        None => false,
    }
}

/// One term: numbers and one metric joined by `*` and `/`.
fn term(text: &str) -> Result<(f64, String), String> {
    if text.is_empty() {
        return Err("an empty term (two operators in a row?)".into());
    }
    let mut coef = 1.0;
    let mut metric: Option<String> = None;
    let mut op = '*';
    let mut rest = text;
    loop {
        let end = rest.find(['*', '/']).unwrap_or(rest.len());
        let f = rest[..end].trim();
        if f.is_empty() {
            return Err(format!("`{text}`: a factor is missing"));
        }
        match f.parse::<f64>() {
            Ok(x) if x.is_finite() => {
                if op == '/' {
                    if x == 0.0 {
                        return Err(format!("`{text}`: division by zero"));
                    }
                    coef /= x;
                } else {
                    coef *= x;
                }
            }
            Ok(_) => return Err(format!("`{text}`: `{f}` is not a finite number")),
            Err(_) => {
                if op == '/' {
                    return Err(format!("`{text}`: divide by numbers only, not by `{f}`"));
                }
                if let Some(m) = &metric {
                    return Err(format!(
                        "`{text}`: `{m}` and `{f}` multiplied; a term holds one metric"
                    ));
                }
                if !f
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
                {
                    return Err(format!("`{text}`: `{f}` is neither a number nor a metric"));
                }
                metric = Some(f.to_string());
            }
        }
        if end == rest.len() {
            break;
        }
        op = rest[end..].chars().next().unwrap_or('*');
        rest = &rest[end + 1..];
    }
    let metric = metric.ok_or_else(|| format!("`{text}`: a term without a metric"))?;
    Ok((coef, metric))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weighted_sums_parse_and_evaluate() {
        let e = CostExpr::parse("2*dsp_est + lut/100").unwrap();
        assert_eq!(
            e.terms,
            vec![(2.0, "dsp_est".to_string()), (0.01, "lut".to_string())]
        );
        let get = |m: &str| match m {
            "dsp_est" => Some(49.0),
            "lut" => Some(3109.0),
            _ => None,
        };
        // 2·49 + 3109/100 = 129.09 (by hand).
        assert!((e.eval(get).unwrap() - 129.09).abs() < 1e-9);
        let e = CostExpr::parse("bit_products + 0.5 * cost.polar.table_bits / 2").unwrap();
        assert_eq!(
            e.terms,
            vec![
                (1.0, "bit_products".to_string()),
                (0.25, "cost.polar.table_bits".to_string())
            ]
        );
        let e = CostExpr::parse("1e-2*lut+dsp").unwrap();
        assert_eq!(
            e.terms,
            vec![(0.01, "lut".to_string()), (1.0, "dsp".to_string())]
        );
        assert_eq!(CostExpr::parse("lut + bram").unwrap().eval(get), None);
    }

    #[test]
    fn bad_expressions_say_why() {
        for (s, says) in [
            ("lut*dsp", "a term holds one metric"),
            ("100/lut", "divide by numbers only"),
            ("lut/0", "division by zero"),
            ("2*", "a factor is missing"),
            ("lut +", "a term is missing"),
            ("3", "a term without a metric"),
            ("lut + (dsp)", "neither a number nor a metric"),
            ("lut - dsp", "negative weight"),
            ("-lut", "negative weight"),
            ("lut + -dsp", "a sign after an operator"),
        ] {
            let e = CostExpr::parse(s).unwrap_err();
            assert!(e.contains(says), "{s}: {e}");
        }
        assert!(is_expr("2*dsp_est") && !is_expr("cost.polar.table_bits"));
    }
}
