// fxs_mad_q: one multiply-add, exact, then quantized: y = Q(a*b + c), or
// y = Q(c - a*b) with SUB = 1.
//
// The sum is aligned at max(FA + FB, FC) fraction bits, exactly as the
// model's datapath aligns it (model/ARITHMETIC.md section 2), then
// fxs_quant rounds and range-limits it to the output format.
//
// Ports (all two's complement):
//   a_i [AW-1:0]  FA fraction bits      b_i [BW-1:0]  FB fraction bits
//   c_i [CW-1:0]  FC fraction bits
//   y_o [OW-1:0]  OF fraction bits, signed if OSIGNED
//   ovf_o         the rounded sum lay outside the output range
// SUB = 1 computes c - a*b. Purely combinational: one
// multiplier, one adder, and fxs_quant's rounding adder and comparators.
`default_nettype none

module fxs_mad_q #(
  parameter integer AW      = 18,
  parameter integer FA      = 15,
  parameter integer BW      = 18,
  parameter integer FB      = 17,
  parameter integer CW      = 18,
  parameter integer FC      = 15,
  parameter integer SUB     = 0,
  parameter integer OW      = 18,
  parameter integer OF      = 17,
  parameter integer OSIGNED = 1,
  parameter integer ROUND   = 2,
  parameter integer SAT     = 1
) (
  input  wire [AW-1:0] a_i,
  input  wire [BW-1:0] b_i,
  input  wire [CW-1:0] c_i,
  output wire [OW-1:0] y_o,
  output wire          ovf_o
);
  localparam integer MW = AW + BW;                      // exact product
  localparam integer MF = FA + FB;
  localparam integer SF = (MF > FC) ? MF : FC;          // frac of the sum
  localparam integer SA = SF - MF;                      // alignment shifts
  localparam integer SC = SF - FC;
  localparam integer WA = MW + SA;
  localparam integer WC = CW + SC;
  localparam integer SW = ((WA > WC) ? WA : WC) + 1;    // exact sum

  wire signed [MW-1:0] m = $signed(a_i) * $signed(b_i);
  wire signed [SW-1:0] ma = {{(SW - MW){m[MW-1]}}, m} <<< SA;
  wire signed [SW-1:0] ca = {{(SW - CW){c_i[CW-1]}}, c_i} <<< SC;
  wire signed [SW-1:0] s = (SUB != 0) ? (ca - ma) : (ma + ca);

  fxs_quant #(.IW(SW), .SHIFT(SF - OF), .OW(OW), .OSIGNED(OSIGNED), .ROUND(ROUND), .SAT(SAT))
    u_q (.x_i(s), .y_o(y_o), .ovf_o(ovf_o));
endmodule

`default_nettype wire
