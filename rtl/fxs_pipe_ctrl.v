// fxs_pipe_ctrl: valid/ready control of a fixed-latency pipeline that
// stalls as a whole.
//
// A transfer happens on valid && ready at either port. The pipeline advances
// (adv_o) when its last stage is empty or being read: ready_o = adv_o =
// ~valid_o | ready_i. So valid_o and the data are held while ready_i is low,
// valid_o (a register) never depends on ready_i, and a vector enters every
// clock when ready_i stays high. Synchronous active-low reset clears the
// valid bits; data registers (in the unit) need no reset.
//
// Ports:
//   valid_i, ready_o  input handshake
//   valid_o, ready_i  output handshake
//   adv_o             enable of every pipeline register of the unit
`default_nettype none

module fxs_pipe_ctrl #(
  parameter integer LATENCY = 4
) (
  input  wire clk_i,
  input  wire rst_ni,
  input  wire valid_i,
  output wire ready_o,
  output wire valid_o,
  input  wire ready_i,
  output wire adv_o
);
  reg [LATENCY-1:0] v_q;
  assign adv_o   = ~v_q[LATENCY-1] | ready_i;
  assign ready_o = adv_o;
  assign valid_o = v_q[LATENCY-1];
  always @(posedge clk_i) begin
    if (!rst_ni) begin
      v_q <= {LATENCY{1'b0}};
    end else if (adv_o) begin
      v_q <= {v_q[LATENCY-2:0], valid_i};
    end
  end
endmodule

`default_nettype wire
