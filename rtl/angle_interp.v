// angle_interp: the polar angles of the surface normal at a pixel, from
// angles set up per vertex (the pipeline's mapped path; no arcsine or
// arctangent per pixel):
//
//   stage 1  products c1*da1, c2*da2, c1*db1, c2*db2                (registered)
//   stage 2  a = Q_angle(a3 + c1*da1 + c2*da2), b likewise           (registered)
//
// Angles are binary angle measures (U0F<K>, a fraction of a turn) and the
// set-up differences da_i = wrap(a_i - a3) are their two's complement
// (I0F<K>), so the wrap of beta at +-180 degrees costs nothing: Q_angle
// rounds with mode A_R and wraps. Model: Pipeline::angle_of in
// model/src/pipeline/mod.rs. Latency 2 cycles; handshake as in normalize.v.
//
// Parameters come from the top (pipeline_params.vh). Ports:
//   c_i   [2*B_W-1:0]  {c1, c2}, barycentric format (B)
//   a_i   [3*K-1:0]    {a3, da1, da2}: U0F<K>, I0F<K>, I0F<K>
//   b_i   [3*K-1:0]    {b3, db1, db2}, likewise
//   an_o, bn_o [K-1:0] the interpolated angles, U0F<K>
//   side_i, side_o [SIDE_W-1:0]  side data carried in lock-step
`default_nettype none

module angle_interp #(
  parameter integer B_W    = 16,
  parameter integer B_F    = 15,
  parameter integer B_S    = 0,
  parameter integer K      = 10,
  parameter integer A_R    = 2,
  parameter integer SIDE_W = 1
) (
  input  wire              clk_i,
  input  wire              rst_ni,
  input  wire              valid_i,
  output wire              ready_o,
  input  wire [2*B_W-1:0]  c_i,
  input  wire [3*K-1:0]    a_i,
  input  wire [3*K-1:0]    b_i,
  output wire              valid_o,
  input  wire              ready_i,
  output wire [K-1:0]      an_o,
  output wire [K-1:0]      bn_o,
  input  wire [SIDE_W-1:0] side_i,
  output wire [SIDE_W-1:0] side_o
);
  localparam integer LATENCY = 2;
  localparam integer CE = B_W + 1;
  localparam integer PW = CE + K;                        // c * delta
  localparam integer SW = ((PW > K + 1 + B_F) ? PW : K + 1 + B_F) + 2;

  wire adv;
  fxs_pipe_ctrl #(.LATENCY(LATENCY)) u_ctrl (
    .clk_i  (clk_i),
    .rst_ni (rst_ni),
    .valid_i(valid_i),
    .ready_o(ready_o),
    .valid_o(valid_o),
    .ready_i(ready_i),
    .adv_o  (adv)
  );
  fxs_side_delay #(.W(SIDE_W), .LATENCY(LATENCY)) u_side (
    .clk_i(clk_i), .adv_i(adv), .d_i(side_i), .q_o(side_o)
  );

  wire signed [CE-1:0] c1 = {(B_S != 0) & c_i[2*B_W-1], c_i[2*B_W-1:B_W]};
  wire signed [CE-1:0] c2 = {(B_S != 0) & c_i[B_W-1], c_i[B_W-1:0]};

  // ---- stage 1 ----------------------------------------------------------------
  reg signed [PW-1:0] pa1_q, pa2_q, pb1_q, pb2_q;
  reg [K-1:0] a3_q, b3_q;
  always @(posedge clk_i) begin
    if (adv) begin
      pa1_q <= c1 * $signed(a_i[2*K-1:K]);
      pa2_q <= c2 * $signed(a_i[K-1:0]);
      pb1_q <= c1 * $signed(b_i[2*K-1:K]);
      pb2_q <= c2 * $signed(b_i[K-1:0]);
      a3_q  <= a_i[3*K-1:2*K];
      b3_q  <= b_i[3*K-1:2*K];
    end
  end

  // ---- stage 2: sums at B_F + K fraction bits, rounded to K, wrapped ----------
  function automatic signed [SW-1:0] sum(input [K-1:0] x3, input signed [PW-1:0] p1,
                                         input signed [PW-1:0] p2);
    sum = ($signed({{(SW - K){1'b0}}, x3}) <<< B_F)
        + {{(SW - PW){p1[PW-1]}}, p1} + {{(SW - PW){p2[PW-1]}}, p2};
  endfunction
  wire [K-1:0] an_c, bn_c;
  wire [1:0]   unused_wrap;
  fxs_quant #(.IW(SW), .SHIFT(B_F), .OW(K), .OSIGNED(0), .ROUND(A_R), .SAT(0))
    u_q_a (.x_i(sum(a3_q, pa1_q, pa2_q)), .y_o(an_c), .ovf_o(unused_wrap[1]));
  fxs_quant #(.IW(SW), .SHIFT(B_F), .OW(K), .OSIGNED(0), .ROUND(A_R), .SAT(0))
    u_q_b (.x_i(sum(b3_q, pb1_q, pb2_q)), .y_o(bn_c), .ovf_o(unused_wrap[0]));
  reg [K-1:0] an_q, bn_q;
  always @(posedge clk_i) begin
    if (adv) begin
      an_q <= an_c;
      bn_q <= bn_c;
    end
  end
  assign an_o = an_q;
  assign bn_o = bn_q;
endmodule

`default_nettype wire
