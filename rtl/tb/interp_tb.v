// interp_tb: self-checking testbench of interp (see fxs_vector_tb.vh).
// Input vector: {c1, c2, N1, N2, N3, N12, N23, N31}; output {ovf[1:0], N}.
`default_nettype none

module interp_tb;
  `include "interp_params.vh"
  parameter integer MAXN = 1024;
  localparam integer IN_W = 2 * B_W + 18 * V_W;
  localparam integer OUT_W = 2 + 3 * O_W;

  reg clk, rst_n, in_valid, out_ready;
  reg [IN_W-1:0] in_data;
  wire in_ready, out_valid;
  wire [3*O_W-1:0] n_out;
  wire [1:0] ovf;
  wire [OUT_W-1:0] out_data = {ovf, n_out};

  wire unused_side;
  interp dut (
    .clk_i  (clk),
    .rst_ni (rst_n),
    .valid_i(in_valid),
    .ready_o(in_ready),
    .c_i    (in_data[IN_W-1:18*V_W]),
    .v_i    (in_data[18*V_W-1:0]),
    .valid_o(out_valid),
    .ready_i(out_ready),
    .n_o    (n_out),
    .ovf_o  (ovf),
    .side_i (1'b0),
    .side_o (unused_side)
  );

  task show(input integer i, input [IN_W-1:0] in, input [OUT_W-1:0] got, input [OUT_W-1:0] want);
    begin
      $display("mismatch at vector %0d: c1 = %0d, c2 = %0d (codes)", i, in[IN_W-1:IN_W-B_W], in[IN_W-B_W-1:18*V_W]);
      $display("  got  ovf {weight,out} = %b, N = (%0d, %0d, %0d)", got[OUT_W-1:OUT_W-2],
               $signed(got[3*O_W-1:2*O_W]), $signed(got[2*O_W-1:O_W]), $signed(got[O_W-1:0]));
      $display("  want ovf {weight,out} = %b, N = (%0d, %0d, %0d)", want[OUT_W-1:OUT_W-2],
               $signed(want[3*O_W-1:2*O_W]), $signed(want[2*O_W-1:O_W]), $signed(want[O_W-1:0]));
    end
  endtask

  `include "fxs_vector_tb.vh"
endmodule

`default_nettype wire
