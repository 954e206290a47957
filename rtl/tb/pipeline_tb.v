// pipeline_tb: self-checking testbench of pipeline (see fxs_vector_tb.vh).
// Input vector: the pixel's fields (pipeline_params.vh, PIX_W bits);
// output vector: {level}. The polar ROM images are read from the working
// directory. +DUMP=<file> writes every output level, in order, as hex.
`default_nettype none

module pipeline_tb;
  `include "pipeline_params.vh"
  parameter integer MAXN = 1024;
  localparam integer IN_W = PIX_W;
  localparam integer OUT_W = LV_W;

  reg clk, rst_n, in_valid, out_ready;
  reg [IN_W-1:0] in_data;
  wire in_ready, out_valid;
  wire [OUT_W-1:0] out_data;

  pipeline dut (
    .clk_i  (clk),
    .rst_ni (rst_n),
    .valid_i(in_valid),
    .ready_o(in_ready),
    .pix_i  (in_data),
    .valid_o(out_valid),
    .ready_i(out_ready),
    .level_o(out_data)
  );

  task show(input integer i, input [IN_W-1:0] in, input [OUT_W-1:0] got, input [OUT_W-1:0] want);
    begin
      $display("mismatch at vector %0d (path %0d): pixel fields %h", i, PATH, in);
      $display("  got  level = %0d", got);
      $display("  want level = %0d", want);
    end
  endtask

  `include "fxs_vector_tb.vh"
endmodule

`default_nettype wire
