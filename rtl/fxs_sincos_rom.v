// fxs_sincos_rom: sin or cos of an angle index, from a ROM.
//
// Ports:
//   idx_i [T-1:0]  angle as an unsigned fraction of a turn (2^T entries per turn)
//   val_o [W-1:0]  sin(2*pi*idx/2^T) (COS = 0) or cos (COS = 1), two's
//                  complement, in the table format of the configuration
//
// QUARTER = 1: a quarter-wave ROM of 2^T/4 + 1 entries, sin over the first
// quarter turn (read from polar_quarter.hex); the quadrant idx[T-1:T-2] mirrors
// the address (2^T/4 - r) and negates the value by symmetry:
//   sin: mirror = q[0],  negate = q[1];  cos: mirror = ~q[0], negate = q[0]^q[1].
// QUARTER = 0: a full ROM of 2^T entries (polar_sin.hex or polar_cos.hex).
// The files are generated per configuration by the model and read from the
// simulator's working directory.
// Both give bit-identical outputs: the model expands the full tables from the
// same quarter-wave entries. Combinational read; contents from $readmemh.
`default_nettype none

module fxs_sincos_rom #(
  parameter integer T       = 10,
  parameter integer W       = 16,
  parameter integer QUARTER = 1,
  parameter integer COS     = 0
) (
  input  wire [T-1:0] idx_i,
  output wire [W-1:0] val_o
);
  generate
    if (QUARTER != 0) begin : g_quarter
      localparam integer Q = 1 << (T - 2);
      reg [W-1:0] mem [0:Q];
      initial $readmemh("polar_quarter.hex", mem);
      wire [1:0]   quad = idx_i[T-1:T-2];
      wire [T-2:0] r = {1'b0, idx_i[T-3:0]};
      wire [T-2:0] qv = Q[T-2:0];
      wire mirror = (COS != 0) ? ~quad[0] : quad[0];
      wire negate = (COS != 0) ? (quad[0] ^ quad[1]) : quad[1];
      wire [T-2:0] addr = mirror ? (qv - r) : r;
      wire [W-1:0] v = mem[addr];
      assign val_o = negate ? (~v + {{(W - 1){1'b0}}, 1'b1}) : v;
    end else begin : g_full
      reg [W-1:0] mem [0:(1 << T) - 1];
      if (COS != 0) begin : g_cos
        initial $readmemh("polar_cos.hex", mem);
      end else begin : g_sin
        initial $readmemh("polar_sin.hex", mem);
      end
      assign val_o = mem[idx_i];
    end
  endgenerate
endmodule

`default_nettype wire
