// polar: method B, L (or H) into the tangent frame of N by polar angles.
//
//   stage 1  i_aL = Q_idx(aL), i_d = Q_idx(bL - bN), i_aN = Q_idx(aN)  (mod a turn)
//   stage 2  six table reads: cos/sin of aL, of bL - bN, of aN
//   stage 3  Lyz = Q_lyz(cos aL * cos d);  L'x = Q_out(cos aL * sin d)
//   stage 4  L'y = Q_out(sin aL * cos aN - Lyz * sin aN)
//            L'z = Q_out(sin aL * sin aN + Lyz * cos aN)
// 6 multiplications, 3 additions, 6 table reads (model/src/polar; see
// `fxshade stages`). The six reads use six single-port ROM copies
// (fxs_sincos_rom), one per read, so a vector enters every clock; three
// dual-port ROMs would do the same.
// Latency 4 cycles; handshake as in normalize.v (ready_o = ~valid_o | ready_i;
// valid_o is a register); synchronous active-low reset clears the valid bits.
//
// Formats from polar_params.vh (generated per configuration). Ports:
//   a_i   [4*K-1:0]  {aL, bL, aN, bN}: unsigned fractions of a turn (U0F<K>);
//                    elevations a in [-1/4, 1/4] turn as codes modulo a turn
//   l_o   [3*O_W-1:0] {L'x, L'y, L'z} in the out format
//   ovf_o [1:0]      overflow at {lyz, out (any component)}
//   side_i, side_o [SIDE_W-1:0]  side data carried in lock-step (fxs_side_delay)
`default_nettype none

module polar #(
  parameter integer SIDE_W = 1
) (
  input  wire             clk_i,
  input  wire             rst_ni,
  input  wire             valid_i,
  output wire             ready_o,
  input  wire [4*K-1:0]   a_i,
  output wire             valid_o,
  input  wire             ready_i,
  output wire [3*O_W-1:0] l_o,
  output wire [1:0]       ovf_o,
  input  wire [SIDE_W-1:0] side_i,
  output wire [SIDE_W-1:0] side_o
);
  `include "polar_params.vh"

  localparam integer LATENCY = 4;
  localparam integer EE = E_W + 1;    // table values, sign-extended
  localparam integer YE = Y_W + 1;

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

  // ---- stage 1: table indices (wrapping) ------------------------------------
  wire [K-1:0] al = a_i[4*K-1:3*K];
  wire [K-1:0] bl = a_i[3*K-1:2*K];
  wire [K-1:0] an = a_i[2*K-1:K];
  wire [K-1:0] bn = a_i[K-1:0];
  wire signed [K:0] d = {1'b0, bl} - {1'b0, bn};
  wire [T-1:0] i_al_c, i_d_c, i_an_c;
  wire [2:0] unused_idx_wrap;
  fxs_quant #(.IW(K + 1), .SHIFT(K - T), .OW(T), .OSIGNED(0), .ROUND(I_R), .SAT(0))
    u_i_al (.x_i({1'b0, al}), .y_o(i_al_c), .ovf_o(unused_idx_wrap[2]));
  fxs_quant #(.IW(K + 1), .SHIFT(K - T), .OW(T), .OSIGNED(0), .ROUND(I_R), .SAT(0))
    u_i_d (.x_i(d), .y_o(i_d_c), .ovf_o(unused_idx_wrap[1]));
  fxs_quant #(.IW(K + 1), .SHIFT(K - T), .OW(T), .OSIGNED(0), .ROUND(I_R), .SAT(0))
    u_i_an (.x_i({1'b0, an}), .y_o(i_an_c), .ovf_o(unused_idx_wrap[0]));
  reg [T-1:0] i_al_q, i_d_q, i_an_q;
  always @(posedge clk_i) begin
    if (adv) begin
      i_al_q <= i_al_c;
      i_d_q  <= i_d_c;
      i_an_q <= i_an_c;
    end
  end

  // ---- stage 2: six table reads ---------------------------------------------
  wire [E_W-1:0] c_al_c, s_al_c, c_d_c, s_d_c, c_an_c, s_an_c;
  fxs_sincos_rom #(.T(T), .W(E_W), .QUARTER(QUARTER), .COS(1)) u_c_al (.idx_i(i_al_q), .val_o(c_al_c));
  fxs_sincos_rom #(.T(T), .W(E_W), .QUARTER(QUARTER), .COS(0)) u_s_al (.idx_i(i_al_q), .val_o(s_al_c));
  fxs_sincos_rom #(.T(T), .W(E_W), .QUARTER(QUARTER), .COS(1)) u_c_d  (.idx_i(i_d_q),  .val_o(c_d_c));
  fxs_sincos_rom #(.T(T), .W(E_W), .QUARTER(QUARTER), .COS(0)) u_s_d  (.idx_i(i_d_q),  .val_o(s_d_c));
  fxs_sincos_rom #(.T(T), .W(E_W), .QUARTER(QUARTER), .COS(1)) u_c_an (.idx_i(i_an_q), .val_o(c_an_c));
  fxs_sincos_rom #(.T(T), .W(E_W), .QUARTER(QUARTER), .COS(0)) u_s_an (.idx_i(i_an_q), .val_o(s_an_c));
  reg [E_W-1:0] c_al_q, s_al_q, c_d_q, s_d_q, c_an_q, s_an_q;
  always @(posedge clk_i) begin
    if (adv) begin
      c_al_q <= c_al_c;
      s_al_q <= s_al_c;
      c_d_q  <= c_d_c;
      s_d_q  <= s_d_c;
      c_an_q <= c_an_c;
      s_an_q <= s_an_c;
    end
  end
  wire signed [EE-1:0] c_al = {(E_S != 0) & c_al_q[E_W-1], c_al_q};
  wire signed [EE-1:0] c_d  = {(E_S != 0) & c_d_q[E_W-1], c_d_q};
  wire signed [EE-1:0] s_d  = {(E_S != 0) & s_d_q[E_W-1], s_d_q};

  // ---- stage 3: Lyz, L'x and the products of sin aL -------------------------
  localparam integer PW = 2 * EE;
  wire signed [PW-1:0] p_lyz = c_al * c_d;
  wire signed [PW-1:0] p_x   = c_al * s_d;
  wire [Y_W-1:0] lyz_c;
  wire [O_W-1:0] x_c;
  wire lyz_ovf, x_ovf;
  fxs_quant #(.IW(PW), .SHIFT(2 * E_F - Y_F), .OW(Y_W), .OSIGNED(Y_S), .ROUND(Y_R), .SAT(Y_SAT))
    u_q_lyz (.x_i(p_lyz), .y_o(lyz_c), .ovf_o(lyz_ovf));
  fxs_quant #(.IW(PW), .SHIFT(2 * E_F - O_F), .OW(O_W), .OSIGNED(O_S), .ROUND(O_R), .SAT(O_SAT))
    u_q_x (.x_i(p_x), .y_o(x_c), .ovf_o(x_ovf));
  reg [Y_W-1:0] lyz_q;
  reg [O_W-1:0] x_q;
  reg           lyz_ovf_q, x_ovf_q;
  reg [E_W-1:0] s_al3_q, c_an3_q, s_an3_q;
  always @(posedge clk_i) begin
    if (adv) begin
      lyz_q     <= lyz_c;
      x_q       <= x_c;
      lyz_ovf_q <= lyz_ovf;
      x_ovf_q   <= x_ovf;
      s_al3_q   <= s_al_q;
      c_an3_q   <= c_an_q;
      s_an3_q   <= s_an_q;
    end
  end

  // ---- stage 4: L'y, L'z ---------------------------------------------------------
  wire signed [EE-1:0] s_al3 = {(E_S != 0) & s_al3_q[E_W-1], s_al3_q};
  wire signed [EE-1:0] c_an  = {(E_S != 0) & c_an3_q[E_W-1], c_an3_q};
  wire signed [EE-1:0] s_an  = {(E_S != 0) & s_an3_q[E_W-1], s_an3_q};
  wire signed [YE-1:0] lyz   = {(Y_S != 0) & lyz_q[Y_W-1], lyz_q};
  // L'y = Q(sin aL*cos aN - Lyz*sin aN), L'z = Q(sin aL*sin aN + Lyz*cos aN):
  // the sin*cos product enters each multiply-add as its addend.
  wire signed [PW-1:0] pa_y = s_al3 * c_an;
  wire signed [PW-1:0] pa_z = s_al3 * s_an;
  wire [O_W-1:0] y_c, z_c;
  wire y_ovf, z_ovf;
  fxs_mad_q #(.AW(YE), .FA(Y_F), .BW(EE), .FB(E_F), .CW(PW), .FC(2 * E_F), .SUB(1),
              .OW(O_W), .OF(O_F), .OSIGNED(O_S), .ROUND(O_R), .SAT(O_SAT))
    u_y (.a_i(lyz), .b_i(s_an), .c_i(pa_y), .y_o(y_c), .ovf_o(y_ovf));
  fxs_mad_q #(.AW(YE), .FA(Y_F), .BW(EE), .FB(E_F), .CW(PW), .FC(2 * E_F), .SUB(0),
              .OW(O_W), .OF(O_F), .OSIGNED(O_S), .ROUND(O_R), .SAT(O_SAT))
    u_z (.a_i(lyz), .b_i(c_an), .c_i(pa_z), .y_o(z_c), .ovf_o(z_ovf));
  reg [3*O_W-1:0] out_q;
  reg [1:0]       ovf_q;
  always @(posedge clk_i) begin
    if (adv) begin
      out_q <= {x_q, y_c, z_c};
      ovf_q <= {lyz_ovf_q, x_ovf_q | y_ovf | z_ovf};
    end
  end
  assign l_o   = out_q;
  assign ovf_o = ovf_q;
endmodule

`default_nettype wire
