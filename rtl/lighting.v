// lighting: diffuse and Blinn-Phong specular as an 8-bit level.
//
//   stage 1       dl = max(Q_dot(N.L), 0), dh = max(Q_dot(N.H), 0),
//                 base = Q_spec(dh)                                (registered)
//   stages 2..    one per bit k of the exponent SHIN, LSB first:
//                 acc  = bit k ? (an earlier bit set ? Q_spec(acc*base) : base) : acc
//                 base = Q_spec(base*base)   (not after the last bit)
//   last          level = Q_level(dl*GAIN_D + acc*GAIN_S)          (registered)
//
// Quantizes at exactly the model's points (model/src/lighting.rs,
// Lighting::shade; see `fxshade stages`). Latency NB + 2 cycles (NB = bit
// length of SHIN); one pixel per clock. Handshake as in normalize.v.
//
// Formats from lighting_params.vh (generated per configuration). Ports:
//   n_i     [3*LN_W-1:0]  {Nx, Ny, Nz}, lighting normal format (LN)
//   l_i     [3*LL_W-1:0]  {Lx, Ly, Lz}, lighting light format (LL)
//   h_i     [3*LL_W-1:0]  {Hx, Hy, Hz}, light format
//   level_o [LV_W-1:0]    the level, level format (LV, U8F0 by default)
`default_nettype none

module lighting (
  input  wire              clk_i,
  input  wire              rst_ni,
  input  wire              valid_i,
  output wire              ready_o,
  input  wire [3*LN_W-1:0] n_i,
  input  wire [3*LL_W-1:0] l_i,
  input  wire [3*LL_W-1:0] h_i,
  output wire              valid_o,
  input  wire              ready_i,
  output wire [LV_W-1:0]   level_o
);
  `include "lighting_params.vh"

  localparam integer LATENCY = NB + 2;
  localparam integer NE = LN_W + 1;
  localparam integer LE = LL_W + 1;
  localparam integer PW = NE + LE;          // one product
  localparam integer SW = PW + 2;           // a sum of three
  localparam integer DE = DT_W + 1;
  localparam integer SE = SP_W + 1;
  localparam integer GE = GN_W + 1;

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

  function automatic signed [NE-1:0] ext_n(input [LN_W-1:0] c);
    ext_n = {(LN_S != 0) & c[LN_W-1], c};
  endfunction
  function automatic signed [LE-1:0] ext_l(input [LL_W-1:0] c);
    ext_l = {(LL_S != 0) & c[LL_W-1], c};
  endfunction
  function automatic signed [DE-1:0] ext_d(input [DT_W-1:0] c);
    ext_d = {(DT_S != 0) & c[DT_W-1], c};
  endfunction
  function automatic signed [SE-1:0] ext_s(input [SP_W-1:0] c);
    ext_s = {(SP_S != 0) & c[SP_W-1], c};
  endfunction
  function automatic signed [SW-1:0] dot(input [3*LN_W-1:0] n, input [3*LL_W-1:0] v);
    reg signed [PW-1:0] x, y, z;
    begin
      x = ext_n(n[3*LN_W-1:2*LN_W]) * ext_l(v[3*LL_W-1:2*LL_W]);
      y = ext_n(n[2*LN_W-1:LN_W]) * ext_l(v[2*LL_W-1:LL_W]);
      z = ext_n(n[LN_W-1:0]) * ext_l(v[LL_W-1:0]);
      dot = {{2{x[PW-1]}}, x} + {{2{y[PW-1]}}, y} + {{2{z[PW-1]}}, z};
    end
  endfunction

  // ---- stage 1: the two dot products, clamped at zero; Q_spec(dh) -----------
  wire [DT_W-1:0] dl_c, dh_c;
  wire [1:0]      unused_dot_ovf;
  fxs_quant #(.IW(SW), .SHIFT(LN_F + LL_F - DT_F), .OW(DT_W), .OSIGNED(DT_S), .ROUND(DT_R), .SAT(DT_SAT))
    u_q_dl (.x_i(dot(n_i, l_i)), .y_o(dl_c), .ovf_o(unused_dot_ovf[1]));
  fxs_quant #(.IW(SW), .SHIFT(LN_F + LL_F - DT_F), .OW(DT_W), .OSIGNED(DT_S), .ROUND(DT_R), .SAT(DT_SAT))
    u_q_dh (.x_i(dot(n_i, h_i)), .y_o(dh_c), .ovf_o(unused_dot_ovf[0]));
  // max(d, 0): one comparator and a multiplexer each, as the model counts
  // them (synthesis reduces a comparison with zero to the sign bit).
  wire [DT_W-1:0] dl_m = (ext_d(dl_c) > $signed({DE{1'b0}})) ? dl_c : {DT_W{1'b0}};
  wire [DT_W-1:0] dh_m = (ext_d(dh_c) > $signed({DE{1'b0}})) ? dh_c : {DT_W{1'b0}};
  wire [SP_W-1:0] b0_c;
  wire            unused_b0_ovf;
  fxs_quant #(.IW(DE), .SHIFT(DT_F - SP_F), .OW(SP_W), .OSIGNED(SP_S), .ROUND(SP_R), .SAT(SP_SAT))
    u_q_b0 (.x_i(ext_d(dh_m)), .y_o(b0_c), .ovf_o(unused_b0_ovf));

  // Stage k of the power chain reads base_w[k], acc_w[k], dl_w[k].
  wire [SP_W-1:0] base_w [0:NB];
  wire [SP_W-1:0] acc_w  [0:NB];
  wire [DT_W-1:0] dl_w   [0:NB];
  reg  [SP_W-1:0] base0_q;
  reg  [DT_W-1:0] dl0_q;
  always @(posedge clk_i) begin
    if (adv) begin
      base0_q <= b0_c;
      dl0_q   <= dl_m;
    end
  end
  assign base_w[0] = base0_q;
  assign acc_w[0]  = {SP_W{1'b0}};
  assign dl_w[0]   = dl0_q;

  // ---- stages 2 .. NB+1: square and multiply ---------------------------------
  genvar gk;
  generate
    for (gk = 0; gk < NB; gk = gk + 1) begin : g_pow
      localparam integer BIT  = (SHIN >> gk) & 1;
      localparam integer HAVE = ((SHIN & ((1 << gk) - 1)) != 0) ? 1 : 0;
      wire signed [SE-1:0] bs = ext_s(base_w[gk]);
      wire [SP_W-1:0] acc_n;
      if (BIT != 0 && HAVE != 0) begin : g_mul
        wire signed [2*SE-1:0] p = ext_s(acc_w[gk]) * bs;
        wire unused_ovf;
        fxs_quant #(.IW(2 * SE), .SHIFT(SP_F), .OW(SP_W), .OSIGNED(SP_S), .ROUND(SP_R), .SAT(SP_SAT))
          u_q (.x_i(p), .y_o(acc_n), .ovf_o(unused_ovf));
      end else if (BIT != 0) begin : g_first
        assign acc_n = base_w[gk];
        wire unused_acc = ^acc_w[gk];
      end else begin : g_keep
        assign acc_n = acc_w[gk];
      end
      reg [SP_W-1:0] acc_q;
      reg [DT_W-1:0] dl_q;
      always @(posedge clk_i) begin
        if (adv) begin
          acc_q <= acc_n;
          dl_q  <= dl_w[gk];
        end
      end
      assign acc_w[gk+1] = acc_q;
      assign dl_w[gk+1]  = dl_q;
      if (gk < NB - 1) begin : g_square
        wire signed [2*SE-1:0] sq = bs * bs;
        wire [SP_W-1:0] base_n;
        wire unused_ovf;
        fxs_quant #(.IW(2 * SE), .SHIFT(SP_F), .OW(SP_W), .OSIGNED(SP_S), .ROUND(SP_R), .SAT(SP_SAT))
          u_q (.x_i(sq), .y_o(base_n), .ovf_o(unused_ovf));
        reg [SP_W-1:0] base_q;
        always @(posedge clk_i) begin
          if (adv) base_q <= base_n;
        end
        assign base_w[gk+1] = base_q;
      end else begin : g_last
        assign base_w[gk+1] = {SP_W{1'b0}};
        wire unused_base = ^{bs, base_w[gk+1]};
      end
    end
  endgenerate

  // ---- last stage: level = Q_level(dl*GAIN_D + acc*GAIN_S) --------------------
  localparam [GN_W-1:0] GD = GAIN_D;
  localparam [GN_W-1:0] GS = GAIN_S;
  wire signed [GE-1:0] gd = {(GN_S != 0) & GD[GN_W-1], GD};
  wire signed [GE-1:0] gs = {(GN_S != 0) & GS[GN_W-1], GS};
  wire signed [DE+GE-1:0] pd = ext_d(dl_w[NB]) * gd;
  wire [LV_W-1:0] level_c;
  wire            unused_level_ovf;
  fxs_mad_q #(.AW(SE), .FA(SP_F), .BW(GE), .FB(GN_F), .CW(DE + GE), .FC(DT_F + GN_F), .SUB(0),
              .OW(LV_W), .OF(LV_F), .OSIGNED(LV_S), .ROUND(LV_R), .SAT(LV_SAT))
    u_level (.a_i(ext_s(acc_w[NB])), .b_i(gs), .c_i(pd), .y_o(level_c), .ovf_o(unused_level_ovf));
  reg [LV_W-1:0] level_q;
  always @(posedge clk_i) begin
    if (adv) level_q <= level_c;
  end
  assign level_o = level_q;
endmodule

`default_nettype wire
