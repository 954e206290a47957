// polar_tb: self-checking testbench of polar (see fxs_vector_tb.vh).
// Input vector: {aL, bL, aN, bN}; output vector: {ovf[1:0], L'x, L'y, L'z}.
// The ROM contents (polar_*.hex) are read from the working directory.
`default_nettype none

module polar_tb;
  `include "polar_params.vh"
  parameter integer MAXN = 1024;
  localparam integer IN_W = 4 * K;
  localparam integer OUT_W = 2 + 3 * O_W;

  reg clk, rst_n, in_valid, out_ready;
  reg [IN_W-1:0] in_data;
  wire in_ready, out_valid;
  wire [3*O_W-1:0] l_out;
  wire [1:0] ovf;
  wire [OUT_W-1:0] out_data = {ovf, l_out};

  wire unused_side;
  polar dut (
    .clk_i  (clk),
    .rst_ni (rst_n),
    .valid_i(in_valid),
    .ready_o(in_ready),
    .a_i    (in_data),
    .valid_o(out_valid),
    .ready_i(out_ready),
    .l_o    (l_out),
    .ovf_o  (ovf),
    .side_i (1'b0),
    .side_o (unused_side)
  );

  task show(input integer i, input [IN_W-1:0] in, input [OUT_W-1:0] got, input [OUT_W-1:0] want);
    begin
      $display("mismatch at vector %0d: aL = %0d, bL = %0d, aN = %0d, bN = %0d (codes of a turn)", i,
               in[4*K-1:3*K], in[3*K-1:2*K], in[2*K-1:K], in[K-1:0]);
      $display("  got  ovf {lyz,out} = %b, L' = (%0d, %0d, %0d)", got[OUT_W-1:OUT_W-2],
               $signed(got[3*O_W-1:2*O_W]), $signed(got[2*O_W-1:O_W]), $signed(got[O_W-1:0]));
      $display("  want ovf {lyz,out} = %b, L' = (%0d, %0d, %0d)", want[OUT_W-1:OUT_W-2],
               $signed(want[3*O_W-1:2*O_W]), $signed(want[2*O_W-1:O_W]), $signed(want[O_W-1:0]));
    end
  endtask

  `include "fxs_vector_tb.vh"
endmodule

`default_nettype wire
