//! The SystemVerilog DPI-C route to the model: for an emitted module, a
//! package `<module>_dpi_pkg` (the C ABI's DPI-C imports, the ports as
//! packed structs, the configuration it was generated for, and an `eval`
//! function from an input struct to an output struct) and a scoreboard
//! testbench `<module>_dpi_tb` that drives the module with random inputs
//! and random valid/ready and checks every output against the model.
//!
//! The library behind the imports is `capi/` (`libfxshade_capi`), whose
//! `fxs_dpi_*` functions take and return only `chandle`, `string`,
//! `longint` and sized `longint` arrays, so no `svdpi.h` call is needed
//! and one declaration serves every package: codes travel in arrays of
//! [`MAX_PORTS`] `longint`s, the flag word in a `longint unsigned`.
//!
//! `fxs_dpi_open(unit, config_toml, sets, layout)` checks `layout` (the
//! package's [`UnitModel::layout`]) against the configuration it is given,
//! so a package generated for other widths is refused, never misread.

use fxshade_numbers::convert::narrow;
use std::fmt::Write as _;

use super::testbench;
use super::unit_model::UnitModel;
use crate::vectors::{Field, GENERATOR};

/// The most input or output ports a DPI-C call carries (the size of its
/// code arrays).
pub const MAX_PORTS: usize = 64;

/// Why a module has no DPI-C package.
#[derive(Debug, thiserror::Error)]
pub enum DpiError {
    /// More ports than the DPI-C call's arrays hold.
    #[error("{module} has {n} {what} ports; the DPI-C calls carry at most {MAX_PORTS}")]
    TooManyPorts {
        /// Module.
        module: String,
        /// Port count.
        n: usize,
        /// `input` or `output`.
        what: &'static str,
    },
    /// A field name that is a SystemVerilog keyword.
    #[error("port {0} is a SystemVerilog keyword and cannot name a struct member")]
    Keyword(String),
}

/// SystemVerilog keywords a field name could plausibly take.
const KEYWORDS: &[&str] = &[
    "alias", "always", "and", "assign", "begin", "bit", "buf", "byte", "case", "cell", "class",
    "config", "const", "cover", "default", "design", "do", "edge", "else", "end", "enum", "event",
    "final", "for", "force", "fork", "function", "if", "initial", "inout", "input", "int",
    "integer", "join", "local", "logic", "longint", "module", "new", "not", "null", "or", "output",
    "package", "real", "reg", "ref", "shortint", "signed", "static", "string", "struct", "super",
    "table", "task", "this", "time", "type", "union", "unsigned", "var", "void", "wait", "while",
    "wire", "with", "xor",
];

/// `s` as a SystemVerilog string literal's contents: `\\`, `\"`, `\n`,
/// `\t`, and every other byte outside printable ASCII as a three-digit
/// octal escape.
pub fn sv_string(s: &str) -> String {
    let mut o = String::new();
    for b in s.bytes() {
        match b {
            b'\\' => o += "\\\\",
            b'"' => o += "\\\"",
            b'\n' => o += "\\n",
            b'\t' => o += "\\t",
            0x20..=0x7e => o.push(b as char),
            _ => {
                let _ = write!(o, "\\{b:03o}");
            }
        }
    }
    o
}

/// A long string as a concatenation of literals of at most `width`
/// characters each (lines of the generated file stay short).
fn sv_concat(s: &str, indent: &str, width: usize) -> String {
    let esc = sv_string(s);
    let mut parts = Vec::new();
    let mut cur = String::new();
    let mut chars = esc.chars().peekable();
    while let Some(c) = chars.next() {
        cur.push(c);
        if c == '\\' {
            // Keep an escape whole.
            if let Some(n) = chars.next() {
                cur.push(n);
                if n.is_ascii_digit() {
                    for _ in 0..2 {
                        if let Some(d) = chars.next() {
                            cur.push(d);
                        }
                    }
                }
            }
        }
        if cur.len() >= width || cur.ends_with("\\n") {
            parts.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() || parts.is_empty() {
        parts.push(cur);
    }
    let lines: Vec<String> = parts.iter().map(|p| format!("{indent}\"{p}\"")).collect();
    format!("{{\n{}\n{indent}}}", lines.join(",\n"))
}

/// A random code of `f`'s width: `$urandom()` (32 bits) cast to the
/// width, `$signed` for a signed field.
fn random_bits(f: &Field) -> String {
    let w = f.format.width();
    let bits = if w <= 32 {
        format!("{w}'($urandom())")
    } else {
        format!("{w}'({{$urandom(), $urandom()}})")
    };
    if f.format.signed() {
        format!("$signed({bits})")
    } else {
        bits
    }
}

fn member(f: &Field) -> String {
    let w = f.format.width();
    if f.format.signed() {
        format!("logic signed [{}:0] {};", w - 1, f.name)
    } else {
        format!("logic [{}:0] {};", w - 1, f.name)
    }
}

fn check(m: &UnitModel) -> Result<(), DpiError> {
    for (n, what) in [(m.inputs().len(), "input"), (m.outputs().len(), "output")] {
        if n > MAX_PORTS {
            return Err(DpiError::TooManyPorts {
                module: m.module().to_string(),
                n,
                what,
            });
        }
    }
    for f in m.inputs().iter().chain(m.outputs()) {
        if KEYWORDS.contains(&f.name.as_str()) {
            return Err(DpiError::Keyword(f.name.clone()));
        }
    }
    Ok(())
}

/// The package `<module>_dpi_pkg.sv` for a unit's model.
///
/// It holds the C ABI's imports, `in_t` (every input field, most
/// significant first: the module's input ports in order, the layout of
/// the vector files' input data), `out_t` (`ovf` first when the unit has
/// flags, then the outputs: the vector files' output data), the unit name,
/// its configuration as TOML text and its layout, `open()` (the model of
/// that configuration) and `eval(model, x, y)` (0, or −1 with
/// `fxs_dpi_error()` saying why).
///
/// # Errors
///
/// [`DpiError::TooManyPorts`] when the model has more than [`MAX_PORTS`] input or output
/// ports; [`DpiError::Keyword`] when a port's name is a SystemVerilog keyword (of those this
/// module lists).
pub fn package(m: &UnitModel) -> Result<String, DpiError> {
    check(m)?;
    let module = m.module();
    let nf = m.flags().len();
    let mut t = String::new();
    t += &super::comment(
        "// ",
        &format!(
            "{module}_dpi_pkg.sv: the bit-exact model of {module} through DPI-C, generated \
             by {GENERATOR}. Do not edit: regenerate with"
        ),
    );
    let _ = writeln!(
        t,
        "//   fxshade rtl {} [--config FILE] [--set KEY=VALUE]... --dpi --out DIR",
        m.unit.name
    );
    t += "//\n";
    t += "// Link the C ABI library (capi/, libfxshade_capi) into the simulation:\n";
    t += "// with the Verilator flag -LDFLAGS \"-L<dir> -lfxshade_capi -Wl,-rpath,<dir>\",\n";
    t += "// or -sv_lib <dir>/libfxshade_capi on simulators that load DPI-C libraries\n";
    t += "// (README.md, \"Use the model in your own testbench\").\n";
    t += &super::comment(
        "// ",
        // Escaped once already (`rtl::units::design`), as in the module's header.
        &format!("Configuration: {}", m.design.config_source),
    );
    let _ = writeln!(t, "// Latency of {module}: {} cycles.", m.latency());
    if nf > 0 {
        t += "// out_t.ovf: overflow flags, one per stage id:\n";
        for (k, s) in m.flags().iter().enumerate() {
            let _ = writeln!(t, "//   bit {:<3} {}", nf - 1 - k, crate::escape::line(s));
        }
    }
    for g in m.setup() {
        t += &super::comment(
            "// ",
            &format!(
                "Set-up port {}: {} (fields {}). Every eval call carries them.",
                g.name,
                crate::escape::line(g.doc),
                g.fields.join(", ")
            ),
        );
    }
    t += "\npackage ";
    let _ = writeln!(t, "{module}_dpi_pkg;\n");
    let _ = writeln!(t, "  localparam int NumIn = {};", m.inputs().len());
    let _ = writeln!(t, "  localparam int NumOut = {};", m.outputs().len());
    if nf > 0 {
        let _ = writeln!(t, "  localparam int NumFlags = {nf};");
    }
    let _ = writeln!(
        t,
        "  localparam string Unit = \"{}\";",
        sv_string(m.unit.name)
    );
    let _ = writeln!(
        t,
        "  localparam string Layout = {};",
        sv_concat(&m.layout(), "    ", 72)
    );
    let _ = writeln!(
        t,
        "  localparam string ConfigToml = {};\n",
        sv_concat(&m.design.config_toml, "    ", 72)
    );
    t += "  // The C ABI (capi/include/fxshade.h); codes in arrays of 64.\n";
    t += "  import \"DPI-C\" function chandle fxs_dpi_open(input string unit,\n";
    t += "    input string config_toml, input string sets, input string layout);\n";
    t += "  import \"DPI-C\" function string fxs_dpi_error();\n";
    t += "  import \"DPI-C\" function int fxs_dpi_eval(input chandle model,\n";
    t += "    input longint in_codes[64], output longint out_codes[64],\n";
    t += "    output longint unsigned flags);\n";
    t += "  import \"DPI-C\" function void fxs_dpi_close(input chandle model);\n\n";
    t += "  typedef struct packed {\n";
    for f in m.inputs() {
        let _ = writeln!(t, "    {}  // {}", member(f), f.format);
    }
    t += "  } in_t;\n\n  typedef struct packed {\n";
    if nf > 0 {
        let _ = writeln!(t, "    logic [{}:0] ovf;", nf - 1);
    }
    for f in m.outputs() {
        let _ = writeln!(t, "    {}  // {}", member(f), f.format);
    }
    t += "  } out_t;\n\n";
    t += "  // The model of this package's configuration (null on an error:\n";
    t += "  // fxs_dpi_error() says why).\n";
    t += "  function automatic chandle open();\n";
    t += "    return fxs_dpi_open(Unit, ConfigToml, \"\", Layout);\n";
    t += "  endfunction\n\n";
    t += "  // y = the model's outputs and flags for x; 0, or -1 on an error.\n";
    t += "  function automatic int eval(input chandle model, input in_t x, output out_t y);\n";
    t += "    longint ic[64];\n    longint oc[64];\n    longint unsigned f;\n    int r;\n";
    t += "    for (int k = NumIn; k < 64; k++) ic[k] = 0;\n";
    t += "    for (int k = NumOut; k < 64; k++) oc[k] = 0;\n";
    for (k, f) in m.inputs().iter().enumerate() {
        let _ = writeln!(t, "    ic[{k}] = longint'(x.{});", f.name);
    }
    t += "    r = fxs_dpi_eval(model, ic, oc, f);\n";
    if nf == 0 {
        t += "    if (f != 0) r = -1;  // no flag stages: the word is 0\n";
    }
    t += "    y = '0;\n";
    if nf > 0 {
        t += "    y.ovf = f[NumFlags-1:0];\n";
        t += "    if ((f >> NumFlags) != 0) r = -1;  // no bits above the flag stages\n";
    }
    for (k, f) in m.outputs().iter().enumerate() {
        let bits = format!("oc[{k}][{}:0]", f.format.width() - 1);
        if f.format.signed() {
            let _ = writeln!(t, "    y.{} = $signed({bits});", f.name);
        } else {
            let _ = writeln!(t, "    y.{} = {bits};", f.name);
        }
    }
    t += "    return r;\n  endfunction\n\nendpackage\n";
    Ok(super::wrap::wrap_verilog(&t, super::wrap::WIDTH))
}

/// The scoreboard `<module>_dpi_tb.sv`: drives `<module>` with random
/// input codes (every code of every port; set-up fields kept for a while
/// and then redrawn, sent through the set-up sequencer of the vector
/// testbench), random `valid_i` and `ready_i` (`+STALL=<percent>`), checks
/// every output transfer in order against the package's `eval`, and ends
/// with `P passed, F failed` (`$fatal` when F > 0 or the module hangs).
/// Plusargs: `+N=<count>` (default 1000), `+SEED=<n>`, `+STALL=<percent>`
/// (default 25).
///
/// # Errors
///
/// As [`package`].
///
/// # Panics
///
/// Never: a model's module is emitted with at most 64 flag stages (its outputs compiled),
/// and each set-up field is one of its input ports (the emitter checks it).
pub fn scoreboard(m: &UnitModel) -> Result<String, DpiError> {
    check(m)?;
    let module = m.module();
    let nf = m.flags().len();
    let inputs = m.inputs();
    let mut outputs: Vec<Field> = Vec::new();
    if nf > 0 {
        outputs.push(Field::new(
            "ovf",
            crate::format::Format::new(false, narrow::<u32, _>(nf), 0).expect("a flag format"),
        ));
    }
    outputs.extend(m.outputs().iter().cloned());
    let mut t = String::new();
    t += &super::comment(
        "// ",
        &format!(
            "{module}_dpi_tb.sv: scoreboard of {module} against its DPI-C model, generated by \
             {GENERATOR}. Random input codes, random valid and ready; every output transfer \
             is checked in order against the package's eval."
        ),
    );
    t += "// Plusargs: +N=<count> (1000), +SEED=<n> (1), +STALL=<percent> (25).\n";
    t += "// Ends with `P passed, F failed`; $fatal when F > 0.\n";
    t += "`default_nettype none\n\n";
    let _ = writeln!(t, "module {module}_dpi_tb;");
    let _ = writeln!(t, "  import {module}_dpi_pkg::*;\n");
    t += "  logic clk, rst_n, in_valid, out_ready;\n";
    t += "  in_t in_data;\n  wire in_ready, out_valid;\n";
    t += "  out_t out_data;\n\n";
    t += &testbench::instance(module, inputs, &outputs, nf, false, m.setup(), true);
    t += "  chandle model;\n  in_t sent_q[$];\n";
    t += "  int n, seed, sent, checked, mism, orphan, quiet;\n  int unsigned stall;\n";
    t += "  bit accepted;\n";
    t += "\n";
    // A new row: every field random, set-up groups kept with probability
    // 7/8 once drawn.
    if m.setup().is_empty() {
        t += "  function automatic in_t next_row();\n";
    } else {
        t += "  function automatic in_t next_row(input bit first);\n";
    }
    t += "    in_t r;\n";
    let mut done = vec![false; inputs.len()];
    for g in m.setup() {
        t += "    if (first || $urandom_range(7) == 0) begin\n";
        for f in &g.fields {
            let k = inputs.iter().position(|x| &x.name == f).expect("a field");
            done[k] = true;
            let _ = writeln!(t, "      r.{f} = {};", random_bits(&inputs[k]));
        }
        t += "    end else begin\n";
        for f in &g.fields {
            let _ = writeln!(t, "      r.{f} = in_data.{f};");
        }
        t += "    end\n";
    }
    for (k, f) in inputs.iter().enumerate() {
        if !done[k] {
            let _ = writeln!(t, "    r.{} = {};", f.name, random_bits(f));
        }
    }
    t += "    return r;\n  endfunction\n\n";
    let next = if m.setup().is_empty() {
        "next_row()"
    } else {
        "next_row(sent == 0)"
    };
    t += &r#"  initial forever #5 clk = ~clk;

  initial begin
    in_t want_in;
    out_t want;
    clk = 1'b0;
    rst_n = 1'b0;
    in_valid = 1'b0;
    out_ready = 1'b0;
    in_data = '0;
    sent = 0;
    checked = 0;
    mism = 0;
    orphan = 0;
    quiet = 0;
    n = 1000;
    if ($value$plusargs("N=%d", n)) begin end
    if (n < 1) $fatal(1, "+N=%0d: at least one vector", n);
    seed = 1;
    if ($value$plusargs("SEED=%d", seed)) begin end
    stall = 25;
    if ($value$plusargs("STALL=%d", stall)) begin end
    void'($urandom(seed));
    model = open();
    if (model == null) $fatal(1, "fxshade model: %s", fxs_dpi_error());
    repeat (3) @(posedge clk);
    rst_n = 1'b1;
    forever begin
      // Handshakes are sampled at the rising edge and new values driven at
      // the falling edge: no race with the module's registers.
      @(posedge clk);
      // Input side: valid stays high until the transfer.
      if (in_valid && in_ready) begin
        sent_q.push_back(in_data);
        sent = sent + 1;
      end
      accepted = in_valid && in_ready;
      // Output side: every transfer checked, in order.
      quiet = quiet + 1;
      if (out_valid && out_ready) begin
        quiet = 0;
        if (sent_q.size() == 0) begin
          orphan = orphan + 1;
          $display("error: an output with no input in flight");
        end else begin
          want_in = sent_q.pop_front();
          if (eval(model, want_in, want) != 0)
            $fatal(1, "fxshade model: %s", fxs_dpi_error());
          if (out_data !== want) begin
            mism = mism + 1;
            if (mism <= 5)
              $display("mismatch at output %0d: in %h got %h want %h", checked, want_in,
                       out_data, want);
          end
          checked = checked + 1;
        end
      end
      if (checked == n || quiet > 100000) begin
        $display("%0d passed, %0d failed", checked - mism, mism + orphan + (n - checked));
        fxs_dpi_close(model);
        if (checked < n)
          $fatal(1, "no output for 100000 cycles after %0d of %0d (+STALL=%0d)", checked, n,
                 stall);
        if (mism + orphan != 0) $fatal(1, "the module disagrees with the model");
        $finish;
      end
      @(negedge clk);
      if (!in_valid || accepted) begin
        if (sent < n && $urandom_range(99) >= stall) begin
          in_valid = 1'b1;
          in_data = NEXT_ROW;
        end else begin
          in_valid = 1'b0;
        end
      end
      out_ready = $urandom_range(99) >= stall;
    end
  end
endmodule

`default_nettype wire
"#
    .replace("NEXT_ROW", next);
    Ok(super::wrap::wrap_verilog(&t, super::wrap::WIDTH))
}
