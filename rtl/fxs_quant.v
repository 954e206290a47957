// fxs_quant: quantize an exact value to a target fixed-point format.
//
// The one place bits are dropped, exactly as model/ARITHMETIC.md section 3
// and the model's quantize.rs specify: rounding first, then overflow.
//
// Ports:
//   x_i    [IW-1:0]  exact value, two's complement, F_in fraction bits
//   y_o    [OW-1:0]  code in the target format (F_out fraction bits;
//                    two's complement when OSIGNED = 1)
//   ovf_o            the rounded value lay outside the target range
//
// Parameters:
//   SHIFT = F_in - F_out: bits dropped (> 0, 1 <= SHIFT < IW) or added (<= 0)
//   ROUND: 0 trunc   r = x >>> S
//          1 half_up r = ((x >>> (S-1)) + 1) >>> 1
//          2 half_even r = (x + {x[S], {(S-1){~x[S]}}}) >>> S
//            (the bias is 2^(S-1) - 1 + x[S]: one adder, ties to even)
//   SAT:   0 wrap (y = r[OW-1:0]), 1 saturate to the range
//
// Purely combinational; one adder for a nearest mode when SHIFT > 0, two
// comparators for the range check.
`default_nettype none

module fxs_quant #(
  parameter integer IW      = 32,
  parameter integer SHIFT   = 8,
  parameter integer OW      = 16,
  parameter integer OSIGNED = 1,
  parameter integer ROUND   = 2,
  parameter integer SAT     = 1
) (
  input  wire [IW-1:0] x_i,
  output wire [OW-1:0] y_o,
  output wire          ovf_o
);
  // Width of the rounded value: one bit of headroom above x >>> S.
  localparam integer RW = (SHIFT > 0) ? (IW + 1) : (IW + 1 - SHIFT);
  // Width of the range comparison.
  localparam integer CW = ((RW > OW) ? RW : OW) + 2;

  wire signed [IW:0] xw = {x_i[IW-1], x_i};
  wire signed [RW-1:0] r;

  generate
    if (SHIFT > 0) begin : g_right
      if (ROUND == 0) begin : g_trunc
        assign r = xw >>> SHIFT;
        wire unused_round = 1'b0;
      end else if (ROUND == 1) begin : g_half_up
        wire signed [IW:0] t = xw >>> (SHIFT - 1);
        wire signed [IW:0] u = t + {{IW{1'b0}}, 1'b1};
        assign r = u >>> 1;
      end else begin : g_half_even
        wire b = xw[SHIFT];
        wire [SHIFT-1:0] bias_low;
        if (SHIFT > 1) begin : g_wide
          assign bias_low = {b, {(SHIFT - 1){~b}}};
        end else begin : g_one
          assign bias_low = b;
        end
        wire signed [IW:0] u = xw + {{(IW + 1 - SHIFT){1'b0}}, bias_low};
        assign r = u >>> SHIFT;
      end
    end else begin : g_left
      assign r = {{(RW - IW - 1){1'b0}}, xw} <<< (-SHIFT);
      wire unused_round = 1'b0;
    end
  endgenerate

  wire signed [CW-1:0] rc = {{(CW - RW){r[RW-1]}}, r};
  localparam [CW-1:0] MAXV = (OSIGNED != 0) ? {{(CW - OW + 1){1'b0}}, {(OW - 1){1'b1}}}
                                            : {{(CW - OW){1'b0}}, {OW{1'b1}}};
  localparam [CW-1:0] MINV = (OSIGNED != 0) ? {{(CW - OW + 1){1'b1}}, {(OW - 1){1'b0}}}
                                            : {CW{1'b0}};
  wire over  = rc > $signed(MAXV);
  wire under = rc < $signed(MINV);
  assign ovf_o = over | under;

  wire [OW-1:0] sat_v = under ? MINV[OW-1:0] : MAXV[OW-1:0];
  assign y_o = (ovf_o && SAT != 0) ? sat_v : rc[OW-1:0];

  // Bits of the comparison width above the output are only compared.
  wire unused_high = ^rc[CW-1:OW];
endmodule

`default_nettype wire
