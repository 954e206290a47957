// Behavioural model of the Lattice ECP5 DP16KD block RAM, for gate-level
// simulation of a netlist that `fxshade synth --target ecp5 --netlist`
// wrote. Yosys 0.23 ships the block with its parameters but no behaviour
// (cells_sim.v); this model covers what Yosys's memory mapping produces:
//
//   two ports, each DATA_WIDTH 18 (word address ADx[13:4], byte write
//   enables ADx[1:0]) or 9 (word address ADx[13:3]); a write on the rising
//   clock edge when CEx and WEx are 1 and the port's chip select matches
//   CSDECODE_x; the read data registered on the same edge when CEx is 1,
//   after the write (WRITETHROUGH), before it (READBEFOREWRITE) or not at
//   all on a write (NORMAL); the optional output register (REGMODE_x =
//   "OUTREG") loaded when OCEx is 1; RSTx clears the output latches
//   (synchronously or asynchronously, RESETMODE); contents from
//   INITVAL_00..INITVAL_3F, 16 words of 18 bits in each 20-bit slot
//   (Yosys's brams_map.v lays them out so), registers power up to 0.
//
// Any other setting (DATA_WIDTH 1, 2, 4 or 36, an inverted clock) stops
// the simulation with a message rather than simulate something the model
// does not know.
`default_nettype none

module DP16KD (
  input  wire DIA0, DIA1, DIA2, DIA3, DIA4, DIA5, DIA6, DIA7, DIA8, DIA9, DIA10, DIA11, DIA12,
      DIA13, DIA14, DIA15, DIA16, DIA17,
  input  wire ADA0, ADA1, ADA2, ADA3, ADA4, ADA5, ADA6, ADA7, ADA8, ADA9, ADA10, ADA11, ADA12,
      ADA13,
  input  wire CEA, OCEA, CLKA, WEA, RSTA,
  input  wire CSA2, CSA1, CSA0,
  output wire DOA0, DOA1, DOA2, DOA3, DOA4, DOA5, DOA6, DOA7, DOA8, DOA9, DOA10, DOA11, DOA12,
      DOA13, DOA14, DOA15, DOA16, DOA17,
  input  wire DIB0, DIB1, DIB2, DIB3, DIB4, DIB5, DIB6, DIB7, DIB8, DIB9, DIB10, DIB11, DIB12,
      DIB13, DIB14, DIB15, DIB16, DIB17,
  input  wire ADB0, ADB1, ADB2, ADB3, ADB4, ADB5, ADB6, ADB7, ADB8, ADB9, ADB10, ADB11, ADB12,
      ADB13,
  input  wire CEB, OCEB, CLKB, WEB, RSTB,
  input  wire CSB2, CSB1, CSB0,
  output wire DOB0, DOB1, DOB2, DOB3, DOB4, DOB5, DOB6, DOB7, DOB8, DOB9, DOB10, DOB11, DOB12,
      DOB13, DOB14, DOB15, DOB16, DOB17
);
  // The block's parameters, every one a netlist may set; those the model
  // does not read are here so that setting them is not an error.
  /* verilator lint_off UNUSEDPARAM */
  parameter integer DATA_WIDTH_A = 18;
  parameter integer DATA_WIDTH_B = 18;
  parameter [127:0] REGMODE_A = "NOREG";
  parameter [127:0] REGMODE_B = "NOREG";
  parameter [127:0] RESETMODE = "SYNC";
  parameter [127:0] ASYNC_RESET_RELEASE = "SYNC";
  parameter [127:0] CSDECODE_A = "0b000";
  parameter [127:0] CSDECODE_B = "0b000";
  parameter [127:0] WRITEMODE_A = "NORMAL";
  parameter [127:0] WRITEMODE_B = "NORMAL";
  parameter [127:0] DIA17MUX = "DIA17";
  parameter [127:0] DIA16MUX = "DIA16";
  parameter [127:0] DIA15MUX = "DIA15";
  parameter [127:0] DIA14MUX = "DIA14";
  parameter [127:0] DIA13MUX = "DIA13";
  parameter [127:0] DIA12MUX = "DIA12";
  parameter [127:0] DIA11MUX = "DIA11";
  parameter [127:0] DIA10MUX = "DIA10";
  parameter [127:0] DIA9MUX = "DIA9";
  parameter [127:0] DIA8MUX = "DIA8";
  parameter [127:0] DIA7MUX = "DIA7";
  parameter [127:0] DIA6MUX = "DIA6";
  parameter [127:0] DIA5MUX = "DIA5";
  parameter [127:0] DIA4MUX = "DIA4";
  parameter [127:0] DIA3MUX = "DIA3";
  parameter [127:0] DIA2MUX = "DIA2";
  parameter [127:0] DIA1MUX = "DIA1";
  parameter [127:0] DIA0MUX = "DIA0";
  parameter [127:0] ADA13MUX = "ADA13";
  parameter [127:0] ADA12MUX = "ADA12";
  parameter [127:0] ADA11MUX = "ADA11";
  parameter [127:0] ADA10MUX = "ADA10";
  parameter [127:0] ADA9MUX = "ADA9";
  parameter [127:0] ADA8MUX = "ADA8";
  parameter [127:0] ADA7MUX = "ADA7";
  parameter [127:0] ADA6MUX = "ADA6";
  parameter [127:0] ADA5MUX = "ADA5";
  parameter [127:0] ADA4MUX = "ADA4";
  parameter [127:0] ADA3MUX = "ADA3";
  parameter [127:0] ADA2MUX = "ADA2";
  parameter [127:0] ADA1MUX = "ADA1";
  parameter [127:0] ADA0MUX = "ADA0";
  parameter [127:0] CEAMUX = "CEA";
  parameter [127:0] OCEAMUX = "OCEA";
  parameter [127:0] CLKAMUX = "CLKA";
  parameter [127:0] WEAMUX = "WEA";
  parameter [127:0] RSTAMUX = "RSTA";
  parameter [127:0] CSA2MUX = "CSA2";
  parameter [127:0] CSA1MUX = "CSA1";
  parameter [127:0] CSA0MUX = "CSA0";
  parameter [127:0] DOA17MUX = "DOA17";
  parameter [127:0] DOA16MUX = "DOA16";
  parameter [127:0] DOA15MUX = "DOA15";
  parameter [127:0] DOA14MUX = "DOA14";
  parameter [127:0] DOA13MUX = "DOA13";
  parameter [127:0] DOA12MUX = "DOA12";
  parameter [127:0] DOA11MUX = "DOA11";
  parameter [127:0] DOA10MUX = "DOA10";
  parameter [127:0] DOA9MUX = "DOA9";
  parameter [127:0] DOA8MUX = "DOA8";
  parameter [127:0] DOA7MUX = "DOA7";
  parameter [127:0] DOA6MUX = "DOA6";
  parameter [127:0] DOA5MUX = "DOA5";
  parameter [127:0] DOA4MUX = "DOA4";
  parameter [127:0] DOA3MUX = "DOA3";
  parameter [127:0] DOA2MUX = "DOA2";
  parameter [127:0] DOA1MUX = "DOA1";
  parameter [127:0] DOA0MUX = "DOA0";
  parameter [127:0] DIB17MUX = "DIB17";
  parameter [127:0] DIB16MUX = "DIB16";
  parameter [127:0] DIB15MUX = "DIB15";
  parameter [127:0] DIB14MUX = "DIB14";
  parameter [127:0] DIB13MUX = "DIB13";
  parameter [127:0] DIB12MUX = "DIB12";
  parameter [127:0] DIB11MUX = "DIB11";
  parameter [127:0] DIB10MUX = "DIB10";
  parameter [127:0] DIB9MUX = "DIB9";
  parameter [127:0] DIB8MUX = "DIB8";
  parameter [127:0] DIB7MUX = "DIB7";
  parameter [127:0] DIB6MUX = "DIB6";
  parameter [127:0] DIB5MUX = "DIB5";
  parameter [127:0] DIB4MUX = "DIB4";
  parameter [127:0] DIB3MUX = "DIB3";
  parameter [127:0] DIB2MUX = "DIB2";
  parameter [127:0] DIB1MUX = "DIB1";
  parameter [127:0] DIB0MUX = "DIB0";
  parameter [127:0] ADB13MUX = "ADB13";
  parameter [127:0] ADB12MUX = "ADB12";
  parameter [127:0] ADB11MUX = "ADB11";
  parameter [127:0] ADB10MUX = "ADB10";
  parameter [127:0] ADB9MUX = "ADB9";
  parameter [127:0] ADB8MUX = "ADB8";
  parameter [127:0] ADB7MUX = "ADB7";
  parameter [127:0] ADB6MUX = "ADB6";
  parameter [127:0] ADB5MUX = "ADB5";
  parameter [127:0] ADB4MUX = "ADB4";
  parameter [127:0] ADB3MUX = "ADB3";
  parameter [127:0] ADB2MUX = "ADB2";
  parameter [127:0] ADB1MUX = "ADB1";
  parameter [127:0] ADB0MUX = "ADB0";
  parameter [127:0] CEBMUX = "CEB";
  parameter [127:0] OCEBMUX = "OCEB";
  parameter [127:0] CLKBMUX = "CLKB";
  parameter [127:0] WEBMUX = "WEB";
  parameter [127:0] RSTBMUX = "RSTB";
  parameter [127:0] CSB2MUX = "CSB2";
  parameter [127:0] CSB1MUX = "CSB1";
  parameter [127:0] CSB0MUX = "CSB0";
  parameter [127:0] DOB17MUX = "DOB17";
  parameter [127:0] DOB16MUX = "DOB16";
  parameter [127:0] DOB15MUX = "DOB15";
  parameter [127:0] DOB14MUX = "DOB14";
  parameter [127:0] DOB13MUX = "DOB13";
  parameter [127:0] DOB12MUX = "DOB12";
  parameter [127:0] DOB11MUX = "DOB11";
  parameter [127:0] DOB10MUX = "DOB10";
  parameter [127:0] DOB9MUX = "DOB9";
  parameter [127:0] DOB8MUX = "DOB8";
  parameter [127:0] DOB7MUX = "DOB7";
  parameter [127:0] DOB6MUX = "DOB6";
  parameter [127:0] DOB5MUX = "DOB5";
  parameter [127:0] DOB4MUX = "DOB4";
  parameter [127:0] DOB3MUX = "DOB3";
  parameter [127:0] DOB2MUX = "DOB2";
  parameter [127:0] DOB1MUX = "DOB1";
  parameter [127:0] DOB0MUX = "DOB0";
  parameter integer WID = 0;
  parameter [127:0] GSR = "ENABLED";
  parameter [127:0] INIT_DATA = "STATIC";
  parameter [319:0] INITVAL_00 = 320'h0;
  parameter [319:0] INITVAL_01 = 320'h0;
  parameter [319:0] INITVAL_02 = 320'h0;
  parameter [319:0] INITVAL_03 = 320'h0;
  parameter [319:0] INITVAL_04 = 320'h0;
  parameter [319:0] INITVAL_05 = 320'h0;
  parameter [319:0] INITVAL_06 = 320'h0;
  parameter [319:0] INITVAL_07 = 320'h0;
  parameter [319:0] INITVAL_08 = 320'h0;
  parameter [319:0] INITVAL_09 = 320'h0;
  parameter [319:0] INITVAL_0A = 320'h0;
  parameter [319:0] INITVAL_0B = 320'h0;
  parameter [319:0] INITVAL_0C = 320'h0;
  parameter [319:0] INITVAL_0D = 320'h0;
  parameter [319:0] INITVAL_0E = 320'h0;
  parameter [319:0] INITVAL_0F = 320'h0;
  parameter [319:0] INITVAL_10 = 320'h0;
  parameter [319:0] INITVAL_11 = 320'h0;
  parameter [319:0] INITVAL_12 = 320'h0;
  parameter [319:0] INITVAL_13 = 320'h0;
  parameter [319:0] INITVAL_14 = 320'h0;
  parameter [319:0] INITVAL_15 = 320'h0;
  parameter [319:0] INITVAL_16 = 320'h0;
  parameter [319:0] INITVAL_17 = 320'h0;
  parameter [319:0] INITVAL_18 = 320'h0;
  parameter [319:0] INITVAL_19 = 320'h0;
  parameter [319:0] INITVAL_1A = 320'h0;
  parameter [319:0] INITVAL_1B = 320'h0;
  parameter [319:0] INITVAL_1C = 320'h0;
  parameter [319:0] INITVAL_1D = 320'h0;
  parameter [319:0] INITVAL_1E = 320'h0;
  parameter [319:0] INITVAL_1F = 320'h0;
  parameter [319:0] INITVAL_20 = 320'h0;
  parameter [319:0] INITVAL_21 = 320'h0;
  parameter [319:0] INITVAL_22 = 320'h0;
  parameter [319:0] INITVAL_23 = 320'h0;
  parameter [319:0] INITVAL_24 = 320'h0;
  parameter [319:0] INITVAL_25 = 320'h0;
  parameter [319:0] INITVAL_26 = 320'h0;
  parameter [319:0] INITVAL_27 = 320'h0;
  parameter [319:0] INITVAL_28 = 320'h0;
  parameter [319:0] INITVAL_29 = 320'h0;
  parameter [319:0] INITVAL_2A = 320'h0;
  parameter [319:0] INITVAL_2B = 320'h0;
  parameter [319:0] INITVAL_2C = 320'h0;
  parameter [319:0] INITVAL_2D = 320'h0;
  parameter [319:0] INITVAL_2E = 320'h0;
  parameter [319:0] INITVAL_2F = 320'h0;
  parameter [319:0] INITVAL_30 = 320'h0;
  parameter [319:0] INITVAL_31 = 320'h0;
  parameter [319:0] INITVAL_32 = 320'h0;
  parameter [319:0] INITVAL_33 = 320'h0;
  parameter [319:0] INITVAL_34 = 320'h0;
  parameter [319:0] INITVAL_35 = 320'h0;
  parameter [319:0] INITVAL_36 = 320'h0;
  parameter [319:0] INITVAL_37 = 320'h0;
  parameter [319:0] INITVAL_38 = 320'h0;
  parameter [319:0] INITVAL_39 = 320'h0;
  parameter [319:0] INITVAL_3A = 320'h0;
  parameter [319:0] INITVAL_3B = 320'h0;
  parameter [319:0] INITVAL_3C = 320'h0;
  parameter [319:0] INITVAL_3D = 320'h0;
  parameter [319:0] INITVAL_3E = 320'h0;
  parameter [319:0] INITVAL_3F = 320'h0;
  /* verilator lint_on UNUSEDPARAM */

  // The contents: 1024 words of 18 bits, written by both ports (each on
  // its own clock), as the block's are.
  /* verilator lint_off MULTIDRIVEN */
  reg [17:0] mem [0:1023];
  /* verilator lint_on MULTIDRIVEN */
  integer k;
  initial begin
    for (k = 0; k < 16; k = k + 1) mem[0*16 + k] = INITVAL_00[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[1*16 + k] = INITVAL_01[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[2*16 + k] = INITVAL_02[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[3*16 + k] = INITVAL_03[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[4*16 + k] = INITVAL_04[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[5*16 + k] = INITVAL_05[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[6*16 + k] = INITVAL_06[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[7*16 + k] = INITVAL_07[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[8*16 + k] = INITVAL_08[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[9*16 + k] = INITVAL_09[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[10*16 + k] = INITVAL_0A[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[11*16 + k] = INITVAL_0B[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[12*16 + k] = INITVAL_0C[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[13*16 + k] = INITVAL_0D[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[14*16 + k] = INITVAL_0E[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[15*16 + k] = INITVAL_0F[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[16*16 + k] = INITVAL_10[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[17*16 + k] = INITVAL_11[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[18*16 + k] = INITVAL_12[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[19*16 + k] = INITVAL_13[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[20*16 + k] = INITVAL_14[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[21*16 + k] = INITVAL_15[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[22*16 + k] = INITVAL_16[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[23*16 + k] = INITVAL_17[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[24*16 + k] = INITVAL_18[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[25*16 + k] = INITVAL_19[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[26*16 + k] = INITVAL_1A[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[27*16 + k] = INITVAL_1B[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[28*16 + k] = INITVAL_1C[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[29*16 + k] = INITVAL_1D[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[30*16 + k] = INITVAL_1E[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[31*16 + k] = INITVAL_1F[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[32*16 + k] = INITVAL_20[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[33*16 + k] = INITVAL_21[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[34*16 + k] = INITVAL_22[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[35*16 + k] = INITVAL_23[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[36*16 + k] = INITVAL_24[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[37*16 + k] = INITVAL_25[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[38*16 + k] = INITVAL_26[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[39*16 + k] = INITVAL_27[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[40*16 + k] = INITVAL_28[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[41*16 + k] = INITVAL_29[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[42*16 + k] = INITVAL_2A[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[43*16 + k] = INITVAL_2B[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[44*16 + k] = INITVAL_2C[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[45*16 + k] = INITVAL_2D[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[46*16 + k] = INITVAL_2E[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[47*16 + k] = INITVAL_2F[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[48*16 + k] = INITVAL_30[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[49*16 + k] = INITVAL_31[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[50*16 + k] = INITVAL_32[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[51*16 + k] = INITVAL_33[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[52*16 + k] = INITVAL_34[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[53*16 + k] = INITVAL_35[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[54*16 + k] = INITVAL_36[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[55*16 + k] = INITVAL_37[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[56*16 + k] = INITVAL_38[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[57*16 + k] = INITVAL_39[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[58*16 + k] = INITVAL_3A[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[59*16 + k] = INITVAL_3B[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[60*16 + k] = INITVAL_3C[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[61*16 + k] = INITVAL_3D[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[62*16 + k] = INITVAL_3E[20*k +: 18];
    for (k = 0; k < 16; k = k + 1) mem[63*16 + k] = INITVAL_3F[20*k +: 18];
  end

  initial begin
    if ((DATA_WIDTH_A != 18 && DATA_WIDTH_A != 9) || (DATA_WIDTH_B != 18 && DATA_WIDTH_B != 9)
        || CLKAMUX != "CLKA" || CLKBMUX != "CLKB"
        || (REGMODE_A != "NOREG" && REGMODE_A != "OUTREG")
        || (REGMODE_B != "NOREG" && REGMODE_B != "OUTREG")) begin
      $display("DP16KD %m: a setting this model does not simulate");
      $finish;
    end
  end

  wire [13:0] ada =
      {ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0};
  wire [13:0] adb =
      {ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0};
  wire [17:0] dia =
      {DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4,
      DIA3, DIA2, DIA1, DIA0};
  wire [17:0] dib =
      {DIB17, DIB16, DIB15, DIB14, DIB13, DIB12, DIB11, DIB10, DIB9, DIB8, DIB7, DIB6, DIB5, DIB4,
      DIB3, DIB2, DIB1, DIB0};

  // A chip-select decode "0bXYZ" matches CSx2..CSx0 = X, Y, Z.
  function cs_match;
    input [23:0] decode;
    input [2:0] cs;
    begin
      cs_match = decode[23:16] == "0" + {7'd0, cs[2]}
              && decode[15:8] == "0" + {7'd0, cs[1]}
              && decode[7:0] == "0" + {7'd0, cs[0]};
    end
  endfunction
  wire sel_a = cs_match(CSDECODE_A[23:0], {CSA2, CSA1, CSA0});
  wire sel_b = cs_match(CSDECODE_B[23:0], {CSB2, CSB1, CSB0});

  // Port x's word and byte: the 18-bit row and, at width 9, its half.
  wire [9:0] row_a = ada[13:4];
  wire [9:0] row_b = adb[13:4];
  wire       half_a = ada[3];
  wire       half_b = adb[3];
  // The bits of the row a write changes: at width 18 the byte enables
  // ADx[1:0], at width 9 the half ADx[3] names.
  function [17:0] write_mask;
    input integer width;
    input [1:0] byte_en;
    input half;
    begin
      if (width == 18) write_mask = {{9{byte_en[1]}}, {9{byte_en[0]}}};
      else write_mask = half ? 18'h3fe00 : 18'h001ff;
    end
  endfunction
  wire [17:0] mask_a = write_mask(DATA_WIDTH_A, ada[1:0], half_a);
  wire [17:0] mask_b = write_mask(DATA_WIDTH_B, adb[1:0], half_b);
  wire [17:0] wdata_a = DATA_WIDTH_A == 18 ? dia : {dia[8:0], dia[8:0]};
  wire [17:0] wdata_b = DATA_WIDTH_B == 18 ? dib : {dib[8:0], dib[8:0]};
  wire        wr_a = CEA && WEA && sel_a;
  wire        wr_b = CEB && WEB && sel_b;
  // Read data of a row at a port's width.
  function [17:0] read_word;
    input integer width;
    input half;
    input [17:0] row;
    begin
      if (width == 18) read_word = row;
      else read_word = {9'd0, half ? row[17:9] : row[8:0]};
    end
  endfunction

  reg  [17:0] lat_a = 18'd0, lat_b = 18'd0, out_a = 18'd0, out_b = 18'd0;
  wire        async_rst = RESETMODE == "ASYNC";
  // The asynchronous resets (a signal of their own: Yosys reads an edge of
  // a net, not of an expression); a synchronous one acts at the clock.
  wire        arst_a = RSTA & async_rst;
  wire        arst_b = RSTB & async_rst;
  // A row before and after the port's write. Writes land after the
  // edge (nonblocking), so both ports read the contents from before it; a
  // read of the row the other port writes at the same edge is undefined in
  // the block, and Yosys's mapping never relies on it.
  wire [17:0] old_a = mem[row_a];
  wire [17:0] old_b = mem[row_b];
  wire [17:0] new_a = (old_a & ~mask_a) | (wdata_a & mask_a);
  wire [17:0] new_b = (old_b & ~mask_b) | (wdata_b & mask_b);

  // Writes do not depend on the reset, which clears only the output
  // latches: Yosys maps an asynchronous read reset without `block_wr`
  // (brams.txt), so a write may coincide with it.
  always @(posedge CLKA) if (wr_a) mem[row_a] <= new_a;
  always @(posedge CLKB) if (wr_b) mem[row_b] <= new_b;

  always @(posedge CLKA or posedge arst_a) begin
    if (arst_a) begin
      lat_a <= 18'd0;
      out_a <= 18'd0;
    end else if (RSTA) begin
      lat_a <= 18'd0;
      out_a <= 18'd0;
    end else begin
      if (CEA && sel_a && !(wr_a && WRITEMODE_A == "NORMAL"))
        lat_a <= read_word(DATA_WIDTH_A, half_a,
                           wr_a && WRITEMODE_A == "WRITETHROUGH" ? new_a : old_a);
      if (OCEA) out_a <= lat_a;
    end
  end
  always @(posedge CLKB or posedge arst_b) begin
    if (arst_b) begin
      lat_b <= 18'd0;
      out_b <= 18'd0;
    end else if (RSTB) begin
      lat_b <= 18'd0;
      out_b <= 18'd0;
    end else begin
      if (CEB && sel_b && !(wr_b && WRITEMODE_B == "NORMAL"))
        lat_b <= read_word(DATA_WIDTH_B, half_b,
                           wr_b && WRITEMODE_B == "WRITETHROUGH" ? new_b : old_b);
      if (OCEB) out_b <= lat_b;
    end
  end

  wire [17:0] doa = REGMODE_A == "OUTREG" ? out_a : lat_a;
  wire [17:0] dob = REGMODE_B == "OUTREG" ? out_b : lat_b;
  assign {DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5,
      DOA4, DOA3, DOA2, DOA1, DOA0} = doa;
  assign {DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5,
      DOB4, DOB3, DOB2, DOB1, DOB0} = dob;
  // Address bits the modelled widths do not use.
  wire unused_address = ^{ada[2], adb[2]};
endmodule

`default_nettype wire
