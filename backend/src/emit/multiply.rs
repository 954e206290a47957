//! Products: operands as built (a signed × unsigned product extends the
//! unsigned operand by one bit), operand registers of their own where the
//! family's blocks absorb them, and products too slow for the period split
//! into block-sized or row partial products summed over later stages.

use crate::*;

impl<'a> Emitter<'a> {
    /// A multiplier too slow for a stage, split into partial products:
    /// `a × b = Σ a_i × b_j · 2^(lo_i + lo_j)` over chunks of each operand
    /// (the top chunk of a signed operand signed, the others unsigned and
    /// zero-extended by one bit when their partner is signed), each partial
    /// product registered, then summed by a tree of adders in the product's
    /// width (exact: the product fits it), with registers between tree
    /// levels where the period needs them. On a target without DSP blocks
    /// the narrower operand is cut into chunks short enough for a LUT
    /// multiplier to fit the period; on a DSP target both operands are cut
    /// to the block's size, so every partial product is one block. Returns
    /// false when no split helps.
    pub(crate) fn split_mul(
        &mut self,
        i: usize,
        oa: &Opnd,
        ob: &Opnd,
        s: u32,
        m: timing::DelayModel,
        budget: f64,
    ) -> bool {
        let a_first = oa.val().width >= ob.val().width;
        let (ox, oy) = if a_first { (oa, ob) } else { (ob, oa) };
        let (x, y) = (ox.val(), oy.val());
        if x.expr.contains('\'') || y.expr.contains('\'') {
            return false;
        }
        let (cx, cy) = match m.dsp {
            None => {
                let mut c = y.width;
                while c > 1 && m.lut_mul(x.width + 1, c + 1) > budget {
                    c -= 1;
                }
                (x.width, c)
            }
            Some(d) => {
                // Chunks that fit the block with the extension bit; an
                // operand that fits whole stays whole.
                // (a signed operand as wide as the block fits it whole).
                let fit = |v: &Val, max: u32| {
                    if v.width < max || (v.signed && v.width == max) {
                        v.width
                    } else {
                        max - 1
                    }
                };
                (fit(x, d.a), fit(y, d.b))
            }
        };
        if cx >= x.width && cy >= y.width {
            return false;
        }
        let name = self.name[i].clone();
        let sym = self.t.sym(i);
        let w = sym.width;
        // Operands read at stage s: chunk wires of the shared value; own
        // operands: each partial product registers its two chunks.
        let xs = match ox {
            Opnd::At(v) => self.chunks(&name, v, cx, "a"),
            Opnd::Own(p) => chunk_slices(p, cx),
        };
        let ys = match oy {
            Opnd::At(v) => self.chunks(&name, v, cy, "b"),
            Opnd::Own(p) => chunk_slices(p, cy),
        };
        let mut parts: Vec<String> = Vec::new();
        let chunk = |&(_, width, signed, lo): &(String, u32, bool, u32)| crate::datapath::Chunk {
            lo,
            width,
            signed,
        };
        let recorded = xs
            .iter()
            .flat_map(|x| ys.iter().map(move |y| (chunk(x), chunk(y))))
            .map(|(x, y)| {
                let (a, b) = if a_first { (x, y) } else { (y, x) };
                crate::datapath::PartialProduct { a, b }
            })
            .collect();
        self.splits.push(crate::datapath::MulSplit {
            node: i,
            parts: recorded,
        });
        let mut slowest: f64 = 0.0;
        for (jx, (xe, xw, xsg, xlo)) in xs.iter().enumerate() {
            for (jy, (ye, yw, ysg, ylo)) in ys.iter().enumerate() {
                let own = |e: &mut Self, o: &Opnd, src: &str, w: u32, sg: bool, tag: &str| {
                    if matches!(o, Opnd::Own(_)) {
                        let q = format!("{name}_{tag}{jx}_{jy}_q");
                        e.own_reg(s, &q, sg, w, &bits::sv(sg, src));
                        q
                    } else {
                        src.to_string()
                    }
                };
                let xe = &own(self, ox, xe, *xw, *xsg, "a");
                let ye = &own(self, oy, ye, *yw, *ysg, "b");
                // Both factors of one signedness: a signed one extends an
                // unsigned partner by its bit.
                let ps = *xsg || *ysg;
                let (xe, xw) = self.extended(&name, xe, *xw, ps && !*xsg, &format!("az{jx}_{jy}"));
                let (ye, yw) = self.extended(&name, ye, *yw, ps && !*ysg, &format!("bz{jx}_{jy}"));
                let pw = xw + yw;
                let pp = format!("{name}_pp{jx}_{jy}");
                self.body
                    .push(format!("wire {} {pp} = {xe} * {ye};", decl(ps, pw)));
                self.hw.muls.push(MulHw {
                    a_width: xw,
                    b_width: yw,
                    signed: ps,
                    a_zext: ps && !*xsg,
                    b_zext: ps && !*ysg,
                    y_width: pw,
                });
                slowest = slowest.max(m.mul(xw, yw));
                let q = format!("{pp}_q");
                self.reg(s + 1, &q, ps, pw, &pp);
                let lo = xlo + ylo;
                // Aligned to the product's width: the partial's weight
                // 2^lo, extended by its own signedness, bits beyond w
                // dropped (the sum is exact modulo 2^w).
                let v = Val {
                    expr: q,
                    width: pw,
                    signed: ps,
                    frac: 0,
                };
                if pw + lo <= w {
                    parts.push(as_bits(bits::align(&v, lo, w)));
                } else {
                    let keep = w - lo;
                    let kept = Val {
                        expr: v.slice(keep - 1, 0),
                        width: keep,
                        signed: false,
                        frac: 0,
                    };
                    parts.push(as_bits(bits::align(&kept, lo, w)));
                    self.unused.push(v.slice(pw - 1, keep));
                }
            }
        }
        self.worst = self.worst.max(slowest);
        if slowest > budget + 1e-9 {
            self.too_slow.push(format!(
                "{name}: its smallest partial products ({} ns > {budget:.2} ns)",
                fmt_ns(slowest)
            ));
        }
        // The adder tree, level by level, from the partial products'
        // registers: in the DSP blocks, so the first level starts late.
        let (mut stage, mut t) = (s + 1, m.dsp.map_or(0.0, |d| d.route_out));
        let mut level = 0;
        while parts.len() > 1 {
            if t > 0.0 && t + m.add(w) > budget {
                let mut regd = Vec::new();
                for (n, p) in parts.iter().enumerate() {
                    let q = format!("{name}_l{level}_{n}_q");
                    self.reg(stage + 1, &q, sym.signed, w, &bits::sv(sym.signed, p));
                    regd.push(format!("{{{q}}}"));
                }
                parts = regd;
                stage += 1;
                t = 0.0;
            }
            let mut next = Vec::new();
            for (n, pair) in parts.chunks(2).enumerate() {
                if pair.len() == 1 {
                    next.push(pair[0].clone());
                    continue;
                }
                let sum = format!("{name}_l{level}_{n}");
                self.body.push(format!(
                    "wire {} {sum} = {};",
                    decl(sym.signed, w),
                    bits::sv(sym.signed, &format!("{} + {}", pair[0], pair[1]))
                ));
                self.hw.adders.push(w);
                next.push(format!("{{{sum}}}"));
            }
            parts = next;
            t += m.add(w);
            level += 1;
        }
        self.body.push(format!(
            "wire {} {name} = {};",
            decl(sym.signed, w),
            bits::sv(sym.signed, &parts[0])
        ));
        self.stage[i] = Some(stage);
        self.at.insert((i, stage), name.clone());
        self.ready(i, t, &name);
        true
    }

    /// A product's operand `tv` at stage `s`: with `own`, when its value
    /// comes from a register at `s` (a staged value from an earlier stage,
    /// or a held set-up value), the value the stage before holds, for the
    /// product to register on its own ([`Opnd::Own`]); else the value at
    /// `s` itself (a constant, a banked or per-triangle selected value,
    /// which are registers of their own already, or stage 0).
    pub(crate) fn mul_operand(&mut self, tv: &TV, s: u32, own: bool) -> Opnd {
        let n = tv.node();
        if let (true, Some(g)) = (own && s >= 1 && !self.lazy[n], self.banked_group(n)) {
            // A banked set-up input: the bank multiplexer as the item in
            // stage s - 1 sees it, a wire the product registers itself.
            let read = s - 1;
            self.drain[g] = self.drain[g].max(read);
            let field = self.name[n].trim_end_matches("_q").to_string();
            let name = format!("{field}_bank_m{read}");
            let sym = self.t.sym(n);
            if !self.bank_wires.contains(&name) {
                let group = self.group_names[g];
                let tag = if read == 0 {
                    format!("{group}_cur_q")
                } else {
                    format!("{group}_tag_q[{}]", read - 1)
                };
                self.body.push(format!(
                    "wire {} {name} = {tag} ? {field}_b1_q : {field}_b0_q;",
                    decl(sym.signed, sym.width)
                ));
                self.bank_wires.insert(name.clone());
            }
            return Opnd::Own(Val {
                expr: name,
                width: sym.width,
                signed: sym.signed,
                frac: tv.frac(),
            });
        }
        let staged_before = self.stage[n].is_some_and(|s0| s0 < s);
        let setup = self.stage[n].is_none()
            && self.banked_group(n).is_none()
            && !matches!(self.t.ops()[n], Op::Const(_));
        if own && !self.lazy[n] && (staged_before || setup) {
            Opnd::Own(self.operand(tv, s - 1))
        } else {
            Opnd::At(self.operand(tv, s))
        }
    }

    /// The operand itself at stage `s`: [`Opnd::Own`] registered whole
    /// into `name` (a register of stage `s`).
    pub(crate) fn own_operand(&mut self, o: Opnd, s: u32, name: &str) -> Val {
        match o {
            Opnd::At(v) => v,
            Opnd::Own(p) => {
                self.own_reg(s, name, p.signed, p.width, &p.expr);
                Val {
                    expr: name.to_string(),
                    ..p
                }
            }
        }
    }

    /// The chunks of operand `v`, `c` bits each from the bottom: (name,
    /// width, signed, weight). The top chunk of a signed operand is signed;
    /// the others are unsigned. One chunk is the operand itself.
    pub(crate) fn chunks(
        &mut self,
        name: &str,
        v: &Val,
        c: u32,
        tag: &str,
    ) -> Vec<(String, u32, bool, u32)> {
        let k = v.width.div_ceil(c);
        if k == 1 {
            return vec![(v.expr.clone(), v.width, v.signed, 0)];
        }
        let mut out = Vec::new();
        for j in 0..k {
            let lo = j * c;
            let hi = (lo + c).min(v.width) - 1;
            let cw = hi - lo + 1;
            let csigned = v.signed && j == k - 1;
            let n = format!("{name}_{tag}{j}");
            self.body.push(format!(
                "wire {} {n} = {};",
                decl(csigned, cw),
                bits::sv(csigned, &v.slice(hi, lo))
            ));
            out.push((n, cw, csigned, lo));
        }
        out
    }

    /// `e` (`w` bits, unsigned) zero-extended into a signed wire of `w + 1`
    /// bits when `zext`, else `e` itself.
    pub(crate) fn extended(
        &mut self,
        name: &str,
        e: &str,
        w: u32,
        zext: bool,
        tag: &str,
    ) -> (String, u32) {
        if !zext {
            return (e.to_string(), w);
        }
        let n = format!("{name}_{tag}");
        self.body
            .push(format!("wire signed [{w}:0] {n} = $signed({{1'b0, {e}}});"));
        (n, w + 1)
    }
}

/// A product's operand as [`Emitter::mul_operand`] finds it.
pub(crate) enum Opnd {
    /// The value at the product's stage, as every reader there sees it.
    At(Val),
    /// The value the stage before holds: the product registers it (or
    /// each of its partial products its chunks) into registers of its own.
    Own(Val),
}

impl Opnd {
    pub(crate) fn val(&self) -> &Val {
        match self {
            Opnd::At(v) | Opnd::Own(v) => v,
        }
    }
}

/// [`Emitter::chunks`] of `v` as slices of its expression (no wires): for
/// registers that load them.
pub(crate) fn chunk_slices(v: &Val, c: u32) -> Vec<(String, u32, bool, u32)> {
    let k = v.width.div_ceil(c);
    if k == 1 {
        return vec![(v.expr.clone(), v.width, v.signed, 0)];
    }
    (0..k)
        .map(|j| {
            let lo = j * c;
            let hi = (lo + c).min(v.width) - 1;
            (v.slice(hi, lo), hi - lo + 1, v.signed && j == k - 1, lo)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::chunk_slices;
    use crate::bits::Val;

    /// The chunks of a `w`-bit operand cut every `c` bits tile it: ⌈w/c⌉
    /// slices, each starting where the one below ends, all `c` bits but the
    /// top one, and only the top one carries the sign.
    #[test]
    fn chunks_tile_the_operand_and_only_the_top_one_is_signed() {
        for signed in [false, true] {
            for w in 1..=40u32 {
                for c in 1..=20u32 {
                    let v = Val {
                        expr: "x".into(),
                        width: w,
                        signed,
                        frac: 0,
                    };
                    let s = chunk_slices(&v, c);
                    assert_eq!(s.len() as u32, w.div_ceil(c), "w {w} c {c}");
                    let mut next = 0;
                    for (k, (_, width, sg, lo)) in s.iter().enumerate() {
                        assert_eq!(*lo, next, "w {w} c {c}");
                        let top = k + 1 == s.len();
                        assert!(top || *width == c, "w {w} c {c}");
                        assert_eq!(*sg, signed && top, "w {w} c {c}");
                        next += width;
                    }
                    assert_eq!(next, w, "w {w} c {c}");
                }
            }
        }
    }
}
