// pipeline: the per-pixel shading pipeline, one pixel per clock, chaining
// the unit modules with valid/ready (model: model/src/pipeline/mod.rs).
//
// PATH 0, smooth (methods C and A):
//   interp -> Q(normalize.normal) -> normalize[sel] -> Q(lighting.normal) -> lighting
//   pix_i = {sel, c1, c2, N1, N2, N3, N12, N23, N31 (x, y, z each), L, H}
// PATH 1, mapped (method B):
//   angle_interp -> polar (L) and polar (H), in lock-step
//                -> Q(lighting.light) -> lighting, with the normal-map texel
//   pix_i = {c1, c2, a3, da1, da2, b3, db1, db2, aL, bL, aH, bH, nx, ny, nz}
// Side data (sel, L, H; the texel and H's angles) travels through each unit
// in lock-step with its pixel (fxs_side_delay). Between units, fxs_quant
// converts one unit's output format to the next unit's input format, as the
// model's port quantizations do (wires when the formats agree).
//
// Handshake: each unit's ready_o = ~valid_o | ready_i, so a stall at
// ready_i holds every unit; valid_o comes from the last unit's register.
//
// Formats from pipeline_params.vh; each unit reads its own <unit>_params.vh
// (all generated together by `fxshade vectors pipeline`). Ports:
//   pix_i   [PIX_W-1:0]  the pixel's fields above, most significant first
//   level_o [LV_W-1:0]   the shaded level (lighting level format)
`default_nettype none

module pipeline (
  input  wire             clk_i,
  input  wire             rst_ni,
  input  wire             valid_i,
  output wire             ready_o,
  input  wire [PIX_W-1:0] pix_i,
  output wire             valid_o,
  input  wire             ready_i,
  output wire [LV_W-1:0]  level_o
);
  `include "pipeline_params.vh"

  generate
    if (PATH == 0) begin : g_smooth
      // ---- unpack ------------------------------------------------------------
      localparam integer LH = 6 * LL_W;
      wire [SEL_W-1:0]  sel = pix_i[PIX_W-1 -: SEL_W];
      wire [2*B_W-1:0]  cc  = pix_i[PIX_W-SEL_W-1 -: 2*B_W];
      wire [18*V_W-1:0] vv  = pix_i[LH + 18*V_W - 1 -: 18*V_W];
      wire [LH-1:0]     lh  = pix_i[LH-1:0];

      // ---- interp --------------------------------------------------------------
      wire              i_valid, i_ready;
      wire [3*IO_W-1:0] i_n;
      wire [1:0]        unused_i_ovf;
      wire [SEL_W+LH-1:0] i_side;
      interp #(.SIDE_W(SEL_W + LH)) u_interp (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(valid_i),
        .ready_o(ready_o),
        .c_i    (cc),
        .v_i    (vv),
        .valid_o(i_valid),
        .ready_i(i_ready),
        .n_o    (i_n),
        .ovf_o  (unused_i_ovf),
        .side_i ({sel, lh}),
        .side_o (i_side)
      );

      // ---- interp.out -> normalize.normal ---------------------------------------
      wire [3*NN_W-1:0] n_n;
      wire [2:0]        unused_c1_ovf;
      genvar gc;
      for (gc = 0; gc < 3; gc = gc + 1) begin : g_c1
        wire [IO_W-1:0] x = i_n[gc*IO_W +: IO_W];
        fxs_quant #(.IW(IO_W + 1), .SHIFT(IO_F - NN_F), .OW(NN_W), .OSIGNED(NN_S), .ROUND(NN_R), .SAT(NN_SAT))
          u_q (.x_i({(IO_S != 0) & x[IO_W-1], x}), .y_o(n_n[gc*NN_W +: NN_W]), .ovf_o(unused_c1_ovf[gc]));
      end

      // ---- normalize -------------------------------------------------------------
      wire              n_valid, n_ready;
      wire [3*NO_W-1:0] n_out;
      wire [3:0]        unused_n_ovf;
      wire [LH-1:0]     n_side;
      normalize #(.SIDE_W(LH)) u_normalize (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(i_valid),
        .ready_o(i_ready),
        .n_i    (n_n),
        .valid_o(n_valid),
        .ready_i(n_ready),
        .n_o    (n_out),
        .ovf_o  (unused_n_ovf),
        .sel_i  (i_side[SEL_W+LH-1 -: SEL_W]),
        .side_i (i_side[LH-1:0]),
        .side_o (n_side)
      );

      // ---- normalize.out -> lighting.normal ---------------------------------------
      wire [3*LN_W-1:0] l_n;
      wire [2:0]        unused_c2_ovf;
      for (gc = 0; gc < 3; gc = gc + 1) begin : g_c2
        wire [NO_W-1:0] x = n_out[gc*NO_W +: NO_W];
        fxs_quant #(.IW(NO_W + 1), .SHIFT(NO_F - LN_F), .OW(LN_W), .OSIGNED(LN_S), .ROUND(LN_R), .SAT(LN_SAT))
          u_q (.x_i({(NO_S != 0) & x[NO_W-1], x}), .y_o(l_n[gc*LN_W +: LN_W]), .ovf_o(unused_c2_ovf[gc]));
      end

      // ---- lighting ----------------------------------------------------------------
      lighting u_lighting (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(n_valid),
        .ready_o(n_ready),
        .n_i    (l_n),
        .l_i    (n_side[LH-1:3*LL_W]),
        .h_i    (n_side[3*LL_W-1:0]),
        .valid_o(valid_o),
        .ready_i(ready_i),
        .level_o(level_o)
      );
    end else begin : g_mapped
      // ---- unpack ------------------------------------------------------------
      localparam integer NW = 3 * LN_W;
      wire [2*B_W-1:0] cc  = pix_i[PIX_W-1 -: 2*B_W];
      wire [3*K-1:0]   aa  = pix_i[PIX_W-2*B_W-1 -: 3*K];
      wire [3*K-1:0]   bb  = pix_i[PIX_W-2*B_W-3*K-1 -: 3*K];
      wire [4*K-1:0]   lhk = pix_i[NW + 4*K - 1 -: 4*K];
      wire [NW-1:0]    tex = pix_i[NW-1:0];

      // ---- angle_interp --------------------------------------------------------
      wire           a_valid, a_ready;
      wire [K-1:0]   an, bn;
      wire [4*K+NW-1:0] a_side;
      angle_interp #(.B_W(B_W), .B_F(B_F), .B_S(B_S), .K(K), .A_R(A_R), .SIDE_W(4*K + NW)) u_angles (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(valid_i),
        .ready_o(ready_o),
        .c_i    (cc),
        .a_i    (aa),
        .b_i    (bb),
        .valid_o(a_valid),
        .ready_i(a_ready),
        .an_o   (an),
        .bn_o   (bn),
        .side_i ({lhk, tex}),
        .side_o (a_side)
      );

      // ---- polar (L carries the texel), polar (H) in lock-step -------------------
      wire              p_valid, l_ready;
      wire [3*PO_W-1:0] lp, hp;
      wire [1:0]        unused_pl_ovf, unused_ph_ovf;
      wire [NW-1:0]     p_tex;
      wire              unused_ph_valid, unused_ph_ready, unused_ph_side;
      polar #(.SIDE_W(NW)) u_polar_l (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(a_valid),
        .ready_o(a_ready),
        .a_i    ({a_side[4*K+NW-1 -: 2*K], an, bn}),
        .valid_o(p_valid),
        .ready_i(l_ready),
        .l_o    (lp),
        .ovf_o  (unused_pl_ovf),
        .side_i (a_side[NW-1:0]),
        .side_o (p_tex)
      );
      polar #(.SIDE_W(1)) u_polar_h (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(a_valid),
        .ready_o(unused_ph_ready),
        .a_i    ({a_side[2*K+NW-1 -: 2*K], an, bn}),
        .valid_o(unused_ph_valid),
        .ready_i(l_ready),
        .l_o    (hp),
        .ovf_o  (unused_ph_ovf),
        .side_i (1'b0),
        .side_o (unused_ph_side)
      );

      // ---- polar.out -> lighting.light -----------------------------------------
      wire [6*LL_W-1:0] lh_q;
      wire [5:0]        unused_c_ovf;
      wire [6*PO_W-1:0] lhp = {lp, hp};
      genvar gc;
      for (gc = 0; gc < 6; gc = gc + 1) begin : g_c
        wire [PO_W-1:0] x = lhp[gc*PO_W +: PO_W];
        fxs_quant #(.IW(PO_W + 1), .SHIFT(PO_F - LL_F), .OW(LL_W), .OSIGNED(LL_S), .ROUND(LL_R), .SAT(LL_SAT))
          u_q (.x_i({(PO_S != 0) & x[PO_W-1], x}), .y_o(lh_q[gc*LL_W +: LL_W]), .ovf_o(unused_c_ovf[gc]));
      end

      // ---- lighting ----------------------------------------------------------------
      lighting u_lighting (
        .clk_i  (clk_i),
        .rst_ni (rst_ni),
        .valid_i(p_valid),
        .ready_o(l_ready),
        .n_i    (p_tex),
        .l_i    (lh_q[6*LL_W-1:3*LL_W]),
        .h_i    (lh_q[3*LL_W-1:0]),
        .valid_o(valid_o),
        .ready_i(ready_i),
        .level_o(level_o)
      );
    end
  endgenerate
endmodule

`default_nettype wire
