// interp: method C, the normal inside a triangle, per pixel.
//
//   c3   = 1 - c1 - c2                                   (exact)
//   SCHEME 2 (quadratic):
//     w_i  = Q_w(c_i*(2c_i - 1)),  u_ij = Q_w(4*c_i*c_j)  stage 1
//     N    = Q_out(sum w_i*N_i + sum u_ij*N_ij)           stages 2, 3
//   SCHEME 1 (linear): N = Q_out(c1*N1 + c2*N2 + c3*N3)
//
// Quantizes at exactly the model's points (model/src/interp/mod.rs; see
// `fxshade stages`), sums aligned as the model aligns them.
// Latency 3 cycles; one pixel per clock at full throughput. Handshake as in
// normalize.v: ready_o = ~valid_o | ready_i; valid_o is a register.
// Synchronous active-low reset clears the valid bits.
//
// Formats from interp_params.vh (generated per configuration). Ports:
//   c_i   [2*B_W-1:0]   {c1, c2}, barycentric format (B)
//   v_i   [18*V_W-1:0]  {N1, N2, N3, N12, N23, N31}, each {x, y, z}, vertex
//                       format (V); N_ij are the unit midpoint normals
//                       (the paper's M_ij = 4*N_ij: the 4 is a shift here)
//   n_o   [3*O_W-1:0]   {x, y, z}, output format (O)
//   ovf_o [1:0]         overflow at {weight (any), out (any component)}
//   side_i, side_o [SIDE_W-1:0]  side data carried in lock-step (fxs_side_delay)
`default_nettype none

module interp #(
  parameter integer SIDE_W = 1
) (
  input  wire              clk_i,
  input  wire              rst_ni,
  input  wire              valid_i,
  output wire              ready_o,
  input  wire [2*B_W-1:0]  c_i,
  input  wire [18*V_W-1:0] v_i,
  output wire              valid_o,
  input  wire              ready_i,
  output wire [3*O_W-1:0]  n_o,
  output wire [1:0]        ovf_o,
  input  wire [SIDE_W-1:0] side_i,
  output wire [SIDE_W-1:0] side_o
);
  `include "interp_params.vh"

  localparam integer LATENCY = 3;
  localparam integer NT = (SCHEME == 2) ? 6 : 3;   // terms per component
  localparam integer CE = B_W + 2;                 // c, with room for c3 < 0
  localparam integer VE = V_W + 1;
  // Weights: quantized (quadratic) or the barycentrics themselves (linear).
  localparam integer WE = (SCHEME == 2) ? W_W + 1 : CE;
  localparam integer WF = (SCHEME == 2) ? W_F : B_F;
  localparam integer PW = WE + VE;                 // one product
  localparam integer SW = PW + 3;                  // a sum of up to 6

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

  // ---- stage 1: c3 and the weights -----------------------------------------
  wire signed [CE-1:0] one = {{(CE - B_F - 1){1'b0}}, 1'b1, {B_F{1'b0}}};
  wire signed [CE-1:0] c1 = {{(CE - B_W){(B_S != 0) & c_i[2*B_W-1]}}, c_i[2*B_W-1:B_W]};
  wire signed [CE-1:0] c2 = {{(CE - B_W){(B_S != 0) & c_i[B_W-1]}}, c_i[B_W-1:0]};
  wire signed [CE-1:0] c3 = one - c1 - c2;
  wire signed [CE-1:0] c [0:2];
  assign c[0] = c1;
  assign c[1] = c2;
  assign c[2] = c3;

  reg  [WE*6-1:0]    w_q;
  reg  [18*V_W-1:0]  vv_q;
  reg                w_ovf_q;
  wire [WE*6-1:0]    w_c;
  wire               w_ovf;

  genvar gi;
  generate
    if (SCHEME == 2) begin : g_quadratic
      wire [5:0] ovf_k;
      for (gi = 0; gi < 3; gi = gi + 1) begin : g_vertex
        // c_i*(2c_i - 1), exact at 2*B_F fraction bits.
        wire signed [CE:0]        e = {c[gi], 1'b0} - {one[CE-1], one};
        wire signed [2*CE:0]      p = c[gi] * e;
        wire [W_W-1:0]            q;
        fxs_quant #(.IW(2 * CE + 1), .SHIFT(2 * B_F - W_F), .OW(W_W), .OSIGNED(W_S), .ROUND(W_R), .SAT(W_SAT))
          u_q (.x_i(p), .y_o(q), .ovf_o(ovf_k[gi]));
        assign w_c[WE*gi +: WE] = {(W_S != 0) & q[W_W-1], q};
      end
      for (gi = 0; gi < 3; gi = gi + 1) begin : g_edge
        // 4*c_i*c_j: the product at 2*B_F fraction bits, read at 2*B_F - 2.
        wire signed [2*CE-1:0] p = c[gi] * c[(gi + 1) % 3];
        wire [W_W-1:0]         q;
        fxs_quant #(.IW(2 * CE), .SHIFT(2 * B_F - 2 - W_F), .OW(W_W), .OSIGNED(W_S), .ROUND(W_R), .SAT(W_SAT))
          u_q (.x_i(p), .y_o(q), .ovf_o(ovf_k[3 + gi]));
        assign w_c[WE*(3+gi) +: WE] = {(W_S != 0) & q[W_W-1], q};
      end
      assign w_ovf = |ovf_k;
    end else begin : g_linear
      assign w_c = {{(3 * WE){1'b0}}, c[2], c[1], c[0]};
      assign w_ovf = 1'b0;
    end
  endgenerate

  always @(posedge clk_i) begin
    if (adv) begin
      w_q     <= w_c;
      vv_q    <= v_i;
      w_ovf_q <= w_ovf;
    end
  end

  // ---- stage 2: products w_k * V_k -------------------------------------------
  // Vector k, component j (0 = x) sits at v_i[V_W*(3*(5-k) + (2-j)) +: V_W].
  reg  [PW*18-1:0] p_q;
  reg              w_ovf2_q;
  genvar gk, gj;
  generate
    for (gk = 0; gk < 6; gk = gk + 1) begin : g_term
      for (gj = 0; gj < 3; gj = gj + 1) begin : g_comp
        wire [V_W-1:0]       vc = vv_q[V_W*(3*(5-gk) + (2-gj)) +: V_W];
        wire signed [VE-1:0] vs = {(V_S != 0) & vc[V_W-1], vc};
        wire signed [WE-1:0] ws = w_q[WE*gk +: WE];
        if (gk < NT) begin : g_used
          always @(posedge clk_i) begin
            if (adv) p_q[PW*(3*gk+gj) +: PW] <= ws * vs;
          end
        end else begin : g_unused
          always @(posedge clk_i) begin
            if (adv) p_q[PW*(3*gk+gj) +: PW] <= {PW{1'b0}};
          end
          wire unused_term = ^{ws, vs};
        end
      end
    end
  endgenerate
  always @(posedge clk_i) begin
    if (adv) w_ovf2_q <= w_ovf_q;
  end

  // ---- stage 3: sums, quantized to the output format ------------------------
  wire [O_W-1:0] o_c [0:2];
  wire [2:0]     o_ovf;
  generate
    for (gj = 0; gj < 3; gj = gj + 1) begin : g_sum
      wire signed [SW-1:0] s [0:5];
      for (gk = 0; gk < 6; gk = gk + 1) begin : g_ext
        wire signed [PW-1:0] pk = p_q[PW*(3*gk+gj) +: PW];
        assign s[gk] = {{3{pk[PW-1]}}, pk};
      end
      wire signed [SW-1:0] acc = (SCHEME == 2) ? (s[0] + s[1] + s[2] + s[3] + s[4] + s[5])
                                               : (s[0] + s[1] + s[2]);
      fxs_quant #(.IW(SW), .SHIFT(WF + V_F - O_F), .OW(O_W), .OSIGNED(O_S), .ROUND(O_R), .SAT(O_SAT))
        u_q (.x_i(acc), .y_o(o_c[gj]), .ovf_o(o_ovf[gj]));
    end
  endgenerate

  reg [3*O_W-1:0] out_q;
  reg [1:0]       ovf_q;
  always @(posedge clk_i) begin
    if (adv) begin
      out_q <= {o_c[0], o_c[1], o_c[2]};
      ovf_q <= {w_ovf2_q, |o_ovf};
    end
  end
  assign n_o   = out_q;
  assign ovf_o = ovf_q;
endmodule

`default_nettype wire
