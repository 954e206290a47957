// fxs_side_delay: carry side data through a unit in lock-step with its
// pipeline, so whatever travels with a pixel (a coefficient-set index, the
// light and half vectors, a normal-map texel) leaves the unit with the
// result it belongs to, stalls included.
//
// Ports:
//   adv_i         the unit's pipeline enable (fxs_pipe_ctrl's adv_o)
//   d_i  [W-1:0]  side data, sampled with the unit's input
//   q_o  [W-1:0]  the same data, LATENCY advances later
// LATENCY registers, no reset (the valid bits live in fxs_pipe_ctrl).
`default_nettype none

module fxs_side_delay #(
  parameter integer W       = 1,
  parameter integer LATENCY = 4
) (
  input  wire         clk_i,
  input  wire         adv_i,
  input  wire [W-1:0] d_i,
  output wire [W-1:0] q_o
);
  reg [W-1:0] q [0:LATENCY-1];
  integer k;
  always @(posedge clk_i) begin
    if (adv_i) begin
      q[0] <= d_i;
      for (k = 1; k < LATENCY; k = k + 1) q[k] <= q[k-1];
    end
  end
  assign q_o = q[LATENCY-1];
endmodule

`default_nettype wire
