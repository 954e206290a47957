// Behavioural model of the Lattice ECP5 MULT18X18D, for gate-level
// simulation of a netlist that `fxshade synth --target ecp5` packed
// (src/dsp_pack.rs). Yosys ships the block only as a black box
// (cells_bb.v); this model covers what Yosys's mapping and the packer use:
//
//   P = A * B, 36 bits, each operand signed when SIGNEDA / SIGNEDB is 1;
//   operand registers (REG_INPUTA_CLK, REG_INPUTB_CLK), the pipeline
//   register (REG_PIPELINE_CLK) and the output register (REG_OUTPUT_CLK),
//   each "NONE" (combinational) or "CLK0", with its clock enable chosen by
//   REG_*_CE ("CE0".."CE3") and its synchronous reset by REG_*_RST
//   ("RST0".."RST3"); registers power up to 0.
//
// SIGNEDA and SIGNEDB are registered with their operands; SIGNEDP is not
// pipelined (Yosys leaves it unused). SOURCEA/SOURCEB (shifting operands
// in from a neighbour; Yosys ties them to 0), the cascade outputs and the
// C input are not modelled. A register setting the model does not know
// (CLK1..CLK3, asynchronous reset, a registered C, MULT_BYPASS) stops the
// simulation with a message, and so does an output register on any enable
// but CE0: nextpnr writes no REG_OUTPUT_CE to the bitstream, so the
// block's own default, CE0, is what the hardware uses.
`default_nettype none

module MULT18X18D (
  input  wire A0, A1, A2, A3, A4, A5, A6, A7, A8, A9, A10, A11, A12, A13, A14, A15, A16, A17,
  input  wire B0, B1, B2, B3, B4, B5, B6, B7, B8, B9, B10, B11, B12, B13, B14, B15, B16, B17,
  input  wire C0, C1, C2, C3, C4, C5, C6, C7, C8, C9, C10, C11, C12, C13, C14, C15, C16, C17,
  input  wire SIGNEDA, SIGNEDB, SOURCEA, SOURCEB,
  input  wire CLK0, CLK1, CLK2, CLK3,
  input  wire CE0, CE1, CE2, CE3,
  input  wire RST0, RST1, RST2, RST3,
  input  wire SRIA0, SRIA1, SRIA2, SRIA3, SRIA4, SRIA5, SRIA6, SRIA7, SRIA8, SRIA9, SRIA10, SRIA11,
      SRIA12, SRIA13, SRIA14, SRIA15, SRIA16, SRIA17,
  input  wire SRIB0, SRIB1, SRIB2, SRIB3, SRIB4, SRIB5, SRIB6, SRIB7, SRIB8, SRIB9, SRIB10, SRIB11,
      SRIB12, SRIB13, SRIB14, SRIB15, SRIB16, SRIB17,
  output wire SROA0, SROA1, SROA2, SROA3, SROA4, SROA5, SROA6, SROA7, SROA8, SROA9, SROA10, SROA11,
      SROA12, SROA13, SROA14, SROA15, SROA16, SROA17,
  output wire SROB0, SROB1, SROB2, SROB3, SROB4, SROB5, SROB6, SROB7, SROB8, SROB9, SROB10, SROB11,
      SROB12, SROB13, SROB14, SROB15, SROB16, SROB17,
  output wire ROA0, ROA1, ROA2, ROA3, ROA4, ROA5, ROA6, ROA7, ROA8, ROA9, ROA10, ROA11, ROA12,
      ROA13, ROA14, ROA15, ROA16, ROA17,
  output wire ROB0, ROB1, ROB2, ROB3, ROB4, ROB5, ROB6, ROB7, ROB8, ROB9, ROB10, ROB11, ROB12,
      ROB13, ROB14, ROB15, ROB16, ROB17,
  output wire ROC0, ROC1, ROC2, ROC3, ROC4, ROC5, ROC6, ROC7, ROC8, ROC9, ROC10, ROC11, ROC12,
      ROC13, ROC14, ROC15, ROC16, ROC17,
  output wire P0, P1, P2, P3, P4, P5, P6, P7, P8, P9, P10, P11, P12, P13, P14, P15, P16, P17, P18,
      P19, P20, P21, P22, P23, P24, P25, P26, P27, P28, P29, P30, P31, P32, P33, P34, P35,
  output wire SIGNEDP
);
  // The block's parameters, every one a netlist may set; those the model
  // does not read are here so that setting them is not an error.
  /* verilator lint_off UNUSEDPARAM */
  parameter [127:0] REG_INPUTA_CLK = "NONE";
  parameter [127:0] REG_INPUTA_CE = "CE0";
  parameter [127:0] REG_INPUTA_RST = "RST0";
  parameter [127:0] REG_INPUTB_CLK = "NONE";
  parameter [127:0] REG_INPUTB_CE = "CE0";
  parameter [127:0] REG_INPUTB_RST = "RST0";
  parameter [127:0] REG_INPUTC_CLK = "NONE";
  parameter [127:0] REG_INPUTC_CE = "CE0";
  parameter [127:0] REG_INPUTC_RST = "RST0";
  parameter [127:0] REG_PIPELINE_CLK = "NONE";
  parameter [127:0] REG_PIPELINE_CE = "CE0";
  parameter [127:0] REG_PIPELINE_RST = "RST0";
  parameter [127:0] REG_OUTPUT_CLK = "NONE";
  parameter [127:0] REG_OUTPUT_CE = "CE0";
  parameter [127:0] REG_OUTPUT_RST = "RST0";
  parameter [127:0] CLK0_DIV = "ENABLED";
  parameter [127:0] CLK1_DIV = "ENABLED";
  parameter [127:0] CLK2_DIV = "ENABLED";
  parameter [127:0] CLK3_DIV = "ENABLED";
  parameter [127:0] HIGHSPEED_CLK = "NONE";
  parameter [127:0] GSR = "ENABLED";
  parameter [127:0] CAS_MATCH_REG = "FALSE";
  parameter [127:0] SOURCEB_MODE = "B_SHIFT";
  parameter [127:0] MULT_BYPASS = "DISABLED";
  parameter [127:0] RESETMODE = "SYNC";
  /* verilator lint_on UNUSEDPARAM */

  wire [3:0] ce  = {CE3, CE2, CE1, CE0};
  wire [3:0] rst = {RST3, RST2, RST1, RST0};

  // The pin index a "CEk" / "RSTk" selection names (4: not one of them).
  function integer pin_index;
    input [127:0] name;
    begin
      case (name)
        "CE0", "RST0": pin_index = 0;
        "CE1", "RST1": pin_index = 1;
        "CE2", "RST2": pin_index = 2;
        "CE3", "RST3": pin_index = 3;
        default:       pin_index = 4;
      endcase
    end
  endfunction

  localparam integer A_CE = pin_index(REG_INPUTA_CE), A_RST = pin_index(REG_INPUTA_RST);
  localparam integer B_CE = pin_index(REG_INPUTB_CE), B_RST = pin_index(REG_INPUTB_RST);
  localparam integer M_CE = pin_index(REG_PIPELINE_CE), M_RST = pin_index(REG_PIPELINE_RST);
  localparam integer P_CE = pin_index(REG_OUTPUT_CE), P_RST = pin_index(REG_OUTPUT_RST);
  localparam A_REG = REG_INPUTA_CLK == "CLK0";
  localparam B_REG = REG_INPUTB_CLK == "CLK0";
  localparam M_REG = REG_PIPELINE_CLK == "CLK0";
  localparam P_REG = REG_OUTPUT_CLK == "CLK0";

  initial begin
    if (!(A_REG || REG_INPUTA_CLK == "NONE") || !(B_REG || REG_INPUTB_CLK == "NONE")
        || !(M_REG || REG_PIPELINE_CLK == "NONE") || !(P_REG || REG_OUTPUT_CLK == "NONE")
        || REG_INPUTC_CLK != "NONE" || A_CE > 3 || A_RST > 3 || B_CE > 3 || B_RST > 3
        || M_CE > 3 || M_RST > 3 || P_CE > 3 || P_RST > 3 || RESETMODE != "SYNC"
        || (P_REG && P_CE != 0)
        || MULT_BYPASS != "DISABLED") begin
      $display("MULT18X18D %m: a setting this model does not simulate");
      $finish;
    end
  end

  wire [17:0] a = {A17, A16, A15, A14, A13, A12, A11, A10, A9, A8, A7, A6, A5, A4, A3, A2, A1, A0};
  wire [17:0] b = {B17, B16, B15, B14, B13, B12, B11, B10, B9, B8, B7, B6, B5, B4, B3, B2, B1, B0};

  reg  [17:0] a_q = 18'd0, b_q = 18'd0;
  reg         sa_q = 1'b0, sb_q = 1'b0;
  always @(posedge CLK0) begin
    if (rst[A_RST & 3]) begin
      a_q <= 18'd0;
      sa_q <= 1'b0;
    end else if (ce[A_CE & 3]) begin
      a_q <= a;
      sa_q <= SIGNEDA;
    end
    if (rst[B_RST & 3]) begin
      b_q <= 18'd0;
      sb_q <= 1'b0;
    end else if (ce[B_CE & 3]) begin
      b_q <= b;
      sb_q <= SIGNEDB;
    end
  end
  wire [17:0] a_m = A_REG ? a_q : a;
  wire [17:0] b_m = B_REG ? b_q : b;
  wire        sa = A_REG ? sa_q : SIGNEDA;
  wire        sb = B_REG ? sb_q : SIGNEDB;

  // Each operand extended by one bit (its sign bit when signed, 0 when
  // unsigned): a 19 x 19 signed product holds every case exactly.
  wire signed [18:0] a_x = $signed({sa & a_m[17], a_m});
  wire signed [18:0] b_x = $signed({sb & b_m[17], b_m});
  wire signed [37:0] prod = a_x * b_x;
  wire [35:0] m_d = prod[35:0];  // the block's P is 36 bits wide
  wire unused_prod = ^prod[37:36];

  reg  [35:0] m_q = 36'd0;
  always @(posedge CLK0)
    if (rst[M_RST & 3]) m_q <= 36'd0;
    else if (ce[M_CE & 3]) m_q <= m_d;
  wire [35:0] p_d = M_REG ? m_q : m_d;

  reg  [35:0] p_q = 36'd0;
  always @(posedge CLK0)
    if (rst[P_RST & 3]) p_q <= 36'd0;
    else if (ce[P_CE & 3]) p_q <= p_d;
  wire [35:0] p = P_REG ? p_q : p_d;

  assign {P35, P34, P33, P32, P31, P30, P29, P28, P27, P26, P25, P24, P23, P22, P21, P20, P19, P18,
      P17, P16, P15, P14, P13, P12, P11, P10, P9, P8, P7, P6, P5, P4, P3, P2, P1, P0} = p;
  // Inputs the modelled subset does not use.
  wire unused_inputs =
      ^{C0, C1, C2, C3, C4, C5, C6, C7, C8, C9, C10, C11, C12, C13, C14, C15, C16, C17,
                         SOURCEA, SOURCEB, CLK1, CLK2, CLK3,
                         SRIA0, SRIA1, SRIA2, SRIA3, SRIA4, SRIA5, SRIA6, SRIA7, SRIA8, SRIA9,
                             SRIA10, SRIA11, SRIA12, SRIA13, SRIA14, SRIA15, SRIA16, SRIA17,
                         SRIB0, SRIB1, SRIB2, SRIB3, SRIB4, SRIB5, SRIB6, SRIB7, SRIB8, SRIB9,
                             SRIB10, SRIB11, SRIB12, SRIB13, SRIB14, SRIB15, SRIB16, SRIB17};
  assign SIGNEDP = sa | sb;
  // Cascade and register outputs: not modelled (Yosys's mapping leaves
  // them unconnected).
  assign {SROA17, SROA16, SROA15, SROA14, SROA13, SROA12, SROA11, SROA10, SROA9, SROA8, SROA7,
      SROA6, SROA5, SROA4, SROA3, SROA2, SROA1, SROA0} = 18'd0;
  assign {SROB17, SROB16, SROB15, SROB14, SROB13, SROB12, SROB11, SROB10, SROB9, SROB8, SROB7,
      SROB6, SROB5, SROB4, SROB3, SROB2, SROB1, SROB0} = 18'd0;
  assign {ROA17, ROA16, ROA15, ROA14, ROA13, ROA12, ROA11, ROA10, ROA9, ROA8, ROA7, ROA6, ROA5,
      ROA4, ROA3, ROA2, ROA1, ROA0} = 18'd0;
  assign {ROB17, ROB16, ROB15, ROB14, ROB13, ROB12, ROB11, ROB10, ROB9, ROB8, ROB7, ROB6, ROB5,
      ROB4, ROB3, ROB2, ROB1, ROB0} = 18'd0;
  assign {ROC17, ROC16, ROC15, ROC14, ROC13, ROC12, ROC11, ROC10, ROC9, ROC8, ROC7, ROC6, ROC5,
      ROC4, ROC3, ROC2, ROC1, ROC0} = 18'd0;
endmodule

`default_nettype wire
