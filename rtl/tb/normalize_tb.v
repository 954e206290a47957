// normalize_tb: self-checking testbench of normalize (see fxs_vector_tb.vh).
// Input vector: {Nx, Ny, Nz}; output vector: {ovf[3:0], N'x, N'y, N'z}.
`default_nettype none

module normalize_tb;
  `include "normalize_params.vh"
  parameter integer MAXN = 1024;
  localparam integer IN_W = 3 * N_W;
  localparam integer OUT_W = 4 + 3 * O_W;

  reg clk, rst_n, in_valid, out_ready;
  reg [IN_W-1:0] in_data;
  wire in_ready, out_valid;
  wire [3*O_W-1:0] n_out;
  wire [3:0] ovf;
  wire [OUT_W-1:0] out_data = {ovf, n_out};

  wire unused_side;
  normalize dut (
    .clk_i  (clk),
    .rst_ni (rst_n),
    .valid_i(in_valid),
    .ready_o(in_ready),
    .n_i    (in_data),
    .valid_o(out_valid),
    .ready_i(out_ready),
    .n_o    (n_out),
    .ovf_o  (ovf),
    .sel_i  ({SEL_W{1'b0}}),
    .side_i (1'b0),
    .side_o (unused_side)
  );

  task show(input integer i, input [IN_W-1:0] in, input [OUT_W-1:0] got, input [OUT_W-1:0] want);
    begin
      $display("mismatch at vector %0d: N = (%0d, %0d, %0d)", i,
               $signed(in[3*N_W-1:2*N_W]), $signed(in[2*N_W-1:N_W]), $signed(in[N_W-1:0]));
      $display("  got  ovf {d,h,g,out} = %b, N' = (%0d, %0d, %0d)", got[OUT_W-1:OUT_W-4],
               $signed(got[3*O_W-1:2*O_W]), $signed(got[2*O_W-1:O_W]), $signed(got[O_W-1:0]));
      $display("  want ovf {d,h,g,out} = %b, N' = (%0d, %0d, %0d)", want[OUT_W-1:OUT_W-4],
               $signed(want[3*O_W-1:2*O_W]), $signed(want[2*O_W-1:O_W]), $signed(want[O_W-1:0]));
    end
  endtask

  `include "fxs_vector_tb.vh"
endmodule

`default_nettype wire
